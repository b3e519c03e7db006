#include "depth_filter_scan_converter/depth_image_view.hpp"

#include <cmath>

namespace depth_filter_scan_converter
{
std::string intrinsicsOf(const CameraModel& model, bool rectified, Intrinsics& out)
{
  const char* source = rectified ? "P" : "K";
  Intrinsics in;
  if (rectified)
    in = { model.P[0], model.P[5], model.P[2], model.P[6] };
  else
    in = { model.K[0], model.K[4], model.K[2], model.K[5] };
  if (!(std::isfinite(in.fx) && in.fx > 0.0 && std::isfinite(in.fy) && in.fy > 0.0))
    return std::string("camera_info ") + source + " has focal lengths fx " + std::to_string(in.fx) + ", fy " +
           std::to_string(in.fy) + " (must be finite and > 0; is the camera calibrated?)";
  if (!(std::isfinite(in.cx) && std::isfinite(in.cy)))
    return std::string("camera_info ") + source + " has a principal point that is not finite";
  out = in;
  return {};
}

std::string makeDepthImageView(const ImageLayout& layout, const std::uint8_t* data, std::size_t data_size,
                               const CameraModel& model, bool rectified, DepthImageView& view)
{
  DepthEncoding encoding;
  std::uint32_t pixel_size;
  if (layout.encoding == "16UC1" || layout.encoding == "mono16")
  {
    encoding = DepthEncoding::UInt16Millimetres;
    pixel_size = 2;
  }
  else if (layout.encoding == "32FC1")
  {
    encoding = DepthEncoding::Float32Metres;
    pixel_size = 4;
  }
  else
  {
    return "encoding '" + layout.encoding + "' is not a depth encoding (16UC1 in millimetres or 32FC1 in metres)";
  }
  if (layout.is_bigendian)
    return "is_bigendian is true (only little-endian data is supported)";
  if (layout.width != model.width || layout.height != model.height)
    return "image is " + std::to_string(layout.width) + "x" + std::to_string(layout.height) + " but camera_info is " +
           std::to_string(model.width) + "x" + std::to_string(model.height);
  const std::uint64_t min_step = static_cast<std::uint64_t>(layout.width) * pixel_size;
  if (layout.step < min_step)
    return "step " + std::to_string(layout.step) + " is smaller than width*" + std::to_string(pixel_size) + " " +
           std::to_string(min_step);
  const std::uint64_t expected = static_cast<std::uint64_t>(layout.step) * layout.height;
  if (data_size != expected)
    return "data size " + std::to_string(data_size) + " does not match step*height " + std::to_string(expected) +
           " (width " + std::to_string(layout.width) + ", height " + std::to_string(layout.height) + ", " +
           layout.encoding + ")";
  if (expected > 0 && !data)
    return "data pointer is null";
  Intrinsics intrinsics;
  const std::string bad_model = intrinsicsOf(model, rectified, intrinsics);
  if (!bad_model.empty())
    return bad_model;

  view = DepthImageView{};
  view.data = data;
  view.width = layout.width;
  view.height = layout.height;
  view.row_step = layout.step;
  view.encoding = encoding;
  view.intrinsics = intrinsics;
  return {};
}

}  // namespace depth_filter_scan_converter
