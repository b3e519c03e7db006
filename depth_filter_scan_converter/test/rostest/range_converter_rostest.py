#!/usr/bin/python3
"""rostest node shared by range_converter_nodelet.test and range_converter_node.test.

An ultrasonic sensor publishes sensor_msgs/Range on range_in; the converter (angle_increment
0.01, min_consecutive_readings 2) must answer each reading with a LaserScan arc in the sensor's
frame: the first in-range reading unconfirmed (NaN), the second an obstacle across the cone,
max_range a no return (+Inf), -Inf too close (-Inf), a finite value below min_range (0.0)
invalid (NaN). Bad messages (NaN field of view,
min_range > max_range, empty frame) give no scan and a diagnostic; a reading with an extreme stamp
is converted like any other; after all of them the next good readings still give their scans.
The subscription to range_in is lazy.
"""
import math
import threading
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import LaserScan, Range

FRAME = "sonar_front"
FOV = 0.52


def reading(rng, stamp, fov=FOV, min_range=0.3, max_range=5.0, frame=FRAME):
    m = Range()
    m.header.stamp = stamp
    m.header.frame_id = frame
    m.radiation_type = Range.ULTRASOUND
    m.field_of_view = fov
    m.min_range = min_range
    m.max_range = max_range
    m.range = rng
    return m


class RangeConverterTest(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.scans = []
        self.diagnostics = []
        self.pub = rospy.Publisher("range_in", Range, queue_size=20)
        deadline = rospy.Time.now() + rospy.Duration(30.0)
        while "/scan" not in [t for t, _ in rospy.get_published_topics()] and not rospy.is_shutdown():
            self.assertLess(rospy.Time.now(), deadline, "the converter never advertised scan")
            rospy.sleep(0.1)
        rospy.sleep(0.5)
        self.assertEqual(self.pub.get_num_connections(), 0, "subscribed to range_in with nobody listening")
        self.sub = rospy.Subscriber("scan", LaserScan, self.on_scan, queue_size=50)
        rospy.Subscriber("/diagnostics", DiagnosticArray, self.on_diagnostics, queue_size=50)
        while self.pub.get_num_connections() == 0 and not rospy.is_shutdown():
            self.assertLess(rospy.Time.now(), deadline, "the converter never subscribed to range_in")
            rospy.sleep(0.05)
        rospy.sleep(0.3)

    def on_scan(self, msg):
        with self.lock:
            self.scans.append(msg)

    def on_diagnostics(self, msg):
        with self.lock:
            self.diagnostics += [s for s in msg.status if "range_converter" in s.name]

    def send(self, msg, expect_scan=True, timeout=3.0):
        with self.lock:
            before = len(self.scans)
        self.pub.publish(msg)
        deadline = rospy.Time.now() + rospy.Duration(timeout if expect_scan else 0.5)
        while rospy.Time.now() < deadline and not rospy.is_shutdown():
            with self.lock:
                if len(self.scans) > before:
                    return self.scans[before]
            rospy.sleep(0.01)
        return None

    def check_geometry(self, scan, stamp):
        self.assertEqual(scan.header.frame_id, FRAME)
        self.assertEqual(scan.header.stamp, stamp)
        self.assertAlmostEqual(scan.angle_min, -FOV / 2, places=5)
        self.assertAlmostEqual(scan.angle_max, FOV / 2, places=5)
        self.assertLessEqual(scan.angle_increment, 0.01 + 1e-6)
        n = int(round((scan.angle_max - scan.angle_min) / scan.angle_increment)) + 1
        self.assertEqual(len(scan.ranges), n)
        self.assertAlmostEqual(scan.range_min, 0.3, places=5)
        self.assertAlmostEqual(scan.range_max, 5.0, places=5)

    def test_readings_bad_messages_and_lazy_subscription(self):
        t = rospy.Time(200.0)
        step = rospy.Duration(0.05)
        scan = self.send(reading(1.5, t))
        self.assertIsNotNone(scan, "no scan for a valid reading")
        self.check_geometry(scan, t)
        self.assertTrue(all(math.isnan(r) for r in scan.ranges), "the first echo is unconfirmed (NaN)")
        t += step
        scan = self.send(reading(1.5, t))
        self.check_geometry(scan, t)
        self.assertTrue(all(abs(r - 1.5) < 1e-6 for r in scan.ranges), "the second echo is an obstacle")
        t += step
        scan = self.send(reading(5.0, t))
        self.assertTrue(all(r == math.inf for r in scan.ranges), "max_range is no return")
        t += step
        scan = self.send(reading(-math.inf, t))
        self.assertTrue(all(r == -math.inf for r in scan.ranges), "-Inf is too close")
        t += step
        scan = self.send(reading(0.0, t))
        self.assertTrue(all(math.isnan(r) for r in scan.ranges), "0.0 (below min_range) is invalid")

        # Bad messages: no scan, the node stays alive.
        for bad in (reading(1.0, t + step, fov=float("nan")), reading(1.0, t + step, min_range=6.0),
                    reading(1.0, t + step, frame="")):
            self.assertIsNone(self.send(bad, expect_scan=False), "a bad message gave a scan")
        # Extreme stamps are converted as they are (nothing may throw on them).
        for extreme in (rospy.Time(4294967295, 999999999), rospy.Time(0, 1)):
            scan = self.send(reading(2.0, extreme))
            self.assertIsNotNone(scan, "no scan for a reading with an extreme stamp")
            self.assertEqual(scan.header.stamp, extreme)
        # Still alive and converting.
        for _ in range(2):
            t += step
            scan = self.send(reading(2.5, t))
            self.assertIsNotNone(scan, "the converter stopped after bad messages")
        self.assertTrue(all(abs(r - 2.5) < 1e-6 for r in scan.ranges))

        # The diagnostics report the bad messages.
        deadline = rospy.Time.now() + rospy.Duration(5.0)
        seen = False
        while not seen and rospy.Time.now() < deadline:
            with self.lock:
                for s in self.diagnostics:
                    values = {kv.key: kv.value for kv in s.values}
                    seen |= values.get("bad messages dropped") == "3"
            rospy.sleep(0.1)
        self.assertTrue(seen, "the diagnostics never counted the 3 bad messages")
        # One hardware ID per sensor: the node's name (four sonars must not share one).
        with self.lock:
            ids = {s.hardware_id for s in self.diagnostics}
        self.assertEqual(ids, {"/range_converter"}, "the hardware ID is not the node's name")

        # Nobody listens any more: the converter lets go of range_in.
        self.sub.unregister()
        deadline = rospy.Time.now() + rospy.Duration(10.0)
        while self.pub.get_num_connections() > 0 and rospy.Time.now() < deadline:
            rospy.sleep(0.05)
        self.assertEqual(self.pub.get_num_connections(), 0, "still subscribed to range_in with nobody listening")


if __name__ == "__main__":
    rospy.init_node("range_converter_rostest")
    rostest.rosrun("depth_filter_scan_converter", "range_converter_rostest", RangeConverterTest)
