"""Differential test: the C++ core against a brute-force numpy reference.

The reference transforms every point in double precision, applies the height band (or the
hole rule), the planar range limits and the angle limits, bins by the nearest beam
(round((angle - angle_min) / angle_increment), fencepost rule, clamped to the last beam) and
keeps the minimum range per beam.

Tolerance, and why: the core works in float32 and maps angles with a polynomial atan2 (error
< 4e-6 rad). A point lying within a tiny epsilon of a border (a bin border, a band limit, a
range or angle limit) may therefore fall on the other side in the core. The reference thus
gives two scans: `lower`, the minimum over every point that *may* land in a beam (either bin
when it lies within epsilon of a bin border, kept when it lies within epsilon of a limit), and
`upper`, the minimum over the points that *surely* land there. The core must lie between them
(with a relative 1e-5 range tolerance). Away from borders lower == upper, so the check is exact.
"""
import math

import numpy as np
import pytest

import depth_filter_scan_converter_core as core

LEN_EPS = 2e-4  # metres: float32 coordinates of points up to ~10 m away
ANG_EPS = 2e-5  # radians: atan2 approximation + float rounding (plus LEN_EPS / range, see below)
RANGE_RTOL = 1e-5


def rot(axis, angle):
    c, s = math.cos(angle), math.sin(angle)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def camera_mount(height, pitch_down=0.0, roll=0.0, yaw=0.0, x=0.0, y=0.0):
    """camera optical frame (z forward, x right, y down) -> reference frame (z up), 4x4."""
    optical_to_body = np.array([[0, 0, 1], [-1, 0, 0], [0, -1, 0]], dtype=float)
    t = np.eye(4)
    t[:3, :3] = rot("z", yaw) @ rot("y", pitch_down) @ rot("x", roll) @ optical_to_body
    t[:3, 3] = (x, y, height)
    return t


def beam_of(p, angle):
    b = np.floor((angle - p.angle_min) / p.angle_increment + 0.5)
    return np.clip(np.nan_to_num(b, nan=0.0), 0, p.beam_count() - 1).astype(np.int64)


def reference_bounds(p, pts, transform):
    """(lower, upper) scans of the brute-force reference; pts (N, 3) in the camera frame."""
    n = p.beam_count()
    lower = np.full(n, np.inf)
    upper = np.full(n, np.inf)
    pts = np.asarray(pts, dtype=np.float64)
    with np.errstate(invalid="ignore", over="ignore"):
        q = pts @ transform[:3, :3].T + transform[:3, 3]
        finite = np.isfinite(q).all(axis=1)
        q = q[finite]
        z = q[:, 2]
        lo, hi = p.floor_height + p.min_height, p.floor_height + p.max_height
        band_sure = (z >= lo + LEN_EPS) & (z <= hi - LEN_EPS)
        band_maybe = (z >= lo - LEN_EPS) & (z <= hi + LEN_EPS)
        candidates = [(q[:, 0], q[:, 1], band_sure, band_maybe)]
        cz = transform[2, 3]
        if p.hole_detection and cz > p.floor_height:
            hole_z = p.floor_height - p.hole_depth
            hole_sure = (z < hole_z - LEN_EPS) & ~band_maybe
            hole_maybe = (z < hole_z + LEN_EPS) & ~band_sure
            s = (p.floor_height - cz) / (z - cz)
            hx = transform[0, 3] + s * (q[:, 0] - transform[0, 3])
            hy = transform[1, 3] + s * (q[:, 1] - transform[1, 3])
            candidates.append((hx, hy, hole_sure, hole_maybe))
        for x, y, sure, maybe in candidates:
            r = np.hypot(x, y)
            a = np.arctan2(y, x)
            # No range_min test: a point nearer than range_min is the beam's (too close) obstacle.
            sure = sure & (r <= p.range_max - LEN_EPS)
            maybe = maybe & (r <= p.range_max + LEN_EPS)
            # Near the origin a coordinate error turns into a larger angle error.
            ang_eps = ANG_EPS + LEN_EPS / np.maximum(r, 1e-9)
            # atan2 may give -pi for a point at +pi: both ends are one direction.
            a_alt = np.where(a > math.pi - ang_eps, a - 2 * math.pi, a)
            sure = sure & (a >= p.angle_min + ang_eps) & (a <= p.angle_max - ang_eps)
            for angle in (a, a_alt):
                maybe_here = maybe & (angle >= p.angle_min - ang_eps) & (angle <= p.angle_max + ang_eps)
                b_lo = beam_of(p, angle - ang_eps)
                b_hi = beam_of(p, angle + ang_eps)
                # Every beam the point may reach (several when ang_eps is large, near the origin).
                for k in range(int((b_hi - b_lo)[maybe_here].max(initial=0)) + 1):
                    m = maybe_here & (b_lo + k <= b_hi)
                    np.minimum.at(lower, b_lo[m] + k, r[m] * (1 - RANGE_RTOL))
            b_lo = beam_of(p, a - ang_eps)
            one_bin = sure & (b_lo == beam_of(p, a + ang_eps))
            np.minimum.at(upper, b_lo[one_bin], r[one_bin] * (1 + RANGE_RTOL))
    return lower, upper


