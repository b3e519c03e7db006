// Standalone node: same class as the nodelet.
#include <ros/ros.h>

#include "multi_laserscan_merger/multi_laserscan_merger_ros.hpp"

int main(int argc, char** argv)
{
  ros::init(argc, argv, "multi_laserscan_merger");
  ros::NodeHandle nh, private_nh("~");
  try
  {
    multi_laserscan_merger::MultiLaserScanMergerRos merger(nh, private_nh);
    ros::spin();
  }
  catch (const multi_laserscan_merger::ParameterError& e)
  {
    ROS_FATAL("bad configuration, not merging: parameter '%s': %s", e.parameter().c_str(), e.reason().c_str());
    return 1;
  }
  return 0;
}
