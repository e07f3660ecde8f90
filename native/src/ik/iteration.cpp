// The Jacobian methods' loop (damped least squares, pseudo-inverse, transpose): each iteration builds
// A at the current pose, finds the method's step within the bounds, and tries it until one is kept
// (raising the damping, adding the curvature, or halving the transpose's step while they fail);
// a standstill that is no solution is escaped from (escape.cpp). Also the steps' common pieces:
// the direction within bounds, clamping, applying and accepting a step.
#include "solver.hpp"

namespace motionkit::ik_internal {

namespace {

// The damping term (lambda^2, or the pseudo-inverse's eps) and its growth (Nielsen).
struct Damping {
  double squared = 0.0, growth = 2.0;
  double floor = 0.0;  // this iteration's least: lambda^2, or eps
  // After a failed step; false once it has grown past any use.
  bool Grow() {
    squared *= growth;
    growth *= 2.0;
    return !(squared > 1e30 * floor);
  }
  // After a kept step, by how well the linear model predicted it.
  void Update(double gain, Curvature& curvature) {
    const double t = 2.0 * gain - 1.0;
    squared = std::max(floor, squared * std::max(1.0 / 3.0, 1.0 - t * t * t));
    growth = 2.0;
    if (gain > 0.75) curvature.weight = curvature.weight > 0.1 ? 0.5 * curvature.weight : 0.0;
  }
};

// What carries from one iteration to the next.
struct LoopState {
  int budget = 0;
  bool dls = false, damped = false;  // the transpose is not damped: its step is halved instead
  Cost cost;
  int it = 0, escapes = 0;
  bool progressed = false;  // some kept step lowered the cost by more than a standstill's share
  Damping damping;
  // The posture prior's offset (prior_offset) and cost at the current pose, kept from the accepted
  // trial that produced them.
  bool have_prior = false;
  double prior = 0.0;
};

// One iteration's: the prior's weight, the merit the step must lower, and the trial.
struct Attempt {
  double mu = 0.0;
  double judged = 0.0;  // the prior's weight in the merit
  double merit = 0.0;
  bool pins_first = false;  // with priorities, the pins are off by more than the slack
  double fraction = 1.0;    // the transpose's share of its direction
  bool have_direction = false;
  double predicted = 0.0;   // the merit's fall the linear model promises (damped methods)
  Cost next;
  double next_merit = 0.0, next_prior = 0.0;
};

enum class Outcome { kAccepted, kStalled, kBroken, kOutOfBudget };

Attempt StartIteration(const Model& m, Data& d, LoopState& s) {
  Attempt t;
  // The prior steers while the targets are far and fades as they are met,
  // so that a reachable target is reached rather than traded for it.
  const double fade = std::min(1.0, s.cost.worst / (1e-2 * m.size));
  t.mu = s.dls ? m.mu * fade * fade : 0.0;
  if (t.mu > 0.0 && !s.have_prior) {
    s.prior = MeasurePrior(m, d, d.current, d.buffers.prior_offset.data());
    s.have_prior = true;
  }
  // With natural defaults the prior is the lowest level: it steers the
  // steps (u0) but a step is judged by the levels above it alone, so that it
  // never trades a target's millimetres for its own comfort.
  t.judged = m.separate_prior ? 0.0 : t.mu;
  t.merit = s.cost.task + (t.judged > 0.0 ? t.judged * s.prior : 0.0);
  t.pins_first = m.priorities && s.cost.pins > PinSlack(m);
  BuildJacobian(m, d, d.fk);
  s.damping.floor = m.lambda * m.lambda;
  if (m.options.method == IkMethod::kPseudoInverse) {  // eps ~ 1e-12 of the system's scale
    double trace = 0.0;
    for (const Block& b : d.blocks) {
      for (double v : b.a) trace += v * v;
    }
    s.damping.floor = 1e-12 * trace / std::max(m.rows, 1) + 1e-300;
  }
  s.damping.squared = std::max(s.damping.squared, s.damping.floor);
  ResetBounds(m, d, d.current);
  return t;
}

enum class Found { kStep, kRetry, kStalled };

// The step to try into buffers.step.
Found FindStep(const Model& m, Data& d, LoopState& s, Attempt& t) {
  StepBuffers& b = d.buffers;
  if (s.damped) {
    if (DirectionWithinBounds(m, d, s.damping.squared, t.mu)) return Found::kStep;
    return s.damping.Grow() ? Found::kRetry : Found::kStalled;
  }
  if (!t.have_direction && !DirectionWithinBounds(m, d, 0.0, 0.0)) return Found::kStalled;
  t.have_direction = true;
  for (int j = 0; j < m.cols; ++j) At(b.step, j) = t.fraction * At(b.direction, j);
  return Found::kStep;
}

// What the linear model promises for the step, for the damping's update.
double PredictedFall(const Model& m, Data& d, const LoopState& s, const Attempt& t) {
  StepBuffers& b = d.buffers;
  MultiplyA(m, d, b.step.data(), b.linear_change.data());
  double model = 0.0;
  for (int i = 0; i < m.rows; ++i) {
    model += (At(b.residual, i) - At(b.linear_change, i)) * (At(b.residual, i) - At(b.linear_change, i));
  }
  if (t.judged > 0.0) {
    for (int j = 0; j < m.cols; ++j) {
      const Column& c = At(m.columns, j);
      const double v = At(b.prior_offset, j) + c.scale * At(b.step, j);
      model += t.mu * c.metric * v * v;
    }
  }
  const double bend_weight = d.curvature.weight;
  if (s.dls && bend_weight > 0.0) {
    for (std::size_t jo = 0; jo < m.joints.size(); ++jo) {
      const Joint& j = m.joints[jo];
      for (int k = 0; k < j.axis_count; ++k) {
        for (int l = 0; l < j.axis_count; ++l) {
          model += bend_weight * At(b.step, j.first_column + k) * d.curvature.joint[jo](k, l) *
                   At(b.step, j.first_column + l);
        }
      }
    }
  }
  return t.merit - model;
}

// The trial pose, its cost and merit.
void TryStep(const Model& m, Data& d, Attempt& t) {
  ApplyStep(m, d, d.current, d.buffers.step.data(), d.trial);
  ForwardKinematics(m, d.trial, d.trial_fk);
  t.next = EvaluateCost(m, d, d.trial_fk, d.buffers.trial_residual.data());
  // The step's curvature took the pins off: one or two steps on the pins
  // alone put them back before it is judged.
  if (m.priorities && t.next.pins > m.pin_tolerance && SecondOrderCorrection(m, d, t.next)) {
    BuildJacobian(m, d, d.fk);  // the correction built the blocks at the trial: back to this iterate
    ResetBounds(m, d, d.current);
  }
  if (t.mu > 0.0) t.next_prior = MeasurePrior(m, d, d.trial, d.buffers.trial_prior_offset.data());
  t.next_merit = t.next.task + (t.judged > 0.0 ? t.judged * t.next_prior : 0.0);
}

// After a failed trial: first let the curvature the linear model left out hold the step back (DLS),
// then raise the damping, or halve the transpose's step. False once nothing is left to try.
bool BackOff(Data& d, LoopState& s, Attempt& t) {
  if (s.dls && d.curvature.weight < 1.0) {
    d.curvature.weight = 1.0;
    return true;
  }
  if (s.damped) return s.damping.Grow();
  t.fraction *= 0.5;
  return !(t.fraction < 1e-8);
}

// Trials until one lowers the merit (or the budget ends, or nothing is left to try).
Outcome TryUntilAccepted(const Model& m, Data& d, LoopState& s, Attempt& t) {
  while (s.it < s.budget) {
    ++s.it;
    const Found found = FindStep(m, d, s, t);
    if (found == Found::kRetry) continue;
    if (found == Found::kStalled) return Outcome::kStalled;
    double largest = 0.0;
    for (double v : d.buffers.step) largest = std::max(largest, std::abs(v));
    if (!(largest > 1e-14)) return Outcome::kStalled;
    ClampStep(m, d.buffers.step.data());
    t.predicted = s.damped ? PredictedFall(m, d, s, t) : 0.0;
    TryStep(m, d, t);
    if (!std::isfinite(t.next_merit)) return Outcome::kBroken;
    if (IsImprovement(m, s.cost.pins, t.next.pins, t.merit, t.next_merit)) {
      if (s.damped && !t.pins_first) {
        s.damping.Update(t.predicted > 0.0 ? (t.merit - t.next_merit) / t.predicted : 1.0, d.curvature);
      }
      return Outcome::kAccepted;
    }
    if (!BackOff(d, s, t)) return Outcome::kStalled;
  }
  return Outcome::kOutOfBudget;
}

// The kept trial becomes the iterate; true if the cost no longer falls (a minimum, met or not).
bool AcceptAttempt(const Model& m, Data& d, LoopState& s, const Attempt& t) {
  AcceptTrial(d);
  s.cost = t.next;
  // A fallback must meet the pins and leave the balance as it may be.
  if (m.priorities && s.cost.pins <= m.pin_tolerance && s.cost.balance <= m.tolerance) {
    RememberPinnedIterate(m, d, d.current);
  }
  if (t.merit - t.next_merit > (s.dls ? kStationary : kCreeping) * t.merit) s.progressed = true;
  if (t.mu > 0.0) {
    std::swap(d.buffers.prior_offset, d.buffers.trial_prior_offset);
    s.prior = t.next_prior;
  }
  s.have_prior = t.mu > 0.0;
  // With recruitment stages too, a warm-started frame's later stages run to a standstill (or their budget):
  // ended at a fall of 1e-5, they stopped wherever their last steps happened to be, a pose carried to the
  // next frame as its warm start and into the second pass's low-pass, whose pops it left larger (the
  // sweep of tests/blender/test_ik_natural.py: MixamoT 13.7 deg against 12.4, RigifyA 7.4 against 6.1).
  const double still = s.dls ? kStationary : kCreeping;
  return !t.pins_first && t.merit - t.next_merit <= still * t.merit;
}

// Out of a standstill that is no solution: EscapeStall, at most twice a frame; true if it moved.
bool EscapeFromStall(const Model& m, Data& d, LoopState& s, double mu) {
  if (s.escapes >= 2 || s.it >= s.budget) return false;
  ++s.it;
  ++s.escapes;
  if (!EscapeStall(m, d, mu, s.cost)) return false;
  s.damping.squared = 0.0;
  s.damping.growth = 2.0;
  d.curvature.weight = 0.0;
  s.have_prior = false;
  return true;
}

}  // namespace

int SolveJacobian(const Model& m, Data& d, int budget) {
  ForwardKinematics(m, d.current, d.fk);
  LoopState s;
  s.cost = EvaluateCost(m, d, d.fk, d.buffers.residual.data());
  s.budget = budget;
  s.dls = m.options.method == IkMethod::kDls;
  s.damped = m.options.method != IkMethod::kTranspose;
  d.curvature.weight = 0.0;
  while (IsUnmet(m, s.cost) && s.it < budget) {
    Attempt t = StartIteration(m, d, s);
    const Outcome outcome = TryUntilAccepted(m, d, s, t);
    if (outcome == Outcome::kBroken) break;  // keep the previous iterate
    if (outcome == Outcome::kAccepted) {
      if (!AcceptAttempt(m, d, s, t)) continue;
      // With priorities a singular chain (a straight arm asked to fold)
      // stands still from the start instead of failing its steps: escape
      // as from a stall. (Standing still after progress is an unreachable
      // target's end: bending then would only take the arm off its line.)
      if (m.priorities && !s.progressed && s.cost.worst > m.tolerance && EscapeFromStall(m, d, s, t.mu)) continue;
      break;
    }
    if (outcome == Outcome::kStalled && EscapeFromStall(m, d, s, t.mu)) continue;
    break;
  }
  return s.it;
}

bool DirectionWithinBounds(const Model& m, Data& d, double lambda2, double mu) {
  const auto direction = [&]() {
    switch (m.options.method) {
      case IkMethod::kDls:
        return DlsStep(m, d, lambda2, mu);
      case IkMethod::kPseudoInverse:
        return PseudoInverseStep(m, d, lambda2);
      case IkMethod::kTranspose:
        return TransposeDirection(m, d);
      case IkMethod::kCcd:
        break;
    }
    return false;
  };
  const double* u = m.options.method == IkMethod::kTranspose ? d.buffers.direction.data() : d.buffers.step.data();
  bool ok = direction();
  while (ok && HoldBoundColumns(m, d, u)) ok = direction();
  return ok;
}

// Scales the step so that no joint turns more than max_step radians, no scale
// changes more than max_step and the root moves at most max_step * ls.
void ClampStep(const Model& m, double* u) {
  double largest = 0.0;
  if (m.translate) largest = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) / m.ls;
  for (const Joint& j : m.joints) {
    double sum = 0.0;
    for (int k = 0; k < j.axis_count; ++k) {
      const double v = j.axis_scale[static_cast<std::size_t>(k)] * u[j.first_column + k];
      sum += v * v;
    }
    largest = std::max(largest, std::sqrt(sum));
    if (j.stretch_column >= 0) largest = std::max(largest, std::abs(j.stretch * u[j.stretch_column]));
  }
  if (largest > m.options.max_step) {
    const double f = m.options.max_step / largest;
    for (int i = 0; i < m.cols; ++i) u[i] *= f;
  }
}

void ApplyStep(const Model& m, const Data& d, const Pose& from, const double* u, Pose& to) {
  if (m.translate) to.root = from.root + Vec3(u[0], u[1], u[2]);
  for (int jo = 0; jo < static_cast<int>(m.joints.size()); ++jo) {
    const Joint& j = At(m.joints, jo);
    const int b = j.bone;
    if (j.axis_count > 0) {
      Vec3 delta = Vec3::Zero();
      for (int k = 0; k < j.axis_count; ++k) {
        const auto slot = static_cast<std::size_t>(k);
        delta[j.axes[slot]] = j.axis_scale[slot] * u[j.first_column + k];
      }
      At(to.basis, b) = (FromRotationVector(delta) * At(from.basis, b)).normalized();
    } else {
      At(to.basis, b) = At(from.basis, b);
    }
    if (j.stretch_column >= 0) At(to.scale, b) = At(from.scale, b) + j.stretch * u[j.stretch_column];
    ClampJoint(m, d, jo, to);
  }
}

void AcceptTrial(Data& d) {
  std::swap(d.current, d.trial);
  std::swap(d.fk, d.trial_fk);
  std::swap(d.buffers.residual, d.buffers.trial_residual);
}

}  // namespace motionkit::ik_internal
