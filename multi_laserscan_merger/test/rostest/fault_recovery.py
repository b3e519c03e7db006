#!/usr/bin/python3
"""Fault rostest in simulated time (issue 8), run by fault_recovery.test.

This node owns /clock: one driver thread advances simulated time in 10 ms ticks and, at
simulated rates, publishes the lidar scan (10 Hz), the camera cloud (10 Hz, to the converter),
the lidar's mount on /tf (20 Hz; the camera's is static) and odometry (50 Hz). When the machine
is slow, simulated time slows with it, so rates and recovery times measured in simulated time
do not depend on the load. Faults, one after the other:
  - the lidar stops for 2 s and comes back (the camera keeps its rate);
  - the lidar's tf stops for 2 s and comes back;
  - /clock jumps back 10 s, then forward 100 s;
  - odometry stops for 2 s, then jumps 10 m.
During a fault the merged output must keep the camera's rate with the right content; after
it, the first output showing both sensors again must come within MAX_RECOVERY (simulated s),
and the output rate must be back. Prints every recovery time."""
import threading
import time
import unittest

import rospy
import rostest
import tf2_ros
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan, PointCloud2
from tf2_msgs.msg import TFMessage

from scan_watch import LIDAR_DISTANCE, WALL_DISTANCE, ScanWatch, mount_transforms, room_fraction, wall_fraction

from laserscan_toolbox.experiments import fuzz_inputs as fz

TICK_NS = 10_000_000  # 10 ms of simulated time per tick
MAX_RECOVERY = 0.5  # s (simulated) from the end of a fault to a complete output
FULL_RATE = 20.0  # Hz: one output per lidar scan and per camera scan
CAMERA_RATE = 10.0


class Driver(threading.Thread):
    """Simulated clock and sensors; the test flips the switches."""

    def __init__(self):
        super().__init__(daemon=True)
        self.lock = threading.Lock()
        self.t_ns = 1_000 * 1_000_000_000  # simulated time starts at 1000 s
        self.tick = 0
        self.lidar_on = self.lidar_tf_on = self.odom_on = True
        self.odom_x = 0.0
        self.running = True
        self.clock_pub = rospy.Publisher("/clock", Clock, queue_size=10)
        self.tf_pub = rospy.Publisher("/tf", TFMessage, queue_size=100)
        self.scan_pub = rospy.Publisher("lidar/scan", LaserScan, queue_size=100)
        self.cloud_pub = rospy.Publisher("camera/points", PointCloud2, queue_size=100)
        self.odom_pub = rospy.Publisher("odom", Odometry, queue_size=100)

    def now(self):
        """Simulated time (s) as the driver last published it (jumps with the clock)."""
        with self.lock:
            return self.t_ns * 1e-9

    def elapsed(self):
        """Simulated seconds run since the start: never jumps, so windows and recovery times
        are measured on it."""
        with self.lock:
            return self.tick * TICK_NS * 1e-9

    def run(self):
        while self.running and not rospy.is_shutdown():
            with self.lock:
                self.t_ns += TICK_NS
                self.tick += 1
                stamp = rospy.Time(nsecs=self.t_ns)
                tick, lidar_on, lidar_tf_on, odom_on, odom_x = (self.tick, self.lidar_on, self.lidar_tf_on,
                                                               self.odom_on, self.odom_x)
            self.clock_pub.publish(Clock(clock=stamp))
            if tick % 5 == 0 and lidar_tf_on:
                self.tf_pub.publish(TFMessage(transforms=mount_transforms(["lidar"], stamp)))
            if tick % 2 == 0 and odom_on:
                self.odom_pub.publish(fz.odometry("odom", "base_link", stamp, x=odom_x))
            if tick % 10 == 0 and lidar_on:
                self.scan_pub.publish(fz.valid_scan("lidar", stamp, distance=LIDAR_DISTANCE))
            if tick % 10 == 5:
                self.cloud_pub.publish(fz.valid_cloud("camera", stamp, WALL_DISTANCE))
            time.sleep(TICK_NS * 1e-9)

    def wait_until(self, t):
        """Blocks (wall time) until elapsed() reaches t."""
        while self.elapsed() < t and not rospy.is_shutdown():
            time.sleep(0.005)


def complete(msg):
    """Both sensors in the output: the lidar's room beside and behind, the camera's wall ahead."""
    return room_fraction(msg) >= 0.95 and wall_fraction(msg) >= 0.9


def camera_only(msg):
    """The lidar left out (no room), the camera's wall still there."""
    return room_fraction(msg) == 0.0 and wall_fraction(msg) >= 0.9


