// An arm's least turn out of its body (native/include/motionkit/body_arm.hpp).
#include "motionkit/body_arm.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <thread>

#include "body_read.hpp"
#include "../parallel.hpp"

namespace motionkit {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr Eigen::Index kBlock = 64;  // frames a thread takes at a time
// A frame's solve stops once no point is short of where it is wanted by more than this share of a cell:
// 0.14 mm on a 1.8 m character, far below the field's own precision (half a cell is kept for it).
constexpr double kConverged = 1e-2;

// One thread's per-point buffers (S each).
struct Scratch {
  explicit Scratch(std::size_t count)
      : posed(count),
        moved(count),
        slope(count),
        distance(count),
        shoulder_turn(Eigen::Matrix3d::Identity()),
        elbow(Eigen::Vector3d::Zero()),
        wrist(Eigen::Vector3d::Zero()) {}
  std::vector<Eigen::Vector3d> posed;
  std::vector<Eigen::Vector3d> moved;
  std::vector<Eigen::Vector3d> slope;
  std::vector<double> distance;
  Eigen::Matrix3d shoulder_turn;   // where Move last put the arm: the shoulder's turn, the elbow and the wrist
  Eigen::Vector3d elbow, wrist;
};

Eigen::Vector3d Head(const BodyArmJob& job, Eigen::Index frame, int bone) {
  return job.heads.block<1, 3>(frame, 3 * bone).transpose();
}

Eigen::Quaterniond FromRotationVector(const Eigen::Vector3d& v) {
  const double angle = v.norm();
  if (!(angle > 1e-15)) return Eigen::Quaterniond::Identity();
  const Eigen::Vector3d axis = std::sin(0.5 * angle) * (v / angle);
  return Eigen::Quaterniond(std::cos(0.5 * angle), axis.x(), axis.y(), axis.z());
}

class ArmFrame {
 public:
  ArmFrame(const BodyArmJob& job, Eigen::Index frame, Scratch& scratch)
      : job_(job),
        frame_(frame),
        s_(scratch),
        shoulder_(Head(job, frame, job.arm[0])),
        elbow_(Head(job, frame, job.arm[1])),
        wrist_(Head(job, frame, job.arm[2])) {
    for (std::size_t n = 0; n < s_.posed.size(); ++n) {
      const int b = job.point_bones[n];
      const Eigen::Quaterniond g(job.orientations(frame, 4 * b), job.orientations(frame, 4 * b + 1),
                                 job.orientations(frame, 4 * b + 2), job.orientations(frame, 4 * b + 3));
      s_.posed[n] = g.normalized() * job.point_local.row(static_cast<Eigen::Index>(n)).transpose() + Head(job, frame, b);
    }
  }

  // Each point where the turns t (shoulder's, elbow's rotation vectors) put it.
  void Move(const Vector6d& t) {
    const Eigen::Quaterniond qs = FromRotationVector(t.head<3>()), both = qs * FromRotationVector(t.tail<3>());
    const Eigen::Vector3d new_elbow = qs * (elbow_ - shoulder_) + shoulder_;
    const Eigen::Vector3d new_wrist = both * (wrist_ - elbow_) + new_elbow;
    s_.shoulder_turn = qs.toRotationMatrix();
    s_.elbow = new_elbow;
    s_.wrist = new_wrist;
    for (std::size_t n = 0; n < s_.moved.size(); ++n) {
      const Eigen::Vector3d& p = s_.posed[n];
      s_.moved[n] = job_.on_hand[n] ? Eigen::Vector3d(p - wrist_ + new_wrist) : Eigen::Vector3d(both * (p - elbow_) + new_elbow);
    }
  }

