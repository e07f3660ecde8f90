// BVH channels <-> Blender pose channels, for a whole clip in one call.
//
// A BVH joint's frame is world-aligned at rest; a Blender bone's is not (its Y
// axis runs head to tail, rolled about it). With C the axis conversion (BVH
// space to Blender armature space), s the scale, B_i a bone's rest
// orientation in armature space and R_i, t_i the joint's local rotation and
// translation from its channels (offset components replaced by position
// channels), the pose channels that reproduce the BVH's world joints are
//   rotation  M_i = B_i^-1 C R_i C^-1 B_i
//   location  l_i = B_i^-1 C s (t_i - offset_i)
// (derivation in docs/bvh.md). Quaternions are (w, x, y, z).
#pragma once

#include <Eigen/Geometry>

#include "motionkit/error.hpp"
#include "motionkit/skeleton.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

// Per joint: bone_rest row i is B_i (w x y z); rows of end sites are ignored.
// Outputs rotations frames x 4J and locations frames x 3J (end-site columns
// are written as identity / zero).
struct BvhToPoseJob {
  BvhToPoseJob(const Skeleton& skeleton_in, ConstMatrixView values_in, ConstMatrixView bone_rest_in,
               Eigen::Ref<RowMatrixXd> rotations_out, Eigen::Ref<RowMatrixXd> locations_out)
      : skeleton(skeleton_in),
        values(values_in),
        bone_rest(bone_rest_in),
        rotations(rotations_out),
        locations(locations_out) {}

  const Skeleton& skeleton;
  ConstMatrixView values;
  ConstMatrixView bone_rest;
  Eigen::Quaterniond conversion = Eigen::Quaterniond::Identity();
  double scale = 1.0;
  Eigen::Ref<RowMatrixXd> rotations;
  Eigen::Ref<RowMatrixXd> locations;

  Status Validate() const;
  void Run();
};

// The inverse: pose channels of the bones back to BVH channel values, Euler
// angles in each joint's channel order, continuous from frame to frame.
struct PoseToBvhJob {
  PoseToBvhJob(const Skeleton& skeleton_in, ConstMatrixView rotations_in,
               ConstMatrixView locations_in, ConstMatrixView bone_rest_in,
               Eigen::Ref<RowMatrixXd> values_out)
      : skeleton(skeleton_in),
        rotations(rotations_in),
        locations(locations_in),
        bone_rest(bone_rest_in),
        values(values_out) {}

  const Skeleton& skeleton;
  ConstMatrixView rotations;  // frames x 4J
  ConstMatrixView locations;  // frames x 3J
  ConstMatrixView bone_rest;  // J x 4
  Eigen::Quaterniond conversion = Eigen::Quaterniond::Identity();
  double scale = 1.0;
  Eigen::Ref<RowMatrixXd> values;  // frames x channel_count

  Status Validate() const;
  void Run();
};

}  // namespace motionkit
