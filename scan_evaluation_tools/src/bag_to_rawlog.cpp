// bag_to_rawlog: the LaserScans of one topic of a ROS 1 bag, with the wheel odometry and the
// sensor mounts from tf, as an MRPT rawlog of action/observation pairs (what rbpf-slam and
// pf-localization read). See the package README for the options and the conventions.
#include "bag_reading.hpp"
#include "laserscan_common/message_checks.hpp"
#include "scan_evaluation_tools/odometry_track.hpp"

#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/poses/CPose2D.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/ros1bridge/laser_scan.h>
#include <mrpt/serialization/CArchive.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace
{
using scan_evaluation_tools::OdometryTrack;
using scan_evaluation_tools::Pose2D;
using scan_evaluation_tools::yawOf;

struct Options
{
  std::string bag;
  std::string output;
  std::string scan_topic;
  std::string odom_topic = "/odom";
  std::string base_frame = "base_link";
  std::string index_file;
  double min_interval = 0.0;  // s between two scans written
};

const char* const kUsage =
  "usage: bag_to_rawlog BAG OUTPUT.rawlog --scan-topic TOPIC [--odom-topic TOPIC] [--base-frame FRAME]\n"
  "                     [--min-interval S] [--index FILE]\n"
  "Writes one action (odometry increment since the previous scan, interpolated at the scan's stamp)\n"
  "and one observation (the scan, its sensor pose in FRAME from /tf_static and /tf) per scan.\n"
  "Exit status: 0 done, 1 nothing usable in the bag, 2 usage error.\n";

Options parseOptions(int argc, char** argv)
{
  Options o;
  const auto positional =
    scan_evaluation_tools::parseArguments(argc, argv, kUsage, [&](const std::string& a, const auto& value) {
      if (a == "--scan-topic")
      {
        o.scan_topic = value();
      }
      else if (a == "--odom-topic")
      {
        o.odom_topic = value();
      }
      else if (a == "--base-frame")
      {
        o.base_frame = value();
      }
      else if (a == "--index")
      {
        o.index_file = value();
      }
      else if (a == "--min-interval")
      {
        const std::string v = value();
        std::size_t used = 0;
        o.min_interval = std::stod(v, &used);
        if (used != v.size() || !(o.min_interval >= 0.0))
        {
          throw std::invalid_argument("--min-interval must be a number of seconds >= 0, got '" + v + "'");
        }
      }
      else
      {
        return false;
      }
      return true;
    });
  if (positional.size() != 2)
  {
    throw std::invalid_argument("expected BAG and OUTPUT.rawlog");
  }
  if (o.scan_topic.empty())
  {
    throw std::invalid_argument("--scan-topic is required");
  }
  o.bag = positional[0];
  o.output = positional[1];
  return o;
}

/// MRPT's scan convention: N beams spread evenly over `aperture`, symmetric around the
/// sensor's x axis; ROS's: beam i at angle_min + i * angle_increment. The observation's sensor
/// pose is therefore the mount turned by the scan's middle angle.
mrpt::obs::CObservation2DRangeScan toObservation(const sensor_msgs::LaserScan& scan, const mrpt::poses::CPose3D& mount)
{
  const std::size_t n = scan.ranges.size();
  const double aperture = scan.angle_increment * static_cast<double>(n - 1);
  const double middle = scan.angle_min + 0.5 * aperture;
  const mrpt::poses::CPose3D sensor = mount + mrpt::poses::CPose3D(0, 0, 0, middle, 0, 0);
  mrpt::obs::CObservation2DRangeScan obs;
  mrpt::ros1bridge::fromROS(scan, sensor, obs);
  obs.aperture = static_cast<float>(aperture);
  obs.rightToLeft = true;
  obs.maxRange = scan.range_max;
  for (std::size_t i = 0; i < n; ++i)
  {
    const float r = scan.ranges[i];
    const bool measured = std::isfinite(r) && r >= scan.range_min && r <= scan.range_max;
    // REP 117: +Inf (or farther than range_max) is "no return": MRPT's invalid range at maxRange,
    // which its grids may take as free space. NaN, -Inf and too-close values say nothing: 0.
    const bool no_return = !measured && !std::isnan(r) && r > scan.range_max;
    obs.setScanRange(i, measured ? r : (no_return ? scan.range_max : 0.0f));
    obs.setScanRangeValidity(i, measured);
  }
  return obs;
}

/// Odometry increments with a Gaussian model loose enough for the simulated wheel odometry
/// (a few percent of scale error and drift); the SLAM's scan matching narrows it.
mrpt::obs::CActionRobotMovement2D::TMotionModelOptions motionModel()
{
  mrpt::obs::CActionRobotMovement2D::TMotionModelOptions m;
  m.modelSelection = mrpt::obs::CActionRobotMovement2D::mmGaussian;
  m.gaussianModel.a1 = 0.05;                       // m of std per m driven
  m.gaussianModel.a2 = mrpt::RAD2DEG(0.001);       // m per degree turned
  m.gaussianModel.a3 = mrpt::DEG2RAD(0.5);         // degree per m driven
  m.gaussianModel.a4 = 0.05;                       // degree per degree turned
  m.gaussianModel.minStdXY = 0.01;                 // m
  m.gaussianModel.minStdPHI = mrpt::DEG2RAD(0.5);  // rad
  return m;
}

int run(const Options& o)
{
  rosbag::Bag bag(o.bag, rosbag::bagmode::Read);
  rosbag::View everything(bag);
  const double span = (everything.getEndTime() - everything.getBeginTime()).toSec();
  tf2::BufferCore tf(ros::Duration(std::max(10.0, span + 10.0)));

  // One pass: mounts, odometry, scans (sorted by stamp afterwards: bag order is arrival order).
  std::vector<std::pair<double, Pose2D>> odometry;
  std::vector<sensor_msgs::LaserScan::ConstPtr> scans;
  // The nodes' rules for /tf, with the time the bag recorded a message as the clock.
  scan_evaluation_tools::BagTransforms transforms(tf);
  rosbag::View view(bag, rosbag::TopicQuery({ "/tf_static", "/tf", o.odom_topic, o.scan_topic }));
  for (const rosbag::MessageInstance& m : view)
  {
    if (m.getTopic() == o.scan_topic)
    {
      if (auto s = m.instantiate<sensor_msgs::LaserScan>())
      {
        scans.push_back(s);
      }
    }
    else if (m.getTopic() == o.odom_topic)
    {
      if (auto od = m.instantiate<nav_msgs::Odometry>())
      {
        const auto& p = od->pose.pose;
        odometry.push_back({ od->header.stamp.toSec(), { p.position.x, p.position.y, yawOf(p.orientation) } });
      }
    }
    else
    {
      transforms.add(m);
    }
  }
  std::sort(odometry.begin(), odometry.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  OdometryTrack track;
  for (const auto& [stamp, pose] : odometry)
  {
    track.add(stamp, pose);  // a repeated stamp is dropped
  }
  std::stable_sort(scans.begin(), scans.end(),
                   [](const auto& a, const auto& b) { return a->header.stamp < b->header.stamp; });
  if (scans.empty() || track.size() < 2)
  {
    std::cerr << "bag_to_rawlog: " << o.bag << ": " << scans.size() << " LaserScans on " << o.scan_topic << " and "
              << track.size() << " odometry poses on " << o.odom_topic << ": need at least 1 and 2\n";
    return 1;
  }

  mrpt::io::CFileGZOutputStream file;
  if (!file.open(o.output, 0))  // level 0: plain file, fast to write and read
  {
    std::cerr << "bag_to_rawlog: cannot write " << o.output << "\n";
    return 1;
  }
  auto archive = mrpt::serialization::archiveFrom(file);
  std::ofstream index;
  if (!o.index_file.empty())
  {
    index.open(o.index_file);
    if (!index)
    {
      std::cerr << "bag_to_rawlog: cannot write " << o.index_file << "\n";
      return 1;
    }
    index << "# entry stamp odom_x odom_y odom_yaw (odometry interpolated at the scan's stamp)\n";
    index.precision(9);
  }
  const auto model = motionModel();
  std::map<std::string, std::size_t> skipped;
  std::size_t written = 0;
  Pose2D previous;
  double last_stamp = -1e300;
  for (const auto& scan : scans)
  {
    const double stamp = scan->header.stamp.toSec();
    const std::size_t n = scan->ranges.size();
    if (n < 2 || !(scan->angle_increment > 0.0f) || !std::isfinite(scan->angle_min) ||
        !(scan->range_max > scan->range_min))
    {
      ++skipped["malformed (fewer than 2 beams, increment <= 0 or range_max <= range_min)"];
      continue;
    }
    if (stamp - last_stamp < o.min_interval)
    {
      continue;  // thinned on purpose, not an error
    }
    const auto pose = track.at(stamp);
    if (!pose)
    {
      ++skipped["outside the odometry's time span"];
      continue;
    }
    mrpt::poses::CPose3D mount;
    try
    {
      const auto t =
        tf.lookupTransform(o.base_frame, laserscan_common::tf2FrameId(scan->header.frame_id), scan->header.stamp);
      const auto& q = t.transform.rotation;
      const auto& p = t.transform.translation;
      mount = mrpt::poses::CPose3D(mrpt::math::CQuaternionDouble(q.w, q.x, q.y, q.z), p.x, p.y, p.z);
    }
    catch (const std::exception&)  // tf2's own, and ros::Time's range errors near 2^32 s
    {
      ++skipped["no transform '" + scan->header.frame_id + "' -> '" + o.base_frame + "'"];
      continue;
    }
    const Pose2D increment = written == 0 ? Pose2D{} : scan_evaluation_tools::between(previous, *pose);
    mrpt::obs::CActionRobotMovement2D movement;
    movement.computeFromOdometry(mrpt::poses::CPose2D(increment.x, increment.y, increment.yaw), model);
    movement.timestamp = mrpt::Clock::fromDouble(stamp);
    mrpt::obs::CActionCollection actions;
    actions.insert(movement);
    mrpt::obs::CSensoryFrame frame;
    frame.insert(mrpt::obs::CObservation2DRangeScan::Create(toObservation(*scan, mount)));
    archive << actions << frame;
    if (index.is_open())
    {
      index << written << ' ' << stamp << ' ' << pose->x << ' ' << pose->y << ' ' << pose->yaw << '\n';
    }
    previous = *pose;
    last_stamp = stamp;
    ++written;
  }
  std::cout << "bag_to_rawlog: wrote " << written << " action/observation pairs of " << scans.size() << " scans on "
            << o.scan_topic << " to " << o.output << "\n";
  for (const auto& [reason, count] : skipped)
  {
    std::cerr << "bag_to_rawlog: " << count << " scan(s) left out: " << reason << "\n";
  }
  if (transforms.malformed() > 0)
  {
    std::cerr << "bag_to_rawlog: warning: " << transforms.malformed()
              << " malformed transform(s) ignored (the nodes' /tf rules), the last: " << transforms.lastFault() << "\n";
  }
  return written > 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv)
{
  return scan_evaluation_tools::runTool<Options>("bag_to_rawlog", kUsage, argc, argv, parseOptions, run);
}
