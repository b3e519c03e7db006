// The thin entry points of the package's converters: the standalone node and the nodelet around
// one ROS class constructed from (nh, private_nh, extra arguments). Private to the package.
#pragma once

#include <nodelet/nodelet.h>
#include <ros/ros.h>

#include <memory>

#include "depth_filter_scan_converter/converter_glue.hpp"

namespace depth_filter_scan_converter
{
/// ros::init with `name`, the converter, spin. Returns the process's exit status: 1 (after a
/// FATAL message naming the parameter) on a bad configuration.
template <class Converter, class... Args>
int runNode(int argc, char** argv, const char* name, Args... args)
{
  ros::init(argc, argv, name);
  // Handles live outside the try: if the last one died with the converter, roscpp would shut
  // down rosconsole and the fatal message below would never be printed.
  ros::NodeHandle nh, private_nh("~");
  try
  {
    Converter converter(nh, private_nh, args...);
    ros::spin();
  }
  catch (const laserscan_common::ParameterError& e)
  {
    ROS_FATAL("not starting: %s", describe(e).c_str());
    return 1;
  }
  return 0;
}

/// The converter in a nodelet manager, constructed with the extra arguments kArgs.
template <class Converter, auto... kArgs>
class ConverterNodelet : public nodelet::Nodelet
{
private:
  void onInit() override
  {
    try
    {
      converter_ = std::make_unique<Converter>(getNodeHandle(), getPrivateNodeHandle(), kArgs...);
    }
    catch (const laserscan_common::ParameterError& e)
    {
      // Bad configuration: say which parameter, and do not process anything.
      NODELET_FATAL("not starting: %s", describe(e).c_str());
    }
  }

  std::unique_ptr<Converter> converter_;
};

}  // namespace depth_filter_scan_converter
