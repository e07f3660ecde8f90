// Mirroring a clip across a plane (native/include/motionkit/mirror.hpp); the rigs are bound in bind_rig.cpp.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <vector>

#include "bindings.hpp"
#include "motionkit/mirror.hpp"
#include "motionkit/rig.hpp"
#include "motionkit/types.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace motionkit::python {
namespace {

// The source's pose and its mirror in one call: the posed clip never reaches Python.
py::tuple Mirror(const RigModel& source, const RigModel& target, const ConstMatrixView& basis_rotations,
                 const ConstMatrixView& basis_locations, const std::vector<int>& partners,
                 const std::vector<int>& kept, const PointArg& normal, const PointArg& point) {
  const Eigen::Index frames = basis_rotations.rows();
  RowMatrixXd source_rotations(frames, 4 * source.size()), source_heads(frames, 3 * source.size());
  Output<> rotations(frames, 4 * target.size()), locations(frames, 3 * target.size());
  ArmaturePoseJob pose(source, basis_rotations, basis_locations, source_rotations, source_heads);
  MirrorJob job(source, target, source_rotations, source_heads, rotations.view, locations.view);
  job.partners = partners;
  job.kept = kept;
  job.normal = normal;
  job.point = point;
  RunWithoutGil(pose);
  RunWithoutGil(job);
  return py::make_tuple(rotations.array, locations.array);
}

}  // namespace

void BindMirror(py::module_& m) {
  m.def("mirror", &Mirror, "source"_a, "target"_a, "basis_rotations"_a.noconvert(), "basis_locations"_a.noconvert(),
        "partners"_a, "kept"_a, py::kw_only(), "normal"_a = Eigen::Vector3d(1, 0, 0),
        "point"_a = Eigen::Vector3d(0, 0, 0),
        R"pbdoc(
        Mirror a clip of the source rig across a plane onto the target rig.

        basis_rotations: float64 (frames, 4s) the source's pose rotations
        (w x y z per bone); basis_locations: (frames, 3s), or (frames, 0) for
        none. partners: per target bone, the source bone whose motion is
        mirrored onto it, or -1; kept: per target bone without a partner, the
        source bone whose pose channels it keeps (following its parent), or -1
        for its rest. normal, point: the plane in armature space (default the
        X = 0 plane). The world-space motion is reflected, then re-expressed in
        each target bone's own rest (mirror.hpp).

        Returns (rotations (frames, 4t) pose quaternions per target bone,
        continuous per bone; locations (frames, 3t) location channels). Errors
        name the bone and frame. The GIL is released while it runs.
      )pbdoc");
}

}  // namespace motionkit::python
