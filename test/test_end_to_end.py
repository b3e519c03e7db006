"""End to end: a short simulated bag through the full launch (one manager:
depth_image_proc, converters, mergers), evaluated against the scenario's ground truth;
and a user's bag without ground truth (two real lidars) through a merger-only launch.

Needs the workspace built and its devel/setup.bash sourced (the nodelets are found
through ROS_PACKAGE_PATH); each evaluation starts its own roscore on a free port.
"""
import json
import math
import os
import re
import subprocess
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
SCRIPTS = os.path.join(REPO, "scripts")
from laserscan_toolbox.evaluation import analysis, playback
from laserscan_toolbox.evaluation.results import EvaluationResult, NotRun
from laserscan_toolbox.ros.rosrun import MANAGER_TAG

DATA = os.path.join(REPO, "test", "data", "real")
DUAL_BAG = os.path.join(DATA, "dual_lidar_scans_demo.bag")
DURATION = 18.0
MERGED, LIDAR_ONLY = "/merged_scan", "/lidar_scan"
#: The unified scan (lidars + cameras, no sonar arcs): what SLAM and localization take.
UNIFIED = "/slam_scan"


def run(cmd, timeout):
    p = subprocess.run([sys.executable] + cmd, capture_output=True, text=True, timeout=timeout)
    return p.returncode, p.stdout + p.stderr[-5000:]


@pytest.fixture(scope="module")
def evaluated(tmp_path_factory):
    d = tmp_path_factory.mktemp("end_to_end")
    bag = str(d / "short.bag")
    code, out = run([os.path.join(SCRIPTS, "simulate_scenario"), "--output", bag,
                     "--duration", str(DURATION), "--seed", "1"], 600)
    assert code == 0, out
    outdir = str(d / "out")
    # The timeout only guards against a hang: the evaluation (playback, ground truth, three
    # maps, two SLAM and two localization runs) takes about 50 s on the 2-core machine alone
    # (it took 405 s at a load of 4 to 7 before the ground truth's ray casting became 2D).
    code, log = run([os.path.join(SCRIPTS, "evaluate_bag"), bag, "--output", outdir,
                     "--save-scans", "--no-progress", "--max-median-error", "0.03", "--slam"],
                    1500)
    with open(os.path.join(outdir, "results.json")) as f:
        results = json.load(f)
    scans = playback.load_scan_records(os.path.join(outdir, "scans.npz"))
    return {"bag": bag, "code": code, "log": log, "results": results, "scans": scans,
            "out": outdir}


def test_merged_scan_is_accurate(evaluated):
    res = evaluated["results"]
    assert evaluated["code"] == 0, evaluated["log"]
    acc = res["accuracy"][MERGED]
    assert acc["scans"] > 50
    assert acc["median_error"] <= 0.03, acc
    assert os.path.isfile(os.path.join(evaluated["out"], "report.md"))


def test_lidar_scans_merged_under_a_newer_stamp_are_not_counted_as_dropped(evaluated):
    """/slam_scan carries its newest input's stamp, mostly a camera's: a lidar scan arrives 135 ms
    after its stamp (one sweep) and goes into the next output under a newer stamp, so its own
    stamp never reappears. The merger's diagnostics count it as received and not dropped; the
    evaluation counts it as merged into a later output, not as dropped."""
    out = evaluated["results"]["outputs"][UNIFIED]
    lidars = [i for i in out["inputs"] if i.get("counted_by_merger")]
    assert lidars, out["inputs"]  # the lidar scans come straight from the bag into the merger
    merged_later = sum(i["merged_later"] for i in lidars)
    assert merged_later == out["merged_later"] > 0, out
    assert out["dropped"] <= 0.01 * sum(i["inputs"] for i in out["inputs"]), out
    with open(os.path.join(evaluated["out"], "report.md")) as f:
        assert "%d merged into a later output" % merged_later in f.read()


def camera_scan_topics(res):
    return [t for t, a in res["accuracy"].items()
            if a.get("frame") == "base_link" and t not in (MERGED, UNIFIED, LIDAR_ONLY)]


def test_no_floor_or_ceiling_obstacles_while_the_cameras_tilt(evaluated):
    """A return where the ideal scan (robot band, true pose) is empty is a false obstacle:
    the floor seen by a camera tilted down, or the ceiling / overhead lamps tilted up."""
    res = evaluated["results"]
    cams = camera_scan_topics(res)
    assert len(cams) == 2, res["accuracy"].keys()
    for t in cams + [MERGED]:
        a = res["accuracy"][t]
        assert a["returns"] > 1000, (t, a)
        # The merged scan also holds the ultrasonic arcs, whose cone widening adds false
        # obstacles of its own (1.9 % measured; 0.3 % without the arcs): the floor and the
        # ceiling are checked on the camera scans at 2 %, the merged scan bounds the sum.
        assert a["false_rate"] <= (0.03 if t == MERGED else 0.02), (t, a)


