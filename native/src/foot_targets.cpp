#include "motionkit/foot_targets.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace motionkit {
namespace {

struct Interval {
  Eigen::Index start, end;  // [start, end)
};

std::vector<Interval> Intervals(const ConstBoolMatrixView& contacts, Eigen::Index p) {
  std::vector<Interval> runs;
  const Eigen::Index frames = contacts.rows();
  for (Eigen::Index f = 0; f < frames;) {
    if (!contacts(f, p)) {
      ++f;
      continue;
    }
    Eigen::Index e = f;
    while (e < frames && contacts(e, p)) ++e;
    runs.push_back({f, e});
    f = e;
  }
  return runs;
}

template <typename Matrix>
Eigen::Vector3d PointAt(const Matrix& points, Eigen::Index f, Eigen::Index p) {
  return points.row(f).template segment<3>(3 * p).transpose();
}

// np.median: the mean of the two middle values for an even count.
double Median(std::vector<double>& values) {
  const std::size_t n = values.size(), mid = n / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(mid), values.end());
  const double upper = values[mid];
  if (n % 2) return upper;
  return 0.5 * (upper + *std::max_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(mid)));
}

double Smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

// Per point its contacts and one plant per contact: the point's mean over it.
struct Plants {
  std::vector<std::vector<Interval>> runs;
  std::vector<std::vector<Eigen::Vector3d>> at;
};

Plants PlantEveryContact(const ConstMatrixView& points, const ConstBoolMatrixView& contacts) {
  const Eigen::Index count = contacts.cols();
  Plants plants;
  plants.runs.resize(static_cast<std::size_t>(count));
  plants.at.resize(static_cast<std::size_t>(count));
  for (Eigen::Index p = 0; p < count; ++p) {
    auto& mine = plants.runs[static_cast<std::size_t>(p)];
    mine = Intervals(contacts, p);
    for (const Interval& run : mine) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (Eigen::Index f = run.start; f < run.end; ++f) sum += PointAt(points, f, p);
      plants.at[static_cast<std::size_t>(p)].push_back(sum / static_cast<double>(run.end - run.start));
    }
  }
  return plants;
}

// A foot's second plant (point b) where its contact overlaps one of the first's (point a): on the line from
// that plant, the distance the two points keep in the clip, so that a rigid foot can hold both.
void PlaceSecondPlants(const ConstMatrixView& points, int a, int b, Plants* plants) {
  const auto& runs_a = plants->runs[static_cast<std::size_t>(a)];
  const auto& runs_b = plants->runs[static_cast<std::size_t>(b)];
  if (runs_a.empty() || runs_b.empty()) return;
  const Eigen::Index frames = points.rows();
  std::vector<double> spans(static_cast<std::size_t>(frames));
  for (Eigen::Index f = 0; f < frames; ++f) {
    spans[static_cast<std::size_t>(f)] = (PointAt(points, f, b) - PointAt(points, f, a)).norm();
  }
  const double distance = Median(spans);
  for (std::size_t j = 0; j < runs_b.size(); ++j) {
    Eigen::Index best_shared = std::numeric_limits<Eigen::Index>::min();
    std::size_t best = 0;
    for (std::size_t i = 0; i < runs_a.size(); ++i) {  // the a contact sharing the most frames, first of equals
      const Eigen::Index shared =
          std::min(runs_b[j].end, runs_a[i].end) - std::max(runs_b[j].start, runs_a[i].start);
      if (shared > best_shared) best_shared = shared, best = i;
    }
    const Eigen::Vector3d& anchor = plants->at[static_cast<std::size_t>(a)][best];
    Eigen::Vector3d& plant = plants->at[static_cast<std::size_t>(b)][j];
    const Eigen::Vector3d offset = plant - anchor;
    const double norm = offset.norm();
    if (best_shared > 0 && norm > 0) plant = anchor + offset * (distance / norm);
  }
}

// Per frame, point p's target is the plant of its nearest contact frame (the earlier one on a tie), its
// weight the ramp over the distance to it; away from every contact the point itself with weight 0.
void TargetNearestPlants(FootTargetsJob& job, const Plants& plants, Eigen::Index p) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const auto& mine = plants.runs[static_cast<std::size_t>(p)];
  const auto& mine_plants = plants.at[static_cast<std::size_t>(p)];
  std::size_t next = 0;  // the first contact that ends after f
  for (Eigen::Index f = 0; f < job.points.rows(); ++f) {
    while (next < mine.size() && mine[next].end <= f) ++next;
    double before = kInf, after = kInf;
    if (next > 0) before = static_cast<double>(f - (mine[next - 1].end - 1));
    if (next < mine.size()) after = f >= mine[next].start ? 0.0 : static_cast<double>(mine[next].start - f);
    if (after == 0.0) before = kInf;  // inside a contact
    const bool use_before = before <= after;
    const double distance = std::min(before, after);
    Eigen::Vector3d target = PointAt(job.points, f, p);
    if (std::isfinite(distance)) target = mine_plants[use_before ? next - 1 : next];
    job.weights(f, p) = std::isfinite(distance) ? Smoothstep(1.0 - distance / (job.blend_frames + 1.0)) : 0.0;
    job.targets.row(f).segment<3>(3 * p) = target.transpose();
  }
}

