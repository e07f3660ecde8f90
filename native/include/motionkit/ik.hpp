// Full-body inverse kinematics on a RigModel (brief, section 3), for a whole
// clip in one call.
//
// Unknowns: each solved bone's pose rotation (its basis, as Blender stores
// it), moved by small incremental rotations about the three axes of the
// bone's rest frame under its posed parent (so a locked axis is a dropped
// column, a hinge is one column); optionally each bone's length scale
// (stretch: a prismatic unknown along the bone's Y axis); and the root
// bone's location and rotation, so that a chain can pass through the root (a
// pinned foot, a hand pulled: the hips move, the foot stays).
//
// Effectors sit at a bone's tail (Blender's IK tip). Each has a position
// target, an optional orientation target (the bone's armature-space
// orientation) and a weight; a pin holds the effector where the frame's
// input pose has it. The solved bones are those on the paths from the root
// (or, without root unknowns, from the bones below the root) to the
// effectors, less excluded bones; every other bone keeps its input rotation.
//
// Methods, each iteration from the current pose:
//   kCcd            cyclic coordinate descent: per effector, joints from the
//                   tip towards the root (through the root when a pin holds the
//                   far end) turn the joint->tip vector onto joint->target;
//                   stretchable bones take the length that leaves the residual
//                   perpendicular to the bone.
//   kTranspose      dtheta = alpha J^T e, alpha = <e, J J^T e> / |J J^T e|^2.
//   kPseudoInverse  dtheta = J^+ e (J^T (J J^T + eps I)^-1, eps ~ 1e-12 of the
//                   system's scale).
//   kDls            damped least squares with the brief's regulariser:
//                   min |J dtheta - e|^2 + lambda^2 |dtheta|^2
//                       + mu |theta + dtheta - theta_ref|^2,
//                   theta_ref the previous frame's solution or the input pose;
//                   solved in effector space (Woodbury), so the cost grows
//                   with the effectors, not the bones.
// J is the geometric Jacobian: a rotation about world axis a at a joint whose
// vector to the effector is r moves it by a x r; root translation moves
// every effector one to one. Rows are weighted by sqrt(weight); orientation
// rows are rotation-vector errors times `orientation_scale` (length units per
// radian). Steps are clamped (max_step radians per joint, max_step *
// orientation_scale for the root's translation) and limits applied after
// every step, so no returned angle leaves its limits.
//
// Joint limits, in Blender's terms (ik_min_*, ik_max_*, lock_ik_*,
// ik_stiffness_*): a basis rotation is split into twist about the bone's Y
// axis and swing (a rotation about an axis in the X-Z plane); the twist angle
// is limited to [min.y, max.y] and the swing's rotation-vector components to
// [min.x, max.x] and [min.z, max.z]. A locked axis has range [0, 0]. Stiffness
// s in [0, 1) scales that axis's column by 1 - s. Limits bind the solved
// bones only (a bone the solver does not move keeps its input, in limits or
// not); a solved bone's starting pose is brought into its limits first.
//
// Details the outline above leaves open (implementation notes, ik.cpp):
//   - "The root" is bone 0 (always parentless); its location channel is
//     input_locations. Other parentless bones are solved like any bone.
//     Root translation and rotation are unknowns only for effectors below
//     bone 0, and not if bone 0 is excluded.
//   - Stretch: a stretched bone's scale s multiplies its length and the
//     component along it (Y) of its children's head offsets, so connected
//     children stay at its tail; the children are not scaled themselves.
//     `stretch` (Blender's ik_stretch) scales the stretch column; CCD takes
//     min(stretch, 1) of the length change it computes per visit.
//   - The root translation's columns are the identity (armature units);
//     DLS's damping and regulariser weigh a move of the root by 1 / ls^2, so
//     that a move of ls counts as much as a turn of one radian (the
//     pseudo-inverse and the transpose use J as it is).
//   - The regulariser acts on each unknown in its own units (the rotation
//     vector from the reference, the scale, the root's move / ls).
//     Its weight on an iteration is mu * min(1, worst error / (0.01 size))^2:
//     it steers the redundancy while the targets are far and fades as they
//     are met, so that a reachable target is reached (to the tolerance)
//     rather than traded against the reference. Unreachable targets keep the
//     full weight.
//   - A Jacobian step is accepted only if it lowers the (weighted,
//     regularised) cost, so the error never grows from one iteration to the
//     next and an unreachable target is approached without jitter. DLS and
//     the pseudo-inverse then adapt their damping term (lambda^2, eps;
//     Levenberg-Marquardt with Nielsen's update, never below lambda^2 or
//     eps); the transpose halves its step. Before DLS raises its damping it
//     adds, per joint, the positive part of the curvature of the position
//     residuals that Gauss-Newton leaves out (a 3 x 3 block per joint, so M
//     stays block diagonal and the Woodbury form holds): at a chain
//     stretched towards an unreachable target it holds the overshoot back
//     without damping the null space, and it is relaxed again while the
//     steps go well. An iteration counts every step tried.
//   - A frame stops when every effector is within the tolerance, after
//     max_iterations, when an accepted step lowers the cost by less than a
//     relative 1e-13, or when a step would produce a non-finite value (the
//     previous iterate is kept). At a stationary point that is not a
//     solution (a straight chain asked to fold, a target straight behind),
//     the joints serving only unmet effectors are bent about their first
//     free swing axis, less the part that moves any effector to first order
//     (the Jacobian's null space), so far that no joint turns more than
//     0.05 rad (or max_step), one way then the other; the bend is kept if it
//     lowers the cost (at most twice a frame; deterministic).
//   - CCD: an iteration is one sweep, non-pinned effectors first, then pins.
//     A pin's sweep turns only the bones no other effector hangs from. Root
//     translation serves CCD only to carry the body about a pinned chain
//     (both root unknowns on): a non-pinned effector's chain then runs up to
//     where it meets the first pin on another branch and down that pin's
//     chain, whose joints turn the rest of the body about themselves; the
//     other pins the body carries join that turn's fit (weighted Kabsch), so
//     that it does not tear them away. Several effectors pull against each
//     other, so a sweep may lose ground: CCD keeps the best pose and stops
//     after 4 sweeps without a better one.
//   - An unknown on a bound (a joint limit, a scale range) that the step
//     would push past is held for that iteration (its column drops out), so
//     that the rest of the step is solved for what can move rather than
//     clamped afterwards; a rotation column stands for its own coordinate
//     (X, Z: swing; Y: twist) to first order.
//   - Limits are met within a rotation's reach: the twist in (-pi, pi), the
//     swing's rotation vector at most pi long (a hair less for both, so
//     that a clamped pose decomposes back to the same numbers). Validate
//     refuses limits that no rotation meets.
//   - The rig's size is the diagonal of its rest pose's bounding box (heads
//     and tails), unless options.size gives it.
//   - errors: the position error of a position effector; for an
//     orientation-only one, its angle times ls.
//
// Quaternions are (w, x, y, z) in arrays.
#pragma once