def check_against_reference(p, cloud, transform, strided):
    ranges, _, _ = core.Projector(p).project(cloud, transform)
    assert ranges.shape == (p.beam_count(),)
    assert not np.isnan(ranges).any()
    lower, upper = reference_bounds(p, strided.reshape(-1, strided.shape[-1])[:, :3], transform)
    no_return = ranges == p.no_return_value()
    too_close = ranges == p.too_close_value()
    got = np.where(no_return, np.inf, ranges.astype(np.float64))
    if not p.use_inf and not too_close.any():
        assert np.all(np.isfinite(ranges))
    # A too-close beam needs a candidate nearer than range_min; a beam whose closest sure
    # candidate is nearer than range_min must read too close (never a range, never no return).
    close_ok = too_close & (lower <= p.range_min * (1 + RANGE_RTOL) + LEN_EPS)
    normal_ok = ~too_close & (got >= lower) & (got <= upper) & ~(upper < p.range_min * (1 - RANGE_RTOL) - LEN_EPS)
    bad = ~(close_ok | normal_ok)
    assert not bad.any(), (
        f"{bad.sum()} beams outside the reference bounds, e.g. beam {np.argmax(bad)}: "
        f"core {got[bad][:5]}, lower {lower[bad][:5]}, upper {upper[bad][:5]}"
    )
    return np.isfinite(got).sum()


def random_params(rng):
    p = core.Parameters()
    p.floor_height = rng.uniform(-0.3, 0.3)
    p.min_height = rng.uniform(-0.1, 0.3)
    p.max_height = p.min_height + rng.uniform(0.1, 2.0)
    p.angle_min = rng.uniform(-math.pi, 0.0)
    p.angle_max = rng.uniform(p.angle_min + 0.5, math.pi)
    p.angle_increment = rng.uniform(0.002, 0.05)
    p.range_min = rng.uniform(0.0, 1.0)
    p.too_close_at_range_min = bool(rng.integers(2))
    p.range_max = rng.uniform(2.0, 8.0)
    p.hole_detection = bool(rng.integers(2))
    p.hole_depth = rng.uniform(0.0, 0.2)
    p.use_inf = bool(rng.integers(2))
    p.inf_epsilon = rng.uniform(0.0, 1.0)
    p.validate()
    return p


def random_mount(rng):
    return camera_mount(
        height=rng.uniform(0.2, 1.5),
        pitch_down=rng.uniform(-0.6, 1.2),  # up to ~70 degrees down, some looking up
        roll=rng.uniform(-0.7, 0.7),
        yaw=rng.uniform(-math.pi, math.pi),
        x=rng.uniform(-0.5, 0.5),
        y=rng.uniform(-0.5, 0.5),
    )


def random_points(rng, shape, dtype, extra_channels):
    pts = np.empty(shape + (3 + extra_channels,), dtype=dtype)
    pts[..., 0] = rng.uniform(-4, 4, shape)
    pts[..., 1] = rng.uniform(-3, 3, shape)
    pts[..., 2] = rng.uniform(0.05, 7, shape)
    pts[..., 3:] = rng.uniform(0, 100, shape + (extra_channels,))
    flat = pts.reshape(-1, pts.shape[-1])
    bad = rng.random(flat.shape[0]) < 0.05  # a few invalid points of every kind
    flat[bad, rng.integers(0, 3, bad.sum())] = rng.choice([np.nan, np.inf, -np.inf], bad.sum())
    return pts


