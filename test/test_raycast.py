"""Ray casting of the scenario simulator against analytic cases."""
import math

import numpy as np
import pytest

from laserscan_toolbox.simulation import raycast
from laserscan_toolbox.simulation.world import World, Box, Cylinder, Hole, Person

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


# ----- the planar (one origin, level rays) ray casting of the ground truth ---------------

def _level(origin_xy, dirs_xy, z=0.0):
    """The 3D rays of planar ones: origin at height z, zero z direction."""
    o = np.tile([origin_xy[0], origin_xy[1], z], (len(dirs_xy), 1))
    return o, np.column_stack([dirs_xy, np.zeros(len(dirs_xy))])


def _same(a, b):
    """Equal within 1e-9, +inf exactly where the other is +inf."""
    assert a.shape == b.shape
    assert np.array_equal(np.isinf(a), np.isinf(b))
    fin = np.isfinite(b)
    np.testing.assert_allclose(a[fin], b[fin], rtol=0, atol=1e-9)


def _special_rects():
    """Rectangles that make the slab method's corner cases from the origin (0, 0):
    the origin inside, on a face, on a corner, inside by less than EPS (its exit along
    -x does not count); faces in the plane of axis-parallel rays (yaw 0 and pi/2: a
    rotated zero direction is not exactly zero, yaw 0 keeps it); zero size in one or
    both axes."""
    c = [(0.3, -0.2), (2.0, 0.0), (0.0, 1.5), (1.5, 0.5), (-1.0, -1.0), (1.0, 0.0),
         (0.0, 0.0), (3.0, 0.0), (0.0, -2.0), (-2.0, 1.0), (0.5 - 5e-13, 3.0)]
    h = [(1.0, 0.5), (0.5, 0.0), (0.0, 0.5), (0.5, 0.5), (1.0, 1.0), (0.0, 0.0),
         (0.0, 0.7), (1.0, 0.3), (0.4, 0.4), (0.5, 1.0), (0.5, 3.5)]
    yaw = [0.7, 0.0, 0.0, 0.0, 0.0, 0.0, math.pi / 2, 0.0, math.pi / 4, -2.5, 0.0]
    return np.array(c), np.array(h), np.array(yaw)


def _test_directions(rng, n):
    """Random unit directions plus the axis and diagonal ones (exact zero components,
    rays along faces and through corners), a non-unit and a zero direction."""
    a = rng.uniform(-math.pi, math.pi, n)
    axes = [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0), (-0.0, 1.0), (1.0, 1.0),
            (1.0, -1.0), (2.5, 0.0), (0.0, 0.0)]
    return np.vstack([np.column_stack([np.cos(a), np.sin(a)]), axes])


def test_planar_rects_equal_ray_boxes():
    """ray_rects_from_point gives ray_boxes' distances for level rays, random boxes (rotated
    or not) and the corner cases, from origins outside and inside the boxes."""
    rng = np.random.default_rng(7)
    for trial in range(30):
        m = 40
        c = rng.uniform(-6, 6, (m, 2))
        h = rng.uniform(0.0, 1.5, (m, 2))
        yaw = np.where(rng.random(m) < 0.3, 0.0, rng.uniform(-math.pi, math.pi, m))
        sc, sh, syaw = _special_rects()
        c, h, yaw = np.vstack([c, sc]), np.vstack([h, sh]), np.concatenate([yaw, syaw])
        origin = (0.0, 0.0) if trial % 2 else tuple(rng.uniform(-3, 3, 2))
        d = _test_directions(rng, 200)
        o3, d3 = _level(origin, d, z=0.5)
        c3 = np.column_stack([c, np.full(len(c), 0.5)])
        h3 = np.column_stack([h, np.full(len(h), 1.0)])
        ref = raycast.ray_boxes(o3, d3, c3, h3, yaw)
        _same(raycast.ray_rects_from_point(origin, d, c, h, yaw), ref)
        _same(raycast.ray_rects_from_point(origin, d, c, h), raycast.ray_boxes(o3, d3, c3, h3))
        assert np.isfinite(ref).any() and np.isinf(ref).any()


