"""The closed-loop simulator on ROS (scripts/simulate_scenario --closed-loop) against a scripted
navigator that follows the lockstep contract (answers every control step on ~step with a twist
computed from the lidar scan stamped at that step): the clock and every stamp are on the step
grid, the robot moves as commanded, the same seed gives the same run whatever the timing, and the
depth clouds are organized clouds of the configured size."""
import json
import os
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPTS = os.path.join(HERE, "..", "scripts")
sys.path.insert(0, SCRIPTS)
from laserscan_toolbox.ros import rosrun  # noqa: E402

STEP = "/fake_navigator/step"
STATE = "/fake_navigator/state"


def fake_navigator(log_path, stop_at=None, block_at=None):
    """The scripted navigator (run as its own process): on every lidar_front scan (stamped t_k,
    sensors at the control rate) it answers step t_k with vx = 0.4 * (the scan's median finite
    range / 6 m, at most 1), vy = 0.05, w = 0.1 once it has a goal, else zero; from ROS time
    ``stop_at`` on it answers nothing (a stuck navigator), from ``block_at`` on it answers zero
    and says "blocked". Logs what it saw."""
    import numpy as np
    import rospy
    from geometry_msgs.msg import PoseStamped, TwistStamped
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import LaserScan, PointCloud2
    from std_msgs.msg import String
    rospy.init_node("fake_navigator")
    state = rospy.Publisher("~state", String, queue_size=1, latch=True)
    step = rospy.Publisher("~step", TwistStamped, queue_size=10)
    seen = {"goal": None, "clock": [], "scans": [], "clouds": []}
    state.publish(String(data="idle"))

    def on_goal(msg):
        seen["goal"] = (msg.header.frame_id, msg.pose.position.x, msg.pose.position.y)
        state.publish(String(data="navigating"))

    def on_scan(msg):
        if stop_at is not None and msg.header.stamp.to_sec() >= stop_at:
            return
        r = np.asarray(msg.ranges)
        r = r[np.isfinite(r)]
        out = TwistStamped()
        out.header.stamp = msg.header.stamp
        if block_at is not None and msg.header.stamp.to_sec() >= block_at:
            state.publish(String(data="blocked"))
        elif seen["goal"] is not None:
            out.twist.linear.x = 0.4 * min(1.0, float(np.median(r)) / 6.0)
            out.twist.linear.y, out.twist.angular.z = 0.05, 0.1
        seen["scans"].append(msg.header.stamp.to_nsec())
        step.publish(out)

    def on_cloud(msg):
        seen["clouds"].append((msg.header.stamp.to_nsec(), msg.height * msg.width, msg.point_step,
                               msg.header.frame_id))

    rospy.Subscriber("move_base_simple/goal", PoseStamped, on_goal)
    rospy.Subscriber("/lidar_front/scan", LaserScan, on_scan, queue_size=100)
    rospy.Subscriber("/camera_left/depth/points", PointCloud2, on_cloud, queue_size=100)
    rospy.Subscriber("/clock", Clock, lambda m: seen["clock"].append(m.clock.to_nsec()), queue_size=1000)
    rospy.on_shutdown(lambda: json.dump(seen, open(log_path, "w")))
    rospy.spin()


def _run(tmp_path, label, seed):
    nav_log = str(tmp_path / (label + "_nav.json"))
    record = str(tmp_path / (label + "_run.json"))
    nav = subprocess.Popen([sys.executable, __file__, "--fake-navigator", nav_log], start_new_session=True)
    try:
        out = subprocess.run(
            [sys.executable, os.path.join(SCRIPTS, "simulate_scenario"), "--closed-loop", "--route", "table",
             "--seed", str(seed), "--camera-points", "2000", "--depth-output", "both", "--step-topic", STEP,
             "--state-topic", STATE, "--wait-for", "/lidar_front/scan", "/camera_left/depth/points",
             "--goal-delay", "0.5", "--timeout", "1.5", "--record", record],
            capture_output=True, text=True, timeout=120)
        assert out.returncode == 0, out.stderr
    finally:
        rosrun.stop_process(nav)
    with open(record) as f:
        rec = json.load(f)
    with open(nav_log) as f:
        return rec, json.load(f)


@pytest.fixture(scope="module")
def master(tmp_path_factory):
    with rosrun.Master(str(tmp_path_factory.mktemp("closed_loop_ros"))) as m:
        yield m


