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
         bool continuous, const Eigen::Vector3d& previous) {
        const EulerOrder order = Order(order_text);
        if (quaternions.cols() != 4 || out.cols() != 3) throw Error("quaternion_to_euler: quaternions (n, 4) and out (n, 3)");
        CheckRows("quaternion_to_euler", quaternions.rows(), out.rows());
        Eigen::Vector3d last = previous;
        for (Eigen::Index i = 0; i < quaternions.rows(); ++i) {
          const Eigen::Vector4d& q = quaternions.row(i).transpose();
          if (!q.allFinite() || !(q.norm() > 1e-12)) {
            throw Error("quaternion_to_euler: quaternion " + std::to_string(i) + " is zero or not finite");
          }
          const Eigen::Quaterniond unit = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
          last = continuous ? QuaternionToEulerCompatible(unit, order, last) : QuaternionToEuler(unit, order);
          out.row(i) = last.transpose();
        }
      },
      "quaternions"_a.noconvert(), "order"_a, "out"_a.noconvert(), "continuous"_a = true,
      "previous"_a = Eigen::Vector3d::Zero(), py::call_guard<py::gil_scoped_release>(),
      R"pbdoc(
        w x y z quaternions to intrinsic Euler angles (radians, letter order), in
        place. continuous=True makes each row the equivalent triple closest to the
        row before (the first to `previous`), as Blender's to_euler(order, compat).
      )pbdoc");

  m.def("blender_euler_mode", [](const std::string& order) { return std::string(BlenderEulerMode(Order(order))); },
        "order"_a, "Blender's rotation_mode for an intrinsic order: the letters reversed.");
}

}  // namespace motionkit::python
