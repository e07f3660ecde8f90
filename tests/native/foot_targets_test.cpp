#include "motionkit/foot_targets.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace motionkit {
namespace {

using BoolMatrix = Eigen::Matrix<bool, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct Solved {
  RowMatrixXd targets, weights;
  Status status = Status::Ok();
};

Solved Targets(const RowMatrixXd& points, const BoolMatrix& contacts, int blend, std::vector<std::array<int, 2>> rigid) {
  Solved out;
  out.targets.resize(points.rows(), points.cols());
  out.weights.resize(contacts.rows(), contacts.cols());
  FootTargetsJob job(points, contacts, blend, std::move(rigid), out.targets, out.weights);
  out.status = job.Validate();
  if (out.status.ok()) job.Run();
  return out;
}

double Smoothstep(double x) { return x * x * (3 - 2 * x); }

TEST(FootTargets, OnePointBlendsToTheMeanOfItsContactOverTheRamp) {
  // A point sliding along x at 1 unit a frame, standing (contact) on frames 2..4: its plant is x = 3.
  RowMatrixXd points(8, 3);
  BoolMatrix contacts = BoolMatrix::Zero(8, 1);
  for (int f = 0; f < 8; ++f) points.row(f) << f, 0.5, 0.0;
  contacts.block(2, 0, 3, 1).setConstant(true);
  const Solved run = Targets(points, contacts, 2, {});
  ASSERT_TRUE(run.status.ok()) << run.status.message();
  // Distance d frames from the contact: weight smoothstep(1 - d / 3).
  const double expected_weights[8] = {Smoothstep(1.0 / 3), Smoothstep(2.0 / 3), 1, 1, 1, Smoothstep(2.0 / 3),
                                      Smoothstep(1.0 / 3), 0};
  for (int f = 0; f < 8; ++f) {
    EXPECT_NEAR(run.weights(f, 0), expected_weights[f], 1e-15) << f;
    const double w = expected_weights[f];
    EXPECT_NEAR(run.targets(f, 0), f + w * (3.0 - f), 1e-12) << f;
    EXPECT_NEAR(run.targets(f, 1), 0.5, 1e-15) << f;
  }
}

TEST(FootTargets, BetweenTwoContactsTheNearerOneWinsAndTheEarlierOnATie) {
  RowMatrixXd points = RowMatrixXd::Zero(9, 3);
  for (int f = 0; f < 9; ++f) points(f, 0) = f;
  BoolMatrix contacts = BoolMatrix::Zero(9, 1);
  contacts(1, 0) = contacts(7, 0) = true;  // plants x = 1 and x = 7; frame 4 is 3 frames from both
  const Solved run = Targets(points, contacts, 10, {});
  ASSERT_TRUE(run.status.ok());
  for (int f = 0; f < 9; ++f) {
    const double plant = f <= 4 ? 1.0 : 7.0, d = std::abs(f - plant);
    const double w = Smoothstep(1.0 - d / 11.0);
    EXPECT_NEAR(run.weights(f, 0), w, 1e-15) << f;
    EXPECT_NEAR(run.targets(f, 0), f + w * (plant - f), 1e-12) << f;
  }
}

TEST(FootTargets, NoContactLeavesThePointsAsTheyAre) {
  RowMatrixXd points = RowMatrixXd::Random(5, 6);
  const Solved run = Targets(points, BoolMatrix::Zero(5, 2), 3, {{0, 1}});
  ASSERT_TRUE(run.status.ok());
  EXPECT_EQ(run.weights.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_TRUE(run.targets.isApprox(points, 1e-15));
}

TEST(FootTargets, AFootsTwoTargetsKeepTheDistanceItsPointsKeep) {
  // Ankle and ball 0.2 apart, turning about the ankle while the ball stands and the ankle lifts off.
  const int frames = 40;
  RowMatrixXd points(frames, 6);
  BoolMatrix contacts = BoolMatrix::Zero(frames, 2);
  for (int f = 0; f < frames; ++f) {
    const double angle = 0.02 * f;
    const Eigen::Vector3d ankle(0.01 * f, 0.0, 0.1 + 0.002 * f);
    points.row(f).head<3>() = ankle.transpose();
    points.row(f).tail<3>() = (ankle + 0.2 * Eigen::Vector3d(std::cos(angle), 0.0, -std::sin(angle))).transpose();
    contacts(f, 0) = f < 15;
    contacts(f, 1) = f >= 5 && f < 30;
  }
  const Solved run = Targets(points, contacts, 4, {{0, 1}});
  ASSERT_TRUE(run.status.ok()) << run.status.message();
  for (int f = 0; f < frames; ++f) {
    const double span = (run.targets.row(f).tail<3>() - run.targets.row(f).head<3>()).norm();
    EXPECT_NEAR(span, 0.2, 1e-12) << f;
  }
  // Where both stand, both hold still.
  for (int f = 6; f < 15; ++f) EXPECT_TRUE(run.targets.row(f).isApprox(run.targets.row(5), 1e-12)) << f;
}

TEST(FootTargets, BadInputIsNamed) {
  RowMatrixXd points = RowMatrixXd::Zero(4, 6);
  points(2, 4) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(Targets(points, BoolMatrix::Zero(4, 2), 1, {}).status.message().find("point 1 is not finite at frame "
                                                                                 "index 2"),
            std::string::npos);
  points(2, 4) = 0.0;
  EXPECT_FALSE(Targets(points, BoolMatrix::Zero(4, 2), -1, {}).status.ok());
  EXPECT_FALSE(Targets(points, BoolMatrix::Zero(4, 2), 1, {{0, 2}}).status.ok());
  EXPECT_FALSE(Targets(points, BoolMatrix::Zero(4, 2), 1, {{1, 1}}).status.ok());
  EXPECT_FALSE(Targets(points, BoolMatrix::Zero(4, 3), 1, {}).status.ok());
}

}  // namespace
}  // namespace motionkit
