"""Real 2D SLAM and localization on recorded scan streams (the paper's Fig. 6 with a SLAM).

For each scan topic (e.g. the lidar-only merge ``/lidar_scan`` and the unified scan of
lidars and depth cameras ``/slam_scan``) recorded while a simulated bag played through the
pipeline:

1. the scans, the bag's ``/odom`` and ``/tf_static`` go into a small bag, which
   ``bag_to_rawlog`` (package scan_evaluation_tools) turns into an MRPT rawlog of
   action/observation pairs (odometry interpolated at each scan's stamp);
2. ``rbpf-slam`` (MRPT's Rao-Blackwellised particle filter grid SLAM, gmapping's family;
   seeded, headless) builds a map and a path from it;
3. the path and the map are brought into the ground truth's frame by the rigid 2D fit of
   the estimated path to the true path (the SLAM's frame is its first pose; the map, the
   most likely particle's, by the fit of that particle's own path), then:
   path RMSE (and that of odometry alone, fitted the same way), map precision (occupied
   cells with a true obstacle within 0.10 m), recall (obstacle cells of the reference map
   with an occupied cell within 0.10 m) and the 3D obstacles found (``mapping.compare_maps``);
4. ``pf-localization`` (MRPT's particle filter localization, AMCL's family) runs on the
   ground-truth obstacle grid with each stream from the true initial pose; its error is the
   RMSE of the weighted particle mean against the true pose.

Needs the MRPT applications (Debian: mrpt-apps) and the built workspace.
"""

import math
import os
import re
import shutil
import subprocess
import time

import numpy as np

from . import mapping
from .results import NotRun, SlamRun, slam_figures

#: Which topics the experiment compares: (lidar-only stream, unified stream). The unified
#: stream is the lidars + depth cameras merge without the ultrasonic arcs (those go to the
#: obstacle-avoidance output /merged_scan only: an arc is no measurement a scan matcher can use).
DEFAULT_TOPICS = ("/lidar_scan", "/slam_scan")
#: Tolerance of the map figures, m.
MAP_TOLERANCE = 0.10
#: Scans closer in time than this to the previous one are left out (both streams get the
#: same rate, and the run stays short).
MIN_INTERVAL = 0.1
#: Targets the demo checks (see check_targets).
TARGETS = {"max_path_rmse": 0.10, "min_map_precision": 0.90, "min_3d_ratio": 2.0,
           "max_localization_gap": 0.02}


class SlamError(Exception):
    """An MRPT application or the converter failed (its log is in the message)."""


# ---------------------------------------------------------------- tools

def package_path(*parts):
    import rospkg
    return os.path.join(rospkg.RosPack().get_path("scan_evaluation_tools"), *parts)


def tool(name):
    """Path of one of scan_evaluation_tools' programs (devel or install space)."""
    from roslib.packages import find_node
    found = find_node("scan_evaluation_tools", name)
    if not found:
        raise SlamError("%s not found: build the workspace and source its setup.bash" % name)
    return found[0]


def _run(cmd, log_path, timeout, cwd=None):
    with open(log_path, "w") as log:
        try:
            # MRPT's apps wait for a key after an error: stdin from /dev/null ends that.
            proc = subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT,
                                  stdin=subprocess.DEVNULL, timeout=timeout, cwd=cwd)
        except FileNotFoundError:
            raise SlamError("%s is not installed (Debian: mrpt-apps)" % cmd[0])
        except subprocess.TimeoutExpired:
            raise SlamError("%s took longer than %.0f s (log %s)" % (cmd[0], timeout, log_path))
    if proc.returncode != 0:
        from ..ros.rosrun import log_tail
        raise SlamError("%s failed with status %d:\n%s" % (" ".join(cmd), proc.returncode,
                                                         log_tail(log_path)))


