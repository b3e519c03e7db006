// Sanitizer fuzz of the merger core (issue 8): seeded malformed and extreme LaserScans,
// odometry and transforms through MergerCore::merge and the OdometryBuffer. Built with
// -fsanitize=address,undefined and no recovery, so an out-of-bounds access or any undefined
// behaviour fails the test; every case also checks the invariants of the output.
#include <gtest/gtest.h>

#include <iostream>

#include "fuzz_values.h"
#include "multi_laserscan_merger/merger_core.hpp"

using namespace multi_laserscan_merger;

namespace
{
// A configuration a user could write, sometimes an invalid one (must throw ParameterError).
MergerParams randomParams(fuzz::Generator& g)
{
  MergerParams p;
  OutputParams& o = p.output;
  o.angle_min = g.sometimesExtreme(-kPi, -1.0, 0.02);
  o.angle_max = g.sometimesExtreme(1.0, kPi, 0.02);
  // Divisors of a full turn (bins wrap) and others; rarely a very fine output.
  o.angle_increment =
    g.chance(0.5) ? 2.0 * kPi / static_cast<double>(g.integer(16, 1440)) : g.sometimesExtreme(0.001, 0.1, 0.02);
  o.range_min = g.sometimesExtreme(0.0, 0.5, 0.05);
  o.range_max = g.sometimesExtreme(1.0, 40.0, 0.05);
  o.use_inf = g.chance(0.7);
  o.inf_epsilon = g.sometimesExtreme(0.0, 2.0, 0.02);
  p.odom_queue_size = static_cast<int>(g.integer(1, 200));
  const std::size_t n_sources = g.integer(g.chance(0.01) ? 0 : 1, 4);
  for (std::size_t i = 0; i < n_sources; ++i)
  {
    SourceParams s;
    s.name = g.chance(0.01) ? "" : "s" + std::to_string(i);
    s.topic = "scan" + std::to_string(i);
    s.timeout = g.sometimesExtreme(0.1, 2.0, 0.02);
    s.angle_min = g.uniform(-kPi, kPi);  // may exceed angle_max: a mask wrapping around +-pi
    s.angle_max = g.chance(0.3) ? kPi : g.uniform(-kPi, kPi);
    s.range_min = g.sometimesExtreme(0.0, 0.3, 0.05);
    s.range_max = g.chance(0.5) ? kInf : g.sometimesExtreme(1.0, 30.0, 0.05);
    s.deskew = g.chance(0.5);
    p.sources.push_back(s);
  }
  return p;
}

// A LaserScan as a driver (or a broken one) might send it; `ranges` and `intensities` own the data.
struct RandomScan
{
  std::vector<float> ranges, intensities;
  ScanView view;
};

void randomScan(fuzz::Generator& g, double t_out, RandomScan& s)
{
  ScanView& v = s.view;
  v = ScanView{};
  v.stamp = g.chance(0.8) ? t_out - g.uniform(0.0, 0.5) : g.chance(0.5) ? g.extremeStamp() : g.extremeDouble();
  v.angle_min = g.sometimesExtreme(-kPi, 0.0, 0.05);
  v.angle_max = g.sometimesExtreme(0.0, kPi, 0.05);
  if (g.chance(0.03))
    std::swap(v.angle_min, v.angle_max);  // angle_max < angle_min
  v.angle_increment = g.sometimesExtreme(0.002, 0.05, 0.05);
  if (g.chance(0.03))
    v.angle_increment = -v.angle_increment;
  v.time_increment = g.chance(0.5) ? 0.0 : g.sometimesExtreme(1e-6, 1e-4, 0.05);
  v.range_min = g.sometimesExtreme(0.0, 0.2, 0.05);
  v.range_max = g.sometimesExtreme(5.0, 40.0, 0.05);
  if (g.chance(0.03))
    std::swap(v.range_min, v.range_max);  // range_min > range_max

  // Length: what the angles give, one off (driver rounding), empty, wrong, or a million.
  const std::size_t expected = expectedBeamCount(v);
  std::size_t n = std::min<std::size_t>(expected, 1000);
  const double length_case = g.uniform(0.0, 1.0);
  if (length_case < 0.0002)
    n = 1000000;
  else if (length_case < 0.05)
    n = g.pick(std::vector<std::size_t>{ 0, 1, n + 1, n > 0 ? n - 1 : 0, n + 7, n / 2 });
  s.ranges.resize(n);
  for (float& r : s.ranges)
    r = g.chance(0.15) ? g.extremeFloat() : static_cast<float>(g.uniform(-0.5, 45.0));
  const double intensity_case = g.uniform(0.0, 1.0);
  s.intensities.assign(intensity_case < 0.4 ? n : intensity_case < 0.45 ? n + 1 : intensity_case < 0.5 ? 1 : 0, 1.0f);
  for (float& i : s.intensities)
    i = g.sometimesExtremeFloat(0.0f, 1000.0f, 0.05);
  v.ranges = s.ranges.empty() && g.chance(0.5) ? nullptr : s.ranges.data();
  v.n_ranges = n;
  v.intensities = s.intensities.empty() ? nullptr : s.intensities.data();
  v.n_intensities = s.intensities.size();
}

// Sensor mounts come from tf, which refuses NaN: rotations are proper, translations may be far.
Eigen::Isometry3d randomMount(fuzz::Generator& g)
{
  Eigen::Quaterniond q(g.uniform(-1, 1), g.uniform(-1, 1), g.uniform(-1, 1), g.uniform(-1, 1));
  if (g.chance(0.7))
    q = Eigen::Quaterniond(Eigen::AngleAxisd(g.uniform(-kPi, kPi), Eigen::Vector3d::UnitZ()));
  q = q.norm() > 1e-3 ? q.normalized() : Eigen::Quaterniond::Identity();
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = q.toRotationMatrix();
  t.translation() = Eigen::Vector3d(g.sometimesExtreme(-0.5, 0.5, 0.02), g.sometimesExtreme(-0.5, 0.5, 0.02),
                                    g.sometimesExtreme(0.0, 1.0, 0.02));
  if (!t.translation().allFinite())
    t.translation().setZero();
  return t;
}

// Odometry as a robot (or a broken driver) sends it: NaN, zero and non-normalised quaternions,
// stamps backwards, extreme stamps, huge jumps.
void feedOdometry(fuzz::Generator& g, OdometryBuffer& odom, double& t, Eigen::Vector3d& position, double& yaw)
{
  const std::size_t messages = g.integer(0, 5);
  for (std::size_t m = 0; m < messages; ++m)
  {
    const double step = g.uniform(0.0, 0.05);
    const double time_case = g.uniform(0.0, 1.0);
    t = time_case < 0.9 ? t + step : time_case < 0.95 ? t - g.uniform(0.0, 20.0) : g.extremeStamp();
    position += Eigen::Vector3d(g.uniform(-0.05, 0.05), g.uniform(-0.05, 0.05), 0.0);
    yaw += g.uniform(-0.05, 0.05);
    Eigen::Vector3d p = position;
    Eigen::Quaterniond q(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
    const double pose_case = g.uniform(0.0, 1.0);
    if (pose_case < 0.03)
      q = Eigen::Quaterniond(0, 0, 0, 0);
    else if (pose_case < 0.06)
      q.coeffs() *= g.pick(std::vector<double>{ 2.0, 1e-7, 1e6, std::nan("") });
    else if (pose_case < 0.09)
      p.x() = g.extremeDouble();
    else if (pose_case < 0.11)
      p += Eigen::Vector3d(1e4, -1e4, 0);  // a jump of the odometry frame
    const std::size_t before = odom.size();
    const auto result = odom.add(g.chance(0.01) ? g.extremeDouble() : t, p, q);
    ASSERT_LE(odom.size(), odom.capacity());
    if (!p.allFinite() || !std::isfinite(q.norm()) || q.norm() < 1e-6)
    {
      ASSERT_EQ(result, OdometryBuffer::AddResult::kRejected);
      ASSERT_EQ(odom.size(), before);
    }
    if (result == OdometryBuffer::AddResult::kAdded || result == OdometryBuffer::AddResult::kClearedBackwards)
    {
      Pose newest;
      ASSERT_TRUE(odom.poseAt(odom.newestTime(), newest));
      ASSERT_NEAR(newest.orientation.norm(), 1.0, 1e-9);
    }
  }
}

void expectMergeInvariants(const MergerCore& core, const std::vector<SourceInput>& inputs, double /*t_out*/,
                           const MergedScan& out, const std::vector<SourceStatus>& status)
{
  const OutputParams& o = core.params().output;
  ASSERT_EQ(out.ranges.size(), o.beamCount());
  ASSERT_TRUE(out.intensities.empty() || out.intensities.size() == out.ranges.size());
  ASSERT_EQ(status.size(), core.params().sources.size());
  for (std::size_t s = 0; s < status.size(); ++s)
    if (inputs[s].present)
    {
      ASSERT_EQ(status[s] == SourceStatus::kInvalid, !scanFault(inputs[s].scan).empty()) << "source " << s;
    }
    else
    {
      ASSERT_EQ(status[s], SourceStatus::kMissing);
    }
  const float rmin = static_cast<float>(o.range_min), rmax = static_cast<float>(o.range_max);
  const float no_return =
    o.use_inf ? std::numeric_limits<float>::infinity() : static_cast<float>(o.range_max + o.inf_epsilon);
  for (std::size_t k = 0; k < out.ranges.size(); ++k)
  {
    const float r = out.ranges[k];
    if (std::isfinite(r) && r != no_return)
    {
      ASSERT_GE(r, rmin) << "beam " << k;
      ASSERT_LE(r, rmax) << "beam " << k;
    }
  }
}
}  // namespace

TEST(MergerCoreFuzz, MalformedScansAndOdometryNeverCrashAndOutputKeepsItsLimits)
{
  const std::uint64_t seed = fuzz::envOr("FUZZ_SEED", 20261130);
  const std::uint64_t cases = fuzz::envOr("FUZZ_CASES", 100000);
  fuzz::Generator g(seed);
  std::unique_ptr<MergerCore> core;
  OdometryBuffer odom;
  std::vector<RandomScan> scans;
  std::vector<SourceInput> inputs;
  MergedScan out;
  std::vector<SourceStatus> status;
  double odom_t = 1.7e9, yaw = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  std::uint64_t refused_configs = 0, merges = 0, invalid_scans = 0, used_scans = 0;

  for (std::uint64_t i = 0; i < cases; ++i)
  {
    SCOPED_TRACE("FUZZ_SEED=" + std::to_string(seed) + " case " + std::to_string(i));
    if (!core || i % 50 == 0)
    {
      const MergerParams p = randomParams(g);
      try
      {
        core = std::make_unique<MergerCore>(p);
        odom = OdometryBuffer(static_cast<std::size_t>(p.odom_queue_size));
        scans.assign(p.sources.size(), RandomScan{});
      }
      catch (const ParameterError& e)
      {
        ++refused_configs;
        ASSERT_FALSE(e.parameter().empty()) << e.what();
      }
      if (!core)
        continue;
    }
    ASSERT_NO_FATAL_FAILURE(feedOdometry(g, odom, odom_t, position, yaw));
    const double t_out = g.chance(0.9) ? odom_t : g.extremeStamp();
    const std::size_t n_src = core->params().sources.size();
    inputs.assign(n_src, SourceInput{});
    for (std::size_t s = 0; s < n_src; ++s)
    {
      inputs[s].present = g.chance(0.9);
      if (!inputs[s].present)
        continue;
      randomScan(g, t_out, scans[s]);
      inputs[s].scan = scans[s].view;
      inputs[s].output_T_sensor = randomMount(g);
    }
    const bool compensate = g.chance(0.7);
    Eigen::Isometry3d output_T_robot = Eigen::Isometry3d::Identity();
    if (g.chance(0.3))
      output_T_robot = randomMount(g);
    core->merge(inputs, t_out, compensate ? &odom : nullptr, output_T_robot, out, status);
    ++merges;
    for (const SourceStatus st : status)
    {
      invalid_scans += st == SourceStatus::kInvalid;
      used_scans += st == SourceStatus::kUsed;
    }
    ASSERT_NO_FATAL_FAILURE(expectMergeInvariants(*core, inputs, t_out, out, status));
  }
  std::cout << "merger core fuzz: seed " << seed << ", " << cases << " cases: " << merges << " merges, " << used_scans
            << " scans used, " << invalid_scans << " scans refused as invalid, " << refused_configs
            << " configurations refused" << std::endl;
  // The generator must reach both sides, or the fuzz tests little.
  EXPECT_GT(used_scans, cases / 2);
  EXPECT_GT(invalid_scans, cases / 20);
  EXPECT_GT(refused_configs, 0u);
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
