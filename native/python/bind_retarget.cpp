// Retargeting a whole clip between two rigs (native/include/motionkit/retarget.hpp); the rigs are bound in
// bind_rig.cpp.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "motionkit/error.hpp"
#include "motionkit/retarget.hpp"
#include "motionkit/rig.hpp"
#include "motionkit/types.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace motionkit::python {
namespace {

using ConstRowMap = Eigen::Map<const RowMatrixXd>;

// A per-bone table (bones x width) seen as one row, as the jobs take it.
ConstRowMap AsRow(const ConstMatrixView& table, Eigen::Index bones, Eigen::Index width, const char* what) {
  if (table.rows() != bones || table.cols() != width) {
    throw Error(std::string(what) + " must have " + std::to_string(bones) + " rows of " + std::to_string(width));
  }
  return ConstRowMap(table.data(), 1, bones * width);
}

// The retarget's results by name: rotations, root_locations, kept_posture.
struct RetargetResult {
  py::array rotations;
  py::array root_locations;
  std::vector<int> kept_posture;
};

RetargetResult Retarget(const RigModel& source, const RigModel& target, const ConstMatrixView& source_rotations,
                   const ConstMatrixView& source_root_heads, const std::vector<int>& bone_map,
                   const ConstMatrixView& source_match, const PointArg& source_match_root,
                   const ConstMatrixView& target_match_basis, const PointArg& target_match_location,
                   int source_root, int target_root, const QuaternionArg& space, double scale, double unit_scale,
                   double vertical_offset, const std::string& root_motion, const std::vector<int>& ground_bones,
                   const PointArg& up, double source_floor, double target_floor,
                   const std::optional<RowMatrixXd>& source_aims, const std::optional<RowMatrixXd>& target_aims,
                   const std::vector<int>& posture_bones, const std::vector<int>& posture_always) {
  const auto motion = ParseRootMotion(root_motion);
  if (!motion) throw Error("unknown root motion '" + root_motion + "'; expected scaled, in_place, offset or none");
  const Eigen::Index frames = source_rotations.rows(), bones = target.size();
  Output<> rotations(frames, 4 * bones), root_locations(frames, 3);
  RetargetJob job(source, target, source_rotations, source_root_heads,
                  AsRow(source_match, source.size(), 4, "source_match"),
                  AsRow(target_match_basis, bones, 4, "target_match_basis"), rotations.view, root_locations.view);
  job.source_match_root = source_match_root;
  job.target_match_location = target_match_location;
  job.bone_map = bone_map;
  job.source_root = source_root;
  job.target_root = target_root;
  job.options.root_motion = *motion;
  job.options.scale = scale;
  job.options.unit_scale = unit_scale;
  job.options.vertical_offset = vertical_offset;
  job.options.space = ToQuaternion(space);
  job.options.ground_bones = ground_bones;
  job.options.posture_bones = posture_bones;
  job.options.posture_always = posture_always;
  job.options.up = up;
  job.options.source_floor = source_floor;
  job.options.target_floor = target_floor;
  if (source_aims) job.source_aims = *source_aims;
  if (target_aims) job.target_aims = *target_aims;
  RunWithoutGil(job);
  return RetargetResult{rotations.array, root_locations.array, job.kept_posture};
}

}  // namespace

void BindRetarget(py::module_& m) {
  py::class_<RetargetResult>(m, "RetargetResult", "What retarget returns, by name.")
      .def_readonly("rotations", &RetargetResult::rotations,
                    "float64 (frames, 4b): pose quaternions per target bone, continuous per bone")
      .def_readonly("root_locations", &RetargetResult::root_locations,
                    "float64 (frames, 3): the target root's location channel")
      .def_readonly("kept_posture", &RetargetResult::kept_posture,
                    "the posture_bones that kept their own posture (ascending)");
  m.def("retarget", &Retarget, "source"_a, "target"_a, "source_rotations"_a.noconvert(),
        "source_root_heads"_a.noconvert(), "bone_map"_a, py::kw_only(), "source_match"_a.noconvert(),
        "source_match_root"_a, "target_match_basis"_a.noconvert(), "target_match_location"_a,
        "source_root"_a, "target_root"_a, "space"_a = Eigen::Vector4d(1, 0, 0, 0), "scale"_a = 1.0,
        "unit_scale"_a = 1.0, "vertical_offset"_a = 0.0, "root_motion"_a = "scaled", "ground_bones"_a = std::vector<int>{},
        "up"_a = Eigen::Vector3d(0, 0, 1), "source_floor"_a = 0.0, "target_floor"_a = 0.0,
        "source_aims"_a = py::none(), "target_aims"_a = py::none(), "posture_bones"_a = std::vector<int>{},
        "posture_always"_a = std::vector<int>{},
        R"pbdoc(
        Retarget a whole clip from the source rig to the target rig.

        source_rotations: float64 (frames, 4a), the source's armature-space
        orientations (armature_pose); source_root_heads: (frames, 3), the
        source root's head. bone_map: per target bone, its source bone index
        or -1. source_match: (a, 4) the source's orientations in the match
        pose, source_match_root its root head there; target_match_basis:
        (b, 4) the target's match pose as pose rotations (identity rows for
        the rest pose), target_match_location the target root's location
        there. space: w x y z rotation from source to target armature space.
        scale: target leg length / source leg length; unit_scale: target
        armature units per source one. root_motion: "scaled", "in_place",
        "offset" or "none" (retarget.hpp says what each does with the root's
        motion across up and its height above the floor); vertical_offset:
        added to the height in "offset". ground_bones: target bones that
        touch the target's floor on the first frame. up: the target
        armature's up (unit); source_floor: the source floor's height along
        up (source units, after space); target_floor: the target's, in its
        armature units. source_aims (a, 3), target_aims (b, 3): where each
        bone points in its own frame, for rigs whose bone axes do not run
        along their limbs (default: every bone's Y axis). posture_bones:
        target bones that keep their own posture in the match pose (carried
        by their parents, not turned onto the source's direction) unless their
        parents carry them more than 45 degrees from it; posture_always:
        bones that keep it whatever the angle (the user's choice).

        Returns a RetargetResult: rotations (frames, 4b) pose quaternions per
        target bone, continuous per bone; root_locations (frames, 3), the
        target root's location channel; kept_posture, the posture_bones that
        kept their posture (one that its parents carry to point more than 45
        degrees from the source's is turned). Errors name the bone and frame.
        The GIL is released while it runs.
      )pbdoc");
}

}  // namespace motionkit::python
