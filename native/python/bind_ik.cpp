// Full-body inverse kinematics over a whole clip (native/include/motionkit/ik.hpp).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "motionkit/error.hpp"
#include "motionkit/ik.hpp"
#include "motionkit/rig.hpp"
#include "motionkit/types.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace motionkit::python {
namespace {

// A per-bone table's checked shape: (bones, width), or (bones,) for width 0.
template <class Array>
void CheckShape(const Array& a, py::ssize_t bones, py::ssize_t width, const char* what) {
  const bool ok = width == 0 ? a.ndim() == 1 && a.shape(0) == bones
                             : a.ndim() == 2 && a.shape(0) == bones && a.shape(1) == width;
  if (!ok) {
    throw Error(std::string(what) + " must have shape (" + std::to_string(bones) +
                (width == 0 ? ",)" : ", " + std::to_string(width) + ")"));
  }
}

// What ik_solve returns: the solved clip's arrays, as attributes.
struct IkArrays {
  py::array rotations, root_locations, scales, errors, iterations;
};

// The per-bone tables ik_solve takes (Python's IkJoints), each optional; their shapes are checked against
// the rig when the solve runs.
struct IkJointTables {
  std::optional<DoubleArray> limit_min, limit_max, stiffness, stretch, scale_range, mass;
  std::optional<BoolArray> locked, excluded, soft;
  std::optional<IntArray> stage;

  bool Empty() const {
    return !(limit_min || limit_max || locked || stiffness || excluded || stretch || scale_range || soft || stage ||
             mass);
  }
};

// The tables checked and gathered into one IkJoint per bone; none when no table is given (every joint free).
std::vector<IkJoint> JointsFromTables(py::ssize_t bones, const IkJointTables& t) {
  if (t.Empty()) return {};
  if (t.limit_min) CheckShape(*t.limit_min, bones, 3, "limit_min");
  if (t.limit_max) CheckShape(*t.limit_max, bones, 3, "limit_max");
  if (t.locked) CheckShape(*t.locked, bones, 3, "locked");
  if (t.stiffness) CheckShape(*t.stiffness, bones, 3, "stiffness");
  if (t.excluded) CheckShape(*t.excluded, bones, 0, "excluded");
  if (t.stretch) CheckShape(*t.stretch, bones, 0, "stretch");
  if (t.scale_range) CheckShape(*t.scale_range, bones, 2, "scale_range");
  if (t.soft) CheckShape(*t.soft, bones, 3, "soft");
  if (t.stage) CheckShape(*t.stage, bones, 0, "stage");
  if (t.mass) CheckShape(*t.mass, bones, 0, "mass");
  std::vector<IkJoint> joints(static_cast<std::size_t>(bones));
  for (py::ssize_t b = 0; b < bones; ++b) {
    IkJoint& j = joints[static_cast<std::size_t>(b)];
    for (py::ssize_t k = 0; k < 3; ++k) {
      const auto i = static_cast<Eigen::Index>(k);
      if (t.limit_min) j.min[i] = t.limit_min->at(b, k);
      if (t.limit_max) j.max[i] = t.limit_max->at(b, k);
      if (t.locked) j.locked[static_cast<std::size_t>(k)] = t.locked->at(b, k);
      if (t.stiffness) j.stiffness[i] = t.stiffness->at(b, k);
      if (t.soft) j.soft[static_cast<std::size_t>(k)] = t.soft->at(b, k);
    }
    if (t.stage) j.stage = t.stage->at(b);
    if (t.mass) j.mass = t.mass->at(b);
    if (t.excluded) j.excluded = t.excluded->at(b);
    if (t.stretch) j.stretch = t.stretch->at(b);
    if (t.scale_range) {
      j.min_scale = t.scale_range->at(b, 0);
      j.max_scale = t.scale_range->at(b, 1);
    }
  }
  return joints;
}

void CheckEffectorsHaveBones(const std::vector<IkEffector>& effectors) {
  for (std::size_t i = 0; i < effectors.size(); ++i) {
    if (effectors[i].bone < 0) {
      throw Error("ik_solve: effector " + std::to_string(i) +
                  (effectors[i].name.empty() ? "" : " '" + effectors[i].name + "'") + " has no bone");
    }
  }
}

IkArrays IkSolve(const RigModel& rig, const ConstMatrixView& input_rotations, const ConstMatrixView& input_locations,
                 const ConstMatrixView& target_positions, const ConstMatrixView& target_orientations,
                 std::vector<IkEffector> effectors, const IkJointTables* joints, const IkOptions* options) {
  std::vector<IkJoint> joint_list = joints ? JointsFromTables(rig.size(), *joints) : std::vector<IkJoint>();
  CheckEffectorsHaveBones(effectors);
  const Eigen::Index bones = rig.size();
  const Eigen::Index frames = target_positions.rows(), count = static_cast<Eigen::Index>(effectors.size());
  Output<> rotations(frames, 4 * bones), root_locations(frames, 3), scales(frames, bones), errors(frames, count);
  OutputVector<int> iterations(frames);
  IkClipJob job(rig, input_rotations, input_locations, target_positions, target_orientations, rotations.view,
                root_locations.view, scales.view, errors.view, iterations.view);
  job.joints = std::move(joint_list);
  job.effectors = std::move(effectors);
  if (options) job.options = *options;
  RunWithoutGil(job);
  return IkArrays{rotations.array, root_locations.array, scales.array, errors.array, iterations.array};
}

constexpr const char* kIkSolveDoc = R"pbdoc(
        Full-body inverse kinematics on a whole clip.

