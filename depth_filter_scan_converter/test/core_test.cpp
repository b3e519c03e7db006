// Tests of the ROS-free core: parameters, cloud layout checks, projection.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "depth_filter_scan_converter/projector.hpp"
#include "depth_filter_scan_converter/parameters.hpp"
#include "cloud_fixtures.hpp"
#include "pcl_cloud.hpp"

namespace dfsc = depth_filter_scan_converter;

namespace
{
using namespace depth_filter_scan_converter::test;  // NOLINT: fixtures of this test

std::size_t countFinite(const std::vector<float>& r)
{
  std::size_t n = 0;
  for (float v : r)
    n += std::isfinite(v) ? 1 : 0;
  return n;
}

std::size_t binOf(const dfsc::Parameters& p, double angle)
{
  return static_cast<std::size_t>(std::lround((angle - p.scan.angle_min) / p.scan.angle_increment));
}

std::vector<float> project(const dfsc::Parameters& p, const TestCloud& c, const Eigen::Isometry3d& t)
{
  dfsc::Projector proj(p);
  std::vector<float> ranges;
  proj.project(c.view(), t, ranges);
  return ranges;
}

// Core and reference may differ for a point within micro-units of a border; count such bins.
std::size_t countDisagreements(const std::vector<float>& a, const std::vector<float>& b, double tol = 1e-4)
{
  EXPECT_EQ(a.size(), b.size());
  std::size_t n = 0;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i)
  {
    if (std::isinf(a[i]) && a[i] == b[i])  // +Inf (no return) and -Inf (too close) differ
      continue;
    if (!(std::fabs(a[i] - b[i]) <= tol * std::max(1.0f, std::fabs(b[i]))))
      ++n;
  }
  return n;
}
}  // namespace

// ---------------------------------------------------------------- parameters

TEST(Parameters, DefaultsAreValidAndFollowTheFencepostRule)
{
  dfsc::Parameters p;
  EXPECT_NO_THROW(p.validate());
  EXPECT_EQ(p.scan.beamCount(), 1441u);
  p.scan.angle_min = 0.0;
  p.scan.angle_max = 1.0;
  p.scan.angle_increment = 0.3;  // 3.33 increments: round -> 3, plus the fencepost
  EXPECT_EQ(p.scan.beamCount(), 4u);
}

TEST(Parameters, ValidateNamesTheBadParameter)
{
  auto expectBad = [](const std::function<void(dfsc::Parameters&)>& change, const std::string& name) {
    dfsc::Parameters p;
    change(p);
    try
    {
      p.validate();
      ADD_FAILURE() << "no exception for " << name;
    }
    catch (const dfsc::ParameterError& e)
    {
      EXPECT_EQ(e.parameter(), name) << e.what();
    }
  };
  expectBad([](auto& p) { p.band.min_height = 2.0; }, "min_height");
  expectBad([](auto& p) { p.band.max_height = kNaN; }, "max_height");
  expectBad([](auto& p) { p.scan.angle_min = 4.0; }, "angle_min");
  expectBad([](auto& p) { p.scan.angle_increment = 0.0; }, "angle_increment");
  expectBad([](auto& p) { p.scan.range_min = -1.0; }, "range_min");
  expectBad([](auto& p) { p.scan.range_min = 20.0; }, "range_min");
  expectBad([](auto& p) { p.band.hole_depth = -0.1; }, "hole_depth");
  expectBad([](auto& p) { p.transform.transform_tolerance = -1.0; }, "transform_tolerance");
  expectBad([](auto& p) { p.input.row_stride = 0; }, "row_stride");
  expectBad([](auto& p) { p.input.column_stride = -2; }, "column_stride");
  expectBad([](auto& p) { p.scan.inf_epsilon = -1.0; }, "inf_epsilon");
  expectBad([](auto& p) { p.transform.reference_frame = ""; }, "reference_frame");
  expectBad([](auto& p) { p.band.floor_height = kInf; }, "floor_height");
  expectBad(
    [](auto& p) {
      p.scan.use_inf = false;
      p.scan.range_max = kInf;
    },
    "range_max");
  // "No limit" is spelled +/-inf and is valid.
  dfsc::Parameters p;
  p.band.min_height = -kInf;
  p.band.max_height = kInf;
  p.scan.range_max = kInf;
  EXPECT_NO_THROW(p.validate());
}

TEST(Projector, SetParametersRejectsInvalidAndKeepsTheOldOnes)
{
  dfsc::Parameters p;
  p.band.max_height = 0.7;
  dfsc::Projector proj(p);
  dfsc::Parameters bad = p;
  bad.band.min_height = 0.9;
  EXPECT_THROW(proj.setParameters(bad), dfsc::ParameterError);
  EXPECT_DOUBLE_EQ(proj.parameters().band.max_height, 0.7);
  EXPECT_DOUBLE_EQ(proj.parameters().band.min_height, 0.05);
  EXPECT_THROW(dfsc::Projector{ bad }, dfsc::ParameterError);
}

// ---------------------------------------------------------------- angle approximation

// ---------------------------------------------------------------- analytic cases

TEST(Projector, CameraPitched30DegOverEmptyFloorGivesNoReturn)
{
  const Eigen::Isometry3d cam = cameraMount(1.0, 30 * kDeg);
  const Points pts = render(Scene{}, cam, 320, 163);
  std::size_t valid = 0;
  for (const auto& p : pts)
    valid += std::isfinite(p.x()) ? 1 : 0;
  ASSERT_GT(valid, pts.size() * 9 / 10);  // the camera does see the floor
  const TestCloud cloud = makeCloud<float>(pts, 320, 163);

  dfsc::Parameters p;
  const std::vector<float> ranges = project(p, cloud, cam);
  ASSERT_EQ(ranges.size(), p.scan.beamCount());
  for (float r : ranges)
    EXPECT_TRUE(std::isinf(r) && r > 0);

  // Same floor, band lowered to include it: now it shows, so the test above is not vacuous.
  p.band.min_height = -0.01;
  EXPECT_GT(countFinite(project(p, cloud, cam)), 100u);
}

