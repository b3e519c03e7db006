// The 3D method's core: depth images become point_cloud_xyz's points, scans their returns, and
// the OcTree has occupied voxels where a box is, free ones in front of it, and a projection that
// keeps what lies in the height band and drops what is above it.
#include "laserscan_common/parameter_error.hpp"
#include "scan_evaluation_tools/occupancy_map_3d.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

namespace sc = scan_evaluation_tools;

namespace
{
/// A wall of points at x = distance, y and z in [lo, hi] on a grid of `step`, seen from the origin.
octomap::Pointcloud wall(double distance, double y_lo, double y_hi, double z_lo, double z_hi, double step = 0.01)
{
  octomap::Pointcloud points;
  for (double y = y_lo; y <= y_hi; y += step)
  {
    for (double z = z_lo; z <= z_hi; z += step)
    {
      points.push_back(static_cast<float>(distance), static_cast<float>(y), static_cast<float>(z));
    }
  }
  return points;
}
}  // namespace

TEST(OctoMapParameters, EachBadValueNamesItself)
{
  auto expectBad = [](auto change, const std::string& name) {
    sc::OctoMapParameters p;
    change(p);
    try
    {
      p.validate();
      FAIL() << name << " accepted";
    }
    catch (const laserscan_common::ParameterError& e)
    {
      EXPECT_EQ(e.parameter(), name);
    }
  };
  expectBad([](auto& p) { p.resolution = 0.0; }, "resolution");
  expectBad([](auto& p) { p.max_range = -1.0; }, "max_range");
  expectBad([](auto& p) { p.prob_hit = 1.0; }, "prob_hit");
  expectBad([](auto& p) { p.prob_miss = 0.6; }, "prob_hit");
  expectBad([](auto& p) { p.clamp_min = 0.98; }, "clamp_min");
  EXPECT_NO_THROW(sc::OctoMapParameters().validate());
}

TEST(DepthImagePoints, PinholeBackProjectionSkipsMissingDepth)
{
  // 3 x 2 image, 16UC1 in mm: pixel (u=2, v=1) at 2 m, (0, 0) at 1.5 m, the others 0 (no measurement).
  std::vector<std::uint16_t> mm = { 1500, 0, 0, 0, 0, 2000 };
  std::vector<std::uint8_t> data(mm.size() * 2);
  std::memcpy(data.data(), mm.data(), data.size());
  const sc::PinholeCamera camera{ 100.0, 200.0, 1.0, 0.5 };
  octomap::Pointcloud points;
  sc::depthImagePoints(data.data(), data.size(), 3, 2, 6, "16UC1", false, camera, points);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_NEAR(points[0].x(), (0 - 1.0) * 1.5 / 100.0, 1e-6);
  EXPECT_NEAR(points[0].y(), (0 - 0.5) * 1.5 / 200.0, 1e-6);
  EXPECT_NEAR(points[0].z(), 1.5, 1e-6);
  EXPECT_NEAR(points[1].x(), (2 - 1.0) * 2.0 / 100.0, 1e-6);
  EXPECT_NEAR(points[1].y(), (1 - 0.5) * 2.0 / 200.0, 1e-6);
  EXPECT_NEAR(points[1].z(), 2.0, 1e-6);

  // 32FC1 in metres, NaN and +Inf are no measurement
  std::vector<float> m = { 1.0f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity() };
  std::vector<std::uint8_t> fdata(m.size() * 4);
  std::memcpy(fdata.data(), m.data(), fdata.size());
  points.clear();
  sc::depthImagePoints(fdata.data(), fdata.size(), 3, 1, 12, "32FC1", false, camera, points);
  ASSERT_EQ(points.size(), 1u);
  EXPECT_NEAR(points[0].z(), 1.0, 1e-6);

  EXPECT_THROW(sc::depthImagePoints(data.data(), data.size(), 3, 2, 6, "rgb8", false, camera, points),
               std::invalid_argument);
  EXPECT_THROW(sc::depthImagePoints(data.data(), data.size() - 1, 3, 2, 6, "16UC1", false, camera, points),
               std::invalid_argument);
}

