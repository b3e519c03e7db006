#include <pluginlib/class_list_macros.hpp>

#include "depth_filter_scan_converter/depth_filter_scan_converter_ros.hpp"
#include "laserscan_common/entry_points.hpp"

namespace depth_filter_scan_converter
{
/// PointCloud2 on cloud_in -> scan.
class DepthFilterScanConverterNodelet : public laserscan_common::NodeletOf<DepthFilterScanConverter, DepthInput::Cloud>
{};
/// Depth image on image + camera_info -> scan.
class DepthImageScanConverterNodelet : public laserscan_common::NodeletOf<DepthFilterScanConverter, DepthInput::Image>
{};
}  // namespace depth_filter_scan_converter

PLUGINLIB_EXPORT_CLASS(depth_filter_scan_converter::DepthFilterScanConverterNodelet, nodelet::Nodelet)
PLUGINLIB_EXPORT_CLASS(depth_filter_scan_converter::DepthImageScanConverterNodelet, nodelet::Nodelet)
