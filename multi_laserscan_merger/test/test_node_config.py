"""The node against its configuration, with its own roscore on a free port (temporary
ROS_HOME / ROS_LOG_DIR): the shipped YAML starts; bad configurations stop the node at
start-up with the parameter's name and a non-zero exit (and the nodelet reports FATAL and
does nothing); a malformed scan is dropped with a message naming the source and the fault."""
import json
import os
import signal
import subprocess

import pytest

from laserscan_toolbox.ros.rosrun import OutputLines, rostopic_pub

PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
GOOD_SOURCE = '{name: a, topic: a/scan}'
NODE = ['rosrun', 'multi_laserscan_merger', 'multi_laserscan_merger_node']
NODELET = ['rosrun', 'nodelet', 'nodelet', 'standalone', 'multi_laserscan_merger/MultiLaserScanMergerNodelet']
#: The merger's last start-up line: it has subscribed and advertised.
STARTED = 'merging '

# The ROS master comes from conftest.py's ros_env (a private roscore for this module).


def set_params(env, ns, yaml_text):
    path = os.path.join(env['ROS_HOME'], ns + '.yaml')
    with open(path, 'w') as f:
        f.write(yaml_text)
    subprocess.run(['rosparam', 'load', path, '/' + ns], env=env, check=True)


def start(env, name, args=(), command=NODE):
    """The merger node (or ``command``) named ``name``; its output read line by line."""
    return OutputLines(subprocess.Popen(command + ['__name:=' + name] + list(args), env=env, stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, text=True))


def wait_started(node, *parts, timeout=30.0):
    """Waits for the node's start-up line (holding ``parts`` too); fails with its output if it
    stops or does not get there."""
    if not node.wait_for(STARTED, *parts, timeout=timeout):
        pytest.fail('the node did not start (%s):\n%s' % (' '.join(parts) or STARTED, node.stop()))


def stop_cleanly(node):
    """Stops a node that must have run until now: exit status 0 after SIGINT (a node that died
    earlier exits otherwise). Returns its output."""
    out = node.stop()
    assert node.proc.returncode == 0, out
    return out


def run_to_exit(env, name, args=(), timeout=15.0):
    """Starts the node and waits for it to exit: (exit code, or None if it still runs after
    ``timeout`` s, output)."""
    node = start(env, name, args)
    try:
        code = node.proc.wait(timeout)
    except subprocess.TimeoutExpired:
        code = None
    return code, node.stop()


def test_shipped_config_starts(ros_env):
    subprocess.run(['rosparam', 'load', os.path.join(PKG, 'config', 'multi_laserscan_merger.yaml'), '/merger_ok'],
                   env=ros_env, check=True)
    node = start(ros_env, 'merger_ok')
    wait_started(node, 'merging 4 sources')
    stop_cleanly(node)


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
    ('sources: [{name: a, topic: x, self_filter: 1}]', 'sources[0].self_filter'),
    ('self_filter: {shapes: [{frame: arm, type: box, size: [0.1, 0.1]}]}\nsources: [%s]' % GOOD_SOURCE,
     'self_filter/shapes[0]/size'),
    ('self_filter: {use_robot_description: true}\nsources: [%s]' % GOOD_SOURCE, 'robot_description'),
])
def test_bad_config_stops_node_naming_parameter(ros_env, yaml_text, parameter):
    ns = 'bad_%d' % (abs(hash(yaml_text)) % 100000)
    set_params(ros_env, ns, yaml_text)
    code, out = run_to_exit(ros_env, ns)
    assert code is not None and code != 0, out
    # Named as the node's every other line: "[<node>] ".
    assert 'FATAL' in out and "[/%s] not starting: parameter '%s'" % (ns, parameter) in out, out


def test_self_filter_block_is_read(ros_env):
    set_params(ros_env, 'merger_self', 'self_filter: {shapes: [{frame: forearm, type: cylinder, radius: 0.05, '
                                       'length: 0.4}]}\nsources: [%s]' % GOOD_SOURCE)
    node = start(ros_env, 'merger_self')
    wait_started(node)
    out = stop_cleanly(node)
    assert 'self filter: 1 shapes on 1 frames' in out, out


