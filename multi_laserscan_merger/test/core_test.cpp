// gtest of the ROS-free core against analytic results.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "multi_laserscan_merger/merger_core.hpp"

using namespace multi_laserscan_merger;

namespace
{
const float kInfF = std::numeric_limits<float>::infinity();
const float kNaNF = std::numeric_limits<float>::quiet_NaN();

SourceParams source(const std::string& name)
{
  SourceParams s;
  s.name = name;
  s.topic = name + "/scan";
  return s;
}

MergerParams oneSource()
{
  MergerParams p;
  p.sources = { source("a") };
  return p;
}

// A 360-degree scan of n beams starting at -pi, all at range r.
struct Scan
{
  std::vector<float> ranges, intensities;
  ScanView view(double stamp = 0.0) const
  {
    ScanView v;
    v.stamp = stamp;
    v.angle_min = -kPi;
    v.angle_increment = 2.0 * kPi / ranges.size();
    v.angle_max = v.angle_min + (ranges.size() - 1) * v.angle_increment;
    v.range_min = 0.05;
    v.range_max = 30.0;
    v.ranges = ranges.data();
    v.n_ranges = ranges.size();
    v.intensities = intensities.empty() ? nullptr : intensities.data();
    v.n_intensities = intensities.size();
    return v;
  }
  double angle(std::size_t i) const { return -kPi + 2.0 * kPi * i / ranges.size(); }
};

SourceInput input(const ScanView& v, const Eigen::Isometry3d& t = Eigen::Isometry3d::Identity())
{
  SourceInput in;
  in.present = true;
  in.scan = v;
  in.output_T_sensor = t;
  return in;
}

Eigen::Isometry3d pose(double x, double y, double z, double roll, double pitch, double yaw)
{
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(x, y, z);
  t.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                 .toRotationMatrix();
  return t;
}

Eigen::Quaterniond yawQ(double yaw)
{
  return Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
}

double yawOf(const Eigen::Quaterniond& q)
{
  const Eigen::Matrix3d r = q.toRotationMatrix();
  return std::atan2(r(1, 0), r(0, 0));
}

// Output bin of a direction for the default output geometry (-pi..pi, pi/720, 1441 bins).
std::size_t binOf(double angle)
{
  double rel = wrapAngle(angle) + kPi;
  long k = std::lround(rel / (kPi / 720.0));
  return static_cast<std::size_t>(k % 1440);
}

// Range of the ray from the origin along `angle` to the square room |x|, |y| <= h.
double squareRoom(double angle, double h)
{
  const double c = std::abs(std::cos(angle)), s = std::abs(std::sin(angle));
  return std::min(c > 1e-12 ? h / c : 1e9, s > 1e-12 ? h / s : 1e9);
}
}  // namespace

// ---------------------------------------------------------------- parameters

TEST(Parameters, DefaultsWithOneSourceAreValid)
{
  MergerParams p = oneSource();
  EXPECT_NO_THROW(p.validate());
  EXPECT_EQ(p.output.beamCount(), 1441u);
}

TEST(Parameters, BadConfigsNameTheParameter)
{
  auto param_of = [](const MergerParams& p) {
    try
    {
      p.validate();
    }
    catch (const ParameterError& e)
    {
      return e.parameter();
    }
    return std::string("none");
  };
  MergerParams p = oneSource();
  p.sources.push_back(source("a"));
  EXPECT_EQ(param_of(p), "sources[1].name");

  p = oneSource();
  p.sources[0].topic.clear();
  EXPECT_EQ(param_of(p), "sources[0].topic");

  p = oneSource();
  p.output.angle_min = 1.0;
  p.output.angle_max = 1.0;
  EXPECT_EQ(param_of(p), "angle_min");

  p = oneSource();
  p.output.range_min = 5.0;
  p.output.range_max = 2.0;
  EXPECT_EQ(param_of(p), "range_min");

  p = oneSource();
  p.sources[0].range_min = 3.0;
  p.sources[0].range_max = 3.0;
  EXPECT_EQ(param_of(p), "sources[0].range_min");

  p = oneSource();
  p.sources[0].angle_min = 0.5;
  p.sources[0].angle_max = 0.5;
  EXPECT_EQ(param_of(p), "sources[0].angle_min");

  p = oneSource();
  p.sources[0].timeout = 0.0;
  EXPECT_EQ(param_of(p), "sources[0].timeout");

  p = oneSource();
  p.output.angle_increment = 0.0;
  EXPECT_EQ(param_of(p), "angle_increment");

  p = oneSource();
  p.odom_queue_size = 1;
  EXPECT_EQ(param_of(p), "odom_queue_size");

  p = oneSource();
  p.sources.clear();
  EXPECT_EQ(param_of(p), "sources");

  p = oneSource();
  p.output.footprint = { { { 0.0, 0.0 } }, { { 1.0, 0.0 } } };
  EXPECT_EQ(param_of(p), "footprint");
  p.output.footprint.push_back({ { 0.0, kNaNF } });
  EXPECT_EQ(param_of(p), "footprint");

  p = oneSource();
  p.output.finite_only = true;  // use_inf is true
  EXPECT_EQ(param_of(p), "finite_only");
  p.output.use_inf = false;  // range_min is 0: 0 would not be below it
  EXPECT_EQ(param_of(p), "range_min");
  p.output.range_min = 0.05;
  EXPECT_EQ(param_of(p), "none");

  p = oneSource();
  p.output.frame = "/base_link";
  EXPECT_EQ(param_of(p), "output_frame");

  for (double bad : { -0.1, static_cast<double>(kNaNF), static_cast<double>(kInfF) })
  {
    p = oneSource();
    p.sources[0].drop_explained_within = bad;
    EXPECT_EQ(param_of(p), "sources[0].drop_explained_within");
  }

  p = oneSource();
  p.publish_rate = 1e-9;  // a period of 1e9 s does not fit a ros::Duration
  EXPECT_EQ(param_of(p), "publish_rate");

  // A wrap-around field of view (min > max) is valid.
  p = oneSource();
  p.sources[0].angle_min = 2.5;
  p.sources[0].angle_max = -2.5;
  EXPECT_NO_THROW(p.validate());
  EXPECT_THROW(MergerCore{ MergerParams() }, ParameterError);
}

// ---------------------------------------------------------------- scan validation

