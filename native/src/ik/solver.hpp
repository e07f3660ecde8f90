// The IK solver's internals, shared by the files of native/src/ik/ (the contract is
// native/include/motionkit/ik.hpp; the design is in docs/ik.md).
//
// How it is organised: Run() validates, then builds a Solver, which works out
// once what every frame shares (the bones FK visits, the solved joints and
// their columns, each effector's path as a list of columns root first, how
// many leading columns any two effectors share, the CCD chains) and sizes
// every buffer; the frame loop allocates nothing. A Jacobian method keeps one
// dense block per effector (its rows x its path's columns, stored column by
// column so that a column's rows lie together). Two paths share
// exactly their common ancestors' columns, and those come first in both
// lists, so the effector-space matrix A W A^T is built block by block from
// dot products of leading columns: its cost grows with the paths, not with
// the rig.
#pragma once

#include "motionkit/ik.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <exception>
#include <limits>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "../parallel.hpp"
#include "../so3.hpp"

namespace motionkit::ik_internal {

using Vec3 = Eigen::Vector3d;
using Quat = Eigen::Quaterniond;

using internal::Cholesky;
using internal::CholeskySolve;
using internal::FromRotationVector;
using internal::kPi;
using internal::RotationVector;
constexpr double kInf = std::numeric_limits<double>::infinity();
// A DLS step that lowers the cost by less than this
// fraction ends the frame: the
// targets are out of reach (a reachable one converges quadratically, each step
// taking a large share of what is left). Unreachable frames stop after a few
// steps instead of running to max_iterations.
constexpr double kStationary = 1e-9;
// The transpose and the pseudo-inverse (without the curvature term, which lets
// DLS settle at once) creep by small fractions: only a standstill ends them.
constexpr double kCreeping = 1e-13;
// With recruitment stages an unreachable target is approached by ever
// smaller steps: on a warm-started frame, once a step has gained ground, one
// that lowers the cost by less than this fraction ends the stage (a cold
// start, which has further to go, keeps kStationary).
constexpr double kSettled = 1e-5;
// The clip's second pass low-passes the first's corrections with a Gaussian
// of this many frames (see Smooth): a pop spread over about five frames.
constexpr double kSmoothSigma = 2.0;
constexpr int kSmoothIterations = 8;  // the second pass's steps a frame, before its settling and polish
constexpr double kPriorGain = 0.2;
// With priorities, the levels' rows are scaled so that the merit a step must
// lower ranks them as the priorities do (a pin's error costs a hundred times a
// target's, the balance's ten thousand times: much more for the pins and the
// steps' curvature, which takes them a little off, would stall the solve; the
// second-order correction and the polish hold them instead), and so that the
// effector-space damping, the same for every level, is small for both.
constexpr double kPinScale = 10;
constexpr double kBalanceScale = 1e2;
// Recruitment inside a stage: once the hips are free (to keep the balance,
// say), a step still prefers the joints of earlier stages, each stage's
// unknowns costing ten times the last's in the damping and the posture prior.
inline double StageCost(int stage) { return std::pow(10.0, stage); }

template <class T>
T& At(std::vector<T>& v, int i) {
  return v[static_cast<std::size_t>(i)];
}
template <class T>
const T& At(const std::vector<T>& v, int i) {
  return v[static_cast<std::size_t>(i)];
}

inline Vec3 Unit(int axis) { return Vec3::Unit(axis); }




// A swing's rotation vector is at most pi long, and a half turn has two (x,
// z) for one rotation; a twist of pi is one of -pi. Limits are kept a hair
// inside both, so that what is clamped decomposes back to the same numbers.
constexpr double kSwingReach = kPi - 1e-6;
constexpr double kTwistReach = kPi - 1e-9;

// The nearest coordinates within the limits' box that a rotation can have:
// the twist in (-pi, pi), the swing (x, z) in the disk of radius pi. When
// the box's clamp leaves the disk, the nearest point of box and disk lies on
// the circle: the radial projection, or where the circle meets the box's
// edges, or a corner of the box.
inline Vec3 ClampToLimits(const Vec3& a, const Vec3& lo, const Vec3& hi) {
  Vec3 c = a.cwiseMax(lo).cwiseMin(hi);
  c.y() = std::clamp(c.y(), std::max(lo.y(), -kTwistReach), std::min(hi.y(), kTwistReach));
  const double x0 = c.x(), z0 = c.z(), r2 = kSwingReach * kSwingReach;
  if (x0 * x0 + z0 * z0 <= r2) return c;
  double best = kInf, bx = x0, bz = z0;
  const auto consider = [&](double x, double z) {
    const double slack = 1e-12;
    if (!(x >= lo.x() - slack && x <= hi.x() + slack && z >= lo.z() - slack && z <= hi.z() + slack)) return;
    if (x * x + z * z > r2 * (1.0 + 1e-12)) return;
    const double d = (x - x0) * (x - x0) + (z - z0) * (z - z0);
    if (d < best) {
      best = d;
      bx = x;
      bz = z;
    }
  };
  const double r = std::hypot(x0, z0);
  consider(x0 * kSwingReach / r, z0 * kSwingReach / r);
  for (const double x : {lo.x(), hi.x()}) {
    if (std::abs(x) > kSwingReach) continue;
    const double h = std::sqrt(r2 - x * x);
    consider(x, h);
    consider(x, -h);
    for (const double z : {lo.z(), hi.z()}) consider(x, z);
  }
  for (const double z : {lo.z(), hi.z()}) {
    if (std::abs(z) > kSwingReach) continue;
    const double h = std::sqrt(r2 - z * z);
    consider(h, z);
    consider(-h, z);
  }
  if (best == kInf) {  // no swing meets the limits (Validate refuses them): the nearest the disk allows
    bx = x0 * kSwingReach / r;
    bz = z0 * kSwingReach / r;
  }
  c.x() = std::clamp(bx, lo.x(), hi.x());
  c.z() = std::clamp(bz, lo.z(), hi.z());
  const double n = std::hypot(c.x(), c.z());
  if (n > kSwingReach) {
    c.x() *= kSwingReach / n;
    c.z() *= kSwingReach / n;
  }
  return c;
}

inline std::string FrameIndex(Eigen::Index f) { return "frame index " + std::to_string(f); }

inline std::string EffectorName(const IkEffector& e, std::size_t i) {
  return e.name.empty() ? "effector " + std::to_string(i) : "effector '" + e.name + "'";
}

// Kernels over an effector's column-major block (R rows: 3, or 6 with an
// orientation), R a constant so that the rows' loops unroll.
template <int R>
inline void BlockTimes(const double* a, const int* columns, std::size_t n, const double* x, double* out) {
  std::array<double, R> sum{};
  for (std::size_t i = 0; i < n; ++i, a += R) {
    const double v = x[columns[i]];
    for (int r = 0; r < R; ++r) sum[static_cast<std::size_t>(r)] += a[r] * v;
  }
  for (int r = 0; r < R; ++r) out[r] = sum[static_cast<std::size_t>(r)];
}

template <int R>
inline void BlockTransposeTimes(const double* a, const int* columns, std::size_t n, const double* y, double* out) {
  for (std::size_t i = 0; i < n; ++i, a += R) {
    double v = out[columns[i]];
    for (int r = 0; r < R; ++r) v += a[r] * y[r];
    out[columns[i]] = v;
  }
}

// sum[ra][rb] = sum over the first c columns of x[ra] z[rb].
template <int RA, int RB>
inline void BlockDots(const double* x, const double* z, std::size_t c, std::array<std::array<double, 6>, 6>& sum) {
  std::array<std::array<double, RB>, RA> acc{};
  for (std::size_t i = 0; i < c; ++i, x += RA, z += RB) {
    for (int ra = 0; ra < RA; ++ra) {
      for (int rb = 0; rb < RB; ++rb) {
        acc[static_cast<std::size_t>(ra)][static_cast<std::size_t>(rb)] += x[ra] * z[rb];
      }
    }
  }
  for (int ra = 0; ra < RA; ++ra) {
    for (int rb = 0; rb < RB; ++rb) {
      sum[static_cast<std::size_t>(ra)][static_cast<std::size_t>(rb)] =
          acc[static_cast<std::size_t>(ra)][static_cast<std::size_t>(rb)];
    }
  }
}

// Solves the job for some of its effectors (`ids`, indices into
// job.effectors). It writes only the bones it moves, its effectors' errors
// and, if it moves the root, the root's location, so that solvers of
// independent groups share the outputs (IkClipJob::Run fills the rest with
// the input first). iterations: one int per frame.
class Solver {
 public:
  Solver(IkClipJob& job, std::vector<int> ids, int* iterations);
  // Frames [first, last), in order. Quaternion signs run on from the output of frame first - 1 only
  // when first is 0 (else from the input: the frame before may be another thread's).
  void Run(Eigen::Index first, Eigen::Index last);
  // The bones it solves.
  std::vector<int> Bones() const;
  RowMatrixXd Jacobian(Eigen::Index f);