def test_source_on_the_remapped_output_topic_is_refused(ros_env):
    # A lidar driver on /scan, and the output remapped to /scan as well: the merger would read itself.
    set_params(ros_env, 'merger_clash', 'sources: [{name: front, topic: front/scan}, {name: lidar, topic: /scan}]')
    code, out = run_to_exit(ros_env, 'merger_clash', ['merged_scan:=/scan'])
    assert code is not None and code != 0, out
    assert "parameter 'sources[1].topic'" in out and "source 'lidar' resolves to '/scan'" in out, out
    # Without the remap the same sources are fine.
    node = start(ros_env, 'merger_clash')
    wait_started(node, "on '/merged_scan'")
    stop_cleanly(node)


def test_bad_config_nodelet_fatal(ros_env):
    set_params(ros_env, 'bad_nodelet', 'sources: [{name: a, topic: x}, {name: a, topic: y}]')
    nodelet = start(ros_env, 'bad_nodelet', command=NODELET)
    assert nodelet.wait_for('FATAL'), nodelet.stop()
    out = nodelet.stop()
    assert 'FATAL' in out and "parameter 'sources[1].name'" in out and 'duplicate' in out, out
    assert "[/bad_nodelet] not starting" in out, out  # which nodelet of a manager's log
    assert 'merging 1 sources' not in out


def node_output_after_one_message(env, name, yaml_text, topic, msg_type, msg, expect):
    """Starts the node, publishes one message (latched: it reaches the node whenever it
    connects) until the node's output holds ``expect``, stops it: (alive: it ran until then and
    shut down cleanly, output)."""
    set_params(env, name, yaml_text)
    node = start(env, name)
    wait_started(node)
    with rostopic_pub(env, topic, msg_type, msg):
        seen = node.wait_for(expect)
    alive = seen and node.proc.poll() is None
    out = node.stop()
    return alive and node.proc.returncode == 0, out


#: What every feed script starts with: waiting for its connections instead of sleeping.
FEED_TOOLS = r'''
import sys, time
def wait_until(condition, what, timeout=30.0):
    deadline = time.time() + timeout
    while not condition():
        if time.time() > deadline:
            print('timed out waiting for', what)
            sys.stdout.flush()
            sys.exit(3)
        time.sleep(0.01)
def wait_connected(*endpoints):
    """Publishers with their subscriber (the merger), subscribers with their publisher."""
    wait_until(lambda: all(e.get_num_connections() > 0 for e in endpoints), 'connections')
'''


def node_output_with_feed(env, name, yaml_text, feed_script, *feed_args):
    """Starts the node, runs the feed script (rospy, after FEED_TOOLS) to its end, stops the node:
    (alive: it ran to the feed's end and shut down cleanly, the feed's CompletedProcess, the
    node's output)."""
    set_params(env, name, yaml_text)
    node = start(env, name)
    wait_started(node)
    feed = subprocess.run(['/usr/bin/python3', '-c', FEED_TOOLS + feed_script, *feed_args], env=env,
                          capture_output=True, text=True, timeout=60)
    alive = node.proc.poll() is None
    out = node.stop()
    return alive and node.proc.returncode == 0, feed, out


def test_malformed_scan_is_reported(ros_env):
    alive, out = node_output_after_one_message(
        ros_env, 'merger_m', 'odom_topic: ""\nsources: [{name: front, topic: m/scan}]', '/m/scan',
        'sensor_msgs/LaserScan', '{header: {frame_id: base_link}, angle_min: 0.0, angle_max: 1.0, '
        'angle_increment: 0.1, range_max: 10.0, ranges: [1.0, 2.0]}', 'malformed scan dropped')
    assert alive, out
    assert "source 'front'" in out and 'malformed scan dropped' in out and 'ranges length' in out, out


def test_tf_with_a_stamp_near_2_to_the_32_is_ignored(ros_env):
    # tf2 adds its cache length to such a stamp and throws "Time is out of dual 32-bit range":
    # through tf2_ros::TransformListener that aborted the process (and a whole nodelet manager).
    alive, out = node_output_after_one_message(
        ros_env, 'merger_tfx', 'odom_topic: ""\nsources: [{name: a, topic: tfx/scan}]', '/tf', 'tf2_msgs/TFMessage',
        '{transforms: [{header: {stamp: {secs: 4294967290, nsecs: 0}, frame_id: base_link}, child_frame_id: x, '
        'transform: {rotation: {w: 1.0}}}]}', 'ignored')
    assert alive, out
    assert "transform 'base_link' -> 'x'" in out and 'stamp 4294967290.000000000 ignored' in out, out


