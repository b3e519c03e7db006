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
  laserscan_common::checkLimits(*this);
}

void BandParams::validate() const
{
  laserscan_common::checkLimits(*this);  // heights may be +-inf ("no limit"), never NaN
  require(min_height < max_height, "min_height", "must be smaller than max_height");
}

void ScanParams::validate() const
{
  laserscan_common::checkLimits(*this);
  // The same rules between fields as multi_laserscan_merger's output: one home, laserscan_common.
  laserscan_common::validateScanGeometry(angle_min, angle_max, angle_increment, range_min, range_max, use_inf);
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
  laserscan_common::checkLimits(*this);
}

void InputParams::validate() const
{
  laserscan_common::checkLimits(*this);
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
