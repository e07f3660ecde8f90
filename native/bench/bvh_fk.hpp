// BVH's forward kinematics of a whole clip in one call, with its own SIMD path. Built for the tests and
// the benchmarks only: the BVH importer needs pose channels, not world positions (docs/bvh.md). A rig's
// (Blender armature's) forward kinematics is rig.hpp's PoseBone:
//   Q_i = Q_p(i) R_i,   p_i = p_p(i) + Q_p(i) t_i
// where R_i composes the joint's rotation channels in file order and t_i is
// the joint's OFFSET with any position channels replacing its components.
// End sites are joints like any other: they get positions and orientations.
#pragma once

#include "motionkit/error.hpp"
#include "motionkit/skeleton.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

// Caller-owned buffers; with threads = 1 Run() allocates nothing (the default,
// 0, as in Python, shares long clips among every core).
//   values:       frames x skeleton.channel_count (BVH rows, degrees)
//   positions:    frames x (3 * joints), world positions, x y z per joint
//   orientations: frames x (4 * joints), world orientations, w x y z per joint
struct ForwardKinematicsJob {
  ForwardKinematicsJob(const Skeleton& skeleton_in, ConstMatrixView values_in,
                       Eigen::Ref<RowMatrixXd> positions_out,
                       Eigen::Ref<RowMatrixXd> orientations_out)
      : skeleton(skeleton_in),
        values(values_in),
        positions(positions_out),
        orientations(orientations_out) {}

  const Skeleton& skeleton;
  ConstMatrixView values;
  Eigen::Ref<RowMatrixXd> positions;
  Eigen::Ref<RowMatrixXd> orientations;

  // Frames are independent: with more than one thread the clip is cut into
  // contiguous runs of rows, each solved on a thread of its own (the calling
  // thread takes the first), with the same numbers to the last bit as one
  // thread gives. 0 (the default, as in Python) means
  // std::thread::hardware_concurrency(). Short clips use fewer threads than
  // asked, down to one, where threads would cost more than they save.
  int threads = 0;

  // Shapes agree, the skeleton validates, threads >= 0, every value is finite
  // (else names the frame and the joint's channel).
  Status Validate() const;
  // Throws Error when Validate() fails, having written nothing.
  void Run();
};

}  // namespace motionkit
