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
// s in [0, 1) scales that axis's column by 1 - s.
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

#include "motionkit/error.hpp"
#include "motionkit/rig.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

enum class IkMethod { kCcd, kTranspose, kPseudoInverse, kDls };

std::optional<IkMethod> ParseIkMethod(std::string_view text);  // "ccd", "transpose", "pinv", "dls"

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
  bool root_translation = false;   // the root bone's location is an unknown
  bool root_rotation = false;      // the root bone's rotation is an unknown
  bool warm_start = true;          // start each frame from the previous frame's solution
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
  // Throws Error when Validate() fails, having written nothing.
  void Run();
};

}  // namespace motionkit
