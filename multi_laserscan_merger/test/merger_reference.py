"""Brute-force numpy reference of the merge (independent of the C++ core), shared by the
differential and real-data tests. Every beam is handled on its own in float64: polar ->
Cartesian -> 4x4 homogeneous transform (robot motion from its own slerp) -> polar, then the
closest range per output bin. Deskew moves every beam from its own time exactly."""
import math

import numpy as np


def yaw_matrix(x, y, z, roll, pitch, yaw):
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    t = np.eye(4)
    t[:3, :3] = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]]) @ \
        np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]]) @ \
        np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    t[:3, 3] = (x, y, z)
    return t


def quat_to_matrix(q):
    x, y, z, w = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def yaw_quat(yaw):
    return np.array([0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])


def slerp(q1, q2, u):
    d = float(np.dot(q1, q2))
    if d < 0:
        q2, d = -q2, -d
    if d > 0.9999999:
        q = (1 - u) * q1 + u * q2
    else:
        th = math.acos(d)
        q = (math.sin((1 - u) * th) * q1 + math.sin(u * th) * q2) / math.sin(th)
    return q / np.linalg.norm(q)


class RefOdometry:
    """List of (t, position, quaternion xyzw), sorted by time."""

    def __init__(self, entries):
        self.entries = sorted(entries, key=lambda e: e[0])

    def pose(self, t):
        e = self.entries
        if t <= e[0][0]:
            p, q = e[0][1], e[0][2]
        elif t >= e[-1][0]:
            p, q = e[-1][1], e[-1][2]
        else:
            i = next(k for k in range(1, len(e)) if e[k][0] > t)
            (t1, p1, q1), (t2, p2, q2) = e[i - 1], e[i]
            u = (t - t1) / (t2 - t1)
            p, q = (1 - u) * np.asarray(p1) + u * np.asarray(p2), slerp(np.asarray(q1), np.asarray(q2), u)
        m = np.eye(4)
        m[:3, :3] = quat_to_matrix(np.asarray(q, float))
        m[:3, 3] = p
        return m


def in_fov(angle, amin, amax):
    span = amax - amin
    if span < 0:
        span += 2 * math.pi
    if span >= 2 * math.pi - 1e-9:
        return np.ones_like(angle, bool)
    rel = np.mod(angle - amin, 2 * math.pi)
    return (rel <= span + 1e-9) | (rel >= 2 * math.pi - 1e-9)


def output_bins(out):
    n = int(round((out['angle_max'] - out['angle_min']) / out['angle_increment'])) + 1
    turns = 2 * math.pi / out['angle_increment']
    n_circle = int(round(turns)) if abs(turns - round(turns)) < 1e-6 * max(1.0, turns) else 0
    return n, n_circle


def bin_of(out, a):
    n, n_circle = output_bins(out)
    rel = np.mod(a - out['angle_min'], 2 * math.pi)
    k = np.floor(rel / out['angle_increment'] + 0.5).astype(np.int64)
    if n_circle:
        k = np.where(k >= n_circle, k - n_circle, k)
    return np.where(k < n, k, -1)


