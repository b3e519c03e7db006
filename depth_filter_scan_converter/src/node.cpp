#include "depth_filter_scan_converter/run_node.hpp"

int main(int argc, char** argv)
{
  return depth_filter_scan_converter::runNode(argc, argv, "depth_filter_scan_converter",
                                              depth_filter_scan_converter::DepthInput::Cloud);
}
