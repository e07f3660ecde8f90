// The model of one solve group: what every frame of the group shares, worked out once from the job
// (BuildModel, model.cpp) and never changed by a solve, so that runs of frames on other threads read
// the same one. What a solve changes lives in Data (data.hpp).
//
// Unknowns are columns: the root's translation (three), then per solved joint its free rotation axes
// and its stretch. An effector's path is the list of its ancestors' columns, root first; two paths
// share exactly their common ancestors' columns, and those come first in both, so the effector-space
// matrix A W A^T is built block by block from dot products of leading columns (`prefix`).
#pragma once

#include <array>
#include <limits>
#include <vector>

#include <Eigen/Geometry>

#include "motionkit/ik.hpp"

namespace motionkit::ik_internal {

using Vec3 = Eigen::Vector3d;
using Quat = Eigen::Quaterniond;

enum class Kind { kTranslate, kRotate, kStretch };

struct Column {
  Kind kind = Kind::kRotate;
  int joint = -1;      // index into Model::joints (kRotate, kStretch)
  int axis = 0;        // X, Y, Z (kTranslate, kRotate)
  double scale = 1.0;  // 1 - stiffness, the stretch factor, or 1
  // How DLS's damping and regulariser weigh a unit of it: 1, or 1 / ls^2
  // for the root's translation (a move of ls counts as a turn of a radian).
  double metric = 1.0;
  int stage = 0;  // recruitment stage (IkJoint::stage)
};

// A solved bone. Its limits as given; soft axes widen on each frame to take in the frame's input
// (Data::limit_lo, limit_hi).
struct Joint {
  int bone = -1;
  int axis_count = 0;  // free rotation axes, X Y Z order
  std::array<int, 3> axes{{0, 1, 2}};
  std::array<double, 3> axis_scale{{1.0, 1.0, 1.0}};
  std::array<bool, 3> free{{true, true, true}};
  int first_column = -1;    // its rotation columns, then its stretch column
  int stretch_column = -1;  // -1: rigid
  double stretch = 0.0;
  double min_scale = 1.0, max_scale = 1.0;
  bool limited = false;
  Vec3 lo = Vec3::Constant(-std::numeric_limits<double>::infinity());
  Vec3 hi = Vec3::Constant(std::numeric_limits<double>::infinity());
  std::array<bool, 3> soft{{false, false, false}};
  int stage = 0;
  bool pinned_chain = false;  // a pin hangs below it
};

// One joint of an effector's CCD chain. A body link turns the rest of the
// body about the joint instead of the bone (the chain runs through the
// root to a pin, as if the pin were the root).
struct Link {
  int joint = -1;
  bool body = false;
  int anchor = -1;  // a body link: the pin it turns about
  double lever = 0.0;  // how far the effector moves per unit of the bone's scale
};

// A run of an effector's columns: one joint's rotation columns, or one
// other column (joint -1).
struct Segment {
  int start = 0, count = 1, joint = -1;
};

// An effector's rows and path. Its rows of A are Data::blocks[its index] (Data::balance_block for
// the centre of mass).
struct Effector {
  int bone = -1;  // -1: the centre of mass (balance)
  int row = 0, rows = 0;
  bool position = true, orientation = false, pin = false;
  int level = 3;  // 1 pins, 2 balance, 3 targets
  double sqrt_weight = 1.0;
  std::vector<int> columns;    // its path's columns, root first
  std::vector<double> levers;  // per column (stretch columns)
  std::vector<Segment> segments;
  std::vector<int> prefix;     // per effector: how many leading columns the two paths share
  std::vector<Link> ccd;
};

// Balance: the bones' masses, the support's bones and the ground's axes.
struct BalanceModel {
  bool enabled = false;     // the centre of mass is a level-2 task (priorities, balance and a pin)
  Effector com;             // the centre of mass's rows (bone -1), every column
  std::vector<double> mass;  // per bone
  std::vector<double> subtree_mass;
  double total_mass = 0.0;
  Vec3 up = Vec3::UnitZ(), side = Vec3::UnitX(), ahead = Vec3::UnitY();  // up, and two horizontal axes
  double margin = 0.0;
  std::vector<int> support_bones;  // pinned bones and their descendants
};

// The bones forward kinematics visits: the effectors' ancestors (every bone with balance), parents
// first; split into those no unknown moves (no solved bone above them, and the root's location is not
// an unknown: the same in every pose of a frame) and the rest.
struct FkOrder {
  std::vector<int> needed, fixed, moving;
};

struct Model {
  const IkClipJob& job;
  const RigModel& rig;
  const IkOptions& options;
  std::vector<int> ids;  // per effector: its index in job.effectors
  int bones = 0, effector_count = 0;
  int rows = 0, cols = 0;  // of A: the effectors' (and the balance's) rows, the unknowns
  double size = 1.0;       // the rig's, which the defaults scale with
  double lambda = 0.0;     // DLS's damping
  double mu = 0.0;         // the posture prior's weight
  double ls = 0.0;         // length units per radian
  double tolerance = 0.0, pin_tolerance = 0.0;
  bool translate = false;   // bone 0's head is an unknown
  bool priorities = false;  // DLS with strict priority levels
  // The posture prior as a level of its own (priorities and recruitment
  // stages, as natural defaults set them), rather than DLS's regulariser.
  bool separate_prior = false;
  bool pinned = false;  // some effector is a pin
  bool body = false;    // CCD may carry the body through the root
  int stages = 1;       // recruitment stages
  FkOrder order;
  std::vector<int> joint_of;  // per bone: its index in joints, or -1
  std::vector<Joint> joints;
  std::vector<Column> columns;
  std::vector<Effector> effectors;
  std::vector<int> ccd_order;  // targets first, then pins
  BalanceModel balance;

  Model(const IkClipJob& job_in, std::vector<int> ids_in);
};

}  // namespace motionkit::ik_internal
