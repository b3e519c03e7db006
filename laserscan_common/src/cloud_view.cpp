#include "laserscan_common/cloud_view.hpp"

namespace laserscan_common
{
std::size_t fieldTypeSize(std::uint8_t datatype)
{
  switch (datatype)
  {
    case 1:
    case 2:
      return 1;
    case 3:
    case 4:
      return 2;
    case 5:
    case 6:
    case 7:
      return 4;
    case 8:
      return 8;
    default:
      return 0;
  }
}

namespace
{
const FieldDescription* findField(const CloudLayout& layout, const std::string& name)
{
  for (const auto& f : layout.fields)
    if (f.name == name)
      return &f;
  return nullptr;
}
}  // namespace

std::string makeCloudView(const CloudLayout& layout, const std::uint8_t* data, std::size_t data_size,
                          const std::string& intensity_field, CloudView& view, std::string* intensity_note)
{
  if (layout.is_bigendian)
    return "is_bigendian is true (only little-endian data is supported)";

  const FieldDescription* xyz[3] = { findField(layout, "x"), findField(layout, "y"), findField(layout, "z") };
  const char* names[3] = { "x", "y", "z" };
  for (int i = 0; i < 3; ++i)
  {
    if (!xyz[i])
      return std::string("field '") + names[i] + "' is missing";
    if (xyz[i]->datatype != static_cast<std::uint8_t>(FieldType::Float32) &&
        xyz[i]->datatype != static_cast<std::uint8_t>(FieldType::Float64))
      return std::string("field '") + names[i] + "' has datatype " + std::to_string(xyz[i]->datatype) +
             " (only FLOAT32=7 and FLOAT64=8 are supported)";
    if (xyz[i]->datatype != xyz[0]->datatype)
      return "fields x, y and z do not share one datatype";
    if (xyz[i]->count < 1)
      return std::string("field '") + names[i] + "' has count 0";
    if (static_cast<std::uint64_t>(xyz[i]->offset) + fieldTypeSize(xyz[i]->datatype) > layout.point_step)
      return std::string("field '") + names[i] + "' (offset " + std::to_string(xyz[i]->offset) +
             ") does not fit in point_step " + std::to_string(layout.point_step);
  }

  const std::uint64_t min_row = static_cast<std::uint64_t>(layout.width) * layout.point_step;
  if (layout.width > 0 && layout.height > 0)
  {
    if (layout.row_step < min_row)
      return "row_step " + std::to_string(layout.row_step) + " is smaller than width*point_step " +
             std::to_string(min_row);
    const std::uint64_t expected = static_cast<std::uint64_t>(layout.row_step) * layout.height;
    if (data_size != expected)
      return "data size " + std::to_string(data_size) + " does not match row_step*height " + std::to_string(expected) +
             " (width " + std::to_string(layout.width) + ", height " + std::to_string(layout.height) + ", point_step " +
             std::to_string(layout.point_step) + ")";
    if (!data)
      return "data pointer is null";
  }
  else if (data_size != 0)
  {
    return "width*height is 0 but data holds " + std::to_string(data_size) + " bytes";
  }

  view = CloudView{};
  view.data = data;
  view.width = layout.width;
  view.height = layout.height;
  view.point_step = layout.point_step;
  view.row_step = layout.row_step;
  view.x_offset = xyz[0]->offset;
  view.y_offset = xyz[1]->offset;
  view.z_offset = xyz[2]->offset;
  view.xyz_type = static_cast<FieldType>(xyz[0]->datatype);

  if (!intensity_field.empty())
  {
    const FieldDescription* f = findField(layout, intensity_field);
    std::string note;
    if (!f)
      note = "intensity field '" + intensity_field + "' is not in the cloud";
    else if (fieldTypeSize(f->datatype) == 0)
      note = "intensity field '" + intensity_field + "' has unknown datatype " + std::to_string(f->datatype);
    else if (static_cast<std::uint64_t>(f->offset) + fieldTypeSize(f->datatype) > layout.point_step)
      note = "intensity field '" + intensity_field + "' does not fit in point_step";
    else
    {
      view.has_intensity = true;
      view.intensity_offset = f->offset;
      view.intensity_type = static_cast<FieldType>(f->datatype);
    }
    if (intensity_note)
      *intensity_note = note;
  }
  return {};
}

}  // namespace laserscan_common
