// Forward kinematics of the solver's pose, the effectors' errors, the cost and the regulariser.
#include "solver.hpp"

namespace motionkit::ik_internal {

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
  fk.moment.assign(static_cast<std::size_t>(bones_), Vec3::Zero());
  return fk;
}

void Solver::Place(int b, const Pose& pose, Fk& fk) const {
  const int p = rig_.parent(b);
  if (p < 0) {
    At(fk.frame, b) = rig_.relative(b);
    At(fk.head, b) = b == 0 ? pose.root : rig_.offset(b);
    At(fk.global, b) = At(fk.frame, b) * At(pose.basis, b);
  } else {
    const PosedBone posed = PoseBone(rig_, b, At(fk.global, p), At(fk.head, p), At(pose.basis, b), Vec3::Zero(),
                                     At(pose.scale, p));
    At(fk.frame, b) = posed.frame;
    At(fk.head, b) = posed.head;
    At(fk.global, b) = posed.global;
  }
}

void Solver::Forward(const Pose& pose, Fk& fk) const {
  for (int b : moving_) Place(b, pose, fk);
  for (int e = 0; e < effector_count_; ++e) {
    const int b = At(effectors_, e).bone;
    At(fk.tip, e) = At(fk.head, b) + At(fk.global, b) * Vec3(0.0, At(pose.scale, b) * rig_.length(b), 0.0);
  }
  if (!balance_) return;
  // Each bone's mass at its midpoint, summed up the tree (parents come first).
  for (int b = 0; b < bones_; ++b) {
    const Vec3 half = At(fk.global, b) * Vec3(0.0, 0.5 * At(pose.scale, b) * rig_.length(b), 0.0);
    At(fk.moment, b) = At(mass_, b) * (At(fk.head, b) + half);
  }
  Vec3 sum = Vec3::Zero();
  for (int b = bones_ - 1; b >= 0; --b) {
    const int p = rig_.parent(b);
    if (p >= 0) {
      At(fk.moment, p) += At(fk.moment, b);
    } else {
      sum += At(fk.moment, b);
    }
  }
  fk.com = sum / total_mass_;
}

double Solver::EffectorError(int e, const Fk& fk, bool position_only) const {
  const Effector& ef = At(effectors_, e);
  double error = 0.0;
  if (ef.position) error = (At(target_position_, e) - At(fk.tip, e)).norm();
  if (ef.orientation && !(position_only && ef.position)) {
    const double angle = RotationVector(At(target_orientation_, e) * At(fk.global, ef.bone).conjugate()).norm();
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
      const Vec3 w = RotationVector(At(target_orientation_, e) * At(fk.global, ef.bone).conjugate());
      orientation = ls_ * w.norm();
      Eigen::Map<Vec3> out(r);
      out = (ef.sqrt_weight * ls_) * w;
    }
    const double weighted = ef.sqrt_weight * ef.sqrt_weight;
    cost.task += weighted * (position * position + orientation * orientation);
    (ef.pin ? cost.pins : cost.worst) = std::max({ef.pin ? cost.pins : cost.worst, position, orientation});
  }
  if (balance_) {
    // Zero rows while the centre of mass is inside: the level is then left out.
    Eigen::Map<Vec3> out(residual + com_.row);
    Vec3 target;
    out.setZero();
    if (BalanceTarget(fk.com, target)) {
      const Vec3 d = target - fk.com;
      cost.balance = d.norm();
      if (BalanceEnforced()) {
        out = com_.sqrt_weight * d;
        cost.task += com_.sqrt_weight * com_.sqrt_weight * d.squaredNorm();
        cost.worst = std::max(cost.worst, cost.balance);
      }
    }
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
    sum += d.squaredNorm() * columns_[0].metric;
  }
  for (const Joint& j : joints_) {
    if (j.axis_count > 0) {
      const Vec3 d = RotationVector(At(pose.basis, j.bone) * At(reference_.basis, j.bone).conjugate());
      for (int k = 0; k < j.axis_count; ++k) {
        const double v = d[j.axes[static_cast<std::size_t>(k)]];
        rho[j.first_column + k] = v;
        sum += StageCost(j.stage) * v * v;
      }
    }
    if (j.stretch_column >= 0) {
      const double d = At(pose.scale, j.bone) - At(reference_.scale, j.bone);
      rho[j.stretch_column] = d;
      sum += StageCost(j.stage) * d * d;
    }
  }
  return sum;
}

double Solver::RegulariserCost(const Pose& pose) const {
  double sum = 0.0;
  if (translate_) sum += (pose.root - reference_.root).squaredNorm() * columns_[0].metric;
  for (const Joint& j : joints_) {
    if (j.axis_count > 0) {
      const Vec3 d = RotationVector(At(pose.basis, j.bone) * At(reference_.basis, j.bone).conjugate());
      for (int k = 0; k < j.axis_count; ++k) {
        sum += StageCost(j.stage) * d[j.axes[static_cast<std::size_t>(k)]] * d[j.axes[static_cast<std::size_t>(k)]];
      }
    }
    if (j.stretch_column >= 0) {
      const double d = At(pose.scale, j.bone) - At(reference_.scale, j.bone);
      sum += StageCost(j.stage) * d * d;
    }
  }
  return sum;
}

}  // namespace motionkit::ik_internal
