// The clip's second pass (natural defaults, warm-started runs of three frames or more).
//
// A recruitment that comes and goes, or a search that ends a little
// differently from one frame to the next, leaves the first pass with poses
// that pop (an out-of-reach straight arm's roll about its line, a spine that
// joins on one frame and not the next). Each frame is solved again from the
// first pass's corrections low-passed over time (zero phase, Gaussian, sigma
// kSmoothSigma frames; rotations averaged in the tangent space at the frame's
// own), with that pose as the posture prior's reference, towards its targets
// moved by the low-passed shortfall (an unreachable target is asked for what
// the frames around it reached, a reachable one exactly; a single frame that
// fell short counts as met). From there a few steps meet the levels again
// (pins, balance, targets), the posture settles towards the smoothed pose,
// and should the pins not be met, the first pass's pose is the fallback (it
// met them).
#include "solver.hpp"

namespace motionkit::ik_internal {

namespace {

// What the frames around frame i did (its own corrections' low-pass into second_pass's sums): the
// sums' total weight; the root's shift summed, and the latest stage any of them ended in.
double LowPass(const Model& m, Data& d, Eigen::Index i, Eigen::Index n, Vec3& root, int& stage) {
  SecondPass& s = d.second_pass;
  const auto radius = static_cast<Eigen::Index>(std::ceil(3.0 * kSmoothSigma));
  const std::size_t joints = m.joints.size(), effectors = static_cast<std::size_t>(m.effector_count);
  const auto own = static_cast<std::size_t>(i);
  double total = 0.0;
  std::fill(s.rotation_sum.begin(), s.rotation_sum.end(), Vec3::Zero());
  std::fill(s.scale_sum.begin(), s.scale_sum.end(), 0.0);
  std::fill(s.shift_sum.begin(), s.shift_sum.end(), Vec3::Zero());
  // A frame that alone fell short (the frames on both sides met the target) fell short by chance: it
  // counts as met.
  const auto missed = [&](Eigen::Index k, std::size_t e) {
    return k >= 0 && k < n && s.shortfalls[static_cast<std::size_t>(k) * effectors + e].norm() > m.tolerance;
  };
  for (Eigen::Index k = std::max<Eigen::Index>(0, i - radius); k <= std::min(n - 1, i + radius); ++k) {
    const double x = static_cast<double>(k - i) / kSmoothSigma, w = std::exp(-0.5 * x * x);
    const auto at = static_cast<std::size_t>(k);
    total += w;
    root += w * s.root_shifts[at];
    stage = std::max(stage, s.end_stages[at]);
    for (std::size_t jo = 0; jo < joints; ++jo) {
      const Quat& mine = s.corrections[own * joints + jo];
      s.rotation_sum[jo] += w * RotationVector(mine.conjugate() * s.corrections[at * joints + jo]);
      s.scale_sum[jo] += w * s.correction_scales[at * joints + jo];
    }
    for (std::size_t e = 0; e < effectors; ++e) {
      if (missed(k, e) && (missed(k - 1, e) || missed(k + 1, e))) {
        s.shift_sum[e] += w * s.shortfalls[at * effectors + e];
      }
    }
  }
  return total;
}

// The frame starts from the smoothed corrections (also the prior's reference); the first pass's pose
// waits in d.trial as the pins' fallback.
void StartFromSmoothed(const Model& m, Data& d, Eigen::Index i, const Vec3& root, double total) {
  const SecondPass& s = d.second_pass;
  const std::size_t joints = m.joints.size();
  const auto own = static_cast<std::size_t>(i);
  for (std::size_t jo = 0; jo < joints; ++jo) {
    const Joint& j = m.joints[jo];
    const Quat& in = At(d.input.basis, j.bone);
    const Quat& correction = s.corrections[own * joints + jo];
    At(d.trial.basis, j.bone) = (correction * in).normalized();
    At(d.trial.scale, j.bone) = s.correction_scales[own * joints + jo];
    At(d.current.basis, j.bone) = (correction * FromRotationVector(s.rotation_sum[jo] / total) * in).normalized();
    At(d.current.scale, j.bone) = s.scale_sum[jo] / total;
    ClampJoint(m, d, static_cast<int>(jo), d.current);
    At(d.reference.basis, j.bone) = At(d.current.basis, j.bone);
    At(d.reference.scale, j.bone) = At(d.current.scale, j.bone);
  }
  d.trial.root = d.input.root + s.root_shifts[own];
  if (m.translate) d.current.root = d.input.root + root / total;
  d.reference.root = d.current.root;
}

// Targets moved by the low-passed shortfall (their own kept aside in second_pass.aside).
void ShiftTargets(const Model& m, Data& d, double total) {
  SecondPass& s = d.second_pass;
  for (std::size_t e = 0; e < static_cast<std::size_t>(m.effector_count); ++e) {
    const Effector& ef = m.effectors[e];
    s.aside[e] = d.target_position[e];
    if (ef.position && !ef.pin) d.target_position[e] += s.shift_sum[e] / total;
  }
}

}  // namespace

void RecordFirstPassCorrection(const Model& m, Data& d, Eigen::Index i) {
  SecondPass& s = d.second_pass;
  const auto at = static_cast<std::size_t>(i);
  const std::size_t joints = m.joints.size();
  for (std::size_t jo = 0; jo < joints; ++jo) {
    const int b = m.joints[jo].bone;
    s.corrections[at * joints + jo] = (At(d.current.basis, b) * At(d.input.basis, b).conjugate()).normalized();
    s.correction_scales[at * joints + jo] = At(d.current.scale, b);
  }
  s.root_shifts[at] = d.current.root - d.input.root;
  for (int e = 0; e < m.effector_count; ++e) {
    const Effector& ef = At(m.effectors, e);
    Vec3 shortfall = Vec3::Zero();
    if (ef.position && !ef.pin) shortfall = At(d.fk.tip, e) - At(d.target_position, e);
    s.shortfalls[at * static_cast<std::size_t>(m.effector_count) + static_cast<std::size_t>(e)] = shortfall;
  }
  s.end_stages[at] = d.ended_stage;
}

void SolveSmoothed(const Model& m, Data& d, IkClipJob& out, Eigen::Index first, Eigen::Index last) {
  SweepSmoothed(m, d, out, first, last, kSmoothIterations);
  if (!(m.balance.enabled && m.translate)) return;
  LeadHips(d, last - first);
  // From a start led away from the smoothed pose, a target the first pass only just reached takes more
  // steps (UnrealA's walk with a hand target by its hips on Blender 5.2: 1.6e-4 short after 32, 4.7e-6 after
  // 64, met after 128).
  SweepSmoothed(m, d, out, first, last, 4 * kSmoothIterations);
}

// Each frame of the run solved again from its smoothed start (plus the hips' lead) in at most `budget`
// steps before the settling, the hips' move from there recorded.
void SweepSmoothed(const Model& m, Data& d, IkClipJob& out, Eigen::Index first, Eigen::Index last, int budget) {
  SecondPass& s = d.second_pass;
  const Eigen::Index n = last - first;
  d.warm.have_last = false;
  d.warm.have_earlier = false;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Index f = first + i;
    const auto at = static_cast<std::size_t>(i);
    StartFrame(m, d, f);
    int stage = 0;
    Vec3 root = Vec3::Zero();
    const double total = LowPass(m, d, i, n, root, stage);
    StartFromSmoothed(m, d, i, root, total);
    if (m.translate) {
      d.current.root += s.hip_leads[at];
      d.reference.root = d.current.root;
    }
    const Vec3 start = d.current.root;
    ShiftTargets(m, d, total);
    StartStagedSolve(m, d);
    if (!d.fallback.have) RememberPinnedIterate(m, d, d.trial);
    d.trial = d.current;
    d.stage = stage;
    const int iterations = SolveNear(m, d, budget);
    const int more = SettleAndMeetPins(m, d, m.options.max_iterations, true);
    for (std::size_t e = 0; e < static_cast<std::size_t>(m.effector_count); ++e) {
      d.target_position[e] = d.second_pass.aside[e];
    }
    s.hip_moves[at] = d.current.root - start;
    FinishFrame(m, d, out, f, d.iterations[f] + iterations + more);
  }
}

