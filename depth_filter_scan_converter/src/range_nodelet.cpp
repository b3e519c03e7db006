#include <pluginlib/class_list_macros.hpp>

#include "depth_filter_scan_converter/range_scan_converter_ros.hpp"
#include "laserscan_common/entry_points.hpp"

namespace depth_filter_scan_converter
{
/// sensor_msgs/Range on range_in -> scan (an arc).
class RangeScanConverterNodelet : public laserscan_common::NodeletOf<RangeScanConverter>
{};
}  // namespace depth_filter_scan_converter

PLUGINLIB_EXPORT_CLASS(depth_filter_scan_converter::RangeScanConverterNodelet, nodelet::Nodelet)
