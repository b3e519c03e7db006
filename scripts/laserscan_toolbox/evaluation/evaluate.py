"""Play a bag through the pipeline and measure what comes out.

``evaluate_bag`` starts a private master (use_sim_time), roslaunches the pipeline,
plays the bag with ``rosbag play --clock``, records every LaserScan the pipeline
publishes (rospy, raw bytes: no re-serialisation cost), samples the CPU of every
launched process, and computes

- per output: count, rate (from stamps), latency (receive /clock time minus stamp),
  bytes/s, messages dropped (inputs whose stamp never came out, see ``match_inputs``);
- per process: CPU (percent of one core over the playback) and memory;
- with ground truth (a ``/scenario`` topic in the bag): range error against the
  ideal scan (median, p95), false and missed obstacles, coverage, per scan topic.

Figures go to ``results.json``; ``report.write_report`` turns them into Markdown + PNG.
"""

import json
import math
import os
import shutil
import struct
import sys
import tempfile
import time

import numpy as np

from . import metrics
from ..ros.rosrun import REPO, BagPlayer, CpuMeter, Launch, Master, RunError

DEFAULT_LAUNCH = os.path.join(REPO, "launch", "pipeline.launch")
GROUND_TRUTH_TOPIC = "/scenario"
SKIP_TOPICS = {"/rosout", "/rosout_agg", "/clock", "/tf", "/tf_static", "/diagnostics"}
BASE_FRAME = "base_link"
MAX_STAMP = 4294967295.999999999  # ROS 1 time: unsigned 32-bit seconds


class BagError(Exception):
    """The bag cannot be evaluated (empty, unindexed, unreadable)."""


# ---------------------------------------------------------------- bag inspection

def _header_stamp(raw):
    """Stamp (s) of a serialised message whose first field is a std_msgs/Header."""
    if len(raw) < 12:
        return None
    _, secs, nsecs = struct.unpack_from("<III", raw, 0)
    return secs + nsecs * 1e-9


def inspect_bag(path, stamps=True):
    """Topics, types, counts, time span, header stamps per topic, static transforms."""
    import rosbag
    if not os.path.isfile(path):
        raise FileNotFoundError("%s: no such bag" % path)
    info = {"path": os.path.abspath(path), "topics": {}, "static_tf": []}
    try:
        bag = rosbag.Bag(path)
    except rosbag.ROSBagUnindexedException:
        raise BagError("%s: the bag is not indexed (a recording that was cut off): "
                       "run `rosbag reindex %s` first" % (path, path)) from None
    except (rosbag.ROSBagException, OSError) as e:
        raise BagError("%s: cannot read the bag: %s" % (path, e)) from None
    with bag:
        ti = bag.get_type_and_topic_info().topics
        if not ti or bag.get_message_count() == 0:
            raise BagError("%s: the bag holds no messages" % path)
        info["start"] = bag.get_start_time()
        info["end"] = bag.get_end_time()
        info["size"] = os.path.getsize(path)
        for t, v in ti.items():
            info["topics"][t] = {"type": v.msg_type, "count": v.message_count,
                                 "frequency": v.frequency, "stamps": [], "bytes": 0, "age": []}
        for topic, raw, bag_t in bag.read_messages(raw=True):
            entry = info["topics"][topic]
            data, pytype = raw[1], raw[4]
            entry["bytes"] += len(data)
            if stamps and topic not in ("/tf", "/tf_static") and getattr(pytype, "_has_header", False):
                s = _header_stamp(data)
                if s is not None:
                    entry["stamps"].append(s)
                    entry["age"].append(bag_t.to_sec() - s)  # already old when recorded
        for _, msg, _ in bag.read_messages(topics=["/tf_static"]):
            for tr in msg.transforms:
                q = tr.transform.rotation
                p = tr.transform.translation
                info["static_tf"].append((tr.header.frame_id.lstrip("/"),
                                          tr.child_frame_id.lstrip("/"),
                                          (p.x, p.y, p.z), (q.x, q.y, q.z, q.w)))
    return info


def _matrix(xyz, q):
    x, y, z, w = q
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    m = np.eye(4)
    m[:3, :3] = r
    m[:3, 3] = xyz
    return m


def static_pose_in(static_tf, frame, base=BASE_FRAME):
    """4x4 pose of ``frame`` in ``base`` from static transforms, or None."""
    parent = {c: (p, _matrix(t, q)) for p, c, t, q in static_tf}
    m = np.eye(4)
    f = frame
    for _ in range(50):
        if f == base:
            return m
        if f not in parent:
            return None
        p, pm = parent[f]
        m = pm @ m
        f = p
    return None


# ---------------------------------------------------------------- recording

