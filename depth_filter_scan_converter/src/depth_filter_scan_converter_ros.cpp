#include "depth_filter_scan_converter/depth_filter_scan_converter_ros.hpp"

#include <sensor_msgs/LaserScan.h>
#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <boost/bind/bind.hpp>
#include <boost/make_shared.hpp>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <type_traits>

#include "depth_filter_scan_converter/projector.hpp"
#include "laserscan_common/self_filter_parameters.hpp"
#include "laserscan_common/node_log.hpp"

namespace depth_filter_scan_converter
{
namespace
{
// dynamic_reconfigure's values travel by name: each parameter of the .cfg is the field of
// Parameters' table with that name (test/test_parameter_tables.py checks name, type, default).
template <class T>
auto& entriesOf(dynamic_reconfigure::Config& message)
{
  if constexpr (std::is_same_v<T, bool>)
    return message.bools;
  else if constexpr (std::is_same_v<T, int>)
    return message.ints;
  else if constexpr (std::is_same_v<T, double>)
    return message.doubles;
  else
    return message.strs;
}

void toConfig(const Parameters& p, DepthFilterScanConverterConfig& config)
{
  dynamic_reconfigure::Config message;
  config.__toMessage__(message);
  visitFields(p, [&message](const auto& field, const laserscan_common::ParamInfo& info) {
    for (auto& entry : entriesOf<std::decay_t<decltype(field)>>(message))
      if (entry.name == info.name)
        entry.value = field;
  });
  config.__fromMessage__(message);
}

void fromConfig(const DepthFilterScanConverterConfig& config, Parameters& p)
{
  dynamic_reconfigure::Config message;
  config.__toMessage__(message);
  visitFields(p, [&message](auto& field, const laserscan_common::ParamInfo& info) {
    using T = std::decay_t<decltype(field)>;
    for (const auto& entry : entriesOf<T>(message))
      if (entry.name == info.name)
        field = static_cast<T>(entry.value);
  });
}
}  // namespace

Parameters loadParameters(laserscan_common::ParameterReader& reader)
{
  Parameters p;
  reader.readFields(p);
  p.validate();
  return p;
}

DepthFilterScanConverter::DepthFilterScanConverter(ros::NodeHandle nh, ros::NodeHandle private_nh, DepthInput input,
                                                   CloudReading reading)
  : nh_(nh),
    private_nh_(private_nh),
    input_(input),
    reading_(reading),
    input_topic_(nh.resolveName(input == DepthInput::Cloud ? "cloud_in" : "image")),
    reader_(private_nh),
    params_(loadParameters(reader_)),
    queue_size_(params_.input.queue_size),
    tf_buffer_(ros::Duration(params_.transform.tf_buffer_duration)),
    lazy_([this] { subscribeInput(); }, [this] { unsubscribeInput(); }),
    projector_(params_),
    diagnostics_(nh, private_nh, "Input and processing",
                 [this](diagnostic_updater::DiagnosticStatusWrapper& status) { diagnose(status); })
{
  frame_id_ = laserscan_common::FrameIdNormaliser([this](const std::string& frame_id, const std::string& used) {
    // tf2_ros's MessageFilter strips it too; say it once, then use the frame without it.
    NODE_WARN(private_nh_.getNamespace(),
              "frame_id '%s' on %s starts with '/', which tf2 does not accept: using '%s' (said once)",
              frame_id.c_str(), input_topic_.c_str(), used.c_str());
  });
  tf_reader_ = std::make_unique<laserscan_common::TransformReader>(nh_, tf_buffer_, private_nh_.getNamespace());
  std::vector<std::string> self_filter_warnings;
  self_filter_ =
    laserscan_common::makeSelfFilter(laserscan_common::readSelfFilterParams(reader_), nh_, self_filter_warnings);
  reader_.warnUnknown();
  for (const std::string& warning : self_filter_warnings)
    NODE_WARN(private_nh_.getNamespace(), "self filter: %s", warning.c_str());
  // A message waits for its own transform and for those of the robot's parts at its stamp.
  tf_targets_ = { params_.transform.reference_frame };
  tf_targets_.insert(tf_targets_.end(), self_filter_.frames().begin(), self_filter_.frames().end());
  if (!self_filter_.empty())
    NODE_INFO(private_nh_.getNamespace(), "self filter: %zu shapes on %zu frames", self_filter_.shapes().size(),
              self_filter_.frames().size());

  // Messages wait for their transforms in laserscan_common's TransformWait, which delivers
  // through nh's callback queue: processing runs in the node's own threads.
  const auto queue = static_cast<std::uint32_t>(queue_size_);
  if (input_ == DepthInput::Cloud)
    cloud_wait_ = std::make_unique<laserscan_common::TransformWait<Cloud>>(
      tf_buffer_, tf_targets_, queue, nh_,
      [this](const Cloud::ConstPtr& cloud, const ros::Time& received) {
        std::lock_guard<std::mutex> lock(mutex_);
        convert(*cloud, cloud->data.data(), cloud->data.size(), nullptr, received);
      },
      [this](const Cloud::ConstPtr& cloud, const std::string& why) { transformFailed(cloud->header, why); });
  else
  {
    image_wait_ = std::make_unique<laserscan_common::TransformWait<CameraFrame>>(
      tf_buffer_, tf_targets_, queue, nh_,
      [this](const boost::shared_ptr<const CameraFrame>& frame, const ros::Time& received) {
        std::lock_guard<std::mutex> lock(mutex_);
        convert(*frame->image, frame->image->data.data(), frame->image->data.size(), frame->info, received);
      },
      [this](const boost::shared_ptr<const CameraFrame>& frame, const std::string& why) {
        transformFailed(frame->header, why);
      });
    image_sync_ = std::make_unique<ImageSync>(message_filters::sync_policies::ExactTime<Image, CameraInfo>(queue),
                                              image_in_, info_sub_);
    // boost::bind: the synchronizer's signals pass nine arguments, the unused ones NullType.
    using boost::placeholders::_1;
    using boost::placeholders::_2;
    image_sync_->registerCallback(boost::bind(&DepthFilterScanConverter::imageArrived, this, _1, _2));
    image_sync_->registerDropCallback(boost::bind(&DepthFilterScanConverter::imageDropped, this, _1, _2));
  }

  reconfigure_server_ = std::make_unique<dynamic_reconfigure::Server<Config>>(private_nh_);
  reconfigure_server_->setCallback([this](Config& config, std::uint32_t level) { reconfigure(config, level); });

  // Lazy: subscribe to the input only while someone listens to an output.
  scan_pub_ = lazy_.advertise<sensor_msgs::LaserScan>(nh_, "scan", 10);
  if (params_.publish_filtered_cloud)
    cloud_pub_ = lazy_.advertise<Cloud>(nh_, "filtered_cloud", 2);
}

DepthFilterScanConverter::~DepthFilterScanConverter()
{
  // Stop the input first: no callback may reach a half-destroyed object.
  lazy_.shutdown();
  diagnostics_.stop();
}

void DepthFilterScanConverter::subscribeInput()
{
  const auto queue = static_cast<std::uint32_t>(queue_size_);
  if (input_ == DepthInput::Cloud)
  {
    InPlaceReader<Cloud> in_place;
    if (reading_ == CloudReading::InPlace)
      in_place = [this](const Cloud& cloud, const std::uint8_t* bytes, std::size_t size) {
        return convertInPlace(cloud, bytes, size);
      };
    input_sub_ = subscribeCopyingOnce<Cloud>(
      nh_, "cloud_in", queue, [this](const Cloud::ConstPtr& cloud) { cloudArrived(cloud); }, in_place);
  }
  else
  {
    input_sub_ =
      subscribeCopyingOnce<Image>(nh_, "image", queue, [this](const Image::ConstPtr& image) { image_in_.add(image); });
    info_sub_.subscribe(nh_, "camera_info", queue);
  }
}

void DepthFilterScanConverter::unsubscribeInput()
{
  input_sub_.shutdown();
  info_sub_.unsubscribe();
}

void DepthFilterScanConverter::cloudArrived(const Cloud::ConstPtr& cloud)
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++received_;
    const Admission admission = admit(cloud->header);
    if (admission == Admission::Dropped)
      return;
    if (admission == Admission::Ready)
    {
      convert(*cloud, cloud->data.data(), cloud->data.size(), nullptr, ros::Time());
      return;
    }
  }
  cloud_wait_->wait(cloud, ros::Time::now());  // outside mutex_: a failure may come back through it
}

