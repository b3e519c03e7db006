// A LaserScan as a node receives it: a view of its fields (no copy of the ranges) and the one
// check every node that takes scans applies before using one (the merger, the navigator).
// ROS-free (plain C++17).
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>
#include <string>

#include "laserscan_common/scan_geometry.hpp"

namespace laserscan_common
{
/// Read-only view of a received LaserScan (no copy of the ranges).
struct ScanView
{
  double stamp = 0.0;                                          ///< s, time of the first beam
  double angle_min = 0.0;                                      ///< rad
  double angle_max = 0.0;                                      ///< rad
  double angle_increment = 0.0;                                ///< rad
  double time_increment = 0.0;                                 ///< s between beams
  double range_min = 0.0;                                      ///< m
  double range_max = std::numeric_limits<double>::infinity();  ///< m
  const float* ranges = nullptr;
  std::size_t n_ranges = 0;
  const float* intensities = nullptr;  ///< nullptr or n_intensities == 0: none
  std::size_t n_intensities = 0;
};

/// The view of a message laid out as sensor_msgs::LaserScan (a template, so that this header needs
/// no ROS message headers).
template <class LaserScan>
ScanView scanViewOf(const LaserScan& m)
{
  ScanView v;
  v.stamp = m.header.stamp.toSec();
  v.angle_min = m.angle_min;
  v.angle_max = m.angle_max;
  v.angle_increment = m.angle_increment;
  v.time_increment = m.time_increment;
  v.range_min = m.range_min;
  v.range_max = m.range_max;
  v.ranges = m.ranges.data();
  v.n_ranges = m.ranges.size();
  v.intensities = m.intensities.empty() ? nullptr : m.intensities.data();
  v.n_intensities = m.intensities.size();
  return v;
}

/// A scan whose beams span more than this (|time_increment| * beams, s) is malformed.
constexpr double kMaxScanDuration = 60.0;

/// Beams implied by the angles (fencepost rule); 0 when the angles are unusable.
inline std::size_t expectedBeamCount(const ScanView& s)
{
  if (!std::isfinite(s.angle_min) || !std::isfinite(s.angle_max) || !std::isfinite(s.angle_increment) ||
      s.angle_increment <= 0.0 || s.angle_max < s.angle_min)
    return 0;
  if ((s.angle_max - s.angle_min) / s.angle_increment > 1e7)
    return 0;
  return beamCount(s.angle_min, s.angle_max, s.angle_increment);
}

/// "" when the scan is usable, otherwise what is wrong with it (the one error convention:
/// CONTRIBUTING.md; a usable scan's empty string allocates nothing).
inline std::string scanFault(const ScanView& s)
{
  if (!std::isfinite(s.stamp))
    return "non-finite stamp";
  if (!std::isfinite(s.angle_min) || !std::isfinite(s.angle_max) || !std::isfinite(s.angle_increment))
    return "non-finite angle_min, angle_max or angle_increment";
  if (s.angle_increment <= 0.0)
    return "angle_increment <= 0";
  if (s.angle_max < s.angle_min)
    return "angle_max < angle_min";
  if (!std::isfinite(s.time_increment))
    return "non-finite time_increment";
  if (std::abs(s.time_increment) * static_cast<double>(s.n_ranges) > kMaxScanDuration)
    return "time_increment * beams spans more than 60 s";
  if (std::isnan(s.range_min) || std::isnan(s.range_max) || s.range_min > s.range_max)
    return "range_min/range_max NaN or range_min > range_max";
  if (s.n_ranges == 0 || s.ranges == nullptr)
    return "empty ranges";
  const std::size_t expected = expectedBeamCount(s);
  if (expected == 0)
    return "angles give too many beams";
  // Drivers round angle_max in different ways; beam i is placed at angle_min + i * increment,
  // so a disagreement of one beam is harmless. More means the message is inconsistent.
  const std::size_t diff = expected > s.n_ranges ? expected - s.n_ranges : s.n_ranges - expected;
  if (diff > 1)
    return "ranges length does not match round((angle_max - angle_min) / angle_increment) + 1";
  if (s.n_intensities != 0 && (s.intensities == nullptr || s.n_intensities != s.n_ranges))
    return "intensities length is neither 0 nor the ranges length";
  return {};
}

}  // namespace laserscan_common
