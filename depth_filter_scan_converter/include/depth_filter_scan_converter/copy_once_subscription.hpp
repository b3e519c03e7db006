// Subscriptions to clouds and depth images that copy each message's bytes once.
//
// roscpp deserialises a uint8[] field with resize() then memcpy: resize() zero-fills the whole
// buffer first, a second pass over every cloud or image that costs as much as the copy (about
// 0.1 ms per 52k-point cloud, 1 ms per 640 x 480 cloud). These subscriptions read the same
// message type from the same wire format with roscpp's own serializer, copying the bytes straight
// from the socket's buffer.
// The subscriber's C++ type stays sensor_msgs::PointCloud2 / Image, so a publisher in the same
// nodelet manager still hands over its shared pointer (no deserialisation at all).
#pragma once

#include <ros/ros.h>
#include <ros/subscription_callback_helper.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>

#include <boost/make_shared.hpp>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace depth_filter_scan_converter
{
namespace wire
{
/// roscpp's input stream with one change: a uint8[] field (a cloud's or an image's data) is
/// copied once, without the zero-fill of resize(). Every other field is read by roscpp's code.
class CopyOnceStream : public ros::serialization::IStream
{
public:
  using IStream::IStream;

  template <typename T>
  void next(T& value)
  {
    IStream::next(value);
  }

  /// Its length, then the bytes. Throws StreamOverrunException on a short buffer, as roscpp does.
  void next(std::vector<std::uint8_t>& bytes)
  {
    std::uint32_t length = 0;
    IStream::next(length);
    const std::uint8_t* const begin = advance(length);
    bytes.assign(begin, begin + length);
  }
};

/// Reads M from `stream` in the field order of roscpp's generated serializer, its top-level
/// uint8[] fields copied once (CopyOnceStream); the stream is left after the message.
template <class M>
void read(ros::serialization::IStream& stream, M& message)
{
  CopyOnceStream copy_once(stream.getData(), stream.getLength());
  ros::serialization::Serializer<M>::read(copy_once, message);
  stream.advance(stream.getLength() - copy_once.getLength());
}
}  // namespace wire

/// roscpp's callback helper for M with the reader above in place of roscpp's deserialiser.
template <class M>
class CopyOnceCallbackHelper : public ros::SubscriptionCallbackHelperT<const boost::shared_ptr<const M>&>
{
public:
  using Base = ros::SubscriptionCallbackHelperT<const boost::shared_ptr<const M>&>;
  using Base::Base;

  ros::VoidConstPtr deserialize(const ros::SubscriptionCallbackHelperDeserializeParams& params) override
  {
    auto message = boost::make_shared<M>();
    ros::serialization::IStream stream(params.buffer, params.length);
    wire::read(stream, *message);
    return message;
  }
};

/// nh.subscribe(topic, queue_size, callback) for M (PointCloud2, Image), copying its bytes once.
template <class M>
ros::Subscriber subscribeCopyingOnce(ros::NodeHandle& nh, const std::string& topic, std::uint32_t queue_size,
                                     const std::function<void(const boost::shared_ptr<const M>&)>& callback)
{
  ros::SubscribeOptions options;
  options.template init<M>(topic, queue_size, callback);
  options.helper = boost::make_shared<CopyOnceCallbackHelper<M>>(callback);
  return nh.subscribe(options);
}

}  // namespace depth_filter_scan_converter
