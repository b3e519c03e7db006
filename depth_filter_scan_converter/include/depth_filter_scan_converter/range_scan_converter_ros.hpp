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
#include "depth_filter_scan_converter/converter_glue.hpp"
#include "laserscan_common/parameter_reader.hpp"

namespace depth_filter_scan_converter
{
/// Reads every field of RangeScanParameters' table from the private namespace (defaults from the
/// struct), validates, and warns about unknown private parameters. Throws
/// laserscan_common::ParameterError naming the parameter that is wrong (type or value).
RangeScanParameters loadRangeScanParameters(const ros::NodeHandle& private_nh);

class RangeScanConverter
{
public:
  /// Topics (range_in, scan) live in nh; parameters in private_nh.
  /// Throws laserscan_common::ParameterError on a bad configuration.
  RangeScanConverter(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~RangeScanConverter();

  RangeScanConverter(const RangeScanConverter&) = delete;
  RangeScanConverter& operator=(const RangeScanConverter&) = delete;

private:
  void rangeArrived(const sensor_msgs::Range::ConstPtr& msg);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

  ros::NodeHandle nh_, private_nh_;
  const RangeScanParameters params_;  // read and validated first
  ros::Subscriber range_sub_;
  ros::Publisher scan_pub_;
  LazySubscription lazy_;

  std::mutex mutex_;  // converter state and statistics
  RangeToScan converter_;
  ArcScan arc_;

  std::uint64_t received_ = 0, published_ = 0, malformed_ = 0;
  std::array<std::uint64_t, kReadingKinds> per_kind_{};  // readings of each ReadingKind
  std::uint64_t malformed_at_last_report_ = 0;
  RateMeter rate_;
  double last_stamp_ = 0.0;
  std::string last_malformed_reason_;
  WarningThrottle warn_malformed_;
  NodeDiagnostics diagnostics_;  // last: its timer may call diagnose() as soon as it exists
};

}  // namespace depth_filter_scan_converter