def test_infinite_transform_is_ignored(ros_env):
    # tf2 refuses NaN but stores an infinite translation: a mount that moves every return away.
    alive, out = node_output_after_one_message(
        ros_env, 'merger_tfinf', 'odom_topic: ""\nsources: [{name: a, topic: tfinf/scan}]', '/tf',
        'tf2_msgs/TFMessage', '{transforms: [{header: {stamp: now, frame_id: base_link}, child_frame_id: lidar, '
        'transform: {translation: {x: .inf}, rotation: {w: 1.0}}}]}', 'not finite')
    assert alive, out
    assert "transform 'base_link' -> 'lidar'" in out and 'not finite' in out, out


TF_CONFLICT_FEED = r"""
import json, math, rospy
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage
rospy.init_node('tf_conflict_feed')
tf = rospy.Publisher('/tf', TFMessage, queue_size=10)
tf_static = rospy.Publisher('/tf_static', TFMessage, queue_size=10, latch=True)
scan = rospy.Publisher('/tc/scan', LaserScan, queue_size=10)
nearest, stamps = [], []
def merged(m):
    nearest.append(min((r for r in m.ranges if math.isfinite(r)), default=-1.0))
    stamps.append(m.header.stamp)
merged_sub = rospy.Subscriber('/merged_scan', LaserScan, merged)
wait_connected(tf, tf_static, scan, merged_sub)
def transform(parent, child, stamp, x=0.0, w=1.0):
    t = TransformStamped()
    t.header.stamp, t.header.frame_id, t.child_frame_id = stamp, parent, child
    t.transform.translation.x, t.transform.rotation.w = x, w
    return t
def lidar(stamp):
    s = LaserScan()
    s.header.stamp, s.header.frame_id = stamp, 'lidar'
    s.angle_min, s.angle_max, s.angle_increment = -0.1, 0.1, 0.05
    s.range_max, s.ranges = 10.0, [2.0] * 5
    scan.publish(s)
tf_static.publish(TFMessage([transform('base_link', 'lidar', rospy.Time(0), x=1.0)]))
# The merger has the static mount once a scan in the lidar's frame comes back merged.
probe = [0.0]
def merged_after_probe():
    if time.time() - probe[0] > 0.1:
        lidar(rospy.Time.now())
        probe[0] = time.time()
    return bool(nearest)
wait_until(merged_after_probe, 'a merged scan on the static mount')
for i in range(20):
    now = rospy.Time.now()
    # The lidar's mount again on /tf, 2 m behind: in tf2 it would replace the static one. And what
    # tf2 refuses itself, but with an error per message: a frame its own parent, a zero rotation.
    tf.publish(TFMessage([transform('base_link', 'lidar', now, x=-1.0), transform('base_link', 'base_link', now),
                          transform('base_link', 'tilted', now, w=0.0)]))
    time.sleep(0.02)
    lidar(now)
    time.sleep(0.08)
wait_until(lambda: now in stamps, 'the last scan merged')  # every earlier output came before it
print(json.dumps(nearest))
"""


def test_faulty_and_conflicting_transforms_are_named_once_and_the_static_mount_stays(ros_env):
    # tf2 logs a frame that is its own parent or a rotation that is not a unit quaternion without
    # throttle; and a /tf transform of a frame that /tf_static holds replaces the static one for
    # good in tf2 (the lidar 1 m ahead of base_link would move 2 m back). The merger ignores both,
    # naming each frame pair once per 5 s.
    alive, feed, out = node_output_with_feed(
        ros_env, 'merger_tf_conflict', 'odom_topic: ""\nsources: [{name: lidar, topic: tc/scan, timeout: 0.5}]',
        TF_CONFLICT_FEED)
    assert alive, out
    assert feed.returncode == 0, feed.stderr
    nearest = json.loads(feed.stdout.strip().splitlines()[-1])
    # Every merged scan sees the wall 2 m ahead of the static mount (3 m), none from the /tf one (1 m).
    assert len(nearest) >= 10 and all(abs(r - 3.0) < 0.05 for r in nearest), (nearest, out)
    assert "transform 'base_link' -> 'lidar' from /tf_conflict_feed on /tf" in out, out
    assert "static transform (from /tf_static)" in out and "own parent" in out and "unit quaternion" in out, out
    for pair in ("'base_link' -> 'lidar'", "'base_link' -> 'base_link'", "'base_link' -> 'tilted'"):
        assert out.count(pair) == 1, (pair, out)  # throttled
    assert "TF_" not in out, out  # tf2 never saw them


