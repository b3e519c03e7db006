"""Differential test: the C++ core against the brute-force numpy reference
(merger_reference.py) on random scans, mounts, masks, output geometries and motions.

Tolerance (documented in the README): a range of the reference must be found by the core in
the same bin or one bin away (a point that lies within float rounding of a bin border may land
in the neighbour: the core bins with float32 and a polynomial atan2 accurate to 2e-6 rad), within
1 cm (deskew interpolates the transform per beam between exact borders every 64 beams), and
the other way round. The classes (real / no return / invalid) must agree except in such border
bins."""
import math

import numpy as np
import pytest

import merger_reference as ref

import multi_laserscan_merger_core as mlc

TOL = 0.01


def random_case(rng, option_rng=None):
    """option_rng (its own stream, so the other draws stay those of rng): some sources get
    drop_explained_within."""
    out_choices = [
        dict(angle_min=-math.pi, angle_max=math.pi, angle_increment=math.pi / 720),
        dict(angle_min=-math.pi, angle_max=math.pi, angle_increment=math.pi / 180),
        dict(angle_min=-2.0, angle_max=2.0, angle_increment=math.radians(0.5)),
        dict(angle_min=0.0, angle_max=2 * math.pi, angle_increment=math.pi / 360),
    ]
    out = dict(out_choices[rng.integers(len(out_choices))])
    out.update(range_min=0.0, range_max=30.0)
    n_src = int(rng.integers(1, 5))
    sources, scans = [], []
    t_out = 10.0
    for s in range(n_src):
        n = int(rng.integers(60, 800))
        span = rng.uniform(math.radians(60), 2 * math.pi)
        amin = rng.uniform(-math.pi, math.pi - span) if span < 2 * math.pi - 0.01 else -math.pi
        inc = span / n
        ranges = rng.uniform(0.2, 12.0, n).astype(np.float32)
        special = rng.uniform(size=n)
        ranges[special < 0.03] = np.nan
        ranges[(special >= 0.03) & (special < 0.08)] = np.inf
        ranges[(special >= 0.08) & (special < 0.09)] = -np.inf
        ranges[(special >= 0.09) & (special < 0.10)] = 0.01  # below the message's range_min
        ranges[(special >= 0.10) & (special < 0.11)] = 25.0  # beyond the message's range_max: no return
        src = dict(name='s%d' % s, topic='t%d' % s, timeout=1.0, deskew=bool(rng.integers(2)))
        kind = rng.integers(3)
        if kind == 1:
            src.update(angle_min=rng.uniform(-math.pi, 0), angle_max=rng.uniform(0, math.pi))
        elif kind == 2:  # wraps around +-pi
            src.update(angle_min=rng.uniform(1.0, math.pi), angle_max=rng.uniform(-math.pi, -1.0))
        if rng.integers(2):
            src.update(range_min=float(rng.uniform(0.05, 1.0)), range_max=float(rng.uniform(5.0, 11.0)))
        roll = math.pi if rng.integers(4) == 0 else rng.uniform(-0.2, 0.2)
        mount = ref.yaw_matrix(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(0, 0.6), roll,
                               rng.uniform(-0.2, 0.2), rng.uniform(-math.pi, math.pi))
        scans.append(dict(stamp=t_out - rng.uniform(0.0, 0.3), angle_min=amin, angle_max=amin + (n - 1) * inc,
                          angle_increment=inc, time_increment=rng.uniform(0.0, 0.1) / n, range_min=0.05,
                          range_max=20.0, ranges=ranges, transform=mount))
        src.update(too_close_is_obstacle=bool(rng.integers(4)), footprint_filter=bool(rng.integers(4)))
        if option_rng is not None and s > 0 and option_rng.integers(3) == 0:
            # Fused only when nothing else explains it (sonar arcs): both outcomes occur.
            src.update(drop_explained_within=float(option_rng.choice([0.005, 0.02, 0.2])))
        sources.append(src)
    if rng.integers(2):  # a robot outline (sometimes concave) around the mounts
        w, h = rng.uniform(0.3, 0.7), rng.uniform(0.3, 0.6)
        out['footprint'] = [[-w, -h], [w, -h], [w, h], [0.0, rng.uniform(0.0, h)], [-w, h]]
    if rng.integers(3) == 0:
        out.update(use_inf=False, finite_only=bool(rng.integers(2)), range_min=0.1)
    # Odometry: constant speed and turn rate from a random pose, 50 Hz, over the last 1.5 s.
    v, w = rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5)
    x0, y0, th0 = rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-math.pi, math.pi)
    entries = []
    for k in range(76):
        t = t_out - 1.5 + 0.02 * k
        th = th0 + w * (t - t_out)
        # Exact unicycle integration (arc), so the poses are consistent with the turn.
        if abs(w) > 1e-9:
            x = x0 + v / w * (math.sin(th) - math.sin(th0))
            y = y0 - v / w * (math.cos(th) - math.cos(th0))
        else:
            x, y = x0 + v * math.cos(th0) * (t - t_out), y0 + v * math.sin(th0) * (t - t_out)
        entries.append((t, np.array([x, y, 0.0]), ref.yaw_quat(th)))
    return out, sources, scans, t_out, entries


