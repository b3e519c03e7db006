// Tests of the range converter's ROS-free core: parameters, message checks, REP 117 classes,
// debounce, and the arc against an analytic cone for rotated and off-centre sensors.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "depth_filter_scan_converter/range_to_scan.hpp"
#include "laserscan_common/scan_geometry.hpp"

namespace dfsc = depth_filter_scan_converter;

namespace
{
using laserscan_common::kPi;

dfsc::RangeReading reading(double range, double fov = 0.5, double min_range = 0.3, double max_range = 5.0)
{
  dfsc::RangeReading r;
  r.frame_id = "sonar_front";
  r.stamp = 100.0;
  r.field_of_view = fov;
  r.min_range = min_range;
  r.max_range = max_range;
  r.range = range;
  return r;
}

dfsc::ArcScan convert(dfsc::RangeToScan& c, const dfsc::RangeReading& r)
{
  dfsc::ArcScan scan;
  const std::string reason = c.convert(r, scan);
  EXPECT_EQ(reason, "");
  return scan;
}

std::size_t fencepostCount(const dfsc::ArcScan& s)
{
  return static_cast<std::size_t>(std::lround((s.angle_max - s.angle_min) / s.angle_increment)) + 1;
}

void expectParameterError(const dfsc::RangeScanParameters& p, const std::string& name)
{
  try
  {
    p.validate();
    ADD_FAILURE() << "accepted a bad '" << name << "'";
  }
  catch (const dfsc::ParameterError& e)
  {
    EXPECT_EQ(e.parameter(), name) << e.what();
  }
}
}  // namespace

TEST(RangeScanParameters, DefaultsAreValid)
{
  EXPECT_NO_THROW(dfsc::RangeScanParameters().validate());
}

TEST(RangeScanParameters, BadValuesNameTheParameter)
{
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (double v : { 0.0, -1.0, 4.5, nan, inf })
  {
    dfsc::RangeScanParameters p;
    p.arc_width_scale = v;
    expectParameterError(p, "arc_width_scale");
  }
  for (double v : { -0.1, 7.0, nan, inf })
  {
    dfsc::RangeScanParameters p;
    p.arc_width = v;
    expectParameterError(p, "arc_width");
  }
  for (double v : { 0.0, -0.01, nan, 1e-6 })
  {
    dfsc::RangeScanParameters p;
    p.angle_increment = v;
    expectParameterError(p, "angle_increment");
  }
  dfsc::RangeScanParameters p;
  p.min_consecutive_readings = 0;
  expectParameterError(p, "min_consecutive_readings");
  EXPECT_THROW(dfsc::RangeToScan{ p }, dfsc::ParameterError);
}

TEST(RangeToScan, ArcGeometryFollowsTheFencepostRule)
{
  dfsc::RangeScanParameters p;
  p.angle_increment = 0.01;
  dfsc::RangeToScan c(p);
  for (double fov : { 0.0, 0.005, 0.01, 0.2, 0.5, 1.3, 2 * kPi })
  {
    const dfsc::ArcScan s = convert(c, reading(1.0, fov));
    EXPECT_NEAR(s.angle_min, -fov / 2, 1e-12);
    EXPECT_NEAR(s.angle_max, fov / 2, 1e-12);
    EXPECT_GT(s.angle_increment, 0.0);
    EXPECT_LE(s.angle_increment, 0.01 + 1e-12);
    EXPECT_EQ(s.ranges.size(), fencepostCount(s)) << "fov " << fov;
  }
  EXPECT_EQ(convert(c, reading(1.0, 0.0)).ranges.size(), 1u);
  EXPECT_EQ(convert(c, reading(1.0, 0.2)).ranges.size(), 21u);
}

