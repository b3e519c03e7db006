// Throttled messages per node instance: ROS_WARN_THROTTLE keeps one timer per call site, shared
// by every node in a nodelet manager, so one sensor's trouble would hide another's.
#pragma once

#include <map>
#include <string>

#include <ros/time.h>

namespace laserscan_common
{

/// True when `period` s have passed since `last` (then `last` becomes now); true the first time.
inline bool due(ros::WallTime& last, double period = 5.0)
{
  const ros::WallTime now = ros::WallTime::now();
  if (!last.isZero() && (now - last).toSec() < period)
    return false;
  last = now;
  return true;
}

/// The kind of a fault whose text carries numbers (stamps, sizes) that change from message to
/// message: the text without its digits, so that a stream of the same defect is one kind.
inline std::string faultKind(const std::string& text)
{
  std::string kind;
  for (const char c : text)
    if (c < '0' || c > '9')
      kind += c;
  return kind;
}

/// A timer per kind of fault (a fault text, a frame pair, ...): a kind is reported at once the
/// first time, then at most every period; one kind never silences another. Not locked: its owner
/// calls it under its own lock.
class WarningThrottle
{
public:
  explicit WarningThrottle(double period = 5.0) : period_(period) {}

  bool due(const std::string& kind) { return due(kind, period_); }
  bool due(const std::string& kind, double period)
  {
    if (last_.size() >= kMaxKinds && last_.count(kind) == 0)
      last_.clear();  // bounded: a publisher inventing names (frames, ...) cannot grow it forever
    return laserscan_common::due(last_[kind], period);
  }

  static constexpr std::size_t kMaxKinds = 100;

private:
  double period_;
  std::map<std::string, ros::WallTime> last_;
};

}  // namespace laserscan_common
