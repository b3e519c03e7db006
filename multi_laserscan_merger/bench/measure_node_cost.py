#!/usr/bin/python3
"""What the merger node costs per merged output, above a node that only relays the same scans.

The merger as a nodelet in a manager, as the standalone node, and `scan_relay_node`
(bench/scan_relay_node.cpp: it subscribes the four scans and publishes one 1441-beam scan per
input, nothing else) are fed with the paper's four sources (2 lidars x 360 beams at 8 Hz, 2 camera
scans x 328 beams at 14 Hz) and odometry at 50 Hz, publish_rate 0 (one output per input). A
separate Python process publishes the inputs and subscribes to the output, so the figure is the
measured process's own work (receive and deserialise the inputs, check, merge, serialise the
output) per output; the node's figure above the relay's is what the merger's glue and core cost.
Starts its own roscore on a free port (the toolbox's Roscore). Run after sourcing the build's
devel/setup.bash:

    /usr/bin/python3 multi_laserscan_merger/bench/measure_node_cost.py --seconds 20

CPU time per output (the default) moves with whatever else the machine does. `--instructions`
counts instead the instructions the process executes per output under valgrind's callgrind
(all its threads, counted only between warm-up and the end of the window), the same on every
run up to the timing of threads and timers; the node and the relay run under it in turn, and
`--compare DEVEL` adds the merger node of another build's devel space (e.g. one of a commit before
a change, built in its own folder), run with that build's libraries and fed the same way. A merger
node's line also gives its core's share (MergerCore::merge) and its diagnostics' (published once a
second, so their share per output shrinks as the rate grows). Under callgrind a process runs some
50 times slower, so the feed can be slowed for all alike (`--rate-scale`, every source and the
odometry by the same factor: the same mix per output):

    /usr/bin/python3 multi_laserscan_merger/bench/measure_node_cost.py --instructions --rate-scale 0.25 \
        --seconds 60 --rounds 3 --compare /path/to/other_build/devel
"""
import argparse
import math
import os
import re
import subprocess
import sys
import tempfile
import time

PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
from laserscan_toolbox.ros.cpu_accounting import snapshot, spent, tree_processes
from laserscan_toolbox.ros.rosrun import Roscore, package_executable, stop_process

# name, frame, x, y, z, yaw, beams, angle_min, increment, rate
SOURCES = [
    ('lidar_front_left', 'lidar_fl', 0.37, 0.24, 0.2, math.pi / 4, 360, -math.pi, 2 * math.pi / 360, 8.0),
    ('lidar_rear_right', 'lidar_rr', -0.37, -0.24, 0.2, -3 * math.pi / 4, 360, -math.pi, 2 * math.pi / 360, 8.0),
    ('camera_front', 'cam_front', 0.37, 0.0, 0.3, 0.0, 328, math.radians(-41), math.radians(0.25), 14.0),
    ('camera_rear', 'cam_rear', -0.37, 0.0, 0.3, math.pi, 328, math.radians(-41), math.radians(0.25), 14.0),
]
ODOMETRY_RATE = 50.0
# When each source sends first (s, at rate scale 1): the camera scans fall on a grid of 1/56 s
# modulo a lidar's period, the lidars halfway between its points, so that no two scans are sent
# less than 1/112 s apart (two scans sent at once may reach the merger in either order, and the
# older one then goes into the next output instead of its own).
PHASES = {'camera_front': 0.0, 'camera_rear': 1.0 / 28, 'lidar_front_left': 1.0 / 112,
          'lidar_rear_right': 1.0 / 112 + 1.0 / 16, 'odom': 0.0}


