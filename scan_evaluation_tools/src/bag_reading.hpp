// What the bag tools (bag_to_rawlog, bag_to_octomap) share: the yaw of a pose, /tf and
// /tf_static read into a tf2 buffer under the nodes' rules, and main's exit-status frame.
#pragma once

#include "laserscan_common/message_checks.hpp"

#include <geometry_msgs/Quaternion.h>
#include <rosbag/message_instance.h>
#include <tf2/buffer_core.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>
#include <cstdlib>
#include <cstdint>
#include <exception>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

namespace scan_evaluation_tools
{
inline double yawOf(const geometry_msgs::Quaternion& q)
{
  return std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
}

/// Feeds a bag's /tf and /tf_static messages into a tf2 buffer with the nodes' rules for /tf,
/// the time the bag recorded a message as the clock; a transform the rules or tf2 refuse is
/// counted and the last one described.
class BagTransforms
{
public:
  explicit BagTransforms(tf2::BufferCore& tf)
    : tf_(tf), max_ahead_(static_cast<std::int64_t>(tf.getCacheLength().toNSec()))
  {}

  /// Returns false when `m` is no tf2_msgs/TFMessage.
  bool add(const rosbag::MessageInstance& m)
  {
    const auto msg = m.instantiate<tf2_msgs::TFMessage>();
    if (!msg)
    {
      return false;
    }
    const bool is_static = m.getTopic() == "/tf_static";
    for (const auto& t : msg->transforms)
    {
      std::string fault = gate_.fault(t, is_static, static_cast<std::int64_t>(m.getTime().toNSec()), max_ahead_);
      if (fault.empty())
      {
        try
        {
          tf_.setTransform(t, "bag", is_static);
        }
        catch (const std::exception& e)  // tf2's own, and ros::Time's range errors
        {
          fault = e.what();
        }
      }
      if (!fault.empty())
      {
        ++malformed_;
        last_fault_ = "'" + t.header.frame_id + "' -> '" + t.child_frame_id + "' on " + m.getTopic() + " with stamp " +
                      laserscan_common::stampText(t.header.stamp.sec, t.header.stamp.nsec) + ": " + fault;
      }
    }
    return true;
  }

  std::size_t malformed() const { return malformed_; }
  const std::string& lastFault() const { return last_fault_; }

private:
  tf2::BufferCore& tf_;
  laserscan_common::TransformGate gate_;
  std::int64_t max_ahead_;
  std::size_t malformed_ = 0;
  std::string last_fault_;
};

/// Walks the command line: each argument starting with '-' goes to `handle(option, value)`,
/// where value() takes the next argument (throwing "<option> needs a value" at the end) and
/// `handle` returns false for an option it does not know; -h and --help print `usage` and exit 0.
/// Returns the other arguments.
template <typename Handle>
std::vector<std::string> parseArguments(int argc, char** argv, const char* usage, Handle handle)
{
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc)
      {
        throw std::invalid_argument(a + " needs a value");
      }
      return argv[++i];
    };
    if (a == "-h" || a == "--help")
    {
      std::cout << usage;
      std::exit(0);
    }
    if (!a.empty() && a[0] == '-')
    {
      if (!handle(a, value))
      {
        throw std::invalid_argument("unknown option " + a);
      }
    }
    else
    {
      positional.push_back(a);
    }
  }
  return positional;
}

/// main's frame: a usage error prints the usage and exits 2; an exception from `run` (rosbag's,
/// a file that cannot be read) is named with the bag and exits 1; else run's status.
template <typename Options, typename Parse, typename Run>
int runTool(const char* name, const char* usage, int argc, char** argv, Parse parse, Run run)
{
  Options options;
  try
  {
    options = parse(argc, argv);
  }
  catch (const std::exception& e)
  {
    std::cerr << name << ": " << e.what() << "\n" << usage;
    return 2;
  }
  try
  {
    return run(options);
  }
  catch (const std::exception& e)
  {
    std::cerr << name << ": " << options.bag << ": " << e.what() << "\n";
    return 1;
  }
}

}  // namespace scan_evaluation_tools
