#include "motionkit/world_key_reduction.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "motionkit/key_reduction.hpp"
#include "motionkit/rotation.hpp"
#include "time_checks.hpp"

namespace motionkit {
namespace {

constexpr int kChannels = 10;          // per bone: rotation 4, location 3, scale 3
constexpr int kGroups = 3;             // rotation, location, scale
constexpr int kGroupColumn[kGroups] = {0, 4, 7};
constexpr int kEulerOrders = 6;
// The search's reach in k: up from 1 by doubling, down by halving (then k = 0),
// and the bisection steps between the last pass and the first failure.
constexpr int kDoublings = 6;
constexpr int kHalvings = 40;
constexpr int kBisections = 3;

struct Affine {
  Eigen::Matrix3d linear;
  Eigen::Vector3d translation;
};

Affine Compose(const Affine& a, const Affine& b) {
  return {a.linear * b.linear, a.translation + a.linear * b.translation};
}

Eigen::Vector3d Apply(const Affine& a, const Eigen::Vector3d& p) { return a.translation + a.linear * p; }

int GroupWidth(int group, int rotation_mode) {
  if (group != 0) return 3;
  return rotation_mode >= kWorldEuler ? 3 : 4;
}

// Blender's pose rotation from one bone's rotation channels.
Eigen::Quaterniond ChannelRotation(int mode, const double* c) {
  if (mode == kWorldQuaternion) return Eigen::Quaterniond(c[0], c[1], c[2], c[3]).normalized();
  if (mode == kWorldAxisAngle) {
    const Eigen::Vector3d axis(c[1], c[2], c[3]);
    const double norm = axis.norm();
    if (!(norm > 0.0)) return Eigen::Quaterniond::Identity();
    return Eigen::Quaterniond(Eigen::AngleAxisd(c[0], axis / norm));
  }
  return EulerToQuaternion(Eigen::Vector3d(c[0], c[1], c[2]), static_cast<EulerOrder>(mode - kWorldEuler));
}

// Rest_p^-1 Rest_b T(loc) R S for one bone's ten channels.
Affine LocalPose(const RigModel& rig, int b, int mode, const double* c) {
  const Affine rest{rig.relative(b).toRotationMatrix(), rig.offset(b)};
  const Eigen::Vector3d scale(c[7], c[8], c[9]);
  const Affine basis{ChannelRotation(mode, c).toRotationMatrix() * scale.asDiagonal(),
                     Eigen::Vector3d(c[4], c[5], c[6])};
  return Compose(rest, basis);
}

using KeyIndices = Eigen::Matrix<std::int64_t, Eigen::Dynamic, 1>;

// The cubic Hermite segments KeyReductionJob fitted, evaluated at every
// sample between the first and the last key (rows of out, relative to the
// group's first sample).
void EvaluateKeys(ConstVectorView times, ConstMatrixView values, const KeyIndices& indices,
                  Eigen::Index count, const RowMatrixXd& slopes_in, const RowMatrixXd& slopes_out,
                  Eigen::Ref<RowMatrixXd> out) {
  out.row(0) = values.row(0);
  for (Eigen::Index k = 0; k + 1 < count; ++k) {
    const Eigen::Index a = indices[k], b = indices[k + 1];
    const double t0 = times[a], h = times[b] - t0;
    for (Eigen::Index j = a + 1; j <= b; ++j) {
      const double u = (times[j] - t0) / h, u2 = u * u, u3 = u2 * u;
      const double h0 = 2 * u3 - 3 * u2 + 1, h1 = 3 * u2 - 2 * u3;
      const double h2 = (u3 - 2 * u2 + u) * h, h3 = (u3 - u2) * h;
      out.row(j) = h0 * values.row(a) + h1 * values.row(b) + h2 * slopes_out.row(k) + h3 * slopes_in.row(k + 1);
    }
  }
}

// One group's fit in a trial.
struct GroupFit {
  KeyIndices indices;
  RowMatrixXd slopes_in, slopes_out;
  Eigen::Index count = 0;
};

// One bone's fit at one k: its groups' keys, and its pose on every sample.
struct Trial {
  double k = 0.0;
  bool passed = false;
  Eigen::Index key_points = 0;
  GroupFit groups[kGroups];
  std::vector<Affine> local, global;  // per sample
};

// What a tolerance search checks: every point of the bone's subtree within
// limit, its descendants posed by `below` ([j * bones + c] local poses).
struct SearchBound {
  double start_k;
  double limit;
  const std::vector<Affine>* below;
};

class WorldReducer {
 public:
  explicit WorldReducer(WorldKeyReductionJob& job);
  void Run();

