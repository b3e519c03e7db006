"""The configuration checker: every shipped YAML passes, each broken one fails on its key."""
import glob
import os
import re
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(REPO, "scripts"))
from laserscan_toolbox import config_check as cc  # noqa: E402

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


def free_port():
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]