TEST(RangeToScan, Rep117Classes)
{
  dfsc::RangeToScan c{ dfsc::RangeScanParameters() };
  const float inf = std::numeric_limits<float>::infinity();
  auto all = [](const dfsc::ArcScan& s, auto pred) {
    for (float v : s.ranges)
      if (!pred(v))
        return false;
    return !s.ranges.empty();
  };
  dfsc::ArcScan s = convert(c, reading(1.25));
  EXPECT_EQ(s.kind, dfsc::ReadingKind::Obstacle);
  EXPECT_TRUE(all(s, [](float v) { return v == 1.25f; }));
  EXPECT_FLOAT_EQ(s.range_min, 0.3);
  EXPECT_FLOAT_EQ(s.range_max, 5.0);
  // Both limits: min_range is in range, max_range is no return (sensors report it when nothing echoes).
  EXPECT_EQ(convert(c, reading(0.3)).kind, dfsc::ReadingKind::Obstacle);
  s = convert(c, reading(5.0));
  EXPECT_EQ(s.kind, dfsc::ReadingKind::NoReturn);
  EXPECT_TRUE(all(s, [inf](float v) { return v == inf; }));
  EXPECT_EQ(convert(c, reading(7.0)).kind, dfsc::ReadingKind::NoReturn);
  EXPECT_EQ(convert(c, reading(inf)).kind, dfsc::ReadingKind::NoReturn);
  // Only -Inf is too close; a finite value below min_range (0.0 is a common driver error or
  // no-echo code) is invalid: an obstacle there would fill the whole cone at min_range.
  s = convert(c, reading(-inf));
  EXPECT_EQ(s.kind, dfsc::ReadingKind::TooClose);
  EXPECT_TRUE(all(s, [inf](float v) { return v == -inf; }));
  for (double below : { 0.1, 0.0, -1.0 })
  {
    s = convert(c, reading(below));
    EXPECT_EQ(s.kind, dfsc::ReadingKind::Invalid) << below;
    EXPECT_TRUE(all(s, [](float v) { return std::isnan(v); })) << below;
  }
  s = convert(c, reading(std::nan("")));
  EXPECT_EQ(s.kind, dfsc::ReadingKind::Invalid);
  EXPECT_TRUE(all(s, [](float v) { return std::isnan(v); }));
}

TEST(RangeToScan, BadMessagesAreRejectedWithTheirReason)
{
  dfsc::RangeToScan c{ dfsc::RangeScanParameters() };
  auto reason = [&c](const dfsc::RangeReading& r) {
    dfsc::ArcScan s;
    s.angle_min = 42.0;
    const std::string why = c.convert(r, s);
    if (!why.empty())
    {
      EXPECT_EQ(s.angle_min, 42.0) << "a rejected reading touched the scan";
    }
    return why;
  };
  dfsc::RangeReading r = reading(1.0);
  r.frame_id.clear();
  EXPECT_NE(reason(r).find("frame_id"), std::string::npos);
  EXPECT_NE(reason(reading(1.0, std::nan(""))).find("field_of_view"), std::string::npos);
  EXPECT_NE(reason(reading(1.0, -0.1)).find("field_of_view"), std::string::npos);
  EXPECT_NE(reason(reading(1.0, 7.0)).find("field_of_view"), std::string::npos);
  EXPECT_NE(reason(reading(1.0, 0.5, 3.0, 2.0)).find("not smaller than max_range"), std::string::npos);
  EXPECT_NE(reason(reading(1.0, 0.5, 2.0, 2.0)).find("not smaller than max_range"), std::string::npos);
  EXPECT_NE(reason(reading(1.0, 0.5, std::nan(""), 2.0)).find("min_range"), std::string::npos);
  EXPECT_NE(reason(reading(1.0, 0.5, -1.0, 2.0)).find("min_range"), std::string::npos);
  EXPECT_NE(reason(reading(1.0, 0.5, 0.0, std::nan(""))).find("max_range"), std::string::npos);
  r = reading(1.0);
  r.radiation_type = 7;
  EXPECT_NE(reason(r).find("radiation_type"), std::string::npos);
  r = reading(1.0);
  r.radiation_type = 1;  // INFRARED
  EXPECT_EQ(reason(r), "");
  // An explicit arc_width makes the message's field of view irrelevant, NaN included.
  dfsc::RangeScanParameters p;
  p.arc_width = 0.4;
  dfsc::RangeToScan fixed(p);
  const dfsc::ArcScan s = convert(fixed, reading(1.0, std::nan("")));
  EXPECT_NEAR(s.angle_max - s.angle_min, 0.4, 1e-12);
}

TEST(RangeToScan, ArcWidthOptions)
{
  dfsc::RangeScanParameters p;
  p.arc_width_scale = 0.5;
  dfsc::RangeToScan half(p);
  dfsc::ArcScan s = convert(half, reading(1.0, 1.0));
  EXPECT_NEAR(s.angle_max, 0.25, 1e-12);
  p.arc_width_scale = 4.0;  // wider than a turn: one turn
  dfsc::RangeToScan wide(p);
  s = convert(wide, reading(1.0, 2.0));
  EXPECT_NEAR(s.angle_max - s.angle_min, 2 * kPi, 1e-12);
  p.arc_width_scale = 0.5;
  p.arc_width = 0.1;  // overrides the scale and the field of view
  dfsc::RangeToScan fixed(p);
  s = convert(fixed, reading(1.0, 1.0));
  EXPECT_NEAR(s.angle_max, 0.05, 1e-12);
}