  // The body's distance (and gradient) at each moved point: the nearest of the carriers' reads.
  void Read(bool slopes) {
    std::fill(s_.distance.begin(), s_.distance.end(), kInf);
    if (slopes) std::fill(s_.slope.begin(), s_.slope.end(), Eigen::Vector3d::Zero());
    for (std::size_t c = 0; c < job_.field.carriers.size(); ++c) {
      const internal::CarrierMotion motion = internal::Motion(job_.field, c, job_.orientations, job_.heads, frame_);
      for (std::size_t n = 0; n < s_.moved.size(); ++n) {
        Eigen::Vector3d slope;
        const double d = internal::ReadThrough(job_.field, motion, s_.moved[n], slopes ? &slope : nullptr);
        if (!(d < s_.distance[n])) continue;
        s_.distance[n] = d;
        if (slopes) s_.slope[n] = slope;
      }
    }
  }

  // One Gauss-Newton step from t, or false where no point is short of where it is wanted.
  bool Step(Vector6d& t) {
    Matrix6d normal;
    Vector6d rhs;
    if (!Linearise(t, normal, rhs)) return false;
    Take(normal.ldlt().solve(rhs), job_.max_step, t);
    return true;
  }

  // The normal equations of a step from t (normal = J^T J + w^2 I, rhs = J^T r), or false where no point
  // is short of where it is wanted (normal and rhs are then w^2 I and 0).
  bool Linearise(const Vector6d& t, Matrix6d& normal, Vector6d& rhs) {
    Move(t);
    Read(true);
    const double wanted = job_.wanted[frame_];
    const bool touch = job_.touch[static_cast<std::size_t>(frame_)] != 0, to_goal = touch && HasGoal();
    const bool contact = to_goal && job_.contacts.rows() != 0;
    const int nearest = contact ? -1 : to_goal ? NearestToGoal() : touch ? NearestOnHand() : -1;
    normal = job_.turn_weight * job_.turn_weight * Matrix6d::Identity();
    rhs.setZero();
    bool short_of_it = false;
    if (to_goal && (contact || nearest >= 0)) {
      // The hand's contact point (or its point nearest the goal) onto the goal: a point moves by each turn's
      // cross product with its lever.
      const std::size_t n = static_cast<std::size_t>(std::max(nearest, 0));
      const Eigen::Vector3d point = contact ? Contact() : s_.moved[n];
      const Eigen::Vector3d lever = contact ? Eigen::Vector3d(s_.wrist - s_.elbow) : Lever(n);
      const Eigen::Vector3d r = Goal() - point;
      short_of_it = r.norm() > kConverged * job_.field.spacing;
      Eigen::Matrix<double, 3, 6> rows;
      rows << -Skew(point - shoulder_), -Skew(lever) * s_.shoulder_turn;
      normal.noalias() += rows.transpose() * rows;
      rhs.noalias() += rows.transpose() * r;
    }
    for (std::size_t n = 0; n < s_.moved.size(); ++n) {
      const double d = s_.distance[n];
      double r;
      if (static_cast<int>(n) == nearest && to_goal) {
        continue;
      } else if (static_cast<int>(n) == nearest) {
        r = job_.touch_distance - d;
      } else if (std::isfinite(d) && wanted - d > 0.0) {
        r = wanted - d;
      } else {
        continue;
      }
      short_of_it = short_of_it || std::abs(r) > kConverged * job_.field.spacing;
      const Eigen::Vector3d& g = s_.slope[n];
      Vector6d row;
      row << (s_.moved[n] - shoulder_).cross(g), s_.shoulder_turn.transpose() * Lever(n).cross(g);
      normal.noalias() += row * row.transpose();
      rhs += r * row;
    }
    if (!short_of_it) {
      normal = job_.turn_weight * job_.turn_weight * Matrix6d::Identity();
      rhs.setZero();
    }
    return short_of_it;
  }

