// The ROS side of the self filter, shared by the converters and the merger: the `self_filter`
// parameter block (SelfFilterParams' table, self_filter.hpp; strict: a wrong type or an unknown
// key is a ParameterError naming it), the
// shapes it describes (robot_description's collision elements and/or listed shapes), and the tf
// lookup of their frames at a message's stamp (one per frame and message, never per point).
#pragma once

#include <string>
#include <vector>

#include <ros/ros.h>
#include <tf2/buffer_core.h>

#include "laserscan_common/parameter_reader.hpp"
#include "laserscan_common/self_filter.hpp"

namespace laserscan_common
{

/// Reads `<private_nh>/<key>` (absent: the filter is off) by the toolbox's one strict rule.
/// Throws ParameterError.
SelfFilterParams readSelfFilterParams(ParameterReader& reader, const std::string& key = "self_filter");

/// The filter the parameters describe: the description's shapes (read from `robot_description`
/// in nh's namespace; package:// meshes through roslib), then the listed ones. Throws
/// ParameterError for a missing or unusable description. Warnings (meshes that could not be
/// read) go to `warnings`.
SelfFilter makeSelfFilter(const SelfFilterParams& params, const ros::NodeHandle& nh,
                          std::vector<std::string>& warnings);

/// Sets the poses of the filter's frames in `target` at `stamp` (one lookup per frame). Throws
/// tf2::TransformException (naming the frames) when one is not there: a node waits for them as
/// for its sensor's own transform (its tf message filter has the shape frames as targets too).
/// `row_yaw`: SelfFilter::setFramePoses's.
void setFramePosesAt(const tf2::BufferCore& buffer, const std::string& target, const ros::Time& stamp,
                     SelfFilter& filter, double row_yaw = 0.0);

}  // namespace laserscan_common
