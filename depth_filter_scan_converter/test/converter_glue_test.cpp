// The pieces the converters' ROS classes share that run without a ROS master, and the one home
// of the PointCloud2 -> CloudLayout conversion (the nodelet's path) against PCL's own cloud.
#include <gtest/gtest.h>
#include <pcl/PCLPointCloud2.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include <string>

#include "depth_filter_scan_converter/cloud_view.hpp"
#include "depth_filter_scan_converter/converter_glue.hpp"

namespace dfsc = depth_filter_scan_converter;

TEST(Describe, NamesTheParameterAsTheNodesLogIt)
{
  const laserscan_common::ParameterError e("min_height", "must be smaller than max_height");
  EXPECT_EQ(dfsc::describe(e), "parameter 'min_height': must be smaller than max_height");
  EXPECT_EQ(std::string(e.what()), "min_height: must be smaller than max_height");
}

TEST(CloudLayoutOf, SameLayoutFromAPointCloud2AndFromPcl)
{
  sensor_msgs::PointCloud2 cloud;
  cloud.height = 2;
  cloud.width = 3;
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2Fields(4, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32,
                                "z", 1, sensor_msgs::PointField::FLOAT32, "intensity", 1,
                                sensor_msgs::PointField::UINT16);
  const dfsc::CloudLayout layout = dfsc::cloudLayoutOf(cloud);
  EXPECT_EQ(layout.width, 3u);
  EXPECT_EQ(layout.height, 2u);
  EXPECT_EQ(layout.point_step, cloud.point_step);
  EXPECT_EQ(layout.row_step, cloud.row_step);
  EXPECT_FALSE(layout.is_bigendian);
  ASSERT_EQ(layout.fields.size(), 4u);
  EXPECT_EQ(layout.fields[3].name, "intensity");
  EXPECT_EQ(layout.fields[3].offset, 12u);
  EXPECT_EQ(layout.fields[3].datatype, static_cast<std::uint8_t>(dfsc::FieldType::UInt16));
  dfsc::CloudView view;
  EXPECT_EQ(dfsc::makeCloudView(layout, cloud.data.data(), cloud.data.size(), "intensity", view), "");
  EXPECT_TRUE(view.has_intensity);

  pcl::PCLPointCloud2 pcl_cloud;
  pcl_cloud.height = cloud.height;
  pcl_cloud.width = cloud.width;
  pcl_cloud.point_step = cloud.point_step;
  pcl_cloud.row_step = cloud.row_step;
  pcl_cloud.is_bigendian = 1;
  for (const auto& f : cloud.fields)
  {
    pcl::PCLPointField p;
    p.name = f.name;
    p.offset = f.offset;
    p.datatype = f.datatype;
    p.count = f.count;
    pcl_cloud.fields.push_back(p);
  }
  const dfsc::CloudLayout from_pcl = dfsc::cloudLayoutOf(pcl_cloud);
  EXPECT_TRUE(from_pcl.is_bigendian);
  ASSERT_EQ(from_pcl.fields.size(), layout.fields.size());
  for (std::size_t i = 0; i < layout.fields.size(); ++i)
  {
    EXPECT_EQ(from_pcl.fields[i].name, layout.fields[i].name);
    EXPECT_EQ(from_pcl.fields[i].offset, layout.fields[i].offset);
    EXPECT_EQ(from_pcl.fields[i].datatype, layout.fields[i].datatype);
    EXPECT_EQ(from_pcl.fields[i].count, layout.fields[i].count);
  }
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
