#include "depth_filter_scan_converter/converter_glue.hpp"

#include <algorithm>
#include <utility>

#include "laserscan_common/diagnostics_timer.hpp"

namespace depth_filter_scan_converter
{
LazySubscription::LazySubscription(std::function<void()> subscribe, std::function<void()> unsubscribe)
  : subscribe_(std::move(subscribe)), unsubscribe_(std::move(unsubscribe))
{}

void LazySubscription::update()
{
  std::lock_guard<std::mutex> lock(mutex_);
  if (shut_down_)
    return;
  const bool listeners = std::any_of(publishers_.begin(), publishers_.end(),
                                     [](const ros::Publisher& p) { return p.getNumSubscribers() > 0; });
  if (listeners && !subscribed_)
  {
    subscribe_();
    subscribed_ = true;
  }
  else if (!listeners && subscribed_)
  {
    unsubscribe_();
    subscribed_ = false;
  }
}

void LazySubscription::shutdown()
{
  std::lock_guard<std::mutex> lock(mutex_);
  shut_down_ = true;
  unsubscribe_();
  subscribed_ = false;
}

ConverterDiagnostics::ConverterDiagnostics(ros::NodeHandle nh, ros::NodeHandle private_nh,
                                           std::function<void(diagnostic_updater::DiagnosticStatusWrapper&)> task)
  : updater_(nh, private_nh, private_nh.getNamespace())
{
  updater_.setHardwareID(private_nh.getNamespace());  // the node's name: one converter per sensor
  updater_.add("Input and processing", std::move(task));
  timer_ = laserscan_common::diagnosticsTimer(nh, updater_, private_nh.getNamespace());
}

double RateMeter::rate(std::uint64_t received)
{
  const ros::WallTime now = ros::WallTime::now();
  const double period = std::max((now - before_).toSec(), 1e-3);
  const double rate = static_cast<double>(received - received_before_) / period;
  received_before_ = received;
  before_ = now;
  return rate;
}

void summarize(diagnostic_updater::DiagnosticStatusWrapper& status, const std::string& problem, bool subscribed,
               double rate, const std::string& nothing_arrives)
{
  if (!problem.empty())
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, problem);
  else if (subscribed && rate == 0.0)
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, nothing_arrives);
  else
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, subscribed ? "converting" : "idle (nobody listens)");
}

}  // namespace depth_filter_scan_converter
