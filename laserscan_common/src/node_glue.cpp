#include "laserscan_common/node_glue.hpp"

#include <algorithm>
#include <utility>

#include "laserscan_common/diagnostics_timer.hpp"

namespace laserscan_common
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

NodeDiagnostics::NodeDiagnostics(ros::NodeHandle nh, ros::NodeHandle private_nh)
  : nh_(nh), name_(private_nh.getNamespace()), updater_(nh, private_nh, name_)
{
  updater_.setHardwareID(private_nh.getNamespace());  // the node's name
}

NodeDiagnostics::NodeDiagnostics(ros::NodeHandle nh, ros::NodeHandle private_nh, const std::string& task_name,
                                 Task task)
  : NodeDiagnostics(nh, private_nh)
{
  add(task_name, std::move(task));
  start();
}

void NodeDiagnostics::start()
{
  timer_ = diagnosticsTimer(nh_, updater_, name_);
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

}  // namespace laserscan_common
