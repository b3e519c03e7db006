// Sanitizer fuzz of the converter core (issue 8): seeded malformed PointCloud2 layouts and
// extreme points through makeCloudView and Projector::project. Built with
// -fsanitize=address,undefined and no recovery, so an out-of-bounds read or any undefined
// behaviour fails the test; every case also checks the invariants of the output.
#include <gtest/gtest.h>

#include <cstring>
#include <iostream>
#include <stdexcept>

#include "depth_filter_scan_converter/projector.hpp"
#include "fuzz_values.h"

using namespace depth_filter_scan_converter;

namespace
{
const std::vector<std::uint8_t> kDatatypes = { 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 255 };

// Parameters a user could load, plus sometimes an invalid one (which must be refused with
// ParameterError and leave the projector as it was).
Parameters randomParameters(fuzz::Generator& g)
{
  Parameters p;
  p.band.floor_height = g.sometimesExtreme(-1.0, 1.0, 0.02);
  p.band.min_height = g.sometimesExtreme(-1.0, 0.5, 0.05);
  p.band.max_height = g.sometimesExtreme(0.5, 3.0, 0.05);
  p.scan.angle_min = g.sometimesExtreme(-M_PI, 0.0, 0.02);
  p.scan.angle_max = g.sometimesExtreme(0.0, M_PI, 0.02);
  // Mostly a few hundred beams; rarely up to the limit of one million.
  p.scan.angle_increment = g.chance(0.001) ? 6.3e-6 : g.sometimesExtreme(0.002, 0.1, 0.02);
  p.scan.range_min = g.sometimesExtreme(0.0, 0.5, 0.05);
  p.scan.range_max = g.chance(0.1) ? std::numeric_limits<double>::infinity() : g.sometimesExtreme(0.5, 30.0, 0.05);
  p.band.hole_detection = g.chance(0.3);
  p.band.hole_depth = g.sometimesExtreme(0.0, 0.2, 0.02);
  if (g.chance(0.5))  // the closest-cluster pass (range noise model)
  {
    p.noise.range_noise_std = g.sometimesExtreme(0.0, 0.01, 0.05);
    p.noise.range_noise_std_per_m2 = g.sometimesExtreme(0.0, 0.005, 0.05);
  }
  p.input.row_stride = g.chance(0.9) ? 1 : static_cast<int>(g.integer(0, 5));
  p.input.column_stride = g.chance(0.9) ? 1 : static_cast<int>(g.integer(0, 5));
  p.scan.use_inf = g.chance(0.7);
  p.scan.inf_epsilon = g.sometimesExtreme(0.0, 2.0, 0.02);
  p.input.intensity_field = g.pick(std::vector<std::string>{ "", "intensity", "x", "missing" });
  return p;
}

FieldDescription randomField(fuzz::Generator& g, const std::string& name, std::uint32_t point_step)
{
  FieldDescription f;
  f.name = name;
  f.datatype = g.chance(0.8) ? g.pick(std::vector<std::uint8_t>{ 7, 8 }) : g.pick(kDatatypes);
  // In bounds, at the end, just past it, or near 2^32 (overflow of offset + size).
  const std::uint32_t span = point_step > 0 ? point_step : 1;
  f.offset =
    g.chance(0.85)
      ? static_cast<std::uint32_t>(g.integer(0, span - 1))
      : g.pick(std::vector<std::uint32_t>{ point_step, point_step + 1, 0xFFFFFFFFu, 0xFFFFFFFCu, 0x80000000u });
  f.count = g.chance(0.95) ? 1 : static_cast<std::uint32_t>(g.pick(std::vector<std::uint64_t>{ 0, 3, 0xFFFFFFFFu }));
  return f;
}

struct RandomCloud
{
  CloudLayout layout;
  std::vector<std::uint8_t> data;  // exactly as large as the message says, so ASan sees any overread
};

RandomCloud randomCloud(fuzz::Generator& g)
{
  RandomCloud c;
  CloudLayout& l = c.layout;
  const bool aligned = g.chance(0.6);  // the usual x, y, z (+ intensity) layout
  const bool dbl = g.chance(0.3);
  const std::uint32_t size = dbl ? 8 : 4;
  l.point_step = g.chance(0.8) ? g.pick(std::vector<std::uint32_t>{ 3 * size, 4 * size, 16, 32, 48 })
                               : g.pick(std::vector<std::uint32_t>{ 0, 1, 7, 13, 0xFFFFFFFFu, 0x80000000u });
  l.width = g.chance(0.9) ? static_cast<std::uint32_t>(g.integer(0, 48))
                          : g.pick(std::vector<std::uint32_t>{ 0xFFFFFFFFu, 0x10000u, 1u << 20 });
  l.height = g.chance(0.9) ? static_cast<std::uint32_t>(g.integer(0, 8))
                           : g.pick(std::vector<std::uint32_t>{ 0xFFFFFFFFu, 0x10000u });
  const std::uint64_t min_row = static_cast<std::uint64_t>(l.width) * l.point_step;
  l.row_step = g.chance(0.8)
                 ? static_cast<std::uint32_t>(std::min<std::uint64_t>(min_row, 0xFFFFFFFFu))
                 : g.pick(std::vector<std::uint32_t>{ 0, static_cast<std::uint32_t>(min_row + 3),
                                                      static_cast<std::uint32_t>(min_row - 1), 0xFFFFFFFFu });
  l.is_bigendian = g.chance(0.03);

  if (aligned && l.point_step >= 3 * size)
  {
    for (int i = 0; i < 3; ++i)
      l.fields.push_back(FieldDescription{ std::string(1, "xyz"[i]), static_cast<std::uint32_t>(i * size),
                                           static_cast<std::uint8_t>(dbl ? 8 : 7), 1 });
    if (l.point_step >= 4 * size)
      l.fields.push_back(FieldDescription{ "intensity", 3 * size, g.pick(kDatatypes), 1 });
  }
  else
  {
    // Any subset of x, y, z, intensity, possibly duplicated, in any layout.
    for (const char* name : { "x", "y", "z", "intensity", "x", "rgb" })
      if (g.chance(0.8))
        l.fields.push_back(randomField(g, name, l.point_step));
  }

  // Data: the size the header implies (when small enough to allocate), sometimes off by a few bytes.
  const std::uint64_t implied = static_cast<std::uint64_t>(l.row_step) * l.height;
  std::uint64_t n = implied <= (1u << 20) ? implied : g.integer(0, 4096);
  if (g.chance(0.1))
    n = g.pick(std::vector<std::uint64_t>{ 0, n + 1, n > 0 ? n - 1 : 0, n + 16 });
  c.data.resize(n);
  // Points: plausible coordinates, extreme values, or raw random bytes.
  const int fill = static_cast<int>(g.integer(0, 2));
  for (std::size_t off = 0; off + size <= n; off += size)
  {
    if (fill == 2)
    {
      const std::uint64_t bits = g.integer(0, ~0ull);
      std::memcpy(&c.data[off], &bits, size);
      continue;
    }
    const double v = fill == 1 && g.chance(0.3) ? g.extremeDouble() : g.uniform(-6.0, 6.0);
    if (dbl)
      std::memcpy(&c.data[off], &v, 8);
    else
    {
      // Finite doubles beyond the float range are clamped (the cast would be undefined).
      const float f = std::isfinite(v) ? static_cast<float>(std::max(-3e38, std::min(3e38, v))) : static_cast<float>(v);
      std::memcpy(&c.data[off], &f, 4);
    }
  }
  return c;
}

Eigen::Isometry3d randomTransform(fuzz::Generator& g)
{
  Eigen::Quaterniond q(g.uniform(-1, 1), g.uniform(-1, 1), g.uniform(-1, 1), g.uniform(-1, 1));
  q = q.norm() > 1e-3 ? q.normalized() : Eigen::Quaterniond::Identity();
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = q.toRotationMatrix();
  t.translation() = Eigen::Vector3d(g.sometimesExtreme(-1, 1, 0.02), g.sometimesExtreme(-1, 1, 0.02),
                                    g.sometimesExtreme(-0.5, 2.0, 0.02));
  return t;
}

// The output's own limits as a LaserScan carries them (float32 fields).
void expectScanInvariants(const Parameters& p, const CloudView& view, const std::vector<float>& ranges,
                          const std::vector<float>* intensities, const std::vector<float>& kept, std::uint64_t seed,
                          std::uint64_t case_index)
{
  SCOPED_TRACE("FUZZ_SEED=" + std::to_string(seed) + " case " + std::to_string(case_index));
  ASSERT_EQ(ranges.size(), p.scan.beamCount());
  const float no_return = p.scan.noReturnValue();
  const float rmin = static_cast<float>(p.scan.range_min), rmax = static_cast<float>(p.scan.range_max);
  for (std::size_t b = 0; b < ranges.size(); ++b)
  {
    const float r = ranges[b];
    if (std::isfinite(r) && r != no_return)
    {
      ASSERT_GE(r, rmin) << "beam " << b;
      ASSERT_LE(r, rmax) << "beam " << b;
    }
  }
  if (intensities)
  {
    ASSERT_EQ(intensities->size(), view.has_intensity ? ranges.size() : 0u);
  }
  ASSERT_EQ(kept.size() % 3, 0u);
  ASSERT_LE(kept.size() / 3, view.size());
}
}  // namespace

