// The thin entry points of every node: the standalone node and the nodelet around one ROS class
// constructed from (nh, private_nh, extra arguments). A bad configuration
// (laserscan_common::ParameterError) gives one FATAL message naming the parameter and the
// reason; the node exits 1, the nodelet stays loaded and does nothing.
#pragma once

#include <nodelet/nodelet.h>
#include <ros/ros.h>

#include <memory>

#include "laserscan_common/node_glue.hpp"
#include "laserscan_common/node_log.hpp"

namespace laserscan_common
{
/// ros::init with `name`, the node's class, spin. Returns the process's exit status: 1 (after a
/// FATAL message naming the parameter) on a bad configuration.
template <class Node, class... Args>
int runNode(int argc, char** argv, const char* name, Args... args)
{
  ros::init(argc, argv, name);
  // Handles live outside the try: if the last one died with the node's class, roscpp would shut
  // down rosconsole and the fatal message below would never be printed.
  ros::NodeHandle nh, private_nh("~");
  try
  {
    Node node(nh, private_nh, args...);
    ros::spin();
  }
  catch (const ParameterError& e)
  {
    NODE_FATAL(private_nh.getNamespace(), "not starting: %s", describe(e).c_str());
    return 1;
  }
  return 0;
}

/// The node's class in a nodelet manager, constructed with the extra arguments kArgs.
template <class Node, auto... kArgs>
class NodeletOf : public nodelet::Nodelet
{
private:
  void onInit() override
  {
    try
    {
      node_ = std::make_unique<Node>(getNodeHandle(), getPrivateNodeHandle(), kArgs...);
    }
    catch (const ParameterError& e)
    {
      // Bad configuration: say which parameter, and do not process anything.
      // Named as every other line of the node: a manager's log holds many nodelets'.
      NODE_FATAL(getPrivateNodeHandle().getNamespace(), "not starting: %s", describe(e).c_str());
    }
  }

  std::unique_ptr<Node> node_;
};

}  // namespace laserscan_common
