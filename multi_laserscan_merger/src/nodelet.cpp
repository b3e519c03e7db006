// Nodelet wrapper: the work is done by MultiLaserScanMergerRos.
#include <pluginlib/class_list_macros.hpp>

#include "laserscan_common/entry_points.hpp"
#include "multi_laserscan_merger/multi_laserscan_merger_ros.hpp"

namespace multi_laserscan_merger
{
class MultiLaserScanMergerNodelet : public laserscan_common::NodeletOf<MultiLaserScanMergerRos>
{};
}  // namespace multi_laserscan_merger

PLUGINLIB_EXPORT_CLASS(multi_laserscan_merger::MultiLaserScanMergerNodelet, nodelet::Nodelet)
