// Recruitment by stages around the Jacobian methods' loop, and a frame's solve's start and end (the
// posture settled, the pins polished, or the last pose that met them).
#include "solver.hpp"

namespace motionkit::ik_internal {

namespace {

// The later stages join where the last frame's solve had them (its
// corrections on this frame's input), not from the input: a target out of
// the limbs' reach on frame after frame is then met by a spine and hips that
// go on from where they were, rather than found again from the input each
// frame (a search that ends a little differently each time: popping). The
// pinned chains come along, their corrections having gone with the hips'.
void CarryLaterStages(const Model& m, Data& d) {
  if (!(m.options.warm_start && d.warm.have_last)) return;
  d.trial = d.current;
  if (m.translate && m.columns[0].stage > 0) d.trial.root = d.input.root + d.warm.last.root;
  for (int jo = 0; jo < static_cast<int>(m.joints.size()); ++jo) {
    const Joint& j = At(m.joints, jo);
    if (j.stage == 0 && !j.pinned_chain) continue;
    At(d.trial.basis, j.bone) = (At(d.warm.last.basis, j.bone) * At(d.input.basis, j.bone)).normalized();
    At(d.trial.scale, j.bone) = At(d.warm.last.scale, j.bone);
    ClampJoint(m, d, jo, d.trial);
  }
  ForwardKinematics(m, d.trial, d.trial_fk);
  ForwardKinematics(m, d.current, d.fk);
  const Cost carried = EvaluateCost(m, d, d.trial_fk, d.buffers.trial_residual.data());
  const Cost here = EvaluateCost(m, d, d.fk, d.buffers.residual.data());
  if (carried.pins <= std::max(here.pins, PinSlack(m))) AcceptTrial(d);
}

// Pins come first: back to the last iterate that met them, or else to the
// frame's input (which meets them by definition) brought into the limits, if
// that holds them better than where the solve ended (limits are never broken:
// a pin a limit forbids is met as nearly as it allows).
void FallBackToPinnedPose(const Model& m, Data& d, const Cost& cost) {
  d.trial = d.fallback.have ? d.fallback.pose : d.input;
  ClampJoints(m, d, d.trial);
  ForwardKinematics(m, d.trial, d.trial_fk);
  if (d.fallback.have || EvaluateCost(m, d, d.trial_fk, d.buffers.trial_residual.data()).pins < cost.pins) {
    d.current.root = d.trial.root;
    for (const Joint& j : m.joints) {
      At(d.current.basis, j.bone) = At(d.trial.basis, j.bone);
      At(d.current.scale, j.bone) = At(d.trial.scale, j.bone);
    }
  }
  ForwardKinematics(m, d.current, d.fk);
}

// Solves the stage again from d.trial and keeps that end when `keep` accepts its cost; otherwise the pose
// it replaced comes back with its cost. The iterations spent either way.
template <typename Keep>
int SolveFromTrialKeepingIf(const Model& m, Data& d, int budget, Cost& cost, const Keep& keep) {
  d.warm.ended = d.current;
  d.current = d.trial;
  const int iterations = SolveJacobian(m, d, budget);
  ForwardKinematics(m, d.current, d.fk);
  const Cost other = EvaluateCost(m, d, d.fk, d.buffers.residual.data());
  if (keep(other)) {
    cost = other;
    return iterations;
  }
  std::swap(d.current, d.warm.ended);
  ForwardKinematics(m, d.current, d.fk);
  cost = EvaluateCost(m, d, d.fk, d.buffers.residual.data());
  return iterations;
}

// A warm start carries the last frame's posture on; near a joint limit that
// posture can hold the limb in a corner from which a target, reachable from
// elsewhere, is not reached (the limb's solve ends against the limit). The
// frame's input, which the limits always admit, is the other start, kept
// only when it meets the targets: a target out of reach from both stays
// where the warm start left it, so that it does not pop between the two.
int SolveAgainFromInput(const Model& m, Data& d, int budget, Cost& cost) {
  if (!(m.options.warm_start && d.warm.have_last) || m.options.method == IkMethod::kCcd) return 0;
  d.trial = d.input;
  ClampJoints(m, d, d.trial);
  return SolveFromTrialKeepingIf(m, d, budget, cost, [&](const Cost& cold) {
    return cold.worst <= m.tolerance && cold.balance <= m.tolerance &&
           cold.pins <= std::max(cost.pins, m.pin_tolerance);
  });
}

// A hinge (a swing axis ranged over a radian or more, its other swing axis over less) of this stage,
// above an unmet effector, that sits on a bound of its range: the index of that axis, else -1.
int HingeOnBound(const Model& m, const Data& d, const Pose& pose, std::size_t jo) {
  const Joint& j = m.joints[jo];
  if (!j.limited || j.stage > d.stage || !j.free[0] || !j.free[2]) return -1;
  const Vec3& lo = d.limit_lo[jo];
  const Vec3& hi = d.limit_hi[jo];
  const int axis = hi[2] - lo[2] > hi[0] - lo[0] ? 2 : 0, other = 2 - axis;
  if (!(std::isfinite(lo[axis]) && std::isfinite(hi[axis]) && hi[axis] - lo[axis] >= 1.0 &&
        hi[other] - lo[other] < 1.0)) {
    return -1;
  }
  const double a = IkSwingTwist(At(pose.basis, j.bone))[axis];
  if (a > lo[axis] + 1e-6 && a < hi[axis] - 1e-6) return -1;
  for (int e = 0; e < m.effector_count; ++e) {
    if (m.rig.IsAncestor(j.bone, At(m.effectors, e).bone) && EffectorError(m, d, e, d.fk, false) > m.tolerance) {
      return axis;
    }
  }
  return -1;
}

// A limb that starts straight against its hinge's bound (a T pose's elbow at 0) can end short of a
// target its range reaches: the Gauss-Newton step at a straight limb pulls the hinge the way its bound
// forbids and cannot see that the other bend, with the upper limb turned about, meets the target. The
// stage is then solved again from its start with each such hinge bent to the middle of its range, and
// that end is kept if it meets the targets (walk60's rest pose: 3 to 36 mm short of targets at 80 % of
// the arm's reach without it).
int SolveAgainWithHingesBent(const Model& m, Data& d, int budget, Cost& cost) {
  if (m.options.method == IkMethod::kCcd) return 0;
  d.trial = d.input;
  ClampJoints(m, d, d.trial);
  bool any = false;
  for (std::size_t jo = 0; jo < m.joints.size(); ++jo) {
    const int axis = HingeOnBound(m, d, d.trial, jo);
    if (axis < 0) continue;
    const Joint& j = m.joints[jo];
    Vec3 a = IkSwingTwist(At(d.trial.basis, j.bone));
    a[axis] = 0.5 * (d.limit_lo[jo][axis] + d.limit_hi[jo][axis]);
    At(d.trial.basis, j.bone) = IkFromSwingTwist(a);
    ClampJoint(m, d, static_cast<int>(jo), d.trial);
    any = true;
  }
  if (!any) return 0;
  // The targets met: the balance, which the limbs alone may not keep, is the later stages' to restore.
  return SolveFromTrialKeepingIf(m, d, budget, cost, [&](const Cost& bent) {
    return bent.worst <= m.tolerance && bent.pins <= std::max(cost.pins, m.pin_tolerance);
  });
}

}  // namespace

// Recruitment: the joints of stage 0 first; while a target (or the balance)
// stays unmet, the later stages' joints join, from where the input has them,
// so that a reachable target never moves them.
//
// Each stage has max_iterations, less a few kept back (with priorities and
// pins) for the pins' polish at the end: without stages, a frame never takes
// more than max_iterations.
int SolveStaged(const Model& m, Data& d) {
  StartStagedSolve(m, d);
  const int max_iterations = m.options.max_iterations;
  const int reserve = m.priorities && m.pinned ? std::min(16, max_iterations / 4) : 0;
  int iterations = 0, last = 0;
  bool limbs_met = false;  // the first stage met the targets (the balance alone calls the later ones)
  d.warm.start = d.current;
  // The first stage alone, then (if a target or the balance is left unmet)
  // every stage at once: within it each later stage's unknowns cost ten times
  // the last's (StageCost), so the spine still gives before the hips, without
  // a solve per stage and a jump from one to the next.
  for (d.stage = 0; d.stage < m.stages; d.stage = d.stage == 0 && m.stages > 1 ? m.stages - 1 : m.stages) {
    // Warm-started, when the limbs alone ended short of a target, the later stages start from the
    // frame's start, not from where the limbs ended: an out-of-reach target's limb solve crawls along
    // a straight arm against its hinge's bound (held columns, the curvature term switching on and off)
    // and ends wherever its budget runs out, which amplified the last bits of the input 1e4 to 1e5
    // times a frame; the warm start is continuous in them. (Limbs that met the targets, leaving only
    // the balance to the hips, converged: their end is the better start. A cold start, the input, may
    // be a straight arm the limbs' stage had to bend out of its singularity first.)
    if (d.stage > 0) {
      if (m.options.warm_start && d.warm.have_last && !limbs_met) d.current = d.warm.start;
      CarryLaterStages(m, d);
    }
    last = SolveJacobian(m, d, max_iterations - reserve);
    ForwardKinematics(m, d.current, d.fk);
    Cost cost = EvaluateCost(m, d, d.fk, d.buffers.residual.data());
    if (d.stage == 0 && cost.worst > m.tolerance && last < max_iterations - reserve) {
      last += SolveAgainFromInput(m, d, max_iterations - reserve - last, cost);
    }
    // With stages (natural defaults) the retry has a stage's budget of its own: the limb's first solve
    // may have crawled along its bound for all of its own.
    if (m.stages > 1 && d.stage == 0 && cost.worst > m.tolerance) {
      last += SolveAgainWithHingesBent(m, d, max_iterations - reserve, cost);
    }
    iterations += last;
    if (d.stage == 0) limbs_met = cost.worst <= m.tolerance;
    if (cost.worst <= m.tolerance && cost.balance <= m.tolerance) break;
  }
  d.stage = std::min(d.stage, m.stages - 1);  // the stage that ended it: its holds and balance for the polish
  d.ended_stage = d.stage;
  // The first pass settles once later stages have joined (their null space is
  // the large one). Within the limbs' reach it leaves the posture to the warm
  // start: settled arms carried on to the next frames stalled short of
  // targets the arm alone reaches (walk60's lab clip: six frames missed by 1
  // to 3 cm).
  return iterations + SettleAndMeetPins(m, d, std::max(max_iterations - last, reserve), d.stage > 0);
}

void StartStagedSolve(const Model& m, Data& d) {
  d.fallback.have = false;
  d.levels.balance_active = false;
  ForwardKinematics(m, d.current, d.fk);
  const Cost start = EvaluateCost(m, d, d.fk, d.buffers.residual.data());
  if (m.priorities && start.pins <= m.pin_tolerance && start.balance <= m.tolerance) {
    RememberPinnedIterate(m, d, d.current);
  }
}

int SettleAndMeetPins(const Model& m, Data& d, int budget, bool settle) {
  Cost cost = EvaluateCost(m, d, d.fk, d.buffers.residual.data());
  int iterations = 0;
  // Pins first: the settling holds the levels' residuals where they are, so pins left a little off
  // (a loop that ran out of budget) would be held there, and every settling step judged by whether it
  // keeps them no further off than they were, a comparison of two equal numbers once the step's
  // correction has put them back (a coin flip on the last bits).
  if (settle && m.priorities && cost.pins > m.pin_tolerance) iterations += PolishPins(m, d, cost, budget);
  // The settling has a whole frame's budget: cut at half, it ended on its budget on walk60's frames
  // where the arm comes back into reach, the null space left where its steps stopped (a pop of 2.8 deg
  // against 1.3 with the whole budget).
  if (settle) iterations += SettlePosture(m, d, cost, m.options.max_iterations);
  if (m.priorities && cost.pins > m.pin_tolerance) iterations += PolishPins(m, d, cost, budget);
  if (m.priorities && cost.pins > m.pin_tolerance) FallBackToPinnedPose(m, d, cost);
  d.stage = m.stages - 1;
  d.fallback.have = false;
  return iterations;
}

void RememberPinnedIterate(const Model& m, Data& d, const Pose& pose) {
  d.fallback.pose.root = pose.root;
  for (const Joint& j : m.joints) {
    At(d.fallback.pose.basis, j.bone) = At(pose.basis, j.bone);
    At(d.fallback.pose.scale, j.bone) = At(pose.scale, j.bone);
  }
  d.fallback.have = true;
}

}  // namespace motionkit::ik_internal