def test_planar_rect_cases():
    # inside: the exit; along a face: a hit (closed box); a corner touched: a hit
    t = raycast.ray_rects_from_point((3.2, 0.0), [(1.0, 0.0)], [(3.0, 0.0)], [(0.5, 0.5)])
    assert t[0, 0] == pytest.approx(0.3)
    t = raycast.ray_rects_from_point((0.0, 0.5), [(1.0, 0.0)], [(3.0, 0.0)], [(0.5, 0.5)])
    assert t[0, 0] == pytest.approx(2.5)
    t = raycast.ray_rects_from_point((0.0, 0.0), [(1.0, 1.0)], [(3.5, 3.5)], [(0.5, 0.5)])
    assert t[0, 0] == pytest.approx(3.0)
    t = raycast.ray_rects_from_point((0.0, 0.5001), [(1.0, 0.0)], [(3.0, 0.0)], [(0.5, 0.5)])
    assert np.isinf(t[0, 0])


def test_planar_circles_equal_ray_vcylinders():
    rng = np.random.default_rng(11)
    for trial in range(30):
        m = 12
        c = rng.uniform(-5, 5, (m, 2))
        r = rng.uniform(0.0, 1.0, m)
        # special ones from the origin (0, 0): around it, through it, zero radius on a
        # ray, tangent to the x axis (y = +-radius), around it by less than EPS on -x
        c = np.vstack([c, [(0.2, 0.1), (0.0, 0.0), (2.0, 0.0), (3.0, 0.5), (-2.0, -0.25),
                           (0.5 - 5e-13, 0.0)]])
        r = np.concatenate([r, [0.5, 0.3, 0.0, 0.5, 0.25, 0.5]])
        origin = (0.0, 0.0) if trial % 2 else tuple(rng.uniform(-3, 3, 2))
        d = _test_directions(rng, 200)
        o3, d3 = _level(origin, d, z=0.3)
        ref = raycast.ray_vcylinders(o3, d3, c, r, np.zeros(len(r)), np.ones(len(r)))
        _same(raycast.ray_circles_from_point(origin, d, c, r), ref)
        assert np.isfinite(ref).any() and np.isinf(ref).any()
    # a tangent ray counts
    t = raycast.ray_circles_from_point((0.0, 0.5), [(1.0, 0.0)], [(3.0, 0.0)], [0.5])
    assert t[0, 0] == pytest.approx(3.0)


def test_pairs_in_reach_hold_every_hit():
    """Every ray / shape pair with a hit within max_range is among pairs_in_reach's, for
    beams in any order and range of angles, from inside and outside the shapes, with
    tangent rays and rays through corners; and most pairs without a hit are left out."""
    rng = np.random.default_rng(5)
    kept = total = 0
    for trial in range(40):
        m = 50
        c = rng.uniform(-8, 8, (m, 2))
        h = rng.uniform(0.0, 1.2, (m, 2))
        yaw = rng.uniform(-math.pi, math.pi, m)
        origin = np.array([0.0, 0.0]) if trial % 3 == 0 else rng.uniform(-4, 4, 2)
        # the special rectangles and circles, placed for the origin (0, 0)
        sc, sh, syaw = _special_rects()
        c, h, yaw = np.vstack([c, sc + origin]), np.vstack([h, sh]), np.concatenate([yaw, syaw])
        # Beams: shuffled, shifted out of [-pi, pi), and straight at every corner.
        n = 300
        angles = rng.permutation(np.linspace(-math.pi, math.pi, n, endpoint=False)) + rng.uniform(-7, 7)
        corners = raycast.box_corners(np.column_stack([c, np.zeros(len(c))]),
                                      np.column_stack([h, np.ones(len(c))]), yaw)[:, ::2, :2]
        rel = corners.reshape(-1, 2) - origin
        angles = np.concatenate([angles, np.arctan2(rel[:, 1], rel[:, 0])])
        d = np.column_stack([np.cos(angles), np.sin(angles)])
        max_range = np.inf if trial % 2 else 6.0
        r = h[:, 0]
        casts = ((lambda pairs=None: raycast.ray_rects_from_point(origin, d, c, h, yaw, pairs=pairs),
                  np.hypot(h[:, 0], h[:, 1])),
                 (lambda pairs=None: raycast.ray_circles_from_point(origin, d, c, r, pairs=pairs), r))
        for cast, radius in casts:
            table = cast()
            rays, shapes = raycast.pairs_in_reach(origin, angles, c, radius, max_range)
            chosen = np.zeros(table.shape, bool)
            chosen[rays, shapes] = True
            assert len(rays) == chosen.sum()  # no pair twice
            assert not (np.isfinite(table) & (table <= max_range) & ~chosen).any()
            assert np.array_equal(cast((rays, shapes)), table[rays, shapes])
            kept += len(rays)
            total += table.size
    assert kept < 0.3 * total


