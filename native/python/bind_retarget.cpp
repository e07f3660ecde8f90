// Rigs, their forward kinematics, and retargeting between them.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
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

using DoubleArray = py::array_t<double, py::array::c_style>;
using RowMap = Eigen::Map<RowMatrixXd>;
using ConstRowMap = Eigen::Map<const RowMatrixXd>;

// A per-bone table (bones x width) seen as one row, as the jobs take it.
ConstRowMap AsRow(const ConstMatrixView& table, Eigen::Index bones, Eigen::Index width, const char* what) {
  if (table.rows() != bones || table.cols() != width) {
    throw Error(std::string(what) + " must have " + std::to_string(bones) + " rows of " + std::to_string(width));
  }
  return ConstRowMap(table.data(), 1, bones * width);
}

py::tuple ArmaturePose(const RigModel& rig, const ConstMatrixView& basis_rotations,
                       const ConstMatrixView& basis_locations) {
  const Eigen::Index frames = basis_rotations.rows(), bones = rig.size();
  DoubleArray rotations({frames, 4 * bones}), heads({frames, 3 * bones});
  RowMap rotations_view(rotations.mutable_data(), frames, 4 * bones);
  RowMap heads_view(heads.mutable_data(), frames, 3 * bones);
  ArmaturePoseJob job(rig, basis_rotations, basis_locations, rotations_view, heads_view);
  job.Validate().ThrowIfFailed();
  {
    py::gil_scoped_release release;
    job.Run();
  }
  return py::make_tuple(rotations, heads);
}

py::tuple Retarget(const RigModel& source, const RigModel& target, const ConstMatrixView& source_rotations,
                   const ConstMatrixView& source_root_heads, const std::vector<int>& bone_map,
                   const ConstMatrixView& source_match, const Eigen::Vector3d& source_match_root,
                   const ConstMatrixView& target_match_basis, const Eigen::Vector3d& target_match_location,
                   int source_root, int target_root, const Eigen::Vector4d& space, double scale, double unit_scale,
                   double vertical_offset, const std::string& root_motion, const std::vector<int>& ground_bones) {
  const auto motion = ParseRootMotion(root_motion);
  if (!motion) throw Error("unknown root motion '" + root_motion + "'; expected scaled, in_place, offset or none");
  const Eigen::Index frames = source_rotations.rows(), bones = target.size();
  DoubleArray rotations({frames, 4 * bones}), root_locations({frames, Eigen::Index{3}});
  RowMap rotations_view(rotations.mutable_data(), frames, 4 * bones);
  RowMap root_view(root_locations.mutable_data(), frames, 3);
  RetargetJob job(source, target, source_rotations, source_root_heads,
                  AsRow(source_match, source.size(), 4, "source_match"),
                  AsRow(target_match_basis, bones, 4, "target_match_basis"), rotations_view, root_view);
  job.source_match_root = source_match_root;
  job.target_match_location = target_match_location;
  job.bone_map = bone_map;
  job.source_root = source_root;
  job.target_root = target_root;
  job.options.root_motion = *motion;
  job.options.scale = scale;
  job.options.unit_scale = unit_scale;
  job.options.vertical_offset = vertical_offset;
  job.options.space = Eigen::Quaterniond(space[0], space[1], space[2], space[3]);
  job.options.ground_bones = ground_bones;
  job.Validate().ThrowIfFailed();
  {
    py::gil_scoped_release release;
    job.Run();
  }
  return py::make_tuple(rotations, root_locations);
}

}  // namespace

void BindRetarget(py::module_& m) {
  py::class_<RigModel, std::shared_ptr<RigModel>>(m, "Rig", R"pbdoc(
        An armature at rest, bones parents first: names, parent indices (-1 for
        roots), rest rotations (n, 4) w x y z and rest heads (n, 3) in armature
        space (Blender's bone.matrix_local), and lengths (n,). Validated when
        made; immutable.
      )pbdoc")
      .def(py::init<std::vector<std::string>, std::vector<int>, const RowMatrixXd&, const RowMatrixXd&,
                    const Eigen::VectorXd&>(),
           "names"_a, "parents"_a, "rest_rotations"_a, "rest_heads"_a, "lengths"_a)
      .def_property_readonly("size", &RigModel::size)
      .def_property_readonly("names", [](const RigModel& rig) {
        std::vector<std::string> names;
        for (int b = 0; b < rig.size(); ++b) names.push_back(rig.name(b));
        return names;
      })
      .def("find", &RigModel::Find, "name"_a, "Index of the bone with that name, or -1.");

  m.def("armature_pose", &ArmaturePose, "rig"_a, "basis_rotations"_a.noconvert(),
        "basis_locations"_a.noconvert(),
        R"pbdoc(
        Pose channels to armature-space orientations and heads, every frame.

        basis_rotations: float64 (frames, 4n) w x y z per bone (Blender's
        pose rotation as a quaternion); basis_locations: float64 (frames, 3n),
        or (frames, 0) for none. Returns (rotations (frames, 4n), heads (frames, 3n)): what
        pose_bone.matrix holds, for bones that inherit rotation and have unit
        scale. The GIL is released while it runs.
      )pbdoc");

  m.def("retarget", &Retarget, "source"_a, "target"_a, "source_rotations"_a.noconvert(),
        "source_root_heads"_a.noconvert(), "bone_map"_a, py::kw_only(), "source_match"_a.noconvert(),
        "source_match_root"_a, "target_match_basis"_a.noconvert(), "target_match_location"_a,
        "source_root"_a, "target_root"_a, "space"_a = Eigen::Vector4d(1, 0, 0, 0), "scale"_a = 1.0,
        "unit_scale"_a = 1.0, "vertical_offset"_a = 0.0, "root_motion"_a = "scaled", "ground_bones"_a = std::vector<int>{},
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
        horizontal motion and its height above armature Z = 0);
        vertical_offset: added to the height in "offset". ground_bones: target bones that touch Z = 0 on the
        first frame.

        Returns (rotations (frames, 4b) pose quaternions per target bone,
        continuous per bone; root_locations (frames, 3), the target root's
        location channel). Errors name the bone and frame. The GIL is released
        while it runs.
      )pbdoc");
}

}  // namespace motionkit::python
