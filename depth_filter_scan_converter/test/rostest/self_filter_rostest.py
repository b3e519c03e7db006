#!/usr/bin/python3
"""rostest node of self_filter.test.

A camera 0.5 m above base_link looks straight ahead at a wall 2 m away. The robot's forearm, a
0.1 m cube (robot_description, padded 2 cm by the converter's self_filter block), moves across
the view on tf: for each pose the test broadcasts the camera and the forearm at one stamp, then
the cloud the camera sees at that stamp (ray cast here, the forearm in it). Every scan must hold
no return on the forearm (without the filter the forearm's beams read about 0.95 m) and, in the
forearm's own direction, the wall behind it (seen above and below the cube).
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
from sensor_msgs.msg import LaserScan, PointCloud2, PointField

from laserscan_toolbox.ros.rosrun import wait_connected

CAMERA_HEIGHT = 0.5
WALL_X = 2.0
ARM_X, ARM_HALF = 1.0, 0.05
ARM_YS = [-0.4, -0.2, 0.0, 0.15, 0.35]  # the forearm's poses, left to right of the view
WIDTH, HEIGHT, HFOV = 160, 120, math.radians(60.0)
ANGLE_MIN, ANGLE_INC = -math.pi, math.pi / 720
# camera optical frame -> base_link (looking along x, no tilt)
OPTICAL_TO_BODY = np.array([[0, 0, 1], [-1, 0, 0], [0, -1, 0]], dtype=float)


def render(arm_y):
    """Organized (HEIGHT, WIDTH, 3) float32 cloud in the optical frame: floor, wall, forearm."""
    origin = np.array([0.0, 0.0, CAMERA_HEIGHT])
    f = (WIDTH / 2.0) / math.tan(HFOV / 2.0)
    u, v = np.meshgrid(np.arange(WIDTH), np.arange(HEIGHT))
    d_cam = np.stack([(u - (WIDTH - 1) / 2.0) / f, (v - (HEIGHT - 1) / 2.0) / f, np.ones(u.shape)], axis=-1)
    d = d_cam @ OPTICAL_TO_BODY.T
    lo = np.array([ARM_X - ARM_HALF, arm_y - ARM_HALF, CAMERA_HEIGHT - ARM_HALF])
    hi = lo + 2 * ARM_HALF
    with np.errstate(divide="ignore", invalid="ignore"):
        t_floor = np.where(d[..., 2] < -1e-9, -origin[2] / d[..., 2], np.inf)
        t_wall = np.where(d[..., 0] > 1e-9, (WALL_X - origin[0]) / d[..., 0], np.inf)
        t0, t1 = (lo - origin) / d, (hi - origin) / d
        t_near = np.nanmax(np.minimum(t0, t1), axis=-1)
        t_far = np.nanmin(np.maximum(t0, t1), axis=-1)
        t_arm = np.where((t_near <= t_far) & (t_near > 0), t_near, np.inf)
    t = np.minimum(np.minimum(t_floor, t_wall), t_arm)
    pts = (d_cam * t[..., None]).astype(np.float32)
    pts[~np.isfinite(t)] = np.nan
    return pts, int(np.count_nonzero(t == t_arm))


def expected_scan(points, arm_y, padding=0.02):
    """Brute force: band points, each beam's closest one off the padded forearm; NaN for a beam
    whose band points are all on the forearm, +Inf for a beam without band points."""
    q = points.reshape(-1, 3).astype(np.float64) @ OPTICAL_TO_BODY.T + np.array([0.0, 0.0, CAMERA_HEIGHT])
    q = q[np.isfinite(q).all(axis=1)]
    q = q[(q[:, 2] >= 0.05) & (q[:, 2] <= 1.0)]
    on_arm = np.all(np.abs(q - np.array([ARM_X, arm_y, CAMERA_HEIGHT])) <= ARM_HALF + padding, axis=1)
    n = int(round(2 * math.pi / ANGLE_INC)) + 1
    beams = np.clip(np.floor((np.arctan2(q[:, 1], q[:, 0]) - ANGLE_MIN) / ANGLE_INC + 0.5).astype(int), 0, n - 1)
    scan = np.full(n, np.inf)
    np.minimum.at(scan, beams[~on_arm], np.hypot(q[~on_arm, 0], q[~on_arm, 1]))
    only_arm = np.zeros(n, dtype=bool)
    only_arm[beams[on_arm]] = True
    scan[only_arm & np.isinf(scan)] = np.nan
    return scan


def cloud_message(points, stamp):
    msg = PointCloud2()
    msg.header.stamp = stamp
    msg.header.frame_id = "camera_optical"
    msg.height, msg.width = points.shape[0], points.shape[1]
    msg.fields = [PointField(name=n, offset=4 * i, datatype=PointField.FLOAT32, count=1) for i, n in enumerate("xyz")]
    msg.point_step = 12
    msg.row_step = 12 * msg.width
    msg.data = np.ascontiguousarray(points, dtype="<f4").tobytes()
    return msg


def transform(stamp, child, xyz, quaternion_xyzw):
    t = TransformStamped()
    t.header.stamp = stamp
    t.header.frame_id = "base_link"
    t.child_frame_id = child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = xyz
    q = t.transform.rotation
    q.x, q.y, q.z, q.w = quaternion_xyzw
    return t


class SelfFilterTest(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.scans = {}
        self.cloud_pub = rospy.Publisher("cloud_in", PointCloud2, queue_size=5)
        self.tf_pub = tf2_ros.TransformBroadcaster()
        self.scan_sub = rospy.Subscriber("scan", LaserScan, self.on_scan, queue_size=20)
        self.assertTrue(wait_connected([self.cloud_pub, self.tf_pub.pub_tf], timeout=30.0),
                        "the converter never subscribed to cloud_in and /tf")
        rospy.sleep(0.2)  # connections are made in the background; let them settle

    def on_scan(self, msg):
        with self.lock:
            self.scans[msg.header.stamp] = msg

    def wait_for(self, stamp, timeout=5.0):
        deadline = rospy.Time.now() + rospy.Duration(timeout)
        while rospy.Time.now() < deadline and not rospy.is_shutdown():
            with self.lock:
                if stamp in self.scans:
                    return self.scans[stamp]
            rospy.sleep(0.01)
        return None

    def test_the_moving_forearm_is_never_an_obstacle_and_the_wall_behind_it_stays(self):
        # optical -> body rotation as a quaternion (x, y, z, w)
        camera_q = (-0.5, 0.5, -0.5, 0.5)
        for arm_y in ARM_YS:
            stamp = rospy.Time.now()
            self.tf_pub.sendTransform(
                [
                    transform(stamp, "camera_optical", (0.0, 0.0, CAMERA_HEIGHT), camera_q),
                    transform(stamp, "forearm", (ARM_X, arm_y, CAMERA_HEIGHT), (0.0, 0.0, 0.0, 1.0)),
                ]
            )
            points, on_arm = render(arm_y)
            self.assertGreater(on_arm, 100, "the forearm is in view")
            self.cloud_pub.publish(cloud_message(points, stamp))
            scan = self.wait_for(stamp)
            self.assertIsNotNone(scan, "no scan for the forearm at y = %.2f" % arm_y)
            ranges = np.array(scan.ranges)
            finite = ranges[np.isfinite(ranges)]
            # No return on the forearm (its face is at 0.95 m, 1.10 m at most along its diagonal).
            self.assertTrue(np.all(finite > 1.5), "returns on the forearm at y = %.2f: %s" % (arm_y, finite[finite <= 1.5]))
            # In the forearm's directions (within 2 degrees of its centre), the wall behind it in
            # every beam that has points (the beams are finer than the camera's columns).
            angle = math.atan2(arm_y, ARM_X)
            near = [int(round((a - ANGLE_MIN) / ANGLE_INC)) for a in angle + np.radians(np.arange(-2.0, 2.01, 0.25))]
            walls = [(b, ranges[b]) for b in near if np.isfinite(ranges[b])]
            self.assertGreater(len(walls), 5, "the wall behind the forearm at y = %.2f" % arm_y)
            for b, r in walls:
                self.assertAlmostEqual(r, WALL_X / math.cos(ANGLE_MIN + b * ANGLE_INC), delta=0.02)
            # Every beam as brute force says: the closest point off the padded forearm.
            expected = expected_scan(points, arm_y)
            np.testing.assert_allclose(ranges, expected, rtol=0, atol=1e-3, err_msg="forearm at y = %.2f" % arm_y)


if __name__ == "__main__":
    rospy.init_node("self_filter_rostest")
    rostest.rosrun("depth_filter_scan_converter", "self_filter", SelfFilterTest)
