// The global planner against analytic cases: paths round obstacles, through passages the robot's
// circle fits, cells forgotten after their memory, cleared by the rays of the sensor that marked
// them, the carrot along the path.
#include <gtest/gtest.h>

#include <cmath>

#include "reactive_navigator/global_planner.hpp"

namespace reactive_navigator
{
namespace
{

// Marks points every 2 cm along the segment a-b.
void markSegment(GlobalPlanner& planner, Eigen::Vector2d a, Eigen::Vector2d b, double time = 0.0)
{
  const int n = static_cast<int>(std::ceil((b - a).norm() / 0.02));
  for (int i = 0; i <= n; ++i)
  {
    const Eigen::Vector2d p = a + (b - a) * (static_cast<double>(i) / std::max(n, 1));
    planner.mark(p.x(), p.y(), time);
  }
}

void markBox(GlobalPlanner& planner, double x0, double x1, double y0, double y1, double time = 0.0)
{
  for (double y = y0; y <= y1 + 1e-9; y += 0.02)
    markSegment(planner, { x0, y }, { x1, y }, time);
}

double length(const std::vector<Eigen::Vector2d>& path)
{
  double sum = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i)
    sum += (path[i] - path[i - 1]).norm();
  return sum;
}

// The smallest distance of the path's points to the box [x0, x1] x [y0, y1].
double clearanceToBox(const std::vector<Eigen::Vector2d>& path, double x0, double x1, double y0, double y1)
{
  double d = INFINITY;
  for (const auto& p : path)
    d = std::min(d, std::hypot(std::max({ x0 - p.x(), 0.0, p.x() - x1 }), std::max({ y0 - p.y(), 0.0, p.y() - y1 })));
  return d;
}

TEST(GlobalPlanner, FreeFloorGivesTheStraightLine)
{
  GlobalPlanner planner{ PlannerSettings{} };
  ASSERT_TRUE(planner.plan(1.0, { 0.0, 0.0 }, { 5.0, 2.0 }));
  EXPECT_EQ(planner.path().front(), Eigen::Vector2d(0.0, 0.0));
  EXPECT_EQ(planner.path().back(), Eigen::Vector2d(5.0, 2.0));
  // 8-connected cells: within the octile bound of the straight line.
  EXPECT_LT(length(planner.path()), std::hypot(5.0, 2.0) * 1.09);
}

TEST(GlobalPlanner, GoesRoundATableTopItWasFed)
{
  // The unified scan's view of a 1.2 m x 1.4 m table across the way: its top, projected.
  GlobalPlanner planner{ PlannerSettings{} };
  markBox(planner, 2.4, 3.6, -0.7, 0.7);
  ASSERT_TRUE(planner.plan(1.0, { 0.0, 0.0 }, { 6.0, 0.0 }));
  // Nowhere closer to the top than the robot's circle (0.44 m) and the inflation, less a cell.
  EXPECT_GT(clearanceToBox(planner.path(), 2.4, 3.6, -0.7, 0.7), 0.44 + 0.05 - 0.1);
  EXPECT_LT(length(planner.path()), 6.0 + 2.5);  // round it, not far off
}

TEST(GlobalPlanner, TakesThePassageBetweenTheLegsItWasFed)
{
  // The same table seen by a lidar alone: four 4 cm legs, 1.24 m apart across the way. The gap
  // (1.20 m between the legs) is wider than the robot's 0.88 m circle + 2 x 0.05 m: the path goes
  // through it, which is what the lidar-only mode misses.
  GlobalPlanner planner{ PlannerSettings{} };
  for (double x : { 2.46, 3.54 })
    for (double y : { -0.62, 0.62 })
      markBox(planner, x - 0.02, x + 0.02, y - 0.02, y + 0.02);
  ASSERT_TRUE(planner.plan(1.0, { 0.0, 0.0 }, { 6.0, 0.0 }));
  for (const auto& p : planner.path())
    if (p.x() > 2.4 && p.x() < 3.6)
    {
      EXPECT_LT(std::abs(p.y()), 0.2) << "left the passage at x = " << p.x();
    }
}

TEST(GlobalPlanner, LeavesAUTrapThroughItsOpening)
{
  // A U open towards the robot, the goal behind its bottom: the path leaves the U and goes round.
  GlobalPlanner planner{ PlannerSettings{} };
  markSegment(planner, { 1.0, -1.5 }, { 3.0, -1.5 });
  markSegment(planner, { 3.0, -1.5 }, { 3.0, 1.5 });
  markSegment(planner, { 3.0, 1.5 }, { 1.0, 1.5 });
  ASSERT_TRUE(planner.plan(1.0, { 2.0, 0.0 }, { 5.0, 0.0 }));
  bool outside = false;
  for (const auto& p : planner.path())
  {
    outside = outside || std::abs(p.y()) > 1.5 + 0.44;
    if (p.x() > 0.9 && p.x() < 3.1)
    {
      EXPECT_GT(std::abs(std::abs(p.y()) - 1.5), 0.39) << "crossed an arm of the U at x = " << p.x();
    }
  }
  EXPECT_TRUE(outside);
}

TEST(GlobalPlanner, ObstaclesAreForgottenAfterTheirMemory)
{
  PlannerSettings settings;
  settings.memory = 5.0;
  GlobalPlanner planner(settings);
  markSegment(planner, { 2.0, -4.0 }, { 2.0, 1.0 }, 10.0);  // a wall across the way, open above y = 1
  ASSERT_TRUE(planner.plan(14.0, { 0.0, 0.05 }, { 4.0, 0.05 }));
  EXPECT_GT(planner.occupiedCells(), 0u);
  EXPECT_GT(length(planner.path()), 4.5);  // round its end
  ASSERT_TRUE(planner.plan(15.5, { 0.0, 0.05 }, { 4.0, 0.05 }));
  EXPECT_EQ(planner.occupiedCells(), 0u);
  EXPECT_NEAR(length(planner.path()), 4.0, 1e-6);
}

TEST(GlobalPlanner, AWallAcrossTheWholeWindowIsCrossedNotAFailure)
{
  // A high but finite cost: a person's remembered trail across the room must not leave the
  // navigator without a path (the reactive navigator decides what can be driven).
  GlobalPlanner planner{ PlannerSettings{} };
  markSegment(planner, { 2.0, -10.0 }, { 2.0, 10.0 });
  ASSERT_TRUE(planner.plan(1.0, { 0.0, 0.05 }, { 4.0, 0.05 }));
  EXPECT_NEAR(length(planner.path()), 4.0, 1e-6);  // straight across, where it is thinnest
}

// Points every 2 cm along the segment a-b.
std::vector<Eigen::Vector2d> pointsAlong(Eigen::Vector2d a, Eigen::Vector2d b)
{
  std::vector<Eigen::Vector2d> points;
  const int n = static_cast<int>(std::ceil((b - a).norm() / 0.02));
  for (int i = 0; i <= n; ++i)
    points.push_back(a + (b - a) * (static_cast<double>(i) / std::max(n, 1)));
  return points;
}

TEST(GlobalPlanner, ASensorsRaysClearWhatItMarkedBeforeAndItsPointsMarkAgain)
{
  GlobalPlanner planner{ PlannerSettings{} };
  const Eigen::Vector2d origin(0.0, 0.0);
  // A person 2 m ahead (4 cells across), a wall at 4 m behind them (20 cells); points off the
  // cells' edges.
  const auto person = pointsAlong({ 2.05, -0.15 }, { 2.05, 0.15 });
  const auto wall = pointsAlong({ 4.05, -0.95 }, { 4.05, 0.95 });
  std::vector<Eigen::Vector2d> seen = person;
  seen.insert(seen.end(), wall.begin(), wall.end());
  planner.observe(0, origin, seen, {}, 0.0);
  const std::size_t with_person = planner.occupiedCells();
  EXPECT_EQ(with_person, 4u + 20u);
  // The person walked on: the beams reach the wall through where they stood.
  planner.observe(0, origin, wall, {}, 0.1);
  EXPECT_EQ(planner.occupiedCells(), 20u);
  // A beam with no return clears its whole length: the wall's cell on it goes, the others stay.
  planner.observe(0, origin, {}, { { 5.05, 0.05 } }, 0.2);
  EXPECT_EQ(planner.occupiedCells(), 19u);
}

TEST(GlobalPlanner, ASourceClearsOnlyTheCellsItMarked)
{
  GlobalPlanner planner{ PlannerSettings{} };
  // Source 1 (a camera) marked a table top's edge 2 m ahead; source 0 (a lidar) sees under it.
  planner.observe(1, { 0.0, 0.0 }, pointsAlong({ 2.05, -0.45 }, { 2.05, 0.45 }), {}, 0.0);
  ASSERT_EQ(planner.occupiedCells(), 10u);
  planner.observe(0, { 0.0, 0.0 }, pointsAlong({ 4.05, -0.45 }, { 4.05, 0.45 }), {}, 0.1);
  EXPECT_EQ(planner.occupiedCells(), 20u);  // the top's cells stay
  // The camera's own rays through them (to a wall twice as wide, twice as far) clear them.
  planner.observe(1, { 0.0, 0.0 }, pointsAlong({ 4.05, -0.95 }, { 4.05, 0.95 }), {}, 0.2);
  EXPECT_EQ(planner.occupiedCells(), 20u);  // the wall's cells only
  EXPECT_EQ(planner.plan(0.3, { 0.05, 0.05 }, { 3.05, 0.05 }), true);
  EXPECT_NEAR(length(planner.path()), 3.0, 1e-9);  // straight through where the top was
}

TEST(GlobalPlanner, RaysClearUpToTheClearingRangeOnly)
{
  PlannerSettings settings;
  settings.clearing_range = 3.0;
  GlobalPlanner planner{ settings };
  planner.mark(2.55, 0.05, 0.0);
  planner.mark(3.55, 0.05, 0.0);
  planner.observe(0, { 0.05, 0.05 }, { { 8.05, 0.05 } }, {}, 0.1);  // a point 8 m away
  EXPECT_EQ(planner.occupiedCells(), 2u);                           // 3.55 beyond the range stays; 8.05 marked
  settings.clearing_range = 0.0;                                    // no clearing at all
  GlobalPlanner expiring{ settings };
  expiring.mark(2.55, 0.05, 0.0);
  expiring.observe(0, { 0.05, 0.05 }, {}, { { 4.05, 0.05 } }, 0.1);
  EXPECT_EQ(expiring.occupiedCells(), 1u);
}

TEST(GlobalPlanner, TheCarrotLiesAlongThePathAhead)
{
  GlobalPlanner planner{ PlannerSettings{} };
  ASSERT_TRUE(planner.plan(1.0, { 0.0, 0.05 }, { 6.0, 0.05 }));
  double remaining = 0.0;
  const Eigen::Vector2d carrot = planner.carrot({ 1.0, 0.05 }, 1.5, remaining);
  EXPECT_NEAR(carrot.x(), 2.5, 0.11);
  EXPECT_NEAR(carrot.y(), 0.05, 1e-9);
  EXPECT_NEAR(remaining, 5.0, 0.11);
  // Beyond the end: the goal itself.
  const Eigen::Vector2d end = planner.carrot({ 5.5, 0.05 }, 1.5, remaining);
  EXPECT_EQ(end, Eigen::Vector2d(6.0, 0.05));
}

}  // namespace
}  // namespace reactive_navigator

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
