// ROS glue of the converter: parameters, lazy subscription, tf, publishing, tuning, diagnostics.
// Shared by the nodelet and the standalone node.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <message_filters/pass_through.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/exact_time.h>
#include <message_filters/synchronizer.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "depth_filter_scan_converter/DepthFilterScanConverterConfig.h"
#include "depth_filter_scan_converter/projector.hpp"
#include "depth_filter_scan_converter/converter_glue.hpp"
#include "depth_filter_scan_converter/copy_once_subscription.hpp"
#include "depth_filter_scan_converter/depth_image_view.hpp"
#include "depth_filter_scan_converter/parameters.hpp"
#include "laserscan_common/message_checks.hpp"
#include "laserscan_common/parameter_reader.hpp"
#include "laserscan_common/self_filter.hpp"
#include "laserscan_common/transform_reader.hpp"
#include "laserscan_common/transform_wait.hpp"

namespace depth_filter_scan_converter
{
/// A depth image with the camera_info of its stamp, as it waits for its transform.
struct CameraFrame
{
  std_msgs::Header header;  ///< the image's
  sensor_msgs::Image::ConstPtr image;
  sensor_msgs::CameraInfo::ConstPtr info;
};

/// Reads every field of Parameters' table from the private namespace (defaults from the struct)
/// and validates. Throws laserscan_common::ParameterError naming the parameter that is wrong.
Parameters loadParameters(laserscan_common::ParameterReader& reader);

/// What the converter reads: a PointCloud2 on cloud_in, or a depth image on image with its
/// CameraInfo on camera_info (the pixels are turned into points inside the projection).
enum class DepthInput
{
  Cloud,
  Image
};

/// How clouds that come over a connection (TCP, not from a nodelet in the same manager) are read.
enum class CloudReading
{
  /// Copied once out of roscpp's receive buffer. The only safe way in a nodelet manager, where
  /// other nodelets may subscribe to the same topic: roscpp gives them the message it read for us.
  CopyOnce,
  /// Converted straight from roscpp's receive buffer when the cloud's transform is already there
  /// (no copy at all), otherwise copied once. For a standalone node, the one subscriber to its
  /// input in its process.
  InPlace
};

class DepthFilterScanConverter
{
public:
  /// Topics (cloud_in or image + camera_info, scan, filtered_cloud) live in nh; parameters in
  /// private_nh. Throws laserscan_common::ParameterError on a bad configuration.
  DepthFilterScanConverter(ros::NodeHandle nh, ros::NodeHandle private_nh, DepthInput input = DepthInput::Cloud,
                           CloudReading reading = CloudReading::CopyOnce);
  ~DepthFilterScanConverter();

  DepthFilterScanConverter(const DepthFilterScanConverter&) = delete;
  DepthFilterScanConverter& operator=(const DepthFilterScanConverter&) = delete;

private:
  using Cloud = sensor_msgs::PointCloud2;
  using Image = sensor_msgs::Image;
  using CameraInfo = sensor_msgs::CameraInfo;
  using Config = DepthFilterScanConverterConfig;
  using ImageSync = message_filters::Synchronizer<message_filters::sync_policies::ExactTime<Image, CameraInfo>>;

