// Each area of the core binds itself into motionkit._native.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "motionkit/types.hpp"

namespace motionkit::python {

// The array types the bindings return (C order, as the jobs' row-major views expect).
using DoubleArray = pybind11::array_t<double, pybind11::array::c_style>;
using BoolArray = pybind11::array_t<bool, pybind11::array::c_style>;
using IntArray = pybind11::array_t<int, pybind11::array::c_style>;
using RowMap = Eigen::Map<RowMatrixXd>;

// The bindings' one way of running a job: validated with the GIL held (a failure is a MotionKitError
// naming the place), then run without it, so that other Python threads go on meanwhile.
template <class Job>
void ValidateAndRun(Job& job) {
  job.Validate().ThrowIfFailed();
  pybind11::gil_scoped_release release;
  job.Run();
}

// The _testing submodule module.cpp made, for the functions only the tests use.
inline pybind11::module_ TestingModule(pybind11::module_& m) { return m.attr("_testing").cast<pybind11::module_>(); }

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

}  // namespace motionkit::python
