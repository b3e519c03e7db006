"""The range converter's arcs through the merger core (both C++ cores through pybind11).

A sensor mounted off-centre and rotated in the robot frame reports a range; its arc, merged into
a 360-degree scan around the robot's origin, must be the analytic cone's front seen from there:
on each output bin, where the bin's ray meets the circle of the measured radius around the sensor
inside the cone. A reading at max_range (no return, +Inf) must leave the merged scan as the other
sources make it: +Inf never replaces a range, and never clears what another sensor sees.
"""
import math

import numpy as np
import pytest

import depth_filter_scan_converter_range_core as rc
import multi_laserscan_merger_core as mlc

OUTPUT = dict(angle_min=-math.pi, angle_max=math.pi, angle_increment=math.pi / 720, range_min=0.0,
              range_max=12.0)
N_OUT = 1441
BIN = math.pi / 720


def mount(x, y, yaw, z=0.3):
    m = np.eye(4)
    m[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
    m[:3, 3] = (x, y, z)
    return m


def as_scan(arc, transform, stamp=10.0):
    return dict(stamp=stamp, angle_min=arc["angle_min"], angle_max=arc["angle_max"],
                angle_increment=arc["angle_increment"], time_increment=0.0, range_min=arc["range_min"],
                range_max=arc["range_max"], ranges=np.asarray(arc["ranges"], np.float32), transform=transform)


def analytic_cone(x, y, yaw, r, fov):
    """Per output bin, the distance from the origin to the arc {|p - s| = r, angle within the
    cone}, +inf where the bin's ray misses it."""
    theta = OUTPUT["angle_min"] + BIN * np.arange(N_OUT)
    u = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    s = np.array([x, y])
    us = u @ s
    disc = us ** 2 - s @ s + r * r
    best = np.full(N_OUT, np.inf)
    for sign in (-1.0, 1.0):
        with np.errstate(invalid="ignore"):
            t = us + sign * np.sqrt(disc)
        p = t[:, None] * u - s
        off = np.arctan2(p[:, 1], p[:, 0]) - yaw
        off = np.arctan2(np.sin(off), np.cos(off))
        ok = (disc >= 0) & (t > 0) & (np.abs(off) <= fov / 2 + 1e-9)
        best = np.where(ok & (t < best), t, best)
    return best


def merge(*scans, names=None):
    sources = [dict(name="s%d" % i, topic="t%d" % i, timeout=1.0) for i in range(len(scans))]
    merger = mlc.Merger(OUTPUT, sources)
    return np.asarray(merger.merge(list(scans), 10.0)["ranges"], float)


def convert(range_m, fov=0.6, min_range=0.3, max_range=5.0, **params):
    p = rc.RangeScanParameters()
    for k, v in params.items():
        setattr(p, k, v)
    arc = rc.RangeToScan(p).convert(range_m, fov, min_range, max_range)
    assert isinstance(arc, dict), arc
    return arc


MOUNTS = [(0.0, 0.0, 0.0), (0.37, 0.12, math.radians(15)), (0.0, -0.24, -math.pi / 2),
          (-0.37, 0.2, 2.8), (0.37, -0.12, math.radians(-15))]


@pytest.mark.parametrize("x,y,yaw", MOUNTS)
@pytest.mark.parametrize("r", [0.3, 0.8, 2.5, 4.9])
def test_merged_arc_is_the_analytic_cone(x, y, yaw, r):
    fov = 0.6
    merged = merge(as_scan(convert(r, fov), mount(x, y, yaw)))
    expected = analytic_cone(x, y, yaw, r, fov)
    hit = np.isfinite(expected)
    assert hit.sum() > 10
    # Bins the cone covers: the merged range is the cone's front there (a bin keeps the closest
    # of the arc beams in it, which lie within half a bin of its centre).
    slope = np.abs(np.gradient(np.where(hit, expected, np.nan))) / BIN
    tol = 0.002 + 0.5 * BIN * np.nan_to_num(slope, nan=0.0)
    got = merged[hit]
    assert np.all(np.isfinite(got)), "a bin inside the cone has no return"
    assert np.all(np.abs(got - expected[hit]) <= tol[hit] + 1e-6), np.max(np.abs(got - expected[hit]) - tol[hit])
    # Outside the cone nothing, except the bin just beyond each edge (an edge beam rounds to it).
    edge = np.convolve(hit.astype(int), np.ones(3, int), mode="same") > 0
    assert np.all(np.isinf(merged[~edge]) & (merged[~edge] > 0)), "the arc leaked out of its cone"


@pytest.mark.parametrize("x,y,yaw", MOUNTS[1:3])
def test_narrow_arc_option(x, y, yaw):
    merged = merge(as_scan(convert(2.0, 0.6, arc_width=0.2), mount(x, y, yaw)))
    expected = analytic_cone(x, y, yaw, 2.0, 0.2)
    assert np.isfinite(merged).sum() == pytest.approx(np.isfinite(expected).sum(), abs=2)


def wall_scan(distance, transform):
    """A 360-degree lidar at the robot's origin facing a wall x = distance."""
    n = 720
    a = -math.pi + np.arange(n) * (2 * math.pi / n)
    with np.errstate(divide="ignore"):
        r = np.where(np.cos(a) > 0.05, distance / np.cos(a), np.inf)
    r = np.where(r <= 10.0, r, np.inf).astype(np.float32)
    return dict(stamp=10.0, angle_min=-math.pi, angle_max=a[-1], angle_increment=2 * math.pi / n, time_increment=0.0,
                range_min=0.1, range_max=10.0, ranges=r, transform=transform)


def test_max_range_reading_never_clears_another_sensor():
    lidar = wall_scan(2.0, np.eye(4))
    alone = merge(lidar)
    for r in (5.0, 7.0, math.inf):
        arc = convert(r)
        assert np.all(np.isposinf(arc["ranges"]))
        both = merge(lidar, as_scan(arc, mount(0.37, 0.0, 0.0)))
        np.testing.assert_array_equal(both, alone)


def test_fusion_keeps_the_closest():
    lidar = wall_scan(3.0, np.eye(4))
    x, y, yaw = 0.37, 0.12, math.radians(15)
    # Glass at 1.2 m from the sensor: the lidar sees through it to the wall, the arc is closer.
    merged = merge(lidar, as_scan(convert(1.2), mount(x, y, yaw)))
    cone = analytic_cone(x, y, yaw, 1.2, 0.6)
    inside = np.isfinite(cone)
    assert np.all(merged[inside] < 3.0 / np.cos(OUTPUT["angle_min"] + BIN * np.arange(N_OUT))[inside])
    assert np.all(np.abs(merged[inside] - cone[inside]) < 0.01)
    # A reading beyond the wall: the wall stays where it is on every bin the lidar covers.
    alone = merge(lidar)
    merged = merge(lidar, as_scan(convert(4.5), mount(x, y, yaw)))
    wall = np.isfinite(alone)
    assert wall.sum() > 200
    np.testing.assert_array_equal(merged[wall], alone[wall])