        rig: the Rig. input_rotations: float64 (frames or 1, 4b), the pose
        rotations (w x y z per bone, Blender's basis); input_locations:
        (frames or 1, 3), the root bone's location channel.
        target_positions: (frames, 3e) armature space; target_orientations:
        (frames, 4e) w x y z, or (frames, 0) when no effector asks for one.
        effectors: a list of IkEffector; an effector is its bone's tail, a
        pin holds where the frame's input pose has it.
        joints: an IkJoints, the per-bone tables (limits, locks, stiffness,
        exclusion, stretch, recruitment stages, masses), each checked against
        the rig's bone count here; None: every joint free.
        options: an IkOptions (method, stopping, damping, the reference pose,
        unknowns, threads, priorities, balance; each field says what it is);
        None: the defaults.

        Returns an IkResult: rotations (frames, 4b) pose quaternions (bones the
        solver does not move keep their input), root_locations (frames, 3),
        scales (frames, b) length scale per bone, errors (frames, e) each
        effector's position error after the solve (an orientation-only
        effector's angle times orientation_scale), iterations (frames,)
        int32, the steps tried (by the slowest group). Errors name the effector or bone and the frame. The GIL is
        released while it runs.
      )pbdoc";

const char* IkMethodName(IkMethod method) {
  switch (method) {
    case IkMethod::kCcd: return "ccd";
    case IkMethod::kTranspose: return "transpose";
    case IkMethod::kPseudoInverse: return "pinv";
    case IkMethod::kDls: break;
  }
  return "dls";
}

// A class's instance built from keywords, each set as Python would set that field (through its checks); a
// keyword that names no field is a TypeError, as for any constructor.
template <class T>
T FromKeywords(const py::kwargs& fields, const char* class_name) {
  T value;
  const py::object self = py::cast(&value, py::return_value_policy::reference);
  const py::object property = py::module_::import("builtins").attr("property");
  for (const auto& item : fields) {
    const auto key = py::cast<std::string>(item.first);
    const py::object field = py::getattr(py::type::of<T>(), key.c_str(), py::none());
    if (!py::isinstance(field, property)) {
      throw py::type_error(std::string(class_name) + ": no field '" + key + "'");
    }
    py::setattr(self, key.c_str(), item.second);
  }
  return value;
}

// A table field of IkJoints: None or an array as ik_solve always took it (C order, the exact dtype, never
// converted; IntArray converts, as stage always did), its shape checked at the solve.
template <class Array>
void DefTable(py::class_<IkJointTables>& c, const char* name, std::optional<Array> IkJointTables::*field,
              const char* doc) {
  const std::string what = std::string("IkJoints.") + name;
  c.def_property(
      name,
      [field](const IkJointTables& t) -> py::object {
        if (!(t.*field)) return py::none();
        return *(t.*field);
      },
      [field, what](IkJointTables& t, const py::object& value) {
        if (value.is_none()) {
          (t.*field).reset();
          return;
        }
        if constexpr (std::is_same_v<Array, IntArray>) {
          Array array = Array::ensure(value);
          if (!array) throw py::type_error(what + ": expected an int32 array or None");
          t.*field = std::move(array);
        } else {
          if (!py::isinstance<Array>(value)) {
            const char* dtype = std::is_same_v<Array, BoolArray> ? "bool" : "float64";
            throw py::type_error(what + ": expected a C-order " + dtype + " array or None");
          }
          t.*field = py::reinterpret_borrow<Array>(value);
        }
      },
      doc);
}

void BindIkJoints(py::module_& m) {
  py::class_<IkJointTables> c(m, "IkJoints", R"pbdoc(
        ik_solve's per-bone tables, each optional (None: that setting's
        default on every bone); IkJoints(**fields) sets the named ones. Each
        is checked against the rig's bone count b when the solve runs.
      )pbdoc");
  c.def(py::init([](const py::kwargs& fields) { return FromKeywords<IkJointTables>(fields, "IkJoints"); }));
  DefTable(c, "limit_min", &IkJointTables::limit_min,
           "float64 (b, 3) radians (swing x, twist y, swing z; Blender's ik_min)");
  DefTable(c, "limit_max", &IkJointTables::limit_max, "float64 (b, 3) radians (Blender's ik_max)");
  DefTable(c, "locked", &IkJointTables::locked, "bool (b, 3)");
  DefTable(c, "stiffness", &IkJointTables::stiffness, "float64 (b, 3), each in [0, 1)");
  DefTable(c, "excluded", &IkJointTables::excluded, "bool (b,): never moved by the solver");
  DefTable(c, "stretch", &IkJointTables::stretch, "float64 (b,) (0: rigid)");
  DefTable(c, "scale_range", &IkJointTables::scale_range,
           "float64 (b, 2): min and max length scale of a stretching bone");
  DefTable(c, "soft", &IkJointTables::soft,
           "bool (b, 3): that axis's limits widen to take in each frame's input");
  DefTable(c, "stage", &IkJointTables::stage,
           "int32 (b,): recruitment; stage 0 first, each later stage joins, from the input, only while a target "
           "stays out of reach");
  DefTable(c, "mass", &IkJointTables::mass, "float64 (b,): for balance; negative: the bone's length");
}

