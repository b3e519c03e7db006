"""The configuration checker: every shipped YAML passes, each broken one fails on its key."""
import glob
import os
import re
import subprocess
import sys
import time

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
from laserscan_toolbox import config_check as cc
from laserscan_toolbox.ros.rosrun import Roscore, free_port, stop_process

CHECK = os.path.join(REPO, "scripts", "check_config")
SHIPPED = sorted(set(glob.glob(os.path.join(REPO, "config", "**", "*.yaml"), recursive=True)
                     + glob.glob(os.path.join(REPO, "*", "config", "*.yaml"))))
BROKEN = sorted(glob.glob(os.path.join(HERE, "data", "broken_configs", "*.yaml")))


def run(*args):
    p = subprocess.run([sys.executable, CHECK] + list(args), capture_output=True, text=True)
    return p.returncode, p.stdout + p.stderr


def expected_key(path):
    with open(path) as f:
        m = re.search(r"^# expect: (\S+)", f.read(), re.M)
    assert m, "%s lacks an '# expect: key.path' line" % path
    return m.group(1)


@pytest.mark.parametrize("path", SHIPPED, ids=[os.path.relpath(p, REPO) for p in SHIPPED])
def test_shipped_configs_pass(path):
    code, out = run(path)
    assert code == 0, out


def test_some_configs_are_shipped():
    # The packages ship example YAMLs; an empty glob would make the test above vacuous.
    assert SHIPPED, "no YAML found under config/ or */config/"


@pytest.mark.parametrize("path", BROKEN, ids=[os.path.basename(p) for p in BROKEN])
def test_broken_configs_fail_on_the_right_key(path):
    key = expected_key(path)
    code, out = run(path)
    assert code == 1, out
    lines = [l.strip() for l in out.splitlines() if l.startswith("  ")]
    assert any(l.startswith(key + ":") for l in lines), "want '%s: ...' in\n%s" % (key, out)


def test_missing_file_and_bad_usage_exit_2(tmp_path):
    assert run(str(tmp_path / "nope.yaml"))[0] == 2
    assert run("--kind", "toaster", str(tmp_path / "x.yaml"))[0] == 2
    assert run()[0] == 2


def test_defaults_alone_are_usable():
    assert cc.check_data({"reference_frame": "base_link"}) == []
    assert cc.check_data({"sources": [{"name": "a", "topic": "a/scan"}]}) == []


def test_wrapping_source_mask_is_allowed_but_pi_is_the_limit():
    ok = {"sources": [{"name": "rear", "topic": "r", "angle_min": 2.5, "angle_max": -2.5}]}
    assert cc.check_data(ok) == []
    bad = {"sources": [{"name": "rear", "topic": "r", "angle_min": 0.0, "angle_max": 3.5}]}
    assert [p.split(":")[0] for p in cc.check_data(bad)] == ["sources[0].angle_max"]
    # pi written with few digits is still pi
    assert cc.check_data({"reference_frame": "b", "angle_max": 3.1415927}) == []


def test_yaml_inf_is_accepted_for_no_limit():
    assert cc.check_data({"sources": [{"name": "a", "topic": "t", "range_max": float("inf")}],
                          "range_max": float("inf")}) == []


def test_kind_option_checks_an_ambiguous_file(tmp_path):
    f = tmp_path / "c.yaml"
    f.write_text("angle_increment: -0.1\n")
    code, out = run("--kind", "converter", str(f))
    assert code == 1 and "angle_increment:" in out
    code, out = run(str(f))
    assert code == 1 and "(file)" in out


def test_frames_against_a_tf_tree():
    tree = cc.TfTree([("odom", "base_link"), ("base_link", "front_laser")])
    frames = {"/front_scan": "front_laser", "/rear_scan": "rear_laser"}
    good = {"output_frame": "base_link", "sources": [{"name": "f", "topic": "front_scan"}]}
    assert cc.check_data(good, tf_tree=tree, topic_frames=frames) == []
    bad = {"output_frame": "base_footprint",
           "sources": [{"name": "f", "topic": "front_scan"}, {"name": "r", "topic": "rear_scan"},
                       {"name": "x", "topic": "missing_scan"}]}
    paths = [p.split(":")[0] for p in cc.check_data(bad, tf_tree=tree, topic_frames=frames)]
    assert "output_frame" in paths and "sources[2].topic" in paths
    tree.add("odom", "base_footprint")
    paths = [p.split(":")[0] for p in cc.check_data(bad, tf_tree=tree, topic_frames=frames)]
    assert paths == ["sources[1].topic", "sources[2].topic"]  # rear_laser not connected