DepthFilterScanConverter::Admission DepthFilterScanConverter::admit(const std_msgs::Header& header)
{
  // Checked before tf2 sees the header: tf2 adds durations to the stamp (roscpp throws past
  // 2^32 s, which would abort the whole manager) and warns without throttle on bad frame ids.
  const std::string problem = headerProblem(header);
  if (!problem.empty())
  {
    dropMalformed(problem, header.frame_id);
    return Admission::Dropped;
  }
  // The usual case, the transform already there: converted now, without the wait's extra trip
  // through the callback queue (and its second tf query).
  const bool ready = input_ == DepthInput::Cloud ? cloud_wait_->ready(header) : image_wait_->ready(header);
  return ready ? Admission::Ready : Admission::Wait;
}

bool DepthFilterScanConverter::convertInPlace(const Cloud& cloud, const std::uint8_t* bytes, std::size_t size)
{
  std::lock_guard<std::mutex> lock(mutex_);
  const Admission admission = admit(cloud.header);
  if (admission == Admission::Wait)
    return false;  // it must wait in the tf filter: copied, the usual path
  ++received_;
  ++read_in_place_;
  if (admission == Admission::Ready)
  {
    try
    {
      convert(cloud, bytes, size, nullptr, ros::Time());
    }
    catch (const std::exception& e)
    {
      // Out of roscpp's deserialiser, it would be logged as a message that could not be read.
      dropMalformed(std::string("conversion failed: ") + e.what(), cloud.header.frame_id);
    }
  }
  return true;
}