def test_missing_transform_is_reported(ros_env):
    set_params(ros_env, 'merger_tf', 'odom_topic: ""\nsources: [{name: side, topic: tf/scan}]')
    node = start(ros_env, 'merger_tf')
    wait_started(node)
    with rostopic_pub(ros_env, '/tf/scan', 'sensor_msgs/LaserScan',
                      '{header: {stamp: now, frame_id: nowhere}, angle_min: 0.0, angle_max: 1.0, angle_increment: 0.1, '
                      'range_max: 10.0, ranges: [1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1]}', '-s', '-r', '5'):
        # Scans arrive and are dropped: diagnostics say why, never "no scan received yet".
        node.wait_for('scan dropped')
        diag = subprocess.run(['rostopic', 'echo', '-n', '1', '/diagnostics'], env=ros_env, capture_output=True,
                              text=True, timeout=30).stdout
    alive = node.proc.poll() is None
    out = stop_cleanly(node)
    assert alive, out
    assert "source 'side'" in out and "no transform 'nowhere' -> 'base_link'" in out and 'scan dropped' in out, out
    assert 'none merged yet' in diag and 'transform' in diag and 'no scan received yet' not in diag, diag
    assert 'hardware_id: "/merger_tf"' in diag, diag


BAD_ODOM_FEED = r'''
import math, rospy
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import LaserScan
rospy.init_node('bad_odom_feed')
odom = rospy.Publisher('/o/odom', Odometry, queue_size=10)
scan = rospy.Publisher('/o/scan', LaserScan, queue_size=10)
merged, warnings = [], []
merged_sub = rospy.Subscriber('/merged_scan', LaserScan, lambda m: merged.append(m))
rosout = rospy.Subscriber('/rosout_agg', Log, lambda m: warnings.append(m.msg) if m.level >= Log.WARN else None)
wait_connected(odom, scan, merged_sub, rosout)
def bad_odom(i):
    o = Odometry()
    o.header.stamp, o.child_frame_id = rospy.Time.now(), 'base_link'
    o.pose.pose.orientation.w = [0.0, math.nan][i % 2]  # zero, then NaN quaternions only
    odom.publish(o)
# Odometry first: the merger has received some (none usable) before any scan.
sent = [0]
def odometry_ignored():
    bad_odom(sent[0])
    sent[0] += 1
    time.sleep(0.02)
    return any('zero quaternion ignored' in w for w in warnings)
wait_until(odometry_ignored, 'the merger ignoring odometry')
for i in range(20):
    bad_odom(i)
    s = LaserScan()
    s.header.stamp, s.header.frame_id = rospy.Time.now(), 'base_link'
    s.angle_min, s.angle_max, s.angle_increment = -1.0, 1.0, 0.1
    s.range_max, s.ranges = 10.0, [2.0] * 21
    scan.publish(s)
    time.sleep(0.1)
wait_until(lambda: len(merged) >= 10, 'ten merged scans', timeout=5.0)
print('merged', len(merged))
sys.stdout.flush()
'''


def test_unusable_odometry_is_named(ros_env):
    alive, feed, out = node_output_with_feed(
        ros_env, 'merger_o', 'odom_topic: o/odom\nsources: [{name: front, topic: o/scan}]', BAD_ODOM_FEED)
    assert alive, out
    assert int(feed.stdout.split()[-1]) >= 10, feed.stdout + feed.stderr  # merged without motion compensation
    assert 'zero quaternion ignored' in out and "none of the" in out and 'odometry messages' in out, out
    assert 'no odometry yet' not in out, out


LATE_FEED = r'''
import rospy
from sensor_msgs.msg import LaserScan
rospy.init_node('late_feed')
pubs = {n: rospy.Publisher('/late/%s' % n, LaserScan, queue_size=10) for n in ('front', 'rear')}
stamps = []
merged_sub = rospy.Subscriber('/merged_scan', LaserScan, lambda m: stamps.append(m.header.stamp.to_nsec()))
wait_connected(merged_sub, *pubs.values())
def send(name, t):
    s = LaserScan()
    s.header.stamp, s.header.frame_id = t, 'base_link'
    s.angle_min, s.angle_max, s.angle_increment = -1.0, 1.0, 0.1
    s.range_max, s.ranges = 10.0, [2.0] * 21
    pubs[name].publish(s)
    time.sleep(0.2)
t0 = rospy.Time.now()
for k in range(5):  # the rear scan arrives after the front one but is 0.4 ms older
    t = t0 + rospy.Duration(0.1 * k)
    send('front', t)
    send('rear', t - rospy.Duration(0.0004))
# What must not come (a second output of a stamp, after the last rear scan) has no event to
# wait for: the last rear scan has had 0.2 s in send(), and 0.5 s more here.
time.sleep(0.5)
print(len(stamps), len(set(stamps)), int(all(a < b for a, b in zip(stamps, stamps[1:]))))
sys.stdout.flush()
'''


