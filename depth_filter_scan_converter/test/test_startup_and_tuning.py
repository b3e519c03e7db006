"""The converter node / nodelet against its configuration, with a private roscore on a free port
(temporary ROS_HOME / ROS_LOG_DIR): the shipped YAML starts; a bad configuration stops the node
at start-up with the parameter's name and a non-zero exit, and makes the nodelet report FATAL
and do nothing; dynamic_reconfigure rejects min >= max and keeps the previous values; the
diagnostics report input rate, processing time, transform failures and malformed clouds."""
import json
import os
import signal
import subprocess
import sys
import time

import pytest

from laserscan_toolbox.ros.rosrun import OutputLines, rostopic_pub

PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHIPPED = os.path.join(PKG, "config", "depth_filter_scan_converter.yaml")


# The ROS master comes from conftest.py's ros_env (a private roscore for this module).


def load_params(env, ns, yaml_text=None, path=SHIPPED):
    subprocess.run(["rosparam", "delete", "/" + ns], env=env, capture_output=True)
    subprocess.run(["rosparam", "load", path, "/" + ns], env=env, check=True)
    if yaml_text:
        extra = os.path.join(env["ROS_HOME"], ns + ".yaml")
        with open(extra, "w") as f:
            f.write(yaml_text)
        subprocess.run(["rosparam", "load", extra, "/" + ns], env=env, check=True)


def start(env, name, nodelet=False, image=False):
    """The cloud converter, or with image=True the depth-image converter (same parameters)."""
    if nodelet:
        kind = "DepthImageScanConverterNodelet" if image else "DepthFilterScanConverterNodelet"
        cmd = ["rosrun", "nodelet", "nodelet", "standalone", "depth_filter_scan_converter/" + kind]
    else:
        node = "depth_image_scan_converter_node" if image else "depth_filter_scan_converter_node"
        cmd = ["rosrun", "depth_filter_scan_converter", node]
    return subprocess.Popen(cmd + ["__name:=" + name], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def stop(p, timeout=20):
    """Output of a process; SIGINT first if it still runs (roscpp shuts down cleanly)."""
    if p.poll() is None:
        p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=timeout)
    return out


def wait_advertised(env, node, topic, proc, timeout=30.0):
    """Waits until the master lists ``node`` as a publisher of ``topic`` (the node is up); False
    if the process ends first or ``timeout`` s pass."""
    import rosgraph
    master = rosgraph.Master("/test_startup_and_tuning", master_uri=env["ROS_MASTER_URI"])
    deadline = time.time() + timeout
    while proc.poll() is None and time.time() < deadline:
        if any(t == topic and node in nodes for t, nodes in master.getSystemState()[0]):
            return True
        time.sleep(0.05)
    return False


def wait_for_service(env, service, timeout=20):
    deadline = time.time() + timeout
    while time.time() < deadline:
        if service in subprocess.run(["rosservice", "list"], env=env, capture_output=True, text=True).stdout:
            return True
        time.sleep(0.3)
    return False


@pytest.mark.parametrize("image", [False, True])
def test_shipped_config_starts(ros_env, image):
    load_params(ros_env, "conv_ok")
    p = start(ros_env, "conv_ok", image=image)
    advertised = wait_advertised(ros_env, "/conv_ok", "/scan", p)
    assert p.poll() is None, stop(p)
    out = stop(p)
    assert advertised, out


@pytest.mark.parametrize(
    "yaml_text,parameter",
    [
        ("min_height: 1.5\nmax_height: 1.0", "min_height"),
        ("range_min: 12.0", "range_min"),
        ("angle_increment: 0.0", "angle_increment"),
        ("angle_min: 1.0\nangle_max: 0.5", "angle_min"),
        ("row_stride: 0", "row_stride"),
        ("range_max: far", "range_max"),
        ("use_inf: false\nrange_max: .inf", "range_max"),
        ("reference_frame: ''", "reference_frame"),
        ("hole_depth: -0.1", "hole_depth"),
        ("range_noise_std: -0.001", "range_noise_std"),
        ("range_noise_std_per_m2: .nan", "range_noise_std_per_m2"),
        ("queue_size: 0", "queue_size"),
        ("depth_image_rectified: 1.5", "depth_image_rectified"),
        ("too_close_at_range_min: maybe", "too_close_at_range_min"),
    ],
)
def test_bad_config_stops_the_node_naming_the_parameter(ros_env, yaml_text, parameter):
    load_params(ros_env, "conv_bad", yaml_text)
    p = start(ros_env, "conv_bad")
    try:
        out, _ = p.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        pytest.fail("node kept running with a bad configuration: " + stop(p))
    assert p.returncode != 0
    assert "FATAL" in out and "'%s'" % parameter in out, out


def test_bad_config_stops_the_depth_image_node_too(ros_env):
    load_params(ros_env, "image_bad", "min_height: 1.5\nmax_height: 1.0")
    p = start(ros_env, "image_bad", image=True)
    try:
        out, _ = p.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        pytest.fail("node kept running with a bad configuration: " + stop(p))
    assert p.returncode != 0
    assert "FATAL" in out and "'min_height'" in out, out