 private:
  enum class Kind { kTranslate, kRotate, kStretch };
  struct Column {
    Kind kind = Kind::kRotate;
    int joint = -1;      // index into joints_ (kRotate, kStretch)
    int axis = 0;        // X, Y, Z (kTranslate, kRotate)
    double scale = 1.0;  // 1 - stiffness, the stretch factor, or 1
    // How DLS's damping and regulariser weigh a unit of it: 1, or 1 / ls^2
    // for the root's translation (a move of ls counts as a turn of a radian).
    double metric = 1.0;
    int stage = 0;  // recruitment stage (IkJoint::stage)
  };
  // A solved bone.
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
    Vec3 lo = Vec3::Constant(-kInf), hi = Vec3::Constant(kInf);
    // The limits as given; lo and hi widen to the frame's input on soft axes.
    Vec3 base_lo = Vec3::Constant(-kInf), base_hi = Vec3::Constant(kInf);
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
    std::vector<double> block;   // rows x columns, column-major (i * rows + r): its rows of A
    std::vector<double> wblock;  // the same times W
    std::vector<Link> ccd;
  };
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
    double task = 0.0;   // weighted squared residuals
    double worst = 0.0;  // largest error of a target or the balance, armature units
    double pins = 0.0;   // largest pin error
    double balance = 0.0;   // how far the centre of mass is from where it may be (enforced or not)
  };

  void PlanJoints();
  void PlanEffectors();
  void PlanCcd();
  Pose MakePose() const;
  Fk MakeFk() const;

  // FK of bone b (its parent placed already).
  void Place(int b, const Pose& pose, Fk& fk) const;
  // FK of the bones the unknowns move (fixed_ is placed once a frame, by StartFrame).
  void Forward(const Pose& pose, Fk& fk) const;
  double EffectorError(int e, const Fk& fk, bool position_only) const;
  Cost Evaluate(const Fk& fk, double* residual) const;
  double RegulariserCost(const Pose& pose) const;
  // Both at once (one RotationVector per joint): writes rho, returns the cost.
  double Regulariser(const Pose& pose, double* rho) const;
  void ClampJoint(const Joint& j, Pose& pose) const;

  void BuildJacobian(const Fk& fk);
  void BuildBend();
  void MultiplyA(const double* x, double* out) const;   // out (rows) = A x
  void MultiplyAt(const double* y, double* out) const;  // out (columns) = A^T y
  void MultiplyW(const double* x, double* out) const;   // out = W x (DLS)
  void Gram(bool weighted, double diagonal);            // s_ = diagonal I + A W A^T
  bool Direction(double lambda2, double mu);            // u_ (DLS) or u0_ (the others)
  void ClampStep(double* u) const;
  void Apply(const Pose& from, const double* u, Pose& to) const;
  bool Kick(double mu, Cost& cost);
  void FindBounds() { FindBounds(current_); }
  void FindBounds(const Pose& pose);  // where the step starts: its limits' coordinates and held columns
  bool Freeze(const double* u);
  void ZeroHeldColumns();  // held columns (frozen_) drop out of every block
  Vec3 BestRotation(int count, const Vec3& pivot) const;

  void StartFrame(Eigen::Index f);
  int SolveJacobian(int budget);  // at most budget iterations
  // Runs SolveJacobian stage by stage (recruitment) until the targets are met.
  int SolveStaged();
  void StartLaterStages();  // the later stages from the last frame's corrections
  void Begin();             // a frame's solve starts: no fallback yet, the balance not yet a level
  // And ends: the posture settled (if `settle`), the pins polished (or the
  // fallback). The first pass settles once later stages have joined (their
  // null space is the large one), the second always. Within the limbs' reach
  // the first pass leaves the posture to the warm start: settled arms carried
  // on to the next frames stalled short of targets the arm alone reaches
  // (walk60's lab clip: six frames missed by 1 to 3 cm).
  int Conclude(int budget, bool settle);
  int ended_stage_ = 0;      // the stage that ended the last SolveStaged
  // The clip's second pass (natural defaults, warm-started runs): the first
  // pass's corrections, root shifts and shortfalls low-passed over time, and
  // every frame solved again from (and towards) the smoothed pose.
  void Record(Eigen::Index i);
  int SolveNear(int budget);
  void Smooth(Eigen::Index first, Eigen::Index last);
  std::vector<Quat> corrections_;
  std::vector<Vec3> root_shifts_, shortfalls_;
  std::vector<double> correction_scales_;
  std::vector<int> end_stages_;
  std::vector<Vec3> rotation_sum_, shift_sum_, aside_;  // Smooth's scratch, per joint and per effector
  std::vector<double> scale_sum_;
  // Whether a step is kept. With priorities the pins come first: while they
  // are off by more than the slack a step must bring them closer; within it,
  // it must keep them there and lower the merit, in which a pin's error weighs
  // a hundred times a target's (curvature takes a step's pins a little off;
  // the next step's level 1 and the polish bring them back).
  double PinSlack() const { return std::max(pin_tolerance_, 1e-3 * size_); }
  bool Better(double pins, double next_pins, double merit, double next_merit) const {
    if (!priorities_) return next_merit < merit;
    return pins > PinSlack() ? next_pins < pins : next_pins <= PinSlack() && next_merit < merit;
  }
  bool Unmet(const Cost& cost) const { return cost.worst > tolerance_ || cost.pins > pin_tolerance_; }
  // Strict priorities: y such that u = u0 + W A^T y meets the levels in
  // order, from s_ = A W A^T and the right-hand side in y_ (e - A u0).
  bool SolveLevels();
  // With priorities, after the loop: Gauss-Newton steps on the pins alone
  // until they are met to pin_tolerance_ (curvature leaves them a little off).
  int PolishPins(Cost& cost, int budget);
  // With the prior as a level of its own, after the loop: steps on the prior
  // alone, in the null space of the levels above, until it stops falling.
  int SettlePosture(Cost& cost, int budget);
  double settle_gain_ = 0.0;  // while settling: the prior's share of the way back a step (else kPriorGain's rule)
  // While settling, every level holds its residual where the settling found
  // it (an unreachable target's too), rather than reaching further.
  bool holding_ = false;
  std::vector<double> hold_;
  double Drift(const double* residual) const;  // squared distance of a residual from what is held
  // The last iterate that met the pins (backup_), for when the polish cannot (a limit in the way).
  void Keep(const Pose& pose);
  bool kept_ = false;
  const Pose* bounds_ = nullptr;  // the pose FindBounds measured (Freeze's scales)
  // The second-order correction of a trial step (trial_, its residual in r_,
  // its cost): pins-only steps (else steps on every level, the prior left
  // out); true if it rebuilt the Jacobian.
  bool Restore(Cost& next, bool pins_only = true);
  Fk fk_scratch_;
  std::vector<double> h_scratch_;
  bool balance_active_ = false;  // the balance has been a level on this frame (SolveLevels)
  bool pins_only_ = false;      // SolveLevels stops after level 1
  // Balance: the support polygon of the frame (StartFrame), and where the
  // centre of mass should go (false: it is inside, `margin_` from the edges).
  void FindSupport();
  double InsideDistance(const Eigen::Vector2d& p) const;  // from the hull's edges (negative: outside)
  // Balance is a level only on the last stage: the limbs and the spine never move to hold it (a hand
  // target would be traded for it); when they leave it unmet, the next stage (the hips) takes over.
  bool BalanceEnforced() const { return balance_ && stage_ == stages_ - 1; }
  bool BalanceTarget(const Vec3& com, Vec3& target) const;
  void BuildBalance(const Fk& fk);  // the centre of mass's block (BuildJacobian)
  void PlanBalance();
  int SolveCcd();
  void CcdPass(int e);
  void FinishFrame(Eigen::Index f, int iterations);

  IkClipJob& job_;
  const RigModel& rig_;
  const IkOptions& options_;
  std::vector<int> ids_;  // per effector: its index in job_.effectors
  int* iterations_ = nullptr;
  int bones_ = 0, effector_count_ = 0;
  double size_ = 1.0, lambda_ = 0.0, mu_ = 0.0, ls_ = 0.0, tolerance_ = 0.0;
  bool translate_ = false;  // bone 0's head is an unknown
  bool priorities_ = false;  // DLS with strict priority levels
  // The posture prior as a level of its own (priorities and recruitment
  // stages, as natural defaults set them), rather than DLS's regulariser.
  bool separate_prior_ = false;
  bool balance_ = false;     // the centre of mass is a level-2 task
  bool pinned_ = false;      // some effector is a pin
  double pin_tolerance_ = 0.0;
  int stages_ = 1, stage_ = 0;  // recruitment stages, and the one being solved
  Effector com_;                // balance's rows (bone -1), every column
  std::vector<double> mass_;    // per bone (balance)
  double total_mass_ = 0.0;
  std::vector<double> subtree_mass_;
  Vec3 up_ = Vec3::UnitZ(), side_ = Vec3::UnitX(), ahead_ = Vec3::UnitY();  // up, and two horizontal axes
  double margin_ = 0.0;
  double frame_margin_ = 0.0;  // this frame's: never more than the input's own (negative: outside)
  int hull_count_ = 0, inner_count_ = 0;
  std::vector<int> support_bones_;          // pinned bones and their descendants
  std::vector<Eigen::Vector2d> support_;    // scratch: the support points, then their hull
  std::vector<Eigen::Vector2d> inner_;      // the hull moved in by the frame's margin (one point when too thin)
  std::vector<Eigen::Vector2d> clip_;       // scratch for clipping it
  // Levels' scratch (SolveLevels).
  std::vector<int> level_rows_, held_rows_;
  std::vector<double> level_a_, level_x_, level_t_, level_r_;
  bool body_ = false;       // CCD may carry the body through the root

  std::vector<int> needed_;    // bones FK visits: the effectors' ancestors, parents first
  // needed_ split: bones no unknown moves (no solved bone above them, and the
  // root's location is not an unknown), the same in every pose of a frame;
  // and the rest.
  std::vector<int> fixed_, moving_;
  std::vector<int> joint_of_;  // per bone: its index in joints_, or -1
  std::vector<Joint> joints_;
  std::vector<Column> columns_;
  std::vector<Effector> effectors_;
  std::vector<int> ccd_order_;
  int rows_ = 0, cols_ = 0;

  std::vector<Vec3> target_position_;
  std::vector<Quat> target_orientation_;
  Pose input_, current_, trial_, reference_, solution_, earlier_, backup_, best_;
  Fk fk_, trial_fk_;
  Eigen::Index first_ = 0;  // the first frame of the run being solved
  bool have_solution_ = false;
  bool have_earlier_ = false;  // earlier_: the solution of the frame before solution_'s

  // Scratch, sized once.
  std::vector<double> e_, r_, y_, h_, u_, u0_, g_, w_, rho_, trial_rho_, s_;
  // W is diagonal (w_) unless DLS adds the residuals' curvature: weight_ then.
  bool full_weight_ = false;
  // Per joint: the residual curvature DLS adds (armature space, then in the
  // joint's columns), and the joint's block of W.
  std::vector<Eigen::Matrix3d> axes_, bend_world_, bend_, weight_;
  bool bend_ready_ = false;
  double bend_weight_ = 0.0;  // how much of the curvature DLS uses: 0 until a step fails
  // Unknowns held for this iteration: on a bound (a limit, a scale range)
  // that the step would push past. Per column, and each limited joint's
  // coordinates (swing x, twist, swing z) at the iteration's start.
  std::vector<char> frozen_;
  std::vector<char> staged_out_;  // per column: held this stage (recruitment)
  std::vector<Vec3> coordinates_;
  std::vector<char> met_, kick_;
  // CCD's points: the effector's own (up to three), then the pins a body link carries.
  std::vector<Vec3> ccd_points_, ccd_targets_;
  std::vector<double> ccd_weights_;
  std::vector<char> ccd_placed_;
};

}  // namespace motionkit::ik_internal
