// Zero-copy view over a depth image (sensor_msgs/Image + CameraInfo), ROS-free.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>

namespace depth_filter_scan_converter
{
/// The depth encodings the converter reads, as sensor_msgs/image_encodings names them.
enum class DepthEncoding : std::uint8_t
{
  UInt16Millimetres,  ///< "16UC1" (or "mono16"): millimetres, 0 = no depth
  Float32Metres       ///< "32FC1": metres, 0 / NaN / Inf = no depth
};

/// Pinhole intrinsics in pixels.
struct Intrinsics
{
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
};

/// The buffer is not owned: it must outlive the view. Pixel (u, v) with depth d is the point
/// ((u - cx) * d / fx, (v - cy) * d / fy, d) of the camera's optical frame, computed in float in
/// the order depth_image_proc's point_cloud_xyz uses, so both paths give the same points.
struct DepthImageView
{
  const std::uint8_t* data = nullptr;
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::uint32_t row_step = 0;  ///< bytes per row (sensor_msgs/Image step)
  DepthEncoding encoding = DepthEncoding::UInt16Millimetres;
  Intrinsics intrinsics;

  std::size_t size() const { return static_cast<std::size_t>(width) * height; }
};

/// Everything of a sensor_msgs/Image header that decides whether its bytes can be read.
struct ImageLayout
{
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::uint32_t step = 0;
  std::string encoding;
  bool is_bigendian = false;
};

/// The parts of a sensor_msgs/CameraInfo the converter uses.
struct CameraModel
{
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  double K[9] = {};   ///< row-major 3x3 camera matrix (raw image)
  double P[12] = {};  ///< row-major 3x4 projection matrix (rectified image)
};

/// The layout of an image message (sensor_msgs::Image or anything with its field names); no
/// checks here, makeDepthImageView does them. A template: the core stays free of ROS.
template <class Image>
ImageLayout imageLayoutOf(const Image& image)
{
  return { image.width, image.height, image.step, image.encoding, image.is_bigendian != 0 };
}

/// The camera model of a camera info message (sensor_msgs::CameraInfo or alike).
template <class CameraInfo>
CameraModel cameraModelOf(const CameraInfo& info)
{
  CameraModel model;
  model.width = info.width;
  model.height = info.height;
  std::copy(info.K.begin(), info.K.end(), model.K);
  std::copy(info.P.begin(), info.P.end(), model.P);
  return model;
}

/// Intrinsics of `model`: from P for a rectified image (as depth_image_proc does), else from K.
/// Returns "" or the reason they are unusable (focal lengths not finite and > 0, centre not finite).
std::string intrinsicsOf(const CameraModel& model, bool rectified, Intrinsics& out);

/// Checks the image against its buffer and camera model and fills `view`. Returns "" when the
/// image is usable, else the reason it is not (unsupported encoding named, sizes that differ
/// from the camera model, step or data size that do not fit, big-endian data).
std::string makeDepthImageView(const ImageLayout& layout, const std::uint8_t* data, std::size_t data_size,
                               const CameraModel& model, bool rectified, DepthImageView& view);

}  // namespace depth_filter_scan_converter
