// Parameters of the merger: one struct per concern, defaults in one place,
// limits in its field table; validate() checks those (laserscan_common::checkLimits) and the
// rules between fields, throwing ParameterError naming the offending parameter.
// ROS-free (plain C++17): the ROS glue only fills these structs.
#pragma once

#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "laserscan_common/parameter_error.hpp"
#include "laserscan_common/parameter_table.hpp"
#include "laserscan_common/scan_geometry.hpp"

namespace multi_laserscan_merger
{

using laserscan_common::kPi;
using laserscan_common::wrapAngle;
constexpr double kInf = std::numeric_limits<double>::infinity();

using laserscan_common::ParameterError;
using laserscan_common::ParamInfo;

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
  laserscan_common::Polygon footprint;

  /// Number of beams by the fencepost rule: round((max - min) / increment) + 1.
  std::size_t beamCount() const;
  /// What a bin without a return reads (+Inf, or range_max + inf_epsilon).
  float noReturnValue() const;
  /// Throws ParameterError (names are the ROS parameter names).
  void validate() const;
};

/// The table of OutputParams (laserscan_common/parameter_table.hpp).
template <class P, class V, std::enable_if_t<std::is_same_v<std::decay_t<P>, OutputParams>, int> = 0>
void visitFields(P& p, V&& visit)
{
  visit(p.frame,
        ParamInfo("output_frame", "", "frame of the merged scan; its z axis is the scan's axis; no leading `/`")
          .nonEmpty()
          .frameId());
  visit(p.angle_min,
        ParamInfo("angle_min", "rad", "first output beam, in [-2 pi, 2 pi]").angleWithin(2.0 * kPi).shownAs("`-pi`"));
  visit(p.angle_max,
        ParamInfo("angle_max", "rad", "last output beam; `angle_min < angle_max`, `angle_max - angle_min` <= 2 pi")
          .angleWithin(2.0 * kPi)
          .shownAs("`pi`"));
  visit(p.angle_increment, ParamInfo("angle_increment", "rad", "output resolution (0.25 degree), > 0")
                             .above(0.0)
                             .finiteOnly()
                             .shownAs("`pi/720`"));
  visit(p.range_min,
        ParamInfo("range_min", "m",
                  "fused ranges closer than this (planar, from the frame's origin) become -Inf (too close), >= 0")
          .atLeast(0.0)
          .finiteOnly());
  visit(p.range_max,
        ParamInfo("range_max", "m",
                  "fused ranges farther become \"no return\"; also the message's `range_max`; `range_min < range_max`")
          .above(0.0));
  visit(p.use_inf,
        ParamInfo("use_inf", "",
                  "\"no return\" is +Inf (REP 117); false: `range_max + inf_epsilon` (needs a finite `range_max`)"));
  visit(p.inf_epsilon, ParamInfo("inf_epsilon", "m", "see `use_inf`, >= 0").atLeast(0.0).finiteOnly());
  visit(
    p.finite_only,
    ParamInfo("finite_only", "",
              "true: every output range is a finite number (table below); needs `use_inf: false` and `range_min > 0`"));
  visit(p.footprint, ParamInfo("footprint", "m",
                               "robot outline in `output_frame`, at least 3 finite points: a return whose point lies "
                               "inside is the robot itself and is dropped (its direction becomes invalid, NaN: nothing "
                               "behind it was seen); also applies to \"too close\" obstacles placed inside it")
                       .shownAs("`[]` (none)"));
}

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

