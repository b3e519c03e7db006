#include "depth_filter_scan_converter/range_to_scan.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "laserscan_common/scan_geometry.hpp"

namespace depth_filter_scan_converter
{
namespace
{
std::string describe(const char* what, double value)
{
  std::ostringstream s;
  s << what << " " << value;
  return s.str();
}
}  // namespace

void RangeScanParameters::validate() const
{
  // Every rule is one field's limits (the table's): up to 4x the cone (wider arcs mark mostly
  // free space: use arc_width for a fixed, wide arc); at most 100000 beams over one turn.
  laserscan_common::checkLimits(*this);
}

const char* readingKindName(ReadingKind kind)
{
  switch (kind)
  {
    case ReadingKind::Obstacle:
      return "obstacle";
    case ReadingKind::Unconfirmed:
      return "unconfirmed";
    case ReadingKind::NoReturn:
      return "no return";
    case ReadingKind::TooClose:
      return "too close";
    default:
      return "invalid";
  }
}

void arcGeometry(double width, double max_increment, ArcScan& scan)
{
  const auto gaps = static_cast<std::size_t>(std::ceil(width / max_increment - 1e-9));
  scan.angle_min = -0.5 * width;
  scan.angle_max = 0.5 * width;
  // One beam for a zero width: a LaserScan still needs a positive increment.
  scan.angle_increment = gaps == 0 ? max_increment : width / static_cast<double>(gaps);
  scan.ranges.resize(gaps + 1);
}

std::string checkReading(const RangeReading& r, const RangeScanParameters& params)
{
  if (r.frame_id.empty())
    return "empty frame_id";
  if (r.radiation_type > 1)
    return describe("unknown radiation_type", r.radiation_type) + " (0 ULTRASOUND, 1 INFRARED)";
  if (!std::isfinite(r.min_range) || r.min_range < 0.0)
    return describe("min_range must be finite and >= 0, got", r.min_range);
  if (std::isnan(r.max_range) || r.max_range <= 0.0)
    return describe("max_range must be > 0, got", r.max_range);
  if (!(r.min_range < r.max_range))
    return describe("min_range", r.min_range) + describe(" is not smaller than max_range", r.max_range);
  if (params.arc_width <= 0.0 &&
      !(std::isfinite(r.field_of_view) && r.field_of_view >= 0.0 && r.field_of_view <= kTwoPi + 1e-6))
    return describe("field_of_view must be within [0, 2*pi] rad, got", r.field_of_view);
  if (!std::isfinite(r.stamp))
    return "non-finite stamp";
  return "";
}

RangeToScan::RangeToScan(const RangeScanParameters& params) : params_(params)
{
  params_.validate();
}

double RangeToScan::arcWidth(double field_of_view) const
{
  const double width = params_.arc_width > 0.0 ? params_.arc_width : field_of_view * params_.arc_width_scale;
  return std::min(width, kTwoPi);
}

void RangeToScan::reset()
{
  in_range_in_a_row_ = 0;
  have_last_stamp_ = false;
}

std::string RangeToScan::convert(const RangeReading& r, ArcScan& scan)
{
  std::string reason = checkReading(r, params_);
  if (!reason.empty())
  {
    in_range_in_a_row_ = 0;  // a broken message breaks the run of confirmations
    return reason;
  }
  if (have_last_stamp_ && r.stamp < last_stamp_)
    in_range_in_a_row_ = 0;
  last_stamp_ = r.stamp;
  have_last_stamp_ = true;

  float value;
  if (std::isnan(r.range))
    scan.kind = ReadingKind::Invalid;
  else if (r.range >= r.max_range)
    scan.kind = ReadingKind::NoReturn;
  else if (r.range == -std::numeric_limits<double>::infinity())
    scan.kind = ReadingKind::TooClose;
  else if (r.range < r.min_range)  // 0.0 and the like are driver errors, not "too close" (REP 117)
    scan.kind = ReadingKind::Invalid;
  else
    scan.kind =
      ++in_range_in_a_row_ >= params_.min_consecutive_readings ? ReadingKind::Obstacle : ReadingKind::Unconfirmed;
  if (scan.kind != ReadingKind::Obstacle && scan.kind != ReadingKind::Unconfirmed)
    in_range_in_a_row_ = 0;
  in_range_in_a_row_ = std::min(in_range_in_a_row_, params_.min_consecutive_readings);

  switch (scan.kind)
  {
    case ReadingKind::Obstacle:
      value = static_cast<float>(r.range);
      break;
    case ReadingKind::NoReturn:
      value = std::numeric_limits<float>::infinity();
      break;
    case ReadingKind::TooClose:
      value = -std::numeric_limits<float>::infinity();
      break;
    default:
      value = std::numeric_limits<float>::quiet_NaN();
  }
  arcGeometry(arcWidth(r.field_of_view), params_.angle_increment, scan);
  std::fill(scan.ranges.begin(), scan.ranges.end(), value);
  scan.range_min = r.min_range;
  scan.range_max = r.max_range;
  return reason;
}

}  // namespace depth_filter_scan_converter
