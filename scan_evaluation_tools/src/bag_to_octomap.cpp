// bag_to_octomap: the 3D method on a bag. The depth data (depth images + camera_info, or
// clouds) and the lidar scans of a ROS 1 bag, placed by a pose source (an Odometry topic such
// as the simulator's ground truth, or a path file) and the mounts from tf, go into an OctoMap
// OcTree as octomap_server builds it; writes the tree, its projected 2D map and the figures
// (CPU per second of data, peak memory, nodes, points). See the package README.
#include "bag_reading.hpp"
#include "laserscan_common/message_checks.hpp"
#include "laserscan_common/parameter_error.hpp"
#include "scan_evaluation_tools/occupancy_map_3d.hpp"
#include "scan_evaluation_tools/odometry_track.hpp"

#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2/buffer_core.h>
#include <tf2_msgs/TFMessage.h>

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
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
  std::string output_dir;
  std::vector<std::string> depth_topics;
  std::vector<std::string> cloud_topics;
  std::vector<std::string> scan_topics;
  std::string pose_topic;
  std::string poses_file;
  std::string base_frame = "base_link";
  std::string voxels_file;  // the leaves as text (tests, plots)
  double band_min = 0.05;   // m above the floor
  double band_max = 1.0;
  double min_interval = 0.0;  // s between two messages of one topic inserted (0: all)
  double duration = 0.0;      // s of the bag read from its start (0: all)
  scan_evaluation_tools::OctoMapParameters octomap;
};

const char* const kUsage =
  "usage: bag_to_octomap BAG OUTPUT_DIR (--pose-topic TOPIC | --poses FILE) [--depth-topic TOPIC]...\n"
  "                      [--cloud-topic TOPIC]... [--scan-topic TOPIC]... [--base-frame FRAME]\n"
  "                      [--resolution M] [--max-range M] [--band-min M] [--band-max M]\n"
  "                      [--min-interval S] [--duration S] [--voxels FILE]\n"
  "Inserts every depth image (with the camera_info beside it), cloud and scan into an OctoMap OcTree\n"
  "from its sensor's origin (robot pose from the pose source, mount from /tf_static and /tf) and writes\n"
  "OUTPUT_DIR/octomap.bt, projected_map.pgm + .yaml (the height band) and figures.json.\n"
  "Exit status: 0 done, 1 nothing usable in the bag or an output that cannot be written, 2 usage error.\n";

double number(const std::string& option, const std::string& v)
{
  std::size_t used = 0;
  double x = 0.0;
  try
  {
    x = std::stod(v, &used);
  }
  catch (const std::exception&)
  {
    used = 0;
  }
  if (used != v.size() || !std::isfinite(x))
  {
    throw std::invalid_argument(option + " must be a number, got '" + v + "'");
  }
  return x;
}

Options parseOptions(int argc, char** argv)
{
  Options o;
  const auto positional =
    scan_evaluation_tools::parseArguments(argc, argv, kUsage, [&](const std::string& a, const auto& value) {
      if (a == "--depth-topic")
        o.depth_topics.push_back(value());
      else if (a == "--cloud-topic")
        o.cloud_topics.push_back(value());
      else if (a == "--scan-topic")
        o.scan_topics.push_back(value());
      else if (a == "--pose-topic")
        o.pose_topic = value();
      else if (a == "--poses")
        o.poses_file = value();
      else if (a == "--base-frame")
        o.base_frame = value();
      else if (a == "--resolution")
        o.octomap.resolution = number(a, value());
      else if (a == "--max-range")
        o.octomap.max_range = number(a, value());
      else if (a == "--band-min")
        o.band_min = number(a, value());
      else if (a == "--band-max")
        o.band_max = number(a, value());
      else if (a == "--min-interval")
        o.min_interval = number(a, value());
      else if (a == "--duration")
        o.duration = number(a, value());
      else if (a == "--voxels")
        o.voxels_file = value();
      else
      {
        return false;
      }
      return true;
    });
  if (positional.size() != 2)
  {
    throw std::invalid_argument("expected BAG and OUTPUT_DIR");
  }
  if (o.pose_topic.empty() == o.poses_file.empty())
  {
    throw std::invalid_argument("give exactly one pose source: --pose-topic or --poses");
  }
  if (o.depth_topics.empty() && o.cloud_topics.empty() && o.scan_topics.empty())
  {
    throw std::invalid_argument("give at least one --depth-topic, --cloud-topic or --scan-topic");
  }
  if (!(o.min_interval >= 0.0) || !(o.duration >= 0.0))
  {
    throw std::invalid_argument("--min-interval and --duration must be >= 0 s");
  }
  if (!(o.band_min < o.band_max))
  {
    throw std::invalid_argument("--band-min must be below --band-max");
  }
  try
  {
    o.octomap.validate();
  }
  catch (const laserscan_common::ParameterError& e)
  {
    throw std::invalid_argument("--" + e.parameter() + ": " + e.reason());
  }
  o.bag = positional[0];
  o.output_dir = positional[1];
  return o;
}