class Recorder:
    """Subscribes to topics with rospy.AnyMsg and keeps what the analysis needs."""

    def __init__(self, topics):
        import rospy
        from sensor_msgs.msg import LaserScan
        from tf2_msgs.msg import TFMessage
        self._scan_cls = LaserScan
        self.data = {}
        self.subs = []
        self.add(topics)
        # the mounts the launch publishes (a bag without tf gets them there): for plots.
        # Not in self.subs, whose connections wait_connected awaits: there may be none.
        self.static_tf = {}
        self._tf_sub = rospy.Subscriber("/tf_static", TFMessage, self._static_cb, queue_size=10)

    def _static_cb(self, msg):
        for tr in msg.transforms:
            q = tr.transform.rotation
            p = tr.transform.translation
            self.static_tf[tr.child_frame_id.lstrip("/")] = (
                tr.header.frame_id.lstrip("/"), tr.child_frame_id.lstrip("/"),
                (p.x, p.y, p.z), (q.x, q.y, q.z, q.w))

    def add(self, topics):
        import rospy
        for t, ty in topics.items():
            if t in self.data:
                continue
            self.data[t] = {"type": ty, "recv_sim": [], "recv_wall": [], "stamp": [],
                            "bytes": [], "scans": []}
            self.subs.append(rospy.Subscriber(t, rospy.AnyMsg, self._cb, callback_args=t,
                                              queue_size=100, tcp_nodelay=True))

    def _cb(self, msg, topic):
        import rospy
        recv_sim = rospy.get_time()
        recv_wall = time.time()
        raw = msg._buff
        d = self.data[topic]
        d["recv_sim"].append(recv_sim)
        d["recv_wall"].append(recv_wall)
        d["bytes"].append(len(raw))
        d["stamp"].append(_header_stamp(raw))
        if d["type"] == "sensor_msgs/LaserScan":
            m = self._scan_cls()
            m.deserialize(raw)
            d["scans"].append({"stamp": m.header.stamp.to_sec(), "frame": m.header.frame_id,
                               "angle_min": m.angle_min, "angle_max": m.angle_max,
                               "angle_increment": m.angle_increment,
                               "range_min": m.range_min, "range_max": m.range_max,
                               "ranges": np.asarray(m.ranges, np.float32)})

    def close(self):
        for s in self.subs + [self._tf_sub]:
            s.unregister()


def wait_connected(recorder, timeout=5.0):
    """Waits until every subscriber of ``recorder`` is connected to its publisher
    (wall time: with use_sim_time the clock stands still before playback)."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        if all(s.get_num_connections() > 0 for s in recorder.subs):
            return True
        time.sleep(0.05)
    return False


class Session:
    """A private master and this process's rospy node, shared by several runs."""

    def __init__(self, workdir=None, keep=False):
        self.own_dir = workdir is None
        self.workdir = workdir or tempfile.mkdtemp(prefix="laserscan_eval_")
        self.keep = keep
        self.master = None

    def __enter__(self):
        self.master = Master(os.path.join(self.workdir, "ros")).__enter__()
        import rospy
        rospy.init_node("laserscan_evaluate", anonymous=True, disable_signals=True,
                        disable_rosout=True)
        return self

    def __exit__(self, *exc):
        import rospy
        rospy.signal_shutdown("evaluation done")
        self.master.__exit__(*exc)
        if self.own_dir and not self.keep:
            shutil.rmtree(self.workdir, ignore_errors=True)


def run_pipeline(session, bag_info, launch_file, launch_args=(), rate=1.0, progress=True,
                 record_types=("sensor_msgs/LaserScan",), label="run", tail=1.5, select=None):
    """One playback through one launch. Returns the raw records (no analysis).

    select(topic, type) says which of the launch's outputs to record (default: those
    whose type is in record_types)."""
    if select is None:
        def select(topic, type_):
            return type_ in record_types
    wd = session.workdir
    launch = Launch(launch_file, launch_args, os.path.join(wd, label + "_roslaunch.log")).start()
    rec = None
    try:
        master = session.master.master
        pubs = launch.wait_ready(master, ignore_nodes=(_own_name(),))
        types = dict(master.getTopicTypes())
        outputs = {t: types.get(t, "?") for t in pubs if t not in SKIP_TOPICS}
        to_record = {t: ty for t, ty in outputs.items() if select(t, ty)}
        rec = Recorder(to_record)
        wait_connected(rec)
        procs = launch.processes()
        cpu = CpuMeter(procs)
        player = BagPlayer(bag_info["path"], os.path.join(wd, label + "_play.log"), rate=rate)
        own0 = sum(os.times()[:2])  # this process is the consumer of what it records
        cpu.start()
        player.start()
        bag_topics = set(bag_info["topics"])

        def late_outputs():
            # Some nodes (relays, lazy publishers) advertise only once data flows.
            try:
                state = master.getSystemState()
                types = dict(master.getTopicTypes())
            except Exception:
                return
            me = _own_name()
            for topic, nodes in state[0]:
                nodes = [n for n in nodes if n not in ("/rosout", me) and "play" not in n]
                if nodes and topic not in outputs and topic not in SKIP_TOPICS \
                        and topic not in bag_topics:
                    outputs[topic] = types.get(topic, "?")
                    if select(topic, outputs[topic]):
                        rec.add({topic: outputs[topic]})

        _wait_playback(player, bag_info, progress, label, late_outputs)
        time.sleep(tail)  # outputs of the last inputs are still on their way
        cpu_res, wall = cpu.stop()
        own_cpu = sum(os.times()[:2]) - own0
        # CPU per second of data: the window also holds rosbag's start delay and the tail,
        # during which the pipeline idles; short bags would otherwise look cheaper.
        data_s = max((bag_info["end"] - bag_info["start"]) / rate, 1e-9)
        for c in cpu_res.values():
            c["cpu_percent_wall"] = c["cpu_percent"]
            c["cpu_percent"] = 100.0 * c["cpu_seconds"] / data_s
        rec.close()
        # roslaunch outlives a node that is not required: its log says whether one died
        with open(launch.log_path, errors="replace") as f:
            died = [l for l in f if "has died" in l or "terminate called" in l or "what()" in l]
        if launch.proc.poll() is not None or died:
            raise RunError("the pipeline stopped during playback:\n%s%s"
                           % ("".join(died), _tail(launch.log_path)))
        return {"outputs": outputs, "publishers": pubs, "records": rec.data, "cpu": cpu_res,
                "static_tf": list(rec.static_tf.values()),
                "consumer_cpu_percent": 100.0 * own_cpu / data_s,
                "wall": wall, "launch": launch.cmd, "player": player.cmd}
    finally:
        if rec is not None:
            rec.close()
        launch.stop()


