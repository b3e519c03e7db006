// ROS glue of the converter: parameters, lazy subscription, tf, publishing, tuning, diagnostics.
// Shared by the nodelet and the standalone node.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <message_filters/subscriber.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>
#include <tf2_ros/transform_listener.h>

#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "depth_filter_scan_converter/DepthFilterScanConverterConfig.h"
#include "depth_filter_scan_converter/parameters.h"
#include "depth_filter_scan_converter/projector.h"

namespace depth_filter_scan_converter
{
/// Reads every parameter from the private namespace (defaults from Parameters) and validates.
/// Throws std::invalid_argument naming the parameter that is wrong (type or value).
Parameters loadParameters(const ros::NodeHandle& private_nh);

class DepthFilterScanConverter
{
public:
  /// Topics (cloud_in, scan, filtered_cloud) live in nh; parameters in private_nh.
  /// Throws std::invalid_argument (naming the parameter) on a bad configuration.
  DepthFilterScanConverter(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~DepthFilterScanConverter();

  DepthFilterScanConverter(const DepthFilterScanConverter&) = delete;
  DepthFilterScanConverter& operator=(const DepthFilterScanConverter&) = delete;

private:
  using Cloud = sensor_msgs::PointCloud2;
  using Config = DepthFilterScanConverterConfig;

  void connectCallback();
  void cloudArrived(const Cloud::ConstPtr& cloud);
  void transformFailed(const Cloud::ConstPtr& cloud, tf2_ros::filter_failure_reasons::FilterFailureReason reason);
  void process(const Cloud::ConstPtr& cloud);
  void reconfigure(Config& config, std::uint32_t level);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);
  bool takeArrival(const Cloud* cloud, ros::Time& arrival);
  /// Why the header cannot reach tf2 ("" when it can); warns once about a leading '/'.
  std::string headerProblem(const std_msgs::Header& header);
  /// Counts a malformed message and warns, throttled per kind of defect.
  void dropMalformed(const std::string& reason, const std::string& frame_id);
  /// Throttling per converter (ROS_WARN_THROTTLE keeps one timer per call site, shared by every
  /// converter in a manager: one camera's trouble would hide another's).
  static bool due(ros::WallTime& last, double period = 5.0);

  ros::NodeHandle nh_, private_nh_;
  Parameters params_;
  int queue_size_ = 10;

  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  message_filters::Subscriber<Cloud> cloud_sub_;
  std::unique_ptr<tf2_ros::MessageFilter<Cloud>> tf_filter_;
  ros::Publisher scan_pub_, cloud_pub_;
  std::mutex connect_mutex_;  // taken before advertise: the connect callback may fire during it
  bool subscribed_ = false;

  std::mutex mutex_;  // projector, parameters, statistics
  Projector projector_;
  std::vector<float> kept_points_;
  std::deque<std::pair<const Cloud*, ros::Time>> arrivals_;  // when each waiting cloud came in

  std::unique_ptr<dynamic_reconfigure::Server<Config>> reconfigure_server_;
  bool first_reconfigure_ = true;

  diagnostic_updater::Updater updater_;
  ros::Timer diagnostics_timer_;
  // Statistics since start and since the last diagnostics update.
  std::uint64_t received_ = 0, published_ = 0, tf_failures_ = 0, malformed_ = 0, stale_ = 0;
  std::uint64_t received_at_last_report_ = 0, malformed_at_last_report_ = 0, tf_failures_at_last_report_ = 0,
                stale_at_last_report_ = 0;
  ros::WallTime last_report_;
  double last_ms_ = 0.0, max_ms_ = 0.0, sum_ms_ = 0.0;
  std::string last_malformed_reason_, last_tf_reason_;
  bool warned_slash_ = false;
  ros::WallTime warned_tf_, warned_late_, warned_malformed_, warned_intensity_;
};

}  // namespace depth_filter_scan_converter