def test_a_late_older_scan_gives_no_second_output_with_the_same_stamp(ros_env):
    _, feed, out = node_output_with_feed(
        ros_env, 'merger_late', 'odom_topic: ""\nsources: [{name: front, topic: late/front}, {name: rear, topic: late/rear}]',
        LATE_FEED)
    count, distinct, increasing = (int(v) for v in feed.stdout.split()[-3:])
    # one output per front scan (the late rear scans go into the next one), stamps all different
    assert count == 5 and distinct == 5 and increasing == 1, feed.stdout + feed.stderr + out


FEED = r'''
import rospy
from rosgraph_msgs.msg import Clock
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
rospy.init_node('jump_feed')
clock = rospy.Publisher('/clock', Clock, queue_size=10)
odom = rospy.Publisher('/j/odom', Odometry, queue_size=10)
scan = rospy.Publisher('/j/scan', LaserScan, queue_size=10)
after = [0]
merged_sub = rospy.Subscriber('/merged_scan', LaserScan,
                             lambda m: after.__setitem__(0, after[0] + (m.header.stamp.to_sec() < 90)))
wait_connected(clock, odom, scan, merged_sub)
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
wait_until(lambda: after[0] > 5, 'outputs after the jump', timeout=5.0)
print('after_jump_outputs', after[0])
sys.stdout.flush()
'''


def test_diagnostics_go_on_while_a_simulated_clock_stands_still(ros_env):
    """use_sim_time with a clock that does not move (a bag not yet playing, paused or ended): each
    source's status still comes every second of wall time, naming the merged scan topic."""
    subprocess.run(['rosparam', 'set', '/use_sim_time', 'true'], env=ros_env, check=True)
    try:
        set_params(ros_env, 'merger_clock', 'sources: [{name: front, topic: clock_test/scan}]')
        node = start(ros_env, 'merger_clock')
        try:
            r = subprocess.run(['rostopic', 'echo', '-n', '3', '/diagnostics'], env=ros_env, capture_output=True,
                               text=True, timeout=30)
        finally:
            node.stop()
    finally:
        subprocess.run(['rosparam', 'delete', '/use_sim_time'], env=ros_env)
    assert r.stdout.count('merger_clock: source front') == 3, r.stdout + r.stderr
    assert 'value: "/merged_scan"' in r.stdout, r.stdout


def test_time_jump_and_odometry_stop(ros_env):
    subprocess.run(['rosparam', 'set', '/use_sim_time', 'true'], env=ros_env, check=True)
    try:
        alive, feed, out = node_output_with_feed(
            ros_env, 'merger_j', 'odom_topic: j/odom\nsources: [{name: front, topic: j/scan, timeout: 0.5}]', FEED)
    finally:
        subprocess.run(['rosparam', 'delete', '/use_sim_time'], env=ros_env)
    assert alive, out
    print(out)
    assert 'odometry stopped' in out, out
    assert 'time jumped backwards' in out and 'buffers cleared' in out, out
    # Merged scans come again after the jump, on the new timeline.
    assert 'after_jump_outputs' in feed.stdout, feed.stdout + feed.stderr
    assert int(feed.stdout.split('after_jump_outputs')[1].split()[0]) > 5, feed.stdout