void DepthFilterScanConverter::imageArrived(const Image::ConstPtr& image, const CameraInfo::ConstPtr& info)
{
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++received_;
    const Admission admission = admit(image->header);
    if (admission == Admission::Dropped)
      return;
    if (admission == Admission::Ready)
    {
      convert(*image, image->data.data(), image->data.size(), info, ros::Time());
      return;
    }
  }
  image_wait_->wait(boost::make_shared<const CameraFrame>(CameraFrame{ image->header, image, info }), ros::Time::now());
}

void DepthFilterScanConverter::imageDropped(const Image::ConstPtr& image, const CameraInfo::ConstPtr& info)
{
  if (!image || info)
    return;  // a camera_info without its image: nothing of ours is lost
  std::lock_guard<std::mutex> lock(mutex_);
  ++received_;
  ++without_info_;
  if (warnings_.due("no camera_info"))
    NODE_WARN(private_nh_.getNamespace(),
              "dropped a depth image on %s (stamp %s): no camera_info with its stamp came on %s before a "
              "newer frame's did, or within queue_size (%d) frames",
              input_topic_.c_str(),
              laserscan_common::stampText(image->header.stamp.sec, image->header.stamp.nsec).c_str(),
              nh_.resolveName("camera_info").c_str(), queue_size_);
}

std::string DepthFilterScanConverter::headerProblem(const std_msgs::Header& header)
{
  // The stamp as text only for a message that is dropped: formatting it costs more than the checks.
  const auto stamp = [&header] { return laserscan_common::stampText(header.stamp.sec, header.stamp.nsec); };
  if (header.frame_id.empty())
    return "empty frame_id (stamp " + stamp() + ")";
  // Only looked up: any stamp that leaves tf2 and roscpp room for what they add to it.
  const laserscan_common::StampLimits limits{
    laserscan_common::kMaxStampAheadNs, params_.transform.tf_buffer_duration + params_.transform.transform_tolerance
  };
  if (const std::string fault = laserscan_common::stampFault(header.stamp.sec, header.stamp.nsec, 0,
                                                             laserscan_common::StampUse::kLookup, limits);
      !fault.empty())
    return fault + " (stamp " + stamp() + ")";
  frame_id_(header.frame_id);
  return {};
}

void DepthFilterScanConverter::dropMalformed(const std::string& reason, const std::string& frame_id)
{
  ++malformed_;
  // A new kind of defect is reported at once, the same one again at most every 5 s. Reasons
  // carry numbers (stamps, sizes) that change from message to message: the kind is the text
  // without them, or a stream of empty frame_ids would be warned about once per message.
  last_malformed_reason_ = reason;
  if (warnings_.due("malformed: " + laserscan_common::faultKind(reason)))
    NODE_WARN(private_nh_.getNamespace(), "dropped a malformed %s on %s (frame '%s'): %s",
              input_ == DepthInput::Cloud ? "cloud" : "depth image", input_topic_.c_str(), frame_id.c_str(),
              reason.c_str());
}

void DepthFilterScanConverter::transformFailed(const std_msgs::Header& header, const std::string& why)
{
  std::lock_guard<std::mutex> lock(mutex_);
  ++tf_failures_;
  last_tf_reason_ = why;
  if (warnings_.due("no transform"))
    NODE_WARN(private_nh_.getNamespace(), "dropped a cloud: no transform %s -> %s at %s: %s", header.frame_id.c_str(),
              params_.transform.reference_frame.c_str(),
              laserscan_common::stampText(header.stamp.sec, header.stamp.nsec).c_str(), why.c_str());
}

