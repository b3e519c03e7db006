"""Figures of a recorded run (``playback.run_pipeline``) and its bag: no ROS node runs here.

- per output: count, rate (from stamps), latency (receive /clock time minus stamp),
  bytes/s, messages dropped (inputs whose stamp never came out, see ``match_inputs``; where a
  merger's diagnostics report on the input, only those it never received or dropped, the rest
  merged into a later output: ``account_with_merger``), delay after the input that carries the
  same stamp;
- with ground truth (the scenario of the bag's ``/scenario`` topic): range error against
  the ideal scan (median, p95), false and missed obstacles, coverage, glass found, per scan
  topic (``ground_truth_stats``, ``glass_stats``);
- without: one moment of every scan for a plot (``scan_snapshot``);
- CPU per process and by role, as a robot on wall time pays it and under the simulated
  clock (``cpu_stats``);
- the thresholds of evaluate_bag's options (``THRESHOLDS``, ``check_thresholds``).
"""

import math
import os

import numpy as np

from . import metrics
from ..ros.rosrun import ROLES, process_role
from .playback import SKIP_TOPICS, bag_scans
from .results import NotRun

BASE_FRAME = "base_link"


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


def merger_counts(diagnostics, output_topic):
    """{input topic: (scans received, scans dropped)} that a merger counted for its sources merged
    into output_topic (from the last values of its /diagnostics statuses: "topic", "merged scan
    topic", "scans received", "scans dropped"). Empty for an output no merger reports on."""
    counts = {}
    for values in diagnostics.values():
        if values.get("merged scan topic") != output_topic or "topic" not in values:
            continue
        try:
            received, dropped = int(values["scans received"]), int(values["scans dropped"])
        except (KeyError, ValueError):
            continue
        r, d = counts.get(values["topic"], (0, 0))
        counts[values["topic"]] = (r + received, d + dropped)
    return counts


def merger_sources(drivers, counts, bag_topics, records):
    """{driver topic: the merger's source topic that carries its messages}: the topic itself where
    the merger reads the bag's topic (a lidar's scan), else the recorded output of the pipeline
    that the merger reads and whose stamps are the driver's (a camera's scan carries its depth
    image's stamps, a range converter's arc its reading's; a converter that lost some inputs
    still matches, at least half of them): what the merger never received then counts as
    dropped. Drivers matched to none are left out."""
    sources = {}
    for drv in drivers:
        if drv["topic"] in counts:
            sources[drv["topic"]] = drv["topic"]
            continue
        inputs = set(_stamp_key(bag_topics[drv["topic"]]["stamps"]).tolist())
        for topic in sorted(counts):
            recorded = set(_stamp_key([st for st in records.get(topic, {}).get("stamp", [])
                                       if st is not None]).tolist())
            if recorded and recorded <= inputs and 2 * len(recorded) >= len(inputs):
                sources[drv["topic"]] = topic
                break
    return sources


def account_with_merger(drivers, counts, sources=None):
    """Where the merger reports on a driver's topic (one of its sources; `sources` maps a driver
    topic to the merger's source topic where they differ, see merger_sources), splits the inputs
    whose stamp never reappears into those really dropped (never received by the merger, or
    dropped by it: malformed, no transform) and those merged into a later output under a newer
    input's stamp (a merger stamps its output with its newest input's time). Changes drivers in
    place."""
    sources = sources or {}
    for drv in drivers:
        source = sources.get(drv["topic"], drv["topic"])
        if source not in counts:
            continue
        received, dropped = counts[source]
        lost = max(drv["inputs"] - received, 0) + dropped
        drv["merged_later"] = max(drv["dropped"] - lost, 0)
        drv["dropped"] = min(drv["dropped"], lost)
        drv["counted_by_merger"] = True
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