class FaultRecovery(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.driver = Driver()
        tf2_ros.StaticTransformBroadcaster().sendTransform(mount_transforms(["camera"], rospy.Time(0)))
        cls.merged = ScanWatch("merged", clock=cls.driver.elapsed)
        cls.driver.start()
        cls.recoveries = {}

    @classmethod
    def tearDownClass(cls):
        cls.driver.running = False

    def assert_rate(self, t0, t1, rate, what, content):
        """Outputs that arrived in [t0, t1] (elapsed simulated s): at least 70 % of `rate`, each
        passing content(msg)."""
        self.driver.wait_until(t1 + 0.3)  # messages on their way when the window closed
        outputs = [m for a, m in self.merged.between(t0, t1)]
        measured = len(outputs) / (t1 - t0)
        print(f"  {what}: {measured:.1f} Hz (expected {rate:.0f} Hz)")
        self.assertGreaterEqual(measured, 0.7 * rate, f"{what}: output rate {measured:.1f} Hz")
        bad = [(round(m.header.stamp.to_sec(), 3), f"room {room_fraction(m):.0%}", f"wall {wall_fraction(m):.0%}")
               for m in outputs if not content(m)]
        self.assertEqual(bad, [], f"{what}: outputs with the wrong content (stamp, room, wall)")

    def end_fault(self, name, change):
        """Ends a fault by change() (under the driver's lock); the first complete output stamped
        in the new time line (within 5 s of the clock at the end: outputs of before a clock
        jump are stamped 10 s later or 100 s earlier) must arrive within MAX_RECOVERY simulated
        seconds. Returns when the window after the fault may open (elapsed s)."""
        d = self.driver
        start = self.merged.count()  # outputs before the change do not count (the clock repeats itself)
        with d.lock:
            change()
            end_stamp, end_elapsed = d.t_ns * 1e-9, d.tick * TICK_NS * 1e-9

        def recovered(m):
            return end_stamp <= m.header.stamp.to_sec() <= end_stamp + 5.0 and complete(m)

        arrival, msg = self.merged.wait_for(recovered, 60.0, start=start)
        self.assertIsNotNone(msg, f"{name}: no complete output after the fault")
        recovery = arrival - end_elapsed
        self.recoveries[name] = recovery
        print(f"  {name}: recovered in {recovery:.3f} s (simulated)")
        self.assertLessEqual(recovery, MAX_RECOVERY, f"{name}: recovery took {recovery:.3f} s")
        # The window after a fault opens one tick after the recovery: an incomplete output can
        # arrive at the same simulated instant just before it (a scan waiting for its tf is
        # merged right after the camera scan that woke it).
        return arrival + TICK_NS * 1e-9

    def set(self, **switches):
        with self.driver.lock:
            for name, value in switches.items():
                setattr(self.driver, name, value)

    def test_faults(self):
        d = self.driver
        # Start-up (plugin loading, tf) may take long on a loaded machine.
        _, msg = self.merged.wait_for(complete, 90.0)
        self.assertIsNotNone(msg, "the pipeline never produced a complete output")
        t = d.elapsed()
        print("\nfault recovery (simulated time):")
        self.assert_rate(t, t + 2.0, FULL_RATE, "normal", complete)

        # A source stops and comes back: the camera keeps its rate, the lidar is left out after its timeout.
        self.set(lidar_on=False)
        t = d.elapsed()
        self.assert_rate(t + 0.8, t + 2.0, CAMERA_RATE, "lidar stopped", camera_only)
        t = self.end_fault("lidar back", lambda: setattr(d, "lidar_on", True))
        self.assert_rate(t, t + 1.0, FULL_RATE, "after the lidar came back", complete)

        # tf of one source missing, then present again.
        self.set(lidar_tf_on=False)
        t = d.elapsed()
        self.assert_rate(t + 0.8, t + 2.0, CAMERA_RATE, "lidar tf missing", camera_only)
        t = self.end_fault("lidar tf back", lambda: setattr(d, "lidar_tf_on", True))
        self.assert_rate(t, t + 1.0, FULL_RATE, "after the tf came back", complete)

        # /clock jumps back 10 s, then forward 100 s.
        for name, seconds in (("clock back 10 s", -10.0), ("clock forward 100 s", 100.0)):
            t = self.end_fault(name, lambda s=seconds: setattr(d, "t_ns", d.t_ns + int(s * 1e9)))
            self.assert_rate(t, t + 1.0, FULL_RATE, f"after {name}", complete)

        # Odometry stops: the output goes on unchanged (no motion known, none applied); it comes
        # back 10 m away (a jump).
        self.set(odom_on=False)
        t = d.elapsed()
        self.assert_rate(t, t + 2.0, FULL_RATE, "odometry stopped", complete)
        t = self.end_fault("odometry back, jumped 10 m",
                           lambda: (setattr(d, "odom_on", True), setattr(d, "odom_x", 10.0)))
        self.assert_rate(t, t + 1.0, FULL_RATE, "after the odometry jump", complete)
        print("recovery times (simulated s): " + ", ".join(f"{k} {v:.3f}" for k, v in self.recoveries.items()))


if __name__ == "__main__":
    rospy.init_node("fault_recovery")
    rostest.rosrun("multi_laserscan_merger", "fault_recovery", FaultRecovery)
