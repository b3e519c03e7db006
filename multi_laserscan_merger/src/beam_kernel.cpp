// The hot loop of the merge. Range validity is decided on the bit patterns (integer compares:
// NaN- and Inf-proof whatever the floating-point flags), so every value that reaches the float
// math is finite.
#include "beam_kernel.hpp"

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "laserscan_common/fast_math.hpp"
#include "laserscan_common/scan_geometry.hpp"

namespace multi_laserscan_merger
{

namespace
{
inline std::int32_t bitsOf(float f)
{
  std::int32_t b;
  std::memcpy(&b, &f, sizeof b);
  return b;
}
}  // namespace

namespace
{
// The loop, with or without the per-beam step of the transform (deskew), so that the usual
// case does not pay for the interpolation.
template <bool kStep, bool kAllInView, bool kPoints>
inline __attribute__((always_inline)) void projectLoop(std::size_t len, const float* __restrict rg,
                                                       const float* __restrict fg, const float* __restrict cg,
                                                       const float* __restrict sg, const float* __restrict m,
                                                       float rmin, float rmax, float rmax_msg, int keep_close,
                                                       float amin, float inv_inc, int wrap, unsigned n_out,
                                                       int* __restrict kg, float* __restrict og, float* __restrict xs,
                                                       float* __restrict ys)
{
  constexpr auto kTwoPi = static_cast<float>(laserscan_common::kTwoPi);
  constexpr std::int32_t kInfBits = 0x7f800000;
  constexpr std::int32_t kMinusInfBits = static_cast<std::int32_t>(0xff800000u);
  // An invalid beam is projected at this range: its direction, whatever the translation.
  constexpr float kFar = 1e6f;
  // For non-negative floats the order of the bit patterns is the order of the values;
  // negative values (and -0, -Inf, negative NaN) are negative integers, +Inf is kInfBits and
  // every positive NaN is above it.
  const float rmin0 = rmin > 0.0f ? rmin : 0.0f;
  const std::int32_t min_bits = bitsOf(rmin0);
  const float max_real = 0.5f * FLT_MAX;  // below kInvalidMark
  const std::int32_t max_bits = bitsOf(rmax < max_real ? rmax : max_real);
  const std::int32_t msg_max_bits = bitsOf(rmax_msg < max_real ? rmax_msg : max_real);
  const float m00 = m[0], m01 = m[1], m02 = m[2], m10 = m[3], m11 = m[4], m12 = m[5];
  const float d00 = m[6], d01 = m[7], d02 = m[8], d10 = m[9], d11 = m[10], d12 = m[11];
  for (std::size_t j = 0; j < len; ++j)
  {
    std::int32_t b;
    std::memcpy(&b, rg + j, sizeof b);
    // Bitwise & on purpose: no short-circuit branches in the vectorised loop.
    const int in_view = kAllInView ? 1 : fg[j] > 0.5f;
    const int too_close = in_view & keep_close & (b == kMinusInfBits);  // kept: a reading at range_min
    const int ok = (in_view & (b >= min_bits) & (b <= max_bits)) | too_close;
    // Below range_min, beyond the source's range_max but within the message's, NaN, or -Inf not kept.
    const int invalid =
      in_view & (too_close ^ 1) & ((b < min_bits) | ((b > max_bits) & (b <= msg_max_bits)) | (b > kInfBits));
    // Beams neither ok nor invalid go to a scratch bin: their range does not matter.
    const float r = ok ? (too_close ? rmin0 : rg[j]) : kFar;
    float a00 = m00, a01 = m01, a02 = m02, a10 = m10, a11 = m11, a12 = m12;
    if (kStep)
    {
      const float fj = static_cast<float>(j);
      a00 += fj * d00, a01 += fj * d01, a02 += fj * d02;
      a10 += fj * d10, a11 += fj * d11, a12 += fj * d12;
    }
    const float x = r * (a00 * cg[j] + a01 * sg[j]) + a02;
    const float y = r * (a10 * cg[j] + a11 * sg[j]) + a12;
    float rel = laserscan_common::fastAtan2(y, x) - amin;
    rel += rel < 0.0f ? kTwoPi : 0.0f;
    rel -= rel >= kTwoPi ? kTwoPi : 0.0f;
    // A far transform (a huge odometry position or mount translation) can make x, y infinite
    // and rel NaN, and a degenerate output increment inv_inc infinite: converting those to int
    // is undefined, so anything outside [0, 2e9) becomes -1 (a scratch bin below).
    const float bin = rel * inv_inc + 0.5f;
    int k = static_cast<int>((bin >= 0.0f) & (bin < 2e9f) ? bin : -1.0f);
    k -= k >= wrap ? wrap : 0;
    const float d = std::sqrt(x * x + y * y);
    og[j] = ok ? d : kInvalidMark;
    if (kPoints)
    {
      xs[j] = x;
      ys[j] = y;
    }
    kg[j] = ((ok | invalid) & (static_cast<unsigned>(k) < n_out)) ? k : static_cast<int>(n_out + (j & (kScratch - 1)));
  }
}
}  // namespace

// AVX-512, AVX2+FMA and baseline versions; the CPU picks at load time.
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void projectBeams(
  std::size_t len, const float* __restrict rg, const float* __restrict fg, const float* __restrict cg,
  const float* __restrict sg, const float* __restrict m, float rmin, float rmax, float rmax_msg, bool keep_too_close,
  float amin, float inv_inc, int wrap, unsigned n_out, int* __restrict kg, float* __restrict og, float* __restrict xs,
  float* __restrict ys)
{
  const int kc = keep_too_close ? 1 : 0;
  const bool step = m[6] != 0.0f || m[7] != 0.0f || m[8] != 0.0f || m[9] != 0.0f || m[10] != 0.0f || m[11] != 0.0f;
#define MLM_PROJECT(kStep, kAll, kPoints)                                                                             \
  projectLoop<kStep, kAll, kPoints>(len, rg, fg, cg, sg, m, rmin, rmax, rmax_msg, kc, amin, inv_inc, wrap, n_out, kg, \
                                    og, xs, ys)
  if (xs != nullptr)  // footprint filter on: the rare case, one variant (mask table and steps as data)
    MLM_PROJECT(true, false, true);
  else if (fg == nullptr && step)
    MLM_PROJECT(true, true, false);
  else if (fg == nullptr)
    MLM_PROJECT(false, true, false);
  else if (step)
    MLM_PROJECT(true, false, false);
  else
    MLM_PROJECT(false, false, false);
#undef MLM_PROJECT
}

}  // namespace multi_laserscan_merger
