// Mirroring a clip left <-> right across a plane (docs/cleanup.md, "Mirroring").
//
// The world-space motion is mirrored, then re-expressed in each target bone's own rest, so that rolls and
// rest poses that are not mirror images of each other still give the mirrored motion. With the plane's
// reflection L = I - 2 n n^T (unit normal n through point c, armature space), the source's posed
// orientations R_a(t) and heads h_a(t), and target bone b driven by its partner p:
//   D_p(t)  = R_p(t) Rest_p^-1               how p has turned from its rest, in armature space
//   R'_b(t) = (L D_p(t) L) Rest_b            the mirrored turn applied to b's own rest
//   h'_b(t) = h_p(t) - 2 ((h_p(t) - c) . n) n
// L D L is a proper rotation: as a quaternion (w, v) it is (w, 2 (n . v) n - v), a half turn about n on
// either side. Each bone's pose channels then come from its parent's new pose (RigModel's forward
// kinematics read backwards), so a root's location carries the mirrored root motion. A target bone
// without a partner (a prop on one hand) keeps a source bone's local transform instead, following its
// parent, or stays at its rest. Mirroring a clip twice, with partners that pair each other, gives it back.
#pragma once

#include <vector>

#include <Eigen/Geometry>

#include "motionkit/error.hpp"
#include "motionkit/rig.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

// Inputs (caller-owned, read-only):
//   source_rotations frames x 4S  the source's armature-space orientations (ArmaturePoseJob)
//   source_heads     frames x 3S  its heads
//   partners         T            per target bone, the source bone mirrored onto it, or -1
//   kept             T            per target bone without a partner, the source bone whose pose channels
//                                 it keeps, or -1 for its rest
//   normal, point                 the plane, in armature space (normal non-zero; normalised here)
// Outputs (caller-owned): rotations frames x 4T, each target bone's pose basis (w x y z, continuous
// from frame to frame); locations frames x 3T, its location channel. Run() allocates only its per-bone
// scratch, once.
struct MirrorJob {
  MirrorJob(const RigModel& source_in, const RigModel& target_in, ConstMatrixView source_rotations_in,
            ConstMatrixView source_heads_in, Eigen::Ref<RowMatrixXd> rotations_out,
            Eigen::Ref<RowMatrixXd> locations_out)
      : source(source_in),
        target(target_in),
        source_rotations(source_rotations_in),
        source_heads(source_heads_in),
        rotations(rotations_out),
        locations(locations_out) {}

  const RigModel& source;
  const RigModel& target;
  ConstMatrixView source_rotations;
  ConstMatrixView source_heads;
  std::vector<int> partners;
  std::vector<int> kept;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX();
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Ref<RowMatrixXd> rotations;
  Eigen::Ref<RowMatrixXd> locations;

  // Shapes, bone indices in range, the plane finite with a non-zero normal, and every source rotation
  // and head usable (naming the bone and frame).
  Status Validate() const;
  // Throws Error when Validate() fails, having written nothing.
  void Run();
};

}  // namespace motionkit
