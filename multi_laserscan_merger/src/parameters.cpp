#include "multi_laserscan_merger/parameters.hpp"

#include <set>

namespace multi_laserscan_merger
{

std::size_t OutputParams::beamCount() const
{
  return laserscan_common::beamCount(angle_min, angle_max, angle_increment);
}

float OutputParams::noReturnValue() const
{
  return laserscan_common::noReturnValue(use_inf, range_max, inf_epsilon);
}

void OutputParams::validate() const
{
  if (frame.empty())
    throw ParameterError("output_frame", "must not be empty");
  if (frame[0] == '/')
    throw ParameterError("output_frame", "must not start with '/' (tf2 frame ids have no leading slash)");
  // The same rules as the converters' scans: one home, laserscan_common.
  laserscan_common::validateScanGeometry(angle_min, angle_max, angle_increment, range_min, range_max, use_inf,
                                         inf_epsilon);
  if (finite_only && use_inf)
    throw ParameterError("finite_only", "needs use_inf: false (no return is then range_max + inf_epsilon)");
  if (finite_only && !(range_min > 0.0))
    throw ParameterError("range_min",
                         "must be > 0 when finite_only is true (invalid and too-close bins are written as 0, "
                         "below range_min, for consumers to discard)");
  if (!footprint.empty() && footprint.size() < 3)
    throw ParameterError("footprint", "needs at least 3 [x, y] points (or none: no footprint filter)");
  for (std::size_t i = 0; i < footprint.size(); ++i)
    if (!std::isfinite(footprint[i][0]) || !std::isfinite(footprint[i][1]))
      throw ParameterError("footprint", "point " + std::to_string(i) + " is not finite");
}

void SourceParams::validate(const std::string& prefix) const
{
  const std::string p = prefix + ".";
  if (name.empty())
    throw ParameterError(p + "name", "missing or empty");
  if (topic.empty())
    throw ParameterError(p + "topic", "missing or empty (source '" + name + "')");
  if (std::isnan(timeout) || timeout <= 0.0)
    throw ParameterError(p + "timeout", "must be > 0 s (source '" + name + "')");
  if (!std::isfinite(angle_min) || angle_min < -kPi - 1e-6 || angle_min > kPi + 1e-6)
    throw ParameterError(p + "angle_min", "must be within [-pi, pi] (source '" + name + "')");
  if (!std::isfinite(angle_max) || angle_max < -kPi - 1e-6 || angle_max > kPi + 1e-6)
    throw ParameterError(p + "angle_max", "must be within [-pi, pi] (source '" + name + "')");
  if (angle_min == angle_max)
    throw ParameterError(p + "angle_min",
                         "equals angle_max: empty field of view (angle_min > angle_max wraps around +-pi)");
  if (std::isnan(range_min) || range_min < 0.0)
    throw ParameterError(p + "range_min", "must be >= 0 (source '" + name + "')");
  if (std::isnan(range_max) || range_min >= range_max)
    throw ParameterError(p + "range_min", "must be smaller than range_max (source '" + name + "')");
  if (!std::isfinite(drop_explained_within) || drop_explained_within < 0.0)
    throw ParameterError(p + "drop_explained_within",
                         "must be a finite value >= 0 m (0 = off) (source '" + name + "')");
}

bool SourceParams::inFieldOfView(double angle) const
{
  double span = angle_max - angle_min;
  if (span < 0.0)
    span += 2.0 * kPi;  // wrap-around mask
  if (span >= 2.0 * kPi - 1e-9)
    return true;
  double rel = std::fmod(angle - angle_min, 2.0 * kPi);
  if (rel < 0.0)
    rel += 2.0 * kPi;
  // Tolerance so a beam exactly on a limit given as a rounded value is kept.
  return rel <= span + 1e-9 || rel >= 2.0 * kPi - 1e-9;
}

void MergerParams::validate() const
{
  output.validate();
  if (odom_queue_size < 2)
    throw ParameterError("odom_queue_size", "must be >= 2 (interpolation needs two entries)");
  if (std::isnan(publish_rate) || publish_rate < 0.0 || !std::isfinite(publish_rate))
    throw ParameterError("publish_rate", "must be a finite value >= 0 Hz (0 = one output per input scan)");
  if (publish_rate > 0.0 && publish_rate < kMinPublishRate)
    throw ParameterError("publish_rate", "must be 0 or at least 1e-6 Hz (a period must fit a ros::Duration)");
  if (!std::isfinite(sync_window) || sync_window < 0.0 || sync_window > kMaxSyncWindow)
    throw ParameterError("sync_window",
                         "must be a finite value in [0, 1] s (0 = never wait for scans of a shared stamp)");
  if (publish_rate > 0.0 && sync_window * publish_rate >= 1.0)
    throw ParameterError("sync_window", "must be shorter than the publish period 1 / publish_rate");
  if (sources.empty())
    throw ParameterError("sources", "at least one source is needed");
  std::set<std::string> names;
  for (std::size_t i = 0; i < sources.size(); ++i)
  {
    const std::string prefix = "sources[" + std::to_string(i) + "]";
    sources[i].validate(prefix);
    if (!names.insert(sources[i].name).second)
      throw ParameterError(prefix + ".name", "duplicate source name '" + sources[i].name + "'");
  }
}

}  // namespace multi_laserscan_merger