std::string DepthFilterScanConverter::viewOf(const Cloud& cloud, const std::uint8_t* bytes, std::size_t size,
                                             const CameraInfo::ConstPtr& /*info*/, CloudView& view)
{
  std::string intensity_note;
  const std::string reason =
    makeCloudView(cloudLayoutOf(cloud), bytes, size, params_.input.intensity_field, view, &intensity_note);
  if (reason.empty() && !intensity_note.empty() && warnings_.due("no intensity field", 30.0))
    NODE_WARN(private_nh_.getNamespace(), "%s: the scan has no intensities", intensity_note.c_str());
  return reason;
}

std::string DepthFilterScanConverter::viewOf(const Image& image, const std::uint8_t* bytes, std::size_t size,
                                             const CameraInfo::ConstPtr& info, DepthImageView& view)
{
  if (!info)
    return "no camera_info for this image";
  return makeDepthImageView(imageLayoutOf(image), bytes, size, cameraModelOf(*info),
                            params_.input.depth_image_rectified, view);
}

template <class M>
void DepthFilterScanConverter::convert(const M& message, const std::uint8_t* bytes, std::size_t size,
                                       const CameraInfo::ConstPtr& info, const ros::Time& received)
{
  const auto start = std::chrono::steady_clock::now();
  const M* const cloud = &message;
  const std::string& name = private_nh_.getNamespace();

  // "How long a cloud may wait for its transform": a late scan is worse than none for a planner.
  if (!received.isZero())
  {
    const double waited = (ros::Time::now() - received).toSec();
    if (waited > params_.transform.transform_tolerance)
    {
      ++stale_;
      if (warnings_.due("late"))
        NODE_WARN(name, "dropped a cloud that waited %.3f s for its transform %s -> %s (transform_tolerance %.3f s)",
                  waited, cloud->header.frame_id.c_str(), params_.transform.reference_frame.c_str(),
                  params_.transform.transform_tolerance);
      return;
    }
  }

  std::conditional_t<std::is_same_v<M, Image>, DepthImageView, CloudView> view;
  const std::string reason = viewOf(*cloud, bytes, size, info, view);
  if (!reason.empty())
  {
    dropMalformed(reason, cloud->header.frame_id);
    return;
  }

  Eigen::Isometry3d camera_to_reference;
  try
  {
    const std::string frame = laserscan_common::tf2FrameId(cloud->header.frame_id);
    const auto transform = tf_buffer_.lookupTransform(params_.transform.reference_frame, frame, cloud->header.stamp);
    // Each stored transform is finite (tf_reader_), but a chain of them can sum to infinity.
    if (!laserscan_common::transformIsFinite(transform.transform))
      throw tf2::TransformException("the transform '" + frame + "' -> '" + params_.transform.reference_frame + "' at " +
                                    laserscan_common::stampText(cloud->header.stamp.sec, cloud->header.stamp.nsec) +
                                    " is not finite (a chain of transforms sums to infinity)");
    camera_to_reference = tf2::transformToEigen(transform);
    // The robot's parts where they are at the cloud's stamp: one lookup per frame. The block
    // test bounds runs of a row's points in axes along the camera's rows.
    if (!self_filter_.empty())
      laserscan_common::setFramePosesAt(tf_buffer_, params_.transform.reference_frame, cloud->header.stamp,
                                        self_filter_, laserscan_common::imageRowYaw(camera_to_reference.linear()));
  }
  catch (const std::exception& e)  // tf2 also throws std::runtime_error on stamps past 32 bits
  {
    ++tf_failures_;
    last_tf_reason_ = e.what();
    if (warnings_.due("no transform"))
      NODE_WARN(name, "dropped a cloud: %s", e.what());
    return;
  }

  auto scan = boost::make_shared<sensor_msgs::LaserScan>();
  scan->header.stamp = cloud->header.stamp;
  scan->header.frame_id = params_.transform.reference_frame;
  scan->angle_min = static_cast<float>(params_.scan.angle_min);
  scan->angle_max = static_cast<float>(params_.scan.angle_max);
  scan->angle_increment = static_cast<float>(params_.scan.angle_increment);
  scan->time_increment = 0.0f;  // a depth image is taken at once
  scan->scan_time = 0.0f;
  scan->range_min = static_cast<float>(params_.scan.range_min);
  scan->range_max = static_cast<float>(params_.scan.range_max);
  const bool want_cloud = params_.publish_filtered_cloud && cloud_pub_ && cloud_pub_.getNumSubscribers() > 0;
  projector_.project(view, camera_to_reference, scan->ranges, &scan->intensities, want_cloud ? &kept_points_ : nullptr,
                     &self_filter_);
  scan_pub_.publish(scan);  // not touched after this: shared zero-copy with nodelets in the manager

  if (want_cloud)
  {
    auto out = boost::make_shared<Cloud>();
    out->header = scan->header;
    out->height = 1;
    out->width = static_cast<std::uint32_t>(kept_points_.size() / 3);
    out->is_bigendian = false;
    out->is_dense = true;
    out->point_step = 12;
    out->row_step = out->point_step * out->width;
    const char* names[3] = { "x", "y", "z" };
    for (std::uint32_t i = 0; i < 3; ++i)
    {
      sensor_msgs::PointField f;
      f.name = names[i];
      f.offset = 4 * i;
      f.datatype = sensor_msgs::PointField::FLOAT32;
      f.count = 1;
      out->fields.push_back(f);
    }
    out->data.resize(kept_points_.size() * sizeof(float));
    if (!kept_points_.empty())
      std::memcpy(out->data.data(), kept_points_.data(), out->data.size());
    cloud_pub_.publish(out);
  }

  ++published_;
  last_ms_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  max_ms_ = std::max(max_ms_, last_ms_);
  sum_ms_ += last_ms_;
}

