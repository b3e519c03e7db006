"""CPU per depth frame of one camera's path to a scan, in one nodelet manager (issue 9).

Two paths get the same 16UC1 depth frames (+ camera_info, rendered by the simulator), from one of
two sources:

- ``manager`` (default): the frames come from a camera stand-in inside the same manager
  (depth_filter_scan_converter/DepthReplayNodelet: it records the rendered frames once, then
  publishes them by shared pointer at the fixed rate, as a camera driver nodelet does), so both
  paths get them zero-copy; the baseline ``source`` is the manager with the stand-in alone. Each
  path's figure is CPU per frame published (counted on camera_info);
- ``tcp``: the frames are published from this process over TCP (a camera driver in a process of
  its own); the baseline is as described below, and figures are CPU per scan.

The paths:

- image: depth_filter_scan_converter/DepthImageScanConverterNodelet (depth image -> scan);
- cloud: depth_image_proc/point_cloud_xyz + depth_filter_scan_converter/DepthFilterScanConverterNodelet
  (depth image -> PointCloud2 -> scan, zero-copy between the two inside the manager);
- baseline: the image path reading one pixel per frame (row_stride and column_stride larger
  than the image): what receiving the frames over TCP, matching camera_info, tf and publishing
  cost, i.e. what no converter can save unless the camera driver runs in the same manager.

Each run starts a fresh manager (one worker thread) with one path, publishes the frames from
this process at a fixed rate and measures the manager's CPU (user + system) over the frames,
divided by the scans that came back (point_cloud_xyz's camera subscriber lets a few frames go
unconverted; the scans per frame are reported). With ``tcp``, both paths receive the same
serialised frames, so the transport into the manager is in both figures; the ratio is cloud / image.
With ``manager``, the scans go to this process over TCP in both paths (a few us per scan).
"""

import dataclasses
import os
import subprocess
import sys
import time

import numpy as np
import yaml

from ..evaluation.report import fmt, table
from ..ros.cpu_accounting import process_cpu_s
from ..ros.rosrun import REPO, Master, RunError, stop_process

PATHS = ("baseline", "image", "cloud")
MANAGER_PATHS = ("source", "image", "cloud")
SOURCES = {"manager": MANAGER_PATHS, "tcp": PATHS}
CONFIG = os.path.join(REPO, "config", "sim_robot", "camera_left_converter.yaml")
TOPIC = "/bench_camera/depth"
RECORDED = "/bench_camera/recorded"  # what the stand-in records (source "manager")


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


def figures(runs, paths=PATHS):
    """runs: [{"path", "cpu_ms_per_frame"}] -> {path: median ms per frame}, "ratio" (cloud / image)
    and "ratio_above_baseline" ((cloud - baseline) / (image - baseline)), the baseline being
    paths[0] (also under the key "baseline")."""
    out = {}
    for path in paths:
        v = [r["cpu_ms_per_frame"] for r in runs if r["path"] == path and np.isfinite(r["cpu_ms_per_frame"])]
        out[path] = float(np.median(v)) if v else float("nan")
    out["baseline"] = out[paths[0]]
    out["ratio"] = out["cloud"] / out["image"] if out["image"] > 0 else float("nan")
    above = out["image"] - out["baseline"]
    out["ratio_above_baseline"] = (out["cloud"] - out["baseline"]) / above if above > 0 else float("nan")
    return out


class _Frames:
    """Publishes frames (image, camera_info on `topic`, static tf) and counts the scans that come
    back and, with count_frames, the camera_infos the manager publishes on TOPIC."""

    def __init__(self, cam, frames, topic=TOPIC, count_frames=False):
        import rospy
        import tf2_ros
        from geometry_msgs.msg import TransformStamped
        from sensor_msgs.msg import CameraInfo, Image, LaserScan
        from ..simulation.robot import quat_from_matrix
        from ..simulation.scenario import Scenario
        self.rospy, self.Image, self.CameraInfo, self.Scenario = rospy, Image, CameraInfo, Scenario
        self.cam, self.frames = cam, frames
        self.image_pub = rospy.Publisher(topic + "/image_rect", Image, queue_size=5)
        self.info_pub = rospy.Publisher(topic + "/camera_info", CameraInfo, queue_size=5)
        self.scans = self.frames_out = 0
        self.scan_sub = rospy.Subscriber("/bench_camera/scan", LaserScan, self._on_scan, queue_size=50)
        self.frame_sub = rospy.Subscriber(TOPIC + "/camera_info", CameraInfo, self._on_frame,
                                          queue_size=50) if count_frames else None
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

    def _on_frame(self, _msg):
        self.frames_out += 1

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
        if self.frame_sub:
            self.frame_sub.unregister()
        self.image_pub.unregister()
        self.info_pub.unregister()


def _start(cmd, log):
    with open(log, "w") as f:
        return subprocess.Popen(cmd, stdout=f, stderr=subprocess.STDOUT, start_new_session=True)


