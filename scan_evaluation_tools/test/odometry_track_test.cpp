// The ROS-free core of bag_to_rawlog: interpolation of odometry and pose increments.
#include "scan_evaluation_tools/odometry_track.hpp"

#include <gtest/gtest.h>

#include <cmath>

using scan_evaluation_tools::between;
using scan_evaluation_tools::compose;
using scan_evaluation_tools::OdometryTrack;
using scan_evaluation_tools::Pose2D;
using scan_evaluation_tools::wrapAngle;

TEST(OdometryTrack, InterpolatesPositionLinearlyAndYawOnTheShortArc)
{
  OdometryTrack track;
  ASSERT_TRUE(track.add(10.0, { 0.0, 0.0, 3.0 }));
  ASSERT_TRUE(track.add(12.0, { 2.0, -4.0, -3.0 }));  // 0.283 rad further across +-pi, not 6 rad back
  const auto mid = track.at(11.0);
  ASSERT_TRUE(mid.has_value());
  EXPECT_NEAR(mid->x, 1.0, 1e-12);
  EXPECT_NEAR(mid->y, -2.0, 1e-12);
  EXPECT_NEAR(std::fabs(mid->yaw), M_PI, 1e-9);
  const auto quarter = track.at(10.5);
  EXPECT_NEAR(quarter->yaw, 3.0 + 0.25 * (2.0 * M_PI - 6.0), 1e-9);
  EXPECT_NEAR(track.at(12.0)->y, -4.0, 1e-12);  // an exact stamp gives its own pose
}

TEST(OdometryTrack, NothingOutsideItsSpanAndStampsMustGoForward)
{
  OdometryTrack track;
  EXPECT_FALSE(track.at(1.0).has_value());
  track.add(1.0, { 0, 0, 0 });
  track.add(2.0, { 1, 0, 0 });
  EXPECT_FALSE(track.add(2.0, { 5, 0, 0 }));  // repeated stamp
  EXPECT_FALSE(track.add(1.5, { 5, 0, 0 }));  // older
  EXPECT_FALSE(track.add(3.0, { NAN, 0, 0 }));
  EXPECT_EQ(track.size(), 2u);
  EXPECT_FALSE(track.at(0.999).has_value());
  EXPECT_FALSE(track.at(2.001).has_value());
  EXPECT_TRUE(track.at(1.0).has_value());
}

TEST(Poses, BetweenIsTheInverseOfCompose)
{
  const Pose2D a{ 1.0, 2.0, 2.5 };
  const Pose2D b{ -3.0, 0.5, -2.9 };
  const Pose2D d = between(a, b);
  const Pose2D back = compose(a, d);
  EXPECT_NEAR(back.x, b.x, 1e-12);
  EXPECT_NEAR(back.y, b.y, 1e-12);
  EXPECT_NEAR(wrapAngle(back.yaw - b.yaw), 0.0, 1e-12);
  // a step forward along a's heading
  const Pose2D step = between({ 0, 0, M_PI / 2 }, { 0, 1, M_PI / 2 });
  EXPECT_NEAR(step.x, 1.0, 1e-12);
  EXPECT_NEAR(step.y, 0.0, 1e-12);
}

TEST(Poses, WrapAngle)
{
  EXPECT_NEAR(wrapAngle(3 * M_PI), M_PI, 1e-12);
  EXPECT_NEAR(wrapAngle(-M_PI), M_PI, 1e-12);
  EXPECT_NEAR(wrapAngle(0.5 - 4 * M_PI), 0.5, 1e-12);
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