def test_bad_config_makes_the_nodelet_report_fatal_and_do_nothing(ros_env):
    load_params(ros_env, "conv_bad_nodelet", "min_height: 2.0\nmax_height: 1.0")
    nodelet = OutputLines(start(ros_env, "conv_bad_nodelet", nodelet=True))
    nodelet.wait_for("FATAL")  # nothing is advertised after it: onInit has ended
    topics = subprocess.run(["rostopic", "list"], env=ros_env, capture_output=True, text=True).stdout.split()
    out = nodelet.stop()
    assert "FATAL" in out and "'min_height'" in out, out
    assert "/conv_bad_nodelet/set_parameters" not in topics
    assert not any(t.endswith("/scan") and "conv_bad_nodelet" in t for t in topics)


RECONFIGURE = r"""
import json, sys
import rospy
import dynamic_reconfigure.client
rospy.init_node("reconfigure_client", anonymous=True)
client = dynamic_reconfigure.client.Client(sys.argv[1], timeout=20)
results = []
for change in json.loads(sys.argv[2]):
    cfg = client.update_configuration(change)
    results.append({k: cfg[k] for k in ("min_height", "max_height", "range_min", "range_max", "hole_depth")})
print(json.dumps(results))
"""


def test_dynamic_reconfigure_checks_min_below_max(ros_env):
    load_params(ros_env, "conv_tune")
    p = start(ros_env, "conv_tune")
    try:
        assert wait_for_service(ros_env, "/conv_tune/set_parameters"), "no dynamic_reconfigure service"
        changes = [
            {"max_height": 0.01},  # below min_height 0.05: rejected
            {"min_height": 0.2, "max_height": 0.8},  # fine
            {"range_min": 20.0},  # above range_max 10: rejected
            {"range_max": 5.0},  # fine
        ]
        r = subprocess.run(
            [sys.executable, "-c", RECONFIGURE, "/conv_tune", json.dumps(changes)],
            env=ros_env,
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert r.returncode == 0, r.stderr
        results = json.loads(r.stdout.strip().splitlines()[-1])
    finally:
        out = stop(p)
    assert results[0]["max_height"] == pytest.approx(1.0) and results[0]["min_height"] == pytest.approx(0.05)
    assert results[1]["min_height"] == pytest.approx(0.2) and results[1]["max_height"] == pytest.approx(0.8)
    assert results[2]["range_min"] == pytest.approx(0.0)
    assert results[3]["range_max"] == pytest.approx(5.0)
    assert "rejected a dynamic_reconfigure change" in out and "'min_height'" in out and "'range_min'" in out, out


def test_diagnostics_are_published(ros_env):
    load_params(ros_env, "conv_diag")
    p = start(ros_env, "conv_diag")
    try:
        r = subprocess.run(
            ["rostopic", "echo", "-n", "3", "/diagnostics"], env=ros_env, capture_output=True, text=True, timeout=30
        )
    finally:
        stop(p)
    assert "Input and processing" in r.stdout, r.stdout
    for key in ("input rate [Hz]", "processing time, mean [ms]", "transform failures", "malformed clouds dropped",
                "last malformed reason", "last transform failure"):
        assert key in r.stdout, key
    # The hardware id names this converter (one per camera), not the package.
    assert 'hardware_id: "/conv_diag"' in r.stdout, r.stdout


def test_diagnostics_go_on_while_a_simulated_clock_stands_still(ros_env):
    """use_sim_time with a clock that does not move (a bag not yet playing, paused or ended): the
    status still comes every second of wall time (diagnostic_updater's own period, in ROS time,
    would publish nothing)."""
    subprocess.run(["rosparam", "set", "/use_sim_time", "true"], env=ros_env, check=True)
    try:
        load_params(ros_env, "conv_clock")
        p = start(ros_env, "conv_clock")
        try:
            r = subprocess.run(["rostopic", "echo", "-n", "3", "/diagnostics"], env=ros_env, capture_output=True,
                               text=True, timeout=30)
        finally:
            stop(p)
    finally:
        subprocess.run(["rosparam", "delete", "/use_sim_time"], env=ros_env)
    assert r.stdout.count("conv_clock: Input and processing") == 3, r.stdout + r.stderr


def test_malformed_warnings_are_throttled_though_stamps_differ(ros_env):
    # The reason names each cloud's stamp; a stream of the same defect must still be warned about
    # once per 5 s, not once per cloud (it was, before the throttle ignored the numbers).
    load_params(ros_env, "conv_throttle")
    p = start(ros_env, "conv_throttle")
    listener = subprocess.Popen(["rostopic", "echo", "/scan"], env=ros_env, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
    feed = subprocess.Popen(["rostopic", "pub", "-s", "-r", "20", "/cloud_in", "sensor_msgs/PointCloud2",
                             "{header: {stamp: now, frame_id: ''}}"], env=ros_env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    node = OutputLines(p)
    try:
        # 20 more clouds after the first warning: unthrottled, each would be warned about
        node.wait_for("dropped a malformed cloud")
        time.sleep(1.0)
        alive = p.poll() is None
    finally:
        for q in (feed, listener):
            q.send_signal(signal.SIGINT)
            q.wait(timeout=20)
        out = node.stop()
    assert alive, out
    warnings = [line for line in out.splitlines() if "dropped a malformed cloud" in line]
    assert 1 <= len(warnings) <= 2 and "empty frame_id" in warnings[0], out


SELF_FILTER_CASES = [
    # (YAML of the self_filter block, the parameter the node names, or None: it starts)
    ("self_filter: {padding: -0.1}", "self_filter/padding"),
    ("self_filter: {paddding: 0.1}", "self_filter/paddding"),
    ("self_filter: {links: [arm]}", "self_filter/links"),
    ("self_filter: {shapes: [{type: box, size: [0.1, 0.1, 0.1]}]}", "self_filter/shapes[0]/frame"),
    ("self_filter: {shapes: [{frame: arm, type: cone, radius: 0.1}]}", "self_filter/shapes[0]/type"),
    ("self_filter: {shapes: [{frame: arm, type: box, size: [0.1, 0.1]}]}", "self_filter/shapes[0]/size"),
    ("self_filter: {shapes: [{frame: arm, type: sphere, radius: 0.1, length: 1.0}]}", "self_filter/shapes[0]/length"),
    ("self_filter: {shapes: [{frame: arm, type: cylinder, radius: 0.1}]}", "self_filter/shapes[0]/length"),
    ("self_filter: {shapes: [{frame: arm, type: box, size: [0.1, 0.1, 0.1], colour: red}]}",
     "self_filter/shapes[0]/colour"),
    ("self_filter: {shapes: [{frame: arm, type: cylinder, radius: 0.0, length: 1.0}]}", "self_filter/shapes[0]"),
    ("self_filter: {shapes: [{frame: arm, type: sphere, radius: 0.1, origin: [0, 0, 0]}]}",
     "self_filter/shapes[0]/origin"),
    ("self_filter: {shapes: [{frame: arm, type: sphere, radius: 0.1, padding: -1.0}]}", "self_filter/shapes[0]"),
    ("self_filter: {shapes: [{name: load, frame: tool0, type: box, size: [0.3, 0.2, 0.1], "
     "origin: [0, 0, 0.05, 0, 0, 0], padding: 0.03}, {frame: arm, type: cylinder, radius: 0.05, length: 0.4}]}", None),
]


@pytest.mark.parametrize("yaml_text,parameter", SELF_FILTER_CASES)
def test_self_filter_config_verdicts_of_node_and_check_config_agree(ros_env, yaml_text, parameter):
    """The converter node and scripts/check_config judge each self_filter block alike (the node
    names the parameter; the checker flags the same key)."""
    import yaml

    from laserscan_toolbox import config_check as cc

    problems = cc.check_converter(yaml.safe_load(yaml_text))
    load_params(ros_env, "conv_self", yaml_text)
    p = start(ros_env, "conv_self")
    if parameter is None:
        assert wait_advertised(ros_env, "/conv_self", "/scan", p), stop(p)
        out = stop(p)
        assert "self filter: 2 shapes on 2 frames" in out, out
        assert problems == []
        return
    try:
        out, _ = p.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        pytest.fail("node kept running with a bad self_filter: " + stop(p))
    assert p.returncode != 0
    assert "FATAL" in out and "'%s" % parameter in out, out
    flagged = parameter.replace("/", ".")
    assert any(problem.startswith(flagged) for problem in problems), (flagged, problems)


def test_self_filter_without_a_robot_description_stops_the_node(ros_env):
    load_params(ros_env, "conv_self_urdf", "self_filter: {use_robot_description: true}")
    p = start(ros_env, "conv_self_urdf")
    out, _ = p.communicate(timeout=20)
    assert p.returncode != 0
    assert "'robot_description': is empty or not set" in out, out


def test_a_clock_at_the_end_of_ros_time_does_not_end_the_node(ros_env):
    """diagnostic_updater schedules its next update at now() + 1 s: with a (simulated) clock within
    1 s of 2^32 s ros::Time throws, and out of the diagnostics timer that ended the process (a
    whole nodelet manager). The status is skipped with a warning instead."""
    subprocess.run(["rosparam", "set", "/use_sim_time", "true"], env=ros_env, check=True)
    try:
        load_params(ros_env, "conv_end")
        p = start(ros_env, "conv_end")
        node = OutputLines(p)
        # running first (the updater's constructor does the same arithmetic: a node started in
        # the last second of ROS time stops at once)
        assert wait_advertised(ros_env, "/conv_end", "/scan", p), node.stop()
        with rostopic_pub(ros_env, "/clock", "rosgraph_msgs/Clock", "{clock: {secs: 4294967295, nsecs: 500000000}}"):
            warned = node.wait_for("diagnostics not published", "out of dual 32-bit range")
        alive = p.poll() is None
        out = node.stop()
    finally:
        subprocess.run(["rosparam", "delete", "/use_sim_time"], env=ros_env)
    assert warned and alive and p.returncode == 0, out