def _own_name():
    import rospy
    return rospy.get_name()


def _tail(path):
    from ..ros.rosrun import log_tail
    return log_tail(path)


def _wait_playback(player, bag_info, progress, label, poll=None):
    import rospy
    duration = max(bag_info["end"] - bag_info["start"], 1e-3)
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=duration, unit="s", mininterval=0.5, desc="playing %s" % label,
                   bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s bag time [{elapsed}]",
                   file=sys.stderr)
    done = 0.0
    last_poll = 0.0
    while player.running():
        time.sleep(0.2)
        if poll is not None and time.time() - last_poll > 1.0:
            poll()
            last_poll = time.time()
        t = rospy.get_time() - bag_info["start"]
        if bar is not None and 0 <= t <= duration + 1 and t > done:
            bar.update(min(t, duration) - done)
            done = min(t, duration)
    if bar is not None:
        bar.n = duration
        bar.refresh()
        bar.close()
    if player.proc.returncode not in (0, None):
        raise RunError("rosbag play failed (status %d):\n%s"
                       % (player.proc.returncode, _tail(player.log_path)))


# ---------------------------------------------------------------- analysis

def _stamp_key(stamps):
    """Stamps (s) as whole microseconds, the key under which stamps are matched."""
    return np.round(np.asarray(stamps, float) * 1e6).astype(np.int64)


def match_inputs(out_stamps, bag_topics, min_matches=3):
    """Input topics whose header stamps reappear on an output, and how many did not.

    A converter's scan carries its cloud's stamp (and so its depth image's), and a
    merger with publish_rate 0 stamps each output with an input's time, so an input
    message whose stamp never shows up on the output was dropped on the way.
    """
    out = set(_stamp_key(out_stamps).tolist())
    drivers = []
    seen = []  # a camera's image and camera_info share their stamps: count the frame once
    for topic, info in sorted(bag_topics.items()):
        st = info.get("stamps") or []
        if not st or topic in SKIP_TOPICS:
            continue
        s = set(_stamp_key(st).tolist())
        if s in seen:
            continue
        seen.append(s)
        m = len(s & out)
        if m >= min_matches and m >= 0.3 * min(len(s), len(out)):
            drivers.append({"topic": topic, "inputs": len(s), "matched": m, "dropped": len(s) - m})
    return drivers


def delay_after_input(recv_sim, stamps, drivers, bag_topics):
    """Receipt time of each output minus the bag time of the input message that carries the
    same stamp: the pipeline's own delay, whatever clock stamped the input (a sensor clock
    ahead of the recorder's makes stamp-based latencies negative, not this)."""
    played = {}
    for drv in drivers:
        info = bag_topics[drv["topic"]]
        bag_t = np.asarray(info["stamps"], float) + np.asarray(info["age"], float)
        for key, t in zip(_stamp_key(info["stamps"]).tolist(), bag_t.tolist()):
            played[key] = max(played.get(key, t), t)
    recv, sent = [], []
    for r, key in zip(recv_sim, _stamp_key(stamps).tolist()):
        if key in played:
            recv.append(r)
            sent.append(played[key])
    return metrics.latency_stats(recv, sent)


def output_stats(run, bag_info):
    stats = {}
    for topic, d in run["records"].items():
        pairs = [(r, s) for r, s in zip(d["recv_sim"], d["stamp"]) if s is not None]
        recv = [r for r, _ in pairs]
        stamps = [s for _, s in pairs]
        rs = metrics.rate_stats(stamps)
        lat = metrics.latency_stats(recv, stamps)
        span = (max(d["recv_wall"]) - min(d["recv_wall"])) if len(d["recv_wall"]) > 1 else 0
        drivers = match_inputs(stamps, bag_info["topics"])
        delay = delay_after_input(recv, stamps, drivers, bag_info["topics"])
        dropped = sum(x["dropped"] for x in drivers)
        inputs = sum(x["inputs"] for x in drivers)
        bag_span = bag_info["end"] - bag_info["start"]
        stats[topic] = {
            "type": d["type"], "count": len(d["stamp"]), "rate_hz": rs["rate"],
            "max_gap_s": rs["max_gap"], "latency_median_s": lat["median"],
            "latency_p95_s": lat["p95"], "latency_max_s": lat["max"],
            "latency_min_s": lat["min"], "negative_latency_fraction": lat["negative_fraction"],
            "delay_after_input_median_s": delay["median"],
            "delay_after_input_p95_s": delay["p95"], "delay_after_input_min_s": delay["min"],
            "bytes_per_msg": float(np.mean(d["bytes"])) if d["bytes"] else 0.0,
            "bytes_per_s": float(np.sum(d["bytes"]) / bag_span) if bag_span > 0 else float("nan"),
            "inputs": drivers, "dropped": dropped,
            "dropped_fraction": dropped / inputs if inputs else float("nan"),
            "coverage": _coverage(d["scans"]),
            "receive_span_wall_s": span,
        }
    return stats


def _coverage(scans):
    if not scans:
        return float("nan")
    r = np.concatenate([s["ranges"] for s in scans])
    return float(np.mean(metrics.is_return(r)))


