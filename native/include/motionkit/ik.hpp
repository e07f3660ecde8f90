// Full-body inverse kinematics on a RigModel (docs/ik.md), for a whole
// clip in one call.
//
// The contract: inputs, outputs, options and what Validate() refuses. How the
// solver works (unknowns, effectors, the methods, joint limits, stopping, and
// the implementation's choices) is in docs/ik.md, "How the solver works";
// the code is in native/src/ik/.
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
  // Per axis: the limits widen on each frame to take in the input pose, so
  // that default limits never move a joint the targets do not need to move.
  std::array<bool, 3> soft{{false, false, false}};
  // Recruitment (Jacobian methods): a frame is solved with the stage-0 joints
  // alone; only while some target stays out of their reach are the stage-1
  // joints freed as well (from the input pose), then stage 2, and so on.
  int stage = 0;
  // For the centre of mass (balance): the bone's mass, at its midpoint;
  // negative: its length (a mass per unit length of 1).
  double mass = -1.0;
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
  // Stop when every effector's error (armature units) is below; 0 picks 3e-7 of the rig's size (0.7 um
  // on a person in a T pose): a reachable target is met to what Blender's float keys can hold, while
  // a warm-started frame of smooth targets still ends after one or two steps.
  double tolerance = 0.0;
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
  // (every frame its own problem) runs of frames too; 0 (the default, as in
  // Python) means std::thread::hardware_concurrency(), 1 stays on the calling
  // thread. The results are the same whatever the count.
  int threads = 0;
  // Strict priorities (DLS; Baerlocher and Boulic 2004): pins, then balance,
  // then targets, then the posture prior, each solved in the null space of
  // the levels above it (a target out of reach never moves a pin). Off: every
  // effector is weighted against every other.
  bool priorities = true;
  // Keep the centre of mass, projected along `up`, inside the support polygon
  // of the pinned effectors' bones (the convex hull of their heads and tails
  // and their descendants' tails), `balance_margin` in from its edges (0
  // picks 0.005 of the rig's size). Needs priorities and a pin.
  bool balance = false;
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  // armature space
  double balance_margin = 0.0;
};

// Inputs (caller-owned):
//   input_rotations  frames x 4B  the clip's pose rotations (basis), or 1 row for every frame
//   input_locations  frames x 3   the root bone's location channel, or 1 row
//   target_positions frames x 3E  armature space (ignored for pins and position=false)
//   target_orientations frames x 4E, or 0 columns (ignored unless orientation)
// Outputs: rotations frames x 4B, root_locations frames x 3, scales frames x B
// (length scale per bone, 1 unless stretched), errors frames x E (position
// error of each effector after the solve, armature units), iterations frames.
// With priorities, pins are met to 1e-7 of the rig's size (or the tolerance,
// if smaller), whatever else cannot be.
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
  // free axes (X, Y, Z; times 1 - stiffness) and its stretch column. With
  // priorities, pins' rows are times 10; with balance, three more rows: the
  // centre of mass's ground projection, times 100. Throws like Run().
  RowMatrixXd Jacobian(Eigen::Index frame) const;
};

}  // namespace motionkit
