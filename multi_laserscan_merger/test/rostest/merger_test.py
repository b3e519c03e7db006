#!/usr/bin/python3
"""rostest node shared by merger_nodelet.test, merger_node.test and merger_rate.test.

Plays the paper's robot standing in a round room (radius 3 m around base_link): two 360-beam
lidars at 8 Hz, two 328-beam camera scans at 14 Hz, odometry at 50 Hz, static tf. Checks
that the merged scan comes for every input (~mode every) or at the set rate (~mode rate),
that it shows the room and carries an input's stamp bit for bit, that when one source stops the
output goes on without it and /diagnostics says so, and recovers when it comes back, and that
malformed scans, odometry and tf (stamps 2^32 s ahead, nsecs not normalised, empty frame ids, NaN
or zero quaternions) are dropped, counted and named while valid input keeps being merged (issue 8)."""
import math
import threading
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

ROOM = 3.0
# name, frame, x, y, z, yaw, beams, angle_min, increment, rate (Hz), deskew time_increment
SOURCES = [
    ('lidar_front_left', 'lidar_fl', 0.37, 0.24, 0.2, math.pi / 4, 360, -math.pi, 2 * math.pi / 360, 8.0, True),
    ('lidar_rear_right', 'lidar_rr', -0.37, -0.24, 0.2, -3 * math.pi / 4, 360, -math.pi, 2 * math.pi / 360, 8.0, True),
    ('camera_front', 'cam_front', 0.37, 0.0, 0.3, 0.0, 328, math.radians(-41), math.radians(0.25), 14.0, False),
    ('camera_rear', 'cam_rear', -0.37, 0.0, 0.3, math.pi, 328, math.radians(-41), math.radians(0.25), 14.0, False),
]


def room_ranges(x, y, yaw, amin, inc, n):
    a = yaw + amin + inc * np.arange(n)
    ux, uy = np.cos(a), np.sin(a)
    su = x * ux + y * uy
    return (-su + np.sqrt(su * su - (x * x + y * y) + ROOM * ROOM)).astype(np.float32)


class MergerTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('merger_test')
        cls.mode = rospy.get_param('~mode', 'every')
        cls.rate = rospy.get_param('~expected_rate', 5.0)
        cls.lock = threading.Lock()
        cls.published = {s[0]: [] for s in SOURCES}
        cls.exact = set()  # (secs, nsecs) of every scan and odometry message published
        cls.odom_stamps = []
        cls.odom_stopped = False
        cls.frame_override = {}
        cls.outputs = []  # (stamp, message)
        cls.arrivals = []  # receive time of each output
        cls.diagnostics = {}
        cls.stopped = set()
        cls.static = tf2_ros.StaticTransformBroadcaster()
        transforms = []
        for name, frame, x, y, z, yaw, *_ in SOURCES:
            t = TransformStamped()
            t.header.stamp = rospy.Time.now()
            t.header.frame_id = 'base_link'
            t.child_frame_id = frame
            t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = x, y, z
            t.transform.rotation.z, t.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
            transforms.append(t)
        cls.static.sendTransform(transforms)
        rospy.Subscriber('merged_scan', LaserScan, cls.on_output, queue_size=100)
        cls.exact_outputs = []  # (secs, nsecs)
        rospy.Subscriber('/diagnostics', DiagnosticArray, cls.on_diagnostics, queue_size=20)
        cls.odom_pub = rospy.Publisher('odom', Odometry, queue_size=10)
        cls.tf_pub = rospy.Publisher('/tf', TFMessage, queue_size=10)
        cls.pubs = {}
        cls.timers = []
        for src in SOURCES:
            cls.pubs[src[0]] = rospy.Publisher(src[0] + '/scan', LaserScan, queue_size=10)
        for src in SOURCES:
            cls.timers.append(rospy.Timer(rospy.Duration(1.0 / src[9]), lambda e, s=src: cls.publish_scan(s)))
        cls.timers.append(rospy.Timer(rospy.Duration(0.02), lambda e: cls.publish_odom()))

    @classmethod
    def tearDownClass(cls):
        for t in cls.timers:
            t.shutdown()

    @classmethod
    def publish_scan(cls, src, stamp=None, frame=None):
        name, default_frame, x, y, z, yaw, n, amin, inc, rate, deskew = src
        if stamp is None and name in cls.stopped:
            return
        m = LaserScan()
        m.header.stamp = stamp if stamp is not None else rospy.Time.now()
        m.header.frame_id = frame if frame is not None else cls.frame_override.get(name, default_frame)
        m.angle_min, m.angle_increment = amin, inc
        m.angle_max = amin + (n - 1) * inc
        m.time_increment = (1.0 / rate) / n if deskew else 0.0
        m.scan_time = 1.0 / rate
        m.range_min, m.range_max = 0.05, 20.0
        m.ranges = room_ranges(x, y, yaw, amin, inc, n).tolist()
        with cls.lock:
            cls.published[name].append(m.header.stamp.to_sec())
            cls.exact.add((m.header.stamp.secs, m.header.stamp.nsecs))
        cls.pubs[name].publish(m)

    @classmethod
    def publish_odom(cls, stamp=None, quaternion=None):
        if stamp is None and cls.odom_stopped:
            return
        m = Odometry()
        m.header.stamp = stamp if stamp is not None else rospy.Time.now()
        m.header.frame_id = 'odom'
        m.child_frame_id = 'base_link'
        m.pose.pose.position.x, m.pose.pose.position.y = 1.0, 2.0  # standing still
        q = m.pose.pose.orientation
        q.x, q.y, q.z, q.w = quaternion or (0.0, 0.0, math.sin(0.15), math.cos(0.15))
        with cls.lock:
            cls.odom_stamps.append(m.header.stamp.to_sec())
            cls.exact.add((m.header.stamp.secs, m.header.stamp.nsecs))
        cls.odom_pub.publish(m)

    @classmethod
    def on_output(cls, m):
        with cls.lock:
            cls.outputs.append((m.header.stamp.to_sec(), m))
            cls.exact_outputs.append((m.header.stamp.secs, m.header.stamp.nsecs))
            cls.arrivals.append(rospy.Time.now().to_sec())

    @classmethod
    def on_diagnostics(cls, m):
        with cls.lock:
            for s in m.status:
                cls.diagnostics[s.name] = s

    def wait_for(self, condition, timeout, what):
        end = rospy.Time.now() + rospy.Duration(timeout)
        while not rospy.is_shutdown() and rospy.Time.now() < end:
            with self.lock:
                if condition():
                    return
            rospy.sleep(0.05)
        self.fail('timed out waiting for ' + what)

    @staticmethod
    def coverage(r):
        """Fraction of 1-degree sectors with a return (1-degree lidars leave gaps between 0.25-degree bins)."""
        return float(np.isfinite(r[:1440].reshape(-1, 4)).any(1).mean())

    def source_status(self, name):
        for key, s in self.diagnostics.items():
            if key.endswith('source ' + name):
                return s
        return None

    def test_1_output(self):
        self.wait_for(lambda: len(self.outputs) > 5, 20.0, 'the first merged scans')
        rospy.sleep(1.0)  # every source is in by now
        start = rospy.Time.now().to_sec()
        rospy.sleep(3.0)
        end = rospy.Time.now().to_sec()
        rospy.sleep(0.5)  # let the last outputs arrive
        with self.lock:
            outs = [(t, m) for t, m in self.outputs if start <= t <= end]
            inputs = sorted(t for v in self.published.values() for t in v if start + 0.1 <= t <= end - 0.1)
            all_inputs = [t for v in self.published.values() for t in v if start <= t <= end]
            odom = list(self.odom_stamps)
        self.assertGreater(len(outs), 0)
        stamps = [t for t, _ in outs]
        if self.mode == 'every':
            # One output per input that is newer than the last output (counted by publish /
            # receive time in the window), each stamped with the newest scan: an input's stamp.
            # Inputs from different connections may arrive out of order; one older than the
            # last output goes into the next output instead of repeating a stamp: none on an
            # idle machine, about 12 % of these inputs with the test suite alone on 2 cores,
            # 26 % with a compiler and a benchmark running beside it. A merger that published
            # for one source only, or on a timer, would give at most a third.
            with self.lock:
                received = sum(1 for t in self.arrivals if start <= t <= end)
            rospy.loginfo('%d inputs published, %d outputs received in %.1f s', len(all_inputs), received, end - start)
            self.assertGreaterEqual(received, 0.6 * len(all_inputs) - 2)
            self.assertLessEqual(received, len(all_inputs) + 4)
            self.assertTrue(all(a < b for a, b in zip(stamps, stamps[1:])), 'output stamps repeat or go back')
            with self.lock:
                every_input = set(t for v in self.published.values() for t in v)
            self.assertTrue(all(t in every_input for t in stamps))
        else:
            rate = len(outs) / (end - start)
            rospy.loginfo('output rate %.2f Hz (expected %.1f)', rate, self.rate)
            self.assertGreater(rate, 0.6 * self.rate)
            self.assertLess(rate, 1.4 * self.rate)
            self.assertTrue(all(b > a for a, b in zip(stamps, stamps[1:])), 'stamps must increase')
            # Synchronised to data that exists (a scan or odometry stamp), never to now().
            known = set(inputs) | set(odom) | set(t for v in self.published.values() for t in v)
            self.assertTrue(all(t in known for t in stamps))
        with self.lock:
            # Bit for bit: (secs, nsecs) of a published scan (or odometry, with a rate), never
            # rounded through double seconds.
            wrong = [e for e in self.exact_outputs if e not in self.exact]
        self.assertEqual(wrong, [], 'output stamps that are no input stamp')
        m = outs[-1][1]
        self.assertEqual(m.header.frame_id, 'base_link')
        self.assertEqual(len(m.ranges), 1441)
        self.assertEqual(m.time_increment, 0.0)
        r = np.array(m.ranges)
        finite = r[np.isfinite(r)]
        self.assertGreater(self.coverage(r), 0.95)
        self.assertAlmostEqual(float(np.median(finite)), ROOM, delta=0.02)
        self.assertLess(float(np.max(np.abs(finite - ROOM))), 0.05)

    def test_2_source_stops_and_comes_back(self):
        self.wait_for(lambda: len(self.outputs) > 5, 20.0, 'merged scans')
        self.stopped.add('camera_rear')
        rospy.sleep(1.5)  # well past its 0.3 s timeout
        mark = rospy.Time.now().to_sec()
        rospy.sleep(1.0)
        with self.lock:
            after = [m for t, m in self.outputs if t >= mark]
        self.assertGreater(len(after), 3, 'the output must go on with the other sources')
        self.assertGreater(self.coverage(np.array(after[-1].ranges)), 0.95)  # the lidars still see the whole room

        def stale():
            s = self.source_status('camera_rear')
            return s is not None and s.level == DiagnosticStatus.WARN and 'stale' in s.message
        self.wait_for(stale, 5.0, 'diagnostics reporting camera_rear stale')
        with self.lock:
            s = self.source_status('camera_rear')
            values = {v.key: v.value for v in s.values}
            others = self.source_status('lidar_front_left')
        self.assertGreaterEqual(int(values['scans left out by timeout']), 1)
        self.assertEqual(others.level, DiagnosticStatus.OK)
        lidar = {v.key: v.value for v in others.values}
        self.assertGreater(float(lidar['rate (Hz)']), 4.0)  # published at 8 Hz
        # The evaluation links a source's counts to the output they are about by this topic.
        self.assertEqual(lidar['merged scan topic'], rospy.resolve_name('merged_scan'))
        self.assertGreater(int(lidar['scans received']), 20)
        self.assertLess(float(lidar['rate (Hz)']), 12.0)
        self.assertLess(float(lidar['age of last scan (s)']), 0.5)
        self.assertEqual(int(lidar['transform failures']), 0)

        self.stopped.discard('camera_rear')

        def back():
            s = self.source_status('camera_rear')
            return s is not None and s.level == DiagnosticStatus.OK
        self.wait_for(back, 5.0, 'diagnostics reporting camera_rear back')
        with self.lock:
            odom = self.source_status('odometry') or [s for k, s in self.diagnostics.items() if k.endswith('odometry')][0]
        self.assertEqual(odom.level, DiagnosticStatus.OK)

    def test_3_bad_input_is_dropped_and_named(self):
        self.wait_for(lambda: len(self.outputs) > 5, 20.0, 'merged scans')
        lidar = SOURCES[0]
        not_normalised = rospy.Time()
        not_normalised.secs, not_normalised.nsecs = rospy.Time.now().secs, 2000000000
        before = self.source_status(lidar[0])
        malformed_before = int({v.key: v.value for v in before.values}['malformed scans']) if before else 0
        # Scans: stamps beyond any ros::Duration from the clock (the crash of issue 8), nsecs not
        # normalised, an empty frame id. Odometry: the same stamp, NaN and zero quaternions.
        for _ in range(3):
            self.publish_scan(lidar, stamp=rospy.Time(4294967295, 999999999))
            self.publish_scan(lidar, stamp=rospy.Time(4294967295, 0))
            self.publish_scan(lidar, stamp=not_normalised)
            self.publish_scan(lidar, frame='')
            self.publish_odom(stamp=rospy.Time(4294967295, 999999999))
            self.publish_odom(quaternion=(float('nan'), 0.0, 0.0, 1.0))
            self.publish_odom(quaternion=(0.0, 0.0, 0.0, 0.0))
            self.publish_odom(quaternion=(0.0, 0.0, 2 * math.sin(0.15), 2 * math.cos(0.15)))  # normalised, used
            t = TransformStamped()  # tf2 itself throws on a stamp this close to 2^32 s
            t.header.stamp, t.header.frame_id, t.child_frame_id = rospy.Time(4294967290, 0), 'base_link', 'junk'
            t.transform.rotation.w = 1.0
            self.tf_pub.publish(TFMessage(transforms=[t]))
            rospy.sleep(0.1)
        # A tf1-era frame id ('/cam_front'): tf2 refuses it, the merger strips the slash.
        with self.lock:
            self.frame_override['camera_front'] = '/cam_front'
        mark = rospy.Time.now().to_sec()
        rospy.sleep(1.5)
        with self.lock:
            after = [m for t, m in self.outputs if t >= mark]
        self.assertGreater(len(after), 3, 'the merger must keep merging valid input')
        r = np.array(after[-1].ranges)
        self.assertGreater(self.coverage(r), 0.95)
        self.assertAlmostEqual(float(np.median(r[np.isfinite(r)])), ROOM, delta=0.02)

        def counted():
            s = self.source_status(lidar[0])
            if s is None:
                return False
            v = {x.key: x.value for x in s.values}
            return int(v['malformed scans']) >= malformed_before + 12
        self.wait_for(counted, 5.0, 'the malformed scans counted in diagnostics')
        with self.lock:
            v = {x.key: x.value for x in self.source_status(lidar[0]).values}
            camera = self.source_status('camera_front')
            cv = {x.key: x.value for x in camera.values}
            odom = [s for k, s in self.diagnostics.items() if k.endswith('odometry')][0]
            ov = {x.key: x.value for x in odom.values}
            self.frame_override.clear()
        self.assertTrue(v['last drop reason'].startswith('malformed scan: '), v['last drop reason'])
        self.assertGreaterEqual(int(ov['messages ignored']), 9)
        self.assertNotEqual(ov['last ignored because'], 'none')
        # The slashed camera frames were merged: no transform failure, no drop, not stale.
        self.assertEqual(int(cv['transform failures']), 0)
        self.assertEqual(int(cv['scans dropped']), 0)
        self.assertLess(float(cv['age of last scan (s)']), 0.3)
        self.assertEqual(camera.hardware_id, odom.hardware_id)
        self.assertIn('merger', camera.hardware_id)

    def test_4_output_stamp_is_the_input_stamp_bit_for_bit(self):
        self.wait_for(lambda: len(self.outputs) > 5, 20.0, 'merged scans')
        with self.lock:
            self.stopped.update(s[0] for s in SOURCES)
            MergerTest.odom_stopped = True  # a class attribute: the publishing timers read it
        rospy.sleep(0.5)
        # A stamp with nsecs 944403171 (issue 7: ...944403171 in, ...172 out), newer than every
        # input so far, so that the output is synchronised to it.
        while rospy.Time.now().nsecs < 950000000:
            rospy.sleep(0.002)
        stamp = rospy.Time(rospy.Time.now().secs, 944403171)
        self.publish_scan(SOURCES[2], stamp=stamp)
        try:
            self.wait_for(lambda: (stamp.secs, stamp.nsecs) in self.exact_outputs, 5.0,
                          'an output stamped %d.%09d' % (stamp.secs, stamp.nsecs))
        finally:
            with self.lock:
                self.stopped.clear()
                MergerTest.odom_stopped = False


if __name__ == '__main__':
    rostest.rosrun('multi_laserscan_merger', 'merger_test', MergerTest)
