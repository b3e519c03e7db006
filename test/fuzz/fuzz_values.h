// Seeded source of malformed and extreme values for the sanitizer fuzz tests of both cores
// (header-only, no ROS). The node fuzz (test/fuzz/fuzz_cases.py) draws from the same lists.
#pragma once

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace fuzz
{
/// FUZZ_SEED and FUZZ_CASES (environment) override the defaults, to replay or extend a run.
inline std::uint64_t envOr(const char* name, std::uint64_t fallback)
{
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? std::strtoull(v, nullptr, 10) : fallback;
}

class Generator
{
public:
  explicit Generator(std::uint64_t seed) : rng_(seed) {}

  bool chance(double p) { return std::uniform_real_distribution<double>(0.0, 1.0)(rng_) < p; }
  double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng_); }
  /// Inclusive.
  std::uint64_t integer(std::uint64_t lo, std::uint64_t hi)
  {
    return std::uniform_int_distribution<std::uint64_t>(lo, hi)(rng_);
  }
  template <typename T>
  const T& pick(const std::vector<T>& options)
  {
    return options[integer(0, options.size() - 1)];
  }

  /// A double that breaks arithmetic: non-finite, signed zero, denormal, huge, near integer limits.
  double extremeDouble()
  {
    static const std::vector<double> values = { 0.0,
                                                -0.0,
                                                std::numeric_limits<double>::quiet_NaN(),
                                                -std::numeric_limits<double>::quiet_NaN(),
                                                std::numeric_limits<double>::infinity(),
                                                -std::numeric_limits<double>::infinity(),
                                                std::numeric_limits<double>::denorm_min(),
                                                DBL_MIN,
                                                DBL_MAX,
                                                -DBL_MAX,
                                                FLT_MAX,
                                                -FLT_MAX,
                                                1e-300,
                                                1e300,
                                                -1e300,
                                                1e38,
                                                1e-38,
                                                2147483647.0,
                                                2147483648.0,
                                                4294967295.0,
                                                4294967296.0,
                                                -1.0,
                                                1.0,
                                                1e-9,
                                                1e9,
                                                3.14159265358979,
                                                -3.14159265358979,
                                                6.28318530717959,
                                                1e7 };
    return pick(values);
  }
  /// A float reading as a driver might write it: non-finite, negative, an error code, huge.
  float extremeFloat()
  {
    static const std::vector<float> values = { 0.0f,
                                               -0.0f,
                                               std::numeric_limits<float>::quiet_NaN(),
                                               -std::numeric_limits<float>::quiet_NaN(),
                                               std::numeric_limits<float>::infinity(),
                                               -std::numeric_limits<float>::infinity(),
                                               std::numeric_limits<float>::denorm_min(),
                                               FLT_MIN,
                                               FLT_MAX,
                                               -FLT_MAX,
                                               1e30f,
                                               -1e30f,
                                               -1.0f,
                                               0.006f,
                                               0.019f,
                                               65.533f,
                                               65.535f,
                                               1e-30f,
                                               16777216.0f };
    return pick(values);
  }
  /// Mostly a plausible value in [lo, hi], sometimes an extreme one.
  double sometimesExtreme(double lo, double hi, double p_extreme = 0.1)
  {
    return chance(p_extreme) ? extremeDouble() : uniform(lo, hi);
  }
  float sometimesExtremeFloat(float lo, float hi, double p_extreme = 0.1)
  {
    return chance(p_extreme) ? extremeFloat() : static_cast<float>(uniform(lo, hi));
  }
  /// Stamps (s) as a ROS header can carry them: 0, negative after a bad subtraction, the
  /// largest secs (the issue-8 crash), a nanosecond step, ordinary.
  double extremeStamp()
  {
    static const std::vector<double> values = { 0.0,          1e-9,         -1.0,  -2147483648.0, 4294967295.999999999,
                                                2147483648.0, 2147483647.0, 1.7e9, 1e9 + 1e-9 };
    return chance(0.5) ? pick(values) : uniform(0.0, 4294967295.0);
  }

private:
  std::mt19937_64 rng_;
};

}  // namespace fuzz
