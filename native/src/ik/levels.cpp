// Strict priorities (Baerlocher and Boulic 2004) in effector space.
//
// Levels in order (1 pins, 2 balance while it is violated, 3 targets), each
// solved, damped, in the null space of the levels above: with A the rows
// already met and R the level's, P = W - W A^T (A W A^T)^-1 A W projects onto
// what leaves A where it is, and the level's increment P J_R^T z is, in the
// rows' coordinates y (u = u0 + W J^T y), z on R and -S_AA^-1 S_AR z on A,
// with (S_RR - S_RA S_AA^-1 S_AR + I) z = r_R, S = J W J^T. So the system
// stays as small as the effectors' rows, and the posture prior (u0) lies
// below every level: whatever it moves, the levels undo first.
#include "solver.hpp"

namespace motionkit::ik_internal {

namespace {

// The level's rows into levels.rows; their count.
int GatherLevelRows(const Model& m, Data& d, int level, bool balance_violated) {
  int count = 0;
  for (const Effector& e : m.effectors) {
    if (e.level != level) continue;
    for (int k = 0; k < e.rows; ++k) At(d.levels.rows, count++) = e.row + k;
  }
  if (level == 2 && balance_violated) {
    for (int k = 0; k < 3; ++k) At(d.levels.rows, count++) = m.balance.com.row + k;
  }
  return count;
}

// With `held` rows above the level's `count`: held_solve = S_AA^-1 S_AR (count columns of held rows),
// and level_gram (S_RR) less S_RA S_AA^-1 S_AR.
bool ProjectOutHeldRows(const Model& m, Data& d, int count, int held) {
  LevelScratch& lv = d.levels;
  const std::vector<double>& s = d.buffers.gram;
  const auto at = [n = m.rows](int i, int j) { return static_cast<std::size_t>(i * n + j); };
  double* saa = lv.held_gram.data();
  double* x = lv.held_solve.data();
  double* tt = lv.level_gram.data();
  double largest = 0.0;
  for (int a = 0; a < held; ++a) {
    for (int b = 0; b < held; ++b) saa[a * held + b] = s[at(At(lv.held_rows, a), At(lv.held_rows, b))];
    largest = std::max(largest, saa[a * held + a]);
  }
  for (int a = 0; a < held; ++a) saa[a * held + a] += 1e-12 * largest + 1e-300;
  if (!Cholesky(saa, held)) return false;
  for (int j = 0; j < count; ++j) {
    double* col = x + j * held;
    for (int a = 0; a < held; ++a) col[a] = s[at(At(lv.held_rows, a), At(lv.rows, j))];
    CholeskySolve(saa, held, col);
  }
  for (int i = 0; i < count; ++i) {
    for (int j = i; j < count; ++j) {
      double v = 0.0;
      for (int a = 0; a < held; ++a) v += s[at(At(lv.rows, i), At(lv.held_rows, a))] * x[j * held + a];
      tt[i * count + j] -= v;
      if (j != i) tt[j * count + i] = tt[i * count + j];
    }
  }
  return true;
}

// One level's increment, in the null space of the `held` rows above it: adds to y.
bool SolveLevel(const Model& m, Data& d, int count, int held, const double* rhs) {
  LevelScratch& lv = d.levels;
  std::vector<double>& y = d.buffers.effector_system;
  const std::vector<double>& s = d.buffers.gram;
  const auto at = [n = m.rows](int i, int j) { return static_cast<std::size_t>(i * n + j); };
  double* r = lv.level_rhs.data();
  for (int i = 0; i < count; ++i) {
    const int row = At(lv.rows, i);
    double v = rhs[row];
    for (int a = 0; a < held; ++a) v -= s[at(row, At(lv.held_rows, a))] * At(y, At(lv.held_rows, a));
    r[i] = v;
  }
  double* tt = lv.level_gram.data();
  for (int i = 0; i < count; ++i) {
    for (int j = 0; j < count; ++j) tt[i * count + j] = s[at(At(lv.rows, i), At(lv.rows, j))];
  }
  if (held > 0 && !ProjectOutHeldRows(m, d, count, held)) return false;
  for (int i = 0; i < count; ++i) tt[i * count + i] += 1.0;
  if (!Cholesky(tt, count)) return false;
  CholeskySolve(tt, count, r);
  for (int i = 0; i < count; ++i) At(y, At(lv.rows, i)) += r[i];
  const double* x = lv.held_solve.data();
  for (int a = 0; a < held; ++a) {
    double v = 0.0;
    for (int j = 0; j < count; ++j) v += x[j * held + a] * r[j];
    At(y, At(lv.held_rows, a)) -= v;
  }
  return true;
}

}  // namespace

bool SolveLevels(const Model& m, Data& d) {
  LevelScratch& lv = d.levels;
  double* rhs = lv.level_rhs.data() + m.rows;
  std::copy(d.buffers.effector_system.begin(), d.buffers.effector_system.end(), rhs);
  std::fill(d.buffers.effector_system.begin(), d.buffers.effector_system.end(), 0.0);
  // Once the balance has been a level this frame it stays one (holding the
  // centre of mass where it is when inside): an inequality that comes and
  // goes from one step to the next makes the steps chatter.
  for (int k = 0; m.balance.enabled && k < 3; ++k) {
    lv.balance_active = lv.balance_active || At(d.buffers.residual, m.balance.com.row + k) != 0.0;
  }
  const bool violated = lv.balance_active && BalanceEnforced(m, d);
  int held = 0;
  for (int level = 1; level <= 3; ++level) {
    const int count = GatherLevelRows(m, d, level, violated);
    if (count == 0) continue;
    if (lv.pins_only && level > 1) break;
    if (!SolveLevel(m, d, count, held, rhs)) return false;
    for (int i = 0; i < count; ++i) At(lv.held_rows, held++) = At(lv.rows, i);
  }
  return true;
}

}  // namespace motionkit::ik_internal
