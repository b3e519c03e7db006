#include "reactive_navigator/obstacle_points.hpp"

#include <cmath>
#include <cstring>
#include <limits>

namespace reactive_navigator
{

std::size_t appendScanPoints(const ScanView& scan, const Eigen::Isometry3d& sensor_to_robot, ObstaclePoints& out)
{
  const std::size_t before = out.size();
  const Eigen::Isometry3f transform = sensor_to_robot.cast<float>();
  for (std::size_t i = 0; i < scan.count; ++i)
  {
    double range = scan.ranges[i];
    if (std::isnan(range) || range == std::numeric_limits<double>::infinity())
      continue;
    if (range == -std::numeric_limits<double>::infinity())
      range = scan.range_min;
    else if (range < scan.range_min || range > scan.range_max)
      continue;
    const double angle = scan.angle_min + static_cast<double>(i) * scan.angle_increment;
    out.push_back(transform * Eigen::Vector3f(static_cast<float>(range * std::cos(angle)),
                                              static_cast<float>(range * std::sin(angle)), 0.0f));
  }
  return out.size() - before;
}

std::size_t appendCloudPoints(const CloudView& cloud, const Eigen::Isometry3d& sensor_to_robot, double band_min,
                              double band_max, ObstaclePoints& out)
{
  const std::size_t before = out.size();
  const Eigen::Isometry3f transform = sensor_to_robot.cast<float>();
  const auto lo = static_cast<float>(band_min);
  const auto hi = static_cast<float>(band_max);
  for (std::size_t i = 0; i < cloud.count; ++i)
  {
    const std::uint8_t* point = cloud.data + i * cloud.point_step;
    Eigen::Vector3f p;
    std::memcpy(&p.x(), point + cloud.offset_x, sizeof(float));
    std::memcpy(&p.y(), point + cloud.offset_y, sizeof(float));
    std::memcpy(&p.z(), point + cloud.offset_z, sizeof(float));
    if (!p.allFinite())
      continue;
    const Eigen::Vector3f q = transform * p;
    if (q.z() >= lo && q.z() <= hi)
      out.push_back(q);
  }
  return out.size() - before;
}

}  // namespace reactive_navigator