#include <array>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "motionkit/error.hpp"
#include "motionkit/rig.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

enum class IkMethod { kCcd, kTranspose, kPseudoInverse, kDls };

std::optional<IkMethod> ParseIkMethod(std::string_view text);  // "ccd", "transpose", "pinv", "dls"

// The limits' coordinates of a basis rotation: (swing x, twist angle, swing
// z) with q = swing * twist, twist about Y in [-pi, pi], swing the rotation
// vector (x, 0, z); and back. (A half-turn swing has no defined twist: 0.)
Eigen::Vector3d IkSwingTwist(const Eigen::Quaterniond& q);
Eigen::Quaterniond IkFromSwingTwist(const Eigen::Vector3d& angles);

struct IkJoint {
  static constexpr double kFree = std::numeric_limits<double>::infinity();
  Eigen::Vector3d min = Eigen::Vector3d::Constant(-kFree);  // radians: swing x, twist y, swing z
  Eigen::Vector3d max = Eigen::Vector3d::Constant(kFree);
  std::array<bool, 3> locked{{false, false, false}};
  Eigen::Vector3d stiffness = Eigen::Vector3d::Zero();  // each in [0, 1)
  bool excluded = false;      // never moved by the solver
  double stretch = 0.0;       // 0: rigid; > 0: length may scale within [min_scale, max_scale]
  double min_scale = 1.0, max_scale = 1.0;
};

struct IkEffector {
  std::string name;  // for messages
  int bone = -1;     // the effector is this bone's tail
  double weight = 1.0;
  bool position = true;
  bool orientation = false;
  bool pin = false;  // hold where the frame's input pose has it (position, and orientation if set)
};

enum class IkReference { kPrevious, kInput };