TEST(Projector, WallAtKnownDistance)
{
  Scene scene;
  scene.wall_x = 2.0;
  const Eigen::Isometry3d cam = cameraMount(0.5, 0.0);
  const TestCloud cloud = makeCloud<float>(render(scene, cam, 320, 163), 320, 163);
  dfsc::Parameters p;
  const std::vector<float> ranges = project(p, cloud, cam);
  std::size_t seen = 0;
  for (std::size_t i = 0; i < ranges.size(); ++i)
  {
    const double a = p.scan.angle_min + i * p.scan.angle_increment;
    if (std::fabs(a) < 28 * kDeg)
    {
      ASSERT_TRUE(std::isfinite(ranges[i])) << "beam " << i;
      EXPECT_NEAR(ranges[i] * std::cos(a), 2.0, 0.01) << "beam " << i;
      ++seen;
    }
    else if (std::fabs(a) > 31 * kDeg)
    {
      EXPECT_TRUE(std::isinf(ranges[i])) << "beam " << i;
    }
  }
  EXPECT_GT(seen, 200u);
  std::vector<float> ref;
  dfsc::referenceProject(p, cloud.view(), cam, ref);
  EXPECT_LE(countDisagreements(ranges, ref), 2u);
}

TEST(Projector, TableTopJustInsideAndJustOutsideTheBand)
{
  dfsc::Parameters p;
  p.band.floor_height = -0.147;
  p.band.min_height = 0.05;
  p.band.max_height = 0.8;
  const double lo = p.band.floor_height + p.band.min_height, hi = p.band.floor_height + p.band.max_height;
  // One table top per direction, 1.5 m away: heights 2 mm inside or outside the band.
  const double heights[] = { lo + 0.002, lo - 0.002, hi - 0.002, hi + 0.002 };
  const double angles[] = { -0.4, -0.1, 0.2, 0.5 };
  const bool expected[] = { true, false, true, false };
  Points ref_pts;
  for (int k = 0; k < 4; ++k)
    for (int j = -3; j <= 3; ++j)  // a small patch, all at the same height
      ref_pts.push_back(
        Vector3d(1.5 * std::cos(angles[k] + j * 0.001), 1.5 * std::sin(angles[k] + j * 0.001), heights[k]));
  const Eigen::Isometry3d cam = cameraMount(0.9, 30 * kDeg, 0.0, 0.0, 0.1, 0.0);
  const std::vector<float> ranges = project(p, makeCloud(toCamera(ref_pts, cam)), cam);
  for (int k = 0; k < 4; ++k)
  {
    const std::size_t centre = binOf(p, angles[k]);
    if (expected[k])
    {
      EXPECT_NEAR(ranges[centre], 1.5, 1e-4) << "table " << k;
    }
    for (std::size_t b = centre - 3; b <= centre + 3; ++b)
    {
      if (!expected[k])
      {
        EXPECT_TRUE(std::isinf(ranges[b])) << "table " << k;
      }
      else if (std::isfinite(ranges[b]))
      {
        EXPECT_NEAR(ranges[b], 1.5, 1e-4) << "table " << k;
      }
    }
  }
  EXPECT_GE(countFinite(ranges), 2u * 2u);
  EXPECT_LE(countFinite(ranges), 2u * 3u);  // 7 points 1 mrad apart cover 2 or 3 beams of 4.4 mrad
}

TEST(Projector, HoleBecomesObstacleWhereTheCameraRayMeetsTheFloor)
{
  const Eigen::Isometry3d cam = cameraMount(1.0, 30 * kDeg);
  const Vector3d hole(2.0, 0.3, -0.3);       // 30 cm below the floor
  const Vector3d shallow(2.0, -0.5, -0.03);  // 3 cm below the floor: not a hole
  const TestCloud cloud = makeCloud(toCamera({ hole, shallow }, cam));
  dfsc::Parameters p;
  EXPECT_EQ(countFinite(project(p, cloud, cam)), 0u);  // hole detection is off by default

  p.band.hole_detection = true;
  p.band.hole_depth = 0.05;
  dfsc::Projector proj(p);
  std::vector<float> ranges, kept;
  proj.project(cloud.view(), cam, ranges, nullptr, &kept);
  // Ray from (0, 0, 1) through (2, 0.3, -0.3) crosses z = 0 at t = 1 / 1.3.
  const Vector3d crossing = cam.translation() + (hole - cam.translation()) / 1.3;
  EXPECT_NEAR(crossing.z(), 0.0, 1e-12);
  EXPECT_EQ(countFinite(ranges), 1u);
  EXPECT_NEAR(ranges[binOf(p, std::atan2(crossing.y(), crossing.x()))], std::hypot(crossing.x(), crossing.y()), 1e-4);
  ASSERT_EQ(kept.size(), 3u);
  EXPECT_NEAR(kept[0], crossing.x(), 1e-4);
  EXPECT_NEAR(kept[1], crossing.y(), 1e-4);
  EXPECT_NEAR(kept[2], 0.0, 1e-6);

  // Range limits apply to the crossing, not to the hole point.
  p.scan.range_max = 1.5;
  EXPECT_EQ(countFinite(project(p, cloud, cam)), 0u);

  // A camera below the floor sees no hole in front of it.
  p.scan.range_max = 10.0;
  p.band.floor_height = 1.5;
  p.band.min_height = 2.0;
  p.band.max_height = 3.0;
  EXPECT_EQ(countFinite(project(p, cloud, cam)), 0u);
}

TEST(Projector, PointExactlyOnAngleMaxStaysInBounds)
{
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  {
    dfsc::Parameters p;  // -pi .. pi: the point behind the robot has atan2 = +pi
    const std::vector<float> ranges = project(p, makeCloud({ Vector3d(-2.0, 0.0, 0.5) }), identity);
    ASSERT_EQ(ranges.size(), 1441u);
    EXPECT_FLOAT_EQ(ranges.back(), 2.0f);
    EXPECT_EQ(countFinite(ranges), 1u);
  }
  {
    dfsc::Parameters p;
    p.scan.angle_min = -1.0;
    p.scan.angle_max = 1.0;
    p.scan.angle_increment = 0.01;
    const Vector3d on_max(2.0 * std::cos(1.0), 2.0 * std::sin(1.0), 0.5);
    const Vector3d on_min(3.0 * std::cos(-1.0), 3.0 * std::sin(-1.0), 0.5);
    const std::vector<float> ranges = project(p, makeCloud({ on_max, on_min }), identity);
    ASSERT_EQ(ranges.size(), 201u);
    EXPECT_FLOAT_EQ(ranges.back(), 2.0f);
    EXPECT_FLOAT_EQ(ranges.front(), 3.0f);
    EXPECT_EQ(countFinite(ranges), 2u);
  }
  {
    dfsc::Parameters p;  // limits that are not a whole number of increments apart
    p.scan.angle_min = 0.0;
    p.scan.angle_max = 1.0;
    p.scan.angle_increment = 0.3;
    const std::vector<float> ranges = project(
      p, makeCloud({ Vector3d(std::cos(1.0), std::sin(1.0), 0.5), Vector3d(std::cos(1.2), std::sin(1.2), 0.5) }),
      identity);
    ASSERT_EQ(ranges.size(), 4u);
    EXPECT_FLOAT_EQ(ranges[3], 1.0f);  // 1.0 rad -> beam 3 (0.9 rad), the point at 1.2 rad is outside
    EXPECT_EQ(countFinite(ranges), 1u);
  }
}