def ini_with(text, values):
    """The ini ``text`` with ``values`` ({section: {key: value}}) set: an existing
    ``key=`` line of the section is replaced, a missing one appended to the section."""
    lines = text.splitlines()
    out, section, pending = [], None, {s: dict(kv) for s, kv in values.items()}

    def flush(sec):
        for k, v in pending.pop(sec, {}).items():
            out.append("%s=%s" % (k, v))

    for line in lines:
        m = re.match(r"\s*\[([^\]]+)\]", line)
        if m:
            flush(section)
            section = m.group(1)
            out.append(line)
            continue
        m = re.match(r"\s*([A-Za-z0-9_]+)\s*=", line)
        if m and section in pending and m.group(1) in pending[section]:
            out.append("%s=%s" % (m.group(1), pending[section].pop(m.group(1))))
            continue
        out.append(line)
    flush(section)
    for sec in list(pending):
        out.append("[%s]" % sec)
        flush(sec)
    return "\n".join(out) + "\n"


# ---------------------------------------------------------------- inputs

def write_scan_bag(path, scans_by_topic, source_bag, copy_topics=("/odom", "/tf_static")):
    """A bag with the recorded scans (evaluate.Recorder's dicts) and ``copy_topics`` of
    ``source_bag``: what bag_to_rawlog reads."""
    import rosbag
    import rospy
    from sensor_msgs.msg import LaserScan
    from ..ros import bagio
    with rosbag.Bag(path, "w") as out:
        with rosbag.Bag(source_bag) as src:
            for topic, msg, t, header in src.read_messages(topics=list(copy_topics),
                                                           return_connection_header=True):
                out.write(topic, msg, t, connection_header=header)
        for topic, scans in scans_by_topic.items():
            for s in scans:
                m = LaserScan()
                m.header.stamp = bagio.stamp(s["stamp"])
                m.header.frame_id = s["frame"]
                m.angle_min, m.angle_max = s["angle_min"], s["angle_max"]
                m.angle_increment = s["angle_increment"]
                m.range_min, m.range_max = s["range_min"], s["range_max"]
                m.ranges = np.asarray(s["ranges"], np.float32).tolist()
                out.write(topic, m, rospy.Time.from_sec(s["stamp"]))


def convert(bag, topic, rawlog, index, min_interval=MIN_INTERVAL, log_path=None):
    """bag_to_rawlog for one topic; returns the index rows (entry, stamp, odom x, y, yaw)."""
    _run([tool("bag_to_rawlog"), bag, rawlog, "--scan-topic", topic, "--index", index,
          "--min-interval", str(min_interval)], log_path or rawlog + ".log", timeout=300)
    return np.loadtxt(index, ndmin=2)


# ---------------------------------------------------------------- rbpf-slam

def run_rbpf_slam(rawlog, workdir, seed=0, config=None, timeout=900):
    """rbpf-slam on a rawlog; returns {"path": (n, 4) stamp x y yaw of the filter's estimate
    (the particles' mean) at every step, "map_path": (m, 4) the same of the most likely
    particle at the steps where it updated its map (see read_map_path), "map": P(occupied)
    array [row = y, col = x] of the most likely particle, "limits": (x_min, x_max, y_min,
    y_max), "wall_s"}."""
    os.makedirs(workdir, exist_ok=True)
    out = os.path.join(workdir, "rbpf_out")
    with open(config or package_path("config", "rbpf_slam.ini")) as f:
        text = f.read()
    ini = os.path.join(workdir, "rbpf_slam.ini")
    with open(ini, "w") as f:
        f.write(ini_with(text, {"MappingApplication": {
            "rawlog_file": os.path.abspath(rawlog), "logOutput_dir": out,
            "RANDOM_SEED": int(seed)}}))
    t0 = time.time()
    _run(["rbpf-slam", ini], os.path.join(workdir, "rbpf_slam.log"), timeout)
    wall = time.time() - t0
    raw = np.loadtxt(os.path.join(out, "log_estimated_path.txt"), ndmin=2)
    # columns: step x y z yaw pitch roll stamp
    path = np.column_stack([raw[:, 7], raw[:, 1], raw[:, 2], raw[:, 4]])
    base = os.path.join(out, "finalMap_mrpt__maps__COccupancyGridMap2D_00")
    p_free = _read_png_gray(base + ".png") / 255.0
    limits = tuple(np.loadtxt(base + "_limits.txt", comments="%").ravel()[:4])
    map_path = read_map_path(np.loadtxt(os.path.join(out, "most_likely_path.txt"), ndmin=2),
                             np.loadtxt(os.path.join(out, "log_times.txt"), comments="%",
                                        ndmin=2), path)
    return {"path": path, "map_path": map_path, "map": 1.0 - p_free[::-1], "limits": limits,
            "wall_s": wall}


