// Zero-copy view over a raw point buffer laid out like sensor_msgs/PointCloud2 (ROS-free): the
// one reading of a cloud's x/y/z fields, strides and rows, organized or not, for the depth
// converters and the navigator.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace laserscan_common
{
/// Field datatypes, numbered as in sensor_msgs/PointField.
enum class FieldType : std::uint8_t
{
  Int8 = 1,
  UInt8 = 2,
  Int16 = 3,
  UInt16 = 4,
  Int32 = 5,
  UInt32 = 6,
  Float32 = 7,
  Float64 = 8
};

/// Size in bytes of one value of the given type; 0 for an unknown code.
std::size_t fieldTypeSize(std::uint8_t datatype);

/// Describes one field of the point layout (mirrors sensor_msgs/PointField).
struct FieldDescription
{
  std::string name;
  std::uint32_t offset = 0;
  std::uint8_t datatype = 0;
  std::uint32_t count = 1;
};

/// The buffer is not owned: it must outlive the view.
struct CloudView
{
  const std::uint8_t* data = nullptr;
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::uint32_t point_step = 0;
  std::uint32_t row_step = 0;
  std::uint32_t x_offset = 0;
  std::uint32_t y_offset = 0;
  std::uint32_t z_offset = 0;
  FieldType xyz_type = FieldType::Float32;  ///< Float32 or Float64
  bool has_intensity = false;
  std::uint32_t intensity_offset = 0;
  FieldType intensity_type = FieldType::Float32;

  std::size_t size() const { return static_cast<std::size_t>(width) * height; }
  /// The first byte of the point in `row` and `column` (rows are row_step bytes apart).
  const std::uint8_t* point(std::size_t row, std::size_t column) const
  {
    return data + row * row_step + column * point_step;
  }
};

/// Reads one value of a field as double (any PointField datatype).
inline double readField(const std::uint8_t* p, FieldType type)
{
  const auto load = [p](auto value) {
    std::memcpy(&value, p, sizeof value);
    return static_cast<double>(value);
  };
  switch (type)
  {
    case FieldType::Int8:
      return load(std::int8_t{});
    case FieldType::UInt8:
      return load(std::uint8_t{});
    case FieldType::Int16:
      return load(std::int16_t{});
    case FieldType::UInt16:
      return load(std::uint16_t{});
    case FieldType::Int32:
      return load(std::int32_t{});
    case FieldType::UInt32:
      return load(std::uint32_t{});
    case FieldType::Float32:
      return load(float{});
    case FieldType::Float64:
      return load(double{});
  }
  return std::numeric_limits<double>::quiet_NaN();
}

/// Everything of a PointCloud2 header that decides whether its bytes can be read.
struct CloudLayout
{
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::uint32_t point_step = 0;
  std::uint32_t row_step = 0;
  bool is_bigendian = false;
  std::vector<FieldDescription> fields;
};

/// The layout of a PointCloud2-like message (sensor_msgs::PointCloud2, pcl::PCLPointCloud2: the
/// same field names and datatype codes); no checks here, makeCloudView does them. A template:
/// the core stays free of ROS and PCL.
template <class Cloud>
CloudLayout cloudLayoutOf(const Cloud& cloud)
{
  CloudLayout layout;
  layout.width = cloud.width;
  layout.height = cloud.height;
  layout.point_step = cloud.point_step;
  layout.row_step = cloud.row_step;
  layout.is_bigendian = cloud.is_bigendian != 0;
  for (const auto& f : cloud.fields)
    layout.fields.push_back({ f.name, f.offset, static_cast<std::uint8_t>(f.datatype), f.count });
  return layout;
}

/// Checks the layout against the buffer and fills `view`.
/// Returns an empty string when the cloud is usable, else the reason it is not.
/// A missing or unusable `intensity_field` is not an error: view.has_intensity stays false
/// and `intensity_note` (if given) says why.
std::string makeCloudView(const CloudLayout& layout, const std::uint8_t* data, std::size_t data_size,
                          const std::string& intensity_field, CloudView& view, std::string* intensity_note = nullptr);

}  // namespace laserscan_common
