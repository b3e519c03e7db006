// The depth-image view of the core: validation, and the same scan as depth_image_proc's
// point_cloud_xyz conversion followed by the cloud core, beam for beam, on synthetic frames and on
// a real frame (five_people.pcd's z channel as a depth image).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "depth_filter_scan_converter/depth_image_view.hpp"
#include "depth_filter_scan_converter/projector.hpp"
#include "depth_image_fixtures.hpp"
#include "pcl_cloud.hpp"

namespace dfsc = depth_filter_scan_converter;
using namespace dfsc::test;  // NOLINT: fixtures

namespace
{
const float kInfF = std::numeric_limits<float>::infinity();

// Beams that differ between two scans; +Inf and -Inf are different values, NaN (a beam that saw
// only the robot) equals NaN. `tol` is relative.
std::size_t differences(const std::vector<float>& a, const std::vector<float>& b, float tol = 1e-6f)
{
  EXPECT_EQ(a.size(), b.size());
  std::size_t n = 0;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i)
    if (!(a[i] == b[i] || (std::isnan(a[i]) && std::isnan(b[i])) ||
          std::fabs(a[i] - b[i]) <= tol * std::max(1.0f, std::fabs(b[i]))))
      ++n;
  return n;
}

std::size_t finiteBeams(const std::vector<float>& r)
{
  std::size_t n = 0;
  for (float v : r)
    n += std::isfinite(v) ? 1 : 0;
  return n;
}

struct BothPaths
{
  std::vector<float> image, cloud, image_kept, cloud_kept;
};

// The scan of the frame through the depth-image view, and through point_cloud_xyz + the cloud view.
BothPaths bothPaths(const dfsc::Parameters& p, const DepthFrame& frame, const Eigen::Isometry3d& mount)
{
  BothPaths out;
  dfsc::Projector projector(p);
  projector.project(imageView(frame), mount, out.image, nullptr, &out.image_kept);
  const sensor_msgs::PointCloud2Ptr cloud = pointCloudXyz(frame);
  projector.project(cloudView(*cloud), mount, out.cloud, nullptr, &out.cloud_kept);
  return out;
}

std::string reasonOf(const DepthFrame& f, bool rectified = true)
{
  dfsc::DepthImageView v;
  return makeFrameView(f, rectified, v);
}

DepthFrame smallFrame(const std::string& encoding)
{
  Eigen::Isometry3d mount;
  return roomFrame(64, 48, encoding, mount);
}
}  // namespace

TEST(DepthImageView, AcceptsMillimetresAndMetres)
{
  EXPECT_EQ(reasonOf(smallFrame("16UC1")), "");
  EXPECT_EQ(reasonOf(smallFrame("32FC1")), "");
  DepthFrame mono = smallFrame("16UC1");
  mono.image->encoding = "mono16";
  EXPECT_EQ(reasonOf(mono), "");
}

TEST(DepthImageView, RejectsWhatItCannotReadNamingTheReason)
{
  DepthFrame f = smallFrame("16UC1");
  f.image->encoding = "rgb8";
  EXPECT_NE(reasonOf(f).find("encoding 'rgb8' is not a depth encoding"), std::string::npos) << reasonOf(f);
  f.image->encoding = "32FC3";
  EXPECT_NE(reasonOf(f).find("'32FC3'"), std::string::npos);

  f = smallFrame("16UC1");
  f.info->width = 640;
  f.info->height = 480;
  EXPECT_EQ(reasonOf(f), "image is 64x48 but camera_info is 640x480");

  f = smallFrame("32FC1");
  f.image->data.pop_back();
  EXPECT_NE(reasonOf(f).find("does not match step*height"), std::string::npos) << reasonOf(f);

  f = smallFrame("32FC1");
  f.image->step = 64 * 2;  // a 16-bit step for a 32-bit image
  EXPECT_NE(reasonOf(f).find("step 128 is smaller than width*4 256"), std::string::npos) << reasonOf(f);

  f = smallFrame("16UC1");
  f.image->is_bigendian = 1;
  EXPECT_NE(reasonOf(f).find("is_bigendian"), std::string::npos);

  f = smallFrame("16UC1");
  f.info->P[0] = 0.0;  // an uncalibrated camera_info
  EXPECT_NE(reasonOf(f).find("camera_info P has focal lengths"), std::string::npos) << reasonOf(f);
  EXPECT_EQ(reasonOf(f, false), "");  // K is still fine
  f.info->K[4] = std::nan("");
  EXPECT_NE(reasonOf(f, false).find("camera_info K"), std::string::npos);
}