TEST(ScanValidation, MalformedScansGiveReasons)
{
  Scan s{ std::vector<float>(360, 1.0f), {} };
  ScanView v = s.view();
  EXPECT_EQ(scanFault(v), "");

  ScanView bad = v;
  bad.n_ranges = 300;
  ASSERT_NE(scanFault(bad), "");
  EXPECT_NE(std::string(scanFault(bad)).find("ranges length"), std::string::npos);

  bad = v;
  bad.angle_increment = 0.0;
  EXPECT_EQ(scanFault(bad), "angle_increment <= 0");
  bad.angle_increment = -0.01;
  EXPECT_EQ(scanFault(bad), "angle_increment <= 0");

  bad = v;
  bad.angle_min = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(std::string(scanFault(bad)).find("non-finite"), std::string::npos);
  bad = v;
  bad.angle_max = std::numeric_limits<double>::infinity();
  EXPECT_NE(std::string(scanFault(bad)).find("non-finite"), std::string::npos);

  bad = v;
  bad.n_ranges = 0;
  EXPECT_EQ(scanFault(bad), "empty ranges");

  std::vector<float> few(10, 1.0f);
  bad = v;
  bad.intensities = few.data();
  bad.n_intensities = few.size();
  EXPECT_NE(std::string(scanFault(bad)).find("intensities"), std::string::npos);

  // A malformed scan is left out of the merge with status kInvalid.
  MergerCore core(oneSource());
  MergedScan out;
  std::vector<SourceStatus> st;
  bad = v;
  bad.angle_increment = 0.0;
  core.merge({ input(bad) }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out, st);
  EXPECT_EQ(st[0], SourceStatus::kInvalid);
  for (float r : out.ranges)
    EXPECT_EQ(r, kInfF);
}

// A scan the caller checked once on arrival (the ROS glue) merges as an unchecked one, and the
// overload that writes into the caller's vectors (the outgoing message's) gives the same output,
// its intensities emptied when no source has any.
TEST(ScanValidation, CheckedInputsAndWritingIntoTheMessage)
{
  MergerCore core(oneSource());
  Scan s{ std::vector<float>(360, 3.0f), {} };
  s.ranges[10] = 1.5f;
  SourceInput unchecked = input(s.view(0.0));
  ASSERT_EQ(scanFault(unchecked.scan), "");
  SourceInput checked = unchecked;
  checked.checked = true;
  MergedScan out;
  std::vector<SourceStatus> st;
  core.merge({ unchecked }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out, st);
  ASSERT_EQ(st[0], SourceStatus::kUsed);
  std::vector<float> ranges, intensities(5, 1.0f);
  core.merge({ checked }, 0.0, nullptr, Eigen::Isometry3d::Identity(), ranges, intensities, st);
  EXPECT_EQ(st[0], SourceStatus::kUsed);
  ASSERT_EQ(ranges.size(), core.beamCount());
  EXPECT_EQ(ranges, out.ranges);
  EXPECT_TRUE(intensities.empty());
}

// ---------------------------------------------------------------- remapping

TEST(Remap, From360To1440AndBack)
{
  std::vector<float> in(360);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> d(0.1f, 10.0f);
  for (auto& r : in)
    r = d(rng);
  std::vector<float> up, down;
  remapResolution(in, 1440, up);
  ASSERT_EQ(up.size(), 1440u);
  for (std::size_t i = 0; i < 1440; ++i)
  {
    if (i % 4 == 0)
      EXPECT_EQ(up[i], in[i / 4]);
    else
      EXPECT_EQ(up[i], kInfF) << "gap " << i << " must be no-return";
  }
  remapResolution(up, 360, down);
  ASSERT_EQ(down.size(), 360u);
  for (std::size_t i = 0; i < 360; ++i)
    EXPECT_EQ(down[i], in[i]);

  // Downsampling keeps the closest of the merged beams.
  std::vector<float> four = { 3.0f, 1.0f, kNaNF, kInfF };
  remapResolution(four, 1, down);
  EXPECT_EQ(down[0], 1.0f);
}

TEST(Remap, MergeOfAlignedSourceMatchesIndexMapping)
{
  // With sensor frame == output frame the merge's binning is Eq. (1).
  Scan s{ std::vector<float>(360), {} };
  for (std::size_t i = 0; i < 360; ++i)
    s.ranges[i] = 1.0f + 0.01f * i;
  MergerCore core(oneSource());
  MergedScan out;
  std::vector<SourceStatus> st;
  core.merge({ input(s.view()) }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out, st);
  std::vector<float> expected;
  remapResolution(s.ranges, 1440, expected);
  ASSERT_EQ(out.ranges.size(), 1441u);
  for (std::size_t i = 0; i < 1440; ++i)
  {
    if (std::isinf(expected[i]))
      EXPECT_EQ(out.ranges[i], expected[i]) << i;
    else
      EXPECT_NEAR(out.ranges[i], expected[i], 1e-5) << i;
  }
  EXPECT_EQ(out.ranges[1440], out.ranges[0]);  // -pi and pi are one direction
}

// ---------------------------------------------------------------- field of view

TEST(FieldOfView, PlainAndWrapAround)
{
  SourceParams s = source("a");
  s.angle_min = -kPi / 2;
  s.angle_max = kPi / 2;
  EXPECT_TRUE(s.inFieldOfView(0.0));
  EXPECT_TRUE(s.inFieldOfView(1.5));
  EXPECT_FALSE(s.inFieldOfView(1.6));
  EXPECT_FALSE(s.inFieldOfView(kPi));
  EXPECT_FALSE(s.inFieldOfView(-1.6));

  s.angle_min = 2.5;  // rear sector only, across +-pi
  s.angle_max = -2.5;
  EXPECT_TRUE(s.inFieldOfView(kPi));
  EXPECT_TRUE(s.inFieldOfView(-kPi));
  EXPECT_TRUE(s.inFieldOfView(2.6));
  EXPECT_TRUE(s.inFieldOfView(-2.6));
  EXPECT_TRUE(s.inFieldOfView(3.0 - 2.0 * kPi));
  EXPECT_FALSE(s.inFieldOfView(0.0));
  EXPECT_FALSE(s.inFieldOfView(2.4));
  EXPECT_FALSE(s.inFieldOfView(-2.4));

  s.angle_min = -kPi;
  s.angle_max = kPi;
  for (double a = -4.0; a < 4.0; a += 0.1)
    EXPECT_TRUE(s.inFieldOfView(a));
}

TEST(FieldOfView, MaskAppliedInMerge)
{
  MergerParams p = oneSource();
  p.sources[0].angle_min = 2.5;
  p.sources[0].angle_max = -2.5;
  MergerCore core(p);
  Scan s{ std::vector<float>(360, 2.0f), {} };
  MergedScan out;
  std::vector<SourceStatus> st;
  core.merge({ input(s.view()) }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out, st);
  for (std::size_t k = 0; k < out.ranges.size(); ++k)
  {
    const double a = -kPi + k * kPi / 720.0;
    if (std::abs(a) < 2.49)
    {
      EXPECT_EQ(out.ranges[k], kInfF) << k;
    }
    if (std::abs(a) > 2.51 && k % 4 == 0)
    {
      EXPECT_NEAR(out.ranges[k], 2.0f, 1e-5) << k;
    }
  }
}

