#include "depth_filter_scan_converter/range_scan_converter_ros.hpp"
#include "laserscan_common/entry_points.hpp"

int main(int argc, char** argv)
{
  using namespace depth_filter_scan_converter;
  return laserscan_common::runNode<RangeScanConverter>(argc, argv, "range_scan_converter");
}
