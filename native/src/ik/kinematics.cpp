// Forward kinematics of the solver's pose, the effectors' errors, the cost and the posture prior.
#include "solver.hpp"

namespace motionkit::ik_internal {

Pose MakePose(const Model& m) {
  Pose p;
  p.basis.assign(static_cast<std::size_t>(m.bones), Quat::Identity());
  p.scale.assign(static_cast<std::size_t>(m.bones), 1.0);
  return p;
}

Fk MakeFk(const Model& m) {
  Fk fk;
  fk.frame.assign(static_cast<std::size_t>(m.bones), Quat::Identity());
  fk.global.assign(static_cast<std::size_t>(m.bones), Quat::Identity());
  fk.head.assign(static_cast<std::size_t>(m.bones), Vec3::Zero());
  fk.tip.assign(static_cast<std::size_t>(m.effector_count), Vec3::Zero());
  fk.moment.assign(static_cast<std::size_t>(m.bones), Vec3::Zero());
  return fk;
}

void PlaceBone(const Model& m, int b, const Pose& pose, Fk& fk) {
  const int p = m.rig.parent(b);
  if (p < 0) {
    At(fk.frame, b) = m.rig.relative(b);
    At(fk.head, b) = b == 0 ? pose.root : m.rig.offset(b);
    At(fk.global, b) = At(fk.frame, b) * At(pose.basis, b);
  } else {
    const PosedBone posed = PoseBone(m.rig, b, At(fk.global, p), At(fk.head, p), At(pose.basis, b), Vec3::Zero(),
                                     At(pose.scale, p));
    At(fk.frame, b) = posed.frame;
    At(fk.head, b) = posed.head;
    At(fk.global, b) = posed.global;
  }
}

namespace {

// Each bone's mass at its midpoint, summed up the tree (parents come first).
void PlaceCentreOfMass(const Model& m, const Pose& pose, Fk& fk) {
  const BalanceModel& bm = m.balance;
  for (int b = 0; b < m.bones; ++b) {
    const Vec3 half = At(fk.global, b) * Vec3(0.0, 0.5 * At(pose.scale, b) * m.rig.length(b), 0.0);
    At(fk.moment, b) = At(bm.mass, b) * (At(fk.head, b) + half);
  }
  Vec3 sum = Vec3::Zero();
  for (int b = m.bones - 1; b >= 0; --b) {
    const int p = m.rig.parent(b);
    if (p >= 0) {
      At(fk.moment, p) += At(fk.moment, b);
    } else {
      sum += At(fk.moment, b);
    }
  }
  fk.com = sum / bm.total_mass;
}

// The balance's rows of the residual (zero while the centre of mass is inside: the level is then
// left out) and its share of the cost.
void EvaluateBalance(const Model& m, const Data& d, const Fk& fk, double* residual, Cost& cost) {
  const Effector& com = m.balance.com;
  Eigen::Map<Vec3> out(residual + com.row);
  Vec3 target;
  out.setZero();
  if (!BalanceTarget(m, d, fk.com, target)) return;
  const Vec3 delta = target - fk.com;
  cost.balance = delta.norm();
  if (BalanceEnforced(m, d)) {
    out = com.sqrt_weight * delta;
    cost.task += com.sqrt_weight * com.sqrt_weight * delta.squaredNorm();
    cost.worst = std::max(cost.worst, cost.balance);
  }
}

}  // namespace

void ForwardKinematics(const Model& m, const Pose& pose, Fk& fk) {
  for (int b : m.order.moving) PlaceBone(m, b, pose, fk);
  for (int e = 0; e < m.effector_count; ++e) {
    const int b = At(m.effectors, e).bone;
    At(fk.tip, e) = At(fk.head, b) + At(fk.global, b) * Vec3(0.0, At(pose.scale, b) * m.rig.length(b), 0.0);
  }
  if (m.balance.enabled) PlaceCentreOfMass(m, pose, fk);
}

bool PoseFinite(const Model& m, const Pose& pose) {
  bool finite = pose.root.allFinite();
  for (const Joint& j : m.joints) {
    finite = finite && At(pose.basis, j.bone).coeffs().allFinite() && std::isfinite(At(pose.scale, j.bone));
  }
  return finite;
}

double EffectorError(const Model& m, const Data& d, int e, const Fk& fk, bool position_only) {
  const Effector& ef = At(m.effectors, e);
  double error = 0.0;
  if (ef.position) error = (At(d.target_position, e) - At(fk.tip, e)).norm();
  if (ef.orientation && !(position_only && ef.position)) {
    const double angle = RotationVector(At(d.target_orientation, e) * At(fk.global, ef.bone).conjugate()).norm();
    error = std::max(error, m.ls * angle);
  }
  return error;
}

Cost EvaluateCost(const Model& m, const Data& d, const Fk& fk, double* residual) {
  Cost cost;
  for (int e = 0; e < m.effector_count; ++e) {
    const Effector& ef = At(m.effectors, e);
    double* r = residual + ef.row;
    double position = 0.0, orientation = 0.0;
    if (ef.position) {
      const Vec3 delta = At(d.target_position, e) - At(fk.tip, e);
      position = delta.norm();
      Eigen::Map<Vec3> out(r);
      out = ef.sqrt_weight * delta;
      r += 3;
    }
    if (ef.orientation) {
      const Vec3 w = RotationVector(At(d.target_orientation, e) * At(fk.global, ef.bone).conjugate());
      orientation = m.ls * w.norm();
      Eigen::Map<Vec3> out(r);
      out = (ef.sqrt_weight * m.ls) * w;
    }
    const double weighted = ef.sqrt_weight * ef.sqrt_weight;
    cost.task += weighted * (position * position + orientation * orientation);
    (ef.pin ? cost.pins : cost.worst) = std::max({ef.pin ? cost.pins : cost.worst, position, orientation});
  }
  if (m.balance.enabled) EvaluateBalance(m, d, fk, residual, cost);
  if (!std::isfinite(cost.task)) cost.worst = kInf;
  return cost;
}

double MeasurePrior(const Model& m, const Data& d, const Pose& pose, double* offset) {
  double sum = 0.0;
  if (m.translate) {
    const Vec3 delta = pose.root - d.reference.root;
    for (int k = 0; k < 3; ++k) offset[k] = delta[k];
    sum += delta.squaredNorm() * m.columns[0].metric;
  }
  for (const Joint& j : m.joints) {
    if (j.axis_count > 0) {
      const Vec3 turn = RotationVector(At(pose.basis, j.bone) * At(d.reference.basis, j.bone).conjugate());
      for (int k = 0; k < j.axis_count; ++k) {
        const double v = turn[j.axes[static_cast<std::size_t>(k)]];
        offset[j.first_column + k] = v;
        sum += StageCost(j.stage) * v * v;
      }
    }
    if (j.stretch_column >= 0) {
      const double s = At(pose.scale, j.bone) - At(d.reference.scale, j.bone);
      offset[j.stretch_column] = s;
      sum += StageCost(j.stage) * s * s;
    }
  }
  return sum;
}

}  // namespace motionkit::ik_internal