TEST(FieldOfView, SourceRangeLimits)
{
  MergerParams p = oneSource();
  p.sources[0].range_min = 0.5;  // tighter than the message's 0.05: the robot's body
  p.sources[0].range_max = 4.0;
  MergerCore core(p);
  Scan s{ std::vector<float>(360, 2.0f), {} };
  s.ranges[0] = 0.3f;    // below the source's range_min: invalid, marked NaN
  s.ranges[1] = 5.0f;    // beyond the source's range_max, within the message's 30 m: a real return
                         // past the trusted range, no proof of free space: invalid
  s.ranges[2] = -kInfF;  // too close, inside the tightened limit: ignored like the body
  s.ranges[3] = 65.5f;   // beyond the message's own range_max: the driver's "no return"
  MergedScan out;
  std::vector<SourceStatus> st;
  core.merge({ input(s.view()) }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out, st);
  EXPECT_TRUE(std::isnan(out.ranges[0]));
  EXPECT_TRUE(std::isnan(out.ranges[4]));
  EXPECT_TRUE(std::isnan(out.ranges[8]));
  EXPECT_EQ(out.ranges[12], kInfF);
  EXPECT_NEAR(out.ranges[16], 2.0f, 1e-5);
}

// Driver error codes (finite, below the message's range_min, like the Hokuyo's 0.006-0.019 m
// with range_min 0.02) are not measurements: never an obstacle, never hiding a real range.
TEST(Readings, OutOfRangeFiniteValuesAreNeverObstacles)
{
  MergerParams p = oneSource();
  p.sources.push_back(source("b"));
  MergerCore core(p);
  Scan a{ std::vector<float>(360, kInfF), {} };
  Scan b{ std::vector<float>(360, kInfF), {} };
  for (std::size_t i = 0; i < 20; ++i)
    a.ranges[i] = 0.006f + 0.0007f * static_cast<float>(i);  // 0.006 .. 0.019 m
  a.ranges[30] = 0.0f;                                       // "no echo" as 0 (SICK style)
  a.ranges[40] = 99.0f;                                      // beyond range_max (30 m)
  b.ranges[40] = 4.0f;                                       // a real return in the same direction
  b.ranges[10] = 2.0f;
  ScanView va = a.view();
  va.range_min = 0.02;
  MergedScan out;
  std::vector<SourceStatus> st;
  core.merge({ input(va), input(b.view()) }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out, st);
  for (std::size_t k = 0; k < out.ranges.size(); ++k)
  {
    if (k == 40 || k == 160)
      continue;
    EXPECT_FALSE(std::isfinite(out.ranges[k]) && out.ranges[k] != kInfF) << "bin " << k << ": " << out.ranges[k];
  }
  EXPECT_NEAR(out.ranges[40], 2.0f, 1e-5);   // b's return wins over a's error code in bin 40
  EXPECT_NEAR(out.ranges[160], 4.0f, 1e-5);  // and over a's 99 m (no return) in bin 160
  EXPECT_TRUE(std::isnan(out.ranges[0]));    // an error code alone: invalid, not free
  EXPECT_TRUE(std::isnan(out.ranges[120]));
}

TEST(Readings, TooCloseIsObstacleSwitch)
{
  Scan a{ std::vector<float>(360, kInfF), {} };
  a.ranges[10] = -kInfF;
  for (bool obstacle : { true, false })
  {
    MergerParams p = oneSource();
    p.sources[0].too_close_is_obstacle = obstacle;
    MergerCore core(p);
    MergedScan out;
    std::vector<SourceStatus> st;
    core.merge({ input(a.view()) }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out, st);
    if (obstacle)
      EXPECT_NEAR(out.ranges[40], 0.05f, 1e-6);  // at the message's range_min
    else
      EXPECT_TRUE(std::isnan(out.ranges[40]));  // invalid: no obstacle, no free space
  }
}

// ---------------------------------------------------------------- input checks

TEST(InputChecks, TimeIncrementSpanningMinutesIsMalformed)
{
  Scan s{ std::vector<float>(360, 1.0f), {} };
  ScanView v = s.view();
  v.time_increment = 1.0;  // 360 s for one scan
  EXPECT_NE(scanFault(v), "");
  v.time_increment = -1e-4;  // a lidar spinning the other way: fine
  EXPECT_EQ(scanFault(v), "");
}

// ---------------------------------------------------------------- footprint

TEST(Footprint, InsidePolygon)
{
  const std::vector<std::array<double, 2>> rect = {
    { { -0.4, -0.3 } }, { { 0.4, -0.3 } }, { { 0.4, 0.3 } }, { { -0.4, 0.3 } }
  };
  EXPECT_TRUE(insidePolygon(rect, 0.0, 0.0));
  EXPECT_TRUE(insidePolygon(rect, 0.39, -0.29));
  EXPECT_FALSE(insidePolygon(rect, 0.41, 0.0));
  EXPECT_FALSE(insidePolygon(rect, 0.0, -0.31));
  // A concave "U" (clockwise): the notch between the arms is outside.
  const std::vector<std::array<double, 2>> u = { { { 0, 0 } }, { { 0, 3 } }, { { 1, 3 } }, { { 1, 1 } },
                                                 { { 2, 1 } }, { { 2, 3 } }, { { 3, 3 } }, { { 3, 0 } } };
  EXPECT_TRUE(insidePolygon(u, 0.5, 2.5));
  EXPECT_TRUE(insidePolygon(u, 2.5, 2.5));
  EXPECT_FALSE(insidePolygon(u, 1.5, 2.0));
  EXPECT_TRUE(insidePolygon(u, 1.5, 0.5));
}

