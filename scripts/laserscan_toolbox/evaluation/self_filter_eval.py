"""False obstacles on the robot's own parts (the simulated arm), with and without the self filter.

The scenario knows where the arm is at every instant (``Arm.boxes``); a return of a scan in
base_link that falls inside a link's padded box, seen from above (the boxes are level), is an
obstacle on the robot itself. Without the filter, the same bag is played once more through the
same launch with configs whose ``self_filter`` blocks are removed (``unfiltered_config_dir``):
the cost is one more playback of the bag (about its duration).

results.json's ``self_filter``, per scan topic: ``returns_on_robot`` (summed over the run),
``returns_on_robot_unfiltered``, ``near_robot_obstacles`` (ideal returns of the world within
``NEAR`` outside a padded box) and ``kept_near_robot_percent`` (of those, the share the output
reads within the accuracy's tolerance).
"""
import glob
import os
import shutil

import numpy as np
import yaml

from . import metrics

#: Obstacles of the world this close outside the padded boxes must be kept (m).
NEAR = 0.05
#: Configs whose self filter the evaluation reads the padding from.
PADDING_CONFIG = "merged_scan.yaml"


def config_padding(config_dir, name=PADDING_CONFIG):
    """The ``self_filter/padding`` of a config (None: the config has no self filter)."""
    with open(os.path.join(config_dir, name)) as f:
        block = (yaml.safe_load(f) or {}).get("self_filter")
    if block is None:
        return None
    return float(block.get("padding", 0.02))


def unfiltered_config_dir(config_dir, dest):
    """A copy of config_dir (every file) whose YAMLs have no ``self_filter`` block."""
    os.makedirs(dest, exist_ok=True)
    for path in glob.glob(os.path.join(config_dir, "*")):
        target = os.path.join(dest, os.path.basename(path))
        if path.endswith(".yaml"):
            with open(path) as f:
                cfg = yaml.safe_load(f) or {}
            cfg.pop("self_filter", None)
            with open(target, "w") as f:
                yaml.safe_dump(cfg, f, sort_keys=False)
        elif os.path.isfile(path):
            shutil.copy(path, target)
    return dest


def _outside_distance(px, py, centers, half, yaw, padding):
    """Distance (P, L) from points to each padded box's footprint, 0 inside."""
    dx = px[:, None] - centers[None, :, 0]
    dy = py[:, None] - centers[None, :, 1]
    c, s = np.cos(yaw)[None], np.sin(yaw)[None]
    lx = np.abs(c * dx + s * dy) - (half[None, :, 0] + padding)
    ly = np.abs(-s * dx + c * dy) - (half[None, :, 1] + padding)
    return np.hypot(np.maximum(lx, 0.0), np.maximum(ly, 0.0))


def _points(ranges, angle_min, angle_increment):
    r = np.asarray(ranges, float)
    a = angle_min + np.arange(r.size) * angle_increment
    ok = metrics.is_return(r)
    r = np.where(ok, r, 0.0)
    return r * np.cos(a), r * np.sin(a), ok


def robot_returns(scans, scenario, padding):
    """Returns of the scans (base_link) inside the arm's padded boxes at their stamps, summed."""
    n = 0
    for s in scans:
        x, y, ok = _points(s["ranges"], s["angle_min"], s["angle_increment"])
        if not ok.any():
            continue
        centers, half, yaw = scenario.robot.arm.boxes(s["stamp"] - scenario.start_time)
        d = _outside_distance(x[ok], y[ok], centers, half, yaw, padding)
        n += int(np.count_nonzero((d <= 0.0).any(axis=1)))
    return n


def kept_near_robot(scans, scenario, padding, band, tol=0.05, rel_tol=0.03, beam_window=1):
    """(obstacles of the world within NEAR outside the padded boxes, how many the scans keep)."""
    near = kept = 0
    _, zlo, zhi = band
    for s in scans:
        ideal = scenario.ideal_scan(s["stamp"], s["angle_min"], s["angle_max"], s["angle_increment"],
                                    s["range_min"], s["range_max"], zlo, zhi)
        x, y, ok = _points(ideal, s["angle_min"], s["angle_increment"])
        if not ok.any():
            continue
        centers, half, yaw = scenario.robot.arm.boxes(s["stamp"] - scenario.start_time)
        d = _outside_distance(x[ok], y[ok], centers, half, yaw, padding).min(axis=1)
        beams = np.flatnonzero(ok)[(d > 0.0) & (d <= NEAR)]
        out = np.asarray(s["ranges"], float)
        for b in beams:
            lo, hi = max(0, b - beam_window), min(out.size, b + beam_window + 1)
            near += 1
            kept += bool(np.any(np.abs(out[lo:hi] - ideal[b]) <= tol + rel_tol * ideal[b]))
    return near, kept


def self_filter_stats(filtered, unfiltered, scenario, padding, band, tol=0.05, rel_tol=0.03,
                      max_scans=300):
    """results.json's ``self_filter`` entry for each topic of ``filtered`` ({topic: scans}):
    returns on the robot over every scan, the obstacles near it over at most max_scans evenly
    spaced ones (each needs an ideal scan)."""
    out = {}
    for topic, scans in filtered.items():
        step = max(1, int(np.ceil(len(scans) / float(max_scans))))
        near, kept = kept_near_robot(scans[::step], scenario, padding, band, tol, rel_tol)
        out[topic] = {
            "scans": len(scans), "padding_m": padding,
            "returns_on_robot": robot_returns(scans, scenario, padding),
            "returns_on_robot_unfiltered": (robot_returns(unfiltered[topic], scenario, padding)
                                            if topic in unfiltered else None),
            "scans_unfiltered": len(unfiltered.get(topic, [])),
            "near_robot_obstacles": near,
            "kept_near_robot_percent": 100.0 * kept / near if near else None}
    return out