STAMP_FEED = r'''
import rospy
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage
rospy.init_node('stamp_feed')
tf = rospy.Publisher('/tf', TFMessage, queue_size=10)
scan = rospy.Publisher('/s/scan', LaserScan, queue_size=10)
merged = []
merged_sub = rospy.Subscriber('/merged_scan', LaserScan, lambda m: merged.append((time.time(), m.header.stamp)))
wait_connected(tf, scan, merged_sub)
bad = sys.argv[1]
def mount(stamp):
    t = TransformStamped()
    t.header.stamp, t.header.frame_id, t.child_frame_id = stamp, 'base_link', 'lidar'
    t.transform.translation.x, t.transform.rotation.w = 0.2, 1.0
    tf.publish(TFMessage(transforms=[t]))
def lidar(stamp):
    s = LaserScan()
    s.header.stamp, s.header.frame_id = stamp, 'lidar'
    s.angle_min, s.angle_max, s.angle_increment = -1.0, 1.0, 0.1
    s.range_max, s.ranges = 10.0, [2.0] * 21
    scan.publish(s)
for i in range(40):
    now = rospy.Time.now()
    if i == 15:
        mark = time.time()
        if bad == 'scan':
            lidar(rospy.Time(0))
        else:
            mount(now + rospy.Duration(1e9))
        time.sleep(0.05)
    mount(now)
    time.sleep(0.02)
    lidar(now)
    time.sleep(0.08)
wait_until(lambda: any(s == now for _, s in merged), 'the last scan merged', timeout=5.0)
print('zero_stamped', sum(1 for _, s in merged if s.is_zero()))
print('after', sum(1 for t, _ in merged if t > mark + 0.5))
sys.stdout.flush()
'''


@pytest.mark.parametrize('bad', ['scan', 'tf'])
def test_zero_and_far_ahead_stamps_are_malformed(ros_env, bad):
    # A scan stamped 0 used to clear every buffer (a "jump back") and give a merged scan stamped 0;
    # a /tf transform stamped far ahead used to poison tf2's cache: every later, valid transform
    # of that frame was refused as too old and the source disappeared without a word.
    alive, feed, out = node_output_with_feed(
        ros_env, 'merger_stamp_' + bad, 'odom_topic: ""\nsources: [{name: lidar, topic: s/scan, timeout: 0.5}]',
        STAMP_FEED, bad)
    assert alive, out
    counts = dict(line.split() for line in feed.stdout.splitlines() if line.startswith(('zero_stamped', 'after')))
    assert counts.get('zero_stamped') == '0', feed.stdout + feed.stderr + out
    assert int(counts.get('after', 0)) >= 10, feed.stdout + feed.stderr + out  # the source keeps merging
    assert 'buffers cleared' not in out, out
    if bad == 'scan':
        assert "source 'lidar'" in out and 'malformed scan dropped: stamp is zero' in out, out
    else:
        assert "transform 'base_link' -> 'lidar'" in out and 'ahead of the clock' in out, out


MOUNT_FEED = r'''
import rospy
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage
rospy.init_node('mount_feed')
tf = rospy.Publisher('/tf', TFMessage, queue_size=10, latch=True)
lidar = rospy.Publisher('/mm/lidar', LaserScan, queue_size=10)
rear = rospy.Publisher('/mm/rear', LaserScan, queue_size=10)
merged = []
merged_sub = rospy.Subscriber('/merged_scan', LaserScan, lambda m: merged.append(m))
wait_connected(tf, lidar, rear, merged_sub)
T = rospy.Time.now()
def mount(stamp, x):  # the lidar slides forward: x 0 at T - 1 s, 1 m from T on
    t = TransformStamped()
    t.header.stamp, t.header.frame_id, t.child_frame_id = stamp, 'base_link', 'lidar'
    t.transform.translation.x, t.transform.rotation.w = x, 1.0
    return t
tf.publish(TFMessage(transforms=[mount(T - rospy.Duration(1.0), 0.0), mount(T, 1.0),
                                 mount(T + rospy.Duration(1.0), 1.0)]))
time.sleep(0.5)  # the mounts' arrival in the merger cannot be seen from here (latched: they go at once)
def scan(pub, frame, stamp, a0, a1):
    s = LaserScan()
    s.header.stamp, s.header.frame_id = stamp, frame
    s.angle_min, s.angle_max, s.angle_increment = a0, a1, 0.05
    s.range_max, s.ranges = 10.0, [2.0] * (int(round((a1 - a0) / 0.05)) + 1)
    pub.publish(s)
scan(lidar, 'lidar', T, -0.5, 0.5)                           # kept, mount x = 1
time.sleep(0.3)
scan(lidar, 'lidar', T - rospy.Duration(0.5), -0.5, 0.5)     # older: discarded (mount x = 0.5)
time.sleep(0.3)
scan(rear, 'base_link', T + rospy.Duration(0.01), 2.5, 3.0)  # a merge with the kept lidar scan
wait_until(lambda: merged and merged[-1].header.stamp == T + rospy.Duration(0.01), "the rear scan's merge",
           timeout=5.0)  # any output of the discarded scan came before it
last = merged[-1]
i = int(round((0.0 - last.angle_min) / last.angle_increment))
print('outputs', len(merged), 'forward', last.ranges[i])
# A scan waiting for its transform (none before T - 1 s), superseded by a newer one: counted.
from diagnostic_msgs.msg import DiagnosticArray
status = {}
def on_diagnostics(msg):
    for st in msg.status:
        if st.name.endswith('source lidar'):
            status.update({kv.key: kv.value for kv in st.values})
rospy.Subscriber('/diagnostics', DiagnosticArray, on_diagnostics)
scan(lidar, 'lidar', T - rospy.Duration(1.5), -0.5, 0.5)
time.sleep(0.05)
scan(lidar, 'lidar', T + rospy.Duration(0.2), -0.5, 0.5)
wait_until(lambda: status.get('transform failures') == '1', 'the superseded scan counted', timeout=5.0)
print('transform_failures', status.get('transform failures'))
print('last_drop', status.get('last drop reason', '').replace(' ', '_'))
# A scan whose transform comes after it waits for it (laserscan_common's TransformWait) and is
# merged once it is there, with no further scan or odometry to retry it.
before = len(merged)
scan(lidar, 'lidar', T + rospy.Duration(2.0), -0.5, 0.5)
time.sleep(0.05)
tf.publish(TFMessage(transforms=[mount(T + rospy.Duration(2.1), 1.0)]))
deadline = time.time() + 5.0
while len(merged) == before and time.time() < deadline:
    time.sleep(0.02)
print('after_its_transform', len(merged) - before, merged[-1].header.stamp == T + rospy.Duration(2.0))
sys.stdout.flush()
'''