def publisher(count_file, rate_scale):
    import numpy as np
    import rospy
    import tf2_ros
    from geometry_msgs.msg import TransformStamped
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import LaserScan

    rospy.init_node('cpu_feed')
    static = tf2_ros.StaticTransformBroadcaster()
    tfs = []
    for name, frame, x, y, z, yaw, *_ in SOURCES:
        t = TransformStamped()
        t.header.stamp = rospy.Time.now()
        t.header.frame_id, t.child_frame_id = 'base_link', frame
        t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = x, y, z
        t.transform.rotation.z, t.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
        tfs.append(t)
    static.sendTransform(tfs)
    pubs = {s[0]: rospy.Publisher(s[0] + '/scan', LaserScan, queue_size=10) for s in SOURCES}
    odom_pub = rospy.Publisher('odom', Odometry, queue_size=10)
    outputs, inputs = [0], [0]
    rospy.Subscriber('merged_scan', LaserScan, lambda m: outputs.__setitem__(0, outputs[0] + 1), queue_size=100)
    rng = np.random.default_rng(0)

    def scan(src):
        name, frame, x, y, z, yaw, n, amin, inc, rate = src
        m = LaserScan()
        m.header.stamp = rospy.Time.now()
        m.header.frame_id = frame
        m.angle_min, m.angle_increment, m.angle_max = amin, inc, amin + (n - 1) * inc
        m.time_increment = (1.0 / rate) / n if n == 360 else 0.0
        m.range_min, m.range_max = 0.05, 20.0
        m.ranges = rng.uniform(0.3, 8.0, n).astype(np.float32).tolist()
        pubs[name].publish(m)
        inputs[0] += 1

    def odom():
        m = Odometry()
        m.header.stamp = rospy.Time.now()
        m.header.frame_id, m.child_frame_id = 'odom', 'base_link'
        t = m.header.stamp.to_sec()
        m.pose.pose.position.x = 0.3 * t % 100.0
        m.pose.pose.orientation.w = 1.0
        odom_pub.publish(m)

    # One thread sends everything, each message stamped as it goes: the merger receives the
    # scans in the order of their stamps (with a timer thread per source, a scan stamped just
    # before another's could be sent after it, and the merger then folds it into the next output).
    period = {name: 1.0 / (rate * rate_scale) for name, *_, rate in SOURCES}
    period['odom'] = 1.0 / (ODOMETRY_RATE * rate_scale)
    start = time.time() + 0.5
    due = {name: start + PHASES[name] / rate_scale for name in period}
    next_count = time.time()
    while not rospy.is_shutdown():
        name = min(due, key=due.get)
        time.sleep(max(0.0, min(due[name], next_count) - time.time()))
        now = time.time()
        if now >= due[name]:
            if name == 'odom':
                odom()
            else:
                scan(next(s for s in SOURCES if s[0] == name))
            due[name] += period[name]
        if now >= next_count:
            # Replaced whole, so that a reader never sees the file empty halfway through a write.
            with open(count_file + '.tmp', 'w') as f:
                f.write('%d %d' % (outputs[0], inputs[0]))
            os.replace(count_file + '.tmp', count_file)
            next_count = now + 0.1


def read_counts(path):
    """(outputs received, input scans published) so far by the feeder."""
    try:
        with open(path) as f:
            outputs, inputs = f.read().split()
        return int(outputs), int(inputs)
    except (OSError, ValueError):
        return 0, 0


def devel_space(executable):
    """The devel space a package executable (<devel>/lib/<package>/<name>) belongs to."""
    return os.path.dirname(os.path.dirname(os.path.dirname(executable)))


