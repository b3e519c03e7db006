#!/usr/bin/python3
"""rostest node shared by converter_nodelet.test and converter_node.test.

A camera on a servo, 0.8 m above base_link (the floor is base_link's z = 0), looks at a floor,
a wall 2.0 m ahead and a box. For every cloud the test broadcasts a new tilt (pitch 10, 25,
40, 15 and 30 degrees down), then publishes the cloud the camera sees with that tilt (ray cast
here), and checks the scan: every beam equals the expected scan (brute force in this file),
every obstacle lies on the wall or on the box, the floor never shows up, and the intensities
are those of the chosen points. Malformed clouds in the middle (one point short, no z, a stamp
at the end of ROS time, an empty frame_id) must not kill the converter: the next good cloud
still gives its scan; a frame_id with a leading '/' is converted. The subscription to cloud_in is lazy: none before the
test listens to the outputs, none after it stops listening.

Clouds come over TCP. The standalone node (~read_in_place: true) converts one whose transform is
already there straight from roscpp's receive buffer; the nodelet (false) copies every one, as
other nodelets in its manager may take the same message. The first cloud is sent well after its
transform, the fourth before it: the node's diagnostics must count the first and the two clouds
with an unusable header (dropped in place) as read in place and not the fourth, the nodelet's
none.
"""
import math
import os
import threading
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import TransformStamped
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import LaserScan, PointCloud2, PointField

from laserscan_toolbox.ros.rosrun import wait_connected

CAMERA_HEIGHT = 0.8
WALL_X = 2.0
BOX_LO = np.array([1.0, 0.3, 0.0])
BOX_HI = np.array([1.3, 0.6, 0.5])
WIDTH, HEIGHT, HFOV = 160, 120, math.radians(60.0)
BAND = (0.05, 1.0)
ANGLE_MIN, ANGLE_MAX, ANGLE_INC = -math.pi, math.pi, math.pi / 720
PITCHES_DEG = [10.0, 25.0, 40.0, 15.0, 30.0]
BOX_INTENSITY, OTHER_INTENSITY = 7.0, 3.0


def camera_pose(pitch):
    """camera optical frame -> base_link: rotation and translation."""
    c, s = math.cos(pitch), math.sin(pitch)
    pitch_down = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    optical_to_body = np.array([[0, 0, 1], [-1, 0, 0], [0, -1, 0]], dtype=float)
    return pitch_down @ optical_to_body, np.array([0.0, 0.0, CAMERA_HEIGHT])


def render(pitch):
    """Organized (HEIGHT, WIDTH, 3) float32 cloud in the optical frame; NaN where nothing is hit."""
    rot, origin = camera_pose(pitch)
    f = (WIDTH / 2.0) / math.tan(HFOV / 2.0)
    u, v = np.meshgrid(np.arange(WIDTH), np.arange(HEIGHT))
    d_cam = np.stack([(u - (WIDTH - 1) / 2.0) / f, (v - (HEIGHT - 1) / 2.0) / f, np.ones(u.shape)], axis=-1)
    d = d_cam @ rot.T
    with np.errstate(divide="ignore", invalid="ignore"):
        t_floor = np.where(d[..., 2] < -1e-9, -origin[2] / d[..., 2], np.inf)
        t_wall = np.where(d[..., 0] > 1e-9, (WALL_X - origin[0]) / d[..., 0], np.inf)
        t0 = (BOX_LO - origin) / d
        t1 = (BOX_HI - origin) / d
        t_near = np.nanmax(np.minimum(t0, t1), axis=-1)
        t_far = np.nanmin(np.maximum(t0, t1), axis=-1)
        t_box = np.where((t_near <= t_far) & (t_near > 0), t_near, np.inf)
    t = np.minimum(np.minimum(t_floor, t_wall), t_box)
    pts = np.empty(t.shape + (4,), dtype=np.float32)
    pts[..., :3] = d_cam * t[..., None]
    pts[~np.isfinite(t), :3] = np.nan
    # Fourth channel, the "intensity" field: the box reflects 7, everything else 3.
    pts[..., 3] = np.where(t == t_box, BOX_INTENSITY, OTHER_INTENSITY)
    return pts


