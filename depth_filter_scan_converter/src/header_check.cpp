#include "depth_filter_scan_converter/header_check.h"

#include <cmath>
#include <cstdio>
#include <limits>

namespace depth_filter_scan_converter
{
std::string stampText(std::uint32_t sec, std::uint32_t nsec)
{
  char text[32];
  std::snprintf(text, sizeof text, "%u.%09u", sec, nsec);
  return text;
}

std::string stampProblem(std::uint32_t sec, std::uint32_t nsec, double margin)
{
  if (nsec >= 1000000000u)
    return "stamp " + stampText(sec, nsec) + " has nsecs >= 1e9";
  const double last_usable = static_cast<double>(std::numeric_limits<std::uint32_t>::max()) - std::ceil(margin);
  if (static_cast<double>(sec) + nsec * 1e-9 > last_usable)
    return "stamp " + stampText(sec, nsec) + " is too close to the end of ROS time (2^32 s) for time arithmetic";
  return {};
}

std::string tfFrameId(const std::string& frame_id, bool* had_slash)
{
  const bool slash = !frame_id.empty() && frame_id[0] == '/';
  if (had_slash)
    *had_slash = slash;
  return slash ? frame_id.substr(1) : frame_id;
}

}  // namespace depth_filter_scan_converter
