// Checks of what a message carries before it reaches roscpp's time arithmetic or tf2: its stamp,
// its frame ids and (for /tf) its transform. ROS-free (plain C++17): the transform checks are
// templates over any type laid out as geometry_msgs' Transform and TransformStamped.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>
#include <unordered_map>
#include <utility>

namespace laserscan_common
{

// ---------------------------------------------------------------- stamps

/// "sec.nsec" with nine digits after the point, whatever the values.
inline std::string stampText(std::uint32_t sec, std::uint32_t nsec)
{
  char text[32];
  std::snprintf(text, sizeof text, "%u.%09u", sec, nsec);
  return text;
}

/// Largest distance (ns) between a message stamp and the node's clock: the largest ros::Duration
/// (2^31 s - 1 ns). A stamp farther away makes every `stamp - now` (in the nodes, in tf2, in
/// consumers) throw "Duration is out of dual 32-bit range".
constexpr std::int64_t kMaxClockOffsetNs = 2147483647LL * 1000000000LL + 999999999LL;

/// Largest distance (ns) a measurement may be stamped ahead of the clock: tf2's default cache
/// length (10 s). A /tf transform farther ahead would make tf2 refuse every later, valid one as
/// too old (TF_OLD_DATA) and the frame would silently disappear; a scan or odometry farther ahead
/// would hold an output's stamp in the future.
constexpr std::int64_t kMaxStampAheadNs = 10LL * 1000000000LL;

/// What a stamp dates, which decides the rules it must follow.
enum class StampUse
{
  /// A scan, odometry or /tf transform: not zero (unset; tf2 reads Time(0) as "the latest"),
  /// at most `max_ahead_ns` ahead of the clock (unchecked while the clock is 0: sim time before
  /// the first /clock) and at most 2^31 s away from it.
  kMeasurement,
  /// A /tf_static transform: timeless, any stamp.
  kStaticTransform,
  /// A stamp at which transforms are only looked up (the converter's inputs, whose scan keeps
  /// the stamp): any stamp, zero included.
  kLookup,
};

/// Limits of the stamp rules; the defaults are the merger's.
struct StampLimits
{
  std::int64_t max_ahead_ns = kMaxStampAheadNs;  ///< kMeasurement: how far ahead of the clock
  /// Seconds kept free before the end of ROS time (2^32 s) for what tf2 and roscpp add to a stamp
  /// (a cache length, a tolerance): beyond it, ros::Time arithmetic throws "Time is out of dual
  /// 32-bit range". Not applied to static transforms, whose stamps tf2 never adds to.
  double end_margin = 0.0;
};

/// "" when a message stamp (ROS's sec and nsec) is usable for `use` against the clock now_ns
/// (integer nanoseconds), otherwise what is wrong with it (the one error convention:
/// CONTRIBUTING.md). Every stamp needs nsec < 1e9.
inline std::string stampFault(std::uint32_t sec, std::uint32_t nsec, std::int64_t now_ns,
                              StampUse use = StampUse::kMeasurement, const StampLimits& limits = {})
{
  if (nsec >= 1000000000u)
    return "stamp nsecs >= 1e9 (not normalised)";
  if (use == StampUse::kStaticTransform)
    return {};
  if (use == StampUse::kMeasurement)
  {
    if (sec == 0 && nsec == 0)
      return "stamp is zero (unset)";
    // Both are below 2^32 s in nanoseconds (< 2^63): the difference cannot overflow.
    const std::int64_t offset = static_cast<std::int64_t>(sec) * 1000000000LL + nsec - now_ns;
    if (now_ns != 0 && offset > limits.max_ahead_ns)
      return "stamp too far ahead of the clock (more than tf2's cache length)";
    if (offset > kMaxClockOffsetNs)
      return "stamp more than 2^31 s ahead of the clock";
    if (offset < -kMaxClockOffsetNs)
      return "stamp more than 2^31 s behind the clock";
  }
  const double last_usable =
    static_cast<double>(std::numeric_limits<std::uint32_t>::max()) - std::ceil(limits.end_margin);
  if (static_cast<double>(sec) + nsec * 1e-9 > last_usable)
    return "stamp too close to the end of ROS time (2^32 s) for time arithmetic";
  return {};
}

// ---------------------------------------------------------------- frame ids

/// A frame id as tf2 wants it: without the one leading '/' of tf1-era drivers and bags ("/laser"
/// -> "laser"), as tf2 and tf2_ros's MessageFilter strip it. `stripped` (when given) tells
/// whether a slash was removed. An empty result is malformed.
inline std::string tf2FrameId(const std::string& frame_id, bool* stripped = nullptr)
{
  const bool slash = !frame_id.empty() && frame_id[0] == '/';
  if (stripped != nullptr)
    *stripped = slash;
  return slash ? frame_id.substr(1) : frame_id;
}

/// tf2FrameId for the frame ids of one input, calling `warn_once(frame_id, used)` the first time
/// it strips a slash (a driver that sends one sends it in every message). Not thread-safe: call
/// it under the owner's lock.
class FrameIdNormaliser
{
public:
  using Warning = std::function<void(const std::string& frame_id, const std::string& used)>;

