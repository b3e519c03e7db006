#!/usr/bin/python3
"""CPU per cloud of the converter node against a per-point node (pointcloud_to_laserscan's
algorithm, re-implemented: bench/per_point_reference_node.cpp), both above the same transport
baseline (a node that receives each cloud and publishes one empty 1441-beam scan), issue 9 part 3.

A fourth node, the converter reading one point per cloud (row and column strides beyond the
cloud), shows what its glue (tf filter, tf, scan, diagnostics, threads) costs in CPU time.

Each run starts one standalone node (shipped parameters, the same YAML for all) on its own
roscore, then measure_node_cost.py's feeder publishes N organized 320 x 163 clouds (52,160
points of 16 bytes) at 10 Hz over TCP; the node's CPU (all its threads, in ns: the toolbox's
ros/cpu_accounting.py) from the first cloud until a second after the last is divided by the
clouds sent. The nodes take turns, `--repeat` rounds; the medians are reported.

pointcloud_to_laserscan is not packaged in Debian 12 and is not built here: the per-point node
is a faithful stand-in for its per-cloud work (tf filter, the whole cloud transformed with
tf2_sensor_msgs, then hypot and atan2 per point), so the ratio is an estimate, not a
measurement of that node.

Run after sourcing the build's devel/setup.bash (the reference node is built with the tests):

    /usr/bin/python3 depth_filter_scan_converter/bench/measure_node_cpu.py [--clouds 100] [--repeat 3]
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
PKG = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(os.path.dirname(PKG), "scripts"))
from laserscan_toolbox.ros.cpu_accounting import process_cpu_s  # noqa: E402
from measure_node_cost import FEED, node_binary, start_master  # noqa: E402

# name -> (executable, extra private parameters)
NODES = {
    "transport": ("per_point_reference_node", ["_mode:=transport"]),
    "converter_glue": ("depth_filter_scan_converter_node", ["_row_stride:=1000000", "_column_stride:=1000000"]),
    "converter": ("depth_filter_scan_converter_node", []),
    "per_point": ("per_point_reference_node", ["_mode:=per_point"]),
}
LABELS = {
    "transport": "transport baseline: receive the cloud, publish an empty 1441-beam scan",
    "converter_glue": "depth_filter_scan_converter_node reading one point per cloud (its glue)",
    "converter": "depth_filter_scan_converter_node",
    "per_point": "per-point node (pointcloud_to_laserscan's algorithm, re-implemented)",
}


def run_once(kind, clouds, tmp):
    """CPU seconds of one node of `kind` over `clouds` clouds, and the scans it sent back."""
    env, core = start_master(tmp)
    node = feed = None
    try:
        executable, params = NODES[kind]
        node = subprocess.Popen([node_binary(env, executable), "__name:=conv"] + params, env=env, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        flag = os.path.join(tmp, "go_%s" % kind)
        feed = subprocess.Popen([sys.executable, "-c", FEED, str(clouds), flag], env=env, stdout=subprocess.PIPE,
                                text=True)
        if feed.stdout.readline().strip() != "ready":
            raise RuntimeError("the feeder did not connect to the %s node" % kind)
        before = process_cpu_s(node.pid)
        open(flag, "w").close()
        scans = int(feed.stdout.readline().split()[1])
        cpu = process_cpu_s(node.pid) - before
        os.remove(flag)
        return cpu, scans
    finally:
        for p in (feed, node, core):
            if p is not None and p.poll() is None:
                p.send_signal(2)
                p.wait(timeout=60)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--clouds", type=int, default=100)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    if args.clouds < 1 or args.repeat < 1:
        print("measure_node_cpu: --clouds and --repeat must be >= 1", file=sys.stderr)
        return 2
    tmp = tempfile.mkdtemp(prefix="node_cpu_")
    ms = {kind: [] for kind in NODES}
    scans = {kind: 0 for kind in NODES}
    for r in range(args.repeat):
        for kind in NODES:
            cpu, n = run_once(kind, args.clouds, tmp)
            ms[kind].append(1000.0 * cpu / args.clouds)
            scans[kind] += n
            print("round %d, %s: %d scans of %d clouds, %.3f ms of CPU per cloud"
                  % (r + 1, kind, n, args.clouds, ms[kind][-1]), file=sys.stderr)
    med = {kind: statistics.median(v) for kind, v in ms.items()}
    above = {kind: med[kind] - med["transport"] for kind in NODES}
    print("CPU per 52,160-point cloud over TCP at 10 Hz, median of %d rounds of %d clouds:" % (args.repeat, args.clouds))
    print()
    print("| node | CPU per cloud [ms] | above transport [ms] | scans / clouds |")
    print("|---|---|---|---|")
    for kind in NODES:
        print("| %s | %.3f | %s | %d / %d |" % (LABELS[kind], med[kind], "" if kind == "transport" else
                                                "%.3f" % above[kind], scans[kind], args.clouds * args.repeat))
    ratio = above["per_point"] / above["converter"] if above["converter"] > 0 else float("nan")
    print()
    print("per-point node / converter node, above transport: %.1fx (in all: %.1fx)"
          % (ratio, med["per_point"] / med["converter"]))
    return 0 if all(scans[k] > 0 for k in NODES) else 3


if __name__ == "__main__":
    sys.exit(main())