def compare(expected, got, points, nan_mark):
    """Number of bins that the tolerance does not explain. A range of the reference must be
    matched by an equal or closer range of the core within one bin (nothing is lost; a closer
    point that moved to a border bin may hide it), every real range of the core must be a point
    of the reference (any source, before fusion) within one bin and TOL, and bins that differ
    in class (no return / invalid / too close) must agree with a neighbour."""
    n = len(expected)
    all_k = np.concatenate([p[0] for p in points]) if points else np.zeros(0, int)
    all_r = np.concatenate([p[1] for p in points]) if points else np.zeros(0)
    bad = 0
    for k in range(n):
        e, g = expected[k], got[k]
        near = [j for j in (k - 1, k, k + 1) if 0 <= j < n] + ([0] if k == n - 1 else []) + ([n - 1] if k == 0 else [])
        if np.isfinite(e) and not any(np.isfinite(got[j]) and got[j] <= e + TOL for j in near):
            bad += 1
            continue
        if np.isfinite(g):
            d = np.abs(all_k - k)
            d = np.minimum(d, n - 1 - d)  # first and last bin may be one direction
            if not np.any((np.minimum(np.abs(all_k - k), d) <= 1) & (np.abs(all_r - g) <= TOL)) and \
                    not (abs(g - e) <= TOL):
                bad += 1
                continue
        if not np.isfinite(e) and not np.isfinite(g) and not (np.isnan(e) and np.isnan(g)) and e != g:
            # NaN against +Inf: an invalid beam's direction next to a bin border.
            same = [j for j in near if (np.isnan(got[j]) and np.isnan(e)) or got[j] == e or
                    (np.isnan(expected[j]) and np.isnan(g)) or expected[j] == g or
                    (nan_mark[j] and np.isnan(g) != np.isnan(e))]
            if not same:
                bad += 1
    return bad


@pytest.mark.parametrize('seed', range(40))
def test_core_matches_numpy_reference(seed):
    rng = np.random.default_rng(seed)
    out, sources, scans, t_out, entries = random_case(rng, np.random.default_rng([seed, 1]))
    odom_ref = ref.RefOdometry(entries)
    odom = mlc.OdometryBuffer(100)
    for t, p, q in entries:
        assert odom.add(t, p, q) == 'added'
    merger = mlc.Merger(out, sources)
    # Every third case: the output frame is not the odometry's child frame.
    o = ref.yaw_matrix(rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), 0.1, 0.0, 0.0,
                       rng.uniform(-math.pi, math.pi)) if seed % 3 == 0 else np.eye(4)
    res = merger.merge(scans, t_out, odom, o)
    expected, points, nan_mark = ref.reference_merge(out, sources, scans, t_out, odom_ref, o)
    expected = ref.apply_output_limits(out, expected)
    got = res['ranges'].astype(np.float64)
    assert len(got) == len(expected) == merger.beam_count
    assert all(s == 'used' for s in res['status'])
    bad = compare(expected, got, points, nan_mark)
    assert bad == 0, 'seed %d: %d bins differ (%d sources)' % (seed, bad, len(sources))
    # Most bins agree exactly in the same bin; border effects stay rare.
    both = np.isfinite(expected) & np.isfinite(got)
    assert both.sum() >= 0.3 * np.isfinite(expected).sum()
    if both.any():
        same = np.abs(expected[both] - got[both]) <= TOL
        assert same.mean() > 0.97, same.mean()


def test_without_odometry_and_with_timeouts():
    rng = np.random.default_rng(123)
    out, sources, scans, t_out, _ = random_case(rng)
    sources[0]['timeout'] = 0.001
    scans[0]['stamp'] = t_out - 0.5
    merger = mlc.Merger(out, sources)
    res = merger.merge(scans, t_out)
    assert res['status'][0] == 'timed_out'
    expected, points, nan_mark = ref.reference_merge(out, sources, scans, t_out, None)
    assert compare(ref.apply_output_limits(out, expected), res['ranges'].astype(np.float64), points, nan_mark) == 0


def test_bad_config_raises_with_parameter_name():
    with pytest.raises(ValueError, match=r'sources\[1\]\.name'):
        mlc.Merger({}, [dict(name='a', topic='x'), dict(name='a', topic='y')])
    with pytest.raises(ValueError, match=r'sources\[0\]\.topic'):
        mlc.Merger({}, [dict(name='a')])
    with pytest.raises(ValueError, match='angle_min'):
        mlc.Merger(dict(angle_min=1.0, angle_max=0.5), [dict(name='a', topic='x')])


def test_fast_atan2_against_numpy():
    rng = np.random.default_rng(5)
    x, y = rng.uniform(-20, 20, 20000), rng.uniform(-20, 20, 20000)
    err = max(abs(mlc.fast_atan2(float(b), float(a)) - math.atan2(b, a)) for a, b in zip(x, y))
    assert err < 1e-5  # half an output beam of pi/720 is 2.2e-3 rad
