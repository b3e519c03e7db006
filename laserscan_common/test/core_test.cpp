// The ROS-free helpers the packages share: ParameterError, the fast atan2, the checks of stamps,
// frame ids and transforms, the gate of the /tf reader; and the throttle (ROS wall clock only).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "laserscan_common/fast_math.hpp"
#include "laserscan_common/message_checks.hpp"
#include "laserscan_common/parameter_error.hpp"
#include "laserscan_common/parameter_table.hpp"
#include "laserscan_common/scan_view.hpp"
#include "laserscan_common/throttle.hpp"

namespace lc = laserscan_common;

namespace
{
constexpr double kInf = std::numeric_limits<double>::infinity();

// Laid out as geometry_msgs::TransformStamped: the checks are templates, so no ROS is needed here.
struct Vector3
{
  double x = 0.0, y = 0.0, z = 0.0;
};
struct Quaternion
{
  double x = 0.0, y = 0.0, z = 0.0, w = 1.0;
};
struct Transform
{
  Vector3 translation;
  Quaternion rotation;
};
struct Stamp
{
  std::uint32_t sec = 0, nsec = 0;
};
struct Header
{
  Stamp stamp;
  std::string frame_id;
};
struct TransformStamped
{
  Header header;
  std::string child_frame_id;
  Transform transform;
};

TransformStamped transform(const std::string& parent, const std::string& child, std::uint32_t sec = 0)
{
  TransformStamped t;
  t.header.frame_id = parent;
  t.child_frame_id = child;
  t.header.stamp.sec = sec;
  return t;
}

bool contains(const std::string& text, const std::string& part)
{
  return !text.empty() && text.find(part) != std::string::npos;
}

constexpr std::int64_t kNow = 1796013955LL * 1000000000LL + 944403171LL;
constexpr std::uint32_t kNowSec = 1796013955u;
}  // namespace

// ---------------------------------------------------------------- ParameterError

TEST(ParameterError, NamesTheParameterAndTheReason)
{
  const lc::ParameterError e("sources[1].timeout", "must be > 0");
  EXPECT_STREQ(e.what(), "sources[1].timeout: must be > 0");
  EXPECT_EQ(e.parameter(), "sources[1].timeout");
  EXPECT_EQ(e.reason(), "must be > 0");
}

// ---------------------------------------------------------------- fast atan2

TEST(FastAtan2, ErrorIsFarBelowHalfABeam)
{
  double worst = 0.0;
  const double radii[] = { 1e-3, 0.5, 1.0, 7.3, 100.0 };
  for (double r : radii)
    for (int i = 0; i <= 200000; ++i)
    {
      const double a = -M_PI + 2 * M_PI * i / 200000.0;
      const float x = static_cast<float>(r * std::cos(a)), y = static_cast<float>(r * std::sin(a));
      const double err = std::fabs(lc::fastAtan2(y, x) - std::atan2(static_cast<double>(y), static_cast<double>(x)));
      worst = std::max(worst, std::min(err, 2 * M_PI - err));  // +pi and -pi are one direction
    }
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> d(-50.0f, 50.0f);
  for (int i = 0; i < 200000; ++i)
  {
    const float x = d(rng), y = d(rng);
    worst =
      std::max(worst, std::fabs(lc::fastAtan2(y, x) - std::atan2(static_cast<double>(y), static_cast<double>(x))));
  }
  EXPECT_LT(worst, lc::kFastAtan2MaxError);
  EXPECT_LT(lc::kFastAtan2MaxError, 0.01 * (M_PI / 720.0) / 2.0);  // < 1 % of half a default beam
}

TEST(FastAtan2, AxesAndOrigin)
{
  EXPECT_EQ(lc::fastAtan2(0.0f, 0.0f), 0.0f);
  EXPECT_FLOAT_EQ(lc::fastAtan2(0.0f, -1.0f), static_cast<float>(M_PI));
  EXPECT_FLOAT_EQ(lc::fastAtan2(-0.0f, -1.0f), static_cast<float>(M_PI));  // y < 0 is false for -0
  EXPECT_FLOAT_EQ(lc::fastAtan2(1.0f, 0.0f), static_cast<float>(M_PI / 2));
  EXPECT_FLOAT_EQ(lc::fastAtan2(-1.0f, 0.0f), static_cast<float>(-M_PI / 2));
  EXPECT_NEAR(lc::fastAtan2(1.0f, 1.0f), M_PI / 4, lc::kFastAtan2MaxError);
  // Tiny coordinates (a point next to the sensor) keep their angle.
  EXPECT_NEAR(lc::fastAtan2(1e-30f, -1e-30f), 3 * M_PI / 4, lc::kFastAtan2MaxError);
}

