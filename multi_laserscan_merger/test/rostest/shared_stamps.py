#!/usr/bin/python3
"""rostest node of merger_shared_stamps.test (publish_rate 0) and merger_shared_stamps_rate.test
(publish_rate 10 Hz), issue 18.

Three sources publish the scans of each frame with ONE stamp at 17 Hz, as a driver that cuts one
lidar into several scans or a simulator whose sensors update in one step: each source is a
120-degree sector of a lidar at base_link whose ranges say which frame they belong to. The three
scans of a frame go out in a random order, spread over up to 30 ms. Checks that every merged
output at a frame's stamp holds every source's scan of that frame, that no stamp is published
twice (stamps increase), and that after one source stops the others' outputs keep coming, each
complete, with the stopped source counted once as missing from an output in its diagnostics."""
import math
import random
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import LaserScan

from scan_watch import ScanWatch, mount_transforms, stamp_key

SECTORS = ["sector_a", "sector_b", "sector_c"]
BEAMS = 120  # per sector, 1 degree apart: beam i of sector k is output bin 120 k + i
RATE = 17.0  # not a multiple of the 10 Hz ticks: they meet every phase of the frames
FRAMES_ALL = 60  # frames from all three sources
FRAMES_AFTER_STOP = 30  # then sector_c stops
SPREAD = 0.015  # s, at most between two scans of one frame


def frame_range(frame):
    """The range every beam of a frame reads (distinct for 50 frames in a row)."""
    return 1.0 + 0.01 * (frame % 50)


def sector_value(msg, k):
    """Median range of sector k's inner bins in a merged scan (NaN when they hold no return)."""
    r = np.array(msg.ranges[BEAMS * k + 10:BEAMS * k + BEAMS - 10], dtype=float)
    r = r[np.isfinite(r)]
    return float(np.median(r)) if r.size else math.nan


