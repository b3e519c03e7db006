// Parameters of the depth-cloud to laser-scan conversion: one struct per concern, defaults in
// one place, limits in its field table; validate() checks those (laserscan_common::checkLimits)
// and the rules between fields, throwing laserscan_common::ParameterError naming the parameter.
// ROS-free (plain C++17): the ROS glue only fills these structs.
// Lengths in metres, angles in radians, times in seconds (REP 103).
#pragma once

#include <cmath>
#include <cstddef>
#include <string>
#include <type_traits>

#include "laserscan_common/parameter_error.hpp"
#include "laserscan_common/parameter_table.hpp"
#include "laserscan_common/scan_geometry.hpp"

namespace depth_filter_scan_converter
{
using laserscan_common::kPi;
using laserscan_common::kTwoPi;
using laserscan_common::ParameterError;
using laserscan_common::ParamInfo;

/// Where the constraints and the scan live, and how long tf may take.
struct TransformParams
{
  std::string reference_frame = "base_link";  ///< frame of the constraints and of the scan (z up)
  double transform_tolerance = 0.1;           ///< how long a cloud may wait for its transform
  double tf_buffer_duration = 10.0;           ///< length of the tf buffer

  void validate() const;
};

/// The table of TransformParams (laserscan_common/parameter_table.hpp); P is it or const it.
template <class P, class V, std::enable_if_t<std::is_same_v<std::decay_t<P>, TransformParams>, int> = 0>
void visitFields(P& p, V&& visit)
{
  visit(p.reference_frame, ParamInfo("reference_frame", "",
                                     "frame of the constraints and of the output scan; its z axis points up; no "
                                     "leading `/` (tf2 refuses it: a start-up error)")
                             .nonEmpty()
                             .frameId());
  visit(
    p.transform_tolerance,
    ParamInfo(
      "transform_tolerance", "s",
      "how long an input may wait for its transform, >= 0; one delivered later is dropped (counted in the diagnostics)")
      .atLeast(0.0)
      .finiteOnly());
  visit(p.tf_buffer_duration,
        ParamInfo("tf_buffer_duration", "s", "length of the node's tf buffer, > 0").above(0.0).finiteOnly());
}

/// The height band in reference_frame, and holes below the floor.
struct BandParams
{
  double floor_height = 0.0;    ///< z of the floor in reference_frame
  double min_height = 0.05;     ///< band bottom above the floor
  double max_height = 1.0;      ///< band top above the floor
  bool hole_detection = false;  ///< points far below the floor become obstacles
  double hole_depth = 0.05;     ///< how far below the floor a point is a hole

  void validate() const;
};

/// The table of BandParams (laserscan_common/parameter_table.hpp); P is it or const it.
template <class P, class V, std::enable_if_t<std::is_same_v<std::decay_t<P>, BandParams>, int> = 0>
void visitFields(P& p, V&& visit)
{
  visit(p.floor_height,
        ParamInfo("floor_height", "m",
                  "z of the floor in `reference_frame` (e.g. `-0.147` when base_link is 14.7 cm above the floor)")
          .finiteOnly());
  visit(p.min_height, ParamInfo("min_height", "m", "bottom of the obstacle band, above the floor (may be `-.inf`)"));
  visit(p.max_height,
        ParamInfo("max_height", "m",
                  "top of the obstacle band, above the floor (may be `.inf`); `min_height < max_height`"));
  visit(p.hole_detection,
        ParamInfo("hole_detection", "", "points lower than `floor_height - hole_depth` become obstacles (rule 2)"));
  visit(p.hole_depth, ParamInfo("hole_depth", "m", "how far below the floor a point must be to be a hole, >= 0")
                        .atLeast(0.0)
                        .finiteOnly());
}

/// Geometry of the scan and the values it writes (REP 117).
struct ScanParams
{
  double angle_min = -kPi;               ///< first beam, around reference z
  double angle_max = kPi;                ///< last beam
  double angle_increment = kPi / 720.0;  ///< beam spacing
  double range_min = 0.0;                ///< planar distance limits from the frame origin
  double range_max = 10.0;
  bool too_close_at_range_min = false;  ///< too close is -Inf (REP 117) ... or range_min
  bool use_inf = true;                  ///< no return is +Inf (REP 117) ...
  double inf_epsilon = 1.0;             ///< ... or range_max + inf_epsilon

