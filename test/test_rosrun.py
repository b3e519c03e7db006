"""ros/rosrun.py without a ROS master: how reports name a launch's processes, and the check that
no node of a launch died (roslaunch outlives a node that is not required)."""
import os
import subprocess
import sys

import psutil
import pytest

from laserscan_toolbox.ros import rosrun


class FakeProcess:
    """What process_name reads of a psutil.Process: its pid and command line."""

    def __init__(self, cmd, pid=4242):
        self.pid, self._cmd = pid, cmd

    def cmdline(self):
        if self._cmd is None:
            raise psutil.NoSuchProcess(self.pid)
        return self._cmd


@pytest.mark.parametrize("cmd, name", [
    (["/usr/lib/nodelet/nodelet", "manager", "__name:=pipeline_manager", "__log:=x.log"],
     "pipeline_manager (manager)"),
    (["/usr/lib/nodelet/nodelet", "load", "depth_filter_scan_converter/DepthFilterScanConverterNodelet",
      "pipeline_manager", "__name:=camera_converter"], "camera_converter (loader)"),
    (["/usr/lib/nodelet/nodelet", "standalone", "pkg/Type", "__name:=alone"], "alone"),
    (["/work/build/devel/lib/multi_laserscan_merger/multi_laserscan_merger_node", "__name:=merger"], "merger"),
    (["/usr/bin/python3", "/work/scripts/scan_relay", "in:=a"], "scan_relay"),
    (["/opt/bin/some_tool", "--flag"], "some_tool"),
    ([], "4242"),
    (None, "4242"),  # gone before its command line was read
])
def test_processes_are_named_like_ros_nodes(cmd, name):
    assert rosrun.process_name(FakeProcess(cmd)) == name


