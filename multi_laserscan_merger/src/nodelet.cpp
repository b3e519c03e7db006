// Nodelet wrapper: the work is done by MultiLaserScanMergerRos.
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include "multi_laserscan_merger/multi_laserscan_merger_ros.hpp"

namespace multi_laserscan_merger
{

class MultiLaserScanMergerNodelet : public nodelet::Nodelet
{
private:
  void onInit() override
  {
    try
    {
      impl_ = std::make_unique<MultiLaserScanMergerRos>(getNodeHandle(), getPrivateNodeHandle());
    }
    catch (const ParameterError& e)
    {
      // Bad configuration: say which parameter and why, and do nothing else.
      NODELET_FATAL("bad configuration, not merging: parameter '%s': %s", e.parameter().c_str(), e.reason().c_str());
    }
  }

  std::unique_ptr<MultiLaserScanMergerRos> impl_;
};

}  // namespace multi_laserscan_merger

PLUGINLIB_EXPORT_CLASS(multi_laserscan_merger::MultiLaserScanMergerNodelet, nodelet::Nodelet)