@pytest.mark.parametrize("seed", range(40))
def test_core_matches_numpy_reference(seed):
    rng = np.random.default_rng(seed)
    p = random_params(rng)
    transform = random_mount(rng)
    dtype = np.float32 if seed % 3 else np.float64
    extra = int(rng.integers(0, 5))  # point_step of 12 to 28 (float) or 24 to 56 (double) bytes
    if seed % 2:
        p.row_stride = int(rng.integers(1, 4))
        p.column_stride = int(rng.integers(1, 4))
        cloud = random_points(rng, (int(rng.integers(20, 60)), int(rng.integers(20, 80))), dtype, extra)
        strided = cloud[:: p.row_stride, :: p.column_stride]
    else:
        p.column_stride = int(rng.integers(1, 4))
        cloud = random_points(rng, (int(rng.integers(500, 3000)),), dtype, extra)
        strided = cloud[:: p.column_stride]
    check_against_reference(p, cloud, transform, strided)


def test_points_on_bin_borders_and_limits():
    """Points placed exactly on beam borders, beams and angle limits (the epsilon cases)."""
    p = core.Parameters()
    p.angle_min, p.angle_max, p.angle_increment = -1.0, 1.0, 0.01
    n = p.beam_count()
    angles = np.concatenate(
        [
            p.angle_min + np.arange(n) * p.angle_increment,  # on beams
            p.angle_min + (np.arange(n - 1) + 0.5) * p.angle_increment,  # on borders
            [p.angle_min, p.angle_max, p.angle_min - 1e-3, p.angle_max + 1e-3],
        ]
    )
    r = np.linspace(0.5, 5.0, angles.size)
    pts = np.stack([r * np.cos(angles), r * np.sin(angles), np.full_like(r, 0.5)], axis=1)
    identity = np.eye(4)
    finite = check_against_reference(p, pts, identity, pts)
    assert finite == n  # every beam gets a point, none outside the limits


def test_tilted_and_rolled_scene_with_large_cloud():
    rng = np.random.default_rng(7)
    p = core.Parameters()
    p.hole_detection = True
    for pitch, roll in [(0.5, 0.0), (0.3, 0.4), (-0.2, -0.5), (1.0, 0.2)]:
        transform = camera_mount(1.0, pitch, roll, yaw=rng.uniform(-3, 3))
        cloud = random_points(rng, (120, 160), np.float32, 1)
        assert check_against_reference(p, cloud, transform, cloud) > 50


def test_fast_atan2_error_bound():
    a = np.linspace(-math.pi, math.pi, 1_000_001)
    for radius in (1e-3, 1.0, 50.0):
        x = (radius * np.cos(a)).astype(np.float32)
        y = (radius * np.sin(a)).astype(np.float32)
        err = np.abs(core.fast_atan2(y, x) - np.arctan2(y.astype(np.float64), x.astype(np.float64)))
        err = np.minimum(err, 2 * math.pi - err)
        assert err.max() < core.FAST_ATAN2_MAX_ERROR
    assert core.FAST_ATAN2_MAX_ERROR < ANG_EPS


def test_parameters_validate_names_the_parameter():
    p = core.Parameters()
    p.validate()
    p.min_height = 2.0
    with pytest.raises(core.ParameterError, match="^min_height: "):
        p.validate()
    with pytest.raises(ValueError, match="^min_height: "):
        core.Projector(p)


