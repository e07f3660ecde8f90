// The IK solver's internals, shared by the files of native/src/ik/ (the contract is
// native/include/motionkit/ik.hpp; the design is in docs/ik.md).
//
// Kept the way Pinocchio keeps its algorithms: a Model (model.hpp) holds what every frame of a solve
// group shares and is built once; a Data (data.hpp) holds what a run of frames changes, every buffer
// sized once; the algorithms are free functions of (const Model&, Data&), one file per method.
//
// Where to start reading: SolveFrames (frame.cpp) runs a range of frames; each frame is solved by
// SolveCcd (ccd.cpp) or SolveStaged (staging.cpp), which runs the Jacobian methods' loop
// SolveJacobian (iteration.cpp) stage by stage; a step's direction is DlsStep (dls.cpp),
// PseudoInverseStep (pinv.cpp) or TransposeDirection (transpose.cpp).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "../so3.hpp"
#include "data.hpp"
#include "model.hpp"

namespace motionkit::ik_internal {

using internal::Cholesky;
using internal::CholeskySolve;
using internal::FromRotationVector;
using internal::kPi;
using internal::RotationVector;
constexpr double kInf = std::numeric_limits<double>::infinity();
// A DLS step that lowers the cost by less than this fraction ends the frame:
// the targets are out of reach (a reachable one converges quadratically, each
// step taking a large share of what is left). Unreachable frames stop after a
// few steps instead of running to max_iterations.
constexpr double kStationary = 1e-9;
// The transpose and the pseudo-inverse (without the curvature term, which lets
// DLS settle at once) creep by small fractions: only a standstill ends them.
constexpr double kCreeping = 1e-13;
// The clip's second pass low-passes the first's corrections with a Gaussian
// of this many frames (see SolveSmoothed): a pop spread over about five frames.
constexpr double kSmoothSigma = 2.0;
// The second pass's steps a frame, before its settling and polish: from the smoothed pose a reachable
// target takes a few; one that the first pass only just reached (a limb at a limit) takes more.
constexpr int kSmoothIterations = 32;
// With the balance on, the second pass's last sweep starts the hips ahead of where the balance moved them
// on the sweep before: their moves low-passed, times this (see LeadHips).
constexpr double kHipLead = 2.0;
constexpr double kPriorGain = 0.2;
// With priorities, the levels' rows are scaled so that the merit a step must
// lower ranks them as the priorities do (a pin's error costs a hundred times a
// target's, the balance's ten thousand times: much more for the pins and the
// steps' curvature, which takes them a little off, would stall the solve; the
// second-order correction and the polish hold them instead), and so that the
// effector-space damping, the same for every level, is small for both.
constexpr double kPinScale = 10;
constexpr double kBalanceScale = 1e2;
// Recruitment inside a stage: once the hips are free (to keep the balance,
// say), a step still prefers the joints of earlier stages, each stage's
// unknowns costing ten times the last's in the damping and the posture prior.
inline double StageCost(int stage) { return std::pow(10.0, stage); }

template <class T>
T& At(std::vector<T>& v, int i) {
  return v[static_cast<std::size_t>(i)];
}
template <class T>
const T& At(const std::vector<T>& v, int i) {
  return v[static_cast<std::size_t>(i)];
}

inline Vec3 Unit(int axis) { return Vec3::Unit(axis); }

inline bool AllFinite(const std::vector<double>& v) {
  for (double x : v) {
    if (!std::isfinite(x)) return false;
  }
  return true;
}

// A swing's rotation vector is at most pi long, and a half turn has two (x,
// z) for one rotation; a twist of pi is one of -pi. Limits are kept a hair
// inside both, so that what is clamped decomposes back to the same numbers.
constexpr double kSwingReach = kPi - 1e-6;
constexpr double kTwistReach = kPi - 1e-9;

// The nearest coordinates within the limits' box that a rotation can have (limits.cpp).
Vec3 ClampToLimits(const Vec3& a, const Vec3& lo, const Vec3& hi);

inline std::string FrameIndex(Eigen::Index f) { return "frame index " + std::to_string(f); }

inline std::string EffectorName(const IkEffector& e, std::size_t i) {
  return e.name.empty() ? "effector " + std::to_string(i) : "effector '" + e.name + "'";
}

// ---- frame.cpp: the clip's driver.
// Frames [first, last), in order, writing the outputs into `out` (the model's job). Quaternion signs
// run on from the output of frame first - 1 only when first is 0 (else from the input: the frame
// before may be another thread's).
void SolveFrames(const Model& m, Data& d, IkClipJob& out, Eigen::Index first, Eigen::Index last);
std::vector<int> SolvedBones(const Model& m);
RowMatrixXd JacobianAt(const Model& m, Data& d, Eigen::Index f);
void StartFrame(const Model& m, Data& d, Eigen::Index f);
void FinishFrame(const Model& m, Data& d, IkClipJob& out, Eigen::Index f, int iterations);

// ---- second_pass.cpp: the clip's second pass (natural defaults, warm-started runs).
void RecordFirstPassCorrection(const Model& m, Data& d, Eigen::Index i);
void SolveSmoothed(const Model& m, Data& d, IkClipJob& out, Eigen::Index first, Eigen::Index last);
void SweepSmoothed(const Model& m, Data& d, IkClipJob& out, Eigen::Index first, Eigen::Index last, int budget);
void LeadHips(Data& d, Eigen::Index n);
int SolveNear(const Model& m, Data& d, int budget);

// ---- kinematics.cpp
Pose MakePose(const Model& m);
Fk MakeFk(const Model& m);
void PlaceBone(const Model& m, int b, const Pose& pose, Fk& fk);  // its parent placed already
// FK of the bones the unknowns move (the fixed ones are placed once a frame, by StartFrame).
void ForwardKinematics(const Model& m, const Pose& pose, Fk& fk);
bool PoseFinite(const Model& m, const Pose& pose);  // the root and the solved joints
double EffectorError(const Model& m, const Data& d, int e, const Fk& fk, bool position_only);
Cost EvaluateCost(const Model& m, const Data& d, const Fk& fk, double* residual);
// The posture prior at `pose`: writes rho (where each unknown stands from the reference, in its
// column's units) and returns the prior's cost.
double MeasurePrior(const Model& m, const Data& d, const Pose& pose, double* offset);

// ---- limits.cpp
// A limited joint's rotation into its limits (lo, hi: the frame's).
void ClampRotation(const Joint& j, const Vec3& lo, const Vec3& hi, Pose& pose);
// Inline: most joints of a rig are neither limited nor stretched, and every trial step clamps them all.
inline void ClampJoint(const Model& m, const Data& d, int joint, Pose& pose) {
  const Joint& j = m.joints[static_cast<std::size_t>(joint)];
  double& scale = pose.scale[static_cast<std::size_t>(j.bone)];
  if (j.stretch_column >= 0) scale = std::clamp(scale, j.min_scale, j.max_scale);
  if (j.limited) {
    ClampRotation(j, d.limit_lo[static_cast<std::size_t>(joint)], d.limit_hi[static_cast<std::size_t>(joint)], pose);
  }
}
void ClampJoints(const Model& m, const Data& d, Pose& pose);
// Where a step starts: each limited joint's coordinates at `pose`, and only the later recruitment
// stages' columns held.
void ResetBounds(const Model& m, Data& d, const Pose& pose);
// Holds the unknowns that sit on a bound the step `u` would push them past; true if any was newly held.
bool HoldBoundColumns(const Model& m, Data& d, const double* u);

// ---- jacobian.cpp: A, its products and the effector-space Gram matrix.
void BuildJacobian(const Model& m, Data& d, const Fk& fk);
void BuildCurvature(const Model& m, Data& d);
void MultiplyA(const Model& m, const Data& d, const double* x, double* out);   // out (rows) = A x
void MultiplyAt(const Model& m, const Data& d, const double* y, double* out);  // out (columns) = A^T y
void MultiplyW(const Model& m, const Data& d, const double* x, double* out);   // out = W x (DLS)
void Gram(const Model& m, Data& d, bool weighted, double diagonal);            // gram = diagonal I + A W A^T

// ---- The step's direction, one file per method: DLS and the pseudo-inverse write step (u), the
// transpose writes direction. False when it cannot be found.
bool DlsStep(const Model& m, Data& d, double lambda2, double mu);  // dls.cpp
bool PseudoInverseStep(const Model& m, Data& d, double eps);       // pinv.cpp
bool TransposeDirection(const Model& m, Data& d);                  // transpose.cpp

// ---- levels.cpp: strict priorities: y such that u = u0 + W A^T y meets the levels in order, from
// gram = A W A^T and the right-hand side in y (e - A u0).
bool SolveLevels(const Model& m, Data& d);

// ---- iteration.cpp: the Jacobian methods' loop.
int SolveJacobian(const Model& m, Data& d, int budget);  // at most budget iterations
// The method's direction, solved again while it pushes an unknown past a bound (which is then held).
bool DirectionWithinBounds(const Model& m, Data& d, double lambda2, double mu);
void ClampStep(const Model& m, double* u);
void ApplyStep(const Model& m, const Data& d, const Pose& from, const double* u, Pose& to);
// The trial (pose, FK, residual) becomes the current iterate.
void AcceptTrial(Data& d);
inline bool IsUnmet(const Model& m, const Cost& cost) {
  return cost.worst > m.tolerance || cost.pins > m.pin_tolerance;
}
// Whether a step is kept. With priorities the pins come first: while they
// are off by more than the slack a step must bring them closer; within it,
// it must keep them there and lower the merit, in which a pin's error weighs
// a hundred times a target's (curvature takes a step's pins a little off;
// the next step's level 1 and the polish bring them back).
inline double PinSlack(const Model& m) { return std::max(m.pin_tolerance, 1e-3 * m.size); }
inline bool IsImprovement(const Model& m, double pins, double next_pins, double merit, double next_merit) {
  if (!m.priorities) return next_merit < merit;
  return pins > PinSlack(m) ? next_pins < pins : next_pins <= PinSlack(m) && next_merit < merit;
}

// ---- escape.cpp: out of a standstill that is no solution.
bool EscapeStall(const Model& m, Data& d, double mu, Cost& cost);

// ---- refine.cpp: with priorities, the steps besides the loop's.
// The step found from the current pose (clamped if `clamp`) tried: the trial pose, its FK, residual
// and cost. False when no direction is found.
bool StepToTrial(const Model& m, Data& d, double lambda2, double mu, bool clamp, Cost& next);
bool SecondOrderCorrection(const Model& m, Data& d, Cost& next, bool pins_only = true);
int PolishPins(const Model& m, Data& d, Cost& cost, int budget);
int SettlePosture(const Model& m, Data& d, Cost& cost, int budget);

// ---- staging.cpp: recruitment stages around SolveJacobian.
int SolveStaged(const Model& m, Data& d);
// The pose as the pins' fallback: the last iterate that met them.
void RememberPinnedIterate(const Model& m, Data& d, const Pose& pose);
// A frame's solve starts: no fallback yet (unless the start meets the pins), the balance not yet a level.
void StartStagedSolve(const Model& m, Data& d);
// And ends: the posture settled (if `settle`), the pins polished, or else the fallback.
int SettleAndMeetPins(const Model& m, Data& d, int budget, bool settle);

// ---- balance.cpp
void FindSupport(const Model& m, Data& d);
bool BalanceTarget(const Model& m, const Data& d, const Vec3& com, Vec3& target);
void BuildBalanceRows(const Model& m, Data& d, const Fk& fk);
// Balance is a level only on the last stage: the limbs and the spine never move to hold it (a hand
// target would be traded for it); when they leave it unmet, the next stage (the hips) takes over.
inline bool BalanceEnforced(const Model& m, const Data& d) {
  return m.balance.enabled && d.stage == m.stages - 1;
}

// ---- ccd.cpp
int SolveCcd(const Model& m, Data& d);

// Kernels over an effector's column-major block (R rows: 3, or 6 with an
// orientation), R a constant so that the rows' loops unroll.
template <int R>
inline void BlockTimes(const double* a, const int* columns, std::size_t n, const double* x, double* out) {
  std::array<double, R> sum{};
  for (std::size_t i = 0; i < n; ++i, a += R) {
    const double v = x[columns[i]];
    for (int r = 0; r < R; ++r) sum[static_cast<std::size_t>(r)] += a[r] * v;
  }
  for (int r = 0; r < R; ++r) out[r] = sum[static_cast<std::size_t>(r)];
}

template <int R>
inline void BlockTransposeTimes(const double* a, const int* columns, std::size_t n, const double* y, double* out) {
  for (std::size_t i = 0; i < n; ++i, a += R) {
    double v = out[columns[i]];
    for (int r = 0; r < R; ++r) v += a[r] * y[r];
    out[columns[i]] = v;
  }
}

// sum[ra][rb] = sum over the first c columns of x[ra] z[rb].
template <int RA, int RB>
inline void BlockDots(const double* x, const double* z, std::size_t c, std::array<std::array<double, 6>, 6>& sum) {
  std::array<std::array<double, RB>, RA> acc{};
  for (std::size_t i = 0; i < c; ++i, x += RA, z += RB) {
    for (int ra = 0; ra < RA; ++ra) {
      for (int rb = 0; rb < RB; ++rb) {
        acc[static_cast<std::size_t>(ra)][static_cast<std::size_t>(rb)] += x[ra] * z[rb];
      }
    }
  }
  for (int ra = 0; ra < RA; ++ra) {
    for (int rb = 0; rb < RB; ++rb) {
      sum[static_cast<std::size_t>(ra)][static_cast<std::size_t>(rb)] =
          acc[static_cast<std::size_t>(ra)][static_cast<std::size_t>(rb)];
    }
  }
}

}  // namespace motionkit::ik_internal
