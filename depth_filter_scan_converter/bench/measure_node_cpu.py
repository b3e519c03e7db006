#!/usr/bin/python3
"""CPU per cloud of the converter node against a per-point node (pointcloud_to_laserscan's work
and structure, re-implemented: bench/per_point_reference_node.cpp), both above the same transport
baseline (a node that receives each cloud and publishes one empty 1441-beam scan), issue 9 part 3.

Another node, the converter reading one point per cloud (row and column strides beyond the
cloud), shows what its glue (tf filter, tf, scan, diagnostics, threads) costs in CPU time.

All five nodes run at once on one roscore (shipped parameters, the same YAML for all), each
subscribed to the same clouds and publishing its own scan topic; measure_node_cost.py's feeder
publishes N organized 320 x 163 clouds (52,160 points of 16 bytes) at 10 Hz over TCP. Each node's
CPU (all its threads, in ns: the toolbox's ros/cpu_accounting.py) from the first cloud until a
second after the last is divided by the clouds sent. Because the nodes take the same clouds in
the same seconds, whatever else the machine does slows them alike: each node's cost above
transport is taken per round, `--repeat` rounds (fresh processes each), and the median and range
are reported, with the ratio of the medians and, at worst, the per-point node's median over the
converter's highest round.

The whole node's CPU includes roscpp's network thread reading the 834 kB cloud from its socket,
in however many reads the data happens to arrive: that alone moves the transport baseline by
about 0.1 ms per cloud from round to round. The work that tells the nodes apart runs in one work
thread: taking the cloud out of roscpp's receive buffer, the tf filter, the conversion and
publishing. That is the main thread of the plain nodes, and a nodelet worker thread of the
per-point node, which like pointcloud_to_laserscan_node loads its nodelet in-process (its busiest
thread other than the main one). Its CPU, read per thread from /proc/<pid>/task/<tid>/schedstat,
is the second, steadier figure. The transport baseline and the per-point node deserialise each
cloud with roscpp (which zero-fills the byte vector, then copies into it); the converter node
converts each cloud straight from the receive buffer (its transform is there in time), so its
cost above transport can be close to zero or below.

pointcloud_to_laserscan is not packaged in Debian 12 and is not built here: the per-point node
is a stand-in that pays its per-cloud costs (nodelet hand-over, tf filter, the whole cloud
transformed with tf2_sensor_msgs into a new cloud, then hypot, atan2 and a debug log check per
point), so the ratio is an estimate, not a measurement of that node.

Its cost depends on the C library: after each cloud glibc may return the two freed cloud-sized
buffers (the received and the transformed cloud) to the kernel, and the next cloud then faults
in and zeroes about 400 fresh pages (2 x 834 kB). The per-point node runs twice: with glibc's
defaults (as that node would run) and with glibc told to keep freed memory (GLIBC_TUNABLES), its
best case. The page faults per cloud (per round on stderr) show which happened.

Run after sourcing the build's devel/setup.bash (the reference node is built with the tests):

    /usr/bin/python3 depth_filter_scan_converter/bench/measure_node_cpu.py [--clouds 100] [--repeat 3]
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

import psutil

HERE = os.path.dirname(os.path.abspath(__file__))
from laserscan_toolbox.ros.cpu_accounting import process_cpu_s, thread_cpu_s
from measure_node_cost import FEED, master, node_binary

# name -> (executable, extra private parameters)
NODES = {
    "transport": ("per_point_reference_node", ["_mode:=transport"]),
    "converter_glue": ("depth_filter_scan_converter_node", ["_row_stride:=1000000", "_column_stride:=1000000"]),
    "converter": ("depth_filter_scan_converter_node", []),
    "per_point": ("per_point_reference_node", ["_mode:=per_point"]),
    "per_point_kept": ("per_point_reference_node", ["_mode:=per_point"]),
}
# Nodes whose clouds are converted on a nodelet worker thread, not in the main thread.
IN_LOADER = ("per_point", "per_point_kept")
# The per-point node's best case: glibc never returns freed memory to the kernel (no trimming, no
# mmap for large blocks), so the buffers of one cloud serve the next.
KEEP_FREED_MEMORY = "glibc.malloc.trim_threshold=4294967295:glibc.malloc.mmap_threshold=33554432"
ENV = {"per_point_kept": {"GLIBC_TUNABLES": KEEP_FREED_MEMORY}}
LABELS = {
    "transport": "transport baseline: receive the cloud, publish an empty 1441-beam scan",
    "converter_glue": "depth_filter_scan_converter_node reading one point per cloud (its glue)",
    "converter": "depth_filter_scan_converter_node",
    "per_point": "per-point node (pointcloud_to_laserscan's work and structure, re-implemented)",
    "per_point_kept": "the same, glibc keeping freed memory (its best case)",
}


IDLE_S = 3.0  # s of no cloud before the feed, for each node's idle CPU
RATE_HZ = 10


def minor_faults(pid):
    """Minor page faults of the process so far (/proc/<pid>/stat field 10): here mostly fresh
    anonymous pages, which the kernel zeroes first."""
    with open("/proc/%d/stat" % pid) as f:
        return int(f.read().rsplit(")", 1)[1].split()[7])


def thread_cpus(pid):
    """{thread id: CPU seconds} of the process's threads (one that ends meanwhile is left out)."""
    out = {}
    for tid in os.listdir("/proc/%d/task" % pid):
        try:
            out[int(tid)] = thread_cpu_s(pid, int(tid))
        except psutil.NoSuchProcess:
            pass
    return out


