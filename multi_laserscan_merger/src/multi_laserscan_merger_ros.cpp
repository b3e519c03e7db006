#include "multi_laserscan_merger/multi_laserscan_merger_ros.hpp"

#include <algorithm>
#include <boost/make_shared.hpp>
#include <cmath>
#include <iterator>
#include <set>

#include <tf2_eigen/tf2_eigen.h>

#include "laserscan_common/self_filter_parameters.hpp"
#include "laserscan_common/node_log.hpp"

namespace multi_laserscan_merger
{

MergerParams loadParams(laserscan_common::ParameterReader& reader)
{
  MergerParams p;
  reader.readFields(p);
  XmlRpc::XmlRpcValue list;
  if (!reader.readRaw("sources", list))
    throw ParameterError("sources",
                         "missing: a list of {name, topic, timeout, angle_min, angle_max, range_min, "
                         "range_max, deskew, too_close_is_obstacle, footprint_filter, self_filter, "
                         "drop_explained_within}");
  if (list.getType() != XmlRpc::XmlRpcValue::TypeArray)
    throw ParameterError("sources", "must be a list of dictionaries");
  for (int i = 0; i < list.size(); ++i)
  {
    const std::string prefix = "sources[" + std::to_string(i) + "]";
    if (list[i].getType() != XmlRpc::XmlRpcValue::TypeStruct)
      throw ParameterError(prefix, "must be a dictionary {name, topic, timeout, angle_min, ...}");
    p.sources.emplace_back();
    laserscan_common::readDictionary(list[i], prefix + ".", p.sources.back());
  }
  p.validate();
  return p;
}

MultiLaserScanMergerRos::MultiLaserScanMergerRos(ros::NodeHandle nh, ros::NodeHandle private_nh)
  : nh_(nh),
    private_nh_(private_nh),
    name_(private_nh.getNamespace()),
    reader_(private_nh),
    params_(loadParams(reader_))
{
  core_ = std::make_unique<MergerCore>(params_);
  odom_topic_ = params_.odom_topic.empty() ? "" : nh_.resolveName(params_.odom_topic);
  // A source on the output topic would merge the merger's own output into itself.
  const std::string output_topic = nh_.resolveName(kOutputTopic);
  for (std::size_t i = 0; i < params_.sources.size(); ++i)
    if (nh_.resolveName(params_.sources[i].topic) == output_topic)
      throw ParameterError("sources[" + std::to_string(i) + "].topic",
                           "source '" + params_.sources[i].name + "' resolves to '" + output_topic +
                             "', the merger's own output topic (remap the output or the source)");
  odom_ = OdometryBuffer(static_cast<std::size_t>(params_.odom_queue_size));
  sources_.resize(params_.sources.size());
  std::vector<std::string> self_filter_warnings;
  const laserscan_common::SelfFilter self_filter =
    laserscan_common::makeSelfFilter(laserscan_common::readSelfFilterParams(reader_), nh_, self_filter_warnings);
  reader_.warnUnknown();
  for (const std::string& warning : self_filter_warnings)
    NODE_WARN(name_, "self filter: %s", warning.c_str());
  for (std::size_t i = 0; i < sources_.size(); ++i)
    if (params_.sources[i].self_filter)
      sources_[i].self_filter = self_filter;
  if (!self_filter.empty())
    NODE_INFO(name_, "self filter: %zu shapes on %zu frames", self_filter.shapes().size(), self_filter.frames().size());
  for (std::size_t i = 0; i < sources_.size(); ++i)
    sources_[i].frame_id = laserscan_common::FrameIdNormaliser([this, i](const std::string& frame_id,
                                                                         const std::string& used) {
      const SourceParams& sp = params_.sources[i];
      NODE_WARN(name_, "source '%s' (%s): frame_id '%s' starts with '/', which tf2 refuses: using '%s' (reported once)",
                sp.name.c_str(), sp.topic.c_str(), frame_id.c_str(), used.c_str());
    });
  odom_child_frame_id_ =
    laserscan_common::FrameIdNormaliser([this](const std::string& frame_id, const std::string& used) {
      NODE_WARN(name_,
                "odometry (%s): child_frame_id '%s' starts with '/', which tf2 refuses: using '%s' (reported once)",
                odom_topic_.c_str(), frame_id.c_str(), used.c_str());
    });
  inputs_.resize(params_.sources.size());
  std::vector<double> timeouts;
  for (const auto& sp : params_.sources)
    timeouts.push_back(sp.timeout);
  SyncedOutputs<ScanInMerge>::Handlers handlers;
  handlers.merge = [this](std::size_t i, const ScanInMerge& scan) {
    sources_[i].scan = scan.msg;
    sources_[i].view = scan.view;
    sources_[i].output_T_sensor = scan.output_T_sensor;
    sources_[i].scan_self_filter = scan.self_filter;
  };
  handlers.wait = [this](std::int64_t, const StampSync::Decision& d) {
    for (std::size_t j : d.due)
      ++sources_[j].waited_for;
    armSyncTimer(d.deadline);
  };
  handlers.publish = [this](std::int64_t stamp, const StampSync::Decision& d, bool waited) {
    const ros::Time t = ros::Time().fromNSec(static_cast<std::uint64_t>(stamp));  // exact: nsecs < 1e9
    reportSync(t, d, waited);
    mergeAndPublish(t);
  };
  outputs_ = std::make_unique<SyncedOutputs<ScanInMerge>>(params_.sync_window, timeouts, params_.publish_rate <= 0.0,
                                                          std::move(handlers));
  sync_timer_ = nh_.createSteadyTimer(
    ros::WallDuration(1.0), [this](const ros::SteadyTimerEvent&) { syncTimerCallback(); }, true, false);
  tf_reader_ = std::make_unique<laserscan_common::TransformReader>(nh_, tf_buffer_, name_);
  for (std::size_t i = 0; i < sources_.size(); ++i)
  {
    // A scan waits for its mount and for the robot's parts it filters out.
    std::vector<std::string> targets{ params_.output.frame };
    targets.insert(targets.end(), sources_[i].self_filter.frames().begin(), sources_[i].self_filter.frames().end());
    sources_[i].wait = std::make_unique<laserscan_common::TransformWait<sensor_msgs::LaserScan>>(
      tf_buffer_, targets, 1, nh_,
      [this, i](const sensor_msgs::LaserScan::ConstPtr& msg, const ros::Time& received) {
        transformArrived(i, msg, received, "");
      },
      [this, i](const sensor_msgs::LaserScan::ConstPtr& msg, const std::string& why) {
        transformArrived(i, msg, ros::Time(), why);
      });
  }
  last_now_ = ros::Time::now();

  diagnostics_ = std::make_unique<laserscan_common::NodeDiagnostics>(nh_, private_nh_);
  for (std::size_t i = 0; i < sources_.size(); ++i)
    diagnostics_->add("source " + params_.sources[i].name,
                      [this, i](diagnostic_updater::DiagnosticStatusWrapper& s) { sourceDiagnostics(i, s); });
  diagnostics_->add("odometry", [this](diagnostic_updater::DiagnosticStatusWrapper& s) { odometryDiagnostics(s); });
  diagnostics_->add("output", [this](diagnostic_updater::DiagnosticStatusWrapper& s) { outputDiagnostics(s); });

  pub_ = nh_.advertise<sensor_msgs::LaserScan>(kOutputTopic, 10);
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
  diagnostics_->start();
  NODE_INFO(name_,
            "merging %zu sources into '%s' on '%s' (%zu beams), publish_rate %.1f Hz, sync_window %.3f s, motion "
            "compensation %s",
            sources_.size(), params_.output.frame.c_str(), output_topic.c_str(), core_->beamCount(),
            params_.publish_rate, params_.sync_window,
            params_.odom_topic.empty() ? "off" : ("from '" + params_.odom_topic + "'").c_str());
}

void MultiLaserScanMergerRos::checkTimeJump()
{
  const ros::Time now = ros::Time::now();
  if (now < last_now_)
  {
    // In seconds (double): a ros::Duration of a jump of more than 2^31 s would throw.
    clearAll("time jumped backwards by " + std::to_string(last_now_.toSec() - now.toSec()) +
               " s (bag loop or restarted clock)",
             "clock jumped backwards");
    tf_buffer_.clear();
  }
  last_now_ = now;
}

void MultiLaserScanMergerRos::clearAll(const std::string& why, const std::string& kind)
{
  if (warnings_.due(kind))
    NODE_WARN(name_, "%s: scan and odometry buffers cleared", why.c_str());
  for (auto& s : sources_)
  {
    s.scan.reset();
    s.pending.reset();
  }
  odom_.clear();
  odom_newest_ = ros::Time();
  outputs_->reset();
}

std::string MultiLaserScanMergerRos::tryTransform(const std::string& frame, const ros::Time& stamp,
                                                  Eigen::Isometry3d& output_T_sensor)
{
  std::string error;
  // Never blocks: canTransform without a timeout, the scan waits in its source's wait instead. tf2 works
  // with ros::Time and ros::Duration internally: whatever it throws is this scan's failure.
  try
  {
    if (!tf_buffer_.canTransform(params_.output.frame, frame, stamp, &error))
    {
      return error.empty() ? "tf2 gave no reason" : error;
    }
    output_T_sensor = tf2::transformToEigen(tf_buffer_.lookupTransform(params_.output.frame, frame, stamp));
    // Finite links can still compose to an infinite chain: such a mount would move every return away.
    if (!output_T_sensor.matrix().allFinite())
      return "the transform is not finite";
  }
  catch (const std::exception& e)
  {
    return e.what();
  }
  return {};
}

std::string MultiLaserScanMergerRos::poseSelfFilter(std::size_t i, const sensor_msgs::LaserScan& msg,
                                                    const std::string& frame, laserscan_common::SelfFilter& posed)
{
  const SourceState& s = sources_[i];
  if (s.self_filter.empty())
    return {};
  posed = s.self_filter;
  // The arm moves during a scan; one pose per scan (not per beam: a few shapes per scan, and
  // between a lidar's 0.1 s scans the arm moves a few cm): at the middle beam's time when the
  // source deskews, which halves the largest error, at the stamp otherwise (the time the
  // merger takes the whole scan for).
  ros::Time t = msg.header.stamp;
  if (params_.sources[i].deskew && msg.ranges.size() > 1)
    t += ros::Duration(0.5 * static_cast<double>(msg.ranges.size() - 1) * msg.time_increment);
  try
  {
    for (const std::string& shape_frame : posed.frames())
      if (std::string error; !tf_buffer_.canTransform(frame, shape_frame, t, &error))
        return "self filter: no transform '" + shape_frame + "' -> '" + frame + "': " + error;
    laserscan_common::setFramePosesAt(tf_buffer_, frame, t, posed);
  }
  catch (const std::exception& e)
  {
    return e.what();
  }
  return {};
}

void MultiLaserScanMergerRos::drop(std::size_t i, std::string why)
{
  ++sources_[i].dropped;
  sources_[i].last_drop = std::move(why);
}

void MultiLaserScanMergerRos::scanCallback(std::size_t i, const sensor_msgs::LaserScan::ConstPtr& msg)
{
  std::lock_guard<std::mutex> lock(mutex_);
  // Last line of defence in a shared nodelet manager: no message may take the process down.
  try
  {
    handleScan(i, msg);
  }
  catch (const std::exception& e)
  {
    ++sources_[i].malformed;
    drop(i, std::string("unexpected error: ") + e.what());
    if (sources_[i].warnings.due("unexpected error"))
      NODE_ERROR(name_, "source '%s' (%s): scan dropped after an unexpected error (please report): %s",
                 params_.sources[i].name.c_str(), params_.sources[i].topic.c_str(), e.what());
  }
}

void MultiLaserScanMergerRos::handleScan(std::size_t i, const sensor_msgs::LaserScan::ConstPtr& msg)
{
  checkTimeJump();
  SourceState& s = sources_[i];
  const SourceParams& sp = params_.sources[i];
  ++s.received;
  const ScanView view = laserscan_common::scanViewOf(*msg);
  const ros::Time now = ros::Time::now();
  std::string fault = scanFault(view);
  if (fault.empty() && laserscan_common::tf2FrameId(msg->header.frame_id).empty())
    fault = "empty frame_id";
  if (fault.empty())
    fault = laserscan_common::stampFault(msg->header.stamp.sec, msg->header.stamp.nsec,
                                         static_cast<std::int64_t>(now.toNSec()));
  if (!fault.empty())
  {
    ++s.malformed;
    const std::string stamp = laserscan_common::stampText(msg->header.stamp.sec, msg->header.stamp.nsec);
    drop(i,
         std::string("malformed scan: ") + fault + " (stamp " + stamp + ", frame_id '" + msg->header.frame_id + "')");
    if (s.warnings.due(fault))  // a fixed text per kind of fault
      NODE_WARN(name_,
                "source '%s' (%s): malformed scan dropped: %s (stamp %s, clock %.3f, frame_id '%s', %zu "
                "ranges, %zu intensities, angles %g..%g step %g)",
                sp.name.c_str(), sp.topic.c_str(), fault.c_str(), stamp.c_str(), now.toSec(),
                msg->header.frame_id.c_str(), msg->ranges.size(), msg->intensities.size(), msg->angle_min,
                msg->angle_max, msg->angle_increment);
    expirePending();
    return;
  }
  const std::string frame = s.frame_id(msg->header.frame_id);
  if (s.scan && view.stamp < s.scan->header.stamp.toSec() - 1.0)
    clearAll("source '" + sp.name + "' stamps jumped backwards", "stamps of source " + sp.name + " jumped backwards");
  Eigen::Isometry3d output_T_sensor;
  laserscan_common::SelfFilter posed;
  std::string error = tryTransform(frame, msg->header.stamp, output_T_sensor);
  if (error.empty())
    error = poseSelfFilter(i, *msg, frame, posed);
  if (error.empty())
  {
    if (s.pending)
    {
      ++s.transform_failures;  // superseded by this newer scan before its transform came
      drop(i, "no transform '" + s.pending_frame + "' -> '" + params_.output.frame +
                "' before a newer scan was merged: " + s.pending_error);
      s.pending.reset();
    }
    accept(i, msg, view, output_T_sensor, std::move(posed));
  }
  else
  {
    if (s.pending)
    {
      ++s.transform_failures;  // replaced before its transform came
      drop(i, "no transform '" + s.pending_frame + "' -> '" + params_.output.frame + "': " + s.pending_error);
      if (s.warnings.due("no transform before the next scan"))
        NODE_WARN(name_, "source '%s': no transform '%s' -> '%s' at %.3f, scan dropped: %s", sp.name.c_str(),
                  s.pending_frame.c_str(), params_.output.frame.c_str(), s.pending->header.stamp.toSec(),
                  s.pending_error.c_str());
    }
    s.pending = msg;
    s.pending_frame = frame;
    s.pending_since = ros::WallTime::now();
    s.pending_error = error;
    // With a self filter on a deskewed source the parts are posed at the middle beam's time
    // (poseSelfFilter): the scan also waits for that.
    ros::Duration extent;
    if (!s.self_filter.empty() && sp.deskew && msg->ranges.size() > 1 && msg->time_increment > 0.0f)
      extent = ros::Duration(0.5 * static_cast<double>(msg->ranges.size() - 1) * msg->time_increment);
    s.wait->wait(msg, ros::Time(s.pending_since.sec, s.pending_since.nsec), extent);
  }
  expirePending();
}

void MultiLaserScanMergerRos::transformArrived(std::size_t i, const sensor_msgs::LaserScan::ConstPtr& msg,
                                               const ros::Time& received, const std::string& why)
{
  std::lock_guard<std::mutex> lock(mutex_);
  SourceState& s = sources_[i];
  try
  {
    checkTimeJump();  // may clear it
    if (msg != s.pending)
      return;  // given up on already (and counted then)
    Eigen::Isometry3d output_T_sensor;
    laserscan_common::SelfFilter posed;
    std::string error = why;
    const bool in_time = (ros::WallTime::now().toSec() - received.toSec()) <= kTransformWait;
    if (error.empty() && in_time)
      error = tryTransform(s.pending_frame, msg->header.stamp, output_T_sensor);
    if (error.empty() && in_time)
      error = poseSelfFilter(i, *msg, s.pending_frame, posed);
    if (error.empty() && in_time)
    {
      s.pending.reset();
      accept(i, msg, laserscan_common::scanViewOf(*msg), output_T_sensor, std::move(posed));
    }
    else
      dropPending(i, error.empty() ? s.pending_error : error);  // empty: it came after kTransformWait
    expirePending();
  }
  catch (const std::exception& e)  // as scanCallback: no message may take the manager down
  {
    ++s.malformed;
    drop(i, std::string("unexpected error: ") + e.what());
    if (s.warnings.due("unexpected error"))
      NODE_ERROR(name_, "source '%s' (%s): scan dropped after an unexpected error (please report): %s",
                 params_.sources[i].name.c_str(), params_.sources[i].topic.c_str(), e.what());
  }
}

void MultiLaserScanMergerRos::expirePending()
{
  // Only the deadline: the transforms' arrival is the wait's to notice (transformArrived).
  const ros::WallTime now = ros::WallTime::now();
  for (std::size_t i = 0; i < sources_.size(); ++i)
    if (sources_[i].pending && (now - sources_[i].pending_since).toSec() > kTransformWait)
      dropPending(i, sources_[i].pending_error);
}

void MultiLaserScanMergerRos::dropPending(std::size_t i, const std::string& error)
{
  SourceState& s = sources_[i];
  ++s.transform_failures;
  drop(i, "no transform '" + s.pending_frame + "' -> '" + params_.output.frame + "' in time: " + error);
  if (s.warnings.due("no transform in time"))
    NODE_WARN(name_, "source '%s': no transform '%s' -> '%s' at %.3f within %.1f s, scan dropped: %s",
              params_.sources[i].name.c_str(), s.pending_frame.c_str(), params_.output.frame.c_str(),
              s.pending->header.stamp.toSec(), kTransformWait, error.c_str());
  s.pending.reset();
}

void MultiLaserScanMergerRos::accept(std::size_t i, const sensor_msgs::LaserScan::ConstPtr& msg, const ScanView& view,
                                     const Eigen::Isometry3d& output_T_sensor, laserscan_common::SelfFilter self_filter)
{
  // outputs_ keeps the scan (unless older than the one kept: a late pending one is not newer
  // information, and its mount must not replace the kept scan's either). publish_rate 0: one
  // output per new scan, at the newest scan's stamp, once the scans of the other sources due at
  // that stamp are in (or sync_window ended). A scan older than the last output (a sensor a
  // little behind another) would give a second output with a stamp already published, which
  // consumers that key on stamps take for the same scan: it goes into the next output instead.
  const double now = ros::SteadyTime::now().toSec();
  outputs_->add(i, static_cast<std::int64_t>(msg->header.stamp.toNSec()), now,
                ScanInMerge{ msg, view, output_T_sensor, std::move(self_filter) }, now);
  if (params_.publish_rate > 0.0 && outputs_->waiting())
    publishTick(false);  // a tick waits for scans of its stamp: this may be the last one
}

void MultiLaserScanMergerRos::armSyncTimer(double deadline)
{
  sync_timer_.stop();
  sync_timer_.setPeriod(ros::WallDuration(std::max(0.0, deadline - ros::SteadyTime::now().toSec())));
  sync_timer_.start();
}

void MultiLaserScanMergerRos::syncTimerCallback()
{
  std::lock_guard<std::mutex> lock(mutex_);
  const double now = ros::SteadyTime::now().toSec();
  if (!outputs_->waiting())
    return;  // completed before the window ended
  if (now < outputs_->deadline())
  {
    armSyncTimer(outputs_->deadline());  // a timer of an earlier window, or a little early
    return;
  }
  if (params_.publish_rate > 0.0)
    publishTick(true);
  else
    outputs_->expire(now);
}

void MultiLaserScanMergerRos::reportSync(const ros::Time& stamp, const StampSync::Decision& decision, bool waited)
{
  if (waited)
    ++outputs_waited_;
  if (decision.due.empty())
    return;
  ++outputs_incomplete_;
  std::string names;
  for (std::size_t j : decision.due)
  {
    SourceState& s = sources_[j];
    const SourceParams& sp = params_.sources[j];
    ++s.missing_at_window;
    names += (names.empty() ? "'" : ", '") + sp.name + "'";
    if (s.warnings.due("late for sync_window"))
      NODE_WARN(name_,
                "source '%s' (%s): its scan stamped %.6f, the stamp of other sources' scans, was due and did not come "
                "within sync_window %.3f s: output published without it (it goes into a later output when it comes; a "
                "larger sync_window waits longer for it, 0 never waits)",
                sp.name.c_str(), sp.topic.c_str(), stamp.toSec(), params_.sync_window);
  }
  last_incomplete_ = laserscan_common::stampText(stamp.sec, stamp.nsec) + " without " + names;
}

void MultiLaserScanMergerRos::odomCallback(const nav_msgs::Odometry::ConstPtr& msg)
{
  std::lock_guard<std::mutex> lock(mutex_);
  try
  {
    handleOdometry(msg);
  }
  catch (const std::exception& e)
  {
    ++odom_rejected_;
    odom_last_rejection_ = std::string("unexpected error: ") + e.what();
    if (warnings_.due("odometry: unexpected error"))
      NODE_ERROR(name_, "odometry message dropped after an unexpected error (please report): %s", e.what());
  }
}

void MultiLaserScanMergerRos::handleOdometry(const nav_msgs::Odometry::ConstPtr& msg)
{
  checkTimeJump();
  ++odom_received_;
  last_odom_arrival_ = ros::WallTime::now();
  const ros::Time now = ros::Time::now();
  if (const std::string fault = laserscan_common::stampFault(msg->header.stamp.sec, msg->header.stamp.nsec,
                                                             static_cast<std::int64_t>(now.toNSec()));
      !fault.empty())
  {
    ++odom_rejected_;
    const std::string stamp = laserscan_common::stampText(msg->header.stamp.sec, msg->header.stamp.nsec);
    odom_last_rejection_ = fault + " (stamp " + stamp + ")";
    if (warnings_.due(std::string("odometry: ") + fault))
      NODE_WARN(name_, "odometry (%s) with stamp %s ignored: %s (clock %.3f)", odom_topic_.c_str(), stamp.c_str(),
                fault.c_str(), now.toSec());
    expirePending();
    return;
  }
  const auto& p = msg->pose.pose;
  const auto r = odom_.add(msg->header.stamp.toSec(), Eigen::Vector3d(p.position.x, p.position.y, p.position.z),
                           Eigen::Quaterniond(p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z));
  if (r == OdometryBuffer::AddResult::kRejected)
  {
    ++odom_rejected_;
    odom_last_rejection_ = "non-finite pose or zero quaternion";
    if (warnings_.due("odometry: not finite"))
      NODE_WARN(name_, "odometry (%s) with a non-finite pose or a zero quaternion ignored (stamp %.3f)",
                odom_topic_.c_str(), msg->header.stamp.toSec());
    expirePending();
    return;
  }
  if (r == OdometryBuffer::AddResult::kClearedBackwards)
  {
    if (warnings_.due("odometry: jumped backwards"))
      NODE_WARN(name_, "odometry time jumped backwards (to %.3f): odometry buffer cleared", msg->header.stamp.toSec());
    for (auto& s : sources_)
      s.scan.reset();  // they belong to the other timeline
    outputs_->reset();
  }
  if (r != OdometryBuffer::AddResult::kOutOfOrder)
    odom_newest_ = msg->header.stamp;
  odom_child_frame_ = odom_child_frame_id_(msg->child_frame_id);
  expirePending();
}

void MultiLaserScanMergerRos::timerCallback(const ros::TimerEvent&)
{
  std::lock_guard<std::mutex> lock(mutex_);
  checkTimeJump();
  expirePending();
  publishTick(false);
}

void MultiLaserScanMergerRos::publishTick(bool at_deadline)
{
  // With a rate, the output is synchronised to the newest data there is: the newest scan, or
  // the newest odometry when it is newer (everything moved to it). Never now(): no pose is known
  // for it. Whether it is published (nothing newer than the last output, scans of the newest
  // stamp still due within sync_window) is outputs_' decision, as with publish_rate 0.
  ros::Time t_out;
  for (const auto& s : sources_)
    if (s.scan)
      t_out = std::max(t_out, s.scan->header.stamp);
  if (!odom_.empty())
    t_out = std::max(t_out, odom_newest_);
  outputs_->tick(static_cast<std::int64_t>(t_out.toNSec()), ros::SteadyTime::now().toSec(), at_deadline);
}

void MultiLaserScanMergerRos::warnNoRobotTransform(const std::string& error)
{
  if (warnings_.due("no transform of the odometry child frame"))
    NODE_WARN(name_, "no transform '%s' -> '%s' (odometry child frame): motion compensation skipped: %s",
              odom_child_frame_.c_str(), params_.output.frame.c_str(), error.c_str());
}

bool MultiLaserScanMergerRos::robotToOutput(Eigen::Isometry3d& out)
{
  out = Eigen::Isometry3d::Identity();
  if (odom_child_frame_.empty() || odom_child_frame_ == params_.output.frame)
    return true;
  std::string error;
  if (!tf_buffer_.canTransform(params_.output.frame, odom_child_frame_, ros::Time(0), &error))
  {
    warnNoRobotTransform(error);
    return false;
  }
  try
  {
    out = tf2::transformToEigen(tf_buffer_.lookupTransform(params_.output.frame, odom_child_frame_, ros::Time(0)));
  }
  catch (const std::exception& e)
  {
    warnNoRobotTransform(e.what());
    return false;
  }
  return true;
}

void MultiLaserScanMergerRos::mergeAndPublish(const ros::Time& stamp)
{
  // The core interpolates in double seconds; the message carries the integer stamp unchanged.
  const double t_out = stamp.toSec();
  for (std::size_t i = 0; i < sources_.size(); ++i)
  {
    inputs_[i].present = static_cast<bool>(sources_[i].scan);
    if (inputs_[i].present)
    {
      inputs_[i].scan = sources_[i].view;
      inputs_[i].checked = true;  // handleScan did
      inputs_[i].output_T_sensor = sources_[i].output_T_sensor;
      inputs_[i].self_filter = &sources_[i].scan_self_filter;
    }
  }
  Eigen::Isometry3d output_T_robot;
  const OdometryBuffer* odom = nullptr;
  if (!params_.odom_topic.empty() && !odom_.empty() && robotToOutput(output_T_robot))
  {
    odom = &odom_;
    if (t_out - odom_.newestTime() > kOdometryStale && warnings_.due("odometry stopped"))
      NODE_WARN(name_,
                "odometry stopped: the newest is %.2f s older than the output time; motion after it is not "
                "compensated",
                t_out - odom_.newestTime());
  }
  else if (!params_.odom_topic.empty() && odom_.empty() && (odom_received_ == 0 || odom_rejected_ < odom_received_))
  {
    if (warnings_.due("no odometry yet", 10.0))
      NODE_WARN(name_, "no odometry yet on '%s': merging without motion compensation", odom_topic_.c_str());
  }
  else if (!params_.odom_topic.empty() && odom_.empty())
  {
    if (warnings_.due("no usable odometry", 10.0))
      NODE_WARN(name_,
                "none of the %zu odometry messages on '%s' was usable (last: %s): merging without motion "
                "compensation",
                odom_received_, odom_topic_.c_str(), odom_last_rejection_.c_str());
  }
  // The core writes straight into the message to publish.
  auto msg = boost::make_shared<sensor_msgs::LaserScan>();
  core_->merge(inputs_, t_out, odom, odom != nullptr ? output_T_robot : Eigen::Isometry3d::Identity(), msg->ranges,
               msg->intensities, status_);
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
    if (s.warnings.due("timed out"))
      NODE_WARN(name_, "source '%s': newest scan is %.2f s old (timeout %.2f s): merged without it",
                params_.sources[i].name.c_str(), t_out - stamp, params_.sources[i].timeout);
  }

