#include <ros/ros.h>

#include <stdexcept>

#include "depth_filter_scan_converter/range_scan_converter_ros.hpp"

int main(int argc, char** argv)
{
  ros::init(argc, argv, "range_scan_converter");
  // Handles live outside the try, so rosconsole is still up for the fatal message.
  ros::NodeHandle nh, private_nh("~");
  try
  {
    depth_filter_scan_converter::RangeScanConverter converter(nh, private_nh);
    ros::spin();
  }
  catch (const std::invalid_argument& e)
  {
    ROS_FATAL("not starting: %s", e.what());
    return 1;
  }
  return 0;
}