def test_a_discarded_older_scan_leaves_the_kept_scans_mount(ros_env):
    # The mount used to be stored when looked up, before accept() discarded the older scan: the
    # kept scan was then merged with the discarded one's mount (wrong with a moving mount).
    _, feed, out = node_output_with_feed(
        ros_env, 'merger_mm', 'odom_topic: ""\nsources: [{name: lidar, topic: mm/lidar, timeout: 2.0}, '
        '{name: rear, topic: mm/rear, timeout: 2.0}]', MOUNT_FEED)
    words = feed.stdout.split()
    assert 'forward' in words, feed.stdout + feed.stderr + out
    assert int(words[words.index('outputs') + 1]) == 2, feed.stdout + out  # the lidar's, then the rear's
    # The kept lidar scan (mount x = 1 m) sees 2 m ahead: 3 m from base_link (2.5 m with x = 0.5 m).
    assert abs(float(words[words.index('forward') + 1]) - 3.0) < 0.03, feed.stdout + out
    # A pending scan superseded by a newer one is counted, with the reason.
    assert words[words.index('transform_failures') + 1] == '1', feed.stdout + out
    assert 'before_a_newer_scan_was_merged' in words[words.index('last_drop') + 1], feed.stdout + out
    # A scan that waited for its transform is merged when the transform comes.
    assert words[words.index('after_its_transform') + 1:][:2] == ['1', 'True'], feed.stdout + out


SHARED_MANAGER_FEED = r'''
import json, sys, time, rospy
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import LaserScan
rospy.init_node('shared_manager_feed')
warnings = []
rosout = rospy.Subscriber('/rosout_agg', Log, lambda m: warnings.append(m.msg) if m.level >= Log.WARN else None)
pubs = {t: rospy.Publisher(t, LaserScan, queue_size=20) for t in ('/sm/front', '/sm/rear', '/sm/b_front')}
def wait_for(condition, what):
    deadline = time.time() + 60.0
    while not condition():
        if time.time() > deadline:
            print(json.dumps({'timeout': what, 'warnings': warnings}))
            sys.exit(0)
        time.sleep(0.1)
# Both mergers subscribed (they are loaded by then) and /rosout_agg connected.
wait_for(lambda: rosout.get_num_connections() > 0 and all(p.get_num_connections() > 0 for p in pubs.values()),
         'connections')
def scan(topic, frame_id='base_link', beams=2):
    s = LaserScan()
    s.header.stamp, s.header.frame_id = rospy.Time.now(), frame_id
    s.angle_min, s.angle_max, s.angle_increment = 0.0, 1.0, 0.1
    s.range_max, s.ranges = 10.0, [1.0] * beams  # 11 beams by the angles: 2 is the same fault everywhere
    pubs[topic].publish(s)
burst = int(sys.argv[1])
for _ in range(burst):  # one source, one fault, again and again
    scan('/sm/front')
scan('/sm/front', frame_id='', beams=11)  # the same source, another fault
scan('/sm/rear')                # the same merger, another source, the same fault
scan('/sm/b_front')             # another merger in the manager, a source of the same name
expected = json.loads(sys.argv[2])
# The last of them comes after the whole burst (one connection per source, in order; one
# /rosout stream): the burst's own warnings are in by then.
wait_for(lambda: all(any(all(part in w for part in e) for w in warnings) for e in expected), 'warnings')
print(json.dumps({'warnings': warnings}))
'''


