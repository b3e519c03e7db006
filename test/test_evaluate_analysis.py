"""The evaluation's analysis on hand-made records (no ROS master, no bag playback)."""
import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts"))
from laserscan_toolbox import evaluate as ev  # noqa: E402


def test_dropped_inputs_are_found_by_stamp():
    cam = np.arange(0, 10, 1 / 14.0)
    lidar = np.arange(0.03, 10, 1 / 8.0)
    bag = {"/cam/depth": {"stamps": cam.tolist()}, "/cam/info": {"stamps": cam.tolist()},
           "/lidar": {"stamps": lidar.tolist()},
           "/odom": {"stamps": np.arange(0.01, 10, 0.02).tolist()}}
    out = np.concatenate([cam[::2], cam[1::2][:-5]])  # 5 camera frames lost
    d = ev.match_inputs(out, bag)
    assert [(x["topic"], x["dropped"]) for x in d] == [("/cam/depth", 5)]
    merged = np.concatenate([cam, lidar[3:]])
    d = {x["topic"]: x["dropped"] for x in ev.match_inputs(merged, bag)}
    assert d == {"/cam/depth": 0, "/lidar": 3}


def test_static_pose_chains_transforms():
    q_yaw = (0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4))  # 90 degrees
    tf = [("base_link", "mount", (1.0, 0.0, 0.2), q_yaw),
          ("mount", "laser", (0.5, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))]
    m = ev.static_pose_in(tf, "laser")
    assert m[:3, 3] == pytest.approx([1.0, 0.5, 0.2])
    assert math.atan2(m[1, 0], m[0, 0]) == pytest.approx(math.pi / 2)
    assert ev.static_pose_in(tf, "camera") is None


class FakeScenario:
    """A circular wall of radius 3 m around the origin; the robot stands at (0.5, 0)."""

    def true_pose(self, t):
        return (0.5, 0.0, 0.0)

    def ideal_scan(self, t, amin, amax, inc, rmin, rmax, zmin, zmax, pose=None):
        x, y, yaw = pose
        n = int(round((amax - amin) / inc)) + 1
        a = yaw + amin + inc * np.arange(n)
        # ray from (x, y) to the circle |p| = 3
        b = x * np.cos(a) + y * np.sin(a)
        return -b + np.sqrt(b * b - (x * x + y * y - 9.0))


def scan(stamp, ranges, frame="base_link"):
    n = len(ranges)
    return {"stamp": stamp, "frame": frame, "angle_min": -math.pi,
            "angle_max": -math.pi + 2 * math.pi / n * (n - 1), "angle_increment": 2 * math.pi / n,
            "range_min": 0.0, "range_max": 10.0, "ranges": np.asarray(ranges, np.float32)}


def test_ground_truth_stats_in_base_link_and_a_lidar_frame():
    sc = FakeScenario()
    n = 360
    ideal = sc.ideal_scan(0, -math.pi, -math.pi + 2 * math.pi / n * (n - 1), 2 * math.pi / n,
                          0, 10, 0, 1, pose=(0.5, 0, 0))
    noisy = ideal + 0.02
    noisy[:10] = 1.0  # ghost obstacles
    # a lidar 0.3 m ahead of base_link, yawed 180 degrees, 0.2 m above the floor
    q = (0.0, 0.0, 1.0, 0.0)
    lid = sc.ideal_scan(0, -math.pi, -math.pi + 2 * math.pi / n * (n - 1), 2 * math.pi / n,
                        0, 10, 0, 1, pose=(0.8, 0, math.pi))
    run = {"records": {"/merged": {"scans": [scan(1.0, noisy), scan(2.0, noisy)]},
                       "/lidar": {"scans": [scan(1.5, lid, "laser")]}}}
    info = {"start": 0.0, "end": 10.0, "static_tf": [("base_link", "laser", (0.3, 0, 0.2), q)]}
    res, ex = ev.ground_truth_stats(run, info, sc, band=(0.0, 0.05, 1.0), beam_window=0)
    m = res["/merged"]
    assert m["scans"] == 2 and m["median_error"] == pytest.approx(0.02, abs=1e-4)
    assert m["false"] == 20 and m["z_band"] == [0.05, 1.0]
    lidar = res["/lidar"]
    assert lidar["median_error"] < 1e-4 and lidar["false"] == 0
    assert lidar["z_band"] == pytest.approx([0.18, 0.22])
    assert set(ex) == {"/merged", "/lidar"}


class FakeGlassScenario(FakeScenario):
    """The circle of radius 3, with a glass pane 1 m in front of the origin on beams 0..19."""

    class world:  # noqa: N801  (duck-types Scenario.world)
        glass = ["pane"]

    def ideal_scan(self, t, amin, amax, inc, rmin, rmax, zmin, zmax, pose=None, glass=True):
        r = FakeScenario.ideal_scan(self, t, amin, amax, inc, rmin, rmax, zmin, zmax, pose or self.true_pose(t))
        if glass:
            r = r.copy()
            r[:20] = 1.0
        return r


def test_glass_beams_are_judged_apart_from_the_range_error():
    sc = FakeGlassScenario()
    n = 360
    clear = FakeScenario.ideal_scan(sc, 0, -math.pi, -math.pi + 2 * math.pi / n * (n - 1), 2 * math.pi / n,
                                    0, 10, 0, 1, pose=(0.5, 0, 0))
    # A lidar-like scan: through the pane to the circle on beams 0..19, exact elsewhere.
    run = {"records": {"/merged": {"scans": [scan(1.0, clear)]}}}
    info = {"start": 0.0, "end": 10.0, "static_tf": []}
    res, _ = ev.ground_truth_stats(run, info, sc, band=(0.0, 0.05, 1.0), beam_window=0)
    m = res["/merged"]
    assert m["median_error"] < 1e-4 and m["false"] == 0 and m["missed"] == 0
    g = ev.glass_stats(run, info, sc, (0.0, 0.05, 1.0))["/merged"]
    assert (g["glass_beams"], g["found"]) == (20, 0)
    seen_pane = clear.copy()
    seen_pane[:20] = 0.98
    g = ev.glass_stats({"records": {"/m": {"scans": [scan(1.0, seen_pane)]}}}, info, sc, (0.0, 0.05, 1.0))["/m"]
    assert (g["glass_beams"], g["found"]) == (20, 20)
