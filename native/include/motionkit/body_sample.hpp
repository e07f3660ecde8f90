// Reading a body's signed-distance field (body_field.hpp) where its bones have moved it: each point taken
// back to rest through every carrier bone's motion and read (trilinear) where that carrier owns the cell;
// the nearest of those, and the trilinear distance's gradient there, in the armature's space
// (docs/body.md). What core/body.Body.posed_with_gradient runs.
#pragma once

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "motionkit/error.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

// A body's field as BodyFieldJob made it and the bones that read it (caller-owned views):
//   distance, owner: the field's nx*ny*nz cells ((i*ny + j)*nz + k), dims, origin (the first cell's
//                    centre) and spacing as BodyFieldJob made them
//   carriers:        the bones that read the field; carrier_rest (K x 4, w x y z) and carrier_heads (K x 3)
//                    their rest orientations and heads; carrier_cells (K x 6, or 0 rows) the first and last
//                    cell (i, j, k) of the box around the cells each owns, so that a point read through a
//                    carrier whose box it misses is passed over without touching the grid
struct BodyFieldView {
  ConstVectorView distance;
  Eigen::Ref<const Eigen::VectorXi> owner;
  Eigen::Vector3i dims;
  Eigen::Vector3d origin;
  double spacing;
  std::vector<int> carriers;
  ConstMatrixView carrier_rest;
  ConstMatrixView carrier_heads;
  Eigen::Ref<const Eigen::Matrix<int, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> carrier_cells;

  // The cells number nx*ny*nz, one rest per carrier, each carrier a bone of a pose of `bones` (the message
  // starts with `job`).
  Status Validate(Eigen::Index bones, const std::string& job) const;
};

// Caller-owned buffers; Run() allocates nothing.
//   field:           the body (BodyFieldView)
//   orientations:    frames x 4B, heads frames x 3B: the armature pose (every bone; carriers index it)
//   points:          frames x 3N, the points to read on each frame
//   read:            frames x N out: the distance, +inf where no carrier owns the cell a point maps to
//   gradient:        frames x 3N out (or 0 columns for none): its gradient, 0 where read is +inf
struct BodySampleJob {
  BodySampleJob(BodyFieldView field_in, ConstMatrixView orientations_in, ConstMatrixView heads_in,
                ConstMatrixView points_in, Eigen::Ref<RowMatrixXd> read_out, Eigen::Ref<RowMatrixXd> gradient_out)
      : field(std::move(field_in)),
        orientations(orientations_in),
        heads(heads_in),
        points(points_in),
        read(read_out),
        gradient(gradient_out) {}

  BodyFieldView field;
  ConstMatrixView orientations;
  ConstMatrixView heads;
  ConstMatrixView points;
  Eigen::Ref<RowMatrixXd> read;
  Eigen::Ref<RowMatrixXd> gradient;

  // Shapes agree, carriers index the pose, the field's cells number nx*ny*nz, finite points (naming the
  // frame and point).
  Status Validate() const;
  void Run();
};

}  // namespace motionkit