  // A step taken on by t: at most max_step radians a joint (the distance is linear in a turn only near it),
  // each turn taken on by the step's turn before it, in the space the Jacobian's rows are in: the
  // shoulder's in the armature's, the elbow's in the shoulder-turned one (the forearm turns by qs qe).
  static void Take(Vector6d step, double max_step, Vector6d& t) {
    for (int joint = 0; joint < 2; ++joint) {
      const double size = step.segment<3>(3 * joint).norm();
      if (size > max_step) step.segment<3>(3 * joint) *= max_step / size;
    }
    t.head<3>() = Compose(step.head<3>(), t.head<3>());
    t.tail<3>() = Compose(step.tail<3>(), t.tail<3>());
  }

  // The nearest and the hand's nearest distance where t puts the arm, and how far the hand is from its goal
  // (0 where it has none).
  void Measure(const Vector6d& t, double& least, double& hand, double& gap) {
    Move(t);
    Read(false);
    least = hand = kInf;
    gap = 0.0;
    for (std::size_t n = 0; n < s_.moved.size(); ++n) {
      least = std::min(least, s_.distance[n]);
      if (job_.on_hand[n]) hand = std::min(hand, s_.distance[n]);
    }
    if (!HasGoal()) return;
    if (job_.contacts.rows() != 0) {
      gap = (Goal() - Contact()).norm();
      return;
    }
    const int nearest = NearestToGoal();
    if (nearest >= 0) gap = (Goal() - s_.moved[static_cast<std::size_t>(nearest)]).norm();
  }

 private:
  bool HasGoal() const { return job_.goals.rows() != 0 && job_.goals.row(frame_).allFinite(); }
  Eigen::Vector3d Goal() const { return job_.goals.row(frame_).transpose(); }
  // The hand's contact point where Move last put the arm: carried by the wrist, as the hand's points are.
  Eigen::Vector3d Contact() const { return job_.contacts.row(frame_).transpose() - wrist_ + s_.wrist; }

  int NearestToGoal() const {
    int found = -1;
    double best = kInf;
    for (std::size_t n = 0; n < s_.moved.size(); ++n) {
      const double d = (s_.moved[n] - Goal()).squaredNorm();
      if (job_.on_hand[n] && d < best) {
        best = d;
        found = static_cast<int>(n);
      }
    }
    return found;
  }

  // How a turn of the elbow moves point n (its lever: from the elbow where the arm is now, to the point on
  // the forearm, to the wrist for a hand point, which the wrist carries).
  Eigen::Vector3d Lever(std::size_t n) const {
    return job_.on_hand[n] ? Eigen::Vector3d(s_.wrist - s_.elbow) : Eigen::Vector3d(s_.moved[n] - s_.elbow);
  }

  // The rotation vector of turning by b, then by a.
  static Eigen::Vector3d Compose(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    const Eigen::AngleAxisd both(FromRotationVector(a) * FromRotationVector(b));
    return both.angle() * both.axis();
  }

  static Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
    Eigen::Matrix3d m;
    m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
    return m;
  }

  int NearestOnHand() const {
    int found = -1;
    for (std::size_t n = 0; n < s_.moved.size(); ++n) {
      if (job_.on_hand[n] && std::isfinite(s_.distance[n]) &&
          (found < 0 || s_.distance[n] < s_.distance[static_cast<std::size_t>(found)])) {
        found = static_cast<int>(n);
      }
    }
    return found;
  }

  const BodyArmJob& job_;
  Eigen::Index frame_;
  Scratch& s_;
  Eigen::Vector3d shoulder_, elbow_, wrist_;
};

int Workers(int threads) {
  return threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

}  // namespace