  void validate() const;

  /// Number of beams by the fencepost rule: round((max - min) / increment) + 1.
  std::size_t beamCount() const;

  /// The value written for "no return" in a bin.
  float noReturnValue() const;

  /// The value written for a beam whose closest obstacle is nearer than range_min: -Inf
  /// (REP 117), or range_min (an obstacle at the closest distance the sensor can report).
  /// Never a no return: a costmap would clear what is right in front of the camera.
  float tooCloseValue() const;
};

/// The table of ScanParams (laserscan_common/parameter_table.hpp); P is it or const it.
template <class P, class V, std::enable_if_t<std::is_same_v<std::decay_t<P>, ScanParams>, int> = 0>
void visitFields(P& p, V&& visit)
{
  visit(p.angle_min, ParamInfo("angle_min", "rad", "first beam, around `reference_frame`'s z axis, in [-2 pi, 2 pi]")
                       .angleWithin(kTwoPi)
                       .shownAs("`-pi`"));
  visit(
    p.angle_max,
    ParamInfo("angle_max", "rad",
              "last beam; `angle_min < angle_max`, `angle_max - angle_min` <= 2 pi (a scan covers at most one turn)")
      .angleWithin(kTwoPi)
      .shownAs("`pi`"));
  visit(
    p.angle_increment,
    ParamInfo("angle_increment", "rad", "beam spacing, > 0").above(0.0).finiteOnly().shownAs("`pi/720` (0.25 deg)"));
  visit(p.range_min,
        ParamInfo("range_min", "m",
                  "smallest planar distance (from `reference_frame`'s origin) the scan reports, >= 0; a beam whose "
                  "closest obstacle is nearer reads \"too close\" (see `too_close_at_range_min`), never \"no return\"")
          .atLeast(0.0)
          .finiteOnly());
  visit(p.range_max,
        ParamInfo("range_max", "m",
                  "largest planar distance kept (may be `.inf` when `use_inf` is true); `range_min < range_max`")
          .above(0.0));
  visit(p.too_close_at_range_min,
        ParamInfo("too_close_at_range_min", "",
                  "a too-close beam reads `-Inf` (REP 117: no marking, no clearing); true: it reads `range_min` (for "
                  "consumers that drop `-Inf` but must still see something right in front of the camera)"));
  visit(p.use_inf,
        ParamInfo("use_inf", "", "\"no return\" is `+Inf` (REP 117); when false it is `range_max + inf_epsilon`"));
  visit(p.inf_epsilon, ParamInfo("inf_epsilon", "m", "see `use_inf`, >= 0").atLeast(0.0).finiteOnly());
}

/// Range noise of one point, std = range_noise_std + range_noise_std_per_m2 * range^2 (a depth
/// camera's model). Both 0: each beam reads its closest point. Otherwise each beam reads the
/// mean of its points within kClusterWidth std of its closest point, at most kClusterCap std
/// beyond it: unbiased on a noisy surface, where the closest of many points is short.
struct RangeNoiseParams
{
  double range_noise_std = 0.0;         ///< m
  double range_noise_std_per_m2 = 0.0;  ///< 1/m

  /// The closest cluster of a beam: its points within kClusterWidth std of the closest one
  /// (+-3 std around a surface whose closest point lies about 3 std short) ...
  static constexpr double kClusterWidth = 6.0;
  /// ... and the beam reads their mean, but never more than kClusterCap std beyond its closest
  /// point: an obstacle is never pushed outward by more than the noise.
  static constexpr double kClusterCap = 3.0;

  void validate() const;