def reference_merge(out, sources, scans, t_out, odom=None, output_T_robot=None):
    """Returns the merged ranges (before output limits: finite, +inf = nothing, nan = invalid only),
    for each source (bins, ranges) of its valid points, and the bins marked by invalid beams."""
    n, n_circle = output_bins(out)
    best = np.full(n, np.inf)
    nan_mark = np.zeros(n, bool)
    points = []
    p_out_inv = np.linalg.inv(odom.pose(t_out)) if odom is not None else None
    # drop_explained_within > 0: after all other sources, judged against them only.
    deferred = []
    for src, scan in zip(sources, scans):
        if scan is None or t_out - scan['stamp'] > src.get('timeout', 1.0):
            points.append((np.zeros(0, int), np.zeros(0)))
            continue
        tolerance = src.get('drop_explained_within', 0.0)
        own_best, own_nan = (np.full(n, np.inf), np.zeros(n, bool)) if tolerance > 0 else (best, nan_mark)
        r = np.asarray(scan['ranges'], np.float64)
        i = np.arange(len(r))
        a = scan['angle_min'] + i * scan['angle_increment']
        rmin = max(scan['range_min'], src.get('range_min', 0.0))
        rmax = min(scan['range_max'], src.get('range_max', math.inf))
        fov = in_fov(a, src.get('angle_min', -math.pi), src.get('angle_max', math.pi))
        keep_close = src.get('too_close_is_obstacle', True) and not (src.get('range_min', 0.0) > scan['range_min'])
        r = np.where(np.isneginf(r) & keep_close, rmin, r)
        valid = fov & (r >= rmin) & (r <= rmax)
        # Below range_min, NaN, -Inf not kept, or a real return beyond the source's tightened range_max;
        # beyond the message's own range_max is the driver's "no return".
        with np.errstate(invalid='ignore'):
            invalid = fov & (~(r >= rmin) | ((r > rmax) & (r <= scan['range_max'])))
        footprint = out.get('footprint') if src.get('footprint_filter', True) else None
        t_beam = scan['stamp'] + (i * scan.get('time_increment', 0.0) if src.get('deskew') else 0.0 * i)
        ks, rs = [], []
        for b in np.nonzero(valid | invalid)[0]:
            t = scan['transform']
            if odom is not None:
                o = np.eye(4) if output_T_robot is None else output_T_robot
                t = o @ p_out_inv @ odom.pose(t_beam[b]) @ np.linalg.inv(o) @ t
            if valid[b]:
                p = t @ np.array([r[b] * math.cos(a[b]), r[b] * math.sin(a[b]), 0.0, 1.0])
                k = int(bin_of(out, math.atan2(p[1], p[0])))
                if k >= 0 and footprint and inside(footprint, p[0], p[1]):
                    own_nan[k] = True  # on the robot: its direction is invalid
                elif k >= 0:
                    ks.append(k)
                    rs.append(math.hypot(p[0], p[1]))
                    own_best[k] = min(own_best[k], rs[-1])
            else:
                d = t[:3, :3] @ np.array([math.cos(a[b]), math.sin(a[b]), 0.0])
                k = int(bin_of(out, math.atan2(d[1], d[0])))
                if k >= 0:
                    own_nan[k] = True
        if tolerance > 0:
            deferred.append((tolerance, own_best, own_nan, len(points)))
        points.append((np.array(ks, int), np.array(rs)))
    first_pass = best.copy()
    for tolerance, own_best, own_nan, i in deferred:
        with np.errstate(invalid='ignore'):
            explained = np.any(np.isfinite(own_best) & np.isfinite(first_pass) &
                               (np.abs(own_best - first_pass) <= tolerance))
        if explained:  # the whole scan is left out
            points[i] = (np.zeros(0, int), np.zeros(0))
        else:
            best = np.minimum(best, own_best)
            nan_mark |= own_nan
    if n_circle and n > n_circle:
        best[n_circle:] = best[:n - n_circle]
        nan_mark[n_circle:] = nan_mark[:n - n_circle]
    merged = np.where(np.isinf(best) & nan_mark, np.nan, best)
    return merged, points, nan_mark


def inside(polygon, x, y):
    """Even-odd rule: a horizontal ray from (x, y) crosses the outline an odd number of times."""
    crossings = 0
    for (xi, yi), (xj, yj) in zip(polygon, polygon[-1:] + polygon[:-1]):
        if (yi > y) != (yj > y) and x < xj + (y - yj) * (xi - xj) / (yi - yj):
            crossings += 1
    return crossings % 2 == 1


def apply_output_limits(out, merged):
    res = merged.copy()
    rmax = out.get('range_max', 30.0)
    no_return = math.inf if out.get('use_inf', True) else rmax + out.get('inf_epsilon', 1.0)
    finite = out.get('finite_only', False)
    with np.errstate(invalid='ignore'):
        res = np.where(res > rmax, no_return, res)
        res = np.where(res < out.get('range_min', 0.0), 0.0 if finite else -np.inf, res)
        if finite:
            res = np.where(np.isnan(res), 0.0, res)
    return res
