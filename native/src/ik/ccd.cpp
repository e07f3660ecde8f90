// Cyclic coordinate descent: the best rotation of a joint towards its effectors, one pass, the loop.
#include "solver.hpp"

namespace motionkit::ik_internal {

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
  return RotationVector(Quat(r));
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
    basis = (FromRotationVector(omega) * old).normalized();
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

}  // namespace motionkit::ik_internal
