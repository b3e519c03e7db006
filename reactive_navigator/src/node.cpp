// Standalone node: same class as the nodelet (its own process, so that its CPU is measured alone).
#include <ros/ros.h>

#include "reactive_navigator/reactive_navigator_ros.hpp"

int main(int argc, char** argv)
{
  ros::init(argc, argv, "reactive_navigator");
  ros::NodeHandle nh, private_nh("~");
  try
  {
    reactive_navigator::ReactiveNavigatorRos navigator(nh, private_nh);
    ros::spin();
  }
  catch (const reactive_navigator::ParameterError& e)
  {
    ROS_FATAL("bad configuration, not navigating: parameter '%s': %s", e.parameter().c_str(), e.reason().c_str());
    return 1;
  }
  return 0;
}