class SharedStamps(unittest.TestCase):
    def setUp(self):
        rospy.init_node("shared_stamps_test")
        tf2_ros.StaticTransformBroadcaster().sendTransform(
            [t for t in mount_transforms(["lidar"], rospy.Time.now())])
        self.pubs = [rospy.Publisher(name + "/scan", LaserScan, queue_size=10) for name in SECTORS]
        self.merged = ScanWatch("merged_scan")
        self.diagnostics = {}
        self.lock = threading.Lock()
        rospy.Subscriber("/diagnostics", DiagnosticArray, self.on_diagnostics, queue_size=20)

    def on_diagnostics(self, m):
        with self.lock:
            for s in m.status:
                self.diagnostics[s.name] = {v.key: v.value for v in s.values}

    def scan(self, k, frame, stamp):
        m = LaserScan()
        m.header.stamp = stamp
        m.header.frame_id = "lidar"
        m.angle_increment = 2 * math.pi / 360
        m.angle_min = -math.pi + BEAMS * k * m.angle_increment
        m.angle_max = m.angle_min + (BEAMS - 1) * m.angle_increment
        m.range_min, m.range_max = 0.05, 20.0
        m.ranges = [frame_range(frame)] * BEAMS
        return m

    def wait_connected(self):
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline and not rospy.is_shutdown():
            if all(p.get_num_connections() > 0 for p in self.pubs) and self.merged.connected():
                return
            time.sleep(0.05)
        self.fail("the merger and this test did not connect within 30 s")

    def play(self, frames, sources, first, rng):
        """Publishes `frames` frames from `sources` at RATE; returns {stamp key: frame}."""
        sent = {}
        start = time.monotonic()
        for f in range(first, first + frames):
            stamp = rospy.Time.now()
            sent[stamp_key(stamp)] = f
            order = list(sources)
            rng.shuffle(order)
            for n, k in enumerate(order):
                if n:
                    time.sleep(rng.uniform(0.0, SPREAD))
                self.pubs[k].publish(self.scan(k, f, stamp))
            time.sleep(max(0.0, start + (f - first + 1) / RATE - time.monotonic()))
        return sent, stamp

    def test_every_output_of_a_shared_stamp_is_complete(self):
        self.wait_connected()
        rng = random.Random(18)
        sent_all, last_all = self.play(FRAMES_ALL, range(3), 0, rng)
        _, last = self.merged.wait_for(lambda m: m.header.stamp >= last_all, 10.0)
        self.assertIsNotNone(last, "no output at the last frame of all three sectors")
        sent_two, last_two = self.play(FRAMES_AFTER_STOP, range(2), FRAMES_ALL, rng)
        _, last = self.merged.wait_for(lambda m: m.header.stamp >= last_two, 10.0)
        self.assertIsNotNone(last, "no output at the last frame after sector_c stopped")
        outputs = [m for _, m in self.merged.between(0.0, math.inf)]
        self.wait_diagnostics(lambda d: int(d["output"]["outputs published"]) >= len(outputs))
        stamps = [stamp_key(m.header.stamp) for m in outputs]
        self.assertEqual(self.merged.problems, [])
        self.assertTrue(all(a < b for a, b in zip(stamps, stamps[1:])), "a stamp published twice, or an older after a newer")
        by_stamp = {stamp_key(m.header.stamp): m for m in outputs}
        # From the third frame on (each source's period is known from two scans): complete.
        incomplete = []
        for key, f in sent_all.items():
            if f < 3 or key not in by_stamp:
                continue
            values = [sector_value(by_stamp[key], k) for k in range(3)]
            if any(abs(v - frame_range(f)) > 1e-4 for v in values):
                incomplete.append((f, values))
        rospy.loginfo("%d frames of three sectors, %d outputs at their stamps, %d incomplete", len(sent_all),
                      sum(1 for k in sent_all if k in by_stamp), len(incomplete))
        self.assertEqual(incomplete, [], "outputs at a shared stamp without every sector's scan of it")
        # With publish_rate 0 every frame gives one output; with a rate, a tick picks the newest.
        rate = rospy.get_param("/merger/publish_rate", 0.0)
        published = sum(1 for k in sent_all if k in by_stamp)
        if rate == 0.0:
            self.assertEqual(published, len(sent_all))
        else:
            self.assertGreater(published, 0.6 * rate / RATE * len(sent_all))
        # sector_c stopped: the others' outputs keep coming, complete (the first one after the stop
        # waited for sector_c until sync_window ended).
        after = [(f, by_stamp[k]) for k, f in sent_two.items() if k in by_stamp]
        if rate == 0.0:
            self.assertEqual(len(after), len(sent_two))
        else:
            self.assertGreater(len(after), 0.6 * rate / RATE * len(sent_two))
        for f, m in after:
            self.assertAlmostEqual(sector_value(m, 0), frame_range(f), delta=1e-4)
            self.assertAlmostEqual(sector_value(m, 1), frame_range(f), delta=1e-4)
        with self.lock:
            c, output = self.status("source sector_c"), self.status("output")
        rospy.loginfo("sector_c: %s; output: %s", c, output)
        waited = int(output["outputs that waited for scans of their stamp"])
        if rate == 0.0:
            # Every frame from the third on waited for the scans after its first; the first
            # output after the stop waited for sector_c in vain.
            self.assertGreaterEqual(waited, FRAMES_ALL + FRAMES_AFTER_STOP - 3)
            self.assertGreaterEqual(int(c["outputs published without its due scan"]), 1)
        else:
            self.assertGreaterEqual(waited, 1)  # ticks that came between the scans of a frame

    def status(self, suffix):
        """Values of the merger's diagnostic status whose name ends with ': <suffix>'."""
        names = [n for n in self.diagnostics if n.endswith(": " + suffix)]
        return dict(self.diagnostics[names[0]]) if names else None

    def wait_diagnostics(self, condition):
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline and not rospy.is_shutdown():
            with self.lock:
                d = {"output": self.status("output")}
            if d["output"] is not None and condition(d):
                return
            time.sleep(0.05)
        self.fail("the merger's diagnostics did not count its outputs within 10 s")


if __name__ == "__main__":
    rostest.rosrun("multi_laserscan_merger", "shared_stamps", SharedStamps)
