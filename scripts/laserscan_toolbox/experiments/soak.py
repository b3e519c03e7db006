"""Soak benchmark (issue 8): the whole pipeline fed at 10x its sensors' rates for a long time.

A short scenario bag is simulated once (scripts/simulate_scenario, no recording step) and
played in a loop with ``rosbag play --clock -l -r RATE`` through launch/pipeline.launch, on
a private master. Every ``interval`` seconds the resident memory (RSS) of every process the
launch started is sampled; every output scan is counted with its arrival time. Reported:
RSS per process and in total at the start and the end, the slope of the total after the
warm-up (least squares) and the growth it implies over the rest of the run, outputs per
topic, and stalls (gaps longer than ``stall_s`` in any output). Each loop of the bag sends
/clock back to the bag's start, so the nodes' time-jump handling is soaked as well.
A benchmark, not a test: it prints figures against the targets (growth below 1 MB after the
warm-up, no stall) and writes soak.json, soak.md and soak.png into the output folder.
"""

import os
import sys
import time

from ..evaluation.report import fmt, table, write_json
from ..ros.rosrun import REPO, BagPlayer, RunError, Session, log_tail, wait_connected

DEFAULT_LAUNCH = os.path.join(REPO, "launch", "pipeline.launch")
OUTPUT_TOPICS = ("/merged_scan", "/lidar_scan", "/camera_left/scan", "/camera_right/scan")
TARGET_GROWTH_MB = 1.0
MB = 1024.0 * 1024.0


# ---------------------------------------------------------------- analysis (pure)

def slope(times, values):
    """Least-squares slope of values against times (units of values per unit of time); 0 for
    fewer than two distinct times."""
    n = len(times)
    if n < 2:
        return 0.0
    mt = sum(times) / n
    mv = sum(values) / n
    sxx = sum((t - mt) ** 2 for t in times)
    if sxx == 0.0:
        return 0.0
    return sum((t - mt) * (v - mv) for t, v in zip(times, values)) / sxx


def warmup_seconds(duration):
    """The first third of a short run, at most 5 minutes of a long one."""
    return min(300.0, duration / 3.0)


def growth_after_warmup(samples, warmup):
    """samples: [(t, rss_bytes)] with t from the start of the feed. Returns the slope after
    the warm-up (bytes/s) and the growth it implies from the end of the warm-up to the last
    sample (bytes); zeros without at least two samples after the warm-up."""
    after = [(t, v) for t, v in samples if t >= warmup]
    if len(after) < 2:
        return 0.0, 0.0
    s = slope([t for t, _ in after], [v for _, v in after])
    return s, s * (after[-1][0] - after[0][0])


def stalls(arrivals, start, end, threshold=1.0):
    """Gaps longer than threshold (s) in a sorted list of arrival times within [start, end],
    counting the wait from start to the first arrival and from the last one to end.
    Returns [(gap start, gap length)]."""
    points = [start] + [a for a in arrivals if start <= a <= end] + [end]
    return [(a, b - a) for a, b in zip(points, points[1:]) if b - a > threshold]


def summarize(rss, arrivals, start, end, stall_s=1.0):
    """rss: {process: [(t, bytes)]} (t from the feed's start); arrivals: {topic: [wall time]};
    start, end: the feed's wall times. Returns the report's figures."""
    duration = end - start
    warmup = warmup_seconds(duration)
    times = sorted({t for series in rss.values() for t, _ in series})
    total = [(t, sum(v for series in rss.values() for ts, v in series if ts == t)) for t in times]
    per_process = {}
    for name, series in sorted(rss.items()):
        s, g = growth_after_warmup(series, warmup)
        per_process[name] = {"start_mb": series[0][1] / MB, "end_mb": series[-1][1] / MB,
                             "slope_mb_per_h": s * 3600.0 / MB, "growth_after_warmup_mb": g / MB}
    s, g = growth_after_warmup(total, warmup)
    outputs = {}
    for topic, times_ in sorted(arrivals.items()):
        gaps = stalls(sorted(times_), start, end, stall_s)
        outputs[topic] = {"count": len(times_), "rate_hz": len(times_) / duration if duration > 0 else 0.0,
                          "stalls": [(round(a - start, 2), round(g_, 2)) for a, g_ in gaps],
                          "longest_gap_s": max((b - a for a, b in zip(times_, times_[1:])), default=float("nan"))}
    n_stalls = sum(len(o["stalls"]) for o in outputs.values())
    return {"duration_s": duration, "warmup_s": warmup, "samples": len(total),
            "total": {"start_mb": total[0][1] / MB if total else float("nan"),
                      "end_mb": total[-1][1] / MB if total else float("nan"),
                      "slope_mb_per_h": s * 3600.0 / MB, "growth_after_warmup_mb": g / MB},
            "processes": per_process, "outputs": outputs, "stalls": n_stalls,
            "target_met": g / MB < TARGET_GROWTH_MB and n_stalls == 0
            and all(o["count"] > 0 for o in outputs.values())}


