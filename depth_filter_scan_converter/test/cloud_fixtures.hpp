// Synthetic clouds for tests and benchmarks: camera mounts, a ray-cast scene (floor, wall,
// boxes) and PointCloud2-like buffers with any layout.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "depth_filter_scan_converter/projector.hpp"

namespace depth_filter_scan_converter
{
namespace test
{
namespace dfsc = depth_filter_scan_converter;
using Eigen::Vector3d;
using Points = std::vector<Vector3d>;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kDeg = M_PI / 180.0;

// Camera optical frame (z forward, x right, y down) at `height` above the reference origin,
// pitched down by `pitch_down`, rolled by `roll` (about the viewing direction), turned by `yaw`.
inline Eigen::Isometry3d cameraMount(double height, double pitch_down, double roll = 0.0, double yaw = 0.0,
                                     double x = 0.0, double y = 0.0)
{
  Eigen::Matrix3d optical_to_body;
  optical_to_body << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = (Eigen::AngleAxisd(yaw, Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch_down, Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll, Vector3d::UnitX()))
                 .toRotationMatrix() *
               optical_to_body;
  t.translation() = Vector3d(x, y, height);
  return t;
}

// A cloud laid out like a PointCloud2: x, y, z of type T at x_offset, then a float32 intensity.
struct TestCloud
{
  dfsc::CloudLayout layout;
  std::vector<std::uint8_t> data;

  dfsc::CloudView view(const std::string& intensity_field = "") const
  {
    dfsc::CloudView v;
    const std::string reason = dfsc::makeCloudView(layout, data.data(), data.size(), intensity_field, v);
    if (!reason.empty())
      throw std::runtime_error("test cloud rejected: " + reason);
    return v;
  }
};

template <typename T>
TestCloud makeCloud(const Points& pts, std::uint32_t width, std::uint32_t height, std::uint32_t x_offset = 0,
                    std::uint32_t extra_step = 0, std::uint32_t row_padding = 0, std::vector<float> intensity = {})
{
  if (pts.size() != static_cast<std::size_t>(width) * height)
    throw std::invalid_argument("makeCloud: point count does not match width*height");
  const std::uint8_t type = sizeof(T) == 4 ? 7 : 8;
  TestCloud c;
  c.layout.width = width;
  c.layout.height = height;
  const std::uint32_t i_off = x_offset + 3 * sizeof(T);
  c.layout.point_step = i_off + 4 + extra_step;
  c.layout.row_step = width * c.layout.point_step + row_padding;
  c.layout.fields = { { "x", x_offset, type, 1 },
                      { "y", static_cast<std::uint32_t>(x_offset + sizeof(T)), type, 1 },
                      { "z", static_cast<std::uint32_t>(x_offset + 2 * sizeof(T)), type, 1 },
                      { "intensity", i_off, 7, 1 } };
  c.data.assign(static_cast<std::size_t>(c.layout.row_step) * height, 0xAB);
  for (std::uint32_t r = 0; r < height; ++r)
    for (std::uint32_t col = 0; col < width; ++col)
    {
      const std::size_t i = static_cast<std::size_t>(r) * width + col;
      std::uint8_t* p = &c.data[static_cast<std::size_t>(r) * c.layout.row_step + col * c.layout.point_step];
      const T xyz[3] = { static_cast<T>(pts[i].x()), static_cast<T>(pts[i].y()), static_cast<T>(pts[i].z()) };
      std::memcpy(p + x_offset, xyz, sizeof xyz);
      const float in = intensity.empty() ? static_cast<float>(i) : intensity[i];
      std::memcpy(p + i_off, &in, sizeof in);
    }
  return c;
}

inline TestCloud makeCloud(const Points& pts)
{
  return makeCloud<float>(pts, static_cast<std::uint32_t>(pts.size()), 1);
}

// Points given in the reference frame, expressed in the camera frame.
inline Points toCamera(const Points& ref_points, const Eigen::Isometry3d& camera_to_reference)
{
  Points out;
  for (const auto& p : ref_points)
    out.push_back(camera_to_reference.inverse() * p);
  return out;
}

// Ray-cast scene in the reference frame: floor z = 0, optional wall x = wall_x, boxes.
struct Box
{
  Vector3d lo, hi;
};
struct Scene
{
  bool floor = true;
  double wall_x = kInf;
  std::vector<Box> boxes;

  double hit(const Vector3d& o, const Vector3d& d) const
  {
    double best = kInf;
    if (floor && d.z() < -1e-12)
    {
      const double t = -o.z() / d.z();
      if (t > 0)
        best = std::min(best, t);
    }
    if (std::isfinite(wall_x) && d.x() > 1e-12)
    {
      const double t = (wall_x - o.x()) / d.x();
      if (t > 0)
        best = std::min(best, t);
    }
    for (const auto& b : boxes)
    {
      double t0 = 0, t1 = kInf;
      for (int k = 0; k < 3; ++k)
      {
        if (std::fabs(d[k]) < 1e-12)
        {
          if (o[k] < b.lo[k] || o[k] > b.hi[k])
            t0 = kInf;
          continue;
        }
        double a = (b.lo[k] - o[k]) / d[k], c = (b.hi[k] - o[k]) / d[k];
        if (a > c)
          std::swap(a, c);
        t0 = std::max(t0, a);
        t1 = std::min(t1, c);
      }
      if (t0 <= t1 && t0 > 0)
        best = std::min(best, t0);
    }
    return best;
  }
};

// Organized cloud (camera frame) of a pinhole camera with the given horizontal field of view.
inline Points render(const Scene& scene, const Eigen::Isometry3d& cam, int width, int height, double hfov = 60 * kDeg)
{
  const double f = (width / 2.0) / std::tan(hfov / 2.0);
  Points out;
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u)
    {
      const Vector3d d_cam((u - (width - 1) / 2.0) / f, (v - (height - 1) / 2.0) / f, 1.0);
      const Vector3d d = cam.linear() * d_cam;
      const double t = scene.hit(cam.translation(), d);
      out.push_back(std::isfinite(t) ? Vector3d(t * d_cam) : Vector3d(kNaN, kNaN, kNaN));
    }
  return out;
}

}  // namespace test
}  // namespace depth_filter_scan_converter

namespace depth_filter_scan_converter
{
namespace test
{
/// Where five_people.pcd's camera really was, fitted once from the data (floor plane by RANSAC +
/// least squares on 32k floor points): floor normal in the optical frame and the camera's height
/// above that floor. The camera was about 1.31 m high and looked down by about 5.3 degrees.
inline Eigen::Vector3d fivePeopleFloorNormal()
{
  return Eigen::Vector3d(0.00650529, -0.99576888, -0.09166258).normalized();
}
constexpr double kFivePeopleCameraHeight = 1.3132385;

/// camera optical frame -> a base frame on the floor (z up) for five_people.pcd.
inline Eigen::Isometry3d fivePeopleMeasuredMount()
{
  // Rotate the floor normal onto the optical "up" (-y), then optical -> body axes.
  const Eigen::Matrix3d level =
    Eigen::Quaterniond::FromTwoVectors(fivePeopleFloorNormal(), -Eigen::Vector3d::UnitY()).toRotationMatrix();
  Eigen::Isometry3d t = cameraMount(kFivePeopleCameraHeight, 0.0);
  t.linear() = t.linear() * level;
  return t;
}
}  // namespace test
}  // namespace depth_filter_scan_converter