def test_no_returns_on_the_robots_arm_with_the_self_filter(evaluated):
    """The arm reaches into the left camera's view (2-8 s) and the rear lidar's plane (8.5-15 s):
    with the self filter no return of /merged_scan lies on it and the shelf 4 cm beyond the
    lowered gripper's padded box is kept; the playback without the filter has false obstacles
    on it (the camera and lidar returns on the gripper)."""
    sf = evaluated["results"]["self_filter"][MERGED]
    assert sf["scans"] > 50 and sf["scans_unfiltered"] > 50, sf
    assert sf["returns_on_robot"] == 0, sf
    assert sf["returns_on_robot_unfiltered"] > 1000, sf
    assert sf["near_robot_obstacles"] > 10, sf
    assert sf["kept_near_robot_percent"] >= 90.0, sf
    with open(os.path.join(evaluated["out"], "report.md")) as f:
        assert "## Self filter (the robot's arm)" in f.read()


def _nearest(stamps, t):
    i = int(np.argmin(np.abs(stamps - t)))
    return i, abs(stamps[i] - t)


def test_table_tops_in_the_fused_scan_not_in_the_lidar_only_scan(evaluated):
    """Beams where something above the lidars' plane (a table top, a shelf's overhang) is
    closer than anything in the plane: the camera-fused scan sees it at the right range,
    the lidar-only scan does not."""
    from laserscan_toolbox.simulation.scenario import Scenario
    sc = Scenario.from_bag(evaluated["bag"])
    res = evaluated["results"]
    floor, zlo, zhi = res["band"]
    plane = next(a["z_band"] for a in res["accuracy"].values()
                 if a.get("frame") not in (None, "base_link"))
    fused, lidar = evaluated["scans"][MERGED], evaluated["scans"][LIDAR_ONLY]
    n = fused["ranges"].shape[1]
    ang = fused["angle_min"] + fused["angle_increment"] * np.arange(n)
    front = np.abs(np.arctan2(np.sin(ang), np.cos(ang))) < math.radians(75)
    seen_fused = seen_lidar = total = 0
    for i in range(0, len(fused["stamp"]), 4):
        t = float(fused["stamp"][i])
        j, dt = _nearest(lidar["stamp"], t)
        if dt > 0.07 or lidar["ranges"].shape[1] != n:
            continue
        pose = sc.true_pose(t)
        args = (t, float(fused["angle_min"]), float(fused["angle_min"] + fused["angle_increment"] * (n - 1)),
                float(fused["angle_increment"]), float(fused["range_min"]), float(fused["range_max"]))
        full = np.asarray(sc.ideal_scan(*args, zlo, zhi, pose=pose), float)
        flat = np.asarray(sc.ideal_scan(*args, plane[0], plane[1], pose=pose), float)
        with np.errstate(invalid="ignore"):
            table = front & np.isfinite(full) & (full < 3.0) & ~(flat < full + 0.3)
        if not table.any():
            continue
        total += int(table.sum())
        near = 0.08
        with np.errstate(invalid="ignore"):
            seen_fused += int((np.abs(fused["ranges"][i] - full) < near)[table].sum())
            seen_lidar += int((np.abs(lidar["ranges"][j] - full) < near)[table].sum())
    assert total > 200, "the route should pass table tops within 3 m (%d beams)" % total
    frac_fused, frac_lidar = seen_fused / total, seen_lidar / total
    print("table-top beams: %d, seen by the fused scan %.0f%%, by the lidar-only scan %.0f%%"
          % (total, 100 * frac_fused, 100 * frac_lidar))
    # The cameras see a table top only while their tilt puts it in view (the servos sweep
    # 15 +- 20 degrees down), so not every beam of every scan can see it.
    assert frac_fused >= 0.4
    assert frac_lidar <= 0.05


def test_maps_show_3d_obstacles_only_with_cameras(evaluated):
    m = evaluated["results"]["mapping"]
    # Reference: a perfect 360-degree sensor in the band; the cameras cover the front 164
    # degrees, so the fused map finds a share of it, the lidar-only map next to nothing.
    assert m[MERGED]["found_3d"] >= 0.25, m
    assert m[MERGED]["found_3d"] >= 2.5 * m[LIDAR_ONLY]["found_3d"], m
    assert os.path.isfile(os.path.join(evaluated["out"], "maps", "maps.png"))