double processCpuSeconds()
{
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/// The camera_info beside a depth image topic (image_transport's convention):
/// /cam/depth/image_rect -> /cam/depth/camera_info.
std::string cameraInfoTopic(const std::string& image_topic)
{
  const auto slash = image_topic.rfind('/');
  return (slash == std::string::npos ? std::string() : image_topic.substr(0, slash + 1)) + "camera_info";
}

/// Path file: one pose per line, `stamp x y yaw` (s, m, m, rad, in the map frame); '#' starts a comment.
void readPoses(const std::string& path, OdometryTrack& track)
{
  std::ifstream in(path);
  if (!in)
  {
    throw std::runtime_error("cannot read " + path);
  }
  std::string line;
  std::size_t number = 0;
  while (std::getline(in, line))
  {
    ++number;
    line = line.substr(0, line.find('#'));
    std::istringstream fields(line);
    double stamp, x, y, yaw;
    if (!(fields >> stamp))
    {
      continue;  // blank or comment
    }
    if (!(fields >> x >> y >> yaw))
    {
      throw std::runtime_error(path + ":" + std::to_string(number) + ": expected 'stamp x y yaw'");
    }
    track.add(stamp, { x, y, yaw });
  }
}

/// x, y, z of a PointCloud2 (FLOAT32 fields); throws std::invalid_argument naming what is wrong.
void cloudPoints(const sensor_msgs::PointCloud2& cloud, octomap::Pointcloud& points)
{
  if (static_cast<std::size_t>(cloud.row_step) * cloud.height != cloud.data.size() ||
      static_cast<std::size_t>(cloud.point_step) * cloud.width > cloud.row_step)
  {
    throw std::invalid_argument("cloud whose width, height, point_step and row_step do not match its data");
  }
  for (const char* name : { "x", "y", "z" })
  {
    const auto f =
      std::find_if(cloud.fields.begin(), cloud.fields.end(), [&](const auto& f) { return f.name == name; });
    if (f == cloud.fields.end() || f->datatype != sensor_msgs::PointField::FLOAT32)
    {
      throw std::invalid_argument(std::string("cloud without a FLOAT32 field '") + name + "'");
    }
  }
  sensor_msgs::PointCloud2ConstIterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
  for (; x != x.end(); ++x, ++y, ++z)
  {
    if (std::isfinite(*x) && std::isfinite(*y) && std::isfinite(*z))
    {
      points.push_back(*x, *y, *z);
    }
  }
}

void writeProjectedMap(const scan_evaluation_tools::ProjectedMap& map, const std::string& base)
{
  std::ofstream pgm(base + ".pgm", std::ios::binary);
  pgm << "P5\n" << map.width << ' ' << map.height << "\n255\n";
  std::vector<char> row(map.width);
  for (std::uint32_t r = map.height; r-- > 0;)  // PGM rows go top-down, the map's y goes up
  {
    for (std::uint32_t c = 0; c < map.width; ++c)
    {
      const auto v = map.cells[static_cast<std::size_t>(r) * map.width + c];
      row[c] = static_cast<char>(v == 100 ? 0 : (v == 0 ? 254 : 205));
    }
    pgm.write(row.data(), static_cast<std::streamsize>(row.size()));
  }
  std::ofstream yaml(base + ".yaml");
  const auto slash = base.rfind('/');
  yaml.precision(10);
  yaml << "image: " << base.substr(slash == std::string::npos ? 0 : slash + 1) << ".pgm\nresolution: " << map.resolution
       << "\norigin: [" << map.origin_x << ", " << map.origin_y
       << ", 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";
  if (!pgm || !yaml)
  {
    throw std::runtime_error("cannot write " + base + ".pgm / .yaml");
  }
}

std::string jsonNumber(double v)
{
  if (!std::isfinite(v))
  {
    return "null";
  }
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

std::string jsonString(const std::string& text)
{
  std::string out = "\"";
  for (const char c : text)
  {
    if (c == '"' || c == '\\')
      out += '\\';
    out += c;
  }
  return out + "\"";
}

int run(const Options& o)
{
  const double cpu_start = processCpuSeconds();
  rosbag::Bag bag(o.bag, rosbag::bagmode::Read);
  rosbag::View everything(bag);
  const double span = (everything.getEndTime() - everything.getBeginTime()).toSec();
  tf2::BufferCore tf(ros::Duration(std::max(10.0, span + 10.0)));
  scan_evaluation_tools::BagTransforms transforms(tf);
  std::map<std::string, std::size_t> left_out;

  // First pass, small messages only: tf, the poses and the cameras' intrinsics by stamp, so
  // that the second pass converts each depth message as it comes (one in memory at a time).
  OdometryTrack track;
  std::vector<std::pair<double, Pose2D>> poses;
  if (!o.poses_file.empty())
  {
    readPoses(o.poses_file, track);
  }
  std::map<std::string, std::string> info_topic_of;  // depth topic -> its camera_info topic
  std::vector<std::string> first_topics = { "/tf", "/tf_static" };
  for (const auto& t : o.depth_topics)
  {
    info_topic_of[t] = cameraInfoTopic(t);
    first_topics.push_back(info_topic_of[t]);
  }
  if (!o.pose_topic.empty())
  {
    first_topics.push_back(o.pose_topic);
  }
  std::map<std::string, std::map<ros::Time, scan_evaluation_tools::PinholeCamera>> intrinsics;
  rosbag::View small(bag, rosbag::TopicQuery(first_topics));
  for (const rosbag::MessageInstance& m : small)
  {
    if (m.getTopic() == o.pose_topic)
    {
      if (auto od = m.instantiate<nav_msgs::Odometry>())
      {
        const auto& p = od->pose.pose;
        poses.push_back({ od->header.stamp.toSec(), { p.position.x, p.position.y, yawOf(p.orientation) } });
      }
    }
    else if (auto info = m.instantiate<sensor_msgs::CameraInfo>())
    {
      intrinsics[m.getTopic()][info->header.stamp] = { info->P[0], info->P[5], info->P[2], info->P[6] };
    }
    else
    {
      transforms.add(m);
    }
  }
  if (transforms.malformed() > 0)
  {
    left_out["malformed transform (the nodes' /tf rules), the last: " + transforms.lastFault()] =
      transforms.malformed();
  }
  std::sort(poses.begin(), poses.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [stamp, pose] : poses)
  {
    track.add(stamp, pose);
  }
  if (track.size() < 2)
  {
    std::cerr << "bag_to_octomap: " << track.size() << " poses from "
              << (o.pose_topic.empty() ? o.poses_file : o.pose_topic) << ": need at least 2\n";
    return 1;
  }

  // Second pass: every depth image, cloud and scan into the tree, in the bag's order.
  scan_evaluation_tools::OccupancyMap3D map(o.octomap);
  std::vector<std::string> data_topics = o.depth_topics;
  data_topics.insert(data_topics.end(), o.cloud_topics.begin(), o.cloud_topics.end());
  data_topics.insert(data_topics.end(), o.scan_topics.begin(), o.scan_topics.end());
  const std::set<std::string> scan_topics(o.scan_topics.begin(), o.scan_topics.end());
  octomap::Pointcloud points;
  double insert_cpu = 0.0;  // ray casting and leaf updates
  double update_cpu = 0.0;  // inner nodes and pruning after each cloud
  std::size_t depth_inserted = 0, scans_inserted = 0;
  const ros::Time begin = everything.getBeginTime();
  const ros::Time end =
    o.duration > 0.0 ? std::min(everything.getEndTime(), begin + ros::Duration(o.duration)) : everything.getEndTime();
  std::map<std::string, double> last_inserted;  // bag time per topic
  std::size_t thinned = 0;
  rosbag::View data(bag, rosbag::TopicQuery(data_topics), begin, end);
  for (const rosbag::MessageInstance& m : data)
  {
    points.clear();
    if (o.min_interval > 0.0)
    {
      const double t = m.getTime().toSec();  // bag time: thinning needs no deserialisation
      const auto last = last_inserted.find(m.getTopic());
      if (last != last_inserted.end() && t - last->second < o.min_interval)
      {
        ++thinned;  // on purpose, not an error
        continue;
      }
      last_inserted[m.getTopic()] = t;
    }
    std_msgs::Header header;
    try
    {
      if (auto image = m.instantiate<sensor_msgs::Image>())
      {
        header = image->header;
        const auto& by_stamp = intrinsics[info_topic_of[m.getTopic()]];
        const auto info = by_stamp.find(header.stamp);
        if (info == by_stamp.end())
        {
          ++left_out["depth image without a camera_info of its stamp on " + info_topic_of[m.getTopic()]];
          continue;
        }
        scan_evaluation_tools::depthImagePoints(image->data.data(), image->data.size(), image->width, image->height,
                                                image->step, image->encoding, image->is_bigendian != 0, info->second,
                                                points);
      }
      else if (auto cloud = m.instantiate<sensor_msgs::PointCloud2>())
      {
        header = cloud->header;
        cloudPoints(*cloud, points);
      }
      else if (auto scan = m.instantiate<sensor_msgs::LaserScan>())
      {
        header = scan->header;
        scan_evaluation_tools::scanPoints(scan->ranges, scan->angle_min, scan->angle_increment, scan->range_min,
                                          scan->range_max, points);
      }
      else
      {
        ++left_out["message of type " + m.getDataType() + " on " + m.getTopic()];
        continue;
      }
    }
    catch (const std::invalid_argument& e)
    {
      ++left_out[std::string(e.what()) + " on " + m.getTopic()];
      continue;
    }
    const double stamp = header.stamp.toSec();
    const auto pose = track.at(stamp);
    if (!pose)
    {
      ++left_out["outside the poses' time span"];
      continue;
    }
    Eigen::Isometry3d mount;
    try
    {
      const auto t = tf.lookupTransform(o.base_frame, laserscan_common::tf2FrameId(header.frame_id), header.stamp);
      const auto& q = t.transform.rotation;
      const auto& p = t.transform.translation;
      mount = Eigen::Translation3d(p.x, p.y, p.z) * Eigen::Quaterniond(q.w, q.x, q.y, q.z);
    }
    catch (const std::exception&)  // tf2's own, and ros::Time's range errors near 2^32 s
    {
      ++left_out["no transform '" + header.frame_id + "' -> '" + o.base_frame + "'"];
      continue;
    }
    const Eigen::Isometry3d robot =
      Eigen::Translation3d(pose->x, pose->y, 0.0) * Eigen::AngleAxisd(pose->yaw, Eigen::Vector3d::UnitZ());
    const Eigen::Isometry3d sensor = robot * mount;
    scan_evaluation_tools::transformPoints(sensor, points);
    const Eigen::Vector3d origin = sensor.translation();
    const double before = processCpuSeconds();
    map.insert(points, octomap::point3d(static_cast<float>(origin.x()), static_cast<float>(origin.y()),
                                        static_cast<float>(origin.z())));
    const double inserted = processCpuSeconds();
    map.update();
    insert_cpu += inserted - before;
    update_cpu += processCpuSeconds() - inserted;
    (scan_topics.count(m.getTopic()) ? scans_inserted : depth_inserted) += 1;
  }
  if (map.cloudsInserted() == 0)
  {
    std::cerr << "bag_to_octomap: " << o.bag << ": nothing inserted\n";
    for (const auto& [reason, count] : left_out)
    {
      std::cerr << "bag_to_octomap: " << count << " left out: " << reason << "\n";
    }
    return 1;
  }

  const auto projected = map.project(o.band_min, o.band_max);
  std::filesystem::create_directories(o.output_dir);
  const std::string tree_file = o.output_dir + "/octomap.bt";
  if (!map.tree().writeBinaryConst(tree_file))
  {
    std::cerr << "bag_to_octomap: cannot write " << tree_file << "\n";
    return 1;
  }
  writeProjectedMap(projected, o.output_dir + "/projected_map");
  if (!o.voxels_file.empty())
  {
    std::ofstream voxels(o.voxels_file);
    voxels << "# x y z size occupied: one leaf of the tree per line (m, centre and edge; 1 occupied, 0 free)\n";
    const auto& tree = map.tree();
    for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it)
    {
      voxels << it.getX() << ' ' << it.getY() << ' ' << it.getZ() << ' ' << it.getSize() << ' '
             << (tree.isNodeOccupied(*it) ? 1 : 0) << '\n';
    }
    if (!voxels)
    {
      std::cerr << "bag_to_octomap: cannot write " << o.voxels_file << "\n";
      return 1;
    }
  }
  const double cpu = processCpuSeconds() - cpu_start;
  const double octomap_cpu = insert_cpu + update_cpu;
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const double data_s = (end - begin).toSec();  // the seconds of data read, what a robot records in them
  std::ofstream figures(o.output_dir + "/figures.json");
  figures << "{\n  \"bag\": " << jsonString(o.bag) << ",\n  \"resolution_m\": " << jsonNumber(o.octomap.resolution)
          << ",\n  \"max_range_m\": " << jsonNumber(o.octomap.max_range) << ",\n  \"band_m\": ["
          << jsonNumber(o.band_min) << ", " << jsonNumber(o.band_max) << "],\n  \"data_s\": " << jsonNumber(data_s)
          << ",\n  \"cpu_s\": " << jsonNumber(cpu) << ",\n  \"cpu_s_per_s\": " << jsonNumber(cpu / data_s)
          << ",\n  \"octomap_cpu_s\": " << jsonNumber(octomap_cpu)
          << ",\n  \"octomap_cpu_s_per_s\": " << jsonNumber(octomap_cpu / data_s)
          << ",\n  \"insert_cpu_s\": " << jsonNumber(insert_cpu) << ",\n  \"update_cpu_s\": " << jsonNumber(update_cpu)
          << ",\n  \"peak_rss_mb\": " << jsonNumber(static_cast<double>(usage.ru_maxrss) / 1024.0)
          << ",\n  \"tree_nodes\": " << map.tree().size() << ",\n  \"tree_leaves\": " << map.tree().getNumLeafNodes()
          << ",\n  \"tree_memory_mb\": " << jsonNumber(static_cast<double>(map.tree().memoryUsage()) / 1e6)
          << ",\n  \"points_inserted\": " << map.pointsInserted()
          << ",\n  \"depth_messages_inserted\": " << depth_inserted << ",\n  \"messages_thinned\": " << thinned
          << ",\n  \"min_interval_s\": " << jsonNumber(o.min_interval) << ",\n  \"scans_inserted\": " << scans_inserted
          << ",\n  \"projected_map\": {\"width\": " << projected.width << ", \"height\": " << projected.height
          << ", \"occupied_cells\": " << projected.occupied() << "},\n  \"left_out\": {";
  const char* separator = "";
  for (const auto& [reason, count] : left_out)
  {
    figures << separator << "\n    " << jsonString(reason) << ": " << count;
    separator = ",";
  }
  figures << (left_out.empty() ? "}\n}\n" : "\n  }\n}\n");
  if (!figures)
  {
    std::cerr << "bag_to_octomap: cannot write " << o.output_dir << "/figures.json\n";
    return 1;
  }
  std::cout << "bag_to_octomap: " << map.pointsInserted() << " points of " << depth_inserted << " depth messages and "
            << scans_inserted << " scans over " << data_s << " s: " << map.tree().size() << " nodes, " << cpu
            << " s CPU (" << octomap_cpu << " s in OctoMap)\n";
  for (const auto& [reason, count] : left_out)
  {
    std::cerr << "bag_to_octomap: " << count << " left out: " << reason << "\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv)
{
  return scan_evaluation_tools::runTool<Options>("bag_to_octomap", kUsage, argc, argv, parseOptions, run);
}
