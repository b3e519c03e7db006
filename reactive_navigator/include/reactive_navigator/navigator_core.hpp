// The navigation core: MRPT's reactive navigator (TP-Space, CPTG_Holo_Blend for an
// omnidirectional base) run one control step at a time on data handed in by the caller, so that
// the same code runs under ROS and in tests. ROS-free; times in seconds of the caller's clock
// (simulated time in simulation), so that a run does not depend on the machine's load.
#pragma once

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "reactive_navigator/parameters.hpp"

namespace reactive_navigator
{

/// A planar pose in the odometry frame (m, rad).
struct Pose2
{
  double x = 0.0;
  double y = 0.0;
  double yaw = 0.0;
};

/// A velocity command in the robot frame (m/s, rad/s), as geometry_msgs/Twist carries it.
struct Command
{
  double vx = 0.0;
  double vy = 0.0;
  double wz = 0.0;
};

enum class NavigationState
{
  Idle,        ///< no goal yet
  Navigating,  ///< driving to the goal
  Reached,     ///< within goal_tolerance of the goal
  Blocked,     ///< no progress for blocked_timeout, or the goal itself is inside an obstacle
};
const char* stateName(NavigationState state);

/// Obstacle points in the robot frame (m). In 2d mode z is ignored (the caller keeps the height band).
using ObstaclePoints = std::vector<Eigen::Vector3f>;

/// Which of a step's obstacle points one sensor saw, and from where: the planner's grid clears
/// along its rays before marking its points (global_planner.hpp). Robot frame (m).
struct Observation
{
  std::size_t source = 0;             ///< the sensor (0 - 63): it clears only the cells it marked
  Eigen::Vector3f origin{ 0, 0, 0 };  ///< where its rays start
  std::size_t begin = 0;              ///< its points: obstacles[begin, end)
  std::size_t end = 0;
  ObstaclePoints free_ends;  ///< ends of its rays that saw nothing (a scan's +Inf beams)
};

class NavigatorCore
{
public:
  /// Throws ParameterError (validate()) for bad parameters.
  explicit NavigatorCore(const NavigatorParameters& parameters);
  ~NavigatorCore();
  NavigatorCore(const NavigatorCore&) = delete;
  NavigatorCore& operator=(const NavigatorCore&) = delete;

  /// A new goal (odometry frame); replaces any former one.
  void setGoal(double x, double y);
  /// One control step at `time` (s, > 0 and increasing; MRPT's clock is set to it, so that the
  /// same inputs give the same commands whatever the load): the robot's pose then and the
  /// obstacles seen.
  /// Points inside the robot's own shape (grown by self_padding) are dropped first: they are its
  /// body (a corner lidar sees it; REP 117's -Inf beams where the body hides the view become
  /// points at range_min, inside it), and MRPT would take them as a collision and never move.
  /// With obstacle_memory > 0, the points of earlier steps (kept in the odometry frame, one per
  /// 5 cm cell, the newest; forgotten obstacle_memory s after their cell was last seen or when
  /// farther than lookahead) are handed to MRPT beside the step's own, seen from the pose now.
  /// `observations` split `obstacles` by sensor, in order (their ranges follow one another from 0
  /// to obstacles.size(); std::invalid_argument otherwise); without them the points mark the
  /// planner's grid and clear nothing.
  /// Returns the command to drive until the next step (zero unless navigating).
  Command step(double time, const Pose2& pose, const ObstaclePoints& obstacles,
               const std::vector<Observation>& observations = {});

  NavigationState state() const;
  /// Obstacle points of the last step: handed to MRPT, and dropped as the robot's own body.
  std::size_t lastObstaclePoints() const;
  std::size_t lastSelfPoints() const;
  /// Of lastObstaclePoints(), those remembered from earlier steps (obstacle_memory).
  std::size_t lastRememberedPoints() const;
  /// Global planner (parameters.planner): the path's length left to the goal at the last step (m;
  /// NaN without a path), the grid's obstacle cells, and the path (odometry frame; empty without one).
  double remainingPath() const;
  std::size_t plannerCells() const;
  const std::vector<Eigen::Vector2d>& plannedPath() const;
  const NavigatorParameters& parameters() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace reactive_navigator