def _load(nodelet, name, remaps, workdir, label):
    return _start(["rosrun", "nodelet", "nodelet", "load", nodelet, "/bench_manager", "__name:=" + name] + remaps,
                  os.path.join(workdir, "%s_%s.log" % (label, name)))


def _feed_until(pub, done, rate, what, manager, workdir):
    """Publishes frames (from this process) until done() holds; k of the next frame."""
    deadline = time.time() + 30.0
    k = 0
    while not done():
        if time.time() > deadline or manager.poll() is not None:
            raise RunError("%s (see %s)" % (what, workdir))
        pub.publish(k)
        k += 1
        time.sleep(1.0 / rate)
    return k


def converter_params(config, path, range_noise=True):
    """The converters' parameters for one path: the config's, without the filtered cloud and the
    self filter, the range noise model off when `range_noise` is false, one pixel read on the
    baseline path."""
    with open(config) as f:
        params = yaml.safe_load(f)
    params["publish_filtered_cloud"] = False
    # The bench camera stands alone: no robot description, no arm on tf (the self filter's cost
    # is measured in the converter core's benchmark, with a 6-link arm).
    params.pop("self_filter", None)
    if not range_noise:
        # The converter's default: no range noise model (its extra passes cost both paths alike).
        params["range_noise_std"] = params["range_noise_std_per_m2"] = 0.0
    if path == "baseline":
        params["row_stride"] = params["column_stride"] = 1000000
    return params


def measure(path, pub, frames, rate, workdir, label, source="tcp", config=CONFIG, range_noise=True):
    """One run of one path in a fresh manager, the frames from `source` ("tcp": published by `pub`;
    "manager": the stand-in nodelet, fed once by `pub`). Returns its figures."""
    import rosgraph
    params = converter_params(config, path, range_noise)
    rosgraph.Master("/camera_path_benchmark").setParam("/bench_converter", params)
    procs = []
    try:
        manager = _start(["rosrun", "nodelet", "nodelet", "manager", "__name:=bench_manager",
                          "_num_worker_threads:=1"], os.path.join(workdir, label + "_manager.log"))
        procs.append(manager)
        if source == "manager":
            rosgraph.Master("/camera_path_benchmark").setParam(
                "/bench_replay", {"rate": float(rate), "frames": len(pub.frames)})
            procs.append(_load("depth_filter_scan_converter/DepthReplayNodelet", "bench_replay",
                               ["image_in:=" + RECORDED + "/image_rect", "camera_info_in:=" + RECORDED + "/camera_info",
                                "image:=" + TOPIC + "/image_rect", "camera_info:=" + TOPIC + "/camera_info"],
                               workdir, label))
        if path != "source":
            kind = "DepthFilterScanConverterNodelet" if path == "cloud" else "DepthImageScanConverterNodelet"
            procs.append(_load("depth_filter_scan_converter/" + kind, "bench_converter",
                               ["image:=" + TOPIC + "/image_rect", "camera_info:=" + TOPIC + "/camera_info",
                                "cloud_in:=" + TOPIC + "/points", "scan:=/bench_camera/scan"], workdir, label))
        if path == "cloud":
            procs.append(_load("depth_image_proc/point_cloud_xyz", "bench_points",
                               ["image_rect:=" + TOPIC + "/image_rect", "camera_info:=" + TOPIC + "/camera_info",
                                "points:=" + TOPIC + "/points"], workdir, label))
        if source == "manager":
            frames0 = pub.frames_out
            _feed_until(pub, lambda: pub.frames_out > frames0, rate, "the replay nodelet published nothing",
                        manager, workdir)
            # Warm up: scans come back (subscriptions are lazy and made in the background).
            deadline, scans0 = time.time() + 30.0, pub.scans
            while (pub.scans - scans0 if path != "source" else pub.frames_out - frames0) < 3:
                if time.time() > deadline or manager.poll() is not None:
                    raise RunError("%s path: no scan came back (see %s)" % (path, workdir))
                time.sleep(0.05)
            time.sleep(0.5)
            before, scans0, frames0 = process_cpu_s(manager.pid), pub.scans, pub.frames_out
            time.sleep(frames / rate)
            cpu = process_cpu_s(manager.pid) - before
            # Counted as they arrive here, at both ends of the window: the same delay at both.
            published, scans = pub.frames_out - frames0, pub.scans - scans0
            per = published
        else:
            scans0 = pub.scans
            k = _feed_until(pub, lambda: pub.scans - scans0 >= 3, rate, "%s path: no scan came back" % path, manager,
                            workdir)
            time.sleep(0.5)
            before, scans0 = process_cpu_s(manager.pid), pub.scans
            for i in range(frames):
                pub.publish(k + i)
                time.sleep(1.0 / rate)
            deadline = time.time() + 5.0
            while pub.scans - scans0 < frames and time.time() < deadline:
                time.sleep(0.05)
            cpu = process_cpu_s(manager.pid) - before
            published, scans = frames, pub.scans - scans0
            per = scans
        return {"path": path, "frames": published, "scans": scans, "cpu_s": cpu,
                "cpu_ms_per_frame": 1000.0 * cpu / per if per else float("nan")}
    finally:
        for p in reversed(procs):
            stop_process(p)


