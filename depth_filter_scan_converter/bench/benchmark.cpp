// Speed of the core against the straightforward per-point converter, measured in the same run.
//   cmake --build <build> --target depth_filter_scan_converter_benchmark
//   <build>/devel/lib/depth_filter_scan_converter/depth_filter_scan_converter_benchmark
// Ends with one line per cloud: core time, reference time and the ratio.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

#include "../test/cloud_fixtures.hpp"
#include "../test/depth_image_fixtures.hpp"
#include "../test/pcl_cloud.hpp"
#include "depth_filter_scan_converter/projector.hpp"
#include "laserscan_common/self_filter.hpp"

namespace dfsc = depth_filter_scan_converter;
using namespace dfsc::test;  // NOLINT: fixtures of the benchmark

namespace
{
struct Input
{
  TestCloud cloud;
  dfsc::CloudView view;
  Eigen::Isometry3d camera_to_reference;
  std::size_t valid_points = 0;
};

// 320 x 163 organized cloud: camera 0.6 m high, pitched down 20 degrees, looking at the floor,
// a wall 3.5 m ahead, a table, a cabinet and a chair-sized box.
const Input& synthetic()
{
  static const Input input = [] {
    Input in;
    Scene scene;
    scene.wall_x = 3.5;
    scene.boxes.push_back({ Vector3d(1.2, -0.9, 0.70), Vector3d(2.0, 0.1, 0.75) });  // table top
    scene.boxes.push_back({ Vector3d(2.6, 0.4, 0.0), Vector3d(3.0, 1.4, 1.8) });     // cabinet
    scene.boxes.push_back({ Vector3d(1.0, 0.5, 0.0), Vector3d(1.45, 0.95, 0.45) });  // chair
    in.camera_to_reference = cameraMount(0.6, 20 * kDeg);
    const Points pts = render(scene, in.camera_to_reference, 320, 163, 87 * kDeg);
    in.cloud = makeCloud<float>(pts, 320, 163, 0, 16);  // 32-byte points: x, y, z, intensity, 16 bytes of other fields
    in.view = in.cloud.view();
    for (const auto& p : pts)
      in.valid_points += std::isfinite(p.x()) ? 1 : 0;
    return in;
  }();
  return input;
}

// The synthetic room with the robot's 6-link arm, and the shapes posed for the self filter:
// boxes, a cylinder and a sphere, as a URDF's collision elements would give. Three poses of the
// whole arm: reaching into the camera's view (a fifth of the cloud's points lie on its padded
// shapes, the case), the same turned by `yaw` about the vertical (room, camera and arm
// together: the links and the camera's rows are then turned against the reference axes, as on
// a camera mounted at an angle), the camera alone turned by `camera_yaw` (the links turned
// against the camera's rows, as an arm's links mostly are: the blocks of a row cross them
// at an angle), and beside the base, moved by `arm_offset`, with the gripper and wrists at the
// edge of the view (one point in twenty on it, the arm's shapes still posed and their union box
// still in the view, as while the arm works beside the camera).
struct ArmInput
{
  Input in;
  laserscan_common::SelfFilter filter;
  std::vector<Eigen::Isometry3d> poses;  // reference <- link frame, as tf gives them per cloud
  std::size_t arm_points = 0;            // valid points inside the padded shapes
  double row_yaw = 0.0;                  // the camera's image rows, as the node gives it (imageRowYaw)
};

ArmInput makeArmInput(const Vector3d& arm_offset, double yaw = 0.0, double camera_yaw = 0.0)
{
  const Eigen::Isometry3d turn(Eigen::AngleAxisd(yaw, Vector3d::UnitZ()));
  ArmInput a;
  Scene scene;
  scene.wall_x = 3.5;
  scene.boxes.push_back({ Vector3d(1.2, -0.9, 0.70), Vector3d(2.0, 0.1, 0.75) });
  scene.boxes.push_back({ Vector3d(2.6, 0.4, 0.0), Vector3d(3.0, 1.4, 1.8) });
  scene.boxes.push_back({ Vector3d(1.0, 0.5, 0.0), Vector3d(1.45, 0.95, 0.45) });
  std::vector<Box> links = {
    { Vector3d(0.6, 0.2, 0.0), Vector3d(0.75, 0.35, 0.5) },      // shoulder
    { Vector3d(0.6, 0.2, 0.5), Vector3d(1.1, 0.3, 0.6) },        // upper arm
    { Vector3d(1.0, -0.1, 0.45), Vector3d(1.1, 0.3, 0.55) },     // forearm
    { Vector3d(0.95, -0.2, 0.35), Vector3d(1.1, -0.1, 0.55) },   // wrist 1
    { Vector3d(0.95, -0.2, 0.25), Vector3d(1.05, -0.1, 0.35) },  // wrist 2
    { Vector3d(0.9, -0.25, 0.1), Vector3d(1.05, -0.05, 0.25) },  // gripper
  };
  for (Box& link : links)
    link.lo += arm_offset, link.hi += arm_offset;
  std::vector<laserscan_common::RobotShape> shapes;
  std::vector<Eigen::Isometry3d>& poses = a.poses;
  for (std::size_t i = 0; i < links.size(); ++i)
  {
    scene.boxes.push_back(links[i]);
    laserscan_common::RobotShape s;
    s.name = s.frame = "link" + std::to_string(i + 1);
    const Vector3d half = 0.5 * (links[i].hi - links[i].lo);
    // A cylinder around the shoulder's box, a sphere around wrist 2's, boxes for the others.
    const double radius = std::hypot(half.x(), half.y());
    s.kind = i == 0   ? laserscan_common::ShapeKind::kCylinder
             : i == 4 ? laserscan_common::ShapeKind::kSphere
                      : laserscan_common::ShapeKind::kBox;
    s.half_extents = i == 0 ? Vector3d(radius, radius, half.z()) : i == 4 ? Vector3d::Constant(half.norm()) : half;
    s.padding = 0.02;
    shapes.push_back(s);
    poses.push_back(turn * Eigen::Translation3d(0.5 * (links[i].lo + links[i].hi)));
  }
  a.filter = laserscan_common::SelfFilter(shapes, "self_filter/shapes");
  const Eigen::Isometry3d camera_to_scene = cameraMount(0.6, 20 * kDeg, 0.0, camera_yaw);
  a.in.camera_to_reference = turn * camera_to_scene;
  a.row_yaw = laserscan_common::imageRowYaw(a.in.camera_to_reference.linear());
  a.filter.setFramePoses(poses, a.row_yaw);
  const Points pts = render(scene, camera_to_scene, 320, 163, 87 * kDeg);
  a.in.cloud = makeCloud<float>(pts, 320, 163, 0, 16);
  a.in.view = a.in.cloud.view();
  for (const auto& p : pts)
  {
    if (!std::isfinite(p.x()))
      continue;
    ++a.in.valid_points;
    const Vector3d r = a.in.camera_to_reference * p;
    a.arm_points += a.filter.contains(static_cast<float>(r.x()), static_cast<float>(r.y()), static_cast<float>(r.z()));
  }
  return a;
}

const ArmInput& syntheticWithArm()
{
  static const ArmInput input = makeArmInput(Vector3d::Zero());
  return input;
}

const ArmInput& syntheticWithArmTurned()
{
  static const ArmInput input = makeArmInput(Vector3d::Zero(), 30 * kDeg);
  return input;
}

const ArmInput& syntheticWithArmAcross()
{
  static const ArmInput input = makeArmInput(Vector3d::Zero(), 0.0, 20 * kDeg);
  return input;
}

const ArmInput& syntheticWithArmAside()
{
  static const ArmInput input = makeArmInput(Vector3d(-0.45, -0.7, 0.0));
  return input;
}

// five_people.pcd, 640 x 480, used as stored, at the camera pose fitted from its floor.
const Input* fivePeople()
{
  static const Input* input = []() -> Input* {
    const char* env = std::getenv("DFSC_DATA_DIR");
    const std::string dir = env ? env : DFSC_DATA_DIR;
    try
    {
      PcdCloud pcd = readPcd(dir + "/five_people.pcd");
      auto* in = new Input;
      in->cloud.layout = pcd.layout;
      in->cloud.data = std::move(pcd.data);
      in->view = in->cloud.view();
      in->camera_to_reference = fivePeopleMeasuredMount();
      for (std::size_t i = 0; i < in->view.size(); ++i)
      {
        float z;
        std::memcpy(&z, in->cloud.data.data() + i * in->view.point_step + in->view.z_offset, sizeof z);
        in->valid_points += std::isfinite(z) ? 1 : 0;
      }
      return in;
    }
    catch (const std::exception& e)
    {
      std::fprintf(stderr, "five_people.pcd not available (%s): skipping those benchmarks\n", e.what());
      return nullptr;
    }
  }();
  return input;
}

void runCore(benchmark::State& state, const Input* in)
{
  if (!in)
  {
    state.SkipWithError("input not available");
    return;
  }
  dfsc::Projector projector{ dfsc::Parameters() };
  std::vector<float> ranges;
  for (auto _ : state)
  {
    projector.project(in->view, in->camera_to_reference, ranges);
    benchmark::DoNotOptimize(ranges.data());
  }
  state.counters["points"] = static_cast<double>(in->view.size());
  state.counters["points/s"] =
    benchmark::Counter(static_cast<double>(in->view.size()), benchmark::Counter::kIsIterationInvariantRate);
}

// An arm cloud through the core, without and with the self filter. With it, the shapes are
// posed for every cloud, as the node does at each cloud's stamp (setFramePosesAt).
void runArmCloud(benchmark::State& state, const ArmInput& a, bool self_filter)
{
  dfsc::Projector projector{ dfsc::Parameters() };
  laserscan_common::SelfFilter filter = a.filter;
  std::vector<float> ranges;
  for (auto _ : state)
  {
    if (self_filter)
      filter.setFramePoses(a.poses, a.row_yaw);
    projector.project(a.in.view, a.in.camera_to_reference, ranges, nullptr, nullptr, self_filter ? &filter : nullptr);
    benchmark::DoNotOptimize(ranges.data());
  }
}

void runReference(benchmark::State& state, const Input* in)
{
  if (!in)
  {
    state.SkipWithError("input not available");
    return;
  }
  const dfsc::Parameters params;
  std::vector<float> ranges;
  for (auto _ : state)
  {
    dfsc::referenceProject(params, in->view, in->camera_to_reference, ranges);
    benchmark::DoNotOptimize(ranges.data());
  }
  state.counters["points"] = static_cast<double>(in->view.size());
  state.counters["points/s"] =
    benchmark::Counter(static_cast<double>(in->view.size()), benchmark::Counter::kIsIterationInvariantRate);
}

// Depth frames of the room (16UC1, as depth cameras and the simulator publish them): the image
// path's core against what the cloud path does per frame outside transport, depth_image_proc's
// conversion (the code point_cloud_xyz runs, including its cloud allocation) + the cloud core.
struct DepthInput
{
  DepthFrame frame;
  dfsc::DepthImageView view;
  sensor_msgs::PointCloud2Ptr cloud;  // point_cloud_xyz's output, for the cloud core alone
  Eigen::Isometry3d camera_to_reference;
};

const DepthInput& roomDepth(std::uint32_t width, std::uint32_t height)
{
  static std::map<std::uint32_t, DepthInput> inputs;
  auto it = inputs.find(width);
  if (it == inputs.end())
  {
    DepthInput in;
    in.frame = roomFrame(width, height, "16UC1", in.camera_to_reference);
    in.view = imageView(in.frame);
    in.cloud = pointCloudXyz(in.frame);
    it = inputs.emplace(width, std::move(in)).first;
  }
  return it->second;
}

void runImageCore(benchmark::State& state, std::uint32_t width, std::uint32_t height,
                  const dfsc::Parameters& params = dfsc::Parameters())
{
  const DepthInput& in = roomDepth(width, height);
  dfsc::Projector projector{ params };
  std::vector<float> ranges;
  for (auto _ : state)
  {
    projector.project(in.view, in.camera_to_reference, ranges);
    benchmark::DoNotOptimize(ranges.data());
  }
}

// The same with the simulated camera's range noise model (closest-cluster mean per beam).
void runImageCoreNoiseModel(benchmark::State& state, std::uint32_t width, std::uint32_t height)
{
  dfsc::Parameters params;
  params.noise.range_noise_std = 0.001;
  params.noise.range_noise_std_per_m2 = 0.001;
  runImageCore(state, width, height, params);
}

void runCloudPath(benchmark::State& state, std::uint32_t width, std::uint32_t height)
{
  const DepthInput& in = roomDepth(width, height);
  dfsc::Projector projector{ dfsc::Parameters() };
  std::vector<float> ranges;
  for (auto _ : state)
  {
    const sensor_msgs::PointCloud2Ptr cloud = pointCloudXyz(in.frame);
    projector.project(cloudView(*cloud), in.camera_to_reference, ranges);
    benchmark::DoNotOptimize(ranges.data());
  }
}

void runCloudCoreOnly(benchmark::State& state, std::uint32_t width, std::uint32_t height)
{
  const DepthInput& in = roomDepth(width, height);
  dfsc::Projector projector{ dfsc::Parameters() };
  std::vector<float> ranges;
  const dfsc::CloudView view = cloudView(*in.cloud);
  for (auto _ : state)
  {
    projector.project(view, in.camera_to_reference, ranges);
    benchmark::DoNotOptimize(ranges.data());
  }
}

void BM_Core_Synthetic320x163(benchmark::State& s)
{
  runCore(s, &synthetic());
}
void BM_Reference_Synthetic320x163(benchmark::State& s)
{
  runReference(s, &synthetic());
}
void BM_Core_FivePeople640x480(benchmark::State& s)
{
  runCore(s, fivePeople());
}
void BM_Reference_FivePeople640x480(benchmark::State& s)
{
  runReference(s, fivePeople());
}

void runArm(benchmark::State& s, bool self_filter)
{
  runArmCloud(s, syntheticWithArm(), self_filter);
}
void runArmTurned(benchmark::State& s, bool self_filter)
{
  runArmCloud(s, syntheticWithArmTurned(), self_filter);
}
void runArmAcross(benchmark::State& s, bool self_filter)
{
  runArmCloud(s, syntheticWithArmAcross(), self_filter);
}
void runArmAside(benchmark::State& s, bool self_filter)
{
  runArmCloud(s, syntheticWithArmAside(), self_filter);
}

BENCHMARK(BM_Core_Synthetic320x163)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK(BM_Reference_Synthetic320x163)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK(BM_Core_FivePeople640x480)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(runArm, WithoutSelfFilter, false)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(runArm, WithSelfFilter, true)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(runArmTurned, WithoutSelfFilter, false)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(runArmTurned, WithSelfFilter, true)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(runArmAcross, WithoutSelfFilter, false)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(runArmAcross, WithSelfFilter, true)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(runArmAside, WithoutSelfFilter, false)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(runArmAside, WithSelfFilter, true)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK(BM_Reference_FivePeople640x480)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(runImageCore, Depth640x480, 640u, 480u)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(runCloudPath, Depth640x480, 640u, 480u)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(runCloudCoreOnly, Depth640x480, 640u, 480u)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(runImageCore, Depth1280x720, 1280u, 720u)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(runImageCoreNoiseModel, Depth640x480, 640u, 480u)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(runImageCoreNoiseModel, Depth1280x720, 1280u, 720u)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(runCloudPath, Depth1280x720, 1280u, 720u)->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(runCloudCoreOnly, Depth1280x720, 1280u, 720u)->Unit(benchmark::kMillisecond)->MinTime(1.0);

// Console output as usual; the CPU time per iteration of every run is kept for the ratio lines
// (CPU time, because the machine may be shared; with --benchmark_repetitions the median is used).
class RatioReporter : public benchmark::ConsoleReporter
{
public:
  RatioReporter() : ConsoleReporter(OO_Tabular) {}  // plain text: the figures go into logs and READMEs

