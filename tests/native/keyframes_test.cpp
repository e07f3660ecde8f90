#include "motionkit/keyframes.hpp"

#include <gtest/gtest.h>

#include <limits>

namespace motionkit {
namespace {

TEST(KeyframeCoJob, InterleavesFramesAndValuesPerCurve) {
  Eigen::VectorXd frames(3);
  frames << 1.0, 2.0, 4.5;
  RowMatrixXd values(2, 3);
  values << 10, 11, 12,  //
      -1, -2, -3;
  RowMatrixXf co(2, 6);
  KeyframeCoJob job(frames, values, co);
  ASSERT_TRUE(job.Validate()) << job.Validate().message();
  job.Run();
  RowMatrixXf expected(2, 6);
  expected << 1, 10, 2, 11, 4.5f, 12,  //
      1, -1, 2, -2, 4.5f, -3;
  EXPECT_EQ(co, expected);
}

TEST(KeyframeCoJob, EmptyClipIsValid) {
  Eigen::VectorXd frames(0);
  RowMatrixXd values(4, 0);
  RowMatrixXf co(4, 0);
  KeyframeCoJob job(frames, values, co);
  EXPECT_TRUE(job.Validate());
  job.Run();
}

TEST(KeyframeCoJob, RejectsNonFiniteValueNamingCurveAndKey) {
  Eigen::VectorXd frames(3);
  frames << 1, 2, 3;
  RowMatrixXd values = RowMatrixXd::Zero(2, 3);
  values(1, 2) = std::numeric_limits<double>::quiet_NaN();
  RowMatrixXf co = RowMatrixXf::Constant(2, 6, 7.0f);
  KeyframeCoJob job(frames, values, co);
  const Status status = job.Validate();
  ASSERT_FALSE(status);
  EXPECT_EQ(status.message(), "keyframes: curve 1, key 2 (frame 3.000000) is not finite");
  EXPECT_THROW(job.Run(), Error);
  // Nothing written on failure.
  EXPECT_EQ(co, RowMatrixXf::Constant(2, 6, 7.0f));
}

TEST(KeyframeCoJob, RejectsInfiniteFrame) {
  Eigen::VectorXd frames(2);
  frames << 1, std::numeric_limits<double>::infinity();
  RowMatrixXd values = RowMatrixXd::Zero(1, 2);
  RowMatrixXf co(1, 4);
  KeyframeCoJob job(frames, values, co);
  EXPECT_EQ(job.Validate().message(), "keyframes: frame time at key 1 is not finite");
}

TEST(KeyframeCoJob, RejectsFramesThatDoNotIncrease) {
  Eigen::VectorXd frames(3);
  frames << 1, 3, 3;
  RowMatrixXd values = RowMatrixXd::Zero(1, 3);
  RowMatrixXf co(1, 6);
  KeyframeCoJob job(frames, values, co);
  EXPECT_NE(job.Validate().message().find("key 2 (3.000000) does not come after key 1"),
            std::string::npos);
}

TEST(KeyframeCoJob, RejectsShapeMismatches) {
  Eigen::VectorXd frames(3);
  frames << 1, 2, 3;
  RowMatrixXd values = RowMatrixXd::Zero(2, 2);
  RowMatrixXf co(2, 6);
  EXPECT_EQ(KeyframeCoJob(frames, values, co).Validate().message(),
            "keyframes: values has 2 columns but there are 3 frames");
  RowMatrixXd values3 = RowMatrixXd::Zero(2, 3);
  RowMatrixXf co_small(2, 5);
  EXPECT_EQ(KeyframeCoJob(frames, values3, co_small).Validate().message(),
            "keyframes: output co must be 2 x 6, got 2 x 5");
}

}  // namespace
}  // namespace motionkit
