// One merge of the paper's four scans (2 lidars x 360 beams, 2 camera scans x 328 beams)
// into 1441 output beams (-pi..pi, pi/720) with motion compensation, against the
// straightforward references measured in the same run:
//  - per point: sin/cos, 4x4 transform of every point, atan2 back (as a hand-written merger does);
//  - laser_geometry::projectLaser + tf2::doTransform of the cloud + atan2 binning;
//  - laser_geometry::transformLaserScanToPointCloud into the fixed frame `odom` with a
//    tf2::BufferCore (per-beam interpolation of the sensor pose: the usual ROS 1 merger's
//    motion-aware path), then odom -> base_link at the output time and atan2 binning.
// Prints the per-merge times and the ratios. Not a test: figures only.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <random>

#include <laser_geometry/laser_geometry.h>
#include <tf2/buffer_core.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_sensor_msgs/tf2_sensor_msgs.h>

#include "multi_laserscan_merger/merger_core.hpp"

using namespace multi_laserscan_merger;

namespace
{
struct Scenario
{
  MergerParams params;
  std::vector<sensor_msgs::LaserScan> scans;
  std::vector<Eigen::Isometry3d> mounts;
  OdometryBuffer odom{ 100 };
  tf2::BufferCore tf{ ros::Duration(10.0) };  // the same robot motion and mounts for the tf reference
  double t_out = 0.0;

  explicit Scenario(bool deskew)
  {
    std::mt19937 rng(42);
    std::uniform_real_distribution<float> range(0.3f, 8.0f);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    auto make_scan = [&](double stamp, double amin, double inc, std::size_t n, double t_inc) {
      sensor_msgs::LaserScan s;
      s.header.stamp.fromSec(stamp);
      s.angle_min = amin;
      s.angle_increment = inc;
      s.angle_max = amin + (n - 1) * inc;
      s.time_increment = t_inc;
      s.range_min = 0.05;
      s.range_max = 12.0;
      s.ranges.resize(n);
      for (auto& r : s.ranges)
      {
        const float u = unit(rng);
        r = u < 0.05f ? std::numeric_limits<float>::infinity() : (u < 0.07f ? std::nanf("") : range(rng));
      }
      return s;
    };
    auto mount = [](double x, double y, double z, double yaw) {
      Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
      t.translation() = Eigen::Vector3d(x, y, z);
      t.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      return t;
    };
    const double deg = kPi / 180.0;
    const char* names[4] = { "lidar_front_left", "lidar_rear_right", "camera_front", "camera_rear" };
    for (int i = 0; i < 4; ++i)
    {
      SourceParams s;
      s.name = names[i];
      s.topic = std::string(names[i]) + "/scan";
      s.deskew = deskew && i < 2;
      params.sources.push_back(s);
    }
    params.sources[0].angle_min = -3 * kPi / 4;  // mask the robot's body (270 degrees kept)
    params.sources[0].angle_max = 3 * kPi / 4;
    params.sources[1].angle_min = -3 * kPi / 4;
    params.sources[1].angle_max = 3 * kPi / 4;
    params.output.range_max = 12.0;
    // 8 Hz lidars (time_increment = 0.125 s / 360), 14 Hz cameras, different ages.
    scans.push_back(make_scan(0.950, -kPi, 1.0 * deg, 360, 0.125 / 360));
    scans.push_back(make_scan(0.900, -kPi, 1.0 * deg, 360, 0.125 / 360));
    scans.push_back(make_scan(0.980, -41.0 * deg, 0.25 * deg, 328, 0.0));
    scans.push_back(make_scan(0.960, -41.0 * deg, 0.25 * deg, 328, 0.0));
    mounts = { mount(0.37, 0.24, 0.2, kPi / 4), mount(-0.37, -0.24, 0.2, -3 * kPi / 4), mount(0.37, 0.0, 0.5, 0.0),
               mount(-0.37, 0.0, 0.5, kPi) };
    for (int i = 0; i < 4; ++i)
    {
      scans[i].header.frame_id = names[i];
      geometry_msgs::TransformStamped t = tf2::eigenToTransform(mounts[i]);
      t.header.frame_id = "base_link";
      t.child_frame_id = names[i];
      tf.setTransform(t, "bench", true);
    }
    // 50 Hz odometry of a robot driving at 0.5 m/s while turning at 0.5 rad/s.
    for (int k = 0; k <= 60; ++k)
    {
      const double t = 0.02 * k, yaw = 0.5 * t;
      odom.add(t, Eigen::Vector3d(std::sin(yaw), 1.0 - std::cos(yaw), 0.0),
               Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())));
      Pose p;
      odom.poseAt(t, p);
      geometry_msgs::TransformStamped ts = tf2::eigenToTransform(p.toIsometry());
      ts.header.stamp.fromSec(t);
      ts.header.frame_id = "odom";
      ts.child_frame_id = "base_link";
      tf.setTransform(ts, "bench", false);
    }
    t_out = 1.0;
  }

  std::vector<SourceInput> inputs() const
  {
    std::vector<SourceInput> in(scans.size());
    for (std::size_t i = 0; i < scans.size(); ++i)
    {
      const auto& s = scans[i];
      in[i].present = true;
      in[i].scan.stamp = s.header.stamp.toSec();
      in[i].scan.angle_min = s.angle_min;
      in[i].scan.angle_max = s.angle_max;
      in[i].scan.angle_increment = s.angle_increment;
      in[i].scan.time_increment = s.time_increment;
      in[i].scan.range_min = s.range_min;
      in[i].scan.range_max = s.range_max;
      in[i].scan.ranges = s.ranges.data();
      in[i].scan.n_ranges = s.ranges.size();
      in[i].output_T_sensor = mounts[i];
    }
    return in;
  }

  // Transform of a scan (taken at its stamp) to the output frame at t_out.
  Eigen::Isometry3d compensated(std::size_t i) const
  {
    return odom.motion(scans[i].header.stamp.toSec(), t_out) * mounts[i];
  }
};