TEST(DepthImageView, IntrinsicsFromPForRectifiedImagesElseK)
{
  dfsc::CameraModel m;
  m.K[0] = 500, m.K[4] = 510, m.K[2] = 320, m.K[5] = 240;
  m.P[0] = 480, m.P[5] = 490, m.P[2] = 300, m.P[6] = 230;
  dfsc::Intrinsics k;
  ASSERT_EQ(dfsc::intrinsicsOf(m, true, k), "");
  EXPECT_EQ(k.fx, 480);
  EXPECT_EQ(k.fy, 490);
  EXPECT_EQ(k.cx, 300);
  EXPECT_EQ(k.cy, 230);
  ASSERT_EQ(dfsc::intrinsicsOf(m, false, k), "");
  EXPECT_EQ(k.fx, 500);
  EXPECT_EQ(k.fy, 510);
  EXPECT_EQ(k.cx, 320);
  EXPECT_EQ(k.cy, 240);
}

// The room at several option sets: the image path gives point_cloud_xyz + cloud core's scan.
class RoomFrames : public ::testing::TestWithParam<std::string>
{};

TEST_P(RoomFrames, SameScanAsPointCloudXyzAndTheCloudCore)
{
  Eigen::Isometry3d mount;
  const DepthFrame frame = roomFrame(320, 163, GetParam(), mount);
  std::vector<dfsc::Parameters> options(5);
  options[1].input.row_stride = 2;
  options[1].input.column_stride = 3;
  options[2].band.hole_detection = true;
  options[2].band.floor_height = 0.1;  // the "floor" 10 cm up: the real floor is a hole
  options[3].scan.range_min = 1.5;     // the table and chair are too close
  options[4].scan.angle_min = -0.3;
  options[4].scan.angle_max = 0.5;
  options[4].scan.angle_increment = 0.002;
  for (std::size_t i = 0; i < options.size(); ++i)
  {
    const BothPaths r = bothPaths(options[i], frame, mount);
    EXPECT_GT(finiteBeams(r.image) + (i == 3 ? 1 : 0), 30u) << "options " << i;
    EXPECT_EQ(differences(r.image, r.cloud), 0u) << "options " << i;
    EXPECT_EQ(r.image_kept.size(), r.cloud_kept.size()) << "options " << i;
  }
  // Too close reads -Inf in both.
  const BothPaths close = bothPaths(options[3], frame, mount);
  EXPECT_GT(std::count(close.image.begin(), close.image.end(), -kInfF), 10);
}

// The self filter on the depth-image path: the room's chair taken for a part of the robot (a
// padded box around it) leaves the same scan as on point_cloud_xyz's cloud, and a different one
// from the unfiltered scan (the chair's beams read NaN or what lies beyond).
TEST_P(RoomFrames, SelfFilterGivesTheSameScanOnBothPaths)
{
  Eigen::Isometry3d mount;
  const DepthFrame frame = roomFrame(320, 163, GetParam(), mount);
  laserscan_common::RobotShape chair;
  chair.name = chair.frame = "chair";
  chair.half_extents = Eigen::Vector3d(0.225, 0.225, 0.225);
  chair.padding = 0.02;
  laserscan_common::SelfFilter filter({ chair }, "self_filter/shapes");
  filter.setFramePoses({ Eigen::Isometry3d(Eigen::Translation3d(1.225, 0.725, 0.225)) });
  dfsc::Projector projector{ dfsc::Parameters() };
  std::vector<float> plain, image, cloud;
  const dfsc::DepthImageView view = imageView(frame);
  projector.project(view, mount, plain);
  projector.project(view, mount, image, nullptr, nullptr, &filter);
  const sensor_msgs::PointCloud2Ptr xyz = pointCloudXyz(frame);
  projector.project(cloudView(*xyz), mount, cloud, nullptr, nullptr, &filter);
  EXPECT_EQ(differences(image, cloud), 0u);
  EXPECT_GT(differences(image, plain), 10u);
  // In the chair's directions (20-43 degrees left), only what lies beyond it (cabinet, wall).
  const dfsc::Parameters p;
  std::size_t beyond = 0;
  for (std::size_t b = 0; b < image.size(); ++b)
  {
    const double a = p.scan.angle_min + b * p.scan.angle_increment;
    if (a > 0.35 && a < 0.75 && std::isfinite(image[b]))
    {
      EXPECT_GT(image[b], 1.6f) << b;
      ++beyond;
    }
  }
  EXPECT_GT(beyond, 10u);
}

INSTANTIATE_TEST_SUITE_P(Encodings, RoomFrames, ::testing::Values("16UC1", "32FC1"));