def markdown(res):
    s = res["summary"]
    rows = [[name, fmt(p["start_mb"]), fmt(p["end_mb"]), fmt(p["slope_mb_per_h"], 1, 2),
             fmt(p["growth_after_warmup_mb"], 1, 2)] for name, p in s["processes"].items()]
    t = s["total"]
    rows.append(["**total**", fmt(t["start_mb"]), fmt(t["end_mb"]), fmt(t["slope_mb_per_h"], 1, 2),
                 fmt(t["growth_after_warmup_mb"], 1, 2)])
    out_rows = [[topic, o["count"], fmt(o["rate_hz"]), fmt(o["longest_gap_s"], 1, 2), len(o["stalls"])]
                for topic, o in s["outputs"].items()]
    return "\n".join([
        "# Soak: launch/pipeline.launch fed at %gx for %.0f s" % (res["rate"], s["duration_s"]), "",
        "Bag: %.0f s simulated (%d camera points, seed %d), played in a loop at %gx; RSS sampled every "
        "%.0f s (%d samples); warm-up %.0f s; stall = a gap over %.1f s in an output. Load average "
        "before / after: %.2f / %.2f on %d cores."
        % (res["bag_duration_s"], res["camera_points"], res["seed"], res["rate"], res["interval_s"],
           s["samples"], s["warmup_s"], res["stall_s"], res["loadavg_before"][0], res["loadavg_after"][0],
           res["cpu_count"]), "",
        table(["process", "RSS start, MB", "RSS end, MB", "slope after warm-up, MB/h",
               "growth after warm-up, MB"], rows), "",
        table(["output", "scans", "rate, Hz", "longest gap, s", "stalls"], out_rows), "",
        "Target (growth below %.0f MB after the warm-up, no stall): %s."
        % (TARGET_GROWTH_MB, "met" if s["target_met"] else "MISSED"), ""])