Status BodyArmJob::Validate() const {
  const Eigen::Index count = static_cast<Eigen::Index>(point_bones.size()), all = orientations.rows();
  const Eigen::Index bones = orientations.cols() / 4;
  if (heads.rows() != all || heads.cols() != 3 * bones || orientations.cols() != 4 * bones) {
    return Status::Fail("body arm: the pose must be F x 4B orientations and F x 3B heads");
  }
  if (Status s = field.Validate(bones, "body arm"); !s.ok()) return s;
  for (int b : arm) {
    if (b < 0 || b >= bones) return Status::Fail("body arm: arm bone " + std::to_string(b) + " out of range");
  }
  for (int b : point_bones) {
    if (b < 0 || b >= bones) return Status::Fail("body arm: point bone " + std::to_string(b) + " out of range");
  }
  if (point_local.rows() != count || point_local.cols() != 3 || !point_local.allFinite() ||
      static_cast<Eigen::Index>(on_hand.size()) != count) {
    return Status::Fail("body arm: one finite offset and one on_hand a point");
  }
  if (wanted.size() != all || static_cast<Eigen::Index>(touch.size()) != all || turns.rows() != all ||
      turns.cols() != 6 || least.size() != static_cast<Eigen::Index>(frames.size()) || hand.size() != least.size() ||
      gap.size() != least.size() || (goals.rows() != 0 && (goals.rows() != all || goals.cols() != 3)) ||
      (contacts.rows() != 0 && (goals.rows() == 0 || contacts.rows() != all || contacts.cols() != 3))) {
    return Status::Fail("body arm: wanted, touch, turns (and goals, contacts) of every frame, least, hand and gap of "
                        "each solved");
  }
  if (iterations < 0 || !(turn_weight > 0.0) || !(max_step > 0.0) || !std::isfinite(touch_distance) ||
      !(smoothness >= 0.0) || !std::isfinite(smoothness)) {
    return Status::Fail("body arm: iterations >= 0, turn_weight and max_step > 0, a finite touch_distance and "
                        "smoothness >= 0");
  }
  std::vector<int> sorted(frames);
  std::sort(sorted.begin(), sorted.end());
  if (const auto twice = std::adjacent_find(sorted.begin(), sorted.end()); twice != sorted.end()) {
    return Status::Fail("body arm: frame index " + std::to_string(*twice) + " listed twice");
  }
  for (int f : frames) {
    if (f < 0 || f >= all) return Status::Fail("body arm: frame index " + std::to_string(f) + " out of range");
    if (!orientations.row(f).allFinite() || !heads.row(f).allFinite() || !turns.row(f).allFinite() ||
        !std::isfinite(wanted[f])) {
      return Status::Fail("body arm: frame index " + std::to_string(f) +
                          ": its pose, turns and wanted distance must be finite");
    }
  }
  return Status::Ok();
}

void BodyArmJob::Run() {
  Validate().ThrowIfFailed();
  if (smoothness > 0.0) {
    RunCoupled();
    return;
  }
  const Eigen::Index solved = static_cast<Eigen::Index>(frames.size());
  const int blocks = static_cast<int>((solved + kBlock - 1) / kBlock);
  // Each block's buffers made before the threads start (a task must not throw).
  std::vector<Scratch> scratches(static_cast<std::size_t>(blocks), Scratch(point_bones.size()));
  internal::ParallelFor(blocks, Workers(threads), [&](int block) {
    Scratch& scratch = scratches[static_cast<std::size_t>(block)];
    const Eigen::Index end = std::min(solved, (block + 1) * kBlock);
    for (Eigen::Index i = block * kBlock; i < end; ++i) {
      const Eigen::Index f = frames[static_cast<std::size_t>(i)];
      ArmFrame arm_frame(*this, f, scratch);
      Vector6d t = turns.row(f).transpose();
      for (int step = 0; step < iterations && arm_frame.Step(t); ++step) {
      }
      if (!t.allFinite()) t.setZero();  // never seen; a frame left as it was, never made not finite
      turns.row(f) = t.transpose();
      arm_frame.Measure(t, least[i], hand[i], gap[i]);
    }
  });
}