  msg->header.stamp = stamp;
  msg->header.frame_id = params_.output.frame;
  msg->angle_min = static_cast<float>(params_.output.angle_min);
  msg->angle_increment = static_cast<float>(params_.output.angle_increment);
  msg->angle_max =
    static_cast<float>(params_.output.angle_min + (core_->beamCount() - 1) * params_.output.angle_increment);
  msg->time_increment = 0.0f;  // every beam is synchronised to the stamp
  msg->scan_time = params_.publish_rate > 0.0 ? static_cast<float>(1.0 / params_.publish_rate) : 0.0f;
  msg->range_min = static_cast<float>(params_.output.range_min);
  msg->range_max = static_cast<float>(params_.output.range_max);
  ++outputs_published_;
  pub_.publish(sensor_msgs::LaserScan::ConstPtr(msg));  // zero-copy in a manager; not touched afterwards
}

void MultiLaserScanMergerRos::sourceDiagnostics(std::size_t i, diagnostic_updater::DiagnosticStatusWrapper& stat)
{
  std::lock_guard<std::mutex> lock(mutex_);
  SourceState& s = sources_[i];
  const SourceParams& sp = params_.sources[i];
  const double rate = s.rate.rate(s.received);
  // In seconds (double): no ros::Duration of stamps, which may be far apart.
  const double age = s.scan ? ros::Time::now().toSec() - s.scan->header.stamp.toSec() : -1.0;
  const std::size_t dropped_now = s.dropped - s.dropped_at_last_report;
  s.dropped_at_last_report = s.dropped;
  stat.add("topic", nh_.resolveName(sp.topic));
  stat.add("merged scan topic", pub_.getTopic());  // which output these counts are about
  stat.add("scans received", s.received);
  stat.add("rate (Hz)", rate);
  stat.add("age of last scan (s)", age);
  stat.add("timeout (s)", sp.timeout);
  stat.add("scans left out by timeout", s.timeouts);
  stat.add("transform failures", s.transform_failures);
  stat.add("malformed scans", s.malformed);
  stat.add("scans dropped", s.dropped);
  stat.add("last drop reason", s.last_drop.empty() ? "none" : s.last_drop);
  stat.add("outputs that waited for its scan (sync_window)", s.waited_for);
  stat.add("outputs published without its due scan", s.missing_at_window);
  using diagnostic_msgs::DiagnosticStatus;
  if (s.received == 0)
    stat.summary(DiagnosticStatus::WARN, "no scan received yet");
  else if (!s.scan && s.pending)
    stat.summaryf(DiagnosticStatus::WARN, "%zu scans received, none merged yet: waiting for transform: %s", s.received,
                  s.pending_error.c_str());
  else if (!s.scan)
    stat.summaryf(DiagnosticStatus::WARN, "%zu scans received, none merged yet: %zu dropped, last: %s", s.received,
                  s.dropped, s.last_drop.c_str());
  else if (age > sp.timeout && dropped_now > 0)
    stat.summaryf(DiagnosticStatus::WARN, "stale: last merged scan %.1f s old; %zu newer scans dropped, last: %s", age,
                  dropped_now, s.last_drop.c_str());
  else if (age > sp.timeout)
    stat.summaryf(DiagnosticStatus::WARN, "stale: last scan %.1f s old, left out of the merge", age);
  else if (dropped_now > 0)
    stat.summaryf(DiagnosticStatus::WARN, "merged, but %zu scans dropped since the last report, last: %s", dropped_now,
                  s.last_drop.c_str());
  else
    stat.summary(DiagnosticStatus::OK, "merged");
}

