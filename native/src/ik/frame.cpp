// The clip's driver: a range of frames solved in order, each started (inputs, targets, limits and the
// warm start in) and finished (outputs and errors out, the correction kept for the next frame).
#include "solver.hpp"

namespace motionkit::ik_internal {

namespace {

void LoadInput(const Model& m, Data& d, Eigen::Index f) {
  const Eigen::Index rot_row = m.job.input_rotations.rows() == 1 ? 0 : f;
  const Eigen::Index loc_row = m.job.input_locations.rows() == 1 ? 0 : f;
  for (int b : m.order.needed) {
    At(d.input.basis, b) = QuatAt(m.job.input_rotations, rot_row, b).normalized();
    At(d.input.scale, b) = 1.0;
  }
  if (m.bones > 0) {
    d.input.root = m.rig.offset(0) + m.rig.relative(0) * m.job.input_locations.row(loc_row).transpose();
  }
}

// Every pose of the frame has the input's basis, scale and root on the bones no unknown moves.
void PlaceFixedBones(const Model& m, Data& d) {
  for (int b : m.order.fixed) {
    PlaceBone(m, b, d.input, d.fk);
    At(d.trial_fk.frame, b) = At(d.fk.frame, b);
    At(d.trial_fk.global, b) = At(d.fk.global, b);
    At(d.trial_fk.head, b) = At(d.fk.head, b);
  }
}

// Soft limits take in this frame's input.
void WidenSoftLimits(const Model& m, Data& d) {
  for (std::size_t jo = 0; jo < m.joints.size(); ++jo) {
    const Joint& j = m.joints[jo];
    if (!(j.soft[0] || j.soft[1] || j.soft[2])) continue;
    const Vec3 a = IkSwingTwist(At(d.input.basis, j.bone));
    for (int k = 0; k < 3; ++k) {
      if (!j.soft[static_cast<std::size_t>(k)]) continue;
      d.limit_lo[jo][k] = std::min(j.lo[k], a[k]);
      d.limit_hi[jo][k] = std::max(j.hi[k], a[k]);
    }
  }
}

// The targets; pins hold where this frame's input pose has them (d.fk holds it).
void LoadTargets(const Model& m, Data& d, Eigen::Index f) {
  for (int e = 0; e < m.effector_count; ++e) {
    const Effector& ef = At(m.effectors, e);
    if (ef.pin) {
      At(d.target_position, e) = At(d.fk.tip, e);
      At(d.target_orientation, e) = At(d.fk.global, ef.bone);
      continue;
    }
    const int id = At(m.ids, e);
    if (ef.position) At(d.target_position, e) = m.job.target_positions.row(f).segment<3>(3 * id).transpose();
    if (ef.orientation) {
      const double* q = m.job.target_orientations.data() + f * m.job.target_orientations.outerStride() + 4 * id;
      At(d.target_orientation, e) = Quat(q[0], q[1], q[2], q[3]).normalized();
    }
  }
}

// A frame starts from the last correction on top of its own input, so that
// an animated input plays on under the IK (a walking leg that no target
// needs follows its walk) instead of being dragged from the last frame's
// pose; with the previous frame as reference, the posture prior pulls
// towards that too.
void StartFromLastCorrection(const Model& m, Data& d) {
  const bool warm = m.options.warm_start && d.warm.have_last;
  for (int b : m.order.needed) {
    At(d.current.basis, b) = At(d.input.basis, b);
    At(d.current.scale, b) = 1.0;
  }
  d.current.root = warm && m.translate ? Vec3(d.input.root + d.warm.last.root) : d.input.root;
  const bool previous = m.options.reference == IkReference::kPrevious && d.warm.have_last;
  d.reference.root = previous ? Vec3(d.input.root + d.warm.last.root) : d.input.root;
  for (int jo = 0; jo < static_cast<int>(m.joints.size()); ++jo) {
    const Joint& j = At(m.joints, jo);
    const Quat& in = At(d.input.basis, j.bone);
    if (warm) {
      At(d.current.basis, j.bone) = (At(d.warm.last.basis, j.bone) * in).normalized();
      At(d.current.scale, j.bone) = At(d.warm.last.scale, j.bone);
    }
    ClampJoint(m, d, jo, d.current);
    At(d.reference.basis, j.bone) = previous ? (At(d.warm.last.basis, j.bone) * in).normalized() : in;
    At(d.reference.scale, j.bone) = previous ? At(d.warm.last.scale, j.bone) : 1.0;
  }
  d.trial = d.current;
}

// Targets that move smoothly move the solution smoothly: carried on as the
// last two frames' corrections went, the start is often close enough for
// one step to meet the tolerance (from the last correction alone, two).
// Kept only when it starts nearer the targets.
void TryExtrapolatedStart(const Model& m, Data& d) {
  const WarmStart& w = d.warm;
  for (int jo = 0; jo < static_cast<int>(m.joints.size()); ++jo) {
    const Joint& j = At(m.joints, jo);
    const Quat& last = At(w.last.basis, j.bone);
    At(d.trial.basis, j.bone) =
        (last * (At(w.earlier.basis, j.bone).conjugate() * last) * At(d.input.basis, j.bone)).normalized();
    At(d.trial.scale, j.bone) = 2.0 * At(w.last.scale, j.bone) - At(w.earlier.scale, j.bone);
    ClampJoint(m, d, jo, d.trial);
  }
  if (m.translate) d.trial.root = d.input.root + 2.0 * w.last.root - w.earlier.root;
  ForwardKinematics(m, d.current, d.fk);
  ForwardKinematics(m, d.trial, d.trial_fk);
  const Cost extrapolated = EvaluateCost(m, d, d.trial_fk, d.buffers.trial_residual.data());
  const Cost last = EvaluateCost(m, d, d.fk, d.buffers.residual.data());
  if (extrapolated.task < last.task) std::swap(d.current, d.trial);
  d.trial = d.current;
}

// Recruitment: the later stages start from the input (the first stage
// holds them there), and so do the pinned chains, whose last correction
// went with the hips' (the input meets the pins by definition).
void StartLaterStagesFromInput(const Model& m, Data& d) {
  if (m.translate && m.columns[0].stage > 0) d.current.root = d.input.root;
  for (int jo = 0; jo < static_cast<int>(m.joints.size()); ++jo) {
    const Joint& j = At(m.joints, jo);
    if (j.stage == 0 && !j.pinned_chain) continue;
    At(d.current.basis, j.bone) = At(d.input.basis, j.bone);
    At(d.current.scale, j.bone) = 1.0;
    ClampJoint(m, d, jo, d.current);
  }
  d.trial = d.current;
}

void WriteOutputs(const Model& m, const Data& d, IkClipJob& out, Eigen::Index f) {
  const Eigen::Index rot_row = m.job.input_rotations.rows() == 1 ? 0 : f;
  double* const out_row = out.rotations.data() + f * out.rotations.outerStride();
  const double* const in_row = m.job.input_rotations.data() + rot_row * m.job.input_rotations.outerStride();
  for (const Joint& j : m.joints) {
    const int b = j.bone;
    double* q_out = out_row + 4 * b;
    const double* in = in_row + 4 * b;
    Quat q = At(d.current.basis, b);
    // Continuous with the previous frame's output (the input's on the first of the run).
    const double* near = f > d.first ? q_out - out.rotations.outerStride() : in;
    if (q.w() * near[0] + q.x() * near[1] + q.y() * near[2] + q.z() * near[3] < 0.0) q.coeffs() = -q.coeffs();
    q_out[0] = q.w();
    q_out[1] = q.x();
    q_out[2] = q.y();
    q_out[3] = q.z();
    out.scales(f, b) = At(d.current.scale, b);
  }
  if (m.translate) {
    out.root_locations.row(f) = (m.rig.relative(0).conjugate() * (d.current.root - m.rig.offset(0))).transpose();
  }
}

// The frame's correction becomes the last, the last the earlier.
void RememberCorrection(const Model& m, Data& d) {
  WarmStart& w = d.warm;
  w.earlier.root = w.last.root;
  for (const Joint& j : m.joints) {
    At(w.earlier.basis, j.bone) = At(w.last.basis, j.bone);
    At(w.earlier.scale, j.bone) = At(w.last.scale, j.bone);
  }
  w.have_earlier = w.have_last;
  w.last.root = d.current.root - d.input.root;
  for (const Joint& j : m.joints) {
    At(w.last.basis, j.bone) = (At(d.current.basis, j.bone) * At(d.input.basis, j.bone).conjugate()).normalized();
    At(w.last.scale, j.bone) = At(d.current.scale, j.bone);
  }
  w.have_last = true;
}

}  // namespace

void StartFrame(const Model& m, Data& d, Eigen::Index f) {
  LoadInput(m, d, f);
  PlaceFixedBones(m, d);
  if (m.pinned) ForwardKinematics(m, d.input, d.fk);
  if (m.balance.enabled) FindSupport(m, d);
  WidenSoftLimits(m, d);
  LoadTargets(m, d, f);
  StartFromLastCorrection(m, d);
  // Not with the prior a level of its own (natural defaults): there a frame's solve leaves its null
  // space (a straight arm's roll, the spine's share) where its steps happened to end, and carrying
  // on along the last two frames' difference doubles each frame what the last bits of the input made
  // of it; on walk60 a nudge of 1e-12 changed the keys by tens of degrees, and by 2e-8 without it.
  if (m.options.warm_start && d.warm.have_last && d.warm.have_earlier && !m.joints.empty() && !m.separate_prior) {
    TryExtrapolatedStart(m, d);
  }
  if (m.stages > 1 && m.options.method != IkMethod::kCcd) StartLaterStagesFromInput(m, d);
  // A step writes the unknowns' joints alone, so every pose a trial is swapped in from must hold this
  // frame's start on the other bones (the other arm, the head, the fingers): the centre of mass, which the
  // balance weighs, is computed from every bone, and a buffer holding another frame's rotations there
  // would make the balance depend on how many corrections the frame kept.
  d.correction.pose = d.current;
  d.fallback.pose = d.current;
}

void FinishFrame(const Model& m, Data& d, IkClipJob& out, Eigen::Index f, int iterations) {
  // Never hand back a non-finite value: fall back on the frame's start.
  if (!PoseFinite(m, d.current)) {
    StartFrame(m, d, f);
    ForwardKinematics(m, d.current, d.fk);
  }
  for (int e = 0; e < m.effector_count; ++e) out.errors(f, At(m.ids, e)) = EffectorError(m, d, e, d.fk, true);
  d.iterations[f] = iterations;
  WriteOutputs(m, d, out, f);
  RememberCorrection(m, d);
}

void SolveFrames(const Model& m, Data& d, IkClipJob& out, Eigen::Index first, Eigen::Index last) {
  d.first = first;
  const bool smooth = m.separate_prior && m.options.warm_start && last - first >= 3;
  if (smooth) {
    SecondPass& s = d.second_pass;
    const auto n = static_cast<std::size_t>(last - first), joints = m.joints.size();
    s.corrections.assign(n * joints, Quat::Identity());
    s.correction_scales.assign(n * joints, 1.0);
    s.root_shifts.assign(n, Vec3::Zero());
    s.hip_moves.assign(n, Vec3::Zero());
    s.hip_leads.assign(n, Vec3::Zero());
    s.shortfalls.assign(n * static_cast<std::size_t>(m.effector_count), Vec3::Zero());
    s.end_stages.assign(n, 0);
  }
  for (Eigen::Index f = first; f < last; ++f) {
    StartFrame(m, d, f);
    const int iterations = m.options.method == IkMethod::kCcd ? SolveCcd(m, d) : SolveStaged(m, d);
    FinishFrame(m, d, out, f, iterations);
    // After FinishFrame: what it kept (a non-finite pose it puts back to the start).
    if (smooth) RecordFirstPassCorrection(m, d, f - first);
  }
  if (smooth) SolveSmoothed(m, d, out, first, last);
}

std::vector<int> SolvedBones(const Model& m) {
  std::vector<int> bones;
  bones.reserve(m.joints.size());
  for (const Joint& j : m.joints) bones.push_back(j.bone);
  return bones;
}

RowMatrixXd JacobianAt(const Model& m, Data& d, Eigen::Index f) {
  d.warm.have_last = false;
  d.warm.have_earlier = false;
  StartFrame(m, d, f);
  ForwardKinematics(m, d.current, d.fk);
  BuildJacobian(m, d, d.fk);
  RowMatrixXd j = RowMatrixXd::Zero(m.rows, m.cols);
  for (std::size_t ei = 0; ei < m.effectors.size(); ++ei) {
    const Effector& e = m.effectors[ei];
    const std::vector<double>& block = d.blocks[ei].a;
    const std::size_t n = e.columns.size();
    for (int r = 0; r < e.rows; ++r) {
      for (std::size_t i = 0; i < n; ++i) {
        j(e.row + r, e.columns[i]) = block[i * static_cast<std::size_t>(e.rows) + static_cast<std::size_t>(r)];
      }
    }
  }
  for (int c = 0; m.balance.enabled && c < m.cols; ++c) {
    for (int r = 0; r < 3; ++r) j(m.balance.com.row + r, c) = d.balance_block.a[static_cast<std::size_t>(3 * c + r)];
  }
  return j;
}

}  // namespace motionkit::ik_internal
