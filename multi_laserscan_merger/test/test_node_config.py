"""The node against its configuration, with its own roscore on a free port (temporary
ROS_HOME / ROS_LOG_DIR): the shipped YAML starts; bad configurations stop the node at
start-up with the parameter's name and a non-zero exit (and the nodelet reports FATAL and
does nothing); a malformed scan is dropped with a message naming the source and the fault."""
import os
import signal
import socket
import subprocess
import tempfile
import time

import pytest

PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
GOOD_SOURCE = '{name: a, topic: a/scan}'


def free_port():
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


@pytest.fixture(scope='module')
def ros_env():
    tmp = tempfile.mkdtemp(prefix='merger_test_')
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI='http://127.0.0.1:%d' % port, ROS_HOME=tmp, ROS_LOG_DIR=tmp,
               PYENV_VERSION='system', ROSCONSOLE_FORMAT='[${severity}] ${message}',
               ROSCONSOLE_STDOUT_LINE_BUFFERED='1')
    core = subprocess.Popen(['roscore', '-p', str(port)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.time() + 30
    while time.time() < deadline:
        if subprocess.run(['rosparam', 'list'], env=env, capture_output=True).returncode == 0:
            break
        time.sleep(0.3)
    else:
        core.terminate()
        pytest.fail('roscore did not start')
    yield env
    core.terminate()
    core.wait(timeout=20)


def set_params(env, ns, yaml_text):
    path = os.path.join(env['ROS_HOME'], ns + '.yaml')
    with open(path, 'w') as f:
        f.write(yaml_text)
    subprocess.run(['rosparam', 'load', path, '/' + ns], env=env, check=True)


def run_node(env, name, wait, args=()):
    """Starts the node; returns (exit code or None if still running after `wait` s, output)."""
    p = subprocess.Popen(['rosrun', 'multi_laserscan_merger', 'multi_laserscan_merger_node', '__name:=' + name] + list(args),
                         env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        out, _ = p.communicate(timeout=wait)
        return p.returncode, out
    except subprocess.TimeoutExpired:
        p.send_signal(signal.SIGINT)  # roscpp shuts down cleanly on SIGINT
        out, _ = p.communicate(timeout=20)
        return None, out


def test_shipped_config_starts(ros_env):
    subprocess.run(['rosparam', 'load', os.path.join(PKG, 'config', 'paper_robot.yaml'), '/merger_ok'],
                   env=ros_env, check=True)
    code, out = run_node(ros_env, 'merger_ok', 4.0)
    assert code is None, out
    assert 'merging 4 sources' in out


@pytest.mark.parametrize('yaml_text,parameter', [
    ('sources: [{name: a, topic: x}, {name: a, topic: y}]', 'sources[1].name'),
    ('sources: [{name: a}]', 'sources[0].topic'),
    ('sources: [{name: a, topic: x, range_min: 5.0, range_max: 2.0}]', 'sources[0].range_min'),
    ('angle_min: 1.0\nangle_max: 0.5\nsources: [%s]' % GOOD_SOURCE, 'angle_min'),
    ('sources: [{name: a, topic: x, timout: 1.0}]', 'sources[0].timout'),
    ('range_max: far\nsources: [%s]' % GOOD_SOURCE, 'range_max'),
    ('odom_queue_size: 1\nsources: [%s]' % GOOD_SOURCE, 'odom_queue_size'),
    ('output_frame: base_link', 'sources'),
    ('footprint: [[0.3, 0.2], [-0.3, 0.2]]\nsources: [%s]' % GOOD_SOURCE, 'footprint'),
    ('footprint: [[0.3, 0.2], [-0.3, 0.2], [0.0]]\nsources: [%s]' % GOOD_SOURCE, 'footprint'),
    ('footprint: [[0.3, 0.2], [-0.3, 0.2], [0.0, .nan]]\nsources: [%s]' % GOOD_SOURCE, 'footprint'),
    ('finite_only: true\nsources: [%s]' % GOOD_SOURCE, 'finite_only'),
    ('use_inf: false\nfinite_only: true\nsources: [%s]' % GOOD_SOURCE, 'range_min'),
    ('output_frame: /base_link\nsources: [%s]' % GOOD_SOURCE, 'output_frame'),
    ('sources: [{name: a, topic: x, too_close_is_obstacle: "yes"}]', 'sources[0].too_close_is_obstacle'),
    ('sources: [{name: a, topic: x, drop_explained_within: -0.1}]', 'sources[0].drop_explained_within'),
    ('sources: [{name: a, topic: x, drop_explained_within: near}]', 'sources[0].drop_explained_within'),
    ('sources: [%s, {name: b, topic: merged_scan}]' % GOOD_SOURCE, 'sources[1].topic'),
])
def test_bad_config_stops_node_naming_parameter(ros_env, yaml_text, parameter):
    ns = 'bad_%d' % (abs(hash(yaml_text)) % 100000)
    set_params(ros_env, ns, yaml_text)
    code, out = run_node(ros_env, ns, 15.0)
    assert code is not None and code != 0, out
    assert 'FATAL' in out and "parameter '%s'" % parameter in out, out


def test_source_on_the_remapped_output_topic_is_refused(ros_env):
    # A lidar driver on /scan, and the output remapped to /scan as well: the merger would read itself.
    set_params(ros_env, 'merger_clash', 'sources: [{name: front, topic: front/scan}, {name: lidar, topic: /scan}]')
    code, out = run_node(ros_env, 'merger_clash', 15.0, ['merged_scan:=/scan'])
    assert code is not None and code != 0, out
    assert "parameter 'sources[1].topic'" in out and "source 'lidar' resolves to '/scan'" in out, out
    # Without the remap the same sources are fine.
    code, out = run_node(ros_env, 'merger_clash', 4.0)
    assert code is None and "on '/merged_scan'" in out, out


def test_bad_config_nodelet_fatal(ros_env):
    set_params(ros_env, 'bad_nodelet', 'sources: [{name: a, topic: x}, {name: a, topic: y}]')
    p = subprocess.Popen(['rosrun', 'nodelet', 'nodelet', 'standalone', 'multi_laserscan_merger/MultiLaserScanMergerNodelet',
                          '__name:=bad_nodelet'], env=ros_env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    time.sleep(5.0)
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=20)
    assert 'FATAL' in out and "parameter 'sources[1].name'" in out and 'duplicate' in out, out
    assert 'merging 1 sources' not in out


def node_output_after_one_message(env, name, yaml_text, topic, msg_type, msg):
    """Starts the node, publishes one message, stops it: (still alive before the stop, output)."""
    set_params(env, name, yaml_text)
    p = subprocess.Popen(['rosrun', 'multi_laserscan_merger', 'multi_laserscan_merger_node', '__name:=' + name],
                         env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    time.sleep(2.0)
    subprocess.run(['rostopic', 'pub', '-1', topic, msg_type, msg], env=env, check=True, capture_output=True,
                   timeout=30)
    time.sleep(1.0)
    alive = p.poll() is None
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=20)
    return alive, out


def test_malformed_scan_is_reported(ros_env):
    alive, out = node_output_after_one_message(
        ros_env, 'merger_m', 'odom_topic: ""\nsources: [{name: front, topic: m/scan}]', '/m/scan',
        'sensor_msgs/LaserScan', '{header: {frame_id: base_link}, angle_min: 0.0, angle_max: 1.0, '
        'angle_increment: 0.1, range_max: 10.0, ranges: [1.0, 2.0]}')
    assert alive, out
    assert "source 'front'" in out and 'malformed scan dropped' in out and 'ranges length' in out, out


def test_tf_with_a_stamp_near_2_to_the_32_is_ignored(ros_env):
    # tf2 adds its cache length to such a stamp and throws "Time is out of dual 32-bit range":
    # through tf2_ros::TransformListener that aborted the process (and a whole nodelet manager).
    alive, out = node_output_after_one_message(
        ros_env, 'merger_tfx', 'odom_topic: ""\nsources: [{name: a, topic: tfx/scan}]', '/tf', 'tf2_msgs/TFMessage',
        '{transforms: [{header: {stamp: {secs: 4294967290, nsecs: 0}, frame_id: base_link}, child_frame_id: x, '
        'transform: {rotation: {w: 1.0}}}]}')
    assert alive, out
    assert "transform 'base_link' -> 'x'" in out and 'stamp 4294967290.000000000 ignored' in out, out


def test_infinite_transform_is_ignored(ros_env):
    # tf2 refuses NaN but stores an infinite translation: a mount that moves every return away.
    alive, out = node_output_after_one_message(
        ros_env, 'merger_tfinf', 'odom_topic: ""\nsources: [{name: a, topic: tfinf/scan}]', '/tf',
        'tf2_msgs/TFMessage', '{transforms: [{header: {frame_id: base_link}, child_frame_id: lidar, '
        'transform: {translation: {x: .inf}, rotation: {w: 1.0}}}]}')
    assert alive, out
    assert "transform 'base_link' -> 'lidar'" in out and 'not finite' in out, out


def test_missing_transform_is_reported(ros_env):
    set_params(ros_env, 'merger_tf', 'odom_topic: ""\nsources: [{name: side, topic: tf/scan}]')
    p = subprocess.Popen(['rosrun', 'multi_laserscan_merger', 'multi_laserscan_merger_node', '__name:=merger_tf'],
                         env=ros_env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    time.sleep(2.0)
    pub = subprocess.Popen(['rostopic', 'pub', '-r', '5', '/tf/scan', 'sensor_msgs/LaserScan',
                            '{header: {frame_id: nowhere}, angle_min: 0.0, angle_max: 1.0, angle_increment: 0.1, '
                            'range_max: 10.0, ranges: [1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1]}'],
                           env=ros_env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(2.0)
    # Scans arrive and are dropped: diagnostics say why, never "no scan received yet".
    diag = subprocess.run(['rostopic', 'echo', '-n', '1', '/diagnostics'], env=ros_env, capture_output=True,
                          text=True, timeout=30).stdout
    time.sleep(1.0)
    pub.send_signal(signal.SIGINT)
    pub.wait(timeout=20)
    alive = p.poll() is None
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=20)
    assert alive, out
    assert "source 'side'" in out and "no transform 'nowhere' -> 'base_link'" in out and 'scan dropped' in out, out
    assert 'none merged yet' in diag and 'transform' in diag and 'no scan received yet' not in diag, diag
    assert 'hardware_id: "/merger_tf"' in diag, diag


BAD_ODOM_FEED = r'''
import math, sys, time, rospy
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
rospy.init_node('bad_odom_feed')
odom = rospy.Publisher('/o/odom', Odometry, queue_size=10)
scan = rospy.Publisher('/o/scan', LaserScan, queue_size=10)
merged = []
rospy.Subscriber('/merged_scan', LaserScan, lambda m: merged.append(m))
time.sleep(1.5)
def bad_odom(i):
    o = Odometry()
    o.header.stamp, o.child_frame_id = rospy.Time.now(), 'base_link'
    o.pose.pose.orientation.w = [0.0, math.nan][i % 2]  # zero, then NaN quaternions only
    odom.publish(o)
for i in range(3):  # odometry first: the merger has received some (none usable) before any scan
    bad_odom(i)
time.sleep(0.5)
for i in range(20):
    bad_odom(i)
    s = LaserScan()
    s.header.stamp, s.header.frame_id = rospy.Time.now(), 'base_link'
    s.angle_min, s.angle_max, s.angle_increment = -1.0, 1.0, 0.1
    s.range_max, s.ranges = 10.0, [2.0] * 21
    scan.publish(s)
    time.sleep(0.1)
time.sleep(0.5)
print('merged', len(merged))
sys.stdout.flush()
'''


def test_unusable_odometry_is_named(ros_env):
    set_params(ros_env, 'merger_o', 'odom_topic: o/odom\nsources: [{name: front, topic: o/scan}]')
    p = subprocess.Popen(['rosrun', 'multi_laserscan_merger', 'multi_laserscan_merger_node', '__name:=merger_o'],
                         env=ros_env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    time.sleep(1.0)
    feed = subprocess.run(['/usr/bin/python3', '-c', BAD_ODOM_FEED], env=ros_env, capture_output=True, text=True,
                          timeout=60)
    alive = p.poll() is None
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=20)
    assert alive, out
    assert int(feed.stdout.split()[-1]) >= 10, feed.stdout + feed.stderr  # merged without motion compensation
    assert 'zero quaternion ignored' in out and "none of the" in out and 'odometry messages' in out, out
    assert 'no odometry yet' not in out, out


FEED = r'''
import sys, rospy
from rosgraph_msgs.msg import Clock
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
rospy.init_node('jump_feed')
clock = rospy.Publisher('/clock', Clock, queue_size=10)
odom = rospy.Publisher('/j/odom', Odometry, queue_size=10)
scan = rospy.Publisher('/j/scan', LaserScan, queue_size=10)
after = [0]
rospy.Subscriber('/merged_scan', LaserScan, lambda m: after.__setitem__(0, after[0] + (m.header.stamp.to_sec() < 90)))
import time
time.sleep(1.5)
def run(t0, seconds, with_odom):
    t = t0
    for i in range(int(seconds / 0.01)):
        t += 0.01
        stamp = rospy.Time.from_sec(t)
        clock.publish(Clock(clock=stamp))
        if with_odom:
            o = Odometry()
            o.header.stamp, o.header.frame_id, o.child_frame_id = stamp, 'odom', 'base_link'
            o.pose.pose.position.x = 0.5 * t
            o.pose.pose.orientation.w = 1.0
            odom.publish(o)
        if i % 10 == 0:
            s = LaserScan()
            s.header.stamp, s.header.frame_id = stamp, 'base_link'
            s.angle_min, s.angle_max, s.angle_increment = -1.0, 1.0, 0.1
            s.range_max, s.ranges = 10.0, [2.0] * 21
            scan.publish(s)
        time.sleep(0.01)
run(100.0, 2.0, True)     # normal
run(102.0, 1.5, False)    # odometry stops
run(50.0, 2.0, True)      # the clock jumps back (a bag played in a loop)
time.sleep(0.5)
print('after_jump_outputs', after[0])
sys.stdout.flush()
'''


def test_time_jump_and_odometry_stop(ros_env):
    subprocess.run(['rosparam', 'set', '/use_sim_time', 'true'], env=ros_env, check=True)
    try:
        set_params(ros_env, 'merger_j', 'odom_topic: j/odom\nsources: [{name: front, topic: j/scan, timeout: 0.5}]')
        p = subprocess.Popen(['rosrun', 'multi_laserscan_merger', 'multi_laserscan_merger_node', '__name:=merger_j'],
                             env=ros_env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        time.sleep(1.0)
        feed = subprocess.run(['/usr/bin/python3', '-c', FEED], env=ros_env, capture_output=True, text=True, timeout=60)
        alive = p.poll() is None
        p.send_signal(signal.SIGINT)
        out, _ = p.communicate(timeout=20)
    finally:
        subprocess.run(['rosparam', 'delete', '/use_sim_time'], env=ros_env)
    assert alive, out
    print(out)
    assert 'odometry stopped' in out, out
    assert 'time jumped backwards' in out and 'buffers cleared' in out, out
    # Merged scans come again after the jump, on the new timeline.
    assert 'after_jump_outputs' in feed.stdout, feed.stdout + feed.stderr
    assert int(feed.stdout.split('after_jump_outputs')[1].split()[0]) > 5, feed.stdout
