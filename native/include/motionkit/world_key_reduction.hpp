// Key reduction bounded in armature space: the fewest Bézier keys such that
// every joint of a posed armature, and points a set length along each bone's
// three axes, stay within a distance of where the original curves put them at
// every sample.
//
// A bone's pose is Blender's: pose_b = pose_p Rest_p^-1 Rest_b T(loc) R S
// (a root: Rest_b T(loc) R S), with R from the bone's rotation channels in
// its mode (quaternions normalised, axis-angle about the normalised axis).
// Its points, in its own frame: the head (0, 0, 0), (a, 0, 0), (0, a, 0) and
// (0, 0, a) for the axis length a, and for a bone without children its tail
// (0, length, 0); each moves with pose_b.
//
// Method (docs/cleanup.md). Bones are reduced parents first. Bone b's channel
// groups (rotation, location, scale) are fitted by KeyReductionJob with
// tolerances k * (budget_b / reach_b) for rotation and scale and k * budget_b
// for location, where reach_b is the farthest any point of b's subtree gets
// from b's head and
//   budget_b = distance * (depth_b + 1) / (depth_b + 1 + height_b)
// (depth: bones above b; height: the longest chain below). A trial k passes
// when, with b's ancestors already reduced, b reduced and its descendants as
// they were, every point of b's subtree is within budget_b of the original on
// every sample: the error measured through the whole chain, not estimated.
// The search doubles or halves k from 1 and then bisects, keeping the passing
// trial with the fewest keys; k = 0 (every sample a key) always passes, since
// it reproduces b's channels and the budget grows down every chain. A leaf's
// budget is the whole distance, so every point ends within distance of the
// original, and each descendant keeps room for its own error. A second pass,
// parents first, runs each bone's search again from its k with the
// descendants as reduced and the whole distance as the limit: the shares
// assume errors that add up in a line, which they seldom do, and the bone's
// current k passes that check, so every point stays within distance.
#pragma once

#include <Eigen/Core>

#include "motionkit/error.hpp"
#include "motionkit/rig.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

// How bone b's rotation channels (columns 10 b .. 10 b + 3) are read.
enum WorldRotationMode : int {
  kWorldQuaternion = 0,  // w x y z
  kWorldAxisAngle = 1,   // angle, x y z (a zero axis is no rotation, as Blender poses it)
  // kWorldEuler + EulerOrder: three angles in the letter order of that
  // EulerOrder (rotation.hpp; Blender's 'XYZ' is kZYX with the angles z y x),
  // the fourth column unused.
  kWorldEuler = 2,
};

using BoolMatrixView = Eigen::Ref<Eigen::Matrix<bool, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>;
using ConstIntMatrixView = Eigen::Ref<const Eigen::Matrix<int, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>;

// Inputs (B bones of rig, m samples):
//   times:          m, strictly increasing, finite.
//   channels:       m x 10 B: per bone its rotation (4 columns, see
//                   WorldRotationMode), location (3) and scale (3) channels
//                   at every sample, finite.
//   rotation_modes: B, WorldRotationMode values.
//   group_ranges:   3 B x 2: for group 3 b + g of bone b (g = 0 rotation,
//                   1 location, 2 scale) the first and last sample of its keys
//                   (inclusive), or -1 -1 for a group left as it is (its
//                   channels posed from the samples). Outside its range a
//                   group keeps its samples.
//   distance:       > 0, armature units; axis_length >= 0.
//   stride:         keys at every stride-th sample of a group's range and its
//                   last (samples per frame keep keys on frames).
// Outputs, caller-owned:
//   keys:           m x 3 B: whether sample j is a key of group 3 b + g.
//   slopes_in, slopes_out: m x 10 B: at a key, its incoming and outgoing slope
//                   per channel (value per time unit; KeyReductionJob's).
//   worst_error:    set by Run(): the largest distance of any point from the
//                   original on any sample, as measured.
struct WorldKeyReductionJob {
  WorldKeyReductionJob(const RigModel& rig_in, ConstVectorView times_in, ConstMatrixView channels_in,
                       Eigen::Ref<const Eigen::VectorXi> rotation_modes_in, ConstIntMatrixView group_ranges_in,
                       BoolMatrixView keys_out, Eigen::Ref<RowMatrixXd> slopes_in_out,
                       Eigen::Ref<RowMatrixXd> slopes_out_out)
      : rig(rig_in),
        times(times_in),
        channels(channels_in),
        rotation_modes(rotation_modes_in),
        group_ranges(group_ranges_in),
        keys(keys_out),
        slopes_in(slopes_in_out),
        slopes_out(slopes_out_out) {}

  const RigModel& rig;
  ConstVectorView times;
  ConstMatrixView channels;
  Eigen::Ref<const Eigen::VectorXi> rotation_modes;
  ConstIntMatrixView group_ranges;
  double distance = 1e-3;
  double axis_length = 0.1;
  Eigen::Index stride = 1;
  BoolMatrixView keys;
  Eigen::Ref<RowMatrixXd> slopes_in;
  Eigen::Ref<RowMatrixXd> slopes_out;
  double worst_error = 0.0;

  // Names the bone, sample or setting at fault.
  Status Validate() const;
  // Throws Error when Validate() fails; else fills the outputs.
  void Run();
};

}  // namespace motionkit
