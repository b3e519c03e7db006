// Depth images for the tests and the benchmark, and the path they are compared with:
// depth_image_proc's own conversion (what its point_cloud_xyz nodelet publishes) + the cloud core.
#pragma once

#include <depth_image_proc/depth_conversions.h>
#include <image_geometry/pinhole_camera_model.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include <boost/make_shared.hpp>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "cloud_fixtures.hpp"
#include "depth_filter_scan_converter/projector.hpp"
#include "depth_filter_scan_converter/depth_image_view.hpp"

namespace depth_filter_scan_converter
{
namespace test
{
struct DepthFrame
{
  sensor_msgs::ImagePtr image;
  sensor_msgs::CameraInfoPtr info;
};

/// A depth image of an organized cloud (camera frame, width x height) with the given intrinsics:
/// the z channel, as 16UC1 millimetres (rounded; 0 = no depth) or 32FC1 metres (NaN = no depth).
inline DepthFrame depthFrame(const Points& pts, std::uint32_t width, std::uint32_t height, const Intrinsics& k,
                             const std::string& encoding)
{
  DepthFrame f;
  f.image = boost::make_shared<sensor_msgs::Image>();
  f.image->header.frame_id = "camera_optical";
  f.image->width = width;
  f.image->height = height;
  f.image->encoding = encoding;
  const bool mm = encoding == "16UC1";
  f.image->step = width * (mm ? 2 : 4);
  f.image->data.resize(static_cast<std::size_t>(f.image->step) * height);
  for (std::size_t i = 0; i < pts.size(); ++i)
  {
    const double z = pts[i].z();
    std::uint8_t* out = f.image->data.data() + i * (mm ? 2 : 4);
    if (mm)
    {
      const std::uint16_t d = std::isfinite(z) && z > 0 ? static_cast<std::uint16_t>(std::lround(z * 1000.0)) : 0;
      std::memcpy(out, &d, 2);
    }
    else
    {
      const float d = std::isfinite(z) && z > 0 ? static_cast<float>(z) : std::nanf("");
      std::memcpy(out, &d, 4);
    }
  }
  f.info = boost::make_shared<sensor_msgs::CameraInfo>();
  f.info->header = f.image->header;
  f.info->width = width;
  f.info->height = height;
  f.info->distortion_model = "plumb_bob";
  f.info->D.assign(5, 0.0);
  f.info->K = { k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1 };
  f.info->R = { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
  f.info->P = { k.fx, 0, k.cx, 0, 0, k.fy, k.cy, 0, 0, 0, 1, 0 };
  return f;
}

/// The frame's view through the core's checks, as the nodelet makes it: "" or why it is unusable.
inline std::string makeFrameView(const DepthFrame& f, bool rectified, DepthImageView& v)
{
  return makeDepthImageView(imageLayoutOf(*f.image), f.image->data.data(), f.image->data.size(), cameraModelOf(*f.info),
                            rectified, v);
}

inline DepthImageView imageView(const DepthFrame& f, bool rectified = true)
{
  DepthImageView v;
  const std::string reason = makeFrameView(f, rectified, v);
  if (!reason.empty())
    throw std::runtime_error(reason);
  return v;
}

/// What depth_image_proc/point_cloud_xyz publishes for the frame (its own conversion code).
inline sensor_msgs::PointCloud2Ptr pointCloudXyz(const DepthFrame& f)
{
  auto cloud = boost::make_shared<sensor_msgs::PointCloud2>();
  cloud->header = f.image->header;
  cloud->height = f.image->height;
  cloud->width = f.image->width;
  cloud->is_dense = false;
  cloud->is_bigendian = false;
  sensor_msgs::PointCloud2Modifier modifier(*cloud);
  modifier.setPointCloud2FieldsByString(1, "xyz");
  image_geometry::PinholeCameraModel model;
  model.fromCameraInfo(f.info);
  if (f.image->encoding == "16UC1")
    depth_image_proc::convert<std::uint16_t>(f.image, cloud, model);
  else
    depth_image_proc::convert<float>(f.image, cloud, model);
  return cloud;
}

inline CloudView cloudView(const sensor_msgs::PointCloud2& cloud)
{
  CloudView v;
  const std::string reason = makeCloudView(cloudLayoutOf(cloud), cloud.data.data(), cloud.data.size(), "", v);
  if (!reason.empty())
    throw std::runtime_error(reason);
  return v;
}

/// Intrinsics of the organized cloud `pts` (width x height) fitted by least squares from
/// x/z = (u - cx) / fx and y/z = (v - cy) / fy over its valid pixels.
inline Intrinsics fitIntrinsics(const Points& pts, std::uint32_t width)
{
  // u = fx * (x/z) + cx: a line fit per axis.
  double n = 0, sa = 0, sb = 0, saa = 0, sab = 0;  // a = x/z, b = u
  double sc = 0, sd = 0, scc = 0, scd = 0;         // c = y/z, d = v
  for (std::size_t i = 0; i < pts.size(); ++i)
  {
    const Vector3d& p = pts[i];
    if (!(std::isfinite(p.z()) && p.z() > 0))
      continue;
    const double a = p.x() / p.z(), b = static_cast<double>(i % width);
    const double c = p.y() / p.z(), d = static_cast<double>(i / width);
    n += 1, sa += a, sb += b, saa += a * a, sab += a * b;
    sc += c, sd += d, scc += c * c, scd += c * d;
  }
  Intrinsics k;
  k.fx = (n * sab - sa * sb) / (n * saa - sa * sa);
  k.cx = (sb - k.fx * sa) / n;
  k.fy = (n * scd - sc * sd) / (n * scc - sc * sc);
  k.cy = (sd - k.fy * sc) / n;
  return k;
}

/// A room (floor, wall 3.5 m ahead, table, cabinet, chair) seen by a camera 0.6 m high pitched
/// 20 degrees down, width x height pixels with an 87 degree horizontal field of view.
inline DepthFrame roomFrame(std::uint32_t width, std::uint32_t height, const std::string& encoding,
                            Eigen::Isometry3d& camera_to_reference)
{
  Scene scene;
  scene.wall_x = 3.5;
  scene.boxes.push_back({ Vector3d(1.2, -0.9, 0.70), Vector3d(2.0, 0.1, 0.75) });  // table top
  scene.boxes.push_back({ Vector3d(2.6, 0.4, 0.0), Vector3d(3.0, 1.4, 1.8) });     // cabinet
  scene.boxes.push_back({ Vector3d(1.0, 0.5, 0.0), Vector3d(1.45, 0.95, 0.45) });  // chair
  camera_to_reference = cameraMount(0.6, 20 * kDeg);
  const double hfov = 87 * kDeg;
  const Points pts = render(scene, camera_to_reference, static_cast<int>(width), static_cast<int>(height), hfov);
  const double f = (width / 2.0) / std::tan(hfov / 2.0);
  return depthFrame(pts, width, height, { f, f, (width - 1) / 2.0, (height - 1) / 2.0 }, encoding);
}

}  // namespace test
}  // namespace depth_filter_scan_converter
