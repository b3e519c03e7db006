// The 3D method the unified scan is compared with: an OctoMap OcTree built the way
// octomap_server builds it (each cloud inserted by ray casting from its sensor's origin, with a
// maximum range and octomap_server's sensor model; lazy evaluation of the inner nodes, made
// consistent and pruned after every cloud), its 2D map projected from the robot's height
// band, and the depth-image and laser-scan conversions that feed it. ROS-free: points in
// metres, frames as Eigen isometries.
#pragma once

#include <Eigen/Geometry>
#include <octomap/OcTree.h>

#include <cstdint>
#include <string>
#include <vector>

namespace scan_evaluation_tools
{
/// octomap_server's parameters, with its defaults (sensor_model/hit, miss, min, max) except
/// the maximum range, which octomap_server leaves unlimited and the robot's sensors do not.
struct OctoMapParameters
{
  double resolution = 0.05;  // m, edge of the smallest voxel
  double max_range = 8.0;    // m from the sensor's origin; farther points only clear up to it
  double prob_hit = 0.7;     // occupancy probability of a voxel a point ends in
  double prob_miss = 0.4;    // ... of a voxel a ray passes through
  double clamp_min = 0.12;   // the log-odds clamping that keeps a voxel able to change
  double clamp_max = 0.97;

  /// Throws laserscan_common::ParameterError naming the parameter and the reason.
  void validate() const;
};

/// A pinhole depth camera as depth_image_proc's point_cloud_xyz reads it from camera_info:
/// the projection matrix P of a rectified image (fx = P[0], cx = P[2], fy = P[5], cy = P[6]).
struct PinholeCamera
{
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
};

/// The depth image's points in its optical frame (z forward, x right, y down), as
/// point_cloud_xyz computes them: x = (u - cx) z / fx, y = (v - cy) z / fy. `depth` holds
/// `height` rows of `width` values `row_step` bytes apart, either 16UC1 (millimetres) or 32FC1
/// (metres); a zero, NaN or infinite depth is no measurement and gives no point (point_cloud_xyz
/// gives NaN, which OctoMap cannot take). `encoding` is "16UC1" or "32FC1"; throws
/// std::invalid_argument on another encoding or a buffer too small for the image.
void depthImagePoints(const std::uint8_t* data, std::size_t size, std::uint32_t width, std::uint32_t height,
                      std::uint32_t row_step, const std::string& encoding, bool big_endian, const PinholeCamera& camera,
                      octomap::Pointcloud& points);

/// The returns of a laser scan in its frame: beam i at angle_min + i * angle_increment, every
/// finite range in [range_min, range_max] (REP 117: +Inf, -Inf and NaN say nothing about where
/// an obstacle is; no return clears nothing, as in the 2D maps it is compared with).
void scanPoints(const std::vector<float>& ranges, double angle_min, double angle_increment, double range_min,
                double range_max, octomap::Pointcloud& points);

/// A 2D occupancy grid, map_server's values: -1 unknown, 0 free, 100 occupied. Cell
/// (row, col) covers x in origin_x + [col, col + 1) * resolution, y likewise with row.
struct ProjectedMap
{
  double origin_x = 0.0;
  double origin_y = 0.0;
  double resolution = 0.0;
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::vector<std::int8_t> cells;  // row-major, row 0 at origin_y

  std::int8_t at(double x, double y) const;  // -1 outside the grid
  std::size_t occupied() const;
};

class OccupancyMap3D
{
public:
  explicit OccupancyMap3D(const OctoMapParameters& parameters);

  /// Inserts one cloud given in the map frame, measured from `origin` (map frame): octomap's
  /// insertPointCloud with lazy evaluation (the inner nodes are left for update()).
  void insert(const octomap::Pointcloud& points_in_map, const octomap::point3d& origin);

  /// Makes the inner nodes consistent and prunes the tree, so that the map is usable: after
  /// every cloud in a live map, as octomap_server prunes and publishes after every cloud.
  void update();

  /// octomap_server's projected map: the leaves whose centre lies in [z_min, z_max]; a cell is
  /// occupied when any of its voxels in the band is, free when it has only free ones, unknown
  /// otherwise. A pruned leaf larger than a cell marks every cell it covers. The grid spans the
  /// tree's extent at the tree's resolution.
  ProjectedMap project(double z_min, double z_max) const;

  const octomap::OcTree& tree() const { return tree_; }
  std::size_t pointsInserted() const { return points_inserted_; }
  std::size_t cloudsInserted() const { return clouds_inserted_; }

private:
  OctoMapParameters parameters_;
  octomap::OcTree tree_;
  std::size_t points_inserted_ = 0;
  std::size_t clouds_inserted_ = 0;
};

/// Transforms `points` (in the sensor's frame) into the map frame in place.
void transformPoints(const Eigen::Isometry3d& map_from_sensor, octomap::Pointcloud& points);

}  // namespace scan_evaluation_tools
