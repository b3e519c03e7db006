// The pieces the converters' ROS classes share that run without a ROS master, and the one home
// of the PointCloud2 -> CloudLayout conversion (the nodelet's path) against PCL's own cloud.
#include <gtest/gtest.h>
#include <pcl/PCLPointCloud2.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include <ros/serialization.h>

#include <algorithm>
#include <string>
#include <vector>

#include "depth_filter_scan_converter/projector.hpp"
#include "depth_filter_scan_converter/converter_glue.hpp"
#include "depth_filter_scan_converter/copy_once_subscription.hpp"

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

namespace
{
template <class M>
std::vector<std::uint8_t> wireBytes(const M& message)
{
  std::vector<std::uint8_t> bytes(ros::serialization::serializationLength(message));
  ros::serialization::OStream stream(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  ros::serialization::serialize(stream, message);
  return bytes;
}

// What roscpp's MessageDeserializer hands a helper: the message's bytes in its receive buffer.
ros::VoidConstPtr deserializeWith(ros::SubscriptionCallbackHelper& helper, std::vector<std::uint8_t>& bytes)
{
  ros::SubscriptionCallbackHelperDeserializeParams params;
  params.buffer = bytes.data();
  params.length = static_cast<std::uint32_t>(bytes.size());
  return helper.deserialize(params);
}

// The copy-once subscription's helper (no in-place reader), made as subscribeCopyingOnce makes
// it (GCC 12 warns about boost::function temporaries on the stack).
template <class M>
boost::shared_ptr<const M> readCopyingOnce(std::vector<std::uint8_t> bytes)
{
  const std::function<void(const boost::shared_ptr<const M>&)> callback = [](const auto&) {};
  dfsc::CopyOnceCallbackHelper<M> helper(callback);
  return boost::static_pointer_cast<const M>(deserializeWith(helper, bytes));
}

// Reads `bytes` with the copy-once subscription's helper and with roscpp's deserialiser, and
// expects both to give the same wire bytes back.
template <class M>
void expectSameAsRoscpp(const std::vector<std::uint8_t>& bytes)
{
  const boost::shared_ptr<const M> ours = readCopyingOnce<M>(bytes);
  ASSERT_NE(ours, nullptr);
  M roscpps;
  ros::serialization::IStream theirs(const_cast<std::uint8_t*>(bytes.data()), static_cast<std::uint32_t>(bytes.size()));
  ros::serialization::deserialize(theirs, roscpps);
  EXPECT_EQ(wireBytes(*ours), bytes);
  EXPECT_EQ(wireBytes(roscpps), bytes);
}

sensor_msgs::PointCloud2 someCloud()
{
  sensor_msgs::PointCloud2 cloud;
  cloud.header.seq = 7;
  cloud.header.stamp = ros::Time(1234, 5678);
  cloud.header.frame_id = "camera_depth_optical_frame";
  cloud.height = 3;
  cloud.width = 5;
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2FieldsByString(1, "xyz");
  for (std::size_t i = 0; i < cloud.data.size(); ++i)
    cloud.data[i] = static_cast<std::uint8_t>(i * 37 + 11);
  cloud.is_bigendian = false;
  cloud.is_dense = true;
  return cloud;
}
}  // namespace

TEST(CopyOnceReader, ReadsPointCloud2AsRoscppDoes)
{
  expectSameAsRoscpp<sensor_msgs::PointCloud2>(wireBytes(someCloud()));
  expectSameAsRoscpp<sensor_msgs::PointCloud2>(wireBytes(sensor_msgs::PointCloud2()));  // empty cloud
}

TEST(CopyOnceReader, ReadsImageAsRoscppDoes)
{
  sensor_msgs::Image image;
  image.header.stamp = ros::Time(99, 1);
  image.header.frame_id = "camera";
  image.height = 4;
  image.width = 6;
  image.encoding = "16UC1";
  image.is_bigendian = 0;
  image.step = 12;
  for (int i = 0; i < 48; ++i)
    image.data.push_back(static_cast<std::uint8_t>(255 - i));
  expectSameAsRoscpp<sensor_msgs::Image>(wireBytes(image));
}

TEST(CopyOnceReader, ShortBuffersThrowAsRoscppsReaderDoes)
{
  const std::vector<std::uint8_t> bytes = wireBytes(someCloud());
  // Cut inside the data, and inside the length of data: both readers must refuse.
  for (std::size_t cut : { bytes.size() - 1, bytes.size() - 20, std::size_t{ 30 } })
  {
    std::vector<std::uint8_t> part(bytes.begin(), bytes.begin() + cut);
    sensor_msgs::PointCloud2 roscpps;
    EXPECT_THROW(readCopyingOnce<sensor_msgs::PointCloud2>(part), ros::serialization::StreamOverrunException) << cut;
    ros::serialization::IStream b(part.data(), static_cast<std::uint32_t>(part.size()));
    EXPECT_THROW(ros::serialization::deserialize(b, roscpps), ros::serialization::StreamOverrunException) << cut;
  }
  // A data length far beyond the buffer (a corrupt length) is refused before anything is copied.
  std::vector<std::uint8_t> corrupt = bytes;
  const std::size_t data_length_at = bytes.size() - 1 - someCloud().data.size() - 4;
  corrupt[data_length_at + 3] = 0x7f;
  EXPECT_THROW(readCopyingOnce<sensor_msgs::PointCloud2>(corrupt), ros::serialization::StreamOverrunException);
}

TEST(CopyOnceReader, SubscribersTypeIsTheMessagesOwnForZeroCopyInAManager)
{
  // roscpp hands a publisher's shared pointer to a subscriber in the same process only when the
  // helper's type is the published type.
  // Made as subscribeCopyingOnce makes them (GCC 12 warns about boost::function temporaries on the stack).
  const std::function<void(const sensor_msgs::PointCloud2ConstPtr&)> on_cloud = [](const auto&) {};
  const std::function<void(const sensor_msgs::ImageConstPtr&)> on_image = [](const auto&) {};
  const auto cloud_helper = boost::make_shared<dfsc::CopyOnceCallbackHelper<sensor_msgs::PointCloud2>>(on_cloud);
  const auto image_helper = boost::make_shared<dfsc::CopyOnceCallbackHelper<sensor_msgs::Image>>(on_image);
  EXPECT_TRUE(cloud_helper->getTypeInfo() == typeid(sensor_msgs::PointCloud2));
  EXPECT_TRUE(image_helper->getTypeInfo() == typeid(sensor_msgs::Image));
}

TEST(InPlaceReader, SeesTheMessageWithItsBytesInTheReceiveBuffer)
{
  const sensor_msgs::PointCloud2 cloud = someCloud();
  std::vector<std::uint8_t> bytes = wireBytes(cloud);
  const std::function<void(const sensor_msgs::PointCloud2ConstPtr&)> on_cloud = [](const auto&) {};
  sensor_msgs::PointCloud2 seen;
  const std::uint8_t* seen_bytes = nullptr;
  std::size_t seen_size = 0;
  dfsc::CopyOnceCallbackHelper<sensor_msgs::PointCloud2> helper(
    on_cloud, [&](const sensor_msgs::PointCloud2& message, const std::uint8_t* data, std::size_t size) {
      seen = message;
      seen_bytes = data;
      seen_size = size;
      return true;
    });
  EXPECT_EQ(deserializeWith(helper, bytes), nullptr);  // taken: roscpp calls no callback
  // The data is not copied: it is the span of the buffer just before the last field (is_dense).
  ASSERT_EQ(seen_size, cloud.data.size());
  EXPECT_EQ(seen_bytes, bytes.data() + bytes.size() - 1 - cloud.data.size());
  EXPECT_TRUE(std::equal(cloud.data.begin(), cloud.data.end(), seen_bytes));
  // Every other field is read.
  EXPECT_TRUE(seen.data.empty());
  seen.data = cloud.data;
  EXPECT_EQ(wireBytes(seen), bytes);
}

namespace
{
// A cloud subscription's helper whose in-place reader counts the clouds offered to it and takes
// them when `take`.
dfsc::CopyOnceCallbackHelper<sensor_msgs::PointCloud2> countingHelper(int& offered, bool take)
{
  const std::function<void(const sensor_msgs::PointCloud2ConstPtr&)> on_cloud = [](const auto&) {};
  return dfsc::CopyOnceCallbackHelper<sensor_msgs::PointCloud2>(
    on_cloud, [&offered, take](const sensor_msgs::PointCloud2&, const std::uint8_t*, std::size_t) {
      ++offered;
      return take;
    });
}
}  // namespace

TEST(InPlaceReader, AMessageItDoesNotTakeIsDeliveredWhole)
{
  std::vector<std::uint8_t> bytes = wireBytes(someCloud());
  int offered = 0;
  auto helper = countingHelper(offered, false);
  const auto message = boost::static_pointer_cast<const sensor_msgs::PointCloud2>(deserializeWith(helper, bytes));
  EXPECT_EQ(offered, 1);
  ASSERT_NE(message, nullptr);
  EXPECT_EQ(wireBytes(*message), bytes);
}

TEST(InPlaceReader, AShortBufferThrowsBeforeTheReaderSeesIt)
{
  const std::vector<std::uint8_t> whole = wireBytes(someCloud());
  std::vector<std::uint8_t> part(whole.begin(), whole.end() - 20);  // cut inside the data
  int offered = 0;
  auto helper = countingHelper(offered, true);
  EXPECT_THROW(deserializeWith(helper, part), ros::serialization::StreamOverrunException);
  EXPECT_EQ(offered, 0);
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