def bag_scans(path, topics, start=None, end=None):
    """LaserScans of the bag (the pipeline's inputs) in the recorder's layout; only those
    recorded between bag times ``start`` and ``end`` (s) when given."""
    import rosbag
    import rospy
    out = {t: {"scans": []} for t in topics}
    window = {k: rospy.Time.from_sec(min(max(v, 0.0), MAX_STAMP)) for k, v in
              (("start_time", start), ("end_time", end)) if v is not None}
    with rosbag.Bag(path) as bag:
        for topic, m, _ in bag.read_messages(topics=list(topics), **window):
            out[topic]["scans"].append({
                "stamp": m.header.stamp.to_sec(), "frame": m.header.frame_id,
                "angle_min": m.angle_min, "angle_max": m.angle_max,
                "angle_increment": m.angle_increment, "range_min": m.range_min,
                "range_max": m.range_max, "ranges": np.asarray(m.ranges, np.float32)})
    return out


def scan_snapshot(bag, bag_info, run, topic=None, window=1.0):
    """One moment of a bag without ground truth, for a plot: the middle scan of ``topic``
    (default: the merged scan, else the first recorded scan topic) and, for every other
    recorded output and every LaserScan of the bag, the scan nearest to it in stamp, each
    with its frame's mount in the reference scan's frame (4x4; None when tf does not say).
    Returns None when nothing was recorded."""
    recs = {t: d for t, d in run["records"].items() if d.get("scans")}
    if not recs:
        return None
    if topic not in recs:
        topic = "/merged_scan" if "/merged_scan" in recs else sorted(recs)[0]
    ref_rec = recs[topic]
    i = len(ref_rec["scans"]) // 2
    ref = ref_rec["scans"][i]
    played_at = ref_rec["recv_sim"][i]  # bag time: the inputs were played just before
    inputs = [t for t, v in bag_info["topics"].items()
              if v["type"] == "sensor_msgs/LaserScan" and t not in recs]
    found = {t: d["scans"] for t, d in recs.items()}
    found.update({t: d["scans"] for t, d in bag_scans(
        bag, inputs, played_at - window, played_at + window).items()})
    static_tf = list(bag_info["static_tf"]) + list(run.get("static_tf", []))
    base = ref["frame"].lstrip("/")
    scans = {}
    for t, candidates in sorted(found.items()):
        if not candidates:
            continue
        s = min(candidates, key=lambda c: abs(c["stamp"] - ref["stamp"]))
        frame = s["frame"].lstrip("/")
        mount = np.eye(4) if frame == base else static_pose_in(static_tf, frame, base)
        scans[t] = dict(s, input=t in inputs, frame=frame,
                        mount=None if mount is None else mount.tolist())
    return {"topic": topic, "stamp": ref["stamp"], "frame": base, "scans": scans}


def band_from_configs(config_dir):
    """(floor_height, min_height, max_height) of the converters in ``config_dir``."""
    import glob
    import yaml
    from ..config_check import find_blocks
    for path in sorted(glob.glob(os.path.join(config_dir or "", "*.yaml"))):
        try:
            with open(path) as f:
                data = yaml.safe_load(f)
        except (OSError, yaml.YAMLError):
            continue
        for _, kind, params in find_blocks(data):
            if kind == "converter":
                return (float(params.get("floor_height", 0.0)),
                        float(params.get("min_height", 0.05)),
                        float(params.get("max_height", 1.0)))
    return None


