// The straightforward converter: what a per-point implementation looks like. Kept as the
// benchmark baseline and as an independent implementation for the tests.
#include <cmath>
#include <limits>
#include <utility>

#include "depth_filter_scan_converter/projector.hpp"

namespace depth_filter_scan_converter
{
void referenceProject(const Parameters& p, const CloudView& v, const Eigen::Isometry3d& T, std::vector<float>& ranges,
                      std::vector<float>* intensities)
{
  const std::size_t beams = p.scan.beamCount();
  ranges.assign(beams, std::numeric_limits<float>::infinity());
  std::vector<double> best(beams, std::numeric_limits<double>::infinity());
  const bool with_intensity = intensities && v.has_intensity;
  if (intensities)
    intensities->assign(with_intensity ? beams : 0, 0.0f);
  const Eigen::Vector3d origin = T.translation();
  std::vector<std::pair<std::size_t, double>> beam_ranges;  // every obstacle, for clusterRanges()

  for (std::uint32_t r = 0; r < v.height; r += p.input.row_stride)
  {
    for (std::uint32_t c = 0; c < v.width; c += p.input.column_stride)
    {
      const std::uint8_t* pt =
        v.data + static_cast<std::size_t>(r) * v.row_step + static_cast<std::size_t>(c) * v.point_step;
      const Eigen::Vector3d cam(readField(pt + v.x_offset, v.xyz_type), readField(pt + v.y_offset, v.xyz_type),
                                readField(pt + v.z_offset, v.xyz_type));
      Eigen::Vector3d q = T * cam;
      double range = std::hypot(q.x(), q.y());
      double angle = std::atan2(q.y(), q.x());
      if (!q.allFinite())
        continue;
      const bool in_band =
        q.z() >= p.band.floor_height + p.band.min_height && q.z() <= p.band.floor_height + p.band.max_height;
      if (!in_band)
      {
        const bool is_hole =
          p.band.hole_detection && q.z() < p.band.floor_height - p.band.hole_depth && origin.z() > p.band.floor_height;
        if (!is_hole)
          continue;
        const double t = (p.band.floor_height - origin.z()) / (q.z() - origin.z());
        q = origin + t * (q - origin);
        range = std::hypot(q.x(), q.y());
        angle = std::atan2(q.y(), q.x());
      }
      if (range > p.scan.range_max || angle < p.scan.angle_min || angle > p.scan.angle_max)
        continue;
      std::size_t bin = static_cast<std::size_t>(std::lround((angle - p.scan.angle_min) / p.scan.angle_increment));
      if (bin >= beams)
        bin = beams - 1;
      if (p.noise.clusterRanges())
        beam_ranges.emplace_back(bin, range);
      if (range < best[bin])
      {
        best[bin] = range;
        if (with_intensity)
          (*intensities)[bin] = static_cast<float>(readField(pt + v.intensity_offset, v.intensity_type));
      }
    }
  }
  const float no_return = p.scan.noReturnValue();
  for (std::size_t b = 0; b < beams; ++b)
    ranges[b] = std::isinf(best[b])          ? no_return
                : best[b] < p.scan.range_min ? p.scan.tooCloseValue()
                                             : static_cast<float>(best[b]);
  if (!p.noise.clusterRanges())
    return;
  std::vector<double> sum(beams, 0.0);
  std::vector<std::size_t> count(beams, 0);
  for (const auto& [bin, range] : beam_ranges)
  {
    if (best[bin] >= p.scan.range_min &&
        range <= best[bin] + RangeNoiseParams::kClusterWidth * p.noise.rangeNoiseStd(best[bin]))
    {
      sum[bin] += range;
      ++count[bin];
    }
  }
  for (std::size_t b = 0; b < beams; ++b)
    if (count[b] > 0)
      ranges[b] = static_cast<float>(
        std::min(sum[b] / count[b], best[b] + RangeNoiseParams::kClusterCap * p.noise.rangeNoiseStd(best[b])));
}

}  // namespace depth_filter_scan_converter