// ---------------------------------------------------------------- stamps

TEST(StampFault, MeasurementsFarFromTheClockAreMalformed)
{
  EXPECT_EQ(lc::stampFault(kNowSec, 944403171u, kNow), "");
  EXPECT_EQ(lc::stampFault(1u, 0u, kNow), "");                   // a bag's stamps years in the past
  EXPECT_NE(lc::stampFault(4294967295u, 999999999u, kNow), "");  // the crash of issue 8
  EXPECT_TRUE(contains(lc::stampFault(4294967295u, 0u, kNow), "ahead"));
  EXPECT_TRUE(contains(lc::stampFault(kNowSec, 1000000000u, kNow), "nsecs"));  // not normalised
  // Sim time before the first /clock (now = 0): every stamp up to 2^31 - 1 s is usable.
  EXPECT_EQ(lc::stampFault(2147483647u, 999999999u, 0), "");
  EXPECT_TRUE(contains(lc::stampFault(2147483648u, 1u, 0), "2^31 s ahead"));
  EXPECT_TRUE(contains(lc::stampFault(1u, 0u, 4294967295LL * 1000000000LL), "behind"));
}

TEST(StampFault, ZeroStampsAndStampsAheadOfTheClockAreMalformedMeasurements)
{
  // Zero: unset (tf2 reads it as "latest"; a scan stamped 0 would clear every buffer as a jump back).
  EXPECT_TRUE(contains(lc::stampFault(0u, 0u, kNow), "zero"));
  EXPECT_NE(lc::stampFault(0u, 0u, 0), "");
  EXPECT_EQ(lc::stampFault(0u, 1u, kNow), "");
  // Ahead: up to tf2's cache length (10 s), not 1 ns more.
  EXPECT_EQ(lc::stampFault(kNowSec + 10u, 944403171u, kNow), "");
  EXPECT_TRUE(contains(lc::stampFault(kNowSec + 10u, 944403172u, kNow), "ahead"));
  EXPECT_NE(lc::stampFault(kNowSec + 1000000000u, 0u, kNow), "");  // the /tf that poisoned tf2's cache
  // ... or up to a longer cache's length.
  const lc::StampLimits longer{ 30LL * 1000000000LL, 0.0 };
  EXPECT_EQ(lc::stampFault(kNowSec + 30u, 0u, kNow, lc::StampUse::kMeasurement, longer), "");
  EXPECT_NE(lc::stampFault(kNowSec + 31u, 0u, kNow, lc::StampUse::kMeasurement, longer), "");
  // Behind: any amount up to 2^31 s (bags, a clock that jumped forward).
  EXPECT_EQ(lc::stampFault(kNowSec - 100000u, 0u, kNow), "");
}

TEST(StampFault, StaticTransformsAreTimeless)
{
  EXPECT_EQ(lc::stampFault(0u, 0u, kNow, lc::StampUse::kStaticTransform), "");
  EXPECT_EQ(lc::stampFault(4294967295u, 999999999u, kNow, lc::StampUse::kStaticTransform), "");
  EXPECT_EQ(lc::stampFault(4294967295u, 999999999u, kNow, lc::StampUse::kStaticTransform, { 0, 100.0 }), "");
  EXPECT_NE(lc::stampFault(5u, 1000000000u, kNow, lc::StampUse::kStaticTransform), "");
}

TEST(StampFault, LookupStampsKeepTheMarginToTheEndOfRosTime)
{
  const lc::StampLimits margin{ lc::kMaxStampAheadNs, 10.1 };
  const auto lookup = [&](std::uint32_t sec, std::uint32_t nsec) {
    return lc::stampFault(sec, nsec, kNow, lc::StampUse::kLookup, margin);
  };
  EXPECT_EQ(lookup(1700000000u, 999999999u), "");
  EXPECT_EQ(lookup(0u, 0u), "");               // zero: "the latest transform", as before
  EXPECT_EQ(lookup(kNowSec + 1000u, 0u), "");  // the clock does not matter
  // The stamp that made roscpp throw "Time is out of dual 32-bit range" inside tf2.
  EXPECT_TRUE(contains(lookup(4294967295u, 999999999u), "end of ROS time"));
  EXPECT_NE(lookup(4294967295u - 10u, 0u), "");
  EXPECT_EQ(lookup(4294967295u - 12u, 0u), "");
  EXPECT_TRUE(contains(lookup(5u, 1000000000u), "nsecs"));
}

