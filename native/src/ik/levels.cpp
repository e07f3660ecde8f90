// Strict priorities (Baerlocher and Boulic 2004) in effector space, and recruitment by stages.
#include "solver.hpp"

namespace motionkit::ik_internal {

// Levels in order (1 pins, 2 balance while it is violated, 3 targets), each
// solved, damped, in the null space of the levels above: with A the rows
// already met and R the level's, P = W - W A^T (A W A^T)^-1 A W projects onto
// what leaves A where it is, and the level's increment P J_R^T z is, in the
// rows' coordinates y (u = u0 + W J^T y), z on R and -S_AA^-1 S_AR z on A,
// with (S_RR - S_RA S_AA^-1 S_AR + I) z = r_R, S = J W J^T. So the system
// stays as small as the effectors' rows, and the posture prior (u0) lies
// below every level: whatever it moves, the levels undo first.
bool Solver::SolveLevels() {
  const int m = rows_;
  const auto at = [m](int i, int j) { return static_cast<std::size_t>(i * m + j); };
  double* r = level_r_.data();
  double* t = level_r_.data() + m;
  std::copy(y_.begin(), y_.end(), t);
  std::fill(y_.begin(), y_.end(), 0.0);
  // Once the balance has been a level this frame it stays one (holding the
  // centre of mass where it is when inside): an inequality that comes and
  // goes from one step to the next makes the steps chatter.
  for (int k = 0; balance_ && k < 3; ++k) balance_active_ = balance_active_ || At(e_, com_.row + k) != 0.0;
  const bool violated = balance_active_ && BalanceEnforced();
  int held = 0;
  for (int level = 1; level <= 3; ++level) {
    int count = 0;
    for (const Effector& e : effectors_) {
      if (e.level != level) continue;
      for (int k = 0; k < e.rows; ++k) At(level_rows_, count++) = e.row + k;
    }
    if (level == 2 && violated) {
      for (int k = 0; k < 3; ++k) At(level_rows_, count++) = com_.row + k;
    }
    if (count == 0) continue;
    if (pins_only_ && level > 1) break;
    for (int i = 0; i < count; ++i) {
      const int row = At(level_rows_, i);
      double v = t[row];
      for (int a = 0; a < held; ++a) v -= s_[at(row, At(held_rows_, a))] * At(y_, At(held_rows_, a));
      r[i] = v;
    }
    double* tt = level_t_.data();
    for (int i = 0; i < count; ++i) {
      for (int j = 0; j < count; ++j) tt[i * count + j] = s_[at(At(level_rows_, i), At(level_rows_, j))];
    }
    double* x = level_x_.data();  // count columns of held rows: S_AA^-1 S_AR
    if (held > 0) {
      double* saa = level_a_.data();
      double largest = 0.0;
      for (int a = 0; a < held; ++a) {
        for (int b = 0; b < held; ++b) saa[a * held + b] = s_[at(At(held_rows_, a), At(held_rows_, b))];
        largest = std::max(largest, saa[a * held + a]);
      }
      for (int a = 0; a < held; ++a) saa[a * held + a] += 1e-12 * largest + 1e-300;
      if (!Cholesky(saa, held)) return false;
      for (int j = 0; j < count; ++j) {
        double* col = x + j * held;
        for (int a = 0; a < held; ++a) col[a] = s_[at(At(held_rows_, a), At(level_rows_, j))];
        CholeskySolve(saa, held, col);
      }
      for (int i = 0; i < count; ++i) {
        for (int j = i; j < count; ++j) {
          double v = 0.0;
          for (int a = 0; a < held; ++a) v += s_[at(At(level_rows_, i), At(held_rows_, a))] * x[j * held + a];
          tt[i * count + j] -= v;
          if (j != i) tt[j * count + i] = tt[i * count + j];
        }
      }
    }
    for (int i = 0; i < count; ++i) tt[i * count + i] += 1.0;
    if (!Cholesky(tt, count)) return false;
    CholeskySolve(tt, count, r);
    for (int i = 0; i < count; ++i) At(y_, At(level_rows_, i)) += r[i];
    for (int a = 0; a < held; ++a) {
      double v = 0.0;
      for (int j = 0; j < count; ++j) v += x[j * held + a] * r[j];
      At(y_, At(held_rows_, a)) -= v;
    }
    for (int i = 0; i < count; ++i) At(held_rows_, held++) = At(level_rows_, i);
  }
  return true;
}

// Recruitment: the joints of stage 0 first; while a target (or the balance)
// stays unmet, the later stages' joints join, from where the input has them,
// so that a reachable target never moves them.
//
// Each stage has max_iterations, less a few kept back (with priorities and
// pins) for the pins' polish at the end: without stages, a frame never takes
// more than max_iterations.
int Solver::SolveStaged() {
  Begin();
  const int reserve = priorities_ && pinned_ ? std::min(16, options_.max_iterations / 4) : 0;
  int iterations = 0, last = 0;
  // The first stage alone, then (if a target or the balance is left unmet)
  // every stage at once: within it each later stage's unknowns cost ten times
  // the last's (StageCost), so the spine still gives before the hips, without
  // a solve per stage and a jump from one to the next.
  for (stage_ = 0; stage_ < stages_; stage_ = stage_ == 0 && stages_ > 1 ? stages_ - 1 : stages_) {
    if (stage_ > 0) StartLaterStages();
    last = SolveJacobian(options_.max_iterations - reserve);
    iterations += last;
    Forward(current_, fk_);
    const Cost cost = Evaluate(fk_, e_.data());
    if (cost.worst <= tolerance_ && cost.balance <= tolerance_) break;
  }
  stage_ = std::min(stage_, stages_ - 1);  // the stage that ended it: its holds and balance for the polish
  ended_stage_ = stage_;
  return iterations + Conclude(options_.max_iterations - last, stage_ > 0);
}

void Solver::Begin() {
  kept_ = false;
  balance_active_ = false;
  Forward(current_, fk_);
  const Cost start = Evaluate(fk_, e_.data());
  if (priorities_ && start.pins <= pin_tolerance_ && start.balance <= tolerance_) Keep(current_);
}

int Solver::Conclude(int budget, bool settle) {
  Cost cost = Evaluate(fk_, e_.data());
  int iterations = settle ? SettlePosture(cost, options_.max_iterations / 2) : 0;
  if (priorities_ && cost.pins > pin_tolerance_) iterations += PolishPins(cost, budget);
  if (priorities_ && cost.pins > pin_tolerance_) {
    // Pins come first: back to the last iterate that met them, or else to
    // the frame's input (which meets them by definition) brought into the
    // limits, if that holds them better than where the solve ended (limits
    // are never broken: a pin a limit forbids is met as nearly as it allows).
    trial_ = kept_ ? backup_ : input_;
    for (const Joint& j : joints_) ClampJoint(j, trial_);
    Forward(trial_, trial_fk_);
    if (kept_ || Evaluate(trial_fk_, r_.data()).pins < cost.pins) {
      current_.root = trial_.root;
      for (const Joint& j : joints_) {
        At(current_.basis, j.bone) = At(trial_.basis, j.bone);
        At(current_.scale, j.bone) = At(trial_.scale, j.bone);
      }
    }
    Forward(current_, fk_);
  }
  stage_ = stages_ - 1;
  kept_ = false;
  return iterations;
}

// The later stages join where the last frame's solve had them (its
// corrections on this frame's input), not from the input: a target out of
// the limbs' reach on frame after frame is then met by a spine and hips that
// go on from where they were, rather than found again from the input each
// frame (a search that ends a little differently each time: popping). The
// pinned chains come along, their corrections having gone with the hips'.
void Solver::StartLaterStages() {
  if (!(options_.warm_start && have_solution_)) return;
  trial_ = current_;
  if (translate_ && columns_[0].stage > 0) trial_.root = input_.root + solution_.root;
  for (const Joint& j : joints_) {
    if (j.stage == 0 && !j.pinned_chain) continue;
    At(trial_.basis, j.bone) = (At(solution_.basis, j.bone) * At(input_.basis, j.bone)).normalized();
    At(trial_.scale, j.bone) = At(solution_.scale, j.bone);
    ClampJoint(j, trial_);
  }
  Forward(trial_, trial_fk_);
  Forward(current_, fk_);
  const Cost carried = Evaluate(trial_fk_, r_.data()), here = Evaluate(fk_, e_.data());
  if (carried.pins <= std::max(here.pins, PinSlack())) {
    std::swap(current_, trial_);
    std::swap(fk_, trial_fk_);
    std::swap(e_, r_);
  }
}

void Solver::Keep(const Pose& pose) {
  backup_.root = pose.root;
  for (const Joint& j : joints_) {
    At(backup_.basis, j.bone) = At(pose.basis, j.bone);
    At(backup_.scale, j.bone) = At(pose.scale, j.bone);
  }
  kept_ = true;
}

}  // namespace motionkit::ik_internal
