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
import time

HERE = os.path.dirname(os.path.abspath(__file__))
PKG = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(PKG, "bench"))
from measure_node_cost import free_port  # noqa: E402

# Publishes one static tf and one organized cloud (a camera 0.5 m high looking forward at a room
# of boxes, some points NaN) until both scans came back; prints them as JSON.
LISTEN = r"""
import json, math, time, numpy as np, rospy
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import LaserScan, PointCloud2, PointField
from tf2_msgs.msg import TFMessage
rospy.init_node('per_point_check')
rng = np.random.default_rng(3)
W, H = 200, 120
v, u = np.mgrid[0:H, 0:W].astype(np.float32)
depth = np.where(u < 70, 1.5, np.where(u < 140, 3.0, 2.2)).astype(np.float32) + 0.3 * rng.random((H, W), np.float32)
depth[rng.random((H, W)) < 0.05] = np.nan
pts = np.zeros((H, W, 4), np.float32)
pts[..., 0], pts[..., 1], pts[..., 2] = (u - W / 2) / 150.0 * depth, (v - H / 2) / 150.0 * depth, depth
m = PointCloud2()
m.header.frame_id, m.height, m.width = 'camera', H, W
m.fields = [PointField(name=c, offset=4 * i, datatype=PointField.FLOAT32, count=1) for i, c in enumerate('xyz')]
m.point_step, m.row_step, m.data = 16, 16 * W, pts.tobytes()
t = TransformStamped()
t.header.frame_id, t.child_frame_id = 'base_link', 'camera'
t.transform.translation.z = 0.5
t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z, t.transform.rotation.w = -0.5, 0.5, -0.5, 0.5
static = rospy.Publisher('/tf_static', TFMessage, queue_size=1, latch=True)
static.publish(TFMessage([t]))
scans = {}
subs = [rospy.Subscriber(n, LaserScan, lambda s, n=n: scans.setdefault(n, list(s.ranges)), queue_size=5)
        for n in ('/scan_converter', '/scan_per_point')]
pub = rospy.Publisher('/cloud_in', PointCloud2, queue_size=5)
deadline = time.time() + 60
while len(scans) < 2 and time.time() < deadline:
    m.header.stamp = rospy.Time.now()
    pub.publish(m)
    time.sleep(0.3)
print(json.dumps({k: [None if not math.isfinite(r) else r for r in v] for k, v in scans.items()}), flush=True)
"""


def test_per_point_node_finds_the_converters_closest_points():
    tmp = tempfile.mkdtemp(prefix="per_point_test_")
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:%d" % port, ROS_HOME=tmp, ROS_LOG_DIR=tmp)
    procs = [subprocess.Popen(["roscore", "-p", str(port)], env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)]
    try:
        while subprocess.run(["rosparam", "list"], env=env, capture_output=True).returncode != 0:
            time.sleep(0.3)
        for name in ("conv", "ref"):
            subprocess.run(["rosparam", "load", os.path.join(PKG, "config", "depth_filter_scan_converter.yaml"),
                            "/" + name], env=env, check=True)
        for exe, args in (("depth_filter_scan_converter_node", ["__name:=conv", "scan:=/scan_converter"]),
                          ("per_point_reference_node", ["__name:=ref", "scan:=/scan_per_point", "_mode:=per_point"])):
            binary = subprocess.run(["catkin_find", "--libexec", "depth_filter_scan_converter", exe], env=env,
                                    capture_output=True, text=True).stdout.split()
            assert binary, "%s not built" % exe
            procs.append(subprocess.Popen([binary[0]] + args, env=env, stdout=subprocess.DEVNULL,
                                          stderr=subprocess.DEVNULL))
        out = subprocess.run([sys.executable, "-c", LISTEN], env=env, capture_output=True, text=True, timeout=120)
        scans = json.loads(out.stdout.strip().splitlines()[-1])
    finally:
        for p in reversed(procs):
            p.send_signal(2)
            p.wait(timeout=30)
    inf = math.inf
    conv = [inf if r is None else r for r in scans["/scan_converter"]]
    ref = [inf if r is None else r for r in scans["/scan_per_point"]]
    assert len(conv) == len(ref) == 1441
    hits = [b for b in range(1441) if ref[b] < inf]
    assert len(hits) > 50  # the camera's 87 degrees at 0.25 degree per beam, most of them hit
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
    for row in ("transport baseline", "depth_filter_scan_converter_node", "per-point node"):
        assert "| %s" % row in out.stdout
    assert "per-point node / converter node, above transport:" in out.stdout