TEST(StampText, NineDigitsAfterThePoint)
{
  EXPECT_EQ(lc::stampText(3u, 5u), "3.000000005");
  EXPECT_EQ(lc::stampText(4294967295u, 999999999u), "4294967295.999999999");
}

// ---------------------------------------------------------------- frame ids

TEST(FrameId, OneLeadingSlashIsStrippedAsTf2Does)
{
  bool stripped = true;
  EXPECT_EQ(lc::tf2FrameId("laser", &stripped), "laser");
  EXPECT_FALSE(stripped);
  EXPECT_EQ(lc::tf2FrameId("/laser", &stripped), "laser");
  EXPECT_TRUE(stripped);
  EXPECT_EQ(lc::tf2FrameId("//laser"), "/laser");  // one only, as tf2
  EXPECT_EQ(lc::tf2FrameId("/", &stripped), "");   // empty: malformed
  EXPECT_TRUE(stripped);
  EXPECT_EQ(lc::tf2FrameId("", &stripped), "");
  EXPECT_FALSE(stripped);
}

TEST(FrameId, TheNormaliserWarnsOnceWithTheFrameItUses)
{
  std::vector<std::string> warnings;
  lc::FrameIdNormaliser normalise(
    [&](const std::string& frame_id, const std::string& used) { warnings.push_back(frame_id + " -> " + used); });
  EXPECT_EQ(normalise("camera"), "camera");
  EXPECT_TRUE(warnings.empty());
  EXPECT_EQ(normalise("/camera"), "camera");
  EXPECT_EQ(normalise("/camera"), "camera");
  EXPECT_EQ(normalise("/other"), "other");
  EXPECT_EQ(warnings, std::vector<std::string>{ "/camera -> camera" });
  lc::FrameIdNormaliser silent;  // no hook: still normalises
  EXPECT_EQ(silent("/camera"), "camera");
}

// ---------------------------------------------------------------- transforms

TEST(TransformFault, EachDefectIsNamed)
{
  EXPECT_EQ(lc::transformFault(transform("base_link", "laser")), "");
  EXPECT_TRUE(contains(lc::transformFault(transform("", "laser")), "empty"));
  EXPECT_TRUE(contains(lc::transformFault(transform("base_link", "")), "empty"));
  EXPECT_TRUE(contains(lc::transformFault(transform("base_link", "base_link")), "own parent"));
  EXPECT_TRUE(contains(lc::transformFault(transform("/base_link", "base_link")), "own parent"));
  for (double bad : { kInf, -kInf, std::nan("") })
  {
    TransformStamped t = transform("base_link", "laser");
    t.transform.translation.y = bad;
    EXPECT_TRUE(contains(lc::transformFault(t), "not finite")) << bad;
    EXPECT_FALSE(lc::transformIsFinite(t.transform));
    t = transform("base_link", "laser");
    t.transform.rotation.z = bad;
    EXPECT_TRUE(contains(lc::transformFault(t), "not finite")) << bad;
  }
  for (double w : { 0.0, 2.0, 1e-3, 1.006 })
  {
    TransformStamped t = transform("base_link", "laser");
    t.transform.rotation.w = w;
    EXPECT_TRUE(contains(lc::transformFault(t), "unit quaternion")) << w;
  }
  TransformStamped t = transform("base_link", "laser");
  t.transform.rotation = { 0.0, 0.0, std::sin(0.3), std::cos(0.3) * 1.004 };  // within tf2's 0.01
  EXPECT_EQ(lc::transformFault(t), "");
  EXPECT_TRUE(lc::transformIsFinite(t.transform));
}

TEST(TransformGate, DynamicTransformsFollowTheMeasurementRules)
{
  // The converter's /tf took these until the gate was shared with the merger.
  lc::TransformGate gate;
  const std::int64_t cache = 10LL * 1000000000LL;
  EXPECT_EQ(gate.fault(transform("odom", "base_link", kNowSec), false, kNow, cache), "");
  EXPECT_TRUE(contains(gate.fault(transform("odom", "base_link", 0u), false, kNow, cache), "zero"));
  EXPECT_TRUE(contains(gate.fault(transform("odom", "base_link", kNowSec + 11u), false, kNow, cache), "ahead"));
  // A longer buffer takes transforms as far ahead as it is long.
  EXPECT_EQ(gate.fault(transform("odom", "base_link", kNowSec + 29u), false, kNow, 30 * 1000000000LL), "");
  // Near 2^32 s: refused whatever the clock (tf2 adds its cache length to the stamp).
  EXPECT_NE(gate.fault(transform("odom", "base_link", 4294967290u), false, 4294967289LL * 1000000000LL, cache), "");
  // Static ones are timeless.
  EXPECT_EQ(gate.fault(transform("base_link", "laser", 0u), true, kNow, cache), "");
  EXPECT_EQ(gate.fault(transform("base_link", "camera", 4294967295u), true, kNow, cache), "");
}