inline void keepClosest(std::vector<float>& out, double x, double y, const OutputParams& o)
{
  double rel = std::atan2(y, x) - o.angle_min;
  if (rel < 0.0)
    rel += 2.0 * kPi;
  long k = std::lround(rel / o.angle_increment);
  if (k >= 1440)
    k -= 1440;
  if (k < 0 || k >= static_cast<long>(out.size()))
    return;
  const float r = static_cast<float>(std::hypot(x, y));
  if (r < out[k])
    out[k] = r;
}

// Reference 1: per point sin/cos, 4x4 homogeneous transform, atan2 back.
void referenceSinCos(const Scenario& sc, std::vector<float>& out)
{
  const OutputParams& o = sc.params.output;
  out.assign(o.beamCount(), std::numeric_limits<float>::infinity());
  for (std::size_t i = 0; i < sc.scans.size(); ++i)
  {
    const auto& s = sc.scans[i];
    const SourceParams& sp = sc.params.sources[i];
    const Eigen::Matrix4d t = sc.compensated(i).matrix();
    for (std::size_t b = 0; b < s.ranges.size(); ++b)
    {
      const double a = s.angle_min + b * s.angle_increment;
      const float r = s.ranges[b];
      // The scenario's masks do not wrap around: a plain comparison is the fair reference.
      if (a < sp.angle_min || a > sp.angle_max || !(r >= s.range_min && r <= s.range_max))
        continue;
      const Eigen::Vector4d p = t * Eigen::Vector4d(r * std::cos(a), r * std::sin(a), 0.0, 1.0);
      keepClosest(out, p.x(), p.y(), o);
    }
  }
}

// Reference 2: laser_geometry projection to a PointCloud2, tf2 transform of the cloud,
// then atan2 binning of every point.
void referenceLaserGeometry(const Scenario& sc, laser_geometry::LaserProjection& projector, std::vector<float>& out)
{
  const OutputParams& o = sc.params.output;
  out.assign(o.beamCount(), std::numeric_limits<float>::infinity());
  sensor_msgs::PointCloud2 cloud, moved;
  for (std::size_t i = 0; i < sc.scans.size(); ++i)
  {
    projector.projectLaser(sc.scans[i], cloud);
    geometry_msgs::TransformStamped tf = tf2::eigenToTransform(sc.compensated(i));
    tf2::doTransform(cloud, moved, tf);
    const SourceParams& sp = sc.params.sources[i];
    for (sensor_msgs::PointCloud2ConstIterator<float> x(moved, "x"), y(moved, "y"), idx(cloud, "x"); x != x.end();
         ++x, ++y, ++idx)
    {
      // The source's mask in the sensor frame needs the point before the transform.
      const double a = std::atan2(idx[1], idx[0]);
      if (a < sp.angle_min || a > sp.angle_max)
        continue;
      keepClosest(out, *x, *y, o);
    }
  }
}

