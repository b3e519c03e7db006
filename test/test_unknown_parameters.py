"""Every node reads its private parameters by one strict reader (laserscan_common/parameter_reader.hpp).

A private parameter that no node reads (a typo) is named once at start-up, with the closest
known name, and the node goes on; an unknown key inside a merger source is an error naming it.
One rule for numbers: an int parameter takes 2.0 (as 2) but refuses 2.5, at the converter's top
level as in the merger's. Each node runs against a private roscore (rosrun.Master).
"""
import os
import signal
import subprocess
import time

import pytest

from laserscan_toolbox.ros.rosrun import Master

SOURCES = [{"name": "front", "topic": "front/scan"}]
NODES = {  # kind: (package, executable, output topic, parameters the node needs)
    "converter": ("depth_filter_scan_converter", "depth_filter_scan_converter_node", "scan", {}),
    "range": ("depth_filter_scan_converter", "range_scan_converter_node", "scan", {}),
    "merger": ("multi_laserscan_merger", "multi_laserscan_merger_node", "merged_scan",
               {"sources": SOURCES, "odom_topic": ""}),
    "navigator": ("reactive_navigator", "reactive_navigator_node", "cmd_vel", {"scan_topics": ["scan"]}),
}
KNOWN = {"converter": {"self_filter": {"padding": 0.05}}, "range": {"queue_size": 5},
         "merger": {"self_filter": {"padding": 0.05}}, "navigator": {"height_band": [0.05, 0.9]}}


@pytest.fixture(scope="module")
def master(tmp_path_factory):
    os.environ["ROSCONSOLE_FORMAT"] = "[${severity}] ${message}"
    os.environ["ROSCONSOLE_STDOUT_LINE_BUFFERED"] = "1"
    with Master(str(tmp_path_factory.mktemp("unknown_parameters")), sim_time=False) as m:
        yield m


def run(master, kind, name, params, timeout=30.0):
    """(exit status or None while it ran, output) of the node until it advertises its output
    (its start-up done) or exits."""
    package, executable, topic, needed = NODES[kind]
    for key, value in dict(needed, **params).items():
        master.master.setParam("/%s/%s" % (name, key), value)
    p = subprocess.Popen(["rosrun", package, executable, "__name:=" + name], stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True)
    deadline = time.time() + timeout
    while p.poll() is None and time.time() < deadline:
        publishers = master.master.getSystemState()[0]
        if any(t == "/" + topic and "/" + name in nodes for t, nodes in publishers):
            break
        time.sleep(0.1)
    status = p.poll()
    if status is None:
        p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=20)
    return status, out


@pytest.mark.parametrize("kind,typo,meant,good", [
    ("converter", "min_hieght", "min_height", {"row_stride": 2.0}),
    ("range", "arc_widht", "arc_width", {"min_consecutive_readings": 3.0}),
    ("merger", "publish_rte", "publish_rate", {"odom_queue_size": 100.0}),
    ("navigator", "goal_tolerence", "goal_tolerance", {"path_count": 4.0}),
])
def test_unknown_parameter_is_named_once_with_the_closest_known_name(master, kind, typo, meant, good):
    name = "%s_typo" % kind
    status, out = run(master, kind, name, dict(good, **{typo: 0.5, "my_block": {"a": 1}}))
    assert status is None, out  # it started: a whole number written 2.0 is an int
    assert out.count("unknown parameter") == 2, out
    assert out.count("[/%s] unknown parameter '%s' (did you mean '%s'?), ignored" % (name, typo, meant)) == 1, out
    assert out.count("[/%s] unknown parameter 'my_block', ignored" % name) == 1, out


@pytest.mark.parametrize("kind", sorted(NODES))
def test_known_parameters_give_no_warning(master, kind):
    status, out = run(master, kind, "%s_clean" % kind, KNOWN[kind])
    assert status is None and "unknown parameter" not in out, out


@pytest.mark.parametrize("kind,params,parameter,reason", [
    ("converter", {"row_stride": 2.5}, "row_stride", "must be a whole number"),
    ("merger", {"odom_queue_size": 100.5}, "odom_queue_size", "must be a whole number"),
    ("navigator", {"path_count": 2.5}, "path_count", "must be a whole number"),
    ("merger", {"sources": [dict(SOURCES[0], timout=1.0)]}, "sources[0].timout",
     "unknown key (did you mean 'timeout'?)"),
])
def test_a_fraction_for_an_int_and_an_unknown_source_key_stop_the_node(master, kind, params, parameter, reason):
    name = "%s_bad_%s" % (kind, parameter.replace("[", "_").replace("]", "_").replace(".", "_"))
    status, out = run(master, kind, name, params)
    assert status == 1, out
    assert "parameter '%s': %s" % (parameter, reason) in out, out
