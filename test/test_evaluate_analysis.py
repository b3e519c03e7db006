"""The evaluation's analysis on hand-made records (no ROS master, no bag playback)."""
import math

import numpy as np
import pytest

from laserscan_toolbox.evaluation import analysis, playback
from laserscan_toolbox.evaluation.results import Check, EvaluationResult


def test_dropped_inputs_are_found_by_stamp():
    cam = np.arange(0, 10, 1 / 14.0)
    lidar = np.arange(0.03, 10, 1 / 8.0)
    bag = {"/cam/depth": {"stamps": cam.tolist()}, "/cam/info": {"stamps": cam.tolist()},
           "/lidar": {"stamps": lidar.tolist()},
           "/odom": {"stamps": np.arange(0.01, 10, 0.02).tolist()}}
    out = np.concatenate([cam[::2], cam[1::2][:-5]])  # 5 camera frames lost
    d = analysis.match_inputs(out, bag)
    assert [(x["topic"], x["dropped"]) for x in d] == [("/cam/depth", 5)]
    merged = np.concatenate([cam, lidar[3:]])
    d = {x["topic"]: x["dropped"] for x in analysis.match_inputs(merged, bag)}
    assert d == {"/cam/depth": 0, "/lidar": 3}


def test_a_mergers_own_counts_tell_dropped_inputs_from_inputs_merged_later():
    """80 lidar scans reach the output under their own stamp, 20 do not. The merger's
    diagnostics for the output say it received 98 and dropped 1: 2 never reached it, 1 it
    dropped, 17 went into a later output. Another merger's statuses (another output), a
    converter's status and unreadable counts change nothing; an input no merger reports on
    keeps its count by stamp."""
    lidar = np.arange(0.0, 10.0, 0.1)
    cam = np.arange(0.05, 10.0, 0.1)
    bag = {"/lidar": {"stamps": lidar.tolist()}, "/cam/depth": {"stamps": cam.tolist()}}
    out = np.concatenate([lidar[:80], cam[:95]])
    diagnostics = {
        "/slam_merger: source lidar": {"topic": "/lidar", "merged scan topic": "/slam_scan",
                                       "scans received": "98", "scans dropped": "1"},
        "/lidar_merger: source lidar": {"topic": "/lidar", "merged scan topic": "/lidar_scan",
                                        "scans received": "50", "scans dropped": "40"},
        "/slam_merger: source broken": {"topic": "/other", "merged scan topic": "/slam_scan",
                                        "scans received": "n/a", "scans dropped": "3"},
        "/camera_converter: Input and processing": {"clouds received": "100"},
    }
    counts = analysis.merger_counts(diagnostics, "/slam_scan")
    assert counts == {"/lidar": (98, 1)}
    drivers = analysis.account_with_merger(analysis.match_inputs(out, bag), counts)
    by_topic = {d["topic"]: d for d in drivers}
    assert (by_topic["/lidar"]["dropped"], by_topic["/lidar"]["merged_later"]) == (3, 17)
    assert by_topic["/cam/depth"]["dropped"] == 5 and "merged_later" not in by_topic["/cam/depth"]
    # A merger that counts more losses than stamps are missing: the stamps bound the drops.
    drivers = analysis.account_with_merger(analysis.match_inputs(out, bag), {"/lidar": (60, 0)})
    assert [(d["dropped"], d["merged_later"]) for d in drivers if d["topic"] == "/lidar"] == [(20, 0)]
    # The report says both.
    from laserscan_toolbox.evaluation import report
    cell = report.dropped_cell({"inputs": drivers, "dropped": 3, "dropped_fraction": 0.03, "merged_later": 17})
    assert cell.startswith("3 (") and cell.endswith("; 17 merged into a later output"), cell
    assert "merged" not in report.dropped_cell({"inputs": drivers, "dropped": 3, "dropped_fraction": 0.03})
    assert report.dropped_cell({"inputs": [], "dropped": 0, "dropped_fraction": float("nan")}) == "n/a"