TEST(ConverterCoreFuzz, MalformedCloudsNeverCrashAndScansKeepTheirLimits)
{
  const std::uint64_t seed = fuzz::envOr("FUZZ_SEED", 20261130);
  const std::uint64_t cases = fuzz::envOr("FUZZ_CASES", 100000);
  fuzz::Generator g(seed);
  Projector projector;  // default parameters until a valid set arrives
  std::vector<float> ranges, intensities, kept;
  std::uint64_t refused_layouts = 0, refused_parameters = 0, projected = 0;

  for (std::uint64_t i = 0; i < cases; ++i)
  {
    if (i % 20 == 0)
    {
      const Parameters p = randomParameters(g);
      const Parameters before = projector.parameters();
      try
      {
        projector.setParameters(p);
      }
      catch (const ParameterError& e)
      {
        ++refused_parameters;
        ASSERT_FALSE(e.parameter().empty()) << e.what();
        ASSERT_EQ(projector.parameters().scan.angle_increment, before.scan.angle_increment);
      }
    }
    const RandomCloud cloud = randomCloud(g);
    CloudView view;
    std::string intensity_note;
    const std::string fault =
      makeCloudView(cloud.layout, cloud.data.empty() ? nullptr : cloud.data.data(), cloud.data.size(),
                    projector.parameters().input.intensity_field, view, &intensity_note);
    if (!fault.empty())
    {
      ++refused_layouts;
      continue;
    }
    const bool want_intensity = g.chance(0.5);
    projector.project(view, randomTransform(g), ranges, want_intensity ? &intensities : nullptr, &kept);
    ++projected;
    expectScanInvariants(projector.parameters(), view, ranges, want_intensity ? &intensities : nullptr, kept, seed, i);
  }
  std::cout << "converter core fuzz: seed " << seed << ", " << cases << " cases: " << projected << " projected, "
            << refused_layouts << " layouts refused, " << refused_parameters << " parameter sets refused" << std::endl;
  // The generator must reach both sides, or the fuzz tests little.
  EXPECT_GT(projected, cases / 10);
  EXPECT_GT(refused_layouts, cases / 10);
  EXPECT_GT(refused_parameters, 0u);
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
