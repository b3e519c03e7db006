// What the ROS classes of the package's converters (depth cloud or image, range) share beyond
// every node's glue (laserscan_common/node_glue.hpp): strict parameter reading, queue_size, the
// summary of their status. Used by the package only.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <string>

#include "laserscan_common/node_glue.hpp"
#include "laserscan_common/parameter_error.hpp"
#include "laserscan_common/throttle.hpp"

namespace depth_filter_scan_converter
{
/// Reads `name` into `value` if it is set; throws ParameterError naming the parameter and the
/// expected `type` when it is set to something else (a value of the wrong type is an error, not
/// a default).
template <typename T>
void readTypedParam(const ros::NodeHandle& nh, const std::string& name, T& value, const char* type)
{
  if (nh.hasParam(name) && !nh.getParam(name, value))
    throw laserscan_common::ParameterError(name, std::string("must be of type ") + type);
}

/// The private parameter queue_size (default 10, >= 1): depth of the input's queues.
int readQueueSize(const ros::NodeHandle& private_nh);

// Per converter, not per call site as ROS_WARN_THROTTLE.
using laserscan_common::WarningThrottle;

// What every node needs (laserscan_common), under the names the converters use.
using laserscan_common::describe;
using laserscan_common::LazySubscription;
using laserscan_common::NodeDiagnostics;
using laserscan_common::RateMeter;

/// The summary of a converter's diagnostics: WARN with `problem` when there is one, WARN when
/// subscribed but nothing arrives (`nothing_arrives`), else OK converting or idle.
void summarize(diagnostic_updater::DiagnosticStatusWrapper& status, const std::string& problem, bool subscribed,
               double rate, const std::string& nothing_arrives);

}  // namespace depth_filter_scan_converter