// The smoothed pose can stand outside the support where its binding edge turns within a few frames (a
// pinned swinging foot passing the standing one), and the balance then moves the hips on those frames
// alone, and back: a pop. The hips' moves low-passed (the first pass's Gaussian) and doubled start the
// last sweep ahead of them: a move a few frames wide keeps about half of its peak under the low-pass, so
// doubled, the frames around it lead the hips about as far as it needs, and its own frames need little.
// (On the sweep of tests/blender/test_ik_natural.py: UnrealA's pop 14.4 deg without it, 3.2 with it,
// MixamoT's 12.4 and 3.6.)
void LeadHips(Data& d, Eigen::Index n) {
  SecondPass& s = d.second_pass;
  const auto radius = static_cast<Eigen::Index>(std::ceil(3.0 * kSmoothSigma));
  for (Eigen::Index i = 0; i < n; ++i) {
    Vec3 sum = Vec3::Zero();
    double total = 0.0;
    for (Eigen::Index k = std::max<Eigen::Index>(0, i - radius); k <= std::min(n - 1, i + radius); ++k) {
      const double x = static_cast<double>(k - i) / kSmoothSigma, w = std::exp(-0.5 * x * x);
      sum += w * s.hip_moves[static_cast<std::size_t>(k)];
      total += w;
    }
    s.hip_leads[static_cast<std::size_t>(i)] = kHipLead * sum / total;
  }
}

// Damped Gauss-Newton steps on the levels (the prior is left to the settling
// after), the pins first as in SolveJacobian, the damping raised only when a
// step fails: from a start close to the answer, a few steps whose result
// depends smoothly on where they start (no curvature term, no stall escape,
// no stationarity test).
int SolveNear(const Model& m, Data& d, int budget) {
  int it = 0;
  ForwardKinematics(m, d.current, d.fk);
  Cost cost = EvaluateCost(m, d, d.fk, d.buffers.residual.data());
  d.curvature.weight = 0.0;
  double damp2 = m.lambda * m.lambda;
  while (it < budget && IsUnmet(m, cost)) {
    ++it;
    BuildJacobian(m, d, d.fk);
    ResetBounds(m, d, d.current);
    Cost next;
    if (!StepToTrial(m, d, damp2, 0.0, true, next)) break;
    if (m.priorities && next.pins > m.pin_tolerance) SecondOrderCorrection(m, d, next);
    if (!IsImprovement(m, cost.pins, next.pins, cost.task, next.task)) {
      damp2 *= 10.0;
      if (damp2 > 1e8 * m.lambda * m.lambda) break;
      continue;
    }
    AcceptTrial(d);
    cost = next;
  }
  return it;
}

}  // namespace motionkit::ik_internal
