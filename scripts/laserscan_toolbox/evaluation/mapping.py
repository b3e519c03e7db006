"""Occupancy grids from scans at known poses, compared with the ground-truth obstacle map
(the paper's Fig. 6: a map from the lidar-only scan against one from the lidar+camera scan).

Grids are ``[iy, ix]`` arrays; cell (iy, ix) covers x in origin_x + [ix, ix+1) * res and
y in origin_y + [iy, iy+1) * res. Each scan counts, per cell, a hit where a beam ends and a
miss where a beam passes through; a cell is occupied when at least OCC_RATIO of its visits
were hits (gmapping's rule and default, occ_thresh 0.25). The rule matters for merged
scans: where the cameras look elsewhere, lidar beams pass under a table top that the
cameras saw before, and a log-odds map with the usual inverse sensor model (hit +0.85,
miss -0.4, clamped) soon erases it. A beam with no return (+Inf) counts nothing: REP 117
says nothing about where
the free space ends.
"""

import math
import os

import numpy as np

from . import metrics

OCC_RATIO = 0.25


class Grid:
    def __init__(self, origin, resolution, shape):
        self.origin = (float(origin[0]), float(origin[1]))
        self.resolution = float(resolution)
        self.shape = tuple(int(s) for s in shape)
        self.hits = np.zeros(self.shape, np.int32)
        self.misses = np.zeros(self.shape, np.int32)

    def cells(self, x, y):
        ix = np.floor((np.asarray(x) - self.origin[0]) / self.resolution).astype(np.int64)
        iy = np.floor((np.asarray(y) - self.origin[1]) / self.resolution).astype(np.int64)
        ok = (ix >= 0) & (iy >= 0) & (ix < self.shape[1]) & (iy < self.shape[0])
        return iy[ok] * self.shape[1] + ix[ok]

    def integrate(self, pose, angle_min, angle_increment, ranges, max_range=8.0):
        """Adds one scan taken at world pose (x, y, yaw)."""
        x, y, yaw = pose
        r = np.asarray(ranges, float)
        a = yaw + angle_min + angle_increment * np.arange(r.size)
        hit = metrics.is_return(r) & (r <= max_range)
        if not np.any(hit):
            return
        rh, ah = r[hit], a[hit]
        c, s = np.cos(ah), np.sin(ah)
        step = self.resolution * 0.7
        n = int(math.ceil(rh.max() / step))
        t = np.arange(n) * step  # distances sampled along every beam
        along = t[None, :] < (rh[:, None] - self.resolution)  # stop a cell short of the hit
        fx = (x + c[:, None] * t[None, :])[along]
        fy = (y + s[:, None] * t[None, :])[along]
        free = np.unique(self.cells(fx, fy))
        occ = np.unique(self.cells(x + c * rh, y + s * rh))
        self.misses.reshape(-1)[free] += 1
        self.hits.reshape(-1)[occ] += 1
        self.misses.reshape(-1)[occ[np.isin(occ, free)]] -= 1  # a hit cell is not also a miss

    def occupied(self, ratio=OCC_RATIO):
        return (self.hits > 0) & (self.hits >= ratio * (self.hits + self.misses))

    def known(self):
        return (self.hits + self.misses) > 0

    def save_pgm(self, path_base):
        """map_server format: PGM (white free, black occupied, grey unknown) + YAML."""
        img = np.full(self.shape, 205, np.uint8)
        img[self.known() & ~self.occupied()] = 254
        img[self.occupied()] = 0
        with open(path_base + ".pgm", "wb") as f:
            f.write(b"P5\n%d %d\n255\n" % (self.shape[1], self.shape[0]))
            f.write(img[::-1].tobytes())  # PGM rows go top-down, the grid's y goes up
        with open(path_base + ".yaml", "w") as f:
            f.write("image: %s.pgm\nresolution: %g\norigin: [%g, %g, 0.0]\nnegate: 0\n"
                    "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
                    % (os.path.basename(path_base), self.resolution, self.origin[0],
                       self.origin[1]))


