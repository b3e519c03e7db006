// Standalone node: same class as the nodelet.
#include "laserscan_common/entry_points.hpp"
#include "multi_laserscan_merger/multi_laserscan_merger_ros.hpp"

int main(int argc, char** argv)
{
  return laserscan_common::runNode<multi_laserscan_merger::MultiLaserScanMergerRos>(argc, argv,
                                                                                    "multi_laserscan_merger");
}
