#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "body_boxes.hpp"
#include "motionkit/body_arm.hpp"

namespace motionkit {
namespace {

using namespace testing_boxes;

constexpr int kForearm = 8, kHand = 4, kFrames = 41;
const Eigen::Vector3d kHalf(0.3, 0.2, 0.5);  // the body: a box about the one carrier's head
constexpr double kSpacing = 0.02, kWanted = 0.02;
// body_arm.cpp's: a frame's solve stops once every point is within a hundredth of a cell of where it is wanted.
constexpr double kConverged = 1e-2;

// Four bones standing unturned: the body's one carrier (0) at the origin, the upper arm (1), the forearm
// (2) and the hand (3) beside the box: the shoulder 40 cm above the elbow, the forearm (30 cm) and the hand
// (10 cm) reaching along -x, the whole arm on frame f as near as a sine asks: the hand's tip from 5 cm off
// the box's face (x = 0.3) to 25 cm into it and back. Eight skin points on the forearm, four on the hand.
struct Scene {
  Field field = Build(Box(kHalf), std::vector<int>(8, 0), kSpacing, 0.2);
  RowMatrixXd orientations = RowMatrixXd::Zero(kFrames, 16);
  RowMatrixXd heads = RowMatrixXd::Zero(kFrames, 12);
  std::vector<int> point_bones;
  RowMatrixXd point_local = RowMatrixXd(kForearm + kHand, 3);
  std::vector<int> on_hand;
  std::vector<int> frames;
  Eigen::VectorXd wanted = Eigen::VectorXd::Constant(kFrames, kWanted);
  std::vector<int> touch = std::vector<int>(kFrames, 0);
  RowMatrixXd goals = RowMatrixXd(0, 3);
  RowMatrixXd no_contacts = RowMatrixXd(0, 3);
  Eigen::Matrix<double, 1, 3> carrier_rest_head = Eigen::Matrix<double, 1, 3>::Zero();
  RowMatrixXd carrier_rest = (RowMatrixXd(1, 4) << 1.0, 0.0, 0.0, 0.0).finished();
  Eigen::Matrix<int, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> no_boxes =
      Eigen::Matrix<int, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>(0, 6);

  Scene() {
    for (int b = 0; b < 4; ++b) orientations.col(4 * b).setOnes();
    for (int f = 0; f < kFrames; ++f) {
      const double elbow = 0.75 - 0.3 * std::sin(M_PI * f / (kFrames - 1));
      heads.row(f) << 0, 0, 0, elbow, 0, 0.4, elbow, 0, 0, elbow - 0.3, 0, 0;
      frames.push_back(f);
    }
    for (int n = 0; n < kForearm + kHand; ++n) {
      const bool hand = n >= kForearm;
      point_bones.push_back(hand ? 3 : 2);
      on_hand.push_back(hand ? 1 : 0);
      point_local.row(n) << (hand ? -0.1 * (n - kForearm + 1.0) / kHand : -0.3 * (n + 1.0) / kForearm), 0, 0;
    }
  }