def test_real_slam_and_localization_on_both_streams(evaluated):
    """rbpf-slam and pf-localization (MRPT) on the recorded lidar-only and unified scans
    (the unified scan of lidars + cameras, /slam_scan; the sonar arcs go to /merged_scan
    only). The bag is short (18 s, about 8 m driven, no loop): the targets of the full
    scenario (docs/slam.md) with margins for a short run."""
    res = evaluated["results"]
    slam, loc = res["slam"], res["localization"]
    assert set(slam) == set(loc) == {LIDAR_ONLY, UNIFIED}, res.get("slam_experiment")
    for t in (LIDAR_ONLY, UNIFIED):
        s = slam[t]
        assert s["scans"] > 100, (t, s)
        assert s["path_rmse_m"] <= 0.10, (t, s)
        # the SLAM corrects odometry (over 8 m the drift is small, so only "not worse")
        assert s["path_rmse_m"] <= s["odometry_rmse_m"] + 0.02, (t, s)
        assert loc[t]["rmse_m"] <= 0.15 and loc[t]["steps"] == s["scans"], (t, loc[t])
    u, l = slam[UNIFIED], slam[LIDAR_ONLY]
    assert u["map_precision"] >= 0.85, u
    assert u["obstacles_3d_found"] >= 0.25, u
    assert u["obstacles_3d_found"] >= 2 * l["obstacles_3d_found"], (u, l)
    assert u["map_recall"] > l["map_recall"], (u, l)
    exp = res["slam_experiment"]
    for png in exp["figures"].values():
        assert os.path.isfile(os.path.join(evaluated["out"], png)), png
    with open(os.path.join(evaluated["out"], "report.md")) as f:
        report = f.read()
    assert "## SLAM and localization" in report and "(slam_maps.png)" in report


def test_cpu_is_reported_as_a_robot_on_wall_time_pays_it(evaluated):
    """The bag's first 10 s replayed on wall time (use_sim_time false, no /clock, stamps moved
    to now): the pipeline works there as on a robot (the merged scan at its rate, which needs
    the transforms at the moved stamps), and each idle loader client costs less than under
    rosbag's 200 Hz /clock, whose share is reported apart."""
    res = evaluated["results"]
    s = res["cpu_summary"]
    assert s["clock"] == "wall" and s["wall_replay_problem"] is None, s
    assert s["window_s"] == pytest.approx(10.0, abs=0.1) and s["rate"] == 1.0
    window = s["wall_replay_data_s"]
    assert s["wall_replay_outputs"][MERGED] >= 0.8 * res["outputs"][MERGED]["rate_hz"] * window, s
    assert s["processes"]["manager"] == 1 and s["processes"]["loader"] >= 9, s
    loaders = [c for c in res["cpu"].values() if c["role"] == "loader"]
    # idle on wall time about 0.3 % of a core each, under /clock about 1.5 %
    assert all(c["cpu_percent"] < c["sim_clock_cpu_percent"] for c in loaders), res["cpu"]
    assert sum(c["clock_share_percent"] for c in loaders) > 0.5 * len(loaders), res["cpu"]
    assert s["total_percent"] == pytest.approx(sum(c["cpu_percent"] for c in res["cpu"].values()))
    assert s["sim_clock_total_percent"] - s["total_percent"] == pytest.approx(s["clock_share_percent"])
    with open(os.path.join(evaluated["out"], "report.md")) as f:
        assert "| nodelet loader clients (%d) |" % len(loaders) in f.read()
    assert "on wall time, as a robot pays it" in evaluated["log"]


