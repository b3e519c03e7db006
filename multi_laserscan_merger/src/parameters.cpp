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
  laserscan_common::checkLimits(*this);
  // The same rules between fields as the converters' scans: one home, laserscan_common.
  laserscan_common::validateScanGeometry(angle_min, angle_max, angle_increment, range_min, range_max, use_inf);
  if (finite_only && use_inf)
    throw ParameterError("finite_only", "needs use_inf: false (no return is then range_max + inf_epsilon)");
  if (finite_only && !(range_min > 0.0))
    throw ParameterError("range_min",
                         "must be > 0 when finite_only is true (invalid and too-close bins are written as 0, "
                         "below range_min)");
}

void SourceParams::validate(const std::string& prefix) const
{
  const std::string p = prefix + ".";
  laserscan_common::checkLimits(*this, p);
  if (angle_min == angle_max)
    throw ParameterError(p + "angle_min",
                         "equals angle_max: empty field of view (angle_min > angle_max wraps around +-pi)");
  if (range_min >= range_max)
    throw ParameterError(p + "range_min", "must be smaller than range_max");
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
  laserscan_common::checkLimits(*this);  // the top level's own fields (output's again: passed)
  if (publish_rate > 0.0 && publish_rate < kMinPublishRate)
    throw ParameterError("publish_rate", "must be 0 or at least 1e-6 Hz (a period must fit a ros::Duration)");
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