TEST(Footprint, ReturnsOnTheRobotAreDroppedOthersKept)
{
  MergerParams p = oneSource();
  p.sources.push_back(source("b"));
  p.sources[1].footprint_filter = false;
  p.output.footprint = { { { -0.4, -0.3 } }, { { 0.4, -0.3 } }, { { 0.4, 0.3 } }, { { -0.4, 0.3 } } };
  MergerCore core(p);
  // Both sensors at (0.3, 0), looking forward; beam 180 of 360 points backwards (angle 0 is
  // beam 180; angle pi is beam 0).
  const Eigen::Isometry3d mount = pose(0.3, 0.0, 0.0, 0.0, 0.0, 0.0);
  Scan a{ std::vector<float>(360, kInfF), {} };
  a.ranges[0] = 0.2f;      // backwards 0.2 m: (0.1, 0), on the robot: dropped
  a.ranges[90] = 0.25f;    // to the right (-pi/2) 0.25 m: (0.3, -0.25), on the robot
  a.ranges[100] = 1.0f;    // (0.3 + cos(-80 deg), sin(-80 deg)): outside, kept
  a.ranges[190] = 0.2f;    // forwards, 10 degrees left: (0.497, 0.035), outside the footprint, kept
  a.ranges[270] = -kInfF;  // too close to the left: at (0.3, 0.05), on the robot: dropped
  Scan b{ std::vector<float>(360, kInfF), {} };
  b.ranges[90] = 0.25f;  // the same point, but b opted out of the filter
  MergedScan out;
  std::vector<SourceStatus> st;
  core.merge({ input(a.view(), mount) }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out, st);
  auto bin = [&](double x, double y) {
    return static_cast<std::size_t>(std::lround((std::atan2(y, x) + kPi) / p.output.angle_increment));
  };
  EXPECT_TRUE(std::isnan(out.ranges[bin(0.1, 0.0)]));
  EXPECT_TRUE(std::isnan(out.ranges[bin(0.3, -0.25)]));
  EXPECT_TRUE(std::isnan(out.ranges[bin(0.3, 0.05)]));
  const double x100 = 0.3 + std::cos(-80.0 * kPi / 180.0), y100 = std::sin(-80.0 * kPi / 180.0);
  EXPECT_NEAR(out.ranges[bin(x100, y100)], std::hypot(x100, y100), 1e-4);
  const double x190 = 0.3 + 0.2 * std::cos(10.0 * kPi / 180.0), y190 = 0.2 * std::sin(10.0 * kPi / 180.0);
  EXPECT_NEAR(out.ranges[bin(x190, y190)], std::hypot(x190, y190), 1e-4);
  for (float r : out.ranges)
    EXPECT_FALSE(std::isfinite(r) && r < 0.45f);  // nothing on the robot

  core.merge({ input(a.view(), mount), input(b.view(), mount) }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out, st);
  EXPECT_NEAR(out.ranges[bin(0.3, -0.25)], std::hypot(0.3, 0.25), 1e-4);  // b's point kept

  MergerParams bad = oneSource();
  bad.output.footprint = { { { 0.0, 0.0 } }, { { 1.0, 0.0 } } };
  EXPECT_THROW(bad.validate(), ParameterError);
}

TEST(SelfFilter, ReturnsOnAMovingArmAreDroppedWithDeskewAndObstaclesBesideItKept)
{
  // A lidar 0.2 m ahead of the robot's centre sees a 4 m square room; the arm's forearm, a
  // 0.2 m box on its own tf frame, stands in front of it, posed (in the sensor's frame) where
  // the glue's tf lookup put it for each scan. The robot turns at 1 rad/s and the source deskews.
  const double h = 2.0, dt = 0.1 / 360.0;
  OdometryBuffer odom(100);
  for (int i = 0; i <= 40; ++i)
    odom.add(0.01 * i, Eigen::Vector3d::Zero(), yawQ(0.01 * i));
  laserscan_common::RobotShape forearm;
  forearm.name = forearm.frame = "forearm";
  forearm.half_extents = Eigen::Vector3d(0.1, 0.1, 0.1);
  forearm.padding = 0.02;
  laserscan_common::SelfFilter arm({ forearm }, "self_filter/shapes");
  MergerParams p = oneSource();
  p.sources[0].deskew = true;
  MergerCore core(p);
  const Eigen::Isometry3d mount = pose(0.2, 0.0, 0.0, 0.0, 0.0, 0.0);
  for (const double arm_y : { -0.5, 0.0, 0.6 })  // the arm moved between scans
  {
    // The forearm's near face is 0.6 m ahead of the sensor; a post 4 cm beside its padded
    // shape, and the room elsewhere.
    arm.setFramePoses({ Eigen::Isometry3d(Eigen::Translation3d(0.7, arm_y, 0.0)) });
    Scan s{ std::vector<float>(360), {} };
    std::size_t on_arm = 0, post_beam = 0;
    for (std::size_t i = 0; i < 360; ++i)
    {
      const double a = s.angle(i);
      double r = squareRoom(a + i * dt, h) - 0.2 * std::cos(a);  // roughly the room, from the sensor
      const double y_at_face = 0.6 * std::tan(a);
      if (std::cos(a) > 0 && std::abs(y_at_face - arm_y) < 0.1)
      {
        r = 0.6 / std::cos(a);  // the forearm's face
        ++on_arm;
      }
      else if (std::cos(a) > 0 && y_at_face > arm_y + 0.16 && y_at_face < arm_y + 0.2 && post_beam == 0)
      {
        r = 0.6 / std::cos(a);  // a post 4 cm beside the padded forearm, at its face's distance
        post_beam = i;
      }
      s.ranges[i] = static_cast<float>(r);
    }
    ASSERT_GT(on_arm, 5u);
    ASSERT_NE(post_beam, 0u);
    ScanView v = s.view(0.0);
    v.time_increment = dt;
    MergedScan plain, filtered;
    std::vector<SourceStatus> st;
    core.merge({ input(v, mount) }, 0.1, &odom, Eigen::Isometry3d::Identity(), plain, st);
    SourceInput in = input(v, mount);
    in.self_filter = &arm;
    core.merge({ in }, 0.1, &odom, Eigen::Isometry3d::Identity(), filtered, st);
    std::size_t near_plain = 0, near_filtered = 0, invalid = 0;
    for (std::size_t k = 0; k < plain.ranges.size(); ++k)
    {
      // The forearm's face lies 0.8 to 1.0 m from the robot's centre, the post too; the room
      // at least 1.8 m.
      near_plain += std::isfinite(plain.ranges[k]) && plain.ranges[k] < 1.3f;
      near_filtered += std::isfinite(filtered.ranges[k]) && filtered.ranges[k] < 1.3f;
      invalid += std::isnan(filtered.ranges[k]) && !std::isnan(plain.ranges[k]);
    }
    EXPECT_GE(near_plain, on_arm + 1) << arm_y;
    EXPECT_EQ(near_filtered, 1u) << arm_y << ": only the post stays";  // the post's one beam
    // The forearm's directions become invalid, not free (one NaN per dropped beam's direction;
    // two adjacent beams' rays from the sensor may share an output bin).
    EXPECT_GE(invalid + 2, on_arm) << arm_y << ": the forearm's directions are invalid, not free";
    EXPECT_GT(invalid, 5u) << arm_y;
  }
}

// ---------------------------------------------------------------- output modes

