// Parameters of the depth-cloud to laser-scan conversion: one struct per concern, defaults in
// one place, validate() throws laserscan_common::ParameterError naming the ROS parameter.
// ROS-free (plain C++17): the ROS glue only fills these structs.
// Lengths in metres, angles in radians, times in seconds (REP 103).
#pragma once

#include <cmath>
#include <cstddef>
#include <string>

#include "laserscan_common/parameter_error.hpp"

namespace depth_filter_scan_converter
{
using laserscan_common::ParameterError;

/// Where the constraints and the scan live, and how long tf may take.
struct TransformParams
{
  std::string reference_frame = "base_link";  ///< frame of the constraints and of the scan (z up)
  double transform_tolerance = 0.1;           ///< how long a cloud may wait for its transform
  double tf_buffer_duration = 10.0;           ///< length of the tf buffer

  void validate() const;
};

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

/// Geometry of the scan and the values it writes (REP 117).
struct ScanParams
{
  double angle_min = -M_PI;               ///< first beam, around reference z
  double angle_max = M_PI;                ///< last beam
  double angle_increment = M_PI / 720.0;  ///< beam spacing
  double range_min = 0.0;                 ///< planar distance limits from the frame origin
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

/// Which points of the input are read, and how.
struct InputParams
{
  int row_stride = 1;                 ///< take every n-th row of an organized cloud
  int column_stride = 1;              ///< take every n-th column
  std::string intensity_field;        ///< empty: no intensities in the scan
  bool depth_image_rectified = true;  ///< depth images: intrinsics from camera_info's P, else K

  void validate() const;
};

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

}  // namespace depth_filter_scan_converter
