// Reference nodes for the node-level comparison of bench/measure_node_cpu.py (issue 9, part 3).
//
// mode "per_point": a stand-in for pointcloud_to_laserscan, which Debian 12 does not package (and
// the project builds nothing from source). Written here after that node's ROS 1 source was read
// for its structure (none of its code is copied), so that it pays the same costs:
// - like pointcloud_to_laserscan_node, the process loads the converter as a nodelet in its own
//   nodelet::Loader: clouds are handed from roscpp's queue to a nodelet worker thread;
// - it subscribes to clouds only while its scan has a subscriber;
// - clouds wait in a tf2_ros::MessageFilter for the transform to the target frame; each cloud is
//   first transformed whole into a new PointCloud2 (tf2_sensor_msgs, the library call that node
//   makes);
// - every point is read through PointCloud2ConstIterator; a point is rejected if NaN, if its z
//   is outside [min_height, max_height], its planar range (hypot) outside [range_min,
//   range_max] or its angle (atan2) outside [angle_min, angle_max], each rejection with a
//   debug-level log statement (off at run time, but checked per point, as that node's are);
//   a beam keeps its closest point; the scan is published.
// Its input queue is the YAML's queue_size, not that node's default of one cloud, so that it
// drops no cloud under load (a dropped cloud would lower its CPU per cloud sent). Its figures
// are an estimate of that node's cost, not a measurement of it.
//
// mode "transport": the baseline both are measured above, a plain node: receives each cloud
// and publishes a scan of the same size with no return in every beam.
//
// Private parameters: mode, and the converter's reference_frame, floor_height, min_height,
// max_height, angle_min, angle_max, angle_increment, range_min, range_max, transform_tolerance,
// queue_size (so both nodes read the same YAML).
#include <message_filters/subscriber.h>
#include <nodelet/loader.h>
#include <nodelet/nodelet.h>
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
#include <mutex>
#include <string>
#include <vector>

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

class PerPointNodelet : public nodelet::Nodelet
{
private:
  void onInit() override
  {
    std::lock_guard<std::mutex> lock(connect_mutex_);
    nh_ = getNodeHandle();
    settings_ = std::make_unique<ScanSettings>(getPrivateNodeHandle());
    buffer_ = std::make_unique<tf2_ros::Buffer>();
    listener_ = std::make_unique<tf2_ros::TransformListener>(*buffer_);
    filter_ = std::make_unique<tf2_ros::MessageFilter<sensor_msgs::PointCloud2>>(cloud_sub_, *buffer_, settings_->frame,
                                                                                 settings_->queue_size, nh_);
    filter_->registerCallback(&PerPointNodelet::cloudIn, this);
    scan_pub_ = nh_.advertise<sensor_msgs::LaserScan>(
      "scan", 10, [this](const ros::SingleSubscriberPublisher&) { connectionChanged(); },
      [this](const ros::SingleSubscriberPublisher&) { connectionChanged(); });
  }

  // Subscribes to clouds while the scan has a subscriber.
  void connectionChanged()
  {
    std::lock_guard<std::mutex> lock(connect_mutex_);
    const bool wanted = scan_pub_.getNumSubscribers() > 0;                  // read once: it may change meanwhile
    const bool subscribed = static_cast<bool>(cloud_sub_.getSubscriber());  // false once unsubscribed
    if (wanted && !subscribed)
      cloud_sub_.subscribe(nh_, "cloud_in", settings_->queue_size);
    else if (!wanted && subscribed)
      cloud_sub_.unsubscribe();
  }

  // Allocates as that node does, in the same order (the scan's ranges, then the transformed cloud),
  // since which buffers the C library keeps between clouds depends on it.
  void cloudIn(const sensor_msgs::PointCloud2ConstPtr& cloud)
  {
    const ScanSettings& s = *settings_;
    sensor_msgs::LaserScanPtr scan = s.emptyScan(cloud->header);
    auto transformed = boost::make_shared<sensor_msgs::PointCloud2>();
    try
    {
      buffer_->transform(*cloud, *transformed, s.frame, ros::Duration(s.tolerance));
    }
    catch (const tf2::TransformException& e)
    {
      NODELET_WARN_THROTTLE(5.0, "cloud dropped: %s", e.what());
      return;
    }
    const sensor_msgs::PointCloud2& in_frame = *transformed;
    sensor_msgs::PointCloud2ConstIterator<float> x(in_frame, "x"), y(in_frame, "y"), z(in_frame, "z");
    for (; x != x.end(); ++x, ++y, ++z)
    {
      if (std::isnan(*x) || std::isnan(*y) || std::isnan(*z))
      {
        NODELET_DEBUG("point (%f, %f, %f) skipped: NaN", *x, *y, *z);
        continue;
      }
      if (*z < s.min_z || *z > s.max_z)
      {
        NODELET_DEBUG("point skipped: height %f outside [%f, %f]", *z, s.min_z, s.max_z);
        continue;
      }
      const double range = std::hypot(*x, *y);
      if (range < s.range_min)
      {
        NODELET_DEBUG("point skipped: range %f below %f", range, s.range_min);
        continue;
      }
      if (range > s.range_max)
      {
        NODELET_DEBUG("point skipped: range %f above %f", range, s.range_max);
        continue;
      }
      const double angle = std::atan2(*y, *x);
      if (angle < s.angle_min || angle > s.angle_max)
      {
        NODELET_DEBUG("point skipped: angle %f outside [%f, %f]", angle, s.angle_min, s.angle_max);
        continue;
      }
      const auto beam = static_cast<std::size_t>((angle - s.angle_min) / s.angle_increment);
      if (beam < scan->ranges.size() && range < scan->ranges[beam])
        scan->ranges[beam] = static_cast<float>(range);
    }
    scan_pub_.publish(scan);
  }

  std::mutex connect_mutex_;
  ros::NodeHandle nh_;
  std::unique_ptr<ScanSettings> settings_;
  std::unique_ptr<tf2_ros::Buffer> buffer_;
  std::unique_ptr<tf2_ros::TransformListener> listener_;
  message_filters::Subscriber<sensor_msgs::PointCloud2> cloud_sub_;
  std::unique_ptr<tf2_ros::MessageFilter<sensor_msgs::PointCloud2>> filter_;
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
  std::string mode = "per_point";
  pnh.param("mode", mode, mode);
  if (mode == "per_point")
  {
    // As pointcloud_to_laserscan_node: the nodelet in a loader of its own, named as the node
    // (so its private parameters are the node's), with the command line's remappings, its
    // callbacks on the loader's worker threads (one per core), and a multi-threaded spinner (one
    // thread per core) on the global queue. Built from a factory, this loader offers no
    // load / unload services, which only idle in that node.
    const boost::function<boost::shared_ptr<nodelet::Nodelet>(const std::string&)> make_nodelet =
      [](const std::string&) { return boost::make_shared<PerPointNodelet>(); };
    nodelet::Loader loader(make_nodelet);
    const std::vector<std::string> no_args;
    if (!loader.load(ros::this_node::getName(), "per_point", ros::names::getRemappings(), no_args))
      return 1;
    ros::MultiThreadedSpinner spinner;
    spinner.spin();
    return 0;
  }
  if (mode != "transport")
  {
    ROS_FATAL("parameter 'mode' must be 'per_point' or 'transport', not '%s'", mode.c_str());
    return 2;
  }
  TransportNode transport(nh, ScanSettings(pnh));
  ros::spin();
  return 0;
}