// What each output option writes for no return, too close and invalid.
TEST(OutputModes, NonFiniteValuesPerOption)
{
  Scan a{ std::vector<float>(360, kInfF), {} };  // bin 0 (-pi): no return
  a.ranges[10] = 0.2f;                           // bin 40: below the output's range_min 0.5: too close
  a.ranges[20] = kNaNF;                          // bin 80: invalid
  a.ranges[30] = 2.0f;                           // bin 120: a real range
  struct Mode
  {
    bool use_inf, finite_only;
    float no_return, too_close, invalid;  // NaN stands for "is NaN"
  };
  const Mode modes[] = { { true, false, kInfF, -kInfF, kNaNF },
                         { false, false, 3.5f, -kInfF, kNaNF },
                         { false, true, 3.5f, 0.0f, 0.0f } };
  for (const Mode& m : modes)
  {
    MergerParams p = oneSource();
    p.output.range_min = 0.5;
    p.output.range_max = 2.5;
    p.output.use_inf = m.use_inf;
    p.output.finite_only = m.finite_only;
    MergerCore core(p);
    MergedScan out;
    std::vector<SourceStatus> st;
    core.merge({ input(a.view()) }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out, st);
    SCOPED_TRACE(std::string("use_inf ") + (m.use_inf ? "true" : "false") + ", finite_only " +
                 (m.finite_only ? "true" : "false"));
    EXPECT_EQ(out.ranges[0], m.no_return);
    EXPECT_EQ(out.ranges[40], m.too_close);
    if (std::isnan(m.invalid))
    {
      EXPECT_TRUE(std::isnan(out.ranges[80]));
    }
    else
    {
      EXPECT_EQ(out.ranges[80], m.invalid);
    }
    EXPECT_NEAR(out.ranges[120], 2.0f, 1e-5);
    if (m.finite_only)
    {
      for (float r : out.ranges)
        EXPECT_TRUE(std::isfinite(r)) << r;
    }
  }
}

// ---------------------------------------------------------------- geometry

TEST(Transform, RearLidarYawPi)
{
  MergerCore core(oneSource());
  Scan s{ std::vector<float>(360, 1.0f), {} };
  MergedScan out;
  std::vector<SourceStatus> st;
  core.merge({ input(s.view(), pose(-0.3, 0.0, 0.2, 0, 0, kPi)) }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out,
             st);
  for (std::size_t i = 0; i < 360; ++i)
  {
    const double a = s.angle(i);
    // Rotated by pi: the sensor's (cos a, sin a) is the robot's (-cos a, -sin a).
    const double x = -0.3 - std::cos(a), y = -std::sin(a);
    EXPECT_NEAR(out.ranges[binOf(std::atan2(y, x))], std::hypot(x, y), 1e-4) << i;
  }
  // The beam straight ahead of the rear lidar is behind the robot at 1.3 m.
  EXPECT_NEAR(out.ranges[0], 1.3, 1e-4);
  EXPECT_NEAR(out.ranges[1440], 1.3, 1e-4);
}

TEST(Transform, UpsideDownLidarIsMirrored)
{
  MergerCore core(oneSource());
  Scan s{ std::vector<float>(360, kInfF), {} };
  // Only the beam at sensor angle +90 degrees sees something, 2 m away.
  s.ranges[270] = 2.0f;
  ASSERT_NEAR(s.angle(270), kPi / 2, 1e-9);
  MergedScan out;
  std::vector<SourceStatus> st;
  core.merge({ input(s.view(), pose(0.2, 0.1, 0.4, kPi, 0, 0)) }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out, st);
  // Upside down (roll pi): the sensor's left is the robot's right.
  const double x = 0.2, y = 0.1 - 2.0;
  EXPECT_NEAR(out.ranges[binOf(std::atan2(y, x))], std::hypot(x, y), 1e-4);
  std::size_t finite = 0;
  for (float r : out.ranges)
    finite += std::isfinite(r) ? 1 : 0;
  EXPECT_EQ(finite, 1u);

  // Every beam of a full scan against the analytic mirror.
  Scan full{ std::vector<float>(360, 1.5f), {} };
  core.merge({ input(full.view(), pose(0.2, 0.1, 0.4, kPi, 0, 0.3)) }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out,
             st);
  for (std::size_t i = 0; i < 360; ++i)
  {
    const double a = full.angle(i);
    // roll pi maps (c, s) to (c, -s); then yaw 0.3 rotates: the angle becomes 0.3 - a.
    const double x = 0.2 + 1.5 * std::cos(0.3 - a), y = 0.1 + 1.5 * std::sin(0.3 - a);
    EXPECT_NEAR(out.ranges[binOf(std::atan2(y, x))], std::hypot(x, y), 1e-4) << i;
  }
}

TEST(Transform, NoOutOfBoundsOnAngleMax)
{
  MergerParams p = oneSource();
  p.output.angle_min = -kPi / 2;
  p.output.angle_max = kPi / 2;
  p.output.angle_increment = kPi / 180;
  MergerCore core(p);
  ASSERT_EQ(core.beamCount(), 181u);
  Scan s{ std::vector<float>(360, 1.0f), {} };
  MergedScan out;
  std::vector<SourceStatus> st;
  core.merge({ input(s.view()) }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out, st);
  ASSERT_EQ(out.ranges.size(), 181u);
  EXPECT_NEAR(out.ranges[0], 1.0f, 1e-5);
  EXPECT_NEAR(out.ranges[180], 1.0f, 1e-5);  // the beam exactly on angle_max
}

// ---------------------------------------------------------------- odometry

TEST(Odometry, InterpolationAcrossPi)
{
  OdometryBuffer b(10);
  b.add(0.0, Eigen::Vector3d(0, 0, 0), yawQ(3.0));
  b.add(1.0, Eigen::Vector3d(2, 4, 0), yawQ(-3.0));  // 3.0 -> 3.283: through +-pi
  Pose p;
  ASSERT_TRUE(b.poseAt(0.5, p));
  EXPECT_NEAR(p.position.x(), 1.0, 1e-12);
  EXPECT_NEAR(p.position.y(), 2.0, 1e-12);
  EXPECT_NEAR(std::abs(yawOf(p.orientation)), kPi, 1e-9);
  ASSERT_TRUE(b.poseAt(0.25, p));
  EXPECT_NEAR(wrapAngle(yawOf(p.orientation) - (3.0 + 0.25 * (2 * kPi - 6.0))), 0.0, 1e-9);
}

TEST(Odometry, ShortestArcForNegatedQuaternion)
{
  OdometryBuffer b(10);
  b.add(0.0, Eigen::Vector3d::Zero(), yawQ(0.2));
  Eigen::Quaterniond q = yawQ(0.4);
  q.coeffs() = -q.coeffs();  // same rotation
  b.add(1.0, Eigen::Vector3d::Zero(), q);
  Pose p;
  ASSERT_TRUE(b.poseAt(0.5, p));
  EXPECT_NEAR(yawOf(p.orientation), 0.3, 1e-9);
  EXPECT_NEAR(yawOf(slerpShortest(yawQ(0.2), q, 0.25)), 0.25, 1e-9);
}

