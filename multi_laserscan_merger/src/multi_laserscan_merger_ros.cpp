#include "multi_laserscan_merger/multi_laserscan_merger_ros.hpp"

#include <boost/make_shared.hpp>
#include <set>

#include <tf2_eigen/tf2_eigen.h>

namespace multi_laserscan_merger
{

namespace
{
bool isNumber(const XmlRpc::XmlRpcValue& v)
{
  return v.getType() == XmlRpc::XmlRpcValue::TypeDouble || v.getType() == XmlRpc::XmlRpcValue::TypeInt;
}

double toDouble(XmlRpc::XmlRpcValue& v)
{
  return v.getType() == XmlRpc::XmlRpcValue::TypeInt ? static_cast<double>(static_cast<int>(v))
                                                     : static_cast<double>(v);
}

void readDouble(const ros::NodeHandle& nh, const std::string& name, double& value)
{
  XmlRpc::XmlRpcValue v;
  if (!nh.getParam(name, v))
    return;  // keep the default
  if (!isNumber(v))
    throw ParameterError(name, "must be a number");
  value = toDouble(v);
}

void readBool(const ros::NodeHandle& nh, const std::string& name, bool& value)
{
  XmlRpc::XmlRpcValue v;
  if (!nh.getParam(name, v))
    return;
  if (v.getType() != XmlRpc::XmlRpcValue::TypeBoolean)
    throw ParameterError(name, "must be true or false");
  value = static_cast<bool>(v);
}

void readString(const ros::NodeHandle& nh, const std::string& name, std::string& value)
{
  XmlRpc::XmlRpcValue v;
  if (!nh.getParam(name, v))
    return;
  if (v.getType() != XmlRpc::XmlRpcValue::TypeString)
    throw ParameterError(name, "must be a string");
  value = static_cast<std::string>(v);
}

SourceParams readSource(XmlRpc::XmlRpcValue& item, const std::string& prefix)
{
  if (item.getType() != XmlRpc::XmlRpcValue::TypeStruct)
    throw ParameterError(prefix, "must be a dictionary {name, topic, timeout, angle_min, ...}");
  SourceParams s;
  static const std::set<std::string> known = { "name",      "topic",     "timeout",   "angle_min",
                                               "angle_max", "range_min", "range_max", "deskew" };
  for (auto& kv : item)
    if (known.count(kv.first) == 0)
      throw ParameterError(prefix + "." + kv.first, "unknown key (a typo?)");
  auto number = [&](const char* key, double& value) {
    if (!item.hasMember(key))
      return;
    if (!isNumber(item[key]))
      throw ParameterError(prefix + "." + key, "must be a number");
    value = toDouble(item[key]);
  };
  auto text = [&](const char* key, std::string& value) {
    if (!item.hasMember(key))
      return;
    if (item[key].getType() != XmlRpc::XmlRpcValue::TypeString)
      throw ParameterError(prefix + "." + key, "must be a string");
    value = static_cast<std::string>(item[key]);
  };
  text("name", s.name);
  text("topic", s.topic);
  number("timeout", s.timeout);
  number("angle_min", s.angle_min);
  number("angle_max", s.angle_max);
  number("range_min", s.range_min);
  number("range_max", s.range_max);
  if (item.hasMember("deskew"))
  {
    if (item["deskew"].getType() != XmlRpc::XmlRpcValue::TypeBoolean)
      throw ParameterError(prefix + ".deskew", "must be true or false");
    s.deskew = static_cast<bool>(item["deskew"]);
  }
  return s;
}

ScanView viewOf(const sensor_msgs::LaserScan& m)
{
  ScanView v;
  v.stamp = m.header.stamp.toSec();
  v.angle_min = m.angle_min;
  v.angle_max = m.angle_max;
  v.angle_increment = m.angle_increment;
  v.time_increment = m.time_increment;
  v.range_min = m.range_min;
  v.range_max = m.range_max;
  v.ranges = m.ranges.data();
  v.n_ranges = m.ranges.size();
  v.intensities = m.intensities.empty() ? nullptr : m.intensities.data();
  v.n_intensities = m.intensities.size();
  return v;
}
}  // namespace

MergerParams loadParams(const ros::NodeHandle& pnh)
{
  MergerParams p;
  readString(pnh, "output_frame", p.output.frame);
  readDouble(pnh, "angle_min", p.output.angle_min);
  readDouble(pnh, "angle_max", p.output.angle_max);
  readDouble(pnh, "angle_increment", p.output.angle_increment);
  readDouble(pnh, "range_min", p.output.range_min);
  readDouble(pnh, "range_max", p.output.range_max);
  readBool(pnh, "use_inf", p.output.use_inf);
  readDouble(pnh, "inf_epsilon", p.output.inf_epsilon);
  readString(pnh, "odom_topic", p.odom_topic);
  double queue = p.odom_queue_size;
  readDouble(pnh, "odom_queue_size", queue);
  if (queue != std::floor(queue) || queue > 1e6)
    throw ParameterError("odom_queue_size", "must be a whole number of messages");
  p.odom_queue_size = static_cast<int>(queue);
  readDouble(pnh, "publish_rate", p.publish_rate);

  XmlRpc::XmlRpcValue list;
  if (!pnh.getParam("sources", list))
    throw ParameterError("sources",
                         "missing: a list of {name, topic, timeout, angle_min, angle_max, range_min, "
                         "range_max, deskew}");
  if (list.getType() != XmlRpc::XmlRpcValue::TypeArray)
    throw ParameterError("sources", "must be a list of dictionaries");
  for (int i = 0; i < list.size(); ++i)
    p.sources.push_back(readSource(list[i], "sources[" + std::to_string(i) + "]"));
  p.validate();
  return p;
}

MultiLaserScanMergerRos::MultiLaserScanMergerRos(ros::NodeHandle nh, ros::NodeHandle private_nh)
  : nh_(nh), private_nh_(private_nh), name_(private_nh.getNamespace()), params_(loadParams(private_nh))
{
  core_ = std::make_unique<MergerCore>(params_);
  odom_ = OdometryBuffer(static_cast<std::size_t>(params_.odom_queue_size));
  sources_.resize(params_.sources.size());
  inputs_.resize(params_.sources.size());
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(tf_buffer_, nh_);
  last_now_ = ros::Time::now();
  last_report_ = ros::WallTime::now();

  updater_ = std::make_unique<diagnostic_updater::Updater>(nh_, private_nh_, name_);
  updater_->setHardwareID("none");
  for (std::size_t i = 0; i < sources_.size(); ++i)
    updater_->add("source " + params_.sources[i].name,
                  [this, i](diagnostic_updater::DiagnosticStatusWrapper& s) { sourceDiagnostics(i, s); });
  updater_->add("odometry", [this](diagnostic_updater::DiagnosticStatusWrapper& s) { odometryDiagnostics(s); });

  pub_ = nh_.advertise<sensor_msgs::LaserScan>("scan", 10);
  for (std::size_t i = 0; i < sources_.size(); ++i)
  {
    sources_[i].sub = nh_.subscribe<sensor_msgs::LaserScan>(
      params_.sources[i].topic, 10, [this, i](const sensor_msgs::LaserScan::ConstPtr& m) { scanCallback(i, m); },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  }
  if (!params_.odom_topic.empty())
    odom_sub_ = nh_.subscribe<nav_msgs::Odometry>(
      params_.odom_topic, std::max(10, params_.odom_queue_size),
      [this](const nav_msgs::Odometry::ConstPtr& m) { odomCallback(m); }, ros::VoidConstPtr(),
      ros::TransportHints().tcpNoDelay());
  if (params_.publish_rate > 0.0)
    publish_timer_ = nh_.createTimer(ros::Duration(1.0 / params_.publish_rate),
                                     [this](const ros::TimerEvent& e) { timerCallback(e); });
  // The updater publishes at its own period (1 s by default) when asked.
  diagnostics_timer_ = nh_.createTimer(ros::Duration(0.5), [this](const ros::TimerEvent&) { updater_->update(); });
  ROS_INFO("%s: merging %zu sources into '%s' (%zu beams), publish_rate %.1f Hz, motion compensation %s", name_.c_str(),
           sources_.size(), params_.output.frame.c_str(), core_->beamCount(), params_.publish_rate,
           params_.odom_topic.empty() ? "off" : ("from '" + params_.odom_topic + "'").c_str());
}

void MultiLaserScanMergerRos::checkTimeJump()
{
  const ros::Time now = ros::Time::now();
  if (now < last_now_)
  {
    clearAll("time jumped backwards by " + std::to_string((last_now_ - now).toSec()) +
             " s (bag loop or restarted clock)");
    tf_buffer_.clear();
  }
  last_now_ = now;
}

void MultiLaserScanMergerRos::clearAll(const std::string& why)
{
  ROS_WARN_THROTTLE(5.0, "%s: %s: scan and odometry buffers cleared", name_.c_str(), why.c_str());
  for (auto& s : sources_)
  {
    s.scan.reset();
    s.pending.reset();
  }
  odom_.clear();
  last_published_ = -1.0;
}

bool MultiLaserScanMergerRos::tryTransform(std::size_t i, const sensor_msgs::LaserScan::ConstPtr& msg,
                                           std::string& error)
{
  const std::string& frame = msg->header.frame_id;
  // Never blocks: canTransform without a timeout, the scan waits as pending instead.
  if (!tf_buffer_.canTransform(params_.output.frame, frame, msg->header.stamp, &error))
    return false;
  try
  {
    sources_[i].output_T_sensor =
      tf2::transformToEigen(tf_buffer_.lookupTransform(params_.output.frame, frame, msg->header.stamp));
  }
  catch (const tf2::TransformException& e)
  {
    error = e.what();
    return false;
  }
  return true;
}

void MultiLaserScanMergerRos::scanCallback(std::size_t i, const sensor_msgs::LaserScan::ConstPtr& msg)
{
  std::lock_guard<std::mutex> lock(mutex_);
  checkTimeJump();
  SourceState& s = sources_[i];
  const SourceParams& sp = params_.sources[i];
  ++s.received;
  const ScanView view = viewOf(*msg);
  if (const char* fault = scanFault(view))
  {
    ++s.malformed;
    ROS_WARN_THROTTLE(5.0,
                      "%s: source '%s' (%s): malformed scan dropped: %s (%zu ranges, %zu intensities, angles "
                      "%g..%g step %g)",
                      name_.c_str(), sp.name.c_str(), sp.topic.c_str(), fault, msg->ranges.size(),
                      msg->intensities.size(), msg->angle_min, msg->angle_max, msg->angle_increment);
    retryPending();
    return;
  }
  if (s.scan && view.stamp < s.scan->header.stamp.toSec() - 1.0)
    clearAll("source '" + sp.name + "' stamps jumped backwards");
  std::string error;
  if (tryTransform(i, msg, error))
  {
    s.pending.reset();
    accept(i, msg);
  }
  else
  {
    if (s.pending)
    {
      ++s.transform_failures;  // replaced before its transform came
      ROS_WARN_THROTTLE(5.0, "%s: source '%s': no transform '%s' -> '%s' at %.3f, scan dropped: %s", name_.c_str(),
                        sp.name.c_str(), s.pending->header.frame_id.c_str(), params_.output.frame.c_str(),
                        s.pending->header.stamp.toSec(), s.pending_error.c_str());
    }
    s.pending = msg;
    s.pending_since = ros::WallTime::now();
    s.pending_error = error;
  }
  retryPending();
}

void MultiLaserScanMergerRos::retryPending()
{
  for (std::size_t i = 0; i < sources_.size(); ++i)
  {
    SourceState& s = sources_[i];
    if (!s.pending)
      continue;
    const sensor_msgs::LaserScan::ConstPtr msg = s.pending;
    std::string error;
    if (tryTransform(i, msg, error))
    {
      s.pending.reset();
      accept(i, msg);
    }
    else if ((ros::WallTime::now() - s.pending_since).toSec() > kTransformWait)
    {
      ++s.transform_failures;
      ROS_WARN_THROTTLE(5.0, "%s: source '%s': no transform '%s' -> '%s' at %.3f within %.1f s, scan dropped: %s",
                        name_.c_str(), params_.sources[i].name.c_str(), msg->header.frame_id.c_str(),
                        params_.output.frame.c_str(), msg->header.stamp.toSec(), kTransformWait, error.c_str());
      s.pending.reset();
    }
  }
}

void MultiLaserScanMergerRos::accept(std::size_t i, const sensor_msgs::LaserScan::ConstPtr& msg)
{
  // A scan older than the one already kept (a late pending one) is not newer information.
  if (sources_[i].scan && msg->header.stamp < sources_[i].scan->header.stamp)
    return;
  sources_[i].scan = msg;
  if (params_.publish_rate > 0.0)
    return;
  // publish_rate 0: one output per new scan, at the newest scan's stamp.
  double t_out = msg->header.stamp.toSec();
  for (const auto& s : sources_)
    if (s.scan)
      t_out = std::max(t_out, s.scan->header.stamp.toSec());
  mergeAndPublish(t_out);
}

void MultiLaserScanMergerRos::odomCallback(const nav_msgs::Odometry::ConstPtr& msg)
{
  std::lock_guard<std::mutex> lock(mutex_);
  checkTimeJump();
  ++odom_received_;
  last_odom_arrival_ = ros::WallTime::now();
  odom_child_frame_ = msg->child_frame_id;
  const auto& p = msg->pose.pose;
  const auto r = odom_.add(msg->header.stamp.toSec(), Eigen::Vector3d(p.position.x, p.position.y, p.position.z),
                           Eigen::Quaterniond(p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z));
  if (r == OdometryBuffer::AddResult::kClearedBackwards)
  {
    ROS_WARN_THROTTLE(5.0, "%s: odometry time jumped backwards (to %.3f): odometry buffer cleared", name_.c_str(),
                      msg->header.stamp.toSec());
    for (auto& s : sources_)
      s.scan.reset();  // they belong to the other timeline
    last_published_ = -1.0;
  }
  else if (r == OdometryBuffer::AddResult::kRejected)
    ROS_WARN_THROTTLE(5.0, "%s: odometry message with a non-finite pose or zero quaternion ignored", name_.c_str());
  retryPending();
}

void MultiLaserScanMergerRos::timerCallback(const ros::TimerEvent&)
{
  std::lock_guard<std::mutex> lock(mutex_);
  checkTimeJump();
  retryPending();
  // With a rate, the output is synchronised to the newest data there is: the newest scan, or
  // the newest odometry when it is newer (everything moved to it). Never now(): no pose is known
  // for it. A tick with nothing newer than the last output publishes nothing.
  double t_out = -1.0;
  for (const auto& s : sources_)
    if (s.scan)
      t_out = std::max(t_out, s.scan->header.stamp.toSec());
  if (t_out < 0.0)
    return;
  if (!odom_.empty())
    t_out = std::max(t_out, odom_.newestTime());
  if (t_out <= last_published_)
    return;
  mergeAndPublish(t_out);
}

bool MultiLaserScanMergerRos::robotToOutput(Eigen::Isometry3d& out)
{
  out = Eigen::Isometry3d::Identity();
  if (odom_child_frame_.empty() || odom_child_frame_ == params_.output.frame)
    return true;
  std::string error;
  if (!tf_buffer_.canTransform(params_.output.frame, odom_child_frame_, ros::Time(0), &error))
  {
    ROS_WARN_THROTTLE(5.0, "%s: no transform '%s' -> '%s' (odometry child frame): motion compensation skipped: %s",
                      name_.c_str(), odom_child_frame_.c_str(), params_.output.frame.c_str(), error.c_str());
    return false;
  }
  out = tf2::transformToEigen(tf_buffer_.lookupTransform(params_.output.frame, odom_child_frame_, ros::Time(0)));
  return true;
}

void MultiLaserScanMergerRos::mergeAndPublish(double t_out)
{
  for (std::size_t i = 0; i < sources_.size(); ++i)
  {
    inputs_[i].present = static_cast<bool>(sources_[i].scan);
    if (inputs_[i].present)
    {
      inputs_[i].scan = viewOf(*sources_[i].scan);
      inputs_[i].output_T_sensor = sources_[i].output_T_sensor;
    }
  }
  Eigen::Isometry3d output_T_robot;
  const OdometryBuffer* odom = nullptr;
  if (!params_.odom_topic.empty() && !odom_.empty() && robotToOutput(output_T_robot))
  {
    odom = &odom_;
    if (t_out - odom_.newestTime() > kOdometryStale)
      ROS_WARN_THROTTLE(5.0,
                        "%s: odometry stopped: the newest is %.2f s older than the output time; motion after it "
                        "is not compensated",
                        name_.c_str(), t_out - odom_.newestTime());
  }
  else if (!params_.odom_topic.empty() && odom_.empty())
    ROS_WARN_THROTTLE(10.0, "%s: no odometry yet on '%s': merging without motion compensation", name_.c_str(),
                      nh_.resolveName(params_.odom_topic).c_str());
  core_->merge(inputs_, t_out, odom, odom != nullptr ? output_T_robot : Eigen::Isometry3d::Identity(), merged_,
               status_);
  for (std::size_t i = 0; i < sources_.size(); ++i)
  {
    if (status_[i] != SourceStatus::kTimedOut)
      continue;
    SourceState& s = sources_[i];
    const double stamp = s.scan->header.stamp.toSec();
    if (stamp != s.last_timed_out_stamp)
    {
      ++s.timeouts;
      s.last_timed_out_stamp = stamp;
    }
    ROS_WARN_THROTTLE(5.0, "%s: source '%s': newest scan is %.2f s old (timeout %.2f s): merged without it",
                      name_.c_str(), params_.sources[i].name.c_str(), t_out - stamp, params_.sources[i].timeout);
  }

  auto msg = boost::make_shared<sensor_msgs::LaserScan>();
  msg->header.stamp.fromSec(t_out);
  msg->header.frame_id = params_.output.frame;
  msg->angle_min = static_cast<float>(params_.output.angle_min);
  msg->angle_increment = static_cast<float>(params_.output.angle_increment);
  msg->angle_max =
    static_cast<float>(params_.output.angle_min + (core_->beamCount() - 1) * params_.output.angle_increment);
  msg->time_increment = 0.0f;  // every beam is synchronised to the stamp
  msg->scan_time = params_.publish_rate > 0.0 ? static_cast<float>(1.0 / params_.publish_rate) : 0.0f;
  msg->range_min = static_cast<float>(params_.output.range_min);
  msg->range_max = static_cast<float>(params_.output.range_max);
  msg->ranges = merged_.ranges;
  msg->intensities = merged_.intensities;
  last_published_ = t_out;
  pub_.publish(sensor_msgs::LaserScan::ConstPtr(msg));  // zero-copy in a manager; not touched afterwards
}

void MultiLaserScanMergerRos::sourceDiagnostics(std::size_t i, diagnostic_updater::DiagnosticStatusWrapper& stat)
{
  std::lock_guard<std::mutex> lock(mutex_);
  SourceState& s = sources_[i];
  const SourceParams& sp = params_.sources[i];
  const ros::WallTime now = ros::WallTime::now();
  const double window = std::max(1e-3, (now - last_report_).toSec());
  const double rate = static_cast<double>(s.received - s.received_at_last_report) / window;
  // The report window is shared by all tasks: the last task (odometry) moves it on.
  const double age = s.scan ? (ros::Time::now() - s.scan->header.stamp).toSec() : -1.0;
  stat.add("topic", nh_.resolveName(sp.topic));
  stat.add("rate (Hz)", rate);
  stat.add("age of last scan (s)", age);
  stat.add("timeout (s)", sp.timeout);
  stat.add("scans left out by timeout", s.timeouts);
  stat.add("transform failures", s.transform_failures);
  stat.add("malformed scans", s.malformed);
  if (!s.scan)
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no scan received yet");
  else if (age > sp.timeout)
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "stale: last scan %.1f s old, left out of the merge", age);
  else
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "merged");
}

void MultiLaserScanMergerRos::odometryDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat)
{
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto& s : sources_)
    s.received_at_last_report = s.received;
  last_report_ = ros::WallTime::now();
  if (params_.odom_topic.empty())
  {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "motion compensation disabled (odom_topic empty)");
    return;
  }
  stat.add("topic", nh_.resolveName(params_.odom_topic));
  stat.add("messages received", odom_received_);
  stat.add("queue entries", odom_.size());
  if (odom_.empty())
  {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no odometry: merging without motion compensation");
    return;
  }
  const double age = ros::Time::now().toSec() - odom_.newestTime();
  stat.add("age of last odometry (s)", age);
  if (age > kOdometryStale)
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "odometry stopped %.1f s ago", age);
  else
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "ok");
}

}  // namespace multi_laserscan_merger
