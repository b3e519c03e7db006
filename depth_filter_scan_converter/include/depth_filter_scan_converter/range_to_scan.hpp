// One range reading (ultrasonic or infrared, sensor_msgs/Range) -> a LaserScan arc (ROS-free).
//
// A reading inside [min_range, max_range) is an obstacle somewhere across the sensor's cone at
// that distance: every beam of the arc reads it. At or beyond max_range it is no return (+Inf),
// -Inf too close, NaN or a finite value below min_range invalid (NaN; REP 117: a 0.0 is a
// driver's error or no-echo code, not an obstacle). The scan lies in the sensor's frame,
// its beams spread symmetrically around the frame's x axis (the cone's axis, as sensor_msgs/Range
// defines it).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cmath>
#include <string>
#include <type_traits>
#include <vector>

#include "laserscan_common/parameter_error.hpp"
#include "laserscan_common/parameter_table.hpp"
#include "laserscan_common/scan_geometry.hpp"

namespace depth_filter_scan_converter
{
using laserscan_common::kTwoPi;
using laserscan_common::ParameterError;

/// Every tunable of the range converter, with its default, in one place (metres, radians).
struct RangeScanParameters
{
  double arc_width_scale = 1.0;          ///< the arc spans field_of_view * this (0 < scale <= 4) ...
  double arc_width = 0.0;                ///< ... unless this is > 0: then the arc spans this (rad)
  double angle_increment = 0.004363323;  ///< largest beam spacing (pi/720, the merger's default)
  int min_consecutive_readings = 1;      ///< in-range readings in a row before one is an obstacle
  int queue_size = 10;                   ///< subscriber queue (ROS glue only)

  /// Throws ParameterError naming the first bad parameter and why.
  void validate() const;
};

/// The table of RangeScanParameters (laserscan_common/parameter_table.hpp).
template <class P, class V, std::enable_if_t<std::is_same_v<std::decay_t<P>, RangeScanParameters>, int> = 0>
void visitFields(P& p, V&& visit)
{
  using laserscan_common::ParamInfo;
  visit(p.arc_width_scale,
        ParamInfo("arc_width_scale", "", "the arc spans `field_of_view * arc_width_scale`; within (0, 4]")
          .above(0.0)
          .atMost(4.0));
  visit(p.arc_width, ParamInfo("arc_width", "rad",
                               "when > 0, the arc spans this, whatever the message's `field_of_view`; within [0, 2 pi]")
                       .atLeast(0.0)
                       .atMost(kTwoPi + 1e-6));
  visit(p.angle_increment, ParamInfo("angle_increment", "rad",
                                     "largest spacing between the arc's beams, > 2 pi / 100000; the merger's default "
                                     "output resolution, so the arc leaves no gaps in its bins")
                             .above(kTwoPi / 100000.0)
                             .finiteOnly()
                             .shownAs("`0.004363323` (pi/720, 0.25 deg)"));
  visit(p.min_consecutive_readings,
        ParamInfo("min_consecutive_readings", "readings",
                  "in-range readings in a row before one is an obstacle (1: no debounce), >= 1")
          .atLeast(1));
  visit(p.queue_size, ParamInfo("queue_size", "readings", "subscriber queue, >= 1").atLeast(1));
}

/// The fields of a sensor_msgs/Range the conversion uses (stamp in seconds).
struct RangeReading
{
  std::string frame_id;
  double stamp = 0.0;
  std::uint8_t radiation_type = 0;  ///< 0 ULTRASOUND, 1 INFRARED
  double field_of_view = 0.0;       ///< rad, full cone angle
  double min_range = 0.0;           ///< m
  double max_range = 0.0;           ///< m
  double range = 0.0;               ///< m
};

/// What a reading says, after the debounce.
enum class ReadingKind
{
  Obstacle,     ///< in range (and confirmed): the arc holds the range
  Unconfirmed,  ///< in range, but fewer than min_consecutive_readings in a row: NaN (no proof either way)
  NoReturn,     ///< at or beyond max_range (or +Inf): +Inf, never an obstacle
  TooClose,     ///< -Inf (the driver says: closer than min_range): -Inf
  Invalid,      ///< NaN, or finite below min_range: NaN
};

constexpr std::size_t kReadingKinds = 5;

const char* readingKindName(ReadingKind kind);

/// A LaserScan's geometry and ranges, in the sensor's frame.
struct ArcScan
{
  double angle_min = 0.0, angle_max = 0.0, angle_increment = 0.0;
  double range_min = 0.0, range_max = 0.0;
  std::vector<float> ranges;
  ReadingKind kind = ReadingKind::Invalid;
};

/// Beams of an arc of `width` rad: the edges are beams, the spacing at most `max_increment`
/// (fencepost rule: round((angle_max - angle_min) / angle_increment) + 1 beams). A zero width
/// gives one beam on the axis.
void arcGeometry(double width, double max_increment, ArcScan& scan);

/// Why a reading cannot be converted ("" when it can): empty frame, non-finite or negative
/// limits, min_range >= max_range, field of view not in [0, 2 pi] (only when the arc uses it),
/// unknown radiation type.
std::string checkReading(const RangeReading& reading, const RangeScanParameters& params);

/// Converts readings one after another (the debounce remembers the previous ones).
class RangeToScan
{
public:
  /// Validates the parameters (ParameterError naming the bad one).
  explicit RangeToScan(const RangeScanParameters& params);

  /// Fills `scan` and returns "" or, for a reading that cannot be converted, the reason (the
  /// scan is then untouched and the debounce forgets its count). A stamp older than the
  /// previous reading's (a bag loop, a clock jump) restarts the debounce.
  std::string convert(const RangeReading& reading, ArcScan& scan);

  /// Forgets the debounce count (e.g. when the input is resubscribed).
  void reset();

  const RangeScanParameters& parameters() const { return params_; }
  /// Arc width in rad for a reading's field of view (clamped to one turn).
  double arcWidth(double field_of_view) const;

private:
  RangeScanParameters params_;
  int in_range_in_a_row_ = 0;
  double last_stamp_ = 0.0;
  bool have_last_stamp_ = false;
};

}  // namespace depth_filter_scan_converter