def ground_truth_stats(run, bag_info, scenario, band, tol=0.05, beam_window=1,
                       max_scans=300, lidar_band=0.02, rel_tol=0.03):
    """Accuracy of every recorded LaserScan against the scenario's ideal scans.

    band: (floor_height in base_link, min_height, max_height) of the robot's obstacle band.
    Scans in base_link are compared with the ideal scan of that band at the true pose;
    scans in another frame fixed to base_link (a lidar) with the ideal scan at the sensor
    origin in a thin band (+-lidar_band) around the sensor's height.
    """
    floor, zlo, zhi = band
    results = {}
    examples = {}
    for topic, d in run["records"].items():
        scans = d["scans"]
        if not scans:
            continue
        frame = scans[0]["frame"].lstrip("/")
        mount = np.eye(4) if frame == BASE_FRAME else static_pose_in(bag_info["static_tf"], frame)
        if mount is None:
            results[topic] = {"skipped": "frame '%s' is not fixed to %s" % (frame, BASE_FRAME)}
            continue
        if mount[2, 2] < 0:
            results[topic] = {"skipped": "frame '%s' is upside down" % frame}
            continue
        if frame == BASE_FRAME:
            z_min, z_max = zlo, zhi
        else:
            h = mount[2, 3] - floor
            z_min, z_max = h - lidar_band, h + lidar_band
        dx, dy = mount[0, 3], mount[1, 3]
        dyaw = math.atan2(mount[1, 0], mount[0, 0])
        # the sensor's field of view: beams that returned at least once in the run
        n = len(scans[0]["ranges"])
        seen = np.zeros(n, bool)
        for s in scans:
            if len(s["ranges"]) == n:
                seen |= metrics.is_return(s["ranges"])
        idx = np.unique(np.linspace(0, len(scans) - 1, min(max_scans, len(scans))).astype(int))
        st = metrics.ScanStats()
        skipped = 0
        for i in idx:
            s = scans[i]
            if len(s["ranges"]) != n or not (bag_info["start"] <= s["stamp"] <= bag_info["end"]):
                skipped += 1
                continue
            x, y, yaw = scenario.true_pose(s["stamp"])
            pose = (x + math.cos(yaw) * dx - math.sin(yaw) * dy,
                    y + math.sin(yaw) * dx + math.cos(yaw) * dy, yaw + dyaw)
            reach = s["range_max"] + tol + rel_tol * s["range_max"]
            ideal = scenario.ideal_scan(s["stamp"], s["angle_min"], s["angle_max"],
                                        s["angle_increment"], s["range_min"], reach,
                                        z_min, z_max, pose=pose)
            ideal = np.asarray(ideal, float)
            if ideal.shape != s["ranges"].shape:
                skipped += 1
                continue
            counted = seen
            if _has_glass(scenario):
                # Beams whose closest obstacle is glass are judged apart (glass_stats): the
                # lidars and cameras see through it, so their ranges there measure the wall
                # behind, a miss of its own kind rather than a range error.
                clear = scenario.ideal_scan(s["stamp"], s["angle_min"], s["angle_max"], s["angle_increment"],
                                            s["range_min"], reach, z_min, z_max, pose=pose, glass=False)
                counted = seen & ~metrics.glass_beams(ideal, clear, tol)
            st.add(metrics.compare_scan(s["ranges"], ideal, tol, beam_window, mask=counted,
                                        rel_tol=rel_tol, range_max=s["range_max"]))
            if i == idx[len(idx) // 2]:
                examples[topic] = {"ranges": s["ranges"].tolist(), "ideal": ideal.tolist(),
                                   "angle_min": s["angle_min"],
                                   "angle_increment": s["angle_increment"],
                                   "stamp": s["stamp"], "frame": frame}
        summ = st.summary()
        summ.update({"frame": frame, "z_band": [z_min, z_max], "skipped_scans": skipped,
                     "tolerance": [tol, rel_tol],
                     "field_of_view_beams": int(seen.sum()), "beams_per_scan": n})
        results[topic] = summ
    return results, examples


def _has_glass(scenario):
    return bool(getattr(getattr(scenario, "world", None), "glass", None))


def glass_stats(run, bag_info, scenario, band, reach=4.5, tol=0.05, rel_tol=0.03, max_scans=300):
    """Glass found per scan topic in base_link: on beams whose closest obstacle in the band is
    a glass pane within ``reach`` (lidars and depth cameras see through it; ultrasonic sensors
    see it), the share where the scan has an obstacle at or before the pane (+ tolerance)."""
    from . import metrics as m
    if not _has_glass(scenario):
        return {}
    _, zlo, zhi = band
    out = {}
    for topic, d in run["records"].items():
        scans = [s for s in d["scans"] if s["frame"].lstrip("/") == BASE_FRAME
                 and bag_info["start"] <= s["stamp"] <= bag_info["end"]]
        if not scans:
            continue
        idx = np.unique(np.linspace(0, len(scans) - 1, min(max_scans, len(scans))).astype(int))
        beams = found = scans_with_glass = 0
        for i in idx:
            s = scans[i]
            args = (s["stamp"], s["angle_min"], s["angle_max"], s["angle_increment"], s["range_min"],
                    s["range_max"], zlo, zhi)
            ideal = np.asarray(scenario.ideal_scan(*args, glass=True), float)
            if ideal.shape != s["ranges"].shape:
                continue
            without = np.asarray(scenario.ideal_scan(*args, glass=False), float)
            glass = m.glass_beams(ideal, without, tol, reach)
            b, f = m.glass_found(s["ranges"], ideal, glass, tol, rel_tol)
            beams += b
            found += f
            scans_with_glass += b > 0
        out[topic] = {"glass_beams": beams, "found": found, "scans_with_glass": int(scans_with_glass),
                      "found_rate": found / beams if beams else float("nan"), "reach": reach}
    return out


# ---------------------------------------------------------------- thresholds

THRESHOLDS = [
    # (option, result key, comparison, applies to, help)
    ("max_median_error", "median_error", "<=", "accuracy", "median range error, m"),
    ("max_p95_error", "p95_error", "<=", "accuracy", "95th percentile range error, m"),
    ("max_false_rate", "false_rate", "<=", "accuracy",
     "false obstacles per output return (0..1)"),
    ("max_missed_rate", "missed_rate", "<=", "accuracy",
     "missed obstacles per ideal return (0..1)"),
    ("min_rate", "rate_hz", ">=", "outputs", "output rate, Hz"),
    ("max_latency", "latency_p95_s", "<=", "outputs", "95th percentile latency, s"),
    ("max_dropped", "dropped_fraction", "<=", "outputs", "dropped input fraction (0..1)"),
    ("min_coverage", "coverage", ">=", "outputs", "fraction of beams with a return"),
]

# SLAM targets (--slam): options of laserscan_toolbox.evaluation.slam.check_targets' targets
SLAM_THRESHOLDS = [
    # (option, target key, help)
    ("max_slam_path_rmse", "max_path_rmse", "SLAM path RMSE of both streams, m"),
    ("min_slam_map_precision", "min_map_precision",
     "share of the unified scan's SLAM map cells near a true obstacle"),
    ("min_slam_3d_ratio", "min_3d_ratio",
     "3D obstacles in the unified scan's SLAM map / in the lidar-only one's"),
    ("max_localization_gap", "max_localization_gap",
     "localization RMSE of the unified scan minus the lidar-only one's, m"),
]


def check_thresholds(results, options, topics):
    """List of (ok, text) for every threshold given, on every topic in ``topics``."""
    checks = []
    for opt, key, cmp, section, _ in THRESHOLDS:
        limit = options.get(opt)
        if limit is None:
            continue
        for topic in topics:
            r = results.get(section, {}).get(topic)
            if r is None or "skipped" in r:
                checks.append((False, "%s: %s has no %s figures" % (opt, topic, section)))
                continue
            v = r.get(key, float("nan"))
            ok = (v <= limit) if cmp == "<=" else (v >= limit)
            ok = bool(ok) and not (isinstance(v, float) and math.isnan(v))
            checks.append((ok, "%s %s: %.4g %s %.4g" % (topic, key, v, cmp, limit)))
    # CPU of the whole pipeline
    if options.get("max_cpu") is not None:
        total = sum(p["cpu_percent"] for p in results.get("cpu", {}).values())
        checks.append((total <= options["max_cpu"],
                       "pipeline cpu_percent: %.4g <= %.4g" % (total, options["max_cpu"])))
    return checks


# ---------------------------------------------------------------- whole evaluation

def evaluate(bag, launch_file=DEFAULT_LAUNCH, launch_args=(), config_dir=None, output=None,
             rate=1.0, progress=True, thresholds=None, threshold_topics=None,
             band=None, tol=0.05, beam_window=1, max_scans=300, plots=True, workdir=None,
             rel_tol=0.03,
             log=print, map_topics=("/lidar_scan", "/slam_scan", "/merged_scan"), map_resolution=0.05,
             save_scans=False, slam=False, slam_targets=None, slam_seed=0):
    """Runs everything and writes results.json (+ report.md and plots when ``plots``).

    slam: also run the SLAM and localization experiment (``laserscan_toolbox.evaluation.slam``) on
    the first two ``map_topics`` (lidar-only, unified); slam_targets: its targets
    (``slam.TARGETS``' keys) joined to the thresholds."""
    t_start = time.time()
    thresholds = thresholds or {}
    log("inspecting %s" % bag)
    info = inspect_bag(bag)  # BagError: the caller says why
    scenario = None
    if GROUND_TRUTH_TOPIC in info["topics"]:
        from ..simulation.scenario import Scenario
        scenario = Scenario.from_bag(bag)
    args = list(launch_args)
    if config_dir:
        args.append("config_dir:=%s" % os.path.abspath(config_dir))
    with Session(workdir=workdir) as session:
        try:
            run = run_pipeline(session, info, launch_file, args, rate=rate, progress=progress,
                               label=os.path.splitext(os.path.basename(bag))[0])
        except RunError as e:
            session.keep = True  # the logs say why (a node that died, a bad config)
            raise RunError("%s\n(logs kept in %s)" % (e, session.workdir))
    results = {"bag": info["path"], "bag_duration_s": info["end"] - info["start"],
               "bag_size_bytes": info["size"], "launch": run["launch"],
               "player": run["player"], "ground_truth": scenario is not None,
               "inputs": {t: {"type": v["type"], "count": v["count"],
                              "rate_hz": metrics.rate_stats(v["stamps"])["rate"]
                              if v["stamps"] else v["frequency"],
                              "bytes_per_s": v["bytes"] / max(info["end"] - info["start"], 1e-9),
                              "age_median_s": float(np.median(v["age"])) if v["age"] else None,
                              "age_min_s": float(np.min(v["age"])) if v["age"] else None}
                          for t, v in info["topics"].items()},
               "outputs": output_stats(run, info), "cpu": run["cpu"],
               "playback_wall_s": run["wall"], "unrecorded_outputs":
                   {t: ty for t, ty in run["outputs"].items() if t not in run["records"]}}
    examples = {}
    if scenario is not None:
        if band is None:
            band = band_from_configs(config_dir or os.path.join(REPO, "config", "sim_robot"))
        band = band or (0.0, 0.05, 1.0)
        results["band"] = list(band)
        results["accuracy"], examples = ground_truth_stats(
            run, info, scenario, band, tol=tol, beam_window=beam_window, max_scans=max_scans,
            rel_tol=rel_tol)
        # the sources that come straight from the bag (lidars), judged the same way
        inputs = [t for t, v in info["topics"].items()
                  if v["type"] == "sensor_msgs/LaserScan" and t not in run["records"]]
        if inputs:
            acc_in, _ = ground_truth_stats({"records": bag_scans(bag, inputs)}, info, scenario,
                                           band, tol=tol, beam_window=beam_window,
                                           max_scans=max_scans, rel_tol=rel_tol)
            for t, a in acc_in.items():
                a["input"] = True
                results["accuracy"][t] = a
        results["glass"] = glass_stats(run, info, scenario, band, max_scans=max_scans)
        refs = None
        if output and map_topics:
            results["mapping"], refs = run_mapping(run, info, scenario, results, map_topics,
                                                   os.path.join(output, "maps"), log=log)
        if slam and refs is not None:
            results.update(run_slam(run, info, scenario, refs, map_topics, output, seed=slam_seed,
                                    log=log))
    elif output and plots:
        run["snapshot"] = scan_snapshot(bag, info, run)
        if run["snapshot"]:
            results["scan_plot"] = {
                "topic": run["snapshot"]["topic"], "stamp": run["snapshot"]["stamp"],
                "frame": run["snapshot"]["frame"],
                "scans": {t: {"frame": v["frame"], "input": v["input"],
                              "mounted": v["mount"] is not None,
                              "returns": int(np.count_nonzero(metrics.is_return(v["ranges"])))}
                          for t, v in run["snapshot"]["scans"].items()}}
    topics = threshold_topics or _default_threshold_topics(results)
    checks = check_thresholds(results, thresholds, topics)
    if slam_targets:
        from . import slam as slam_module
        checks += slam_module.check_targets(results, slam_targets, *(map_topics or ())[:2])
    results["thresholds"] = [{"ok": ok, "check": text} for ok, text in checks]
    results["passed"] = all(ok for ok, _ in checks)
    results["evaluation_wall_s"] = time.time() - t_start
    if output:
        os.makedirs(output, exist_ok=True)
        with open(os.path.join(output, "results.json"), "w") as f:
            json.dump(results, f, indent=1, default=_json_default)
        if save_scans:
            save_scan_records(run, os.path.join(output, "scans.npz"))
        if plots:
            from . import report
            report.write_report(results, examples, run, output)
    return results


def run_mapping(run, info, scenario, results, map_topics, outdir, resolution=0.05,
                min_dt=0.2, log=print):
    """The mapping experiment on the recorded scans (true poses, ground-truth grid)."""
    from . import mapping
    streams = {}
    for t in map_topics:
        scans = run["records"].get(t, {}).get("scans")
        if scans:
            streams["%s" % t] = [s for s in scans if info["start"] <= s["stamp"] <= info["end"]]
    if not streams:
        return {"skipped": "none of %s was recorded" % ", ".join(map_topics)}, None
    log("mapping experiment on %s" % ", ".join(streams))
    floor, zlo, zhi = results["band"]
    plane = None
    for a in results.get("accuracy", {}).values():
        if a.get("frame", BASE_FRAME) != BASE_FRAME and "z_band" in a:
            plane = tuple(a["z_band"])
            break
    # Reference: ideal scans in the robot's band along the path, at the fused stream's
    # stamps, over the directions the 3D sensors look (the camera scans' angular spans in
    # base_link): what perfect cameras would have put in the map.
    last_topic = list(streams)[-1]
    spans = []
    for t, d in run["records"].items():
        sc0 = d["scans"][0] if d.get("scans") else None
        if sc0 and sc0["frame"].lstrip("/") == BASE_FRAME and t not in map_topics \
                and t not in ("/merged_scan", "/slam_scan", "/lidar_scan"):
            spans.append((sc0["angle_min"], sc0["angle_max"]))
    ideal, ideal_view, last = [], [], -1e18
    for s in streams[last_topic]:
        if s["stamp"] - last < min_dt:
            continue
        last = s["stamp"]
        r = np.asarray(scenario.ideal_scan(
            s["stamp"], s["angle_min"], s["angle_max"], s["angle_increment"], s["range_min"],
            s["range_max"], zlo, zhi, pose=scenario.true_pose(s["stamp"])), float)
        ideal.append(dict(s, ranges=r))
        if spans:
            view = np.zeros(r.size, bool)
            for lo, hi in spans:
                view |= metrics.angular_mask(r.size, s["angle_min"], s["angle_increment"], lo, hi)
            ideal_view.append(dict(s, ranges=np.where(view, r, np.inf)))
    ts = np.arange(info["start"], info["end"], 0.1)
    traj = np.array([scenario.true_pose(t)[:2] for t in ts])
    fig, refs = mapping.mapping_experiment(streams, scenario, outdir, resolution=resolution,
                                           band=(zlo, zhi), plane_band=plane, trajectory=traj,
                                           ideal_scans=ideal, ideal_scans_3d=ideal_view or None,
                                           return_grids=True)
    fig["plane_band"] = plane
    fig["band"] = (zlo, zhi)
    fig["reference_spans"] = spans
    return fig, refs


def run_slam(run, info, scenario, refs, map_topics, output, seed=0, log=print):
    """The SLAM and localization experiment on the recorded streams; returns the results'
    "slam", "localization" (keyed by topic) and "slam_experiment" entries."""
    from . import slam
    scans = {t: [s for s in run["records"].get(t, {}).get("scans", [])
                 if info["start"] <= s["stamp"] <= info["end"]] for t in map_topics[:2]}
    try:
        res = slam.slam_experiment(scans, info["path"], scenario, refs, output,
                                   topics=tuple(map_topics[:2]), seed=seed, log=log)
    except slam.SlamError as e:
        log("SLAM experiment failed: %s" % e)
        return {"slam_experiment": {"error": str(e)}}
    if "skipped" in res:
        return {"slam_experiment": res}
    out = {"slam": res.pop("slam"), "slam_experiment": res}
    if "localization" in res:
        out["localization"] = res.pop("localization")
    return out


def save_scan_records(run, path):
    """Every recorded LaserScan as arrays: <topic>/stamp, /ranges (scans x beams; scans of
    another length are left out), /angle_min, /angle_increment, /range_min, /range_max, and
    /recv_sim (receive time on the bag clock)."""
    arrays = {}
    for topic, d in run["records"].items():
        scans = d["scans"]
        if not scans:
            continue
        n = len(scans[0]["ranges"])
        keep = [i for i, s in enumerate(scans) if len(s["ranges"]) == n]
        scans = [scans[i] for i in keep]
        key = topic.strip("/").replace("/", "__")
        arrays[key + "/stamp"] = np.array([s["stamp"] for s in scans])
        arrays[key + "/recv_sim"] = np.asarray(d["recv_sim"], float)[keep]
        arrays[key + "/ranges"] = np.stack([s["ranges"] for s in scans])
        for f in ("angle_min", "angle_increment", "range_min", "range_max"):
            arrays[key + "/" + f] = np.float64(scans[0][f])
        arrays[key + "/frame"] = np.array(scans[0]["frame"])
    np.savez_compressed(path, **arrays)


def load_scan_records(path):
    """{topic: {"stamp", "ranges", "angle_min", ...}} from save_scan_records' file."""
    out = {}
    with np.load(path) as z:
        for k in z.files:
            key, field = k.rsplit("/", 1)
            out.setdefault("/" + key.replace("__", "/"), {})[field] = z[k]
    return out


def _default_threshold_topics(results):
    outs = results.get("outputs", {})
    if "/merged_scan" in outs:
        return ["/merged_scan"]
    return [t for t, v in outs.items() if v["type"] == "sensor_msgs/LaserScan"]


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)


