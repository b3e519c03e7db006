"""The unified scan against OctoMap over depth points per camera and resolutions.

For each number of depth points per camera, a scenario bag is simulated (the CPU
experiment's ``simulate``) and evaluated with the OctoMap comparison
(``evaluation.evaluate`` with ``octomap``: the pipeline, the known-pose maps, bag_to_octomap at
each resolution); the runs of every point count go into one JSON file
(``octomap_comparison.json``: ``{"runs": [...], "targets": [...]}``), a table
(``octomap_comparison.md``), the plot of CPU and memory against the points
(``octomap_cost.png``) and the maps of the point count nearest 100k (``octomap_maps.png``).
"""

import json
import os
import shutil
import sys
import time

from ..evaluation import octomap_comparison as oc
from ..evaluation.evaluate import evaluate
from ..evaluation.report import octomap_table, write_json
from ..evaluation.results import EvaluationResult, NotRun, ran
from ..ros.rosrun import RunError
from .cpu import simulate

POINTS = (10000, 50000, 100000, 300000)
QUICK_POINTS = (100000,)
RESOLUTIONS = (0.05, 0.10)


def one_point_count(work, n, resolutions, duration, seed, log, attempts=2):
    """The evaluation with the OctoMap comparison on a simulated bag of ``n`` points per
    camera; returns its "octomap" entry. A playback that recorded nothing (seen once on a
    loaded shared machine: no output at all) is run again."""
    bag = os.path.join(work, "scenario.bag")
    os.makedirs(work, exist_ok=True)
    log("%d points per camera: simulating %.0f s" % (n, duration))
    simulate(bag, duration, n, seed)
    try:
        for attempt in range(attempts):
            res = evaluate(bag, output=work, progress=False, plots=False, log=log,
                           octomap=resolutions)
            comparison = res.octomap
            if comparison is None:  # not run: the mapping step said why, or there is no truth
                comparison = res.mapping if isinstance(res.mapping, NotRun) else NotRun(
                    "the bag has no ground truth")
            if ran(comparison):
                return comparison
            log("%d points per camera, attempt %d: OctoMap comparison skipped: %s"
                % (n, attempt + 1, comparison.reason))
    finally:
        os.remove(bag)
    raise RunError("OctoMap comparison skipped: %s" % comparison.reason)


def done_before(work, resolutions, duration):
    """The "octomap" entry of an earlier run in ``work`` with the same duration and
    resolutions, or None (results.json holds no seed: --resume is for the same command)."""
    try:
        with open(os.path.join(work, "results.json")) as f:
            res = EvaluationResult.from_json(json.load(f))
    except (OSError, ValueError, TypeError):
        return None
    comparison = res.octomap
    same = (ran(comparison) and abs(res.bag_duration_s - duration) < 1.0
            and sorted(r["resolution_m"] for r in comparison["runs"] if r["method"] == "octomap")
            == sorted(resolutions))
    return comparison if same else None


def sweep(outdir, points=POINTS, resolutions=RESOLUTIONS, duration=20.0, seed=0, log=print,
          resume=False):
    os.makedirs(outdir, exist_ok=True)
    t0 = time.time()
    runs, per_point = [], {}
    for n in points:
        work = os.path.join(outdir, "points_%d" % n)
        comparison = done_before(work, resolutions, duration) if resume else None
        if comparison is None:
            comparison = one_point_count(work, n, resolutions, duration, seed, log)
        else:
            log("%d points per camera: kept from %s" % (n, work))
        runs += comparison["runs"]
        per_point[n] = comparison
    nearest = min(per_point, key=lambda n: abs(n - 100000))
    shutil.copy(os.path.join(outdir, "points_%d" % nearest, "octomap", per_point[nearest]["figure"]),
                os.path.join(outdir, "octomap_maps.png"))
    res = {"runs": runs, "targets": [{"ok": ok, "check": c} for ok, c in oc.check_targets(runs)],
           "duration_s": duration, "seed": seed, "resolutions_m": list(resolutions),
           "accuracy_interval_s": oc.ACCURACY_INTERVAL, "cost_window_s": oc.COST_WINDOW,
           "maps_points_per_camera": nearest, "wall_s": time.time() - t0}
    write_json(res, os.path.join(outdir, "octomap_comparison.json"))
    plot_cost(runs, os.path.join(outdir, "octomap_cost.png"))
    with open(os.path.join(outdir, "octomap_comparison.md"), "w") as f:
        f.write("\n".join(["# The unified scan against OctoMap", "",
                           "Scenario bags of %.0f s per point count (seed %d); this run took %.0f s (point counts kept "
                           "by --resume not counted). "
                           "Method: docs/octomap.md." % (duration, seed, res["wall_s"]), "",
                           octomap_table(runs), ""]
                          + ["- %s %s" % ("met:" if t["ok"] else "**missed:**", t["check"])
                             for t in res["targets"]]
                          + ["", "![cost](octomap_cost.png)", "", "![maps](octomap_maps.png)", ""]))
    return res


