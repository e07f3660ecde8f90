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

void Solver::ClampJoint(const Joint& j, Pose& pose) const {
  if (j.stretch_column >= 0) At(pose.scale, j.bone) = std::clamp(At(pose.scale, j.bone), j.min_scale, j.max_scale);
  if (!j.limited) return;
  Quat& q = At(pose.basis, j.bone);
  const Vec3 a = IkSwingTwist(q);
  const Vec3 c = ClampToLimits(a, j.lo, j.hi);
  if (c != a) q = IkFromSwingTwist(c);
}

// Where each limited joint stands in its limits' coordinates, at the
// iteration's start; nothing is held yet.
void Solver::FindBounds(const Pose& pose) {
  bounds_ = &pose;
  std::fill(frozen_.begin(), frozen_.end(), 0);
  for (std::size_t jo = 0; jo < joints_.size(); ++jo) {
    if (joints_[jo].limited) coordinates_[jo] = IkSwingTwist(At(pose.basis, joints_[jo].bone));
  }
  if (stages_ < 2) return;
  // Recruitment: the later stages' columns are held (and drop out of A).
  bool any = false;
  for (int c = 0; c < cols_; ++c) {
    At(frozen_, c) = columns_[static_cast<std::size_t>(c)].stage > stage_;
    any = any || At(frozen_, c);
  }
  if (any) ZeroHeldColumns();
}

void Solver::ZeroHeldColumns() {
  for (std::size_t ei = 0; ei <= effectors_.size(); ++ei) {
    if (ei == effectors_.size() && !balance_) break;
    Effector& e = ei < effectors_.size() ? effectors_[ei] : com_;
    const std::size_t n = e.columns.size(), rows = static_cast<std::size_t>(e.rows);
    for (std::size_t i = 0; i < n; ++i) {
      if (!At(frozen_, e.columns[i])) continue;
      for (std::size_t r = 0; r < rows; ++r) e.block[i * rows + r] = 0.0;
    }
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
      const double s = At(bounds_->scale, j.bone), du = u[j.stretch_column];
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
  ZeroHeldColumns();
  return true;
}

}  // namespace ik_internal
}  // namespace motionkit
