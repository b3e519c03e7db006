// The nodes' /tf reader: feeds /tf and /tf_static into a tf2 buffer instead of
// tf2_ros::TransformListener, whose callback lets tf2 throw on a stamp near 2^32 s (tf2 adds its
// cache length to it) and takes the process, or a whole nodelet manager, down. What tf2 would
// refuse with an unthrottled error, or store although it is wrong, is ignored with a message
// throttled per frame pair (TransformGate decides).
#pragma once

#include <cstdint>
#include <mutex>
#include <string>

#include <ros/ros.h>
#include <tf2/buffer_core.h>
#include <tf2_msgs/TFMessage.h>

#include "laserscan_common/message_checks.hpp"
#include "laserscan_common/node_log.hpp"
#include "laserscan_common/throttle.hpp"

namespace laserscan_common
{

class TransformReader
{
public:
  /// Seconds between two messages about the same frame pair.
  static constexpr double kWarningPeriod = 5.0;

  /// Subscribes /tf and /tf_static through nh (its callback queue runs the reader); `name`
  /// starts every message (the node's name). The buffer must outlive the reader.
  TransformReader(ros::NodeHandle nh, tf2::BufferCore& buffer, std::string name)
    : buffer_(buffer), name_(std::move(name))
  {
    tf_sub_ = nh.subscribe("/tf", 100, &TransformReader::tfArrived, this);
    tf_static_sub_ = nh.subscribe("/tf_static", 100, &TransformReader::tfStaticArrived, this);
  }

  TransformReader(const TransformReader&) = delete;
  TransformReader& operator=(const TransformReader&) = delete;

  /// Stores each usable transform of the message in the buffer; warns about the others.
  void add(const tf2_msgs::TFMessage& message, const std::string& authority, bool is_static)
  {
    const std::int64_t now = static_cast<std::int64_t>(ros::Time::now().toNSec());
    const std::int64_t max_ahead = static_cast<std::int64_t>(buffer_.getCacheLength().toNSec());
    for (const auto& t : message.transforms)
    {
      std::string why;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        why = gate_.fault(t, is_static, now, max_ahead);
        if (!why.empty())
        {
          const std::string parent = gate_.staticParent(t.child_frame_id);
          if (!is_static && !parent.empty() && parent != tf2FrameId(t.header.frame_id))
            why += " (its static parent is '" + parent + "')";
        }
      }
      if (why.empty())
        try
        {
          buffer_.setTransform(t, authority, is_static);  // locks itself
        }
        catch (const std::exception& e)
        {
          why = e.what();
        }
      if (!why.empty())
        warn(t, authority, is_static, why);
    }
  }

private:
  // Member functions, not lambdas: roscpp passes a lambda the message alone, without its publisher.
  void tfArrived(const ros::MessageEvent<const tf2_msgs::TFMessage>& event)
  {
    add(*event.getMessage(), event.getPublisherName(), false);
  }
  void tfStaticArrived(const ros::MessageEvent<const tf2_msgs::TFMessage>& event)
  {
    add(*event.getMessage(), event.getPublisherName(), true);
  }

  /// Throttled per frame pair and per reader (ROS_WARN_THROTTLE keeps one timer per call site,
  /// shared by every node in a manager): one faulty publisher must not hide another.
  void warn(const geometry_msgs::TransformStamped& t, const std::string& authority, bool is_static,
            const std::string& why)
  {
    const std::string pair = "'" + t.header.frame_id + "' -> '" + t.child_frame_id + "'";
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!warned_.due(pair))
        return;
    }
    NODE_WARN(name_, "transform %s from %s on %s with stamp %s ignored: %s", pair.c_str(), authority.c_str(),
              is_static ? "/tf_static" : "/tf", stampText(t.header.stamp.sec, t.header.stamp.nsec).c_str(),
              why.c_str());
  }

  tf2::BufferCore& buffer_;
  const std::string name_;
  std::mutex mutex_;  // /tf and /tf_static may arrive at once (multi-threaded manager)
  TransformGate gate_;
  WarningThrottle warned_{ kWarningPeriod };  ///< per frame pair
  ros::Subscriber tf_sub_, tf_static_sub_;
};

}  // namespace laserscan_common