def plot_cost(runs, path):
    """CPU per second of data and memory against depth points, both methods."""
    from ..evaluation.report import _plt
    plt = _plt()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 3.4))
    series = {}
    for r in runs:
        key = ("unified (converters + mergers + 2D grid)" if r["method"] == "unified"
               else "OctoMap %.2f m" % r["resolution_m"])
        series.setdefault(key, []).append(r)
    for key, rs in series.items():
        rs = sorted(rs, key=lambda r: r["points_per_camera"])
        x = [r["points_per_camera"] / 1000.0 for r in rs]
        marker = "o" if key.startswith("unified") else "s"
        line = a1.semilogy(x, [r["cpu_s_per_s"] for r in rs], marker + "-", label=key)[0]
        a2.semilogy(x, [r["map_memory_mb"] for r in rs], marker + "-", color=line.get_color(),
                    label=key + ", map")
        a2.semilogy(x, [r["peak_memory_mb"] for r in rs], marker + ":", color=line.get_color(),
                    alpha=0.6, label=key + ", peak of the process")
    a1.set_xlabel("depth points per camera (thousands)")
    a1.set_ylabel("CPU s per s of data")
    a2.set_xlabel("depth points per camera (thousands)")
    a2.set_ylabel("memory, MB")
    for a in (a1, a2):
        a.grid(alpha=0.3, which="both")
        a.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main(argv=None):
    import argparse
    p = argparse.ArgumentParser(
        prog="octomap_comparison",
        description="The unified scan against OctoMap (bag_to_octomap) on simulated bags: "
                    "accuracy of the maps and cost, over depth points per camera and "
                    "resolutions (docs/octomap.md). Writes DIR/octomap_comparison.json. Exit "
                    "status: 0 done (targets met or not: see the JSON), 2 usage error, 3 the "
                    "pipeline, the simulator or bag_to_octomap failed.")
    p.add_argument("--output", default="octomap_comparison", metavar="DIR")
    p.add_argument("--points", type=int, nargs="+", metavar="N",
                   help="points per camera (default %s)" % " ".join(map(str, POINTS)))
    p.add_argument("--resolutions", type=float, nargs="+", metavar="M",
                   help="OcTree resolutions, m (default %s)" % " ".join(map(str, RESOLUTIONS)))
    p.add_argument("--duration", type=float, default=20.0, help="bag length per point count, s")
    p.add_argument("--quick", action="store_true", help="%s points per camera only" %
                   "/".join(map(str, QUICK_POINTS)))
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--resume", action="store_true",
                   help="keep the point counts that DIR already holds with the same settings")
    try:
        a = p.parse_args(argv)
    except SystemExit as e:
        return 2 if e.code else 0
    points = a.points or (QUICK_POINTS if a.quick else POINTS)
    resolutions = a.resolutions or RESOLUTIONS
    if any(n <= 0 for n in points) or any(r <= 0 for r in resolutions) or a.duration <= 0:
        print("octomap_comparison: points, resolutions and duration must be > 0", file=sys.stderr)
        return 2
    try:
        res = sweep(a.output, points, resolutions, a.duration, a.seed,
                    log=lambda m: print(m, file=sys.stderr), resume=a.resume)
    except (RunError, oc.OctoMapError) as e:
        print("octomap_comparison: %s" % e, file=sys.stderr)
        return 3
    for t in res["targets"]:
        print("%s %s" % ("met" if t["ok"] else "MISSED", t["check"]))
    print("wrote %s" % os.path.join(a.output, "octomap_comparison.json"))
    return 0
