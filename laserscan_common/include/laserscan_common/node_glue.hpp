// What the ROS class of every node (the converters, the merger) needs around its own work:
// lazy subscription, diagnostics under the node's name, the input rate between two reports,
// how a bad parameter is named in the log. ROS glue (the library laserscan_common_node_glue).
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include "laserscan_common/parameter_error.hpp"

namespace laserscan_common
{
/// How the nodes name a bad parameter in their log: "parameter '<name>': <reason>".
inline std::string describe(const ParameterError& e)
{
  return "parameter '" + e.parameter() + "': " + e.reason();
}

/// Subscribes to the input only while someone listens to an output. The mutex is taken before
/// advertise: the connect callback may fire during it.
class LazySubscription
{
public:
  /// `subscribe` and `unsubscribe` run under the subscription's own lock.
  LazySubscription(std::function<void()> subscribe, std::function<void()> unsubscribe);

  /// Advertises an output whose listeners keep the input subscribed.
  template <class M>
  ros::Publisher advertise(ros::NodeHandle& nh, const std::string& topic, std::uint32_t queue_size)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const ros::SubscriberStatusCallback connect = [this](const ros::SingleSubscriberPublisher&) { update(); };
    publishers_.push_back(nh.advertise<M>(topic, queue_size, connect, connect));
    return publishers_.back();
  }

  /// Unsubscribes for good (call first in the owner's destructor: no callback may reach a
  /// half-destroyed object).
  void shutdown();
  bool subscribed() const { return subscribed_; }

private:
  void update();

  std::function<void()> subscribe_, unsubscribe_;
  std::mutex mutex_;
  std::vector<ros::Publisher> publishers_;
  std::atomic<bool> subscribed_{ false };
  bool shut_down_ = false;
};

/// The diagnostics of one node: its tasks under the node's name as hardware ID (one node per
/// sensor or per merged scan), published every second of wall time once started (also while a
/// simulated clock stands still).
class NodeDiagnostics
{
public:
  using Task = std::function<void(diagnostic_updater::DiagnosticStatusWrapper&)>;

  NodeDiagnostics(ros::NodeHandle nh, ros::NodeHandle private_nh);
  /// One task and started at once (a node with one status).
  NodeDiagnostics(ros::NodeHandle nh, ros::NodeHandle private_nh, const std::string& task_name, Task task);

  void add(const std::string& task_name, Task task) { updater_.add(task_name, std::move(task)); }
  /// Tasks may run from here on: start once what they read exists.
  void start();
  void stop() { timer_.stop(); }

private:
  ros::NodeHandle nh_;
  std::string name_;  ///< the node's, for the timer's warnings
  diagnostic_updater::Updater updater_;
  ros::WallTimer timer_;
};

/// Input messages per second between two diagnostics reports, each counter with its own window
/// (no report depends on another having run first).
class RateMeter
{
public:
  /// The rate since the previous call (or construction), `received` counting since start.
  double rate(std::uint64_t received);

private:
  std::uint64_t received_before_ = 0;
  ros::WallTime before_ = ros::WallTime::now();
};

}  // namespace laserscan_common