def test_users_bag_without_ground_truth(tmp_path):
    """Two real lidars, no tf, no odometry: launch/dual_lidar_demo.launch publishes the
    mounts and merges; the tool reports rates, drops, coverage and CPU, no accuracy."""
    assert os.path.isfile(DUAL_BAG), "missing %s" % DUAL_BAG
    out = str(tmp_path / "out")
    code, log = run([os.path.join(SCRIPTS, "evaluate_bag"), DUAL_BAG, "--launch",
                     os.path.join(REPO, "launch", "dual_lidar_demo.launch"), "--output", out,
                     "--rate", "2", "--no-progress", "--min-rate", "15", "--max-dropped", "0.05",
                     "--min-coverage", "0.3"], 300)
    assert code == 0, log
    with open(os.path.join(out, "results.json")) as f:
        r = json.load(f)
    m = r["outputs"][MERGED]
    assert {i["topic"] for i in m["inputs"]} == {"/front_scan", "/rear_scan"}
    assert "accuracy" not in r and not r["ground_truth"]
    assert any(n.endswith(MANAGER_TAG) for n in r["cpu"]), r["cpu"]
    # replayed on wall time through a launch without a use_sim_time argument (the master's
    # parameter does it); played at rate 2 under /clock, so no /clock share is given
    cpu = r["cpu_summary"]
    assert cpu["clock"] == "wall" and cpu["wall_replay_outputs"][MERGED] > 100, cpu
    assert cpu["clock_share_percent"] is None, cpu
    # the scans are plotted: inputs placed by the mounts the launch publishes, merged scan
    plot = r["scan_plot"]
    assert plot["topic"] == MERGED and plot["frame"] == "base_link"
    assert set(plot["scans"]) == {"/front_scan", "/rear_scan", MERGED}
    assert all(s["mounted"] and s["returns"] > 100 for s in plot["scans"].values()), plot
    assert plot["scans"]["/rear_scan"]["input"] and not plot["scans"][MERGED]["input"]
    assert os.path.getsize(os.path.join(out, "scans.png")) > 10000
    with open(os.path.join(out, "report.md")) as f:
        assert "(scans.png)" in f.read()
    # the pipeline's own delay: a merger answers within a few clock ticks of its input
    assert -0.05 < m["delay_after_input_median_s"] < 0.05, m


def rewrite_dual_bag(path, seconds, stamp_of):
    """The first ``seconds`` of the dual-lidar bag with header stamps stamp_of(bag time,
    bag start time)."""
    import rosbag
    import rospy
    with rosbag.Bag(DUAL_BAG) as src, rosbag.Bag(path, "w") as dst:
        t0 = rospy.Time.from_sec(src.get_start_time())
        for topic, msg, t in src.read_messages(end_time=t0 + rospy.Duration(seconds)):
            msg.header.stamp = stamp_of(t, t0)
            dst.write(topic, msg, t)
    return path


def test_stamps_at_the_end_of_ros_time_are_reported_not_a_crash(tmp_path):
    """Header stamps a few seconds before the end of ROS 1 time (2^32 s), 2.8e9 s ahead of
    the bag's clock: no node dies (roscpp used to throw out of the merger's callback and
    take the manager down), the tool reports instead of a traceback."""
    import rospy
    bag = rewrite_dual_bag(str(tmp_path / "end_of_time.bag"), 5.0,
                           lambda t, t0: rospy.Time(2 ** 32 - 8) + (t - t0))
    code, log = run([os.path.join(SCRIPTS, "evaluate_bag"), bag, "--launch",
                     os.path.join(REPO, "launch", "dual_lidar_demo.launch"), "--output",
                     str(tmp_path / "out"), "--rate", "2", "--no-progress", "--cpu-replay", "0"], 300)
    assert "Traceback" not in log, log
    # No node may die of such stamps (the merger drops them as malformed, naming them).
    assert "has died" not in log, log
    assert code in (0, 1), log
    # ... and the merger is measured to the end of the bag (its CPU line), alive.
    assert re.search(r"CPU of the pipeline: .*merger", log), log


def test_a_node_that_dies_during_playback_is_named(tmp_path):
    """roslaunch outlives a node that is not required; the evaluation must not pass over
    its death."""
    launch = tmp_path / "dies.launch"
    launch.write_text("""<launch>
  <include file="%s"/>
  <node pkg="tf2_ros" type="static_transform_publisher" name="short_lived"
        args="0 0 0 0 0 0 base_link short_lived" launch-prefix="bash -c 'sleep 3; exit 7' --"/>
</launch>
""" % os.path.join(REPO, "launch", "dual_lidar_demo.launch"))
    code, log = run([os.path.join(SCRIPTS, "evaluate_bag"), DUAL_BAG, "--launch", str(launch),
                     "--rate", "4", "--no-progress"], 300)
    assert code == 3, log
    assert "short_lived" in log and "has died" in log, log


