// Test and benchmark helper: reads a PCD file with PCL's own reader (the project does not
// own a PCD parser) and hands its bytes to the core as a CloudLayout plus buffer, exactly as
// the nodelet does with a PointCloud2, so recorded data takes the production path.
#pragma once

#include <pcl/PCLPointCloud2.h>
#include <pcl/PCLPointField.h>
#include <pcl/io/pcd_io.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "depth_filter_scan_converter/projector.hpp"

namespace depth_filter_scan_converter
{
namespace test
{
// The datatype codes are copied as numbers: this holds only while PCL numbers them like
// sensor_msgs/PointField (anything else the core rejects as an unknown type).
static_assert(pcl::PCLPointField::INT8 == static_cast<int>(FieldType::Int8) &&
                pcl::PCLPointField::UINT8 == static_cast<int>(FieldType::UInt8) &&
                pcl::PCLPointField::INT16 == static_cast<int>(FieldType::Int16) &&
                pcl::PCLPointField::UINT16 == static_cast<int>(FieldType::UInt16) &&
                pcl::PCLPointField::INT32 == static_cast<int>(FieldType::Int32) &&
                pcl::PCLPointField::UINT32 == static_cast<int>(FieldType::UInt32) &&
                pcl::PCLPointField::FLOAT32 == static_cast<int>(FieldType::Float32) &&
                pcl::PCLPointField::FLOAT64 == static_cast<int>(FieldType::Float64),
              "PCL field type codes differ from sensor_msgs/PointField");

struct PcdCloud
{
  CloudLayout layout;
  std::vector<std::uint8_t> data;
};

/// Loads a PCD file (any DATA mode PCL reads); throws naming the file when PCL cannot.
inline PcdCloud readPcd(const std::string& path)
{
  pcl::PCLPointCloud2 cloud;
  if (pcl::io::loadPCDFile(path, cloud) < 0)
    throw std::runtime_error("PCL cannot read " + path);
  PcdCloud out;
  out.layout = cloudLayoutOf(cloud);
  out.data = std::move(cloud.data);  // the interleaved bytes as PCL laid them out, no copy
  return out;
}

}  // namespace test
}  // namespace depth_filter_scan_converter
