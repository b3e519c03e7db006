#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>
#include <stdexcept>

#include "depth_filter_scan_converter/depth_filter_scan_converter_ros.hpp"

namespace depth_filter_scan_converter
{
/// The converter in a nodelet manager; kInput says what it reads.
template <DepthInput kInput>
class ConverterNodelet : public nodelet::Nodelet
{
private:
  void onInit() override
  {
    try
    {
      converter_ = std::make_unique<DepthFilterScanConverter>(getNodeHandle(), getPrivateNodeHandle(), kInput);
    }
    catch (const std::invalid_argument& e)
    {
      // Bad configuration: say which parameter, and do not process anything.
      NODELET_FATAL("not starting: %s", e.what());
    }
  }

  std::unique_ptr<DepthFilterScanConverter> converter_;
};

/// PointCloud2 on cloud_in -> scan.
class DepthFilterScanConverterNodelet : public ConverterNodelet<DepthInput::Cloud>
{};
/// Depth image on image + camera_info -> scan.
class DepthImageScanConverterNodelet : public ConverterNodelet<DepthInput::Image>
{};
}  // namespace depth_filter_scan_converter

PLUGINLIB_EXPORT_CLASS(depth_filter_scan_converter::DepthFilterScanConverterNodelet, nodelet::Nodelet)
PLUGINLIB_EXPORT_CLASS(depth_filter_scan_converter::DepthImageScanConverterNodelet, nodelet::Nodelet)
