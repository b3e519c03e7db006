"""ros/cpu_accounting: the CPU of real processes, process trees and threads, and the window between
two snapshots. Every figure is CPU time, which load on the machine does not inflate: a busy loop
runs until its own process has spent a given CPU time, so the measured time has that as an exact
lower bound, and the upper bounds leave room for what an interpreter does around the loop."""
import os
import subprocess
import sys
import threading
import time

import psutil
import pytest

from laserscan_toolbox.ros import cpu_accounting as ca

BUSY_S = 0.3
# What a process may spend besides its busy loop inside a window (waking up, one print): well
# under 1 ms; the bound is generous for a loaded machine (cache misses, page faults).
SLACK_S = 0.05

# Spins the CPU seconds of its own CPU time (the clock this module reads) written on each line
# of stdin, then answers "done"; with "tree", a grandchild (named like a ROS node) spins instead.
SPIN = r"""
import subprocess, sys, time
def spin(seconds):
    start = time.process_time()
    while time.process_time() - start < seconds:
        pass
worker = None
if "tree" in sys.argv[1:]:
    worker = subprocess.Popen([sys.executable, "-c", sys.argv[1], "__name:=worker"],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert worker.stdout.readline() == "ready\n"
print("ready", flush=True)
for line in sys.stdin:
    if worker:
        worker.stdin.write(line); worker.stdin.flush()
        print(worker.stdout.readline(), end="", flush=True)
    else:
        spin(float(line))
        print("done", flush=True)
"""


