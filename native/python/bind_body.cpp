// The body's signed-distance field (native/include/motionkit/body_field.hpp).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "motionkit/body_arm.hpp"
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

using CellBoxes = Eigen::Ref<const Eigen::Matrix<int, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>;

BodyFieldView Field(const ConstVectorView& distance, const Eigen::Ref<const Eigen::VectorXi>& owner,
                    const std::vector<int>& dims, const PointArg& origin, double spacing,
                    const std::vector<int>& carriers, const ConstMatrixView& carrier_rest,
                    const ConstMatrixView& carrier_heads, const CellBoxes& carrier_cells, const char* name) {
  if (dims.size() != 3) throw py::value_error(std::string(name) + ": dims must be three cell counts");
  return {distance,     owner,        Eigen::Vector3i(dims[0], dims[1], dims[2]), origin, spacing, carriers,
          carrier_rest, carrier_heads, carrier_cells};
}

py::object BodySample(const ConstVectorView& distance, const Eigen::Ref<const Eigen::VectorXi>& owner,
                      const std::vector<int>& dims, const PointArg& origin, double spacing,
                      const std::vector<int>& carriers, const ConstMatrixView& carrier_rest,
                      const ConstMatrixView& carrier_heads, const CellBoxes& carrier_cells,
                      const ConstMatrixView& orientations,
                      const ConstMatrixView& heads, const ConstMatrixView& points, bool gradient) {
  const Eigen::Index frames = points.rows(), count = points.cols() / 3;
  Output<> read(frames, count), slope(frames, gradient ? 3 * count : 0);
  BodySampleJob job(Field(distance, owner, dims, origin, spacing, carriers, carrier_rest, carrier_heads, carrier_cells,
                          "body_sample"),
                    orientations, heads, points, read.view, slope.view);
  RunWithoutGil(job);
  return py::make_tuple(read.array, gradient ? py::object(slope.array) : py::object(py::none()));
}

// What body_arm returns, by name.
struct BodyArmResult {
  py::array_t<double> least;
  py::array_t<double> hand;
  py::array_t<double> gap;
};

BodyArmResult BodyArm(const ConstVectorView& distance, const Eigen::Ref<const Eigen::VectorXi>& owner,
                      const std::vector<int>& dims, const PointArg& origin, double spacing,
                      const std::vector<int>& carriers, const ConstMatrixView& carrier_rest,
                      const ConstMatrixView& carrier_heads, const CellBoxes& carrier_cells,
                      const ConstMatrixView& orientations, const ConstMatrixView& heads, const std::vector<int>& arm,
                      const std::vector<int>& point_bones, const ConstMatrixView& point_local,
                      const std::vector<int>& on_hand, const std::vector<int>& frames, const ConstVectorView& wanted,
                      const std::vector<int>& touch, Eigen::Ref<RowMatrixXd> turns,
                      const std::optional<RowMatrixXd>& goals, const std::optional<RowMatrixXd>& contacts,
                      double touch_distance, int iterations,
                      double turn_weight, double max_step, double smoothness, int threads) {
  if (arm.size() != 3) throw py::value_error("body_arm: arm must be the upper arm's, forearm's and hand's bones");
  const Eigen::Index solved = static_cast<Eigen::Index>(frames.size());
  OutputVector<double> least(solved), hand(solved), gap(solved);
  const RowMatrixXd none(0, 3);
  BodyArmJob job(Field(distance, owner, dims, origin, spacing, carriers, carrier_rest, carrier_heads, carrier_cells,
                       "body_arm"),
                 orientations, heads, {arm[0], arm[1], arm[2]}, point_bones, point_local, on_hand, frames, wanted,
                 touch, goals ? *goals : none, contacts ? *contacts : none, turns, least.view, hand.view, gap.view);
  job.touch_distance = touch_distance;
  job.iterations = iterations;
  job.turn_weight = turn_weight;
  job.max_step = max_step;
  job.smoothness = smoothness;
  job.threads = threads;
  RunWithoutGil(job);
  return {least.array, hand.array, gap.array};
}

}  // namespace

