#include <ros/ros.h>

#include <stdexcept>

#include "depth_filter_scan_converter/depth_filter_scan_converter.h"

int main(int argc, char** argv)
{
  ros::init(argc, argv, "depth_filter_scan_converter");
  try
  {
    depth_filter_scan_converter::DepthFilterScanConverter converter(ros::NodeHandle(), ros::NodeHandle("~"));
    ros::spin();
  }
  catch (const std::invalid_argument& e)
  {
    ROS_FATAL("not starting: %s", e.what());
    return 1;
  }
  return 0;
}