def read_map_path(most_likely, times, path):
    """(m, 4) stamp x y yaw of the path of the particle whose map rbpf-slam saves.

    The per-step path (``log_estimated_path.txt``) is the particles' mean at each step, as
    the filter knew it then; the saved map is the most likely particle's at the end, built
    along that particle's own history (``most_likely_path.txt``: x y yaw, the initial pose
    then one pose per filter update, without stamps). The two can differ by the heading
    spread of the particles, so the map is placed by the fit of its own path. Filter and map
    are updated at the same steps (localizeLinDistance = insertionLinDistance, ...):
    ``log_times.txt``'s 4th column marks them, and ``path`` (the per-step path) gives their
    stamps."""
    most_likely = np.asarray(most_likely, float).reshape(-1, 3)
    times = np.asarray(times, float)
    steps = times[times[:, 3] == 1, 0].astype(int)
    if len(most_likely) != len(steps) + 1:
        raise SlamError("rbpf-slam: %d poses in most_likely_path.txt for %d map updates in "
                        "log_times.txt (expected the initial pose and one per update: the "
                        "filter and the map must update at the same steps)"
                        % (len(most_likely), len(steps)))
    most_likely = most_likely[1:]
    # rows of the per-step path are steps 0, 1, ...
    return np.column_stack([np.asarray(path, float)[steps, 0], most_likely])


def _read_png_gray(path):
    import matplotlib.image as mpimg
    img = mpimg.imread(path)
    if img.ndim == 3:
        img = img[..., 0]
    return np.asarray(img, float) * (255.0 if img.dtype != np.uint8 else 1.0)


# ---------------------------------------------------------------- alignment

def fit_rigid_2d(src, dst):
    """Rotation angle and translation (theta, t) minimising sum |R(theta) src + t - dst|^2
    over matching (n, 2) point sets (least squares, no scale)."""
    src = np.asarray(src, float)
    dst = np.asarray(dst, float)
    cs, cd = src.mean(0), dst.mean(0)
    a, b = src - cs, dst - cd
    theta = math.atan2(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]),
                       np.sum(a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]))
    r = _rot(theta)
    return theta, cd - r @ cs


def _rot(theta):
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


def transform_points(xy, theta, t):
    return np.asarray(xy, float) @ _rot(theta).T + t


def aligned_rmse(est_xy, true_xy):
    """(rmse, theta, t): RMSE of the estimated positions after the best rigid 2D fit."""
    theta, t = fit_rigid_2d(est_xy, true_xy)
    err = transform_points(est_xy, theta, t) - np.asarray(true_xy, float)
    return float(np.sqrt(np.mean(np.sum(err ** 2, 1)))), theta, t


