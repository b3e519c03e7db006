"""CPU of the whole pipeline in ONE nodelet manager (zero-copy) against standalone nodes.

One short scenario bag is simulated once and played through launch/pipeline.launch in both
modes (same launch arguments except ``standalone``), alternating the modes ``repeat`` times
to spread background load evenly. For every run this process subscribes to the merged
outputs (so the whole path is active) and measures the CPU time (user + sys, in ns:
ros.cpu_accounting) of every process roslaunch started (the manager, or every standalone
node), over the playback window only. The bag is played on wall time as a robot's drivers
publish (``ros.wall_clock_play``: no /clock, stamps moved to now): under rosbag's /clock every
process, each standalone node and each idle loader client, would also pay for taking the clock
200 times a second. Reported per mode (medians over the repeats): CPU per
merged output in ms, CPU in % of one core (per second of window), outputs counted, and the
ratio standalone / manager.
"""

import os
import statistics
import sys
import time

from ..evaluation.report import fmt, table, write_json
from ..ros.cpu_accounting import snapshot, spent, tree_processes
from ..ros.rosrun import (LOADER_TAG, REPO, RunError, Session, WallClockPlayer, log_tail, process_name,
                          wait_connected)

MODES = ("manager", "standalone")
OUTPUT_TOPICS = ("/merged_scan", "/lidar_scan")
DEFAULT_LAUNCH = os.path.join(REPO, "launch", "pipeline.launch")


def loader_cpu_s(per_process):
    """CPU seconds of the nodelet loader clients among ``spent()``'s per_process figures."""
    return sum(v for k, v in per_process.items() if k.rsplit("[", 1)[0].endswith(LOADER_TAG))


# ---------------------------------------------------------------- results (pure)

def run_figures(cpu_s, window_s, outputs, loader_s=0.0):
    """Figures of one run: CPU per merged output (ms) and CPU in % of one core, of every
    process, and of the working processes only (without the nodelet loader clients)."""
    work = cpu_s - loader_s
    return {"cpu_s": cpu_s, "loader_s": loader_s, "window_s": window_s, "outputs": outputs,
            "cpu_ms_per_output": 1000.0 * cpu_s / outputs if outputs > 0 else float("nan"),
            "cpu_percent": 100.0 * cpu_s / window_s if window_s > 0 else float("nan"),
            "work_ms_per_output": 1000.0 * work / outputs if outputs > 0 else float("nan")}


FIGURES = ("cpu_ms_per_output", "cpu_percent", "work_ms_per_output")


def summarize(runs):
    """runs: [{"mode": ..., "cpu_ms_per_output", "cpu_percent", "outputs", "processes"}].
    Returns {mode: medians} plus "ratio" (standalone / manager) of both CPU figures."""
    out = {}
    for mode in MODES:
        rs = [r for r in runs if r["mode"] == mode]
        if not rs:
            continue
        out[mode] = {k: statistics.median(r[k] for r in rs)
                     for k in FIGURES + ("outputs", "processes")}
        out[mode]["runs"] = len(rs)
    if "manager" in out and "standalone" in out:
        m, s = out["manager"], out["standalone"]
        out["ratio"] = {k: (s[k] / m[k] if m[k] > 0 else float("nan")) for k in FIGURES}
    return out


def markdown_table(summary):
    rows = []
    for mode, label in (("manager", "one nodelet manager (zero-copy)"),
                        ("standalone", "standalone nodes")):
        if mode in summary:
            s = summary[mode]
            rows.append([label, "%d" % s["processes"], fmt(s["cpu_ms_per_output"], 1, 2),
                         fmt(s["cpu_percent"]), fmt(s["work_ms_per_output"], 1, 2),
                         "%d" % s["outputs"], "%d" % s["runs"]])
    if "ratio" in summary:
        r = summary["ratio"]
        rows.append(["ratio standalone / manager", "", fmt(r["cpu_ms_per_output"], 1, 2),
                     fmt(r["cpu_percent"], 1, 2), fmt(r["work_ms_per_output"], 1, 2), "", ""])
    return table(["mode", "processes", "CPU per merged scan, ms", "CPU, % of one core",
                  "CPU per merged scan without loader clients, ms", "merged scans counted",
                  "runs (median)"], rows)


# ---------------------------------------------------------------- one run (needs ROS)

