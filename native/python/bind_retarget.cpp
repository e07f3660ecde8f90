// Retargeting a whole clip between two rigs (native/include/motionkit/retarget.hpp); the rigs are bound in
// bind_rig.cpp.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
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

const char* RootMotionName(RootMotion motion) {
  switch (motion) {
    case RootMotion::kInPlace: return "in_place";
    case RootMotion::kOffset: return "offset";
    case RootMotion::kNone: return "none";
    case RootMotion::kScaled: break;
  }
  return "scaled";
}

RetargetResult Retarget(const RigModel& source, const RigModel& target, const ConstMatrixView& source_rotations,
                        const ConstMatrixView& source_root_heads, const std::vector<int>& bone_map,
                        const ConstMatrixView& source_match, const PointArg& source_match_root,
                        const ConstMatrixView& target_match_basis, const PointArg& target_match_location,
                        int source_root, int target_root, const RetargetOptions& options,
                        const std::optional<RowMatrixXd>& source_aims,
                        const std::optional<RowMatrixXd>& target_aims) {
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
  job.options = options;
  if (source_aims) job.source_aims = *source_aims;
  if (target_aims) job.target_aims = *target_aims;
  RunWithoutGil(job);
  return RetargetResult{rotations.array, root_locations.array, job.kept_posture};
}

}  // namespace

void BindRetargetOptions(py::module_& m) {
  py::class_<RetargetOptions>(m, "RetargetOptions", "The retarget's options (motionkit/retarget.hpp says what each "
                                                    "does); checked when the retarget runs.")
      .def(py::init<>())
      .def_property(
          "root_motion", [](const RetargetOptions& o) { return std::string(RootMotionName(o.root_motion)); },
          [](RetargetOptions& o, const std::string& text) {
            const auto motion = ParseRootMotion(text);
            if (!motion) throw Error("unknown root motion '" + text + "'; expected scaled, in_place, offset or none");
            o.root_motion = *motion;
          })
      .def_readwrite("scale", &RetargetOptions::scale, "the root path's scale: how high the target's hips stand / the source's")
      .def_readwrite("unit_scale", &RetargetOptions::unit_scale, "target armature units per source one")
      .def_readwrite("vertical_offset", &RetargetOptions::vertical_offset, "offset: added to the root's height")
      .def_readwrite("scale_horizontal", &RetargetOptions::scale_horizontal,
                     "scaled, offset: the motion across the floor, times this on top of scale")
      // Plain arrays both ways: g++ 14 takes an Eigen temporary made in a lambda for uninitialized.
      .def_property(
          "space",
          [](const RetargetOptions& o) {
            return std::array<double, 4>{o.space.w(), o.space.x(), o.space.y(), o.space.z()};
          },
          [](RetargetOptions& o, const std::array<double, 4>& q) {
            o.space = Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
          },
          "w x y z rotation from source to target armature space")
      .def_property(
          "up", [](const RetargetOptions& o) { return std::array<double, 3>{o.up.x(), o.up.y(), o.up.z()}; },
          [](RetargetOptions& o, const std::array<double, 3>& v) { o.up = Eigen::Vector3d(v[0], v[1], v[2]); },
          "the target armature's up (unit)")
      .def_readwrite("source_floor", &RetargetOptions::source_floor, "source units, after space")
      .def_readwrite("target_floor", &RetargetOptions::target_floor, "target armature units")
      .def_readwrite("posture_bones", &RetargetOptions::posture_bones,
                     "keep their own posture unless carried 45 degrees across the source's")
      .def_readwrite("posture_always", &RetargetOptions::posture_always, "keep it whatever the angle")
      .def_readwrite("helper_bones", &RetargetOptions::helper_bones,
                     "unmapped helpers carried where the mapped bone above aims past them")
      .def_readwrite("threads", &RetargetOptions::threads,
                     "frames posed on this many threads (0: one per hardware thread); the same result on any");
}

void BindRetarget(py::module_& m) {
  BindRetargetOptions(m);
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
        "source_root"_a, "target_root"_a, "options"_a = RetargetOptions(), "source_aims"_a = py::none(),
        "target_aims"_a = py::none(),
        R"pbdoc(
        Retarget a whole clip from the source rig to the target rig.

        source_rotations: float64 (frames, 4a), the source's armature-space
        orientations (armature_pose); source_root_heads: (frames, 3), the
        source root's head. bone_map: per target bone, its source bone index
        or -1. source_match: (a, 4) the source's orientations in the match
        pose, source_match_root its root head there; target_match_basis:
        (b, 4) the target's match pose as pose rotations (identity rows for
        the rest pose), target_match_location the target root's location
        there. options: a RetargetOptions (root motion, scale, unit scale,
        vertical offset, space, up, floors and posture bones; each
        field says what it is). source_aims (a, 3), target_aims (b, 3): where
        each bone points in its own frame, for rigs whose bone axes do not run
        along their limbs (default: every bone's Y axis).

        Returns a RetargetResult: rotations (frames, 4b) pose quaternions per
        target bone, continuous per bone; root_locations (frames, 3), the
        target root's location channel; kept_posture, the posture_bones that
        kept their posture (one that its parents carry to point more than 45
        degrees from the source's is turned). Errors name the bone and frame.
        The GIL is released while it runs.
      )pbdoc");
}

}  // namespace motionkit::python
