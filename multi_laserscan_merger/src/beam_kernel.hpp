// Internal: the per-beam kernel of MergerCore::addScan.
#pragma once

#include <cstddef>

namespace multi_laserscan_merger
{

/// Scratch bins after the n_out output bins: bin n_out takes the beams pass 3 must look at
/// again, the kScratch after it take the beams left out (spread, so that the scatter has no
/// store-to-load chain through one bin). Power of two.
constexpr std::size_t kScratch = 16;

/// Pass 1 of addScan for one group of beams: output bin and planar range of every beam.
/// m = { m00 m01 m02 m10 m11 m12, and their per-beam steps (deskew; zero otherwise) }: the
/// planar part of output <- sensor. fov may be nullptr: every beam is inside the mask.
/// A beam inside the mask (fov > 0.5) with a range in
/// [rmin, rmax] (finite) gets its bin in [0, n_out) (or a scratch bin when it falls outside the
/// output's field of view); one holding NaN, -Inf or a range below rmin gets bin n_out;
/// the others (masked, +Inf, beyond rmax) a scratch bin. Returns the number of bin-n_out beams.
int projectBeams(std::size_t len, const float* ranges, const float* fov, const float* cos_a, const float* sin_a,
                 const float* m, float rmin, float rmax, float angle_min, float inv_increment, int wrap,
                 unsigned n_out, int* bins, float* out_ranges);

}  // namespace multi_laserscan_merger
