// The body's signed-distance field (native/include/motionkit/body_field.hpp).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <vector>

#include "bindings.hpp"
#include "motionkit/body_field.hpp"
#include "motionkit/body_sample.hpp"
#include "motionkit/types.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace motionkit::python {
namespace {

py::tuple BodyField(const ConstMatrixView& vertices, const ConstTriangleView& triangles,
                    const std::vector<int>& vertex_bone, const PointArg& origin, double spacing,
                    const std::vector<int>& dims) {
  if (dims.size() != 3) throw py::value_error("body_field: dims must be three cell counts");
  const Eigen::Index cells = static_cast<Eigen::Index>(dims[0]) * dims[1] * dims[2];
  OutputVector<double> distance(std::max<Eigen::Index>(cells, 0));
  OutputVector<int> bone(std::max<Eigen::Index>(cells, 0));
  BodyFieldJob job(vertices, triangles, vertex_bone, origin, spacing, Eigen::Vector3i(dims[0], dims[1], dims[2]),
                   distance.view, bone.view);
  RunWithoutGil(job);
  return py::make_tuple(distance.array, bone.array);
}

py::object BodySample(const ConstVectorView& distance, const Eigen::Ref<const Eigen::VectorXi>& owner,
                      const std::vector<int>& dims, const PointArg& origin, double spacing,
                      const std::vector<int>& carriers, const ConstMatrixView& carrier_rest,
                      const ConstMatrixView& carrier_heads, const ConstMatrixView& orientations,
                      const ConstMatrixView& heads, const ConstMatrixView& points, bool gradient) {
  if (dims.size() != 3) throw py::value_error("body_sample: dims must be three cell counts");
  const Eigen::Index frames = points.rows(), count = points.cols() / 3;
  Output<> read(frames, count), slope(frames, gradient ? 3 * count : 0);
  BodySampleJob job(distance, owner, Eigen::Vector3i(dims[0], dims[1], dims[2]), origin, spacing, carriers,
                    carrier_rest, carrier_heads, orientations, heads, points, read.view, slope.view);
  RunWithoutGil(job);
  return py::make_tuple(read.array, gradient ? py::object(slope.array) : py::object(py::none()));
}

}  // namespace

void BindBody(py::module_& m) {
  m.def("body_field", &BodyField, "vertices"_a.noconvert(), "triangles"_a.noconvert(), "vertex_bone"_a,
        py::kw_only(), "origin"_a, "spacing"_a, "dims"_a,
        R"pbdoc(
        A closed mesh's signed-distance field on a regular grid.

        vertices: float64 (V, 3) rest positions; triangles: int32 (T, 3);
        vertex_bone: per vertex the bone carrying it most (-1 for none).
        origin: the first cell's centre; spacing: the cells' size; dims: the
        cells along x, y, z. Cell (i, j, k) is at origin + spacing (i, j, k).

        Returns (distance (nx*ny*nz,) to the surface, negative inside, the sign
        voted by rays along the three axes, each counting crossings by
        their winding (inside any shell is inside); bone (nx*ny*nz,) int32, the
        bone of the nearest surface point's nearest vertex), cell (i, j, k) at
        (i*ny + j)*nz + k. Errors name the triangle or vertex. The GIL is
        released while it runs.
      )pbdoc");
  m.def("body_sample", &BodySample, "distance"_a.noconvert(), "owner"_a.noconvert(), py::kw_only(), "dims"_a,
        "origin"_a, "spacing"_a, "carriers"_a, "carrier_rest"_a.noconvert(), "carrier_heads"_a.noconvert(),
        "orientations"_a.noconvert(), "heads"_a.noconvert(), "points"_a.noconvert(), "gradient"_a = false,
        R"pbdoc(
        Read a body_field where the rig's bones have moved it.

        distance (cells,) float64 and owner (cells,) int32: body_field's; dims,
        origin, spacing: its grid. carriers: the bones that read it, with
        carrier_rest (K, 4) their rest orientations (w x y z) and
        carrier_heads (K, 3) their rest heads. orientations (frames, 4B), heads
        (frames, 3B): an armature pose; points (frames, 3N).

        Returns (read (frames, N): each point taken back to rest through every
        carrier's motion and read where that carrier owns the cell, the nearest
        of those, +inf where none does; its gradient (frames, 3N) in the
        armature's space when gradient, else None). The GIL is released.
      )pbdoc");
}

}  // namespace motionkit::python