TEST(Projector, NanAndInfPointsAreSkipped)
{
  Points pts(16, Vector3d(kNaN, kNaN, kNaN));
  pts[3] = Vector3d(kInf, 0.0, 0.5);
  pts[4] = Vector3d(1.0, -kInf, 0.5);
  pts[5] = Vector3d(1.0, 0.0, kInf);
  pts[6] = Vector3d(1.0, 0.0, -kInf);
  pts[7] = Vector3d(kNaN, 0.0, 0.5);
  pts[9] = Vector3d(1.0, 1.0, 0.5);
  const TestCloud cloud = makeCloud<float>(pts, 4, 4);
  dfsc::Parameters p;
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  std::vector<float> ranges = project(p, cloud, identity);
  EXPECT_EQ(countFinite(ranges), 1u);
  EXPECT_FLOAT_EQ(ranges[binOf(p, M_PI / 4)], static_cast<float>(std::sqrt(2.0)));
  // With every limit open, infinite points must still not slip through.
  p.band.min_height = -kInf;
  p.band.max_height = kInf;
  p.scan.range_max = kInf;
  p.band.hole_detection = true;
  ranges = project(p, cloud, cameraMount(1.0, 0.3));
  EXPECT_EQ(countFinite(ranges), 1u);
  for (float r : ranges)
    EXPECT_FALSE(std::isnan(r));
}

TEST(Projector, EmptyCloudGivesAllNoReturn)
{
  dfsc::Parameters p;
  for (const auto& wh : { std::pair<std::uint32_t, std::uint32_t>{ 0, 0 }, { 10, 0 }, { 0, 1 } })
  {
    const TestCloud cloud = makeCloud<float>({}, wh.first, wh.second);
    const std::vector<float> ranges = project(p, cloud, cameraMount(1.0, 0.0));
    ASSERT_EQ(ranges.size(), p.scan.beamCount());
    EXPECT_EQ(countFinite(ranges), 0u);
  }
}

TEST(Projector, UnorganizedCloudMatchesOrganizedOne)
{
  Scene scene;
  scene.wall_x = 3.0;
  scene.boxes.push_back({ Vector3d(1.0, -0.5, 0.0), Vector3d(1.4, 0.1, 0.6) });
  const Eigen::Isometry3d cam = cameraMount(0.8, 20 * kDeg);
  const Points pts = render(scene, cam, 64, 48);
  dfsc::Parameters p;
  const std::vector<float> organized = project(p, makeCloud<float>(pts, 64, 48), cam);
  const std::vector<float> unorganized = project(p, makeCloud(pts), cam);
  EXPECT_EQ(organized, unorganized);
  EXPECT_GT(countFinite(organized), 50u);
  // The box is closer than the wall in its directions.
  float nearest = std::numeric_limits<float>::infinity();
  for (std::size_t b = binOf(p, -2 * kDeg); b <= binOf(p, 2 * kDeg); ++b)  // columns are ~1 degree apart
    nearest = std::min(nearest, organized[b]);
  EXPECT_NEAR(nearest, 1.0, 0.01);
}

TEST(Projector, Float64FieldsGiveTheSameScan)
{
  Scene scene;
  scene.wall_x = 2.5;
  scene.boxes.push_back({ Vector3d(1.2, 0.2, 0.0), Vector3d(1.6, 0.8, 0.4) });
  const Eigen::Isometry3d cam = cameraMount(0.6, 15 * kDeg, 5 * kDeg);
  const Points pts = render(scene, cam, 80, 60);
  dfsc::Parameters p;
  const std::vector<float> f32 = project(p, makeCloud<float>(pts, 80, 60), cam);
  const std::vector<float> f64 = project(p, makeCloud<double>(pts, 80, 60), cam);
  EXPECT_GT(countFinite(f32), 50u);
  EXPECT_EQ(countDisagreements(f32, f64, 1e-5), 0u);
}

TEST(Projector, OddPointStepAndRowPadding)
{
  Scene scene;
  scene.wall_x = 2.0;
  const Eigen::Isometry3d cam = cameraMount(0.5, 10 * kDeg);
  const Points pts = render(scene, cam, 40, 30);
  dfsc::Parameters p;
  const std::vector<float> plain = project(p, makeCloud<float>(pts, 40, 30), cam);
  // x at byte 3 (unaligned), point_step 3 + 12 + 4 + 6 = 25, 7 padding bytes per row.
  const TestCloud odd = makeCloud<float>(pts, 40, 30, 3, 6, 7);
  EXPECT_EQ(odd.layout.point_step, 25u);
  EXPECT_EQ(project(p, odd, cam), plain);
  // 32-byte points take a kernel of their own (fixed step); 16 bytes is the plain layout.
  const TestCloud wide = makeCloud<float>(pts, 40, 30, 0, 16);
  EXPECT_EQ(wide.layout.point_step, 32u);
  EXPECT_EQ(project(p, wide, cam), plain);
  const TestCloud wide_offset = makeCloud<float>(pts, 40, 30, 8, 8);
  EXPECT_EQ(wide_offset.layout.point_step, 32u);
  EXPECT_EQ(project(p, wide_offset, cam), plain);
  const TestCloud odd64 = makeCloud<double>(pts, 40, 30, 5, 1, 3);
  EXPECT_EQ(countDisagreements(project(p, odd64, cam), plain, 1e-5), 0u);
  EXPECT_GT(countFinite(plain), 50u);
}

