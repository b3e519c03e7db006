#include "depth_filter_scan_converter/parameters.hpp"

#include <limits>

namespace depth_filter_scan_converter
{
namespace
{
void require(bool ok, const char* parameter, const char* reason)
{
  if (!ok)
    throw ParameterError(parameter, reason);
}
}  // namespace

void TransformParams::validate() const
{
  require(!reference_frame.empty(), "reference_frame", "must not be empty");
  require(reference_frame.front() != '/', "reference_frame",
          "must not start with '/' (tf2 frame ids have no leading slash)");
  require(std::isfinite(transform_tolerance) && transform_tolerance >= 0.0, "transform_tolerance",
          "must be finite and >= 0");
  require(std::isfinite(tf_buffer_duration) && tf_buffer_duration > 0.0, "tf_buffer_duration",
          "must be finite and > 0");
}

void BandParams::validate() const
{
  require(std::isfinite(floor_height), "floor_height", "must be finite");
  // Heights may be +/-inf ("no limit") but not NaN.
  require(!std::isnan(min_height), "min_height", "must not be NaN");
  require(!std::isnan(max_height), "max_height", "must not be NaN");
  require(min_height < max_height, "min_height", "must be smaller than max_height");
  require(std::isfinite(hole_depth) && hole_depth >= 0.0, "hole_depth", "must be finite and >= 0");
}

void ScanParams::validate() const
{
  // The same angle rules as multi_laserscan_merger's output: a scan covers at most one turn,
  // which also catches limits written in degrees.
  constexpr double kTwoPi = 2.0 * 3.14159265358979323846;
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

std::size_t ScanParams::beamCount() const
{
  return static_cast<std::size_t>(std::lround((angle_max - angle_min) / angle_increment)) + 1;
}

float ScanParams::noReturnValue() const
{
  return use_inf ? std::numeric_limits<float>::infinity() : static_cast<float>(range_max + inf_epsilon);
}

float ScanParams::tooCloseValue() const
{
  return too_close_at_range_min ? static_cast<float>(range_min) : -std::numeric_limits<float>::infinity();
}

void RangeNoiseParams::validate() const
{
  require(std::isfinite(range_noise_std) && range_noise_std >= 0.0, "range_noise_std", "must be finite and >= 0 (m)");
  require(std::isfinite(range_noise_std_per_m2) && range_noise_std_per_m2 >= 0.0, "range_noise_std_per_m2",
          "must be finite and >= 0 (1/m)");
}

void InputParams::validate() const
{
  require(row_stride >= 1, "row_stride", "must be >= 1");
  require(column_stride >= 1, "column_stride", "must be >= 1");
  require(queue_size >= 1, "queue_size", "must be >= 1");
}

void Parameters::validate() const
{
  transform.validate();
  band.validate();
  scan.validate();
  noise.validate();
  input.validate();
}

}  // namespace depth_filter_scan_converter
