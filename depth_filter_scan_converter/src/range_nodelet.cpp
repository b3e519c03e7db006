#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>
#include <stdexcept>

#include "depth_filter_scan_converter/range_scan_converter_ros.hpp"

namespace depth_filter_scan_converter
{
class RangeScanConverterNodelet : public nodelet::Nodelet
{
private:
  void onInit() override
  {
    try
    {
      converter_ = std::make_unique<RangeScanConverter>(getNodeHandle(), getPrivateNodeHandle());
    }
    catch (const std::invalid_argument& e)
    {
      // Bad configuration: say which parameter, and do not convert anything.
      NODELET_FATAL("not starting: %s", e.what());
    }
  }

  std::unique_ptr<RangeScanConverter> converter_;
};
}  // namespace depth_filter_scan_converter

PLUGINLIB_EXPORT_CLASS(depth_filter_scan_converter::RangeScanConverterNodelet, nodelet::Nodelet)