TEST(Odometry, ClampingQueueSizeAndTimeBackwards)
{
  OdometryBuffer b(3);
  Pose p;
  EXPECT_FALSE(b.poseAt(1.0, p));
  for (int i = 0; i < 5; ++i)
    EXPECT_EQ(b.add(i, Eigen::Vector3d(i, 0, 0), yawQ(0.1 * i)), OdometryBuffer::AddResult::kAdded);
  EXPECT_EQ(b.size(), 3u);
  EXPECT_EQ(b.oldestTime(), 2.0);
  EXPECT_EQ(b.newestTime(), 4.0);
  ASSERT_TRUE(b.poseAt(-10.0, p));  // before the oldest: the oldest
  EXPECT_EQ(p.position.x(), 2.0);
  EXPECT_NEAR(yawOf(p.orientation), 0.2, 1e-12);
  ASSERT_TRUE(b.poseAt(100.0, p));  // after the newest: the newest, no extrapolation
  EXPECT_EQ(p.position.x(), 4.0);
  ASSERT_TRUE(b.poseAt(3.5, p));
  EXPECT_NEAR(p.position.x(), 3.5, 1e-12);
  EXPECT_NEAR(yawOf(p.orientation), 0.35, 1e-9);

  // A small step back is a late message: ignored. A big one is a jump back: cleared.
  EXPECT_EQ(b.add(3.5, Eigen::Vector3d(9, 0, 0), yawQ(0)), OdometryBuffer::AddResult::kOutOfOrder);
  EXPECT_EQ(b.size(), 3u);
  EXPECT_EQ(b.newestTime(), 4.0);
  EXPECT_EQ(b.add(1.0, Eigen::Vector3d(9, 0, 0), yawQ(0)), OdometryBuffer::AddResult::kClearedBackwards);
  EXPECT_EQ(b.size(), 1u);
  EXPECT_EQ(b.oldestTime(), 1.0);
  EXPECT_EQ(b.add(2.0, Eigen::Vector3d(std::nan(""), 0, 0), yawQ(0)), OdometryBuffer::AddResult::kRejected);
  Eigen::Quaterniond zero(0, 0, 0, 0);
  EXPECT_EQ(b.add(2.0, Eigen::Vector3d::Zero(), zero), OdometryBuffer::AddResult::kRejected);
  EXPECT_EQ(b.size(), 1u);
}

// ---------------------------------------------------------------- motion compensation

TEST(MotionCompensation, HeadingNinetyDegreesDrivingForward)
{
  // Robot heading +90 degrees in odom (facing +y) drives forward at 1 m/s.
  OdometryBuffer odom(10);
  for (int i = 0; i <= 4; ++i)
    odom.add(0.05 * i, Eigen::Vector3d(0, 0.05 * i, 0), yawQ(kPi / 2));
  MergerCore core(oneSource());
  Scan s{ std::vector<float>(360, kInfF), {} };
  s.ranges[180] = 2.0f;  // straight ahead (angle 0), 2 m
  s.ranges[270] = 2.0f;  // to the left, 2 m
  MergedScan out;
  std::vector<SourceStatus> st;
  // The scan is 100 ms old at the output time 0.15.
  core.merge({ input(s.view(0.05)) }, 0.15, &odom, Eigen::Isometry3d::Identity(), out, st);
  EXPECT_EQ(st[0], SourceStatus::kUsed);
  // The obstacle ahead came 0.1 m closer; it did not move sideways.
  EXPECT_NEAR(out.ranges[binOf(0.0)], 1.9f, 1e-4);
  // The one on the left is now 0.1 m behind the robot's y axis.
  EXPECT_NEAR(out.ranges[binOf(std::atan2(2.0, -0.1))], std::hypot(2.0, 0.1), 1e-4);
  EXPECT_EQ(out.ranges[binOf(kPi / 2)], kInfF);

  // A sensor mounted elsewhere: same motion, same answer in the robot frame.
  core.merge({ input(s.view(0.05), pose(0.3, 0.0, 0.0, 0, 0, 0)) }, 0.15, &odom, Eigen::Isometry3d::Identity(), out,
             st);
  EXPECT_NEAR(out.ranges[binOf(0.0)], 2.2f, 1e-4);

  // An output frame that is not the odometry's child frame: the motion (in the robot frame)
  // is conjugated into it. Output frame = robot frame turned by +90 degrees and shifted.
  const Eigen::Isometry3d output_T_robot = pose(0.5, 0.0, 0.0, 0, 0, -kPi / 2);
  // Sensor at the robot's origin, looking along the robot's x axis.
  core.merge({ input(s.view(0.05), output_T_robot) }, 0.15, &odom, output_T_robot, out, st);
  // The obstacle ahead is at robot (1.9, 0) at t_out, i.e. output (0.5, -1.9).
  EXPECT_NEAR(out.ranges[binOf(std::atan2(-1.9, 0.5))], std::hypot(0.5, 1.9), 1e-4);
}

TEST(MotionCompensation, TimeoutLeavesOldScansOut)
{
  MergerParams p = oneSource();
  p.sources.push_back(source("b"));
  p.sources[0].timeout = 0.2;
  MergerCore core(p);
  Scan s{ std::vector<float>(360, 1.0f), {} };
  Scan s2{ std::vector<float>(360, 3.0f), {} };
  MergedScan out;
  std::vector<SourceStatus> st;
  SourceInput missing;
  core.merge({ input(s.view(0.0)), input(s2.view(0.5)) }, 0.5, nullptr, Eigen::Isometry3d::Identity(), out, st);
  EXPECT_EQ(st[0], SourceStatus::kTimedOut);
  EXPECT_EQ(st[1], SourceStatus::kUsed);
  EXPECT_NEAR(out.ranges[0], 3.0f, 1e-5);
  core.merge({ missing, input(s2.view(0.5)) }, 0.5, nullptr, Eigen::Isometry3d::Identity(), out, st);
  EXPECT_EQ(st[0], SourceStatus::kMissing);
}

TEST(MotionCompensation, DeskewWhileRotatingOneRadPerSecond)
{
  // Robot at the centre of a 4 m square room, turning in place at 1 rad/s (yaw = t).
  const double h = 2.0, dt = 0.1 / 360.0;
  OdometryBuffer odom(100);
  for (int i = 0; i <= 20; ++i)
    odom.add(0.01 * i, Eigen::Vector3d::Zero(), yawQ(0.01 * i));
  Scan s{ std::vector<float>(360), {} };
  for (std::size_t i = 0; i < 360; ++i)
    s.ranges[i] = static_cast<float>(squareRoom(s.angle(i) + i * dt, h));  // measured at t = i*dt
  ScanView v = s.view(0.0);
  v.time_increment = dt;
  MergerParams p = oneSource();
  p.sources[0].deskew = true;
  MergerCore core(p);
  MergedScan out;
  std::vector<SourceStatus> st;
  const double t_out = 0.1;
  core.merge({ input(v) }, t_out, &odom, Eigen::Isometry3d::Identity(), out, st);
  double worst = 0.0;
  std::size_t checked = 0;
  for (std::size_t k = 0; k < 1440; ++k)
  {
    if (!std::isfinite(out.ranges[k]))
      continue;
    const double a = -kPi + k * kPi / 720.0;  // in the robot frame at t_out
    // The bin holds the beam nearest its centre (within half a bin): compare with the
    // room's range along the bin's direction, allowing the slope of the wall over half a bin.
    const double expected = squareRoom(a + t_out, h);
    const double slope = std::abs(squareRoom(a + t_out + kPi / 1440, h) - squareRoom(a + t_out - kPi / 1440, h));
    worst = std::max(worst, std::abs(out.ranges[k] - expected) - slope);
    ++checked;
  }
  EXPECT_GT(checked, 300u);
  EXPECT_LT(worst, 0.01);

  // Without deskew the same scan is visibly wrong (the 0.1 rad turn during the scan).
  p.sources[0].deskew = false;
  MergerCore plain(p);
  plain.merge({ input(v) }, t_out, &odom, Eigen::Isometry3d::Identity(), out, st);
  double worst_plain = 0.0;
  for (std::size_t k = 0; k < 1440; ++k)
    if (std::isfinite(out.ranges[k]))
      worst_plain = std::max(worst_plain, std::abs(out.ranges[k] - squareRoom(-kPi + k * kPi / 720.0 + t_out, h)));
  EXPECT_GT(worst_plain, 0.1);
}