void BindIkOptions(py::module_& m) {
  py::class_<IkOptions>(m, "IkOptions", R"pbdoc(
        ik_solve's options (motionkit/ik.hpp says what each does);
        IkOptions(**fields) sets the named ones, the others keep their
        defaults. The numbers are checked when the solve runs.
      )pbdoc")
      .def(py::init([](const py::kwargs& fields) { return FromKeywords<IkOptions>(fields, "IkOptions"); }))
      .def_property(
          "method", [](const IkOptions& o) { return std::string(IkMethodName(o.method)); },
          [](IkOptions& o, const std::string& text) {
            const auto method = ParseIkMethod(text);
            if (!method) {
              throw Error("IkOptions.method: unknown method '" + text + "'; expected ccd, transpose, pinv or dls");
            }
            o.method = *method;
          },
          "\"dls\" (damped least squares), \"pinv\", \"transpose\" or \"ccd\"")
      .def_readwrite("max_iterations", &IkOptions::max_iterations)
      .def_readwrite("tolerance", &IkOptions::tolerance, "armature units (0: 3e-7 of the rig's size)")
      .def_readwrite("max_step", &IkOptions::max_step, "radians per joint per iteration")
      .def_readwrite("damping", &IkOptions::damping, "0: 1e-3 of the rig's size")
      .def_readwrite("regularization", &IkOptions::regularization, "the pull towards the reference")
      .def_property(
          "reference",
          [](const IkOptions& o) { return std::string(o.reference == IkReference::kInput ? "input" : "previous"); },
          [](IkOptions& o, const std::string& text) {
            if (text == "input") {
              o.reference = IkReference::kInput;
            } else if (text == "previous") {
              o.reference = IkReference::kPrevious;
            } else {
              throw Error("IkOptions.reference: unknown reference '" + text + "'; expected previous or input");
            }
          },
          "\"previous\" (the previous frame's solution) or \"input\" (the frame's input pose)")
      .def_readwrite("orientation_scale", &IkOptions::orientation_scale,
                     "armature units per radian (0: a tenth of the rig's size)")
      .def_readwrite("root_translation", &IkOptions::root_translation, "the root bone's location is an unknown")
      .def_readwrite("root_rotation", &IkOptions::root_rotation, "the root bone's rotation is an unknown")
      .def_readwrite("warm_start", &IkOptions::warm_start, "start each frame from the previous one's solution")
      .def_readwrite("threads", &IkOptions::threads,
                     "independent effector groups on up to this many threads (0: all cores; same result)")
      .def_readwrite("size", &IkOptions::size,
                     "the rig's size the defaults scale with (0: its rest pose's bounding-box diagonal; give the "
                     "whole rig's when solving part of one)")
      .def_readwrite("priorities", &IkOptions::priorities,
                     "DLS: pins, then balance, then targets, then the reference, each in the null space of those "
                     "above")
      .def_readwrite("balance", &IkOptions::balance,
                     "keep the centre of mass, along up, inside the pinned bones' support polygon")
      // Plain arrays both ways: g++ 14 takes an Eigen temporary made in a lambda for uninitialized.
      .def_property(
          "up", [](const IkOptions& o) { return std::array<double, 3>{o.up.x(), o.up.y(), o.up.z()}; },
          [](IkOptions& o, const std::array<double, 3>& v) { o.up = Eigen::Vector3d(v[0], v[1], v[2]); },
          "armature space, for balance")
      .def_readwrite("balance_margin", &IkOptions::balance_margin,
                     "in from the support polygon's edges (0: 0.005 of the rig's size)");
}

