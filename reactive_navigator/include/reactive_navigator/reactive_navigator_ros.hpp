// ROS glue of the navigator: goal, tf pose, LaserScan and PointCloud2 obstacles in; cmd_vel,
// ~state, ~step and /diagnostics out. One class shared by the nodelet and the node.
#pragma once

#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <diagnostic_updater/diagnostic_updater.h>
#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2/buffer_core.h>

#include "laserscan_common/cloud_view.hpp"
#include "laserscan_common/node_glue.hpp"
#include "laserscan_common/parameter_reader.hpp"
#include "laserscan_common/throttle.hpp"
#include "laserscan_common/transform_reader.hpp"
#include "reactive_navigator/navigator_core.hpp"

namespace reactive_navigator
{

/// Reads the private parameters through laserscan_common's strict reader (one rule for numbers;
/// unknown ones named once) and validates; throws ParameterError naming the parameter.
void readParameters(laserscan_common::ParameterReader& reader, NavigatorParameters& navigator, NodeParameters& node);

class ReactiveNavigatorRos
{
public:
  ReactiveNavigatorRos(ros::NodeHandle nh, ros::NodeHandle private_nh);

private:
  // The messages of one obstacle topic, oldest first (a few: a step takes the newest stamped up to
  // its time, and newer ones may already be there).
  // A cloud that passed laserscan_common::makeCloudView, with its view (into the message's bytes,
  // which the message keeps).
  struct CloudMessage
  {
    sensor_msgs::PointCloud2::ConstPtr message;
    laserscan_common::CloudView view;
  };
  struct Source
  {
    std::string topic;
    bool is_cloud = false;
    std::deque<sensor_msgs::LaserScan::ConstPtr> scans;
    std::deque<CloudMessage> clouds;
    ros::Time newest_stamp;
  };

  void goalArrived(const geometry_msgs::PoseStamped::ConstPtr& goal);
  bool tryPendingGoal(bool give_up_when_late);  // true when it became the core's goal
  void scanArrived(std::size_t source, const sensor_msgs::LaserScan::ConstPtr& scan);
  void cloudArrived(std::size_t source, const sensor_msgs::PointCloud2::ConstPtr& cloud);
  void timerStep(const ros::TimerEvent& event);
  void lockstepWatchdog(const ros::WallTimerEvent& event);
  void tryLockstepStep();
  bool poseAt(const ros::Time& time, bool latest, Pose2& pose);
  void collectObstacles(const ros::Time& time, bool up_to_time);
  void runStep(const ros::Time& time, bool latest_pose);
  ros::Time onGrid(const ros::Time& time, long& index) const;
  void publishState();                      // ~state when it changed (latched)
  void publishPlan(const ros::Time& time);  // ~plan when the planner's path changed (latched)
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);
  void warn(const std::string& kind, const std::string& text);

  NavigatorParameters navigator_parameters_;
  NodeParameters parameters_;
  std::unique_ptr<NavigatorCore> core_;

  ros::NodeHandle nh_, private_nh_;
  tf2::BufferCore tf_buffer_;
  std::unique_ptr<laserscan_common::TransformReader> tf_reader_;
  ros::Subscriber goal_sub_;
  std::vector<ros::Subscriber> obstacle_subs_;
  ros::Publisher cmd_pub_, state_pub_, step_pub_, plan_pub_;
  std::vector<Eigen::Vector2d> published_plan_;
  ros::Timer step_timer_;
  ros::WallTimer watchdog_timer_, retry_timer_;
  laserscan_common::NodeDiagnostics diagnostics_;
  laserscan_common::WarningThrottle throttle_;

  std::mutex mutex_;  // the callbacks may run on several threads (a nodelet manager)
  std::vector<Source> sources_;
  geometry_msgs::PoseStamped::ConstPtr pending_goal_;  // waiting for its transform
  ros::WallTime pending_since_;
  ObstaclePoints points_;
  std::vector<Observation> observations_;  // points_ by source, with each sensor's origin
  long next_step_ = -1;                    // lockstep: grid index of the next step (time = index / rate)
  ros::WallTime waiting_since_;            // lockstep: when the pending step started waiting
  NavigationState published_state_ = NavigationState::Idle;
  bool state_published_ = false;
  // Diagnostics since the last report.
  double cpu_sum_ = 0.0;
  double cpu_max_ = 0.0;
  std::size_t points_sum_ = 0;
  std::size_t self_points_sum_ = 0;
  std::size_t remembered_points_sum_ = 0;  // of points_sum_, from the obstacle memory
  std::size_t steps_ = 0;
  std::size_t steps_total_ = 0;
};

}  // namespace reactive_navigator