// Reference 3: laser_geometry with tf (per-beam sensor pose between the scan's start and end
// into the fixed frame odom), then odom -> base_link at the output time, atan2 binning.
void referenceLaserGeometryTf(const Scenario& sc, laser_geometry::LaserProjection& projector, std::vector<float>& out)
{
  const OutputParams& o = sc.params.output;
  out.assign(o.beamCount(), std::numeric_limits<float>::infinity());
  sensor_msgs::PointCloud2 in_odom, moved;
  const geometry_msgs::TransformStamped base_T_odom = sc.tf.lookupTransform("base_link", "odom", ros::Time(sc.t_out));
  for (std::size_t i = 0; i < sc.scans.size(); ++i)
  {
    const auto& scan = sc.scans[i];
    projector.transformLaserScanToPointCloud("odom", scan, in_odom, const_cast<tf2::BufferCore&>(sc.tf));
    tf2::doTransform(in_odom, moved, base_T_odom);
    const SourceParams& sp = sc.params.sources[i];
    // The mask (sensor frame) is applied on the beam index the cloud carries.
    sensor_msgs::PointCloud2ConstIterator<int> index(moved, "index");
    for (sensor_msgs::PointCloud2ConstIterator<float> x(moved, "x"), y(moved, "y"); x != x.end(); ++x, ++y, ++index)
    {
      const double a = scan.angle_min + *index * scan.angle_increment;
      if (a < sp.angle_min || a > sp.angle_max)
        continue;
      keepClosest(out, *x, *y, o);
    }
  }
}

double g_core_ns = 0.0, g_core_deskew_ns = 0.0, g_core_footprint_ns = 0.0, g_ref_ns = 0.0, g_lg_ns = 0.0,
       g_lgtf_ns = 0.0;

// One merge of the paper's four scans; deskew moves every lidar beam from its own time;
// footprint drops the returns on the paper robot's 0.74 m x 0.48 m outline.
void runCoreMerge(benchmark::State& state, bool deskew, bool footprint = false)
{
  Scenario sc(deskew);
  if (footprint)
    sc.params.output.footprint = { { { 0.37, 0.24 } }, { { -0.37, 0.24 } }, { { -0.37, -0.24 } }, { { 0.37, -0.24 } } };
  MergerCore core(sc.params);
  const auto in = sc.inputs();
  MergedScan out;
  std::vector<SourceStatus> st;
  for (auto _ : state)
  {
    core.merge(in, sc.t_out, &sc.odom, Eigen::Isometry3d::Identity(), out, st);
    benchmark::DoNotOptimize(out.ranges.data());
    benchmark::ClobberMemory();
  }
}

void BM_CoreMerge(benchmark::State& state)
{
  runCoreMerge(state, false);
}

void BM_CoreMergeDeskew(benchmark::State& state)
{
  runCoreMerge(state, true);
}

void BM_CoreMergeFootprint(benchmark::State& state)
{
  runCoreMerge(state, false, true);
}