def measure(session, bag, mode, launch_file, launch_args, label, tail=0.5):
    """Plays ``bag`` through the launch in ``mode``; returns that run's figures."""
    args = list(launch_args) + ["standalone:=%s" % ("true" if mode == "standalone" else "false")]
    wd = session.workdir
    rec = None
    with session.launched(launch_file, args, label, wall_time=True) as (launch, pubs):
        try:
            missing = [t for t in OUTPUT_TOPICS if t not in pubs]
            if missing:
                raise RunError("%s: the pipeline does not publish %s:\n%s"
                               % (mode, ", ".join(missing), log_tail(launch.log_path)))
            rec = _Counter(OUTPUT_TOPICS)
            if not wait_connected(rec.subs, timeout=10.0):
                raise RunError("%s: could not connect to %s" % (mode, ", ".join(OUTPUT_TOPICS)))
            procs = tree_processes(launch.proc.pid)
            player = WallClockPlayer(bag, os.path.join(wd, label + "_play.log"))
            try:
                player.start()
                before = snapshot(procs, process_name)
                t0 = time.time()
                n0 = dict(rec.count)
                player.wait(timeout=600.0)
            finally:
                player.stop()
            time.sleep(tail)  # the last inputs' outputs are still on their way
            # re-list the tree: a node respawned during the window would be counted from 0
            after = snapshot(tree_processes(launch.proc.pid), process_name)
            window = time.time() - t0
            counts = {t: rec.count[t] - n0[t] for t in OUTPUT_TOPICS}
            launch.raise_if_stopped("%s: the pipeline" % mode)
            d = spent(before, after)
            if counts["/merged_scan"] == 0:
                raise RunError("%s: no /merged_scan during playback:\n%s"
                               % (mode, log_tail(launch.log_path)))
            fig = run_figures(d["total_s"], window, counts["/merged_scan"],
                              loader_cpu_s(d["per_process"]))
            fig.update({"mode": mode, "processes": len(d["per_process"]), "counts": counts,
                        "per_process_cpu_s": d["per_process"], "lost": d["lost"],
                        "cpu_source": d["source"]})
            return fig
        finally:
            if rec is not None:
                rec.close()


class _Counter:
    """Counts messages per topic without deserialising them (AnyMsg)."""

    def __init__(self, topics):
        import rospy
        self.count = {t: 0 for t in topics}
        self.subs = [rospy.Subscriber(t, rospy.AnyMsg, self._cb, callback_args=t,
                                      queue_size=100, tcp_nodelay=True) for t in topics]

    def _cb(self, _msg, topic):
        self.count[topic] += 1

    def close(self):
        for s in self.subs:
            s.unregister()


def experiment(outdir, duration=12.0, camera_points=None, repeat=2, launch_file=DEFAULT_LAUNCH,
               launch_args=(), seed=0, log=print):
    from .cpu import simulate
    os.makedirs(outdir, exist_ok=True)
    t_start = time.time()
    runs = []
    load0 = os.getloadavg()
    with Session() as session:
        bag = os.path.join(session.workdir, "transport.bag")
        if camera_points is None:
            _simulate_default(bag, duration, seed)
        else:
            simulate(bag, duration, camera_points, seed)
        for i in range(repeat):
            # alternate which mode goes first so slow drifts in background load cancel
            order = MODES if i % 2 == 0 else MODES[::-1]
            for mode in order:
                r = measure(session, bag, mode, launch_file, launch_args, "%s_%d" % (mode, i))
                r["repeat"] = i
                runs.append(r)
                log("run %d %-10s: %s ms CPU per merged scan (%s without loaders), %s %% of "
                    "one core, %d merged scans, %d processes"
                    % (i, mode, fmt(r["cpu_ms_per_output"], 1, 2),
                       fmt(r["work_ms_per_output"], 1, 2), fmt(r["cpu_percent"]),
                       r["outputs"], r["processes"]))
    summary = summarize(runs)
    res = {"duration_s": duration, "camera_points": camera_points, "repeat": repeat,
           "seed": seed, "launch": launch_file, "launch_args": list(launch_args),
           "loadavg_before": load0, "loadavg_after": os.getloadavg(), "cpu_count": os.cpu_count(),
           "runs": runs, "summary": summary, "wall_s": time.time() - t_start}
    write_json(res, os.path.join(outdir, "transport_results.json"))
    text = markdown(res)
    with open(os.path.join(outdir, "transport_experiment.md"), "w") as f:
        f.write(text)
    return res, text