def expected_scan(points, pitch):
    """Brute force: transform, band, planar range, nearest beam, minimum."""
    rot, origin = camera_pose(pitch)
    q = points[..., :3].reshape(-1, 3).astype(np.float64) @ rot.T + origin
    q = q[np.isfinite(q).all(axis=1)]
    q = q[(q[:, 2] >= BAND[0]) & (q[:, 2] <= BAND[1])]
    r = np.hypot(q[:, 0], q[:, 1])
    a = np.arctan2(q[:, 1], q[:, 0])
    n = int(round((ANGLE_MAX - ANGLE_MIN) / ANGLE_INC)) + 1
    beams = np.clip(np.floor((a - ANGLE_MIN) / ANGLE_INC + 0.5).astype(int), 0, n - 1)
    scan = np.full(n, np.inf)
    np.minimum.at(scan, beams, r)
    return scan, q


def cloud_message(points, stamp, frame):
    msg = PointCloud2()
    msg.header.stamp = stamp
    msg.header.frame_id = frame
    msg.height, msg.width = points.shape[0], points.shape[1]
    names = ("x", "y", "z", "intensity")
    msg.fields = [PointField(name=n, offset=4 * i, datatype=PointField.FLOAT32, count=1) for i, n in enumerate(names)]
    msg.is_bigendian = False
    msg.point_step = 16
    msg.row_step = 16 * msg.width
    msg.is_dense = False
    msg.data = np.ascontiguousarray(points, dtype="<f4").tobytes()
    return msg


