// Subscriptions to clouds and depth images that copy each message's bytes once.
//
// roscpp deserialises a uint8[] field with resize() then memcpy: resize() zero-fills the whole
// buffer first, a second pass over every cloud or image that costs as much as the copy (about
// 0.1 ms per 52k-point cloud, 1 ms per 640 x 480 cloud). These subscriptions read the same
// message type from the same wire format, copying the bytes straight from the socket's buffer.
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
/// A uint8[] field: its length, then the bytes, copied once. Throws ros::serialization's
/// StreamOverrunException on a short buffer, as roscpp's own reader does.
inline void readBytes(ros::serialization::IStream& stream, std::vector<std::uint8_t>& bytes)
{
  std::uint32_t length = 0;
  stream.next(length);
  const std::uint8_t* const begin = stream.advance(length);
  bytes.assign(begin, begin + length);  // copies, without the zero-fill of resize()
}

/// The fields in the order of sensor_msgs/PointCloud2's definition.
inline void read(ros::serialization::IStream& stream, sensor_msgs::PointCloud2& cloud)
{
  stream.next(cloud.header);
  stream.next(cloud.height);
  stream.next(cloud.width);
  stream.next(cloud.fields);
  stream.next(cloud.is_bigendian);
  stream.next(cloud.point_step);
  stream.next(cloud.row_step);
  readBytes(stream, cloud.data);
  stream.next(cloud.is_dense);
}

/// The fields in the order of sensor_msgs/Image's definition.
inline void read(ros::serialization::IStream& stream, sensor_msgs::Image& image)
{
  stream.next(image.header);
  stream.next(image.height);
  stream.next(image.width);
  stream.next(image.encoding);
  stream.next(image.is_bigendian);
  stream.next(image.step);
  readBytes(stream, image.data);
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

/// nh.subscribe(topic, queue_size, callback) for M = PointCloud2 or Image, copying bytes once.
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
