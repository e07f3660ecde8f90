// Cyclic coordinate descent: per effector, the joints from the tip towards the root (through the root
// when a pin holds the far end) each turned to best take the effector's points onto their targets;
// sweeps until the targets are met or the best pose stops improving.
#include <Eigen/SVD>

#include "solver.hpp"

namespace motionkit::ik_internal {

namespace {

// A CCD point relative to the pivot (a direction turns about nothing).
Vec3 FromPivot(const CcdScratch& c, const std::vector<Vec3>& v, std::size_t i, const Vec3& pivot) {
  return c.placed[i] ? Vec3(v[i] - pivot) : v[i];
}

// The rotation about `pivot` that best takes the first `count` CCD points
// onto their targets (weighted): the shortest arc for one point, Kabsch for more.
Vec3 BestFitRotation(const Model& m, const CcdScratch& c, int count, const Vec3& pivot) {
  const double tiny = 1e-12 * m.size;
  if (count == 1) {
    const Vec3 v = FromPivot(c, c.points, 0, pivot), u = FromPivot(c, c.targets, 0, pivot);
    if (v.norm() < tiny || u.norm() < tiny) return Vec3::Zero();
    const Vec3 axis = v.cross(u);
    const double s = axis.norm(), cosine = v.dot(u);
    if (s > 1e-14 * v.norm() * u.norm()) return axis * (std::atan2(s, cosine) / s);
    if (cosine < 0.0) return kPi * v.unitOrthogonal();
    return Vec3::Zero();
  }
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (int i = 0; i < count; ++i) {
    const auto k = static_cast<std::size_t>(i);
    h += c.weights[k] * FromPivot(c, c.points, k, pivot) * FromPivot(c, c.targets, k, pivot).transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d fix = Eigen::Matrix3d::Identity();
  fix(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;
  const Eigen::Matrix3d r = svd.matrixV() * fix * svd.matrixU().transpose();
  return RotationVector(Quat(r));
}

// The effector's own points: its tip, and for an orientation two more at ls along the bone's X and
// Z (about the tip; bare directions without a position). Returns their count.
int GatherOwnPoints(const Model& m, Data& d, int ei) {
  const Effector& e = At(m.effectors, ei);
  CcdScratch& c = d.ccd;
  const double weight = e.sqrt_weight * e.sqrt_weight;
  int own = 0;
  const auto add = [&](const Vec3& point, const Vec3& target, bool position) {
    const auto i = static_cast<std::size_t>(own++);
    c.points[i] = point;
    c.targets[i] = target;
    c.weights[i] = weight;
    c.placed[i] = position;
  };
  if (e.position) add(At(d.fk.tip, ei), At(d.target_position, ei), true);
  if (e.orientation) {
    const Quat& g = At(d.fk.global, e.bone);
    const Quat& q = At(d.target_orientation, ei);
    const Vec3 bp = e.position ? c.points[0] : Vec3::Zero(), bt = e.position ? c.targets[0] : Vec3::Zero();
    for (int axis : {0, 2}) add(bp + m.ls * (g * Unit(axis)), bt + m.ls * (q * Unit(axis)), e.position);
  }
  return own;
}

// A body link also carries the other pins that hang from the body: they join the fit after the
// effector's own points, so that the turn serves the effector without tearing them away. Returns the
// points' count.
int AddCarriedPins(const Model& m, Data& d, int ei, const Link& link, int own) {
  CcdScratch& c = d.ccd;
  const int b = At(m.joints, link.joint).bone;
  int count = own;
  for (int o = 0; o < m.effector_count; ++o) {
    const Effector& pin = At(m.effectors, o);
    if (!pin.pin || !pin.position || o == link.anchor || o == ei || m.rig.IsAncestor(b, pin.bone)) continue;
    const auto i = static_cast<std::size_t>(count++);
    c.points[i] = At(d.fk.tip, o);
    c.targets[i] = At(d.target_position, o);
    c.weights[i] = pin.sqrt_weight * pin.sqrt_weight;
    c.placed[i] = 1;
  }
  return count;
}

// The turn (in the bone's rest frame) that best takes `count` points onto their targets: a hinge's
// best angle about its one axis, else the best rotation less its locked axes; the stiffness applied
// and max_step kept.
Vec3 LinkTurn(const Model& m, const Data& d, const Link& link, int count) {
  const Joint& j = At(m.joints, link.joint);
  const CcdScratch& c = d.ccd;
  const Vec3 pivot = At(d.fk.head, j.bone);
  const Quat& frame = At(d.fk.frame, j.bone);
  Vec3 omega = Vec3::Zero();
  if (j.axis_count == 1) {
    const int axis = j.axes[0];
    const Vec3 a = frame * Unit(axis);
    double num = 0.0, den = 0.0;
    for (int i = 0; i < count; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const Vec3 v = FromPivot(c, c.points, k, pivot), u = FromPivot(c, c.targets, k, pivot);
      num += c.weights[k] * a.dot(v.cross(u));
      den += c.weights[k] * (v.dot(u) - a.dot(v) * a.dot(u));
    }
    if (num != 0.0 || den != 0.0) omega[axis] = std::atan2(num, den);
  } else if (j.axis_count > 1) {
    omega = frame.conjugate() * BestFitRotation(m, c, count, pivot);
    for (int k = 0; k < 3; ++k) {
      if (!j.free[static_cast<std::size_t>(k)]) omega[k] = 0.0;
    }
  }
  if (link.body) omega = -omega;  // the bone turns back as the body turns
  for (int k = 0; k < j.axis_count; ++k) {
    omega[j.axes[static_cast<std::size_t>(k)]] *= j.axis_scale[static_cast<std::size_t>(k)];
  }
  const double angle = omega.norm();
  if (angle > m.options.max_step) omega *= m.options.max_step / angle;
  return omega;
}

// An ordinary link's bone turned by `turn` (world): the effector's own points follow, then a
// stretchable bone takes the length that leaves the residual perpendicular to it.
void MoveOwnPoints(const Model& m, Data& d, const Link& link, int own, const Quat& turn, const Effector& e) {
  const Joint& j = At(m.joints, link.joint);
  CcdScratch& c = d.ccd;
  const int b = j.bone;
  const Vec3 pivot = At(d.fk.head, b);
  const Quat& frame = At(d.fk.frame, b);
  const Quat world = frame * turn * frame.conjugate();
  for (int i = 0; i < own; ++i) {
    const auto k = static_cast<std::size_t>(i);
    c.points[k] = c.placed[k] ? Vec3(pivot + world * (c.points[k] - pivot)) : Vec3(world * c.points[k]);
  }
  if (j.stretch_column < 0 || !e.position || !(std::abs(link.lever) > 1e-12 * m.size)) return;
  const Vec3 dir = (frame * At(d.current.basis, b)) * Vec3::UnitY();
  const double s0 = At(d.current.scale, b);
  const double s1 = std::clamp(s0 + std::min(1.0, j.stretch) * (c.targets[0] - c.points[0]).dot(dir) / link.lever,
                               j.min_scale, j.max_scale);
  At(d.current.scale, b) = s1;
  const Vec3 shift = ((s1 - s0) * link.lever) * dir;
  for (int i = 0; i < own; ++i) {
    if (c.placed[static_cast<std::size_t>(i)]) c.points[static_cast<std::size_t>(i)] += shift;
  }
}

// A body link: the body (root and all but this bone's subtree) turns about the joint, the other way.
void TurnBody(const Model& m, Data& d, const Link& link, const Quat& turn) {
  const int b = At(m.joints, link.joint).bone;
  const Vec3 pivot = At(d.fk.head, b);
  const Quat& frame = At(d.fk.frame, b);
  const Quat body = frame * turn.conjugate() * frame.conjugate();
  const Quat& rest = m.rig.relative(0);
  Quat& root = At(d.current.basis, 0);
  root = (rest.conjugate() * body * rest * root).normalized();
  ClampJoint(m, d, At(m.joint_of, 0), d.current);
  d.current.root = pivot + body * (d.current.root - pivot);
}

// One effector's chain, tip first.
void TurnChain(const Model& m, Data& d, int ei) {
  const Effector& e = At(m.effectors, ei);
  if (e.ccd.empty()) return;
  ForwardKinematics(m, d.current, d.fk);
  if (EffectorError(m, d, ei, d.fk, false) <= m.tolerance) return;
  int own = GatherOwnPoints(m, d, ei);
  for (const Link& link : e.ccd) {
    const int count = link.body ? AddCarriedPins(m, d, ei, link, own) : own;
    const Vec3 omega = LinkTurn(m, d, link, count);
    const int b = At(m.joints, link.joint).bone;
    Quat& basis = At(d.current.basis, b);
    const Quat old = basis;
    basis = (FromRotationVector(omega) * old).normalized();
    ClampJoint(m, d, link.joint, d.current);
    const Quat turn = basis * old.conjugate();  // what the bone did, in its rest frame
    if (!link.body) {
      MoveOwnPoints(m, d, link, own, turn, e);
      continue;
    }
    TurnBody(m, d, link, turn);
    ForwardKinematics(m, d.current, d.fk);
    own = GatherOwnPoints(m, d, ei);
  }
}

}  // namespace

int SolveCcd(const Model& m, Data& d) {
  CcdScratch& c = d.ccd;
  ForwardKinematics(m, d.current, d.fk);
  Cost cost = EvaluateCost(m, d, d.fk, d.buffers.residual.data());
  c.best = d.current;
  Cost best = cost;
  const int limit = m.options.max_iterations;
  int it = 0, escapes = 0, stale = 0;
  while (best.worst > m.tolerance && it < limit) {
    ++it;
    c.previous = d.current;
    for (int e : m.ccd_order) TurnChain(m, d, e);
    ForwardKinematics(m, d.current, d.fk);
    cost = EvaluateCost(m, d, d.fk, d.buffers.residual.data());
    if (!(std::isfinite(cost.task) && PoseFinite(m, d.current))) {  // keep the previous iterate
      std::swap(d.current, c.previous);
      break;
    }
    // Several effectors pull against each other, so a sweep may lose ground
    // before it gains: carry on, keep the best pose, and stop after a few
    // sweeps without a new best.
    if (cost.task < best.task * (1.0 - 1e-12)) {
      c.best = d.current;
      best = cost;
      stale = 0;
      continue;
    }
    if (++stale < 4) continue;
    stale = 0;
    d.current = c.best;
    ForwardKinematics(m, d.current, d.fk);
    cost = best;
    if (best.worst > m.tolerance && escapes < 2 && it < limit) {
      ++it;
      ++escapes;
      d.trial = d.current;
      if (EscapeStall(m, d, 0.0, cost)) {
        c.best = d.current;
        best = cost;
        continue;
      }
    }
    break;
  }
  if (best.task < cost.task || !(cost.task == cost.task)) d.current = c.best;
  ForwardKinematics(m, d.current, d.fk);
  return it;
}

}  // namespace motionkit::ik_internal