void DepthFilterScanConverter::reconfigure(Config& config, std::uint32_t /*level*/)
{
  std::lock_guard<std::mutex> lock(mutex_);
  if (first_reconfigure_)
  {
    // The server's first call carries its clamped copy of the start-up values (it cannot hold
    // "no limit" = inf): the loaded, validated parameters win, and the server shows them.
    first_reconfigure_ = false;
    toConfig(params_, config);
    return;
  }
  Parameters p = params_;
  fromConfig(config, p);  // what dynamic_reconfigure tunes: the .cfg's fields
  try
  {
    projector_.setParameters(p);  // validates
    params_ = p;
    NODE_INFO(private_nh_.getNamespace(),
              "reconfigured: band %.3f .. %.3f m above floor %.3f m, range %.3f .. %.3f m, holes %s (depth %.3f m)",
              p.band.min_height, p.band.max_height, p.band.floor_height, p.scan.range_min, p.scan.range_max,
              p.band.hole_detection ? "on" : "off", p.band.hole_depth);
  }
  catch (const ParameterError& e)
  {
    NODE_WARN(private_nh_.getNamespace(), "rejected a dynamic_reconfigure change: %s; keeping the previous values",
              describe(e).c_str());
    toConfig(params_, config);
  }
}

void DepthFilterScanConverter::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status)
{
  std::lock_guard<std::mutex> lock(mutex_);
  const double rate = rate_.rate(received_);
  const bool subscribed = lazy_.subscribed();

  // The summary names what dropped clouds since the last update, with the last reason of each.
  std::string dropped;
  auto add_cause = [&dropped](std::uint64_t now_count, std::uint64_t before, const char* what,
                              const std::string& last) {
    if (now_count == before)
      return;
    dropped += (dropped.empty() ? "dropped " : "; ") + std::to_string(now_count - before) + " " + what;
    if (!last.empty())
      dropped += " (last: " + last + ")";
  };
  add_cause(malformed_, malformed_at_last_report_, "malformed", last_malformed_reason_);
  add_cause(tf_failures_, tf_failures_at_last_report_, "without transform", last_tf_reason_);
  add_cause(stale_, stale_at_last_report_, "late (transform_tolerance)", "");
  add_cause(without_info_, without_info_at_last_report_, "depth images without camera_info", "");

  summarize(status, dropped, subscribed, rate, "subscribed, but nothing arrives on " + input_topic_);

  status.add("subscribed", subscribed);
  status.add("input rate [Hz]", rate);
  status.add("clouds received", received_);
  if (input_ == DepthInput::Cloud)
    status.add("clouds read in place (no copy)", read_in_place_);
  status.add("scans published", published_);
  status.add("processing time, last [ms]", last_ms_);
  status.add("processing time, mean [ms]", published_ > 0 ? sum_ms_ / static_cast<double>(published_) : 0.0);
  status.add("processing time, max [ms]", max_ms_);
  status.add("transform failures", tf_failures_);
  status.add("late clouds dropped (transform_tolerance)", stale_);
  status.add("malformed clouds dropped", malformed_);
  if (input_ == DepthInput::Image)
    status.add("depth images without camera_info", without_info_);
  status.add("last malformed reason", last_malformed_reason_);
  status.add("last transform failure", last_tf_reason_);
  malformed_at_last_report_ = malformed_;
  tf_failures_at_last_report_ = tf_failures_;
  stale_at_last_report_ = stale_;
  without_info_at_last_report_ = without_info_;
}

}  // namespace depth_filter_scan_converter
