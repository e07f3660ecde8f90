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

#include "parallel.hpp"

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

namespace motionkit {

namespace {

using Vec3 = Eigen::Vector3d;
using Quat = Eigen::Quaterniond;

constexpr double kPi = 3.14159265358979323846;
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

template <class T>
T& At(std::vector<T>& v, int i) {
  return v[static_cast<std::size_t>(i)];
}
template <class T>
const T& At(const std::vector<T>& v, int i) {
  return v[static_cast<std::size_t>(i)];
}

Vec3 Unit(int axis) { return Vec3::Unit(axis); }

// Rotation vector -> unit quaternion.
Quat Exp(const Vec3& v) {
  const double a = v.norm();
  // Both unconditionally, so that the compiler makes them one sincos call.
  const double sine = std::sin(0.5 * a), cosine = std::cos(0.5 * a);
  const double s = a < 1e-6 ? 0.5 - a * a / 48.0 : sine / a;  // sin(a/2) / a
  return Quat(cosine, s * v.x(), s * v.y(), s * v.z());
}

// Unit quaternion -> rotation vector, angle in [0, pi].
Vec3 Log(const Quat& q) {
  double w = q.w();
  Vec3 v = q.vec();
  if (w < 0) {
    w = -w;
    v = -v;
  }
  const double s = v.norm();
  if (s < 1e-9) return (2.0 / std::max(w, 1e-300)) * v;
  return (2.0 * std::atan2(s, w) / s) * v;
}

}  // namespace

Eigen::Vector3d IkSwingTwist(const Eigen::Quaterniond& q) {
  double tw = q.w(), ty = q.y();
  const double n = std::hypot(tw, ty);
  if (n > 1e-12) {
    tw /= n;
    ty /= n;
  } else {  // a half turn of swing: no twist to speak of
    tw = 1.0;
    ty = 0.0;
  }
  if (tw < 0) {
    tw = -tw;
    ty = -ty;
  }
  const Vec3 swing = Log(q * Quat(tw, 0.0, -ty, 0.0));
  return Vec3(swing.x(), 2.0 * std::atan2(ty, tw), swing.z());
}

Eigen::Quaterniond IkFromSwingTwist(const Eigen::Vector3d& angles) {
  const double h = 0.5 * angles.y();
  return (Exp(Vec3(angles.x(), 0.0, angles.z())) * Quat(std::cos(h), 0.0, std::sin(h), 0.0)).normalized();
}

namespace {

// In-place Cholesky of a symmetric n x n row-major matrix (its lower
// triangle). False when it is not numerically positive definite.
bool Cholesky(double* a, int n) {
  for (int j = 0; j < n; ++j) {
    double d = a[j * n + j];
    for (int k = 0; k < j; ++k) d -= a[j * n + k] * a[j * n + k];
    if (!(d > 0.0) || !std::isfinite(d)) return false;
    d = std::sqrt(d);
    a[j * n + j] = d;
    for (int i = j + 1; i < n; ++i) {
      double s = a[i * n + j];
      for (int k = 0; k < j; ++k) s -= a[i * n + k] * a[j * n + k];
      a[i * n + j] = s / d;
    }
  }
  return true;
}

void CholeskySolve(const double* l, int n, double* x) {
  for (int i = 0; i < n; ++i) {
    double s = x[i];
    for (int k = 0; k < i; ++k) s -= l[i * n + k] * x[k];
    x[i] = s / l[i * n + i];
  }
  for (int i = n - 1; i >= 0; --i) {
    double s = x[i];
    for (int k = i + 1; k < n; ++k) s -= l[k * n + i] * x[k];
    x[i] = s / l[i * n + i];
  }
}

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
Vec3 ClampToLimits(const Vec3& a, const Vec3& lo, const Vec3& hi) {
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

std::string FrameIndex(Eigen::Index f) { return "frame index " + std::to_string(f); }

std::string EffectorName(const IkEffector& e, std::size_t i) {
  return e.name.empty() ? "effector " + std::to_string(i) : "effector '" + e.name + "'";
}

// Kernels over an effector's column-major block (R rows: 3, or 6 with an
// orientation), R a constant so that the rows' loops unroll.
template <int R>
void BlockTimes(const double* a, const int* columns, std::size_t n, const double* x, double* out) {
  std::array<double, R> sum{};
  for (std::size_t i = 0; i < n; ++i, a += R) {
    const double v = x[columns[i]];
    for (int r = 0; r < R; ++r) sum[static_cast<std::size_t>(r)] += a[r] * v;
  }
  for (int r = 0; r < R; ++r) out[r] = sum[static_cast<std::size_t>(r)];
}

template <int R>
void BlockTransposeTimes(const double* a, const int* columns, std::size_t n, const double* y, double* out) {
  for (std::size_t i = 0; i < n; ++i, a += R) {
    double v = out[columns[i]];
    for (int r = 0; r < R; ++r) v += a[r] * y[r];
    out[columns[i]] = v;
  }
}

// sum[ra][rb] = sum over the first c columns of x[ra] z[rb].
template <int RA, int RB>
void BlockDots(const double* x, const double* z, std::size_t c, std::array<std::array<double, 6>, 6>& sum) {
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
    int bone = -1;
    int row = 0, rows = 0;
    bool position = true, orientation = false, pin = false;
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
  };
  struct Cost {
    double task = 0.0;   // weighted squared residuals
    double worst = 0.0;  // largest effector error, armature units
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
  // Both at once (one Log per joint): writes rho, returns the cost.
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
  void FindBounds();
  bool Freeze(const double* u);
  Vec3 BestRotation(int count, const Vec3& pivot) const;

  void StartFrame(Eigen::Index f);
  int SolveJacobian();
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
  std::vector<Vec3> coordinates_;
  std::vector<char> met_, kick_;
  // CCD's points: the effector's own (up to three), then the pins a body link carries.
  std::vector<Vec3> ccd_points_, ccd_targets_;
  std::vector<double> ccd_weights_;
  std::vector<char> ccd_placed_;
};

Solver::Solver(IkClipJob& job, std::vector<int> ids, int* iterations)
    : job_(job), rig_(job.rig), options_(job.options), ids_(std::move(ids)), iterations_(iterations) {
  bones_ = rig_.size();
  effector_count_ = static_cast<int>(ids_.size());
  // The rig's size: the diagonal of its rest pose's bounding box.
  Vec3 lo = Vec3::Constant(kInf), hi = Vec3::Constant(-kInf);
  for (int b = 0; b < bones_; ++b) {
    const Vec3 head = rig_.head(b), tail = head + rig_.rest(b) * (rig_.length(b) * Vec3::UnitY());
    lo = lo.cwiseMin(head).cwiseMin(tail);
    hi = hi.cwiseMax(head).cwiseMax(tail);
  }
  size_ = options_.size > 0 ? options_.size : std::max((hi - lo).norm(), 1e-300);
  lambda_ = options_.damping > 0 ? options_.damping : 1e-3 * size_;
  ls_ = options_.orientation_scale > 0 ? options_.orientation_scale : 0.1 * size_;
  mu_ = options_.regularization;
  tolerance_ = options_.tolerance;

  std::vector<char> need(static_cast<std::size_t>(bones_), 0);
  for (int id : ids_) {
    for (int b = At(job.effectors, id).bone; b >= 0; b = rig_.parent(b)) At(need, b) = 1;
  }
  for (int b = 0; b < bones_; ++b) {
    if (At(need, b)) needed_.push_back(b);
  }
  PlanJoints();
  std::vector<char> moves(static_cast<std::size_t>(bones_), 0);
  for (int b : needed_) {
    const int p = rig_.parent(b);
    At(moves, b) = At(joint_of_, b) >= 0 || (p >= 0 ? At(moves, p) : b == 0 && translate_);
    (At(moves, b) ? moving_ : fixed_).push_back(b);
  }
  PlanEffectors();
  PlanCcd();

  input_ = MakePose();
  current_ = MakePose();
  trial_ = MakePose();
  reference_ = MakePose();
  solution_ = MakePose();
  earlier_ = MakePose();
  backup_ = MakePose();
  best_ = MakePose();
  fk_ = MakeFk();
  trial_fk_ = MakeFk();
  target_position_.assign(static_cast<std::size_t>(effector_count_), Vec3::Zero());
  target_orientation_.assign(static_cast<std::size_t>(effector_count_), Quat::Identity());
  const auto rows = static_cast<std::size_t>(rows_), cols = static_cast<std::size_t>(cols_);
  for (std::vector<double>* v : {&e_, &r_, &y_, &h_}) v->assign(rows, 0.0);
  s_.assign(rows * rows, 0.0);
  for (std::vector<double>* v : {&u_, &u0_, &g_, &w_, &rho_, &trial_rho_}) v->assign(cols, 0.0);
  for (auto* v : {&axes_, &bend_world_, &bend_, &weight_}) v->assign(joints_.size(), Eigen::Matrix3d::Zero());
  met_.assign(static_cast<std::size_t>(effector_count_), 0);
  frozen_.assign(cols, 0);
  const auto points = static_cast<std::size_t>(3 + effector_count_);
  ccd_points_.assign(points, Vec3::Zero());
  ccd_targets_.assign(points, Vec3::Zero());
  ccd_weights_.assign(points, 0.0);
  ccd_placed_.assign(points, 0);
  coordinates_.assign(joints_.size(), Vec3::Zero());
  kick_.assign(joints_.size(), 0);
}

void Solver::PlanJoints() {
  const auto limits_of = [&](int b) { return job_.joints.empty() ? IkJoint{} : At(job_.joints, b); };
  joint_of_.assign(static_cast<std::size_t>(bones_), -1);
  const bool root_needed = !needed_.empty() && needed_.front() == 0;
  translate_ = options_.root_translation && root_needed && !limits_of(0).excluded;
  if (translate_) {
    for (int k = 0; k < 3; ++k) columns_.push_back({Kind::kTranslate, -1, k, 1.0, 1.0 / (ls_ * ls_)});
  }
  for (int b : needed_) {
    const IkJoint limits = limits_of(b);
    if (limits.excluded || (b == 0 && !options_.root_rotation)) continue;
    Joint j;
    j.bone = b;
    j.first_column = static_cast<int>(columns_.size());
    for (int k = 0; k < 3; ++k) {
      const bool locked = limits.locked[static_cast<std::size_t>(k)];
      j.lo[k] = locked ? 0.0 : limits.min[k];
      j.hi[k] = locked ? 0.0 : limits.max[k];
      // Swing components and the twist angle never leave [-pi, pi].
      if (j.lo[k] > -kPi || j.hi[k] < kPi) j.limited = true;
      j.free[static_cast<std::size_t>(k)] = !locked;
      if (locked) continue;
      const auto slot = static_cast<std::size_t>(j.axis_count++);
      j.axes[slot] = k;
      j.axis_scale[slot] = 1.0 - limits.stiffness[k];
      columns_.push_back({Kind::kRotate, static_cast<int>(joints_.size()), k, j.axis_scale[slot]});
    }
    if (limits.stretch > 0.0) {
      j.stretch = limits.stretch;
      j.min_scale = limits.min_scale;
      j.max_scale = limits.max_scale;
      j.stretch_column = static_cast<int>(columns_.size());
      columns_.push_back({Kind::kStretch, static_cast<int>(joints_.size()), 1, limits.stretch});
    }
    At(joint_of_, b) = static_cast<int>(joints_.size());
    joints_.push_back(j);
  }
  cols_ = static_cast<int>(columns_.size());
}

void Solver::PlanEffectors() {
  rows_ = 0;
  std::vector<int> path;
  for (int id : ids_) {
    const IkEffector& in = At(job_.effectors, id);
    Effector e;
    e.bone = in.bone;
    e.position = in.position;
    e.orientation = in.orientation;
    e.pin = in.pin;
    e.sqrt_weight = std::sqrt(in.weight);
    e.row = rows_;
    e.rows = (in.position ? 3 : 0) + (in.orientation ? 3 : 0);
    rows_ += e.rows;
    path.clear();
    for (int b = in.bone; b >= 0; b = rig_.parent(b)) path.push_back(b);
    std::reverse(path.begin(), path.end());
    if (translate_ && path.front() == 0) {
      for (int k = 0; k < 3; ++k) {
        e.segments.push_back({static_cast<int>(e.columns.size()), 1, -1});
        e.columns.push_back(k);
        e.levers.push_back(0.0);
      }
    }
    for (std::size_t i = 0; i < path.size(); ++i) {
      const int jo = At(joint_of_, path[i]);
      if (jo < 0) continue;
      const Joint& j = At(joints_, jo);
      if (j.axis_count > 0) e.segments.push_back({static_cast<int>(e.columns.size()), j.axis_count, jo});
      for (int k = 0; k < j.axis_count; ++k) {
        e.columns.push_back(j.first_column + k);
        e.levers.push_back(0.0);
      }
      if (j.stretch_column >= 0) {
        e.segments.push_back({static_cast<int>(e.columns.size()), 1, -1});
        // The effector is this bone's tail, or hangs from the head of a child
        // whose offset along the bone the scale stretches.
        e.columns.push_back(j.stretch_column);
        e.levers.push_back(i + 1 == path.size() ? rig_.length(path[i]) : rig_.offset(path[i + 1]).y());
      }
    }
    e.block.assign(static_cast<std::size_t>(e.rows) * e.columns.size(), 0.0);
    e.wblock = e.block;
    effectors_.push_back(std::move(e));
  }
  for (Effector& a : effectors_) {
    for (const Effector& b : effectors_) {
      std::size_t c = 0;
      while (c < a.columns.size() && c < b.columns.size() && a.columns[c] == b.columns[c]) ++c;
      a.prefix.push_back(static_cast<int>(c));
    }
  }
}

void Solver::PlanCcd() {
  body_ = translate_ && At(joint_of_, 0) >= 0;
  const auto lowest_common = [&](int a, int b) {
    for (int x = a; x >= 0; x = rig_.parent(x)) {
      if (rig_.IsAncestor(x, b)) return x;
    }
    return -1;
  };
  for (int ei = 0; ei < effector_count_; ++ei) {
    Effector& e = At(effectors_, ei);
    // Ordinary links from the effector's bone up to `stop` (exclusive).
    const auto ordinary = [&](int stop, bool pin) {
      int child = -1;
      for (int b = e.bone; b >= 0 && b != stop; child = b, b = rig_.parent(b)) {
        if (pin) {  // a pin's own links are the bones no other effector hangs from
          bool shared = false;
          for (int o = 0; o < effector_count_; ++o) {
            if (o != ei && rig_.IsAncestor(b, At(effectors_, o).bone)) shared = true;
          }
          if (shared) break;
        }
        const int jo = At(joint_of_, b);
        if (jo < 0) continue;
        const double lever = child < 0 ? rig_.length(b) : rig_.offset(child).y();
        e.ccd.push_back({jo, false, -1, lever});
      }
    };
    if (e.pin) {
      ordinary(-1, true);
      continue;
    }
    // Through the root towards the first pin on another branch, if the body can move.
    int anchor = -1, meet = -1;
    for (int a = 0; body_ && a < effector_count_ && anchor < 0; ++a) {
      const Effector& pin = At(effectors_, a);
      if (!pin.pin || rig_.IsAncestor(pin.bone, e.bone) || rig_.IsAncestor(e.bone, pin.bone)) continue;
      const int lca = lowest_common(pin.bone, e.bone);
      if (lca < 0) continue;
      bool any = false;
      for (int b = pin.bone; b != lca; b = rig_.parent(b)) any = any || At(joint_of_, b) >= 0;
      if (any) {
        anchor = a;
        meet = lca;
      }
    }
    ordinary(meet, false);
    if (anchor >= 0) {
      const std::size_t first = e.ccd.size();
      for (int b = At(effectors_, anchor).bone; b != meet; b = rig_.parent(b)) {
        if (At(joint_of_, b) >= 0) e.ccd.push_back({At(joint_of_, b), true, anchor, 0.0});
      }
      std::reverse(e.ccd.begin() + static_cast<std::ptrdiff_t>(first), e.ccd.end());
    }
  }
  for (int pass = 0; pass < 2; ++pass) {
    for (int e = 0; e < effector_count_; ++e) {
      if (At(effectors_, e).pin == (pass == 1)) ccd_order_.push_back(e);
    }
  }
}

Solver::Pose Solver::MakePose() const {
  Pose p;
  p.basis.assign(static_cast<std::size_t>(bones_), Quat::Identity());
  p.scale.assign(static_cast<std::size_t>(bones_), 1.0);
  return p;
}

Solver::Fk Solver::MakeFk() const {
  Fk fk;
  fk.frame.assign(static_cast<std::size_t>(bones_), Quat::Identity());
  fk.global.assign(static_cast<std::size_t>(bones_), Quat::Identity());
  fk.head.assign(static_cast<std::size_t>(bones_), Vec3::Zero());
  fk.tip.assign(static_cast<std::size_t>(effector_count_), Vec3::Zero());
  return fk;
}

void Solver::Place(int b, const Pose& pose, Fk& fk) const {
  const int p = rig_.parent(b);
  if (p < 0) {
    At(fk.frame, b) = rig_.relative(b);
    At(fk.head, b) = b == 0 ? pose.root : rig_.offset(b);
  } else {
    const Quat& gp = At(fk.global, p);
    At(fk.frame, b) = gp * rig_.relative(b);
    Vec3 offset = rig_.offset(b);
    offset.y() *= At(pose.scale, p);
    At(fk.head, b) = At(fk.head, p) + gp * offset;
  }
  At(fk.global, b) = At(fk.frame, b) * At(pose.basis, b);
}

void Solver::Forward(const Pose& pose, Fk& fk) const {
  for (int b : moving_) Place(b, pose, fk);
  for (int e = 0; e < effector_count_; ++e) {
    const int b = At(effectors_, e).bone;
    At(fk.tip, e) = At(fk.head, b) + At(fk.global, b) * Vec3(0.0, At(pose.scale, b) * rig_.length(b), 0.0);
  }
}

double Solver::EffectorError(int e, const Fk& fk, bool position_only) const {
  const Effector& ef = At(effectors_, e);
  double error = 0.0;
  if (ef.position) error = (At(target_position_, e) - At(fk.tip, e)).norm();
  if (ef.orientation && !(position_only && ef.position)) {
    const double angle = Log(At(target_orientation_, e) * At(fk.global, ef.bone).conjugate()).norm();
    error = std::max(error, ls_ * angle);
  }
  return error;
}

Solver::Cost Solver::Evaluate(const Fk& fk, double* residual) const {
  Cost cost;
  for (int e = 0; e < effector_count_; ++e) {
    const Effector& ef = At(effectors_, e);
    double* r = residual + ef.row;
    double position = 0.0, orientation = 0.0;
    if (ef.position) {
      const Vec3 d = At(target_position_, e) - At(fk.tip, e);
      position = d.norm();
      Eigen::Map<Vec3> out(r);
      out = ef.sqrt_weight * d;
      r += 3;
    }
    if (ef.orientation) {
      const Vec3 w = Log(At(target_orientation_, e) * At(fk.global, ef.bone).conjugate());
      orientation = ls_ * w.norm();
      Eigen::Map<Vec3> out(r);
      out = (ef.sqrt_weight * ls_) * w;
    }
    const double weighted = ef.sqrt_weight * ef.sqrt_weight;
    cost.task += weighted * (position * position + orientation * orientation);
    cost.worst = std::max({cost.worst, position, orientation});
  }
  if (!std::isfinite(cost.task)) cost.worst = kInf;
  return cost;
}

// Where each unknown stands from the reference, in its column's units (rho),
// and the regulariser's cost.
double Solver::Regulariser(const Pose& pose, double* rho) const {
  double sum = 0.0;
  if (translate_) {
    const Vec3 d = pose.root - reference_.root;
    for (int k = 0; k < 3; ++k) rho[k] = d[k];
    sum += d.squaredNorm() / (ls_ * ls_);
  }
  for (const Joint& j : joints_) {
    if (j.axis_count > 0) {
      const Vec3 d = Log(At(pose.basis, j.bone) * At(reference_.basis, j.bone).conjugate());
      for (int k = 0; k < j.axis_count; ++k) {
        const double v = d[j.axes[static_cast<std::size_t>(k)]];
        rho[j.first_column + k] = v;
        sum += v * v;
      }
    }
    if (j.stretch_column >= 0) {
      const double d = At(pose.scale, j.bone) - At(reference_.scale, j.bone);
      rho[j.stretch_column] = d;
      sum += d * d;
    }
  }
  return sum;
}

double Solver::RegulariserCost(const Pose& pose) const {
  double sum = 0.0;
  if (translate_) sum += (pose.root - reference_.root).squaredNorm() / (ls_ * ls_);
  for (const Joint& j : joints_) {
    if (j.axis_count > 0) {
      const Vec3 d = Log(At(pose.basis, j.bone) * At(reference_.basis, j.bone).conjugate());
      for (int k = 0; k < j.axis_count; ++k) sum += d[j.axes[static_cast<std::size_t>(k)]] * d[j.axes[static_cast<std::size_t>(k)]];
    }
    if (j.stretch_column >= 0) {
      const double d = At(pose.scale, j.bone) - At(reference_.scale, j.bone);
      sum += d * d;
    }
  }
  return sum;
}

void Solver::ClampJoint(const Joint& j, Pose& pose) const {
  if (j.stretch_column >= 0) At(pose.scale, j.bone) = std::clamp(At(pose.scale, j.bone), j.min_scale, j.max_scale);
  if (!j.limited) return;
  Quat& q = At(pose.basis, j.bone);
  const Vec3 a = IkSwingTwist(q);
  const Vec3 c = ClampToLimits(a, j.lo, j.hi);
  if (c != a) q = IkFromSwingTwist(c);
}

// The part of -r . d2p/dtheta_k dtheta_l (rotations about axes k, l through
// a joint, v from the joint to the effector, r the effector's residual) that
// is positive semi-definite: (r.v) I - sym(r v^T) less its negative
// eigenvalues, 1/2 (r.v - |r||v|) along r^ + v^ and r.v across both.
Eigen::Matrix3d PositiveBend(const Vec3& r, const Vec3& v) {
  const double rv = r.dot(v), nr = r.norm(), nv = v.norm();
  if (!(nr * nv > 0.0)) return Eigen::Matrix3d::Zero();
  Eigen::Matrix3d s = rv * Eigen::Matrix3d::Identity() - 0.5 * (r * v.transpose() + v * r.transpose());
  Vec3 plus = r / nr + v / nv;
  const double np = plus.norm();
  if (np < 1e-9) return Eigen::Matrix3d::Zero();  // opposite: nothing positive
  plus /= np;
  s -= (0.5 * (rv - nr * nv)) * plus * plus.transpose();
  if (rv < 0.0) {
    Vec3 across = r.cross(v);
    const double na = across.norm();
    if (na > 0.0) {
      across /= na;
      s -= rv * across * across.transpose();
    }
  }
  return s;
}

void Solver::BuildJacobian(const Fk& fk) {
  for (std::size_t jo = 0; jo < joints_.size(); ++jo) axes_[jo] = At(fk.frame, joints_[jo].bone).toRotationMatrix();
  bend_ready_ = false;
  for (int ei = 0; ei < effector_count_; ++ei) {
    Effector& e = At(effectors_, ei);
    const Vec3& tip = At(fk.tip, ei);
    const auto rows = static_cast<std::size_t>(e.rows);
    const std::size_t ori = e.position ? 3 : 0;  // the orientation rows' offset in a column
    const double sw = e.sqrt_weight;
    const auto store = [&](std::size_t i, const Vec3& dp, const Vec3& dr) {
      double* out = e.block.data() + i * rows;
      if (e.position) {
        for (int k = 0; k < 3; ++k) out[k] = sw * dp[k];
      }
      if (e.orientation) {
        for (int k = 0; k < 3; ++k) out[ori + static_cast<std::size_t>(k)] = sw * dr[k];
      }
    };
    for (const Segment& sg : e.segments) {
      const auto at = static_cast<std::size_t>(sg.start);
      if (sg.joint < 0) {  // the root's translation, or a stretch column
        const Column& c = columns_[static_cast<std::size_t>(e.columns[at])];
        Vec3 dp = Vec3::Zero();
        if (c.kind == Kind::kTranslate) {
          dp[c.axis] = 1.0;  // the root's head moves every effector below it one to one
        } else {
          const Joint& j = At(joints_, c.joint);
          dp = (c.scale * e.levers[at]) * (At(fk.global, j.bone) * Vec3::UnitY());
        }
        store(at, dp, Vec3::Zero());
        continue;
      }
      const Vec3 lever = tip - At(fk.head, At(joints_, sg.joint).bone);
      const Eigen::Matrix3d& axes = At(axes_, sg.joint);
      for (int k = 0; k < sg.count; ++k) {
        const std::size_t i = at + static_cast<std::size_t>(k);
        const Column& c = columns_[static_cast<std::size_t>(e.columns[i])];
        const Vec3 a = axes.col(c.axis);
        store(i, c.scale * a.cross(lever), (c.scale * ls_) * a);
      }
    }
  }
}

// The residuals' curvature per joint (DLS), at the pose the Jacobian was
// built at (fk_): summed over the effectors below the joint in armature
// space, then C = (A D)^T S (A D) in the joint's columns, A its free axes.
void Solver::BuildBend() {
  std::fill(bend_world_.begin(), bend_world_.end(), Eigen::Matrix3d::Zero());
  for (int ei = 0; ei < effector_count_; ++ei) {
    const Effector& e = At(effectors_, ei);
    if (!e.position) continue;
    const Vec3& tip = At(fk_.tip, ei);
    const Vec3 residual = At(target_position_, ei) - tip;
    const double weight = e.sqrt_weight * e.sqrt_weight;
    for (const Segment& sg : e.segments) {
      if (sg.joint < 0) continue;
      At(bend_world_, sg.joint) += weight * PositiveBend(residual, tip - At(fk_.head, At(joints_, sg.joint).bone));
    }
  }
  for (std::size_t jo = 0; jo < joints_.size(); ++jo) {
    const Joint& j = joints_[jo];
    Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
    for (int k = 0; k < j.axis_count; ++k) {
      const auto slot = static_cast<std::size_t>(k);
      a.col(k) = j.axis_scale[slot] * axes_[jo].col(j.axes[slot]);
    }
    bend_[jo] = a.transpose() * bend_world_[jo] * a;
  }
  bend_ready_ = true;
}

void Solver::MultiplyA(const double* x, double* out) const {
  for (const Effector& e : effectors_) {
    const std::size_t n = e.columns.size();
    if (e.rows == 3) {
      BlockTimes<3>(e.block.data(), e.columns.data(), n, x, out + e.row);
    } else {
      BlockTimes<6>(e.block.data(), e.columns.data(), n, x, out + e.row);
    }
  }
}

void Solver::MultiplyW(const double* x, double* out) const {
  for (int j = 0; j < cols_; ++j) out[j] = At(w_, j) * x[j];
  if (!full_weight_) return;
  for (std::size_t jo = 0; jo < joints_.size(); ++jo) {
    const Joint& j = joints_[jo];
    const double* in = x + j.first_column;
    for (int k = 0; k < j.axis_count; ++k) {
      double sum = 0.0;
      for (int l = 0; l < j.axis_count; ++l) sum += weight_[jo](k, l) * in[l];
      out[j.first_column + k] = sum;
    }
  }
}

void Solver::MultiplyAt(const double* y, double* out) const {
  std::fill(out, out + cols_, 0.0);
  for (const Effector& e : effectors_) {
    const std::size_t n = e.columns.size();
    if (e.rows == 3) {
      BlockTransposeTimes<3>(e.block.data(), e.columns.data(), n, y + e.row, out);
    } else {
      BlockTransposeTimes<6>(e.block.data(), e.columns.data(), n, y + e.row, out);
    }
  }
}

void Solver::Gram(bool weighted, double diagonal) {
  const int m = rows_;
  for (int a = 0; a < effector_count_; ++a) {
    const Effector& ea = At(effectors_, a);
    const double* left = weighted ? ea.wblock.data() : ea.block.data();
    const auto ra_count = static_cast<std::size_t>(ea.rows);
    for (int b = a; b < effector_count_; ++b) {
      const Effector& eb = At(effectors_, b);
      const auto rb_count = static_cast<std::size_t>(eb.rows);
      const auto c = static_cast<std::size_t>(At(ea.prefix, b));
      // Over the shared leading columns: sum[ra][rb] += x[ra] z[rb].
      std::array<std::array<double, 6>, 6> sum;
      const double* z = eb.block.data();
      if (ra_count == 3) {
        if (rb_count == 3) BlockDots<3, 3>(left, z, c, sum);
        else BlockDots<3, 6>(left, z, c, sum);
      } else {
        if (rb_count == 3) BlockDots<6, 3>(left, z, c, sum);
        else BlockDots<6, 6>(left, z, c, sum);
      }
      for (std::size_t ra = 0; ra < ra_count; ++ra) {
        for (std::size_t rb = (a == b ? ra : 0); rb < rb_count; ++rb) {
          double s = sum[ra][rb];
          const int i0 = ea.row + static_cast<int>(ra), i1 = eb.row + static_cast<int>(rb);
          if (i0 == i1) s += diagonal;
          s_[static_cast<std::size_t>(i0 * m + i1)] = s;
          s_[static_cast<std::size_t>(i1 * m + i0)] = s;
        }
      }
    }
  }
}

bool Solver::Direction(double lambda2, double mu) {
  switch (options_.method) {
    case IkMethod::kDls: {
      // min |A u - e|^2 + lambda^2 |u|_G^2 + mu |rho + D u|_G^2 + u^T C u (G
      // the columns' metric: 1, or 1 / ls^2 for the root's move): with
      // M = (lambda^2 + mu D^2) G + C (block diagonal: 3 x 3 per joint) and
      // W = M^-1, u = W b + W A^T (I + A W A^T)^-1 (e - A W b),
      // b = -mu D rho (Woodbury): an effector-space system. C is the
      // residual's curvature at each joint that Gauss-Newton leaves out
      // (BuildJacobian): it stops a chain reaching for an unreachable target
      // from overshooting, so lambda need not grow to do it.
      if (bend_weight_ > 0.0 && !bend_ready_) BuildBend();
      for (int j = 0; j < cols_; ++j) {
        const Column& c = columns_[static_cast<std::size_t>(j)];
        const double d = c.scale;
        const bool held = At(frozen_, j);
        At(w_, j) = held ? 0.0 : 1.0 / ((lambda2 + mu * d * d) * c.metric);
        At(g_, j) = mu > 0.0 && !held ? -mu * d * c.metric * At(rho_, j) : 0.0;  // b
      }
      // Without the curvature M is diagonal, and W is w_ (a held column's 0).
      full_weight_ = bend_weight_ > 0.0;
      for (std::size_t jo = 0; full_weight_ && jo < joints_.size(); ++jo) {
        const Joint& j = joints_[jo];
        if (j.axis_count == 0) continue;
        Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
        for (int k = 0; k < j.axis_count; ++k) {
          if (At(frozen_, j.first_column + k)) continue;
          for (int l = 0; l < j.axis_count; ++l) {
            const bool bend = bend_weight_ > 0.0 && !At(frozen_, j.first_column + l);
            m(k, l) = bend ? bend_weight_ * bend_[jo](k, l) : 0.0;
          }
          const double d = j.axis_scale[static_cast<std::size_t>(k)];
          m(k, k) += lambda2 + mu * d * d;
        }
        weight_[jo] = m.inverse();
        for (int k = 0; k < j.axis_count; ++k) {
          if (!At(frozen_, j.first_column + k)) continue;
          weight_[jo].row(k).setZero();
          weight_[jo].col(k).setZero();
        }
      }
      MultiplyW(g_.data(), u0_.data());  // u0 = W b
      MultiplyA(u0_.data(), h_.data());
      for (int i = 0; i < rows_; ++i) At(y_, i) = At(e_, i) - At(h_, i);
      for (Effector& e : effectors_) {
        const std::size_t n = e.columns.size();
        const auto rows = static_cast<std::size_t>(e.rows);
        if (!full_weight_) {
          for (std::size_t i = 0; i < n; ++i) {
            const double w = At(w_, e.columns[i]);
            for (std::size_t r = 0; r < rows; ++r) e.wblock[i * rows + r] = e.block[i * rows + r] * w;
          }
          continue;
        }
        for (std::size_t r = 0; r < rows; ++r) {
          const double* in = e.block.data() + r;
          double* out = e.wblock.data() + r;
          for (const Segment& sg : e.segments) {
            const auto at = static_cast<std::size_t>(sg.start);
            if (sg.joint < 0) {
              out[at * rows] = in[at * rows] * At(w_, e.columns[at]);
              continue;
            }
            const Eigen::Matrix3d& w = At(weight_, sg.joint);
            for (int k = 0; k < sg.count; ++k) {
              double sum = 0.0;
              for (int l = 0; l < sg.count; ++l) sum += in[(at + static_cast<std::size_t>(l)) * rows] * w(l, k);
              out[(at + static_cast<std::size_t>(k)) * rows] = sum;
            }
          }
        }
      }
      Gram(true, 1.0);
      if (!Cholesky(s_.data(), rows_)) return false;
      CholeskySolve(s_.data(), rows_, y_.data());
      MultiplyAt(y_.data(), g_.data());
      MultiplyW(g_.data(), u_.data());
      for (int j = 0; j < cols_; ++j) At(u_, j) += At(u0_, j);
      for (double v : u_) {
        if (!std::isfinite(v)) return false;
      }
      return true;
    }
    case IkMethod::kPseudoInverse: {
      // u = A^T (A A^T + eps I)^-1 e.
      Gram(false, lambda2);
      if (!Cholesky(s_.data(), rows_)) return false;
      std::copy(e_.begin(), e_.end(), y_.begin());
      CholeskySolve(s_.data(), rows_, y_.data());
      MultiplyAt(y_.data(), u_.data());
      for (double v : u_) {
        if (!std::isfinite(v)) return false;
      }
      return true;
    }
    case IkMethod::kTranspose: {
      // u = alpha A^T e, alpha = <e, A A^T e> / |A A^T e|^2 (Buss).
      MultiplyAt(e_.data(), u0_.data());
      MultiplyA(u0_.data(), h_.data());
      double num = 0.0, den = 0.0;
      for (int i = 0; i < rows_; ++i) {
        num += At(e_, i) * At(h_, i);
        den += At(h_, i) * At(h_, i);
      }
      if (!(den > 0.0)) return false;
      for (double& v : u0_) v *= num / den;
      break;
    }
    case IkMethod::kCcd:
      return false;
  }
  for (double v : u0_) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

// Scales the step so that no joint turns more than max_step radians, no scale
// changes more than max_step and the root moves at most max_step * ls.
void Solver::ClampStep(double* u) const {
  double largest = 0.0;
  if (translate_) largest = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) / ls_;
  for (const Joint& j : joints_) {
    double sum = 0.0;
    for (int k = 0; k < j.axis_count; ++k) {
      const double v = j.axis_scale[static_cast<std::size_t>(k)] * u[j.first_column + k];
      sum += v * v;
    }
    largest = std::max(largest, std::sqrt(sum));
    if (j.stretch_column >= 0) largest = std::max(largest, std::abs(j.stretch * u[j.stretch_column]));
  }
  if (largest > options_.max_step) {
    const double f = options_.max_step / largest;
    for (int i = 0; i < cols_; ++i) u[i] *= f;
  }
}

void Solver::Apply(const Pose& from, const double* u, Pose& to) const {
  if (translate_) to.root = from.root + Vec3(u[0], u[1], u[2]);
  for (const Joint& j : joints_) {
    const int b = j.bone;
    if (j.axis_count > 0) {
      Vec3 delta = Vec3::Zero();
      for (int k = 0; k < j.axis_count; ++k) {
        const auto slot = static_cast<std::size_t>(k);
        delta[j.axes[slot]] = j.axis_scale[slot] * u[j.first_column + k];
      }
      At(to.basis, b) = (Exp(delta) * At(from.basis, b)).normalized();
    } else {
      At(to.basis, b) = At(from.basis, b);
    }
    if (j.stretch_column >= 0) At(to.scale, b) = At(from.scale, b) + j.stretch * u[j.stretch_column];
    ClampJoint(j, to);
  }
}

// Where each limited joint stands in its limits' coordinates, at the
// iteration's start; nothing is held yet.
void Solver::FindBounds() {
  std::fill(frozen_.begin(), frozen_.end(), 0);
  for (std::size_t jo = 0; jo < joints_.size(); ++jo) {
    if (joints_[jo].limited) coordinates_[jo] = IkSwingTwist(At(current_.basis, joints_[jo].bone));
  }
}

// Holds the unknowns that sit on a bound the step `u` would push them past
// (their columns drop out of the Jacobian for this iteration), so that the
// rest of the step is solved for what can move instead of being clamped
// afterwards. A rotation column stands for its own coordinate (X and Z for
// the swing, Y for the twist), to first order. True if any was newly held.
bool Solver::Freeze(const double* u) {
  bool any = false;
  const auto hold = [&](int column) {
    if (At(frozen_, column)) return;
    At(frozen_, column) = 1;
    any = true;
  };
  for (std::size_t jo = 0; jo < joints_.size(); ++jo) {
    const Joint& j = joints_[jo];
    if (j.stretch_column >= 0) {
      const double s = At(current_.scale, j.bone), du = u[j.stretch_column];
      if ((du > 0.0 && s >= j.max_scale) || (du < 0.0 && s <= j.min_scale)) hold(j.stretch_column);
    }
    if (!j.limited) continue;
    const Vec3& a = coordinates_[jo];
    for (int k = 0; k < j.axis_count; ++k) {
      const int axis = j.axes[static_cast<std::size_t>(k)], column = j.first_column + k;
      const double du = u[column];
      if ((du > 0.0 && a[axis] >= j.hi[axis] - 1e-9) || (du < 0.0 && a[axis] <= j.lo[axis] + 1e-9)) hold(column);
    }
  }
  if (!any) return false;
  for (Effector& e : effectors_) {
    const std::size_t n = e.columns.size();
    for (std::size_t i = 0; i < n; ++i) {
      if (!At(frozen_, e.columns[i])) continue;
      for (int r = 0; r < e.rows; ++r) e.block[i * static_cast<std::size_t>(e.rows) + static_cast<std::size_t>(r)] = 0.0;
    }
  }
  return true;
}

// A stationary point that is not a solution (a straight chain asked to fold,
// a target straight behind): bend the joints that only serve unmet effectors
// a little about their first free swing axis, one way then the other, and
// keep the bend if it helps. Deterministic.
bool Solver::Kick(double mu, Cost& cost) {
  if (joints_.empty() || rows_ == 0) return false;
  for (int e = 0; e < effector_count_; ++e) At(met_, e) = EffectorError(e, fk_, false) <= tolerance_;
  bool any = false;
  for (int pass = 0; pass < 2 && !any; ++pass) {
    for (std::size_t j = 0; j < joints_.size(); ++j) {
      bool unmet = false, met = false;
      for (int e = 0; e < effector_count_; ++e) {
        if (!rig_.IsAncestor(joints_[j].bone, At(effectors_, e).bone)) continue;
        (At(met_, e) ? met : unmet) = true;
      }
      kick_[j] = unmet && (pass == 1 || !met) && joints_[j].axis_count > 0;
      any = any || kick_[j];
    }
  }
  if (!any) return false;
  // Every kicked joint about its first free swing axis (X, else Z, else Y),
  // less what moves any effector to first order (the projection onto the
  // Jacobian's null space): what is left bends the chain without moving the
  // effectors except through the curvature that the stationary point hides.
  std::fill(u0_.begin(), u0_.end(), 0.0);
  for (std::size_t jo = 0; jo < joints_.size(); ++jo) {
    if (!kick_[jo]) continue;
    const Joint& j = joints_[jo];
    const int axis = j.free[0] ? 0 : j.free[2] ? 2 : 1;
    for (int k = 0; k < j.axis_count; ++k) {
      if (j.axes[static_cast<std::size_t>(k)] == axis) At(u0_, j.first_column + k) = 1.0;
    }
  }
  BuildJacobian(fk_);
  Gram(false, 0.0);
  double trace = 0.0;
  for (int i = 0; i < rows_; ++i) trace += s_[static_cast<std::size_t>(i * rows_ + i)];
  Gram(false, 1e-9 * trace / rows_ + 1e-300);
  if (Cholesky(s_.data(), rows_)) {
    MultiplyA(u0_.data(), y_.data());
    CholeskySolve(s_.data(), rows_, y_.data());
    MultiplyAt(y_.data(), g_.data());
    double left = 0.0;
    for (int j = 0; j < cols_; ++j) left = std::max(left, std::abs(At(u0_, j) - At(g_, j)));
    if (left > 1e-3) {  // else the kick lies in the Jacobian's range: keep it as it is
      for (int j = 0; j < cols_; ++j) At(u0_, j) -= At(g_, j);
    }
  }
  double largest = 0.0;
  for (const Joint& j : joints_) {
    double sum = 0.0;
    for (int k = 0; k < j.axis_count; ++k) {
      const double v = j.axis_scale[static_cast<std::size_t>(k)] * At(u0_, j.first_column + k);
      sum += v * v;
    }
    largest = std::max(largest, std::sqrt(sum));
  }
  if (!(largest > 0.0) || !std::isfinite(largest)) return false;
  const double angle = std::min(0.05, options_.max_step);
  const double merit = cost.task + (mu > 0.0 ? mu * RegulariserCost(current_) : 0.0);
  for (const double sign : {1.0, -1.0}) {
    for (int j = 0; j < cols_; ++j) At(u_, j) = sign * angle / largest * At(u0_, j);
    Apply(current_, u_.data(), trial_);
    Forward(trial_, trial_fk_);
    const Cost next = Evaluate(trial_fk_, r_.data());
    const double next_merit = next.task + (mu > 0.0 ? mu * RegulariserCost(trial_) : 0.0);
    if (std::isfinite(next_merit) && next_merit < merit) {
      std::swap(current_, trial_);
      std::swap(fk_, trial_fk_);
      std::swap(e_, r_);
      cost = next;
      return true;
    }
  }
  return false;
}

void Solver::StartFrame(Eigen::Index f) {
  const Eigen::Index rot_row = job_.input_rotations.rows() == 1 ? 0 : f;
  const Eigen::Index loc_row = job_.input_locations.rows() == 1 ? 0 : f;
  for (int b : needed_) {
    At(input_.basis, b) = QuatAt(job_.input_rotations, rot_row, b).normalized();
    At(input_.scale, b) = 1.0;
  }
  if (bones_ > 0) {
    input_.root = rig_.offset(0) + rig_.relative(0) * job_.input_locations.row(loc_row).transpose();
  }
  // Every pose of the frame has the input's basis, scale and root on these.
  for (int b : fixed_) {
    Place(b, input_, fk_);
    At(trial_fk_.frame, b) = At(fk_.frame, b);
    At(trial_fk_.global, b) = At(fk_.global, b);
    At(trial_fk_.head, b) = At(fk_.head, b);
  }
  // Pins hold where this frame's input pose has them.
  bool pins = false;
  for (const Effector& e : effectors_) pins = pins || e.pin;
  if (pins) Forward(input_, fk_);
  for (int e = 0; e < effector_count_; ++e) {
    const Effector& ef = At(effectors_, e);
    if (ef.pin) {
      At(target_position_, e) = At(fk_.tip, e);
      At(target_orientation_, e) = At(fk_.global, ef.bone);
      continue;
    }
    const int id = At(ids_, e);
    if (ef.position) At(target_position_, e) = job_.target_positions.row(f).segment<3>(3 * id).transpose();
    if (ef.orientation) {
      const double* q = job_.target_orientations.data() + f * job_.target_orientations.outerStride() + 4 * id;
      At(target_orientation_, e) = Quat(q[0], q[1], q[2], q[3]).normalized();
    }
  }
  const bool warm = options_.warm_start && have_solution_;
  for (int b : needed_) {
    At(current_.basis, b) = At(input_.basis, b);
    At(current_.scale, b) = 1.0;
  }
  current_.root = warm && translate_ ? solution_.root : input_.root;
  const bool previous = options_.reference == IkReference::kPrevious && have_solution_;
  reference_.root = previous ? solution_.root : input_.root;
  for (const Joint& j : joints_) {
    if (warm) {
      At(current_.basis, j.bone) = At(solution_.basis, j.bone);
      At(current_.scale, j.bone) = At(solution_.scale, j.bone);
    }
    ClampJoint(j, current_);
    At(reference_.basis, j.bone) = previous ? At(solution_.basis, j.bone) : At(input_.basis, j.bone);
    At(reference_.scale, j.bone) = previous ? At(solution_.scale, j.bone) : 1.0;
  }
  trial_ = current_;
  // Targets that move smoothly move the solution smoothly: carried on as the
  // last two frames' solutions went, the start is often close enough for one
  // step to meet the tolerance (from the last solution alone, two). Kept
  // only when it starts nearer the targets.
  if (warm && have_earlier_ && !joints_.empty()) {
    for (const Joint& j : joints_) {
      const Quat& last = At(solution_.basis, j.bone);
      At(trial_.basis, j.bone) = (last * (At(earlier_.basis, j.bone).conjugate() * last)).normalized();
      At(trial_.scale, j.bone) = 2.0 * At(solution_.scale, j.bone) - At(earlier_.scale, j.bone);
      ClampJoint(j, trial_);
    }
    if (translate_) trial_.root = 2.0 * solution_.root - earlier_.root;
    Forward(current_, fk_);
    Forward(trial_, trial_fk_);
    if (Evaluate(trial_fk_, r_.data()).task < Evaluate(fk_, e_.data()).task) {
      std::swap(current_, trial_);
    }
    trial_ = current_;
  }
}

int Solver::SolveJacobian() {
  Forward(current_, fk_);
  Cost cost = Evaluate(fk_, e_.data());
  const IkMethod method = options_.method;
  const bool dls = method == IkMethod::kDls, damped = method != IkMethod::kTranspose;
  const int limit = options_.max_iterations;
  int it = 0, kicks = 0;
  double damp2 = 0.0, nu = 2.0;  // the damping term (lambda^2, or the pseudo-inverse's eps) and its growth
  bend_weight_ = 0.0;
  // The regulariser's residual and cost at current_, kept from the accepted
  // trial that produced it.
  bool have_rho = false;
  double regulariser = 0.0, trial_regulariser = 0.0;
  while (cost.worst > tolerance_ && it < limit) {
    // The regulariser steers while the targets are far and fades as they are
    // met, so that a reachable target is reached rather than traded for it.
    const double fade = std::min(1.0, cost.worst / (1e-2 * size_));
    const double mu = dls ? mu_ * fade * fade : 0.0;
    if (mu > 0.0 && !have_rho) {
      regulariser = Regulariser(current_, rho_.data());
      have_rho = true;
    }
    const double merit = cost.task + (mu > 0.0 ? mu * regulariser : 0.0);
    BuildJacobian(fk_);
    double floor2 = lambda_ * lambda_;
    if (method == IkMethod::kPseudoInverse) {  // eps ~ 1e-12 of the system's scale
      double trace = 0.0;
      for (const Effector& e : effectors_) {
        for (double v : e.block) trace += v * v;
      }
      floor2 = 1e-12 * trace / std::max(rows_, 1) + 1e-300;
    }
    damp2 = std::max(damp2, floor2);
    FindBounds();
    bool have_direction = false, accepted = false, stalled = false, broken = false;
    double fraction = 1.0, next_merit = 0.0;
    Cost next;
    while (it < limit) {
      ++it;
      if (!damped) {
        if (!have_direction) {
          bool ok = Direction(0.0, 0.0);
          while (ok && Freeze(u0_.data())) ok = Direction(0.0, 0.0);
          if (!ok) {
            stalled = true;
            break;
          }
        }
        have_direction = true;
        for (int j = 0; j < cols_; ++j) At(u_, j) = fraction * At(u0_, j);
      } else {
        bool ok = Direction(damp2, mu);
        while (ok && Freeze(u_.data())) ok = Direction(damp2, mu);
        if (!ok) {
          damp2 *= nu;
          nu *= 2.0;
          if (damp2 > 1e30 * floor2) {
            stalled = true;
            break;
          }
          continue;
        }
      }
      double largest = 0.0;
      for (double v : u_) largest = std::max(largest, std::abs(v));
      if (!(largest > 1e-14)) {
        stalled = true;
        break;
      }
      ClampStep(u_.data());
      // What the linear model promises, for the damping's update.
      double predicted = 0.0;
      if (damped) {
        MultiplyA(u_.data(), h_.data());
        double model = 0.0;
        for (int i = 0; i < rows_; ++i) model += (At(e_, i) - At(h_, i)) * (At(e_, i) - At(h_, i));
        if (mu > 0.0) {
          for (int j = 0; j < cols_; ++j) {
            const Column& c = columns_[static_cast<std::size_t>(j)];
            const double v = At(rho_, j) + c.scale * At(u_, j);
            model += mu * c.metric * v * v;
          }
        }
        if (dls && bend_weight_ > 0.0) {
          for (std::size_t jo = 0; jo < joints_.size(); ++jo) {
            const Joint& j = joints_[jo];
            for (int k = 0; k < j.axis_count; ++k) {
              for (int l = 0; l < j.axis_count; ++l) {
                model += bend_weight_ * At(u_, j.first_column + k) * bend_[jo](k, l) * At(u_, j.first_column + l);
              }
            }
          }
        }
        predicted = merit - model;
      }
      Apply(current_, u_.data(), trial_);
      Forward(trial_, trial_fk_);
      next = Evaluate(trial_fk_, r_.data());
      if (mu > 0.0) trial_regulariser = Regulariser(trial_, trial_rho_.data());
      next_merit = next.task + (mu > 0.0 ? mu * trial_regulariser : 0.0);
      if (!std::isfinite(next_merit)) {
        broken = true;
        break;
      }
      if (next_merit < merit) {
        accepted = true;
        if (damped) {  // Nielsen's update
          const double gain = predicted > 0.0 ? (merit - next_merit) / predicted : 1.0;
          const double t = 2.0 * gain - 1.0;
          damp2 = std::max(floor2, damp2 * std::max(1.0 / 3.0, 1.0 - t * t * t));
          nu = 2.0;
          if (gain > 0.75) bend_weight_ = bend_weight_ > 0.1 ? 0.5 * bend_weight_ : 0.0;
        }
        break;
      }
      if (dls && bend_weight_ < 1.0) {
        bend_weight_ = 1.0;  // first let the curvature the linear model left out hold the step back
      } else if (damped) {
        damp2 *= nu;
        nu *= 2.0;
        if (damp2 > 1e30 * floor2) {
          stalled = true;
          break;
        }
      } else {
        fraction *= 0.5;
        if (fraction < 1e-8) {
          stalled = true;
          break;
        }
      }
    }
    if (broken) break;  // keep the previous iterate
    if (accepted) {
      std::swap(current_, trial_);
      std::swap(fk_, trial_fk_);
      std::swap(e_, r_);
      cost = next;
      if (mu > 0.0) {
        std::swap(rho_, trial_rho_);
        regulariser = trial_regulariser;
      }
      have_rho = mu > 0.0;
      // A minimum that does not meet the targets: the cost no longer falls.
      if (merit - next_merit <= (dls ? kStationary : kCreeping) * merit) break;
      continue;
    }
    if (stalled && kicks < 2 && it < limit) {
      ++it;
      ++kicks;
      if (Kick(mu, cost)) {
        have_rho = false;
        damp2 = 0.0;
        nu = 2.0;
        bend_weight_ = 0.0;
        continue;
      }
    }
    break;
  }
  return it;
}

// The rotation about `pivot` that best takes the first `count` CCD points
// onto their targets (weighted; directions turn about nothing): the shortest
// arc for one point, Kabsch for more.
Vec3 Solver::BestRotation(int count, const Vec3& pivot) const {
  const auto offset = [&](const std::vector<Vec3>& v, std::size_t i) {
    return ccd_placed_[i] ? Vec3(v[i] - pivot) : v[i];
  };
  const double tiny = 1e-12 * size_;
  if (count == 1) {
    const Vec3 v = offset(ccd_points_, 0), u = offset(ccd_targets_, 0);
    if (v.norm() < tiny || u.norm() < tiny) return Vec3::Zero();
    const Vec3 axis = v.cross(u);
    const double s = axis.norm(), c = v.dot(u);
    if (s > 1e-14 * v.norm() * u.norm()) return axis * (std::atan2(s, c) / s);
    if (c < 0.0) return kPi * v.unitOrthogonal();
    return Vec3::Zero();
  }
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (int i = 0; i < count; ++i) {
    const auto k = static_cast<std::size_t>(i);
    h += ccd_weights_[k] * offset(ccd_points_, k) * offset(ccd_targets_, k).transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d fix = Eigen::Matrix3d::Identity();
  fix(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;
  const Eigen::Matrix3d r = svd.matrixV() * fix * svd.matrixU().transpose();
  return Log(Quat(r));
}

void Solver::CcdPass(int ei) {
  const Effector& e = At(effectors_, ei);
  if (e.ccd.empty()) return;
  Forward(current_, fk_);
  if (EffectorError(ei, fk_, false) <= tolerance_) return;
  // The points to move: the tip, and for an orientation two more at ls along
  // the bone's X and Z (about the tip; bare directions without a position).
  std::vector<Vec3>& p = ccd_points_;
  std::vector<Vec3>& t = ccd_targets_;
  std::vector<double>& w = ccd_weights_;
  std::vector<char>& placed = ccd_placed_;  // a position, not a direction
  int own = 0;
  const double weight = e.sqrt_weight * e.sqrt_weight;
  const auto gather = [&]() {
    own = 0;
    const auto add = [&](const Vec3& point, const Vec3& target, bool position) {
      const auto i = static_cast<std::size_t>(own++);
      p[i] = point;
      t[i] = target;
      w[i] = weight;
      placed[i] = position;
    };
    if (e.position) add(At(fk_.tip, ei), At(target_position_, ei), true);
    if (e.orientation) {
      const Quat& g = At(fk_.global, e.bone);
      const Quat& q = At(target_orientation_, ei);
      const Vec3 bp = e.position ? p[0] : Vec3::Zero(), bt = e.position ? t[0] : Vec3::Zero();
      for (int axis : {0, 2}) add(bp + ls_ * (g * Unit(axis)), bt + ls_ * (q * Unit(axis)), e.position);
    }
  };
  gather();
  for (const Link& link : e.ccd) {
    const Joint& j = At(joints_, link.joint);
    const int b = j.bone;
    const Vec3 pivot = At(fk_.head, b);
    const Quat frame = At(fk_.frame, b);
    // A body link also carries the other pins that hang from the body: they
    // join the fit, so that the turn serves the effector without tearing
    // them away.
    int count = own;
    if (link.body) {
      for (int o = 0; o < effector_count_; ++o) {
        const Effector& pin = At(effectors_, o);
        if (!pin.pin || !pin.position || o == link.anchor || o == ei || rig_.IsAncestor(b, pin.bone)) continue;
        const auto i = static_cast<std::size_t>(count++);
        p[i] = At(fk_.tip, o);
        t[i] = At(target_position_, o);
        w[i] = pin.sqrt_weight * pin.sqrt_weight;
        placed[i] = 1;
      }
    }
    Vec3 omega = Vec3::Zero();  // in the bone's rest frame
    if (j.axis_count == 1) {
      // A hinge: the best angle about its one axis.
      const int axis = j.axes[0];
      const Vec3 a = frame * Unit(axis);
      double num = 0.0, den = 0.0;
      for (int i = 0; i < count; ++i) {
        const auto k = static_cast<std::size_t>(i);
        const Vec3 v = placed[k] ? Vec3(p[k] - pivot) : p[k], u = placed[k] ? Vec3(t[k] - pivot) : t[k];
        num += w[k] * a.dot(v.cross(u));
        den += w[k] * (v.dot(u) - a.dot(v) * a.dot(u));
      }
      if (num != 0.0 || den != 0.0) omega[axis] = std::atan2(num, den);
    } else if (j.axis_count > 1) {
      omega = frame.conjugate() * BestRotation(count, pivot);
      for (int k = 0; k < 3; ++k) {
        if (!j.free[static_cast<std::size_t>(k)]) omega[k] = 0.0;
      }
    }
    if (link.body) omega = -omega;  // the bone turns back as the body turns
    for (int k = 0; k < j.axis_count; ++k) {
      omega[j.axes[static_cast<std::size_t>(k)]] *= j.axis_scale[static_cast<std::size_t>(k)];
    }
    const double angle = omega.norm();
    if (angle > options_.max_step) omega *= options_.max_step / angle;
    Quat& basis = At(current_.basis, b);
    const Quat old = basis;
    basis = (Exp(omega) * old).normalized();
    ClampJoint(j, current_);
    const Quat turn = basis * old.conjugate();  // what the bone did, in its rest frame
    if (!link.body) {
      const Quat world = frame * turn * frame.conjugate();
      for (int i = 0; i < own; ++i) {
        const auto k = static_cast<std::size_t>(i);
        p[k] = placed[k] ? Vec3(pivot + world * (p[k] - pivot)) : Vec3(world * p[k]);
      }
      if (j.stretch_column >= 0 && e.position && std::abs(link.lever) > 1e-12 * size_) {
        // The length that leaves the residual perpendicular to the bone.
        const Vec3 dir = (frame * basis) * Vec3::UnitY();
        const double s0 = At(current_.scale, b);
        const double s1 = std::clamp(s0 + std::min(1.0, j.stretch) * (t[0] - p[0]).dot(dir) / link.lever,
                                     j.min_scale, j.max_scale);
        At(current_.scale, b) = s1;
        const Vec3 shift = ((s1 - s0) * link.lever) * dir;
        for (int i = 0; i < own; ++i) {
          if (placed[static_cast<std::size_t>(i)]) p[static_cast<std::size_t>(i)] += shift;
        }
      }
    } else {
      // The body (root and all but this bone's subtree) turns about the joint.
      const Quat body = frame * turn.conjugate() * frame.conjugate();
      const Quat& rest = rig_.relative(0);
      Quat& root = At(current_.basis, 0);
      root = (rest.conjugate() * body * rest * root).normalized();
      ClampJoint(At(joints_, At(joint_of_, 0)), current_);
      current_.root = pivot + body * (current_.root - pivot);
      Forward(current_, fk_);
      gather();
    }
  }
}

int Solver::SolveCcd() {
  Forward(current_, fk_);
  Cost cost = Evaluate(fk_, e_.data());
  best_ = current_;
  Cost best = cost;
  const int limit = options_.max_iterations;
  int it = 0, kicks = 0, stale = 0;
  while (best.worst > tolerance_ && it < limit) {
    ++it;
    backup_ = current_;
    for (int e : ccd_order_) CcdPass(e);
    Forward(current_, fk_);
    cost = Evaluate(fk_, e_.data());
    bool finite = std::isfinite(cost.task) && current_.root.allFinite();
    for (const Joint& j : joints_) {
      finite = finite && At(current_.basis, j.bone).coeffs().allFinite() && std::isfinite(At(current_.scale, j.bone));
    }
    if (!finite) {  // keep the previous iterate
      std::swap(current_, backup_);
      break;
    }
    // Several effectors pull against each other, so a sweep may lose ground
    // before it gains: carry on, keep the best pose, and stop after a few
    // sweeps without a new best.
    if (cost.task < best.task * (1.0 - 1e-12)) {
      best_ = current_;
      best = cost;
      stale = 0;
      continue;
    }
    if (++stale < 4) continue;
    stale = 0;
    current_ = best_;
    Forward(current_, fk_);
    cost = best;
    if (best.worst > tolerance_ && kicks < 2 && it < limit) {
      ++it;
      ++kicks;
      trial_ = current_;
      if (Kick(0.0, cost)) {
        best_ = current_;
        best = cost;
        continue;
      }
    }
    break;
  }
  if (best.task < cost.task || !(cost.task == cost.task)) current_ = best_;
  Forward(current_, fk_);
  return it;
}

void Solver::FinishFrame(Eigen::Index f, int iterations) {
  // Never hand back a non-finite value: fall back on the frame's start.
  bool finite = current_.root.allFinite();
  for (const Joint& j : joints_) {
    finite = finite && At(current_.basis, j.bone).coeffs().allFinite() && std::isfinite(At(current_.scale, j.bone));
  }
  if (!finite) {
    StartFrame(f);
    Forward(current_, fk_);
  }
  for (int e = 0; e < effector_count_; ++e) job_.errors(f, At(ids_, e)) = EffectorError(e, fk_, true);
  iterations_[f] = iterations;
  const Eigen::Index rot_row = job_.input_rotations.rows() == 1 ? 0 : f;
  double* const out_row = job_.rotations.data() + f * job_.rotations.outerStride();
  const double* const in_row = job_.input_rotations.data() + rot_row * job_.input_rotations.outerStride();
  for (const Joint& j : joints_) {
    const int b = j.bone;
    double* out = out_row + 4 * b;
    const double* in = in_row + 4 * b;
    Quat q = At(current_.basis, b);
    // Continuous with the previous frame's output (the input's on the first of the run).
    const double* near = f > first_ ? out - job_.rotations.outerStride() : in;
    if (q.w() * near[0] + q.x() * near[1] + q.y() * near[2] + q.z() * near[3] < 0.0) q.coeffs() = -q.coeffs();
    out[0] = q.w();
    out[1] = q.x();
    out[2] = q.y();
    out[3] = q.z();
    job_.scales(f, b) = At(current_.scale, b);
  }
  if (translate_) {
    job_.root_locations.row(f) = (rig_.relative(0).conjugate() * (current_.root - rig_.offset(0))).transpose();
  }
  earlier_.root = solution_.root;
  for (const Joint& j : joints_) {
    At(earlier_.basis, j.bone) = At(solution_.basis, j.bone);
    At(earlier_.scale, j.bone) = At(solution_.scale, j.bone);
  }
  have_earlier_ = have_solution_;
  solution_.root = current_.root;
  for (const Joint& j : joints_) {
    At(solution_.basis, j.bone) = At(current_.basis, j.bone);
    At(solution_.scale, j.bone) = At(current_.scale, j.bone);
  }
  have_solution_ = true;
}

std::vector<int> Solver::Bones() const {
  std::vector<int> bones;
  bones.reserve(joints_.size());
  for (const Joint& j : joints_) bones.push_back(j.bone);
  return bones;
}

void Solver::Run(Eigen::Index first, Eigen::Index last) {
  first_ = first;
  for (Eigen::Index f = first; f < last; ++f) {
    StartFrame(f);
    const int iterations = options_.method == IkMethod::kCcd ? SolveCcd() : SolveJacobian();
    FinishFrame(f, iterations);
  }
}

RowMatrixXd Solver::Jacobian(Eigen::Index f) {
  have_solution_ = false;
  have_earlier_ = false;
  StartFrame(f);
  Forward(current_, fk_);
  BuildJacobian(fk_);
  RowMatrixXd j = RowMatrixXd::Zero(rows_, cols_);
  for (const Effector& e : effectors_) {
    const std::size_t n = e.columns.size();
    for (int r = 0; r < e.rows; ++r) {
      for (std::size_t i = 0; i < n; ++i) {
        j(e.row + r, e.columns[i]) = e.block[i * static_cast<std::size_t>(e.rows) + static_cast<std::size_t>(r)];
      }
    }
  }
  return j;
}

}  // namespace

namespace {

// Effectors that share no unknown are independent problems: the cost is a
// sum of one term per group, so each group is solved on its own (smaller
// systems, and a group stops when its own targets are met). Two effectors
// share an unknown when a bone the solver may move (not excluded; bone 0
// only with root_rotation) lies on both paths to the root, or when both hang
// from bone 0 and its location is an unknown.
std::vector<std::vector<int>> IndependentGroups(const IkClipJob& job) {
  const int bones = job.rig.size(), count = static_cast<int>(job.effectors.size());
  const auto excluded = [&](int b) { return !job.joints.empty() && At(job.joints, b).excluded; };
  // Union-find over effectors, through the first effector seen on each unknown.
  std::vector<int> parent(static_cast<std::size_t>(count));
  for (int e = 0; e < count; ++e) At(parent, e) = e;
  const auto find = [&](int e) {
    while (At(parent, e) != e) e = At(parent, e) = At(parent, At(parent, e));
    return e;
  };
  std::vector<int> owner(static_cast<std::size_t>(bones) + 1, -1);  // the last slot: the root's location
  const auto claim = [&](std::size_t slot, int e) {
    if (owner[slot] < 0) {
      owner[slot] = e;
    } else {
      At(parent, find(e)) = find(owner[slot]);
    }
  };
  for (int e = 0; e < count; ++e) {
    for (int b = At(job.effectors, e).bone; b >= 0; b = job.rig.parent(b)) {
      if (!excluded(b) && (b != 0 || job.options.root_rotation)) claim(static_cast<std::size_t>(b), e);
      if (b == 0 && job.options.root_translation && !excluded(0)) claim(static_cast<std::size_t>(bones), e);
    }
  }
  std::vector<std::vector<int>> groups;
  std::vector<int> group_of(static_cast<std::size_t>(count), -1);
  for (int e = 0; e < count; ++e) {
    int& g = At(group_of, find(e));
    if (g < 0) {
      g = static_cast<int>(groups.size());
      groups.emplace_back();
    }
    groups[static_cast<std::size_t>(g)].push_back(e);
  }
  return groups;
}

}  // namespace

std::optional<IkMethod> ParseIkMethod(std::string_view text) {
  if (text == "ccd") return IkMethod::kCcd;
  if (text == "transpose") return IkMethod::kTranspose;
  if (text == "pinv") return IkMethod::kPseudoInverse;
  if (text == "dls") return IkMethod::kDls;
  return std::nullopt;
}

Status IkClipJob::Validate() const {
  const int bones = rig.size();
  const auto count = static_cast<Eigen::Index>(effectors.size());
  const Eigen::Index frames = target_positions.rows();
  const auto fail = [](const std::string& m) { return Status::Fail("ik: " + m); };
  if (bones == 0) return fail("the rig has no bones");
  if (input_rotations.cols() != 4 * bones || (input_rotations.rows() != 1 && input_rotations.rows() != frames)) {
    return fail("input rotations must be frames (or 1) x " + std::to_string(4 * bones) + " (4 per bone)");
  }
  if (input_locations.cols() != 3 || (input_locations.rows() != 1 && input_locations.rows() != frames)) {
    return fail("input locations must be frames (or 1) x 3 (the root bone's location)");
  }
  if (target_positions.cols() != 3 * count) {
    return fail("target positions must be frames x " + std::to_string(3 * count) + " (3 per effector)");
  }
  if (target_orientations.cols() != 0 &&
      (target_orientations.cols() != 4 * count || target_orientations.rows() != frames)) {
    return fail("target orientations must be frames x " + std::to_string(4 * count) +
                " (4 per effector), or have no columns");
  }
  if (rotations.rows() != frames || rotations.cols() != 4 * bones || root_locations.rows() != frames ||
      root_locations.cols() != 3 || scales.rows() != frames || scales.cols() != bones || errors.rows() != frames ||
      errors.cols() != count || iterations.size() != frames) {
    return fail("outputs must be frames x 4 per bone, frames x 3, frames x bones, frames x effectors and frames");
  }
  if (!joints.empty() && joints.size() != static_cast<std::size_t>(bones)) {
    return fail("joint settings must be given for every bone, or for none");
  }
  const IkOptions& o = options;
  if (o.max_iterations < 0) return fail("max_iterations must not be negative");
  if (o.threads < 0) return fail("threads must be 0 (all) or more, got " + std::to_string(o.threads));
  if (!(std::isfinite(o.tolerance) && o.tolerance >= 0)) return fail("tolerance must be finite and >= 0");
  if (!(std::isfinite(o.max_step) && o.max_step > 0)) return fail("max_step must be finite and > 0");
  if (!(std::isfinite(o.damping) && o.damping >= 0)) return fail("damping must be finite and >= 0");
  if (!(std::isfinite(o.regularization) && o.regularization >= 0)) {
    return fail("regularization must be finite and >= 0");
  }
  if (!(std::isfinite(o.size) && o.size >= 0)) return fail("size must be finite and >= 0");
  if (!(std::isfinite(o.orientation_scale) && o.orientation_scale >= 0)) {
    return fail("orientation_scale must be finite and >= 0");
  }
  for (std::size_t i = 0; i < effectors.size(); ++i) {
    const IkEffector& e = effectors[i];
    const std::string name = EffectorName(e, i);
    if (e.bone < 0 || e.bone >= bones) return fail(name + ": bone index " + std::to_string(e.bone) + " out of range");
    if (!(std::isfinite(e.weight) && e.weight > 0)) return fail(name + ": the weight must be finite and positive");
    if (!e.position && !e.orientation) return fail(name + " has nothing to reach (neither position nor orientation)");
    if (e.orientation && !e.pin && target_orientations.cols() == 0) {
      return fail(name + " asks for an orientation but no target orientations were given");
    }
  }
  for (std::size_t b = 0; b < joints.size(); ++b) {
    const IkJoint& j = joints[b];
    const std::string name = "bone '" + rig.name(static_cast<int>(b)) + "'";
    for (int k = 0; k < 3; ++k) {
      if (std::isnan(j.min[k]) || std::isnan(j.max[k]) || j.min[k] > j.max[k]) {
        return fail(name + ": limit min must not exceed max (axis " + std::string(1, "XYZ"[k]) + ")");
      }
      if (!(std::isfinite(j.stiffness[k]) && j.stiffness[k] >= 0 && j.stiffness[k] < 1)) {
        return fail(name + ": stiffness must be in [0, 1)");
      }
    }
    // Something must lie within the limits: a twist in [-pi, pi], a swing
    // whose rotation vector is at most pi long.
    Eigen::Vector3d lo = j.min, hi = j.max;
    for (int k = 0; k < 3; ++k) {
      if (j.locked[static_cast<std::size_t>(k)]) lo[k] = hi[k] = 0.0;
    }
    const double near_x = std::clamp(0.0, lo.x(), hi.x()), near_z = std::clamp(0.0, lo.z(), hi.z());
    if (lo.y() > kPi - 1e-6 || hi.y() < -kPi + 1e-6 || std::hypot(near_x, near_z) > kSwingReach) {
      return fail(name + ": the limits leave no rotation (twist within [-pi, pi], swing at most pi)");
    }
    if (!(std::isfinite(j.stretch) && j.stretch >= 0)) return fail(name + ": stretch must be finite and >= 0");
    if (j.stretch > 0 && !(std::isfinite(j.min_scale) && std::isfinite(j.max_scale) && j.min_scale > 0 &&
                           j.min_scale <= j.max_scale)) {
      return fail(name + ": the scale range must be positive, finite and ordered");
    }
  }
  for (Eigen::Index f = 0; f < input_rotations.rows(); ++f) {
    for (int b = 0; b < bones; ++b) {
      const Eigen::Quaterniond q = QuatAt(input_rotations, f, b);
      if (!q.coeffs().allFinite() || !(q.norm() > 1e-12)) {
        return fail("bone '" + rig.name(b) + "' has a zero or non-finite input rotation at " + FrameIndex(f));
      }
    }
  }
  for (Eigen::Index f = 0; f < input_locations.rows(); ++f) {
    if (!input_locations.row(f).allFinite()) return fail("the root location is not finite at " + FrameIndex(f));
  }
  for (Eigen::Index f = 0; f < frames; ++f) {
    for (Eigen::Index i = 0; i < count; ++i) {
      const IkEffector& e = effectors[static_cast<std::size_t>(i)];
      if (e.pin) continue;
      if (e.position && !target_positions.row(f).segment<3>(3 * i).allFinite()) {
        return fail(EffectorName(e, static_cast<std::size_t>(i)) + " has a non-finite target position at " +
                    FrameIndex(f));
      }
      if (e.orientation) {
        const Eigen::Quaterniond q = QuatAt(target_orientations, f, i);
        if (!q.coeffs().allFinite() || !(q.norm() > 1e-12)) {
          return fail(EffectorName(e, static_cast<std::size_t>(i)) +
                      " has a zero or non-finite target orientation at " + FrameIndex(f));
        }
      }
    }
  }
  return Status::Ok();
}

void IkClipJob::Run() {
  Validate().ThrowIfFailed();
  std::vector<std::vector<int>> groups = IndependentGroups(*this);
  const Eigen::Index frames = target_positions.rows();
  // Every output as the input has it; each group's solver then writes its own bones and effectors.
  for (Eigen::Index f = 0; f < frames; ++f) {
    rotations.row(f) = input_rotations.row(input_rotations.rows() == 1 ? 0 : f);
    root_locations.row(f) = input_locations.row(input_locations.rows() == 1 ? 0 : f);
  }
  scales.setOnes();
  // Larger groups first, so that the threads finish together.
  std::stable_sort(groups.begin(), groups.end(),
                   [](const std::vector<int>& a, const std::vector<int>& b) { return a.size() > b.size(); });
  std::vector<std::vector<int>> counts(groups.size(), std::vector<int>(static_cast<std::size_t>(frames), 0));
  int threads = options.threads;
  if (threads == 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  // Without a warm start and with the input as the reference, no frame depends on another: the threads
  // a group leaves idle take runs of its frames (each run with its own solver), same numbers.
  const bool frames_apart = !options.warm_start && options.reference == IkReference::kInput;
  const int group_count = static_cast<int>(groups.size());
  const Eigen::Index runs = frames_apart && group_count > 0 && threads > group_count
                                ? std::max<Eigen::Index>(1, std::min<Eigen::Index>(threads / group_count, frames))
                                : 1;
  const int tasks = group_count * static_cast<int>(runs);
  std::vector<std::exception_ptr> failures(static_cast<std::size_t>(tasks));
  std::vector<std::vector<int>> solved(static_cast<std::size_t>(tasks));
  const auto run_start = [&](Eigen::Index run) { return frames * run / runs; };
  internal::ParallelFor(tasks, threads, [&](int t) {
    const auto i = static_cast<std::size_t>(t / runs);
    const Eigen::Index run = t % runs;
    try {
      Solver solver(*this, groups[i], counts[i].data());
      solver.Run(run_start(run), run_start(run + 1));
      solved[static_cast<std::size_t>(t)] = solver.Bones();
    } catch (...) {
      failures[static_cast<std::size_t>(t)] = std::current_exception();
    }
  });
  for (const std::exception_ptr& failure : failures) {
    if (failure) std::rethrow_exception(failure);
  }
  // Each later run began its signs from the input: carry on from the run before, as one thread would.
  for (int t = 0; t < tasks; ++t) {
    const Eigen::Index run = t % runs, first = run_start(run), last = run_start(run + 1);
    if (run == 0 || first == last) continue;
    for (int b : solved[static_cast<std::size_t>(t)]) {
      if (rotations.row(first).segment<4>(4 * b).dot(rotations.row(first - 1).segment<4>(4 * b)) < 0.0) {
        rotations.block(first, 4 * b, last - first, 4) *= -1.0;
      }
    }
  }
  for (Eigen::Index f = 0; f < frames; ++f) {
    int most = 0;
    for (const std::vector<int>& c : counts) most = std::max(most, c[static_cast<std::size_t>(f)]);
    iterations[f] = most;
  }
}

RowMatrixXd IkClipJob::Jacobian(Eigen::Index frame) const {
  Validate().ThrowIfFailed();
  if (frame < 0 || frame >= target_positions.rows()) throw Error("ik: frame index out of range");
  IkClipJob job = *this;  // views and settings: the solver writes nothing here
  std::vector<int> ids(job.effectors.size());
  for (std::size_t e = 0; e < ids.size(); ++e) ids[e] = static_cast<int>(e);
  Solver solver(job, std::move(ids), nullptr);
  return solver.Jacobian(frame);
}

}  // namespace motionkit
