// Obstacle points for the navigator from a scan's beams or a cloud's points, in the robot frame.
// ROS-free: the glue hands in the message's arrays (a cloud as laserscan_common's view) and the
// sensor's transform at its stamp.
#pragma once

#include <cstddef>
#include <cstdint>

#include <Eigen/Geometry>

#include "laserscan_common/cloud_view.hpp"
#include "laserscan_common/scan_view.hpp"
#include "reactive_navigator/navigator_core.hpp"

namespace reactive_navigator
{

/// A received LaserScan (laserscan_common's view; the node checks it with scanFault first).
using laserscan_common::ScanView;

/// Appends one point per beam that sees an obstacle, in the robot frame. REP 117: a finite range
/// within [range_min, range_max] is a point; -Inf (an object closer than range_min) becomes a
/// point at range_min, so that what is too close stays an obstacle; +Inf (no return), NaN and
/// finite ranges outside the limits add nothing. A scan is planar: no height band (its plane, or
/// the unified scan's projection, already chose what is an obstacle). Returns the points added.
std::size_t appendScanPoints(const ScanView& scan, const Eigen::Isometry3d& sensor_to_robot, ObstaclePoints& out);

/// Appends, for each beam with no return (+Inf, REP 117), the point `distance` m along it, in the
/// robot frame: the end of a ray that saw free space (the planner's grid clears along it).
/// Returns the points added.
std::size_t appendScanNoReturns(const ScanView& scan, const Eigen::Isometry3d& sensor_to_robot, double distance,
                                ObstaclePoints& out);

/// Appends the cloud's finite points whose height in the robot frame is within
/// [band_min, band_max] (as a costmap's obstacle layer keeps its band). The cloud is read through
/// laserscan_common's view (laserscan_common::makeCloudView checked it): rows row_step bytes
/// apart, x/y/z float32 or float64. Returns the points added.
std::size_t appendCloudPoints(const laserscan_common::CloudView& cloud, const Eigen::Isometry3d& sensor_to_robot,
                              double band_min, double band_max, ObstaclePoints& out);

}  // namespace reactive_navigator