  BodyFieldView View() const {
    return {field.distance, field.bone, field.dims, field.origin, field.spacing, {0}, carrier_rest, carrier_rest_head,
            no_boxes};
  }
  Eigen::Vector3d Head(int f, int b) const { return heads.block<1, 3>(f, 3 * b).transpose(); }
};

struct Solved {
  RowMatrixXd turns = RowMatrixXd::Zero(kFrames, 6);
  Eigen::VectorXd least = Eigen::VectorXd(kFrames), hand = Eigen::VectorXd(kFrames), gap = Eigen::VectorXd(kFrames);
};

Solved Solve(const Scene& s, int iterations, int threads = 1, double smoothness = 0.0) {
  Solved out;
  BodyArmJob job(s.View(), s.orientations, s.heads, {1, 2, 3}, s.point_bones, s.point_local, s.on_hand, s.frames,
                 s.wanted, s.touch, s.goals, s.no_contacts, out.turns, out.least, out.hand, out.gap);
  job.iterations = iterations;
  job.threads = threads;
  job.smoothness = smoothness;
  job.touch_distance = 0.5 * kSpacing;
  job.Run();
  return out;
}

// The largest change of a joint's turn from one frame to the next.
double LargestChange(const RowMatrixXd& turns) {
  double most = 0.0;
  for (Eigen::Index f = 1; f < turns.rows(); ++f) {
    for (int joint = 0; joint < 2; ++joint) {
      most = std::max(most, (turns.block<1, 3>(f, 3 * joint) - turns.block<1, 3>(f - 1, 3 * joint)).norm());
    }
  }
  return most;
}

Eigen::Quaterniond Turn(const Eigen::Vector3d& v) {
  return v.norm() > 0.0 ? Eigen::Quaterniond(Eigen::AngleAxisd(v.norm(), v.normalized())) : Eigen::Quaterniond::Identity();
}

// The points of frame f where the turns put them, as the header says a turn moves them.
std::vector<Eigen::Vector3d> Moved(const Scene& s, const RowMatrixXd& turns, int f) {
  const Eigen::Vector3d shoulder = s.Head(f, 1), elbow = s.Head(f, 2), wrist = s.Head(f, 3);
  const Eigen::Quaterniond qs = Turn(turns.block<1, 3>(f, 0).transpose()), qe = Turn(turns.block<1, 3>(f, 3).transpose());
  const Eigen::Vector3d new_elbow = qs * (elbow - shoulder) + shoulder, new_wrist = qs * qe * (wrist - elbow) + new_elbow;
  std::vector<Eigen::Vector3d> out;
  for (int n = 0; n < kForearm + kHand; ++n) {
    const bool hand = s.on_hand[static_cast<std::size_t>(n)] != 0;
    const Eigen::Vector3d p = s.Head(f, hand ? 3 : 2) + s.point_local.row(n).transpose();  // the bones unturned
    out.push_back(hand ? Eigen::Vector3d(p - wrist + new_wrist) : Eigen::Vector3d(qs * qe * (p - elbow) + new_elbow));
  }
  return out;
}

double Nearest(const std::vector<Eigen::Vector3d>& points) {
  double d = std::numeric_limits<double>::infinity();
  for (const auto& p : points) d = std::min(d, BoxDistance(p, kHalf));
  return d;
}

// Measured without turning, the arm's nearest point is the box's exact distance: outside the box and within
// ten cells inside its face, the field is the distance of its one nearest face, linear, so trilinear reading
// is exact to doubles (body_field_test's 1e-12).
TEST(BodyArm, MeasuringAloneReadsTheBodysDistanceAndTurnsNothing) {
  const Scene s;
  const Solved m = Solve(s, 0);
  EXPECT_TRUE((m.turns.array() == 0.0).all());
  for (int f = 0; f < kFrames; ++f) {
    const std::vector<Eigen::Vector3d> points = Moved(s, m.turns, f);
    const double want = Nearest(points);
    if (want > -0.1) {
      EXPECT_NEAR(m.least[f], want, 1e-12) << "frame " << f;
    }
  }
}

// Out to the clearance asked by the field (to the solve's convergence, a hundredth of a cell), and out of the
// box by its own distance: the field is within sqrt(3)/2 of a cell of it anywhere (the distance is
// 1-Lipschitz, read between cell centres where it is exact), so a clearance of a cell leaves a gap;
// frames already clear left to the bit. Given the steps to converge: the deepest frame, 25 cm in, takes
// more than the stage's 6 a round.
TEST(BodyArm, AnArmIntoTheBoxComesOutToTheClearanceAndAClearOneIsLeft) {
  const Scene s;
  const Solved m = Solve(s, 0), solved = Solve(s, 40);
  int moved = 0;
  for (int f = 0; f < kFrames; ++f) {
    if (m.least[f] >= kWanted) {
      EXPECT_TRUE((solved.turns.row(f).array() == 0.0).all()) << "frame " << f;
      continue;
    }
    ++moved;
    const double out = Nearest(Moved(s, solved.turns, f));
    EXPECT_GT(solved.least[f], kWanted - kConverged * kSpacing) << "frame " << f;
    EXPECT_GT(out, kWanted - std::sqrt(3.0) / 2.0 * kSpacing) << "frame " << f;
  }
  EXPECT_GT(moved, kFrames / 2);
}

// Only the frames listed are solved and measured, in their order; the others' turns are left as given.
TEST(BodyArm, OnlyTheFramesListedAreSolved) {
  Scene s;
  const Solved all = Solve(s, 6);
  s.frames = {20, 5};
  Solved some;
  some.least.resize(2);
  some.hand.resize(2);
  some.gap.resize(2);
  some.turns.row(7).setConstant(0.125);
  BodyArmJob job(s.View(), s.orientations, s.heads, {1, 2, 3}, s.point_bones, s.point_local, s.on_hand, s.frames,
                 s.wanted, s.touch, s.goals, s.no_contacts, some.turns, some.least, some.hand, some.gap);
  job.Run();
  EXPECT_TRUE((some.turns.row(20).array() == all.turns.row(20).array()).all());
  EXPECT_TRUE((some.turns.row(5).array() == all.turns.row(5).array()).all());
  EXPECT_EQ(some.least[0], all.least[20]);
  EXPECT_EQ(some.least[1], all.least[5]);
  EXPECT_TRUE((some.turns.row(7).array() == 0.125).all());
  EXPECT_TRUE((some.turns.row(10).array() == 0.0).all());
}

TEST(BodyArm, ThreadsChangeNothing) {
  const Scene s;
  const Solved one = Solve(s, 6, 1), two = Solve(s, 6, 2), five = Solve(s, 6, 5);
  EXPECT_TRUE((one.turns.array() == two.turns.array()).all() && (one.turns.array() == five.turns.array()).all());
  EXPECT_TRUE((one.least.array() == two.least.array()).all());
}

// Where the hand is to touch (and the rest of the arm asked to keep no more than the touch's half cell, as
// where the source touches its own body), its nearest point comes to half a cell from the box, from outside
// or in: to the solve's convergence by the field, to the field's bound by the box's own distance. Given
// the steps to converge (the deepest frames' nearest hand point changes as the hand comes out; the stage
// takes 6 a round, and rounds).
TEST(BodyArm, AHandToTouchIsBroughtOntoTheBody) {
  Scene s;
  std::fill(s.touch.begin(), s.touch.end(), 1);
  s.wanted.setConstant(0.5 * kSpacing);
  const Solved solved = Solve(s, 40);
  for (int f = 0; f < kFrames; ++f) {
    const std::vector<Eigen::Vector3d> points = Moved(s, solved.turns, f);
    double hand = std::numeric_limits<double>::infinity();
    for (int n = kForearm; n < kForearm + kHand; ++n) hand = std::min(hand, BoxDistance(points[static_cast<std::size_t>(n)], kHalf));
    EXPECT_NEAR(solved.hand[f], 0.5 * kSpacing, kConverged * kSpacing) << "frame " << f;  // the solve's convergence
    EXPECT_NEAR(hand, 0.5 * kSpacing, std::sqrt(3.0) / 2.0 * kSpacing) << "frame " << f;  // the field's bound
  }
}

// With a goal (a place on the body, half a cell off the box's side, 30 cm below the shoulder's height), the
// touching hand's nearest point is brought onto it on every frame, wherever the arm started, by the
// points' own positions (the test's Moved); the rest of the arm stays out by the field's bound.
TEST(BodyArm, AHandWithAGoalIsBroughtOntoThatPlace) {
  Scene s;
  std::fill(s.touch.begin(), s.touch.end(), 1);
  s.wanted.setConstant(0.5 * kSpacing);
  const Eigen::Vector3d goal(kHalf.x() + 0.5 * kSpacing, 0.0, 0.1);
  s.goals = goal.transpose().replicate(kFrames, 1);
  const Solved solved = Solve(s, 40);
  for (int f = 0; f < kFrames; ++f) {
    const std::vector<Eigen::Vector3d> points = Moved(s, solved.turns, f);
    double gap = std::numeric_limits<double>::infinity(), inside = 0.0;
    for (int n = 0; n < kForearm + kHand; ++n) {
      const Eigen::Vector3d& p = points[static_cast<std::size_t>(n)];
      if (n >= kForearm) gap = std::min(gap, (p - goal).norm());
      inside = std::min(inside, BoxDistance(p, kHalf));
    }
    EXPECT_LT(gap, kConverged * kSpacing) << "frame " << f;  // the solve's convergence
    EXPECT_NEAR(solved.gap[f], gap, 1e-12) << "frame " << f;
    EXPECT_GT(inside, -std::sqrt(3.0) / 2.0 * kSpacing) << "frame " << f;
  }
}

// Solved as one run, the frames' turns change less from one frame to the next than each frame's alone (by
// 5 times here), and every frame still comes out of the box to within half a cell of its clearance (the
// field's precision the stage keeps; measured 0.03 of a cell): the coupling (0.02 a radian against the
// points' metres) pulls a frame toward its neighbours far less than its points' own rows hold it out.
// The frames are listed out of order (the runs are found by index), and any thread count gives the same.
TEST(BodyArm, ARunSolvedAsOneTakesAlikeTurnsAndStillComesOut) {
  Scene s;
  const Solved alone = Solve(s, 40);
  std::reverse(s.frames.begin(), s.frames.end());
  const Solved one = Solve(s, 40, 1, 0.02), two = Solve(s, 40, 2, 0.02);
  EXPECT_LT(LargestChange(one.turns), 0.5 * LargestChange(alone.turns));
  EXPECT_TRUE((one.turns.array() == two.turns.array()).all());
  for (int f = 0; f < kFrames; ++f) {
    EXPECT_GT(one.least[kFrames - 1 - f], kWanted - 0.5 * kSpacing) << "frame " << f;
    // least is measured where the turns put the arm (the list's order: reversed).
    EXPECT_NEAR(one.least[kFrames - 1 - f], Nearest(Moved(s, one.turns, f)), std::sqrt(3.0) / 2.0 * kSpacing);
  }
}

TEST(BodyArm, BadInputIsRefusedByName) {
  Scene s;
  s.heads(7, 4) = std::nan("");
  Solved out;
  BodyArmJob job(s.View(), s.orientations, s.heads, {1, 2, 3}, s.point_bones, s.point_local, s.on_hand, s.frames,
                 s.wanted, s.touch, s.goals, s.no_contacts, out.turns, out.least, out.hand, out.gap);
  EXPECT_NE(job.Validate().message().find("frame index 7"), std::string::npos);
  s.heads(7, 4) = 0.0;
  EXPECT_TRUE(job.Validate().ok());
  job.on_hand.pop_back();
  EXPECT_NE(job.Validate().message().find("one on_hand a point"), std::string::npos);
  job.on_hand.push_back(1);
  job.point_bones[3] = 4;
  EXPECT_NE(job.Validate().message().find("point bone 4 out of range"), std::string::npos);
  job.point_bones[3] = 2;
  job.frames[3] = job.frames[2];
  EXPECT_NE(job.Validate().message().find("frame index 2 listed twice"), std::string::npos);
  job.frames[3] = 3;
  job.smoothness = -1.0;
  EXPECT_NE(job.Validate().message().find("smoothness >= 0"), std::string::npos);
  job.smoothness = 0.0;
  job.max_step = 0.0;
  EXPECT_THROW(job.Run(), Error);
}

}  // namespace
}  // namespace motionkit
