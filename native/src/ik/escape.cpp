// Out of a stationary point that is not a solution (a straight chain asked to fold, a target straight
// behind): bend the joints that only serve unmet effectors a little about their first free swing
// axis, one way then the other, and keep the bend if it helps. Deterministic.
#include "solver.hpp"

namespace motionkit::ik_internal {

namespace {

// Marks the joints to bend (escape.joint_bent): those above an unmet effector and, on a first pass,
// above no met one; false if there are none.
bool ChooseJointsToBend(const Model& m, Data& d) {
  EscapeScratch& x = d.escape;
  for (int e = 0; e < m.effector_count; ++e) At(x.effector_met, e) = EffectorError(m, d, e, d.fk, false) <= m.tolerance;
  bool any = false;
  for (int pass = 0; pass < 2 && !any; ++pass) {
    for (std::size_t j = 0; j < m.joints.size(); ++j) {
      bool unmet = false, met = false;
      for (int e = 0; e < m.effector_count; ++e) {
        if (!m.rig.IsAncestor(m.joints[j].bone, At(m.effectors, e).bone)) continue;
        (At(x.effector_met, e) ? met : unmet) = true;
      }
      x.joint_bent[j] = unmet && (pass == 1 || !met) && m.joints[j].axis_count > 0 && m.joints[j].stage <= d.stage;
      any = any || x.joint_bent[j];
    }
  }
  return any;
}

// The bend into buffers.direction: every chosen joint about its first free swing axis (X, else Z,
// else Y), less what moves any effector to first order (the projection onto the Jacobian's null
// space), so that it bends the chain without moving the effectors except through the curvature that
// the stationary point hides. Returns its largest turn of a joint.
double BendDirection(const Model& m, Data& d) {
  StepBuffers& b = d.buffers;
  std::fill(b.direction.begin(), b.direction.end(), 0.0);
  for (std::size_t jo = 0; jo < m.joints.size(); ++jo) {
    if (!d.escape.joint_bent[jo]) continue;
    const Joint& j = m.joints[jo];
    const int axis = j.free[0] ? 0 : j.free[2] ? 2 : 1;
    for (int k = 0; k < j.axis_count; ++k) {
      if (j.axes[static_cast<std::size_t>(k)] == axis) At(b.direction, j.first_column + k) = 1.0;
    }
  }
  BuildJacobian(m, d, d.fk);
  Gram(m, d, false, 0.0);
  double trace = 0.0;
  for (int i = 0; i < m.rows; ++i) trace += b.gram[static_cast<std::size_t>(i * m.rows + i)];
  Gram(m, d, false, 1e-9 * trace / m.rows + 1e-300);
  if (Cholesky(b.gram.data(), m.rows)) {
    MultiplyA(m, d, b.direction.data(), b.effector_system.data());
    CholeskySolve(b.gram.data(), m.rows, b.effector_system.data());
    MultiplyAt(m, d, b.effector_system.data(), b.at_y.data());
    double left = 0.0;
    for (int j = 0; j < m.cols; ++j) left = std::max(left, std::abs(At(b.direction, j) - At(b.at_y, j)));
    if (left > 1e-3) {  // else the bend lies in the Jacobian's range: keep it as it is
      for (int j = 0; j < m.cols; ++j) At(b.direction, j) -= At(b.at_y, j);
    }
  }
  double largest = 0.0;
  for (const Joint& j : m.joints) {
    double sum = 0.0;
    for (int k = 0; k < j.axis_count; ++k) {
      const double v = j.axis_scale[static_cast<std::size_t>(k)] * At(b.direction, j.first_column + k);
      sum += v * v;
    }
    largest = std::max(largest, std::sqrt(sum));
  }
  return largest;
}

}  // namespace

bool EscapeStall(const Model& m, Data& d, double mu, Cost& cost) {
  if (m.joints.empty() || m.rows == 0) return false;
  if (!ChooseJointsToBend(m, d)) return false;
  const double largest = BendDirection(m, d);
  if (!(largest > 0.0) || !std::isfinite(largest)) return false;
  StepBuffers& b = d.buffers;
  const double angle = std::min(0.05, m.options.max_step);
  const double prior = m.separate_prior ? 0.0 : mu;  // a prior of its own steers but is not judged
  double* scratch = b.trial_prior_offset.data();
  const double merit = cost.task + (prior > 0.0 ? prior * MeasurePrior(m, d, d.current, scratch) : 0.0);
  for (const double sign : {1.0, -1.0}) {
    for (int j = 0; j < m.cols; ++j) At(b.step, j) = sign * angle / largest * At(b.direction, j);
    ApplyStep(m, d, d.current, b.step.data(), d.trial);
    ForwardKinematics(m, d.trial, d.trial_fk);
    const Cost next = EvaluateCost(m, d, d.trial_fk, b.trial_residual.data());
    const double next_merit = next.task + (prior > 0.0 ? prior * MeasurePrior(m, d, d.trial, scratch) : 0.0);
    if (std::isfinite(next_merit) && next_merit < merit) {
      AcceptTrial(d);
      cost = next;
      return true;
    }
  }
  return false;
}

}  // namespace motionkit::ik_internal
