// Throttled messages per node instance: ROS_WARN_THROTTLE keeps one timer per call site, shared
// by every node in a nodelet manager, so one sensor's trouble would hide another's.
#pragma once

#include <ros/time.h>

namespace laserscan_common
{

/// True when `period` s have passed since `last` (then `last` becomes now); true the first time.
inline bool due(ros::WallTime& last, double period = 5.0)
{
  const ros::WallTime now = ros::WallTime::now();
  if (!last.isZero() && (now - last).toSec() < period)
    return false;
  last = now;
  return true;
}

}  // namespace laserscan_common