  /// True when the beams read the closest cluster's mean rather than the closest point.
  bool clusterRanges() const { return range_noise_std > 0.0 || range_noise_std_per_m2 > 0.0; }

  /// The noise std of a point at this range (m).
  double rangeNoiseStd(double range) const { return range_noise_std + range_noise_std_per_m2 * range * range; }
};

/// The table of RangeNoiseParams (laserscan_common/parameter_table.hpp); P is it or const it.
template <class P, class V, std::enable_if_t<std::is_same_v<std::decay_t<P>, RangeNoiseParams>, int> = 0>
void visitFields(P& p, V&& visit)
{
  visit(
    p.range_noise_std,
    ParamInfo(
      "range_noise_std", "m",
      "a point's range noise std at range 0, finite, >= 0; std(r) = `range_noise_std + range_noise_std_per_m2 * r^2`")
      .atLeast(0.0)
      .finiteOnly());
  visit(p.range_noise_std_per_m2,
        ParamInfo("range_noise_std_per_m2", "1/m",
                  "growth of the noise std with range squared, finite, >= 0 (a depth camera's model). Both 0: each "
                  "beam reads its closest point; otherwise the mean of its closest cluster (rule 6)")
          .atLeast(0.0)
          .finiteOnly());
}

/// Which points of the input are read, and how.
struct InputParams
{
  int row_stride = 1;                 ///< take every n-th row of an organized cloud
  int column_stride = 1;              ///< take every n-th column
  std::string intensity_field;        ///< empty: no intensities in the scan
  bool depth_image_rectified = true;  ///< depth images: intrinsics from camera_info's P, else K
  int queue_size = 10;                ///< inputs waiting for their transform (ROS glue only)

  void validate() const;
};

/// The table of InputParams (laserscan_common/parameter_table.hpp); P is it or const it.
template <class P, class V, std::enable_if_t<std::is_same_v<std::decay_t<P>, InputParams>, int> = 0>
void visitFields(P& p, V&& visit)
{
  visit(p.row_stride,
        ParamInfo("row_stride", "", "take every n-th row of an organized cloud or image, >= 1").atLeast(1));
  visit(p.column_stride,
        ParamInfo("column_stride", "", "take every n-th column (every n-th point of an unorganized cloud), >= 1")
          .atLeast(1));
  visit(p.intensity_field,
        ParamInfo("intensity_field", "",
                  "when set and present in the cloud, `intensities` carries that field (any PointField datatype) of "
                  "the point chosen for each beam (0 where there is no return); when empty, `intensities` is empty"));
  visit(p.depth_image_rectified,
        ParamInfo("depth_image_rectified", "",
                  "image node only: the image is rectified (`image_rect`), intrinsics from camera_info's `P`, as "
                  "depth_image_proc does; false: from `K` (a raw image whose distortion is negligible)"));
  visit(p.queue_size, ParamInfo("queue_size", "frames",
                                "how many inputs may wait for their transform at once (the oldest is dropped first); "
                                "for depth images also the camera_info queue, >= 1")
                        .atLeast(1));
}

/// Everything the converter needs.
struct Parameters
{
  TransformParams transform;
  BandParams band;
  ScanParams scan;
  RangeNoiseParams noise;
  InputParams input;
  bool publish_filtered_cloud = false;  ///< publish the kept points (for rviz)

  /// Throws ParameterError naming the first bad parameter and why.
  void validate() const;
};

/// The table of Parameters (laserscan_common/parameter_table.hpp); P is it or const it.
template <class P, class V, std::enable_if_t<std::is_same_v<std::decay_t<P>, Parameters>, int> = 0>
void visitFields(P& p, V&& visit)
{
  visitFields(p.transform, visit);
  visitFields(p.band, visit);
  visitFields(p.scan, visit);
  visitFields(p.noise, visit);
  visitFields(p.input, visit);
  visit(p.publish_filtered_cloud, ParamInfo("publish_filtered_cloud", "", "advertise and publish `filtered_cloud`"));
}

}  // namespace depth_filter_scan_converter
