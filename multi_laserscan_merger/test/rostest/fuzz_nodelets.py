#!/usr/bin/python3
"""Node fuzz (issue 8), run by fuzz_nodelets.test.

A converter and a merger nodelet share one manager (fuzz_pipeline.launch). Each burst sends
seeded malformed clouds (to the converter), scans (to the merger's lidar source), odometry
and tf (laserscan_toolbox.experiments.fuzz_inputs; and /tf transforms of the lidar's static mount, 5 m off,
which must not replace it), while the camera's mount is published on /tf at 50 Hz; then a
valid cloud and a valid lidar scan must each give a correct output within ~max_latency
seconds, stamped exactly as the valid input (bit for bit).
Every scan either node publishes is checked (length against the angles, no finite range
outside its limits), and the manager must be alive at the end. Prints the counts."""
import collections
import random
import time
import unittest

import rosnode
import rospy
import rostest
import tf2_ros
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan, PointCloud2
from tf2_msgs.msg import TFMessage

from scan_watch import LIDAR_DISTANCE, WALL_DISTANCE, ScanWatch, mount_transforms, room_fraction, wall_fraction

from laserscan_toolbox.experiments import fuzz_inputs as fz

def frame_problem(msg):
    return [] if msg.header.frame_id == "base_link" else [f"frame {msg.header.frame_id!r}"]


class Pipeline:
    """Publishers into, and watches on, the nodelets under test."""

    def __init__(self):
        self.cloud_pub = rospy.Publisher("camera/points", PointCloud2, queue_size=1000)
        self.scan_pub = rospy.Publisher("lidar/scan", LaserScan, queue_size=1000)
        self.odom_pub = rospy.Publisher("odom", Odometry, queue_size=1000)
        self.camera = ScanWatch("camera/scan")
        self.merged = ScanWatch("merged")

    def wait_connected(self, timeout):
        deadline = time.monotonic() + timeout
        pubs = (self.cloud_pub, self.scan_pub, self.odom_pub)
        while time.monotonic() < deadline and not rospy.is_shutdown():
            if all(p.get_num_connections() > 0 for p in pubs):
                return True
            time.sleep(0.05)
        return False

    def round_trip(self, timeout):
        """Valid odometry, cloud and lidar scan; returns (camera latency, merged latency, problems)."""
        problems = []
        now = rospy.Time.now()
        self.odom_pub.publish(fz.odometry("odom", "base_link", now))
        s1 = rospy.Time.now()
        sent = time.monotonic()
        self.cloud_pub.publish(fz.valid_cloud("camera", s1, WALL_DISTANCE))
        arrival, cam = self.camera.wait_stamp(s1, timeout)
        camera_latency = arrival - sent if cam else None
        if cam is None:
            problems.append(f"no camera scan stamped {s1.secs}.{s1.nsecs:09d} within {timeout} s")
        else:
            problems += ["camera scan: " + p for p in frame_problem(cam)]
            if wall_fraction(cam) < 1.0:
                problems.append(f"camera scan: only {wall_fraction(cam):.0%} of the front beams on the wall")
        s2 = rospy.Time.now()
        if s2 <= s1:
            s2 = s1 + rospy.Duration(0, 1)
        self.odom_pub.publish(fz.odometry("odom", "base_link", s2))
        sent = time.monotonic()
        self.scan_pub.publish(fz.valid_scan("lidar", s2, distance=LIDAR_DISTANCE))
        arrival, merged = self.merged.wait_stamp(s2, timeout)
        merged_latency = arrival - sent if merged else None
        if merged is None:
            later = self.merged.wait_for(lambda m: m.header.stamp >= s2, 0.0)[1]
            problems.append(f"no merged scan stamped exactly {s2.secs}.{s2.nsecs:09d} within {timeout} s" +
                            (f" (one came stamped {later.header.stamp.secs}.{later.header.stamp.nsecs:09d})"
                             if later else ""))
        else:
            problems += ["merged scan: " + p for p in frame_problem(merged)]
            if room_fraction(merged) < 0.95:
                problems.append(f"merged scan: only {room_fraction(merged):.0%} of the side beams on the room")
        return camera_latency, merged_latency, problems