def build_map(scans, pose_of, origin, resolution, shape, min_dt=0.2, max_range=8.0):
    """Grid from scans (dicts with stamp, angle_min, angle_increment, ranges) at
    ``pose_of(stamp)``; scans closer than ``min_dt`` in time to the previous one used are
    skipped (mapping packages also throttle their input)."""
    g = Grid(origin, resolution, shape)
    last = -1e18
    for s in sorted(scans, key=lambda s: s["stamp"]):
        if s["stamp"] - last < min_dt:
            continue
        last = s["stamp"]
        g.integrate(pose_of(s["stamp"]), s["angle_min"], s["angle_increment"], s["ranges"],
                    max_range)
    return g


def dilate(mask, cells=1):
    out = mask.copy()
    for dy in range(-cells, cells + 1):
        for dx in range(-cells, cells + 1):
            out |= np.roll(np.roll(mask, dy, 0), dx, 1)
    return out


def compare_maps(maps, truth, truth_plane, reference=None, tolerance_cells=1, reference_3d=None):
    """Figures of each map against the ground truth.

    truth: obstacle cells of the robot's full height band (filled solids);
    truth_plane: those a planar lidar can see (its thin band). reference: the map built
    from ideal scans along the same path, i.e. the surfaces a perfect sensor in the band
    could have seen; obstacles are judged against it (solids' insides and their far sides
    are never seen). ``3d`` cells (table tops, overhangs) are reference cells not near
    ``truth_plane``; ``reference_3d`` (default: reference) is the map they are taken from,
    e.g. one built only over the directions the cameras look.
    """
    observed = np.zeros(truth.shape, bool)
    for g in maps.values():
        observed |= g.known()
    if reference is not None:
        observed |= reference.known()
    observed = dilate(observed, 1)
    seen = reference.occupied() if reference is not None else truth & observed
    seen3d = reference_3d.occupied() if reference_3d is not None else seen
    only3d = seen3d & ~dilate(truth_plane, 1)
    out = {"observed_cells": int(observed.sum()), "reference_cells": int(seen.sum()),
           "reference_3d_cells": int(only3d.sum())}
    near_truth = dilate(truth, tolerance_cells)
    for name, g in maps.items():
        occ = g.occupied()
        near_occ = dilate(occ, tolerance_cells)
        false_cells = int((occ & observed & ~near_truth).sum())
        occupied_cells = int((occ & observed).sum())
        out[name] = {
            # against the filled ground-truth grid inside the observed area
            "iou_truth": metrics.grid_iou(occ, truth, observed),
            # against what could be seen, a cell matching within tolerance_cells
            "iou": _tolerant_iou(occ, seen, observed, tolerance_cells),
            # occupied cells with no obstacle nearby in the ground truth
            "false_cells": false_cells,
            "occupied_cells": occupied_cells,
            # share of the occupied cells with an obstacle within tolerance_cells
            "precision": 1.0 - false_cells / occupied_cells if occupied_cells else float("nan"),
            "found": float((seen & near_occ).sum() / max(1, seen.sum())),
            "found_3d": float((only3d & near_occ).sum() / max(1, only3d.sum())),
        }
    return out


def _tolerant_iou(occ, truth, region, k):
    """IoU where a cell matches when the other grid has an obstacle within k cells."""
    occ = occ & region
    truth = truth & region
    tp_occ = occ & dilate(truth, k)
    tp_truth = truth & dilate(occ, k)
    fp = occ & ~tp_occ
    fn = truth & ~tp_truth
    denom = tp_truth.sum() + fp.sum() + fn.sum()
    return float(tp_truth.sum() / denom) if denom else float("nan")


def reference_maps(scenario, resolution=0.05, band=(0.05, 1.0), plane_band=None, max_range=8.0,
                   ideal_scans=None, ideal_scans_3d=None):
    """What maps are judged against: the ground-truth obstacle grids of the robot's band
    (``truth``) and of the lidars' band (``plane``), and the maps of ideal scans along the
    path (``reference``, ``reference_3d``, or None); with ``origin`` and ``resolution``."""
    truth, origin = scenario.ground_truth_grid(resolution, band[0], band[1], static_only=True)
    truth = np.asarray(truth, bool)
    if plane_band is not None:
        plane, _ = scenario.ground_truth_grid(resolution, plane_band[0], plane_band[1],
                                              static_only=True)
        plane = np.asarray(plane, bool)
    else:
        plane = np.zeros_like(truth)
    refs = {"truth": truth, "plane": plane, "origin": origin, "resolution": resolution,
            "band": band, "reference": None, "reference_3d": None}
    for key, scans in (("reference", ideal_scans), ("reference_3d", ideal_scans_3d)):
        if scans:
            refs[key] = build_map(scans, lambda t: scenario.true_pose(t), origin, resolution,
                                  truth.shape, max_range=max_range)
    return refs


