#include "depth_filter_scan_converter/range_scan_converter_ros.hpp"

#include <sensor_msgs/LaserScan.h>

#include <boost/make_shared.hpp>
#include <stdexcept>

#include "depth_filter_scan_converter/ros_param.hpp"

namespace depth_filter_scan_converter
{
namespace
{
constexpr double kWarnPeriod = 5.0;  // s between two messages about the same defect
}  // namespace

RangeScanParameters loadRangeScanParameters(const ros::NodeHandle& pnh)
{
  RangeScanParameters p;
  readTypedParam(pnh, "arc_width_scale", p.arc_width_scale, "double");
  readTypedParam(pnh, "arc_width", p.arc_width, "double");
  readTypedParam(pnh, "angle_increment", p.angle_increment, "double");
  readTypedParam(pnh, "min_consecutive_readings", p.min_consecutive_readings, "int");
  p.validate();
  return p;
}

RangeScanConverter::RangeScanConverter(ros::NodeHandle nh, ros::NodeHandle private_nh)
  : nh_(nh),
    private_nh_(private_nh),
    converter_(loadRangeScanParameters(private_nh)),
    updater_(nh, private_nh, private_nh.getNamespace())
{
  readTypedParam(private_nh_, "queue_size", queue_size_, "int");
  if (queue_size_ < 1)
    throw std::invalid_argument("parameter 'queue_size' must be >= 1");

  updater_.setHardwareID(private_nh_.getNamespace());  // the node's name: one ID per sensor
  updater_.add("Input and processing", this, &RangeScanConverter::diagnose);
  last_report_ = ros::WallTime::now();
  diagnostics_timer_ = nh_.createTimer(ros::Duration(1.0), [this](const ros::TimerEvent&) { updater_.update(); });

  // Lazy: subscribe to the ranges only while someone listens to the scan.
  std::lock_guard<std::mutex> lock(connect_mutex_);
  const ros::SubscriberStatusCallback connect = [this](const ros::SingleSubscriberPublisher&) { connectCallback(); };
  scan_pub_ = nh_.advertise<sensor_msgs::LaserScan>("scan", 10, connect, connect);
}

RangeScanConverter::~RangeScanConverter()
{
  std::lock_guard<std::mutex> lock(connect_mutex_);
  range_sub_.shutdown();
  diagnostics_timer_.stop();
}

void RangeScanConverter::connectCallback()
{
  std::lock_guard<std::mutex> lock(connect_mutex_);
  const bool listeners = scan_pub_.getNumSubscribers() > 0;
  if (listeners && !range_sub_)
  {
    {
      std::lock_guard<std::mutex> state(mutex_);
      converter_.reset();  // readings from before a pause do not confirm new ones
    }
    range_sub_ =
      nh_.subscribe("range_in", static_cast<std::uint32_t>(queue_size_), &RangeScanConverter::rangeArrived, this);
  }
  else if (!listeners && range_sub_)
    range_sub_.shutdown();
}

void RangeScanConverter::rangeArrived(const sensor_msgs::Range::ConstPtr& msg)
{
  std::lock_guard<std::mutex> lock(mutex_);
  ++received_;
  RangeReading reading;
  reading.frame_id = msg->header.frame_id;
  // toSec() is plain arithmetic: no stamp, however extreme, can throw here (no ros::Duration
  // is ever formed from a message's stamp).
  reading.stamp = msg->header.stamp.toSec();
  reading.radiation_type = msg->radiation_type;
  reading.field_of_view = msg->field_of_view;
  reading.min_range = msg->min_range;
  reading.max_range = msg->max_range;
  reading.range = msg->range;
  const std::string reason = converter_.convert(reading, arc_);
  if (!reason.empty())
  {
    ++malformed_;
    // A new kind of defect is reported at once, the same one again at most every 5 s (per
    // converter: several in one manager do not hide each other's messages).
    const ros::WallTime now = ros::WallTime::now();
    if (reason != last_malformed_reason_ || warned_malformed_.isZero() ||
        (now - warned_malformed_).toSec() >= kWarnPeriod)
    {
      ROS_ERROR("[%s] dropped a bad range message (frame '%s', stamp %.3f): %s", private_nh_.getNamespace().c_str(),
                msg->header.frame_id.c_str(), reading.stamp, reason.c_str());
      warned_malformed_ = now;
    }
    last_malformed_reason_ = reason;
    return;
  }
  ++per_kind_[static_cast<std::size_t>(arc_.kind)];
  last_stamp_ = reading.stamp;

  auto scan = boost::make_shared<sensor_msgs::LaserScan>();
  scan->header = msg->header;  // the sensor's frame and the reading's time
  scan->angle_min = static_cast<float>(arc_.angle_min);
  scan->angle_max = static_cast<float>(arc_.angle_max);
  scan->angle_increment = static_cast<float>(arc_.angle_increment);
  scan->time_increment = 0.0f;  // every beam is the same instant
  scan->scan_time = 0.0f;
  scan->range_min = static_cast<float>(arc_.range_min);
  scan->range_max = static_cast<float>(arc_.range_max);
  scan->ranges = arc_.ranges;
  scan_pub_.publish(scan);  // not touched after this: shared zero-copy with nodelets in the manager
  ++published_;
}

void RangeScanConverter::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status)
{
  std::lock_guard<std::mutex> lock(mutex_);
  const ros::WallTime now = ros::WallTime::now();
  const double period = std::max((now - last_report_).toSec(), 1e-3);
  const double rate = static_cast<double>(received_ - received_at_last_report_) / period;
  const bool subscribed = static_cast<bool>(range_sub_);

  if (malformed_ > malformed_at_last_report_)
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "bad range messages dropped: " + last_malformed_reason_);
  else if (subscribed && rate == 0.0)
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, "subscribed, but no reading arrives on range_in");
  else
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, subscribed ? "converting" : "idle (nobody listens)");

  status.add("subscribed", subscribed);
  status.add("input rate [Hz]", rate);
  status.add("readings received", received_);
  status.add("scans published", published_);
  status.add("obstacles", per_kind_[static_cast<std::size_t>(ReadingKind::Obstacle)]);
  status.add("unconfirmed (min_consecutive_readings)", per_kind_[static_cast<std::size_t>(ReadingKind::Unconfirmed)]);
  status.add("no returns", per_kind_[static_cast<std::size_t>(ReadingKind::NoReturn)]);
  status.add("too close", per_kind_[static_cast<std::size_t>(ReadingKind::TooClose)]);
  status.add("invalid (NaN)", per_kind_[static_cast<std::size_t>(ReadingKind::Invalid)]);
  status.add("bad messages dropped", malformed_);
  status.add("last bad message", last_malformed_reason_);
  status.add("stamp of the last reading [s]", last_stamp_);
  received_at_last_report_ = received_;
  malformed_at_last_report_ = malformed_;
  last_report_ = now;
}

}  // namespace depth_filter_scan_converter