struct IkOptions {
  IkMethod method = IkMethod::kDls;
  int max_iterations = 64;
  double tolerance = 1e-5;       // stop when every effector's error (armature units) is below
  double max_step = 0.3;         // radians per joint per iteration
  double damping = 0.0;          // lambda; 0 picks 1e-3 of the rig's size
  double regularization = 1e-4;  // mu, towards the reference pose
  IkReference reference = IkReference::kPrevious;
  double orientation_scale = 0.0;  // length units per radian; 0 picks 0.1 of the rig's size
  // The rig's size, which the defaults above scale with; 0: the diagonal of
  // its rest pose's bounding box. A caller solving part of a rig gives the
  // whole rig's, so that the part is solved as the whole would be.
  double size = 0.0;
  bool root_translation = false;   // the root bone's location is an unknown
  bool root_rotation = false;      // the root bone's rotation is an unknown
  // Start each frame from the previous frame's solution, or, from the third
  // frame on, from where the last two solutions were heading when that
  // starts nearer the targets (smooth targets then take one step a frame).
  bool warm_start = true;
  // Independent groups of effectors (see Run) may be solved on up to this
  // many threads, and without warm_start and with the input as reference
  // (every frame its own problem) runs of frames too; 0 means
  // std::thread::hardware_concurrency(). The results are the same whatever
  // the count.
  int threads = 1;
};

// Inputs (caller-owned):
//   input_rotations  frames x 4B  the clip's pose rotations (basis), or 1 row for every frame
//   input_locations  frames x 3   the root bone's location channel, or 1 row
//   target_positions frames x 3E  armature space (ignored for pins and position=false)
//   target_orientations frames x 4E, or 0 columns (ignored unless orientation)
// Outputs: rotations frames x 4B, root_locations frames x 3, scales frames x B
// (length scale per bone, 1 unless stretched), errors frames x E (position
// error of each effector after the solve, armature units), iterations frames.
struct IkClipJob {
  IkClipJob(const RigModel& rig_in, ConstMatrixView input_rotations_in, ConstMatrixView input_locations_in,
            ConstMatrixView target_positions_in, ConstMatrixView target_orientations_in,
            Eigen::Ref<RowMatrixXd> rotations_out, Eigen::Ref<RowMatrixXd> root_locations_out,
            Eigen::Ref<RowMatrixXd> scales_out, Eigen::Ref<RowMatrixXd> errors_out,
            Eigen::Ref<Eigen::VectorXi> iterations_out)
      : rig(rig_in),
        input_rotations(input_rotations_in),
        input_locations(input_locations_in),
        target_positions(target_positions_in),
        target_orientations(target_orientations_in),
        rotations(rotations_out),
        root_locations(root_locations_out),
        scales(scales_out),
        errors(errors_out),
        iterations(iterations_out) {}

  const RigModel& rig;
  std::vector<IkJoint> joints;  // one per bone, or empty for all free
  std::vector<IkEffector> effectors;
  IkOptions options;
  ConstMatrixView input_rotations;
  ConstMatrixView input_locations;
  ConstMatrixView target_positions;
  ConstMatrixView target_orientations;
  Eigen::Ref<RowMatrixXd> rotations;
  Eigen::Ref<RowMatrixXd> root_locations;
  Eigen::Ref<RowMatrixXd> scales;
  Eigen::Ref<RowMatrixXd> errors;
  Eigen::Ref<Eigen::VectorXi> iterations;

  // Shapes; effectors (bone in range, weight finite and positive, something
  // to reach); limits (min <= max, stiffness in [0, 1), scales positive);
  // every input finite, naming the effector (or bone) and the frame.
  Status Validate() const;
  // Throws Error when Validate() fails, having written nothing. Effectors
  // that share no unknown (their paths meet only at bones the solver does
  // not move, and not both through the root's location) are independent
  // problems: each group is solved on its own, as if the job had only its
  // effectors, so that its system is small and it stops when its own targets
  // are met. iterations[f] is then the most any group took on frame f.
  void Run();

  // For tests: the Jacobian the solver builds at `frame`'s input pose (as a
  // cold start sees it), rows per effector (position, then orientation, each
  // times sqrt(weight); orientation rows also times ls), columns the root
  // translation (3, identity), then per solved bone in bone order its
  // free axes (X, Y, Z; times 1 - stiffness) and its stretch column. Throws
  // like Run().
  RowMatrixXd Jacobian(Eigen::Index frame) const;
};

}  // namespace motionkit