def experiment(width=640, height=480, frames=150, rate=15.0, repeat=2, workdir=None, log=print,
               sources=("manager", "tcp"), config=CONFIG, range_noise=True):
    """{source: results} for each source of frames ("manager", "tcp"; see the module's doc)."""
    import tempfile
    workdir = workdir or tempfile.mkdtemp(prefix="camera_path_benchmark_")
    _, cam, rendered = render_frames(width, height, 8)
    results = {}
    with Master(workdir, sim_time=False):
        import rospy
        rospy.init_node("camera_path_benchmark", anonymous=True, disable_signals=True)
        for source in sources:
            runs = []
            pub = _Frames(cam, rendered, RECORDED if source == "manager" else TOPIC, count_frames=source == "manager")
            try:
                for r in range(repeat):
                    for path in SOURCES[source]:
                        run = measure(path, pub, frames, rate, workdir, "%s_%s_%d" % (source, path, r), source,
                                      config, range_noise)
                        runs.append(run)
                        log("%s source, %s path, run %d: %d scans of %d frames, manager CPU %.3f ms per frame"
                            % (source, path, r + 1, run["scans"], run["frames"], run["cpu_ms_per_frame"]))
            finally:
                pub.close()
            results[source] = {"width": width, "height": height, "frames": frames, "rate": rate, "runs": runs,
                               "source": source, "figures": figures(runs, SOURCES[source])}
        rospy.signal_shutdown("done")
    return results


ROW_LABELS = {
    "baseline": "baseline: transport, camera_info, tf, publishing (image path reading one pixel)",
    "source": "source: the replay nodelet alone (what a camera driver nodelet costs anyway)",
    "image": "depth image -> scan (DepthImageScanConverterNodelet)",
    "cloud": "point_cloud_xyz + cloud converter",
}


def markdown(res):
    f = res["figures"]
    paths = SOURCES[res.get("source", "tcp")]
    def scans(path):
        runs = [r for r in res["runs"] if r["path"] == path]
        return "%d / %d" % (sum(r["scans"] for r in runs), sum(r["frames"] for r in runs))
    def above(path):
        return fmt(f[path] - f["baseline"], 1, 3) if path != paths[0] else ""
    rows = [[ROW_LABELS[path], fmt(f[path], 1, 3), above(path), scans(path)] for path in paths]
    if paths == MANAGER_PATHS:
        where, per = "frames published inside the manager (zero copy)", "frame"
    else:
        where, per = "frames received over TCP", "scan"
    return "\n".join([
        "Manager CPU per %dx%d 16UC1 frame, %s (median of %d runs of %d frames at %.0f Hz each): "
        "cloud path / image path = **%sx** in all, **%sx** above the baseline (%s)." % (
            res["width"], res["height"], where, len(res["runs"]) // len(paths), res["frames"], res["rate"],
            fmt(f["ratio"], 1, 1), fmt(f["ratio_above_baseline"], 1, 1), paths[0]),
        "", table(["path", "manager CPU per %s [ms]" % per, "above the baseline [ms]", "scans / frames"], rows), ""])


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
    p.add_argument("--source", choices=("manager", "tcp", "both"), default="both",
                   help="where the frames come from: a replay nodelet in the manager (zero copy, as a camera "
                        "driver nodelet), this process over TCP (a driver in its own process), or both")
    p.add_argument("--config", default=CONFIG,
                   help="the converters' parameters (default: the simulated robot's left camera, with its range "
                        "noise model)")
    p.add_argument("--range-noise", choices=("config", "off"), default="config",
                   help="the converters' range noise model as the config sets it, or off (the converter's "
                        "default)")
    try:
        a = p.parse_args(argv)
    except SystemExit as e:
        return 2 if e.code else 0
    if min(a.width, a.height, a.frames, a.repeat) < 1 or not 0 < a.rate <= 100:
        print("camera_path_benchmark: sizes, frames and repeat must be >= 1, rate in (0, 100]",
              file=sys.stderr)
        return 2
    try:
        results = experiment(a.width, a.height, a.frames, a.rate, a.repeat,
                             log=lambda m: print(m, file=sys.stderr),
                             sources=("manager", "tcp") if a.source == "both" else (a.source,), config=a.config,
                             range_noise=a.range_noise == "config")
    except RunError as e:
        print("camera_path_benchmark: %s" % e, file=sys.stderr)
        return 3
    for res in results.values():
        print(markdown(res))
    return 0
