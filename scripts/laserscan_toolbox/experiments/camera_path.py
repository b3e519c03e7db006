"""CPU per depth frame of one camera's path to a scan, in one nodelet manager (issue 9).

Two paths get the same 16UC1 depth frames (+ camera_info, rendered by the simulator):

- image: depth_filter_scan_converter/DepthImageScanConverterNodelet (depth image -> scan);
- cloud: depth_image_proc/point_cloud_xyz + depth_filter_scan_converter/DepthFilterScanConverterNodelet
  (depth image -> PointCloud2 -> scan, zero-copy between the two inside the manager);
- baseline: the image path reading one pixel per frame (row_stride and column_stride larger
  than the image): what receiving the frames over TCP, matching camera_info, tf and publishing
  cost, i.e. what no converter can save unless the camera driver runs in the same manager.

Each run starts a fresh manager (one worker thread) with one path, publishes the frames from
this process at a fixed rate and measures the manager's CPU (user + system) over the frames,
divided by the scans that came back (point_cloud_xyz's camera subscriber lets a few frames go
unconverted; the scans per frame are reported). Both paths receive the same serialised frames,
so the transport into the manager is in both figures; the ratio is cloud / image.
"""

import dataclasses
import os
import subprocess
import sys
import time

import numpy as np
import yaml

from ..evaluation.report import fmt, table
from ..ros.rosrun import REPO, Master, RunError, stop_process
from .transport import cpu_delta, cpu_snapshot

PATHS = ("baseline", "image", "cloud")
CONFIG = os.path.join(REPO, "config", "sim_robot", "camera_left_converter.yaml")
TOPIC = "/bench_camera/depth"


def render_frames(width, height, count, seed=0):
    """(camera, [(depth uint16 mm array, rel time)]) of the default scenario's left camera at width x height."""
    from ..simulation.scenario import Scenario
    sc = Scenario.default(seed=seed)
    cam = dataclasses.replace([c for c in sc.robot.cameras if c.name == "camera_left"][0],
                              width=width, height=height)
    rng = np.random.default_rng(seed)
    frames = []
    for k in range(count):
        rel = 0.5 + 3.0 * k / max(count, 1)
        frames.append((np.round(sc.depth_image(cam, rel, rng) * 1000.0).astype("<u2"), rel))
    return sc, cam, frames


def figures(runs):
    """runs: [{"path", "cpu_ms_per_frame"}] -> {path: median ms per frame}, "ratio" (cloud / image)
    and "ratio_above_baseline" ((cloud - baseline) / (image - baseline))."""
    out = {}
    for path in PATHS:
        v = [r["cpu_ms_per_frame"] for r in runs if r["path"] == path and np.isfinite(r["cpu_ms_per_frame"])]
        out[path] = float(np.median(v)) if v else float("nan")
    out["ratio"] = out["cloud"] / out["image"] if out["image"] > 0 else float("nan")
    above = out["image"] - out["baseline"]
    out["ratio_above_baseline"] = (out["cloud"] - out["baseline"]) / above if above > 0 else float("nan")
    return out