def read_cpu(nodes):
    """{kind: (CPU seconds of the whole node, {thread id: CPU seconds of that thread}, minor page
    faults)}."""
    return {kind: (process_cpu_s(p.pid), thread_cpus(p.pid), minor_faults(p.pid)) for kind, p in nodes.items()}


def work_thread_cpu_s(kind, pid, before, after):
    """CPU seconds between two reads of the node's thread that takes each cloud from roscpp's queue
    and converts it: the main thread of a plain node; in a nodelet loader the busiest other
    thread."""
    if kind not in IN_LOADER:
        return after[pid] - before[pid]
    return max(after[tid] - before[tid] for tid in after if tid in before and tid != pid)


def run_round(clouds, tmp):
    """Per node of NODES fed the same `clouds` clouds: (CPU seconds of the whole node, of its work
    thread, idle CPU seconds per second, minor page faults); the scans each sent; the window's length
    in seconds."""
    with master(tmp, node_names=tuple(NODES)) as env:
        nodes, feed = {}, None
        try:
            for kind, (executable, params) in NODES.items():
                nodes[kind] = subprocess.Popen(
                    [node_binary(env, executable), "__name:=%s" % kind, "scan:=/scan_%s" % kind] + params,
                    env=dict(env, **ENV.get(kind, {})), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            flag = os.path.join(tmp, "go")
            feed = subprocess.Popen([sys.executable, "-c", FEED, str(clouds), flag, str(RATE_HZ),
                                     ",".join("/scan_%s" % kind for kind in NODES)], env=env, stdout=subprocess.PIPE,
                                    text=True)
            if feed.stdout.readline().strip() != "ready":
                raise RuntimeError("the feeder did not connect to the nodes")
            quiet = read_cpu(nodes)
            time.sleep(IDLE_S)  # connected, no cloud yet: what each node spends anyway
            before = read_cpu(nodes)
            start = time.monotonic()
            open(flag, "w").close()
            scans = [int(n) for n in feed.stdout.readline().split()[1:]]
            after = read_cpu(nodes)
            window = time.monotonic() - start
            os.remove(flag)
            # per node: CPU seconds in the window (whole node, work thread), idle CPU seconds per second,
            # page faults in the window
            cpu = {kind: (after[kind][0] - before[kind][0],
                          work_thread_cpu_s(kind, nodes[kind].pid, before[kind][1], after[kind][1]),
                          (before[kind][0] - quiet[kind][0]) / IDLE_S, after[kind][2] - before[kind][2])
                   for kind in NODES}
            return cpu, dict(zip(NODES, scans)), window
        finally:
            for p in [feed] + list(nodes.values()):
                if p is not None and p.poll() is None:
                    p.send_signal(2)
                    p.wait(timeout=60)


def ratio_text(reference, converter):
    """The reference node's CPU per cloud above transport against the converter's, from the rounds'
    figures: the ratio of the medians and, at worst, the reference's median over the converter's
    highest round. The converter's own cost above transport is close to the rounds' noise (the
    transport baseline alone moves by about 0.1 ms from round to round), so a ratio of medians alone
    could say far more than the data does."""
    ref, conv = statistics.median(reference), statistics.median(converter)
    text = "reference %.3f ms (rounds %.3f..%.3f), converter %.3f ms (rounds %.3f..%.3f)" % (
        ref, min(reference), max(reference), conv, min(converter), max(converter))
    if ref <= 0:
        return text + ": the reference cost no more than transport (no ratio)"
    if max(converter) <= 0:
        return text + ": the converter cost no more than transport in any round"
    if conv <= 0:
        return text + ": at worst %.1fx (the converter's median is at or below transport)" % (ref / max(converter))
    return text + ": %.1fx, at worst %.1fx" % (ref / conv, ref / max(converter))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--clouds", type=int, default=100)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    if args.clouds < 1 or args.repeat < 1:
        print("measure_node_cpu: --clouds and --repeat must be >= 1", file=sys.stderr)
        return 2
    tmp = tempfile.mkdtemp(prefix="node_cpu_")
    # ms[view][kind]: per round, CPU per cloud: 0 the whole node, 1 its work thread, 2 the whole node
    # without its idle CPU (what it spends per second with no cloud: tf polling, timers)
    ms = tuple({kind: [] for kind in NODES} for _ in range(3))
    idle = {kind: [] for kind in NODES}
    faults = {kind: [] for kind in NODES}
    scans = {kind: 0 for kind in NODES}
    for r in range(args.repeat):
        cpu, sent, window = run_round(args.clouds, tmp)
        for kind in NODES:
            node, work, idle_per_s, window_faults = cpu[kind]
            faults[kind].append(window_faults / args.clouds)
            ms[0][kind].append(1000.0 * node / args.clouds)
            ms[1][kind].append(1000.0 * work / args.clouds)
            ms[2][kind].append(1000.0 * (node - idle_per_s * window) / args.clouds)
            idle[kind].append(1000.0 * idle_per_s)
            scans[kind] += sent[kind]
        figures = ["%s %.3f / %.3f / %.3f, %.0f" % (k, ms[0][k][-1], ms[2][k][-1], ms[1][k][-1], faults[k][-1])
                   for k in NODES]
        print("round %d, CPU per cloud [ms], node / without idle / work thread, page faults per cloud: %s"
              % (r + 1, ", ".join(figures)), file=sys.stderr)

    def above(view, kind):  # per round, both from the same round
        return [a - t for a, t in zip(ms[view][kind], ms[view]["transport"])]

    def cell(view, kind, relative):
        if relative and kind == "transport":
            return ""
        return "%.3f" % statistics.median(above(view, kind) if relative else ms[view][kind])

    print("CPU per 52,160-point cloud over TCP at %d Hz, all nodes fed the same clouds at once, median of %d "
          "rounds of %d clouds:" % (RATE_HZ, args.repeat, args.clouds))
    print()
    print("| node | whole node [ms/cloud] | idle [ms/s] | without idle [ms/cloud] | above transport [ms] "
          "| work thread [ms/cloud] | above transport [ms] | page faults / cloud | scans / clouds |")
    print("|---|---|---|---|---|---|---|---|---|")
    for kind in NODES:
        print("| %s | %s | %.2f | %s | %s | %s | %s | %.0f | %d / %d |" % (
            LABELS[kind], cell(0, kind, False), statistics.median(idle[kind]), cell(2, kind, False),
            cell(2, kind, True), cell(1, kind, False), cell(1, kind, True), statistics.median(faults[kind]),
            scans[kind], args.clouds * args.repeat))
    print()
    for reference, name in (("per_point", "per-point node"), ("per_point_kept", "per-point node keeping memory")):
        for view, what in ((0, "whole node"), (2, "whole node without idle"), (1, "work thread")):
            print("%s / converter node, above transport, %s: %s" % (name, what, ratio_text(above(view, reference),
                                                                                         above(view, "converter"))))
    return 0 if all(scans[k] > 0 for k in NODES) else 3

if __name__ == "__main__":
    sys.exit(main())