def _simulate_default(bag, duration, seed):
    """simulate_scenario with its default camera size."""
    import subprocess
    from .cpu import SIMULATE
    p = subprocess.run([sys.executable, SIMULATE, "--output", bag, "--duration", str(duration),
                        "--seed", str(seed), "--no-progress"], capture_output=True, text=True)
    if p.returncode != 0:
        raise RunError("simulate_scenario failed: %s" % (p.stderr[-2000:] or p.stdout[-2000:]))


def markdown(res):
    cam = "default camera size" if res["camera_points"] is None else \
        "%d points per camera" % res["camera_points"]
    la, lb = res["loadavg_before"], res["loadavg_after"]
    return "\n".join([
        "# One nodelet manager (zero-copy) against standalone nodes", "",
        "Whole pipeline of launch/pipeline.launch (every node it starts: the depth-camera converters, "
        "with depth_input:=cloud after depth_image_proc's point_cloud_xyz, the range converters and the "
        "mergers; transport_results.json names each process); "
        "one simulated bag of %.0f s (%s, seed %d) played %d times per mode, modes alternating; "
        "medians. The bag is played on wall time (no /clock, stamps moved to now), as a robot runs. "
        "CPU = user + sys of every process roslaunch started, over the playback window "
        "(playback, 0.5 s tail), with a consumer of /merged_scan and "
        "/lidar_scan. Load average before / after: %.2f / %.2f on %d cores. Total run %.0f s."
        % (res["duration_s"], cam, res["seed"], res["repeat"], la[0], lb[0], res["cpu_count"],
           res["wall_s"]), "",
        "In the manager mode roslaunch also starts one `nodelet load` client per nodelet; "
        "they only idle and are counted in the first two figures, not in the third.", "",
        markdown_table(res["summary"]), ""])


def main(argv=None):
    import argparse
    p = argparse.ArgumentParser(
        prog="transport_experiment",
        description="CPU per merged scan of the whole pipeline in one nodelet manager "
                    "(zero-copy) against one process per node (standalone:=true), same bag, "
                    "same launch arguments. Writes transport_experiment.md and "
                    "transport_results.json into --output and prints the table. Exit status: "
                    "0 done, 2 usage error, 3 the pipeline or the simulator failed.")
    p.add_argument("--duration", type=float, default=12.0, help="bag length, s (default 12)")
    p.add_argument("--camera-points", type=int, default=None, metavar="N",
                   help="pixels per depth image (default: simulate_scenario's default)")
    p.add_argument("--repeat", type=int, default=2, help="runs per mode (default 2)")
    p.add_argument("--output", default="transport_experiment", metavar="DIR")
    p.add_argument("--launch", default=DEFAULT_LAUNCH, help="launch file (default: pipeline)")
    p.add_argument("--arg", action="append", default=[], metavar="NAME:=VALUE",
                   help="extra launch argument, given to both modes")
    p.add_argument("--seed", type=int, default=0)
    try:
        a = p.parse_args(argv)
    except SystemExit as e:
        return 2 if e.code else 0
    if not a.duration > 1.0:
        print("transport_experiment: --duration must be more than 1 s, got %s" % a.duration,
              file=sys.stderr)
        return 2
    if a.repeat < 1:
        print("transport_experiment: --repeat must be >= 1, got %d" % a.repeat, file=sys.stderr)
        return 2
    if a.camera_points is not None and not 100 <= a.camera_points <= 2000000:
        print("transport_experiment: --camera-points must be within 100..2000000, got %d"
              % a.camera_points, file=sys.stderr)
        return 2
    if any(x.startswith("standalone:=") for x in a.arg):
        print("transport_experiment: --arg standalone:=... is set by the experiment itself",
              file=sys.stderr)
        return 2
    try:
        _, text = experiment(a.output, a.duration, a.camera_points, a.repeat, a.launch, a.arg,
                             a.seed, log=lambda m: print(m, file=sys.stderr))
    except RunError as e:
        print("transport_experiment: %s" % e, file=sys.stderr)
        return 3
    print(text)
    print("wrote %s" % os.path.join(a.output, "transport_experiment.md"))
    return 0
