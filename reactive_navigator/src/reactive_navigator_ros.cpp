#include "reactive_navigator/reactive_navigator_ros.hpp"

#include <time.h>

#include <cmath>

#include <geometry_msgs/Twist.h>
#include <geometry_msgs/TwistStamped.h>
#include <std_msgs/String.h>
#include <tf2_eigen/tf2_eigen.h>

#include "laserscan_common/cloud_view.hpp"
#include "laserscan_common/message_checks.hpp"
#include "laserscan_common/node_log.hpp"
#include "laserscan_common/parameter_reader.hpp"
#include "reactive_navigator/obstacle_points.hpp"

namespace reactive_navigator
{

namespace
{

using XmlRpc::XmlRpcValue;

// The navigator's structured parameters, converted by laserscan_common's one rule for numbers.
Polygon toPolygon(XmlRpcValue& v, const std::string& name)
{
  laserscan_common::Polygon vertices;
  laserscan_common::fromXmlRpc(v, name, vertices);
  Polygon polygon;
  for (const auto& vertex : vertices)
    polygon.emplace_back(vertex[0], vertex[1]);
  return polygon;
}

double toNumber(XmlRpcValue& v, const std::string& name)
{
  double value = 0.0;
  laserscan_common::fromXmlRpc(v, name, value);
  return value;
}

double cpuSeconds()
{
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

constexpr double kStampEpsilon = 1e-6;  // s: stamps this close to a step's time count as that time
constexpr std::size_t kKeptMessages = 8;
constexpr double kGoalTransformWait = 2.0;  // wall s a goal waits for its transform

}  // namespace

void readParameters(laserscan_common::ParameterReader& reader, NavigatorParameters& p, NodeParameters& n)
{
  reader.readFields(p);
  XmlRpcValue v;
  if (reader.readRaw("footprint", v))
    p.footprint = toPolygon(v, "footprint");
  if (reader.readRaw("shape_3d", v))
  {
    if (v.getType() != XmlRpcValue::TypeArray)
      throw ParameterError("shape_3d", "must be a list of {height: m, polygon: [[x, y], ...]}");
    p.shape_3d.clear();
    for (int i = 0; i < v.size(); ++i)
    {
      const std::string name = "shape_3d[" + std::to_string(i) + "]";
      XmlRpcValue& level = v[i];
      if (level.getType() != XmlRpcValue::TypeStruct || !level.hasMember("height") || !level.hasMember("polygon"))
        throw ParameterError(name, "must be {height: m, polygon: [[x, y], ...]}");
      p.shape_3d.push_back(
        ShapeLevel{ toNumber(level["height"], name + ".height"), toPolygon(level["polygon"], name + ".polygon") });
    }
  }
  p.validate();

  reader.readFields(n);
  if (reader.readRaw("height_band", v))
  {
    if (v.getType() != XmlRpcValue::TypeArray || v.size() != 2)
      throw ParameterError("height_band", "must be [min, max] (m, robot frame)");
    n.height_band_min = toNumber(v[0], "height_band[0]");
    n.height_band_max = toNumber(v[1], "height_band[1]");
  }
  n.validate();
  reader.warnUnknown();
}

ReactiveNavigatorRos::ReactiveNavigatorRos(ros::NodeHandle nh, ros::NodeHandle private_nh)
  : nh_(nh), private_nh_(private_nh), diagnostics_(nh, private_nh)
{
  laserscan_common::ParameterReader reader(private_nh_);
  readParameters(reader, navigator_parameters_, parameters_);
  core_ = std::make_unique<NavigatorCore>(navigator_parameters_);
  parameters_.odom_frame = laserscan_common::tf2FrameId(parameters_.odom_frame);
  parameters_.robot_frame = laserscan_common::tf2FrameId(parameters_.robot_frame);

  tf_reader_ = std::make_unique<laserscan_common::TransformReader>(nh_, tf_buffer_, private_nh_.getNamespace());
  cmd_pub_ = nh_.advertise<geometry_msgs::Twist>("cmd_vel", 10);
  state_pub_ = private_nh_.advertise<std_msgs::String>("state", 1, true);
  step_pub_ = private_nh_.advertise<geometry_msgs::TwistStamped>("step", 10);
  plan_pub_ = private_nh_.advertise<nav_msgs::Path>("plan", 1, true);
  goal_sub_ = nh_.subscribe("move_base_simple/goal", 5, &ReactiveNavigatorRos::goalArrived, this);

  for (const auto& topic : parameters_.scan_topics)
  {
    sources_.push_back(Source{ topic, false, {}, {}, ros::Time() });
    const std::size_t index = sources_.size() - 1;
    obstacle_subs_.push_back(nh_.subscribe<sensor_msgs::LaserScan>(
      topic, 10, [this, index](const sensor_msgs::LaserScan::ConstPtr& m) { scanArrived(index, m); }));
  }
  for (const auto& topic : parameters_.cloud_topics)
  {
    sources_.push_back(Source{ topic, true, {}, {}, ros::Time() });
    const std::size_t index = sources_.size() - 1;
    obstacle_subs_.push_back(nh_.subscribe<sensor_msgs::PointCloud2>(
      topic, 10, [this, index](const sensor_msgs::PointCloud2::ConstPtr& m) { cloudArrived(index, m); }));
  }

  if (parameters_.lockstep)
  {
    // Steps run when their data are there (tryLockstepStep); the watchdog runs a step that
    // waited longer than lockstep_timeout on what there is.
    watchdog_timer_ = nh_.createWallTimer(ros::WallDuration(parameters_.lockstep_timeout / 4.0),
                                          &ReactiveNavigatorRos::lockstepWatchdog, this);
    retry_timer_ = nh_.createWallTimer(
      ros::WallDuration(0.002), [this](const ros::WallTimerEvent&) { tryLockstepStep(); }, true, false);
  }
  else
    step_timer_ =
      nh_.createTimer(ros::Duration(1.0 / parameters_.control_rate), &ReactiveNavigatorRos::timerStep, this);

  diagnostics_.add("navigator", [this](diagnostic_updater::DiagnosticStatusWrapper& status) { diagnose(status); });
  diagnostics_.start();

  publishState();
}

void ReactiveNavigatorRos::warn(const std::string& kind, const std::string& text)
{
  if (throttle_.due(kind))
    NODE_WARN(private_nh_.getNamespace(), "%s", text.c_str());
}

void ReactiveNavigatorRos::goalArrived(const geometry_msgs::PoseStamped::ConstPtr& goal)
{
  std::lock_guard<std::mutex> lock(mutex_);
  const auto& q = goal->pose.orientation;
  const auto& p = goal->pose.position;
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !std::isfinite(q.x) || !std::isfinite(q.y) ||
      !std::isfinite(q.z) || !std::isfinite(q.w))
  {
    warn("goal", "goal ignored: its pose is not finite");
    return;
  }
  // Its transform may not be in yet (the /tf of its stamp travels on another connection): the
  // goal is taken now if it can be, else at the next steps (tryPendingGoal).
  pending_goal_ = goal;
  pending_since_ = ros::WallTime::now();
  if (!tryPendingGoal(false))
  {
    // Say so at once all the same: a simulator waits for the state before the goal's first step.
    std_msgs::String message;
    message.data = stateName(NavigationState::Navigating);
    state_pub_.publish(message);
    published_state_ = NavigationState::Navigating;
  }
}

bool ReactiveNavigatorRos::tryPendingGoal(bool give_up_when_late)
{
  if (!pending_goal_)
    return false;
  const auto& goal = *pending_goal_;
  const std::string frame = laserscan_common::tf2FrameId(goal.header.frame_id);
  const auto& p = goal.pose.position;
  Eigen::Vector3d in_odom(p.x, p.y, p.z);
  if (frame != parameters_.odom_frame)
  {
    try
    {
      // At the goal's stamp; a zero stamp means "the latest transform".
      const auto t = tf_buffer_.lookupTransform(parameters_.odom_frame, frame.empty() ? "?" : frame, goal.header.stamp);
      in_odom = tf2::transformToEigen(t) * in_odom;
    }
    catch (const std::exception& e)
    {
      if (give_up_when_late && (ros::WallTime::now() - pending_since_).toSec() > kGoalTransformWait)
      {
        warn("goal", std::string("goal ignored: no transform from its frame '") + frame + "' to '" +
                       parameters_.odom_frame + "' within " + std::to_string(kGoalTransformWait) + " s: " + e.what());
        pending_goal_.reset();
        publishState();  // back to what the core says
      }
      return false;
    }
  }
  pending_goal_.reset();
  core_->setGoal(in_odom.x(), in_odom.y());
  publishState();  // at once: a simulator waits for it before the goal's first step
  NODE_INFO(private_nh_.getNamespace(), "new goal (%.2f, %.2f) in '%s'", in_odom.x(), in_odom.y(),
            parameters_.odom_frame.c_str());
  return true;
}

void ReactiveNavigatorRos::scanArrived(std::size_t index, const sensor_msgs::LaserScan::ConstPtr& scan)
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
    Source& source = sources_[index];
    // The merger's check (laserscan_common::scanFault): a scan it would drop is not driven on.
    const std::string fault = laserscan_common::scanFault(laserscan_common::scanViewOf(*scan));
    if (!fault.empty())
    {
      warn("malformed " + source.topic + ": " + laserscan_common::faultKind(fault),
           "dropped a malformed scan on '" + source.topic + "' (frame '" + scan->header.frame_id + "'): " + fault);
      return;
    }
    source.scans.push_back(scan);
    if (source.scans.size() > kKeptMessages)
      source.scans.pop_front();
    source.newest_stamp = std::max(source.newest_stamp, scan->header.stamp);
  }
  if (parameters_.lockstep)
    tryLockstepStep();
}

