// Rotation keys interpolated on the quaternion sphere (and the naive Euler and
// axis-angle splines, for comparison).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <optional>
#include <string>

#include "bindings.hpp"
#include "motionkit/error.hpp"
#include "motionkit/rotation_interpolation.hpp"
#include "motionkit/types.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace motionkit::python {
namespace {

using CastingArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

// Per-key parameters are small and often typed as lists: converted, not
// required to be float64 arrays.
std::optional<CastingArray> PerKey(const py::object& values, const char* name) {
  if (values.is_none()) return std::nullopt;
  CastingArray array = CastingArray::ensure(values);
  if (!array || array.ndim() != 1) throw Error(std::string(name) + " must be None or one number per key");
  return array;
}

Eigen::Map<const Eigen::VectorXd> View(const std::optional<CastingArray>& array) {
  if (!array) return Eigen::Map<const Eigen::VectorXd>(nullptr, 0);
  return Eigen::Map<const Eigen::VectorXd>(array->data(), array->shape(0));
}

EulerOrder Order(const std::string& text) {
  const auto order = ParseEulerOrder(text);
  if (!order) throw Error("unknown Euler order '" + text + "'; expected XYZ, XZY, YXZ, YZX, ZXY or ZYX");
  return *order;
}

py::object InterpolateRotations(const ConstVectorView& times, const ConstMatrixView& quats,
                                const ConstVectorView& eval_times, const std::string& kind_text,
                                const py::object& tension, const py::object& continuity,
                                const py::object& bias, const std::string& euler_order,
                                bool want_velocity) {
  const auto kind = ParseRotationInterpolant(kind_text);
  if (!kind) {
    throw Error("unknown rotation interpolation '" + kind_text + "'; expected one of " +
                RotationInterpolantNames());
  }
  const std::optional<CastingArray> t = PerKey(tension, "tension");
  const std::optional<CastingArray> c = PerKey(continuity, "continuity");
  const std::optional<CastingArray> b = PerKey(bias, "bias");
  const py::ssize_t m = eval_times.size();
  Output<> out(m, 4), velocity(want_velocity ? m : 0, 3);
  RotationInterpolateJob job(times, quats, eval_times, out.view, velocity.view, KeyTcb(View(t), View(c), View(b)));
  job.options.kind = *kind;
  job.options.euler_order = Order(euler_order);
  RunWithoutGil(job);
  if (want_velocity) return py::make_tuple(out.array, velocity.array);
  return py::object(std::move(out.array));
}

DoubleArray SlerpMany(const QuaternionArg& q0, const QuaternionArg& q1, const ConstVectorView& u) {
  const Eigen::Quaterniond a = ToQuaternion(q0), b = ToQuaternion(q1);
  if (!q0.allFinite() || !q1.allFinite() || !(q0.norm() > 1e-12) || !(q1.norm() > 1e-12)) {
    throw Error("slerp: q0 and q1 must be finite and not zero");
  }
  if (!u.allFinite()) throw Error("slerp: u must be finite");
  Output<> out(u.size(), 4);
  {
    py::gil_scoped_release release;
    for (Eigen::Index j = 0; j < u.size(); ++j) {
      const Eigen::Quaterniond q = Slerp(a, b, u[j]);
      out.view.row(j) << q.w(), q.x(), q.y(), q.z();
    }
  }
  return out.array;
}

}  // namespace

void BindRotationInterpolation(py::module_& m) {
  m.def("interpolate_rotations", &InterpolateRotations, "times"_a.noconvert(), "quats"_a.noconvert(),
        "eval_times"_a.noconvert(), "kind"_a = "squad", py::kw_only(), "tension"_a = py::none(),
        "continuity"_a = py::none(), "bias"_a = py::none(), "euler_order"_a = "XYZ",
        "angular_velocity"_a = false,
        R"pbdoc(
        Interpolate rotation keys at many times.

        times: float64 (n,), strictly increasing; quats: float64 (n, 4) w x y z,
        any length (not zero) and any signs; eval_times: float64 (m,), any order.
        kind: "slerp", "squad", "catmull-rom", "kochanek-bartels" (on the
        quaternion sphere), or the naive "euler-catmull-rom" (per Euler angle in
        euler_order, intrinsic as euler_to_quaternion) and
        "axis-angle-catmull-rom" (per rotation-vector component).
        tension, continuity, bias: per key, kochanek-bartels only; None = 0.
        Keys are joined by their shorter arcs; outside the keys the end rotation
        is held.

        Returns out, float64 (m, 4) unit w x y z, each row in the hemisphere of
        the row before; with angular_velocity=True, (out, omega) where omega is
        (m, 3) world-frame angular velocity in radians per time unit
        (dq/dt = 1/2 omega q), the curve's exact derivative.
        The GIL is released while it runs.
      )pbdoc");

  py::module_ testing = TestingModule(m);
  testing.def("slerp", &SlerpMany, "q0"_a, "q1"_a, "u"_a.noconvert(),
        R"pbdoc(
        Slerp from q0 (u = 0) to q1 (u = 1) along the shorter arc, at every u of a
        float64 (m,) array: float64 (m, 4) unit w x y z. q0, q1: 4 numbers w x y z.
      )pbdoc");
  testing.def(
      "slerp",
      [](const QuaternionArg& q0, const QuaternionArg& q1, double u) {
        const Eigen::VectorXd one = Eigen::VectorXd::Constant(1, u);
        return DoubleArray(SlerpMany(q0, q1, one).attr("reshape")(4));
      },
      "q0"_a, "q1"_a, "u"_a, "The same for one u: float64 (4,).");
}

}  // namespace motionkit::python
