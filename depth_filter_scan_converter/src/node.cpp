#include <ros/ros.h>

#include <stdexcept>

#include "depth_filter_scan_converter/depth_filter_scan_converter.h"

int main(int argc, char** argv)
{
  ros::init(argc, argv, "depth_filter_scan_converter");
  // Handles live outside the try: if the last one died with the converter, roscpp would shut
  // down rosconsole and the fatal message below would never be printed.
  ros::NodeHandle nh, private_nh("~");
  try
  {
    depth_filter_scan_converter::DepthFilterScanConverter converter(nh, private_nh);
    ros::spin();
  }
  catch (const std::invalid_argument& e)
  {
    ROS_FATAL("not starting: %s", e.what());
    return 1;
  }
  return 0;
}
