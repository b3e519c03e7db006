// Planar poses of the robot over time from wheel odometry: interpolation at any stamp
// and the relative motion between two poses (what a rawlog's odometry action holds).
// ROS-free: times in seconds, poses in the odometry frame.
#pragma once

#include <optional>
#include <vector>

namespace scan_evaluation_tools
{
struct Pose2D
{
  double x = 0.0;
  double y = 0.0;
  double yaw = 0.0;  // rad, in (-pi, pi]
};

/// a (+) b: pose b given in a's frame, expressed in a's parent frame.
Pose2D compose(const Pose2D& a, const Pose2D& b);

/// (-)a (+) b: pose b expressed in a's frame (b = compose(a, between(a, b))).
Pose2D between(const Pose2D& a, const Pose2D& b);

/// Angle wrapped into (-pi, pi].
double wrapAngle(double a);

class OdometryTrack
{
public:
  /// Adds a pose; stamps must not go back (an older or equal stamp returns false and is not added).
  bool add(double stamp, const Pose2D& pose);

  /// Pose at `stamp` by linear interpolation of position and shortest-arc interpolation of
  /// yaw between the two poses around it; empty outside [first stamp, last stamp].
  std::optional<Pose2D> at(double stamp) const;

  std::size_t size() const { return stamps_.size(); }
  double firstStamp() const { return stamps_.front(); }
  double lastStamp() const { return stamps_.back(); }

private:
  std::vector<double> stamps_;
  std::vector<Pose2D> poses_;
};

}  // namespace scan_evaluation_tools