class _Frames:
    """Publishes frames (image, camera_info, static tf) and counts the scans that come back."""

    def __init__(self, cam, frames):
        import rospy
        import tf2_ros
        from geometry_msgs.msg import TransformStamped
        from sensor_msgs.msg import CameraInfo, Image, LaserScan
        from ..simulation.robot import quat_from_matrix
        from ..simulation.scenario import Scenario
        self.rospy, self.Image, self.CameraInfo, self.Scenario = rospy, Image, CameraInfo, Scenario
        self.cam, self.frames = cam, frames
        self.image_pub = rospy.Publisher(TOPIC + "/image_rect", Image, queue_size=5)
        self.info_pub = rospy.Publisher(TOPIC + "/camera_info", CameraInfo, queue_size=5)
        self.scans = 0
        self.scan_sub = rospy.Subscriber("/bench_camera/scan", LaserScan, self._on_scan, queue_size=50)
        rot, pos = cam.optical_in_base(0.0)
        t = TransformStamped()
        t.header.stamp = rospy.Time.now()
        t.header.frame_id, t.child_frame_id = "base_link", cam.optical_frame
        t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = (float(v) for v in pos)
        (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
         t.transform.rotation.w) = quat_from_matrix(rot)
        self.static_tf = tf2_ros.StaticTransformBroadcaster()
        self.static_tf.sendTransform(t)

    def _on_scan(self, _msg):
        self.scans += 1

    def publish(self, k):
        depth, _ = self.frames[k % len(self.frames)]
        img = self.Image()
        img.header.stamp = self.rospy.Time.now()
        img.header.frame_id = self.cam.optical_frame
        img.height, img.width = depth.shape
        img.encoding, img.is_bigendian, img.step = "16UC1", 0, 2 * depth.shape[1]
        img.data = depth.tobytes()
        self.image_pub.publish(img)
        self.info_pub.publish(self.Scenario.camera_info(self.cam, img.header, self.CameraInfo))

    def close(self):
        self.scan_sub.unregister()
        self.image_pub.unregister()
        self.info_pub.unregister()


def _start(cmd, log):
    with open(log, "w") as f:
        return subprocess.Popen(cmd, stdout=f, stderr=subprocess.STDOUT, start_new_session=True)


def measure(path, pub, frames, rate, workdir, label):
    """One run of one path in a fresh manager. Returns its figures."""
    import psutil
    import rosgraph
    with open(CONFIG) as f:
        params = yaml.safe_load(f)
    params["publish_filtered_cloud"] = False
    if path == "baseline":
        params["row_stride"] = params["column_stride"] = 1000000
    rosgraph.Master("/camera_path_benchmark").setParam("/bench_converter", params)
    procs = []
    try:
        manager = _start(["rosrun", "nodelet", "nodelet", "manager", "__name:=bench_manager",
                          "_num_worker_threads:=1"], os.path.join(workdir, label + "_manager.log"))
        procs.append(manager)
        kind = "DepthFilterScanConverterNodelet" if path == "cloud" else "DepthImageScanConverterNodelet"
        procs.append(_start(["rosrun", "nodelet", "nodelet", "load", "depth_filter_scan_converter/" + kind,
                             "/bench_manager", "__name:=bench_converter", "image:=" + TOPIC + "/image_rect",
                             "camera_info:=" + TOPIC + "/camera_info", "cloud_in:=" + TOPIC + "/points",
                             "scan:=/bench_camera/scan"], os.path.join(workdir, label + "_converter.log")))
        if path == "cloud":
            procs.append(_start(["rosrun", "nodelet", "nodelet", "load", "depth_image_proc/point_cloud_xyz",
                                 "/bench_manager", "__name:=bench_points", "image_rect:=" + TOPIC + "/image_rect",
                                 "camera_info:=" + TOPIC + "/camera_info", "points:=" + TOPIC + "/points"],
                                os.path.join(workdir, label + "_points.log")))
        # Warm up: frames until scans come back (subscriptions are lazy and made in the background).
        deadline = time.time() + 30.0
        k = 0
        while pub.scans < 3:
            if time.time() > deadline or manager.poll() is not None:
                raise RunError("%s path: no scan came back (see %s)" % (path, workdir))
            pub.publish(k)
            k += 1
            time.sleep(1.0 / rate)
        time.sleep(0.5)
        mgr = psutil.Process(manager.pid)
        before, scans0 = cpu_snapshot([mgr]), pub.scans
        for i in range(frames):
            pub.publish(k + i)
            time.sleep(1.0 / rate)
        deadline = time.time() + 5.0
        while pub.scans - scans0 < frames and time.time() < deadline:
            time.sleep(0.05)
        cpu = cpu_delta(before, cpu_snapshot([mgr]))["total_s"]
        scans = pub.scans - scans0
        return {"path": path, "frames": frames, "scans": scans, "cpu_s": cpu,
                "cpu_ms_per_frame": 1000.0 * cpu / scans if scans else float("nan")}
    finally:
        for p in reversed(procs):
            stop_process(p)


