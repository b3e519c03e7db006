// Nodelet wrapper: the work is done by ReactiveNavigatorRos.
#include <pluginlib/class_list_macros.hpp>

#include "laserscan_common/entry_points.hpp"
#include "reactive_navigator/reactive_navigator_ros.hpp"

namespace reactive_navigator
{
class ReactiveNavigatorNodelet : public laserscan_common::NodeletOf<ReactiveNavigatorRos>
{};
}  // namespace reactive_navigator

PLUGINLIB_EXPORT_CLASS(reactive_navigator::ReactiveNavigatorNodelet, nodelet::Nodelet)
