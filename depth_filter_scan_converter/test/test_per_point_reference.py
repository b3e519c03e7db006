"""bench/measure_node_cpu.py compares the converter node with a per-point node
(bench/per_point_reference_node.cpp, pointcloud_to_laserscan's algorithm re-implemented) above a
transport-only node. The comparison means something only if the per-point node does the same
job: on the same cloud and tf, its scan must hold the converter node's closest points (up to
the binning: it truncates the beam index, the converter rounds it); and the benchmark's
machinery must run (a short run, no timing asserted)."""
import json
import math
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
PKG = os.path.dirname(HERE)
# The benchmark scripts (bench/, a folder of scripts) come from pytest.ini's pythonpath.
from measure_node_cost import FEED, master, node_binary

# Prints the first scan of each node as JSON (None for no return), once both came.
LISTEN = r"""
import json, math, time, rospy
from sensor_msgs.msg import LaserScan
rospy.init_node('per_point_check')
scans = {}
subs = [rospy.Subscriber(n, LaserScan, lambda s, n=n: scans.setdefault(n, list(s.ranges)), queue_size=5)
        for n in ('/scan_converter', '/scan_per_point')]
deadline = time.time() + 60
while len(scans) < 2 and time.time() < deadline:
    time.sleep(0.1)
print(json.dumps({k: [r if math.isfinite(r) else None for r in v] for k, v in scans.items()}), flush=True)
"""


def test_per_point_node_finds_the_converters_closest_points():
    tmp = tempfile.mkdtemp(prefix="per_point_test_")
    with master(tmp, ("conv", "ref")) as env:
        procs = []
        try:
            for exe, args in (("depth_filter_scan_converter_node", ["__name:=conv", "scan:=/scan_converter"]),
                              ("per_point_reference_node",
                               ["__name:=ref", "scan:=/scan_per_point", "_mode:=per_point"])):
                procs.append(subprocess.Popen([node_binary(env, exe)] + args, env=env, stdout=subprocess.DEVNULL,
                                              stderr=subprocess.DEVNULL))
            listen = subprocess.Popen([sys.executable, "-c", LISTEN], env=env, stdout=subprocess.PIPE, text=True)
            procs.append(listen)
            # measure_node_cost's feeder: a static tf and organized clouds of a camera looking forward.
            flag = os.path.join(tmp, "go")
            open(flag, "w").close()
            procs.append(subprocess.Popen(
                [sys.executable, "-c", FEED, "5", flag, "10", "/scan_converter,/scan_per_point"], env=env,
                stdout=subprocess.DEVNULL))
            out, _ = listen.communicate(timeout=120)
            scans = json.loads(out.strip().splitlines()[-1])
        finally:
            for p in reversed(procs):
                if p.poll() is None:
                    p.send_signal(2)
                    p.wait(timeout=30)
    inf = math.inf
    conv = [inf if r is None else r for r in scans["/scan_converter"]]
    ref = [inf if r is None else r for r in scans["/scan_per_point"]]
    assert len(conv) == len(ref) == 1441
    hits = [b for b in range(1441) if ref[b] < inf]
    assert len(hits) > 100  # the feeder's camera sees about 60 degrees, 0.25 degree per beam
    # Beam b of the per-point node takes angles [b, b+1) increments, the converter's [b-0.5, b+0.5):
    # each one's closest point is among the other's two neighbouring beams.
    tol = 1e-3
    for b in range(1441):
        assert min(conv[b], conv[min(b + 1, 1440)]) <= ref[b] + tol, b
        assert min(ref[max(b - 1, 0)], ref[b]) <= conv[b] + tol, b


def test_measure_node_cpu_runs():
    out = subprocess.run([sys.executable, os.path.join(PKG, "bench", "measure_node_cpu.py"), "--clouds", "3",
                          "--repeat", "1"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    for row in ("transport baseline", "depth_filter_scan_converter_node", "per-point node", "the same, glibc keeping"):
        assert "| %s" % row in out.stdout
    for reference in ("per-point node", "per-point node keeping memory"):
        for view in ("whole node", "whole node without idle", "work thread"):
            assert "%s / converter node, above transport, %s:" % (reference, view) in out.stdout
    # Every node took every cloud; each row ends with its page faults per cloud and scans / clouds.
    rows = [line.split("|") for line in out.stdout.splitlines() if line.startswith("| ") and "/ 3 |" in line]
    assert len(rows) == 5, out.stdout
    assert all(row[-2].strip() == "3 / 3" and row[-3].strip().isdigit() for row in rows), out.stdout


def test_ratio_text_gives_the_worst_case_beside_the_ratio_of_medians():
    from measure_node_cpu import ratio_text
    text = ratio_text([2.0, 1.9, 2.1], [0.05, 0.1, 0.2])
    assert text.endswith(": 20.0x, at worst 10.0x"), text
    assert "reference 2.000 ms (rounds 1.900..2.100), converter 0.100 ms (rounds 0.050..0.200)" in text
    # A converter whose median is at or below transport: no ratio of medians, only the worst case.
    assert ratio_text([1.0, 1.0, 1.0], [-0.02, 0.0, 0.05]).endswith(
        ": at worst 20.0x (the converter's median is at or below transport)")
    assert ratio_text([1.0, 1.0], [-0.1, -0.05]).endswith(": the converter cost no more than transport in any round")
