#include <cstdlib>
// A frame's start and finish (inputs in, outputs and errors out), and running a range of frames.
#include <cmath>

#include "solver.hpp"

namespace motionkit::ik_internal {

void Solver::StartFrame(Eigen::Index f) {
  const Eigen::Index rot_row = job_.input_rotations.rows() == 1 ? 0 : f;
  const Eigen::Index loc_row = job_.input_locations.rows() == 1 ? 0 : f;
  for (int b : needed_) {
    At(input_.basis, b) = QuatAt(job_.input_rotations, rot_row, b).normalized();
    At(input_.scale, b) = 1.0;
  }
  if (bones_ > 0) {
    input_.root = rig_.offset(0) + rig_.relative(0) * job_.input_locations.row(loc_row).transpose();
  }
  // Every pose of the frame has the input's basis, scale and root on these.
  for (int b : fixed_) {
    Place(b, input_, fk_);
    At(trial_fk_.frame, b) = At(fk_.frame, b);
    At(trial_fk_.global, b) = At(fk_.global, b);
    At(trial_fk_.head, b) = At(fk_.head, b);
  }
  // Pins hold where this frame's input pose has them.
  if (pinned_) Forward(input_, fk_);
  if (balance_) FindSupport();
  // Soft limits take in this frame's input.
  for (Joint& j : joints_) {
    if (!(j.soft[0] || j.soft[1] || j.soft[2])) continue;
    const Vec3 a = IkSwingTwist(At(input_.basis, j.bone));
    for (int k = 0; k < 3; ++k) {
      if (!j.soft[static_cast<std::size_t>(k)]) continue;
      j.lo[k] = std::min(j.base_lo[k], a[k]);
      j.hi[k] = std::max(j.base_hi[k], a[k]);
    }
  }
  for (int e = 0; e < effector_count_; ++e) {
    const Effector& ef = At(effectors_, e);
    if (ef.pin) {
      At(target_position_, e) = At(fk_.tip, e);
      At(target_orientation_, e) = At(fk_.global, ef.bone);
      continue;
    }
    const int id = At(ids_, e);
    if (ef.position) At(target_position_, e) = job_.target_positions.row(f).segment<3>(3 * id).transpose();
    if (ef.orientation) {
      const double* q = job_.target_orientations.data() + f * job_.target_orientations.outerStride() + 4 * id;
      At(target_orientation_, e) = Quat(q[0], q[1], q[2], q[3]).normalized();
    }
  }
  // solution_ and earlier_ hold the last two frames' corrections: each
  // joint's solved basis times its input's inverse (the scale and the root's
  // move as they are). A frame starts from the last correction on top of its
  // own input, so that an animated input plays on under the IK (a walking
  // leg that no target needs follows its walk) instead of being dragged from
  // the last frame's pose; with the previous frame as reference, the posture
  // prior pulls towards that too.
  const bool warm = options_.warm_start && have_solution_;
  for (int b : needed_) {
    At(current_.basis, b) = At(input_.basis, b);
    At(current_.scale, b) = 1.0;
  }
  current_.root = warm && translate_ ? Vec3(input_.root + solution_.root) : input_.root;
  const bool previous = options_.reference == IkReference::kPrevious && have_solution_;
  reference_.root = previous ? Vec3(input_.root + solution_.root) : input_.root;
  for (const Joint& j : joints_) {
    const Quat& in = At(input_.basis, j.bone);
    if (warm) {
      At(current_.basis, j.bone) = (At(solution_.basis, j.bone) * in).normalized();
      At(current_.scale, j.bone) = At(solution_.scale, j.bone);
    }
    ClampJoint(j, current_);
    At(reference_.basis, j.bone) = previous ? (At(solution_.basis, j.bone) * in).normalized() : in;
    At(reference_.scale, j.bone) = previous ? At(solution_.scale, j.bone) : 1.0;
  }
  trial_ = current_;
  // Targets that move smoothly move the solution smoothly: carried on as the
  // last two frames' corrections went, the start is often close enough for
  // one step to meet the tolerance (from the last correction alone, two).
  // Kept only when it starts nearer the targets.
  if (warm && have_earlier_ && !joints_.empty()) {
    for (const Joint& j : joints_) {
      const Quat& last = At(solution_.basis, j.bone);
      At(trial_.basis, j.bone) =
          (last * (At(earlier_.basis, j.bone).conjugate() * last) * At(input_.basis, j.bone)).normalized();
      At(trial_.scale, j.bone) = 2.0 * At(solution_.scale, j.bone) - At(earlier_.scale, j.bone);
      ClampJoint(j, trial_);
    }
    if (translate_) trial_.root = input_.root + 2.0 * solution_.root - earlier_.root;
    Forward(current_, fk_);
    Forward(trial_, trial_fk_);
    const Cost extrapolated = Evaluate(trial_fk_, r_.data()), last = Evaluate(fk_, e_.data());
    if (extrapolated.task < last.task) {
      std::swap(current_, trial_);
    }
    trial_ = current_;
  }
  // Recruitment: the later stages start from the input (the first stage
  // holds them there), and so do the pinned chains, whose last correction
  // went with the hips' (the input meets the pins by definition).
  if (stages_ > 1 && options_.method != IkMethod::kCcd) {
    if (translate_ && columns_[0].stage > 0) current_.root = input_.root;
    for (const Joint& j : joints_) {
      if (j.stage == 0 && !j.pinned_chain) continue;
      At(current_.basis, j.bone) = At(input_.basis, j.bone);
      At(current_.scale, j.bone) = 1.0;
      ClampJoint(j, current_);
    }
    trial_ = current_;
  }
}


void Solver::FinishFrame(Eigen::Index f, int iterations) {
  // Never hand back a non-finite value: fall back on the frame's start.
  bool finite = current_.root.allFinite();
  for (const Joint& j : joints_) {
    finite = finite && At(current_.basis, j.bone).coeffs().allFinite() && std::isfinite(At(current_.scale, j.bone));
  }
  if (!finite) {
    StartFrame(f);
    Forward(current_, fk_);
  }
  for (int e = 0; e < effector_count_; ++e) job_.errors(f, At(ids_, e)) = EffectorError(e, fk_, true);
  iterations_[f] = iterations;
  const Eigen::Index rot_row = job_.input_rotations.rows() == 1 ? 0 : f;
  double* const out_row = job_.rotations.data() + f * job_.rotations.outerStride();
  const double* const in_row = job_.input_rotations.data() + rot_row * job_.input_rotations.outerStride();
  for (const Joint& j : joints_) {
    const int b = j.bone;
    double* out = out_row + 4 * b;
    const double* in = in_row + 4 * b;
    Quat q = At(current_.basis, b);
    // Continuous with the previous frame's output (the input's on the first of the run).
    const double* near = f > first_ ? out - job_.rotations.outerStride() : in;
    if (q.w() * near[0] + q.x() * near[1] + q.y() * near[2] + q.z() * near[3] < 0.0) q.coeffs() = -q.coeffs();
    out[0] = q.w();
    out[1] = q.x();
    out[2] = q.y();
    out[3] = q.z();
    job_.scales(f, b) = At(current_.scale, b);
  }
  if (translate_) {
    job_.root_locations.row(f) = (rig_.relative(0).conjugate() * (current_.root - rig_.offset(0))).transpose();
  }
  earlier_.root = solution_.root;
  for (const Joint& j : joints_) {
    At(earlier_.basis, j.bone) = At(solution_.basis, j.bone);
    At(earlier_.scale, j.bone) = At(solution_.scale, j.bone);
  }
  have_earlier_ = have_solution_;
  solution_.root = current_.root - input_.root;
  for (const Joint& j : joints_) {
    At(solution_.basis, j.bone) = (At(current_.basis, j.bone) * At(input_.basis, j.bone).conjugate()).normalized();
    At(solution_.scale, j.bone) = At(current_.scale, j.bone);
  }
  have_solution_ = true;
}

// Damped Gauss-Newton steps on the levels (the prior is left to the settling
// after), the pins first as in SolveJacobian, the damping raised only when a
// step fails: from a start close to the answer, a few steps whose result
// depends smoothly on where they start (no curvature term, no kick, no
// stationarity test).
int Solver::SolveNear(int budget) {
  int it = 0;
  Forward(current_, fk_);
  Cost cost = Evaluate(fk_, e_.data());
  bend_weight_ = 0.0;
  double damp2 = lambda_ * lambda_;
  while (it < budget && Unmet(cost)) {
    ++it;
    BuildJacobian(fk_);
    FindBounds();
    bool ok = Direction(damp2, 0.0);
    while (ok && Freeze(u_.data())) ok = Direction(damp2, 0.0);
    if (!ok) break;
    ClampStep(u_.data());
    Apply(current_, u_.data(), trial_);
    Forward(trial_, trial_fk_);
    Cost next = Evaluate(trial_fk_, r_.data());
    if (priorities_ && next.pins > pin_tolerance_) Restore(next);
    if (!Better(cost.pins, next.pins, cost.task, next.task)) {
      damp2 *= 10.0;
      if (damp2 > 1e8 * lambda_ * lambda_) break;
      continue;
    }
    std::swap(current_, trial_);
    std::swap(fk_, trial_fk_);
    std::swap(e_, r_);
    cost = next;
  }
  return it;
}

std::vector<int> Solver::Bones() const {
  std::vector<int> bones;
  bones.reserve(joints_.size());
  for (const Joint& j : joints_) bones.push_back(j.bone);
  return bones;
}

void Solver::Run(Eigen::Index first, Eigen::Index last) {
  first_ = first;
  const bool smooth = separate_prior_ && options_.warm_start && last - first >= 3;
  if (smooth) {
    const auto n = static_cast<std::size_t>(last - first), joints = joints_.size();
    corrections_.assign(n * joints, Quat::Identity());
    correction_scales_.assign(n * joints, 1.0);
    root_shifts_.assign(n, Vec3::Zero());
    shortfalls_.assign(n * static_cast<std::size_t>(effector_count_), Vec3::Zero());
    end_stages_.assign(n, 0);
  }
  for (Eigen::Index f = first; f < last; ++f) {
    StartFrame(f);
    const int iterations = options_.method == IkMethod::kCcd ? SolveCcd() : SolveStaged();
    FinishFrame(f, iterations);
    if (smooth) Record(f - first);  // after FinishFrame: what it kept (a non-finite pose it puts back to the start)
  }
  if (smooth) Smooth(first, last);
}

void Solver::Record(Eigen::Index i) {
  const auto at = static_cast<std::size_t>(i);
  for (std::size_t jo = 0; jo < joints_.size(); ++jo) {
    const int b = joints_[jo].bone;
    corrections_[at * joints_.size() + jo] = (At(current_.basis, b) * At(input_.basis, b).conjugate()).normalized();
    correction_scales_[at * joints_.size() + jo] = At(current_.scale, b);
  }
  root_shifts_[at] = current_.root - input_.root;
  for (int e = 0; e < effector_count_; ++e) {
    const Effector& ef = At(effectors_, e);
    Vec3 d = Vec3::Zero();
    if (ef.position && !ef.pin) d = At(fk_.tip, e) - At(target_position_, e);
    shortfalls_[at * static_cast<std::size_t>(effector_count_) + static_cast<std::size_t>(e)] = d;
  }
  end_stages_[at] = ended_stage_;
}

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
void Solver::Smooth(Eigen::Index first, Eigen::Index last) {
  const Eigen::Index n = last - first;
  const auto radius = static_cast<Eigen::Index>(std::ceil(3.0 * kSmoothSigma));
  const std::size_t joints = joints_.size(), effectors = static_cast<std::size_t>(effector_count_);
  have_solution_ = false;
  have_earlier_ = false;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Index f = first + i;
    const auto own = static_cast<std::size_t>(i);
    StartFrame(f);
    double total = 0.0;
    int stage = 0;
    Vec3 root = Vec3::Zero();
    for (std::size_t jo = 0; jo < joints; ++jo) {
      rotation_sum_[jo].setZero();
      scale_sum_[jo] = 0.0;
    }
    for (std::size_t e = 0; e < effectors; ++e) shift_sum_[e].setZero();
    for (Eigen::Index k = std::max<Eigen::Index>(0, i - radius); k <= std::min(n - 1, i + radius); ++k) {
      const double x = static_cast<double>(k - i) / kSmoothSigma, w = std::exp(-0.5 * x * x);
      const auto at = static_cast<std::size_t>(k);
      total += w;
      root += w * root_shifts_[at];
      stage = std::max(stage, end_stages_[at]);
      for (std::size_t jo = 0; jo < joints; ++jo) {
        rotation_sum_[jo] += w * RotationVector(corrections_[own * joints + jo].conjugate() * corrections_[at * joints + jo]);
        scale_sum_[jo] += w * correction_scales_[at * joints + jo];
      }
      for (std::size_t e = 0; e < effectors; ++e) {
        // A frame that alone fell short (the frames on both sides met the
        // target) fell short by chance: it counts as met.
        const auto missed = [&](Eigen::Index m) {
          return m >= 0 && m < n && shortfalls_[static_cast<std::size_t>(m) * effectors + e].norm() > tolerance_;
        };
        if (missed(k) && (missed(k - 1) || missed(k + 1))) shift_sum_[e] += w * shortfalls_[at * effectors + e];
      }
    }
    for (std::size_t jo = 0; jo < joints; ++jo) {
      const Joint& j = joints_[jo];
      const Quat& in = At(input_.basis, j.bone);
      At(trial_.basis, j.bone) = (corrections_[own * joints + jo] * in).normalized();
      At(trial_.scale, j.bone) = correction_scales_[own * joints + jo];
      At(current_.basis, j.bone) =
          (corrections_[own * joints + jo] * FromRotationVector(rotation_sum_[jo] / total) * in).normalized();
      At(current_.scale, j.bone) = scale_sum_[jo] / total;
      ClampJoint(j, current_);
      At(reference_.basis, j.bone) = At(current_.basis, j.bone);
      At(reference_.scale, j.bone) = At(current_.scale, j.bone);
    }
    trial_.root = input_.root + root_shifts_[own];
    if (translate_) current_.root = input_.root + root / total;
    reference_.root = current_.root;
    for (std::size_t e = 0; e < effectors; ++e) {
      const Effector& ef = effectors_[e];
      aside_[e] = target_position_[e];
      if (ef.position && !ef.pin) target_position_[e] += shift_sum_[e] / total;
    }
    Begin();
    if (!kept_) Keep(trial_);
    trial_ = current_;
    stage_ = stage;
    const int iterations = SolveNear(kSmoothIterations);
    const int more = Conclude(options_.max_iterations, true);
      for (std::size_t e = 0; e < effectors; ++e) target_position_[e] = aside_[e];
    FinishFrame(f, iterations_[f] + iterations + more);
  }
}

RowMatrixXd Solver::Jacobian(Eigen::Index f) {
  have_solution_ = false;
  have_earlier_ = false;
  StartFrame(f);
  Forward(current_, fk_);
  BuildJacobian(fk_);
  RowMatrixXd j = RowMatrixXd::Zero(rows_, cols_);
  for (const Effector& e : effectors_) {
    const std::size_t n = e.columns.size();
    for (int r = 0; r < e.rows; ++r) {
      for (std::size_t i = 0; i < n; ++i) {
        j(e.row + r, e.columns[i]) = e.block[i * static_cast<std::size_t>(e.rows) + static_cast<std::size_t>(r)];
      }
    }
  }
  for (int c = 0; balance_ && c < cols_; ++c) {
    for (int r = 0; r < 3; ++r) j(com_.row + r, c) = com_.block[static_cast<std::size_t>(3 * c + r)];
  }
  return j;
}

}  // namespace motionkit::ik_internal