TEST(RangeToScan, DebounceNeedsConsecutiveInRangeReadings)
{
  dfsc::RangeScanParameters p;
  p.min_consecutive_readings = 3;
  dfsc::RangeToScan c(p);
  auto kind = [&c](double range, double stamp) {
    dfsc::RangeReading r = reading(range);
    r.stamp = stamp;
    return convert(c, r);
  };
  dfsc::ArcScan s = kind(1.0, 1.0);
  EXPECT_EQ(s.kind, dfsc::ReadingKind::Unconfirmed);
  EXPECT_TRUE(std::isnan(s.ranges[0])) << "an unconfirmed echo is no proof of free space either";
  EXPECT_EQ(kind(1.1, 1.1).kind, dfsc::ReadingKind::Unconfirmed);
  EXPECT_EQ(kind(1.2, 1.2).kind, dfsc::ReadingKind::Obstacle);
  EXPECT_EQ(kind(1.2, 1.3).kind, dfsc::ReadingKind::Obstacle);
  // A no return breaks the run.
  EXPECT_EQ(kind(9.0, 1.4).kind, dfsc::ReadingKind::NoReturn);
  EXPECT_EQ(kind(1.0, 1.5).kind, dfsc::ReadingKind::Unconfirmed);
  EXPECT_EQ(kind(1.0, 1.6).kind, dfsc::ReadingKind::Unconfirmed);
  // Time going back (a bag loop) restarts the count.
  EXPECT_EQ(kind(1.0, 0.5).kind, dfsc::ReadingKind::Unconfirmed);
  EXPECT_EQ(kind(1.0, 0.6).kind, dfsc::ReadingKind::Unconfirmed);
  EXPECT_EQ(kind(1.0, 0.7).kind, dfsc::ReadingKind::Obstacle);
  // reset() (resubscription) forgets the run; a bad message breaks it too.
  c.reset();
  EXPECT_EQ(kind(1.0, 0.8).kind, dfsc::ReadingKind::Unconfirmed);
  EXPECT_EQ(kind(1.0, 0.9).kind, dfsc::ReadingKind::Unconfirmed);
  dfsc::ArcScan ignored;
  EXPECT_NE(c.convert(reading(1.0, std::nan("")), ignored), "");
  EXPECT_EQ(kind(1.0, 1.0).kind, dfsc::ReadingKind::Unconfirmed);
}

// The arc, placed by a sensor's mount (yaw, position) in the robot frame, is the analytic cone's
// front: every beam end lies at the measured distance from the sensor, inside the cone, and the
// first and last beams lie on the cone's edges.
TEST(RangeToScan, ArcIsTheConeFrontForRotatedAndOffCentreSensors)
{
  dfsc::RangeScanParameters p;
  p.angle_increment = 0.002;
  dfsc::RangeToScan c(p);
  struct Mount
  {
    double x, y, yaw;
  };
  for (const Mount m :
       { Mount{ 0, 0, 0 }, Mount{ 0.37, 0.2, 0.6 }, Mount{ -0.37, -0.24, -2.5 }, Mount{ 0.1, 0.24, kPi } })
    for (double range : { 0.3, 1.7, 4.99 })
    {
      const double fov = 0.52;
      const dfsc::ArcScan s = convert(c, reading(range, fov));
      ASSERT_EQ(s.ranges.size(), fencepostCount(s));
      for (std::size_t i = 0; i < s.ranges.size(); ++i)
      {
        const double a = s.angle_min + static_cast<double>(i) * s.angle_increment;
        const double bx = m.x + s.ranges[i] * std::cos(m.yaw + a);
        const double by = m.y + s.ranges[i] * std::sin(m.yaw + a);
        // Analytic cone: apex at the sensor, axis along its yaw, half angle fov / 2.
        const double dx = bx - m.x, dy = by - m.y;
        EXPECT_NEAR(std::hypot(dx, dy), range, 1e-6);
        double off_axis = std::atan2(dy, dx) - m.yaw;
        off_axis = std::atan2(std::sin(off_axis), std::cos(off_axis));
        EXPECT_LE(std::fabs(off_axis), fov / 2 + 1e-9);
      }
      EXPECT_NEAR(s.angle_min, -fov / 2, 1e-12);
      EXPECT_NEAR(s.angle_min + static_cast<double>(s.ranges.size() - 1) * s.angle_increment, fov / 2, 1e-9);
    }
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
