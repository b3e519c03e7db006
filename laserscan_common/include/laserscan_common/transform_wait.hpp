// The one way a node waits for a message's transforms (converters and merger alike): a message
// whose transforms are there goes on at once; one whose are not waits in tf2_ros's MessageFilter
// (never in a callback, never polled) and comes back through the node's callback queue once they
// are, with the time it was received riding on its message event (no record of it to match
// back), or comes back as a failure (pushed out by newer ones, older than the tf buffer).
#pragma once

#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>

#include <boost/function.hpp>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "laserscan_common/message_checks.hpp"

namespace laserscan_common
{
/// What a message that waited in a TransformWait failed on, as a user reads it.
inline std::string transformWaitFailure(tf2_ros::filter_failure_reasons::FilterFailureReason reason)
{
  switch (reason)
  {
    case tf2_ros::filter_failure_reasons::OutTheBack:
      return "the transform is older than the tf buffer (OutTheBack)";
    case tf2_ros::filter_failure_reasons::EmptyFrameID:  // the nodes check frame ids before; kept for completeness
      return "the message has an empty frame_id";
    default:
      return "no transform arrived before newer messages pushed it out of the queue";
  }
}

/// Messages of type M (a ROS message, or any struct with a `header` for which
/// ros::message_traits::HasHeader is true) waiting for the transforms from their frame to each
/// of `targets` at their stamp. Thread-safe as MessageFilter is; the callbacks run from `nh`'s
/// callback queue, never from inside wait(), so wait() may be called with the node's lock held.
/// There is deliberately no clear(): MessageFilter's takes the callback queue's lock, which
/// deadlocks against a callback of the filter waiting for the node's lock. A node that gives
/// up on a waiting message forgets it itself and ignores it when it comes back.
template <class M>
class TransformWait
{
public:
  using ConstPtr = boost::shared_ptr<const M>;
  /// A message whose transforms came; `received` is the time passed to wait().
  using Ready = std::function<void(const ConstPtr& message, const ros::Time& received)>;
  /// A message that will not get its transforms; `why` as transformWaitFailure says it.
  using Failed = std::function<void(const ConstPtr& message, const std::string& why)>;

  /// At most `queue_size` messages wait (a newer one pushes the oldest out, as a failure).
  TransformWait(tf2_ros::Buffer& buffer, const std::vector<std::string>& targets, std::uint32_t queue_size,
                const ros::NodeHandle& nh, Ready ready, Failed failed)
    : buffer_(buffer), targets_(targets), filter_(buffer, targets.front(), queue_size, nh)
  {
    filter_.setTargetFrames(targets_);
    filter_.registerCallback(boost::function<void(const ros::MessageEvent<M const>&)>(
      [ready](const ros::MessageEvent<M const>& event) { ready(event.getConstMessage(), event.getReceiptTime()); }));
    filter_.registerFailureCallback(
      [failed](const ConstPtr& message, tf2_ros::filter_failure_reasons::FilterFailureReason reason) {
        failed(message, transformWaitFailure(reason));
      });
  }

  /// Whether every transform of `header` (its frame_id as tf2 takes it) is there now: the usual
  /// case, where the message need not wait (nor take the filter's extra trip through the queue).
  bool ready(const std_msgs::Header& header) const
  {
    const tf2::BufferCore& transforms = buffer_;
    const std::string frame = tf2FrameId(header.frame_id);
    for (const std::string& target : targets_)
      if (!transforms.canTransform(target, frame, header.stamp))
        return false;
    return true;
  }

  /// Lets `message`, received at `received` (the clock the node measures its wait with), wait
  /// for its transforms; at its stamp and, with `extent` > 0, also at stamp + extent (a scan
  /// whose beams span that time).
  void wait(const ConstPtr& message, const ros::Time& received, const ros::Duration& extent = ros::Duration())
  {
    filter_.setTolerance(extent);
    filter_.add(ros::MessageEvent<M const>(message, received));
  }

private:
  tf2_ros::Buffer& buffer_;
  const std::vector<std::string> targets_;
  tf2_ros::MessageFilter<M> filter_;
};

}  // namespace laserscan_common