// Frame f's targets blended from the points to the plants by weight; each point's offset kept for its
// foot's other point.
void BlendToPlants(FootTargetsJob& job, Eigen::Index f, std::vector<Eigen::Vector3d>* offsets) {
  for (Eigen::Index p = 0; p < job.contacts.cols(); ++p) {
    const Eigen::Vector3d point = PointAt(job.points, f, p);
    Eigen::Vector3d& offset = (*offsets)[static_cast<std::size_t>(p)];
    offset = job.weights(f, p) * (PointAt(job.targets, f, p) - point);
    job.targets.row(f).segment<3>(3 * p) = (point + offset).transpose();
  }
}

// A foot's two targets on frame f: each carried with the other's offset as far as it is free (1 - weight),
// then put the distance apart its points keep, the correction shared in proportion to how free each is.
void KeepFootSpan(FootTargetsJob& job, Eigen::Index f, int a, int b, const std::vector<Eigen::Vector3d>& offsets) {
  const Eigen::Vector3d point_a = PointAt(job.points, f, a), point_b = PointAt(job.points, f, b);
  const Eigen::Vector3d &offset_a = offsets[static_cast<std::size_t>(a)], &offset_b = offsets[static_cast<std::size_t>(b)];
  const double w_a = job.weights(f, a), w_b = job.weights(f, b);
  Eigen::Vector3d out_a = point_a + offset_a + (1.0 - w_a) * offset_b;
  Eigen::Vector3d out_b = point_b + offset_b + (1.0 - w_b) * offset_a;
  const double distance = (point_b - point_a).norm();
  const Eigen::Vector3d span = out_b - out_a;
  const double length = span.norm();
  const Eigen::Vector3d unit = length > 0 ? Eigen::Vector3d(span / length) : Eigen::Vector3d::Zero();
  const double free_a = 1.0 - w_a, free_b = 1.0 - w_b, total = free_a + free_b;
  const double share_a = total > 0 ? free_a / total : 0.5;
  const Eigen::Vector3d excess = (length - distance) * unit;
  out_a += share_a * excess;
  out_b -= (1.0 - share_a) * excess;
  job.targets.row(f).segment<3>(3 * a) = out_a.transpose();
  job.targets.row(f).segment<3>(3 * b) = out_b.transpose();
}

}  // namespace

Status FootTargetsJob::Validate() const {
  const Eigen::Index frames = points.rows(), count = contacts.cols();
  if (points.cols() != 3 * count || contacts.rows() != frames) {
    return Status::Fail("foot targets: points must be (frames, 3P) and contacts (frames, P); got points (" +
                        std::to_string(frames) + ", " + std::to_string(points.cols()) + "), contacts (" +
                        std::to_string(contacts.rows()) + ", " + std::to_string(count) + ")");
  }
  if (targets.rows() != frames || targets.cols() != points.cols() || weights.rows() != frames ||
      weights.cols() != count) {
    return Status::Fail("foot targets: the outputs must be (frames, 3P) and (frames, P)");
  }
  if (blend_frames < 0) return Status::Fail("foot targets: blend_frames must not be negative");
  std::vector<bool> paired(static_cast<std::size_t>(count), false);
  for (const auto& pair : rigid) {
    for (const int p : pair) {
      if (p < 0 || p >= count || paired[static_cast<std::size_t>(p)] || pair[0] == pair[1]) {
        return Status::Fail("foot targets: rigid pairs must name distinct points in [0, " + std::to_string(count) +
                            "), each in one pair at most");
      }
      paired[static_cast<std::size_t>(p)] = true;
    }
  }
  for (Eigen::Index f = 0; f < frames; ++f) {
    for (Eigen::Index c = 0; c < points.cols(); ++c) {
      if (!std::isfinite(points(f, c))) {
        return Status::Fail("foot targets: point " + std::to_string(c / 3) + " is not finite at frame index " +
                            std::to_string(f));
      }
    }
  }
  return Status::Ok();
}

void FootTargetsJob::Run() {
  Validate().ThrowIfFailed();
  Plants plants = PlantEveryContact(points, contacts);
  for (const auto& [a, b] : rigid) PlaceSecondPlants(points, a, b, &plants);
  for (Eigen::Index p = 0; p < contacts.cols(); ++p) TargetNearestPlants(*this, plants, p);
  std::vector<Eigen::Vector3d> offsets(static_cast<std::size_t>(contacts.cols()));
  for (Eigen::Index f = 0; f < points.rows(); ++f) {
    BlendToPlants(*this, f, &offsets);
    for (const auto& [a, b] : rigid) KeepFootSpan(*this, f, a, b, offsets);
  }
}

}  // namespace motionkit
