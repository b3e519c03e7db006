// The floor under the merger node's cost (bench/measure_node_cost.py): a node that subscribes
// the merger's four source topics and publishes one 1441-beam LaserScan per input scan, with
// no check, no transform and no merge. What the merger spends above it is its own glue and core.
#include <boost/make_shared.hpp>
#include <limits>
#include <string>
#include <vector>

#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>

int main(int argc, char** argv)
{
  ros::init(argc, argv, "scan_relay");
  ros::NodeHandle nh;
  const ros::Publisher pub = nh.advertise<sensor_msgs::LaserScan>("merged_scan", 10);
  constexpr std::size_t kBeams = 1441;  // the merger's default output: 0.25 degree over a turn
  const auto relay = [&pub](const sensor_msgs::LaserScan::ConstPtr& in) {
    auto out = boost::make_shared<sensor_msgs::LaserScan>();
    out->header.stamp = in->header.stamp;
    out->header.frame_id = "base_link";
    out->angle_min = -3.14159265f;
    out->angle_max = 3.14159265f;
    out->angle_increment = 0.00436332313f;
    out->range_max = 12.0f;
    out->ranges.assign(kBeams, std::numeric_limits<float>::infinity());
    pub.publish(sensor_msgs::LaserScan::ConstPtr(out));
  };
  std::vector<ros::Subscriber> subs;
  for (const char* topic :
       { "lidar_front_left/scan", "lidar_rear_right/scan", "camera_front/scan", "camera_rear/scan" })
    subs.push_back(nh.subscribe<sensor_msgs::LaserScan>(topic, 10, relay));
  ros::spin();
  return 0;
}