def start(env, mode, executable, tmp, instructions):
    """Starts what is measured; returns (the process whose CPU or instructions count, all started)."""
    if mode == 'compared':
        # The executable's RUNPATH loses against the sourced devel space's LD_LIBRARY_PATH: its
        # own build's libraries first, or it would run this build's merger.
        env = dict(env, LD_LIBRARY_PATH=os.path.join(devel_space(executable), 'lib') + os.pathsep +
                   env.get('LD_LIBRARY_PATH', ''))
    subprocess.run(['rosparam', 'load', os.path.join(PKG, 'config', 'multi_laserscan_merger.yaml'), '/merger'],
                   env=env, check=True)
    quiet = dict(env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    if mode == 'nodelet':
        manager = subprocess.Popen(['rosrun', 'nodelet', 'nodelet', 'manager', '__name:=manager'], **quiet)
        time.sleep(1.0)
        loader = subprocess.Popen(['rosrun', 'nodelet', 'nodelet', 'load',
                                   'multi_laserscan_merger/MultiLaserScanMergerNodelet', 'manager', '__name:=merger'],
                                  **quiet)
        return manager, [manager, loader]
    prefix = []
    if instructions:
        # Counting starts off: callgrind_control switches it on once the node is warm.
        prefix = ['valgrind', '--tool=callgrind', '--instr-atstart=no',
                  '--callgrind-out-file=' + os.path.join(tmp, mode + '.callgrind')]
    node = subprocess.Popen(prefix + [executable, '__name:=merger'], **quiet)
    return node, [node]


def loaded_merger_library(pid):
    """The path of the merger library the process mapped (None before it is loaded)."""
    with open('/proc/%d/maps' % pid) as f:
        for line in f:
            if line.rstrip().endswith('/libmulti_laserscan_merger.so'):
                return line.split()[-1]
    return None


# The parts of a merger node's instructions (callgrind_annotate's inclusive counts): the core's
# merge, and the diagnostics published once a second whatever the rate.
PARTS = {'core': r'multi_laserscan_merger::MergerCore::merge\(',
         'diagnostics': r'diagnostic_updater::Updater::force_update\(\)'}


def callgrind_parts(path):
    """{part: instructions} of PARTS in a callgrind output file (the first, largest, match)."""
    annotated = subprocess.run(['callgrind_annotate', '--inclusive=yes', '--threshold=100', path],
                               capture_output=True, text=True).stdout
    parts = {}
    for name, pattern in PARTS.items():
        for line in annotated.splitlines():
            if re.search(pattern, line):
                parts[name] = int(line.split()[0].replace(',', ''))
                break
    return parts


def callgrind_total(path):
    """The instructions (Ir) a callgrind output file counts: its `totals:` line (its `summary:`
    line reads 0 when counting was switched on and off by callgrind_control)."""
    with open(path) as f:
        totals = [int(line.split()[1]) for line in f if line.startswith('totals:')]
    if not totals:
        raise RuntimeError('no totals in ' + path)
    return sum(totals)


def measure(env, mode, executable, seconds, rate_scale, tmp, instructions):
    """(CPU seconds or instructions of the process in the window, {part: instructions} of a merger
    node under callgrind, outputs, inputs, wall seconds)."""
    target, procs = start(env, mode, executable, tmp, instructions)
    count_file = os.path.join(tmp, mode + '.count')
    feed = subprocess.Popen([sys.executable, os.path.abspath(__file__), '--publish', count_file,
                             '--rate-scale', str(rate_scale)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        # Connections and warm-up: outputs flow (a node under valgrind takes many seconds to
        # start), then a few seconds more.
        deadline = time.time() + 180.0
        while read_counts(count_file)[0] < 3:
            if time.time() > deadline or target.poll() is not None:
                raise RuntimeError('%s: no output came' % mode)
            time.sleep(0.2)
        time.sleep(4.0)
        if mode in ('node', 'compared'):
            library = loaded_merger_library(target.pid)
            if library is None or not library.startswith(devel_space(executable) + os.sep):
                raise RuntimeError('%s: %s runs with the merger library %s' % (mode, executable, library))
        if instructions:
            subprocess.run(['callgrind_control', '-i', 'on', str(target.pid)], check=True, capture_output=True)
        else:
            # rosrun may exec or fork: take the process and its children.
            c0 = snapshot(tree_processes(target.pid, include_root=True))
        (o0, i0), t0 = read_counts(count_file), time.time()
        time.sleep(seconds)
        if instructions:
            subprocess.run(['callgrind_control', '-i', 'off', str(target.pid)], check=True, capture_output=True)
        else:
            cost = spent(c0, snapshot(tree_processes(target.pid, include_root=True)))['total_s']
        (o1, i1), t1 = read_counts(count_file), time.time()
    finally:
        for p in [feed] + procs[::-1]:
            stop_process(p, timeout=60.0)  # valgrind writes its counts on the way out
    parts = {}
    if instructions:
        cost = callgrind_total(os.path.join(tmp, mode + '.callgrind'))
        if mode != 'relay':
            parts = callgrind_parts(os.path.join(tmp, mode + '.callgrind'))
    return cost, parts, o1 - o0, i1 - i0, t1 - t0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('--seconds', type=float, default=20.0, help='length of the measured window per mode')
    ap.add_argument('--instructions', action='store_true',
                    help='count instructions under callgrind (node and relay) instead of CPU time')
    ap.add_argument('--rate-scale', type=float, default=1.0,
                    help='every input rate times this (0.25 under callgrind, whose node runs ~50x slower)')
    ap.add_argument('--compare', metavar='DEVEL',
                    help="also measure the merger node of another build's devel space, fed the same way")
    ap.add_argument('--rounds', type=int, default=1, help='measure every mode this many times, in turn')
    ap.add_argument('--publish', help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.publish:
        publisher(args.publish, args.rate_scale)
        return 0
    tmp = tempfile.mkdtemp(prefix='merger_cost_')
    with Roscore(tmp, base_env=dict(os.environ, PYENV_VERSION='system')) as core:
        env = core.env
        modes = [('node', package_executable(env, 'multi_laserscan_merger', 'multi_laserscan_merger_node')),
                 ('relay', package_executable(env, 'multi_laserscan_merger', 'scan_relay_node'))]
        if not args.instructions:
            modes.insert(0, ('nodelet', None))
        if args.compare:
            devel = os.path.abspath(args.compare)
            modes.append(('compared', os.path.join(devel, 'lib', 'multi_laserscan_merger',
                                                   'multi_laserscan_merger_node')))
        unit, scale = ('k instructions', 1e-3) if args.instructions else ('us', 1e6)
        rounds = []  # per round: {mode: cost per output}
        for round_number in range(1, args.rounds + 1):
            per_output = {}
            for mode, executable in modes:
                cost, parts, outputs, inputs, wall = measure(env, mode, executable, args.seconds, args.rate_scale,
                                                             tmp, args.instructions)
                per_output[mode] = cost / max(outputs, 1)
                if args.instructions:
                    print('round %d %-8s %5d outputs of %5d input scans in %.1f s: %.0f instructions = %.0f k per '
                          'output, %.0f k per input scan%s'
                          % (round_number, mode, outputs, inputs, wall, cost, per_output[mode] / 1e3,
                             cost / max(inputs, 1) / 1e3,
                             ''.join('; %s %.0f k' % (name, n / max(outputs, 1) / 1e3) for name, n in parts.items())))
                else:
                    print('round %d %-8s %5d outputs of %5d input scans in %.1f s (%.1f Hz): process CPU %.3f s = '
                          '%.1f us per output (%.1f%% of one core)'
                          % (round_number, mode, outputs, inputs, wall, outputs / wall, cost, 1e6 * per_output[mode],
                             100 * cost / wall))
                if outputs < 0.95 * inputs:
                    # The node fell behind and dropped scans, or took scans late and folded them into
                    # later outputs: a figure per output then holds more than one input's work.
                    print('%s: %d outputs for %d input scans: lower --rate-scale' % (mode, outputs, inputs),
                          file=sys.stderr)
            rounds.append(per_output)
        print('per output over %d round(s), lowest-highest (%s):' % (len(rounds), unit))
        for mode, _ in modes:
            figures = [scale * r[mode] for r in rounds]
            print('  %-24s %.1f-%.1f' % (mode, min(figures), max(figures)))
        for mode in ('node', 'compared'):
            if mode in rounds[0]:
                above = [scale * (r[mode] - r['relay']) for r in rounds]
                print('  %-24s %.1f-%.1f (its glue and core)' % (mode + ' above the relay', min(above), max(above)))
    return 0


if __name__ == '__main__':
    sys.exit(main())