void MultiLaserScanMergerRos::outputDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat)
{
  std::lock_guard<std::mutex> lock(mutex_);
  const std::size_t incomplete_now = outputs_incomplete_ - incomplete_at_last_report_;
  incomplete_at_last_report_ = outputs_incomplete_;
  stat.add("merged scan topic", pub_.getTopic());
  stat.add("outputs published", outputs_published_);
  stat.add("sync_window (s)", params_.sync_window);
  stat.add("outputs that waited for scans of their stamp", outputs_waited_);
  stat.add("outputs published without a due scan", outputs_incomplete_);
  stat.add("last output without a due scan", last_incomplete_.empty() ? "none" : last_incomplete_);
  if (incomplete_now > 0)
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                  "%zu outputs since the last report published without a scan due at their stamp (last: %s)",
                  incomplete_now, last_incomplete_.c_str());
  else
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::OK, "%zu published", outputs_published_);
}

void MultiLaserScanMergerRos::odometryDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat)
{
  std::lock_guard<std::mutex> lock(mutex_);
  if (params_.odom_topic.empty())
  {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "motion compensation disabled (odom_topic empty)");
    return;
  }
  stat.add("topic", odom_topic_);
  stat.add("messages received", odom_received_);
  stat.add("messages ignored", odom_rejected_);
  stat.add("last ignored because", odom_last_rejection_.empty() ? "none" : odom_last_rejection_);
  stat.add("queue entries", odom_.size());
  if (odom_.empty())
  {
    if (odom_received_ == 0 || odom_rejected_ < odom_received_)
      stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no odometry: merging without motion compensation");
    else
      stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                    "%zu odometry messages received, none usable (last: %s): merging without motion compensation",
                    odom_received_, odom_last_rejection_.c_str());
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
