// Checks of a message header before the header reaches roscpp's time arithmetic or tf2 (ROS-free).
#pragma once

#include <cstdint>
#include <string>

namespace depth_filter_scan_converter
{
/// "sec.nsec" with nine digits after the point, whatever the values.
std::string stampText(std::uint32_t sec, std::uint32_t nsec);

/// Why a stamp cannot be used, or "" when it can. roscpp's Time arithmetic throws ("Time is out
/// of dual 32-bit range") past 2^32 s, and tf2 adds durations such as its cache length to a
/// stamp: a usable stamp keeps `margin` seconds between itself and that end, and has
/// nsec < 1e9 (a normalised time).
std::string stampProblem(std::uint32_t sec, std::uint32_t nsec, double margin);

/// frame_id as tf2 wants it: one leading '/' (a tf1 habit) removed, as tf2_ros's
/// MessageFilter does. Sets `had_slash` when it removed one.
std::string tfFrameId(const std::string& frame_id, bool* had_slash = nullptr);

}  // namespace depth_filter_scan_converter
