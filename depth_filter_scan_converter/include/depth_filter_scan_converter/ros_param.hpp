// Reading private parameters strictly: a value of the wrong type is an error, not a default.
#pragma once

#include <ros/node_handle.h>

#include <stdexcept>
#include <string>

namespace depth_filter_scan_converter
{
/// Reads `name` into `value` if it is set; throws std::invalid_argument naming the parameter
/// and the expected `type` when it is set to something else.
template <typename T>
void readTypedParam(const ros::NodeHandle& nh, const std::string& name, T& value, const char* type)
{
  if (nh.hasParam(name) && !nh.getParam(name, value))
    throw std::invalid_argument("parameter '" + name + "' must be of type " + type);
}

}  // namespace depth_filter_scan_converter