TEST(TransformGate, WhatTf2RefusesIsFilteredBeforeIt)
{
  // The merger passed these to tf2, which logged an unthrottled error per message.
  lc::TransformGate gate;
  EXPECT_TRUE(contains(gate.fault(transform("base_link", "base_link", kNowSec), false, kNow, lc::kMaxStampAheadNs),
                       "own parent"));
  TransformStamped t = transform("base_link", "laser", kNowSec);
  t.transform.rotation.w = 0.0;
  EXPECT_TRUE(contains(gate.fault(t, false, kNow, lc::kMaxStampAheadNs), "unit quaternion"));
  t.transform.rotation.w = std::nan("");
  EXPECT_TRUE(contains(gate.fault(t, true, kNow, lc::kMaxStampAheadNs), "not finite"));
  // The content is named before the stamp: a zero-stamped broken transform is reported as broken.
  t = transform("base_link", "", 0u);
  EXPECT_TRUE(contains(gate.fault(t, false, kNow, lc::kMaxStampAheadNs), "empty"));
}

TEST(TransformGate, DynamicTransformsDoNotReplaceStaticOnes)
{
  lc::TransformGate gate;
  const std::int64_t cache = lc::kMaxStampAheadNs;
  EXPECT_EQ(gate.fault(transform("base_link", "/laser", 0u), true, kNow, cache), "");
  EXPECT_EQ(gate.staticParent("laser"), "base_link");
  EXPECT_EQ(gate.staticParent("/laser"), "base_link");
  EXPECT_EQ(gate.staticParent("base_link"), "");
  // Same pair, another parent, with or without the slash: all would replace the static transform in tf2.
  EXPECT_TRUE(contains(gate.fault(transform("base_link", "laser", kNowSec), false, kNow, cache), "static"));
  EXPECT_TRUE(contains(gate.fault(transform("odom", "/laser", kNowSec), false, kNow, cache), "static"));
  // Other frames pass, and a new /tf_static transform of the frame replaces the static one, as in tf2.
  EXPECT_EQ(gate.fault(transform("odom", "base_link", kNowSec), false, kNow, cache), "");
  EXPECT_EQ(gate.fault(transform("mast", "laser", 0u), true, kNow, cache), "");
  EXPECT_EQ(gate.staticParent("laser"), "mast");
  // A refused static transform does not make its frame static.
  TransformStamped broken = transform("base_link", "camera", 0u);
  broken.transform.translation.x = kInf;
  EXPECT_NE(gate.fault(broken, true, kNow, cache), "");
  EXPECT_EQ(gate.fault(transform("base_link", "camera", kNowSec), false, kNow, cache), "");
}

TEST(Due, PerTimerNotPerCallSite)
{
  ros::WallTime first, second;
  EXPECT_TRUE(lc::due(first, 60.0));
  EXPECT_FALSE(lc::due(first, 60.0));
  EXPECT_TRUE(lc::due(second, 60.0));  // another node's timer is its own
  EXPECT_TRUE(lc::due(first, 0.0));
}

TEST(WarningThrottle, EachKindAtOnceThenOncePerPeriod)
{
  lc::WarningThrottle throttle(60.0);
  EXPECT_TRUE(throttle.due("empty frame_id"));
  EXPECT_FALSE(throttle.due("empty frame_id"));
  EXPECT_TRUE(throttle.due("ranges length does not match"));  // another kind: said at once
  // Alternating faults do not flood: back to the first kind, still within its period.
  EXPECT_FALSE(throttle.due("empty frame_id"));
  EXPECT_FALSE(throttle.due("ranges length does not match"));
  EXPECT_TRUE(throttle.due("empty frame_id", 0.0));  // a period of its own for this call
  // Another instance (another node, another source) has timers of its own.
  lc::WarningThrottle other(60.0);
  EXPECT_TRUE(other.due("empty frame_id"));
  lc::WarningThrottle unthrottled(0.0);
  EXPECT_TRUE(unthrottled.due("x"));
  EXPECT_TRUE(unthrottled.due("x"));
}

