// The navigator's parameters: the robot's shape, its limits and the navigation's tuning (core), and
// what only the ROS node needs (topics, frames, rate, lockstep). Defaults are written here, limits
// in each struct's field table (laserscan_common/parameter_table.hpp: the ROS reader, the pybind11
// module, check_config's schema and the README table walk it); every validate() checks those
// (laserscan_common::checkLimits), then the rules a table line cannot say, throwing
// laserscan_common::ParameterError naming the parameter and the reason. The structured parameters
// (footprint, shape_3d, height_band) are read and checked outside the tables.
#pragma once

#include <string>
#include <type_traits>
#include <vector>

#include <Eigen/Core>

#include "laserscan_common/parameter_error.hpp"
#include "laserscan_common/parameter_table.hpp"

namespace reactive_navigator
{

using laserscan_common::ParameterError;
using laserscan_common::ParamInfo;

/// A polygon in the robot frame (m), vertices in order.
using Polygon = std::vector<Eigen::Vector2d>;

/// One prism of the robot's 3D shape: `height` m tall, stacked on the one below it (the first
/// starts at z = 0 of the robot frame, the floor), with `polygon` as its cross-section.
struct ShapeLevel
{
  double height = 0.0;
  Polygon polygon;
};

/// The paper's robot: a 0.74 m x 0.48 m base, centred on base_link.
Polygon paperRobotFootprint();
/// The paper's robot by height: the base (0 - 0.60 m) and the stowed arm above it (0.60 - 0.90 m,
/// the simulator's arm: scripts/laserscan_toolbox/simulation/robot.py).
std::vector<ShapeLevel> paperRobotShape3d();

/// What the navigation core needs (ROS-free).
struct NavigatorParameters
{
  /// "2d": MRPT's CReactiveNavigationSystem (footprint, obstacle points projected to the floor);
  /// "3d": CReactiveNavigationSystem3D (the shape by height, 3D obstacle points).
  std::string mode = "2d";
  Polygon footprint = paperRobotFootprint();               ///< m, robot frame (2d)
  std::vector<ShapeLevel> shape_3d = paperRobotShape3d();  ///< m, robot frame (3d)
  double max_linear_speed = 0.5;                           ///< m/s
  double max_angular_speed = 0.8;                          ///< rad/s
  double linear_acceleration = 1.0;                        ///< m/s^2 (the PTG's ramp time is speed / this)
  double goal_tolerance = 0.25;                            ///< m, the goal is reached closer than this
  double lookahead = 4.0;                                  ///< m, obstacles farther away are ignored
  int path_count = 61;                                     ///< candidate directions of the PTG
  double blocked_timeout = 15.0;                           ///< s without approaching the goal -> blocked
  double self_padding = 0.05;  ///< m: points within the shape grown by this are the robot's own body
  /// s: obstacle points are remembered (in the odometry frame, one per 5 cm cell) this long after
  /// they were last seen, as a costmap's obstacle layer keeps what left the sensors' view (a table
  /// top the cameras no longer see when the robot is under its edge); 0 = only the step's points.
  double obstacle_memory = 2.0;

  // ---- Global planner (global_planner.hpp): an occupancy grid of the navigator's own obstacle
  // points (the same points MRPT is given: the scan's beams, or in 3d the points up to the robot's
  // top) and A* on it, replanned at planner_rate; MRPT is given the point carrot_distance ahead
  // along the path instead of the goal, so that remembered obstacles between the robot and the
  // goal (a table's top and legs) are gone round rather than a local minimum.
  bool planner = true;               ///< false: MRPT is given the goal itself (purely reactive)
  double planner_rate = 2.0;         ///< Hz of the caller's clock: replans per second
  double planner_resolution = 0.10;  ///< m, grid cell
  double planner_memory = 20.0;      ///< s: a cell is an obstacle this long after its last point
  /// m: each sensor's rays clear the cells it marked up to this far (costmap_2d's raytrace_range);
  /// 0 = cells only expire
  double planner_clearing_range = 5.0;
  double planner_inflation = 0.05;  ///< m beyond the robot's circle: as costly as an obstacle
  double planner_clearance = 0.20;  ///< m beyond that over which the extra cost falls to none
  double planner_margin = 3.0;      ///< m around the robot and the goal that the search covers
  /// m along the path: MRPT's target (the goal once less is left). Not much less than lookahead:
  /// MRPT's holonomic method shuns a target close in front of an obstacle (at 1.5 m before a
  /// 1.3 m gap its commands reversed every half second and it ended blocked; at 3 m it passes).
  double carrot_distance = 3.0;

