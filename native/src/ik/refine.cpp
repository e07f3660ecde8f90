// With priorities, the steps besides the loop's: the second-order correction of a trial step, the
// pins' polish after the loop, and the posture's settling in the null space of the levels.
#include "solver.hpp"

namespace motionkit::ik_internal {

namespace {

// Squared distance of a residual from what the levels hold (from zero while not holding).
double DistanceFromHeldResiduals(const Model& m, const Data& d, const double* residual) {
  const StepBuffers& b = d.buffers;
  double sum = 0.0;
  for (int i = 0; i < m.rows; ++i) {
    const double diff = residual[i] - (b.holding ? At(b.held_residual, i) : 0.0);
    sum += diff * diff;
  }
  return sum;
}

// One correction step on the trial (its residual in buffers.residual meanwhile); false when it does
// not bring the trial closer.
bool CorrectTrial(const Model& m, Data& d, Cost& next, bool pins_only) {
  Correction& c = d.correction;
  BuildJacobian(m, d, d.trial_fk);
  ResetBounds(m, d, d.trial);
  const double saved = d.curvature.weight;
  d.curvature.weight = 0.0;
  const bool ok = DirectionWithinBounds(m, d, m.lambda * m.lambda, 0.0);
  d.curvature.weight = saved;
  if (!ok) return false;
  ApplyStep(m, d, d.trial, d.buffers.step.data(), c.pose);
  ForwardKinematics(m, c.pose, c.fk);
  const Cost fixed = EvaluateCost(m, d, c.fk, c.residual.data());
  const bool closer = pins_only ? fixed.pins < next.pins
                                : DistanceFromHeldResiduals(m, d, c.residual.data()) <
                                      DistanceFromHeldResiduals(m, d, d.buffers.residual.data());
  if (!closer) return false;
  std::swap(d.trial, c.pose);
  std::swap(d.trial_fk, c.fk);
  std::copy(c.residual.begin(), c.residual.end(), d.buffers.residual.begin());
  next = fixed;
  return true;
}

}  // namespace

bool StepToTrial(const Model& m, Data& d, double lambda2, double mu, bool clamp, Cost& next) {
  if (!DirectionWithinBounds(m, d, lambda2, mu)) return false;
  if (clamp) ClampStep(m, d.buffers.step.data());
  ApplyStep(m, d, d.current, d.buffers.step.data(), d.trial);
  ForwardKinematics(m, d.trial, d.trial_fk);
  next = EvaluateCost(m, d, d.trial_fk, d.buffers.trial_residual.data());
  return true;
}

// The trial (its residual in buffers.trial_residual, its cost `next`) put back by one or two steps:
// on the pins alone, else on every level (the prior left out), each holding its residual where it is.
// True if it rebuilt the Jacobian.
bool SecondOrderCorrection(const Model& m, Data& d, Cost& next, bool pins_only) {
  bool touched = false;
  d.levels.pins_only = pins_only;
  std::swap(d.buffers.residual, d.buffers.trial_residual);  // the direction works from the trial's residual
  for (int pass = 0; pass < 2 && (next.pins > m.pin_tolerance || !pins_only); ++pass) {
    touched = true;
    if (!CorrectTrial(m, d, next, pins_only)) break;
  }
  std::swap(d.buffers.residual, d.buffers.trial_residual);
  d.levels.pins_only = false;
  return touched;
}

// Gauss-Newton on the pins until they are met to pin_tolerance (curvature leaves them a little off),
// the damping raised tenfold while a step fails (a straight leg is a singular chain: the plain step
// overshoots).
int PolishPins(const Model& m, Data& d, Cost& cost, int budget) {
  int it = 0;
  d.levels.pins_only = true;
  d.curvature.weight = 0.0;
  double damp2 = m.lambda * m.lambda;
  bool fresh = false;
  while (cost.pins > m.pin_tolerance && it < budget) {
    ++it;
    if (!fresh) {
      BuildJacobian(m, d, d.fk);
      ResetBounds(m, d, d.current);
      fresh = true;
    }
    Cost next;
    if (!StepToTrial(m, d, damp2, 0.0, false, next)) break;
    if (!(next.pins < cost.pins)) {
      damp2 *= 10.0;
      if (damp2 > 1e12 * m.lambda * m.lambda) break;
      continue;
    }
    AcceptTrial(d);
    cost = next;
    fresh = false;
    damp2 = std::max(m.lambda * m.lambda, damp2 / 10.0);
  }
  d.levels.pins_only = false;
  return it;
}

// The loop ends when the levels above stand still (met, or as near as an
// unreachable target gets), wherever the prior's capped steps had got to: in
// the null space the levels leave (an out-of-reach straight arm's roll about
// its line, an elbow's swivel) that is a matter of how many steps a frame
// took, and it jumps from one frame to the next. Here the prior goes on as
// the lowest level: its Newton step in its own metric, projected by the levels
// above, each of which holds its residual where it is (an unreachable target
// is not reached for again), then put back onto what they hold by steps on
// them alone. A step is kept when it lowers the prior and costs the levels
// nothing that shows: a target a tenth of the tolerance or a thousandth of its
// shortfall, the balance nothing beyond the tolerance, the pins what the
// polish puts back.
int SettlePosture(const Model& m, Data& d, Cost& cost, int budget) {
  if (!m.separate_prior || !(m.mu > 0.0)) return 0;
  StepBuffers& b = d.buffers;
  const double worst = std::max(cost.worst, m.tolerance) + std::max(0.1 * m.tolerance, 1e-3 * cost.worst);
  const double balance = std::max(cost.balance, m.tolerance);
  const double pins = std::max(cost.pins, 1e-5 * m.size);
  double prior = MeasurePrior(m, d, d.current, b.prior_offset.data());
  std::copy(b.residual.begin(), b.residual.end(), b.held_residual.begin());
  b.holding = true;
  double gain = 1.0;
  int it = 0;
  bool fresh = false;
  d.curvature.weight = 0.0;
  while (it < budget && prior > 1e-16) {
    ++it;
    if (!fresh) {
      BuildJacobian(m, d, d.fk);
      ResetBounds(m, d, d.current);
      fresh = true;
    }
    d.settle_gain = gain;
    Cost next;
    const bool stepped = StepToTrial(m, d, m.lambda * m.lambda, m.mu, true, next);
    d.settle_gain = 0.0;
    if (!stepped) break;
    // Back onto what the levels hold (the step is theirs only to first order).
    SecondOrderCorrection(m, d, next, false);
    fresh = false;
    const double next_prior = MeasurePrior(m, d, d.trial, b.trial_prior_offset.data());
    if (std::isfinite(next_prior) && next_prior < prior && next.worst <= worst && next.pins <= pins &&
        next.balance <= balance) {
      AcceptTrial(d);
      std::swap(b.prior_offset, b.trial_prior_offset);
      cost = next;
      const double gained = prior - next_prior;
      prior = next_prior;
      gain = std::min(1.0, 2.0 * gain);
      if (gained <= 1e-3 * (prior + gained)) break;
    } else {
      gain *= 0.25;
      if (gain < 1e-3) break;
    }
  }
  b.holding = false;
  return it;
}

}  // namespace motionkit::ik_internal
