// ROS glue of the range converter: parameters, lazy subscription, publishing, diagnostics.
// Shared by RangeScanConverterNodelet and range_scan_converter_node.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>
#include <sensor_msgs/Range.h>

#include <array>
#include <cstdint>
#include <mutex>
#include <string>

#include "depth_filter_scan_converter/range_to_scan.hpp"

namespace depth_filter_scan_converter
{
/// Reads every parameter from the private namespace (defaults from RangeScanParameters) and
/// validates. Throws std::invalid_argument naming the parameter that is wrong (type or value).
RangeScanParameters loadRangeScanParameters(const ros::NodeHandle& private_nh);

class RangeScanConverter
{
public:
  /// Topics (range_in, scan) live in nh; parameters in private_nh.
  /// Throws std::invalid_argument (naming the parameter) on a bad configuration.
  RangeScanConverter(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~RangeScanConverter();

  RangeScanConverter(const RangeScanConverter&) = delete;
  RangeScanConverter& operator=(const RangeScanConverter&) = delete;

private:
  void connectCallback();
  void rangeArrived(const sensor_msgs::Range::ConstPtr& msg);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

  ros::NodeHandle nh_, private_nh_;
  int queue_size_ = 10;
  ros::Subscriber range_sub_;
  ros::Publisher scan_pub_;
  std::mutex connect_mutex_;  // taken before advertise: the connect callback may fire during it

  std::mutex mutex_;  // converter state and statistics
  RangeToScan converter_;
  ArcScan arc_;

  diagnostic_updater::Updater updater_;
  ros::Timer diagnostics_timer_;
  std::uint64_t received_ = 0, published_ = 0, malformed_ = 0;
  std::array<std::uint64_t, kReadingKinds> per_kind_{};  // readings of each ReadingKind
  std::uint64_t received_at_last_report_ = 0, malformed_at_last_report_ = 0;
  double last_stamp_ = 0.0;
  std::string last_malformed_reason_;
  ros::WallTime last_report_, warned_malformed_;
};

}  // namespace depth_filter_scan_converter
