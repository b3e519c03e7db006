// Parameters of the merger: one struct per concern, defaults in one place,
// validate() throws ParameterError naming the offending parameter.
// ROS-free (plain C++17): the ROS glue only fills these structs.
#pragma once

#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "laserscan_common/parameter_error.hpp"
#include "laserscan_common/scan_geometry.hpp"

namespace multi_laserscan_merger
{

using laserscan_common::kPi;
using laserscan_common::wrapAngle;
constexpr double kInf = std::numeric_limits<double>::infinity();

using laserscan_common::ParameterError;

/// Geometry and limits of the merged scan (REP 117 conventions).
struct OutputParams
{
  std::string frame = "base_link";       ///< output_frame
  double angle_min = -kPi;               ///< rad
  double angle_max = kPi;                ///< rad
  double angle_increment = kPi / 720.0;  ///< rad
  double range_min = 0.0;                ///< m, planar distance from the output frame's origin
  double range_max = 30.0;               ///< m (finite: consumers use it to clear along no-return beams)
  bool use_inf = true;                   ///< false: "no return" = range_max + inf_epsilon
  double inf_epsilon = 1.0;              ///< m
  /// true (needs use_inf false and range_min > 0): every output range is finite; invalid and
  /// too-close bins are written as 0, below range_min, which LaserScan consumers discard.
  bool finite_only = false;
  /// Robot outline in the output frame (m), >= 3 points or empty (no filter): returns whose
  /// point lies inside are the robot itself and are dropped (their direction becomes invalid).
  std::vector<std::array<double, 2>> footprint;

  /// Number of beams by the fencepost rule: round((max - min) / increment) + 1.
  std::size_t beamCount() const;
  /// What a bin without a return reads (+Inf, or range_max + inf_epsilon).
  float noReturnValue() const;
  /// Throws ParameterError (names are the ROS parameter names).
  void validate() const;
};

/// One input scan source.
struct SourceParams
{
  std::string name;      ///< unique; used in messages and diagnostics
  std::string topic;     ///< required
  double timeout = 1.0;  ///< s; a scan older than this relative to the output time is left out
  /// Field-of-view mask in the sensor's own frame (rad). angle_min > angle_max
  /// means the mask wraps around +-pi (e.g. 2.5 .. -2.5 keeps the rear sector).
  /// A span of 2*pi or more keeps everything.
  double angle_min = -kPi;
  double angle_max = kPi;
  double range_min = 0.0;   ///< m; only tightens the message's own range_min
  double range_max = kInf;  ///< m; only tightens the message's own range_max
  bool deskew = false;      ///< move every beam from its own time (time_increment)
  /// -Inf ("too close", REP 117) is an obstacle at the sensor's range_min (true) or an
  /// invalid reading (false).
  bool too_close_is_obstacle = true;
  bool footprint_filter = true;  ///< false: the output footprint does not apply to this source
  bool self_filter = true;       ///< false: the merger's self_filter block does not apply to this source
  /// m; > 0: this source only adds what the other sources do not explain (for sonar arcs, whose
  /// cone widening draws false obstacles). It is fused after all sources without this option;
  /// its whole scan is dropped when any of its returns lies within this distance of a return of
  /// those sources in the same output bin. 0 = off (fused like any other source).
  double drop_explained_within = 0.0;

  /// Throws ParameterError; `prefix` is e.g. "sources[1]".
  void validate(const std::string& prefix) const;
  /// True when the sensor-frame angle (any value, wrapped internally) is inside the mask.
  bool inFieldOfView(double angle) const;
};

/// Smallest publish_rate (Hz) other than 0: its period must fit a ros::Duration (2^31 s).
constexpr double kMinPublishRate = 1e-6;

/// Largest sync_window (s): it is a bound on latency, meant to be milliseconds.
constexpr double kMaxSyncWindow = 1.0;

/// Everything the merger needs.
struct MergerParams
{
  OutputParams output;
  std::string odom_topic = "odom";  ///< empty disables motion compensation
  int odom_queue_size = 100;        ///< odometry messages kept
  double publish_rate = 0.0;        ///< Hz; 0 = one output for every new input scan
  /// s; how long an output waits for the scans of other sources due at its stamp (sources that
  /// share stamps: stamp_sync.hpp); 0 = never waits. 10 ms: a quarter of a 40 Hz output's period,
  /// several times the spread with which one instant's scans of one driver or of two converters
  /// of one camera arrive.
  double sync_window = 0.01;
  std::vector<SourceParams> sources;

  /// Validates everything including cross-field checks (duplicate names, >= 1 source).
  void validate() const;
};

}  // namespace multi_laserscan_merger