TEST(Projector, RowAndColumnStridesSkipPoints)
{
  // 6 x 6 organized cloud, all NaN except two obstacle points.
  Points pts(36, Vector3d(kNaN, kNaN, kNaN));
  pts[1 * 6 + 1] = Vector3d(1.0, 0.0, 0.5);  // row 1, column 1: skipped by row_stride 2
  pts[2 * 6 + 3] = Vector3d(0.0, 2.0, 0.5);  // row 2, column 3: kept by row 2 / column 3 strides
  const TestCloud cloud = makeCloud<float>(pts, 6, 6);
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  dfsc::Parameters p;
  EXPECT_EQ(countFinite(project(p, cloud, identity)), 2u);
  p.input.row_stride = 2;
  p.input.column_stride = 3;
  const std::vector<float> ranges = project(p, cloud, identity);
  EXPECT_EQ(countFinite(ranges), 1u);
  EXPECT_FLOAT_EQ(ranges[binOf(p, M_PI / 2)], 2.0f);
  p.input.column_stride = 2;
  EXPECT_EQ(countFinite(project(p, cloud, identity)), 0u);

  // On a rendered scene, strides agree with the reference that applies the same strides.
  Scene scene;
  scene.wall_x = 2.2;
  scene.boxes.push_back({ Vector3d(1.0, -0.3, 0.0), Vector3d(1.3, 0.3, 0.3) });
  const Eigen::Isometry3d cam = cameraMount(0.7, 25 * kDeg);
  const TestCloud big = makeCloud<float>(render(scene, cam, 160, 120), 160, 120);
  p.input.row_stride = 3;
  p.input.column_stride = 2;
  std::vector<float> ref;
  dfsc::referenceProject(p, big.view(), cam, ref);
  const std::vector<float> fast = project(p, big, cam);
  EXPECT_GT(countFinite(fast), 50u);
  EXPECT_LE(countDisagreements(fast, ref), 2u);
}

TEST(Projector, UseInfFalseWritesRangeMaxPlusEpsilon)
{
  dfsc::Parameters p;
  p.scan.use_inf = false;
  p.scan.range_max = 6.0;
  p.scan.inf_epsilon = 0.5;
  const std::vector<float> ranges = project(p, makeCloud({ Vector3d(1.0, 0.0, 0.5) }), Eigen::Isometry3d::Identity());
  EXPECT_FLOAT_EQ(ranges[binOf(p, 0.0)], 1.0f);
  for (std::size_t i = 0; i < ranges.size(); ++i)
  {
    if (i != binOf(p, 0.0))
    {
      ASSERT_FLOAT_EQ(ranges[i], 6.5f);
    }
  }
}

TEST(Projector, RangeLimitsArePlanarDistances)
{
  dfsc::Parameters p;
  p.scan.range_min = 1.0;
  p.scan.range_max = 3.0;
  const Points pts = { Vector3d(0.9, 0.0, 0.5), Vector3d(0.0, 1.1, 0.9), Vector3d(-3.1, 0.0, 0.5),
                       Vector3d(0.0, -2.9, 0.1) };
  const std::vector<float> ranges = project(p, makeCloud(pts), Eigen::Isometry3d::Identity());
  EXPECT_EQ(countFinite(ranges), 2u);
  EXPECT_FLOAT_EQ(ranges[binOf(p, M_PI / 2)], 1.1f);
  EXPECT_FLOAT_EQ(ranges[binOf(p, -M_PI / 2)], 2.9f);
  EXPECT_EQ(ranges[binOf(p, 0.0)], -std::numeric_limits<float>::infinity());  // 0.9 m: too close
  EXPECT_EQ(ranges[binOf(p, M_PI)], std::numeric_limits<float>::infinity());  // 3.1 m: beyond range_max
}

// A person 0.2 m in front of a camera whose range_min is 0.3 m must never read as free space
// (+Inf): a costmap with inf_is_valid would clear it.
TEST(Projector, TooCloseIsNegativeInfinityOrRangeMinNeverNoReturn)
{
  dfsc::Parameters p;
  p.scan.range_min = 0.3;
  // Beam at 0: the person's legs at 0.2 m and the wall behind at 2 m; beam at 1 rad: the wall only.
  const Points pts = { Vector3d(0.2, 0.0, 0.5), Vector3d(2.0, 0.0, 0.5),
                       Vector3d(2.0 * std::cos(1.0), 2.0 * std::sin(1.0), 0.5) };
  const TestCloud cloud = makeCloud(pts);
  for (bool at_range_min : { false, true })
  {
    p.scan.too_close_at_range_min = at_range_min;
    const std::vector<float> ranges = project(p, cloud, Eigen::Isometry3d::Identity());
    std::vector<float> ref;
    dfsc::referenceProject(p, cloud.view(), Eigen::Isometry3d::Identity(), ref);
    const float too_close = at_range_min ? 0.3f : -std::numeric_limits<float>::infinity();
    EXPECT_EQ(ranges[binOf(p, 0.0)], too_close);
    EXPECT_EQ(ref[binOf(p, 0.0)], too_close);
    EXPECT_FLOAT_EQ(ranges[binOf(p, 1.0)], 2.0f);
    EXPECT_EQ(countDisagreements(ranges, ref), 0u);
    // Too close points are obstacles: the filtered cloud shows them.
    std::vector<float> again, kept;
    dfsc::Projector(p).project(cloud.view(), Eigen::Isometry3d::Identity(), again, nullptr, &kept);
    EXPECT_EQ(kept.size(), 9u);
  }
  // A point outside the band is no obstacle, however close.
  p.scan.too_close_at_range_min = false;
  const std::vector<float> ranges = project(p, makeCloud({ Vector3d(0.2, 0.0, 1.5) }), Eigen::Isometry3d::Identity());
  EXPECT_EQ(ranges[binOf(p, 0.0)], std::numeric_limits<float>::infinity());
}

TEST(Projector, IntensityOfTheClosestPoint)
{
  const Points pts = { Vector3d(2.0, 0.0, 0.5), Vector3d(1.0, 0.0, 0.5), Vector3d(3.0, 0.0, 0.5),
                       Vector3d(0.0, 1.0, 0.5) };
  const TestCloud cloud = makeCloud<float>(pts, 4, 1, 0, 0, 0, { 5.0f, 9.0f, 7.0f, 3.0f });
  dfsc::Parameters p;
  dfsc::Projector proj(p);
  std::vector<float> ranges, intensities;
  proj.project(cloud.view("intensity"), Eigen::Isometry3d::Identity(), ranges, &intensities);
  ASSERT_EQ(intensities.size(), ranges.size());
  EXPECT_FLOAT_EQ(intensities[binOf(p, 0.0)], 9.0f);
  EXPECT_FLOAT_EQ(intensities[binOf(p, M_PI / 2)], 3.0f);
  EXPECT_FLOAT_EQ(intensities[binOf(p, 1.0)], 0.0f);
  // No intensity field selected: the output is empty.
  proj.project(cloud.view(), Eigen::Isometry3d::Identity(), ranges, &intensities);
  EXPECT_TRUE(intensities.empty());
}

