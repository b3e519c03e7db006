// The geometry every scan the toolbox writes follows (a converter's scan, the merger's output):
// pi, angle wrapping, the fencepost rule, the no-return value, and the checks of an output
// scan's angles and limits. ROS-free (plain C++17).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <limits>
#include <string>

#include "laserscan_common/parameter_error.hpp"

namespace laserscan_common
{
constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2.0 * kPi;

/// Wraps an angle to [-pi, pi).
inline double wrapAngle(double a)
{
  a = std::fmod(a + kPi, kTwoPi);
  if (a < 0.0)
    a += kTwoPi;
  return a - kPi;
}

/// Number of beams by the fencepost rule: round((max - min) / increment) + 1.
inline std::size_t beamCount(double angle_min, double angle_max, double angle_increment)
{
  return static_cast<std::size_t>(std::lround((angle_max - angle_min) / angle_increment)) + 1;
}

/// What a beam without a return reads: +Inf (REP 117), or range_max + inf_epsilon for consumers
/// that want finite ranges.
inline float noReturnValue(bool use_inf, double range_max, double inf_epsilon)
{
  return use_inf ? std::numeric_limits<float>::infinity() : static_cast<float>(range_max + inf_epsilon);
}

/// The rules between the angles and limits of a scan the node writes, under their parameter
/// names (each one's own limits are its table line's: checkLimits runs first); throws
/// ParameterError. A scan covers at most one turn, which also catches limits written in degrees.
inline void validateScanGeometry(double angle_min, double angle_max, double angle_increment, double range_min,
                                 double range_max, bool use_inf)
{
  const auto require = [](bool ok, const char* parameter, const char* reason) {
    if (!ok)
      throw ParameterError(parameter, reason);
  };
  require(angle_min < angle_max, "angle_min", "must be smaller than angle_max");
  if (!(angle_max - angle_min <= kTwoPi + 1e-6))
  {
    char span[32];
    std::snprintf(span, sizeof span, "%g", angle_max - angle_min);
    throw ParameterError("angle_max", "angle_max - angle_min must not exceed 2 pi (" + std::string(span) + " rad)");
  }
  require((angle_max - angle_min) / angle_increment < 1e6, "angle_increment", "gives more than one million beams");
  require(range_min < range_max, "range_min", "must be smaller than range_max");
  require(use_inf || std::isfinite(range_max), "range_max",
          "must be finite when use_inf is false (no return = range_max + inf_epsilon)");
}

}  // namespace laserscan_common
