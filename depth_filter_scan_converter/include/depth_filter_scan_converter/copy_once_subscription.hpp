// Subscriptions to clouds and depth images that copy each message's bytes at most once.
//
// roscpp deserialises a uint8[] field with resize() then memcpy: resize() zero-fills the whole
// buffer first, a second pass over every cloud or image that costs as much as the copy (about
// 0.1 ms per 52k-point cloud, 1 ms per 640 x 480 cloud). These subscriptions read the same
// message type from the same wire format with roscpp's own serializer, copying the bytes straight
// from the socket's buffer.
// The subscriber's C++ type stays sensor_msgs::PointCloud2 / Image, so a publisher in the same
// nodelet manager still hands over its shared pointer (no deserialisation at all).
//
// A subscription that is the only one to its topic in its process (a standalone node) may also
// read messages in place: a reader sees each message with its bytes still in roscpp's receive
// buffer and may take it there, with no copy at all.
#pragma once

#include <ros/ros.h>
#include <ros/subscription_callback_helper.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>

#include <boost/make_shared.hpp>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace depth_filter_scan_converter
{
namespace wire
{
/// roscpp's input stream with one change: a uint8[] field (a cloud's or an image's data) is not
/// read into its vector, which stays empty; the stream remembers where its bytes are in the
/// buffer. For a message with one such field (PointCloud2, Image: `data`). Every other field is
/// read by roscpp's code.
class BorrowingStream : public ros::serialization::IStream
{
public:
  using IStream::IStream;

  template <typename T>
  void next(T& value)
  {
    IStream::next(value);
  }

  /// Its length, then the bytes, skipped. Throws StreamOverrunException on a short buffer, as
  /// roscpp does.
  void next(std::vector<std::uint8_t>& bytes)
  {
    std::uint32_t length = 0;
    IStream::next(length);
    bytes_ = advance(length);
    size_ = length;
    bytes.clear();
  }

  const std::uint8_t* bytes() const { return bytes_; }
  std::size_t size() const { return size_; }

private:
  const std::uint8_t* bytes_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace wire

/// Takes a message straight from roscpp's receive buffer, in the thread that would run its
/// callback: `message` holds every field but `data`, whose bytes are [bytes, bytes + size) in that
/// buffer, valid during the call only. Returns true when it has taken the message, which then goes
/// no further (no copy, no callback); false to have it copied and delivered as usual.
///
/// Only for a subscription that is the only one to its topic in the process: roscpp hands the
/// message it deserialised for the first callback of a topic to every callback with the same C++
/// type, and a message taken in place reaches none of them.
template <class M>
using InPlaceReader = std::function<bool(const M& message, const std::uint8_t* bytes, std::size_t size)>;

/// roscpp's callback helper for M with the readers above in place of roscpp's deserialiser.
template <class M>
class CopyOnceCallbackHelper : public ros::SubscriptionCallbackHelperT<const boost::shared_ptr<const M>&>
{
public:
  using Base = ros::SubscriptionCallbackHelperT<const boost::shared_ptr<const M>&>;

  explicit CopyOnceCallbackHelper(const typename Base::Callback& callback, InPlaceReader<M> in_place = {})
    : Base(callback), in_place_(std::move(in_place))
  {}

  /// Null when the in-place reader took the message (roscpp then calls no callback).
  ros::VoidConstPtr deserialize(const ros::SubscriptionCallbackHelperDeserializeParams& params) override
  {
    auto message = boost::make_shared<M>();
    wire::BorrowingStream stream(params.buffer, params.length);
    ros::serialization::Serializer<M>::read(stream, *message);
    if (in_place_ && in_place_(*message, stream.bytes(), stream.size()))
      return {};
    message->data.assign(stream.bytes(), stream.bytes() + stream.size());
    return message;
  }

private:
  InPlaceReader<M> in_place_;
};

/// nh.subscribe(topic, queue_size, callback) for M (PointCloud2, Image), copying its bytes once;
/// with `in_place`, a message that reader takes is not copied at all (see InPlaceReader: only for
/// the one subscription to its topic in the process).
template <class M>
ros::Subscriber subscribeCopyingOnce(ros::NodeHandle& nh, const std::string& topic, std::uint32_t queue_size,
                                     const std::function<void(const boost::shared_ptr<const M>&)>& callback,
                                     InPlaceReader<M> in_place = {})
{
  ros::SubscribeOptions options;
  options.template init<M>(topic, queue_size, callback);
  options.helper = boost::make_shared<CopyOnceCallbackHelper<M>>(callback, std::move(in_place));
  return nh.subscribe(options);
}

}  // namespace depth_filter_scan_converter