def test_a_running_process_is_named_from_its_command_line():
    p = subprocess.Popen([sys.executable, "-c", "import sys; print(); sys.stdin.read()", "__name:=worker"],
                         stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    try:
        p.stdout.readline()  # running: its command line is set (not yet right after a vfork)
        assert rosrun.process_name(psutil.Process(p.pid)) == "worker"
    finally:
        p.stdin.close()
        p.wait(30)


def _launch_with(tmp_path, log_lines, running):
    """A Launch whose roslaunch is a sleeping (or an ended) process and whose log holds log_lines."""
    launch = rosrun.Launch(os.path.join(rosrun.REPO, "launch", "pipeline.launch"), [], str(tmp_path / "roslaunch.log"))
    (tmp_path / "roslaunch.log").write_text("".join(line + "\n" for line in log_lines))
    launch.proc = subprocess.Popen(["sleep", "30" if running else "0"])
    if not running:
        launch.proc.wait(30)
    return launch


def test_a_launch_whose_nodes_all_run_passes(tmp_path):
    launch = _launch_with(tmp_path, ["started roslaunch server", "process[merger-2]: started with pid [7]"], True)
    try:
        launch.raise_if_stopped()
    finally:
        launch.proc.kill()
        launch.proc.wait(30)


@pytest.mark.parametrize("line", [
    "[camera_converter-4] process has died [pid 81, exit code -11, cmd ...]",
    "terminate called after throwing an instance of 'std::runtime_error'",
    "  what():  bad cloud",
])
def test_a_dead_node_is_named(tmp_path, line):
    launch = _launch_with(tmp_path, ["process[merger-2]: started with pid [7]", line], True)
    try:
        with pytest.raises(rosrun.RunError) as e:
            launch.raise_if_stopped("manager mode: the pipeline")
        assert str(e.value).startswith("manager mode: the pipeline stopped during playback")
        assert line in str(e.value)
    finally:
        launch.proc.kill()
        launch.proc.wait(30)


def test_an_ended_roslaunch_is_reported(tmp_path):
    launch = _launch_with(tmp_path, ["shutting down processing monitor..."], False)
    with pytest.raises(rosrun.RunError, match="the pipeline stopped during playback"):
        launch.raise_if_stopped()


class _FakeLaunch:
    """Stands in for roslaunch in Session.launched: records what was started, waited for, stopped."""

    made = []

    def __init__(self, launch_file, args, log_path, fail_waiting=False):
        self.launch_file, self.args, self.log_path = launch_file, list(args), log_path
        self.calls, self.fail_waiting = [], fail_waiting
        _FakeLaunch.made.append(self)

    def start(self):
        self.calls.append("start")
        return self

    def wait_ready(self, master, ignore_nodes=()):
        self.calls.append(("wait_ready", master, tuple(ignore_nodes)))
        if self.fail_waiting:
            raise rosrun.RunError("roslaunch exited with status 1")
        return {"/merged_scan": ["/merger"]}

    def stop(self):
        self.calls.append("stop")


@pytest.fixture
def fake_session(tmp_path, monkeypatch):
    """A Session on tmp_path whose launches are _FakeLaunch and whose master is a marker object."""
    _FakeLaunch.made = []
    monkeypatch.setattr(rosrun, "own_node_name", lambda: "/laserscan_evaluate_1")
    session = rosrun.Session(workdir=str(tmp_path))
    session.master = type("M", (), {"master": "the master proxy"})()
    return session


def test_a_session_launch_is_ready_inside_and_stopped_after(fake_session, monkeypatch, tmp_path):
    monkeypatch.setattr(rosrun, "Launch", _FakeLaunch)
    with fake_session.launched("pipeline.launch", ["standalone:=true"], "manager_1") as (launch, pubs):
        assert pubs == {"/merged_scan": ["/merger"]}
        assert launch.calls == ["start", ("wait_ready", "the master proxy", ("/laserscan_evaluate_1",))]
    assert launch.calls[-1] == "stop"
    assert launch.args == ["standalone:=true"]
    assert launch.log_path == str(tmp_path / "manager_1_roslaunch.log")


def test_a_session_launch_is_stopped_when_the_run_fails(fake_session, monkeypatch):
    monkeypatch.setattr(rosrun, "Launch", _FakeLaunch)
    with pytest.raises(ValueError):
        with fake_session.launched("pipeline.launch"):
            raise ValueError("the run failed")
    assert _FakeLaunch.made[0].calls[-1] == "stop"


def test_a_session_launch_that_never_gets_ready_is_stopped(fake_session, monkeypatch):
    monkeypatch.setattr(rosrun, "Launch", lambda *a: _FakeLaunch(*a, fail_waiting=True))
    with pytest.raises(rosrun.RunError, match="roslaunch exited"):
        with fake_session.launched("pipeline.launch"):
            pytest.fail("the body must not run when the launch never got ready")
    assert _FakeLaunch.made[0].calls[-1] == "stop"


def test_a_free_port_lies_below_the_ephemeral_range_that_nodes_bind_to():
    low = rosrun._ephemeral_low()
    for _ in range(20):
        port = rosrun.free_port()
        assert 1024 <= port < low
        with __import__("socket").socket() as s:
            s.bind(("127.0.0.1", port))  # free when handed out


def test_a_roscore_whose_port_a_node_took_starts_on_another(monkeypatch, tmp_path):
    # The first port handed out is held by what a ROS node serves on its port, an XML-RPC API
    # that answers getPid too (a node took the port between free_port() and roscore's bind): the
    # master is not taken for ours, and is started again on another port.
    import threading
    from xmlrpc.server import SimpleXMLRPCServer
    node_api = SimpleXMLRPCServer(("127.0.0.1", 0), logRequests=False)
    node_api.register_function(lambda caller_id: [1, "", os.getpid()], "getPid")
    threading.Thread(target=node_api.serve_forever, daemon=True).start()
    taken = node_api.server_address[1]
    ports = iter([taken])
    real = rosrun.free_port
    monkeypatch.setattr(rosrun, "free_port", lambda: next(ports, None) or real())
    try:
        with rosrun.Roscore(str(tmp_path), timeout=10.0) as core:
            assert core.port != taken
            pid = core.master.getPid()
            assert pid != os.getpid()
    finally:
        node_api.shutdown()
        node_api.server_close()


LATE_SUBSCRIBER = r"""
import rospy
from sensor_msgs.msg import Range
rospy.init_node("late_subscriber", disable_signals=True)
rospy.Subscriber("/range", Range, lambda m: print("%.3f" % m.header.stamp.to_sec(), flush=True),
                 queue_size=100)
rospy.spin()
"""

PLAYER = r"""
import sys
from laserscan_toolbox.ros.rosrun import BagPlayer
player = BagPlayer(sys.argv[1], sys.argv[2]).start()
print("playing; not connected:", sorted(getattr(player, "unconnected", {})), flush=True)
player.proc.wait(timeout=60)
"""


def test_a_bag_plays_only_once_every_subscriber_is_connected(tmp_path):
    # A subscriber that the master lists but that connects late (stopped here for 3 s, as a node
    # on a loaded machine that has not run since the player advertised) still gets the bag's
    # first messages: rosbag's own fixed delay (-d 1) sent them to no one.
    import signal
    import time
    import rosbag
    import rospy
    from sensor_msgs.msg import Range
    bag = str(tmp_path / "ranges.bag")
    stamps = [100.0 + 0.1 * i for i in range(5)]
    with rosbag.Bag(bag, "w") as b:
        for s in stamps:
            m = Range()
            m.header.stamp, m.header.frame_id = rospy.Time.from_sec(s), "sonar"
            b.write("/range", m, t=m.header.stamp)
    scripts = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(rosrun.__file__))))
    with rosrun.Roscore(str(tmp_path / "ros"), sim_time=False) as core:
        env = dict(core.env, PYTHONPATH=scripts + os.pathsep + core.env.get("PYTHONPATH", ""))
        sub = subprocess.Popen([sys.executable, "-c", LATE_SUBSCRIBER], env=env,
                               stdout=subprocess.PIPE, text=True)
        try:
            deadline = time.time() + 30
            while not any(t == "/range" and "/late_subscriber" in n
                          for t, n in core.master.getSystemState()[1]):
                assert time.time() < deadline and sub.poll() is None, "the subscriber did not come up"
                time.sleep(0.05)
            os.kill(sub.pid, signal.SIGSTOP)
            player = subprocess.Popen([sys.executable, "-c", PLAYER, bag, str(tmp_path / "play.log")],
                                      env=env, stdout=subprocess.PIPE, text=True)
            time.sleep(3.0)
            waited = player.poll() is None  # still paused
            os.kill(sub.pid, signal.SIGCONT)
            out, _ = player.communicate(timeout=60)
            assert player.returncode == 0 and "not connected: []" in out, out
            time.sleep(1.0)
        finally:
            os.kill(sub.pid, signal.SIGCONT)
            sub.terminate()
            received, _ = sub.communicate(timeout=30)
    assert [float(x) for x in received.split()] == pytest.approx(stamps), received
    assert waited