def test_a_cameras_frames_are_counted_by_the_merger_on_its_converters_scan():
    """A camera's frames reach the merger as its converter's scans (the depth image's stamps).
    Some come out under their own stamp, the others in later outputs: the merger's counts on the
    scan topic (all received, none dropped) make them merged later, not dropped. Where the
    converter lost 4 frames (its scan is recorded without them), those are dropped."""
    cam = np.arange(0.0, 10.0, 1 / 14.0)
    sonar = np.arange(0.02, 10.0, 0.1)
    bag = {"/cam/depth/image": {"stamps": cam.tolist()}, "/cam/depth/camera_info": {"stamps": cam.tolist()},
           "/sonar/range": {"stamps": sonar.tolist()}}
    out = np.concatenate([cam[::3], sonar])  # a third of the frames under their own stamp
    diagnostics = {"/merger: source cam": {"topic": "/cam/scan", "merged scan topic": "/merged_scan",
                                           "scans received": str(len(cam) - 4), "scans dropped": "0"}}
    counts = analysis.merger_counts(diagnostics, "/merged_scan")
    drivers = analysis.match_inputs(out, bag)
    assert {d["topic"] for d in drivers} == {"/cam/depth/camera_info", "/sonar/range"}
    lost = {4, 5, 7, 8}  # never converted, so never on /cam/scan (none of them on the output)
    records = {"/cam/scan": {"stamp": [s for i, s in enumerate(cam) if i not in lost]},
               "/merged_scan": {"stamp": out.tolist()}}
    sources = analysis.merger_sources(drivers, counts, bag, records)
    assert sources == {"/cam/depth/camera_info": "/cam/scan"}
    by_topic = {d["topic"]: d for d in analysis.account_with_merger(drivers, counts, sources)}
    cam_driver = by_topic["/cam/depth/camera_info"]
    assert cam_driver["inputs"] == len(cam) and cam_driver["matched"] == len(cam[::3])
    assert (cam_driver["dropped"], cam_driver["merged_later"]) == (4, len(cam) - len(cam[::3]) - 4)
    assert by_topic["/sonar/range"]["dropped"] == 0
    # Without the scan's record, or with only a third of the frames on it, nothing is mapped.
    assert analysis.merger_sources(drivers, counts, bag, {}) == {}
    assert analysis.merger_sources(drivers, counts, bag, {"/cam/scan": {"stamp": cam[::3].tolist()}}) == {}


def test_static_pose_chains_transforms():
    q_yaw = (0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4))  # 90 degrees
    tf = [("base_link", "mount", (1.0, 0.0, 0.2), q_yaw),
          ("mount", "laser", (0.5, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))]
    m = analysis.static_pose_in(tf, "laser")
    assert m[:3, 3] == pytest.approx([1.0, 0.5, 0.2])
    assert math.atan2(m[1, 0], m[0, 0]) == pytest.approx(math.pi / 2)
    assert analysis.static_pose_in(tf, "camera") is None


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
    res, ex = analysis.ground_truth_stats(run, info, sc, band=(0.0, 0.05, 1.0), beam_window=0)
    m = res["/merged"]
    assert m["scans"] == 2 and m["median_error"] == pytest.approx(0.02, abs=1e-4)
    assert m["false"] == 20 and m["z_band"] == [0.05, 1.0]
    lidar = res["/lidar"]
    assert lidar["median_error"] < 1e-4 and lidar["false"] == 0
    assert lidar["z_band"] == pytest.approx([0.18, 0.22])
    assert set(ex) == {"/merged", "/lidar"}


# ------------------------------------------------ extreme stamps: reported, never a crash

MAX_STAMP = 4294967295.999999999  # ROS 1 time's largest value


def test_header_stamp_reads_the_largest_ros_time():
    import struct
    raw = struct.pack("<III", 7, 0xFFFFFFFF, 999999999) + b"\x00\x00\x00\x00"
    assert playback._header_stamp(raw) == pytest.approx(MAX_STAMP, abs=1e-6)
    assert playback._header_stamp(b"\x00" * 8) is None  # too short for a header


def _records(stamps, recv):
    scans = [{"stamp": s, "frame": "base_link", "angle_min": -1.0, "angle_max": 1.0,
              "angle_increment": 0.5, "range_min": 0.1, "range_max": 10.0,
              "ranges": np.array([1.0, np.inf, 2.0, np.nan, 0.05], np.float32)}
             for s in stamps if s is not None]
    return {"type": "sensor_msgs/LaserScan", "recv_sim": list(recv),
            "recv_wall": [1000.0 + r - recv[0] for r in recv], "stamp": list(stamps),
            "bytes": [100] * len(recv), "scans": scans}


