// Internal: the per-beam kernel of MergerCore::addScan.
#pragma once

#include <cfloat>
#include <cstddef>

namespace multi_laserscan_merger
{

/// Scratch bins after the n_out output bins take the beams left out, spread so that the
/// scatter has no store-to-load chain through one bin. Power of two.
constexpr std::size_t kScratch = 16;

/// Range given to an invalid beam's direction (NaN, -Inf ignored, outside the limits): larger
/// than every real range and smaller than +Inf, so that keeping the minimum per bin makes it
/// replace only "no return" and lose against any real range. Bins holding it become NaN.
constexpr float kInvalidMark = FLT_MAX;

/// Pass 1 of addScan for one run of beams: output bin and planar range of every beam.
/// m = { m00 m01 m02 m10 m11 m12, and their per-beam steps (deskew; zero otherwise) }: the
/// planar part of output <- sensor at the first beam. fov may be nullptr: every beam is
/// inside the mask. rmax is the source's limit (<= rmax_msg, the message's own). For a beam
/// inside the mask:
/// - a range in [rmin, rmax] (finite), or -Inf when keep_too_close (as a point at rmin): its
///   bin and planar range;
/// - NaN, a range below rmin, a range in (rmax, rmax_msg] (a real return beyond the source's
///   trusted range), or -Inf when not keep_too_close: the bin of its direction (a ray to
///   infinity) and kInvalidMark;
/// - +Inf or beyond rmax_msg (a driver's finite "no return", e.g. range_max + epsilon): a
///   scratch bin.
/// Beams outside the mask and points outside the output's field of view get a scratch bin.
/// xs, ys (both or neither nullptr): the point of every beam in the output frame (for the
/// footprint filter).
void projectBeams(std::size_t len, const float* ranges, const float* fov, const float* cos_a, const float* sin_a,
                  const float* m, float rmin, float rmax, float rmax_msg, bool keep_too_close, float angle_min,
                  float inv_increment, int wrap, unsigned n_out, int* bins, float* out_ranges, float* xs, float* ys);

}  // namespace multi_laserscan_merger
