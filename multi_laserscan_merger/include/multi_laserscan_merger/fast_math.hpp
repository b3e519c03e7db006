// Small math kernels of the hot path.
#pragma once

namespace multi_laserscan_merger
{

/// atan2 by an odd degree-11 polynomial fitted (weighted least squares, this
/// project) to atan on [0, 1], plus octant folding. Maximum error about 2e-6 rad,
/// i.e. three orders of magnitude below half an output beam (pi/1440 = 2.2e-3 rad);
/// checked against std::atan2 in the gtest. Returns a value in [-pi, pi]; (0, 0) gives 0.
inline float fastAtan2(float y, float x)
{
  const float ax = x < 0.0f ? -x : x;
  const float ay = y < 0.0f ? -y : y;
  // Selects instead of branches, so that loops calling this are vectorised.
  const float mx = ax > ay ? ax : ay;
  const float mn = ax > ay ? ay : ax;
  const float a = mn / (mx > 1e-30f ? mx : 1e-30f);
  const float s = a * a;
  float r =
    ((((-0.01172077f * s + 0.05265143f) * s - 0.11643014f) * s + 0.19354178f) * s - 0.33262304f) * s + 0.99997723f;
  r *= a;
  r = ay > ax ? 1.57079632679f - r : r;
  r = x < 0.0f ? 3.14159265359f - r : r;
  return y < 0.0f ? -r : r;
}

}  // namespace multi_laserscan_merger