def test_launch_fragment_aborts_roslaunch_on_a_bad_config(tmp_path):
    """roslaunch runs the check while parsing, before it starts a master or any node."""
    launch = os.path.join(REPO, "launch", "check_config.launch")
    bad = os.path.join(HERE, "data", "broken_configs", "converter_min_ge_max.yaml")
    env = dict(os.environ, ROS_HOME=str(tmp_path), ROS_LOG_DIR=str(tmp_path),
               ROS_MASTER_URI="http://127.0.0.1:%d" % free_port())
    p = subprocess.run(["roslaunch", launch, "config:=" + bad, "kind:=converter"],
                       capture_output=True, text=True, env=env, timeout=60)
    assert p.returncode != 0
    assert "max_height: must be greater than min_height" in p.stdout + p.stderr
    ok = tmp_path / "ok.yaml"
    ok.write_text("reference_frame: base_link\nmin_height: 0.1\n")
    p = subprocess.run(["roslaunch", "--dump-params", launch, "config:=%s" % ok],
                       capture_output=True, text=True, env=env, timeout=60)
    assert p.returncode == 0 and "/config_check/config" in p.stdout, p.stdout + p.stderr


DUAL_BAG = os.path.join(HERE, "data", "real", "dual_lidar_scans_demo.bag")
DUAL_MERGER = os.path.join(REPO, "config", "dual_lidar_demo", "merger.yaml")
# the bag's mounts (test/data/real/README.md); the bag itself has no tf
FRONT_MOUNT = "0.23565 -0.0005 0.06795 0 0 0 base_link front_scanner"
REAR_MOUNT = "-0.23832 0.00542 0.09888 3.141592 0 0 base_link rear_scanner"


def test_bag_without_tf_needs_the_mounts_and_takes_them_from_the_command_line():
    code, out = run(DUAL_MERGER, "--bag", DUAL_BAG)
    assert code == 1 and "--static-tf" in out, out  # says how to give the mounts
    code, out = run(DUAL_MERGER, "--bag", DUAL_BAG, "--static-tf", FRONT_MOUNT)
    assert code == 1, out
    assert "sources[1].topic: its frame 'rear_scanner' has no tf path" in out
    code, out = run(DUAL_MERGER, "--bag", DUAL_BAG, "--static-tf", FRONT_MOUNT,
                    "--static-tf", REAR_MOUNT)
    assert code == 0, out
    # the quaternion form of the same mount
    code, out = run(DUAL_MERGER, "--bag", DUAL_BAG, "--static-tf", FRONT_MOUNT,
                    "--static-tf", "-0.23832 0.00542 0.09888 0 0 1 0 base_link rear_scanner")
    assert code == 0, out


def test_bag_mounts_from_a_launch_file(tmp_path):
    code, out = run(DUAL_MERGER, "--bag", DUAL_BAG, "--tf-launch",
                    os.path.join(REPO, "launch", "dual_lidar_demo.launch"))
    assert code == 0, out
    # a launch with the old tf package's publisher (period argument) and only one mount
    launch = tmp_path / "mounts.launch"
    launch.write_text('<launch><node pkg="tf" type="static_transform_publisher" name="m" '
                      'args="%s 100"/></launch>' % FRONT_MOUNT)
    code, out = run(DUAL_MERGER, "--bag", DUAL_BAG, "--tf-launch", str(launch))
    assert code == 1 and "'rear_scanner' has no tf path" in out, out
    empty = tmp_path / "empty.launch"
    empty.write_text("<launch/>")
    code, out = run(DUAL_MERGER, "--bag", DUAL_BAG, "--tf-launch", str(empty))
    assert code == 2 and "no static_transform_publisher" in out, out
    # a launch naming a package that is not on ROS_PACKAGE_PATH (an unsourced workspace)
    unsourced = tmp_path / "unsourced.launch"
    unsourced.write_text('<launch><include file="$(find no_such_robot_pkg)/launch/x.launch"/></launch>')
    code, out = run(DUAL_MERGER, "--bag", DUAL_BAG, "--tf-launch", str(unsourced))
    assert code == 2 and "source the workspace" in out, out


@pytest.mark.parametrize("spec,reason", [
    ("0 0 0 0 0 base_link laser", "7 words given"),
    ("0 0 zero 0 0 0 base_link laser", "expected numbers"),
    ("0 0 0 0 0 nan base_link laser", "finite"),
    ("0 0 0 0 0 0 2 base_link laser", "not normalized"),
    ("0 0 0 0 0 0 laser laser", "two different frames")])
def test_malformed_mount_is_a_usage_error(spec, reason):
    code, out = run(DUAL_MERGER, "--bag", DUAL_BAG, "--static-tf", spec)
    assert code == 2 and reason in out, out


