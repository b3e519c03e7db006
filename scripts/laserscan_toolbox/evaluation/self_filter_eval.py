"""False obstacles on the robot's own parts (the simulated arm), with and without the self filter.

The scenario knows where the arm is at every instant (``Arm.boxes``); a return of a scan in
base_link that falls inside a link's padded box, seen from above (the boxes are level), is an
obstacle on the robot itself: the boxes where they are at the scan's stamp and where they were in
the world during the LOOKBACK before it, seen from the robot at the stamp (a merger's deskewed
returns on the arm land there). Without the filter, the same bag is played once more through the
same launch with configs whose ``self_filter`` blocks are removed (``unfiltered_config_dir``):
the cost is one more playback of the bag (about its duration).

results.json's ``self_filter``, per scan topic: ``returns_on_robot`` (summed over the run),
``returns_on_robot_unfiltered``, ``near_robot_obstacles`` (returns without the filter within
``NEAR`` outside a padded box that the ideal scan confirms as the world's) and
``kept_near_robot_percent`` (of those, the share the filtered output reads at the same stamp).
"""
import glob
import os
import shutil

import numpy as np
import yaml

from . import metrics

#: Obstacles of the world this close outside the padded boxes must be kept (m).
NEAR = 0.05
#: How long before a scan's stamp its returns may have been measured (s): the mergers' longest
#: source timeout. A merger deskews every return as a point fixed in the world, so one on the
#: arm (which moves with the robot) lands where the arm was in the world when it was measured.
LOOKBACK = 0.3
LOOKBACK_STEP = 0.025
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


def delete_self_filter_params(master):
    """Delete every ``.../self_filter`` namespace from the parameter server (rosgraph.Master)."""
    spaces = set()
    for name in master.getParamNames():
        parts = name.split("/")
        if "self_filter" in parts:
            spaces.add("/".join(parts[:parts.index("self_filter") + 1]))
    for space in sorted(spaces):
        master.deleteParam(space)
    return sorted(spaces)


def _outside_distance(px, py, centers, half, yaw, padding):
    """Distance (P, L) from points to each padded box's footprint, 0 inside."""
    dx = px[:, None] - centers[None, :, 0]
    dy = py[:, None] - centers[None, :, 1]
    c, s = np.cos(yaw)[None], np.sin(yaw)[None]
    lx = np.abs(c * dx + s * dy) - (half[None, :, 0] + padding)
    ly = np.abs(-s * dx + c * dy) - (half[None, :, 1] + padding)
    return np.hypot(np.maximum(lx, 0.0), np.maximum(ly, 0.0))


def arm_boxes_at(scenario, stamp):
    """The arm's boxes (centres (K, 3), half sizes (K, 3), yaws (K,)) in base_link at ``stamp``:
    at the stamp and at the world poses they had over the LOOKBACK before it."""
    taus = stamp - np.arange(0.0, LOOKBACK + 1e-9, LOOKBACK_STEP)
    centers, half, yaw = scenario.robot.arm.boxes(taus - scenario.start_time)   # (T, L, ...)
    x, y, th = scenario.true_pose(taus)
    x0, y0, th0 = scenario.true_pose(stamp)
    c, s = np.cos(th)[:, None], np.sin(th)[:, None]
    wx = x[:, None] + c * centers[..., 0] - s * centers[..., 1]
    wy = y[:, None] + s * centers[..., 0] + c * centers[..., 1]
    c0, s0 = np.cos(th0), np.sin(th0)
    bx = c0 * (wx - x0) + s0 * (wy - y0)
    by = -s0 * (wx - x0) + c0 * (wy - y0)
    out_c = np.stack([bx, by, centers[..., 2]], -1).reshape(-1, 3)
    out_h = np.broadcast_to(half, centers.shape).reshape(-1, 3)
    out_yaw = (yaw + (th - th0)[:, None]).reshape(-1)
    return out_c, out_h, out_yaw


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
        centers, half, yaw = arm_boxes_at(scenario, s["stamp"])
        d = _outside_distance(x[ok], y[ok], centers, half, yaw, padding)
        n += int(np.count_nonzero((d <= 0.0).any(axis=1)))
    return n


def kept_near_robot(filtered, unfiltered, scenario, padding, band, tol=0.05, rel_tol=0.03,
                    beam_window=1):
    """(obstacles near the robot, how many of them the filtered scans keep).

    Obstacles near the robot: returns of the scans without the filter within NEAR outside the
    padded boxes that the ideal scan confirms (a true obstacle, not the arm; only what the
    sensors see, so nothing the arm hides). Kept: the filtered scan of the same stamp reads it
    (within the tolerance, beam_window beams either side)."""
    _, zlo, zhi = band
    by_stamp = {s["stamp"]: s for s in filtered}
    near = kept = 0
    for u in unfiltered:
        f = by_stamp.get(u["stamp"])
        if f is None or len(f["ranges"]) != len(u["ranges"]):
            continue
        x, y, ok = _points(u["ranges"], u["angle_min"], u["angle_increment"])
        if not ok.any():
            continue
        centers, half, yaw = arm_boxes_at(scenario, u["stamp"])
        d = _outside_distance(x[ok], y[ok], centers, half, yaw, padding).min(axis=1)
        beams = np.flatnonzero(ok)[(d > 0.0) & (d <= NEAR)]
        if not beams.size:
            continue
        ideal = scenario.ideal_scan(u["stamp"], u["angle_min"], u["angle_max"], u["angle_increment"],
                                    u["range_min"], u["range_max"], zlo, zhi)
        ur = np.asarray(u["ranges"], float)
        fr = np.asarray(f["ranges"], float)
        for b in beams:
            lo, hi = max(0, b - beam_window), min(ur.size, b + beam_window + 1)
            bound = tol + rel_tol * ur[b]
            if not np.any(np.abs(ideal[lo:hi] - ur[b]) <= bound):
                continue
            near += 1
            kept += bool(np.any(np.abs(fr[lo:hi] - ur[b]) <= bound))
    return near, kept


def self_filter_stats(filtered, unfiltered, scenario, padding, band, tol=0.05, rel_tol=0.03):
    """results.json's ``self_filter`` entry for each topic of ``filtered`` ({topic: scans});
    without ``unfiltered`` scans of a topic its unfiltered figures are None."""
    out = {}
    for topic, scans in filtered.items():
        plain = unfiltered.get(topic)
        near, kept = (kept_near_robot(scans, plain, scenario, padding, band, tol, rel_tol)
                      if plain else (0, 0))
        out[topic] = {
            "scans": len(scans), "padding_m": padding, "near_m": NEAR,
            "returns_on_robot": robot_returns(scans, scenario, padding),
            "returns_on_robot_unfiltered": robot_returns(plain, scenario, padding) if plain else None,
            "scans_unfiltered": len(plain or []),
            "near_robot_obstacles": near,
            "kept_near_robot_percent": 100.0 * kept / near if near else None}
    return out