@pytest.fixture(scope="module")
def runs(master, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("closed_loop")
    return [_run(tmp, "a", 4), _run(tmp, "b", 4)]


def test_the_clock_and_every_stamp_are_on_the_step_grid_and_every_step_is_answered(runs):
    rec, seen = runs[0]
    start = 1000 * 10**9
    assert rec["lockstep_timeouts"] == 0 and rec["timed_out"] and not rec["reached"]
    assert rec["simulated_s"] == pytest.approx(2.0)
    clock = [c for c in seen["clock"] if c > start]
    assert clock and all((c - start) % 20_000_000 == 0 for c in clock)  # 50 Hz steps, exact ns
    assert seen["scans"][-1] == start + 19 * 100_000_000  # the last step before the end (k = 19)
    assert all((s - start) % 100_000_000 == 0 for s in seen["scans"])
    assert seen["goal"] == ["map", pytest.approx(11.8), pytest.approx(8.8)]
    stamps, sizes, steps, frames = zip(*seen["clouds"])
    assert set(sizes) == {rec["points_per_camera"]} and set(steps) == {12}
    assert set(frames) == {"camera_left_optical_frame"} and set(stamps) <= set(seen["scans"])


def test_the_robot_moves_as_commanded(runs):
    rec, _ = runs[0]
    traj = rec["trajectory"]
    t0, x0, y0, yaw0 = traj[0]
    t1, x1, y1, yaw1 = traj[-1]
    # Commands from the goal's step (0.5 s, the goal came before its data) on: w = 0.1 rad/s,
    # reached at 1.2 rad/s^2 (0.1^2 / 2.4 rad lost), for 1.5 s.
    assert yaw1 - yaw0 == pytest.approx(0.1 * 1.5 - 0.1 ** 2 / 2.4, abs=0.001)
    assert x1 - x0 > 0.2 and y1 > y0  # forward (+x, the route's heading) and to the left
    chords = [((b[1] - a[1]) ** 2 + (b[2] - a[2]) ** 2) ** 0.5 for a, b in zip(traj, traj[1:]) if a[0] >= 0.5]
    assert rec["path_length_m"] == pytest.approx(sum(chords), rel=0.02)


def test_the_same_seed_gives_the_same_run(runs):
    (a, _), (b, _) = runs
    assert a["trajectory"] == b["trajectory"]
    assert {k: v for k, v in a.items() if k != "wall_s"} == {k: v for k, v in b.items() if k != "wall_s"}


def test_the_run_ends_when_the_navigator_is_blocked(master, tmp_path):
    nav = subprocess.Popen([sys.executable, __file__, "--fake-navigator", str(tmp_path / "nav.json"),
                            "2000", "1001.0"], start_new_session=True)
    try:
        out = subprocess.run(
            [sys.executable, os.path.join(SCRIPTS, "simulate_scenario"), "--closed-loop",
             "--camera-points", "2000", "--step-topic", STEP, "--state-topic", STATE, "--wait-for",
             "/lidar_front/scan", "--goal-delay", "0.5", "--record", str(tmp_path / "run.json")],
            capture_output=True, text=True, timeout=60)
    finally:
        rosrun.stop_process(nav)
    assert out.returncode == 0, out.stderr
    with open(tmp_path / "run.json") as f:
        rec = json.load(f)
    # Blocked from step 1.0 s on: the run ends there (or one step later: the state is its own
    # topic), not after the 90 s timeout.
    assert rec["navigator_state"] == "blocked" and not rec["timed_out"] and not rec["reached"]
    assert rec["simulated_s"] in (pytest.approx(1.0), pytest.approx(1.1))
    assert rec["trajectory"][-1][0] == pytest.approx(rec["simulated_s"])


def test_a_navigator_that_stops_answering_ends_the_run_with_exit_3(master, tmp_path):
    nav = subprocess.Popen([sys.executable, __file__, "--fake-navigator", str(tmp_path / "nav.json"),
                            "1000.3"], start_new_session=True)
    try:
        out = subprocess.run(
            [sys.executable, os.path.join(SCRIPTS, "simulate_scenario"), "--closed-loop",
             "--camera-points", "2000", "--step-topic", STEP, "--wait-for", "/lidar_front/scan",
             "--lockstep-timeout", "0.2", "--record", str(tmp_path / "run.json")],
            capture_output=True, text=True, timeout=60)
    finally:
        rosrun.stop_process(nav)
    assert out.returncode == 3, out.stderr
    assert "stopped answering %s (t = 1000.500, 3 steps in a row" % STEP in out.stderr
    assert out.stderr.count("no %s for t = " % STEP) == 3  # 1000.3, .4, .5 waited for, then given up
    assert not (tmp_path / "run.json").exists()


if __name__ == "__main__" and sys.argv[1:2] == ["--fake-navigator"]:
    fake_navigator(sys.argv[2], *(float(a) for a in sys.argv[3:]))
