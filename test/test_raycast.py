"""Ray casting of the scenario simulator against analytic cases."""
import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts"))
from laserscan_toolbox.simulation import raycast  # noqa: E402
from laserscan_toolbox.simulation.world import World, Box, Cylinder, Hole, Person  # noqa: E402

O = np.array([[0.0, 0.0, 0.5]])


def ray(dx, dy, dz, o=O):
    return o, np.array([[dx, dy, dz]], float)


def test_box_face_distance():
    # unit box centred at (3, 0, 0.5): near face at x = 2.5
    t = raycast.ray_boxes(*ray(1, 0, 0), [[3, 0, 0.5]], [[0.5, 0.5, 0.5]])
    assert t[0, 0] == pytest.approx(2.5)
    # un-normalised direction: t in units of |d|
    t = raycast.ray_boxes(*ray(2, 0, 0), [[3, 0, 0.5]], [[0.5, 0.5, 0.5]])
    assert t[0, 0] == pytest.approx(1.25)
    # oblique: the face at x = 2.5 reached along 45 degrees
    d = np.array([[1, 1, 0]]) / math.sqrt(2)
    t = raycast.ray_boxes(O, d, [[3, 2.5, 0.5]], [[0.5, 0.5, 0.5]])
    assert t[0, 0] == pytest.approx(2.5 * math.sqrt(2))


def test_oriented_box():
    # a 2 x 0.2 board rotated 90 degrees stands across the x axis: face at x = 2.9
    t = raycast.ray_boxes(*ray(1, 0, 0), [[3, 0, 0.5]], [[1.0, 0.1, 1.0]], [math.pi / 2])
    assert t[0, 0] == pytest.approx(2.9)
    # rotated 0: the ray along x meets its end face at x = 2
    t = raycast.ray_boxes(*ray(1, 0, 0), [[3, 0, 0.5]], [[1.0, 0.1, 1.0]], [0.0])
    assert t[0, 0] == pytest.approx(2.0)


def test_box_miss_and_behind():
    t = raycast.ray_boxes(*ray(1, 0, 0), [[3, 2, 0.5], [-3, 0, 0.5]], [[0.5, 0.5, 0.5]] * 2)
    assert np.all(np.isinf(t))


def test_ray_parallel_to_face():
    # Travels in the plane y = 0.5 of the box's face: on the face counts (closed box),
    # just outside misses; no NaN from 0 * inf.
    o = np.array([[0.0, 0.5, 0.5], [0.0, 0.5001, 0.5]])
    d = np.array([[1.0, 0.0, 0.0]] * 2)
    t = raycast.ray_boxes(o, d, [[3, 0, 0.5]], [[0.5, 0.5, 0.5]])[:, 0]
    assert t[0] == pytest.approx(2.5)
    assert np.isinf(t[1])
    assert not np.isnan(t).any()


def test_ray_from_inside_box_reports_exit():
    t = raycast.ray_boxes(np.array([[3.2, 0, 0.5]]), np.array([[1.0, 0, 0]]), [[3, 0, 0.5]],
                          [[0.5, 0.5, 0.5]])
    assert t[0, 0] == pytest.approx(0.3)


def test_cylinder_hit_tangent_miss():
    c, r = [[4.0, 0.0]], [0.5]
    t = raycast.ray_vcylinders(*ray(1, 0, 0), c, r, [0.0], [1.0])
    assert t[0, 0] == pytest.approx(3.5)
    # passing at 0.5 - 1e-6 from the axis: hit near x = 4; at 0.5 + 1e-6: miss
    o_in = np.array([[0.0, 0.5 - 1e-6, 0.5]])
    o_out = np.array([[0.0, 0.5 + 1e-6, 0.5]])
    d = np.array([[1.0, 0, 0]])
    assert raycast.ray_vcylinders(o_in, d, c, r, [0.0], [1.0])[0, 0] == pytest.approx(4.0, abs=2e-3)
    assert np.isinf(raycast.ray_vcylinders(o_out, d, c, r, [0.0], [1.0])[0, 0])
    # above the cylinder's top: miss
    o_hi = np.array([[0.0, 0.0, 1.2]])
    assert np.isinf(raycast.ray_vcylinders(o_hi, d, c, r, [0.0], [1.0])[0, 0])
    # straight down onto the top cap
    t = raycast.ray_vcylinders(np.array([[4.1, 0.0, 3.0]]), np.array([[0, 0, -1.0]]), c, r, [0.0], [1.0])
    assert t[0, 0] == pytest.approx(2.0)


def test_moving_cylinders_per_ray():
    # Two rays see the same person at two times (positions per ray).
    o = np.zeros((2, 3))
    d = np.array([[1.0, 0, 0]] * 2)
    xy = np.array([[[3.0, 0.0]], [[5.0, 0.0]]])
    t = raycast.ray_vcylinders(o, d, xy, [0.25], [-1.0], [2.0])[:, 0]
    assert t == pytest.approx([2.75, 4.75])


