#include "reactive_navigator/obstacle_points.hpp"

#include <cmath>
#include <cstring>
#include <limits>

namespace reactive_navigator
{

namespace
{

// The cloud's x, y, z stored as T (float or double), row by row (rows may be padded: row_step),
// transformed in T's precision. A float64 point kept must fit a float (a cast out of range is
// undefined): one beyond that is no obstacle a robot meets.
template <typename T>
std::size_t appendPoints(const laserscan_common::CloudView& cloud, const Eigen::Isometry3d& sensor_to_robot,
                         double band_min, double band_max, ObstaclePoints& out)
{
  using Vector = Eigen::Matrix<T, 3, 1>;
  const std::size_t before = out.size();
  const Eigen::Transform<T, 3, Eigen::Isometry> transform = sensor_to_robot.cast<T>();
  const auto lo = static_cast<T>(band_min);
  const auto hi = static_cast<T>(band_max);
  const auto largest = static_cast<T>(std::numeric_limits<float>::max());
  const auto load = [](const std::uint8_t* p) {
    T value;
    std::memcpy(&value, p, sizeof value);
    return value;
  };
  for (std::size_t row = 0; row < cloud.height; ++row)
    for (std::size_t column = 0; column < cloud.width; ++column)
    {
      const std::uint8_t* point = cloud.point(row, column);
      const Vector p(load(point + cloud.x_offset), load(point + cloud.y_offset), load(point + cloud.z_offset));
      if (!p.allFinite())
        continue;
      const Vector q = transform * p;
      if (q.z() >= lo && q.z() <= hi && q.cwiseAbs().maxCoeff() <= largest)
        out.push_back(q.template cast<float>());
    }
  return out.size() - before;
}

}  // namespace

std::size_t appendScanPoints(const ScanView& scan, const Eigen::Isometry3d& sensor_to_robot, ObstaclePoints& out)
{
  const std::size_t before = out.size();
  const Eigen::Isometry3f transform = sensor_to_robot.cast<float>();
  for (std::size_t i = 0; i < scan.n_ranges; ++i)
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

std::size_t appendScanNoReturns(const ScanView& scan, const Eigen::Isometry3d& sensor_to_robot, double distance,
                                ObstaclePoints& out)
{
  const std::size_t before = out.size();
  const Eigen::Isometry3f transform = sensor_to_robot.cast<float>();
  for (std::size_t i = 0; i < scan.n_ranges; ++i)
    if (scan.ranges[i] == std::numeric_limits<float>::infinity())
    {
      const double angle = scan.angle_min + static_cast<double>(i) * scan.angle_increment;
      out.push_back(transform * Eigen::Vector3f(static_cast<float>(distance * std::cos(angle)),
                                                static_cast<float>(distance * std::sin(angle)), 0.0f));
    }
  return out.size() - before;
}

std::size_t appendCloudPoints(const laserscan_common::CloudView& cloud, const Eigen::Isometry3d& sensor_to_robot,
                              double band_min, double band_max, ObstaclePoints& out)
{
  if (cloud.xyz_type == laserscan_common::FieldType::Float64)
    return appendPoints<double>(cloud, sensor_to_robot, band_min, band_max, out);
  return appendPoints<float>(cloud, sensor_to_robot, band_min, band_max, out);
}

}  // namespace reactive_navigator