class ConverterTest(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.scans = {}
        self.filtered = {}
        self.cloud_pub = rospy.Publisher("cloud_in", PointCloud2, queue_size=5)
        self.diagnostics = {}  # the converter's last diagnostics values
        self.diag_sub = rospy.Subscriber("/diagnostics", DiagnosticArray, self.on_diagnostics, queue_size=20)
        self.tf_pub = tf2_ros.TransformBroadcaster()
        # Lazy: while nobody listens to the outputs, the converter does not subscribe to cloud_in.
        deadline = rospy.Time.now() + rospy.Duration(30.0)
        while "/scan" not in [t for t, _ in rospy.get_published_topics()] and not rospy.is_shutdown():
            self.assertLess(rospy.Time.now(), deadline, "the converter never advertised scan")
            rospy.sleep(0.1)
        rospy.sleep(1.0)
        self.assertEqual(self.cloud_pub.get_num_connections(), 0, "subscribed to cloud_in with nobody listening")
        # Subscribing to the outputs is what makes the lazy converter subscribe to cloud_in.
        self.scan_sub = rospy.Subscriber("scan", LaserScan, self.on_scan, queue_size=20)
        self.cloud_sub = rospy.Subscriber("filtered_cloud", PointCloud2, self.on_filtered, queue_size=20)
        # The converter's tf listener must be connected too, or the first tilt is lost.
        self.assertTrue(wait_connected([self.cloud_pub, self.tf_pub.pub_tf], timeout=30.0),
                        "the converter never subscribed to cloud_in and /tf")
        rospy.sleep(0.2)  # connections are made in the background; let them settle

    def on_scan(self, msg):
        with self.lock:
            self.scans[msg.header.stamp] = msg

    def on_diagnostics(self, msg):
        for status in msg.status:
            if status.hardware_id == "/converter":  # the node's name, one converter per sensor
                with self.lock:
                    self.diagnostics = {kv.key: kv.value for kv in status.values}

    def counter(self, key):
        with self.lock:
            return int(self.diagnostics.get(key, -1))

    def on_filtered(self, msg):
        with self.lock:
            self.filtered[msg.header.stamp] = msg

    def wait_for(self, store, stamp, timeout=5.0):
        deadline = rospy.Time.now() + rospy.Duration(timeout)
        while rospy.Time.now() < deadline and not rospy.is_shutdown():
            with self.lock:
                if stamp in store:
                    return store[stamp]
            rospy.sleep(0.01)
        return None

    def send_tilt(self, pitch, stamp):
        rot, origin = camera_pose(pitch)
        # rotation matrix -> quaternion (w > 0 branch is enough for these tilts)
        w = math.sqrt(max(0.0, 1.0 + rot[0, 0] + rot[1, 1] + rot[2, 2])) / 2.0
        t = TransformStamped()
        t.header.stamp = stamp
        t.header.frame_id = "base_link"
        t.child_frame_id = "camera_optical"
        t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = origin
        t.transform.rotation.w = w
        t.transform.rotation.x = (rot[2, 1] - rot[1, 2]) / (4 * w)
        t.transform.rotation.y = (rot[0, 2] - rot[2, 0]) / (4 * w)
        t.transform.rotation.z = (rot[1, 0] - rot[0, 1]) / (4 * w)
        self.tf_pub.sendTransform(t)

    def check_scan(self, scan, points, pitch):
        n = int(round((ANGLE_MAX - ANGLE_MIN) / ANGLE_INC)) + 1
        self.assertEqual(scan.header.frame_id, "base_link")
        self.assertEqual(len(scan.ranges), n)
        ranges = np.array(scan.ranges, dtype=np.float64)
        self.assertFalse(np.isnan(ranges).any())
        expected, _ = expected_scan(points, pitch)
        finite = np.isfinite(expected)
        self.assertGreater(finite.sum(), 50, "the scene should show the wall and the box")
        # Equal beam by beam; a point within micro-radians of a beam border may go to the
        # neighbour (float32 and the fast atan2 in the converter): at most 5 such beams of 1441
        # (0 to 2 seen with these scenes).
        with np.errstate(invalid="ignore"):
            same = (np.isinf(ranges) & ~finite) | (np.abs(ranges - expected) <= 1e-4 * np.maximum(1.0, expected))
        self.assertLessEqual(np.sum(~same), 5, f"pitch {math.degrees(pitch):.0f}: {np.sum(~same)} beams differ")
        # Every obstacle is on the wall or on the box: the floor never shows up.
        a = ANGLE_MIN + np.arange(n) * ANGLE_INC
        hit = np.isfinite(ranges)
        x, y = ranges[hit] * np.cos(a[hit]), ranges[hit] * np.sin(a[hit])
        on_wall = np.abs(x - WALL_X) < 0.02
        on_box = (x > BOX_LO[0] - 0.02) & (x < BOX_HI[0] + 0.02) & (y > BOX_LO[1] - 0.02) & (y < BOX_HI[1] + 0.02)
        self.assertTrue(np.all(on_wall | on_box), f"pitch {math.degrees(pitch):.0f}: obstacle off the wall and box")
        self.assertTrue(on_box.any(), "the box should be seen")
        # Intensities (intensity_field: intensity): those of the chosen points.
        intensities = np.array(scan.intensities)
        self.assertEqual(len(intensities), n)
        self.assertTrue(np.all(intensities[~hit] == 0.0))
        inside_box = on_box & ~on_wall
        self.assertTrue(np.all(intensities[hit][inside_box] == BOX_INTENSITY))
        self.assertTrue(np.all(intensities[hit][on_wall & ~on_box] == OTHER_INTENSITY))

    def test_servo_tilt_and_malformed_cloud(self):
        stamp = rospy.Time.now()
        for k, pitch_deg in enumerate(PITCHES_DEG):
            pitch = math.radians(pitch_deg)
            stamp = max(rospy.Time.now(), stamp + rospy.Duration(0.05))
            points = render(pitch)
            if k == 3:  # the cloud before its transform: it waits for it (in the tf filter)
                self.cloud_pub.publish(cloud_message(points, stamp, "camera_optical"))
                rospy.sleep(0.1)  # well within transform_tolerance (0.5 s)
                self.send_tilt(pitch, stamp)
            else:
                self.send_tilt(pitch, stamp)
                if k == 0:
                    rospy.sleep(0.5)  # the transform surely there before the cloud
                self.cloud_pub.publish(cloud_message(points, stamp, "camera_optical"))
            scan = self.wait_for(self.scans, stamp)
            self.assertIsNotNone(scan, f"no scan for the cloud with pitch {pitch_deg}")
            self.check_scan(scan, points, pitch)
            filtered = self.wait_for(self.filtered, stamp)
            self.assertIsNotNone(filtered, "no filtered cloud")
            z = np.frombuffer(bytes(filtered.data), dtype="<f4").reshape(-1, 3)[:, 2]
            self.assertGreater(z.size, 0)
            self.assertTrue(np.all((z >= BAND[0] - 1e-4) & (z <= BAND[1] + 1e-4)), "filtered cloud left the band")

            if k == 1:
                # Malformed: the data is one point short of width * height * point_step.
                bad_stamp = stamp + rospy.Duration(0.01)
                self.send_tilt(pitch, bad_stamp)
                bad = cloud_message(points, bad_stamp, "camera_optical")
                bad.data = bad.data[:-16]
                self.cloud_pub.publish(bad)
                # And one without a z field.
                bad2_stamp = stamp + rospy.Duration(0.02)
                self.send_tilt(pitch, bad2_stamp)
                bad2 = cloud_message(points, bad2_stamp, "camera_optical")
                bad2.fields = bad2.fields[:2]
                self.cloud_pub.publish(bad2)
                self.assertIsNone(self.wait_for(self.scans, bad_stamp, timeout=0.5), "malformed cloud gave a scan")
                self.assertIsNone(self.wait_for(self.scans, bad2_stamp, timeout=0.2), "cloud without z gave a scan")
                stamp = bad2_stamp
            if k == 2:
                # Headers that reach roscpp's time arithmetic or tf2: a stamp at the end of ROS
                # time (roscpp throws "Time is out of dual 32-bit range" there, which would abort
                # the whole manager) and an empty frame_id are dropped; the converter lives on.
                huge = cloud_message(points, rospy.Time(4294967295, 999999999), "camera_optical")
                self.cloud_pub.publish(huge)
                empty_stamp = stamp + rospy.Duration(0.01)
                self.cloud_pub.publish(cloud_message(points, empty_stamp, ""))
                self.assertIsNone(self.wait_for(self.scans, huge.header.stamp, timeout=0.5), "huge stamp gave a scan")
                self.assertIsNone(self.wait_for(self.scans, empty_stamp, timeout=0.2), "empty frame_id gave a scan")
                # A leading slash (tf1 style) is stripped, as tf2_ros's MessageFilter does.
                slash_stamp = stamp + rospy.Duration(0.02)
                self.send_tilt(pitch, slash_stamp)
                self.cloud_pub.publish(cloud_message(points, slash_stamp, "/camera_optical"))
                scan = self.wait_for(self.scans, slash_stamp)
                self.assertIsNotNone(scan, "no scan for a frame_id with a leading slash")
                self.check_scan(scan, points, pitch)
                stamp = slash_stamp

        # 10 clouds sent: 6 good, 4 malformed. Diagnostics come once a second.
        deadline = rospy.Time.now() + rospy.Duration(10.0)
        while self.counter("clouds received") < 10 and rospy.Time.now() < deadline:
            rospy.sleep(0.1)
        self.assertEqual(self.counter("clouds received"), 10)
        in_place = self.counter("clouds read in place (no copy)")
        if rospy.get_param("~read_in_place"):
            # Surely taken in place: the first cloud (its transform long there) and the two with a
            # header tf2 cannot take (dropped in place); never the one that came before its transform.
            self.assertGreaterEqual(in_place, 3, "the standalone node copied clouds it could take in place")
            self.assertLessEqual(in_place, 9, "a cloud that came before its transform cannot be converted in place")
        else:
            self.assertEqual(in_place, 0, "a nodelet must copy clouds: others in its manager may take the same message")

        # Nobody listens any more: the converter lets go of cloud_in.
        self.scan_sub.unregister()
        self.cloud_sub.unregister()
        self.diag_sub.unregister()
        deadline = rospy.Time.now() + rospy.Duration(10.0)
        while self.cloud_pub.get_num_connections() > 0 and rospy.Time.now() < deadline:
            rospy.sleep(0.05)
        self.assertEqual(self.cloud_pub.get_num_connections(), 0, "still subscribed to cloud_in with nobody listening")


if __name__ == "__main__":
    rospy.init_node("converter_rostest")
    rostest.rosrun("depth_filter_scan_converter", "converter_rostest", ConverterTest)