/// The table of SourceParams (laserscan_common/parameter_table.hpp): the keys of one `sources` entry.
template <class P, class V, std::enable_if_t<std::is_same_v<std::decay_t<P>, SourceParams>, int> = 0>
void visitFields(P& p, V&& visit)
{
  visit(p.name, ParamInfo("name", "", "used in messages and diagnostics").nonEmpty().shownAs("(required, unique)"));
  visit(p.topic, ParamInfo("topic", "", "LaserScan topic").nonEmpty().shownAs("(required)"));
  visit(p.timeout,
        ParamInfo("timeout", "s", "a scan older than this, relative to the output time, is left out").above(0.0));
  visit(p.angle_min, ParamInfo("angle_min", "rad",
                               "field-of-view mask in the sensor's own frame, in [-pi, pi]; `angle_min > angle_max` "
                               "wraps around +-pi (e.g. 2.5, -2.5 keeps the rear 76 degrees); a span of 2 pi keeps all")
                       .angleWithin(kPi)
                       .shownAs("`-pi`"));
  visit(p.angle_max,
        ParamInfo("angle_max", "rad", "the mask's other edge, in [-pi, pi]").angleWithin(kPi).shownAs("`pi`"));
  visit(p.range_min,
        ParamInfo("range_min", "m", "only tightens the message's own `range_min`, never loosens it").atLeast(0.0));
  visit(p.range_max, ParamInfo("range_max", "m", "only tightens the message's own `range_max`, never loosens it")
                       .above(0.0)
                       .shownAs("`+inf`"));
  visit(p.deskew,
        ParamInfo("deskew", "", "move every beam from its own time `stamp + i * time_increment` (needs odometry)"));
  visit(p.too_close_is_obstacle,
        ParamInfo(
          "too_close_is_obstacle", "",
          "-Inf (\"too close\", REP 117) is an obstacle at the sensor's `range_min` along its beam; false: an invalid "
          "reading (for drivers that write -Inf for errors). Default true: REP 117 says something IS there, closer "
          "than the sensor can measure; dropping it would let a costmap clear a real obstacle at the robot's skin"));
  visit(p.footprint_filter,
        ParamInfo("footprint_filter", "",
                  "false: the merger's `footprint` does not apply to this source (e.g. a sensor whose returns on the "
                  "robot are already removed, or that must see a moving part)"));
  visit(p.self_filter,
        ParamInfo("self_filter", "", "false: the merger's `self_filter` block does not apply to this source"));
  visit(p.drop_explained_within,
        ParamInfo("drop_explained_within", "m",
                  "> 0: this source only adds what the other sources do not already explain (ultrasonic arcs: glass "
                  "that lidars and cameras see through). It is fused after all sources without the option; if any of "
                  "its returns lies within this distance of another source's return in the same output beam, its whole "
                  "scan is dropped (an echo of something the others see; the arc's cone widening would only add false "
                  "obstacles), otherwise it is fused as usual. Several such sources are each judged against the others "
                  "only, never against each other. Intensities follow the usual rule. Finite, >= 0")
          .atLeast(0.0)
          .finiteOnly()
          .shownAs("`0.0` (off)"));
}

/// Smallest publish_rate (Hz) other than 0: its period must fit a ros::Duration (2^31 s).
constexpr double kMinPublishRate = 1e-6;

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

/// The table of MergerParams (laserscan_common/parameter_table.hpp) without `sources` and `self_filter`, read on their
/// own.
template <class P, class V, std::enable_if_t<std::is_same_v<std::decay_t<P>, MergerParams>, int> = 0>
void visitFields(P& p, V&& visit)
{
  visitFields(p.output, visit);
  visit(p.odom_topic, ParamInfo("odom_topic", "", "odometry for motion compensation; `\"\"` disables it (and deskew)"));
  visit(p.odom_queue_size, ParamInfo("odom_queue_size", "messages", "odometry poses kept, >= 2").atLeast(2));
  visit(p.publish_rate,
        ParamInfo("publish_rate", "Hz",
                  "0: one output per new input scan (no timer, no polling); > 0: fixed rate, at least 1e-6 Hz")
          .atLeast(0.0)
          .finiteOnly());
  visit(p.sync_window,
        ParamInfo("sync_window", "s",
                  "longest wait of an output for other sources' scans due at its stamp (sources that share stamps, "
                  "[above](#sources-that-share-a-stamp-sync_window)); 0: never wait (each output at the first scan of "
                  "its stamp). In [0, 1], and shorter than the period `1 / publish_rate` when that is > 0")
          .atLeast(0.0)
          .atMost(1.0)
          .finiteOnly());
}

}  // namespace multi_laserscan_merger
