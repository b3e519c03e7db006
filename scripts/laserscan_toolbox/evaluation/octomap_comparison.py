"""The unified scan against a 3D method on the same data: OctoMap (the paper's title claim).

On a simulated bag that ``evaluate`` has played through the pipeline (with the mapping
experiment's ground truth and maps), ``bag_to_octomap`` (package scan_evaluation_tools)
builds an OctoMap OcTree from the bag's depth images and lidar scans at the true poses, as
octomap_server would, at each resolution asked; its projected map of the robot's height band
is judged with the mapping experiment's own figures (``mapping.compare_maps``, in one call with
the known-pose maps of the scan streams, so that every map is judged over the same observed
area), and its cost is put beside the unified path's:

- OctoMap, accuracy run: one message per topic per ``ACCURACY_INTERVAL`` s (mapping packages
  throttle their input, as the known-pose 2D maps do); map memory: the tree's
  (``OcTree::memoryUsage``);
- OctoMap, cost run: every depth image and scan of the first ``COST_WINDOW`` s, as a live
  octomap_server gets them; CPU: the tool's process CPU time per second of data (bag reading,
  depth image to points, insertion, inner nodes and pruning after every cloud; offline, no
  /clock); peak memory: the larger of the two runs' peak resident memory;
- unified: the nodelet manager's CPU per second of data while the bag played (the
  converters, mergers and range converters in one process, as ``evaluate`` measures it:
  under simulated time, so with its /clock subscription) plus the process CPU of building
  the known-pose 2D grid of the unified scan in this process; map memory: that grid as a
  robot holds it (one byte per cell, nav_msgs/OccupancyGrid) over the box of the cells it
  knows; peak memory: the manager's peak resident memory. With the SLAM experiment run,
  its map figures and rbpf-slam's time per second of data are added under ``slam``.
"""

import json
import os
import subprocess
import time

import numpy as np

from . import mapping
from .results import NotRun
from ..ros.rosrun import MANAGER_TAG

#: One message per topic per this many seconds in the accuracy run.
ACCURACY_INTERVAL = 1.0
#: Seconds of data of the cost run (every message).
COST_WINDOW = 2.0
RESOLUTIONS = (0.05,)
UNIFIED_TOPIC = "/slam_scan"
LIDAR_TOPIC = "/lidar_scan"
POSE_TOPIC = "/ground_truth/odom"
#: Targets of issue 20 (docs/octomap.md).
TARGETS = {"min_3d_ratio": 0.9, "max_precision_gap": 0.05, "min_cpu_ratio": 10.0,
           "cpu_ratio_from_points": 100000, "min_memory_ratio": 10.0}


class OctoMapError(Exception):
    """bag_to_octomap failed (its output is in the message)."""


def voxel_band(band, resolution):
    """The band's lower edge raised to the next voxel boundary: a voxel that reaches into the
    band counts (octomap_server's test), so at 0.10 m the voxel [0, 0.10) that holds the floor
    would make the whole floor an obstacle of a 0.05-1.0 m band; a user of that map sets the
    band's floor to 0.10 m, and misses what is lower."""
    import math
    lo = math.ceil(band[0] / resolution - 1e-9) * resolution + 1e-6
    return (lo, band[1])


def run_tool(bag, outdir, resolution, depth_topics, scan_topics, band, pose_topic=POSE_TOPIC,
             min_interval=0.0, duration=0.0, poses=None):
    """bag_to_octomap on ``bag``; returns its figures.json as a dict."""
    from .slam import tool
    os.makedirs(outdir, exist_ok=True)
    cmd = [tool("bag_to_octomap"), bag, outdir, "--resolution", str(resolution),
           "--band-min", str(band[0]), "--band-max", str(band[1]),
           "--min-interval", str(min_interval), "--duration", str(duration)]
    cmd += ["--poses", poses] if poses else ["--pose-topic", pose_topic]
    for t in depth_topics:
        cmd += ["--depth-topic", t]
    for t in scan_topics:
        cmd += ["--scan-topic", t]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise OctoMapError("%s failed with status %d:\n%s" % (" ".join(cmd), p.returncode,
                                                             (p.stderr or p.stdout)[-2000:]))
    with open(os.path.join(outdir, "figures.json")) as f:
        return json.load(f)


