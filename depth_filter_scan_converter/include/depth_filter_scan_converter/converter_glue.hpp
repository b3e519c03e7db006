// What the ROS classes of the package's converters (depth cloud or image, range) share: the
// parameter error's log text, throttled warnings, lazy subscription, diagnostics. Used by the package only.
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
#include "laserscan_common/throttle.hpp"

namespace depth_filter_scan_converter
{
/// How the nodes name a bad parameter in their log: "parameter '<name>': <reason>".
inline std::string describe(const laserscan_common::ParameterError& e)
{
  return "parameter '" + e.parameter() + "': " + e.reason();
}

// Per converter, not per call site as ROS_WARN_THROTTLE.
using laserscan_common::WarningThrottle;

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

/// The diagnostics of one converter: one task, "Input and processing", updated every second,
/// under the node's name as hardware ID (one converter per sensor).
class ConverterDiagnostics
{
public:
  ConverterDiagnostics(ros::NodeHandle nh, ros::NodeHandle private_nh,
                       std::function<void(diagnostic_updater::DiagnosticStatusWrapper&)> task);
  void stop() { timer_.stop(); }

private:
  diagnostic_updater::Updater updater_;
  ros::WallTimer timer_;
};

/// Input messages per second between two diagnostics updates.
class RateMeter
{
public:
  /// The rate since the previous call (or construction), `received` counting since start.
  double rate(std::uint64_t received);

private:
  std::uint64_t received_before_ = 0;
  ros::WallTime before_ = ros::WallTime::now();
};

/// The summary of a converter's diagnostics: WARN with `problem` when there is one, WARN when
/// subscribed but nothing arrives (`nothing_arrives`), else OK converting or idle.
void summarize(diagnostic_updater::DiagnosticStatusWrapper& status, const std::string& problem, bool subscribed,
               double rate, const std::string& nothing_arrives);

}  // namespace depth_filter_scan_converter