void ReactiveNavigatorRos::cloudArrived(std::size_t index, const sensor_msgs::PointCloud2::ConstPtr& cloud)
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
    Source& source = sources_[index];
    // The converters' checks (laserscan_common::makeCloudView): x/y/z float32 or float64,
    // little-endian, inside point_step, rows row_step apart, the data exactly row_step x height.
    laserscan_common::CloudView view;
    const std::string reason = laserscan_common::makeCloudView(laserscan_common::cloudLayoutOf(*cloud),
                                                               cloud->data.data(), cloud->data.size(), "", view);
    if (!reason.empty())
    {
      // Throttled per topic and kind of defect (the reason without its numbers).
      warn("malformed " + source.topic + ": " + laserscan_common::faultKind(reason),
           "dropped a malformed cloud on '" + source.topic + "' (frame '" + cloud->header.frame_id + "'): " + reason);
      return;
    }
    source.clouds.push_back(CloudMessage{ cloud, view });
    if (source.clouds.size() > kKeptMessages)
      source.clouds.pop_front();
    source.newest_stamp = std::max(source.newest_stamp, cloud->header.stamp);
  }
  if (parameters_.lockstep)
    tryLockstepStep();
}

void ReactiveNavigatorRos::timerStep(const ros::TimerEvent& event)
{
  std::lock_guard<std::mutex> lock(mutex_);
  runStep(event.current_real, true);  // ROS time: simulated time in simulation
}