  explicit FrameIdNormaliser(Warning warn_once = {}) : warn_once_(std::move(warn_once)) {}

  std::string operator()(const std::string& frame_id)
  {
    bool stripped = false;
    std::string used = tf2FrameId(frame_id, &stripped);
    if (stripped && !warned_)
    {
      warned_ = true;
      if (warn_once_)
        warn_once_(frame_id, used);
    }
    return used;
  }

private:
  Warning warn_once_;
  bool warned_ = false;
};

// ---------------------------------------------------------------- transforms

/// True when translation and rotation (geometry_msgs::Transform-like) are all finite. tf2 refuses
/// NaN but keeps an infinite translation, and a chain of finite transforms can sum to infinity.
template <class Transform>
bool transformIsFinite(const Transform& t)
{
  return std::isfinite(t.translation.x) && std::isfinite(t.translation.y) && std::isfinite(t.translation.z) &&
         std::isfinite(t.rotation.x) && std::isfinite(t.rotation.y) && std::isfinite(t.rotation.z) &&
         std::isfinite(t.rotation.w);
}

/// "" when tf2 can store the transform (geometry_msgs::TransformStamped-like), otherwise why
/// not. tf2 checks most of these too, but logs each refusal without
/// throttle (a faulty publisher at 100 Hz floods the log); an infinite translation it does not
/// refuse at all.
template <class TransformStamped>
std::string transformFault(const TransformStamped& t)
{
  if (t.header.frame_id.empty() || t.child_frame_id.empty())
    return "frame_id or child_frame_id is empty";
  if (tf2FrameId(t.header.frame_id) == tf2FrameId(t.child_frame_id))
    return "a frame cannot be its own parent";
  if (!transformIsFinite(t.transform))
    return "translation or rotation is not finite (tf2 itself refuses only NaN)";
  const auto& q = t.transform.rotation;
  // tf2's own limit for a normalised quaternion.
  if (std::fabs(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w - 1.0) > 0.01)
    return "the rotation is not a unit quaternion";
  return {};
}

/// Decides which /tf and /tf_static transforms go into a tf2 buffer: the transform checks, the
/// stamp rules (a static transform is timeless, a dynamic one a measurement; max_ahead_ns is the
/// buffer's cache length), and static frames stay static. tf2 keeps one parent and one cache per
/// child frame: a /tf transform about a child that /tf_static already holds would replace the
/// static transform for good (and that frame would then expire when the /tf publisher stops);
/// two publishers disagreeing about a frame is a mistake to report, and the static one, declared
/// timeless, wins. A later /tf_static transform of the same child replaces the static one, as in
/// tf2. Not thread-safe: call it under the owner's lock.
class TransformGate
{
public:
  template <class TransformStamped>
  std::string fault(const TransformStamped& t, bool is_static, std::int64_t now_ns, std::int64_t max_ahead_ns)
  {
    if (std::string f = transformFault(t); !f.empty())
      return f;
    if (std::string f = stampFault(t.header.stamp.sec, t.header.stamp.nsec, now_ns,
                                   is_static ? StampUse::kStaticTransform : StampUse::kMeasurement,
                                   StampLimits{ max_ahead_ns, static_cast<double>(max_ahead_ns) * 1e-9 });
        !f.empty())
      return f;
    std::string child = tf2FrameId(t.child_frame_id);
    if (is_static)
      static_parents_[std::move(child)] = tf2FrameId(t.header.frame_id);
    else if (static_parents_.count(child) != 0)
      return "the child frame has a static transform (from /tf_static), which this /tf transform would replace "
             "for good";
    return {};
  }

  /// The parent of a child frame held static, or "" when it is not.
  std::string staticParent(const std::string& child) const
  {
    const auto it = static_parents_.find(tf2FrameId(child));
    return it == static_parents_.end() ? std::string() : it->second;
  }

private:
  std::unordered_map<std::string, std::string> static_parents_;  ///< child -> parent, both as tf2 wants them
};

}  // namespace laserscan_common