def read_map_server(yaml_path):
    """(P(occupied) array [row = y up, col = x] with 1 occupied, 0 free, 0.5 unknown,
    (x_min, x_max, y_min, y_max)) of map_server files (trinary PGM + YAML)."""
    import yaml
    with open(yaml_path) as f:
        meta = yaml.safe_load(f)
    with open(os.path.join(os.path.dirname(yaml_path), meta["image"]), "rb") as f:
        magic, width, height, _ = f.readline(), *map(int, f.readline().split()), f.readline()
        if magic.strip() != b"P5":
            raise ValueError("%s: not a binary PGM" % meta["image"])
        img = np.frombuffer(f.read(width * height), np.uint8).reshape(height, width)[::-1]
    p = np.full(img.shape, 0.5)
    p[img == 0] = 1.0
    p[img == 254] = 0.0
    res = float(meta["resolution"])
    x0, y0 = float(meta["origin"][0]), float(meta["origin"][1])
    return p, (x0, x0 + width * res, y0, y0 + height * res)


def projected_grid(outdir, refs):
    """The tool's projected map on the ground truth's grid (duck-types mapping.Grid)."""
    from .slam import ResampledMap
    p, limits = read_map_server(os.path.join(outdir, "projected_map.yaml"))
    return ResampledMap(p, limits, 0.0, np.zeros(2), refs)


def grid_memory_mb(grid):
    """A 2D grid as a robot holds it: one byte per cell over the box of its known cells."""
    rows, cols = np.nonzero(grid.known())
    if not rows.size:
        return 0.0
    return (rows.max() - rows.min() + 1) * (cols.max() - cols.min() + 1) / 1e6


def _manager(cpu):
    return [c for name, c in cpu.items() if name.endswith(MANAGER_TAG)]