TEST(ScanPoints, OnlyMeasuredRangesBecomePoints)
{
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<float> ranges = { 1.0f, inf, -inf, std::numeric_limits<float>::quiet_NaN(), 0.01f, 30.0f, 2.0f };
  octomap::Pointcloud points;
  sc::scanPoints(ranges, 0.0, M_PI / 2, 0.1, 20.0, points);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_NEAR(points[0].x(), 1.0, 1e-6);
  EXPECT_NEAR(points[0].y(), 0.0, 1e-6);
  EXPECT_NEAR(points[1].x(), 2.0 * std::cos(6 * M_PI / 2), 1e-5);  // beam 6 at 3 pi
  EXPECT_NEAR(points[1].y(), 0.0, 1e-5);
}

TEST(OccupancyMap3D, BoxIsOccupiedWithinOneVoxelAndTheSpaceInFrontFree)
{
  sc::OctoMapParameters p;
  sc::OccupancyMap3D map(p);
  const auto face = wall(2.0, -0.3, 0.3, 0.2, 0.6);
  for (int i = 0; i < 3; ++i)
  {
    map.insert(face, octomap::point3d(0.0f, 0.0f, 0.4f));
    map.update();
  }
  const auto& tree = map.tree();
  const auto* hit = tree.search(2.0, 0.0, 0.4);
  ASSERT_NE(hit, nullptr);
  EXPECT_TRUE(tree.isNodeOccupied(hit));
  const auto* free = tree.search(1.0, 0.0, 0.4);
  ASSERT_NE(free, nullptr);
  EXPECT_FALSE(tree.isNodeOccupied(free));
  EXPECT_EQ(tree.search(2.5, 0.0, 0.4), nullptr);  // behind the face: never seen
  // every occupied leaf lies on the face, within one voxel
  std::size_t occupied = 0;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it)
  {
    if (tree.isNodeOccupied(*it))
    {
      ++occupied;
      EXPECT_NEAR(it.getX(), 2.0, p.resolution + 1e-6);
      EXPECT_LE(std::abs(it.getY()), 0.3 + p.resolution);
    }
  }
  EXPECT_GT(occupied, 100u);
  EXPECT_EQ(map.cloudsInserted(), 3u);
  EXPECT_EQ(map.pointsInserted(), 3 * face.size());
}

TEST(OccupancyMap3D, FartherThanMaxRangeOnlyClears)
{
  sc::OctoMapParameters p;
  p.max_range = 1.0;
  sc::OccupancyMap3D map(p);
  map.insert(wall(2.0, -0.2, 0.2, 0.2, 0.6), octomap::point3d(0.0f, 0.0f, 0.4f));
  map.update();
  const auto& tree = map.tree();
  EXPECT_EQ(tree.search(2.0, 0.0, 0.4), nullptr);
  const auto* near = tree.search(0.5, 0.0, 0.4);
  ASSERT_NE(near, nullptr);
  EXPECT_FALSE(tree.isNodeOccupied(near));
}

TEST(OccupancyMap3D, ProjectionKeepsTheBandAndDropsWhatIsAbove)
{
  sc::OccupancyMap3D map(sc::OctoMapParameters{});
  // a table top at 0.7 m (in the band 0.05 - 1.0) 2 m ahead, a shelf board at 1.5 m 1 m to the left
  octomap::Pointcloud points = wall(2.0, -0.3, 0.3, 0.7, 0.72);
  const auto shelf = wall(2.0, 0.7, 1.3, 1.5, 1.52);
  for (const auto& q : shelf)
  {
    points.push_back(q);
  }
  map.insert(points, octomap::point3d(0.0f, 0.0f, 0.9f));
  map.update();
  const auto projected = map.project(0.05, 1.0);
  EXPECT_EQ(projected.at(2.02, 0.0), 100);
  EXPECT_NE(projected.at(2.02, 1.0), 100);  // the shelf is above the band: dropped
  EXPECT_EQ(projected.at(1.0, 0.0), 0);
  EXPECT_EQ(projected.at(-5.0, 0.0), -1);
  EXPECT_GT(projected.occupied(), 10u);
  // the shelf is in a band that reaches it
  EXPECT_EQ(map.project(1.4, 1.6).at(2.02, 1.0), 100);
  EXPECT_NEAR(projected.resolution, 0.05, 1e-12);
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
