// The geometry every scan the toolbox writes follows (a converter's scan, the merger's output):
// pi, angle wrapping, the fencepost rule, the no-return value, and the checks of an output
// scan's angles and limits. ROS-free (plain C++17).
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>

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

/// The angles and limits of a scan the node writes, under their parameter names; throws
/// ParameterError. A scan covers at most one turn, which also catches limits written in degrees.
inline void validateScanGeometry(double angle_min, double angle_max, double angle_increment, double range_min,
                                 double range_max, bool use_inf, double inf_epsilon)
{
  const auto require = [](bool ok, const char* parameter, const char* reason) {
    if (!ok)
      throw ParameterError(parameter, reason);
  };
  require(std::isfinite(angle_min) && angle_min >= -kTwoPi && angle_min <= kTwoPi, "angle_min",
          "must be finite and within [-2*pi, 2*pi] (radians)");
  require(std::isfinite(angle_max) && angle_max >= -kTwoPi && angle_max <= kTwoPi, "angle_max",
          "must be finite and within [-2*pi, 2*pi] (radians)");
  require(angle_min < angle_max, "angle_min", "must be smaller than angle_max");
  require(angle_max - angle_min <= kTwoPi + 1e-6, "angle_max", "angle_max - angle_min must not exceed 2*pi");
  require(std::isfinite(angle_increment) && angle_increment > 0.0, "angle_increment", "must be a finite value > 0");
  require((angle_max - angle_min) / angle_increment < 1e6, "angle_increment", "gives more than one million beams");
  require(std::isfinite(range_min) && range_min >= 0.0, "range_min", "must be finite and >= 0");
  require(!std::isnan(range_max), "range_max", "must not be NaN");
  require(range_min < range_max, "range_min", "must be smaller than range_max");
  require(std::isfinite(inf_epsilon) && inf_epsilon >= 0.0, "inf_epsilon", "must be finite and >= 0");
  require(use_inf || std::isfinite(range_max), "range_max",
          "must be finite when use_inf is false (no return = range_max + inf_epsilon)");
}

}  // namespace laserscan_common
