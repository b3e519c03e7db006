#!/usr/bin/python3
"""CPU per merged output of the whole ROS path: the merger as a nodelet in a manager against
the standalone node, fed with the paper's four sources (2 lidars x 360 beams at 8 Hz, 2 camera
scans x 328 beams at 14 Hz) and odometry at 50 Hz, publish_rate 0 (one output per input).

Starts its own roscore on a free port. A separate Python process publishes the inputs and
subscribes to the output in every mode, so the figure is the merger process's CPU (receive
and deserialise the inputs, merge, serialise the output) per output. The third mode runs
`scan_relay_node` (bench/scan_relay_node.cpp) instead: it subscribes the four scans and
publishes one 1441-beam scan per input, nothing else; the node's figure above it is what the
merger's glue and core cost. Run after sourcing the
build's devel/setup.bash:

    /usr/bin/python3 multi_laserscan_merger/bench/measure_node_cost.py [--seconds 20]
"""
import argparse
import math
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time

PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
from laserscan_toolbox.ros.cpu_accounting import snapshot, spent, tree_processes

# name, frame, x, y, z, yaw, beams, angle_min, increment, rate
SOURCES = [
    ('lidar_front_left', 'lidar_fl', 0.37, 0.24, 0.2, math.pi / 4, 360, -math.pi, 2 * math.pi / 360, 8.0),
    ('lidar_rear_right', 'lidar_rr', -0.37, -0.24, 0.2, -3 * math.pi / 4, 360, -math.pi, 2 * math.pi / 360, 8.0),
    ('camera_front', 'cam_front', 0.37, 0.0, 0.3, 0.0, 328, math.radians(-41), math.radians(0.25), 14.0),
    ('camera_rear', 'cam_rear', -0.37, 0.0, 0.3, math.pi, 328, math.radians(-41), math.radians(0.25), 14.0),
]


def publisher(count_file):
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
    count = [0]
    rospy.Subscriber('merged_scan', LaserScan, lambda m: count.__setitem__(0, count[0] + 1), queue_size=100)
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

    def odom(_):
        m = Odometry()
        m.header.stamp = rospy.Time.now()
        m.header.frame_id, m.child_frame_id = 'odom', 'base_link'
        t = m.header.stamp.to_sec()
        m.pose.pose.position.x = 0.3 * t % 100.0
        m.pose.pose.orientation.w = 1.0
        odom_pub.publish(m)

    timers = [rospy.Timer(rospy.Duration(1.0 / s[9]), lambda e, s=s: scan(s)) for s in SOURCES]
    timers.append(rospy.Timer(rospy.Duration(0.02), odom))
    while not rospy.is_shutdown():
        # Replaced whole, so that a reader never sees the file empty halfway through a write.
        with open(count_file + '.tmp', 'w') as f:
            f.write(str(count[0]))
        os.replace(count_file + '.tmp', count_file)
        rospy.sleep(0.1)
    del timers


def free_port():
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def read_count(path):
    try:
        with open(path) as f:
            return int(f.read() or 0)
    except (OSError, ValueError):
        return 0


def measure(env, mode, seconds, tmp):
    subprocess.run(['rosparam', 'load', os.path.join(PKG, 'config', 'multi_laserscan_merger.yaml'), '/merger'], env=env, check=True)
    procs = []
    if mode == 'nodelet':
        manager = subprocess.Popen(['rosrun', 'nodelet', 'nodelet', 'manager', '__name:=manager'], env=env,
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        procs.append(manager)
        time.sleep(1.0)
        procs.append(subprocess.Popen(['rosrun', 'nodelet', 'nodelet', 'load',
                                       'multi_laserscan_merger/MultiLaserScanMergerNodelet', 'manager',
                                       '__name:=merger'], env=env, stdout=subprocess.DEVNULL,
                                      stderr=subprocess.DEVNULL))
        target = manager
    else:
        program = 'scan_relay_node' if mode == 'relay' else 'multi_laserscan_merger_node'
        target = subprocess.Popen(['rosrun', 'multi_laserscan_merger', program, '__name:=merger'],
                                  env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        procs.append(target)
    count_file = os.path.join(tmp, mode + '.count')
    feed = subprocess.Popen([sys.executable, os.path.abspath(__file__), '--publish', count_file], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(4.0)  # connections and warm-up

    def cpu():
        # rosrun may exec or fork: take the process and its children.
        return snapshot(tree_processes(target.pid, include_root=True))
    c0, n0, t0 = cpu(), read_count(count_file), time.time()
    time.sleep(seconds)
    c1, n1, t1 = cpu(), read_count(count_file), time.time()
    for p in [feed] + procs[::-1]:
        p.send_signal(signal.SIGINT)
    for p in [feed] + procs:
        try:
            p.wait(timeout=15)
        except subprocess.TimeoutExpired:
            p.kill()
    outputs = n1 - n0
    return spent(c0, c1)["total_s"], outputs, (t1 - t0)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--seconds', type=float, default=20.0)
    ap.add_argument('--publish', help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.publish:
        publisher(args.publish)
        return
    tmp = tempfile.mkdtemp(prefix='merger_cpu_')
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI='http://127.0.0.1:%d' % port, ROS_HOME=tmp, ROS_LOG_DIR=tmp,
               PYENV_VERSION='system')
    core = subprocess.Popen(['roscore', '-p', str(port)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    try:
        while subprocess.run(['rosparam', 'list'], env=env, capture_output=True).returncode != 0:
            time.sleep(0.3)
        per_output = {}
        for mode in ('nodelet', 'node', 'relay'):
            cpu, outputs, wall = measure(env, mode, args.seconds, tmp)
            per_output[mode] = 1e6 * cpu / max(outputs, 1)
            print('%-8s %5d outputs in %.1f s (%.1f Hz): merger process CPU %.3f s = %.1f us per output '
                  '(%.1f%% of one core)' % (mode, outputs, wall, outputs / wall, cpu, per_output[mode],
                                            100 * cpu / wall))
        print('node above the relay: %.1f us per output (glue and core; the core alone is about 2.4 us: '
              'bench/benchmark.cpp)' % (per_output['node'] - per_output['relay']))
    finally:
        core.send_signal(signal.SIGINT)
        core.wait(timeout=30)


if __name__ == '__main__':
    main()