void BindIkEffector(py::module_& m) {
  py::class_<IkEffector>(m, "IkEffector", R"pbdoc(
        One effector of ik_solve: its bone's tail reaches a target (position,
        and orientation if asked), or with pin holds where the frame's input
        pose has it. name is for messages; weight scales its share of the
        error when effectors cannot all be met.
      )pbdoc")
      .def(py::init([](int bone, std::string name, double weight, bool position, bool orientation, bool pin) {
             return IkEffector{std::move(name), bone, weight, position, orientation, pin};
           }),
           "bone"_a, py::kw_only(), "name"_a = "", "weight"_a = 1.0, "position"_a = true, "orientation"_a = false,
           "pin"_a = false)
      .def_readwrite("bone", &IkEffector::bone)
      .def_readwrite("name", &IkEffector::name)
      .def_readwrite("weight", &IkEffector::weight)
      .def_readwrite("position", &IkEffector::position)
      .def_readwrite("orientation", &IkEffector::orientation)
      .def_readwrite("pin", &IkEffector::pin)
      .def("__repr__", [](const IkEffector& e) {
        return "IkEffector(" + std::to_string(e.bone) + (e.name.empty() ? "" : ", name='" + e.name + "'") +
               (e.pin ? ", pin=True" : "") + ")";
      });
}

void BindIkResult(py::module_& m) {
  py::class_<IkArrays>(m, "IkResult", R"pbdoc(
        What ik_solve returns: rotations (frames, 4b), root_locations
        (frames, 3), scales (frames, b), errors (frames, e) and iterations
        (frames,) int32; see ik_solve.
      )pbdoc")
      .def_readonly("rotations", &IkArrays::rotations)
      .def_readonly("root_locations", &IkArrays::root_locations)
      .def_readonly("scales", &IkArrays::scales)
      .def_readonly("errors", &IkArrays::errors)
      .def_readonly("iterations", &IkArrays::iterations);
}

}  // namespace

void BindIk(py::module_& m) {
  BindIkEffector(m);
  BindIkResult(m);
  BindIkJoints(m);
  BindIkOptions(m);
  m.def("ik_solve", &IkSolve, "rig"_a, "input_rotations"_a.noconvert(), "input_locations"_a.noconvert(),
        "target_positions"_a.noconvert(), "target_orientations"_a.noconvert(), "effectors"_a, py::kw_only(),
        "joints"_a = py::none(), "options"_a = py::none(), kIkSolveDoc);
}

}  // namespace motionkit::python