  void ReportRuns(const std::vector<Run>& runs) override
  {
    ConsoleReporter::ReportRuns(runs);
    for (const auto& r : runs)
      if (!r.error_occurred && r.iterations > 0 && r.run_type == Run::RT_Iteration)
        ms_[r.run_name.function_name].push_back(r.cpu_accumulated_time * 1e3 / static_cast<double>(r.iterations));
  }
  void printRatios()
  {
    std::printf("\n%-20s %10s %15s %8s   (CPU time per cloud, median of repetitions)\n", "cloud", "core [ms]",
                "reference [ms]", "ratio");
    for (const char* cloud : { "Synthetic320x163", "FivePeople640x480" })
    {
      const double core = median(std::string("BM_Core_") + cloud);
      const double ref = median(std::string("BM_Reference_") + cloud);
      if (core > 0 && ref > 0)
        std::printf("%-20s %10.4f %15.4f %7.1fx\n", cloud, core, ref, ref / core);
    }
    std::printf("\n%-24s %10s %18s %8s\n", "cloud with 6-link arm", "core [ms]", "with self filter", "ratio");
    for (const auto& [arm, cloud] : { std::pair<const char*, const char*>{ "runArm", "Synthetic320x163Arm" },
                                      { "runArmTurned", "Synthetic320x163ArmTurned" },
                                      { "runArmAcross", "Synthetic320x163ArmAcross" },
                                      { "runArmAside", "Synthetic320x163ArmAside" } })
    {
      const double without = median(std::string(arm) + "/WithoutSelfFilter");
      const double with = median(std::string(arm) + "/WithSelfFilter");
      if (without > 0 && with > 0)
        std::printf("%-24s %10.4f %18.4f %7.2fx\n", cloud, without, with, with / without);
    }
    std::printf("\n%-20s %15s %26s %8s %18s\n", "depth frame (16UC1)", "image core [ms]", "point_cloud_xyz+core [ms]",
                "ratio", "cloud core [ms]");
    for (const char* frame : { "Depth640x480", "Depth1280x720" })
    {
      const double image = median(std::string("runImageCore/") + frame);
      const double path = median(std::string("runCloudPath/") + frame);
      const double core = median(std::string("runCloudCoreOnly/") + frame);
      if (image > 0 && path > 0)
        std::printf("%-20s %15.4f %26.4f %7.1fx %18.4f\n", frame, image, path, path / image, core);
    }
    std::printf("\n%-20s %15s %26s %8s\n", "depth frame (16UC1)", "image core [ms]", "with range noise model [ms]",
                "ratio");
    for (const char* frame : { "Depth640x480", "Depth1280x720" })
    {
      const double image = median(std::string("runImageCore/") + frame);
      const double noise = median(std::string("runImageCoreNoiseModel/") + frame);
      if (image > 0 && noise > 0)
        std::printf("%-20s %15.4f %26.4f %7.2fx\n", frame, image, noise, noise / image);
    }
  }

private:
  double median(const std::string& name)
  {
    auto it = ms_.find(name);
    if (it == ms_.end() || it->second.empty())
      return 0.0;
    std::vector<double>& v = it->second;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  }
  std::map<std::string, std::vector<double>> ms_;
};
}  // namespace

int main(int argc, char** argv)
{
  benchmark::Initialize(&argc, argv);
  synthetic();
  if (const Input* fp = fivePeople())
    std::printf("five_people.pcd: %zu points, %zu valid\n", fp->view.size(), fp->valid_points);
  std::printf("synthetic: %zu points, %zu valid\n", synthetic().view.size(), synthetic().valid_points);
  for (const auto& [arm, name] : { std::pair<const ArmInput*, const char*>{ &syntheticWithArm(), "" },
                                   { &syntheticWithArmTurned(), " turned" },
                                   { &syntheticWithArmAcross(), " across the camera" },
                                   { &syntheticWithArmAside(), " aside" } })
    std::printf("synthetic with arm%s: %zu points, %zu valid, %zu on the arm's padded shapes\n", name,
                arm->in.view.size(), arm->in.valid_points, arm->arm_points);
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.printRatios();
  benchmark::Shutdown();
  return 0;
}
