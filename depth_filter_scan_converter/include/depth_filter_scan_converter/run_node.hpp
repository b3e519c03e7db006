// The standalone nodes: one converter in its own process.
#pragma once

#include "depth_filter_scan_converter/depth_filter_scan_converter_ros.hpp"

namespace depth_filter_scan_converter
{
/// ros::init with `name`, the converter for `input`, spin. Returns the process's exit status:
/// 1 (after a FATAL message naming the parameter) on a bad configuration.
int runNode(int argc, char** argv, const char* name, DepthInput input);
}  // namespace depth_filter_scan_converter
