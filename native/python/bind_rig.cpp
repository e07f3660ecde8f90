// Rigs at rest (Rig) and their forward kinematics over a clip (armature_pose): native/include/motionkit/rig.hpp.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "motionkit/error.hpp"
#include "motionkit/rig.hpp"
#include "motionkit/types.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace motionkit::python {
namespace {

py::tuple ArmaturePose(const RigModel& rig, const ConstMatrixView& basis_rotations,
                       const ConstMatrixView& basis_locations) {
  const Eigen::Index frames = basis_rotations.rows(), bones = rig.size();
  Output<> rotations(frames, 4 * bones), heads(frames, 3 * bones);
  ArmaturePoseJob job(rig, basis_rotations, basis_locations, rotations.view, heads.view);
  RunWithoutGil(job);
  return py::make_tuple(rotations.array, heads.array);
}

}  // namespace

void BindRig(py::module_& m) {
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

}

}  // namespace motionkit::python