def test_validate_cloud_reasons():
    fields = [("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1)]
    data = bytes(12 * 6)
    assert core.validate_cloud(fields, 3, 2, 12, 36, False, data) == ""
    assert "field 'z' is missing" in core.validate_cloud(fields[:2], 3, 2, 12, 36, False, data)
    assert "is_bigendian" in core.validate_cloud(fields, 3, 2, 12, 36, True, data)
    assert "does not match" in core.validate_cloud(fields, 3, 2, 12, 36, False, data[:-1])
    assert "datatype 2" in core.validate_cloud([("x", 0, 2, 1)] + fields[1:], 3, 2, 12, 36, False, data)


def test_empty_cloud_and_kept_points():
    p = core.Parameters()
    ranges, intensities, kept = core.Projector(p).project(np.zeros((0, 3), np.float32), np.eye(4))
    assert ranges.shape == (1441,) and np.isinf(ranges).all()
    assert intensities.size == 0 and kept.shape == (0, 3)
    pts = np.array([[1.0, 0.0, 0.5, 7.0], [2.0, 0.0, 0.5, 9.0], [1.0, 1.0, 3.0, 1.0]], np.float32)
    ranges, intensities, kept = core.Projector(p).project(pts, np.eye(4), intensity_channel=3, keep_points=True)
    assert kept.shape == (2, 3)
    assert intensities[720] == 7.0 and ranges[720] == 1.0


CLUSTER_WIDTH, CLUSTER_CAP = core.RANGE_NOISE_CLUSTER_WIDTH, core.RANGE_NOISE_CLUSTER_CAP


def noise_std(p, r):
    return p.range_noise_std + p.range_noise_std_per_m2 * r * r


def cluster_reference(p, q):
    """The range noise rule in numpy, on points q (N, 3) of the reference frame that all lie in
    the band and within the range and angle limits: per beam the closest range m; the beam reads
    the mean range of its points within CLUSTER_WIDTH std(m) of m, at most m + CLUSTER_CAP
    std(m); too close when m < range_min. Returns (expected ranges, beams whose outcome a float
    rounding may flip: a point on the cluster's edge, or m on range_min)."""
    n = p.beam_count()
    r = np.hypot(q[:, 0], q[:, 1])
    b = beam_of(p, np.arctan2(q[:, 1], q[:, 0]))
    closest = np.full(n, np.inf)
    np.minimum.at(closest, b, r)
    with np.errstate(invalid="ignore"):
        limit = closest + CLUSTER_WIDTH * noise_std(p, closest)
    inside = r <= limit[b]
    sums = np.bincount(b[inside], r[inside], n)
    counts = np.bincount(b[inside], minlength=n)
    with np.errstate(invalid="ignore", divide="ignore"):
        expected = np.minimum(sums / counts, closest + CLUSTER_CAP * noise_std(p, closest))
    expected = np.where(np.isinf(closest), p.no_return_value(), expected)
    too_close = closest < p.range_min
    expected = np.where(too_close, p.too_close_value(), expected)
    unsure = np.zeros(n, bool)
    unsure[b[np.abs(r - limit[b]) < 1e-5 * (1 + limit[b])]] = True  # float32 ranges: ~1e-6 relative
    unsure |= np.abs(closest - p.range_min) < 1e-5
    return expected, unsure


@pytest.mark.parametrize("seed", range(20))
def test_range_noise_rule_matches_numpy_reference(seed):
    """Noisy surfaces (1 to 300 points per beam, some with a second surface 0 to 10 std behind:
    one cluster, the cap, or two clusters) seen from a random mount."""
    rng = np.random.default_rng(100 + seed)
    p = core.Parameters()
    p.angle_min, p.angle_max = -2.0, 2.0
    p.angle_increment = rng.uniform(0.003, 0.02)
    p.range_min = rng.uniform(0.0, 0.4)
    p.range_max = 8.0
    p.too_close_at_range_min = bool(rng.integers(2))
    p.range_noise_std = rng.uniform(0.0, 0.01)
    p.range_noise_std_per_m2 = rng.uniform(0.0005, 0.005)
    lo, hi = p.floor_height + p.min_height, p.floor_height + p.max_height
    pts = []
    for beam in 1 + rng.choice(p.beam_count() - 2, size=60, replace=False):  # inside the angle limits
        surface = rng.uniform(0.1, 6.0)
        std = noise_std(p, surface)
        count = int(rng.integers(1, 300))
        ranges = surface + rng.normal(0.0, std, count)
        if rng.random() < 0.5:
            ranges = np.concatenate([ranges, surface + rng.uniform(0, 10) * std + rng.normal(0.0, std, count)])
        angles = p.angle_min + (beam + rng.uniform(-0.3, 0.3, ranges.size)) * p.angle_increment
        z = rng.uniform(lo + 0.05, hi - 0.05, ranges.size)
        pts.append(np.stack([ranges * np.cos(angles), ranges * np.sin(angles), z], axis=1))
    q = np.concatenate(pts)
    q = q[np.hypot(q[:, 0], q[:, 1]) > 0.01]
    mount = random_mount(rng)
    cam = (q - mount[:3, 3]) @ mount[:3, :3]  # reference -> camera frame
    ranges, _, _ = core.Projector(p).project(cam.astype(np.float32), mount)
    expected, unsure = cluster_reference(p, q)
    # A dense beam may well have a point within float rounding of its cluster's edge.
    assert (~unsure & np.isfinite(expected)).sum() >= 40
    ok = unsure | np.isclose(ranges, expected, rtol=2e-5, atol=2e-5) | (ranges == expected)
    assert ok.all(), f"beams {np.flatnonzero(~ok)[:5]}: core {ranges[~ok][:5]}, numpy {expected[~ok][:5]}"
