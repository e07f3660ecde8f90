// Euler angles and quaternions in bulk, for the add-on and for tests against scipy.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>

#include "bindings.hpp"
#include "motionkit/error.hpp"
#include "motionkit/rotation.hpp"
#include "motionkit/types.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace motionkit::python {
namespace {

EulerOrder Order(const std::string& text) {
  const auto order = ParseEulerOrder(text);
  if (!order) throw Error("unknown Euler order '" + text + "'; expected XYZ, XZY, YXZ, YZX, ZXY or ZYX");
  return *order;
}

}  // namespace

void BindRotation(py::module_& m) {
  m.def(
      "euler_to_quaternion",
      [](Eigen::Ref<const RowMatrixXd> angles, const std::string& order_text) {
        const EulerOrder order = Order(order_text);
        if (angles.cols() != 3) throw Error("euler_to_quaternion: angles must be (n, 3)");
        Output<> quaternions(angles.rows(), 4);
        {
          py::gil_scoped_release release;
          for (Eigen::Index i = 0; i < angles.rows(); ++i) {
            const Eigen::Quaterniond q = EulerToQuaternion(angles.row(i).transpose(), order);
            quaternions.view.row(i) << q.w(), q.x(), q.y(), q.z();
          }
        }
        return quaternions.array;
      },
      "angles"_a.noconvert(), "order"_a,
      R"pbdoc(
        Intrinsic Euler angles (n, 3) (radians, in the order's letter order) to
        w x y z quaternions (n, 4). "ZXY" means Rz Rx Ry, as scipy's upper case.
      )pbdoc");

  m.def(
      "quaternion_to_euler",
      [](Eigen::Ref<const RowMatrixXd> quaternions, const std::string& order_text, bool continuous,
         const Eigen::VectorXd& previous, int threads) {
        const EulerOrder order = Order(order_text);
        const Eigen::Index columns = 3 * (quaternions.cols() / 4);
        Output<> angles(quaternions.rows(), columns);
        Status status = Status::Ok();
        {
          py::gil_scoped_release release;
          status = QuaternionsToEulers(quaternions, order, angles.view, continuous, previous, threads);
        }
        status.ThrowIfFailed();
        return angles.array;
      },
      "quaternions"_a.noconvert(), "order"_a, "continuous"_a = true, "previous"_a = Eigen::VectorXd(),
      "threads"_a = 0,
      R"pbdoc(
        w x y z quaternions (n, 4k) to intrinsic Euler angles (n, 3k) (radians,
        letter order), each of the k column groups one bone's sequence (k bones
        in one call, spread over `threads` threads, 0: every core).
        continuous=True makes each row the equivalent triple closest to the row
        before (the first to `previous`, 3k angles, default zeros), as
        Blender's to_euler(order, compat).
      )pbdoc");

  m.def(
      "quaternion_channels",
      [](Eigen::Ref<const RowMatrixXd> quaternions, const Eigen::VectorXd& previous, int threads,
         std::optional<py::array_t<double>> out) -> py::array_t<double> {
        const Eigen::Index rows = quaternions.cols(), cols = quaternions.rows();
        py::array_t<double> array;
        if (out) {
          // The caller's buffer (a block of its curves' rows): written in place, nothing else allocated.
          if (out->ndim() != 2 || out->shape(0) != rows || out->shape(1) != cols || !out->writeable() ||
              !(out->flags() & py::array::c_style)) {
            throw Error("quaternion_channels: out must be a writable C-contiguous float64 array (4k, n)");
          }
          array = *out;
        } else {
          array = py::array_t<double>({rows, cols});
        }
        Eigen::Map<RowMatrixXd> view(array.mutable_data(), rows, cols);
        Status status = Status::Ok();
        {
          py::gil_scoped_release release;
          status = QuaternionChannels(quaternions, previous, view, threads);
        }
        status.ThrowIfFailed();
        return array;
      },
      "quaternions"_a.noconvert(), "previous"_a = Eigen::VectorXd(), "threads"_a = 0, "out"_a = py::none(),
      R"pbdoc(
        k bones' w x y z quaternions (n, 4k) as F-curve rows (4k, n), row 4j + c
        bone j's component c, each bone kept on one hemisphere from row to row,
        the first on the side of previous' quaternion j (4k values; none: w >= 0).
        out: a C-contiguous float64 (4k, n) array to write into and return.
      )pbdoc");

  TestingModule(m).def("blender_euler_mode", [](const std::string& order) { return std::string(BlenderEulerMode(Order(order))); },
        "order"_a, "Blender's rotation_mode for an intrinsic order: the letters reversed.");
}

}  // namespace motionkit::python
