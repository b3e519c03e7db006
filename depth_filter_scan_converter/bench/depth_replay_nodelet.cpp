// A depth camera stand-in for node-level benchmarks: it records a few depth images and one
// camera_info (from a bag being played, or from the benchmark), then publishes them again and
// again at a fixed rate, with fresh stamps, from inside the nodelet manager. Consumers in the same
// manager get every frame by shared pointer (zero copy), as they would from a camera driver
// nodelet (openni2_camera, realsense2_camera, depth_image_proc); each frame is a fresh message,
// filled by copying the recorded one, as a driver fills its message from the device's buffer.
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <boost/make_shared.hpp>
#include <cmath>
#include <string>
#include <vector>

#include "laserscan_common/entry_points.hpp"
#include "laserscan_common/node_log.hpp"
#include "laserscan_common/parameter_reader.hpp"

namespace depth_filter_scan_converter
{
class DepthReplay
{
public:
  /// Throws ParameterError on a bad `rate` or `frames` (the entry point reports it).
  DepthReplay(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh), name_(pnh.getNamespace())
  {
    laserscan_common::ParameterReader reader(pnh);
    reader.read("rate", rate_);
    reader.read("frames", frame_count_);
    reader.warnUnknown();
    if (!std::isfinite(rate_) || rate_ <= 0.0)
      throw laserscan_common::ParameterError("rate", "must be a positive number of frames per second");
    if (frame_count_ < 1)
      throw laserscan_common::ParameterError("frames", "must be at least 1");
    image_pub_ = nh_.advertise<sensor_msgs::Image>("image", 5);
    info_pub_ = nh_.advertise<sensor_msgs::CameraInfo>("camera_info", 5);
    image_sub_ = nh_.subscribe("image_in", 10, &DepthReplay::imageIn, this);
    info_sub_ = nh_.subscribe("camera_info_in", 10, &DepthReplay::infoIn, this);
    NODE_INFO(
      name_, "recording %d depth images from %s (and a camera_info from %s), then replaying them at %g Hz on %s",
      frame_count_, image_sub_.getTopic().c_str(), info_sub_.getTopic().c_str(), rate_, image_pub_.getTopic().c_str());
  }

private:
  void imageIn(const sensor_msgs::ImageConstPtr& image)
  {
    if (frames_.size() < static_cast<std::size_t>(frame_count_))
      frames_.push_back(image);
    startWhenRecorded();
  }

  void infoIn(const sensor_msgs::CameraInfoConstPtr& info)
  {
    info_ = info;
    startWhenRecorded();
  }

  void startWhenRecorded()
  {
    if (timer_ || !info_ || frames_.size() < static_cast<std::size_t>(frame_count_))
      return;
    image_sub_.shutdown();
    info_sub_.shutdown();
    NODE_INFO(name_, "recorded %zu depth images: replaying", frames_.size());
    timer_ = nh_.createWallTimer(ros::WallDuration(1.0 / rate_), &DepthReplay::publishFrame, this);
  }

  void publishFrame(const ros::WallTimerEvent&)
  {
    auto image = boost::make_shared<sensor_msgs::Image>(*frames_[next_frame_]);
    auto info = boost::make_shared<sensor_msgs::CameraInfo>(*info_);
    next_frame_ = (next_frame_ + 1) % frames_.size();
    image->header.stamp = ros::Time::now();
    info->header = image->header;
    info_pub_.publish(info);
    image_pub_.publish(image);
  }

  ros::NodeHandle nh_;
  std::string name_;  ///< for messages
  double rate_ = 15.0;
  int frame_count_ = 8;
  std::vector<sensor_msgs::ImageConstPtr> frames_;
  sensor_msgs::CameraInfoConstPtr info_;
  std::size_t next_frame_ = 0;
  ros::Subscriber image_sub_, info_sub_;
  ros::Publisher image_pub_, info_pub_;
  ros::WallTimer timer_;
};

/// The replay in a nodelet manager (laserscan_common's entry point: a bad parameter is its FATAL).
class DepthReplayNodelet : public laserscan_common::NodeletOf<DepthReplay>
{};
}  // namespace depth_filter_scan_converter

PLUGINLIB_EXPORT_CLASS(depth_filter_scan_converter::DepthReplayNodelet, nodelet::Nodelet)