class ResampledMap:
    """An occupancy probability grid (another frame, another resolution) seen on the ground
    truth's grid: nearest cell after the rigid transform (theta, t) from its frame into
    the truth's. Duck-types mapping.Grid for compare_maps (occupied, known)."""

    def __init__(self, p_occ, limits, theta, t, refs, unknown_band=0.02):
        p_occ = np.asarray(p_occ, float)
        x_min, x_max, y_min, y_max = limits
        res_x = (x_max - x_min) / p_occ.shape[1]
        res_y = (y_max - y_min) / p_occ.shape[0]
        (x0, y0), res = refs["origin"], refs["resolution"]
        ny, nx = refs["truth"].shape
        gx, gy = np.meshgrid(x0 + (np.arange(nx) + 0.5) * res, y0 + (np.arange(ny) + 0.5) * res)
        # truth frame -> the map's own frame (inverse of the fitted transform)
        pts = (np.column_stack([gx.ravel(), gy.ravel()]) - t) @ _rot(theta)
        ix = np.floor((pts[:, 0] - x_min) / res_x).astype(np.int64)
        iy = np.floor((pts[:, 1] - y_min) / res_y).astype(np.int64)
        inside = (ix >= 0) & (iy >= 0) & (ix < p_occ.shape[1]) & (iy < p_occ.shape[0])
        p = np.full(ix.size, 0.5)
        p[inside] = p_occ[iy[inside], ix[inside]]
        self.p = p.reshape(ny, nx)
        self.unknown_band = unknown_band

    def occupied(self):
        return self.p > 0.5 + self.unknown_band

    def known(self):
        return np.abs(self.p - 0.5) > self.unknown_band


# ---------------------------------------------------------------- pf-localization

def write_gridmap(refs, workdir, name="truth"):
    """The ground-truth obstacle grid as map_server files, converted to MRPT's .gridmap
    (ros-map-yaml2mrpt); returns the .gridmap path."""
    os.makedirs(workdir, exist_ok=True)
    g = mapping.Grid(refs["origin"], refs["resolution"], refs["truth"].shape)
    g.hits[refs["truth"]] = 1
    g.misses[~refs["truth"]] = 1
    base = os.path.join(workdir, name)
    g.save_pgm(base)
    _run(["ros-map-yaml2mrpt", "-q", "-w", "-i", base + ".yaml", "-d", workdir],
         base + "_yaml2mrpt.log", timeout=120)
    for cand in (base + ".gridmap", base + ".gridmap.gz"):
        if os.path.isfile(cand):
            return cand
    raise SlamError("ros-map-yaml2mrpt wrote no %s.gridmap" % base)


_PDF_LINE = re.compile(r"PDF estimation:\s*\(?\s*([-+0-9.eE]+)\s*,\s*([-+0-9.eE]+)\s*,"
                       r"\s*([-+0-9.eE]+)")


def run_pf_localization(rawlog, gridmap, start_pose, workdir, config=None, timeout=900,
                        box=0.2, box_yaw_deg=5.0):
    """pf-localization on ``gridmap`` from a uniform box around ``start_pose`` (x, y, yaw);
    returns {"mean": (steps, 3) x y yaw of the weighted particle mean per rawlog entry,
    "wall_s"}."""
    os.makedirs(workdir, exist_ok=True)
    with open(config or package_path("config", "pf_localization.ini")) as f:
        text = f.read()
    x, y, yaw = start_pose
    ini = os.path.join(workdir, "pf_localization.ini")
    with open(ini, "w") as f:
        f.write(ini_with(text, {"LocalizationExperiment": {
            "map_file": os.path.abspath(gridmap), "rawlog_file": os.path.abspath(rawlog),
            "logOutput_dir": os.path.join(workdir, "pf_out"),
            "init_PDF_min_x": x - box, "init_PDF_max_x": x + box,
            "init_PDF_min_y": y - box, "init_PDF_max_y": y + box,
            "init_PDF_min_yaw_deg": math.degrees(yaw) - box_yaw_deg,
            "init_PDF_max_yaw_deg": math.degrees(yaw) + box_yaw_deg}}))
    log = os.path.join(workdir, "pf_localization.log")
    t0 = time.time()
    _run(["pf-localization", ini], log, timeout)
    wall = time.time() - t0
    with open(log, errors="replace") as f:
        means = parse_pf_estimates(f)
    if not len(means):
        raise SlamError("pf-localization printed no estimate (log %s)" % log)
    return {"mean": means, "wall_s": wall}


