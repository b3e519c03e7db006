"""The evaluation's ground truth for returns on the robot's own parts (the simulated arm):
what counts as on the arm, what counts as a kept obstacle near it, and the configs of the
replay without the self filter."""
import math
import os
import sys

import numpy as np
import yaml

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts"))
from laserscan_toolbox.evaluation import self_filter_eval  # noqa: E402
from laserscan_toolbox.simulation.scenario import Scenario  # noqa: E402

REPO = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
BESIDE = 10.0   # s after the start: the gripper lowered beside the robot's right side


def _scan(scenario, points, n=1441):
    """A base_link scan at BESIDE with a return at each (x, y) of points, no return elsewhere."""
    inc = 2 * math.pi / (n - 1)
    r = np.full(n, np.inf, np.float32)
    for x, y in points:
        r[int(round((math.atan2(y, x) + math.pi) / inc))] = math.hypot(x, y)
    return {"stamp": scenario.start_time + BESIDE, "frame": "base_link", "angle_min": -math.pi,
            "angle_max": math.pi, "angle_increment": inc, "range_min": 0.0, "range_max": 12.0,
            "ranges": r}


def test_returns_inside_the_padded_gripper_count_and_outside_do_not():
    sc = Scenario.default(duration=20.0, camera_points=1000)
    centers, half, yaw = sc.robot.arm.boxes(BESIDE)
    gripper, h, a = centers[2], half[2], yaw[2]
    # Points along the gripper's own x axis: inside, 1 cm inside the 3 cm padding, 1 cm beyond.
    along = np.array([math.cos(a), math.sin(a)])
    inside = [tuple(gripper[:2]), tuple(gripper[:2] + along * (h[0] + 0.02))]
    outside = [tuple(gripper[:2] + along * (h[0] + 0.04))]
    assert self_filter_eval.robot_returns([_scan(sc, inside)], sc, 0.03) == 2
    assert self_filter_eval.robot_returns([_scan(sc, outside)], sc, 0.03) == 0
    assert self_filter_eval.robot_returns([_scan(sc, outside)], sc, 0.05) == 1   # the padding counts
    # Stowed (at the start) the arm is over the body: the same points are off the robot.
    early = dict(_scan(sc, inside), stamp=sc.start_time + 1.0)
    assert self_filter_eval.robot_returns([early], sc, 0.03) == 0


def test_obstacles_near_the_arm_are_kept_only_when_the_scan_reads_them():
    """The world's obstacles within 5 cm outside the padded boxes: the ideal scan itself keeps
    all of them; a scan without returns keeps none."""
    sc = Scenario.default(duration=60.0, camera_points=1000)
    band = (0.0, 0.05, 1.0)
    near_total = 0
    for t in np.arange(9.0, 12.0, 0.25):
        scan = _scan(sc, [])
        scan["stamp"] = sc.start_time + t
        ideal = sc.ideal_scan(scan["stamp"], -math.pi, math.pi, scan["angle_increment"], 0.0, 12.0,
                              0.05, 1.0)
        near, kept = self_filter_eval.kept_near_robot([dict(scan, ranges=ideal)], sc, 0.03, band)
        assert kept == near
        near_none, kept_none = self_filter_eval.kept_near_robot([scan], sc, 0.03, band)
        assert near_none == near and kept_none == 0
        near_total += near
    assert near_total > 0   # the shelf beside the lowered gripper


def test_the_replay_configs_have_no_self_filter_and_keep_the_description(tmp_path):
    configs = os.path.join(REPO, "config", "sim_robot")
    assert self_filter_eval.config_padding(configs) == 0.03
    plain = self_filter_eval.unfiltered_config_dir(configs, str(tmp_path / "plain"))
    assert self_filter_eval.config_padding(plain) is None
    names = sorted(os.listdir(configs))
    assert sorted(os.listdir(plain)) == names and "robot.urdf" in names
    for name in names:
        if name.endswith(".yaml"):
            with open(os.path.join(configs, name)) as f:
                original = yaml.safe_load(f)
            with open(os.path.join(plain, name)) as f:
                copy = yaml.safe_load(f)
            original.pop("self_filter", None)
            assert copy == original