 private:
  void PoseOriginal();
  void MeasureReach();
  double ReduceBone(int b, const SearchBound& bound);
  void RunTrial(int b, double k, const SearchBound& bound, Trial& trial);
  double SubtreeError(int b, Eigen::Index j, const Affine& posed, const SearchBound& bound);
  void PoseFromParent(int b);
  void StoreBest(int b, const Trial& best);
  bool Reducible(int b) const { return Reduced(b, 0) || Reduced(b, 1) || Reduced(b, 2); }
  bool Reduced(int b, int g) const { return job_.group_ranges(kGroups * b + g, 0) >= 0; }
  double Budget(int b) const;

  WorldKeyReductionJob& job_;
  const RigModel& rig_;
  const Eigen::Index samples_;
  const int bones_;
  std::vector<std::vector<int>> subtree_;         // per bone: itself then its descendants, parents first
  std::vector<int> depth_, height_;
  std::vector<std::vector<Eigen::Vector3d>> points_;  // per bone, in its own frame
  std::vector<Affine> original_local_, original_;  // sample-major: [j * bones + b]
  std::vector<Affine> reduced_local_, reduced_;    // bones done so far, as reduced
  std::vector<double> chosen_k_;
  std::vector<double> reach_;
  std::vector<Affine> scratch_;                    // a subtree's poses at one sample
  RowMatrixXd values_;                             // one bone's channels in a trial, m x 10
};

WorldReducer::WorldReducer(WorldKeyReductionJob& job)
    : job_(job), rig_(job.rig), samples_(job.times.size()), bones_(job.rig.size()) {
  subtree_.resize(static_cast<std::size_t>(bones_));
  depth_.assign(static_cast<std::size_t>(bones_), 0);
  height_.assign(static_cast<std::size_t>(bones_), 0);
  for (int b = 0; b < bones_; ++b) {
    const int p = rig_.parent(b);
    if (p >= 0) depth_[b] = depth_[p] + 1;
    for (int a = b; a >= 0; a = rig_.parent(a)) subtree_[a].push_back(b);
  }
  for (int b = bones_ - 1; b >= 0; --b) {
    const int p = rig_.parent(b);
    if (p >= 0) height_[p] = std::max(height_[p], height_[b] + 1);
  }
  const double a = job.axis_length;
  points_.resize(static_cast<std::size_t>(bones_));
  for (int b = 0; b < bones_; ++b) {
    points_[b] = {Eigen::Vector3d::Zero(), Eigen::Vector3d(a, 0, 0), Eigen::Vector3d(0, a, 0),
                  Eigen::Vector3d(0, 0, a)};
    if (subtree_[b].size() == 1) points_[b].emplace_back(0.0, rig_.length(b), 0.0);
  }
}

double WorldReducer::Budget(int b) const {
  const double depth = depth_[b] + 1.0;
  return job_.distance * depth / (depth + height_[b]);
}

void WorldReducer::PoseOriginal() {
  const auto n = static_cast<std::size_t>(samples_ * bones_);
  original_local_.resize(n);
  original_.resize(n);
  for (Eigen::Index j = 0; j < samples_; ++j) {
    const double* row = job_.channels.data() + j * job_.channels.outerStride();
    for (int b = 0; b < bones_; ++b) {
      const std::size_t at = static_cast<std::size_t>(j * bones_ + b);
      original_local_[at] = LocalPose(rig_, b, job_.rotation_modes[b], row + kChannels * b);
      const int p = rig_.parent(b);
      original_[at] = p >= 0 ? Compose(original_[static_cast<std::size_t>(j * bones_ + p)], original_local_[at])
                             : original_local_[at];
    }
  }
  reduced_local_ = original_local_;
  reduced_ = original_;
}

// How far any point of a bone's subtree gets from the bone's head: what turns
// an angle into a distance.
void WorldReducer::MeasureReach() {
  reach_.assign(static_cast<std::size_t>(bones_), 0.0);
  for (Eigen::Index j = 0; j < samples_; ++j) {
    const Affine* pose = &original_[static_cast<std::size_t>(j * bones_)];
    for (int b = 0; b < bones_; ++b) {
      for (int c : subtree_[b]) {
        for (const Eigen::Vector3d& p : points_[c]) {
          reach_[b] = std::max(reach_[b], (Apply(pose[c], p) - pose[b].translation).norm());
        }
      }
    }
  }
}

void WorldReducer::Run() {
  PoseOriginal();
  MeasureReach();
  values_.resize(samples_, kChannels);
  job_.keys.setZero();
  job_.slopes_in.setZero();
  job_.slopes_out.setZero();
  // First pass: each bone within its share of the distance, its descendants
  // as they were.
  chosen_k_.assign(static_cast<std::size_t>(bones_), 0.0);
  for (int b = 0; b < bones_; ++b) {
    if (Reducible(b)) {
      chosen_k_[b] = ReduceBone(b, {1.0, Budget(b), &original_local_});
    } else {
      PoseFromParent(b);
    }
  }
  // Second pass: the errors seldom add up as the shares allow, so each bone
  // is loosened as far as its subtree, as now reduced, stays within the
  // whole distance. Its current k passes that check, so nothing gets worse.
  for (int b = 0; b < bones_; ++b) {
    if (!Reducible(b)) continue;
    chosen_k_[b] = ReduceBone(b, {chosen_k_[b], job_.distance, &reduced_local_});
    for (int c : subtree_[b]) {
      if (c != b) PoseFromParent(c);
    }
  }
  double worst = 0.0;
  for (Eigen::Index j = 0; j < samples_; ++j) {
    for (int b = 0; b < bones_; ++b) {
      const std::size_t at = static_cast<std::size_t>(j * bones_ + b);
      for (const Eigen::Vector3d& p : points_[b]) {
        worst = std::max(worst, (Apply(reduced_[at], p) - Apply(original_[at], p)).norm());
      }
    }
  }
  job_.worst_error = worst;
}

// Bone b's pose on every sample from its parent's reduced pose and its own
// reduced local pose.
void WorldReducer::PoseFromParent(int b) {
  const int p = rig_.parent(b);
  for (Eigen::Index j = 0; j < samples_; ++j) {
    const std::size_t at = static_cast<std::size_t>(j * bones_);
    reduced_[at + b] = p >= 0 ? Compose(reduced_[at + p], reduced_local_[at + b]) : reduced_local_[at + b];
  }
}

// The largest distance of any point of b's subtree from the original at
// sample j when b is posed at `posed` and its descendants by bound.below;
// stops early once past the limit.
double WorldReducer::SubtreeError(int b, Eigen::Index j, const Affine& posed, const SearchBound& bound) {
  const std::vector<Affine>& below_local = *bound.below;
  const std::size_t at = static_cast<std::size_t>(j * bones_);
  const std::vector<int>& below = subtree_[b];
  double worst = 0.0;
  for (std::size_t i = 0; i < below.size(); ++i) {
    const int c = below[i];
    if (i == 0) {
      scratch_[c] = posed;
    } else {
      scratch_[c] = Compose(scratch_[rig_.parent(c)], below_local[at + c]);
    }
    for (const Eigen::Vector3d& p : points_[c]) {
      worst = std::max(worst, (Apply(scratch_[c], p) - Apply(original_[at + c], p)).norm());
    }
    if (worst > bound.limit) return worst;
  }
  return worst;
}

void WorldReducer::RunTrial(int b, double k, const SearchBound& bound, Trial& trial) {
  const int mode = job_.rotation_modes[b];
  const double budget = Budget(b);
  const double angle = reach_[b] > 0.0 ? budget / reach_[b] : budget;
  const double tolerances[kGroups] = {k * angle, k * budget, k * angle};
  trial.k = k;
  trial.key_points = 0;
  values_ = job_.channels.middleCols(kChannels * b, kChannels);
  for (int g = 0; g < kGroups; ++g) {
    if (!Reduced(b, g)) continue;
    const Eigen::Index first = job_.group_ranges(kGroups * b + g, 0), last = job_.group_ranges(kGroups * b + g, 1);
    const Eigen::Index n = last - first + 1, width = GroupWidth(g, mode), column = kChannels * b + kGroupColumn[g];
    GroupFit& fit = trial.groups[g];
    fit.indices.resize(n);
    fit.slopes_in.resize(n, width);
    fit.slopes_out.resize(n, width);
    const ConstVectorView times = job_.times.segment(first, n);
    const ConstMatrixView values = job_.channels.block(first, column, n, width);
    KeyReductionJob reduce(times, values, tolerances[g], fit.indices, fit.slopes_in, fit.slopes_out);
    reduce.mode = g != 0 || mode == kWorldAxisAngle ? KeyToleranceMode::kAbsolute
                  : mode == kWorldQuaternion        ? KeyToleranceMode::kQuaternion
                                                    : KeyToleranceMode::kEuler;
    if (mode >= kWorldEuler) reduce.euler_order = static_cast<EulerOrder>(mode - kWorldEuler);
    reduce.stride = job_.stride;
    reduce.Run();
    fit.count = reduce.key_count;
    trial.key_points += fit.count * width;
    EvaluateKeys(times, values, fit.indices, fit.count, fit.slopes_in, fit.slopes_out,
                 values_.block(first, kGroupColumn[g], n, width));
  }
  const int p = rig_.parent(b);
  trial.local.resize(static_cast<std::size_t>(samples_));
  trial.global.resize(static_cast<std::size_t>(samples_));
  trial.passed = false;
  for (Eigen::Index j = 0; j < samples_; ++j) {
    const auto at = static_cast<std::size_t>(j);
    trial.local[at] = LocalPose(rig_, b, mode, values_.row(j).data());
    trial.global[at] = p >= 0 ? Compose(reduced_[static_cast<std::size_t>(j * bones_ + p)], trial.local[at])
                              : trial.local[at];
    if (SubtreeError(b, j, trial.global[at], bound) > bound.limit) return;
  }
  trial.passed = true;
}

// The tolerance search: from bound.start_k, doubling while trials pass or
// halving until one does, then bisecting; the passing trial with the fewest
// keys becomes the bone's. Returns its k.
double WorldReducer::ReduceBone(int b, const SearchBound& bound) {
  scratch_.resize(static_cast<std::size_t>(bones_));
  Trial trials[2];
  Trial* current = &trials[0];
  Trial* best = &trials[1];
  best->passed = false;
  double pass = -1.0, fail = -1.0;
  const auto attempt = [&](double k) {
    RunTrial(b, k, bound, *current);
    if (!current->passed) {
      fail = k;
      return false;
    }
    pass = std::max(pass, k);
    if (!best->passed || current->key_points < best->key_points ||
        (current->key_points == best->key_points && k > best->k)) {
      std::swap(current, best);
    }
    return true;
  };
  double k = bound.start_k;
  if (k > 0.0 && attempt(k)) {
    for (int i = 0; i < kDoublings && attempt(k *= 2.0);) ++i;
  } else {
    for (int i = 0; i < kHalvings && k > 0.0 && !attempt(k *= 0.5);) ++i;
    if (pass < 0.0) attempt(0.0);
  }
  for (int i = 0; i < kBisections && pass > 0.0 && fail > pass; ++i) attempt(std::sqrt(pass * fail));
  if (!best->passed) std::swap(current, best);  // k = 0 reproduces the channels: only round-off can fail it
  StoreBest(b, *best);
  return best->k;
}

void WorldReducer::StoreBest(int b, const Trial& best) {
  const int mode = job_.rotation_modes[b];
  for (int g = 0; g < kGroups; ++g) {
    if (!Reduced(b, g)) continue;
    const GroupFit& fit = best.groups[g];
    job_.keys.col(kGroups * b + g).setZero();
    const Eigen::Index first = job_.group_ranges(kGroups * b + g, 0);
    const Eigen::Index width = GroupWidth(g, mode), column = kChannels * b + kGroupColumn[g];
    for (Eigen::Index k = 0; k < fit.count; ++k) {
      const Eigen::Index j = first + fit.indices[k];
      job_.keys(j, kGroups * b + g) = true;
      job_.slopes_in.block(j, column, 1, width) = fit.slopes_in.row(k);
      job_.slopes_out.block(j, column, 1, width) = fit.slopes_out.row(k);
    }
  }
  for (Eigen::Index j = 0; j < samples_; ++j) {
    reduced_local_[static_cast<std::size_t>(j * bones_ + b)] = best.local[static_cast<std::size_t>(j)];
    reduced_[static_cast<std::size_t>(j * bones_ + b)] = best.global[static_cast<std::size_t>(j)];
  }
}

std::string BoneName(const RigModel& rig, Eigen::Index b) { return "bone '" + rig.name(static_cast<int>(b)) + "'"; }

}  // namespace

Status WorldKeyReductionJob::Validate() const {
  const Eigen::Index m = times.size(), bones = rig.size();
  if (!(std::isfinite(distance) && distance > 0.0)) {
    return Status::Fail("world key reduction: distance must be finite and > 0, got " + std::to_string(distance));
  }
  if (!(std::isfinite(axis_length) && axis_length >= 0.0)) {
    return Status::Fail("world key reduction: axis_length must be finite and >= 0, got " +
                        std::to_string(axis_length));
  }
  if (stride < 1) return Status::Fail("world key reduction: stride must be at least 1");
  if (m < 1) return Status::Fail("world key reduction: no samples");
  if (channels.rows() != m || channels.cols() != kChannels * bones || rotation_modes.size() != bones ||
      group_ranges.rows() != kGroups * bones || group_ranges.cols() != 2) {
    return Status::Fail("world key reduction: expected channels (samples, 10 per bone), rotation modes (bones) "
                        "and group ranges (3 per bone, 2)");
  }
  if (keys.rows() != m || keys.cols() != kGroups * bones || slopes_in.rows() != m ||
      slopes_in.cols() != kChannels * bones || slopes_out.rows() != m || slopes_out.cols() != kChannels * bones) {
    return Status::Fail("world key reduction: outputs must be keys (samples, 3 per bone) and slopes "
                        "(samples, 10 per bone)");
  }
  for (Eigen::Index j = 0; j < m; ++j) {
    if (!internal::TimeInOrder(times.data(), j)) {
      return internal::TimeOrderFailure(times.data(), j, "world key reduction: ",
                                        {"time of sample", "sample times", "sample"});
    }
  }
  for (Eigen::Index b = 0; b < bones; ++b) {
    const int mode = rotation_modes[b];
    if (mode < 0 || mode >= kWorldEuler + kEulerOrders) {
      return Status::Fail("world key reduction: " + BoneName(rig, b) + " has rotation mode " + std::to_string(mode));
    }
    for (int g = 0; g < kGroups; ++g) {
      const int first = group_ranges(kGroups * b + g, 0), last = group_ranges(kGroups * b + g, 1);
      const bool kept = first == -1 && last == -1;
      if (!kept && !(0 <= first && first <= last && last < m)) {
        return Status::Fail("world key reduction: " + BoneName(rig, b) + " group " + std::to_string(g) +
                            " has sample range " + std::to_string(first) + ".." + std::to_string(last));
      }
    }
    for (Eigen::Index j = 0; j < m; ++j) {
      const auto row = channels.block(j, kChannels * b, 1, kChannels);
      const bool zero = mode == kWorldQuaternion && !(row.leftCols(4).squaredNorm() > 0.0);
      if (!row.allFinite() || zero) {
        return Status::Fail("world key reduction: " + BoneName(rig, b) + " at sample " + std::to_string(j) +
                            " has a non-finite channel or a zero quaternion");
      }
    }
  }
  return Status::Ok();
}

void WorldKeyReductionJob::Run() {
  Validate().ThrowIfFailed();
  WorldReducer reducer(*this);
  reducer.Run();
}

}  // namespace motionkit