def parse_pf_estimates(lines):
    """(steps, 3) x, y, yaw (rad) from pf-localization's "PDF estimation: (x,y,yawdeg)"
    lines, one per rawlog entry."""
    means = [[float(v) for v in m.groups()] for m in map(_PDF_LINE.search, lines) if m]
    means = np.asarray(means, float).reshape(-1, 3)
    means[:, 2] = np.radians(means[:, 2])  # MRPT prints the angle in degrees
    return means


# ---------------------------------------------------------------- the experiment

def slam_experiment(scans_by_topic, source_bag, scenario, refs, outdir, workdir=None,
                    topics=DEFAULT_TOPICS, seed=0, min_interval=MIN_INTERVAL,
                    localization=True, log=print):
    """SLAM and localization on each recorded stream; writes slam_maps.png and
    slam_paths.png into ``outdir`` and returns a ``SlamRun`` (NotRun when no topic was
    recorded).

    scans_by_topic: {topic: [scan dicts]} (evaluate.Recorder); refs: the dict of
    ``mapping.reference_maps`` (ground-truth grids, reference maps, known-pose maps)."""
    topics = [t for t in topics if scans_by_topic.get(t)]
    if not topics:
        return NotRun("none of the SLAM topics was recorded")
    own = workdir is None
    workdir = workdir or os.path.join(outdir, "slam_work")
    os.makedirs(workdir, exist_ok=True)
    bag = os.path.join(workdir, "scans.bag")
    write_scan_bag(bag, {t: scans_by_topic[t] for t in topics}, source_bag)
    gridmap = write_gridmap(refs, workdir) if localization else None
    slam, loc, runs = {}, {}, {}
    for topic in topics:
        key = topic.strip("/").replace("/", "_")
        wd = os.path.join(workdir, key)
        os.makedirs(wd, exist_ok=True)
        rawlog = os.path.join(wd, key + ".rawlog")
        index = convert(bag, topic, rawlog, os.path.join(wd, key + ".index"), min_interval)
        log("SLAM on %s: %d scans, rbpf-slam" % (topic, len(index)))
        run = run_rbpf_slam(rawlog, wd, seed=seed)
        slam[topic], runs[topic] = evaluate_slam(run, index, scenario, refs)
        slam[topic]["scans"] = int(len(index))
        if localization:
            log("localization on %s: pf-localization on the ground-truth map" % topic)
            start = scenario.true_pose(index[0, 1])
            pf = run_pf_localization(rawlog, gridmap, start, os.path.join(wd, "pf"))
            loc[topic] = evaluate_localization(pf, index, scenario)
            runs[topic]["localization"] = pf
    figures = {"maps": plot_maps(slam, runs, refs, os.path.join(outdir, "slam_maps.png")),
               "paths": plot_paths(runs, refs, scenario, os.path.join(outdir, "slam_paths.png"))}
    if own:
        shutil.rmtree(workdir, ignore_errors=True)
    return SlamRun(slam=slam, localization=loc if localization else None, figures=figures,
                   min_interval_s=min_interval, seed=seed, tolerance_m=MAP_TOLERANCE)


