#include "scan_evaluation_tools/occupancy_map_3d.hpp"

#include "laserscan_common/parameter_error.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace scan_evaluation_tools
{
namespace
{
void requireProbability(const char* name, double p)
{
  if (!(p > 0.0 && p < 1.0))
  {
    throw laserscan_common::ParameterError(name, "must be a probability in (0, 1), got " + std::to_string(p));
  }
}

template <typename Depth>
void addDepthPoints(const std::uint8_t* data, std::uint32_t width, std::uint32_t height, std::uint32_t row_step,
                    bool swap, double unit, const PinholeCamera& c, octomap::Pointcloud& points)
{
  const double inv_fx = 1.0 / c.fx;
  const double inv_fy = 1.0 / c.fy;
  for (std::uint32_t v = 0; v < height; ++v)
  {
    const std::uint8_t* row = data + static_cast<std::size_t>(v) * row_step;
    const double dy = (static_cast<double>(v) - c.cy) * inv_fy;
    for (std::uint32_t u = 0; u < width; ++u)
    {
      Depth raw;
      std::memcpy(&raw, row + u * sizeof(Depth), sizeof(Depth));
      if (swap)
      {
        auto* b = reinterpret_cast<std::uint8_t*>(&raw);
        std::reverse(b, b + sizeof(Depth));
      }
      const double z = static_cast<double>(raw) * unit;
      if (!(z > 0.0) || !std::isfinite(z))
      {
        continue;  // no measurement
      }
      points.push_back(static_cast<float>((static_cast<double>(u) - c.cx) * inv_fx * z), static_cast<float>(dy * z),
                       static_cast<float>(z));
    }
  }
}
}  // namespace

void OctoMapParameters::validate() const
{
  if (!(resolution > 0.0) || !std::isfinite(resolution))
  {
    throw laserscan_common::ParameterError("resolution", "must be > 0 m, got " + std::to_string(resolution));
  }
  if (!(max_range > 0.0))
  {
    throw laserscan_common::ParameterError("max_range", "must be > 0 m, got " + std::to_string(max_range));
  }
  requireProbability("prob_hit", prob_hit);
  requireProbability("prob_miss", prob_miss);
  requireProbability("clamp_min", clamp_min);
  requireProbability("clamp_max", clamp_max);
  if (!(prob_hit > 0.5 && prob_miss < 0.5))
  {
    throw laserscan_common::ParameterError("prob_hit",
                                           "a hit must raise (> 0.5) and a miss lower (< 0.5) the occupancy");
  }
  if (!(clamp_min < clamp_max))
  {
    throw laserscan_common::ParameterError("clamp_min", "must be below clamp_max");
  }
}

void depthImagePoints(const std::uint8_t* data, std::size_t size, std::uint32_t width, std::uint32_t height,
                      std::uint32_t row_step, const std::string& encoding, bool big_endian, const PinholeCamera& camera,
                      octomap::Pointcloud& points)
{
  const bool mm = encoding == "16UC1" || encoding == "mono16";
  if (!mm && encoding != "32FC1")
  {
    throw std::invalid_argument("depth encoding '" + encoding + "' (expected 16UC1 or 32FC1)");
  }
  const std::size_t pixel = mm ? 2 : 4;
  if (static_cast<std::size_t>(row_step) < width * pixel || static_cast<std::size_t>(row_step) * height > size)
  {
    throw std::invalid_argument("depth image of " + std::to_string(width) + " x " + std::to_string(height) +
                                " with step " + std::to_string(row_step) + " does not fit its " + std::to_string(size) +
                                " bytes");
  }
  if (!(camera.fx > 0.0) || !(camera.fy > 0.0))
  {
    throw std::invalid_argument("camera_info with a focal length <= 0 (P[0] or P[5])");
  }
  const bool swap = big_endian != (__BYTE_ORDER__ == __ORDER_BIG_ENDIAN__);
  if (mm)
  {
    addDepthPoints<std::uint16_t>(data, width, height, row_step, swap, 0.001, camera, points);
  }
  else
  {
    addDepthPoints<float>(data, width, height, row_step, swap, 1.0, camera, points);
  }
}

void scanPoints(const std::vector<float>& ranges, double angle_min, double angle_increment, double range_min,
                double range_max, octomap::Pointcloud& points)
{
  for (std::size_t i = 0; i < ranges.size(); ++i)
  {
    const double r = ranges[i];
    if (!std::isfinite(r) || r < range_min || r > range_max)
    {
      continue;
    }
    const double a = angle_min + angle_increment * static_cast<double>(i);
    points.push_back(static_cast<float>(r * std::cos(a)), static_cast<float>(r * std::sin(a)), 0.0f);
  }
}

void transformPoints(const Eigen::Isometry3d& map_from_sensor, octomap::Pointcloud& points)
{
  const Eigen::Matrix3f r = map_from_sensor.linear().cast<float>();
  const Eigen::Vector3f t = map_from_sensor.translation().cast<float>();
  for (auto& p : points)
  {
    const Eigen::Vector3f q = r * Eigen::Vector3f(p.x(), p.y(), p.z()) + t;
    p = octomap::point3d(q.x(), q.y(), q.z());
  }
}

std::int8_t ProjectedMap::at(double x, double y) const
{
  const double col = std::floor((x - origin_x) / resolution);
  const double row = std::floor((y - origin_y) / resolution);
  if (col < 0 || row < 0 || col >= width || row >= height)
  {
    return -1;
  }
  return cells[static_cast<std::size_t>(row) * width + static_cast<std::size_t>(col)];
}

std::size_t ProjectedMap::occupied() const
{
  return static_cast<std::size_t>(std::count(cells.begin(), cells.end(), std::int8_t{ 100 }));
}

OccupancyMap3D::OccupancyMap3D(const OctoMapParameters& parameters)
  : parameters_(parameters), tree_((parameters.validate(), parameters.resolution))
{
  tree_.setProbHit(parameters_.prob_hit);
  tree_.setProbMiss(parameters_.prob_miss);
  tree_.setClampingThresMin(parameters_.clamp_min);
  tree_.setClampingThresMax(parameters_.clamp_max);
}

void OccupancyMap3D::insert(const octomap::Pointcloud& points_in_map, const octomap::point3d& origin)
{
  tree_.insertPointCloud(points_in_map, origin, parameters_.max_range, /*lazy_eval=*/true);
  points_inserted_ += points_in_map.size();
  ++clouds_inserted_;
}

void OccupancyMap3D::update()
{
  tree_.updateInnerOccupancy();
  tree_.prune();
}

ProjectedMap OccupancyMap3D::project(double z_min, double z_max) const
{
  ProjectedMap map;
  map.resolution = tree_.getResolution();
  if (tree_.size() == 0)
  {
    return map;
  }
  double x0, y0, z0, x1, y1, z1;
  tree_.getMetricMin(x0, y0, z0);
  tree_.getMetricMax(x1, y1, z1);
  const double res = map.resolution;
  map.origin_x = x0;
  map.origin_y = y0;
  map.width = static_cast<std::uint32_t>(std::lround((x1 - x0) / res));
  map.height = static_cast<std::uint32_t>(std::lround((y1 - y0) / res));
  map.cells.assign(static_cast<std::size_t>(map.width) * map.height, -1);
  for (auto it = tree_.begin_leafs(), end = tree_.end_leafs(); it != end; ++it)
  {
    const double half = 0.5 * it.getSize();
    // octomap_server's test: the voxel reaches into the band
    if (!(it.getZ() + half > z_min && it.getZ() - half < z_max))
    {
      continue;
    }
    const bool occupied = tree_.isNodeOccupied(*it);
    const long c0 = std::lround((it.getX() - half - x0) / res);
    const long r0 = std::lround((it.getY() - half - y0) / res);
    const long n = std::max(1L, std::lround(it.getSize() / res));
    for (long r = std::max(0L, r0); r < std::min<long>(map.height, r0 + n); ++r)
    {
      for (long c = std::max(0L, c0); c < std::min<long>(map.width, c0 + n); ++c)
      {
        auto& cell = map.cells[static_cast<std::size_t>(r) * map.width + static_cast<std::size_t>(c)];
        if (occupied)
        {
          cell = 100;
        }
        else if (cell == -1)
        {
          cell = 0;
        }
      }
    }
  }
  return map;
}

}  // namespace scan_evaluation_tools