ros::Time ReactiveNavigatorRos::onGrid(const ros::Time& time, long& index) const
{
  // The grid index of the step at or before `time`; the step's time is `time` itself when it is
  // on the grid (bit for bit the stamp the data carry: 2.4 s in Python is 2.399999999 s), else
  // the grid time.
  index = static_cast<long>(std::floor(time.toSec() * parameters_.control_rate + kStampEpsilon));
  const double grid = static_cast<double>(index) / parameters_.control_rate;
  return std::abs(time.toSec() - grid) <= kStampEpsilon ? time : ros::Time(grid);
}

void ReactiveNavigatorRos::tryLockstepStep()
{
  std::lock_guard<std::mutex> lock(mutex_);
  // The step's time: the newest grid time every source has data for (stamps up to it).
  ros::Time complete = sources_.front().newest_stamp;
  for (const auto& s : sources_)
    complete = std::min(complete, s.newest_stamp);
  if (complete.isZero())
    return;
  long index = 0;
  const ros::Time time = onGrid(complete, index);
  if (index < next_step_)
    return;
  Pose2 pose;
  if (!poseAt(time, false, pose))
  {
    // Its tf is not in yet: look again shortly (the watchdog gives up after lockstep_timeout).
    if (waiting_since_.isZero())
      waiting_since_ = ros::WallTime::now();
    retry_timer_.stop();
    retry_timer_.start();
    return;
  }
  runStep(time, false);
  next_step_ = index + 1;
  waiting_since_ = ros::WallTime();
}