def only_3d(refs):
    """Ground-truth cells above the lidars' plane (table tops, overhangs)."""
    return refs["truth"] & ~dilate(refs["plane"], 1)


def grid_extent(refs):
    """(x_min, x_max, y_min, y_max) of the ground-truth grid, for imshow."""
    (x0, y0), res, shape = refs["origin"], refs["resolution"], refs["truth"].shape
    return (x0, x0 + shape[1] * res, y0, y0 + shape[0] * res)


def map_image(grid, refs):
    """RGB picture of a map: unknown grey, free white, occupied black, 3D obstacles red."""
    im = np.full(refs["truth"].shape + (3,), 0.75)
    im[grid.known() & ~grid.occupied()] = (1.0, 1.0, 1.0)
    im[grid.occupied()] = (0.0, 0.0, 0.0)
    im[grid.occupied() & dilate(only_3d(refs), 1)] = (0.85, 0.1, 0.1)
    return im


def truth_image(refs):
    """RGB picture of the ground truth (3D obstacles red)."""
    img = np.full(refs["truth"].shape + (3,), 1.0)
    img[refs["truth"]] = (0.1, 0.1, 0.1)
    img[only_3d(refs)] = (0.85, 0.1, 0.1)
    return img


def mapping_experiment(scans_by_name, scenario, outdir, resolution=0.05, band=(0.05, 1.0),
                       plane_band=None, trajectory=None, max_range=8.0, ideal_scans=None,
                       ideal_scans_3d=None, return_grids=False):
    """Maps of each scan stream at the true poses, side by side with the ground truth.

    scans_by_name: {"lidar only (/lidar_scan)": [scan dicts], ...}; band: the robot's
    obstacle band (heights above the floor); plane_band: the lidars' band; ideal_scans:
    scan dicts of the ideal scan in ``band`` along the path (the reference map);
    ideal_scans_3d: the same restricted to where the 3D sensors look (the reference of the
    "3D obstacles found" figure; default ideal_scans).
    Writes maps.png and map_server files; returns the figures, and with ``return_grids``
    also ``reference_maps``' dict with the built maps under "maps".
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    refs = reference_maps(scenario, resolution, band, plane_band, max_range, ideal_scans,
                          ideal_scans_3d)
    truth, plane, origin = refs["truth"], refs["plane"], refs["origin"]
    reference, reference_3d = refs["reference"], refs["reference_3d"]
    maps = {}
    for name, scans in scans_by_name.items():
        maps[name] = build_map(scans, lambda t: scenario.true_pose(t), origin, resolution,
                               truth.shape, max_range=max_range)
    refs["maps"] = maps
    figures = compare_maps(maps, truth, plane, reference, reference_3d=reference_3d)
    os.makedirs(outdir, exist_ok=True)
    files = {}
    for i, (name, g) in enumerate(maps.items()):
        base = os.path.join(outdir, "map_%d" % i)
        g.save_pgm(base)
        files[name] = os.path.basename(base) + ".pgm"
    figures["files"] = files

    extent = grid_extent(refs)
    n = len(maps) + 1
    fig, axes = plt.subplots(1, n, figsize=(4.2 * n, 3.6))
    axes[0].imshow(truth_image(refs), origin="lower", extent=extent, interpolation="nearest")
    axes[0].set_title("ground truth, %.2f-%.2f m\n(red: above the lidars' plane)" % band,
                      fontsize=8)
    for ax, (name, g) in zip(axes[1:], maps.items()):
        ax.imshow(map_image(g, refs), origin="lower", extent=extent, interpolation="nearest")
        f = figures[name]
        ax.set_title("%s\nIoU %.2f, 3D obstacles found %.0f%%"
                     % (name, f["iou"], 100 * f["found_3d"]), fontsize=8)
    if trajectory is not None:
        for ax in axes:
            ax.plot(trajectory[:, 0], trajectory[:, 1], "-", color="tab:blue", lw=0.8)
    for ax in axes:
        ax.tick_params(labelsize=6)
        ax.set_xlabel("x, m", fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "maps.png"), dpi=100)
    plt.close(fig)
    figures["figure"] = "maps.png"
    return (figures, refs) if return_grids else figures
