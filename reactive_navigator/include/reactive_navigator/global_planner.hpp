// The navigator's global layer: an occupancy grid built from the navigator's own obstacle points
// (whatever its mode is fed: the scan's beams, or the 3D points within the robot's height) and
// A* on it, so that the reactive navigator is given a target along a path round what it has seen,
// not the goal behind it. A reactive navigator alone keeps no plan: remembered obstacles between it
// and the goal (a table's top and legs) make a local minimum that it leaves by chance or never.
// ROS-free; positions in the odometry frame (m), times in the caller's clock (s).
#pragma once

#include <cstdint>
#include <unordered_map>
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
};

class GlobalPlanner
{
public:
  explicit GlobalPlanner(const PlannerSettings& settings);

  /// An obstacle point (odometry frame) seen at `time`.
  void mark(double x, double y, double time);
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

  PlannerSettings settings_;
  std::unordered_map<std::int64_t, double> cells_;  // obstacle cells: when last seen
  std::int64_t last_key_ = -1;                      // the last cell marked (runs of points share cells)
  double last_time_ = -1.0;
  std::vector<Eigen::Vector2d> path_;
};

}  // namespace reactive_navigator
