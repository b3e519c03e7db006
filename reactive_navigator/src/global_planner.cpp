#include "reactive_navigator/global_planner.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>

namespace reactive_navigator
{

namespace
{

// A search window larger than this (cells) is not planned in: 2000 x 2000 cells, 200 m x 200 m at 0.1 m.
constexpr std::size_t kMaxCells = 4'000'000;
// Extra cost per cell at the inflated obstacle's edge, falling to 0 over `clearance`: a path keeps
// away from obstacles where the floor allows, but takes a passage the robot fits through rather
// than a detour of a few cells.
constexpr double kClearanceCost = 0.25;
constexpr double kSqrt2 = 1.4142135623730951;

}  // namespace

GlobalPlanner::GlobalPlanner(const PlannerSettings& settings) : settings_(settings) {}

long GlobalPlanner::index(double v) const
{
  return static_cast<long>(std::floor(v / settings_.resolution));
}

std::int64_t GlobalPlanner::key(long ix, long iy) const
{
  // 31 bits per axis: +-107 km at 0.1 m.
  return (static_cast<std::int64_t>(ix + (1L << 30)) << 31) | static_cast<std::int64_t>(iy + (1L << 30));
}

namespace
{
std::uint64_t sourceBit(std::size_t source)
{
  return std::uint64_t{ 1 } << std::min(source, kPlannerSources - 1);
}
}  // namespace

void GlobalPlanner::mark(double x, double y, double time, std::size_t source)
{
  const std::int64_t k = key(index(x), index(y));
  const std::uint64_t bit = sourceBit(source);
  if (k == last_key_ && time == last_time_ && bit == last_bit_)  // neighbouring points share cells
    return;
  last_key_ = k;
  last_time_ = time;
  last_bit_ = bit;
  auto [cell, added] = cells_.try_emplace(k, Cell{ time, bit });
  if (!added)
  {
    cell->second.time = std::max(cell->second.time, time);
    cell->second.sources |= bit;
  }
}

void GlobalPlanner::clearRay(long x0, long y0, long x1, long y1, bool last, std::uint64_t source_bit)
{
  // Bresenham's line through the cells; a cell off the line's 8-connected walk is not crossed.
  const long dx = std::abs(x1 - x0), dy = -std::abs(y1 - y0);
  const long sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
  long error = dx + dy;
  for (long x = x0, y = y0;;)
  {
    const bool end = x == x1 && y == y1;
    if (!end || last)
    {
      const auto it = cells_.find(key(x, y));
      if (it != cells_.end() && (it->second.sources &= ~source_bit) == 0)
        cells_.erase(it);
    }
    if (end)
      return;
    const long e2 = 2 * error;
    if (e2 >= dy)
    {
      error += dy;
      x += sx;
    }
    if (e2 <= dx)
    {
      error += dx;
      y += sy;
    }
  }
}

void GlobalPlanner::observe(std::size_t source, const Eigen::Vector2d& origin,
                            const std::vector<Eigen::Vector2d>& points, const std::vector<Eigen::Vector2d>& free_ends,
                            double time)
{
  const std::uint64_t bit = sourceBit(source);
  const double range = settings_.clearing_range;
  if (range > 0.0 && !cells_.empty())
  {
    const long ox = index(origin.x()), oy = index(origin.y());
    traced_.clear();
    std::int64_t previous = -1;  // consecutive points of a scan or cloud row often share a cell
    const auto trace = [&](const Eigen::Vector2d& end, bool hit) {
      Eigen::Vector2d to = end;
      const double length = (end - origin).norm();
      if (length > range)  // beyond the clearing range: the ray clears up to it, its end too
      {
        to = origin + (end - origin) * (range / length);
        hit = false;
      }
      const long ex = index(to.x()), ey = index(to.y());
      // A ray that ends on an obstacle and one that passes through the same cell differ in their
      // last cell only: keyed apart.
      const std::int64_t k = 2 * key(ex, ey) + (hit ? 1 : 0);
      if (k == previous || !traced_.insert(k).second)
        return;
      previous = k;
      clearRay(ox, oy, ex, ey, !hit, bit);
    };
    for (const auto& p : points)
      trace(p, true);
    for (const auto& p : free_ends)
      trace(p, false);
  }
  for (const auto& p : points)
    mark(p.x(), p.y(), time, source);
}

bool GlobalPlanner::plan(double time, const Eigen::Vector2d& start, const Eigen::Vector2d& goal)
{
  path_.clear();
  for (auto it = cells_.begin(); it != cells_.end();)
    it = time - it->second.time > settings_.memory ? cells_.erase(it) : std::next(it);

  const double r = settings_.resolution;
  const long x0 = index(std::min(start.x(), goal.x()) - settings_.margin);
  const long y0 = index(std::min(start.y(), goal.y()) - settings_.margin);
  const long x1 = index(std::max(start.x(), goal.x()) + settings_.margin);
  const long y1 = index(std::max(start.y(), goal.y()) + settings_.margin);
  const long w = x1 - x0 + 1, h = y1 - y0 + 1;
  if (static_cast<std::size_t>(w) * static_cast<std::size_t>(h) > kMaxCells)
    return false;
  const auto at = [w](long x, long y) { return static_cast<std::size_t>(y * w + x); };

  // Distance (cells) to the nearest obstacle cell: a two-pass chamfer transform (1, sqrt 2).
  const double far = std::numeric_limits<double>::infinity();
  std::vector<double> distance(static_cast<std::size_t>(w * h), far);
  for (long iy = y0; iy <= y1; ++iy)
    for (long ix = x0; ix <= x1; ++ix)
      if (cells_.count(key(ix, iy)) != 0)
        distance[at(ix - x0, iy - y0)] = 0.0;
  const auto relax = [&](long x, long y, long dx, long dy, double step) {
    const long nx = x + dx, ny = y + dy;
    if (nx >= 0 && ny >= 0 && nx < w && ny < h)
      distance[at(x, y)] = std::min(distance[at(x, y)], distance[at(nx, ny)] + step);
  };
  for (long y = 0; y < h; ++y)
    for (long x = 0; x < w; ++x)
    {
      relax(x, y, -1, 0, 1.0);
      relax(x, y, 0, -1, 1.0);
      relax(x, y, -1, -1, kSqrt2);
      relax(x, y, 1, -1, kSqrt2);
    }
  for (long y = h - 1; y >= 0; --y)
    for (long x = w - 1; x >= 0; --x)
    {
      relax(x, y, 1, 0, 1.0);
      relax(x, y, 0, 1, 1.0);
      relax(x, y, 1, 1, kSqrt2);
      relax(x, y, -1, 1, kSqrt2);
    }
  // The cost of crossing a cell, in cells of free floor.
  const double inflated = settings_.robot_radius + settings_.inflation;
  std::vector<double> cost(distance.size());
  for (std::size_t i = 0; i < cost.size(); ++i)
  {
    const double d = distance[i] * r;
    if (d < inflated)
      cost[i] = 1.0 + settings_.obstacle_cost;
    else if (d < inflated + settings_.clearance)
      cost[i] = 1.0 + kClearanceCost * (1.0 - (d - inflated) / settings_.clearance);
    else
      cost[i] = 1.0;
  }

  // A* over 8 neighbours; the straight-line distance (cells) is admissible, as no cell costs < 1.
  const long sx = index(start.x()) - x0, sy = index(start.y()) - y0;
  const long gx = index(goal.x()) - x0, gy = index(goal.y()) - y0;
  std::vector<double> g(cost.size(), far);
  std::vector<std::int32_t> parent(cost.size(), -1);
  using Entry = std::pair<double, std::size_t>;  // (f, cell)
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  const auto heuristic = [&](long x, long y) { return std::hypot(double(x - gx), double(y - gy)); };
  g[at(sx, sy)] = 0.0;
  open.emplace(heuristic(sx, sy), at(sx, sy));
  const std::size_t target = at(gx, gy);
  while (!open.empty())
  {
    const auto [f, cell] = open.top();
    open.pop();
    if (cell == target)
      break;
    const long cx = static_cast<long>(cell) % w, cy = static_cast<long>(cell) / w;
    if (f > g[cell] + heuristic(cx, cy) + 1e-9)  // a stale entry
      continue;
    for (long dy = -1; dy <= 1; ++dy)
      for (long dx = -1; dx <= 1; ++dx)
      {
        const long nx = cx + dx, ny = cy + dy;
        if ((dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= w || ny >= h)
          continue;
        const std::size_t next = at(nx, ny);
        const double step = (dx != 0 && dy != 0 ? kSqrt2 : 1.0) * 0.5 * (cost[cell] + cost[next]);
        if (g[cell] + step < g[next])
        {
          g[next] = g[cell] + step;
          parent[next] = static_cast<std::int32_t>(cell);
          open.emplace(g[next] + heuristic(nx, ny), next);
        }
      }
  }
  if (!std::isfinite(g[target]))
    return false;
  for (std::int64_t cell = static_cast<std::int64_t>(target); cell >= 0; cell = parent[static_cast<std::size_t>(cell)])
  {
    const long cx = static_cast<long>(cell) % w, cy = static_cast<long>(cell) / w;
    path_.emplace_back((static_cast<double>(cx + x0) + 0.5) * r, (static_cast<double>(cy + y0) + 0.5) * r);
  }
  std::reverse(path_.begin(), path_.end());
  path_.front() = start;
  path_.back() = goal;
  return true;
}

Eigen::Vector2d GlobalPlanner::carrot(const Eigen::Vector2d& position, double distance, double& remaining) const
{
  std::size_t nearest = 0;
  for (std::size_t i = 1; i < path_.size(); ++i)
    if ((path_[i] - position).squaredNorm() < (path_[nearest] - position).squaredNorm())
      nearest = i;
  remaining = 0.0;
  for (std::size_t i = nearest + 1; i < path_.size(); ++i)
    remaining += (path_[i] - path_[i - 1]).norm();
  Eigen::Vector2d point = path_[nearest];
  double left = distance;
  for (std::size_t i = nearest + 1; i < path_.size(); ++i)
  {
    const double segment = (path_[i] - path_[i - 1]).norm();
    if (segment >= left)
      return path_[i - 1] + (path_[i] - path_[i - 1]) * (left / segment);
    left -= segment;
    point = path_[i];
  }
  return point;
}

}  // namespace reactive_navigator
