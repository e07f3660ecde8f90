#include "motionkit/fcurve_eval.hpp"

#include <gtest/gtest.h>

#include <limits>

namespace motionkit {
namespace {

struct Curves {
  RowMatrixXd co, left, right;
  Eigen::VectorXi interpolation, offsets, linear;
};

// One curve of keys (x, y) with the given interpolation; handles a third of
// the way to the neighbours (so Bezier segments are straight lines).
Curves OneCurve(const std::vector<std::pair<double, double>>& keys, int interpolation, bool linear) {
  const auto n = static_cast<Eigen::Index>(keys.size());
  Curves c{RowMatrixXd(n, 2), RowMatrixXd(n, 2), RowMatrixXd(n, 2), Eigen::VectorXi::Constant(n, interpolation),
           Eigen::VectorXi(2), Eigen::VectorXi::Constant(1, linear ? 1 : 0)};
  for (Eigen::Index k = 0; k < n; ++k) c.co.row(k) << keys[static_cast<std::size_t>(k)].first, keys[static_cast<std::size_t>(k)].second;
  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Index prev = k > 0 ? k - 1 : k, next = k + 1 < n ? k + 1 : k;
    c.left.row(k) = c.co.row(k) + (c.co.row(prev) - c.co.row(k)) / 3.0;
    c.right.row(k) = c.co.row(k) + (c.co.row(next) - c.co.row(k)) / 3.0;
  }
  c.offsets << 0, static_cast<int>(n);
  return c;
}

Eigen::RowVectorXd Evaluate(const Curves& c, const Eigen::VectorXd& times) {
  RowMatrixXd out(1, times.size());
  FCurveEvaluateJob job(c.co, c.left, c.right, c.interpolation, c.offsets, c.linear, times, out);
  job.Run();
  return out.row(0);
}

TEST(FCurveEvaluate, LinearKeysAndBothExtrapolations) {
  Eigen::VectorXd times(5);
  times << -5, 0, 2.5, 10, 12;
  const Curves linear = OneCurve({{0, 0}, {10, 10}}, kKeyLinear, true);
  EXPECT_TRUE(Evaluate(linear, times).isApprox(Eigen::RowVectorXd(times.transpose())));
  const Curves held = OneCurve({{0, 0}, {10, 10}}, kKeyLinear, false);
  Eigen::RowVectorXd expected(5);
  expected << 0, 0, 2.5, 10, 10;
  EXPECT_TRUE(Evaluate(held, times).isApprox(expected));
}

TEST(FCurveEvaluate, ConstantKeysHoldTheirValue) {
  Eigen::VectorXd times(3);
  times << 0.5, 1.0, 1.99;
  const Curves c = OneCurve({{0, 3}, {1, 4}, {2, 5}}, kKeyConstant, false);
  Eigen::RowVectorXd expected(3);
  expected << 3, 4, 4;
  EXPECT_EQ(Evaluate(c, times), expected);
}

TEST(FCurveEvaluate, BezierWithThirdHandlesIsTheStraightLine) {
  const Curves c = OneCurve({{0, 0}, {3, 6}, {4, 2}}, kKeyBezier, false);
  Eigen::VectorXd times = Eigen::VectorXd::LinSpaced(41, 0.0, 4.0);
  const Eigen::RowVectorXd got = Evaluate(c, times);
  for (Eigen::Index i = 0; i < times.size(); ++i) {
    const double t = times[i];
    const double want = t <= 3 ? 2 * t : 6 - 4 * (t - 3);
    EXPECT_NEAR(got[i], want, 1e-12) << t;
  }
}

TEST(FCurveEvaluate, OverlongHandlesAreShortenedToTheSegment) {
  // Handles reaching 10 frames over a 1-frame segment behave as 1-frame handles.
  Curves c = OneCurve({{0, 0}, {1, 1}}, kKeyBezier, false);
  c.right.row(0) << 10, 0;
  c.left.row(1) << -9, 1;
  Curves shortened = c;
  shortened.right.row(0) << 1, 0;
  shortened.left.row(1) << 0, 1;
  Eigen::VectorXd times = Eigen::VectorXd::LinSpaced(9, 0.1, 0.9);
  EXPECT_TRUE(Evaluate(c, times).isApprox(Evaluate(shortened, times), 1e-12));
}

TEST(FCurveEvaluate, TimesNearAKeySnapToIt) {
  Curves c = OneCurve({{0, 0}, {1, 100}}, kKeyLinear, false);
  Eigen::VectorXd times(1);
  times << 1.0 - 5e-5;
  EXPECT_EQ(Evaluate(c, times)[0], 100.0);
}

TEST(FCurveEvaluate, RejectsBadInput) {
  Curves c = OneCurve({{0, 0}, {1, 1}}, kKeyLinear, false);
  c.co(1, 1) = std::numeric_limits<double>::quiet_NaN();
  Eigen::VectorXd times(1);
  times << 0.5;
  RowMatrixXd out(1, 1);
  FCurveEvaluateJob job(c.co, c.left, c.right, c.interpolation, c.offsets, c.linear, times, out);
  EXPECT_EQ(job.Validate().message(), "fcurve evaluate: curve 0, key 1 is not finite");
  EXPECT_THROW(job.Run(), Error);
  Curves unordered = OneCurve({{2, 0}, {1, 1}}, kKeyLinear, false);
  FCurveEvaluateJob job2(unordered.co, unordered.left, unordered.right, unordered.interpolation,
                         unordered.offsets, unordered.linear, times, out);
  EXPECT_EQ(job2.Validate().message(), "fcurve evaluate: curve 0, key 1 comes before the key it follows");
}

}  // namespace
}  // namespace motionkit