def compare(bag, info, scenario, results, refs, run, outdir, resolutions=RESOLUTIONS,
            accuracy_interval=ACCURACY_INTERVAL, cost_window=COST_WINDOW, log=print):
    """The comparison on one evaluated bag (``results``: its EvaluationResult so far); returns
    {"runs": [...], "targets": [...], ...} (NotRun without depth images or the unified map)
    and writes octomap_maps.png into ``outdir``."""
    depth = sorted(t for t, v in info["topics"].items()
                   if v["type"] == "sensor_msgs/Image" and "depth" in t)
    lidars = sorted(t for t, v in info["topics"].items()
                    if v["type"] == "sensor_msgs/LaserScan")
    maps = refs.get("maps", {})
    if not depth or UNIFIED_TOPIC not in maps:
        return NotRun("needs depth images in the bag and the known-pose map of %s" % UNIFIED_TOPIC)
    floor, zlo, zhi = results.band
    band = (floor + zlo, floor + zhi)
    data_s = info["end"] - info["start"]
    cam = scenario.robot.cameras[0]
    points = int(cam.width * cam.height)
    os.makedirs(outdir, exist_ok=True)
    octo = {}
    for r in resolutions:
        key = "octomap %.2f m" % r
        wd = os.path.join(outdir, "octomap_%03.0fmm" % (r * 1000))
        log("OctoMap at %.2f m: accuracy run (one message per topic per %.1f s)"
            % (r, accuracy_interval))
        acc = run_tool(bag, wd, r, depth, lidars, voxel_band(band, r),
                       min_interval=accuracy_interval)
        log("OctoMap at %.2f m: cost run (every message of %.1f s)" % (r, cost_window))
        cost = run_tool(bag, wd + "_cost", r, depth, lidars, voxel_band(band, r),
                        duration=cost_window)
        octo[key] = {"resolution": r, "accuracy": acc, "cost": cost,
                     "grid": projected_grid(wd, refs)}
    judged = dict(maps)
    judged.update({k: v["grid"] for k, v in octo.items()})
    figures = mapping.compare_maps(judged, refs["truth"], refs["plane"], refs["reference"],
                                   reference_3d=refs["reference_3d"])

    # the unified path's cost: the manager while the bag played + the 2D grid built here
    scans = [s for s in run["records"][UNIFIED_TOPIC]["scans"]
             if info["start"] <= s["stamp"] <= info["end"]]
    t0 = time.process_time()
    mapping.build_map(scans, scenario.true_pose, refs["origin"], refs["resolution"],
                      refs["truth"].shape)
    grid_cpu = (time.process_time() - t0) / data_s
    managers = _manager(results.cpu)
    pipeline_cpu = sum(c["cpu_percent"] for c in managers) / 100.0
    peak = sum(c.get("peak_rss_mb", c["rss_mb"]) for c in managers)

    def accuracy(name):
        f = figures[name]
        return {"obstacles_3d_found": f["found_3d"], "map_precision": f["precision"],
                "map_recall": f["found"], "false_cells": f["false_cells"],
                "iou": f["iou"]}

    unified = dict({"method": "unified", "points_per_camera": points,
                    "resolution_m": refs["resolution"],
                    "cpu_s_per_s": pipeline_cpu + grid_cpu, "pipeline_cpu_s_per_s": pipeline_cpu,
                    "grid_cpu_s_per_s": grid_cpu, "map_memory_mb": grid_memory_mb(maps[UNIFIED_TOPIC]),
                    "peak_memory_mb": peak, "topic": UNIFIED_TOPIC}, **accuracy(UNIFIED_TOPIC))
    slam = results.slam_figures()[0].get(UNIFIED_TOPIC)
    if slam:
        unified["slam"] = {"map_precision": slam["map_precision"], "map_recall": slam["map_recall"],
                           "obstacles_3d_found": slam["obstacles_3d_found"],
                           "wall_s_per_s": slam["wall_s"] / data_s}
    runs = [unified]
    for key, o in octo.items():
        acc, cost = o["accuracy"], o["cost"]
        runs.append(dict({"method": "octomap", "points_per_camera": points,
                          "resolution_m": o["resolution"], "cpu_s_per_s": cost["cpu_s_per_s"],
                          "octomap_cpu_s_per_s": cost["octomap_cpu_s_per_s"],
                          "update_share": cost["update_cpu_s"] / max(1e-9, cost["octomap_cpu_s"]),
                          "map_memory_mb": acc["tree_memory_mb"],
                          "peak_memory_mb": max(acc["peak_rss_mb"], cost["peak_rss_mb"]),
                          "tree_nodes": acc["tree_nodes"],
                          "points_inserted": acc["points_inserted"],
                          "points_per_s": cost["points_inserted"] / cost["data_s"],
                          "accuracy_cpu_s": acc["cpu_s"]}, **accuracy(key)))
    out = {"runs": runs, "bag_s": data_s, "band_m": list(band), "depth_topics": depth,
           "scan_topics": lidars, "accuracy_interval_s": accuracy_interval,
           "cost_window_s": cost_window, "lidar_only": accuracy(LIDAR_TOPIC) if LIDAR_TOPIC in
           figures else None}
    out["targets"] = [{"ok": ok, "check": text} for ok, text in check_targets(runs)]
    columns = [(n, maps[n]) for n in (LIDAR_TOPIC, UNIFIED_TOPIC) if n in maps]
    columns += [(k, o["grid"]) for k, o in octo.items()]
    out["figure"] = plot_maps(columns, figures, refs, os.path.join(outdir, "octomap_maps.png"))
    return out


def _k(n):
    """A point count as the sweep names it (the simulator rounds to whole image rows)."""
    return "%dk" % round(n / 1000.0)


