// Reference nodes for the node-level comparison of bench/measure_node_cpu.py (issue 9, part 3).
//
// mode "per_point": a stand-in for pointcloud_to_laserscan, which Debian 12 does not package (and
// the project builds nothing from source). Written here from that node's documented behaviour,
// not from its code: clouds wait in a tf2_ros::MessageFilter for the transform to the target
// frame; each cloud is first transformed whole into a new PointCloud2 (tf2_sensor_msgs, the
// library call that node makes), then every point is read through PointCloud2ConstIterator,
// NaNs skipped, kept if its z lies in [min_height, max_height], its planar range (std::hypot) in
// [range_min, range_max] and its angle (std::atan2) in [angle_min, angle_max]; a beam keeps its
// closest point; the scan is published. Its figures are an estimate of that node's cost, not a
// measurement of it.
//
// mode "transport": the baseline both are measured above: receives each cloud and publishes a
// scan of the same size with no return in every beam.
//
// Private parameters: mode, and the converter's reference_frame, floor_height, min_height,
// max_height, angle_min, angle_max, angle_increment, range_min, range_max, transform_tolerance,
// queue_size (so both nodes read the same YAML).
#include <message_filters/subscriber.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>
#include <tf2_ros/transform_listener.h>
#include <tf2_sensor_msgs/tf2_sensor_msgs.h>

#include <cmath>
#include <limits>
#include <memory>
#include <string>

namespace
{
struct ScanSettings
{
  std::string frame = "base_link";
  double min_z = 0.05, max_z = 1.0;
  double angle_min = -M_PI, angle_max = M_PI, angle_increment = M_PI / 720.0;
  double range_min = 0.0, range_max = 10.0;
  double tolerance = 0.1;
  int queue_size = 10;

  explicit ScanSettings(const ros::NodeHandle& pnh)
  {
    double floor = 0.0, min_height = min_z, max_height = max_z;
    pnh.param("reference_frame", frame, frame);
    pnh.param("floor_height", floor, floor);
    pnh.param("min_height", min_height, min_height);
    pnh.param("max_height", max_height, max_height);
    min_z = floor + min_height;
    max_z = floor + max_height;
    pnh.param("angle_min", angle_min, angle_min);
    pnh.param("angle_max", angle_max, angle_max);
    pnh.param("angle_increment", angle_increment, angle_increment);
    pnh.param("range_min", range_min, range_min);
    pnh.param("range_max", range_max, range_max);
    pnh.param("transform_tolerance", tolerance, tolerance);
    pnh.param("queue_size", queue_size, queue_size);
  }

  sensor_msgs::LaserScanPtr emptyScan(const std_msgs::Header& cloud_header) const
  {
    auto scan = boost::make_shared<sensor_msgs::LaserScan>();
    scan->header.stamp = cloud_header.stamp;
    scan->header.frame_id = frame;
    scan->angle_min = angle_min;
    scan->angle_max = angle_max;
    scan->angle_increment = angle_increment;
    scan->range_min = range_min;
    scan->range_max = range_max;
    const auto beams = static_cast<std::size_t>(std::lround((angle_max - angle_min) / angle_increment)) + 1;
    scan->ranges.assign(beams, std::numeric_limits<float>::infinity());
    return scan;
  }
};

class PerPointNode
{
public:
  PerPointNode(ros::NodeHandle& nh, const ScanSettings& s)
    : s_(s),
      listener_(buffer_),
      cloud_sub_(nh, "cloud_in", s.queue_size),
      filter_(cloud_sub_, buffer_, s.frame, s.queue_size, nh),
      scan_pub_(nh.advertise<sensor_msgs::LaserScan>("scan", 10))
  {
    filter_.registerCallback(&PerPointNode::cloudIn, this);
  }

private:
  void cloudIn(const sensor_msgs::PointCloud2ConstPtr& cloud)
  {
    sensor_msgs::PointCloud2 in_frame;
    try
    {
      buffer_.transform(*cloud, in_frame, s_.frame, ros::Duration(s_.tolerance));
    }
    catch (const tf2::TransformException& e)
    {
      ROS_WARN_THROTTLE(5.0, "cloud dropped: %s", e.what());
      return;
    }
    sensor_msgs::LaserScanPtr scan = s_.emptyScan(cloud->header);
    sensor_msgs::PointCloud2ConstIterator<float> x(in_frame, "x"), y(in_frame, "y"), z(in_frame, "z");
    for (; x != x.end(); ++x, ++y, ++z)
    {
      if (std::isnan(*x) || std::isnan(*y) || std::isnan(*z) || *z < s_.min_z || *z > s_.max_z)
        continue;
      const double range = std::hypot(*x, *y);
      if (range < s_.range_min || range > s_.range_max)
        continue;
      const double angle = std::atan2(*y, *x);
      if (angle < s_.angle_min || angle > s_.angle_max)
        continue;
      const auto beam = static_cast<std::size_t>((angle - s_.angle_min) / s_.angle_increment);
      if (beam < scan->ranges.size() && range < scan->ranges[beam])
        scan->ranges[beam] = static_cast<float>(range);
    }
    scan_pub_.publish(scan);
  }

  ScanSettings s_;
  tf2_ros::Buffer buffer_;
  tf2_ros::TransformListener listener_;
  message_filters::Subscriber<sensor_msgs::PointCloud2> cloud_sub_;
  tf2_ros::MessageFilter<sensor_msgs::PointCloud2> filter_;
  ros::Publisher scan_pub_;
};

class TransportNode
{
public:
  TransportNode(ros::NodeHandle& nh, const ScanSettings& s)
    : s_(s),
      cloud_sub_(nh.subscribe("cloud_in", s.queue_size, &TransportNode::cloudIn, this)),
      scan_pub_(nh.advertise<sensor_msgs::LaserScan>("scan", 10))
  {}

private:
  void cloudIn(const sensor_msgs::PointCloud2ConstPtr& cloud) { scan_pub_.publish(s_.emptyScan(cloud->header)); }

  ScanSettings s_;
  ros::Subscriber cloud_sub_;
  ros::Publisher scan_pub_;
};
}  // namespace

int main(int argc, char** argv)
{
  ros::init(argc, argv, "per_point_reference");
  ros::NodeHandle nh, pnh("~");
  const ScanSettings settings(pnh);
  std::string mode = "per_point";
  pnh.param("mode", mode, mode);
  std::unique_ptr<PerPointNode> per_point;
  std::unique_ptr<TransportNode> transport;
  if (mode == "per_point")
    per_point = std::make_unique<PerPointNode>(nh, settings);
  else if (mode == "transport")
    transport = std::make_unique<TransportNode>(nh, settings);
  else
  {
    ROS_FATAL("parameter 'mode' must be 'per_point' or 'transport', not '%s'", mode.c_str());
    return 2;
  }
  ros::spin();
  return 0;
}
