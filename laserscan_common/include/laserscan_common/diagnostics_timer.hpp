// When the nodes publish their diagnostics (ROS glue, header-only).
#pragma once

#include <ros/ros.h>

namespace laserscan_common
{
/// A timer that publishes `updater`'s status (a diagnostic_updater::Updater) every second of wall
/// time, so also while a simulated clock stands still (a bag not yet playing, paused or ended):
/// the updater's own period runs on ROS time and would publish nothing then. A template, so this
/// package needs no diagnostic_updater; the timer must not outlive the updater.
template <class Updater>
ros::WallTimer diagnosticsTimer(ros::NodeHandle& nh, Updater& updater)
{
  return nh.createWallTimer(ros::WallDuration(1.0), [&updater](const ros::WallTimerEvent&) { updater.force_update(); });
}

}  // namespace laserscan_common