class NodeFuzz(unittest.TestCase):
    def test_malformed_bursts_then_valid_input(self):
        seed = rospy.get_param("~seed", 8)
        bursts = rospy.get_param("~bursts", 40)
        burst_size = rospy.get_param("~burst_size", 55)
        max_latency = rospy.get_param("~max_latency", 1.0)
        rng = random.Random(seed)
        tf2_ros.StaticTransformBroadcaster().sendTransform(mount_transforms(["lidar"], rospy.Time.now()))
        # The camera's mount is dynamic (as on a tilting head), so that clouds wait in the
        # converter's tf filter: extreme stamps reach tf2's and roscpp's time arithmetic there.
        tf_pub = rospy.Publisher("/tf", TFMessage, queue_size=100)
        mounts_sent = [0]

        def send_mount(_):
            tf_pub.publish(TFMessage(mount_transforms(["camera"], rospy.Time.now())))
            mounts_sent[0] += 1

        tf_timer = rospy.Timer(rospy.Duration(0.02), send_mount)
        self.addCleanup(tf_timer.shutdown)
        p = Pipeline()
        self.assertTrue(p.wait_connected(60.0), "the nodelets did not subscribe within 60 s")
        # Start-up (plugin loading, tf) may take long on a loaded machine: retry the first round trip.
        deadline = time.monotonic() + 60.0
        while True:
            _, _, problems = p.round_trip(2.0)
            if not problems or time.monotonic() > deadline:
                break
        self.assertEqual(problems, [], "the pipeline never produced a correct output on valid input")

        counts = collections.Counter()
        failures = []
        camera_latencies, merged_latencies = [], []
        for burst in range(bursts):
            for _ in range(burst_size):
                now = rospy.Time.now()
                kind = rng.random()
                if kind < 0.4:
                    msg, case = fz.malformed_cloud(rng, "camera", now)
                    p.cloud_pub.publish(msg)
                elif kind < 0.8:
                    msg, case = fz.malformed_scan(rng, "lidar", now)
                    p.scan_pub.publish(msg)
                elif kind < 0.95:
                    msg, case = fz.malformed_odometry(rng, "odom", "base_link", now)
                    p.odom_pub.publish(msg)
                elif kind < 0.975:
                    msg, case = fz.malformed_tf(rng, "base_link", "camera", now)
                    tf_pub.publish(msg)
                else:
                    # A well-formed /tf transform of the lidar's static mount, 5 m off: in tf2 it
                    # would replace the static transform for good; the nodes ignore it.
                    conflict = mount_transforms(["lidar"], now)
                    conflict[0].transform.translation.x += 5.0
                    tf_pub.publish(TFMessage(conflict))
                    case = "tf/static_conflict"
                counts[case] += 1
                time.sleep(0.002)  # let the nodes take most of them (their queues are short)
            # tf2 interpolates the camera's mount at the valid cloud's stamp from the samples
            # around it: two good ones must have followed the burst's last malformed one.
            sent = mounts_sent[0]
            deadline = time.monotonic() + 10.0
            while mounts_sent[0] < sent + 2 and time.monotonic() < deadline:
                time.sleep(0.005)
            camera_latency, merged_latency, problems = p.round_trip(max_latency)
            failures += [f"burst {burst}: {problem}" for problem in problems]
            if camera_latency is not None:
                camera_latencies.append(camera_latency)
            if merged_latency is not None:
                merged_latencies.append(merged_latency)

        alive = rosnode.rosnode_ping(rospy.resolve_name("fuzz_manager"), max_count=1, verbose=False)
        total = sum(counts.values())
        kinds = collections.Counter(case.split("/")[0] for case in counts.elements())
        print(f"\nnode fuzz (seed {seed}): {total} malformed messages in {bursts} bursts "
              f"({kinds['cloud']} clouds, {kinds['scan']} scans, {kinds['odometry']} odometry, {kinds['tf']} tf); "
              f"{len(merged_latencies)}/{bursts} valid round trips correct in time; "
              f"worst latency camera {max(camera_latencies, default=float('nan')):.3f} s, "
              f"merged {max(merged_latencies, default=float('nan')):.3f} s; "
              f"{p.camera.count()} camera and {p.merged.count()} merged scans checked; "
              f"manager {'alive' if alive else 'DEAD'}")
        print("cases: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
        self.assertGreaterEqual(total, 2000)
        self.assertTrue(alive, "the nodelet manager died")
        self.assertEqual(failures, [])
        self.assertEqual(p.camera.problems, [], "camera scans breaking the invariants")
        self.assertEqual(p.merged.problems, [], "merged scans breaking the invariants")


if __name__ == "__main__":
    rospy.init_node("fuzz_nodelets")
    rostest.rosrun("multi_laserscan_merger", "fuzz_nodelets", NodeFuzz)
