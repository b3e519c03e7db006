// Small math kernels of the hot paths (ROS-free): the one fast atan2 both nodes map points to
// beams with.
#pragma once

#include <algorithm>
#include <cfloat>
#include <cmath>

namespace laserscan_common
{

/// Largest error of fastAtan2 against std::atan2, in radians, with margin for float rounding (the
/// polynomial alone stays under 1.8e-6). Tests check this bound; it is far below half a beam for
/// any sensible angle_increment (half the merger's default beam is 2.2e-3 rad).
constexpr float kFastAtan2MaxError = 4e-6f;

/// atan2(y, x) in [-pi, pi]; (0, 0) gives 0. An odd degree-11 polynomial, least-squares fitted
/// (this project; Chebyshev nodes, error-weighted) to atan on [0, 1], after reducing to the first
/// octant. One division, no library call; the selects compile to blends, so there is no branch
/// and loops calling this vectorise.
inline float fastAtan2(float y, float x)
{
  const float ax = std::fabs(x);
  const float ay = std::fabs(y);
  const float mx = std::max(ax, ay);
  const float mn = std::min(ax, ay);
  // mx == 0 only at the origin: 0 / FLT_MIN = 0, as std::atan2(0, 0). No branch around the
  // division.
  const float a = mn / std::max(mx, FLT_MIN);
  const float s = a * a;
  float r = 0.9999772310256958f +
            s * (-0.33262282609939575f +
                 s * (0.19354033470153809f +
                      s * (-0.11642635613679886f + s * (0.052647195756435394f + s * -0.011719069443643093f))));
  r *= a;
  r = ay > ax ? 1.57079632679489662f - r : r;
  r = x < 0.0f ? 3.14159265358979324f - r : r;
  return y < 0.0f ? -r : r;
}

}  // namespace laserscan_common