void BindBody(py::module_& m) {
  py::class_<BodyArmResult>(m, "BodyArmResult", "What body_arm returns, by name.")
      .def_readonly("least", &BodyArmResult::least,
                    "float64 (frames,): the nearest arm point's distance from the body after the turns")
      .def_readonly("hand", &BodyArmResult::hand, "float64 (frames,): the nearest hand point's distance")
      .def_readonly("gap", &BodyArmResult::gap,
                    "float64 (frames,): the hand's nearest point's distance to its goal (0 where none)");
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
        "carrier_cells"_a.noconvert(),
        "orientations"_a.noconvert(), "heads"_a.noconvert(), "points"_a.noconvert(), "gradient"_a = false,
        R"pbdoc(
        Read a body_field where the rig's bones have moved it.

        distance (cells,) float64 and owner (cells,) int32: body_field's; dims,
        origin, spacing: its grid. carriers: the bones that read it, with
        carrier_rest (K, 4) their rest orientations (w x y z),
        carrier_heads (K, 3) their rest heads and carrier_cells (K, 6) int32
        the first and last cell (i, j, k) of the box around the cells each
        owns (or (0, 6): the whole grid). orientations (frames, 4B), heads
        (frames, 3B): an armature pose; points (frames, 3N).

        Returns (read (frames, N): each point taken back to rest through every
        carrier's motion and read where that carrier owns the cell, the nearest
        of those, +inf where none does; its gradient (frames, 3N) in the
        armature's space when gradient, else None). The GIL is released.
      )pbdoc");
  m.def("body_arm", &BodyArm, "distance"_a.noconvert(), "owner"_a.noconvert(), py::kw_only(), "dims"_a, "origin"_a,
        "spacing"_a, "carriers"_a, "carrier_rest"_a.noconvert(), "carrier_heads"_a.noconvert(),
        "carrier_cells"_a.noconvert(),
        "orientations"_a.noconvert(), "heads"_a.noconvert(), "arm"_a, "point_bones"_a, "point_local"_a.noconvert(),
        "on_hand"_a, "frames"_a, "wanted"_a.noconvert(), "touch"_a, "turns"_a.noconvert(), "goals"_a = py::none(),
        "contacts"_a = py::none(),
        "touch_distance"_a = 0.0,
        "iterations"_a = 6, "turn_weight"_a = 0.05, "max_step"_a = 0.25, "smoothness"_a = 0.0,
        "threads"_a = 0,
        R"pbdoc(
        An arm's least turn out of its body, by Gauss-Newton on its skin points.

        The field and carriers as body_sample takes them; orientations (F,
        4B), heads (F, 3B): the armature pose; arm: the upper arm's, forearm's
        and hand's bones (the shoulder, elbow and wrist their heads);
        point_bones (S,) and point_local (S, 3): each skin point's bone and its
        offset in the bone's rest frame; on_hand (S,): nonzero for a hand
        point; frames: the frames to solve; wanted (F,): the clearance every
        point is to keep; touch (F,): nonzero where the hand's nearest point is
        brought to touch_distance instead, or where goals (F, 3), when
        given, has a finite row, the hand's point nearest it onto it (or
        contacts' (F, 3): the hand's own point posed that goes there).
        turns (F, 6) float64 is read and
        written in place on the frames solved: where each starts and what it
        found (the shoulder's and the elbow's rotation vectors, the armature's
        space; a forearm point turns about the elbow by both, a hand point is
        carried by the wrist, keeping its orientation). iterations 0 only
        measures. smoothness: where > 0, each run of consecutive frames is
        solved as one, smoothness times the difference of neighbouring
        frames' turns among its rows (frames then each once; 0: each frame
        alone). threads: 0 for one per hardware thread; the same result on
        any.

        Returns BodyArmResult (least, hand: per frame solved, after the turns,
        the nearest point's and the nearest hand point's distance, +inf where
        none is read; gap: the hand's distance to its goal, 0 where none). Errors name the frame. The GIL is released.
      )pbdoc");
}

}  // namespace motionkit::python