void ReactiveNavigatorRos::lockstepWatchdog(const ros::WallTimerEvent&)
{
  std::lock_guard<std::mutex> lock(mutex_);
  const ros::Time now = ros::Time::now();
  long index = 0;
  const ros::Time time = onGrid(now, index);
  if (now.isZero() || index < next_step_)
    return;
  if (waiting_since_.isZero())
  {
    waiting_since_ = ros::WallTime::now();
    return;
  }
  if ((ros::WallTime::now() - waiting_since_).toSec() < parameters_.lockstep_timeout)
    return;
  std::string late;
  for (const auto& s : sources_)
    if (s.newest_stamp.toSec() + kStampEpsilon < time.toSec())
      late += " '" + s.topic + "'";
  warn("lockstep", "lockstep: step at " + std::to_string(time.toSec()) + " s ran after waiting " +
                     std::to_string(parameters_.lockstep_timeout) + " s for" +
                     (late.empty() ? std::string(" the robot's tf") : late));
  runStep(time, true);
  next_step_ = index + 1;
  waiting_since_ = ros::WallTime();
}

bool ReactiveNavigatorRos::poseAt(const ros::Time& time, bool latest, Pose2& pose)
{
  try
  {
    const auto t =
      tf_buffer_.lookupTransform(parameters_.odom_frame, parameters_.robot_frame, latest ? ros::Time(0) : time);
    const auto& q = t.transform.rotation;
    pose.x = t.transform.translation.x;
    pose.y = t.transform.translation.y;
    pose.yaw = std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
    return true;
  }
  catch (const std::exception&)
  {
    return false;
  }
}

void ReactiveNavigatorRos::collectObstacles(const ros::Time& time, bool up_to_time)
{
  points_.clear();
  observations_.clear();
  const ros::Time target_time = time;
  for (std::size_t source = 0; source < sources_.size(); ++source)
  {
    Source& s = sources_[source];
    // The newest message stamped up to the step's time (or the newest of all).
    auto pick = [&](const auto& queue, const auto& message_of) -> decltype(&queue.back()) {
      for (auto it = queue.rbegin(); it != queue.rend(); ++it)
        if (!up_to_time || message_of(*it).header.stamp.toSec() <= time.toSec() + kStampEpsilon)
          return &*it;
      return nullptr;
    };
    const std_msgs::Header* header = nullptr;
    const sensor_msgs::LaserScan* scan = nullptr;
    const CloudMessage* cloud = nullptr;
    if (s.is_cloud)
    {
      cloud = pick(s.clouds, [](const CloudMessage& c) -> const sensor_msgs::PointCloud2& { return *c.message; });
      header = cloud ? &cloud->message->header : nullptr;
    }
    else
    {
      const auto* newest = pick(s.scans, [](const auto& m) -> const sensor_msgs::LaserScan& { return *m; });
      scan = newest ? newest->get() : nullptr;
      header = scan ? &scan->header : nullptr;
    }
    if (header == nullptr)
      continue;
    Eigen::Isometry3d sensor_to_robot;
    try
    {
      // The sensor's points as they were at its stamp, seen from the robot at the step's time
      // (through the odometry frame, which does not move).
      sensor_to_robot = tf2::transformToEigen(tf_buffer_.lookupTransform(parameters_.robot_frame, target_time,
                                                                         laserscan_common::tf2FrameId(header->frame_id),
                                                                         header->stamp, parameters_.odom_frame));
    }
    catch (const std::exception& e)
    {
      warn("tf " + s.topic,
           "no transform for '" + s.topic + "' from '" + header->frame_id + "' at its stamp: " + e.what());
      continue;
    }
    Observation observation;
    observation.source = source;
    observation.origin = sensor_to_robot.translation().cast<float>();
    observation.begin = points_.size();
    if (scan != nullptr)
    {
      const ScanView view = laserscan_common::scanViewOf(*scan);
      appendScanPoints(view, sensor_to_robot, points_);
      appendScanNoReturns(view, sensor_to_robot, navigator_parameters_.planner_clearing_range, observation.free_ends);
    }
    else
    {
      appendCloudPoints(cloud->view, sensor_to_robot, parameters_.height_band_min, parameters_.height_band_max,
                        points_);
    }
    observation.end = points_.size();
    observations_.push_back(std::move(observation));
  }
}

