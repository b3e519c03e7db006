// Bounded queue of robot poses (odometry) with interpolation in time:
// linear for the position, slerp along the shortest arc for the orientation.
// Requests before the oldest entry use the oldest, after the newest use the newest
// (no extrapolation). ROS-free; times are real-valued seconds.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <vector>

namespace multi_laserscan_merger
{

struct Pose
{
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();

  Eigen::Isometry3d toIsometry() const;
};

/// Slerp that always takes the shortest arc (q and -q are the same rotation).
/// u = 0 gives a, u = 1 gives b (or -b). Inputs must be unit quaternions.
Eigen::Quaterniond slerpShortest(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b, double u);

class OdometryBuffer
{
public:
  enum class AddResult
  {
    kAdded,             ///< appended (or replaced an entry with the same time)
    kOutOfOrder,        ///< older than the newest entry by less than the jump threshold: ignored
    kClearedBackwards,  ///< older by the jump threshold or more (time jumped back, e.g. a bag
                        ///< played in a loop): the buffer was cleared, then this entry kept
    kRejected           ///< non-finite time/position or degenerate quaternion: ignored
  };

  /// capacity: entries kept (oldest dropped first). jump_back_threshold (s): a message
  /// older than the newest by at least this much means time jumped back; a smaller step
  /// back is a message delivered out of order and is ignored.
  explicit OdometryBuffer(std::size_t capacity = 100, double jump_back_threshold = 1.0);

  /// Adds the pose of the robot at time t (s). Orientation is normalised here.
  AddResult add(double t, const Eigen::Vector3d& position, const Eigen::Quaterniond& orientation);

  /// Interpolated pose at t; false when the buffer is empty.
  bool poseAt(double t, Pose& out) const;

  /// Motion of the robot between t_from and t_to, expressed in the robot frame at t_to:
  /// P(t_to)^-1 * P(t_from). A point seen in the robot frame at t_from, multiplied by it,
  /// is where that point is in the robot frame at t_to. Identity when empty.
  Eigen::Isometry3d motion(double t_from, double t_to) const;

  void clear() { entries_.clear(); }
  bool empty() const { return entries_.empty(); }
  std::size_t size() const { return entries_.size(); }
  std::size_t capacity() const { return capacity_; }
  double oldestTime() const;  ///< NaN when empty
  double newestTime() const;  ///< NaN when empty

private:
  struct Entry
  {
    double t;
    Pose pose;
  };
  std::size_t capacity_;
  double jump_back_threshold_;
  std::vector<Entry> entries_;  ///< contiguous: the look-up (hot) is a binary search; dropping the oldest moves <=
                                ///< capacity entries at odometry rate
};

}  // namespace multi_laserscan_merger
