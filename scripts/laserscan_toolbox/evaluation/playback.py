"""Play a bag through the pipeline and record what comes out.

``inspect_bag`` reads a bag's topics, counts, time span, header stamps and static
transforms; ``run_pipeline`` roslaunches the pipeline under a ``ros.rosrun.Session``
(private master, use_sim_time), plays the bag with ``rosbag play --clock``, records every
output it selects (rospy, raw bytes: no re-serialisation cost) and samples the CPU of every
launched process. ``bag_scans`` reads a bag's LaserScans in the recorder's layout;
``save_scan_records`` / ``load_scan_records`` keep the recorded scans in a ``.npz``.
Nothing here analyses: see ``analysis``.
"""

import os
import struct
import sys
import time

import numpy as np

from ..ros.cpu_accounting import process_cpu_s
from ..ros.rosrun import (REPO, BagPlayer, CpuMeter, RunError, WallClockPlayer, log_tail, own_node_name,
                          wait_connected)

DEFAULT_LAUNCH = os.path.join(REPO, "launch", "pipeline.launch")
#: How long a playback waits (wall time) for the recorder's and the pipeline's connections.
CONNECT_TIMEOUT_S = 60.0
SKIP_TOPICS = {"/rosout", "/rosout_agg", "/clock", "/tf", "/tf_static", "/diagnostics"}
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


# ---------------------------------------------------------------- recording

def scan_record(msg):
    """A sensor_msgs/LaserScan as the recorder keeps it (the analysis' scan layout)."""
    return {"stamp": msg.header.stamp.to_sec(), "frame": msg.header.frame_id,
            "angle_min": msg.angle_min, "angle_max": msg.angle_max,
            "angle_increment": msg.angle_increment, "range_min": msg.range_min,
            "range_max": msg.range_max, "ranges": np.asarray(msg.ranges, np.float32)}


class Recorder:
    """Subscribes to topics with rospy.AnyMsg and keeps what the analysis needs."""

    def __init__(self, topics):
        import rospy
        from sensor_msgs.msg import LaserScan
        from diagnostic_msgs.msg import DiagnosticArray
        from tf2_msgs.msg import TFMessage
        self._scan_cls = LaserScan
        self.data = {}
        self.subs = []
        self.add(topics)
        # the mounts the launch publishes (a bag without tf gets them there): for plots.
        # Not in self.subs, whose connections wait_connected awaits: there may be none.
        self.static_tf = {}
        self._tf_sub = rospy.Subscriber("/tf_static", TFMessage, self._static_cb, queue_size=10)
        # The nodes' own counts (a merger's drops per source): the last values of each status.
        self.diagnostics = {}
        self._diag_sub = rospy.Subscriber("/diagnostics", DiagnosticArray, self._diagnostics_cb, queue_size=50)

    def _diagnostics_cb(self, msg):
        for status in msg.status:
            self.diagnostics[status.name] = {kv.key: kv.value for kv in status.values}

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
            d["scans"].append(scan_record(m))

    def close(self):
        for s in self.subs + [self._tf_sub, self._diag_sub]:
            s.unregister()


def run_pipeline(session, bag_info, launch_file, launch_args=(), rate=1.0, progress=True,
                 record_types=("sensor_msgs/LaserScan",), label="run", tail=1.5, select=None,
                 cpu_window=None):
    """One playback through one launch. Returns the raw records (no analysis).

    select(topic, type) says which of the launch's outputs to record (default: those
    whose type is in record_types). cpu_window (s): also the CPU over the bag's first
    cpu_window seconds of data alone ("cpu_window": figures per process, "cpu_window_s"), to
    set beside ``run_pipeline_on_wall_time``'s figures of the same data."""
    if select is None:
        def select(topic, type_):
            return type_ in record_types
    wd = session.workdir
    rec = None
    with session.launched(launch_file, launch_args, label) as (launch, pubs):
        master = session.master.master
        try:
            types = dict(master.getTopicTypes())
            outputs = {t: types.get(t, "?") for t in pubs if t not in SKIP_TOPICS}
            to_record = {t: ty for t, ty in outputs.items() if select(t, ty)}
            rec = Recorder(to_record)
            # Recorded from the first output on (a lazy converter subscribes to its input once
            # its scan has a subscriber); the player then waits for the pipeline's connections.
            # 5 s were too short on a loaded machine, and the wait ends as soon as they are there.
            wait_connected(rec.subs, timeout=CONNECT_TIMEOUT_S)
            procs = launch.processes()
            cpu = CpuMeter(procs)
            player = BagPlayer(bag_info["path"], os.path.join(wd, label + "_play.log"), rate=rate,
                               connect_timeout=CONNECT_TIMEOUT_S)
            own0 = process_cpu_s(os.getpid())  # this process is the consumer of what it records
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
                me = own_node_name()
                for topic, nodes in state[0]:
                    nodes = [n for n in nodes if n not in ("/rosout", me) and "play" not in n]
                    if nodes and topic not in outputs and topic not in SKIP_TOPICS \
                            and topic not in bag_topics:
                        outputs[topic] = types.get(topic, "?")
                        if select(topic, outputs[topic]):
                            rec.add({topic: outputs[topic]})

            window = {}

            def mark_window(t):
                # the window opens at the bag's first data and closes cpu_window s later
                if "start" not in window and t >= bag_info["start"]:
                    window["start"] = (t, cpu.snapshot())
                elif "start" in window and "end" not in window and \
                        t >= bag_info["start"] + cpu_window:
                    window["end"] = (t, cpu.snapshot())

            _wait_playback(player, bag_info, progress, label, late_outputs,
                           mark_window if cpu_window else None)
            extra = {}
            if cpu_window and "start" in window:
                import rospy
                (t0, before), (t1, after) = window["start"], window.get(
                    "end", (rospy.get_time(), cpu.snapshot()))  # a bag shorter than the window
                extra = {"cpu_window": cpu.figures(before, after, (t1 - t0) / rate),
                         "cpu_window_s": t1 - t0}
            time.sleep(tail)  # outputs of the last inputs are still on their way
            cpu_res, wall = cpu.stop()
            own_cpu = process_cpu_s(os.getpid()) - own0
            # CPU per second of data: the window also holds rosbag's start delay and the tail,
            # during which the pipeline idles; short bags would otherwise look cheaper.
            data_s = max((bag_info["end"] - bag_info["start"]) / rate, 1e-9)
            for c in cpu_res.values():
                c["cpu_percent_wall"] = c["cpu_percent"]
                c["cpu_percent"] = 100.0 * c["cpu_seconds"] / data_s
            rec.close()
            launch.raise_if_stopped()
            return {"outputs": outputs, "publishers": pubs, "records": rec.data, "cpu": cpu_res,
                    "static_tf": list(rec.static_tf.values()), "diagnostics": dict(rec.diagnostics),
                    "consumer_cpu_percent": 100.0 * own_cpu / data_s,
                    "wall": wall, "launch": launch.cmd, "player": player.cmd, "clock": "sim",
                    "player_connect_wait_s": player.connect_wait_s,
                    "player_unconnected": player.unconnected,
                    **extra}
        finally:
            if rec is not None:
                rec.close()