def check_targets(runs, targets=TARGETS):
    """(ok, text) per target of issue 20 that ``runs`` hold figures for: accuracy per point count
    against OctoMap at the finest resolution; CPU at ``cpu_ratio_from_points`` and above; map
    memory at the finest resolution; with several point counts, the unified CPU flat (largest /
    smallest below 1.5) while OctoMap's grows (more than 2x)."""
    checks = []
    octo = [r for r in runs if r["method"] == "octomap"]
    if not octo:
        return checks
    finest = min(r["resolution_m"] for r in octo)
    for u in (r for r in runs if r["method"] == "unified"):
        n = u["points_per_camera"]
        o = next((r for r in octo if r["points_per_camera"] == n and r["resolution_m"] == finest), None)
        if o is None:
            continue
        checks.append((u["obstacles_3d_found"] >= targets["min_3d_ratio"] * o["obstacles_3d_found"],
                       "%s points: unified 3D obstacles found %.3f >= %.1f x OctoMap's %.3f"
                       % (_k(n), u["obstacles_3d_found"], targets["min_3d_ratio"],
                          o["obstacles_3d_found"])))
        checks.append((u["map_precision"] >= o["map_precision"] - targets["max_precision_gap"],
                       "%s points: unified map precision %.3f >= OctoMap's %.3f - %.2f"
                       % (_k(n), u["map_precision"], o["map_precision"],
                          targets["max_precision_gap"])))
        if n >= 0.99 * targets["cpu_ratio_from_points"]:
            ratio = o["cpu_s_per_s"] / u["cpu_s_per_s"]
            checks.append((ratio >= targets["min_cpu_ratio"],
                           "%s points: OctoMap CPU / unified CPU %.1f >= %.0f"
                           % (_k(n), ratio, targets["min_cpu_ratio"])))
        mem = o["map_memory_mb"] / max(1e-12, u["map_memory_mb"])
        checks.append((mem >= targets["min_memory_ratio"],
                       "%s points: OcTree memory at %.2f m / 2D grid %.1f >= %.0f"
                       % (_k(n), finest, mem, targets["min_memory_ratio"])))
    uni = sorted((r for r in runs if r["method"] == "unified"), key=lambda r: r["points_per_camera"])
    fin = sorted((r for r in octo if r["resolution_m"] == finest), key=lambda r: r["points_per_camera"])
    if len(uni) > 1 and len(fin) > 1:
        cpu = [r["cpu_s_per_s"] for r in uni]
        checks.append((max(cpu) / min(cpu) < 1.5, "unified CPU flat across point counts: largest / "
                       "smallest %.2f < 1.5" % (max(cpu) / min(cpu))))
        growth = fin[-1]["cpu_s_per_s"] / fin[0]["cpu_s_per_s"]
        checks.append((growth > 2.0, "OctoMap CPU grows with the points: %s / %s points %.1f > 2"
                       % (_k(fin[-1]["points_per_camera"]), _k(fin[0]["points_per_camera"]), growth)))
    return [(bool(ok), text) for ok, text in checks]


def plot_maps(columns, figures, refs, path):
    """Ground truth, then each map (lidar-only, unified, OctoMap projections) side by side."""
    from .report import _plt
    plt = _plt()
    n = len(columns) + 1
    fig, axes = plt.subplots(1, n, figsize=(4.0 * n, 3.6))
    extent = mapping.grid_extent(refs)
    axes[0].imshow(mapping.truth_image(refs), origin="lower", extent=extent,
                   interpolation="nearest")
    axes[0].set_title("ground truth (red: above the lidars' plane)", fontsize=8)
    for ax, (name, g) in zip(axes[1:], columns):
        ax.imshow(mapping.map_image(g, refs), origin="lower", extent=extent,
                  interpolation="nearest")
        f = figures[name]
        ax.set_title("%s\nprecision %.2f, recall %.2f, 3D obstacles %.0f%%"
                     % (name, f["precision"], f["found"], 100 * f["found_3d"]), fontsize=8)
    for ax in axes:
        ax.tick_params(labelsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return os.path.basename(path)
