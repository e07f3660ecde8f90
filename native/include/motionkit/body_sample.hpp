// Reading a body's signed-distance field (body_field.hpp) where its bones have moved it: each point taken
// back to rest through every carrier bone's motion and read (trilinear) where that carrier owns the cell;
// the nearest of those, and the trilinear distance's gradient there, in the armature's space
// (docs/body.md). What core/body.Body.posed_with_gradient runs.
#pragma once

#include <Eigen/Core>
#include <utility>
#include <vector>

#include "motionkit/error.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

// Caller-owned buffers; Run() allocates nothing.
//   distance, owner: the field's nx*ny*nz cells ((i*ny + j)*nz + k), dims, origin (the first cell's
//                    centre) and spacing as BodyFieldJob made them
//   carriers:        the bones that read the field; carrier_rest (K x 4, w x y z) and carrier_heads (K x 3)
//                    their rest orientations and heads
//   orientations:    frames x 4B, heads frames x 3B: the armature pose (every bone; carriers index it)
//   points:          frames x 3N, the points to read on each frame
//   read:            frames x N out: the distance, +inf where no carrier owns the cell a point maps to
//   gradient:        frames x 3N out (or 0 columns for none): its gradient, 0 where read is +inf
struct BodySampleJob {
  BodySampleJob(ConstVectorView distance_in, Eigen::Ref<const Eigen::VectorXi> owner_in, Eigen::Vector3i dims_in,
                Eigen::Vector3d origin_in, double spacing_in, std::vector<int> carriers_in,
                ConstMatrixView carrier_rest_in, ConstMatrixView carrier_heads_in, ConstMatrixView orientations_in,
                ConstMatrixView heads_in, ConstMatrixView points_in, Eigen::Ref<RowMatrixXd> read_out,
                Eigen::Ref<RowMatrixXd> gradient_out)
      : distance(distance_in),
        owner(owner_in),
        dims(dims_in),
        origin(origin_in),
        spacing(spacing_in),
        carriers(std::move(carriers_in)),
        carrier_rest(carrier_rest_in),
        carrier_heads(carrier_heads_in),
        orientations(orientations_in),
        heads(heads_in),
        points(points_in),
        read(read_out),
        gradient(gradient_out) {}

  ConstVectorView distance;
  Eigen::Ref<const Eigen::VectorXi> owner;
  Eigen::Vector3i dims;
  Eigen::Vector3d origin;
  double spacing;
  std::vector<int> carriers;
  ConstMatrixView carrier_rest;
  ConstMatrixView carrier_heads;
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
