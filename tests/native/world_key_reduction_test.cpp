#include "motionkit/world_key_reduction.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "motionkit/rig.hpp"

namespace motionkit {
namespace {

// A chain of three bones along Y (rest: identity), each turning about a
// tilted axis, the root also moving; 4 samples per frame over 120 frames.
struct Chain {
  RigModel rig{{"root", "mid", "tip"},
               {-1, 0, 1},
               RowMatrixXd::NullaryExpr(3, 4, [](Eigen::Index, Eigen::Index c) { return c == 0 ? 1.0 : 0.0; }),
               (RowMatrixXd(3, 3) << 0, 0, 0, 0, 0.5, 0, 0, 0.9, 0).finished(),
               Eigen::Vector3d(0.5, 0.4, 0.3)};
  Eigen::VectorXd times;
  RowMatrixXd channels;
  Eigen::VectorXi modes = Eigen::VectorXi::Zero(3);
  Eigen::Matrix<int, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> ranges;

  Chain() {
    const Eigen::Index m = 481;
    times = Eigen::VectorXd::LinSpaced(m, 0.0, 120.0);
    channels = RowMatrixXd::Zero(m, 30);
    for (Eigen::Index j = 0; j < m; ++j) {
      for (int b = 0; b < 3; ++b) {
        const double angle = 0.6 * std::sin(times[j] / (9.0 + 4.0 * b));
        const Eigen::Quaterniond q(Eigen::AngleAxisd(angle, Eigen::Vector3d(1.0, 0.3 * b, 0.5).normalized()));
        channels.block(j, 10 * b, 1, 4) << q.w(), q.x(), q.y(), q.z();
        channels.block(j, 10 * b + 7, 1, 3).setOnes();
      }
      channels.block(j, 4, 1, 3) << 0.2 * std::sin(times[j] / 11.0), 0.0, 0.1 * std::cos(times[j] / 7.0);
    }
    ranges.setConstant(9, 2, -1);
    for (int b = 0; b < 3; ++b) ranges.row(3 * b) << 0, static_cast<int>(m - 1);
    ranges.row(1) << 0, static_cast<int>(m - 1);  // the root's location
  }
};

struct Result {
  Eigen::Matrix<bool, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> keys;
  RowMatrixXd slopes_in, slopes_out;
  double worst = 0.0;
};

Result Reduce(const Chain& chain, double distance, double axis_length) {
  const Eigen::Index m = chain.times.size();
  Result r{decltype(Result::keys)(m, 9), RowMatrixXd(m, 30), RowMatrixXd(m, 30), 0.0};
  WorldKeyReductionJob job(chain.rig, chain.times, chain.channels, chain.modes, chain.ranges, r.keys, r.slopes_in,
                           r.slopes_out);
  job.distance = distance;
  job.axis_length = axis_length;
  job.stride = 4;
  job.Run();
  r.worst = job.worst_error;
  return r;
}

// Every channel of the reduced curves at every sample, drawn as Blender draws
// Bézier keys with handles at a third of each segment (Bernstein form).
RowMatrixXd Redraw(const Chain& chain, const Result& r) {
  RowMatrixXd out = chain.channels;
  const int group_of_column[10] = {0, 0, 0, 0, 1, 1, 1, 2, 2, 2};
  for (Eigen::Index c = 0; c < 30; ++c) {
    const Eigen::Index group = 3 * (c / 10) + group_of_column[c % 10];
    if (chain.ranges(group, 0) < 0) continue;
    Eigen::Index a = 0;
    for (Eigen::Index b = 1; b < chain.times.size(); ++b) {
      if (!r.keys(b, group)) continue;
      const double h = chain.times[b] - chain.times[a];
      const double p0 = chain.channels(a, c), p3 = chain.channels(b, c);
      const double p1 = p0 + r.slopes_out(a, c) * h / 3, p2 = p3 - r.slopes_in(b, c) * h / 3;
      for (Eigen::Index j = a + 1; j < b; ++j) {
        const double u = (chain.times[j] - chain.times[a]) / h, v = 1 - u;
        out(j, c) = v * v * v * p0 + 3 * v * v * u * p1 + 3 * v * u * u * p2 + u * u * u * p3;
      }
      a = b;
    }
  }
  return out;
}

// Heads, axis points and the tip's tail of every bone on every sample, through
// the armature pose job (unit scale).
std::vector<Eigen::Vector3d> Points(const Chain& chain, const RowMatrixXd& channels, double axis_length) {
  const Eigen::Index m = chain.times.size();
  RowMatrixXd rotations(m, 12), locations(m, 9), posed(m, 12), heads(m, 9);
  for (int b = 0; b < 3; ++b) {
    rotations.middleCols(4 * b, 4) = channels.middleCols(10 * b, 4);
    locations.middleCols(3 * b, 3) = channels.middleCols(10 * b + 4, 3);
  }
  ArmaturePoseJob job(chain.rig, rotations, locations, posed, heads);
  job.Run();
  std::vector<Eigen::Vector3d> points;
  for (Eigen::Index j = 0; j < m; ++j) {
    for (int b = 0; b < 3; ++b) {
      const Eigen::Quaterniond q(posed(j, 4 * b), posed(j, 4 * b + 1), posed(j, 4 * b + 2), posed(j, 4 * b + 3));
      const Eigen::Vector3d head = heads.row(j).segment<3>(3 * b).transpose();
      points.push_back(head);
      for (int axis = 0; axis < 3; ++axis) points.push_back(head + axis_length * (q * Eigen::Vector3d::Unit(axis)));
      if (b == 2) points.push_back(head + q * Eigen::Vector3d(0, chain.rig.length(b), 0));
    }
  }
  return points;
}

TEST(WorldKeyReduction, EveryPointStaysWithinTheDistanceThroughTheChain) {
  const Chain chain;
  const double distance = 1e-3, axis_length = 0.1;
  const Result r = Reduce(chain, distance, axis_length);
  EXPECT_LE(r.worst, distance);
  const auto original = Points(chain, chain.channels, axis_length);
  const auto reduced = Points(chain, Redraw(chain, r), axis_length);
  double worst = 0.0;
  for (std::size_t i = 0; i < original.size(); ++i) worst = std::max(worst, (reduced[i] - original[i]).norm());
  EXPECT_LE(worst, distance * (1 + 1e-9));
  EXPECT_GT(worst, 0.2 * distance);  // the bound is used, not met by keeping everything
  for (int group : {0, 1, 3, 6}) {
    const Eigen::Index keys = r.keys.col(group).count();
    EXPECT_GE(keys, 2);
    EXPECT_LT(keys, 60) << "group " << group;
    for (Eigen::Index j = 0; j < chain.times.size(); ++j) {
      if (r.keys(j, group)) {
        EXPECT_TRUE(j % 4 == 0 || j + 1 == chain.times.size()) << "key off a frame at sample " << j;
      }
    }
  }
  EXPECT_EQ(r.keys.col(2).count(), 0);  // a group left as it is gets no keys
}

TEST(WorldKeyReduction, BadSettingsNameThemselves) {
  const Chain chain;
  const Eigen::Index m = chain.times.size();
  decltype(Result::keys) keys(m, 9);
  RowMatrixXd in(m, 30), out(m, 30);
  WorldKeyReductionJob job(chain.rig, chain.times, chain.channels, chain.modes, chain.ranges, keys, in, out);
  job.distance = 0.0;
  EXPECT_NE(job.Validate().message().find("distance"), std::string::npos);
  job.distance = std::nan("");
  EXPECT_NE(job.Validate().message().find("distance"), std::string::npos);
  job.distance = 1e-3;
  job.axis_length = -0.1;
  EXPECT_NE(job.Validate().message().find("axis_length"), std::string::npos);
  job.axis_length = 0.1;
  EXPECT_TRUE(job.Validate());
  auto ranges = chain.ranges;
  ranges.row(0) << 5, static_cast<int>(m);
  WorldKeyReductionJob bad(chain.rig, chain.times, chain.channels, chain.modes, ranges, keys, in, out);
  EXPECT_NE(bad.Validate().message().find("bone 'root'"), std::string::npos);
}

}  // namespace
}  // namespace motionkit
