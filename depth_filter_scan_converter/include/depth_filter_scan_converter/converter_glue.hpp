// What the ROS classes of the package's converters (depth cloud or image, range) share beyond
// every node's glue (laserscan_common/node_glue.hpp): the summary of their status. Used by the
// package only.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <string>

#include "laserscan_common/node_glue.hpp"
#include "laserscan_common/parameter_error.hpp"
#include "laserscan_common/throttle.hpp"

namespace depth_filter_scan_converter
{
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
