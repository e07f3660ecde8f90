// Each area of the core binds itself into motionkit._native.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Geometry>
#include <utility>
#include <vector>

#include "motionkit/types.hpp"

namespace motionkit::python {

// The array types the bindings return (C order, as the jobs' row-major views expect).
using DoubleArray = pybind11::array_t<double, pybind11::array::c_style>;
using BoolArray = pybind11::array_t<bool, pybind11::array::c_style>;
using IntArray = pybind11::array_t<int, pybind11::array::c_style>;

// Small fixed-size arguments (a quaternion, a point) are taken as views, never as plain fixed-size
// matrices: pybind11 2.13's caster for those (Debian 13's) move-assigns an uninitialised temporary into
// its value before copying the numbers in (g++ 14 rightly warns, -Wmaybe-uninitialized); the view's caster
// maps numpy's array or its converted copy instead. Either accepts the same arguments.
using QuaternionArg = Eigen::Ref<const Eigen::Vector4d>;  // w x y z
using PointArg = Eigen::Ref<const Eigen::Vector3d>;

inline Eigen::Quaterniond ToQuaternion(const QuaternionArg& wxyz) {
  return Eigen::Quaterniond(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
}

// An output a binding allocates and returns: the numpy array (C order) and the view the job writes into
// it, so that nothing is copied on the way out. Output<T>(rows, cols) is (rows, cols) to numpy as to the
// job; Output<T>(rows) is (rows,) to numpy and a column to the job; OutputVector<T>(rows) the same for
// jobs that take a vector.
template <class T, class Matrix>
class OutputArray {
 public:
  OutputArray(Eigen::Index rows, Eigen::Index cols) : OutputArray({rows, cols}, rows, cols) {}
  explicit OutputArray(Eigen::Index rows) : OutputArray({rows}, rows, 1) {}

  pybind11::array_t<T, pybind11::array::c_style> array;
  Eigen::Map<Matrix> view;

 private:
  OutputArray(std::vector<pybind11::ssize_t> shape, Eigen::Index rows, Eigen::Index cols)
      : array(std::move(shape)), view(array.mutable_data(), rows, cols) {}
};
template <class T = double>
using Output = OutputArray<T, Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>;
template <class T>
using OutputVector = OutputArray<T, Eigen::Matrix<T, Eigen::Dynamic, 1>>;

// The bindings' one way of running a job, once its outputs are allocated: without the GIL, so that other
// Python threads go on meanwhile. Run() validates first and throws Error having written nothing, which
// reaches Python as MotionKitError once the GIL is back.
template <class Job>
void RunWithoutGil(Job& job) {
  pybind11::gil_scoped_release release;
  job.Run();
}

// The _testing submodule module.cpp made, for the functions only the tests use.
inline pybind11::module_ TestingModule(pybind11::module_& m) { return m.attr("_testing").cast<pybind11::module_>(); }

void BindBody(pybind11::module_& m);
void BindBvh(pybind11::module_& m);
void BindRotation(pybind11::module_& m);
void BindFCurve(pybind11::module_& m);
void BindRotationInterpolation(pybind11::module_& m);
void BindKeyReduction(pybind11::module_& m);
void BindInterpolation(pybind11::module_& m);
void BindRig(pybind11::module_& m);
void BindRetarget(pybind11::module_& m);
void BindIk(pybind11::module_& m);
void BindContacts(pybind11::module_& m);
void BindFilters(pybind11::module_& m);
void BindMirror(pybind11::module_& m);

}  // namespace motionkit::python
