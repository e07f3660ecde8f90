#include "motionkit/bvh_pose.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace motionkit {
namespace {

// A root with position and ZXY rotation channels and one child with XYZ.
Skeleton TwoJoints() {
  Skeleton s;
  s.joints.resize(2);
  s.joints[0].name = "root";
  s.joints[0].channel_count = 6;
  s.joints[0].channels = {ChannelType::kXposition, ChannelType::kYposition, ChannelType::kZposition,
                          ChannelType::kZrotation, ChannelType::kXrotation, ChannelType::kYrotation};
  s.joints[1].name = "child";
  s.joints[1].parent = 0;
  s.joints[1].offset = Eigen::Vector3d(0, 1, 0);
  s.joints[1].channel_count = 3;
  s.joints[1].channels[0] = ChannelType::kXrotation;
  s.joints[1].channels[1] = ChannelType::kYrotation;
  s.joints[1].channels[2] = ChannelType::kZrotation;
  s.joints[1].first_channel = 6;
  s.channel_count = 9;
  return s;
}

TEST(BvhPose, IdentityRestGivesTheChannelsBack) {
  const Skeleton skeleton = TwoJoints();
  RowMatrixXd values(1, 9);
  values << 1, 2, 3, 90, 0, 0, 0, 0, 0;
  RowMatrixXd rest(2, 4);
  rest << 1, 0, 0, 0, 1, 0, 0, 0;
  RowMatrixXd rotations(1, 8), locations(1, 6);
  BvhToPoseJob job(skeleton, values, rest, rotations, locations);
  job.Run();
  // 90 degrees about Z, location equal to the channels (offset is zero).
  EXPECT_NEAR(rotations(0, 0), std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(rotations(0, 3), std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(locations(0, 0), 1.0, 1e-15);
  EXPECT_NEAR(locations(0, 2), 3.0, 1e-15);
  // The child has no position channels: zero location, identity rotation.
  EXPECT_EQ(locations.row(0).tail<3>().norm(), 0.0);
  EXPECT_NEAR(rotations(0, 4), 1.0, 1e-15);
}

TEST(BvhPose, RoundTripsThroughPoseToBvh) {
  const Skeleton skeleton = TwoJoints();
  RowMatrixXd values(2, 9);
  values << 0.5, -1, 2, 30, -20, 170, 10, 80, -45,  //
      0.6, -1, 2.1, 35, -25, -175, 12, 85, -40;     // crosses 180 degrees on Y
  RowMatrixXd rest(2, 4);
  rest << std::sqrt(0.5), std::sqrt(0.5), 0, 0, 0.5, 0.5, 0.5, 0.5;
  RowMatrixXd rotations(2, 8), locations(2, 6), back(2, 9);
  BvhToPoseJob to_pose(skeleton, values, rest, rotations, locations);
  to_pose.conversion = Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()));
  to_pose.scale = 0.01;
  to_pose.Run();
  PoseToBvhJob to_bvh(skeleton, rotations, locations, rest, back);
  to_bvh.conversion = to_pose.conversion;
  to_bvh.scale = 0.01;
  to_bvh.Run();
  // The same rotations and positions; the second frame's -175 comes back as
  // 185, the equivalent angle closest to the first frame's 170.
  RowMatrixXd expected = values;
  expected(1, 5) = 185;
  EXPECT_TRUE(back.isApprox(expected, 1e-9)) << back;
}

TEST(BvhPose, RejectsNonFiniteChannelsNamingFrameJointAndChannel) {
  const Skeleton skeleton = TwoJoints();
  RowMatrixXd values = RowMatrixXd::Zero(3, 9);
  values(2, 7) = std::numeric_limits<double>::infinity();
  RowMatrixXd rest(2, 4);
  rest << 1, 0, 0, 0, 1, 0, 0, 0;
  RowMatrixXd rotations(3, 8), locations(3, 6);
  BvhToPoseJob job(skeleton, values, rest, rotations, locations);
  EXPECT_EQ(job.Validate().message(), "bvh pose: frame 2, joint 'child' channel Yrotation is not finite");
  RowMatrixXd bad_rest = RowMatrixXd::Zero(2, 4);
  BvhToPoseJob job2(skeleton, RowMatrixXd::Zero(3, 9), bad_rest, rotations, locations);
  EXPECT_EQ(job2.Validate().message(), "bvh pose: rest orientation of 'root' is not a unit quaternion");
}

}  // namespace
}  // namespace motionkit