TEST(DepthImage, ZeroAndNaNDepthsAreNoReturn)
{
  // The camera sits inside the band: a zero depth read as a point would be an obstacle on it.
  const Eigen::Isometry3d mount = cameraMount(0.5, 0.0);
  for (const std::string encoding : { "16UC1", "32FC1" })
  {
    DepthFrame f = depthFrame(Points(64 * 48, Vector3d(0, 0, 0)), 64, 48, { 50, 50, 31.5, 23.5 }, encoding);
    std::vector<float> ranges;
    dfsc::Projector projector{ dfsc::Parameters() };
    projector.project(imageView(f), mount, ranges);
    EXPECT_EQ(finiteBeams(ranges), 0u) << encoding;
    EXPECT_EQ(std::count(ranges.begin(), ranges.end(), kInfF), static_cast<long>(ranges.size())) << encoding;
  }
  // 32FC1: NaN and +Inf depths too.
  Points pts(64 * 48, Vector3d(0, 0, 2.0));
  pts[10] = Vector3d(0, 0, kNaN);
  DepthFrame f = depthFrame(pts, 64, 48, { 50, 50, 31.5, 23.5 }, "32FC1");
  const float inf = kInfF;
  std::memcpy(f.image->data.data() + 4 * 11, &inf, 4);
  dfsc::Parameters everything;  // every point is an obstacle: kept points count the valid pixels
  everything.band.min_height = -std::numeric_limits<double>::infinity();
  everything.band.max_height = std::numeric_limits<double>::infinity();
  everything.scan.range_max = std::numeric_limits<double>::infinity();
  std::vector<float> ranges, kept;
  dfsc::Projector projector(everything);
  projector.project(imageView(f), mount, ranges, nullptr, &kept);
  EXPECT_EQ(kept.size(), 3u * (64 * 48 - 2));
}

// five_people.pcd, 640 x 480: its z channel is the depth image; the intrinsics follow from x/z
// and y/z per pixel. The image path must give the scan of point_cloud_xyz + the cloud core, and
// nearly the scan of the recorded cloud itself.
class FivePeopleDepth : public ::testing::TestWithParam<std::string>
{};

TEST_P(FivePeopleDepth, SameScanAsPointCloudXyzAndCloseToTheRecording)
{
  const PcdCloud pcd = readPcd(std::string(TEST_DATA_DIR) + "/five_people.pcd");
  dfsc::CloudView recorded;
  ASSERT_EQ(dfsc::makeCloudView(pcd.layout, pcd.data.data(), pcd.data.size(), "", recorded), "");
  ASSERT_EQ(recorded.width, 640u);
  ASSERT_EQ(recorded.height, 480u);
  Points pts;
  for (std::size_t i = 0; i < recorded.size(); ++i)
  {
    const std::uint8_t* p = pcd.data.data() + i * recorded.point_step;
    pts.push_back(Vector3d(dfsc::readField(p + recorded.x_offset, recorded.xyz_type),
                           dfsc::readField(p + recorded.y_offset, recorded.xyz_type),
                           dfsc::readField(p + recorded.z_offset, recorded.xyz_type)));
  }
  const dfsc::Intrinsics k = fitIntrinsics(pts, 640);
  // The fitted model reproduces the recorded x and y (the cloud came from a pinhole depth image).
  std::size_t valid = 0, off = 0;
  for (std::size_t i = 0; i < pts.size(); ++i)
  {
    if (!std::isfinite(pts[i].z()))
      continue;
    ++valid;
    const double x = (static_cast<double>(i % 640) - k.cx) * pts[i].z() / k.fx;
    const double y = (static_cast<double>(i / 640) - k.cy) * pts[i].z() / k.fy;
    off += std::hypot(x - pts[i].x(), y - pts[i].y()) > 2e-3 ? 1 : 0;
  }
  EXPECT_GT(valid, 200000u);
  EXPECT_LT(off, valid / 1000) << "fx " << k.fx << " fy " << k.fy << " cx " << k.cx << " cy " << k.cy;

  const DepthFrame frame = depthFrame(pts, 640, 480, k, GetParam());
  for (const Eigen::Isometry3d& mount : { fivePeopleMeasuredMount(), cameraMount(1.0, 20 * kDeg) })
  {
    dfsc::Parameters p;
    const BothPaths r = bothPaths(p, frame, mount);
    EXPECT_GT(finiteBeams(r.image), 50u);
    EXPECT_EQ(differences(r.image, r.cloud), 0u);
    EXPECT_EQ(r.image_kept.size(), r.cloud_kept.size());
    p.input.column_stride = 2;
    p.input.row_stride = 2;
    p.band.hole_detection = true;
    const BothPaths s = bothPaths(p, frame, mount);
    EXPECT_EQ(differences(s.image, s.cloud), 0u);
  }
  // Against the recording itself: the same obstacles, within the depth rounding (1 mm for 16UC1).
  std::vector<float> from_image, from_recording;
  dfsc::Projector projector{ dfsc::Parameters() };
  projector.project(imageView(frame), fivePeopleMeasuredMount(), from_image);
  projector.project(recorded, fivePeopleMeasuredMount(), from_recording);
  std::size_t close = 0;
  for (std::size_t i = 0; i < from_image.size(); ++i)
    close += (std::isinf(from_image[i]) && from_image[i] == from_recording[i]) ||
                 std::fabs(from_image[i] - from_recording[i]) < 0.01f
               ? 1
               : 0;
  EXPECT_GE(close, from_image.size() - 5);
}

INSTANTIATE_TEST_SUITE_P(Encodings, FivePeopleDepth, ::testing::Values("16UC1", "32FC1"));

int main(int argc, char** argv)
{
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
