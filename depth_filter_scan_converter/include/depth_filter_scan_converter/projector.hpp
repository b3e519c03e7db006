// Projection of a depth cloud onto a laser scan in the robot's frame (ROS-free).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "depth_filter_scan_converter/depth_image_view.hpp"
#include "depth_filter_scan_converter/parameters.hpp"
#include "laserscan_common/cloud_view.hpp"
#include "laserscan_common/self_filter.hpp"

namespace depth_filter_scan_converter
{
// The cloud view is laserscan_common's (the navigator reads clouds through it too).
using laserscan_common::CloudLayout;
using laserscan_common::cloudLayoutOf;
using laserscan_common::CloudView;
using laserscan_common::FieldDescription;
using laserscan_common::FieldType;
using laserscan_common::fieldTypeSize;
using laserscan_common::makeCloudView;
using laserscan_common::readField;

/// Fills the ranges (and intensities) of a scan from a cloud.
///
/// Rules, all in the reference frame (z up):
/// - a point is an obstacle when floor_height+min_height <= z <= floor_height+max_height and
///   hypot(x, y) <= range_max and angle_min <= atan2(y, x) <= angle_max;
/// - with hole_detection, a point lower than floor_height-hole_depth is a hole: its obstacle
///   is where the ray camera origin -> point crosses z = floor_height (range and angle limits
///   then apply to that crossing);
/// - beam i covers the angles nearest to angle_min + i*angle_increment (round to nearest),
///   clamped to the last beam, so a point on angle_max stays in bounds;
/// - each beam keeps its closest obstacle; beams without one read noReturnValue(); a beam whose
///   closest obstacle is nearer than range_min reads tooCloseValue() (-Inf by default, REP 117);
/// - with a range noise model (Parameters::clusterRanges()), a beam whose closest obstacle m is
///   within range reads the mean range of its obstacles within kClusterWidth * std(m) of m, at
///   most m + kClusterCap * std(m), instead of m: the closest of many noisy points of one
///   surface is biased short by about 3 std;
/// - NaN / Inf points are skipped;
/// - with a self filter (its shapes posed in the reference frame at the cloud's stamp), a point
///   that would be an obstacle (or a hole's floor crossing) and lies inside a padded shape of the
///   robot is not projected: it is no obstacle, and its beam has not seen what lies beyond it
///   either, so a beam whose only such points are on the robot reads NaN (invalid, REP 117), not
///   no return; an obstacle point of the same beam still decides. Only points inside the shapes'
///   bounding box are tested against the shapes.
/// Beam angles come from fastAtan2 (error < laserscan_common::kFastAtan2MaxError) and the arithmetic is float, so
/// a point within a few micro-radians (or micrometres) of a border may land on either side.
///
/// Not thread-safe: the object keeps its work buffers between calls to avoid allocations.
class Projector
{
public:
  /// Throws ParameterError (naming the parameter) if params are invalid.
  explicit Projector(const Parameters& params = Parameters());

  /// Throws ParameterError and keeps the old parameters if params are invalid.
  void setParameters(const Parameters& params);
  const Parameters& parameters() const { return params_; }

  /// camera_to_reference maps a point of the cloud's frame into the reference frame, at the
  /// cloud's stamp. `ranges` is resized to beamCount(). `intensities`, if given, is resized to
  /// beamCount() when the view has an intensity field (value of the closest point, 0 where there
  /// is no return) and cleared otherwise. `kept_points`, if given, receives x, y, z (reference
  /// frame) of every obstacle point (too close ones and hole crossings included). `self_filter`,
  /// if given and not empty, holds the robot's shapes at their poses for this cloud (reference
  /// frame): points inside are not projected (see the rules above).
  void project(const CloudView& cloud, const Eigen::Isometry3d& camera_to_reference, std::vector<float>& ranges,
               std::vector<float>* intensities = nullptr, std::vector<float>* kept_points = nullptr,
               const laserscan_common::SelfFilter* self_filter = nullptr);

  /// The same for a depth image: its pixels are the points (see DepthImageView), with the same
  /// rules and strides. A depth image has no intensities: `intensities`, if given, is cleared.
  void project(const DepthImageView& image, const Eigen::Isometry3d& camera_to_reference, std::vector<float>& ranges,
               std::vector<float>* intensities = nullptr, std::vector<float>* kept_points = nullptr,
               const laserscan_common::SelfFilter* self_filter = nullptr);

  /// Per-cloud constants of the inner loop, and where the inner loop records points for the
  /// range noise model (defined in projector.cpp).
  struct Frame;
  struct Record;

private:
  Frame start(const Eigen::Isometry3d& camera_to_reference, std::vector<float>* kept_points,
              const laserscan_common::SelfFilter* self_filter);
  void finish(const Frame& frame, std::vector<float>& ranges);
  /// Room for n more recorded points (a null Record without a noise model).
  Record recordSpace(const Frame& frame, std::uint32_t n);
  template <bool kHole, bool kKeep>
  void runDepth(const DepthImageView& image, const Frame& frame, std::vector<float>* kept_points);
  template <typename T, bool kHole, bool kIndex, bool kKeep>
  void run(const CloudView& cloud, const Frame& frame, std::vector<float>* kept_points);
  template <typename T, bool kHole>
  void dispatchOutputs(const CloudView& cloud, const Frame& frame, bool index, std::vector<float>* kept_points);

  Parameters params_;
  std::vector<float> best_r2_;
  std::vector<std::uint32_t> best_index_;
  std::vector<float> column_offsets_;  // u - cx of every column taken from a depth image
  // With a noise model: beam and squared range of every obstacle point of the cloud (the first
  // recorded_points_), for the closest-cluster pass once every beam's closest point is known.
  std::vector<std::int32_t> point_bins_;
  std::vector<float> point_r2s_;
  std::size_t recorded_points_ = 0;
  std::vector<double> cluster_sum_;
  std::vector<std::uint32_t> cluster_count_;
  std::vector<float> cluster_limit_r2_;
};

/// The straightforward per-point converter (Eigen transform in double, then std::atan2 and
/// std::hypot for every point, field type looked up per point), with the same rules as
/// Projector. Baseline for benchmarks and an independent check in tests.
void referenceProject(const Parameters& params, const CloudView& cloud, const Eigen::Isometry3d& camera_to_reference,
                      std::vector<float>& ranges, std::vector<float>* intensities = nullptr);

}  // namespace depth_filter_scan_converter
