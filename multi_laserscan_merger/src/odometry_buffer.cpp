#include "multi_laserscan_merger/odometry_buffer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace multi_laserscan_merger
{

Eigen::Isometry3d Pose::toIsometry() const
{
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  iso.linear() = orientation.toRotationMatrix();
  iso.translation() = position;
  return iso;
}

Eigen::Quaterniond slerpShortest(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b, double u)
{
  double d = a.coeffs().dot(b.coeffs());
  Eigen::Vector4d bc = b.coeffs();
  if (d < 0.0)
  {
    // b and -b are the same rotation; -b is the one on the short arc from a.
    d = -d;
    bc = -bc;
  }
  double wa, wb;
  if (d > 0.9995)
  {
    // Nearly parallel: sin(theta) ~ 0, a normalised lerp is exact to rounding.
    wa = 1.0 - u;
    wb = u;
  }
  else
  {
    const double theta = std::acos(std::min(d, 1.0));
    const double s = std::sin(theta);
    wa = std::sin((1.0 - u) * theta) / s;
    wb = std::sin(u * theta) / s;
  }
  Eigen::Quaterniond q;
  q.coeffs() = wa * a.coeffs() + wb * bc;
  q.normalize();
  return q;
}

OdometryBuffer::OdometryBuffer(std::size_t capacity, double jump_back_threshold)
  : capacity_(std::max<std::size_t>(capacity, 1)), jump_back_threshold_(jump_back_threshold)
{
  entries_.reserve(capacity_ + 1);
}

OdometryBuffer::AddResult OdometryBuffer::add(double t, const Eigen::Vector3d& position,
                                              const Eigen::Quaterniond& orientation)
{
  const double n = orientation.norm();
  if (!std::isfinite(t) || !position.allFinite() || !std::isfinite(n) || n < 1e-6)
    return AddResult::kRejected;
  Entry e{ t, Pose{ position, orientation.normalized() } };
  AddResult result = AddResult::kAdded;
  if (!entries_.empty())
  {
    if (t < entries_.back().t && t > entries_.back().t - jump_back_threshold_)
      return AddResult::kOutOfOrder;
    if (t < entries_.back().t)
    {
      // A bag played in a loop or a restarted clock: old poses would be
      // interpolated against new ones, so start afresh.
      entries_.clear();
      result = AddResult::kClearedBackwards;
    }
    else if (t == entries_.back().t)
    {
      entries_.back() = e;
      return result;
    }
  }
  entries_.push_back(e);
  if (entries_.size() > capacity_)
    entries_.erase(entries_.begin(), entries_.begin() + static_cast<std::ptrdiff_t>(entries_.size() - capacity_));
  return result;
}

bool OdometryBuffer::poseAt(double t, Pose& out) const
{
  if (entries_.empty())
    return false;
  if (!(t > entries_.front().t))  // also catches NaN: use the oldest
  {
    out = entries_.front().pose;
    return true;
  }
  if (t >= entries_.back().t)
  {
    out = entries_.back().pose;
    return true;
  }
  // First entry with time > t; its predecessor has time <= t.
  const auto it =
    std::upper_bound(entries_.begin(), entries_.end(), t, [](double v, const Entry& e) { return v < e.t; });
  const Entry& e2 = *it;
  const Entry& e1 = *(it - 1);
  const double u = (t - e1.t) / (e2.t - e1.t);
  out.position = (1.0 - u) * e1.pose.position + u * e2.pose.position;
  out.orientation = slerpShortest(e1.pose.orientation, e2.pose.orientation, u);
  return true;
}

Eigen::Isometry3d OdometryBuffer::motion(double t_from, double t_to) const
{
  Pose from, to;
  if (!poseAt(t_from, from) || !poseAt(t_to, to))
    return Eigen::Isometry3d::Identity();
  return to.toIsometry().inverse(Eigen::Isometry) * from.toIsometry();
}

double OdometryBuffer::oldestTime() const
{
  return entries_.empty() ? std::numeric_limits<double>::quiet_NaN() : entries_.front().t;
}

double OdometryBuffer::newestTime() const
{
  return entries_.empty() ? std::numeric_limits<double>::quiet_NaN() : entries_.back().t;
}

}  // namespace multi_laserscan_merger
