"""The navigation experiment's pieces: reactive_navigator's parameters in check_config's schema
(the shipped YAML passes, each bad value is named), the experiment's targets from runs, and one
short closed-loop run end to end (scripts/navigation_experiment's run: the simulator in lockstep
with the real navigator, lidar-only, a few simulated seconds)."""
import math
import os

import pytest
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
from laserscan_toolbox import config_check
from laserscan_toolbox.experiments import navigation

YAML = os.path.join(REPO, "reactive_navigator", "config", "reactive_navigator.yaml")


def test_the_shipped_navigator_yaml_passes_and_names_every_parameter():
    assert config_check.check_file(YAML) == []
    with open(YAML) as f:
        assert set(yaml.safe_load(f)) == set(config_check.NAVIGATOR)


def test_the_readme_lists_every_navigator_parameter():
    with open(os.path.join(REPO, "reactive_navigator", "README.md")) as f:
        text = f.read()
    for key in config_check.NAVIGATOR:
        assert "| `%s` |" % key in text, key


@pytest.mark.parametrize("key, value, says", [
    ("mode", "2.5d", "mode"), ("scan_topics", ["a", "a"], "listed twice"), ("height_band", [0.9, 0.1], "below"),
    ("footprint", [[0, 0], [1, 0]], "footprint"), ("shape_3d", [{"height": 0, "polygon": [[0, 0], [1, 0], [0, 1]]}],
                                                   "shape_3d[0].height"),
    ("max_linear_speed", 0, "max_linear_speed"), ("path_count", 2, "path_count"), ("lockstep", 1, "lockstep"),
    ("self_padding", -0.1, "self_padding"), ("control_rate", float("inf"), "control_rate"),
    ("obstacle_memory", -1.0, "obstacle_memory"), ("planner", 1, "planner"), ("planner_rate", 0, "planner_rate"),
    ("planner_resolution", 2.0, "planner_resolution"), ("planner_memory", -1.0, "planner_memory"),
    ("planner_clearing_range", -0.5, "planner_clearing_range"),
    ("planner_inflation", -0.1, "planner_inflation"), ("carrot_distance", 0, "carrot_distance"),
])
def test_check_config_names_each_bad_navigator_value(key, value, says):
    params = {"scan_topics": ["merged_scan"], key: value}
    problems = config_check.check_data(params, kind="navigator")
    assert any(says in p for p in problems), problems


def test_each_mode_listens_to_its_inputs():
    # unified: the raw modes' own sensors (lidars + cameras, as the paper's experiment); the arcs
    # only in unified_sonar.
    assert navigation.navigator_config("unified")["scan_topics"] == ["/slam_scan"]
    assert navigation.navigator_config("unified_sonar")["scan_topics"] == ["/merged_scan"]
    with open(os.path.join(navigation.REPO, "config", "sim_robot", "slam_scan.yaml")) as f:
        slam = yaml.safe_load(f)
    assert sorted(s["name"] for s in slam["sources"]) == ["camera_left", "camera_right", "lidar_front", "lidar_rear"]
    raw = navigation.navigator_config("raw_3d")
    assert raw["mode"] == "3d" and raw["cloud_topics"] and raw["scan_topics"]
    assert config_check.check_data(raw, kind="navigator") == []


def test_the_experiments_pipeline_waits_for_every_source_of_a_step_in_both_mergers(tmp_path):
    cfg = navigation.pipeline_config(str(tmp_path))
    for name in ("merged_scan.yaml", "slam_scan.yaml"):
        with open(os.path.join(cfg, name)) as f:
            assert yaml.safe_load(f)["sync_window"] == 1.0, name


def test_the_demo_summary_reports_each_run_and_each_target_met_or_missed():
    from laserscan_toolbox.evaluation import report
    run = {"mode": "unified", "points_per_camera": 50000, "reached": False, "time_to_goal_s": None,
           "collisions": 0, "collisions_3d": 0, "navigator_cpu_percent": 15.8, "system_cpu_percent": 25.2}
    lines = report.navigation_summary_lines({"runs": [run], "targets": {
        "unified_reached_without_collision": {"met": False, "figure": []},
        "lidar_only_misses_3d_obstacle": {"met": True, "figure": [1]}}})
    assert "unified" in lines[0] and "reached no" in lines[0] and "(3D 0)" in lines[0] and "15.8" in lines[0]
    assert lines[1:] == ["  navigation target unified_reached_without_collision: missed",
                         "  navigation target lidar_only_misses_3d_obstacle: met"]
    assert report.navigation_summary_lines(None) == []


def test_a_navigator_that_arrived_is_reached_by_ground_truth():
    # The simulator's map -> odom is the true pose: the navigator stops on it, within a tolerance
    # tighter than the simulator's, so that its "reached" is the record's.
    from laserscan_toolbox.simulation.closed_loop import ClosedLoopConfig
    for mode in navigation.MODES:
        cfg = navigation.navigator_config(mode)
        assert cfg["odom_frame"] == "map"
        assert cfg["goal_tolerance"] < ClosedLoopConfig(route="table").goal_tolerance_m