TEST(Projector, KeptPointsAreTheFilteredPointsInTheReferenceFrame)
{
  const Eigen::Isometry3d cam = cameraMount(1.0, 20 * kDeg, 0.0, 0.3, 0.2, -0.1);
  const Points ref_pts = { Vector3d(1.0, 0.2, 0.4), Vector3d(1.5, 0.2, 0.01), Vector3d(2.0, -1.0, 0.9) };
  dfsc::Projector proj{ dfsc::Parameters() };
  std::vector<float> ranges, kept;
  proj.project(makeCloud(toCamera(ref_pts, cam)).view(), cam, ranges, nullptr, &kept);
  ASSERT_EQ(kept.size(), 6u);
  EXPECT_NEAR(kept[0], 1.0, 1e-5);
  EXPECT_NEAR(kept[1], 0.2, 1e-5);
  EXPECT_NEAR(kept[2], 0.4, 1e-5);
  EXPECT_NEAR(kept[3], 2.0, 1e-5);
  EXPECT_NEAR(kept[4], -1.0, 1e-5);
  EXPECT_NEAR(kept[5], 0.9, 1e-5);
}

TEST(Projector, BuffersReusedAcrossCallsDoNotLeak)
{
  dfsc::Parameters p;
  dfsc::Projector proj(p);
  std::vector<float> ranges;
  proj.project(makeCloud({ Vector3d(1.0, 0.0, 0.5) }).view(), Eigen::Isometry3d::Identity(), ranges);
  EXPECT_EQ(countFinite(ranges), 1u);
  proj.project(makeCloud({ Vector3d(0.0, 1.0, 0.5) }).view(), Eigen::Isometry3d::Identity(), ranges);
  EXPECT_EQ(countFinite(ranges), 1u);
  EXPECT_FLOAT_EQ(ranges[binOf(p, M_PI / 2)], 1.0f);
  p.scan.angle_min = -1.0;
  p.scan.angle_max = 1.0;
  proj.setParameters(p);
  proj.project(makeCloud({ Vector3d(0.0, 1.0, 0.5) }).view(), Eigen::Isometry3d::Identity(), ranges);
  EXPECT_EQ(ranges.size(), p.scan.beamCount());
  EXPECT_EQ(countFinite(ranges), 0u);
}

TEST(Projector, AgreesWithTheReferenceOnRandomMounts)
{
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::size_t finite = 0;
  for (int trial = 0; trial < 20; ++trial)
  {
    const Eigen::Isometry3d cam =
      cameraMount(0.3 + 0.7 * (u(rng) + 1), 40 * kDeg * u(rng), 30 * kDeg * u(rng), M_PI * u(rng), u(rng), u(rng));
    Points pts;
    for (int i = 0; i < 3000; ++i)
      pts.push_back(Vector3d(3 * u(rng), 3 * u(rng), 0.5 + 3 * (u(rng) + 1)));
    dfsc::Parameters p;
    p.band.floor_height = 0.2 * u(rng);
    p.band.hole_detection = trial % 2 == 0;
    p.scan.angle_min = -2.5 + 0.5 * u(rng);
    p.scan.angle_max = 2.0 + 0.5 * u(rng);
    p.scan.angle_increment = 0.01 + 0.005 * u(rng);
    p.scan.range_min = 0.2;
    p.scan.range_max = 4.0;
    const TestCloud cloud = makeCloud(pts);
    std::vector<float> ref;
    dfsc::referenceProject(p, cloud.view(), cam, ref);
    const std::vector<float> fast = project(p, cloud, cam);
    finite += countFinite(fast);
    // A few bins may differ where a point lies within micro-units of a border (see projector.hpp).
    EXPECT_LE(countDisagreements(fast, ref), 2u) << "trial " << trial;
  }
  EXPECT_GT(finite, 1000u);
}

// ---------------------------------------------------------------- layout validation

namespace
{
TestCloud goodCloud()
{
  return makeCloud<float>(Points(6, Vector3d(1.0, 0.0, 0.5)), 3, 2);
}
std::string reasonOf(const TestCloud& c, std::size_t size_delta = 0)
{
  dfsc::CloudView v;
  return dfsc::makeCloudView(c.layout, c.data.data(), c.data.size() - size_delta, "", v);
}
}  // namespace

TEST(CloudValidation, GoodCloudIsAccepted)
{
  EXPECT_EQ(reasonOf(goodCloud()), "");
}

TEST(CloudValidation, MalformedCloudsAreRejectedWithAReason)
{
  auto expectReason = [](const TestCloud& c, const std::string& part, std::size_t size_delta = 0) {
    const std::string reason = reasonOf(c, size_delta);
    EXPECT_NE(reason.find(part), std::string::npos) << "reason: '" << reason << "', expected '" << part << "'";
  };
  TestCloud c = goodCloud();
  c.layout.fields.erase(c.layout.fields.begin() + 2);
  expectReason(c, "field 'z' is missing");

  c = goodCloud();
  c.layout.fields[0].datatype = 5;  // INT32
  expectReason(c, "field 'x' has datatype 5");

  c = goodCloud();
  c.layout.fields[1].datatype = 8;
  expectReason(c, "do not share one datatype");

  c = goodCloud();
  c.layout.is_bigendian = true;
  expectReason(c, "is_bigendian");

  expectReason(goodCloud(), "does not match row_step*height", 4);

  c = goodCloud();
  c.layout.height = 3;  // claims more rows than the data holds
  expectReason(c, "does not match row_step*height");

  c = goodCloud();
  c.layout.row_step = 8;
  expectReason(c, "row_step 8 is smaller than width*point_step");

  c = goodCloud();
  c.layout.fields[2].offset = 14;  // z would end beyond point_step 16
  expectReason(c, "field 'z' (offset 14) does not fit in point_step 16");

  c = goodCloud();
  c.layout.width = 0;
  expectReason(c, "width*height is 0 but data holds");
}

