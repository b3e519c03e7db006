#include "reactive_navigator/parameters.hpp"

#include <cmath>
#include <set>

namespace reactive_navigator
{

namespace
{

// Twice the signed area (shoelace formula): zero for a degenerate polygon.
double doubleArea(const Polygon& polygon)
{
  double sum = 0.0;
  for (std::size_t i = 0; i < polygon.size(); ++i)
  {
    const Eigen::Vector2d& a = polygon[i];
    const Eigen::Vector2d& b = polygon[(i + 1) % polygon.size()];
    sum += a.x() * b.y() - b.x() * a.y();
  }
  return sum;
}

void requirePolygon(const std::string& name, const Polygon& polygon)
{
  if (polygon.size() < 3)
    throw ParameterError(name, "needs at least 3 vertices [x, y]");
  for (const auto& v : polygon)
    if (!v.allFinite())
      throw ParameterError(name, "vertices must be finite");
  if (std::abs(doubleArea(polygon)) < 1e-6)
    throw ParameterError(name, "the polygon has no area (collinear or repeated vertices)");
}

Polygon box(double x_min, double x_max, double y_min, double y_max)
{
  return { { x_max, y_max }, { x_min, y_max }, { x_min, y_min }, { x_max, y_min } };
}

}  // namespace

Polygon paperRobotFootprint()
{
  return box(-0.37, 0.37, -0.24, 0.24);
}

std::vector<ShapeLevel> paperRobotShape3d()
{
  // The stowed arm stays within the base's outline; above the base it is the whole robot's top.
  return { { 0.60, paperRobotFootprint() }, { 0.30, paperRobotFootprint() } };
}

void NavigatorParameters::validate() const
{
  laserscan_common::checkLimits(*this);
  if (mode != "2d" && mode != "3d")
    throw ParameterError("mode", "must be '2d' or '3d', not '" + mode + "'");
  requirePolygon("footprint", footprint);
  if (shape_3d.empty())
    throw ParameterError("shape_3d", "needs at least one level {height, polygon}");
  for (std::size_t i = 0; i < shape_3d.size(); ++i)
  {
    const std::string name = "shape_3d[" + std::to_string(i) + "]";
    if (!std::isfinite(shape_3d[i].height) || shape_3d[i].height <= 0.0)
      throw ParameterError(name + ".height", "must be a finite number > 0");
    requirePolygon(name + ".polygon", shape_3d[i].polygon);
  }
}

void NodeParameters::validate() const
{
  laserscan_common::checkLimits(*this);
  if (scan_topics.empty() && cloud_topics.empty())
    throw ParameterError("scan_topics", "no obstacle source: give scan_topics and/or cloud_topics");
  std::set<std::string> seen;
  for (const auto* list : { &scan_topics, &cloud_topics })
    for (const auto& topic : *list)
    {
      const char* name = list == &scan_topics ? "scan_topics" : "cloud_topics";
      if (topic.empty())
        throw ParameterError(name, "a topic name is empty");
      if (!seen.insert(topic).second)
        throw ParameterError(name, "topic '" + topic + "' is listed twice");
    }
  if (robot_frame == odom_frame)
    throw ParameterError("robot_frame", "must differ from odom_frame");
  if (!std::isfinite(height_band_min) || !std::isfinite(height_band_max) || height_band_min >= height_band_max)
    throw ParameterError("height_band", "must be [min, max] with finite min < max (m, robot frame)");
}

}  // namespace reactive_navigator
