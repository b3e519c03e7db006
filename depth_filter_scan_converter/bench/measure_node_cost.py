#!/usr/bin/python3
"""Where the converter node's work per cloud goes, in instructions (valgrind's callgrind: the
same count on every run, unlike CPU time on a shared machine).

Starts its own roscore on a free port (the toolbox's Roscore) and the standalone converter node (shipped parameters)
under callgrind, instrumentation off until the node is connected; then a separate Python
process publishes N organized 320 x 163 clouds (52,160 points of 16 bytes, a camera 0.5 m high
looking forward at depths of 2-4 m) at 10 Hz and listens to the scans. The node's instructions
are split into

- transport: roscpp deserialising the clouds (MessageDeserializer::deserialize), what any node
  subscribing to them pays, without the conversion of a cloud read in place, which runs inside
  it (convertInPlace: counted as core and glue);
- core: Projector::project;
- glue: everything else (header checks, tf, the tf filter, scan allocation and publishing,
  diagnostics, roscpp's poll and timer threads).

Run after sourcing the build's devel/setup.bash (valgrind must be installed):

    /usr/bin/python3 depth_filter_scan_converter/bench/measure_node_cost.py [--clouds 100]
"""
import argparse
import contextlib
import os
import re
import subprocess
import sys
import tempfile

PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
from laserscan_toolbox.ros.rosrun import Roscore, package_executable

FEED = r"""
import os, sys, time, numpy as np, rospy
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import LaserScan, PointCloud2, PointField
from tf2_msgs.msg import TFMessage
count, flag = int(sys.argv[1]), sys.argv[2]
period = 1.0 / float(sys.argv[3]) if len(sys.argv) > 3 else 0.1
scan_topics = sys.argv[4].split(',') if len(sys.argv) > 4 else ['/scan']
rospy.init_node('node_cost_feed')
W, H = 320, 163
v, u = np.mgrid[0:H, 0:W].astype(np.float32)
z = 2.0 + 2.0 * np.random.default_rng(0).random((H, W)).astype(np.float32)
pts = np.zeros((H, W, 4), np.float32)
pts[..., 0], pts[..., 1], pts[..., 2] = (u - W / 2) / 300.0 * z, (v - H / 2) / 300.0 * z, z
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
pub = rospy.Publisher('/cloud_in', PointCloud2, queue_size=5)
scans = [0] * len(scan_topics)
subs = [rospy.Subscriber(topic, LaserScan, lambda s, i=i: scans.__setitem__(i, scans[i] + 1), queue_size=50)
        for i, topic in enumerate(scan_topics)]
# Every node subscribes to the clouds once a listener of its scan is there (lazy nodes).
while pub.get_num_connections() < len(scan_topics) or any(s.get_num_connections() == 0 for s in subs):
    time.sleep(0.05)
time.sleep(1.0)
print('ready', flush=True)
while not os.path.exists(flag):
    time.sleep(0.05)
for i in range(count):
    m.header.stamp = rospy.Time.now()
    pub.publish(m)
    time.sleep(period)
time.sleep(1.0)
print('scans', *scans, flush=True)
"""

# The conversion of a cloud read in place, which runs inside MessageDeserializer::deserialize.
IN_PLACE = r"DepthFilterScanConverter::convertInPlace\("
PARTS = {
    "transport": r"ros::MessageDeserializer::deserialize\(\)",
    "core": r"depth_filter_scan_converter::Projector::project\(",
}


@contextlib.contextmanager
def master(tmp, node_names=("conv",)):
    """A private roscore (the toolbox's Roscore: a free port, ROS_HOME and logs in tmp) with the
    shipped parameters loaded for each node name; yields the environment for the children."""
    with Roscore(tmp) as core:
        for name in node_names:
            subprocess.run(["rosparam", "load", os.path.join(PKG, "config", "depth_filter_scan_converter.yaml"),
                            "/" + name], env=core.env, check=True)
        yield core.env


def node_binary(env, executable):
    """The package's built program `executable` (the toolbox's package_executable)."""
    return package_executable(env, "depth_filter_scan_converter", executable)


def inclusive(annotated, pattern):
    for line in annotated.splitlines():
        if re.search(pattern, line):
            return int(line.split()[0].replace(",", ""))
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--clouds", type=int, default=100)
    ap.add_argument("--rate", type=float, default=10.0,
                    help="clouds per second; lower it if the node under callgrind cannot keep up")
    ap.add_argument("--executable", default="depth_filter_scan_converter_node",
                    help="the package's node to measure, e.g. per_point_reference_node (then its core is in glue)")
    ap.add_argument("params", nargs="*", help="extra arguments for the node, e.g. _mode:=per_point")
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="node_cost_")
    with master(tmp) as env:
        node = feed = None
        try:
            binary = node_binary(env, args.executable)
            out = os.path.join(tmp, "callgrind.out")
            node = subprocess.Popen(["valgrind", "--tool=callgrind", "--instr-atstart=no",
                                     "--callgrind-out-file=" + out, binary, "__name:=conv"] + args.params, env=env,
                                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            flag = os.path.join(tmp, "go")
            feed = subprocess.Popen([sys.executable, "-c", FEED, str(args.clouds), flag, str(args.rate)], env=env,
                                    stdout=subprocess.PIPE, text=True)
            assert feed.stdout.readline().strip() == "ready"
            subprocess.run(["callgrind_control", "-i", "on", str(node.pid)], check=True, capture_output=True)
            open(flag, "w").close()
            scans = int(feed.stdout.readline().split()[1])
            subprocess.run(["callgrind_control", "-i", "off", str(node.pid)], check=True, capture_output=True)
        finally:
            for p in (feed, node):
                if p is not None and p.poll() is None:
                    p.send_signal(2)
                    p.wait(timeout=60)
    annotated = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", out], capture_output=True,
                               text=True).stdout
    total = int(re.search(r"([0-9,]+) \(100.0%\)\s+PROGRAM TOTALS", annotated).group(1).replace(",", ""))
    parts = {name: inclusive(annotated, pattern) for name, pattern in PARTS.items()}
    # A cloud converted in roscpp's receive buffer (the usual case: the node reads it in place) is
    # converted inside the deserialiser: that conversion is not transport.
    parts["transport"] -= inclusive(annotated, IN_PLACE)
    parts["glue"] = total - sum(parts.values())
    print("%d clouds sent, %d scans back" % (args.clouds, scans))
    if scans < args.clouds:
        # The node under callgrind fell behind and dropped clouds, some before and some after
        # deserialising them: no divisor is right for every part.
        print("the node dropped clouds: figures not per cloud, run again with a lower --rate", file=sys.stderr)
        return 3
    print("| part | instructions per cloud | share |")
    print("|---|---|---|")
    for name in ("transport", "core", "glue"):
        print("| %s | %.0f k | %.1f %% |" % (name, parts[name] / args.clouds / 1e3, 100.0 * parts[name] / total))
    print("glue / core: %.3f" % (parts["glue"] / parts["core"] if parts["core"] else float("nan")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
