// Joint limits: swing-twist coordinates (the public IkSwingTwist and IkFromSwingTwist), clamping a joint
// into its limits, and holding the unknowns that sit on a bound during a step.
#include "solver.hpp"

namespace motionkit {

using ik_internal::FromRotationVector;
using ik_internal::RotationVector;
using ik_internal::Quat;
using ik_internal::Vec3;

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
  const Vec3 swing = RotationVector(q * Quat(tw, 0.0, -ty, 0.0));
  return Vec3(swing.x(), 2.0 * std::atan2(ty, tw), swing.z());
}

Eigen::Quaterniond IkFromSwingTwist(const Eigen::Vector3d& angles) {
  const double h = 0.5 * angles.y();
  return (FromRotationVector(Vec3(angles.x(), 0.0, angles.z())) * Quat(std::cos(h), 0.0, std::sin(h), 0.0)).normalized();
}

namespace ik_internal {

namespace {

// Of the points where the swing disk's circle meets the box's edges, and the box's corners, the
// nearest to (x0, z0) that lies in both (best_x, best_z; false when none does).
bool NearestOnCircle(double x0, double z0, const Vec3& lo, const Vec3& hi, double& best_x, double& best_z) {
  const double r2 = kSwingReach * kSwingReach;
  double best = kInf;
  const auto consider = [&](double x, double z) {
    const double slack = 1e-12;
    if (!(x >= lo.x() - slack && x <= hi.x() + slack && z >= lo.z() - slack && z <= hi.z() + slack)) return;
    if (x * x + z * z > r2 * (1.0 + 1e-12)) return;
    const double dist = (x - x0) * (x - x0) + (z - z0) * (z - z0);
    if (dist < best) {
      best = dist;
      best_x = x;
      best_z = z;
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
  return best != kInf;
}

}  // namespace

// The nearest coordinates within the limits' box that a rotation can have:
// the twist in (-pi, pi), the swing (x, z) in the disk of radius pi. When
// the box's clamp leaves the disk, the nearest point of box and disk lies on
// the circle: the radial projection, or where the circle meets the box's
// edges, or a corner of the box.
Vec3 ClampToLimits(const Vec3& a, const Vec3& lo, const Vec3& hi) {
  Vec3 c = a.cwiseMax(lo).cwiseMin(hi);
  c.y() = std::clamp(c.y(), std::max(lo.y(), -kTwistReach), std::min(hi.y(), kTwistReach));
  const double x0 = c.x(), z0 = c.z();
  if (x0 * x0 + z0 * z0 <= kSwingReach * kSwingReach) return c;
  double bx = x0, bz = z0;
  if (!NearestOnCircle(x0, z0, lo, hi, bx, bz)) {  // no swing meets the limits (Validate refuses them)
    const double r = std::hypot(x0, z0);
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

void ClampRotation(const Joint& j, const Vec3& lo, const Vec3& hi, Pose& pose) {
  Quat& q = At(pose.basis, j.bone);
  const Vec3 a = IkSwingTwist(q);
  const Vec3 c = ClampToLimits(a, lo, hi);
  if (c != a) q = IkFromSwingTwist(c);
}

void ClampJoints(const Model& m, const Data& d, Pose& pose) {
  for (int jo = 0; jo < static_cast<int>(m.joints.size()); ++jo) ClampJoint(m, d, jo, pose);
}

namespace {

// Held columns drop out of every block.
void DropHeldColumns(const Model& m, Data& d) {
  for (std::size_t ei = 0; ei <= m.effectors.size(); ++ei) {
    if (ei == m.effectors.size() && !m.balance.enabled) break;
    const Effector& e = ei < m.effectors.size() ? m.effectors[ei] : m.balance.com;
    std::vector<double>& block = ei < m.effectors.size() ? d.blocks[ei].a : d.balance_block.a;
    const std::size_t n = e.columns.size(), rows = static_cast<std::size_t>(e.rows);
    for (std::size_t i = 0; i < n; ++i) {
      if (!At(d.bounds.held, e.columns[i])) continue;
      for (std::size_t r = 0; r < rows; ++r) block[i * rows + r] = 0.0;
    }
  }
}

}  // namespace

void ResetBounds(const Model& m, Data& d, const Pose& pose) {
  d.bounds.pose = &pose;
  std::fill(d.bounds.held.begin(), d.bounds.held.end(), 0);
  for (std::size_t jo = 0; jo < m.joints.size(); ++jo) {
    if (m.joints[jo].limited) d.bounds.coordinates[jo] = IkSwingTwist(At(pose.basis, m.joints[jo].bone));
  }
  if (m.stages < 2) return;
  // Recruitment: the later stages' columns are held (and drop out of A).
  bool any = false;
  for (int c = 0; c < m.cols; ++c) {
    At(d.bounds.held, c) = At(m.columns, c).stage > d.stage;
    any = any || At(d.bounds.held, c);
  }
  if (any) DropHeldColumns(m, d);
}

// Holding the unknowns that sit on a bound the step `u` would push them past
// (their columns drop out of the Jacobian for this iteration) solves the rest
// of the step for what can move instead of clamping it afterwards. A rotation
// column stands for its own coordinate (X and Z for the swing, Y for the
// twist), to first order.
bool HoldBoundColumns(const Model& m, Data& d, const double* u) {
  bool any = false;
  const auto hold = [&](int column) {
    if (At(d.bounds.held, column)) return;
    At(d.bounds.held, column) = 1;
    any = true;
  };
  for (std::size_t jo = 0; jo < m.joints.size(); ++jo) {
    const Joint& j = m.joints[jo];
    if (j.stretch_column >= 0) {
      const double s = At(d.bounds.pose->scale, j.bone), du = u[j.stretch_column];
      if ((du > 0.0 && s >= j.max_scale) || (du < 0.0 && s <= j.min_scale)) hold(j.stretch_column);
    }
    if (!j.limited) continue;
    const Vec3& a = d.bounds.coordinates[jo];
    const Vec3& lo = d.limit_lo[jo];
    const Vec3& hi = d.limit_hi[jo];
    for (int k = 0; k < j.axis_count; ++k) {
      const int axis = j.axes[static_cast<std::size_t>(k)], column = j.first_column + k;
      const double du = u[column];
      if ((du > 0.0 && a[axis] >= hi[axis] - 1e-9) || (du < 0.0 && a[axis] <= lo[axis] + 1e-9)) hold(column);
    }
  }
  if (!any) return false;
  DropHeldColumns(m, d);
  return true;
}

}  // namespace ik_internal
}  // namespace motionkit
