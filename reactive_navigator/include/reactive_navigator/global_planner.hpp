// The navigator's global layer: an occupancy grid built from the navigator's own obstacle points
// (whatever its mode is fed: the scan's beams, or the 3D points within the robot's height) and
// A* on it, so that the reactive navigator is given a target along a path round what it has seen,
// not the goal behind it. A reactive navigator alone keeps no plan: remembered obstacles between it
// and the goal (a table's top and legs) make a local minimum that it leaves by chance or never.
// A sensor's rays clear the cells they cross before its points mark theirs (costmap_2d's obstacle
// layer), so that a person who walked on leaves no trail once the sensors see the floor empty;
// each sensor clears only the cells it marked itself: a lidar beam passing under a table top the
// cameras marked leaves the top (a 2D grid cannot tell the heights apart, the sources can).
// ROS-free; positions in the odometry frame (m), times in the caller's clock (s).
#pragma once

#include <cstdint>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include <Eigen/Core>

namespace reactive_navigator
{

struct PlannerSettings
{
  double resolution = 0.10;    ///< m, grid cell
  double memory = 20.0;        ///< s a cell stays an obstacle after its last point
  double robot_radius = 0.44;  ///< m: cells closer than this + inflation to an obstacle are as bad as one
  double inflation = 0.05;     ///< m beyond robot_radius
  double clearance = 0.50;     ///< m beyond that over which a cell's extra cost falls to zero
  double margin = 3.0;         ///< m around the robot and the goal that the search covers
  /// Cost of crossing one cell as bad as an obstacle, in cells of free floor: high but finite, so
  /// that a path always exists (a person's trail of remembered cells across the whole room is
  /// crossed where it is thinnest) and the reactive navigator decides what can really be driven.
  double obstacle_cost = 100.0;
  /// m from the sensor that its rays clear (a ray to a farther point clears this far, a beam with
  /// no return too); 0 = no clearing, cells only expire.
  double clearing_range = 5.0;
};

/// Sources a grid tells apart (the bits of a cell's mask); a larger source number shares the last.
constexpr std::size_t kPlannerSources = 64;

class GlobalPlanner
{
public:
  explicit GlobalPlanner(const PlannerSettings& settings);

  /// An obstacle point (odometry frame) seen at `time` by sensor `source`.
  void mark(double x, double y, double time, std::size_t source = 0);
  /// One sensor's observation (odometry frame), as costmap_2d's obstacle layer takes it: the ray
  /// from `origin` to each point and to each of `free_ends` (beams that saw nothing) clears the
  /// cells this source marked along it, up to clearing_range, the point's own cell excepted; then
  /// the points mark theirs. Rays ending in one cell cross the same cells: each is traced once.
  void observe(std::size_t source, const Eigen::Vector2d& origin, const std::vector<Eigen::Vector2d>& points,
               const std::vector<Eigen::Vector2d>& free_ends, double time);
  /// Plans from `start` to `goal` on the cells seen within `memory` s of `time` (older ones are
  /// forgotten); false when the search found nothing (only if the goal is outside the grid's reach).
  bool plan(double time, const Eigen::Vector2d& start, const Eigen::Vector2d& goal);
  /// The path of the last plan, start to goal (cell centres; the first the start, the last the goal).
  const std::vector<Eigen::Vector2d>& path() const { return path_; }
  /// The point `distance` m along the path beyond the path's point closest to `position`, and the
  /// path's length left from there to the goal.
  Eigen::Vector2d carrot(const Eigen::Vector2d& position, double distance, double& remaining) const;
  std::size_t occupiedCells() const { return cells_.size(); }

private:
  std::int64_t key(long ix, long iy) const;
  long index(double v) const;
  // Removes `source`'s mark from the cells from (x0, y0) to (x1, y1) (indices), the last one too
  // when `last`; a cell no source marks any more is free.
  void clearRay(long x0, long y0, long x1, long y1, bool last, std::uint64_t source_bit);

  struct Cell
  {
    double time;            // when last marked
    std::uint64_t sources;  // bit per source that marked it and has not cleared it since
  };
  PlannerSettings settings_;
  std::unordered_map<std::int64_t, Cell> cells_;  // obstacle cells
  std::int64_t last_key_ = -1;                    // the last cell marked (runs of points share cells)
  double last_time_ = -1.0;
  std::uint64_t last_bit_ = 0;
  std::unordered_set<std::int64_t> traced_;  // observe(): end cells whose ray was traced
  std::vector<Eigen::Vector2d> path_;
};

}  // namespace reactive_navigator