def experiment(width=640, height=480, frames=150, rate=15.0, repeat=2, workdir=None, log=print):
    import tempfile
    workdir = workdir or tempfile.mkdtemp(prefix="camera_path_benchmark_")
    _, cam, rendered = render_frames(width, height, 8)
    runs = []
    with Master(workdir, sim_time=False):
        import rospy
        rospy.init_node("camera_path_benchmark", anonymous=True, disable_signals=True)
        pub = _Frames(cam, rendered)
        try:
            for r in range(repeat):
                for path in PATHS:
                    run = measure(path, pub, frames, rate, workdir, "%s_%d" % (path, r))
                    runs.append(run)
                    log("%s path, run %d: %d scans of %d frames, manager CPU %.3f ms per frame"
                        % (path, r + 1, run["scans"], frames, run["cpu_ms_per_frame"]))
        finally:
            pub.close()
            rospy.signal_shutdown("done")
    return {"width": width, "height": height, "frames": frames, "rate": rate, "runs": runs,
            "figures": figures(runs)}


def markdown(res):
    f = res["figures"]
    def scans(path):
        runs = [r for r in res["runs"] if r["path"] == path]
        return "%d / %d" % (sum(r["scans"] for r in runs), sum(r["frames"] for r in runs))
    def above(path):
        return fmt(f[path] - f["baseline"], 1, 3)
    rows = [["baseline: transport, camera_info, tf, publishing (image path reading one pixel)",
             fmt(f["baseline"], 1, 3), "", scans("baseline")],
            ["depth image -> scan (DepthImageScanConverterNodelet)", fmt(f["image"], 1, 3), above("image"),
             scans("image")],
            ["point_cloud_xyz + cloud converter", fmt(f["cloud"], 1, 3), above("cloud"), scans("cloud")]]
    return "\n".join([
        "Manager CPU per %dx%d 16UC1 frame (median of %d runs of %d frames at %.0f Hz each): "
        "cloud path / image path = **%sx** in all, **%sx** above the baseline." % (
            res["width"], res["height"], len(res["runs"]) // len(PATHS), res["frames"], res["rate"],
            fmt(f["ratio"], 1, 1), fmt(f["ratio_above_baseline"], 1, 1)),
        "", table(["path", "manager CPU per scan [ms]", "above the baseline [ms]", "scans / frames"], rows), ""])


def main(argv=None):
    import argparse
    p = argparse.ArgumentParser(
        prog="camera_path_benchmark",
        description="CPU per depth frame of the depth-image converter against point_cloud_xyz + the "
                    "cloud converter, each in one nodelet manager. Exit status: 0 done, 2 usage "
                    "error, 3 a run failed.")
    p.add_argument("--width", type=int, default=640)
    p.add_argument("--height", type=int, default=480)
    p.add_argument("--frames", type=int, default=150, help="measured frames per run")
    p.add_argument("--rate", type=float, default=15.0, help="frames per second")
    p.add_argument("--repeat", type=int, default=2, help="runs per path")
    try:
        a = p.parse_args(argv)
    except SystemExit as e:
        return 2 if e.code else 0
    if min(a.width, a.height, a.frames, a.repeat) < 1 or not 0 < a.rate <= 100:
        print("camera_path_benchmark: sizes, frames and repeat must be >= 1, rate in (0, 100]",
              file=sys.stderr)
        return 2
    try:
        res = experiment(a.width, a.height, a.frames, a.rate, a.repeat,
                         log=lambda m: print(m, file=sys.stderr))
    except RunError as e:
        print("camera_path_benchmark: %s" % e, file=sys.stderr)
        return 3
    print(markdown(res))
    return 0