def test_one_sources_warning_hides_no_other_sources_or_mergers_in_a_manager(ros_env):
    # ROS_WARN_THROTTLE keeps one timer per call site for the whole process: with two mergers
    # in one manager, the first malformed scan silenced every other source's and merger's for 5 s.
    sources = {'merger_sa': '[{name: front, topic: sm/front}, {name: rear, topic: sm/rear}]',
               'merger_sb': '[{name: front, topic: sm/b_front}]'}
    manager = subprocess.Popen(['rosrun', 'nodelet', 'nodelet', 'manager', '__name:=shared_manager'], env=ros_env,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    loaders = []
    try:
        for name, source_list in sources.items():
            set_params(ros_env, name, 'odom_topic: ""\nsources: %s' % source_list)
            loaders.append(subprocess.Popen(
                ['rosrun', 'nodelet', 'nodelet', 'load', 'multi_laserscan_merger/MultiLaserScanMergerNodelet',
                 '/shared_manager', '__name:=' + name, 'merged_scan:=/%s/merged_scan' % name],
                env=ros_env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        burst = 5
        ranges_fault = 'malformed scan dropped: ranges length does not match'
        expected = [["[/merger_sa] source 'front'", ranges_fault],
                    ["[/merger_sa] source 'front'", 'malformed scan dropped: empty frame_id'],
                    ["[/merger_sa] source 'rear'", ranges_fault],
                    ["[/merger_sb] source 'front'", ranges_fault]]
        feed = subprocess.run(['/usr/bin/python3', '-c', SHARED_MANAGER_FEED, str(burst), json.dumps(expected)],
                              env=ros_env, capture_output=True, text=True, timeout=180)
        alive = manager.poll() is None
    finally:
        for p in loaders + [manager]:
            p.send_signal(signal.SIGINT)
        for p in loaders + [manager]:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
    out = manager.communicate()[0]
    assert feed.returncode == 0, feed.stdout + feed.stderr
    result = json.loads(feed.stdout.strip().splitlines()[-1])
    assert 'timeout' not in result, (result, out)
    assert alive, out
    warnings = result['warnings']
    for parts in expected:  # each reported at once, none hidden by another's throttle
        assert any(all(p in w for p in parts) for w in warnings), (parts, warnings)
    # Still throttled per source and fault: the burst is not one warning per scan.
    front = [w for w in warnings if "[/merger_sa] source 'front'" in w and ranges_fault in w]
    assert 1 <= len(front) < burst, warnings


def test_a_clock_at_the_end_of_ros_time_does_not_end_the_node(ros_env):
    # diagnostic_updater schedules its next update at now() + 1 s: with a (simulated) clock within
    # 1 s of 2^32 s ros::Time throws, and out of the diagnostics timer that ended the process (a
    # whole nodelet manager). The status is skipped with a warning instead.
    subprocess.run(['rosparam', 'set', '/use_sim_time', 'true'], env=ros_env, check=True)
    try:
        set_params(ros_env, 'merger_end', 'odom_topic: ""\nsources: [{name: front, topic: end/scan}]')
        node = start(ros_env, 'merger_end')
        wait_started(node)
        with rostopic_pub(ros_env, '/clock', 'rosgraph_msgs/Clock', '{clock: {secs: 4294967295, nsecs: 500000000}}'):
            warned = node.wait_for('diagnostics not published', 'out of dual 32-bit range')
        alive = node.proc.poll() is None
        out = node.stop()
    finally:
        subprocess.run(['rosparam', 'delete', '/use_sim_time'], env=ros_env)
    assert warned and alive and node.proc.returncode == 0, out