TEST(CloudValidation, MissingIntensityFieldIsANoteNotAnError)
{
  const TestCloud c = goodCloud();
  dfsc::CloudView v;
  std::string note;
  EXPECT_EQ(dfsc::makeCloudView(c.layout, c.data.data(), c.data.size(), "reflectivity", v, &note), "");
  EXPECT_FALSE(v.has_intensity);
  EXPECT_NE(note.find("'reflectivity' is not in the cloud"), std::string::npos);
  EXPECT_EQ(dfsc::makeCloudView(c.layout, c.data.data(), c.data.size(), "intensity", v, &note), "");
  EXPECT_TRUE(v.has_intensity);
  EXPECT_EQ(note, "");
}

// ---------------------------------------------------------------- range noise model

// Points of a beam at angle_min + b * angle_increment (spread over +-30 % of the beam), ranges
// range + N(0, std), in the reference frame at z = 0.5 (inside the band).
Points noisyBeamPoints(const dfsc::Parameters& p, std::size_t beam, int count, double range, double std,
                       std::mt19937& rng)
{
  std::normal_distribution<double> noise(0.0, std);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);
  Points pts;
  for (int i = 0; i < count; ++i)
  {
    const double a = p.scan.angle_min + (static_cast<double>(beam) + jitter(rng)) * p.scan.angle_increment;
    const double r = range + noise(rng);
    pts.emplace_back(r * std::cos(a), r * std::sin(a), 0.5);
  }
  return pts;
}

dfsc::Parameters simCameraNoise()
{
  dfsc::Parameters p;  // the simulated depth camera: std 1 mm + 1 mm per m^2 (2.6 cm at 5 m)
  p.noise.range_noise_std = 0.001;
  p.noise.range_noise_std_per_m2 = 0.001;
  return p;
}

TEST(RangeNoise, NoisyWallReadsItsRangeNotItsClosestPoint)
{
  const dfsc::Parameters p = simCameraNoise();
  const double wall = 5.0, std = p.noise.rangeNoiseStd(wall);
  std::mt19937 rng(7);
  Points pts;
  const std::size_t first = 700, beams = 40;  // 300 points per 0.25-degree beam, as the camera gives
  for (std::size_t b = first; b < first + beams; ++b)
  {
    const Points beam = noisyBeamPoints(p, b, 300, wall, std, rng);
    pts.insert(pts.end(), beam.begin(), beam.end());
  }
  const TestCloud cloud = makeCloud(pts);
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  dfsc::Parameters exact = p;
  exact.noise.range_noise_std = exact.noise.range_noise_std_per_m2 = 0.0;
  const std::vector<float> closest = project(exact, cloud, identity);
  const std::vector<float> clustered = project(p, cloud, identity);
  std::vector<float> reference;
  dfsc::referenceProject(p, cloud.view(), identity, reference);
  EXPECT_EQ(countDisagreements(clustered, reference), 0u);
  double closest_bias = 0.0, clustered_bias = 0.0;
  for (std::size_t b = first; b < first + beams; ++b)
  {
    closest_bias += (closest[b] - wall) / beams;
    clustered_bias += (clustered[b] - wall) / beams;
    // The mean of ~300 points (std / 17), unless the cap (closest + 3 std) bites on a beam whose
    // closest point is unusually short: then a little short, the safe side.
    EXPECT_NEAR(clustered[b], wall, std) << "beam " << b;
  }
  EXPECT_LT(closest_bias, -2.0 * std);          // the closest of 300 points: about -2.9 std
  EXPECT_NEAR(clustered_bias, 0.0, 0.2 * std);  // 5 mm at 5 m
  EXPECT_EQ(countFinite(clustered), beams);
}

TEST(RangeNoise, ObstacleInFrontOfAWallStaysAtItsRange)
{
  const dfsc::Parameters p = simCameraNoise();
  std::mt19937 rng(11);
  const std::size_t beam = 720;
  // A chair leg at 3 m (20 noisy points) in front of a wall at 3.5 m (300 points).
  Points pts = noisyBeamPoints(p, beam, 300, 3.5, p.noise.rangeNoiseStd(3.5), rng);
  const Points leg = noisyBeamPoints(p, beam, 20, 3.0, p.noise.rangeNoiseStd(3.0), rng);
  pts.insert(pts.end(), leg.begin(), leg.end());
  const std::vector<float> ranges = project(p, makeCloud(pts), Eigen::Isometry3d::Identity());
  EXPECT_NEAR(ranges[beam], 3.0, p.noise.rangeNoiseStd(3.0));

  // A single exact point at 2 m, 4 std in front of a dense exact surface: both are one cluster
  // (within 6 std), and the cap keeps the beam within 3 std of the point.
  const double near = 2.0, std = p.noise.rangeNoiseStd(near);
  Points close_pair = noisyBeamPoints(p, beam, 300, near + 4.0 * std, 1e-9, rng);
  close_pair.emplace_back(near * std::cos(0.0), 0.0, 0.5);
  const std::vector<float> capped = project(p, makeCloud(close_pair), Eigen::Isometry3d::Identity());
  EXPECT_NEAR(capped[beam], near + 3.0 * std, 1e-5);
}

TEST(RangeNoise, HolesTooCloseAndNoReturnKeepTheirMeaning)
{
  dfsc::Parameters p = simCameraNoise();
  p.band.hole_detection = true;
  p.scan.range_min = 0.3;
  const Eigen::Isometry3d cam = cameraMount(1.0, 30 * kDeg);
  const Vector3d hole(2.0, 0.3, -0.3);
  const Vector3d too_close(0.2, -0.1, 0.5);  // 0.22 m < range_min
  const TestCloud cloud = makeCloud(toCamera({ hole, too_close }, cam));
  const std::vector<float> ranges = project(p, cloud, cam);
  const Vector3d crossing = cam.translation() + (hole - cam.translation()) / 1.3;
  EXPECT_NEAR(ranges[binOf(p, std::atan2(crossing.y(), crossing.x()))], std::hypot(crossing.x(), crossing.y()), 1e-4);
  EXPECT_EQ(ranges[binOf(p, std::atan2(too_close.y(), too_close.x()))], -std::numeric_limits<float>::infinity());
  EXPECT_EQ(countFinite(ranges), 1u);
  EXPECT_EQ(ranges[0], std::numeric_limits<float>::infinity());
}

