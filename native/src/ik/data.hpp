// What a solve changes: one Data per run of frames, sized once from its Model (data.cpp) so that the
// frame loop allocates nothing. Vectors over rows are the effectors' rows of A (Model::rows); over
// columns, the unknowns (Model::cols).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "model.hpp"

namespace motionkit::ik_internal {

struct Pose {
  std::vector<Quat> basis;    // per bone
  std::vector<double> scale;  // per bone
  Vec3 root = Vec3::Zero();   // bone 0's head, armature space
};

struct Fk {
  std::vector<Quat> frame;  // per bone: its rest frame under its posed parent
  std::vector<Quat> global;
  std::vector<Vec3> head;
  std::vector<Vec3> tip;  // per effector
  // Balance: per bone, mass times position summed over its subtree; the
  // centre of mass.
  std::vector<Vec3> moment;
  Vec3 com = Vec3::Zero();
};

struct Cost {
  double task = 0.0;     // weighted squared residuals
  double worst = 0.0;    // largest error of a target or the balance, armature units
  double pins = 0.0;     // largest pin error
  double balance = 0.0;  // how far the centre of mass is from where it may be (enforced or not)
};

// An effector's rows of A: rows x its path's columns, column-major (i * rows + r), so that a
// column's rows lie together; and the same times W (DLS).
struct Block {
  std::vector<double> a, wa;
};

// The vectors and the matrix of one step. u = u0 + W A^T y: y solves an effector-space system.
struct StepBuffers {
  std::vector<double> residual;        // rows: e, the weighted residual at the current pose
  std::vector<double> trial_residual;  // rows: at the trial pose
  std::vector<double> effector_system;  // rows: the right-hand side, solved in place into y
  std::vector<double> linear_change;   // rows: A times a step (the change the linear model predicts)
  std::vector<double> step;            // columns: u, the step to try
  std::vector<double> prior_step;      // columns: u0, the posture prior's share of a DLS step
  // Columns: a direction the caller scales into the step (the transpose's steepest descent, the
  // stall's bend).
  std::vector<double> direction;
  std::vector<double> prior_pull;      // columns: b = -mu D G rho, the prior's gradient (DLS)
  std::vector<double> at_y;            // columns: A^T y
  std::vector<double> prior_offset;    // columns: rho, where each unknown stands from the reference
  std::vector<double> trial_prior_offset;
  std::vector<double> gram;            // rows x rows: diagonal I + A W A^T, factored in place
  // While settling, every level holds its residual where the settling found it (an unreachable
  // target's too), rather than reaching further.
  std::vector<double> held_residual;
  bool holding = false;
};

// W, the inverse of DLS's column metric M: diagonal unless DLS adds the residuals' curvature, then
// one 3 x 3 block per joint.
struct Weight {
  std::vector<double> diagonal;             // per column
  std::vector<Eigen::Matrix3d> joint;       // per joint
  bool blocks = false;
};

// The residuals' curvature DLS adds per joint (armature space, then in the joint's columns).
struct Curvature {
  std::vector<Eigen::Matrix3d> world, joint;
  bool ready = false;
  double weight = 0.0;  // how much of it DLS uses: 0 until a step fails
};

// Unknowns held for this iteration: on a bound (a limit, a scale range) that the step would push
// past, or in a later recruitment stage. Per column, and each limited joint's coordinates (swing x,
// twist, swing z) at the iteration's start.
struct Bounds {
  std::vector<char> held;
  std::vector<Vec3> coordinates;
  const Pose* pose = nullptr;  // the pose they were measured at
};

// Strict priorities' scratch (SolveLevels).
struct LevelScratch {
  std::vector<int> rows, held_rows;
  std::vector<double> held_gram, held_solve, level_gram, level_rhs;
  bool balance_active = false;  // the balance has been a level on this frame
  bool pins_only = false;       // stop after level 1
};

// The support polygon of the frame (FindSupport), and where the centre of mass may go.
struct Support {
  std::vector<Eigen::Vector2d> hull;   // scratch: the support points' projections, then their hull
  std::vector<Eigen::Vector2d> inner;  // the hull moved in by the frame's margin (one point when too thin)
  std::vector<Eigen::Vector2d> clip;   // scratch for clipping it
  int hull_count = 0, inner_count = 0;
  double frame_margin = 0.0;  // this frame's: never more than the input's own (negative: outside)
};

// CCD's points: the effector's own (up to three), then the pins a body link carries.
struct CcdScratch {
  std::vector<Vec3> points, targets;
  std::vector<double> weights;
  std::vector<char> placed;  // a position, not a direction
  Pose best;                 // the best sweep's pose
  Pose previous;             // the sweep's start, kept should it end non-finite
};

// The second-order correction's trial (SecondOrderCorrection).
struct Correction {
  Pose pose;
  Fk fk;
  std::vector<double> residual;
};

// The clip's second pass (natural defaults, warm-started runs): the first pass's corrections, root
// shifts and shortfalls per frame, and the sums of their low-pass.
struct SecondPass {
  std::vector<Quat> corrections;  // per frame and joint
  std::vector<double> correction_scales;
  std::vector<Vec3> root_shifts;  // per frame
  // Per frame: how far the levels moved the hips from the smoothed start (the balance, mostly), and how far
  // the last sweep starts them ahead of it.
  std::vector<Vec3> hip_moves, hip_leads;
  std::vector<Vec3> shortfalls;   // per frame and effector
  std::vector<int> end_stages;    // per frame
  std::vector<Vec3> rotation_sum;  // per joint
  std::vector<double> scale_sum;
  std::vector<Vec3> shift_sum, aside;  // per effector: the shortfall's low-pass, the frame's own target
};

// The last two frames' corrections (each joint's solved basis times its input's inverse; the scale
// and the root's move as they are), which a warm start carries on.
struct WarmStart {
  Pose last, earlier;
  Pose start;  // the frame's start: the later stages' too, when the first stage ends short
  Pose ended;  // where the solve from the warm start ended, while the frame is tried from its input
  bool have_last = false, have_earlier = false;
};

// The last iterate that met the pins, for when the polish cannot (a limit in the way).
struct PinnedFallback {
  Pose pose;
  bool have = false;
};

// EscapeStall's: which effectors are met, which joints it bends.
struct EscapeScratch {
  std::vector<char> effector_met, joint_bent;
};

struct Data {
  Pose input, current, trial, reference;
  Fk fk, trial_fk;
  std::vector<Vec3> target_position;  // per effector, this frame's
  std::vector<Quat> target_orientation;
  std::vector<Vec3> limit_lo, limit_hi;  // per joint, this frame's (soft axes take in the input)
  std::vector<Eigen::Matrix3d> joint_axes;  // per joint: its rest frame's axes (BuildJacobian's pose)
  std::vector<Block> blocks;  // per effector
  Block balance_block;        // 3 x columns
  StepBuffers buffers;
  Weight weight;
  Curvature curvature;
  Bounds bounds;
  LevelScratch levels;
  Support support;
  CcdScratch ccd;
  Correction correction;
  SecondPass second_pass;
  WarmStart warm;
  PinnedFallback fallback;
  EscapeScratch escape;
  int stage = 0;           // the recruitment stage being solved
  int ended_stage = 0;     // the stage that ended the last SolveStaged
  double settle_gain = 0.0;  // while settling: the prior's share of the way back a step
  Eigen::Index first = 0;  // the first frame of the run being solved
  int* iterations = nullptr;  // per frame of the job (none for Jacobian())

  explicit Data(const Model& m);
};

}  // namespace motionkit::ik_internal