def test_floor_ceiling_and_hole():
    holes = [[2.0, 3.0, -1.0, 1.0, 0.3]]
    d = np.array([[1.0, 0.0, -0.5]])  # reaches z = 0 at x = 1 (floor), slope 1/2
    o = np.array([[0.0, 0.0, 0.5]])
    assert raycast.ray_floor_ceiling(o, d, holes, 3.0)[0] == pytest.approx(1.0)
    # Starting at x = 1.5 the ray crosses z = 0 at x = 2.5, inside the hole, and
    # continues to the bottom z = -0.3 at x = 3.1 > 3.0: it stops at the far wall x = 3.
    o2 = np.array([[1.5, 0.0, 0.5]])
    assert raycast.ray_floor_ceiling(o2, d, holes, 3.0)[0] == pytest.approx(1.5)
    # steeper ray reaches the bottom: z = -0.3 at t = 0.8 / 1.0
    d3 = np.array([[0.25, 0.0, -1.0]])
    o3 = np.array([[2.2, 0.0, 0.5]])
    assert raycast.ray_floor_ceiling(o3, d3, holes, 3.0)[0] == pytest.approx(0.8)
    # up to the ceiling at 3 m
    assert raycast.ray_floor_ceiling(o, np.array([[0, 0, 1.0]]), holes, 3.0)[0] == pytest.approx(2.5)
    # level ray: neither
    assert np.isinf(raycast.ray_floor_ceiling(o, np.array([[1.0, 0, 0]]), holes, 3.0)[0])


def _small_world():
    return World(bounds=(0, 10, -5, 5), ceiling=3.0,
                 boxes=[Box("wall", (5.1, 0.0, 1.5), (0.2, 10.0, 3.0)),
                        Box("tabletop", (2.0, 0.0, 0.73), (0.6, 1.0, 0.04))],
                 cylinders=[Cylinder("post", (0.0, 2.0), 0.1, 0.0, 1.0)],
                 holes=[Hole("pit", -3.0, -2.0, -1.0, 1.0, 0.3)],
                 people=[Person("p", [(0.0, -3.0), (0.0, -1.0)], 1.0, phase=0.0, radius=0.2)])


def test_band_scan_known_geometry():
    w = _small_world()
    ang = np.array([0.0, math.pi / 2, math.pi, -math.pi / 2])
    # Low band: table top out of band, wall at 5; post at 2 - 0.1; pit rim at 2; person at 3 - 0.2
    r = w.band_scan((0.0, 0.0), ang, 0.05, 0.5, rel_time=0.0)
    assert r == pytest.approx([5.0, 1.9, 2.0, 2.8])
    # Band with the table top: its near edge at 1.7; person moved 1 m closer at t = 1 s
    r = w.band_scan((0.0, 0.0), ang, 0.05, 1.0, rel_time=1.0)
    assert r == pytest.approx([1.7, 1.9, 2.0, 1.8])
    # Above everything but the wall and the person
    r = w.band_scan((0.0, 0.0), ang, 1.2, 1.5, rel_time=0.0, max_range=4.0)
    assert np.isinf(r[0]) and np.isinf(r[1]) and r[2] == pytest.approx(2.0) and r[3] == pytest.approx(2.8)


def test_render_depth_matches_brute_force():
    """The culled renderer gives exactly the plain cast of every pixel."""
    w = _small_world()
    w.boxes.append(Box("rotated_crate", (3.0, -0.8, 0.4), (0.6, 0.4, 0.8), 0.7))
    w.boxes.append(Box("aligned_with_ray", (4.0, 0.0, 0.3), (0.2, 0.2, 0.6), 0.0))
    w._pack()
    fx = fy = 50.0
    rot = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])  # optical -> world, level
    pitch = math.radians(20)
    ry = np.array([[math.cos(pitch), 0, math.sin(pitch)], [0, 1, 0], [-math.sin(pitch), 0, math.cos(pitch)]])
    rot = ry @ rot
    pos = np.array([0.0, 0.0, 0.6])
    img = raycast.render_depth(w.solids(0.0), w.hole_arr, w.ceiling, rot, pos, (fx, fy, 39.5, 24.5),
                               80, 50, 20.0)
    rays = raycast.pixel_rays(80, 50, fx, fy, 39.5, 24.5).reshape(-1, 3) @ rot.T
    ref = w.cast(np.broadcast_to(pos, rays.shape), rays, 0.0).reshape(50, 80)
    assert np.array_equal(img, ref)
    # centre pixel looks 20 degrees down: floor at depth 0.6 / sin(20 deg), table top edge first?
    assert np.isfinite(img).all()
