"""The converter against faulty transforms on /tf, with a private roscore: a transform stamped
near 2^32 s (tf2 adds its cache length to the stamp, roscpp throws "Time is out of dual 32-bit
range", and through tf2_ros::TransformListener that aborted the process and a whole nodelet
manager) and one with an infinite translation (tf2 refuses only NaN) are ignored, each named in a
warning, and clouds keep being converted. So are the transforms tf2 refuses itself, but with
an unthrottled error per message (no child frame, a frame its own parent, a zero quaternion), and
/tf transforms stamped 0 or more than tf2's cache length ahead of the clock (one far ahead made
tf2 refuse every later transform of that frame as too old).
A cloud whose camera -> robot transform is not finite (a chain of finite transforms can sum to
infinity) is dropped and counted with that reason, not published as a scan of no returns."""
import json
import subprocess
import sys

import pytest

from test_startup_and_tuning import load_params, start, stop

FEED = r"""
import json, math, struct, sys, time
import rospy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import LaserScan, PointCloud2, PointField
from tf2_msgs.msg import TFMessage

rospy.init_node('tf_fault_feed')
tf = rospy.Publisher('/tf', TFMessage, queue_size=10)
tf_static = rospy.Publisher('/tf_static', TFMessage, queue_size=10, latch=True)
clouds = rospy.Publisher('/cloud_in', PointCloud2, queue_size=10)
scans = {}  # frame of the cloud (told by its stamp) -> scans received
sent = {}
diag = []
def on_scan(m):
    frame = sent.get(m.header.stamp.to_nsec())
    scans.setdefault(frame, []).append(sum(1 for r in m.ranges if math.isfinite(r)))
rospy.Subscriber('/scan', LaserScan, on_scan, queue_size=100)
rospy.Subscriber('/diagnostics', DiagnosticArray, lambda m: diag.append(m), queue_size=100)

def transform(parent, child, x, secs=None):
    t = TransformStamped()
    t.header.frame_id, t.child_frame_id = parent, child
    if secs is not None:
        t.header.stamp.secs = secs
    t.transform.translation.x = x
    t.transform.translation.z = 0.3
    t.transform.rotation.w = 1.0
    return t

def cloud(frame):
    m = PointCloud2()
    m.header.stamp, m.header.frame_id = rospy.Time.now(), frame
    m.height, m.width = 1, 20
    m.fields = [PointField(name=n, offset=4 * i, datatype=PointField.FLOAT32, count=1) for i, n in enumerate('xyz')]
    m.point_step, m.row_step = 12, 12 * 20
    m.data = b''.join(struct.pack('<fff', 2.0, -0.5 + 0.05 * i, 0.0) for i in range(20))
    sent[m.header.stamp.to_nsec()] = frame
    return m

deadline = time.time() + 20
while (clouds.get_num_connections() == 0 or tf.get_num_connections() == 0) and time.time() < deadline:
    time.sleep(0.05)
# A finite chain whose sum is not: base_link -> far -> far_camera, 1e308 m each.
tf_static.publish(TFMessage([transform('base_link', 'camera', 0.0), transform('base_link', 'far', 1e308),
                             transform('far', 'far_camera', 1e308)]))
time.sleep(0.5)
tf.publish(TFMessage([transform('base_link', 'late', 0.0, secs=4294967290)]))
tf.publish(TFMessage([transform('base_link', 'lidar', math.inf)]))
# What tf2 refuses itself, but with an error per message: ours are throttled per frame pair.
zero_rotation = transform('base_link', 'tilted', 0.0)
zero_rotation.transform.rotation.w = 0.0
for i in range(5):
    tf.publish(TFMessage([zero_rotation, transform('base_link', 'base_link', 0.0), transform('base_link', '', 0.0)]))
time.sleep(0.5)
for i in range(20):
    clouds.publish(cloud('camera' if i % 2 == 0 else 'far_camera'))
    time.sleep(0.1)
# A camera on a moving mount (/tf). A transform of it stamped 60 s ahead would make tf2 refuse
# every later one as too old (its cache is 10 s), and a dynamic one stamped 0 is unset: both are
# ignored under the merger's rules for measurements, and the valid ones that follow are used.
def at(t, stamp):
    t.header.stamp = stamp
    return t
tf.publish(TFMessage([transform('base_link', 'moving', 0.0, secs=rospy.Time.now().secs + 60),
                      transform('base_link', 'unset', 0.0, secs=0)]))
time.sleep(0.3)
for i in range(10):
    m = cloud('moving')
    tf.publish(TFMessage([at(transform('base_link', 'moving', 0.0), m.header.stamp)]))
    clouds.publish(m)
    time.sleep(0.1)
tf.publish(TFMessage([at(transform('base_link', 'moving', 0.0), rospy.Time.now())]))
time.sleep(2.5)
last_tf = [v.value for m in diag for s in m.status for v in s.values if v.key == 'last transform failure']
failures = [int(v.value) for m in diag for s in m.status for v in s.values if v.key == 'transform failures']
print(json.dumps({'camera': scans.get('camera', []), 'far_camera': scans.get('far_camera', []),
                  'moving': scans.get('moving', []),
                  'last_tf': last_tf[-1] if last_tf else '', 'failures': max(failures) if failures else 0}))
"""


@pytest.mark.parametrize("nodelet", [False, True])
def test_faulty_transforms_are_ignored_and_conversion_goes_on(ros_env, nodelet):
    name = "conv_tf_nodelet" if nodelet else "conv_tf"
    load_params(ros_env, name)
    p = start(ros_env, name, nodelet=nodelet)
    try:
        feed = subprocess.run([sys.executable, "-c", FEED], env=ros_env, capture_output=True, text=True, timeout=60)
        alive = p.poll() is None
    finally:
        out = stop(p)
    assert alive, out
    assert feed.returncode == 0, feed.stderr
    result = json.loads(feed.stdout.strip().splitlines()[-1])
    # Both faulty transforms are named, and the clouds of the good camera are converted.
    assert "'base_link' -> 'late' from /tf_fault_feed" in out and "4294967290.000000000" in out, out
    assert "'base_link' -> 'lidar'" in out and "not finite" in out, out
    assert "'base_link' -> 'tilted'" in out and "not a unit quaternion" in out, out
    assert "own parent" in out and "child_frame_id is empty" in out, out
    assert out.count("'base_link' -> 'tilted'") == 1 and "TF_" not in out, out  # throttled; tf2 never logs
    assert len(result["camera"]) >= 8 and min(result["camera"]) == 20, (result, out)
    # The camera whose transform sums to infinity gets no scan, and the drops are counted and named.
    assert result["far_camera"] == [], (result, out)
    assert "not finite" in result["last_tf"] and result["failures"] >= 8, (result, out)
    assert "'far_camera'" in out and "not finite" in out, out
    # /tf stamped far ahead of the clock or 0 is ignored and named; the moving camera's clouds go on.
    assert "'base_link' -> 'moving' from /tf_fault_feed on /tf" in out and "ahead of the clock" in out, out
    assert "'base_link' -> 'unset'" in out and "stamp is zero" in out, out
    assert len(result["moving"]) >= 8 and min(result["moving"]) == 20, (result, out)