def run_pipeline_on_wall_time(session, bag_info, launch_file, launch_args=(), duration=None,
                              record_types=("sensor_msgs/LaserScan",), label="wall", select=None,
                              topics=None):
    """The bag's first ``duration`` seconds (all of it when None) through the launch on wall
    time, as on a robot: use_sim_time false, no /clock, stamps moved to now
    (``ros.wall_clock_play``). For the CPU a robot pays: every roscpp and rospy process takes
    /clock under simulated time, which the robot does not pay.

    Records the outputs chosen by ``topics`` ({topic: type}) or else by select / record_types
    as run_pipeline does (a consumer subscribed as in the simulated-time run, so that the
    nodes publish the same). Returns run_pipeline's keys ("clock": "wall"; "stamp_offset_s",
    what was added to every stamp; "cpu" is measured over the playback alone, from the first
    message to the last, per second of the data played, "data_s")."""
    if select is None:
        def select(topic, type_):
            return type_ in record_types
    master = session.master.master
    rec = None
    try:
        with session.launched(launch_file, launch_args, label, wall_time=True) as (launch, pubs):
            types = dict(master.getTopicTypes())
            outputs = {t: types.get(t, "?") for t in pubs if t not in SKIP_TOPICS}
            to_record = topics if topics is not None else {
                t: ty for t, ty in outputs.items() if select(t, ty)}
            rec = Recorder(to_record)
            wait_connected(rec.subs)
            cpu = CpuMeter(launch.processes())
            player = WallClockPlayer(bag_info["path"], os.path.join(session.workdir, label + "_play.log"),
                                     duration)
            own0 = process_cpu_s(os.getpid())
            try:
                player.start()
                t0, before = time.time(), cpu.snapshot()
                player.wait(timeout=bag_info["end"] - bag_info["start"] + 60.0)
                seconds, after = time.time() - t0, cpu.snapshot()
            finally:
                player.stop()
            own_cpu = process_cpu_s(os.getpid()) - own0
            rec.close()
            launch.raise_if_stopped()
            # per second of data, as run_pipeline: the player may fall a little behind
            data_s = max(player.data_s, 1e-9)
            return {"outputs": outputs, "publishers": pubs, "records": rec.data,
                    "cpu": cpu.figures(before, after, data_s), "data_s": data_s,
                    "static_tf": list(rec.static_tf.values()), "diagnostics": dict(rec.diagnostics),
                    "consumer_cpu_percent": 100.0 * own_cpu / data_s, "wall": seconds,
                    "launch": launch.cmd, "player": player.cmd, "clock": "wall",
                    "stamp_offset_s": player.offset_s, "messages_played": player.sent}
    finally:
        if rec is not None:
            rec.close()


def _wait_playback(player, bag_info, progress, label, poll=None, on_clock=None):
    """Waits for the end of playback; poll() about once a second, on_clock(bag clock) every
    few ms while on_clock is given (else every 0.2 s)."""
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
        time.sleep(0.02 if on_clock else 0.2)
        if on_clock is not None:
            on_clock(rospy.get_time())
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
                       % (player.proc.returncode, log_tail(player.log_path)))


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
            out[topic]["scans"].append(scan_record(m))
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
