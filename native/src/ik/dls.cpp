// The Jacobian methods' iteration (damped least squares, pseudo-inverse, transpose): the step, the
// kick out of a standstill, and the frame's loop.
#include "solver.hpp"

namespace motionkit::ik_internal {

// A stationary point that is not a solution (a straight chain asked to fold,
// a target straight behind): bend the joints that only serve unmet effectors
// a little about their first free swing axis, one way then the other, and
// keep the bend if it helps. Deterministic.
bool Solver::Kick(double mu, Cost& cost) {
  if (joints_.empty() || rows_ == 0) return false;
  for (int e = 0; e < effector_count_; ++e) At(met_, e) = EffectorError(e, fk_, false) <= tolerance_;
  bool any = false;
  for (int pass = 0; pass < 2 && !any; ++pass) {
    for (std::size_t j = 0; j < joints_.size(); ++j) {
      bool unmet = false, met = false;
      for (int e = 0; e < effector_count_; ++e) {
        if (!rig_.IsAncestor(joints_[j].bone, At(effectors_, e).bone)) continue;
        (At(met_, e) ? met : unmet) = true;
      }
      kick_[j] = unmet && (pass == 1 || !met) && joints_[j].axis_count > 0 && joints_[j].stage <= stage_;
      any = any || kick_[j];
    }
  }
  if (!any) return false;
  // Every kicked joint about its first free swing axis (X, else Z, else Y),
  // less what moves any effector to first order (the projection onto the
  // Jacobian's null space): what is left bends the chain without moving the
  // effectors except through the curvature that the stationary point hides.
  std::fill(u0_.begin(), u0_.end(), 0.0);
  for (std::size_t jo = 0; jo < joints_.size(); ++jo) {
    if (!kick_[jo]) continue;
    const Joint& j = joints_[jo];
    const int axis = j.free[0] ? 0 : j.free[2] ? 2 : 1;
    for (int k = 0; k < j.axis_count; ++k) {
      if (j.axes[static_cast<std::size_t>(k)] == axis) At(u0_, j.first_column + k) = 1.0;
    }
  }
  BuildJacobian(fk_);
  Gram(false, 0.0);
  double trace = 0.0;
  for (int i = 0; i < rows_; ++i) trace += s_[static_cast<std::size_t>(i * rows_ + i)];
  Gram(false, 1e-9 * trace / rows_ + 1e-300);
  if (Cholesky(s_.data(), rows_)) {
    MultiplyA(u0_.data(), y_.data());
    CholeskySolve(s_.data(), rows_, y_.data());
    MultiplyAt(y_.data(), g_.data());
    double left = 0.0;
    for (int j = 0; j < cols_; ++j) left = std::max(left, std::abs(At(u0_, j) - At(g_, j)));
    if (left > 1e-3) {  // else the kick lies in the Jacobian's range: keep it as it is
      for (int j = 0; j < cols_; ++j) At(u0_, j) -= At(g_, j);
    }
  }
  double largest = 0.0;
  for (const Joint& j : joints_) {
    double sum = 0.0;
    for (int k = 0; k < j.axis_count; ++k) {
      const double v = j.axis_scale[static_cast<std::size_t>(k)] * At(u0_, j.first_column + k);
      sum += v * v;
    }
    largest = std::max(largest, std::sqrt(sum));
  }
  if (!(largest > 0.0) || !std::isfinite(largest)) return false;
  const double angle = std::min(0.05, options_.max_step);
  const double prior = separate_prior_ ? 0.0 : mu;  // a prior of its own steers but is not judged
  const double merit = cost.task + (prior > 0.0 ? prior * RegulariserCost(current_) : 0.0);
  for (const double sign : {1.0, -1.0}) {
    for (int j = 0; j < cols_; ++j) At(u_, j) = sign * angle / largest * At(u0_, j);
    Apply(current_, u_.data(), trial_);
    Forward(trial_, trial_fk_);
    const Cost next = Evaluate(trial_fk_, r_.data());
    const double next_merit = next.task + (prior > 0.0 ? prior * RegulariserCost(trial_) : 0.0);
    if (std::isfinite(next_merit) && next_merit < merit) {
      std::swap(current_, trial_);
      std::swap(fk_, trial_fk_);
      std::swap(e_, r_);
      cost = next;
      return true;
    }
  }
  return false;
}


int Solver::SolveJacobian(int budget) {
  Forward(current_, fk_);
  Cost cost = Evaluate(fk_, e_.data());
  const IkMethod method = options_.method;
  const bool dls = method == IkMethod::kDls, damped = method != IkMethod::kTranspose;
  const int limit = budget;
  int it = 0, kicks = 0;
  bool progressed = false;
  double damp2 = 0.0, nu = 2.0;  // the damping term (lambda^2, or the pseudo-inverse's eps) and its growth
  // Out of a standstill that is no solution: bend (Kick), at most twice a frame; true if it did.
  const auto kick = [&](double mu) {
    if (kicks >= 2 || it >= limit) return false;
    ++it;
    ++kicks;
    if (!Kick(mu, cost)) return false;
    damp2 = 0.0;
    nu = 2.0;
    bend_weight_ = 0.0;
    return true;
  };
  bend_weight_ = 0.0;
  // The regulariser's residual and cost at current_, kept from the accepted
  // trial that produced it.
  bool have_rho = false;
  double regulariser = 0.0, trial_regulariser = 0.0;
  while (Unmet(cost) && it < limit) {
    // The regulariser steers while the targets are far and fades as they are
    // met, so that a reachable target is reached rather than traded for it.
    const double fade = std::min(1.0, cost.worst / (1e-2 * size_));
    const double mu = dls ? mu_ * fade * fade : 0.0;
    if (mu > 0.0 && !have_rho) {
      regulariser = Regulariser(current_, rho_.data());
      have_rho = true;
    }
    // With natural defaults the prior is the lowest level: it steers the
    // steps (u0) but a step is judged by the levels above it alone, so that it
    // never trades a target's millimetres for its own comfort.
    const double judged = separate_prior_ ? 0.0 : mu;
    const double merit = cost.task + (judged > 0.0 ? judged * regulariser : 0.0);
    BuildJacobian(fk_);
    double floor2 = lambda_ * lambda_;
    if (method == IkMethod::kPseudoInverse) {  // eps ~ 1e-12 of the system's scale
      double trace = 0.0;
      for (const Effector& e : effectors_) {
        for (double v : e.block) trace += v * v;
      }
      floor2 = 1e-12 * trace / std::max(rows_, 1) + 1e-300;
    }
    damp2 = std::max(damp2, floor2);
    FindBounds();
    bool have_direction = false, accepted = false, stalled = false, broken = false, pins_first = false;
    double fraction = 1.0, next_merit = 0.0;
    Cost next;
    while (it < limit) {
      ++it;
      if (!damped) {
        if (!have_direction) {
          bool ok = Direction(0.0, 0.0);
          while (ok && Freeze(u0_.data())) ok = Direction(0.0, 0.0);
          if (!ok) {
            stalled = true;
            break;
          }
        }
        have_direction = true;
        for (int j = 0; j < cols_; ++j) At(u_, j) = fraction * At(u0_, j);
      } else {
        bool ok = Direction(damp2, mu);
        while (ok && Freeze(u_.data())) ok = Direction(damp2, mu);
        if (!ok) {
          damp2 *= nu;
          nu *= 2.0;
          if (damp2 > 1e30 * floor2) {
            stalled = true;
            break;
          }
          continue;
        }
      }
      double largest = 0.0;
      for (double v : u_) largest = std::max(largest, std::abs(v));
      if (!(largest > 1e-14)) {
        stalled = true;
        break;
      }
      ClampStep(u_.data());
      // What the linear model promises, for the damping's update.
      double predicted = 0.0;
      if (damped) {
        MultiplyA(u_.data(), h_.data());
        double model = 0.0;
        for (int i = 0; i < rows_; ++i) model += (At(e_, i) - At(h_, i)) * (At(e_, i) - At(h_, i));
        if (judged > 0.0) {
          for (int j = 0; j < cols_; ++j) {
            const Column& c = columns_[static_cast<std::size_t>(j)];
            const double v = At(rho_, j) + c.scale * At(u_, j);
            model += mu * c.metric * v * v;
          }
        }
        if (dls && bend_weight_ > 0.0) {
          for (std::size_t jo = 0; jo < joints_.size(); ++jo) {
            const Joint& j = joints_[jo];
            for (int k = 0; k < j.axis_count; ++k) {
              for (int l = 0; l < j.axis_count; ++l) {
                model += bend_weight_ * At(u_, j.first_column + k) * bend_[jo](k, l) * At(u_, j.first_column + l);
              }
            }
          }
        }
        predicted = merit - model;
      }
      Apply(current_, u_.data(), trial_);
      Forward(trial_, trial_fk_);
      next = Evaluate(trial_fk_, r_.data());
      // A second-order correction: the step's curvature took the pins off;
      // one or two steps on the pins alone put them back before it is judged.
      if (priorities_ && next.pins > pin_tolerance_ && Restore(next)) {
        BuildJacobian(fk_);  // the blocks are the trial's now: back to this iterate's
        FindBounds();
        bend_ready_ = false;
      }
      if (mu > 0.0) trial_regulariser = Regulariser(trial_, trial_rho_.data());
      next_merit = next.task + (judged > 0.0 ? judged * trial_regulariser : 0.0);
      if (!std::isfinite(next_merit)) {
        broken = true;
        break;
      }
      pins_first = priorities_ && cost.pins > PinSlack();
      if (Better(cost.pins, next.pins, merit, next_merit)) {
        accepted = true;
        if (damped && !pins_first) {  // Nielsen's update
          const double gain = predicted > 0.0 ? (merit - next_merit) / predicted : 1.0;
          const double t = 2.0 * gain - 1.0;
          damp2 = std::max(floor2, damp2 * std::max(1.0 / 3.0, 1.0 - t * t * t));
          nu = 2.0;
          if (gain > 0.75) bend_weight_ = bend_weight_ > 0.1 ? 0.5 * bend_weight_ : 0.0;
        }
        break;
      }
      if (dls && bend_weight_ < 1.0) {
        bend_weight_ = 1.0;  // first let the curvature the linear model left out hold the step back
      } else if (damped) {
        damp2 *= nu;
        nu *= 2.0;
        if (damp2 > 1e30 * floor2) {
          stalled = true;
          break;
        }
      } else {
        fraction *= 0.5;
        if (fraction < 1e-8) {
          stalled = true;
          break;
        }
      }
    }
    if (broken) break;  // keep the previous iterate
    if (accepted) {
      std::swap(current_, trial_);
      std::swap(fk_, trial_fk_);
      std::swap(e_, r_);
      cost = next;
      // A fallback must meet the pins and leave the balance as it may be.
      if (priorities_ && cost.pins <= pin_tolerance_ && cost.balance <= tolerance_) Keep(current_);
      if (merit - next_merit > (dls ? kStationary : kCreeping) * merit) progressed = true;
      if (mu > 0.0) {
        std::swap(rho_, trial_rho_);
        regulariser = trial_regulariser;
      }
      have_rho = mu > 0.0;
      // A minimum that does not meet the targets: the cost no longer falls.
      const double still = dls ? (stages_ > 1 && progressed && have_solution_ ? kSettled : kStationary) : kCreeping;
      if (!pins_first && merit - next_merit <= still * merit) {
        // With priorities a singular chain (a straight arm asked to fold)
        // stands still from the start instead of failing its steps: bend it as
        // a stall would. (Standing still after progress is an unreachable
        // target's end: bending then would only take the arm off its line.)
        if (priorities_ && !progressed && cost.worst > tolerance_ && kick(mu)) {
          have_rho = false;
          continue;
        }
        break;
      }
      continue;
    }
    if (stalled && kick(mu)) {
      have_rho = false;
      continue;
    }
    break;
  }
  return it;
}

bool Solver::Restore(Cost& next, bool pins_only) {
  bool touched = false;
  pins_only_ = pins_only;
  std::swap(e_, r_);  // Direction works from e_: the trial's residual
  for (int pass = 0; pass < 2 && (next.pins > pin_tolerance_ || !pins_only); ++pass) {
    touched = true;
    BuildJacobian(trial_fk_);
    FindBounds(trial_);
    const double saved = bend_weight_;
    bend_weight_ = 0.0;
    bool ok = Direction(lambda_ * lambda_, 0.0);
    while (ok && Freeze(u_.data())) ok = Direction(lambda_ * lambda_, 0.0);
    bend_weight_ = saved;
    if (!ok) break;
    Apply(trial_, u_.data(), best_);
    Forward(best_, fk_scratch_);
    const Cost fixed = Evaluate(fk_scratch_, h_scratch_.data());
    if (!(pins_only ? fixed.pins < next.pins : Drift(h_scratch_.data()) < Drift(e_.data()))) break;
    std::swap(trial_, best_);
    std::swap(trial_fk_, fk_scratch_);
    std::copy(h_scratch_.begin(), h_scratch_.end(), e_.begin());
    next = fixed;
  }
  std::swap(e_, r_);
  pins_only_ = false;
  return touched;
}

double Solver::Drift(const double* residual) const {
  double sum = 0.0;
  for (int i = 0; i < rows_; ++i) {
    const double d = residual[i] - (holding_ ? At(hold_, i) : 0.0);
    sum += d * d;
  }
  return sum;
}

int Solver::PolishPins(Cost& cost, int budget) {
  int it = 0;
  pins_only_ = true;
  bend_weight_ = 0.0;
  // Gauss-Newton on the pins, the damping raised tenfold while a step fails
  // (a straight leg is a singular chain: the plain step overshoots).
  double damp2 = lambda_ * lambda_;
  bool fresh = false;
  while (cost.pins > pin_tolerance_ && it < budget) {
    ++it;
    if (!fresh) {
      BuildJacobian(fk_);
      FindBounds();
      fresh = true;
    }
    bool ok = Direction(damp2, 0.0);
    while (ok && Freeze(u_.data())) ok = Direction(damp2, 0.0);
    if (!ok) break;
    Apply(current_, u_.data(), trial_);
    Forward(trial_, trial_fk_);
    const Cost next = Evaluate(trial_fk_, r_.data());
    if (!(next.pins < cost.pins)) {
      damp2 *= 10.0;
      if (damp2 > 1e12 * lambda_ * lambda_) break;
      continue;
    }
    std::swap(current_, trial_);
    std::swap(fk_, trial_fk_);
    std::swap(e_, r_);
    cost = next;
    fresh = false;
    damp2 = std::max(lambda_ * lambda_, damp2 / 10.0);
  }
  pins_only_ = false;
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
int Solver::SettlePosture(Cost& cost, int budget) {
  if (!separate_prior_ || !(mu_ > 0.0)) return 0;
  const double worst = std::max(cost.worst, tolerance_) + std::max(0.1 * tolerance_, 1e-3 * cost.worst);
  const double balance = std::max(cost.balance, tolerance_);
  const double pins = std::max(cost.pins, 1e-5 * size_);
  double prior = Regulariser(current_, rho_.data());
  std::copy(e_.begin(), e_.end(), hold_.begin());
  holding_ = true;
  double gain = 1.0;
  int it = 0;
  bool fresh = false;
  bend_weight_ = 0.0;
  while (it < budget && prior > 1e-16) {
    ++it;
    if (!fresh) {
      BuildJacobian(fk_);
      FindBounds();
      fresh = true;
    }
    settle_gain_ = gain;
    bool ok = Direction(lambda_ * lambda_, mu_);
    while (ok && Freeze(u_.data())) ok = Direction(lambda_ * lambda_, mu_);
    settle_gain_ = 0.0;
    if (!ok) break;
    ClampStep(u_.data());
    Apply(current_, u_.data(), trial_);
    Forward(trial_, trial_fk_);
    Cost next = Evaluate(trial_fk_, r_.data());
    Restore(next, false);  // back onto what the levels hold (the step is theirs only to first order)
    fresh = false;
    const double next_prior = Regulariser(trial_, trial_rho_.data());
    if (std::isfinite(next_prior) && next_prior < prior && next.worst <= worst && next.pins <= pins &&
        next.balance <= balance) {
      std::swap(current_, trial_);
      std::swap(fk_, trial_fk_);
      std::swap(e_, r_);
      std::swap(rho_, trial_rho_);
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
  holding_ = false;
  return it;
}

}  // namespace motionkit::ik_internal
