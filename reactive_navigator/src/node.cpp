// Standalone node: same class as the nodelet (its own process, so that its CPU is measured alone).
#include "laserscan_common/entry_points.hpp"
#include "reactive_navigator/reactive_navigator_ros.hpp"

int main(int argc, char** argv)
{
  return laserscan_common::runNode<reactive_navigator::ReactiveNavigatorRos>(argc, argv, "reactive_navigator");
}