TEST(RangeNoise, BadNoiseParametersAreNamed)
{
  for (const auto& [name, value] : { std::pair<std::string, double>{ "range_noise_std", -0.01 },
                                     { "range_noise_std", std::nan("") },
                                     { "range_noise_std_per_m2", -1.0 },
                                     { "range_noise_std_per_m2", std::numeric_limits<double>::infinity() } })
  {
    dfsc::Parameters p;
    (name == "range_noise_std" ? p.noise.range_noise_std : p.noise.range_noise_std_per_m2) = value;
    try
    {
      p.validate();
      ADD_FAILURE() << name << " = " << value << " accepted";
    }
    catch (const dfsc::ParameterError& e)
    {
      EXPECT_EQ(e.parameter(), name) << e.what();
    }
  }
}

// ---------------------------------------------------------------- real data
#include "five_people_test.inc"

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}

// ---------------------------------------------------------------- self filter

namespace
{
// Two links of an arm in front of a camera 0.6 m high pitched 10 degrees down, a wall at 3 m:
// a tall link that hides the wall in its beams (left, 11-22 degrees) and a short one in the band
// with the wall visible above it and a post 3 cm beyond its padded shape visible below it
// (right, around -15 degrees).
struct ArmScene
{
  Scene scene;
  Eigen::Isometry3d cam = cameraMount(0.6, 10 * kDeg);
  Points points;
  laserscan_common::SelfFilter filter;

  ArmScene()
  {
    scene.wall_x = 3.0;
    scene.boxes.push_back({ Vector3d(1.0, 0.2, 0.0), Vector3d(1.2, 0.4, 1.4) });      // tall link
    scene.boxes.push_back({ Vector3d(1.0, -0.4, 0.3), Vector3d(1.2, -0.2, 0.6) });    // short link
    scene.boxes.push_back({ Vector3d(1.25, -0.4, 0.0), Vector3d(1.35, -0.2, 0.2) });  // post behind it
    points = render(scene, cam, 200, 150, 60 * kDeg);
    laserscan_common::RobotShape tall, short_link;
    tall.name = "tall", tall.frame = "tall_link", tall.kind = laserscan_common::ShapeKind::kBox;
    tall.half_extents = Vector3d(0.1, 0.1, 0.7);
    tall.padding = 0.02;
    short_link = tall;
    short_link.name = "short", short_link.frame = "short_link", short_link.half_extents = Vector3d(0.1, 0.1, 0.15);
    filter = laserscan_common::SelfFilter({ tall, short_link }, "self_filter/shapes");
    filter.setFramePoses({ Eigen::Isometry3d(Eigen::Translation3d(1.1, 0.3, 0.7)),
                           Eigen::Isometry3d(Eigen::Translation3d(1.1, -0.3, 0.45)) });
  }
};

float beamAt(const dfsc::Parameters& p, const std::vector<float>& ranges, double angle_deg)
{
  return ranges[binOf(p, angle_deg * kDeg)];
}
}  // namespace

TEST(SelfFilter, ArmPointsAreNeitherObstaclesNorSeeThrough)
{
  const ArmScene arm;
  const TestCloud cloud = makeCloud<float>(arm.points, 200, 150);
  dfsc::Parameters p;
  dfsc::Projector proj(p);
  std::vector<float> plain, filtered, kept;
  proj.project(cloud.view(), arm.cam, plain);
  proj.project(cloud.view(), arm.cam, filtered, nullptr, &kept, &arm.filter);
  // Without the filter, both links are obstacles at about 1 m.
  EXPECT_NEAR(beamAt(p, plain, 16.0), 1.04, 0.03);
  EXPECT_NEAR(beamAt(p, plain, -15.0), 1.04, 0.03);
  // With it: the tall link's beams saw nothing else (NaN: not free either) ...
  for (double a = 13.0; a <= 20.0; a += 1.0)
    EXPECT_TRUE(std::isnan(beamAt(p, filtered, a))) << a << " deg: " << beamAt(p, filtered, a);
  // ... the short link's beams read what lies beyond it: the post below it, 3 cm beyond the
  // padded shape, and the wall above it where the post is not.
  EXPECT_NEAR(beamAt(p, filtered, -12.0), 1.25 / std::cos(12.0 * kDeg), 0.02);
  EXPECT_NEAR(beamAt(p, filtered, -7.0), 3.0 / std::cos(7.0 * kDeg), 0.03);
  // Beams away from the arm are unchanged.
  for (double a = -40.0; a <= 40.0; a += 0.5)
  {
    if (a < -23.0 || (a > -7.0 && a < 8.0) || a > 23.0)
    {
      EXPECT_EQ(beamAt(p, filtered, a), beamAt(p, plain, a)) << a;
    }
  }
  // No kept point lies on the robot.
  ASSERT_FALSE(kept.empty());
  for (std::size_t i = 0; i < kept.size(); i += 3)
    EXPECT_FALSE(arm.filter.contains(kept[i], kept[i + 1], kept[i + 2])) << kept[i] << " " << kept[i + 1];
}

TEST(SelfFilter, TheSameWithIntensitiesAndTheRangeNoiseModel)
{
  const ArmScene arm;
  std::vector<float> intensity(arm.points.size(), 5.0f);
  const TestCloud cloud = makeCloud<float>(arm.points, 200, 150, 0, 0, 0, intensity);
  dfsc::Parameters p;
  p.noise.range_noise_std = 0.001;
  dfsc::Projector proj(p);
  std::vector<float> ranges, intensities;
  proj.project(cloud.view("intensity"), arm.cam, ranges, &intensities, nullptr, &arm.filter);
  EXPECT_TRUE(std::isnan(beamAt(p, ranges, 16.0)));
  EXPECT_EQ(intensities[binOf(p, 16.0 * kDeg)], 0.0f);  // no return there: no intensity
  EXPECT_NEAR(beamAt(p, ranges, -12.0), 1.25 / std::cos(12.0 * kDeg), 0.02);
  EXPECT_EQ(intensities[binOf(p, -12.0 * kDeg)], 5.0f);
}

