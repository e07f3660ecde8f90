// Full-body inverse kinematics over a whole clip (native/include/motionkit/ik.hpp).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <optional>
#include <string>
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

// The per-bone tables ik_solve takes, each optional, checked and gathered into one IkJoint per bone; none
// when no table is given.
std::vector<IkJoint> JointsFromTables(py::ssize_t bones, const std::optional<DoubleArray>& limit_min,
                                      const std::optional<DoubleArray>& limit_max,
                                      const std::optional<BoolArray>& locked,
                                      const std::optional<DoubleArray>& stiffness,
                                      const std::optional<BoolArray>& excluded,
                                      const std::optional<DoubleArray>& stretch,
                                      const std::optional<DoubleArray>& scale_range,
                                      const std::optional<BoolArray>& soft, const std::optional<IntArray>& stage,
                                      const std::optional<DoubleArray>& mass) {
  if (!(limit_min || limit_max || locked || stiffness || excluded || stretch || scale_range || soft || stage || mass)) {
    return {};
  }
  if (limit_min) CheckShape(*limit_min, bones, 3, "limit_min");
  if (limit_max) CheckShape(*limit_max, bones, 3, "limit_max");
  if (locked) CheckShape(*locked, bones, 3, "locked");
  if (stiffness) CheckShape(*stiffness, bones, 3, "stiffness");
  if (excluded) CheckShape(*excluded, bones, 0, "excluded");
  if (stretch) CheckShape(*stretch, bones, 0, "stretch");
  if (scale_range) CheckShape(*scale_range, bones, 2, "scale_range");
  if (soft) CheckShape(*soft, bones, 3, "soft");
  if (stage) CheckShape(*stage, bones, 0, "stage");
  if (mass) CheckShape(*mass, bones, 0, "mass");
  std::vector<IkJoint> joints(static_cast<std::size_t>(bones));
  for (py::ssize_t b = 0; b < bones; ++b) {
    IkJoint& j = joints[static_cast<std::size_t>(b)];
    for (py::ssize_t k = 0; k < 3; ++k) {
      const auto i = static_cast<Eigen::Index>(k);
      if (limit_min) j.min[i] = limit_min->at(b, k);
      if (limit_max) j.max[i] = limit_max->at(b, k);
      if (locked) j.locked[static_cast<std::size_t>(k)] = locked->at(b, k);
      if (stiffness) j.stiffness[i] = stiffness->at(b, k);
      if (soft) j.soft[static_cast<std::size_t>(k)] = soft->at(b, k);
    }
    if (stage) j.stage = stage->at(b);
    if (mass) j.mass = mass->at(b);
    if (excluded) j.excluded = excluded->at(b);
    if (stretch) j.stretch = stretch->at(b);
    if (scale_range) {
      j.min_scale = scale_range->at(b, 0);
      j.max_scale = scale_range->at(b, 1);
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
                 std::vector<IkEffector> effectors, const std::optional<DoubleArray>& limit_min,
                 const std::optional<DoubleArray>& limit_max, const std::optional<BoolArray>& locked,
                 const std::optional<DoubleArray>& stiffness, const std::optional<BoolArray>& excluded,
                 const std::optional<DoubleArray>& stretch, const std::optional<DoubleArray>& scale_range,
                 const std::optional<BoolArray>& soft, const std::optional<IntArray>& stage,
                 const std::optional<DoubleArray>& mass,
                 const std::string& method, int max_iterations, double tolerance, double max_step, double damping,
                 double regularization, const std::string& reference, double orientation_scale,
                 bool root_translation, bool root_rotation, bool warm_start, int threads, double size,
                 bool priorities, bool balance, const std::array<double, 3>& up, double balance_margin) {
  const auto parsed = ParseIkMethod(method);
  if (!parsed) throw Error("ik_solve: unknown method '" + method + "'; expected ccd, transpose, pinv or dls");
  if (reference != "previous" && reference != "input") {
    throw Error("ik_solve: unknown reference '" + reference + "'; expected previous or input");
  }
  const Eigen::Index bones = rig.size();
  std::vector<IkJoint> joints = JointsFromTables(bones, limit_min, limit_max, locked, stiffness, excluded, stretch,
                                                 scale_range, soft, stage, mass);
  CheckEffectorsHaveBones(effectors);
  const Eigen::Index frames = target_positions.rows(), count = static_cast<Eigen::Index>(effectors.size());
  Output<> rotations(frames, 4 * bones), root_locations(frames, 3), scales(frames, bones), errors(frames, count);
  OutputVector<int> iterations(frames);
  IkClipJob job(rig, input_rotations, input_locations, target_positions, target_orientations, rotations.view,
                root_locations.view, scales.view, errors.view, iterations.view);
  job.joints = std::move(joints);
  job.effectors = std::move(effectors);
  job.options.method = *parsed;
  job.options.max_iterations = max_iterations;
  job.options.tolerance = tolerance;
  job.options.max_step = max_step;
  job.options.damping = damping;
  job.options.regularization = regularization;
  job.options.reference = reference == "input" ? IkReference::kInput : IkReference::kPrevious;
  job.options.orientation_scale = orientation_scale;
  job.options.root_translation = root_translation;
  job.options.root_rotation = root_rotation;
  job.options.warm_start = warm_start;
  job.options.threads = threads;
  job.options.size = size;
  job.options.priorities = priorities;
  job.options.balance = balance;
  job.options.up = Eigen::Vector3d(up[0], up[1], up[2]);
  job.options.balance_margin = balance_margin;
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
        priorities (DLS): strict levels, each in the null space of those
        above: pins, then balance, then targets, then the pull towards the
        reference; off, pins are weighted like targets and share the error.

        Per bone (all optional): limit_min, limit_max float64 (b, 3) radians
        (swing x, twist y, swing z; Blender's ik_min/ik_max), locked bool
        (b, 3), stiffness float64 (b, 3) in [0, 1), excluded bool (b,),
        stretch float64 (b,) (0: rigid), scale_range float64 (b, 2) (min and
        max length scale of a stretching bone), soft bool (b, 3) (that
        axis's limits widen to take in each frame's input), stage int32 (b,)
        (recruitment: stage 0 first, each later stage joins, from the input,
        only while a target stays out of reach), mass float64 (b,) (balance;
        negative: the bone's length).
        balance (with priorities and a pin): the centre of mass, projected
        along `up` (armature space), stays inside the support polygon of the
        pinned bones (heads and tails, theirs and their descendants'),
        balance_margin in from its edges (0: 0.005 of the rig's size).

        method: "dls" (damped least squares), "pinv", "transpose" or "ccd".
        tolerance: armature units (0: 3e-7 of the rig's size); max_step: radians per joint per iteration;
        damping: 0 picks 1e-3 of the rig's size; regularization: the pull
        towards the reference ("previous": the previous frame's solution,
        "input": the frame's input pose); orientation_scale: armature units
        per radian (0: a tenth of the rig's size). root_translation and
        root_rotation make the root bone's location and rotation unknowns;
        warm_start starts each frame from the previous one's solution.
        Effectors that share no unknown (say, chains cut off by excluded
        bones) are solved as separate problems, on up to `threads` threads
        (0, the default: all; the result does not depend on it). size: the
        rig's size, which the defaults scale with (0: the diagonal of the
        rest pose's bounding box; give the whole rig's when solving part of
        one).

        Returns an IkResult: rotations (frames, 4b) pose quaternions (bones the
        solver does not move keep their input), root_locations (frames, 3),
        scales (frames, b) length scale per bone, errors (frames, e) each
        effector's position error after the solve (an orientation-only
        effector's angle times orientation_scale), iterations (frames,)
        int32, the steps tried (by the slowest group). Errors name the effector or bone and the frame. The GIL is
        released while it runs.
      )pbdoc";

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
  m.def("ik_solve", &IkSolve, "rig"_a, "input_rotations"_a.noconvert(), "input_locations"_a.noconvert(),
        "target_positions"_a.noconvert(), "target_orientations"_a.noconvert(), "effectors"_a, py::kw_only(),
        "limit_min"_a.noconvert() = py::none(), "limit_max"_a.noconvert() = py::none(),
        "locked"_a.noconvert() = py::none(), "stiffness"_a.noconvert() = py::none(),
        "excluded"_a.noconvert() = py::none(), "stretch"_a.noconvert() = py::none(),
        "scale_range"_a.noconvert() = py::none(), "soft"_a.noconvert() = py::none(),
        "stage"_a = py::none(), "mass"_a.noconvert() = py::none(), "method"_a = "dls", "max_iterations"_a = 64,
        "tolerance"_a = 0.0, "max_step"_a = 0.3, "damping"_a = 0.0, "regularization"_a = 1e-4,
        "reference"_a = "previous", "orientation_scale"_a = 0.0, "root_translation"_a = false,
        "root_rotation"_a = false, "warm_start"_a = true, "threads"_a = 0, "size"_a = 0.0, "priorities"_a = true,
        "balance"_a = false, "up"_a = std::array<double, 3>{{0.0, 0.0, 1.0}}, "balance_margin"_a = 0.0,
        kIkSolveDoc);
}

}  // namespace motionkit::python