TEST(WarningThrottle, BoundedWhenKindsNeverRepeat)
{
  lc::WarningThrottle throttle(60.0);
  EXPECT_TRUE(throttle.due("frame 0"));
  for (std::size_t i = 1; i < lc::WarningThrottle::kMaxKinds; ++i)
    EXPECT_TRUE(throttle.due("frame " + std::to_string(i)));
  EXPECT_FALSE(throttle.due("frame 0"));  // full, but a known kind keeps its timer
  // One kind more forgets them all (rather than growing forever): each may be said again.
  EXPECT_TRUE(throttle.due("frame " + std::to_string(lc::WarningThrottle::kMaxKinds)));
  EXPECT_TRUE(throttle.due("frame 0"));
}

TEST(WarningThrottle, AFaultKindIsItsTextWithoutNumbers)
{
  // Two clouds with the same defect but other sizes are one kind, another defect is another.
  EXPECT_EQ(lc::faultKind("row_step 599 is smaller than width*point_step 600"),
            lc::faultKind("row_step 1279 is smaller than width*point_step 1280"));
  EXPECT_EQ(lc::faultKind("empty frame_id (stamp 12.000000000)"), "empty frame_id (stamp .)");
  EXPECT_NE(lc::faultKind("field 'x' is missing"), lc::faultKind("field 'z' is missing"));
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}

TEST(ParameterTable, ClosestNameIsTheLikeliestTypoOnly)
{
  const std::vector<std::string> known = { "min_height", "max_height", "range_min", "publish_rate" };
  EXPECT_EQ(lc::closestName("min_hieght", known), "min_height");
  EXPECT_EQ(lc::closestName("max_heigth", known), "max_height");
  EXPECT_EQ(lc::closestName("publish_rte", known), "publish_rate");
  EXPECT_EQ(lc::closestName("my_block", known), "");  // nothing alike: no suggestion
  EXPECT_DOUBLE_EQ(lc::nameSimilarity("abc", "abc"), 1.0);
  EXPECT_DOUBLE_EQ(lc::nameSimilarity("abcd", "abxy"), 0.5);
}

// ---------------------------------------------------------------- received scans

TEST(ScanFault, EachDefectOfAReceivedScanIsNamed)
{
  using laserscan_common::scanFault;
  using laserscan_common::ScanView;
  const std::vector<float> ranges(361, 1.0f);
  ScanView v;
  v.stamp = 12.5;
  v.angle_min = -laserscan_common::kPi;
  v.angle_increment = 2.0 * laserscan_common::kPi / 360.0;
  v.angle_max = v.angle_min + 360.0 * v.angle_increment;
  v.range_min = 0.05;
  v.range_max = 30.0;
  v.ranges = ranges.data();
  v.n_ranges = ranges.size();
  EXPECT_EQ(scanFault(v), "");

  // Drivers round angle_max differently: one beam more or less is accepted, two are not.
  ScanView bad = v;
  bad.n_ranges = 360;
  EXPECT_EQ(scanFault(bad), "");
  bad.n_ranges = 359;
  EXPECT_EQ(scanFault(bad), "ranges length does not match round((angle_max - angle_min) / angle_increment) + 1");

  const double nan = std::numeric_limits<double>::quiet_NaN();
  bad = v;
  bad.stamp = nan;
  EXPECT_EQ(scanFault(bad), "non-finite stamp");
  bad = v;
  bad.angle_increment = std::numeric_limits<double>::infinity();
  EXPECT_EQ(scanFault(bad), "non-finite angle_min, angle_max or angle_increment");
  bad = v;
  bad.angle_increment = -v.angle_increment;
  EXPECT_EQ(scanFault(bad), "angle_increment <= 0");
  bad = v;
  bad.angle_max = v.angle_min - 0.1;
  EXPECT_EQ(scanFault(bad), "angle_max < angle_min");
  bad = v;
  bad.time_increment = nan;
  EXPECT_EQ(scanFault(bad), "non-finite time_increment");
  bad = v;
  bad.time_increment = 0.2;  // 361 beams x 0.2 s = 72 s
  EXPECT_EQ(scanFault(bad), "time_increment * beams spans more than 60 s");
  bad = v;
  bad.range_min = 40.0;
  EXPECT_EQ(scanFault(bad), "range_min/range_max NaN or range_min > range_max");
  bad = v;
  bad.ranges = nullptr;
  EXPECT_EQ(scanFault(bad), "empty ranges");
  bad = v;
  bad.angle_increment = 1e-9;
  bad.angle_max = v.angle_min + 1.0;
  EXPECT_EQ(scanFault(bad), "angles give too many beams");
  bad = v;
  bad.intensities = ranges.data();
  bad.n_intensities = 10;
  EXPECT_EQ(scanFault(bad), "intensities length is neither 0 nor the ranges length");
  bad.n_intensities = ranges.size();
  EXPECT_EQ(scanFault(bad), "");
}