def reference_band_scan(world, origin_xy, angles, z_min, z_max, rel_time, max_range=np.inf,
                        static_only=False, glass=True):
    """The ground truth as it was cast with the 3D ray casting (every obstacle of the band
    extruded to a prism around z = 0, where the rays lie): slow, plain, the reference."""
    angles = np.asarray(angles, float)
    n = len(angles)
    o = np.zeros((n, 3))
    o[:, 0], o[:, 1] = origin_xy[0], origin_xy[1]
    d = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(n)])
    t = np.full(n, np.inf)
    box_c, box_h, box_yaw = world.box_c, world.box_h, world.box_yaw
    if glass and len(world.glass):
        box_c = np.vstack([box_c, world.glass_c])
        box_h = np.vstack([box_h, world.glass_h])
        box_yaw = np.concatenate([box_yaw, world.glass_yaw])
    sel = (box_c[:, 2] + box_h[:, 2] >= z_min) & (box_c[:, 2] - box_h[:, 2] <= z_max)
    if sel.any():
        c, h = box_c[sel].copy(), box_h[sel].copy()
        c[:, 2], h[:, 2] = 0.0, 1.0
        t = np.minimum(t, raycast.ray_boxes(o, d, c, h, box_yaw[sel]).min(axis=1))
    ha = world.hole_arr
    if len(ha):
        c = np.column_stack([(ha[:, 0] + ha[:, 1]) / 2, (ha[:, 2] + ha[:, 3]) / 2, np.zeros(len(ha))])
        h = np.column_stack([(ha[:, 1] - ha[:, 0]) / 2, (ha[:, 3] - ha[:, 2]) / 2, np.ones(len(ha))])
        t = np.minimum(t, raycast.ray_boxes(o, d, c, h).min(axis=1))
    solids = world.solids(rel_time, static_only=static_only)
    sel = (solids["cyl_z1"] >= z_min) & (solids["cyl_z0"] <= z_max)
    if sel.any():
        m = int(sel.sum())
        t = np.minimum(t, raycast.ray_vcylinders(o, d, solids["cyl_xy"][sel], solids["cyl_r"][sel],
                                                 -np.ones(m), np.ones(m)).min(axis=1))
    return np.where(t <= max_range, t, np.inf)


def test_band_scan_equals_the_3d_reference():
    """On the built-in shop floor, along the route and off it (inside obstacles too), in
    the robot's band, a lidar's thin band and above the pallet, at several times (people
    move), with and without glass, with and without a maximum range."""
    from laserscan_toolbox.simulation.scenario import Scenario
    sc = Scenario.default(seed=0)
    w = sc.world
    rng = np.random.default_rng(3)
    angles = -math.pi + np.arange(720) * (2 * math.pi / 720)
    origins = [tuple(sc.true_pose(sc.start_time + s)[:2]) for s in (0.0, 7.0, 19.0, 33.0, 48.0)]
    origins += [(8.35, 6.45), (18.5, 12.5), (17.3, 4.5), (8.0, 11.7)]  # in the glass, crate, pit, pillar
    origins += [tuple(p) for p in rng.uniform((0.5, 0.5), (19.5, 14.5), (6, 2))]
    bands = [(0.05, 1.0), (0.18, 0.22), (0.16, 0.4), (1.2, 2.0), (2.5, 3.0)]
    compared = 0
    for k, origin in enumerate(origins):
        rel = (5.3 * k) % sc.duration
        for z_min, z_max in bands:
            for max_range in (np.inf, 4.5):
                with_glass, without = w.band_scans(origin, angles, z_min, z_max, rel, max_range)
                for glass, scan in ((True, with_glass), (False, without)):
                    ref = reference_band_scan(w, origin, angles, z_min, z_max, rel, max_range,
                                              glass=glass)
                    _same(w.band_scan(origin, angles, z_min, z_max, rel, max_range, glass=glass), ref)
                    _same(np.where(scan <= max_range, scan, np.inf), ref)
                    compared += np.isfinite(ref).sum()
    assert compared > 100000
    # beams in any order and angle range (an ideal scan's angles + the robot's yaw)
    order = rng.permutation(len(angles))
    for shift in (2.5, -7.0, 13.0):
        a = angles[order] + shift
        for glass in (True, False):
            ref = reference_band_scan(w, origins[0], a, 0.05, 1.0, 4.0, glass=glass)
            _same(w.band_scan(origins[0], a, 0.05, 1.0, 4.0, glass=glass), ref)
    # the static world alone: no people
    ref = reference_band_scan(w, origins[1], angles, 0.05, 1.0, 3.0, static_only=True)
    _same(w.band_scan(origins[1], angles, 0.05, 1.0, 3.0, static_only=True), ref)