void ReactiveNavigatorRos::runStep(const ros::Time& time, bool latest_pose)
{
  const double cpu_start = cpuSeconds();
  Command command;
  Pose2 pose;
  tryPendingGoal(true);
  if (poseAt(time, latest_pose, pose))
  {
    collectObstacles(time, !latest_pose);
    command = core_->step(time.toSec(), pose, points_, observations_);
  }
  else
    warn("pose", "no pose: no transform '" + parameters_.odom_frame + "' -> '" + parameters_.robot_frame + "' at " +
                   std::to_string(time.toSec()) + " s; the robot is stopped");
  const double cpu = cpuSeconds() - cpu_start;

  geometry_msgs::TwistStamped step;
  step.header.stamp = time;
  step.header.frame_id = parameters_.robot_frame;
  step.twist.linear.x = command.vx;
  step.twist.linear.y = command.vy;
  step.twist.angular.z = command.wz;
  cmd_pub_.publish(step.twist);
  step_pub_.publish(step);
  publishState();
  publishPlan(time);
  cpu_sum_ += cpu;
  cpu_max_ = std::max(cpu_max_, cpu);
  points_sum_ += core_->lastObstaclePoints();
  self_points_sum_ += core_->lastSelfPoints();
  remembered_points_sum_ += core_->lastRememberedPoints();
  ++steps_;
  ++steps_total_;
}

void ReactiveNavigatorRos::publishPlan(const ros::Time& time)
{
  const std::vector<Eigen::Vector2d>& path = core_->plannedPath();
  if (path == published_plan_)
    return;
  published_plan_ = path;
  nav_msgs::Path message;
  message.header.stamp = time;
  message.header.frame_id = parameters_.odom_frame;
  message.poses.resize(path.size());
  for (std::size_t i = 0; i < path.size(); ++i)
  {
    message.poses[i].header = message.header;
    message.poses[i].pose.position.x = path[i].x();
    message.poses[i].pose.position.y = path[i].y();
    message.poses[i].pose.orientation.w = 1.0;
  }
  plan_pub_.publish(message);
}

void ReactiveNavigatorRos::publishState()
{
  const NavigationState state = core_->state();
  if (state_published_ && state == published_state_)
    return;
  std_msgs::String message;
  message.data = stateName(state);
  state_pub_.publish(message);
  published_state_ = state;
  state_published_ = true;
}

void ReactiveNavigatorRos::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status)
{
  std::lock_guard<std::mutex> lock(mutex_);
  const NavigationState state = core_->state();
  if (state == NavigationState::Blocked)
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "blocked: no progress to the goal");
  else
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, stateName(state));
  status.add("state", stateName(state));
  status.add("mode", navigator_parameters_.mode);
  status.add("steps", steps_total_);
  status.add("cpu per step mean (ms)", steps_ ? 1e3 * cpu_sum_ / static_cast<double>(steps_) : 0.0);
  status.add("cpu per step max (ms)", 1e3 * cpu_max_);
  status.add("obstacle points per step", steps_ ? points_sum_ / steps_ : 0);
  status.add("own body points per step", steps_ ? self_points_sum_ / steps_ : 0);
  status.add("remembered points per step", steps_ ? remembered_points_sum_ / steps_ : 0);
  status.add("planner", navigator_parameters_.planner ? "on" : "off");
  if (navigator_parameters_.planner)
  {
    status.add("planner obstacle cells", core_->plannerCells());
    status.add("path left (m)", core_->remainingPath());
  }
  cpu_sum_ = cpu_max_ = 0.0;
  points_sum_ = self_points_sum_ = remembered_points_sum_ = steps_ = 0;
}

}  // namespace reactive_navigator
