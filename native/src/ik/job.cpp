// IkClipJob: validation, splitting the effectors into independent problems, and running them over the
// clip's frames on threads.
#include <exception>
#include <thread>

#include "../parallel.hpp"
#include "solver.hpp"

namespace motionkit {

using ik_internal::At;
using ik_internal::EffectorName;
using ik_internal::FrameIndex;
using ik_internal::kPi;
using ik_internal::kSwingReach;
using ik_internal::Data;
using ik_internal::Model;

namespace {

// Effectors that share no unknown are independent problems: the cost is a
// sum of one term per group, so each group is solved on its own (smaller
// systems, and a group stops when its own targets are met). Two effectors
// share an unknown when a bone the solver may move (not excluded; bone 0
// only with root_rotation) lies on both paths to the root, or when both hang
// from bone 0 and its location is an unknown.
std::vector<std::vector<int>> IndependentGroups(const IkClipJob& job) {
  const int bones = job.rig.size(), count = static_cast<int>(job.effectors.size());
  const auto excluded = [&](int b) { return !job.joints.empty() && At(job.joints, b).excluded; };
  // Union-find over effectors, through the first effector seen on each unknown.
  std::vector<int> parent(static_cast<std::size_t>(count));
  for (int e = 0; e < count; ++e) At(parent, e) = e;
  const auto find = [&](int e) {
    while (At(parent, e) != e) e = At(parent, e) = At(parent, At(parent, e));
    return e;
  };
  std::vector<int> owner(static_cast<std::size_t>(bones) + 1, -1);  // the last slot: the root's location
  const auto claim = [&](std::size_t slot, int e) {
    if (owner[slot] < 0) {
      owner[slot] = e;
    } else {
      At(parent, find(e)) = find(owner[slot]);
    }
  };
  for (int e = 0; e < count; ++e) {
    for (int b = At(job.effectors, e).bone; b >= 0; b = job.rig.parent(b)) {
      if (!excluded(b) && (b != 0 || job.options.root_rotation)) claim(static_cast<std::size_t>(b), e);
      if (b == 0 && job.options.root_translation && !excluded(0)) claim(static_cast<std::size_t>(bones), e);
    }
  }
  // Balance weighs the whole body against the pins: one problem.
  bool pinned = false;
  for (const IkEffector& e : job.effectors) pinned = pinned || e.pin;
  if (job.options.balance && job.options.priorities && job.options.method == IkMethod::kDls && pinned) {
    for (int e = 0; e < count; ++e) At(parent, find(e)) = find(0);
  }
  std::vector<std::vector<int>> groups;
  std::vector<int> group_of(static_cast<std::size_t>(count), -1);
  for (int e = 0; e < count; ++e) {
    int& g = At(group_of, find(e));
    if (g < 0) {
      g = static_cast<int>(groups.size());
      groups.emplace_back();
    }
    groups[static_cast<std::size_t>(g)].push_back(e);
  }
  return groups;
}

}  // namespace

std::optional<IkMethod> ParseIkMethod(std::string_view text) {
  if (text == "ccd") return IkMethod::kCcd;
  if (text == "transpose") return IkMethod::kTranspose;
  if (text == "pinv") return IkMethod::kPseudoInverse;
  if (text == "dls") return IkMethod::kDls;
  return std::nullopt;
}

Status IkClipJob::Validate() const {
  const int bones = rig.size();
  const auto count = static_cast<Eigen::Index>(effectors.size());
  const Eigen::Index frames = target_positions.rows();
  const auto fail = [](const std::string& m) { return Status::Fail("ik: " + m); };
  if (bones == 0) return fail("the rig has no bones");
  if (input_rotations.cols() != 4 * bones || (input_rotations.rows() != 1 && input_rotations.rows() != frames)) {
    return fail("input rotations must be frames (or 1) x " + std::to_string(4 * bones) + " (4 per bone)");
  }
  if (input_locations.cols() != 3 || (input_locations.rows() != 1 && input_locations.rows() != frames)) {
    return fail("input locations must be frames (or 1) x 3 (the root bone's location)");
  }
  if (target_positions.cols() != 3 * count) {
    return fail("target positions must be frames x " + std::to_string(3 * count) + " (3 per effector)");
  }
  if (target_orientations.cols() != 0 &&
      (target_orientations.cols() != 4 * count || target_orientations.rows() != frames)) {
    return fail("target orientations must be frames x " + std::to_string(4 * count) +
                " (4 per effector), or have no columns");
  }
  if (rotations.rows() != frames || rotations.cols() != 4 * bones || root_locations.rows() != frames ||
      root_locations.cols() != 3 || scales.rows() != frames || scales.cols() != bones || errors.rows() != frames ||
      errors.cols() != count || iterations.size() != frames) {
    return fail("outputs must be frames x 4 per bone, frames x 3, frames x bones, frames x effectors and frames");
  }
  if (!joints.empty() && joints.size() != static_cast<std::size_t>(bones)) {
    return fail("joint settings must be given for every bone, or for none");
  }
  const IkOptions& o = options;
  if (o.max_iterations < 0) return fail("max_iterations must not be negative");
  if (o.threads < 0) return fail("threads must be 0 (all) or more, got " + std::to_string(o.threads));
  if (!(std::isfinite(o.tolerance) && o.tolerance >= 0)) return fail("tolerance must be finite and >= 0");
  if (!(std::isfinite(o.max_step) && o.max_step > 0)) return fail("max_step must be finite and > 0");
  if (!(std::isfinite(o.damping) && o.damping >= 0)) return fail("damping must be finite and >= 0");
  if (!(std::isfinite(o.regularization) && o.regularization >= 0)) {
    return fail("regularization must be finite and >= 0");
  }
  if (!(std::isfinite(o.size) && o.size >= 0)) return fail("size must be finite and >= 0");
  if (!(std::isfinite(o.orientation_scale) && o.orientation_scale >= 0)) {
    return fail("orientation_scale must be finite and >= 0");
  }
  if (!(o.up.allFinite() && o.up.norm() > 1e-12)) return fail("up must be a finite, non-zero direction");
  if (!(std::isfinite(o.balance_margin) && o.balance_margin >= 0)) {
    return fail("balance_margin must be finite and >= 0");
  }
  for (std::size_t i = 0; i < effectors.size(); ++i) {
    const IkEffector& e = effectors[i];
    const std::string name = EffectorName(e, i);
    if (e.bone < 0 || e.bone >= bones) return fail(name + ": bone index " + std::to_string(e.bone) + " out of range");
    if (!(std::isfinite(e.weight) && e.weight > 0)) return fail(name + ": the weight must be finite and positive");
    if (!e.position && !e.orientation) return fail(name + " has nothing to reach (neither position nor orientation)");
    if (e.orientation && !e.pin && target_orientations.cols() == 0) {
      return fail(name + " asks for an orientation but no target orientations were given");
    }
  }
  for (std::size_t b = 0; b < joints.size(); ++b) {
    const IkJoint& j = joints[b];
    const std::string name = "bone '" + rig.name(static_cast<int>(b)) + "'";
    for (int k = 0; k < 3; ++k) {
      if (std::isnan(j.min[k]) || std::isnan(j.max[k]) || j.min[k] > j.max[k]) {
        return fail(name + ": limit min must not exceed max (axis " + std::string(1, "XYZ"[k]) + ")");
      }
      if (!(std::isfinite(j.stiffness[k]) && j.stiffness[k] >= 0 && j.stiffness[k] < 1)) {
        return fail(name + ": stiffness must be in [0, 1)");
      }
    }
    // Something must lie within the limits: a twist in [-pi, pi], a swing
    // whose rotation vector is at most pi long.
    Eigen::Vector3d lo = j.min, hi = j.max;
    for (int k = 0; k < 3; ++k) {
      if (j.locked[static_cast<std::size_t>(k)]) lo[k] = hi[k] = 0.0;
    }
    const double near_x = std::clamp(0.0, lo.x(), hi.x()), near_z = std::clamp(0.0, lo.z(), hi.z());
    if (lo.y() > kPi - 1e-6 || hi.y() < -kPi + 1e-6 || std::hypot(near_x, near_z) > kSwingReach) {
      return fail(name + ": the limits leave no rotation (twist within [-pi, pi], swing at most pi)");
    }
    if (!(std::isfinite(j.stretch) && j.stretch >= 0)) return fail(name + ": stretch must be finite and >= 0");
    if (j.stage < 0) return fail(name + ": the stage must be 0 or more");
    if (!std::isfinite(j.mass)) return fail(name + ": the mass must be finite (negative: from its length)");
    if (j.stretch > 0 && !(std::isfinite(j.min_scale) && std::isfinite(j.max_scale) && j.min_scale > 0 &&
                           j.min_scale <= j.max_scale)) {
      return fail(name + ": the scale range must be positive, finite and ordered");
    }
  }
  for (Eigen::Index f = 0; f < input_rotations.rows(); ++f) {
    for (int b = 0; b < bones; ++b) {
      const Eigen::Quaterniond q = QuatAt(input_rotations, f, b);
      if (!internal::IsRotationQuaternion(q)) {
        return fail("bone '" + rig.name(b) + "' has a zero or non-finite input rotation at " + FrameIndex(f));
      }
    }
  }
  for (Eigen::Index f = 0; f < input_locations.rows(); ++f) {
    if (!input_locations.row(f).allFinite()) return fail("the root location is not finite at " + FrameIndex(f));
  }
  for (Eigen::Index f = 0; f < frames; ++f) {
    for (Eigen::Index i = 0; i < count; ++i) {
      const IkEffector& e = effectors[static_cast<std::size_t>(i)];
      if (e.pin) continue;
      if (e.position && !target_positions.row(f).segment<3>(3 * i).allFinite()) {
        return fail(EffectorName(e, static_cast<std::size_t>(i)) + " has a non-finite target position at " +
                    FrameIndex(f));
      }
      if (e.orientation) {
        const Eigen::Quaterniond q = QuatAt(target_orientations, f, i);
        if (!internal::IsRotationQuaternion(q)) {
          return fail(EffectorName(e, static_cast<std::size_t>(i)) +
                      " has a zero or non-finite target orientation at " + FrameIndex(f));
        }
      }
    }
  }
  return Status::Ok();
}

void IkClipJob::Run() {
  Validate().ThrowIfFailed();
  std::vector<std::vector<int>> groups = IndependentGroups(*this);
  const Eigen::Index frames = target_positions.rows();
  // Every output as the input has it; each group's solver then writes its own bones and effectors.
  for (Eigen::Index f = 0; f < frames; ++f) {
    rotations.row(f) = input_rotations.row(input_rotations.rows() == 1 ? 0 : f);
    root_locations.row(f) = input_locations.row(input_locations.rows() == 1 ? 0 : f);
  }
  scales.setOnes();
  // Larger groups first, so that the threads finish together.
  std::stable_sort(groups.begin(), groups.end(),
                   [](const std::vector<int>& a, const std::vector<int>& b) { return a.size() > b.size(); });
  std::vector<std::vector<int>> counts(groups.size(), std::vector<int>(static_cast<std::size_t>(frames), 0));
  int threads = options.threads;
  if (threads == 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  // Without a warm start and with the input as the reference, no frame depends on another: the threads
  // a group leaves idle take runs of its frames (each run with its own solver), same numbers.
  const bool frames_apart = !options.warm_start && options.reference == IkReference::kInput;
  const int group_count = static_cast<int>(groups.size());
  const Eigen::Index runs = frames_apart && group_count > 0 && threads > group_count
                                ? std::max<Eigen::Index>(1, std::min<Eigen::Index>(threads / group_count, frames))
                                : 1;
  const int tasks = group_count * static_cast<int>(runs);
  std::vector<std::exception_ptr> failures(static_cast<std::size_t>(tasks));
  std::vector<std::vector<int>> solved(static_cast<std::size_t>(tasks));
  // One model per group, shared by its runs (they only read it).
  std::vector<Model> models;
  models.reserve(groups.size());
  for (const std::vector<int>& group : groups) models.emplace_back(*this, group);
  const auto run_start = [&](Eigen::Index run) { return frames * run / runs; };
  internal::ParallelFor(tasks, threads, [&](int t) {
    const auto i = static_cast<std::size_t>(t / runs);
    const Eigen::Index run = t % runs;
    try {
      Data data(models[i]);
      data.iterations = counts[i].data();
      ik_internal::SolveFrames(models[i], data, *this, run_start(run), run_start(run + 1));
      solved[static_cast<std::size_t>(t)] = ik_internal::SolvedBones(models[i]);
    } catch (...) {
      failures[static_cast<std::size_t>(t)] = std::current_exception();
    }
  });
  for (const std::exception_ptr& failure : failures) {
    if (failure) std::rethrow_exception(failure);
  }
  // Each later run began its signs from the input: carry on from the run before, as one thread would.
  for (int t = 0; t < tasks; ++t) {
    const Eigen::Index run = t % runs, first = run_start(run), last = run_start(run + 1);
    if (run == 0 || first == last) continue;
    for (int b : solved[static_cast<std::size_t>(t)]) {
      if (rotations.row(first).segment<4>(4 * b).dot(rotations.row(first - 1).segment<4>(4 * b)) < 0.0) {
        rotations.block(first, 4 * b, last - first, 4) *= -1.0;
      }
    }
  }
  for (Eigen::Index f = 0; f < frames; ++f) {
    int most = 0;
    for (const std::vector<int>& c : counts) most = std::max(most, c[static_cast<std::size_t>(f)]);
    iterations[f] = most;
  }
}

RowMatrixXd IkClipJob::Jacobian(Eigen::Index frame) const {
  Validate().ThrowIfFailed();
  if (frame < 0 || frame >= target_positions.rows()) throw Error("ik: frame index out of range");
  IkClipJob job = *this;  // views and settings: the solver writes nothing here
  std::vector<int> ids(job.effectors.size());
  for (std::size_t e = 0; e < ids.size(); ++e) ids[e] = static_cast<int>(e);
  const Model model(job, std::move(ids));
  Data data(model);
  return ik_internal::JacobianAt(model, data, frame);
}

}  // namespace motionkit
