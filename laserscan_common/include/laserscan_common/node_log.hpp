// Every node's log lines, as NODELET_WARN and friends name them, with one prefix: "[<node>] "
// (the node's name, its private namespace), so that a line in a shared manager's log says which
// converter or merger wrote it. `node` is a std::string.
#pragma once

#include <ros/console.h>

#define NODE_INFO(node, format, ...) ROS_INFO("[%s] " format, (node).c_str(), ##__VA_ARGS__)
#define NODE_WARN(node, format, ...) ROS_WARN("[%s] " format, (node).c_str(), ##__VA_ARGS__)
#define NODE_ERROR(node, format, ...) ROS_ERROR("[%s] " format, (node).c_str(), ##__VA_ARGS__)
#define NODE_FATAL(node, format, ...) ROS_FATAL("[%s] " format, (node).c_str(), ##__VA_ARGS__)
