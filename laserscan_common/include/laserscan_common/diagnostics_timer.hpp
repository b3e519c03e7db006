// When the nodes publish their diagnostics (ROS glue, header-only).
#pragma once

#include <exception>
#include <string>

#include <ros/ros.h>

#include "laserscan_common/throttle.hpp"

namespace laserscan_common
{
/// A timer that publishes `updater`'s status (a diagnostic_updater::Updater) every second of wall
/// time, so also while a simulated clock stands still (a bag not yet playing, paused or ended):
/// the updater's own period runs on ROS time and would publish nothing then. A template, so this
/// package needs no diagnostic_updater; the timer must not outlive the updater. `name` (the
/// node's) starts the warning below.
///
/// force_update() schedules the updater's next update at now() + its period, which ros::Time
/// refuses with std::runtime_error when the clock is within that period of the end of ROS 1 time
/// (2^32 s, a simulated clock can be there). Out of a timer callback the exception would end
/// the process, a whole nodelet manager: that status is skipped with a warning (every 5 s).
template <class Updater>
ros::WallTimer diagnosticsTimer(ros::NodeHandle& nh, Updater& updater, const std::string& name)
{
  return nh.createWallTimer(ros::WallDuration(1.0),
                            [&updater, name, last_warning = ros::WallTime()](const ros::WallTimerEvent&) mutable {
                              try
                              {
                                updater.force_update();
                              }
                              catch (const std::exception& e)
                              {
                                if (due(last_warning))
                                  ROS_WARN(
                                    "[%s] diagnostics not published: %s (clock %.3f s; the end of ROS time is "
                                    "2^32 s)",
                                    name.c_str(), e.what(), ros::Time::now().toSec());
                              }
                            });
}

}  // namespace laserscan_common