  void validate() const;
  bool volumetric() const { return mode == "3d"; }
};

/// The table of NavigatorParameters (footprint and shape_3d apart).
template <class P, class V, std::enable_if_t<std::is_same_v<std::decay_t<P>, NavigatorParameters>, int> = 0>
void visitFields(P& p, V&& visit)
{
  visit(p.mode, ParamInfo("mode", "",
                          "`2d`: CReactiveNavigationSystem (footprint, points projected to the floor); `3d`: "
                          "CReactiveNavigationSystem3D (shape_3d, 3D points)"));
  visit(p.max_linear_speed, ParamInfo("max_linear_speed", "m/s", "speed limit").above(0.0).finiteOnly());
  visit(p.max_angular_speed, ParamInfo("max_angular_speed", "rad/s", "turn rate limit").above(0.0).finiteOnly());
  visit(p.linear_acceleration, ParamInfo("linear_acceleration", "m/s^2",
                                         "the PTG reaches its speed in `max_linear_speed / linear_acceleration` s")
                                 .above(0.0)
                                 .finiteOnly());
  visit(p.goal_tolerance, ParamInfo("goal_tolerance", "m", "reached closer than this").above(0.0).finiteOnly());
  visit(p.lookahead, ParamInfo("lookahead", "m", "obstacles farther away are not considered (MRPT's ref_distance)")
                       .above(0.0)
                       .finiteOnly());
  visit(p.path_count,
        ParamInfo("path_count", "", "candidate directions of the PTG (3 - 1001)").atLeast(3).atMost(1001));
  visit(p.blocked_timeout,
        ParamInfo("blocked_timeout", "s",
                  "no 0.1 m of progress towards the goal (along the planner's path; a new path 1 m longer than "
                  "the last, a detour, counts from where the robot is) for this long: `blocked`")
          .above(0.0)
          .finiteOnly());
  visit(p.self_padding, ParamInfo("self_padding", "m", "points within this of the robot's shape are its own body")
                          .atLeast(0.0)
                          .finiteOnly());
  visit(p.obstacle_memory,
        ParamInfo("obstacle_memory", "s",
                  "obstacle points kept this long after last seen (odometry frame, one per 5 cm cell, within "
                  "`lookahead`); 0 = only the step's points")
          .atLeast(0.0)
          .finiteOnly());
  visit(p.planner, ParamInfo("planner", "",
                             "the global planner gives MRPT a carrot along its path (false: MRPT is given the "
                             "goal, purely reactive)"));
  visit(p.planner_rate, ParamInfo("planner_rate", "Hz", "replans per second of ROS time").above(0.0).finiteOnly());
  visit(p.planner_resolution,
        ParamInfo("planner_resolution", "m", "the planner's grid cell (at most 1 m)").above(0.0).atMost(1.0));
  visit(p.planner_memory,
        ParamInfo("planner_memory", "s", "a cell is an obstacle this long after its last point (or until cleared)")
          .above(0.0)
          .finiteOnly());
  visit(p.planner_clearing_range,
        ParamInfo("planner_clearing_range", "m",
                  "each sensor's rays (to its points, and its beams with no return) clear the cells it marked "
                  "up to this far from it, before its points mark theirs; 0 = cells only expire")
          .atLeast(0.0)
          .finiteOnly());
  visit(p.planner_inflation, ParamInfo("planner_inflation", "m",
                                       "beyond the robot's circle: cells this close to an obstacle cost as much as one")
                               .atLeast(0.0)
                               .finiteOnly());
  visit(p.planner_clearance, ParamInfo("planner_clearance", "m", "beyond that, the extra cost falls to none over this")
                               .atLeast(0.0)
                               .finiteOnly());
  visit(p.planner_margin,
        ParamInfo("planner_margin", "m", "the search covers the rectangle around the robot and the goal grown by this")
          .above(0.0)
          .finiteOnly());
  visit(p.carrot_distance,
        ParamInfo("carrot_distance", "m",
                  "MRPT's target: this far along the path (the goal once less is left); not much below "
                  "`lookahead` (MRPT shuns a target close in front of an obstacle)")
          .above(0.0)
          .finiteOnly());
}

/// What only the ROS node needs.
struct NodeParameters
{
  std::vector<std::string> scan_topics;   ///< LaserScan obstacle sources
  std::vector<std::string> cloud_topics;  ///< PointCloud2 obstacle sources (x, y, z float32 or float64)
  std::string odom_frame = "odom";
  std::string robot_frame = "base_link";
  double height_band_min = 0.05;  ///< m, robot frame: cloud points below are dropped (the floor)
  double height_band_max = 0.90;  ///< m, robot frame: cloud points above are dropped (the robot passes under)
  double control_rate = 10.0;     ///< Hz, on ROS time
  bool lockstep = false;          ///< wait for every source's data of a step (simulation only)
  double lockstep_timeout = 5.0;  ///< wall s a lockstep step waits before running on what it has

  void validate() const;
};

/// The table of NodeParameters (height_band apart: one [min, max] parameter for two fields).
template <class P, class V, std::enable_if_t<std::is_same_v<std::decay_t<P>, NodeParameters>, int> = 0>
void visitFields(P& p, V&& visit)
{
  visit(p.scan_topics, ParamInfo("scan_topics", "", "LaserScan obstacle sources (at least one source in all)"));
  visit(p.cloud_topics, ParamInfo("cloud_topics", "", "PointCloud2 obstacle sources"));
  visit(p.odom_frame, ParamInfo("odom_frame", "", "the frame the pose and the goal are in").nonEmpty());
  visit(p.robot_frame, ParamInfo("robot_frame", "", "the robot's frame (the commands' frame)").nonEmpty());
  visit(p.control_rate, ParamInfo("control_rate", "Hz", "steps per second of ROS time").above(0.0).finiteOnly());
  visit(p.lockstep, ParamInfo("lockstep", "", "steps wait for every source's data (simulation; see above)"));
  visit(p.lockstep_timeout,
        ParamInfo("lockstep_timeout", "s", "wall seconds after which a lockstep step runs on what there is")
          .above(0.0)
          .finiteOnly());
}

}  // namespace reactive_navigator
