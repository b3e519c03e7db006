"""CPU against depth points (the paper's Fig. 8).

For each number of depth points per camera, a short scenario bag is simulated and played
three times through the pipeline (one nodelet manager):

- run "merged_image": the cameras' depth images go straight to scans (pipeline.launch's
  default depth_input:=image: depth-image converters + mergers); a consumer takes only the
  merged scan. Measured: CPU of the manager, size and rate of the merged scan.
- run "merged": the same through depth_image_proc/point_cloud_xyz + the cloud converters
  (depth_input:=cloud), the path for cameras that only publish clouds.
- run "raw" (depth_input:=cloud): a consumer takes what it would need without the pipeline's
  output: the depth clouds and the lidar scans. Measured: their size and rate as received, the
  manager's CPU (which now also serialises the clouds for an out-of-process consumer),
  and the consumer's own CPU.

Every run plays the bag on wall time as a robot's drivers publish (``run_pipeline_on_wall_time``:
use_sim_time false, no /clock, stamps moved to now): under rosbag's /clock every ROS process
would also pay for taking the clock 200 times a second, which a robot does not.
"""

import os
import subprocess
import sys
import time

import numpy as np

from ..evaluation import metrics
from ..evaluation.playback import DEFAULT_LAUNCH, inspect_bag, run_pipeline_on_wall_time
from ..evaluation.report import fmt, table, write_json
from ..ros.rosrun import MANAGER_TAG, REPO, RunError, Session

POINTS = (10000, 50000, 100000, 200000, 300000)
QUICK_POINTS = (10000, 100000, 300000)
SIMULATE = os.path.join(REPO, "scripts", "simulate_scenario")


def simulate(path, duration, points, seed=0):
    cmd = [sys.executable, SIMULATE, "--output", path, "--duration", str(duration),
           "--seed", str(seed), "--camera-points", str(points)]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise RunError("simulate_scenario failed: %s" % (p.stderr[-2000:] or p.stdout[-2000:]))
    return path


def manager_cpu_percent(cpu):
    """CPU (% of one core) of the nodelet managers among a run's figures per process (named by
    rosrun.process_name): the work of every nodelet, without the idle loader clients."""
    return sum(c["cpu_percent"] for name, c in cpu.items() if name.endswith(MANAGER_TAG))


def measure(session, bag, launch, launch_args, consumer, merged_topic):
    """One playback; consumer 'merged' or 'raw'. Returns figures."""
    info = inspect_bag(bag)
    if consumer == "merged":
        types = ("sensor_msgs/LaserScan",)
    else:
        types = ("sensor_msgs/PointCloud2", "sensor_msgs/LaserScan")
    run = run_pipeline_on_wall_time(session, info, launch, launch_args, record_types=types,
                                    label="%s_%s" % (os.path.basename(bag), consumer),
                                    select=_selector(consumer, merged_topic, info))
    own = run["consumer_cpu_percent"]
    dur = run["data_s"]
    recv = {t: d for t, d in run["records"].items()}
    out = {"consumer": consumer, "bag_s": dur, "topics": {}, "consumer_cpu_percent": own}
    total_bytes = 0
    for t, d in recv.items():
        b = float(np.sum(d["bytes"])) if d["bytes"] else 0.0
        total_bytes += b
        st = [s for s in d["stamp"] if s is not None]
        out["topics"][t] = {"messages": len(d["bytes"]), "bytes_per_s": b / dur,
                            "rate_hz": metrics.rate_stats(st)["rate"]}
    out["bytes_per_s"] = total_bytes / dur
    # lidar scans come from the bag: what a consumer of raw inputs also takes
    if consumer == "raw":
        for t, v in info["topics"].items():
            if v["type"] == "sensor_msgs/LaserScan" and t not in recv:
                out["topics"][t] = {"messages": v["count"], "bytes_per_s": v["bytes"] / dur,
                                    "rate_hz": metrics.rate_stats(v["stamps"])["rate"]}
                out["bytes_per_s"] += v["bytes"] / dur
    out["manager_cpu_percent"] = manager_cpu_percent(run["cpu"])
    out["all_cpu_percent"] = sum(c["cpu_percent"] for c in run["cpu"].values())
    out["cpu"] = run["cpu"]
    return out