// Runs of consecutive frames, each solved as one least-squares problem: every frame's own rows (as Step
// takes them) and smoothness (t_f - t_{f-1}) between neighbours. Its normal equations are block-tridiagonal
// (6 x 6 blocks: D_f = N_f + smoothness^2 (neighbours) I, -smoothness^2 I beside), eliminated frame by frame
// (block Thomas: D'_f = D_f - c^2 D'_{f-1}^-1, c = smoothness^2) on every Gauss-Newton step.
void BodyArmJob::RunCoupled() {
  const std::size_t solved = frames.size();
  std::vector<std::size_t> order(solved);
  for (std::size_t i = 0; i < solved; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return frames[a] < frames[b]; });
  std::vector<std::size_t> starts;  // where each run begins in order, and its end last
  for (std::size_t k = 0; k < solved; ++k) {
    if (k == 0 || frames[order[k]] != frames[order[k - 1]] + 1) starts.push_back(k);
  }
  starts.push_back(solved);
  const int runs = static_cast<int>(starts.size()) - 1;
  // Every buffer made before the threads start (a task must not throw): per run a scratch, per frame the
  // turns, the eliminated blocks' inverses and right-hand sides.
  std::vector<Scratch> scratches(static_cast<std::size_t>(std::max(runs, 0)), Scratch(point_bones.size()));
  std::vector<Vector6d> t(solved), y(solved), step(solved);
  std::vector<Matrix6d> inverse(solved);
  const double c = smoothness * smoothness;
  internal::ParallelFor(runs, Workers(threads), [&](int run) {
    Scratch& scratch = scratches[static_cast<std::size_t>(run)];
    const std::size_t first = starts[static_cast<std::size_t>(run)], last = starts[static_cast<std::size_t>(run) + 1];
    for (std::size_t k = first; k < last; ++k) t[k] = turns.row(frames[order[k]]).transpose();
    for (int iteration = 0; iteration < iterations; ++iteration) {
      bool short_of_it = false;
      for (std::size_t k = first; k < last; ++k) {
        ArmFrame arm_frame(*this, frames[order[k]], scratch);
        Matrix6d normal;
        Vector6d rhs;
        short_of_it = arm_frame.Linearise(t[k], normal, rhs) || short_of_it;
        // The coupling's rows: each neighbour's difference pulls the frame toward it.
        if (k > first) {
          normal.diagonal().array() += c;
          rhs -= c * (t[k] - t[k - 1]);
        }
        if (k + 1 < last) {
          normal.diagonal().array() += c;
          rhs -= c * (t[k] - t[k + 1]);
        }
        if (k > first) {
          normal -= c * c * inverse[k - 1];
          rhs += c * (inverse[k - 1] * y[k - 1]);
        }
        inverse[k] = normal.ldlt().solve(Matrix6d::Identity());
        y[k] = rhs;
      }
      double largest = 0.0;
      for (std::size_t k = last; k-- > first;) {
        step[k] = inverse[k] * (k + 1 < last ? Vector6d(y[k] + c * step[k + 1]) : y[k]);
        largest = std::max(largest, step[k].cwiseAbs().maxCoeff());
      }
      for (std::size_t k = first; k < last; ++k) ArmFrame::Take(step[k], max_step, t[k]);
      // Converged: no frame short of where it is wanted, and the coupling's pull down to a ten-thousandth
      // of a radian.
      if (!short_of_it && largest < 1e-4) break;
    }
    for (std::size_t k = first; k < last; ++k) {
      const std::size_t i = order[k];
      const Eigen::Index f = frames[i];
      if (!t[k].allFinite()) t[k].setZero();  // never seen; a frame left as it was, never made not finite
      turns.row(f) = t[k].transpose();
      ArmFrame arm_frame(*this, f, scratch);
      arm_frame.Measure(t[k], least[static_cast<Eigen::Index>(i)], hand[static_cast<Eigen::Index>(i)],
                        gap[static_cast<Eigen::Index>(i)]);
    }
  });
}

}  // namespace motionkit
