#include "depth_filter_scan_converter/projector.h"

#include <cfloat>
#include <cmath>
#include <cstring>
#include <limits>

#include "depth_filter_scan_converter/fast_atan2.h"

namespace depth_filter_scan_converter
{
namespace
{
template <typename T>
inline float load(const std::uint8_t* p)
{
  T v;
  std::memcpy(&v, p, sizeof(T));  // the buffer gives no alignment guarantee
  return static_cast<float>(v);
}

// Angles this close outside [angle_min, angle_max] still count: fastAtan2 may put a point
// that lies exactly on a limit just outside it.
constexpr float kAngleSlack = 1e-5f;

float clampToFloat(double v)
{
  if (v > FLT_MAX)
    return FLT_MAX;
  if (v < -FLT_MAX)
    return -FLT_MAX;
  return static_cast<float>(v);
}
}  // namespace

double readField(const std::uint8_t* p, FieldType type)
{
  switch (type)
  {
    case FieldType::Int8:
      return load<std::int8_t>(p);
    case FieldType::UInt8:
      return load<std::uint8_t>(p);
    case FieldType::Int16:
      return load<std::int16_t>(p);
    case FieldType::UInt16:
      return load<std::uint16_t>(p);
    case FieldType::Int32:
      return load<std::int32_t>(p);
    case FieldType::UInt32:
      return load<std::uint32_t>(p);
    case FieldType::Float32:
    {
      float v;
      std::memcpy(&v, p, sizeof v);
      return v;
    }
    case FieldType::Float64:
    {
      double v;
      std::memcpy(&v, p, sizeof v);
      return v;
    }
  }
  return std::numeric_limits<double>::quiet_NaN();
}

/// Everything the inner loop needs, precomputed once per cloud in float.
/// Bounds are clamped to +/-FLT_MAX so that +/-Inf and NaN points always fail the tests.
struct Projector::Frame
{
  float r00, r01, r02, t0;
  float r10, r11, r12, t1;
  float r20, r21, r22, t2;
  float z_lo, z_hi, z_hole, floor_z;
  float r2_min, r2_max;
  float a_lo, a_hi;  // acceptance limits, with slack
  float a_min, inv_inc;  // exact angle_min for the bin formula
  int beams;
  std::uint32_t row_stride, column_stride;
};

Projector::Projector(const Parameters& params)
{
  setParameters(params);
}

void Projector::setParameters(const Parameters& params)
{
  params.validate();
  params_ = params;
}

template <typename T, bool kHole, bool kIndex, bool kKeep>
void Projector::run(const CloudView& v, const Frame& f, std::vector<float>* kept)
{
  float* const best = best_r2_.data();
  std::uint32_t* const best_index = best_index_.data();
  const std::uint8_t* const base = v.data;
  const std::uint32_t xo = v.x_offset, yo = v.y_offset, zo = v.z_offset, step = v.point_step;

  for (std::uint32_t r = 0; r < v.height; r += f.row_stride)
  {
    const std::uint8_t* const row = base + static_cast<std::size_t>(r) * v.row_step;
    for (std::uint32_t c = 0; c < v.width; c += f.column_stride)
    {
      const std::uint8_t* const p = row + static_cast<std::size_t>(c) * step;
      const float x = load<T>(p + xo);
      const float y = load<T>(p + yo);
      const float z = load<T>(p + zo);
      // Height first: most floor and ceiling points leave after three multiply-adds.
      float zr = f.r20 * x + f.r21 * y + f.r22 * z + f.t2;
      float xr, yr;
      if (!(zr >= f.z_lo && zr <= f.z_hi))  // NaN fails too
      {
        if (!kHole || !(zr < f.z_hole && zr > -FLT_MAX))
          continue;
        // A hole: move the obstacle to where the camera ray meets the floor. The camera is above
        // the floor (checked per cloud) and the point below it, so 0 < t < 1.
        const float px = f.r00 * x + f.r01 * y + f.r02 * z + f.t0;
        const float py = f.r10 * x + f.r11 * y + f.r12 * z + f.t1;
        const float t = (f.floor_z - f.t2) / (zr - f.t2);
        xr = f.t0 + t * (px - f.t0);
        yr = f.t1 + t * (py - f.t1);
        zr = f.floor_z;
      }
      else
      {
        xr = f.r00 * x + f.r01 * y + f.r02 * z + f.t0;
        yr = f.r10 * x + f.r11 * y + f.r12 * z + f.t1;
      }
      // Squared ranges: the square root is taken once per beam at the end.
      const float r2 = xr * xr + yr * yr;
      if (!(r2 >= f.r2_min && r2 <= f.r2_max))
        continue;
      const float a = fastAtan2(yr, xr);
      if (!(a >= f.a_lo && a <= f.a_hi))
        continue;
      int b = static_cast<int>((a - f.a_min) * f.inv_inc + 0.5f);
      b = b < 0 ? 0 : (b >= f.beams ? f.beams - 1 : b);  // bounds check, also for a == angle_max
      if (r2 < best[b])
      {
        best[b] = r2;
        if (kIndex)
          best_index[b] = r * v.width + c;
      }
      if (kKeep)
      {
        kept->push_back(xr);
        kept->push_back(yr);
        kept->push_back(zr);
      }
    }
  }
}

template <typename T, bool kHole>
void Projector::dispatchOutputs(const CloudView& cloud, const Frame& frame, bool index, std::vector<float>* kept)
{
  if (index)
  {
    if (kept)
      run<T, kHole, true, true>(cloud, frame, kept);
    else
      run<T, kHole, true, false>(cloud, frame, kept);
  }
  else
  {
    if (kept)
      run<T, kHole, false, true>(cloud, frame, kept);
    else
      run<T, kHole, false, false>(cloud, frame, kept);
  }
}

void Projector::project(const CloudView& cloud, const Eigen::Isometry3d& camera_to_reference,
                        std::vector<float>& ranges, std::vector<float>* intensities, std::vector<float>* kept_points)
{
  const Parameters& p = params_;
  const int beams = static_cast<int>(p.beamCount());
  best_r2_.assign(beams, std::numeric_limits<float>::infinity());
  const bool want_index = intensities && cloud.has_intensity;
  if (want_index)
    best_index_.assign(beams, 0);
  if (kept_points)
    kept_points->clear();

  const Eigen::Matrix3f R = camera_to_reference.linear().cast<float>();
  const Eigen::Vector3d t = camera_to_reference.translation();
  Frame f;
  f.r00 = R(0, 0), f.r01 = R(0, 1), f.r02 = R(0, 2), f.t0 = static_cast<float>(t.x());
  f.r10 = R(1, 0), f.r11 = R(1, 1), f.r12 = R(1, 2), f.t1 = static_cast<float>(t.y());
  f.r20 = R(2, 0), f.r21 = R(2, 1), f.r22 = R(2, 2), f.t2 = static_cast<float>(t.z());
  f.z_lo = clampToFloat(p.floor_height + p.min_height);
  f.z_hi = clampToFloat(p.floor_height + p.max_height);
  f.z_hole = clampToFloat(p.floor_height - p.hole_depth);
  f.floor_z = static_cast<float>(p.floor_height);
  f.r2_min = clampToFloat(p.range_min * p.range_min);
  f.r2_max = clampToFloat(p.range_max * p.range_max);
  f.a_lo = static_cast<float>(p.angle_min) - kAngleSlack;
  f.a_hi = static_cast<float>(p.angle_max) + kAngleSlack;
  f.a_min = static_cast<float>(p.angle_min);
  f.inv_inc = static_cast<float>(1.0 / p.angle_increment);
  f.beams = beams;
  f.row_stride = static_cast<std::uint32_t>(p.row_stride);
  f.column_stride = static_cast<std::uint32_t>(p.column_stride);

  // A ray from a camera at or below the floor never meets the floor in front of it.
  const bool hole = p.hole_detection && t.z() > p.floor_height;
  if (cloud.size() > 0 && cloud.data)
  {
    const Frame& g = f;
    if (cloud.xyz_type == FieldType::Float64)
    {
      if (hole)
        dispatchOutputs<double, true>(cloud, g, want_index, kept_points);
      else
        dispatchOutputs<double, false>(cloud, g, want_index, kept_points);
    }
    else
    {
      if (hole)
        dispatchOutputs<float, true>(cloud, g, want_index, kept_points);
      else
        dispatchOutputs<float, false>(cloud, g, want_index, kept_points);
    }
  }

  ranges.resize(beams);
  const float no_return = p.noReturnValue();
  for (int b = 0; b < beams; ++b)
    ranges[b] = std::isinf(best_r2_[b]) ? no_return : std::sqrt(best_r2_[b]);

  if (intensities)
  {
    intensities->clear();
    if (want_index)
    {
      intensities->resize(beams, 0.0f);
      for (int b = 0; b < beams; ++b)
      {
        if (std::isinf(best_r2_[b]))
          continue;
        const std::uint32_t i = best_index_[b];
        const std::uint8_t* pt = cloud.data + static_cast<std::size_t>(i / cloud.width) * cloud.row_step +
                                 static_cast<std::size_t>(i % cloud.width) * cloud.point_step;
        (*intensities)[b] = static_cast<float>(readField(pt + cloud.intensity_offset, cloud.intensity_type));
      }
    }
  }
}

}  // namespace depth_filter_scan_converter
