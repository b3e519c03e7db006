// ROS-free core of the merger: scan validation, resolution remapping, field-of-view
// and range masking, full 3D transform of every beam into the output frame, motion
// compensation by odometry (optionally per beam group: deskew) and fusion keeping
// the closest range (REP 117). Times are real-valued seconds.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "laserscan_common/scan_view.hpp"
#include "laserscan_common/self_filter.hpp"
#include "multi_laserscan_merger/odometry_buffer.hpp"
#include "multi_laserscan_merger/parameters.hpp"

namespace multi_laserscan_merger
{

// The received scan's view and its check are every scan consumer's (laserscan_common).
using laserscan_common::expectedBeamCount;
using laserscan_common::kMaxScanDuration;
using laserscan_common::scanFault;
using laserscan_common::ScanView;

/// True when the point (x, y) lies inside the polygon (crossing number; any simple polygon).
bool insidePolygon(const std::vector<std::array<double, 2>>& polygon, double x, double y);

/// The paper's resolution conversion (Eq. 1) between two 360-degree layouts:
/// beam i_init goes to round(n_new / n_init * i_init) (mod n_new); bins that receive
/// nothing are +Inf (no return); several beams in one bin keep the closest
/// (same rules as fuse()). `out` is resized to n_new.
void remapResolution(const std::vector<float>& in, std::size_t n_new, std::vector<float>& out);

/// REP 117 fusion of one candidate range into a bin (bins start at +Inf = no return):
/// a real range replaces +Inf, NaN and any larger range; +Inf and NaN never replace a
/// real range; NaN replaces only +Inf (an invalid reading is no proof of free space);
/// -Inf ("too close") compares as the closest of all.
inline void fuse(float& bin, float candidate)
{
  if (candidate != candidate)
  {
    if (bin == std::numeric_limits<float>::infinity())
      bin = candidate;
    return;
  }
  if (candidate < bin || (bin != bin && candidate != std::numeric_limits<float>::infinity()))
    bin = candidate;
}

/// One source's latest scan and where its sensor was at the scan's stamp.
struct SourceInput
{
  bool present = false;
  ScanView scan;
  /// The caller found scanFault(scan) empty when the scan arrived: the merge does not check
  /// it again (a kept scan goes into several merges). false: the merge checks it (kInvalid).
  bool checked = false;
  /// Output frame <- sensor frame at scan.stamp (full 3D; moving sensors allowed).
  Eigen::Isometry3d output_T_sensor = Eigen::Isometry3d::Identity();
  /// The robot's own parts posed in the sensor's frame (nullptr or empty: none): a return whose
  /// point lies inside one is dropped, and its direction becomes invalid (nothing was seen past it).
  const laserscan_common::SelfFilter* self_filter = nullptr;
};

enum class SourceStatus : std::uint8_t
{
  kMissing,  ///< no scan yet
  kUsed,
  kTimedOut,  ///< older than the source's timeout relative to the output time
  kInvalid    ///< scanFault() found a fault
};

/// The merged ranges (the ROS glue has the core write straight into its outgoing message instead).
struct MergedScan
{
  std::vector<float> ranges;
  std::vector<float> intensities;  ///< empty when no used source had intensities
};

class MergerCore
{
public:
  /// Validates the parameters (throws ParameterError).
  explicit MergerCore(const MergerParams& params);

  const MergerParams& params() const { return params_; }
  std::size_t beamCount() const { return n_out_; }

  /// Merges the inputs (one per configured source, same order) at time t_out.
  /// odom: pose queue for motion compensation (nullptr or empty: none, and no deskew).
  /// output_T_robot: output frame <- odometry child frame (identity when they coincide).
  /// status (resized to the number of sources) tells what happened to each input.
  /// Sources with drop_explained_within > 0 are fused after the others, each judged against
  /// those others only (their order does not matter): a scan with a return within that distance
  /// of another source's return in the same bin is dropped whole, otherwise fused as usual.
  /// No memory is allocated once the buffers have grown to size.
  void merge(const std::vector<SourceInput>& inputs, double t_out, const OdometryBuffer* odom,
             const Eigen::Isometry3d& output_T_robot, MergedScan& out, std::vector<SourceStatus>& status)
  {
    merge(inputs, t_out, odom, output_T_robot, out.ranges, out.intensities, status);
  }
  /// The same, into `ranges` and `intensities` (e.g. those of the message to publish; resized to
  /// beamCount(), intensities emptied when no used source has any).
  void merge(const std::vector<SourceInput>& inputs, double t_out, const OdometryBuffer* odom,
             const Eigen::Isometry3d& output_T_robot, std::vector<float>& ranges, std::vector<float>& intensities,
             std::vector<SourceStatus>& status);

  /// Beams per deskew group: the transform is computed exactly at every group border
  /// and interpolated linearly per beam in between.
  static constexpr std::size_t kDeskewGroup = 64;

private:
  /// Per-source tables, rebuilt only when the scan geometry changes.
  struct SourceCache
  {
    double angle_min = kInf;
    double angle_increment = 0.0;
    std::size_t n = 0;
    std::vector<float> cos_a, sin_a;
    std::size_t first_in = 0, end_in = 0;  ///< span of beams from the first to the last inside the mask
    bool span_all_in = false;              ///< every beam of the span is inside the mask
    std::vector<float> in_fov;             ///< 1 inside the source's mask (float: keeps the hot loop vectorisable)
  };
  void updateCache(std::size_t source, const ScanView& scan);
  /// The input itself, or (with a self filter) a copy whose returns on the robot are NaN.
  const SourceInput& withoutSelfReturns(std::size_t source, const SourceInput& in);
  /// A return of own_bins_ lies within the source's drop_explained_within of first_pass_bins_.
  bool explainedByFirstPass(std::size_t source) const;
  /// Fuses own_bins_ (and own_ibins_) into bins_ (ibins_) by the first pass's rule.
  void fuseOwnBins(bool with_intensity);
  template <bool kInterpolate>
  void addScan(std::size_t source, const SourceInput& in, const Eigen::Matrix<float, 2, 3>* transforms,
               std::size_t group_size, bool with_intensity);

  MergerParams params_;
  std::size_t n_out_;
  std::size_t n_circle_;  ///< beams per full turn when the increment divides 2*pi, else 0
  float out_angle_min_, out_inv_increment_;
  double footprint_radius_ = 0.0;  ///< no vertex is farther from the origin: points beyond are outside
  std::vector<SourceCache> caches_;
  std::vector<Eigen::Matrix<float, 2, 3>> group_transforms_;
  std::vector<int> bin_buffer_;
  std::vector<float> range_buffer_, x_buffer_, y_buffer_;
  std::vector<float> bins_, ibins_;  ///< fusion buffers: n_out bins + scratch bins (see beam_kernel.hpp)
  /// Second pass (drop_explained_within): the first-pass bins, and one such source's own bins.
  std::vector<float> first_pass_bins_, own_bins_, own_ibins_;
  /// Self filter: the ranges of the source being added, returns on the robot made NaN.
  std::vector<float> self_ranges_;
  SourceInput self_input_;
};

}  // namespace multi_laserscan_merger