def test_extreme_and_missing_stamps_are_reported(tmp_path):
    """An output whose stamps are far ahead of the bag clock (near the end of ROS time),
    one from 1970 (an unset stamp), one message without a readable stamp: figures and the
    report come out, with the negative latencies explained."""
    from laserscan_toolbox.evaluation import report
    bag_t = 1.4839920e9 + np.arange(6) * 0.1
    inputs = {"/scan_in": {"type": "sensor_msgs/LaserScan", "count": 6, "frequency": 10.0,
                           "stamps": (MAX_STAMP - 1 + np.arange(6) * 0.1).tolist(), "bytes": 600,
                           "age": []}}
    inputs["/scan_in"]["age"] = (bag_t - np.asarray(inputs["/scan_in"]["stamps"])).tolist()
    bag_info = {"path": "x.bag", "topics": inputs, "start": bag_t[0], "end": bag_t[-1],
                "size": 1000, "static_tf": []}
    ahead = inputs["/scan_in"]["stamps"]
    run = {"records": {"/far": _records(ahead[:4] + [None, 0.0], bag_t + 0.002),
                       "/dup": _records([5.0, 5.0, 5.0], bag_t[:3])},
           "cpu": {}, "outputs": {}}
    stats = analysis.output_stats(run, bag_info)
    far = stats["/far"]
    assert far["count"] == 6
    assert far["latency_min_s"] == pytest.approx(bag_t[0] + 0.002 - MAX_STAMP + 1, rel=1e-9)
    assert far["negative_latency_fraction"] == pytest.approx(4 / 5)  # the 1970 one is late
    assert [i["topic"] for i in far["inputs"]] == ["/scan_in"]
    # the pipeline's own delay does not depend on the stamping clock
    assert far["delay_after_input_median_s"] == pytest.approx(0.002, abs=1e-4)
    assert math.isnan(stats["/dup"]["rate_hz"])  # one stamp thrice: no rate, no crash

    results = EvaluationResult(
        bag="x.bag", bag_duration_s=0.5, bag_size_bytes=1000, player=["rosbag", "play"],
        launch=["roslaunch", "x"], playback_wall_s=1.0, outputs=stats,
        inputs={"/scan_in": {"type": "sensor_msgs/LaserScan", "count": 6, "rate_hz": 10.0, "bytes_per_s": 1.0,
                             "age_median_s": float(np.median(inputs["/scan_in"]["age"])),
                             "age_min_s": float(np.min(inputs["/scan_in"]["age"]))}})
    report.write_report(results, {}, run, str(tmp_path))
    text = (tmp_path / "report.md").read_text()
    assert "**Negative latencies.**" in text
    assert "input `/scan_in`: stamps up to" in text
    assert "likely cause: stamps ahead of the bag clock" in text
    assert (tmp_path / "latency.png").stat().st_size > 0
    assert "negative latencies" in report.summary_text(results)
    # no note when every latency is positive
    results.outputs = {"/dup": stats["/dup"]}
    results.inputs["/scan_in"]["age_min_s"] = 0.01
    assert report.stamps_ahead_note(results) == []


def test_stale_receive_clock_is_told_apart_from_stamps_ahead():
    from laserscan_toolbox.evaluation import report
    results = EvaluationResult(outputs={"/m": {"latency_min_s": -0.1, "negative_latency_fraction": 0.003,
                                               "delay_after_input_median_s": 0.001,
                                               "delay_after_input_p95_s": 0.004,
                                               "delay_after_input_min_s": -0.18}},
                               inputs={"/in": {"age_min_s": 0.08, "age_median_s": 0.084}})
    text = "\n".join(report.stamps_ahead_note(results))
    assert "likely cause: the receiving clock read stale" in text
    assert "input `/in`" not in text


def test_snapshot_plot_places_inputs_by_their_mounts(tmp_path):
    from laserscan_toolbox.evaluation import report

    def scan(ranges, frame, inp, mount):
        return {"stamp": 10.0, "frame": frame, "input": inp, "angle_min": 0.0,
                "angle_increment": math.pi / 2, "range_min": 0.1, "range_max": 5.0,
                "ranges": np.asarray(ranges, np.float32),
                "mount": None if mount is None else mount.tolist()}
    flip = np.diag([-1.0, -1.0, 1.0, 1.0])  # a rear lidar turned by pi
    snap = {"topic": "/merged", "stamp": 10.0, "frame": "base_link", "scans": {
        "/merged": scan([1, 2, 3, np.inf], "base_link", False, np.eye(4)),
        "/rear": scan([1, np.nan, 0.05, 9.0], "rear", True, flip),
        "/odd": scan([1, 1, 1, 1], "elsewhere", True, None)}}
    x, y = report._scan_points(snap["scans"]["/rear"])
    assert x.tolist() == pytest.approx([-1.0]) and y.tolist() == pytest.approx([0.0], abs=1e-9)
    path = report.plot_snapshot(snap, str(tmp_path / "scans.png"))
    import matplotlib.image as mpimg
    assert mpimg.imread(path).shape[1] > 3 * mpimg.imread(path).shape[0] * 0.8  # three panels


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
    res, _ = analysis.ground_truth_stats(run, info, sc, band=(0.0, 0.05, 1.0), beam_window=0)
    m = res["/merged"]
    assert m["median_error"] < 1e-4 and m["false"] == 0 and m["missed"] == 0
    g = analysis.glass_stats(run, info, sc, (0.0, 0.05, 1.0))["/merged"]
    assert (g["glass_beams"], g["found"]) == (20, 0)
    seen_pane = clear.copy()
    seen_pane[:20] = 0.98
    g = analysis.glass_stats({"records": {"/m": {"scans": [scan(1.0, seen_pane)]}}}, info, sc, (0.0, 0.05, 1.0))["/m"]
    assert (g["glass_beams"], g["found"]) == (20, 20)