def evaluate_slam(run, index, scenario, refs):
    """Figures of one rbpf-slam run against the ground truth (and the run's aligned data
    for the plots). The per-step path is placed by the rigid fit of it to the true path, the
    map by the fit of its own particle's path (read_map_path)."""
    path = run["path"]
    true = np.array([scenario.true_pose(s)[:2] for s in path[:, 0]])
    rmse, theta, t = aligned_rmse(path[:, 1:3], true)
    map_path = run["map_path"]
    map_true = np.array([scenario.true_pose(s)[:2] for s in map_path[:, 0]])
    map_rmse, map_theta, map_t = aligned_rmse(map_path[:, 1:3], map_true)
    odo_true = np.array([scenario.true_pose(s)[:2] for s in index[:, 1]])
    odo_rmse, odo_theta, odo_t = aligned_rmse(index[:, 2:4], odo_true)
    grid = ResampledMap(run["map"], run["limits"], map_theta, map_t, refs)
    tol = int(round(MAP_TOLERANCE / refs["resolution"]))
    f = mapping.compare_maps({"slam": grid}, refs["truth"], refs["plane"], refs["reference"],
                             tolerance_cells=tol, reference_3d=refs["reference_3d"])["slam"]
    fig = {"path_rmse_m": rmse, "odometry_rmse_m": odo_rmse,
           "path_max_error_m": float(np.max(np.hypot(*(transform_points(path[:, 1:3], theta, t)
                                                      - true).T))),
           "map_precision": f["precision"], "map_recall": f["found"],
           "obstacles_3d_found": f["found_3d"], "occupied_cells": f["occupied_cells"],
           "false_cells": f["false_cells"], "alignment_deg": math.degrees(theta),
           "map_path_rmse_m": map_rmse, "map_alignment_deg": math.degrees(map_theta),
           "steps": int(len(path)), "wall_s": run["wall_s"]}
    aligned = {"path": transform_points(path[:, 1:3], theta, t), "true": true,
               "odometry": transform_points(index[:, 2:4], odo_theta, odo_t), "grid": grid}
    return fig, aligned


def evaluate_localization(pf, index, scenario):
    """RMSE of the weighted particle mean per rawlog entry against the true pose."""
    mean = pf["mean"]
    n = min(len(mean), len(index))
    true = np.array([scenario.true_pose(s) for s in index[:n, 1]])
    err = np.hypot(mean[:n, 0] - true[:, 0], mean[:n, 1] - true[:, 1])
    dyaw = (mean[:n, 2] - true[:, 2] + np.pi) % (2 * np.pi) - np.pi
    pf["true"] = true[:, :2]
    return {"rmse_m": float(np.sqrt(np.mean(err ** 2))), "max_error_m": float(err.max()),
            "yaw_rmse_deg": float(np.degrees(np.sqrt(np.mean(dyaw ** 2)))), "steps": int(n),
            "wall_s": pf["wall_s"]}


# ---------------------------------------------------------------- targets

def check_targets(run, targets=TARGETS, lidar_topic=DEFAULT_TOPICS[0],
                  unified_topic=DEFAULT_TOPICS[1]):
    """(ok, text) per target of the SLAM step ``run`` (SlamRun, NotRun or None): both
    streams' SLAM path RMSE, the unified map's precision, its 3D obstacles against the
    lidar-only map's, localization of the unified stream against the lidar-only one. A target
    whose figures are missing fails."""
    slam, loc = slam_figures(run)
    checks = []

    def get(section, topic, key):
        v = section.get(topic, {}).get(key)
        return float("nan") if v is None else float(v)

    if targets.get("max_path_rmse") is not None:
        for topic in (lidar_topic, unified_topic):
            v = get(slam, topic, "path_rmse_m")
            checks.append((v <= targets["max_path_rmse"],
                           "slam %s path_rmse_m: %.4g <= %.4g" % (topic, v,
                                                                   targets["max_path_rmse"])))
    if targets.get("min_map_precision") is not None:
        v = get(slam, unified_topic, "map_precision")
        checks.append((v >= targets["min_map_precision"], "slam %s map_precision: %.4g >= %.4g"
                       % (unified_topic, v, targets["min_map_precision"])))
    if targets.get("min_3d_ratio") is not None:
        u, l = get(slam, unified_topic, "obstacles_3d_found"), get(slam, lidar_topic,
                                                                     "obstacles_3d_found")
        need = targets["min_3d_ratio"] * l
        checks.append((u >= need and u > 0, "slam %s obstacles_3d_found: %.4g >= %.4g x %s's "
                       "(%.4g)" % (unified_topic, u, targets["min_3d_ratio"], lidar_topic, l)))
    if targets.get("max_localization_gap") is not None and loc:
        u, l = get(loc, unified_topic, "rmse_m"), get(loc, lidar_topic, "rmse_m")
        checks.append((u <= l + targets["max_localization_gap"],
                       "localization %s rmse_m: %.4g <= %s's %.4g + %.4g"
                       % (unified_topic, u, lidar_topic, l, targets["max_localization_gap"])))
    return [(bool(ok), text) for ok, text in checks]


