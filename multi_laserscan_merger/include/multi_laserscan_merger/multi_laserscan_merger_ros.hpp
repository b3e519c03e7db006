// ROS glue of the merger: one class taking (nh, private_nh), shared by the nodelet and the
// standalone node. The math lives in the ROS-free core (merger_core.hpp).
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <diagnostic_updater/diagnostic_updater.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "multi_laserscan_merger/merger_core.hpp"

namespace multi_laserscan_merger
{

/// Reads every parameter from the private namespace; throws ParameterError naming the
/// parameter (wrong type, unknown key, failed check).
MergerParams loadParams(const ros::NodeHandle& private_nh);

class MultiLaserScanMergerRos
{
public:
  /// Throws ParameterError on a bad configuration (nothing is subscribed then).
  MultiLaserScanMergerRos(ros::NodeHandle nh, ros::NodeHandle private_nh);

  /// How long a scan may wait for its transform (s) before it is dropped.
  static constexpr double kTransformWait = 0.2;
  /// Odometry older than this (s) relative to the output time is reported as stopped.
  static constexpr double kOdometryStale = 0.5;

private:
  struct SourceState
  {
    sensor_msgs::LaserScan::ConstPtr scan;  ///< latest accepted scan
    Eigen::Isometry3d output_T_sensor = Eigen::Isometry3d::Identity();
    sensor_msgs::LaserScan::ConstPtr pending;  ///< waiting for its transform
    ros::WallTime pending_since;
    std::string pending_error;
    // Diagnostics.
    std::size_t received = 0, received_at_last_report = 0;
    std::size_t timeouts = 0, transform_failures = 0, malformed = 0;
    double last_timed_out_stamp = -1.0;
    ros::Subscriber sub;
  };

  void scanCallback(std::size_t source, const sensor_msgs::LaserScan::ConstPtr& msg);
  void odomCallback(const nav_msgs::Odometry::ConstPtr& msg);
  void timerCallback(const ros::TimerEvent&);

  // All below run with mutex_ held.
  void checkTimeJump();
  void clearAll(const std::string& why);
  bool tryTransform(std::size_t source, const sensor_msgs::LaserScan::ConstPtr& msg, std::string& error);
  void accept(std::size_t source, const sensor_msgs::LaserScan::ConstPtr& msg);
  void retryPending();
  void mergeAndPublish(double t_out);
  bool robotToOutput(Eigen::Isometry3d& out);

  void sourceDiagnostics(std::size_t source, diagnostic_updater::DiagnosticStatusWrapper& stat);
  void odometryDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat);

  ros::NodeHandle nh_, private_nh_;
  std::string name_;  ///< for messages
  MergerParams params_;
  std::unique_ptr<MergerCore> core_;
  std::mutex mutex_;

  tf2_ros::Buffer tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::vector<SourceState> sources_;
  OdometryBuffer odom_;
  std::string odom_child_frame_;
  ros::WallTime last_odom_arrival_;
  std::size_t odom_received_ = 0;

  std::vector<SourceInput> inputs_;  ///< reused across merges
  std::vector<SourceStatus> status_;
  MergedScan merged_;
  double last_published_ = -1.0;
  ros::Time last_now_;
  ros::WallTime last_report_;

  ros::Publisher pub_;
  ros::Subscriber odom_sub_;
  ros::Timer publish_timer_, diagnostics_timer_;
  std::unique_ptr<diagnostic_updater::Updater> updater_;
};

}  // namespace multi_laserscan_merger
