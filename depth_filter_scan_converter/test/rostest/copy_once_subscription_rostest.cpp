// subscribeCopyingOnce against a roscore: a publisher in the same process hands over its shared
// pointer (what nodelets in one manager rely on), and the subscription starts and stops.
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "depth_filter_scan_converter/copy_once_subscription.hpp"

namespace dfsc = depth_filter_scan_converter;

namespace
{
// Spins until `done` or a generous deadline (a loaded machine), and says which.
template <class Done>
bool spinUntil(Done done)
{
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!done() && std::chrono::steady_clock::now() < deadline)
  {
    ros::spinOnce();
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return done();
}

template <class M>
void expectSamePointerInProcess(const std::string& topic)
{
  ros::NodeHandle nh;
  boost::shared_ptr<const M> received;
  ros::Subscriber sub = dfsc::subscribeCopyingOnce<M>(
    nh, topic, 1, [&received](const boost::shared_ptr<const M>& message) { received = message; });
  ros::Publisher pub = nh.advertise<M>(topic, 1);
  ASSERT_TRUE(spinUntil([&] { return pub.getNumSubscribers() > 0; }));
  auto sent = boost::make_shared<M>();
  sent->header.frame_id = "camera";
  sent->data.assign(1000, 7);
  pub.publish(sent);
  ASSERT_TRUE(spinUntil([&] { return received != nullptr; }));
  EXPECT_EQ(received.get(), sent.get());  // the same message, not a copy
  sub.shutdown();
  EXPECT_TRUE(spinUntil([&] { return pub.getNumSubscribers() == 0; }));
}
}  // namespace

TEST(CopyOnceSubscription, APublisherInTheSameProcessHandsOverItsCloud)
{
  expectSamePointerInProcess<sensor_msgs::PointCloud2>("cloud_in");
}

TEST(CopyOnceSubscription, APublisherInTheSameProcessHandsOverItsImage)
{
  expectSamePointerInProcess<sensor_msgs::Image>("image");
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "copy_once_subscription_test");
  ros::NodeHandle nh;  // keeps the node up between the tests
  return RUN_ALL_TESTS();
}