  /// The lazy subscription's actions (its lock held).
  void subscribeInput();
  void unsubscribeInput();
  /// A cloud from the subscription: header checks, then converted or left to wait for its transform.
  void cloudArrived(const Cloud::ConstPtr& cloud);
  /// A message that waited for its transform in vain (why: as transformWaitFailure says).
  void transformFailed(const std_msgs::Header& header, const std::string& why);
  /// CloudReading::InPlace: takes a cloud whose bytes are still in roscpp's receive buffer and
  /// converts it (or drops it for a header that cannot reach tf2) if its transform is there; false
  /// leaves it to the usual path (cloudArrived), copied, to wait for its transform.
  bool convertInPlace(const Cloud& cloud, const std::uint8_t* bytes, std::size_t size);
  /// Freshness, view, projection, publishing; mutex_ held. `bytes` and `size` are the message's
  /// data, wherever they are; `info` is an image's camera_info (null for a cloud). `received` is
  /// zero for a message that never waited for its transform.
  template <class M>
  void convert(const M& message, const std::uint8_t* bytes, std::size_t size, const CameraInfo::ConstPtr& info,
               const ros::Time& received);
  std::string viewOf(const Cloud& cloud, const std::uint8_t* bytes, std::size_t size, const CameraInfo::ConstPtr& info,
                     CloudView& view);
  std::string viewOf(const Image& image, const std::uint8_t* bytes, std::size_t size, const CameraInfo::ConstPtr& info,
                     DepthImageView& view);
  void imageArrived(const Image::ConstPtr& image, const CameraInfo::ConstPtr& info);
  /// The synchronizer let go of an image whose camera_info never came (or of a lone camera_info).
  void imageDropped(const Image::ConstPtr& image, const CameraInfo::ConstPtr& info);
  void reconfigure(Config& config, std::uint32_t level);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);
  /// Why the header cannot reach tf2 ("" when it can); warns once about a leading '/'.
  std::string headerProblem(const std_msgs::Header& header);
  /// What a new input's header allows (mutex_ held): dropped as malformed (counted and warned
  /// here), converted now (its transform is there), or waiting for its transform.
  enum class Admission
  {
    Dropped,
    Ready,
    Wait
  };
  Admission admit(const std_msgs::Header& header);
  /// Counts a malformed message and warns, throttled per kind of defect.
  void dropMalformed(const std::string& reason, const std::string& frame_id);

  ros::NodeHandle nh_, private_nh_;
  const DepthInput input_;
  const CloudReading reading_;
  std::string input_topic_;                   // resolved, for messages
  laserscan_common::ParameterReader reader_;  // knows every name read, for the unknown-key warning
  Parameters params_;
  int queue_size_;

  tf2_ros::Buffer tf_buffer_;
  std::unique_ptr<laserscan_common::TransformReader> tf_reader_;  // feeds tf_buffer_ from /tf and /tf_static
  ros::Subscriber input_sub_;  // the clouds or the depth images (copy_once_subscription.hpp)
  std::unique_ptr<laserscan_common::TransformWait<Cloud>> cloud_wait_;
  // Images wait for the camera_info of their stamp (ExactTime, queue_size frames), as
  // image_transport's CameraSubscriber does, then for their transform.
  message_filters::PassThrough<Image> image_in_;  // input_sub_'s images, into the synchronizer
  message_filters::Subscriber<CameraInfo> info_sub_;
  std::unique_ptr<ImageSync> image_sync_;
  std::unique_ptr<laserscan_common::TransformWait<CameraFrame>> image_wait_;
  ros::Publisher scan_pub_, cloud_pub_;
  LazySubscription lazy_;

  std::mutex mutex_;  // projector, parameters, statistics
  Projector projector_;
  /// The robot's own parts (the `self_filter` block; empty: off), posed at each cloud's stamp.
  laserscan_common::SelfFilter self_filter_;
  /// Frames a message waits for: reference_frame, then the self filter's.
  std::vector<std::string> tf_targets_;
  std::vector<float> kept_points_;

  std::unique_ptr<dynamic_reconfigure::Server<Config>> reconfigure_server_;
  bool first_reconfigure_ = true;

  // Statistics since start and since the last diagnostics update.
  std::uint64_t received_ = 0, published_ = 0, tf_failures_ = 0, malformed_ = 0, stale_ = 0, without_info_ = 0,
                read_in_place_ = 0;
  std::uint64_t malformed_at_last_report_ = 0, tf_failures_at_last_report_ = 0, stale_at_last_report_ = 0,
                without_info_at_last_report_ = 0;
  RateMeter rate_;
  double last_ms_ = 0.0, max_ms_ = 0.0, sum_ms_ = 0.0;
  std::string last_malformed_reason_, last_tf_reason_;
  laserscan_common::FrameIdNormaliser frame_id_;  // warns once about a leading '/'
  WarningThrottle warnings_;     // per kind of fault: a missing transform, a late cloud, each malformed kind, ...
  NodeDiagnostics diagnostics_;  // last: its timer may call diagnose() as soon as it exists
};

}  // namespace depth_filter_scan_converter

namespace ros::message_traits
{
// A CameraFrame waits in tf2_ros's MessageFilter by its header, as the image would.
template <>
struct HasHeader<depth_filter_scan_converter::CameraFrame> : TrueType
{};
}  // namespace ros::message_traits
