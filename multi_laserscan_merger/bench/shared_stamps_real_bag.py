"""sync_window before/after on a real recording (issue 18): /front_scan of
test/data/real/dual_lidar_scans_demo.bag cut into three sectors, published as three sources with
the scan's own stamp (each frame's three within 0-4 ms of bag time, in a random order), played
in real time with `rosbag play` through the standalone merger node on its own roscore.

For every merged output at a frame's stamp it compares the output with the ideal one (the core
merging that frame's three sectors): returns of the frame missing, returns that are not the
frame's (an older frame's). Also prints the spread with which a subscriber beside the merger
received each frame's three scans. Needs the workspace built and devel/setup.bash sourced; each
window runs in its own process (rospy initialises once per process)."""
import argparse
import os
import random
import subprocess
import sys
import tempfile
import time

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
BAG = os.path.join(REPO, "test", "data", "real", "dual_lidar_scans_demo.bag")
MOUNT = (0.23565, -0.0005, 0.06795)  # base_link -> front_scanner (test/data/real/README.md)
SOURCES = [{"name": "sector_%d" % k, "topic": "/sector_%d/scan" % k} for k in range(3)]


def write_sector_bag(out):
    """The sector bag; returns {(secs, nsecs): [three sector scans]}."""
    import rosbag
    import rospy
    from sensor_msgs.msg import LaserScan
    rng = random.Random(18)
    frames = {}
    with rosbag.Bag(BAG) as b, rosbag.Bag(out, "w") as o:
        for _, m, t in b.read_messages(topics=["/front_scan"]):
            n = len(m.ranges)
            cut = [0, n // 3, 2 * n // 3, n]
            sectors = []
            for k in range(3):
                s = LaserScan(header=m.header, angle_increment=m.angle_increment, time_increment=m.time_increment,
                              scan_time=m.scan_time, range_min=m.range_min, range_max=m.range_max)
                s.angle_min = m.angle_min + cut[k] * m.angle_increment
                s.angle_max = s.angle_min + (cut[k + 1] - cut[k] - 1) * m.angle_increment
                s.ranges = m.ranges[cut[k]:cut[k + 1]]
                sectors.append(s)
            order = [0, 1, 2]
            rng.shuffle(order)
            for k, d in zip(order, [0.0] + sorted(rng.uniform(0, 0.004) for _ in range(2))):
                o.write(SOURCES[k]["topic"], sectors[k], t + rospy.Duration(d))
            frames[(m.header.stamp.secs, m.header.stamp.nsecs)] = sectors
    return frames


def ideal(merger, sectors, t):
    transform = np.eye(4)
    transform[:3, 3] = MOUNT
    scans = [{"stamp": t, "angle_min": s.angle_min, "angle_max": s.angle_max, "angle_increment": s.angle_increment,
              "time_increment": s.time_increment, "range_min": s.range_min, "range_max": s.range_max,
              "ranges": np.array(s.ranges, np.float32), "transform": transform} for s in sectors]
    return np.array(merger.merge(scans, t, None)["ranges"], float)


def run(window, workdir):
    import rospy
    from sensor_msgs.msg import LaserScan
    import multi_laserscan_merger_core as core
    from laserscan_toolbox.ros.rosrun import Master, stop_process
    frames = write_sector_bag(os.path.join(workdir, "sectors.bag"))
    got, arrivals = [], {}
    with Master(os.path.join(workdir, "ros"), sim_time=False):
        rospy.init_node("shared_stamps_real_bag", disable_signals=True)
        rospy.Subscriber("/merged_scan", LaserScan, got.append, queue_size=1000)

        def on_sector(m):
            arrivals.setdefault((m.header.stamp.secs, m.header.stamp.nsecs), []).append(time.monotonic())
        for s in SOURCES:
            rospy.Subscriber(s["topic"], LaserScan, on_sector, queue_size=100)
        yaml = os.path.join(workdir, "merger.yaml")
        with open(yaml, "w") as f:
            f.write("odom_topic: ''\nsync_window: %r\nsources:\n" % window)
            for s in SOURCES:
                f.write("  - {name: %s, topic: %s}\n" % (s["name"], s["topic"]))
        subprocess.check_call(["rosparam", "load", yaml, "/merger"])
        procs = [subprocess.Popen(["rosrun", "tf2_ros", "static_transform_publisher"] + [str(v) for v in MOUNT]
                                  + ["0", "0", "0", "base_link", "front_scanner"], start_new_session=True,
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL),
                 subprocess.Popen(["rosrun", "multi_laserscan_merger", "multi_laserscan_merger_node", "__name:=merger"],
                                  start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
        deadline = time.monotonic() + 30.0  # the node subscribed: the sector topics have two subscribers
        master = rospy.get_master()
        while time.monotonic() < deadline:
            subs = dict((t, n) for t, n in master.getSystemState()[2][1])
            if all(len(subs.get(s["topic"], [])) >= 2 for s in SOURCES):
                break
            time.sleep(0.1)
        subprocess.check_call(["rosbag", "play", "-q", os.path.join(workdir, "sectors.bag")],
                              stdout=subprocess.DEVNULL)
        time.sleep(1.0)  # the last outputs (no condition to wait on: the last frame may give none)
        for p in procs:
            stop_process(p)
    merger = core.Merger({}, SOURCES)
    outs = [m for m in got if (m.header.stamp.secs, m.header.stamp.nsecs) in frames]
    missing, other, complete, returns = [], [], 0, 0
    for m in outs:
        ref = ideal(merger, frames[(m.header.stamp.secs, m.header.stamp.nsecs)], m.header.stamp.to_sec())
        act = np.array(m.ranges, float)
        same = np.isfinite(ref) & np.isfinite(act) & (np.abs(np.nan_to_num(act) - np.nan_to_num(ref)) < 1e-4)
        missing.append(int(np.sum(np.isfinite(ref) & ~same)))
        other.append(int(np.sum(np.isfinite(act) & ~same)))
        returns += int(np.isfinite(ref).sum())
        complete += missing[-1] == 0 and other[-1] == 0
    stamps = [(m.header.stamp.secs, m.header.stamp.nsecs) for m in got]
    spread = np.array([max(v) - min(v) for v in arrivals.values() if len(v) == 3]) * 1000
    print("sync_window %g s: %d frames, %d outputs (%d at a frame's stamp, %d distinct stamps, increasing: %s), "
          "%d complete; returns of the frame missing: %d of %d (at most %d in one output); returns not of the "
          "frame: %d (at most %d)" % (window, len(frames), len(got), len(outs), len(set(stamps)),
                                       all(a < b for a, b in zip(stamps, stamps[1:])), complete, sum(missing),
                                       returns, max(missing, default=0), sum(other), max(other, default=0)))
    print("  spread of a frame's three scans at a subscriber: median %.1f ms, p95 %.1f ms, p99 %.1f ms, max %.1f ms"
          % (np.median(spread), np.percentile(spread, 95), np.percentile(spread, 99), spread.max()))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--windows", type=float, nargs="+", default=[0.0, 0.01], help="sync_window values (s)")
    ap.add_argument("--one", type=float, help=argparse.SUPPRESS)  # a single window, in this process
    args = ap.parse_args()
    if args.one is not None:
        with tempfile.TemporaryDirectory() as d:
            run(args.one, d)
        return
    for w in args.windows:
        subprocess.check_call([sys.executable, os.path.realpath(__file__), "--one", repr(w)])


if __name__ == "__main__":
    main()
