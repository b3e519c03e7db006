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

#include "laserscan_common/message_checks.hpp"
#include "laserscan_common/parameter_reader.hpp"
#include "laserscan_common/node_glue.hpp"
#include "laserscan_common/throttle.hpp"
#include "laserscan_common/transform_reader.hpp"
#include "laserscan_common/transform_wait.hpp"
#include "multi_laserscan_merger/merger_core.hpp"
#include "multi_laserscan_merger/stamp_sync.hpp"

namespace multi_laserscan_merger
{

/// Reads every parameter of MergerParams' tables from the private namespace (defaults from the
/// structs); throws ParameterError naming the parameter (wrong type, unknown source key, failed
/// check).
MergerParams loadParams(laserscan_common::ParameterReader& reader);

class MultiLaserScanMergerRos
{
public:
  /// Throws ParameterError on a bad configuration (nothing is subscribed then).
  MultiLaserScanMergerRos(ros::NodeHandle nh, ros::NodeHandle private_nh);

  /// How long a scan may wait for its transform (s) before it is dropped.
  static constexpr double kTransformWait = 0.2;
  /// Odometry older than this (s) relative to the output time is reported as stopped.
  static constexpr double kOdometryStale = 0.5;
  /// Name of the merged scan's topic (in the node's namespace; remap it). Not "scan": that is
  /// the usual topic of a lidar driver, which a remap of the output would rewire to itself.
  static constexpr const char* kOutputTopic = "merged_scan";

private:
  struct SourceState
  {
    sensor_msgs::LaserScan::ConstPtr scan;  ///< latest accepted scan
    ScanView view;                          ///< of `scan`, checked once on arrival
    Eigen::Isometry3d output_T_sensor = Eigen::Isometry3d::Identity();
    /// The robot's parts as configured for this source (unposed; empty: no self filter).
    laserscan_common::SelfFilter self_filter;
    /// The same, posed in the sensor's frame for `scan` (each scan carries its own poses: with
    /// sync_window a newer scan may arrive before an older one is merged).
    laserscan_common::SelfFilter scan_self_filter;
    /// The scans waiting for their transforms (one deep: a newer scan replaces a waiting one).
    std::unique_ptr<laserscan_common::TransformWait<sensor_msgs::LaserScan>> wait;
    /// The scan waiting for its transform; one that comes back from `wait` but is no longer
    /// this one was given up on (replaced, superseded, cleared) and is ignored.
    sensor_msgs::LaserScan::ConstPtr pending;
    std::string pending_frame;  ///< its frame id as tf2 wants it
    ros::WallTime pending_since;
    std::string pending_error;
    laserscan_common::FrameIdNormaliser frame_id;  ///< reports a leading '/' once per source
    /// Per source and kind of fault: one source's (or merger's) fault never hides another's,
    /// which ROS_WARN_THROTTLE's one timer per call site in the whole manager would.
    laserscan_common::WarningThrottle warnings;
    // Diagnostics.
    std::size_t received = 0;
    laserscan_common::RateMeter rate;  ///< scans per second between two reports
    std::size_t timeouts = 0, transform_failures = 0, malformed = 0;
    std::size_t dropped = 0, dropped_at_last_report = 0;  ///< malformed + transform failures
    std::string last_drop;                                ///< why the last scan was dropped
    double last_timed_out_stamp = -1.0;
    std::size_t waited_for = 0;         ///< outputs that waited for its scan of their stamp (sync_window)
    std::size_t missing_at_window = 0;  ///< outputs published without its due scan at the window's end
    ros::Subscriber sub;
  };

  void scanCallback(std::size_t source, const sensor_msgs::LaserScan::ConstPtr& msg);
  void handleScan(std::size_t source, const sensor_msgs::LaserScan::ConstPtr& msg);
  void odomCallback(const nav_msgs::Odometry::ConstPtr& msg);
  void handleOdometry(const nav_msgs::Odometry::ConstPtr& msg);
  void timerCallback(const ros::TimerEvent&);