def _selector(consumer, merged_topic, info):
    def select(topic, type_):
        if consumer == "merged":
            return topic == merged_topic
        if type_ == "sensor_msgs/PointCloud2":
            return "filtered" not in topic  # the converters' inputs, not their rviz output
        return False
    return select


def experiment(outdir, points=POINTS, duration=4.0, launch=DEFAULT_LAUNCH, launch_args=(),
               merged_topic="/merged_scan", seed=0, progress=True, log=print, workdir=None):
    os.makedirs(outdir, exist_ok=True)
    rows = []
    t0 = time.time()
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(points) * 4, desc="cpu experiment", unit="step", file=sys.stderr)
    with Session(workdir=workdir) as session:
        for n in points:
            bag = os.path.join(session.workdir, "points_%d.bag" % n)
            simulate(bag, duration, n, seed)
            if bar:
                bar.update()
            image_args, cloud_args = list(launch_args) + ["depth_input:=image"], list(launch_args) + [
                "depth_input:=cloud"]
            merged_image = measure(session, bag, launch, image_args, "merged", merged_topic)
            if bar:
                bar.update()
            merged = measure(session, bag, launch, cloud_args, "merged", merged_topic)
            if bar:
                bar.update()
            raw = measure(session, bag, launch, cloud_args, "raw", merged_topic)
            if bar:
                bar.update()
            os.remove(bag)
            rows.append({"points_per_camera": n, "merged_image": merged_image, "merged": merged, "raw": raw})
            log("%7d points/camera: manager CPU %s%% (image path) / %s%% (cloud path), merged scan %s kB/s, "
                "raw inputs %s kB/s" % (n, fmt(merged_image["manager_cpu_percent"]),
                                        fmt(merged["manager_cpu_percent"]),
                                        fmt(merged["bytes_per_s"], 1e-3),
                                        fmt(raw["bytes_per_s"], 1e-3)))
    if bar:
        bar.close()
    res = {"points": list(points), "duration_s": duration, "rows": rows,
           "wall_s": time.time() - t0}
    write_json(res, os.path.join(outdir, "cpu_results.json"))
    plot(res, os.path.join(outdir, "cpu_vs_points.png"))
    write_markdown(res, os.path.join(outdir, "cpu_experiment.md"))
    return res