def test_users_bag_with_stamps_ahead_of_the_bag_clock(tmp_path):
    """The dual-lidar bag rewritten with every header stamp 0.5 s ahead of its bag time
    (a sensor clock ahead of the recorder's): latencies go negative, the report says why,
    and the delay after input still shows the pipeline's real delay."""
    import rospy
    shifted = rewrite_dual_bag(str(tmp_path / "ahead.bag"), 8.0,
                               lambda t, _t0: t + rospy.Duration(0.5))
    out = str(tmp_path / "out")
    # no wall-time CPU replay: nothing here is about CPU (test_users_bag_without_ground_truth
    # replays the same launch)
    code, log = run([os.path.join(SCRIPTS, "evaluate_bag"), shifted, "--launch",
                     os.path.join(REPO, "launch", "dual_lidar_demo.launch"), "--output", out,
                     "--rate", "2", "--no-progress", "--cpu-replay", "0"], 300)
    assert code == 0, log
    assert "negative latencies" in log
    with open(os.path.join(out, "results.json")) as f:
        r = json.load(f)
    m = r["outputs"][MERGED]
    assert m["latency_median_s"] < -0.4 and m["negative_latency_fraction"] > 0.9, m
    assert -0.05 < m["delay_after_input_median_s"] < 0.05, m
    assert r["inputs"]["/front_scan"]["age_min_s"] == pytest.approx(-0.5, abs=1e-3)
    with open(os.path.join(out, "report.md")) as f:
        text = f.read()
    assert "**Negative latencies.**" in text
    assert "input `/front_scan`: stamps up to 500.0 ms ahead of the bag time" in text


def test_unusable_bags_are_reported(tmp_path):
    import rosbag
    empty = str(tmp_path / "empty.bag")
    rosbag.Bag(empty, "w").close()
    code, log = run([os.path.join(SCRIPTS, "evaluate_bag"), empty, "--no-progress"], 60)
    assert code == 2 and "holds no messages" in log and "Traceback" not in log, log
    garbage = tmp_path / "garbage.bag"
    garbage.write_bytes(b"#ROSBAG V2.0\n" + b"\x00" * 64)
    code, log = run([os.path.join(SCRIPTS, "evaluate_bag"), str(garbage), "--no-progress"], 60)
    assert code == 2 and "Traceback" not in log, log


def test_thresholds_decide_the_exit_status():
    results = EvaluationResult(
        outputs={"/s": {"rate_hz": 10.0, "latency_p95_s": 0.02, "dropped_fraction": 0.0, "coverage": 0.5},
                 "/skipped": {"rate_hz": 10.0}},
        accuracy={"/s": {"median_error": 0.01, "p95_error": 0.2, "false_rate": 0.0, "missed_rate": 0.4},
                  "/skipped": NotRun("frame 'x' is upside down")},
        cpu={"m": {"cpu_percent": 30.0}})
    ok = analysis.check_thresholds(results, {"max_median_error": 0.03, "min_rate": 8}, ["/s"])
    assert all(c for c, _ in ok) and len(ok) == 2
    bad = analysis.check_thresholds(results, {"max_p95_error": 0.1, "max_cpu": 10}, ["/s"])
    assert [c for c, _ in bad] == [False, False]
    missing = analysis.check_thresholds(results, {"min_rate": 1}, ["/other"])
    assert [c for c, _ in missing] == [False]
    # a topic whose accuracy step did not run has no figures: its accuracy threshold fails
    skipped = analysis.check_thresholds(results, {"max_median_error": 0.03}, ["/skipped"])
    assert skipped == [(False, "max_median_error: /skipped has no accuracy figures")]


def test_evaluate_bag_usage_errors(tmp_path):
    tool = os.path.join(SCRIPTS, "evaluate_bag")
    assert run([tool, str(tmp_path / "none.bag")], 60)[0] == 2
    assert run([tool], 60)[0] == 2
    assert run([tool, DUAL_BAG, "--launch", str(tmp_path / "none.launch")], 60)[0] == 2
    assert run([tool, DUAL_BAG, "--slam"], 60)[0] == 2  # the SLAM's pictures need --output


def test_glass_wall_in_the_merged_scan_only_with_the_ultrasonic_sensors(evaluated):
    """The route passes a glass wall (and the lidars and cameras see through it): the merged
    scan, which takes the four ultrasonic arcs, marks it; the lidar-only scan, the SLAM's
    unified scan and the camera scans, which have no ultrasonic input, do not."""
    g = evaluated["results"]["glass"]
    merged, lidar = g[MERGED], g[LIDAR_ONLY]
    print("glass beams found: merged %.0f%% of %d, lidar-only %.0f%% of %d"
          % (100 * merged["found_rate"], merged["glass_beams"], 100 * lidar["found_rate"], lidar["glass_beams"]))
    assert merged["scans_with_glass"] >= 20, merged
    assert lidar["found_rate"] <= 0.02, lidar
    assert g[UNIFIED]["found_rate"] <= 0.02, g[UNIFIED]
    for cam in camera_scan_topics(evaluated["results"]):
        assert g[cam]["found_rate"] <= 0.02, (cam, g[cam])
    # Glass beams in every direction count, the four cones cover a part of them (9.5 % found
    # measured, 0 % without the arcs).
    assert merged["found_rate"] >= 0.05, merged
    assert merged["found_rate"] >= 10 * max(lidar["found_rate"], 0.002), (merged, lidar)