def plot(res, path):
    """RSS of every process and the total (top), and each one's change since its first sample
    (bottom: a leak shows as a rising line, whatever the process's size)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax, dax) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    total = {}
    for name, series in sorted(res["rss"].items()):
        ts, mb = [t for t, _ in series], [v / MB for _, v in series]
        ax.plot(ts, mb, label=name, linewidth=1)
        dax.plot(ts, [m - mb[0] for m in mb], label=name, linewidth=1)
        for t, v in series:
            total[t] = total.get(t, 0) + v
    ts = sorted(total)
    tot = [total[t] / MB for t in ts]
    ax.plot(ts, tot, label="total", color="black", linewidth=2)
    dax.plot(ts, [v - tot[0] for v in tot], label="total", color="black", linewidth=2)
    for a in (ax, dax):
        a.axvline(res["summary"]["warmup_s"], color="grey", linestyle="--", linewidth=1, label="end of warm-up")
        a.grid(alpha=0.3)
    ax.set_ylabel("RSS, MB")
    ax.set_title("Soak at %gx: RSS of every process of the pipeline" % res["rate"])
    ax.legend(fontsize=7, loc="center right")
    dax.set_ylabel("RSS change since the start, MB")
    dax.set_xlabel("time since the feed started, s")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


# ---------------------------------------------------------------- the run (needs ROS)

class _Arrivals:
    """Wall time of every message per topic, without deserialising (AnyMsg)."""

    def __init__(self, topics):
        import rospy
        self.times = {t: [] for t in topics}
        self.subs = [rospy.Subscriber(t, rospy.AnyMsg, self._cb, callback_args=t, queue_size=100)
                     for t in topics]

    def _cb(self, _msg, topic):
        self.times[topic].append(time.time())

    def close(self):
        for s in self.subs:
            s.unregister()


def _rss_sample(procs):
    """{name[pid]: rss bytes} of the processes still alive."""
    import psutil
    out = {}
    for name, p in procs:
        try:
            out["%s[%d]" % (name, p.pid)] = p.memory_info().rss
        except psutil.Error:
            continue
    return out


def run(outdir, duration=1800.0, rate=10.0, interval=10.0, bag_duration=10.0, camera_points=10000, seed=0,
        stall_s=1.0, launch_file=DEFAULT_LAUNCH, log=print):
    from .cpu import simulate
    os.makedirs(outdir, exist_ok=True)
    load0 = os.getloadavg()
    with Session() as session:
        wd = session.workdir
        bag = simulate(os.path.join(wd, "soak.bag"), bag_duration, camera_points, seed)
        with session.launched(launch_file, label="soak") as (launch, _):
            arrivals = player = None
            try:
                arrivals = _Arrivals(OUTPUT_TOPICS)
                if not wait_connected(arrivals.subs, timeout=20.0):
                    raise RunError("could not connect to %s:\n%s" % (", ".join(OUTPUT_TOPICS),
                                                                     log_tail(launch.log_path)))
                player = BagPlayer(bag, os.path.join(wd, "play.log"), rate=rate, extra=["-l"]).start()
                # The feed starts after rosbag play's 1 s delay; the first outputs mark it.
                deadline = time.time() + 30.0
                while not arrivals.times["/merged_scan"]:
                    if time.time() > deadline or not player.running():
                        raise RunError("no /merged_scan within 30 s of the feed:\n%s" % log_tail(launch.log_path))
                    time.sleep(0.05)
                start = time.time()
                rss = {}
                next_sample = start
                while True:
                    now = time.time()
                    if now >= next_sample:
                        procs = launch.processes()
                        for name, value in _rss_sample(procs).items():
                            rss.setdefault(name, []).append((round(now - start, 3), value))
                        log("  %4.0f s: RSS total %.1f MB, %s" % (
                            now - start, sum(s[-1][1] for s in rss.values()) / MB,
                            ", ".join("%s %d" % (t, len(v)) for t, v in arrivals.times.items())))
                        next_sample += interval
                    if now - start >= duration:
                        break
                    if launch.proc.poll() is not None or not player.running():
                        raise RunError("the pipeline or the player stopped after %.0f s:\n%s"
                                       % (now - start, log_tail(launch.log_path)))
                    time.sleep(min(0.5, max(0.0, next_sample - time.time())))
                end = time.time()
                # Processes that exited before the end (e.g. the check_config runs) are not the
                # pipeline's memory: keep those sampled at the end.
                last_t = max(t for series in rss.values() for t, _ in series)
                rss = {k: v for k, v in rss.items() if v[-1][0] == last_t}
                times = {t: list(v) for t, v in arrivals.times.items()}
            finally:
                if player is not None:
                    player.stop()
                if arrivals is not None:
                    arrivals.close()
    res = {"duration_s": duration, "rate": rate, "interval_s": interval, "bag_duration_s": bag_duration,
           "camera_points": camera_points, "seed": seed, "stall_s": stall_s, "loadavg_before": load0,
           "loadavg_after": os.getloadavg(), "cpu_count": os.cpu_count(), "rss": rss,
           "summary": summarize(rss, times, start, end, stall_s)}
    write_json(res, os.path.join(outdir, "soak.json"))
    text = markdown(res)
    with open(os.path.join(outdir, "soak.md"), "w") as f:
        f.write(text)
    plot(res, os.path.join(outdir, "soak.png"))
    return res, text


def main(argv=None):
    import argparse
    p = argparse.ArgumentParser(
        prog="soak",
        description="Soak benchmark: launch/pipeline.launch fed by a simulated bag in a loop at RATE x its "
                    "sensors' rates; samples every process's RSS, counts outputs, finds stalls. Writes "
                    "soak.md, soak.json and soak.png into --output and prints the tables. Exit status: 0 done "
                    "(whether or not the targets were met: see the last line), 2 usage error, 3 the "
                    "pipeline or the simulator failed.")
    p.add_argument("--duration", type=float, default=1800.0, help="seconds of feed (default 1800: 30 min)")
    p.add_argument("--quick", action="store_true", help="a 60-second run for a quick look")
    p.add_argument("--rate", type=float, default=10.0, help="playback rate (default 10x)")
    p.add_argument("--interval", type=float, default=10.0, help="seconds between RSS samples (default 10)")
    p.add_argument("--bag-duration", type=float, default=10.0, help="length of the simulated bag, s (default 10)")
    p.add_argument("--camera-points", type=int, default=10000, help="pixels per depth image (default 10000)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--output", default="soak", metavar="DIR")
    try:
        a = p.parse_args(argv)
    except SystemExit as e:
        return 2 if e.code else 0
    duration = 60.0 if a.quick else a.duration
    problems = []
    if not duration >= 3 * a.interval:
        problems.append("--duration must be at least 3 sampling intervals (%g s), got %g" % (3 * a.interval, duration))
    if not a.interval > 0:
        problems.append("--interval must be > 0")
    if not 0 < a.rate <= 100:
        problems.append("--rate must be within (0, 100]")
    if not a.bag_duration > 1.0:
        problems.append("--bag-duration must be more than 1 s")
    if not 100 <= a.camera_points <= 2000000:
        problems.append("--camera-points must be within 100..2000000")
    if problems:
        for m in problems:
            print("soak: " + m, file=sys.stderr)
        return 2
    try:
        res, text = run(a.output, duration, a.rate, a.interval, a.bag_duration, a.camera_points, a.seed)
    except RunError as e:
        print("soak: %s" % e, file=sys.stderr)
        return 3
    print(text)
    return 0