// ---------------------------------------------------------------- fusion

TEST(Fusion, Rep117Rules)
{
  float bin = kInfF;
  fuse(bin, kNaNF);
  EXPECT_TRUE(std::isnan(bin));  // invalid is kept over no-return
  fuse(bin, kInfF);
  EXPECT_TRUE(std::isnan(bin));  // no-return never replaces invalid
  fuse(bin, 2.0f);
  EXPECT_EQ(bin, 2.0f);  // a real range replaces NaN
  fuse(bin, kInfF);
  fuse(bin, kNaNF);
  fuse(bin, 3.0f);
  EXPECT_EQ(bin, 2.0f);  // +Inf, NaN and farther ranges never replace it
  fuse(bin, 1.0f);
  EXPECT_EQ(bin, 1.0f);
  fuse(bin, -kInfF);
  EXPECT_EQ(bin, -kInfF);  // too close is the closest
  fuse(bin, 0.5f);
  fuse(bin, kNaNF);
  EXPECT_EQ(bin, -kInfF);
}

TEST(Fusion, TwoSourcesClosestWinsAndNoReturnNeverHides)
{
  MergerParams p = oneSource();
  p.sources.push_back(source("b"));
  MergerCore core(p);
  Scan a{ std::vector<float>(360, 2.0f), std::vector<float>(360, 10.0f) };
  Scan b{ std::vector<float>(360, 3.0f), std::vector<float>(360, 20.0f) };
  a.ranges[0] = kNaNF;
  a.ranges[1] = kInfF;
  a.ranges[2] = -kInfF;  // too close for a: obstacle at a's range_min 0.05
  b.ranges[3] = 1.0f;
  MergedScan out;
  std::vector<SourceStatus> st;
  core.merge({ input(a.view()), input(b.view()) }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out, st);
  EXPECT_NEAR(out.ranges[0], 3.0f, 1e-5);
  EXPECT_EQ(out.intensities[0], 20.0f);
  EXPECT_NEAR(out.ranges[4], 3.0f, 1e-5);
  EXPECT_NEAR(out.ranges[8], 0.05f, 1e-5);
  EXPECT_EQ(out.intensities[8], 10.0f);
  EXPECT_NEAR(out.ranges[12], 1.0f, 1e-5);
  EXPECT_NEAR(out.ranges[16], 2.0f, 1e-5);
  EXPECT_EQ(out.intensities[16], 10.0f);
  EXPECT_EQ(out.ranges[17], kInfF);  // gaps of the low-resolution inputs
  EXPECT_EQ(out.intensities[17], 0.0f);
}

TEST(Fusion, NoReturnStaysNoReturnWithoutAnyRangeLimit)
{
  MergerCore core(oneSource());  // the source's range_max is +Inf
  Scan a{ std::vector<float>(360, kInfF), {} };
  a.ranges[10] = 2.0f;
  ScanView v = a.view();
  v.range_max = std::numeric_limits<double>::infinity();  // and the message's too
  MergedScan out;
  std::vector<SourceStatus> st;
  core.merge({ input(v) }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out, st);
  std::size_t finite = 0;
  for (float r : out.ranges)
    finite += std::isfinite(r) ? 1 : 0;
  EXPECT_EQ(finite, 1u);
  EXPECT_NEAR(out.ranges[40], 2.0f, 1e-5);
  EXPECT_EQ(out.ranges[44], kInfF);
}

TEST(Fusion, OutputLimitsAndUseInf)
{
  MergerParams p = oneSource();
  p.output.range_min = 0.5;
  p.output.range_max = 2.5;
  p.output.use_inf = false;
  p.output.inf_epsilon = 0.5;
  MergerCore core(p);
  Scan a{ std::vector<float>(360, 2.0f), {} };
  a.ranges[0] = 3.0f;
  a.ranges[1] = 0.2f;
  a.ranges[2] = kNaNF;
  MergedScan out;
  std::vector<SourceStatus> st;
  core.merge({ input(a.view()) }, 0.0, nullptr, Eigen::Isometry3d::Identity(), out, st);
  EXPECT_EQ(out.ranges[0], 3.0f);    // beyond range_max: no return = range_max + inf_epsilon
  EXPECT_EQ(out.ranges[1], 3.0f);    // a gap: no return
  EXPECT_EQ(out.ranges[4], -kInfF);  // closer than range_min: too close
  EXPECT_TRUE(std::isnan(out.ranges[8]));
  EXPECT_NEAR(out.ranges[12], 2.0f, 1e-5);
  EXPECT_TRUE(out.intensities.empty());
}

// ---------------------------------------------------------------- drop_explained_within

// A sonar arc as the range converter makes it: every beam of the cone at the echo's range.
struct Arc
{
  std::vector<float> ranges = std::vector<float>(31);  // 1 degree apart: a 30-degree cone
  explicit Arc(float r) { std::fill(ranges.begin(), ranges.end(), r); }
  ScanView view() const
  {
    ScanView v;
    v.angle_min = -15.0 * kPi / 180.0;
    v.angle_increment = kPi / 180.0;
    v.angle_max = v.angle_min + (ranges.size() - 1) * v.angle_increment;
    v.range_min = 0.02;
    v.range_max = 5.0;
    v.ranges = ranges.data();
    v.n_ranges = ranges.size();
    return v;
  }
};

// A 720-beam lidar (output bins 2k) seeing `far` everywhere and a wall at `wall` within +-5 degrees.
Scan lidarWithWall(float far, float wall)
{
  Scan lidar{ std::vector<float>(720, far), {} };
  for (int i = 350; i <= 370; ++i)
    lidar.ranges[i] = wall;
  return lidar;
}