def main(argv=None):
    import argparse
    p = argparse.ArgumentParser(
        prog="evaluate_bag",
        description="Play BAG through the laser-scan pipeline (private roscore, use_sim_time, "
                    "rosbag play --clock) and report rate, latency, CPU, dropped messages and, "
                    "when the bag carries the scenario's ground truth, range error and "
                    "false / missed obstacles per scan topic. Exit status: 0 all thresholds "
                    "met, 1 a threshold not met, 2 usage error, missing file or unusable bag, 3 the "
                    "pipeline could not be run.")
    p.add_argument("bag")
    p.add_argument("--launch", default=DEFAULT_LAUNCH,
                   help="launch file of the pipeline (default: launch/pipeline.launch)")
    p.add_argument("--config", metavar="DIR",
                   help="configuration folder, passed to the launch as config_dir:=DIR")
    p.add_argument("--arg", action="append", default=[], metavar="NAME:=VALUE",
                   help="extra roslaunch argument (repeatable)")
    p.add_argument("--output", metavar="DIR", help="write report.md, results.json, plots here")
    p.add_argument("--rate", type=float, default=1.0, help="playback rate factor (default 1)")
    p.add_argument("--topic", action="append", dest="threshold_topics", metavar="TOPIC",
                   help="topics the thresholds apply to (default /merged_scan if published, "
                        "else every scan)")
    p.add_argument("--band", type=float, nargs=3, metavar=("FLOOR", "ZMIN", "ZMAX"),
                   help="obstacle band for the ideal scan: floor z in base_link and band "
                        "above the floor, m (default: from the converter YAML)")
    p.add_argument("--tolerance", type=float, default=0.05,
                   help="range tolerance for false/missed obstacles, m (default 0.05) ...")
    p.add_argument("--relative-tolerance", type=float, default=0.03,
                   help="... plus this fraction of the range (default 0.03)")
    p.add_argument("--beam-window", type=int, default=1,
                   help="beams either side searched when matching ranges (default 1)")
    p.add_argument("--max-scans", type=int, default=300,
                   help="scans per topic compared with ground truth (evenly spaced)")
    p.add_argument("--map-topics", nargs="*", default=["/lidar_scan", "/slam_scan", "/merged_scan"],
                   metavar="TOPIC", help="scan topics mapped at the true poses when the bag has "
                   "ground truth (default: /lidar_scan /slam_scan /merged_scan; none to skip)")
    p.add_argument("--slam", action="store_true",
                   help="also run real 2D SLAM (MRPT rbpf-slam) and localization "
                   "(pf-localization on the ground-truth map) on the first two --map-topics "
                   "(lidar-only, unified): docs/slam.md")
    p.add_argument("--slam-seed", type=int, default=0, help="rbpf-slam's random seed")
    for opt, _, hlp in SLAM_THRESHOLDS:
        p.add_argument("--" + opt.replace("_", "-"), type=float, help="threshold (--slam): " + hlp)
    p.add_argument("--save-scans", action="store_true",
                   help="also write every recorded scan to OUTPUT/scans.npz")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--no-plots", action="store_true")
    for opt, _, _, _, hlp in THRESHOLDS:
        p.add_argument("--" + opt.replace("_", "-"), type=float, help="threshold: " + hlp)
    p.add_argument("--max-cpu", type=float,
                   help="threshold: CPU of all launched processes, percent of one core")
    try:
        a = p.parse_args(argv)
    except SystemExit as e:
        return 2 if e.code else 0
    if not os.path.isfile(a.bag):
        print("evaluate_bag: %s: no such bag" % a.bag, file=sys.stderr)
        return 2
    if a.save_scans and not a.output:
        print("evaluate_bag: --save-scans needs --output", file=sys.stderr)
        return 2
    if not os.path.isfile(a.launch):
        print("evaluate_bag: %s: no such launch file" % a.launch, file=sys.stderr)
        return 2
    if a.config and not os.path.isdir(a.config):
        print("evaluate_bag: %s: no such folder" % a.config, file=sys.stderr)
        return 2
    if a.slam and not a.output:
        print("evaluate_bag: --slam needs --output", file=sys.stderr)
        return 2
    thresholds = {opt: getattr(a, opt) for opt, *_ in THRESHOLDS}
    slam_targets = {key: getattr(a, opt) for opt, key, _ in SLAM_THRESHOLDS
                    if getattr(a, opt) is not None}
    thresholds["max_cpu"] = a.max_cpu
    try:
        res = evaluate(a.bag, a.launch, a.arg, a.config, a.output, a.rate, not a.no_progress,
                       thresholds, a.threshold_topics, a.band, a.tolerance, a.beam_window,
                       a.max_scans, plots=not a.no_plots,
                       log=lambda m: print(m, file=sys.stderr), map_topics=a.map_topics,
                       save_scans=a.save_scans, rel_tol=a.relative_tolerance, slam=a.slam,
                       slam_targets=slam_targets if a.slam else None, slam_seed=a.slam_seed)
    except BagError as e:
        print("evaluate_bag: %s" % e, file=sys.stderr)
        return 2
    except RunError as e:
        print("evaluate_bag: %s" % e, file=sys.stderr)
        return 3
    from . import report
    print(report.summary_text(res))
    if a.output:
        print("report: %s" % os.path.join(a.output, "report.md"))
    return 0 if res["passed"] else 1