# ------------------------------------------------ results.json and the demo's summary

def test_results_json_and_demo_summary_link_each_section_once(tmp_path):
    """write_json takes numpy figures; demo_summary reads them back and links the CPU
    experiment and the rviz picture from report.md once, however often it runs."""
    import json
    from laserscan_toolbox.evaluation import report
    results = EvaluationResult(bag="/x/s.bag", bag_duration_s=np.float64(6.0),
                               cpu={"manager": {"cpu_percent": np.float32(12.5)}},
                               scan_plot={"beams": np.arange(3), "frames": {"odom"}},
                               thresholds=[Check(True, "rate")])
    report.write_json(results.to_json(), str(tmp_path / "results.json"))
    back = json.loads((tmp_path / "results.json").read_text())
    assert back["scan_plot"] == {"beams": [0, 1, 2], "frames": ["odom"]}
    assert back["cpu"]["manager"]["cpu_percent"] == 12.5
    (tmp_path / "cpu").mkdir()
    row = {"points_per_camera": 10000, "merged": {"manager_cpu_percent": 3.0, "bytes_per_s": 2e3},
           "raw": {"bytes_per_s": 4e6}}
    report.write_json({"rows": [row]}, str(tmp_path / "cpu" / "cpu_results.json"))
    (tmp_path / "report.md").write_text("# Pipeline evaluation\n")
    (tmp_path / "rviz.png").write_bytes(b"png")
    for _ in range(2):
        text = report.demo_summary(str(tmp_path), "total 1s")
    assert text.startswith("Demo figures (total 1s)\nbag s.bag: 6.0 s")
    assert "PASS rate" in text and "10k points: manager 3.0%" in text
    md = (tmp_path / "report.md").read_text()
    assert md.count("(cpu/cpu_experiment.md)") == 1 and md.count("(rviz.png)") == 1


def test_cpu_experiment_counts_the_managers_cpu_by_the_process_names():
    """The CPU experiment's manager figure takes the processes that process_name tags as
    managers, not the loader clients or other nodes, on the names of a real run's launch."""
    from laserscan_toolbox.experiments import cpu
    from laserscan_toolbox.ros.rosrun import process_name

    class Proc:
        def __init__(self, *cmd):
            self.pid, self._cmd = 1, list(cmd)

        def cmdline(self):
            return self._cmd

    nodelet = "/usr/lib/nodelet/nodelet"
    names = [process_name(Proc(nodelet, "manager", "__name:=pipeline_manager")),
             process_name(Proc(nodelet, "load", "multi_laserscan_merger/MultiLaserScanMergerNodelet",
                               "pipeline_manager", "__name:=merged_scan_merger")),
             process_name(Proc("/usr/bin/python3", "/opt/ros/lib/tf2_ros/static_transform_publisher"))]
    figures = dict(zip(names, ({"cpu_percent": 8.5}, {"cpu_percent": 0.5}, {"cpu_percent": 0.25})))
    assert cpu.manager_cpu_percent(figures) == pytest.approx(8.5)
    assert cpu.manager_cpu_percent({}) == 0


def test_input_stats_rate_from_stamps_else_rosbag_frequency():
    topics = {"/scan": {"type": "sensor_msgs/LaserScan", "count": 5, "frequency": 3.0,
                        "stamps": [0.0, 0.1, 0.2, 0.3, 0.4], "bytes": 1000,
                        "age": [0.02, 0.01, 0.03, 0.02, 0.02]},
              "/tf": {"type": "tf2_msgs/TFMessage", "count": 4, "frequency": 7.5, "stamps": [],
                      "bytes": 400, "age": []}}
    s = analysis.input_stats({"topics": topics, "start": 0.0, "end": 2.0})
    assert s["/scan"]["rate_hz"] == pytest.approx(10.0)
    assert s["/scan"]["age_median_s"] == pytest.approx(0.02)
    assert s["/scan"]["age_min_s"] == pytest.approx(0.01)
    assert s["/scan"]["bytes_per_s"] == pytest.approx(500.0)
    assert s["/tf"] == {"type": "tf2_msgs/TFMessage", "count": 4, "rate_hz": 7.5,
                        "bytes_per_s": 200.0, "age_median_s": None, "age_min_s": None}