// Output bin of sensor beam j (0..30) of an arc facing yaw_deg: 0.25-degree bins, 720 = straight ahead.
std::size_t arcBin(int j, int yaw_deg)
{
  return static_cast<std::size_t>(720 + 4 * (j - 15 + yaw_deg));
}

MergedScan mergeAll(const std::vector<SourceParams>& sources, const std::vector<SourceInput>& inputs)
{
  MergerParams p;
  p.sources = sources;
  MergerCore core(p);
  MergedScan out;
  std::vector<SourceStatus> st;
  core.merge(inputs, 0.0, nullptr, Eigen::Isometry3d::Identity(), out, st);
  for (SourceStatus s : st)
    EXPECT_EQ(s, SourceStatus::kUsed);
  return out;
}

SourceParams arcSource(const std::string& name, double tolerance)
{
  SourceParams s = source(name);
  s.drop_explained_within = tolerance;
  return s;
}

// Bin by bin: equal (NaN to NaN), finite values within `tolerance`.
void expectSameRanges(const std::vector<float>& got, const std::vector<float>& expected, float tolerance = 0.0f)
{
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t k = 0; k < got.size(); ++k)
  {
    if (std::isfinite(expected[k]))
    {
      EXPECT_NEAR(got[k], expected[k], tolerance) << "bin " << k;
    }
    else if (!(std::isnan(got[k]) && std::isnan(expected[k])))
    {
      EXPECT_EQ(got[k], expected[k]) << "bin " << k;
    }
  }
}

TEST(DropExplained, ArcOnAWallTheLidarSeesIsDropped)
{
  const Scan lidar = lidarWithWall(kInfF, 2.0f);
  const MergedScan lidar_only = mergeAll({ source("lidar") }, { input(lidar.view()) });
  for (float echo : { 2.0f, 2.1f, 1.9f })  // the sonar's own range error, within 0.15 m
  {
    const Arc arc(echo);
    const MergedScan out =
      mergeAll({ source("lidar"), arcSource("sonar", 0.15) }, { input(lidar.view()), input(arc.view()) });
    expectSameRanges(out.ranges, lidar_only.ranges);
  }
  // Beyond the tolerance the echo is something else: the arc is kept.
  const Arc arc(1.8f);
  const MergedScan out =
    mergeAll({ source("lidar"), arcSource("sonar", 0.15) }, { input(lidar.view()), input(arc.view()) });
  EXPECT_FLOAT_EQ(out.ranges[arcBin(0, 0)], 1.8f);
}

TEST(DropExplained, ArcBeforeGlassIsKept)
{
  const Scan lidar = lidarWithWall(5.0f, 5.0f);  // through the pane
  const Arc arc(1.0f);
  const MergedScan lidar_only = mergeAll({ source("lidar") }, { input(lidar.view()) });
  const MergedScan out =
    mergeAll({ arcSource("sonar", 0.15), source("lidar") }, { input(arc.view()), input(lidar.view()) });
  std::vector<float> expected = lidar_only.ranges;
  for (int j = 0; j <= 30; ++j)
    expected[arcBin(j, 0)] = 1.0f;
  expectSameRanges(out.ranges, expected, 1e-5f);
}

TEST(DropExplained, ZeroToleranceIsTheUsualFusion)
{
  const Scan lidar = lidarWithWall(kInfF, 2.0f);
  Arc arc(2.0f);
  arc.ranges[0] = -kInfF;  // too close: an obstacle at range_min, as for any source
  arc.ranges[1] = kNaNF;   // invalid: replaces only the lidar's no return
  const MergedScan out =
    mergeAll({ source("lidar"), arcSource("sonar", 0.0) }, { input(lidar.view()), input(arc.view()) });
  EXPECT_FLOAT_EQ(out.ranges[arcBin(0, 0)], 0.02f);
  EXPECT_TRUE(std::isnan(out.ranges[arcBin(1, 0)]));
  for (int j = 2; j <= 30; ++j)
    EXPECT_FLOAT_EQ(out.ranges[arcBin(j, 0)], 2.0f) << j;  // the cone's widening included
  const MergedScan plain = mergeAll({ source("lidar"), source("sonar") }, { input(lidar.view()), input(arc.view()) });
  expectSameRanges(out.ranges, plain.ranges);
}

TEST(DropExplained, KeptArcKeepsTooCloseAndInvalidAsTheFirstPass)
{
  const Scan lidar = lidarWithWall(5.0f, 5.0f);
  Arc arc(1.0f);
  arc.ranges[0] = -kInfF;
  arc.ranges[1] = kNaNF;
  const MergedScan out =
    mergeAll({ source("lidar"), arcSource("sonar", 0.15) }, { input(lidar.view()), input(arc.view()) });
  const MergedScan plain = mergeAll({ source("lidar"), source("sonar") }, { input(lidar.view()), input(arc.view()) });
  expectSameRanges(out.ranges, plain.ranges);
  EXPECT_FLOAT_EQ(out.ranges[arcBin(0, 0)], 0.02f);
  EXPECT_FLOAT_EQ(out.ranges[arcBin(1, 0)], 5.0f);  // invalid never hides a return
}

TEST(DropExplained, SeveralArcsAreJudgedAgainstTheOtherSourcesOnly)
{
  const Scan lidar = lidarWithWall(5.0f, 2.0f);
  const Arc wall_arc(2.05f);  // ahead: explained by the lidar's wall, dropped
  const Arc glass_arc(1.0f);  // to the left: the lidar sees 5 m, kept
  const Arc near_arc(1.05f);  // 10 degrees further: overlaps glass_arc's cone, must not be judged against it
  const Eigen::Isometry3d glass = pose(0, 0, 0, 0, 0, 90.0 * kPi / 180.0);
  const Eigen::Isometry3d at100 = pose(0, 0, 0, 0, 0, 100.0 * kPi / 180.0);
  const SourceParams l = source("lidar"), w = arcSource("w", 0.15), g = arcSource("g", 0.15), n = arcSource("n", 0.15);
  const SourceInput li = input(lidar.view()), wi = input(wall_arc.view()), gi = input(glass_arc.view(), glass),
                    ni = input(near_arc.view(), at100);
  const MergedScan ref = mergeAll({ l, w, g, n }, { li, wi, gi, ni });
  expectSameRanges(mergeAll({ n, g, w, l }, { ni, gi, wi, li }).ranges, ref.ranges);
  expectSameRanges(mergeAll({ g, l, n, w }, { gi, li, ni, wi }).ranges, ref.ranges);
  const MergedScan lidar_only = mergeAll({ l }, { li });
  std::vector<float> expected = lidar_only.ranges;
  for (int j = 0; j <= 30; ++j)
  {
    expected[arcBin(j, 100)] = 1.05f;
    expected[arcBin(j, 90)] = 1.0f;  // closest wins where the two cones overlap
  }
  expectSameRanges(ref.ranges, expected, 1e-5f);
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