def row(mode, pts, cpu, system, t=20.0, reached=True, collisions=0, c3d=0, route="table"):
    return {"mode": mode, "route": route, "points_per_camera": pts, "navigator_cpu_percent": cpu,
            "system_cpu_percent": system, "time_to_goal_s": t, "reached": reached, "collisions": collisions,
            "collisions_3d": c3d}


def test_targets_from_runs():
    runs = [row("unified", 50000, 2.0, 10.0, 20.5), row("raw_3d", 50000, 15.0, 15.0, 20.0),
            row("unified", 300000, 2.2, 11.0), row("raw_3d", 300000, 30.0, 30.0),
            row("lidar_only", 50000, 1.0, 1.0, c3d=1)]
    t = navigation.targets(runs)
    assert t["unified_reached_without_collision"]["met"]
    assert t["unified_time_within_5_percent_of_raw_3d"]["met"]
    assert t["lidar_only_misses_3d_obstacle"]["met"]
    assert t["unified_navigator_cpu_flat_table"]["met"]
    assert math.isclose(t["navigator_cpu_10x_below_raw_at_300k_table"]["figure"], 30.0 / 2.2)
    assert t["navigator_cpu_10x_below_raw_at_300k_table"]["met"]
    assert t["system_cpu_below_raw_from_50k_table"]["met"]
    runs[0]["system_cpu_percent"] = 16.0
    runs[0]["collisions"] = 1
    t = navigation.targets(runs)
    assert not t["system_cpu_below_raw_from_50k_table"]["met"]
    assert not t["unified_reached_without_collision"]["met"]


def test_the_check_fails_on_any_contact_time_or_cpu_and_reports_the_cpu_ratios():
    runs = [row("unified", 50000, 15.0, 25.0, 20.5), row("raw_3d", 50000, 160.0, 160.0, 20.0),
            row("lidar_only", 50000, 7.0, 7.0, c3d=1)]
    assert navigation.check({"runs": runs, "targets": navigation.targets(runs)}) == []
    # A contact (a person), and 10 % longer than raw 3D: each fails it.
    runs[0].update(collisions=1)
    assert navigation.check({"runs": runs, "targets": navigation.targets(runs)}) == [
        "unified_reached_without_collision"]
    runs[0].update(collisions=0, time_to_goal_s=22.0)
    assert navigation.check({"runs": runs, "targets": navigation.targets(runs)}) == [
        "unified_time_within_5_percent_of_raw_3d"]
    # The CPU ratios of the whole sweep are reported, not checked.
    runs += [row("unified", 300000, 15.0, 25.0, 20.5), row("raw_3d", 300000, 100.0, 100.0, 20.0)]
    res = navigation.targets(runs)
    assert res["navigator_cpu_10x_below_raw_at_300k_table"]["met"] is False
    runs[0].update(time_to_goal_s=20.5)
    runs = runs[:3]
    # Unified not reached (no time to compare), or lidar-only not touching the table top: it fails.
    runs[0].update(reached=False, time_to_goal_s=None)
    assert navigation.check({"runs": runs, "targets": navigation.targets(runs)}) == [
        "unified_reached_without_collision", "unified_reached_goal", "unified_time_within_5_percent_of_raw_3d"]
    runs[0].update(reached=True, time_to_goal_s=20.5, collisions=0)
    runs[2]["collisions_3d"] = 0
    assert navigation.check({"runs": runs, "targets": navigation.targets(runs)}) == ["lidar_only_misses_3d_obstacle"]
    runs[2]["collisions_3d"] = 1
    # A unified run touching a table top fails it, as does more navigator CPU than raw 3D.
    runs[0]["collisions_3d"] = 1
    assert navigation.check({"runs": runs, "targets": navigation.targets(runs)}) == ["unified_no_3d_contact"]
    runs[0]["collisions_3d"] = 0
    runs[0]["navigator_cpu_percent"] = 170.0
    assert navigation.check({"runs": runs, "targets": navigation.targets(runs)}) == ["navigator_cpu_below_raw_table"]


def test_a_short_closed_loop_run_end_to_end(tmp_path):
    """The real navigator drives the simulated robot (lidar-only, the table route) for 4 simulated
    seconds after the goal: every step answered in lockstep, the robot went towards the goal, the
    navigator's CPU and memory measured."""
    r, record = navigation.run_one("lidar_only", 10000, "table", str(tmp_path), timeout_s=4.0)
    assert r["lockstep_timeouts"] == 0
    assert r["path_length_m"] > 0.8  # at up to 0.5 m/s, from standstill
    start, end = record["trajectory"][0], record["trajectory"][-1]
    assert end[1] - start[1] > 0.5  # the goal lies along +x of the map
    assert 0.0 < r["navigator_cpu_percent"] < 100.0
    assert r["system_cpu_percent"] == r["navigator_cpu_percent"]  # no pipeline in lidar-only mode
    assert r["navigator_memory_mb"] > 1.0