def input_stats(bag_info):
    """Per topic of the bag: type, count, rate (from stamps, else rosbag's frequency), bytes/s
    and how old its messages already were when recorded (median, min; s)."""
    span = max(bag_info["end"] - bag_info["start"], 1e-9)
    return {t: {"type": v["type"], "count": v["count"],
                "rate_hz": metrics.rate_stats(v["stamps"])["rate"] if v["stamps"] else v["frequency"],
                "bytes_per_s": v["bytes"] / span,
                "age_median_s": float(np.median(v["age"])) if v["age"] else None,
                "age_min_s": float(np.min(v["age"])) if v["age"] else None}
            for t, v in bag_info["topics"].items()}


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
        counts = merger_counts(run.get("diagnostics", {}), topic)
        drivers = account_with_merger(drivers, counts,
                                      merger_sources(drivers, counts, bag_info["topics"], run["records"]))
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
            "merged_later": sum(x.get("merged_later", 0) for x in drivers),
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
    """Accuracy of every recorded LaserScan against the scenario's ideal scans: ({topic:
    figures, or NotRun when its frame cannot be placed}, {topic: an example scan}).

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
            results[topic] = NotRun("frame '%s' is not fixed to %s" % (frame, BASE_FRAME))
            continue
        if mount[2, 2] < 0:
            results[topic] = NotRun("frame '%s' is upside down" % frame)
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
            glass = metrics.glass_beams(ideal, without, tol, reach)
            b, f = metrics.glass_found(s["ranges"], ideal, glass, tol, rel_tol)
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


def cpu_stats(sim_clock, wall=None, rate=1.0):
    """The evaluation's CPU figures: (per process, summary).

    sim_clock: figures per process (``CpuMeter.figures``: cpu_percent, cpu_seconds, rss_mb)
    under rosbag's /clock; wall: those of the same data replayed on wall time
    (``run_pipeline_on_wall_time``), what a robot pays, or None when there was no such replay.
    Per process: "cpu_percent" is the wall-time figure (the simulated-time one without a
    replay), "role" (``rosrun.process_role``), "sim_clock_cpu_percent", and
    "clock_share_percent" = under /clock minus on wall time, when both ran at rate 1 (else
    None: the simulated-time run then did more or less work per second). A process measured
    under /clock only (it ended before the replay) is listed in the summary's
    "missing_on_wall_time", not summed. Summary: "clock" ("wall" or "sim": what cpu_percent
    was measured on), "total_percent", "by_role" and "processes" (percent and count per role),
    "sim_clock_total_percent", "clock_share_percent"."""
    source = wall if wall is not None else sim_clock
    comparable = wall is not None and rate == 1.0
    per = {}
    for name, c in source.items():
        sim = sim_clock.get(name, {}).get("cpu_percent")
        per[name] = dict(c, role=process_role(name), sim_clock_cpu_percent=sim,
                         clock_share_percent=(sim - c["cpu_percent"]) if comparable and
                         sim is not None else None)
    by_role = {r: sum(c["cpu_percent"] for c in per.values() if c["role"] == r) for r in ROLES}
    summary = {"clock": "wall" if wall is not None else "sim",
               "total_percent": sum(by_role.values()), "by_role": by_role,
               "processes": {r: sum(1 for c in per.values() if c["role"] == r) for r in ROLES},
               "sim_clock_total_percent": sum(c["cpu_percent"] for c in sim_clock.values()),
               "clock_share_percent": None,
               "missing_on_wall_time": sorted(set(sim_clock) - set(per))}
    if comparable:
        summary["clock_share_percent"] = sum(c["clock_share_percent"] for c in per.values()
                                             if c["clock_share_percent"] is not None)
    return per, summary


def check_thresholds(results, options, topics):
    """List of (ok, text) for every threshold given, on every topic in ``topics``, of an
    ``EvaluationResult``."""
    checks = []
    figures = {"accuracy": results.accuracy_figures(), "outputs": results.outputs}
    for opt, key, cmp, section, _ in THRESHOLDS:
        limit = options.get(opt)
        if limit is None:
            continue
        for topic in topics:
            r = figures[section].get(topic)
            if r is None:
                checks.append((False, "%s: %s has no %s figures" % (opt, topic, section)))
                continue
            v = r.get(key, float("nan"))
            ok = (v <= limit) if cmp == "<=" else (v >= limit)
            ok = bool(ok) and not (isinstance(v, float) and math.isnan(v))
            checks.append((ok, "%s %s: %.4g %s %.4g" % (topic, key, v, cmp, limit)))
    # CPU of the whole pipeline
    if options.get("max_cpu") is not None:
        total = sum(p["cpu_percent"] for p in results.cpu.values())
        checks.append((total <= options["max_cpu"],
                       "pipeline cpu_percent: %.4g <= %.4g" % (total, options["max_cpu"])))
    return checks


def default_threshold_topics(results):
    outs = results.outputs
    if "/merged_scan" in outs:
        return ["/merged_scan"]
    return [t for t, v in outs.items() if v["type"] == "sensor_msgs/LaserScan"]
