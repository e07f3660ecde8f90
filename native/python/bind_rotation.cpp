// Euler angles and quaternions in bulk, for the add-on and for tests against scipy.
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>

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

void CheckRows(const char* what, Eigen::Index a, Eigen::Index b) {
  if (a != b) throw Error(std::string(what) + ": input has " + std::to_string(a) + " rows, output " + std::to_string(b));
}

}  // namespace

void BindRotation(py::module_& m) {
  m.def(
      "euler_to_quaternion",
      [](Eigen::Ref<const RowMatrixXd> angles, const std::string& order_text, Eigen::Ref<RowMatrixXd> out) {
        const EulerOrder order = Order(order_text);
        if (angles.cols() != 3 || out.cols() != 4) throw Error("euler_to_quaternion: angles (n, 3) and out (n, 4)");
        CheckRows("euler_to_quaternion", angles.rows(), out.rows());
        for (Eigen::Index i = 0; i < angles.rows(); ++i) {
          const Eigen::Quaterniond q = EulerToQuaternion(angles.row(i).transpose(), order);
          out.row(i) << q.w(), q.x(), q.y(), q.z();
        }
      },
      "angles"_a.noconvert(), "order"_a, "out"_a.noconvert(), py::call_guard<py::gil_scoped_release>(),
      R"pbdoc(
        Intrinsic Euler angles (radians, in the order's letter order) to w x y z
        quaternions, in place. "ZXY" means Rz Rx Ry, as scipy's upper case.
      )pbdoc");

  m.def(
      "quaternion_to_euler",
      [](Eigen::Ref<const RowMatrixXd> quaternions, const std::string& order_text, Eigen::Ref<RowMatrixXd> out,
         bool continuous, const Eigen::VectorXd& previous, int threads) {
        QuaternionsToEulers(quaternions, Order(order_text), out, continuous, previous, threads).ThrowIfFailed();
      },
      "quaternions"_a.noconvert(), "order"_a, "out"_a.noconvert(), "continuous"_a = true,
      "previous"_a = Eigen::VectorXd(), "threads"_a = 0, py::call_guard<py::gil_scoped_release>(),
      R"pbdoc(
        w x y z quaternions to intrinsic Euler angles (radians, letter order), in
        place: quaternions (n, 4k) and out (n, 3k), each of the k column groups
        one bone's sequence (k bones in one call, spread over `threads` threads,
        0: every core). continuous=True makes each row the equivalent triple
        closest to the row before (the first to `previous`, 3k angles, default
        zeros), as Blender's to_euler(order, compat).
      )pbdoc");

  TestingModule(m).def("blender_euler_mode", [](const std::string& order) { return std::string(BlenderEulerMode(Order(order))); },
        "order"_a, "Blender's rotation_mode for an intrinsic order: the letters reversed.");
}

}  // namespace motionkit::python
