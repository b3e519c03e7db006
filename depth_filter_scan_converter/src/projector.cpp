#include "depth_filter_scan_converter/projector.hpp"

#include <cfloat>
#include <cmath>
#include <algorithm>
#include <cstring>
#include <limits>
#include <type_traits>

#include "laserscan_common/fast_math.hpp"

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

/// Where pass 3 appends the beam and squared range of every obstacle (the range noise model's
/// closest-cluster pass needs them); bins == nullptr: nothing is recorded.
struct Projector::Record
{
  std::int32_t* bins;
  float* r2s;
  std::size_t count;
};

/// Everything the inner loop needs, precomputed once per cloud in float.
/// Bounds are clamped to +/-FLT_MAX so that +/-Inf and NaN points always fail the tests.
struct Projector::Frame
{
  float r00, r01, r02, t0;
  float r10, r11, r12, t1;
  float r20, r21, r22, t2;
  float z_lo, z_hi, z_hole, floor_z;
  float r2_min, r2_max;
  float a_lo, a_hi;      // acceptance limits, with slack
  float a_min, inv_inc;  // exact angle_min for the bin formula
  int beams;
  std::uint32_t row_stride, column_stride;
  bool hole;                                 // hole detection on, and the camera above the floor
  bool cluster;                              // beams read the closest cluster's mean (a range noise model is set)
  const laserscan_common::SelfFilter* self;  // nullptr: no self filter
  float self_lo[3], self_hi[3];              // the self filter's shapes' bounding box (reference frame)
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

namespace
{
constexpr std::uint32_t kChunk = 256;
// Rejected points go to one of these slots after the last beam, spread by index so that pass 3
// can update the minimum without a branch and without one long chain of stores to one slot.
constexpr std::int32_t kScratchSlots = 8;
// Squared range of a point on the robot itself (self filter): finite, so that it stays in its
// beam, but larger than any real obstacle's, so that any obstacle of the beam wins the minimum;
// a beam left with it reads NaN (nothing seen there). Never kept nor recorded.
constexpr float kSelfR2 = FLT_MAX;

// One chunk of points of a row, as plain float arrays (structure of arrays).
struct alignas(64) Chunk
{
  float xs[kChunk], ys[kChunk], zs[kChunk], r2s[kChunk];
  std::int32_t bins[kChunk];
  std::int32_t
    near_self[kChunk];         // with a self filter: -1 if the point would be projected and lies in its bounding box
  std::int32_t any_near_self;  // with a self filter: nonzero if a near_self is
};

// Pass 2 of the projection, on n points already gathered into c.xs/ys/zs (camera frame):
// transform, band / hole / range / angle tests, beam index. A rejected point gets an infinite
// squared range and a scratch slot after the last beam, so that pass 3 never keeps it.
// xs/ys/zs are overwritten with the point in the reference frame (for the filtered cloud).
// kSelf: near_self marks the points to test against the self filter's shapes, here where the
// point is in registers (a pass of its own over the chunk cost as much as the shape tests): the
// projected points within the x/y extent of the shapes' bounding box. Its z extent is left out
// (the band already bounds the height; two comparisons less per point, about 5 % of the
// kernel); the block test compares each shape's box in all three axes, so the result is the same.
// Non-short-circuit & and selects only: no branch, so the compiler vectorizes it.
template <bool kHole, bool kSelf>
__attribute__((always_inline)) inline void transformChunk(std::uint32_t n, const Projector::Frame& f, Chunk& c)
{
  const float inf = std::numeric_limits<float>::infinity();
  const float last_beam = static_cast<float>(f.beams - 1);
  std::int32_t any_near = 0;
  for (std::uint32_t i = 0; i < n; ++i)
  {
    const float x = c.xs[i], y = c.ys[i], z = c.zs[i];
    float zr = f.r20 * x + f.r21 * y + f.r22 * z + f.t2;
    float xr = f.r00 * x + f.r01 * y + f.r02 * z + f.t0;
    float yr = f.r10 * x + f.r11 * y + f.r12 * z + f.t1;
    bool ok = (zr >= f.z_lo) & (zr <= f.z_hi);  // false for NaN; bounds are finite, so also for Inf
    if (kHole)
    {
      // A hole (only if the point is not an obstacle itself, which a band reaching below the
      // floor allows): the obstacle is where the camera ray meets the floor. The camera is above
      // the floor (checked per cloud) and the point below it, so 0 < t < 1.
      const bool hole = (zr < f.z_hole) & (zr > -FLT_MAX) & !ok;
      const float t = (f.floor_z - f.t2) / (zr - f.t2);
      xr = hole ? f.t0 + t * (xr - f.t0) : xr;
      yr = hole ? f.t1 + t * (yr - f.t1) : yr;
      zr = hole ? f.floor_z : zr;
      ok = ok | hole;
    }
    // Squared ranges: the square root is taken once per beam at the end. No range_min test
    // here: a point that is too close is the beam's closest obstacle, reported at the end.
    const float r2 = xr * xr + yr * yr;
    ok = ok & (r2 <= f.r2_max);
    const float a = laserscan_common::fastAtan2(yr, xr);
    ok = ok & (a >= f.a_lo) & (a <= f.a_hi);
    // Clamp before converting (NaN -> 0): the bounds check of the beam index, which also keeps a
    // point on angle_max in the last beam.
    float fb = (a - f.a_min) * f.inv_inc + 0.5f;
    fb = fb > 0.0f ? fb : 0.0f;
    fb = fb < last_beam ? fb : last_beam;
    c.bins[i] = ok ? static_cast<std::int32_t>(fb) : f.beams + static_cast<std::int32_t>(i % kScratchSlots);
    c.r2s[i] = ok ? r2 : inf;
    if (kSelf)
    {
      const std::int32_t near = -static_cast<std::int32_t>(ok & (xr >= f.self_lo[0]) & (xr <= f.self_hi[0]) &
                                                           (yr >= f.self_lo[1]) & (yr <= f.self_hi[1]));
      c.near_self[i] = near;
      any_near |= near;
    }
    c.xs[i] = xr;
    c.ys[i] = yr;
    c.zs[i] = zr;
  }
  if (kSelf)
    c.any_near_self = any_near;
}

// Passes 1 and 2 for n cloud points starting at p, col_step bytes apart: gather x, y, z from
// the strided buffer (any point_step, float or double), then transformChunk.
// kStep > 0 fixes the distance between points at compile time (the common 16- and 32-byte
// layouts), which lets the compiler vectorize the gather as well.
template <typename T, bool kHole, bool kSelf, std::size_t kStep>
__attribute__((always_inline)) inline void chunkKernel(const std::uint8_t* p, std::size_t col_step, std::uint32_t xo,
                                                       std::uint32_t yo, std::uint32_t zo, std::uint32_t n,
                                                       const Projector::Frame& f, Chunk& c)
{
  const std::size_t step = kStep > 0 ? kStep : col_step;
  for (std::uint32_t i = 0; i < n; ++i)
  {
    c.xs[i] = load<T>(p + i * step + xo);
    c.ys[i] = load<T>(p + i * step + yo);
    c.zs[i] = load<T>(p + i * step + zo);
  }
  transformChunk<kHole, kSelf>(n, f, c);
}

// Passes 1 and 2 for n depth pixels of one row starting at p, col_step bytes apart: the point
// of each pixel, then transformChunk. du[i] = u - cx of pixel i, dv = v - cy of the row;
// kx = unit / fx, ky = unit / fy, unit = metres per depth unit. The same float operations in the
// same order as depth_image_proc::convert, so a scan from the image equals the scan from
// point_cloud_xyz's cloud bit for bit. No depth (0, NaN, Inf) gives a NaN point.
template <typename D, bool kHole, bool kSelf>
__attribute__((always_inline)) inline void depthChunkKernel(const std::uint8_t* p, std::size_t col_step,
                                                            const float* du, float dv, float kx, float ky, float unit,
                                                            std::uint32_t n, const Projector::Frame& f, Chunk& c)
{
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (std::uint32_t i = 0; i < n; ++i)
  {
    const float d = load<D>(p + i * col_step);
    const bool valid = (d > 0.0f) & (d < inf);
    c.xs[i] = valid ? du[i] * d * kx : nan;
    c.ys[i] = valid ? dv * d * ky : nan;
    c.zs[i] = valid ? d * unit : nan;
  }
  transformChunk<kHole, kSelf>(n, f, c);
}

// The kernels are compiled twice and picked at load time by the CPU (ifunc): AVX2+FMA where
// available, baseline x86-64 otherwise. No -march=native, so the binary runs anywhere.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define DFSC_CLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define DFSC_CLONES
#endif
// Each kernel in four variants: with or without hole detection, with or without the self
// filter's mark (kernels without it pay nothing for it).
#define DFSC_KERNEL(NAME, T, HOLE, SELF, STEP)                                                           \
  DFSC_CLONES void NAME(const std::uint8_t* p, std::size_t col_step, std::uint32_t xo, std::uint32_t yo, \
                        std::uint32_t zo, std::uint32_t n, const Projector::Frame& f, Chunk& c)          \
  {                                                                                                      \
    chunkKernel<T, HOLE, SELF, STEP>(p, col_step, xo, yo, zo, n, f, c);                                  \
  }
#define DFSC_KERNELS(NAME, T, STEP)             \
  DFSC_KERNEL(NAME, T, false, false, STEP)      \
  DFSC_KERNEL(NAME##Hole, T, true, false, STEP) \
  DFSC_KERNEL(NAME##Self, T, false, true, STEP) \
  DFSC_KERNEL(NAME##HoleSelf, T, true, true, STEP)
DFSC_KERNELS(kernelFloat, float, 0)
DFSC_KERNELS(kernelFloat16, float, 16)
DFSC_KERNELS(kernelFloat32, float, 32)
DFSC_KERNELS(kernelDouble, double, 0)
#undef DFSC_KERNELS
#undef DFSC_KERNEL
#define DFSC_DEPTH_KERNEL(NAME, D, HOLE, SELF)                                                                      \
  DFSC_CLONES void NAME(const std::uint8_t* p, std::size_t col_step, const float* du, float dv, float kx, float ky, \
                        float unit, std::uint32_t n, const Projector::Frame& f, Chunk& c)                           \
  {                                                                                                                 \
    depthChunkKernel<D, HOLE, SELF>(p, col_step, du, dv, kx, ky, unit, n, f, c);                                    \
  }
#define DFSC_DEPTH_KERNELS(NAME, D)             \
  DFSC_DEPTH_KERNEL(NAME, D, false, false)      \
  DFSC_DEPTH_KERNEL(NAME##Hole, D, true, false) \
  DFSC_DEPTH_KERNEL(NAME##Self, D, false, true) \
  DFSC_DEPTH_KERNEL(NAME##HoleSelf, D, true, true)
DFSC_DEPTH_KERNELS(kernelDepthMm, std::uint16_t)
DFSC_DEPTH_KERNELS(kernelDepthMetres, float)
#undef DFSC_DEPTH_KERNELS
#undef DFSC_DEPTH_KERNEL

// The self filter on a chunk after pass 2 that holds a point the kernel marked near_self (it
// would be projected and lies inside the shapes' bounding box): those points are tested against
// the shapes; those inside a shape get kSelfR2. Cloned like the kernels, so that the inlined
// shape tests vectorize too.
DFSC_CLONES void removeSelfPoints(const laserscan_common::SelfFilter& filter, std::uint32_t n, Chunk& c)
{
  float* const r2s = c.r2s;
  filter.forEachInside(
    n, c.xs, c.ys, c.zs, c.near_self,
    [r2s](std::size_t first, const laserscan_common::lanes::Ints& in) {
      laserscan_common::lanes::Floats r2;
      std::memcpy(&r2, r2s + first, sizeof r2);
      r2 = in ? laserscan_common::lanes::Floats{} + kSelfR2 : r2;
      std::memcpy(r2s + first, &r2, sizeof r2);
    },
    [r2s](std::size_t i) { r2s[i] = kSelfR2; });
}

using DepthKernel = void (*)(const std::uint8_t*, std::size_t, const float*, float, float, float, float, std::uint32_t,
                             const Projector::Frame&, Chunk&);

// Pass 3: each beam keeps its closest point. Without indices a select, no branch: noisy depth
// makes "closer than the beam's best" a coin toss that a branch predictor cannot learn.
template <bool kIndex, bool kKeep>
__attribute__((always_inline)) inline void keepClosest(const Chunk& c, std::uint32_t n, std::uint32_t first_index,
                                                       std::uint32_t index_step, float* best, std::uint32_t* best_index,
                                                       std::vector<float>* kept, Projector::Record& record)
{
  std::size_t k = record.count;
  for (std::uint32_t i = 0; i < n; ++i)
  {
    if (record.bins)  // the same for the whole cloud: predicted; a compaction without branch
    {
      record.bins[k] = c.bins[i];
      record.r2s[k] = c.r2s[i];
      k += c.r2s[i] < kSelfR2 ? 1 : 0;
    }
    const std::int32_t b = c.bins[i];
    if (!kIndex)
    {
      const float r2 = c.r2s[i], current = best[b];
      best[b] = r2 < current ? r2 : current;
    }
    else if (c.r2s[i] < best[b])
    {
      best[b] = c.r2s[i];
      best_index[b] = first_index + i * index_step;
    }
    if (kKeep && c.r2s[i] < kSelfR2)
    {
      kept->push_back(c.xs[i]);
      kept->push_back(c.ys[i]);
      kept->push_back(c.zs[i]);
    }
  }
  record.count = k;
}

using Kernel = void (*)(const std::uint8_t*, std::size_t, std::uint32_t, std::uint32_t, std::uint32_t, std::uint32_t,
                        const Projector::Frame&, Chunk&);

// The variant of a kernel for hole detection and the self filter.
template <typename K>
K pickVariant(bool hole, bool self, K plain, K with_hole, K with_self, K with_hole_self)
{
  return hole ? (self ? with_hole_self : with_hole) : (self ? with_self : plain);
}

// Chosen once per cloud: no per-point branch on the layout.
template <typename T, bool kHole>
Kernel pickKernel(std::size_t col_step, bool self)
{
  if constexpr (std::is_same_v<T, float>)
  {
    if (col_step == 16)
      return pickVariant<Kernel>(kHole, self, kernelFloat16, kernelFloat16Hole, kernelFloat16Self,
                                 kernelFloat16HoleSelf);
    if (col_step == 32)
      return pickVariant<Kernel>(kHole, self, kernelFloat32, kernelFloat32Hole, kernelFloat32Self,
                                 kernelFloat32HoleSelf);
    return pickVariant<Kernel>(kHole, self, kernelFloat, kernelFloatHole, kernelFloatSelf, kernelFloatHoleSelf);
  }
  else
  {
    return pickVariant<Kernel>(kHole, self, kernelDouble, kernelDoubleHole, kernelDoubleSelf, kernelDoubleHoleSelf);
  }
}
}  // namespace

template <typename T, bool kHole, bool kIndex, bool kKeep>
void Projector::run(const CloudView& v, const Frame& f, std::vector<float>* kept)
{
  // Chunks of one row go through the branch-free kernel (passes 1 and 2), then pass 3 keeps
  // the closest point per beam (keepClosest).
  Chunk c;
  float* const best = best_r2_.data();
  std::uint32_t* const best_index = best_index_.data();
  const std::size_t col_step = static_cast<std::size_t>(v.point_step) * f.column_stride;
  const Kernel kernel = pickKernel<T, kHole>(col_step, f.self != nullptr);

  for (std::uint32_t r = 0; r < v.height; r += f.row_stride)
  {
    const std::uint8_t* const row = v.data + static_cast<std::size_t>(r) * v.row_step;
    for (std::uint32_t c0 = 0; c0 < v.width; c0 += kChunk * f.column_stride)
    {
      const std::uint32_t n = std::min(kChunk, (v.width - c0 + f.column_stride - 1) / f.column_stride);
      kernel(row + static_cast<std::size_t>(c0) * v.point_step, col_step, v.x_offset, v.y_offset, v.z_offset, n, f, c);
      if (f.self && c.any_near_self)  // most chunks: no point near the robot, no call
        removeSelfPoints(*f.self, n, c);
      Record record = recordSpace(f, n);
      keepClosest<kIndex, kKeep>(c, n, r * v.width + c0, f.column_stride, best, best_index, kept, record);
      recorded_points_ = record.count;
    }
  }
}

template <bool kHole, bool kKeep>
void Projector::runDepth(const DepthImageView& v, const Frame& f, std::vector<float>* kept)
{
  const bool mm = v.encoding == DepthEncoding::UInt16Millimetres;
  const bool self = f.self != nullptr;
  const DepthKernel kernel = mm ? pickVariant<DepthKernel>(kHole, self, kernelDepthMm, kernelDepthMmHole,
                                                           kernelDepthMmSelf, kernelDepthMmHoleSelf)
                                : pickVariant<DepthKernel>(kHole, self, kernelDepthMetres, kernelDepthMetresHole,
                                                           kernelDepthMetresSelf, kernelDepthMetresHoleSelf);
  const std::size_t col_step = static_cast<std::size_t>(mm ? 2 : 4) * f.column_stride;
  // As depth_image_proc: metres per unit in float, the factors unit / f in double, then float.
  const float unit = mm ? 0.001f : 1.0f;
  const float kx = static_cast<float>(static_cast<double>(unit) / v.intrinsics.fx);
  const float ky = static_cast<float>(static_cast<double>(unit) / v.intrinsics.fy);
  const float cx = static_cast<float>(v.intrinsics.cx);
  const float cy = static_cast<float>(v.intrinsics.cy);
  column_offsets_.clear();
  for (std::uint32_t u = 0; u < v.width; u += f.column_stride)
    column_offsets_.push_back(static_cast<float>(static_cast<int>(u)) - cx);

  Chunk c;
  float* const best = best_r2_.data();
  for (std::uint32_t r = 0; r < v.height; r += f.row_stride)
  {
    const std::uint8_t* const row = v.data + static_cast<std::size_t>(r) * v.row_step;
    const float dv = static_cast<float>(static_cast<int>(r)) - cy;
    for (std::uint32_t k0 = 0; k0 < column_offsets_.size(); k0 += kChunk)
    {
      const std::uint32_t n = std::min<std::uint32_t>(kChunk, static_cast<std::uint32_t>(column_offsets_.size()) - k0);
      kernel(row + k0 * col_step, col_step, column_offsets_.data() + k0, dv, kx, ky, unit, n, f, c);
      if (f.self && c.any_near_self)  // most chunks: no point near the robot, no call
        removeSelfPoints(*f.self, n, c);
      Record record = recordSpace(f, n);
      keepClosest<false, kKeep>(c, n, 0, 0, best, nullptr, kept, record);
      recorded_points_ = record.count;
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

Projector::Frame Projector::start(const Eigen::Isometry3d& camera_to_reference, std::vector<float>* kept_points,
                                  const laserscan_common::SelfFilter* self_filter)
{
  const Parameters& p = params_;
  const int beams = static_cast<int>(p.scan.beamCount());
  best_r2_.assign(beams + kScratchSlots, std::numeric_limits<float>::infinity());
  if (kept_points)
    kept_points->clear();

  const Eigen::Matrix3f R = camera_to_reference.linear().cast<float>();
  const Eigen::Vector3d t = camera_to_reference.translation();
  Frame f;
  f.r00 = R(0, 0), f.r01 = R(0, 1), f.r02 = R(0, 2), f.t0 = static_cast<float>(t.x());
  f.r10 = R(1, 0), f.r11 = R(1, 1), f.r12 = R(1, 2), f.t1 = static_cast<float>(t.y());
  f.r20 = R(2, 0), f.r21 = R(2, 1), f.r22 = R(2, 2), f.t2 = static_cast<float>(t.z());
  f.z_lo = clampToFloat(p.band.floor_height + p.band.min_height);
  f.z_hi = clampToFloat(p.band.floor_height + p.band.max_height);
  f.z_hole = clampToFloat(p.band.floor_height - p.band.hole_depth);
  f.floor_z = static_cast<float>(p.band.floor_height);
  f.r2_min = clampToFloat(p.scan.range_min * p.scan.range_min);
  f.r2_max = clampToFloat(p.scan.range_max * p.scan.range_max);
  f.a_lo = static_cast<float>(p.scan.angle_min) - kAngleSlack;
  f.a_hi = static_cast<float>(p.scan.angle_max) + kAngleSlack;
  f.a_min = static_cast<float>(p.scan.angle_min);
  f.inv_inc = static_cast<float>(1.0 / p.scan.angle_increment);
  f.beams = beams;
  f.row_stride = static_cast<std::uint32_t>(p.input.row_stride);
  f.column_stride = static_cast<std::uint32_t>(p.input.column_stride);
  // A ray from a camera at or below the floor never meets the floor in front of it.
  f.hole = p.band.hole_detection && t.z() > p.band.floor_height;
  f.cluster = p.noise.clusterRanges();
  f.self = self_filter && !self_filter->empty() && !self_filter->bounds().empty() ? self_filter : nullptr;
  for (int axis = 0; axis < 3; ++axis)
  {
    f.self_lo[axis] = f.self ? f.self->bounds().lo(axis) : 0.0f;
    f.self_hi[axis] = f.self ? f.self->bounds().hi(axis) : 0.0f;
  }
  recorded_points_ = 0;
  return f;
}

Projector::Record Projector::recordSpace(const Frame& f, std::uint32_t n)
{
  if (!f.cluster)
    return Record{ nullptr, nullptr, 0 };
  if (point_bins_.size() < recorded_points_ + n)
  {
    point_bins_.resize(2 * (recorded_points_ + n));
    point_r2s_.resize(2 * (recorded_points_ + n));
  }
  return Record{ point_bins_.data(), point_r2s_.data(), recorded_points_ };
}

void Projector::finish(const Frame& f, std::vector<float>& ranges)
{
  const Parameters& p = params_;
  ranges.resize(f.beams);
  const float no_return = p.scan.noReturnValue();
  const float too_close = p.scan.tooCloseValue();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int b = 0; b < f.beams; ++b)
    ranges[b] = std::isinf(best_r2_[b])  ? no_return
                : best_r2_[b] == kSelfR2 ? nan
                : best_r2_[b] < f.r2_min ? too_close
                                         : std::sqrt(best_r2_[b]);
  if (!f.cluster)
    return;

  // Closest cluster: the points of a beam within kClusterWidth std of its closest point. Beams
  // without a measurement (no return, too close) take no point (limit -1).
  // Consecutive points mostly fall into the same beam: kBanks interleaved accumulators per beam
  // break the chain of dependent read-add-writes to one memory slot.
  constexpr std::size_t kBanks = 4;
  const std::size_t slots = best_r2_.size();
  cluster_limit_r2_.assign(slots, -1.0f);
  cluster_sum_.assign(slots * kBanks, 0.0);
  cluster_count_.assign(slots * kBanks, 0);
  for (int b = 0; b < f.beams; ++b)
  {
    if (std::isinf(best_r2_[b]) || best_r2_[b] == kSelfR2 || best_r2_[b] < f.r2_min)
      continue;  // no return, only the robot, or too close: the closest point decides
    const double limit = ranges[b] + RangeNoiseParams::kClusterWidth * p.noise.rangeNoiseStd(ranges[b]);
    cluster_limit_r2_[b] = static_cast<float>(limit * limit);
  }
  const std::int32_t* const bins = point_bins_.data();
  const float* const r2s = point_r2s_.data();
  double* const sums = cluster_sum_.data();
  std::uint32_t* const counts = cluster_count_.data();
  const float* const limits = cluster_limit_r2_.data();
  for (std::size_t i = 0; i < recorded_points_; ++i)
  {
    const std::int32_t b = bins[i];
    const bool inside = r2s[i] <= limits[b];
    const std::size_t slot = static_cast<std::size_t>(b) * kBanks + (i & (kBanks - 1));
    sums[slot] += inside ? std::sqrt(r2s[i]) : 0.0f;
    counts[slot] += inside ? 1 : 0;
  }
  for (int b = 0; b < f.beams; ++b)
  {
    double sum = 0.0;
    std::uint32_t count = 0;
    for (std::size_t k = 0; k < kBanks; ++k)
    {
      sum += sums[b * kBanks + k];
      count += counts[b * kBanks + k];
    }
    if (count == 0)
      continue;
    const double closest = ranges[b];
    const double cap = closest + RangeNoiseParams::kClusterCap * p.noise.rangeNoiseStd(closest);
    ranges[b] = static_cast<float>(std::min(sum / count, cap));
  }
}

void Projector::project(const DepthImageView& image, const Eigen::Isometry3d& camera_to_reference,
                        std::vector<float>& ranges, std::vector<float>* intensities, std::vector<float>* kept_points,
                        const laserscan_common::SelfFilter* self_filter)
{
  const Frame f = start(camera_to_reference, kept_points, self_filter);
  if (image.size() > 0 && image.data)
  {
    if (f.hole)
      kept_points ? runDepth<true, true>(image, f, kept_points) : runDepth<true, false>(image, f, kept_points);
    else
      kept_points ? runDepth<false, true>(image, f, kept_points) : runDepth<false, false>(image, f, kept_points);
  }
  finish(f, ranges);
  if (intensities)
    intensities->clear();
}

void Projector::project(const CloudView& cloud, const Eigen::Isometry3d& camera_to_reference,
                        std::vector<float>& ranges, std::vector<float>* intensities, std::vector<float>* kept_points,
                        const laserscan_common::SelfFilter* self_filter)
{
  const Frame f = start(camera_to_reference, kept_points, self_filter);
  const int beams = f.beams;
  const bool want_index = intensities && cloud.has_intensity;
  if (want_index)
    best_index_.assign(beams + kScratchSlots, 0);
  const bool hole = f.hole;
  if (cloud.size() > 0 && cloud.data)
  {
    if (cloud.xyz_type == FieldType::Float64)
    {
      if (hole)
        dispatchOutputs<double, true>(cloud, f, want_index, kept_points);
      else
        dispatchOutputs<double, false>(cloud, f, want_index, kept_points);
    }
    else
    {
      if (hole)
        dispatchOutputs<float, true>(cloud, f, want_index, kept_points);
      else
        dispatchOutputs<float, false>(cloud, f, want_index, kept_points);
    }
  }

  finish(f, ranges);

  if (intensities)
  {
    intensities->clear();
    if (want_index)
    {
      intensities->resize(beams, 0.0f);
      for (int b = 0; b < beams; ++b)
      {
        if (std::isinf(best_r2_[b]) || best_r2_[b] == kSelfR2)
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
