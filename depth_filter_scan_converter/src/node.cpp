#include "depth_filter_scan_converter/depth_filter_scan_converter_ros.hpp"
#include "laserscan_common/entry_points.hpp"

int main(int argc, char** argv)
{
  using namespace depth_filter_scan_converter;
  return laserscan_common::runNode<DepthFilterScanConverter>(
    argc, argv, "depth_filter_scan_converter", DepthInput::Cloud,
    CloudReading::InPlace);  // the only subscriber to its input in its process
}