def test_mounts_alone_form_the_tree():
    code, out = run(DUAL_MERGER, "--static-tf", FRONT_MOUNT)
    assert code == 0, out
    code, out = run(DUAL_MERGER, "--static-tf", "0 0 0 0 0 0 odom base_footprint")
    assert code == 1 and "output_frame: frame 'base_link' is not in the tf tree" in out, out


@pytest.fixture
def master(tmp_path):
    """A private roscore (``Roscore``) with /use_sim_time true; yields the environment that
    reaches it and start(*cmd), which runs a process on it until the test ends."""
    procs = []

    def start(*cmd):
        procs.append(subprocess.Popen(list(cmd), env=core.env, stdout=subprocess.DEVNULL,
                                      stderr=subprocess.DEVNULL, start_new_session=True))
    with Roscore(str(tmp_path / "ros"), sim_time=True) as core:
        try:
            yield core.env, start
        finally:
            for p in reversed(procs):
                stop_process(p, timeout=15)


def test_live_with_sim_time_and_no_clock_times_out_with_advice(master, tmp_path):
    env, start = master
    footprint = tmp_path / "footprint.yaml"
    footprint.write_text("reference_frame: base_footprint\n")
    t0 = time.time()
    p = subprocess.run([sys.executable, CHECK, DUAL_MERGER, "--live", "--clock-timeout", "1"],
                       capture_output=True, text=True, env=env, timeout=60)
    assert p.returncode == 2, p.stdout + p.stderr
    assert "/use_sim_time is true but nothing published /clock" in p.stderr
    assert "rosbag play --clock" in p.stderr
    assert time.time() - t0 < 30
    # once a clock runs, the same check listens to tf and finds the frames
    start("rostopic", "pub", "-r", "20", "/clock", "rosgraph_msgs/Clock", "clock: {secs: 100}")
    start("rosrun", "tf2_ros", "static_transform_publisher", *FRONT_MOUNT.split())
    p = subprocess.run([sys.executable, CHECK, DUAL_MERGER, "--live", "--clock-timeout", "20"],
                       capture_output=True, text=True, env=env, timeout=90)
    assert p.returncode == 0, p.stdout + p.stderr
    p = subprocess.run([sys.executable, CHECK, "--live", "--clock-timeout", "20", "--kind",
                        "converter", str(footprint)],
                       capture_output=True, text=True, env=env, timeout=90)
    assert p.returncode == 1 and "'base_footprint' is not in the tf tree" in p.stdout, p.stdout


def test_live_without_master_says_so(tmp_path):
    env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:%d" % free_port())
    p = subprocess.run([sys.executable, CHECK, DUAL_MERGER, "--live"], capture_output=True,
                       text=True, env=env, timeout=60)
    assert p.returncode == 2 and "no ROS master" in p.stderr, p.stderr


def test_launch_fragment_is_included_the_usual_ways(tmp_path):
    """A user's launch file elsewhere (a path with a space), run from another directory,
    includes check_config.launch relative to itself ($(dirname)) and through $(find)."""
    ws = tmp_path / "my ws"
    (ws / "my_robot" / "launch").mkdir(parents=True)
    os.symlink(REPO, str(ws / "toolbox"))
    bad = os.path.join(HERE, "data", "broken_configs", "converter_min_ge_max.yaml")
    user = ws / "my_robot" / "launch" / "bringup.launch"
    user.write_text("""<launch>
  <arg name="config"/>
  <include file="$(dirname)/../../toolbox/launch/check_config.launch">
    <arg name="config" value="$(dirname)/../../toolbox/config/dual_lidar_demo/merger.yaml"/>
    <arg name="name" value="relative"/>
  </include>
  <include file="$(find multi_laserscan_merger)/../launch/check_config.launch">
    <arg name="config" value="$(arg config)"/> <arg name="name" value="found"/>
  </include>
</launch>
""")
    env = dict(os.environ, ROS_HOME=str(tmp_path), ROS_LOG_DIR=str(tmp_path),
               ROS_PACKAGE_PATH=REPO, ROS_MASTER_URI="http://127.0.0.1:%d" % free_port())
    p = subprocess.run(["roslaunch", "--dump-params", str(user), "config:=" + DUAL_MERGER],
                       capture_output=True, text=True, env=env, timeout=60, cwd="/")
    assert p.returncode == 0, p.stdout + p.stderr
    assert "/config_check/relative" in p.stdout and "/config_check/found" in p.stdout
    assert p.stderr.count("merger.yaml: ok") == 2, p.stderr
    # roslaunch runs the check while parsing, before it starts a master or any node
    p = subprocess.run(["roslaunch", str(user), "config:=" + bad],
                       capture_output=True, text=True, env=env, timeout=60, cwd="/")
    assert p.returncode != 0
    assert "max_height: must be greater than min_height" in p.stdout + p.stderr

