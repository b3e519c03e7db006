#include "scan_evaluation_tools/odometry_track.hpp"

#include <algorithm>
#include <cmath>

namespace scan_evaluation_tools
{
double wrapAngle(double a)
{
  a = std::remainder(a, 2.0 * M_PI);  // [-pi, pi]
  return a <= -M_PI ? a + 2.0 * M_PI : a;
}

Pose2D compose(const Pose2D& a, const Pose2D& b)
{
  const double c = std::cos(a.yaw), s = std::sin(a.yaw);
  return { a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, wrapAngle(a.yaw + b.yaw) };
}

Pose2D between(const Pose2D& a, const Pose2D& b)
{
  const double c = std::cos(a.yaw), s = std::sin(a.yaw);
  const double dx = b.x - a.x, dy = b.y - a.y;
  return { c * dx + s * dy, -s * dx + c * dy, wrapAngle(b.yaw - a.yaw) };
}

bool OdometryTrack::add(double stamp, const Pose2D& pose)
{
  if (!std::isfinite(stamp) || !std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.yaw))
  {
    return false;
  }
  if (!stamps_.empty() && stamp <= stamps_.back())
  {
    return false;
  }
  stamps_.push_back(stamp);
  poses_.push_back({ pose.x, pose.y, wrapAngle(pose.yaw) });
  return true;
}

std::optional<Pose2D> OdometryTrack::at(double stamp) const
{
  if (stamps_.empty() || !(stamp >= stamps_.front() && stamp <= stamps_.back()))
  {
    return std::nullopt;
  }
  const auto upper = std::lower_bound(stamps_.begin(), stamps_.end(), stamp);
  const std::size_t i = static_cast<std::size_t>(upper - stamps_.begin());
  if (stamps_[i] == stamp)
  {
    return poses_[i];
  }
  const Pose2D& a = poses_[i - 1];
  const Pose2D& b = poses_[i];
  const double f = (stamp - stamps_[i - 1]) / (stamps_[i] - stamps_[i - 1]);
  return Pose2D{ a.x + f * (b.x - a.x), a.y + f * (b.y - a.y), wrapAngle(a.yaw + f * wrapAngle(b.yaw - a.yaw)) };
}

}  // namespace scan_evaluation_tools