namespace
{
// Differential test of the projection with the self filter (the kernel's mark, the per-block
// culling, the exact test) against the plain projection and the brute-force per-point test:
// random rooms and random robots (1 to 12 boxes, cylinders and spheres at random poses in
// front of the camera), 300 x 60 clouds (a row is a chunk of 256 points and one of 44, whose
// last 12 are the per-point tail). The kept points with the filter must be exactly the kept
// points without it that contains() finds outside every shape. contains() runs here in this
// file's instructions, the projection in its own (maybe FMA) clone, so a point within a
// rounding error of a padded surface may be decided either way: a mismatch is accepted only
// for points within 0.1 mm of the surface (inside the shapes grown by 0.1 mm, outside the ones
// shrunk by 0.1 mm). along_axes: the shapes turned by right angles about z only, so that most
// blocks of their points take the block test's shortcut (a block in a shape's inner box).
// yaw: room, camera and robot turned together about the vertical, the filter's block frame
// along the camera's rows as the node sets it (imageRowYaw), so that the shortcut runs in a
// turned frame.
void expectKeptPointsAreTheBruteForceSelection(unsigned seed, bool along_axes, double yaw = 0.0)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::size_t removed_total = 0, kept_near_total = 0, border_total = 0;
  for (int trial = 0; trial < 12; ++trial)
  {
    Scene scene;
    scene.wall_x = 2.5 + 2.0 * unit(rng);
    std::vector<laserscan_common::RobotShape> shapes, grown, shrunk;
    std::vector<Eigen::Isometry3d> poses;
    const int count = 1 + static_cast<int>(unit(rng) * 12);
    for (int i = 0; i < count; ++i)
    {
      const Vector3d centre(0.6 + 1.5 * unit(rng), 1.4 * unit(rng) - 0.7, 0.1 + 0.9 * unit(rng));
      const Vector3d half(0.05 + 0.15 * unit(rng), 0.05 + 0.15 * unit(rng), 0.05 + 0.25 * unit(rng));
      scene.boxes.push_back({ centre - half, centre + half });  // something on the shape to see
      laserscan_common::RobotShape s;
      s.name = s.frame = "link" + std::to_string(i);
      s.kind = static_cast<laserscan_common::ShapeKind>(i % 3);
      s.half_extents = s.kind == laserscan_common::ShapeKind::kBox      ? half
                       : s.kind == laserscan_common::ShapeKind::kSphere ? Vector3d::Constant(half.x())
                                                                        : Vector3d(half.x(), half.x(), half.z());
      s.padding = 0.02 * unit(rng) + 0.0002;
      s.origin =
        along_axes
          ? Eigen::Isometry3d(Eigen::AngleAxisd(90 * kDeg * static_cast<int>(4 * unit(rng)), Vector3d::UnitZ()))
          : Eigen::Isometry3d(Eigen::AngleAxisd(3.0 * unit(rng), Vector3d(unit(rng), unit(rng), 1.0).normalized()));
      shapes.push_back(s);
      s.padding += 1e-4, grown.push_back(s);
      s.padding -= 2e-4, shrunk.push_back(s);
      poses.push_back(Eigen::Isometry3d(Eigen::Translation3d(centre)));
    }
    const Eigen::Isometry3d turn(Eigen::AngleAxisd(yaw, Vector3d::UnitZ()));
    for (Eigen::Isometry3d& pose : poses)
      pose = turn * pose;
    const Eigen::Isometry3d scene_cam = cameraMount(0.4 + 0.5 * unit(rng), (5.0 + 25.0 * unit(rng)) * kDeg);
    const Eigen::Isometry3d cam = turn * scene_cam;
    const double row_yaw = laserscan_common::imageRowYaw(cam.linear());
    laserscan_common::SelfFilter filter(shapes, "shapes"), outer(grown, "grown"), inner(shrunk, "shrunk");
    filter.setFramePoses(poses, row_yaw), outer.setFramePoses(poses), inner.setFramePoses(poses);
    const TestCloud cloud = makeCloud<float>(render(scene, scene_cam, 300, 60, 80 * kDeg), 300, 60);
    dfsc::Parameters p;
    dfsc::Projector proj(p);
    std::vector<float> ranges, all, kept;
    proj.project(cloud.view(), cam, ranges, nullptr, &all);
    proj.project(cloud.view(), cam, ranges, nullptr, &kept, &filter);
    std::size_t k = 0;
    for (std::size_t i = 0; i < all.size(); i += 3)
    {
      const float x = all[i], y = all[i + 1], z = all[i + 2];
      const bool in = filter.contains(x, y, z);
      const bool was_kept = k < kept.size() && kept[k] == x && kept[k + 1] == y && kept[k + 2] == z;
      if (was_kept)
        k += 3;
      if (was_kept == !in)
      {
        removed_total += in ? 1 : 0;
        kept_near_total += !in && outer.contains(x, y, z) ? 1 : 0;
        continue;
      }
      ++border_total;
      EXPECT_TRUE(outer.contains(x, y, z) && !inner.contains(x, y, z))
        << "trial " << trial << ": point " << x << " " << y << " " << z << (in ? " inside but kept" : " removed");
    }
    EXPECT_EQ(k, kept.size()) << "trial " << trial << ": kept points that the plain projection does not keep";
  }
  EXPECT_GT(removed_total, 10000u);  // the robots do fill part of the views
  EXPECT_GT(kept_near_total, 0u);    // and points just outside their shapes are kept
  EXPECT_LE(border_total, 3u);       // rounding cases are rare
}
}  // namespace

TEST(SelfFilter, KeptPointsAreTheBruteForceSelectionOnRandomScenesAndRobots)
{
  expectKeptPointsAreTheBruteForceSelection(21, false);
}

TEST(SelfFilter, KeptPointsAreTheBruteForceSelectionWithShapesAlongTheAxes)
{
  expectKeptPointsAreTheBruteForceSelection(22, true);
}

TEST(SelfFilter, KeptPointsAreTheBruteForceSelectionWithTheCameraAtAYaw)
{
  expectKeptPointsAreTheBruteForceSelection(23, false, 35 * kDeg);
  expectKeptPointsAreTheBruteForceSelection(24, true, -50 * kDeg);
}

TEST(SelfFilter, AMovedLinkIsFilteredWhereItIsNow)
{
  ArmScene arm;
  const TestCloud cloud = makeCloud<float>(arm.points, 200, 150);
  dfsc::Parameters p;
  dfsc::Projector proj(p);
  std::vector<float> ranges;
  // The shapes moved away (1 m to the left): the links in view are obstacles again.
  arm.filter.setFramePoses({ Eigen::Isometry3d(Eigen::Translation3d(1.1, 1.3, 0.7)),
                             Eigen::Isometry3d(Eigen::Translation3d(1.1, 0.7, 0.45)) });
  proj.project(cloud.view(), arm.cam, ranges, nullptr, nullptr, &arm.filter);
  EXPECT_NEAR(beamAt(p, ranges, 16.0), 1.04, 0.03);
  EXPECT_NEAR(beamAt(p, ranges, -15.0), 1.04, 0.03);
}