class Spinner:
    """A process (with a grandchild doing the work when ``tree``) that spends the CPU seconds
    asked by spin() and then waits."""

    def __init__(self, tree=False):
        self.proc = subprocess.Popen([sys.executable, "-c", SPIN, SPIN] + (["tree"] if tree else []),
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        assert self.proc.stdout.readline() == "ready\n"

    def spin(self, seconds):
        self.proc.stdin.write("%r\n" % seconds)
        self.proc.stdin.flush()
        assert self.proc.stdout.readline() == "done\n"

    def close(self):
        self.proc.stdin.close()
        self.proc.wait(30)


@pytest.fixture
def spinner():
    s = Spinner()
    yield s
    s.close()


@pytest.fixture
def tree():
    s = Spinner(tree=True)
    yield s
    s.close()


def test_the_nanosecond_clock_is_in_use_on_linux():
    assert ca.SOURCE == ca.NANOSECONDS


def test_process_cpu_of_a_busy_child(spinner):
    before = ca.process_cpu_s(spinner.proc.pid)
    spinner.spin(BUSY_S)
    spent = ca.process_cpu_s(spinner.proc.pid) - before
    assert BUSY_S <= spent < BUSY_S + SLACK_S


def test_a_process_that_ended_is_no_such_process():
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    proc = psutil.Process(p.pid)
    p.wait(30)
    with pytest.raises(psutil.NoSuchProcess):
        ca.process_cpu_s(p.pid)
    assert ca.snapshot([proc]) == {}


def test_threads_count_also_one_that_ended():
    def burn(seconds):
        start = time.thread_time()
        while time.thread_time() - start < seconds:
            pass
    before = ca.process_cpu_s(os.getpid())
    worker = threading.Thread(target=burn, args=(0.2,))
    worker.start()
    burn(0.1)
    worker.join()  # it has ended: its CPU is still the process's
    spent = ca.process_cpu_s(os.getpid()) - before
    assert 0.3 <= spent < 0.3 + SLACK_S


def test_one_threads_cpu_apart_from_the_others():
    def burn(seconds):
        start = time.thread_time()
        while time.thread_time() - start < seconds:
            pass
    tid = threading.get_native_id()
    before = ca.thread_cpu_s(os.getpid(), tid)
    worker = threading.Thread(target=burn, args=(0.2,))
    worker.start()
    worker.join()  # the other thread's CPU is not this one's
    burn(0.1)
    spent = ca.thread_cpu_s(os.getpid(), tid) - before
    assert 0.1 <= spent < 0.1 + SLACK_S
    with pytest.raises(psutil.NoSuchProcess):
        ca.thread_cpu_s(os.getpid(), worker.native_id)  # it has ended


def test_tick_fallback_reads_the_same_time(spinner, monkeypatch):
    spinner.spin(BUSY_S)  # the child now waits: its CPU time stands still
    ns = ca.process_cpu_s(spinner.proc.pid)
    monkeypatch.setattr(ca, "SOURCE", ca.CLOCK_TICKS)
    ticks = ca.process_cpu_s(spinner.proc.pid)
    assert abs(ticks - ns) <= 0.03  # user and system, each cut to whole 10 ms ticks
    assert ca.spent({}, ca.snapshot([psutil.Process(spinner.proc.pid)]))["source"] == ca.CLOCK_TICKS


def test_tree_lists_descendants_and_the_root_if_asked(tree):
    procs = ca.tree_processes(tree.proc.pid)
    assert len(procs) == 1 and procs[0].ppid() == tree.proc.pid  # the grandchild
    assert [p.pid for p in ca.tree_processes(tree.proc.pid, include_root=True)] == \
        [tree.proc.pid, procs[0].pid]
    assert ca.tree_processes(2 ** 22 + 1) == []  # beyond pid_max: no such root


def test_window_over_a_tree_counts_the_grandchild(tree):
    procs = ca.tree_processes(tree.proc.pid, include_root=True)
    before = ca.snapshot(procs, lambda p: "root" if p.pid == tree.proc.pid else "worker")
    tree.spin(BUSY_S)
    after = ca.snapshot(ca.tree_processes(tree.proc.pid, include_root=True),
                        lambda p: "root" if p.pid == tree.proc.pid else "worker")
    d = ca.spent(before, after)
    worker = ca.label("worker", procs[1].pid)
    assert set(d["per_process"]) == {ca.label("root", tree.proc.pid), worker}
    assert BUSY_S <= d["per_process"][worker] < BUSY_S + SLACK_S
    assert d["per_process"][ca.label("root", tree.proc.pid)] < SLACK_S  # it only relayed
    assert d["total_s"] == pytest.approx(sum(d["per_process"].values()))
    # the window only: both processes had spent CPU before it (their start-up)
    assert d["total_s"] == pytest.approx(sum(c for _, c in after.values())
                                         - sum(c for _, c in before.values()))
    assert d["lost"] == [] and d["source"] == ca.NANOSECONDS


def test_window_with_processes_started_and_ended_inside():
    before = {(10, 1.0): ("a", 2.0), (11, 1.0): ("gone", 5.0)}
    after = {(10, 1.0): ("a", 2.5), (12, 3.0): ("new", 0.25), (11, 9.0): ("recycled", 1.0)}
    d = ca.spent(before, after)
    # a new process counts all its CPU; pid 11 with another create_time is another process
    assert d["per_process"] == {"a[10]": 0.5, "new[12]": 0.25, "recycled[11]": 1.0}
    assert d["total_s"] == pytest.approx(1.75)
    assert d["lost"] == ["gone[11]"]


# ---------------------------------------------------------------- what a robot pays, and /clock

def _serialized(msg):
    import io
    b = io.BytesIO()
    msg.serialize(b)
    return b.getvalue()


def _scan(secs, nsecs):
    from sensor_msgs.msg import LaserScan
    m = LaserScan()
    m.header.seq, m.header.frame_id = 7, "laser"
    m.header.stamp.secs, m.header.stamp.nsecs = secs, nsecs
    m.ranges = [1.0, 2.0]
    return m


def _read(cls, raw):
    m = cls()
    m.deserialize(raw)
    return m


def test_header_stamps_are_moved_by_the_offset_with_carry():
    from sensor_msgs.msg import LaserScan
    from laserscan_toolbox.ros import wall_clock_play as wcp
    raw = _serialized(_scan(1000, 999_999_000))
    out = _read(LaserScan, wcp.shift_header_stamp(raw, 1_000_002_000))  # 1 s + 2 us
    assert (out.header.stamp.secs, out.header.stamp.nsecs) == (1002, 1000)  # nsecs carried
    assert out.header.seq == 7 and out.header.frame_id == "laser" and list(out.ranges) == [1, 2]
    back = _read(LaserScan, wcp.shift_header_stamp(raw, -999_000))
    assert (back.header.stamp.secs, back.header.stamp.nsecs) == (1000, 999_000_000)


def test_zero_stamps_and_stamps_the_offset_would_carry_out_of_ros_time_stay():
    from laserscan_toolbox.ros import wall_clock_play as wcp
    for secs, nsecs, offset in ((0, 0, 10 ** 18), (2 ** 32 - 2, 0, 5 * 10 ** 9), (3, 0, -4 * 10 ** 9)):
        raw = _serialized(_scan(secs, nsecs))
        assert wcp.shift_header_stamp(raw, offset) == raw, (secs, offset)


def test_every_transform_of_a_tf_message_is_moved():
    from geometry_msgs.msg import TransformStamped
    from tf2_msgs.msg import TFMessage
    from laserscan_toolbox.ros import wall_clock_play as wcp
    msg = TFMessage()
    for i, (parent, child) in enumerate((("odom", "base_link"), ("base_link", "a_longer_frame_name"),
                                         ("base_link", "static_at_zero"))):
        t = TransformStamped()
        t.header.frame_id, t.child_frame_id = parent, child
        t.header.stamp.secs = 0 if child == "static_at_zero" else 50 + i
        t.transform.translation.x, t.transform.rotation.w = 0.5 + i, 1.0
        msg.transforms.append(t)
    raw = _serialized(msg)
    out = _read(TFMessage, wcp.shift_tf_stamps(raw, 10 * 10 ** 9))
    assert [t.header.stamp.secs for t in out.transforms] == [60, 61, 0]
    assert [t.child_frame_id for t in out.transforms] == ["base_link", "a_longer_frame_name",
                                                          "static_at_zero"]
    assert [t.transform.translation.x for t in out.transforms] == [0.5, 1.5, 2.5]
    with pytest.raises(ValueError):
        wcp.shift_tf_stamps(raw[:-8], 1)  # the last transform cut short
    assert wcp.stamp_shifter("tf2_msgs/TFMessage", False) is wcp.shift_tf_stamps
    assert wcp.stamp_shifter("sensor_msgs/Image", True) is wcp.shift_header_stamp
    assert wcp.stamp_shifter("std_msgs/String", False) is None


def _figures(**percent):
    return {name: {"cpu_percent": p, "cpu_seconds": p / 10.0, "rss_mb": 20.0}
            for name, p in percent.items()}


MGR, LOAD_A, LOAD_B, NODE = ("pipeline_manager (manager)", "merger (loader)",
                             "converter (loader)", "static_tf")


def test_cpu_stats_reports_the_wall_time_figures_by_role_and_the_clock_share():
    from laserscan_toolbox.evaluation.analysis import cpu_stats
    sim = _figures(**{MGR: 8.0, LOAD_A: 2.0, LOAD_B: 2.25, NODE: 1.0})
    wall = _figures(**{MGR: 6.5, LOAD_A: 0.25, LOAD_B: 0.5, NODE: 1.25})
    per, summary = cpu_stats(sim, wall)
    assert summary["clock"] == "wall"
    assert {n: c["cpu_percent"] for n, c in per.items()} == {MGR: 6.5, LOAD_A: 0.25, LOAD_B: 0.5,
                                                           NODE: 1.25}
    assert {n: c["role"] for n, c in per.items()} == {MGR: "manager", LOAD_A: "loader",
                                                    LOAD_B: "loader", NODE: "node"}
    assert per[LOAD_A]["sim_clock_cpu_percent"] == 2.0
    assert per[LOAD_A]["clock_share_percent"] == pytest.approx(1.75)
    assert per[NODE]["clock_share_percent"] == pytest.approx(-0.25)  # noise keeps its sign
    assert summary["by_role"] == pytest.approx({"manager": 6.5, "loader": 0.75, "node": 1.25})
    assert summary["processes"] == {"manager": 1, "loader": 2, "node": 1}
    assert summary["total_percent"] == pytest.approx(8.5)
    assert summary["sim_clock_total_percent"] == pytest.approx(13.25)
    assert summary["clock_share_percent"] == pytest.approx(13.25 - 8.5)
    assert summary["missing_on_wall_time"] == []


def test_cpu_stats_without_a_replay_or_at_another_rate_gives_no_clock_share():
    from laserscan_toolbox.evaluation.analysis import cpu_stats
    sim = _figures(**{MGR: 8.0, LOAD_A: 2.0})
    per, summary = cpu_stats(sim)
    assert summary["clock"] == "sim" and summary["total_percent"] == pytest.approx(10.0)
    assert summary["clock_share_percent"] is None and per[MGR]["clock_share_percent"] is None
    # played at rate 2 under /clock, replayed at rate 1: twice the work per second, no share
    per, summary = cpu_stats(sim, _figures(**{MGR: 4.0}), rate=2.0)
    assert summary["clock"] == "wall" and summary["clock_share_percent"] is None
    assert per[MGR]["clock_share_percent"] is None and per[MGR]["sim_clock_cpu_percent"] == 8.0
    # a loader that ended before the replay is named, not summed
    assert summary["missing_on_wall_time"] == [LOAD_A] and summary["total_percent"] == 4.0


def test_process_roles_follow_the_tags_of_process_names():
    from laserscan_toolbox.ros.rosrun import LOADER_TAG, MANAGER_TAG, process_role
    assert process_role("laser_manager" + MANAGER_TAG) == "manager"
    assert process_role("front_converter" + LOADER_TAG) == "loader"
    assert process_role("merger_node") == "node"
    assert process_role("loader") == "node"  # a node named so is no loader client


def test_wall_time_replay_overrides_use_sim_time_where_the_launch_declares_it(tmp_path):
    from laserscan_toolbox.ros.rosrun import wall_time_args
    declares = tmp_path / "declares.launch"
    declares.write_text('<launch><arg name="use_sim_time" default="true"/>'
                        '<arg name="other" default="1"/></launch>')
    silent = tmp_path / "silent.launch"
    silent.write_text('<launch><arg name="other" default="1"/></launch>')
    assert wall_time_args(str(declares), ["use_sim_time:=true", "other:=2"]) == \
        ["other:=2", "use_sim_time:=false"]
    # roslaunch refuses an argument the file does not declare: the master's parameter does it
    assert wall_time_args(str(silent), ["other:=2"]) == ["other:=2"]


def test_the_report_gives_what_a_robot_pays_beside_the_clock_share():
    from laserscan_toolbox.evaluation import report
    from laserscan_toolbox.evaluation.analysis import cpu_stats
    from laserscan_toolbox.evaluation.results import EvaluationResult
    sim = _figures(**{MGR: 8.0, LOAD_A: 2.0, LOAD_B: 2.25})
    per, summary = cpu_stats(sim, _figures(**{MGR: 6.5, LOAD_A: 0.25, LOAD_B: 0.5}))
    summary.update(window_s=10.0, clock_hz=200, rate=1.0, wall_replay_problem=None)
    res = EvaluationResult(cpu=per, cpu_summary=summary, playback_wall_s=60.0)
    text = report.cpu_table(res)
    assert "| nodelet loader clients (2) | 0.8 | 4.2 | 3.5 |  |" in text
    assert "| **all launched processes** | **7.2** | 12.2 | 5.0 |  |" in text
    assert "on wall time (what a robot pays)" in text
    lines = "\n".join(report.cpu_summary_lines(res))
    assert "CPU of the pipeline: 7.2% of one core on wall time" in lines
    assert "by role: nodelet manager 6.5%, 2 nodelet loader clients 0.8%" in lines
    assert "under rosbag's 200 Hz /clock: 12.2% (the /clock share, not paid on a robot: 5.0%)" in lines
    # without a replay the figures say they are the simulated clock's
    per, summary = cpu_stats(sim)
    res = EvaluationResult(cpu=per, cpu_summary=dict(summary, wall_replay_problem=None), playback_wall_s=60.0)
    assert "under the simulated clock" in report.cpu_table(res)
    assert "12.2% of one core under the simulated clock" in "\n".join(report.cpu_summary_lines(res))


def test_a_wall_clock_player_that_cannot_start_says_why(tmp_path):
    from laserscan_toolbox.ros.rosrun import RunError, WallClockPlayer
    player = WallClockPlayer(str(tmp_path / "missing.bag"), str(tmp_path / "play.log"))
    with pytest.raises(RunError, match="did not start(.|\n)*missing.bag"):
        player.start(timeout=30.0)
    assert player.proc.poll() is not None  # nothing left running