def plot(res, path):
    from ..evaluation.report import _plt
    plt = _plt()
    pts = np.array([r["points_per_camera"] for r in res["rows"]]) / 1000.0
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 3.4))
    a1.plot(pts, [r["merged_image"]["manager_cpu_percent"] for r in res["rows"]], "D-",
            label="pipeline manager, depth images -> scans, merged scan out")
    a1.plot(pts, [r["merged"]["manager_cpu_percent"] for r in res["rows"]], "o-",
            label="pipeline manager, point_cloud_xyz + cloud converters, merged scan out")
    a1.plot(pts, [r["raw"]["manager_cpu_percent"] for r in res["rows"]], "s--",
            label="pipeline manager, consumer takes raw clouds")
    a1.plot(pts, [r["raw"]["consumer_cpu_percent"] for r in res["rows"]], "^:",
            label="consumer of raw clouds + scans")
    a1.plot(pts, [r["merged"]["consumer_cpu_percent"] for r in res["rows"]], "v:",
            label="consumer of the merged scan")
    a1.set_xlabel("depth points per camera (thousands)")
    a1.set_ylabel("CPU, % of one core")
    a1.legend(fontsize=6)
    a1.grid(alpha=0.3)
    a2.semilogy(pts, [r["raw"]["bytes_per_s"] / 1e6 for r in res["rows"]], "s--",
                label="raw inputs (clouds + lidar scans)")
    a2.semilogy(pts, [r["merged"]["bytes_per_s"] / 1e6 for r in res["rows"]], "o-",
                label="merged scan")
    a2.set_xlabel("depth points per camera (thousands)")
    a2.set_ylabel("what the consumer receives, MB/s")
    a2.legend(fontsize=6)
    a2.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def write_markdown(res, path):
    rows = []
    for r in res["rows"]:
        m, w = r["merged"], r["raw"]
        mrate = [v["rate_hz"] for t, v in m["topics"].items()]
        rows.append([r["points_per_camera"], fmt(r["merged_image"]["manager_cpu_percent"]),
                     fmt(m["manager_cpu_percent"]),
                     fmt(w["manager_cpu_percent"]), fmt(m["consumer_cpu_percent"]),
                     fmt(w["consumer_cpu_percent"]), fmt(m["bytes_per_s"], 1e-3),
                     fmt(mrate[0] if mrate else float("nan")), fmt(w["bytes_per_s"], 1e-6, 2),
                     fmt(w["bytes_per_s"] / m["bytes_per_s"] if m["bytes_per_s"] else float("nan"), 1, 0)])
    text = ["# CPU against depth points", "",
            "Simulated bags of %.0f s per point count; one nodelet manager runs one of the two "
            "camera paths (image path: depth-image converters; cloud path: depth_image_proc + "
            "cloud converters) and the mergers. Each bag is played on wall time as a robot runs "
            "(no /clock, stamps moved to now). CPU: CPU seconds per second of bag data, in "
            "percent of one core; "
            "sizes as received by an out-of-process consumer. Total run %.0f s." % (
                res["duration_s"], res["wall_s"]), "",
            table(["points per camera", "manager CPU %, image path, merged consumer",
                   "manager CPU %, cloud path, merged consumer",
                   "manager CPU %, raw consumer", "consumer CPU %, merged",
                   "consumer CPU %, raw", "merged scan kB/s", "merged scan Hz",
                   "raw inputs MB/s", "raw / merged size"], rows), "",
            "![cpu](cpu_vs_points.png)", ""]
    with open(path, "w") as f:
        f.write("\n".join(text))


def main(argv=None):
    import argparse
    p = argparse.ArgumentParser(
        prog="cpu_experiment",
        description="CPU of the pipeline and size of what a consumer receives against the "
                    "number of depth points per camera (paper Fig. 8). Exit status: 0 done, "
                    "2 usage error, 3 the pipeline or the simulator failed.")
    p.add_argument("--output", default="cpu_experiment", metavar="DIR")
    p.add_argument("--points", type=int, nargs="+", metavar="N",
                   help="points per camera (default %s)" % " ".join(map(str, POINTS)))
    p.add_argument("--duration", type=float, default=4.0, help="bag length per run, s")
    p.add_argument("--quick", action="store_true",
                   help="%s points, 2 s bags" % "/".join(map(str, QUICK_POINTS)))
    p.add_argument("--launch", default=DEFAULT_LAUNCH)
    p.add_argument("--arg", action="append", default=[], metavar="NAME:=VALUE")
    p.add_argument("--merged-topic", default="/merged_scan")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--no-progress", action="store_true")
    try:
        a = p.parse_args(argv)
    except SystemExit as e:
        return 2 if e.code else 0
    points = a.points or (QUICK_POINTS if a.quick else POINTS)
    duration = 2.0 if a.quick and a.duration == 4.0 else a.duration
    if any(n <= 0 for n in points) or duration <= 0:
        print("cpu_experiment: points and duration must be > 0", file=sys.stderr)
        return 2
    try:
        experiment(a.output, points, duration, a.launch, a.arg, a.merged_topic, a.seed,
                   not a.no_progress, log=lambda m: print(m, file=sys.stderr))
    except RunError as e:
        print("cpu_experiment: %s" % e, file=sys.stderr)
        return 3
    print("wrote %s" % os.path.join(a.output, "cpu_experiment.md"))
    return 0