  // All below run with mutex_ held.
  void checkTimeJump();
  /// Warns (throttled per `kind` of cause) and clears every buffer.
  void clearAll(const std::string& why, const std::string& kind);
  /// output_T_sensor at stamp; the reason when tf2 has none or it is not finite ("" when found).
  std::string tryTransform(const std::string& frame, const ros::Time& stamp, Eigen::Isometry3d& output_T_sensor);
  /// Poses a copy of the source's self filter (if any) in the scan's frame into `posed`: at the
  /// scan's stamp, or at its middle beam's time when the source deskews. The reason ("" when
  /// posed) while a shape frame's transform is not there: the scan waits for it as for its own.
  std::string poseSelfFilter(std::size_t source, const sensor_msgs::LaserScan& msg, const std::string& frame,
                             laserscan_common::SelfFilter& posed);
  /// Keeps msg with the mount it was transformed with, unless an older scan than the one kept;
  /// with publish_rate 0 publishes (now or when the scans due at its stamp are in: outputs_).
  void accept(std::size_t source, const sensor_msgs::LaserScan::ConstPtr& msg, const ScanView& view,
              const Eigen::Isometry3d& output_T_sensor, laserscan_common::SelfFilter self_filter);
  /// publish_rate > 0: asks outputs_ whether to publish at the newest data (a tick, a scan while
  /// a tick waits, or the end of its window: `at_deadline`).
  void publishTick(bool at_deadline);
  void syncTimerCallback();
  void armSyncTimer(double deadline);
  /// Counts an output that waited or misses due scans, and names the late sources (throttled).
  void reportSync(const ros::Time& stamp, const StampSync::Decision& decision, bool waited);
  void drop(std::size_t source, std::string why);
  /// A scan back from its source's wait: its transforms came (`why` empty; received at `received`,
  /// wall time), or `why` they will not.
  void transformArrived(std::size_t source, const sensor_msgs::LaserScan::ConstPtr& msg, const ros::Time& received,
                        const std::string& why);
  /// Drops a waiting scan that waited longer than kTransformWait (its transforms did not come).
  void expirePending();
  /// Counts and warns about the waiting scan of `source` whose transforms did not come in time.
  void dropPending(std::size_t source, const std::string& error);
  /// t_out is the stamp of a scan or an odometry message: published bit for bit.
  void mergeAndPublish(const ros::Time& t_out);
  bool robotToOutput(Eigen::Isometry3d& out);
  void warnNoRobotTransform(const std::string& error);

  void sourceDiagnostics(std::size_t source, diagnostic_updater::DiagnosticStatusWrapper& stat);
  void odometryDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat);
  void outputDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat);

  ros::NodeHandle nh_, private_nh_;
  std::string name_;                          ///< for messages
  laserscan_common::ParameterReader reader_;  ///< knows every name read, for the unknown-key warning
  MergerParams params_;
  std::unique_ptr<MergerCore> core_;
  std::mutex mutex_;

  tf2_ros::Buffer tf_buffer_;
  std::unique_ptr<laserscan_common::TransformReader> tf_reader_;  ///< feeds tf_buffer_ from /tf and /tf_static
  std::vector<SourceState> sources_;
  OdometryBuffer odom_;
  std::string odom_topic_;  ///< resolved, for messages
  std::string odom_child_frame_;
  ros::Time odom_newest_;  ///< stamp of the newest entry of odom_ (zero when empty)
  ros::WallTime last_odom_arrival_;
  std::size_t odom_received_ = 0, odom_rejected_ = 0;
  std::string odom_last_rejection_;
  laserscan_common::FrameIdNormaliser odom_child_frame_id_;  ///< reports a leading '/' once
  laserscan_common::WarningThrottle warnings_;               ///< per kind, for what is not one source's

  std::vector<SourceInput> inputs_;  ///< reused across merges
  std::vector<SourceStatus> status_;
  /// A source's scan as it goes into the merge: the message, its mount at the scan's stamp and
  /// the robot's parts posed for it.
  struct ScanInMerge
  {
    sensor_msgs::LaserScan::ConstPtr msg;
    ScanView view;  ///< of msg, checked once on arrival
    Eigen::Isometry3d output_T_sensor;
    laserscan_common::SelfFilter self_filter;
  };
  /// When an output may be published (sources sharing stamps wait for each other, sync_window).
  std::unique_ptr<SyncedOutputs<ScanInMerge>> outputs_;
  /// Fires at the end of a window. Steady (wall) time: the window bounds the latency a consumer
  /// sees, and never stalls while a simulated clock stands still (a bag paused or ended); a bag
  /// played faster than real time still delivers the scans of one stamp close together in wall time.
  ros::SteadyTimer sync_timer_;
  std::size_t outputs_published_ = 0, outputs_waited_ = 0, outputs_incomplete_ = 0;
  std::size_t incomplete_at_last_report_ = 0;
  std::string last_incomplete_;  ///< the last output published without a due scan, and whose
  ros::Time last_now_;

  ros::Publisher pub_;
  ros::Subscriber odom_sub_;
  ros::Timer publish_timer_;
  std::unique_ptr<laserscan_common::NodeDiagnostics> diagnostics_;
};

}  // namespace multi_laserscan_merger
