#include "depth_filter_scan_converter/range_scan_converter_ros.hpp"

#include <sensor_msgs/LaserScan.h>

#include <boost/make_shared.hpp>
#include "laserscan_common/node_log.hpp"

namespace depth_filter_scan_converter
{
RangeScanParameters loadRangeScanParameters(const ros::NodeHandle& pnh)
{
  laserscan_common::ParameterReader reader(pnh);
  RangeScanParameters p;
  reader.readFields(p);
  p.validate();
  reader.warnUnknown();
  return p;
}

RangeScanConverter::RangeScanConverter(ros::NodeHandle nh, ros::NodeHandle private_nh)
  : nh_(nh),
    private_nh_(private_nh),
    params_(loadRangeScanParameters(private_nh)),
    lazy_(
      [this] {
        {
          std::lock_guard<std::mutex> state(mutex_);
          converter_.reset();  // readings from before a pause do not confirm new ones
        }
        range_sub_ = nh_.subscribe("range_in", static_cast<std::uint32_t>(params_.queue_size),
                                   &RangeScanConverter::rangeArrived, this);
      },
      [this] { range_sub_.shutdown(); }),
    converter_(params_),
    diagnostics_(nh, private_nh, "Input and processing",
                 [this](diagnostic_updater::DiagnosticStatusWrapper& status) { diagnose(status); })
{
  // Lazy: subscribe to the ranges only while someone listens to the scan.
  scan_pub_ = lazy_.advertise<sensor_msgs::LaserScan>(nh_, "scan", 10);
}

RangeScanConverter::~RangeScanConverter()
{
  lazy_.shutdown();
  diagnostics_.stop();
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
    if (warn_malformed_.due(reason))
      NODE_ERROR(private_nh_.getNamespace(), "dropped a bad range message (frame '%s', stamp %.3f): %s",
                 msg->header.frame_id.c_str(), reading.stamp, reason.c_str());
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
  const double rate = rate_.rate(received_);
  const bool subscribed = lazy_.subscribed();
  summarize(status,
            malformed_ > malformed_at_last_report_ ? "bad range messages dropped: " + last_malformed_reason_ : "",
            subscribed, rate, "subscribed, but no reading arrives on range_in");

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
  malformed_at_last_report_ = malformed_;
}

}  // namespace depth_filter_scan_converter
