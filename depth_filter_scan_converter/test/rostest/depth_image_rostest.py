#!/usr/bin/python3
"""rostest node of depth_image_nodelet.test and depth_image_node.test.

The simulator's left camera (scripts/laserscan_toolbox, the default scenario: shop floor, servo
tilting the camera 15 +- 20 degrees) renders depth frames at several times. Each frame goes out
as the simulator's bags carry it (16UC1 millimetres + camera_info, tilt on /tf) and reaches two
paths at once:
  image path: depth_filter_scan_converter's depth-image converter      -> image_scan
  cloud path: depth_image_proc/point_cloud_xyz + the cloud converter   -> cloud_scan
Both scans must be equal beam for beam (within float rounding), and show the scene. Bad frames
(an rgb8 image, a camera_info of another size, an image without camera_info, a 32FC1 frame with
a wrong step) give no scan and a good frame afterwards still does. The image converter
subscribes to image and camera_info only while somebody listens.
"""
import math
import threading
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import CameraInfo, Image, LaserScan

from laserscan_toolbox.simulation.robot import quat_from_matrix
from laserscan_toolbox.simulation.scenario import Scenario

TIMES = [0.4, 1.1, 1.9, 2.6, 3.4]  # s into the scenario: the servo is at different tilts


class DepthImageTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.scenario = Scenario.default(seed=3)
        cls.cam = [c for c in cls.scenario.robot.cameras if c.name == "camera_left"][0]

    def setUp(self):
        self.lock = threading.Lock()
        self.scans = {"image_scan": {}, "cloud_scan": {}}
        self.image_pub = rospy.Publisher("camera/depth/image_rect", Image, queue_size=10)
        self.info_pub = rospy.Publisher("camera/depth/camera_info", CameraInfo, queue_size=10)
        self.tf_pub = tf2_ros.TransformBroadcaster()
        deadline = rospy.Time.now() + rospy.Duration(30.0)
        while "/image_scan" not in [t for t, _ in rospy.get_published_topics()] and not rospy.is_shutdown():
            self.assertLess(rospy.Time.now(), deadline, "the image converter never advertised its scan")
            rospy.sleep(0.1)
        rospy.sleep(1.0)
        # Lazy: nobody listens to the scans, so nobody reads the depth topics.
        self.assertEqual(self.image_pub.get_num_connections(), 0, "image subscribed with nobody listening")
        self.assertEqual(self.info_pub.get_num_connections(), 0, "camera_info subscribed with nobody listening")
        self.subs = [rospy.Subscriber(topic, LaserScan, self.on_scan, topic, queue_size=20) for topic in self.scans]
        # Both paths read the image and the camera_info (in one manager they share one connection
        # per topic, so connections cannot be counted): send a frame until both scans come back.
        while not rospy.is_shutdown():
            self.assertLess(rospy.Time.now(), deadline, "the two paths never gave a scan of the warm-up frame")
            stamp = rospy.Time.now()
            img, info = self.frame(TIMES[0], stamp)
            self.send(img, info, TIMES[0])
            if self.wait_for("image_scan", stamp, 0.3) and self.wait_for("cloud_scan", stamp, 0.3):
                break

    def on_scan(self, msg, topic):
        with self.lock:
            self.scans[topic][msg.header.stamp] = msg

    def wait_for(self, topic, stamp, timeout=5.0):
        deadline = rospy.Time.now() + rospy.Duration(timeout)
        while rospy.Time.now() < deadline and not rospy.is_shutdown():
            with self.lock:
                if stamp in self.scans[topic]:
                    return self.scans[topic][stamp]
            rospy.sleep(0.01)
        return None

    def send_tilt(self, rel, stamp):
        rot, pos = self.cam.optical_in_base(rel)
        t = TransformStamped()
        t.header.stamp = stamp
        t.header.frame_id = "base_link"
        t.child_frame_id = self.cam.optical_frame
        t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = (float(v) for v in pos)
        q = quat_from_matrix(rot)
        t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z, t.transform.rotation.w = q
        self.tf_pub.sendTransform(t)

    def frame(self, rel, stamp):
        depth = self.scenario.depth_image(self.cam, rel, np.random.default_rng(int(rel * 10)))
        img = Image()
        img.header.stamp = stamp
        img.header.frame_id = self.cam.optical_frame
        img.height, img.width = self.cam.height, self.cam.width
        img.encoding = "16UC1"
        img.is_bigendian = 0
        img.step = 2 * self.cam.width
        img.data = np.round(depth * 1000.0).astype("<u2").tobytes()
        info = Scenario.camera_info(self.cam, img.header, CameraInfo)
        return img, info

    def send(self, img, info, rel, tilt_late=False):
        """tilt_late: the camera's transform 0.1 s after the frame (within transform_tolerance): the
        frame waits for it, as a cloud does."""
        if not tilt_late:
            self.send_tilt(rel, img.header.stamp)
        if img is not None:
            self.image_pub.publish(img)
        if info is not None:
            self.info_pub.publish(info)
        if tilt_late:
            rospy.sleep(0.1)
            self.send_tilt(rel, img.header.stamp)

    def test_same_scan_as_point_cloud_xyz_while_tilting_and_bad_frames(self):
        stamp = rospy.Time.now()
        pitches = []
        for k, rel in enumerate(TIMES):
            stamp = max(rospy.Time.now(), stamp + rospy.Duration(0.05))
            img, info = self.frame(rel, stamp)
            self.send(img, info, rel, tilt_late=(k == 2))
            from_image = self.wait_for("image_scan", stamp)
            from_cloud = self.wait_for("cloud_scan", stamp)
            self.assertIsNotNone(from_image, f"no scan from the image at t = {rel}")
            self.assertIsNotNone(from_cloud, f"no scan from point_cloud_xyz's cloud at t = {rel}")
            a = np.array(from_image.ranges, dtype=np.float64)
            b = np.array(from_cloud.ranges, dtype=np.float64)
            self.assertEqual(a.shape, b.shape)
            self.assertEqual(from_image.header.frame_id, "base_link")
            with np.errstate(invalid="ignore"):
                same = (a == b) | (np.abs(a - b) <= 1e-6 * np.maximum(1.0, np.abs(b)))
            self.assertTrue(same.all(), f"t = {rel}: {np.sum(~same)} beams differ, e.g. {a[~same][:5]} vs {b[~same][:5]}")
            self.assertGreater(np.isfinite(a).sum(), 20, f"t = {rel}: the camera should see the shop floor")
            pitches.append(float(self.cam.pitch(rel)))

            if k == 1:
                self.bad_frames(rel, stamp)
                stamp = stamp + rospy.Duration(0.04)
        # The servo really tilted the camera between frames.
        self.assertGreater(max(pitches) - min(pitches), math.radians(15.0))

        for s in self.subs:
            s.unregister()
        deadline = rospy.Time.now() + rospy.Duration(10.0)
        while self.image_pub.get_num_connections() > 0 and rospy.Time.now() < deadline:
            rospy.sleep(0.05)
        self.assertEqual(self.image_pub.get_num_connections(), 0, "still reading images with nobody listening")

    def bad_frames(self, rel, stamp):
        """Each gives no scan from the image path; the converter lives on (checked by the next frame)."""
        bad = []
        # An encoding that is not depth.
        s = stamp + rospy.Duration(0.01)
        img, info = self.frame(rel, s)
        img.encoding = "rgb8"
        bad.append((img, info, "rgb8 image"))
        # A camera_info of another size than the image.
        s = stamp + rospy.Duration(0.02)
        img, info = self.frame(rel, s)
        info.width, info.height = 2 * info.width, 2 * info.height
        bad.append((img, info, "camera_info of another size"))
        # An image without camera_info (it waits in the synchronizer's queue, then is dropped).
        s = stamp + rospy.Duration(0.03)
        img, _ = self.frame(rel, s)
        bad.append((img, None, "image without camera_info"))
        # 32FC1 whose step is that of a 16-bit image. point_cloud_xyz gets it too and does not check
        # the step against the data: it reads width floats per row, step bytes apart, so data of the
        # 16-bit frame's size would let it read 608 bytes past the end (valgrind: invalid reads in
        # depth_image_proc::convert<float>), which crashed the whole manager about once in 25 runs.
        # Data for a 32FC1 frame keeps its reads inside; the step alone must be refused here.
        s = stamp + rospy.Duration(0.04)
        img, info = self.frame(rel, s)
        img.encoding = "32FC1"
        img.data = img.data * 2
        bad.append((img, info, "32FC1 with a 16-bit step"))
        for img, info, _ in bad:
            self.send(img, info, rel)
        for img, _, what in bad:
            self.assertIsNone(self.wait_for("image_scan", img.header.stamp, timeout=0.3), f"{what} gave a scan")


if __name__ == "__main__":
    rospy.init_node("depth_image_rostest")
    rostest.rosrun("depth_filter_scan_converter", "depth_image_rostest", DepthImageTest)