void BM_ReferenceSinCosAtan2(benchmark::State& state)
{
  Scenario sc(false);
  std::vector<float> out;
  for (auto _ : state)
  {
    referenceSinCos(sc, out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
}

void BM_ReferenceLaserGeometry(benchmark::State& state)
{
  Scenario sc(false);
  laser_geometry::LaserProjection projector;
  std::vector<float> out;
  for (auto _ : state)
  {
    referenceLaserGeometry(sc, projector, out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
}

void BM_ReferenceLaserGeometryTf(benchmark::State& state)
{
  Scenario sc(false);
  laser_geometry::LaserProjection projector;
  std::vector<float> out;
  for (auto _ : state)
  {
    referenceLaserGeometryTf(sc, projector, out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
}

BENCHMARK(BM_CoreMerge)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CoreMergeDeskew)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CoreMergeFootprint)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ReferenceSinCosAtan2)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ReferenceLaserGeometry)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ReferenceLaserGeometryTf)->Unit(benchmark::kMicrosecond);

// Collects the per-iteration CPU times (steadier than wall time on a shared machine)
// to print the ratios at the end.
class RatioReporter : public benchmark::ConsoleReporter
{
public:
  void ReportRuns(const std::vector<Run>& runs) override
  {
    ConsoleReporter::ReportRuns(runs);
    for (const auto& r : runs)
    {
      // Single runs, or the median when --benchmark_repetitions is given.
      const bool median = r.run_type == Run::RT_Aggregate && r.aggregate_name == "median";
      if ((r.run_type != Run::RT_Iteration && !median) || r.iterations == 0)
        continue;
      const double ns = r.cpu_accumulated_time * 1e9 / static_cast<double>(r.iterations);
      const std::string name = r.run_name.function_name;
      if (name == "BM_CoreMerge")
        g_core_ns = ns;
      else if (name == "BM_CoreMergeDeskew")
        g_core_deskew_ns = ns;
      else if (name == "BM_CoreMergeFootprint")
        g_core_footprint_ns = ns;
      else if (name == "BM_ReferenceSinCosAtan2")
        g_ref_ns = ns;
      else if (name == "BM_ReferenceLaserGeometry")
        g_lg_ns = ns;
      else if (name == "BM_ReferenceLaserGeometryTf")
        g_lgtf_ns = ns;
    }
  }
};

// Fraction of the core's real ranges that a reference also has within one bin and 1 cm:
// shows that the references compute the same scan (so the ratio compares like with like).
double agreement(const std::vector<float>& core, const std::vector<float>& ref)
{
  std::size_t n = 0, ok = 0;
  for (std::size_t k = 0; k + 1 < core.size(); ++k)
  {
    if (!std::isfinite(core[k]))
      continue;
    ++n;
    for (std::size_t j = (k == 0 ? 0 : k - 1); j <= k + 1 && j < ref.size(); ++j)
      if (std::abs(ref[j] - core[k]) < 0.01f)
      {
        ++ok;
        break;
      }
  }
  return n ? static_cast<double>(ok) / n : 0.0;
}

void checkReferences()
{
  Scenario sc(false);
  MergerCore core(sc.params);
  MergedScan out;
  std::vector<SourceStatus> st;
  core.merge(sc.inputs(), sc.t_out, &sc.odom, Eigen::Isometry3d::Identity(), out, st);
  laser_geometry::LaserProjection projector;
  std::vector<float> r1, r2, r3;
  referenceSinCos(sc, r1);
  referenceLaserGeometry(sc, projector, r2);
  referenceLaserGeometryTf(sc, projector, r3);
  // laser_geometry with tf moves every lidar beam from its own time: compare with the deskewing core.
  Scenario sc_deskew(true);
  MergerCore core_deskew(sc_deskew.params);
  MergedScan out_deskew;
  core_deskew.merge(sc_deskew.inputs(), sc_deskew.t_out, &sc_deskew.odom, Eigen::Isometry3d::Identity(), out_deskew,
                    st);
  std::printf(
    "Agreement of the references with the core (real ranges within one bin and 1 cm): "
    "sin/cos %.1f%%, laser_geometry+tf2 %.1f%%, laser_geometry with tf (against the deskewing core) %.1f%%\n\n",
    100 * agreement(out.ranges, r1), 100 * agreement(out.ranges, r2), 100 * agreement(out_deskew.ranges, r3));
}
}  // namespace

int main(int argc, char** argv)
{
  benchmark::Initialize(&argc, argv);
  checkReferences();
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  if (g_core_ns > 0.0 && g_ref_ns > 0.0 && g_lg_ns > 0.0)
  {
    std::printf("\nOne merge of 2x360 + 2x328 beams into 1441 beams with motion compensation:\n");
    std::printf("  core                         %8.2f us\n", g_core_ns / 1e3);
    if (g_core_deskew_ns > 0.0)
      std::printf("  core, lidars deskewed        %8.2f us\n", g_core_deskew_ns / 1e3);
    if (g_core_footprint_ns > 0.0)
      std::printf("  core, footprint filter       %8.2f us  (%.2fx the core without it)\n", g_core_footprint_ns / 1e3,
                  g_core_footprint_ns / g_core_ns);
    std::printf("  reference sin/cos/atan2      %8.2f us  ratio reference/core %6.1fx\n", g_ref_ns / 1e3,
                g_ref_ns / g_core_ns);
    std::printf("  reference laser_geometry+tf2 %8.2f us  ratio reference/core %6.1fx\n", g_lg_ns / 1e3,
                g_lg_ns / g_core_ns);
    if (g_lgtf_ns > 0.0 && g_core_deskew_ns > 0.0)
      std::printf(
        "  reference laser_geometry, tf  %8.2f us  ratio reference/deskewed core %6.1fx "
        "(it moves every beam from its own time too)\n",
        g_lgtf_ns / 1e3, g_lgtf_ns / g_core_deskew_ns);
    if (g_core_deskew_ns > 0.0)
      std::printf("  (deskewed core vs sin/cos reference without deskew: %.1fx)\n", g_ref_ns / g_core_deskew_ns);
  }
  benchmark::Shutdown();
  return 0;
}
