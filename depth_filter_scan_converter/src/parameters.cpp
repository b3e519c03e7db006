#include "depth_filter_scan_converter/parameters.hpp"

#include <limits>

#include "laserscan_common/scan_geometry.hpp"

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
  // The same rules as multi_laserscan_merger's output: one home, laserscan_common.
  laserscan_common::validateScanGeometry(angle_min, angle_max, angle_increment, range_min, range_max, use_inf,
                                         inf_epsilon);
}

std::size_t ScanParams::beamCount() const
{
  return laserscan_common::beamCount(angle_min, angle_max, angle_increment);
}

float ScanParams::noReturnValue() const
{
  return laserscan_common::noReturnValue(use_inf, range_max, inf_epsilon);
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