# ---------------------------------------------------------------- plots

def map_columns(known, runs):
    """The topics of the map figure's columns after the ground truth: the known-pose maps' topics,
    then those only SLAM ran on; each SLAM map goes under the known-pose map of its own scan."""
    return list(known) + [t for t in runs if t not in known]


def plot_maps(slam, runs, refs, path):
    """Ground truth, the known-pose maps (mapping experiment) and the SLAM maps, one PNG."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    known = refs.get("maps", {})
    # One column per topic: a SLAM map under the known-pose map of the same scan.
    topics = map_columns(known, runs)
    cols = len(topics) + 1
    fig, axes = plt.subplots(2, cols, figsize=(4.2 * cols, 7.0), squeeze=False)
    extent = mapping.grid_extent(refs)
    axes[0][0].imshow(mapping.truth_image(refs), origin="lower", extent=extent,
                      interpolation="nearest")
    axes[0][0].set_title("ground truth (red: above the lidars' plane)", fontsize=8)
    used = {(0, 0)}
    for name, g in known.items():
        col = 1 + topics.index(name)
        ax = axes[0][col]
        used.add((0, col))
        ax.imshow(mapping.map_image(g, refs), origin="lower", extent=extent,
                  interpolation="nearest")
        ax.set_title("known poses: %s" % name, fontsize=8)
    for topic, r in runs.items():
        col = 1 + topics.index(topic)
        ax = axes[1][col]
        used.add((1, col))
        ax.imshow(mapping.map_image(r["grid"], refs), origin="lower", extent=extent,
                  interpolation="nearest")
        f = slam[topic]
        ax.set_title("rbpf-slam: %s\npath RMSE %.3f m, precision %.2f, 3D obstacles %.0f%%"
                     % (topic, f["path_rmse_m"], f["map_precision"],
                        100 * f["obstacles_3d_found"]), fontsize=8)
    for r, row in enumerate(axes):
        for c, ax in enumerate(row):
            if (r, c) not in used:
                ax.axis("off")  # no map for this scan (e.g. a topic mapped but not fed to SLAM)
    for row in axes:
        for ax in row:
            ax.tick_params(labelsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return os.path.basename(path)


def plot_paths(runs, refs, scenario, path):
    """The true path, odometry and each stream's SLAM and localization paths over the
    ground-truth map."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(9, 6.5))
    img = np.where(refs["truth"][..., None], 0.55, 1.0) * np.ones(3)
    ax.imshow(img, origin="lower", extent=mapping.grid_extent(refs), interpolation="nearest")
    first = next(iter(runs.values()))
    ax.plot(*first["true"].T, "k-", lw=2.0, label="ground truth")
    ax.plot(*first["odometry"].T, ":", color="tab:gray", lw=1.2,
            label="odometry alone (fitted)")
    colours = ["tab:orange", "tab:red", "tab:green", "tab:purple"]
    for (topic, r), c in zip(runs.items(), colours):
        ax.plot(*r["path"].T, "-", color=c, lw=1.0, label="rbpf-slam %s" % topic)
        if "localization" in r:
            ax.plot(*r["localization"]["mean"][:, :2].T, "--", color=c, lw=0.8,
                    label="pf-localization %s" % topic)
    tr = first["true"]
    pad = 2.0
    ax.set_xlim(tr[:, 0].min() - pad, tr[:, 0].max() + pad)
    ax.set_ylim(tr[:, 1].min() - pad, tr[:, 1].max() + pad)
    ax.set_aspect("equal")
    ax.legend(fontsize=7, loc="best")
    ax.set_xlabel("x, m")
    ax.set_ylabel("y, m")
    ax.set_title("Paths in the ground truth's frame (SLAM paths after the rigid 2D fit)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return os.path.basename(path)
