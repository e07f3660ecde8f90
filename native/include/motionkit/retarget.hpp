// Retargeting a whole clip from one rig to another (docs/retargeting.md).
//
// Per mapped pair (source bone a, target bone b), with M the orientations of
// the match pose (the rest pose, or a pose the user set so that the two rigs
// stand alike), R the rotation from source to target armature space and
// S_b the shortest rotation that turns b's match direction (its Y axis) onto
// a's (carried by R), the target bone's orientation on every frame is
//   G_b(t) = D_a(t) S_b M_b,   D_a(t) = R G_a(t) M_a^-1 R^-1,
// docs/retargeting.md's Q^B = Q^A (Q^{A->B})^T with Q^{A->B} = M_b^-1 S_b^-1 M_a
// read in each rig's own bone frames. So b points where a points on every
// frame whatever the rest poses (T, A, anything) and bone rolls, and turns
// about itself as a does. "Points" is along each bone's aim: its Y axis, or
// the direction the caller gives (source_aims, target_aims) where a rig's
// bone axes do not run along its limbs. Locals come back as G_p^-1 G_b against each bone's
// rest (Blender's pose basis).
//
// Each character's posture: a target bone in `posture_bones` keeps the
// orientation its parent carries it to in the match pose (S_b = 1), so it
// moves from its own rest as a moves from the source's, and a hunched spine
// or a bent knee stays the character's own (a reference pose is a pose, not
// a body shape). The caller decides per chain which rest
// differences are poses (T against A arms: turned, S_b) and which are the
// body's (kept). A posture bone that its parents carry to point more than 45
// degrees from the source's is turned all the same: so far apart, the rigs
// stand in different poses there (a capture's foot pointing down its shin);
// kept_posture says which bones kept theirs. A bone in posture_always (the
// user's choice) keeps it whatever the angle.
//
// Chains of different lengths: target bones left out of the map that lie
// between two mapped bones (b0 above b) take, at the fraction of the chain's
// length where their tails lie, the rotation interpolated (slerp) along the
// source chain between a0 and a, so the chain bends as the source's does and
// ends as a. Where they are all helpers (helper_bones) they keep the match
// pose's local rotation instead, as Mixamo's retargets leave its `*_split`
// joints: always where they are posture bones too (a chain kept in the
// target's posture), else where b0 aims past them at b. Other unmapped bones
// keep the match pose's local rotation.
//
// Root motion: the target root's head moves across `up` (the target
// armature's up direction) as the source root moved from its match pose, and
// stands at the source root's height above the source's floor, both carried
// by R and scaled by `scale`, the ratio of how high the rigs' hips stand (in
// their own armature units). Each rig's floor is its own (its rest soles, or where the
// caller says): heights are measured along up from `source_floor` (source
// units, after R) and put above `target_floor`:
//   kScaled   horizontal and height scaled;
//   kInPlace  height scaled; the horizontal stays at the match pose;
//   kOffset   horizontal scaled, height unscaled (`unit_scale` converts
//             source armature units to target ones) plus `vertical_offset`
//             (the caller passes the difference in hip heights);
//   kNone     the root stays at the match pose.
// `scale_horizontal` multiplies the motion across the floor (kScaled, kOffset)
// on top of `scale`: a character whose stride the rigs' proportions do not
// give (Unreal's "Scale Horizontal").
#pragma once

#include <optional>
#include <string_view>
#include <vector>

#include <Eigen/Geometry>

#include "motionkit/error.hpp"
#include "motionkit/rig.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

enum class RootMotion { kScaled, kInPlace, kOffset, kNone };

std::optional<RootMotion> ParseRootMotion(std::string_view text);

struct RetargetOptions {
  RootMotion root_motion = RootMotion::kScaled;
  double scale = 1.0;       // the root path's: how high the target's hips stand / the source's
  double unit_scale = 1.0;  // target armature units per source armature unit
  double vertical_offset = 0.0;  // kOffset: added to the root's unscaled height
  double scale_horizontal = 1.0;  // kScaled, kOffset: the motion across up, times this on top of scale
  Eigen::Quaterniond space = Eigen::Quaterniond::Identity();  // source armature -> target armature
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  // the target armature's up (unit)
  double source_floor = 0.0;  // the source floor's height along up, source units carried by space
  double target_floor = 0.0;  // the target floor's height along up, target armature units
  std::vector<int> posture_bones;  // target bones that keep their own posture in the match pose (S_b = 1)
  std::vector<int> posture_always;  // ... and do so even where their parents carry them 45 degrees across
  // Unmapped target bones that are helpers (Mixamo's `*_split` joints): carried, not turned along the chain,
  // where they keep their posture or the mapped bone above aims past them at the mapped one below
  // (target_aims).
  std::vector<int> helper_bones;
  int threads = 0;  // frames posed on this many threads (0: one per hardware thread); the same result on any
};

// Inputs (caller-owned, read-only):
//   source_rotations  frames x 4A  armature-space orientations G_a (ArmaturePoseJob)
//   source_root_heads frames x 3   the source root's head
//   source_match      A x 4        M_a (the rest rotations, or a frame of source_rotations)
//   source_match_root 3            the source root's head in the match pose
//   target_match_basis B x 4       the target's match pose as pose channels (identity: rest)
//   target_match_location 3        the target root's location channel in the match pose
//   bone_map          B            per target bone, its source bone or -1
//   source_root, target_root       the bones whose heads carry the translation (-1: none)
// Outputs: rotations frames x 4B (basis quaternions, each bone's continuous
// from frame to frame), root_locations frames x 3 (the target root's location
// channel; zero without a target root).
struct RetargetJob {
  RetargetJob(const RigModel& source_in, const RigModel& target_in, ConstMatrixView source_rotations_in,
              ConstMatrixView source_root_heads_in, ConstMatrixView source_match_in,
              ConstMatrixView target_match_basis_in, Eigen::Ref<RowMatrixXd> rotations_out,
              Eigen::Ref<RowMatrixXd> root_locations_out)
      : source(source_in),
        target(target_in),
        source_rotations(source_rotations_in),
        source_root_heads(source_root_heads_in),
        source_match(source_match_in),
        target_match_basis(target_match_basis_in),
        rotations(rotations_out),
        root_locations(root_locations_out) {}

  const RigModel& source;
  const RigModel& target;
  ConstMatrixView source_rotations;
  ConstMatrixView source_root_heads;
  ConstMatrixView source_match;
  ConstMatrixView target_match_basis;
  Eigen::Vector3d source_match_root = Eigen::Vector3d::Zero();
  Eigen::Vector3d target_match_location = Eigen::Vector3d::Zero();
  std::vector<int> bone_map;
  // Optional, bones x 3 (or no rows: every bone's Y axis): where each bone points in its own frame, for
  // rigs whose bone axes do not run along their limbs (an FBX import without automatic bone orientation).
  RowMatrixXd source_aims;
  RowMatrixXd target_aims;
  int source_root = -1;
  int target_root = -1;
  RetargetOptions options;
  Eigen::Ref<RowMatrixXd> rotations;
  Eigen::Ref<RowMatrixXd> root_locations;
  std::vector<int> kept_posture;  // output: the posture bones that kept their posture (ascending)

  // Shapes, finiteness (naming bone and frame), the map (indices in range, at
  // least one bone, and no crossing: if target b0 is above b, source a0 must
  // not be below a), and roots in range.
  Status Validate() const;
  // Throws Error when Validate() fails, having written nothing.
  void Run();
};

}  // namespace motionkit
