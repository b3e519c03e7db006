"""Vectorised ray casting against simple primitives (numpy, no ROS).

Conventions shared by every function here:

- Rays are ``origins`` (N, 3) and ``directions`` (N, 3).  Directions need not be
  unit vectors: the returned parameter ``t`` is the distance along the ray in
  units of ``|direction|`` (a unit direction gives metres; a camera ray whose
  optical-axis component is 1 gives the depth along that axis directly).
- A miss is ``+inf``.  Hits at ``t <= EPS`` (behind or at the origin) do not count.
- A ray that starts inside a solid reports where it leaves it (its exit
  distance); world sensors never start inside obstacles, but a camera looking
  into a floor hole is "inside" the hole's volume once it crosses the floor
  plane, and that exit is exactly the hole's bottom or wall.
- Boxes are given by centre (M, 3), half extents (M, 3) and a yaw (M,) around
  the vertical axis (oriented boxes that stay upright, which is all a shop
  floor needs).  Cylinders are vertical: centre xy (M, 2), radius (M,),
  z range [z0, z1].
- The ``*_from_point`` functions are the planar case: rays in the plane from one
  origin (a 2D scan), against the sections of the boxes (rectangles) and
  cylinders (circles) by that plane, with the same results as the 3D functions.
"""
import numpy as np

EPS = 1e-9


def _slab(lo, hi, o, d):
    """Per-axis parameter interval [tmin, tmax] of a ray inside the slab lo <= x <= hi.

    A zero direction component is decided by the origin alone (inside the slab:
    the whole line; outside: empty), which avoids the 0 * inf = NaN of 1/d and
    makes a ray lying in a face's plane count as touching it (closed solids).
    """
    zero = d == 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / np.where(zero, 1.0, d)
        t1 = (lo - o) * inv
        t2 = (hi - o) * inv
    inside = (o >= lo) & (o <= hi)
    tmin = np.where(zero, np.where(inside, -np.inf, np.inf), np.minimum(t1, t2))
    tmax = np.where(zero, np.inf, np.maximum(t1, t2))
    return tmin, tmax


def ray_boxes(origins, directions, centers, half, yaw=None):
    """Distances from every ray to every box (slab method).

    origins, directions: (N, 3).  centers, half: (M, 3).  yaw: (M,) or None.
    Returns t (N, M): entry distance, exit distance for a ray starting inside,
    +inf for a miss.
    """
    o = np.asarray(origins, float)[:, None, :]
    d = np.asarray(directions, float)[:, None, :]
    c = np.asarray(centers, float)[None, :, :]
    h = np.asarray(half, float)[None, :, :]
    rel = o - c
    if yaw is not None:
        yaw = np.asarray(yaw, float)
        cs, sn = np.cos(yaw)[None, :], np.sin(yaw)[None, :]
        # Express the rays in each box's own frame (rotate by -yaw).
        rx = cs * rel[..., 0] + sn * rel[..., 1]
        ry = -sn * rel[..., 0] + cs * rel[..., 1]
        dx = cs * d[..., 0] + sn * d[..., 1]
        dy = -sn * d[..., 0] + cs * d[..., 1]
        rel = np.stack([rx, ry, np.broadcast_to(rel[..., 2], rx.shape)], axis=-1)
        d = np.stack([dx, dy, np.broadcast_to(d[..., 2], dx.shape)], axis=-1)
    tmin, tmax = _slab(-h, h, rel, d)
    tnear = tmin.max(axis=-1)
    tfar = tmax.min(axis=-1)
    hit = (tnear <= tfar) & (tfar > EPS)
    t = np.where(tnear > EPS, tnear, tfar)
    return np.where(hit, t, np.inf)


def ray_own_boxes(origins, directions, centers, half, yaw):
    """Distance from each ray to the closest of its own boxes (a swept lidar meets the moving
    arm where it is at each beam's time).

    origins, directions: (N, 3).  centers: (N, M, 3).  half: (M, 3).  yaw: (N, M).
    Returns (N,): entry distance (exit distance from inside), +inf for a miss.
    """
    rel = np.asarray(origins, float)[:, None, :] - np.asarray(centers, float)
    d = np.broadcast_to(np.asarray(directions, float)[:, None, :], rel.shape)
    cs, sn = np.cos(yaw), np.sin(yaw)
    rel = np.stack([cs * rel[..., 0] + sn * rel[..., 1], -sn * rel[..., 0] + cs * rel[..., 1],
                    rel[..., 2]], axis=-1)
    d = np.stack([cs * d[..., 0] + sn * d[..., 1], -sn * d[..., 0] + cs * d[..., 1], d[..., 2]], axis=-1)
    h = np.asarray(half, float)[None, :, :]
    tmin, tmax = _slab(-h, h, rel, d)
    tnear = tmin.max(axis=-1)
    tfar = tmax.min(axis=-1)
    hit = (tnear <= tfar) & (tfar > EPS)
    t = np.where(hit, np.where(tnear > EPS, tnear, tfar), np.inf)
    return t.min(axis=1)


def ray_aabb_exit(origins, directions, lo, hi):
    """Exit distance (N, M) of rays from axis-aligned boxes [lo, hi] (M, 3), or +inf."""
    o = np.asarray(origins, float)[:, None, :]
    d = np.asarray(directions, float)[:, None, :]
    tmin, tmax = _slab(np.asarray(lo, float)[None], np.asarray(hi, float)[None], o, d)
    tnear = tmin.max(axis=-1)
    tfar = tmax.min(axis=-1)
    return np.where((tnear <= tfar) & (tfar > EPS), tfar, np.inf)


def ray_vcylinders(origins, directions, centers_xy, radius, z0, z1):
    """Distances from rays to vertical cylinders.

    centers_xy: (M, 2), or (N, M, 2) when the cylinders move and every ray sees
    them at its own time.  radius, z0, z1: (M,).  Returns t (N, M).
    A tangent ray (touching the side at one point) counts as a hit.
    """
    o = np.asarray(origins, float)
    d = np.asarray(directions, float)
    cxy = np.asarray(centers_xy, float)
    if cxy.ndim == 2:
        cxy = cxy[None]
    r = np.asarray(radius, float)[None, :]
    ox = o[:, None, 0] - cxy[..., 0]
    oy = o[:, None, 1] - cxy[..., 1]
    dx, dy = d[:, None, 0], d[:, None, 1]
    a = dx * dx + dy * dy
    b = 2.0 * (ox * dx + oy * dy)
    c = ox * ox + oy * oy - r * r
    vertical = a < 1e-18
    a_safe = np.where(vertical, 1.0, a)
    disc = b * b - 4.0 * a_safe * c
    sq = np.sqrt(np.maximum(disc, 0.0))
    tc0 = np.where(vertical, -np.inf, (-b - sq) / (2.0 * a_safe))
    tc1 = np.where(vertical, np.inf, (-b + sq) / (2.0 * a_safe))
    side_ok = np.where(vertical, c <= 0.0, disc >= 0.0)
    oz, dz = o[:, None, 2], d[:, None, 2]
    tz_min, tz_max = _slab(np.asarray(z0, float)[None, :], np.asarray(z1, float)[None, :], oz, dz)
    tnear = np.maximum(tc0, tz_min)
    tfar = np.minimum(tc1, tz_max)
    hit = side_ok & (tnear <= tfar) & (tfar > EPS)
    t = np.where(tnear > EPS, tnear, tfar)
    return np.where(hit, t, np.inf)


def _slab_from_point(lo, hi, o, d):
    """``_slab`` for one origin: lo, hi, o (M,) per box with d (N, M) or (N, 1), or all
    (P,) per ray / box pair.  The zero direction components (rare: a beam exactly along
    a face) are patched afterwards."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        t1 = (lo - o) * inv
        t2 = (hi - o) * inv
    tmin = np.minimum(t1, t2)
    tmax = np.maximum(t1, t2)
    zero = d == 0.0
    if zero.any():
        zero = np.broadcast_to(zero, tmin.shape)
        inside = (o >= lo) & (o <= hi)
        tmin[zero] = np.broadcast_to(np.where(inside, -np.inf, np.inf), tmin.shape)[zero]
        tmax[zero] = np.inf
    return tmin, tmax


def _planar_rays(origin, directions, centers, pairs):
    """The origin relative to every centre (M,) and the direction components, shaped to
    broadcast: (N, 1) for a whole (N, M) table; with ``pairs`` = (rays, shapes) index
    arrays (P,), everything (P,) for just those pairs."""
    o = np.asarray(origin, float)
    d = np.asarray(directions, float).reshape(-1, 2)
    c = np.asarray(centers, float).reshape(-1, 2)
    rx, ry = o[0] - c[:, 0], o[1] - c[:, 1]
    if pairs is None:
        return rx, ry, d[:, 0:1], d[:, 1:2], slice(None)
    rays, shapes = pairs
    return rx[shapes], ry[shapes], d[rays, 0], d[rays, 1], shapes


def ray_rects_from_point(origin, directions, centers, half, yaw=None, pairs=None):
    """Distances (N, M) from ONE origin (2,) along planar directions (N, 2) to upright
    rectangles: centre (M, 2), half extents (M, 2), yaw (M,) or None.  With ``pairs`` =
    (rays, shapes) index arrays (P,): the distances (P,) of those ray / rectangle pairs.

    The 2D case of ``ray_boxes`` (level rays inside the boxes' height), with its results
    and conventions; the origin in each box's frame is per box, only the directions
    turned into the boxes' frames are per ray and box.
    """
    rx, ry, dx, dy, sel = _planar_rays(origin, directions, centers, pairs)
    h = np.asarray(half, float).reshape(-1, 2)[sel]
    if yaw is not None:
        yaw = np.asarray(yaw, float)[sel]
        cs, sn = np.cos(yaw), np.sin(yaw)
        # The rays in each box's own frame (rotated by -yaw), as ray_boxes does.
        rx, ry = cs * rx + sn * ry, -sn * rx + cs * ry
        dx, dy = cs * dx + sn * dy, -sn * dx + cs * dy
    tnear, tfar = _slab_from_point(-h[:, 0], h[:, 0], rx, dx)
    ty_min, ty_max = _slab_from_point(-h[:, 1], h[:, 1], ry, dy)
    tnear = np.maximum(tnear, ty_min)
    tfar = np.minimum(tfar, ty_max)
    hit = (tnear <= tfar) & (tfar > EPS)
    return np.where(hit, np.where(tnear > EPS, tnear, tfar), np.inf)


def ray_circles_from_point(origin, directions, centers, radius, pairs=None):
    """Distances (N, M) from ONE origin (2,) along planar directions (N, 2) to circles:
    centre (M, 2), radius (M,); with ``pairs``: (P,) as ``ray_rects_from_point``.  The 2D
    case of ``ray_vcylinders`` (level rays inside the cylinders' height), with its results
    and conventions (a tangent ray hits)."""
    ox, oy, dx, dy, sel = _planar_rays(origin, directions, centers, pairs)
    r = np.asarray(radius, float)[sel]
    a = dx * dx + dy * dy
    # A zero direction never reaches a side (ray_vcylinders: +inf whether inside or not).
    flat = a < 1e-18
    a = np.where(flat, 1.0, a)
    b = 2.0 * (ox * dx + oy * dy)
    c = ox * ox + oy * oy - r * r
    disc = b * b - 4.0 * a * c
    sq = np.sqrt(np.maximum(disc, 0.0))
    t0 = (-b - sq) / (2.0 * a)
    t1 = (-b + sq) / (2.0 * a)
    hit = (disc >= 0.0) & (t0 <= t1) & (t1 > EPS) & ~flat
    return np.where(hit, np.where(t0 > EPS, t0, t1), np.inf)


#: Angle (rad) by which ``pairs_in_reach`` widens every shape's sector: far more than the
#: rounding of the beams' angles and directions, so that no grazing beam is left out.
SECTOR_MARGIN = 1e-7


def pairs_in_reach(origin, angles, centers, radius, max_range=np.inf):
    """The (rays, shapes) index pairs (P,) that can meet: ray i from ONE origin (2,) at
    angle ``angles[i]`` (rad, any order and range) passes within ``radius[j]`` of
    ``centers[j]`` (M, 2) (a shape's bounding circle) and that circle comes within
    ``max_range`` of the origin.  Pairs that cannot meet may be among them (a margin of
    SECTOR_MARGIN), never the reverse.  Pairs come shape by shape.

    Every shape is seen under a sector of directions; the beams in it are found by a
    search in the sorted angles, which keeps a scan's ray casting to the pairs that
    matter (a few thousand of a 720-beam scan's 50,000 in a shop).
    """
    a = np.mod(np.asarray(angles, float), 2 * np.pi)
    order = np.argsort(a, kind="stable")
    a = a[order]
    n = len(a)
    c = np.asarray(centers, float).reshape(-1, 2) - np.asarray(origin, float)[:2]
    r = np.asarray(radius, float)
    dist = np.hypot(c[:, 0], c[:, 1])
    reach = dist - r <= max_range
    around = dist <= r  # the origin in the circle: every direction
    with np.errstate(divide="ignore", invalid="ignore"):
        half = np.where(around, np.pi, np.arcsin(np.minimum(r / dist, 1.0))) + SECTOR_MARGIN
    lo = np.mod(np.arctan2(c[:, 1], c[:, 0]) - half, 2 * np.pi)
    hi = lo + 2 * half
    # [lo, hi] in the sorted angles, and its part past 2 pi from 0 on.
    first = np.searchsorted(a, lo, "left")
    count = np.searchsorted(a, hi, "right") - first
    wrapped = np.searchsorted(a, hi - 2 * np.pi, "right")
    first = np.where(around, 0, first)
    count = np.where(around, n, count)
    wrapped = np.where(around, 0, np.minimum(wrapped, first))  # never a beam twice
    count, wrapped = count * reach, wrapped * reach
    shapes = np.repeat(np.arange(len(r)), count + wrapped)
    starts = np.stack([first, np.zeros_like(first)], axis=1).ravel()
    counts = np.stack([count, wrapped], axis=1).ravel()
    ends = np.cumsum(counts)
    idx = np.arange(ends[-1] if len(ends) else 0) - np.repeat(ends - counts - starts, counts)
    return order[idx], shapes


def ray_floor_ceiling(origins, directions, holes=None, ceiling=np.inf):
    """Distances (N,) to the floor plane z = 0 (with holes) and the ceiling.

    holes: (K, 5) rows ``x0, x1, y0, y1, depth``: inside the rectangle the floor
    is missing and the ground is ``depth`` lower.  A ray that crosses z = 0
    inside a hole continues into it and stops at the hole's bottom or side wall
    (its exit from the box [x0, x1] x [y0, y1] x [-depth, 0]).
    """
    o = np.asarray(origins, float)
    d = np.asarray(directions, float)
    oz, dz = o[:, 2], d[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        t_floor = np.where((dz < 0.0) & (oz >= 0.0), -oz / dz, np.inf)
        t_ceil = np.where((dz > 0.0) & (oz <= ceiling), (ceiling - oz) / dz, np.inf)
    if holes is not None and len(holes):
        holes = np.asarray(holes, float)
        finite = np.isfinite(t_floor)
        if finite.any():
            idx = np.nonzero(finite)[0]
            p = o[idx] + t_floor[idx, None] * d[idx]
            inside = ((p[:, None, 0] >= holes[None, :, 0]) & (p[:, None, 0] <= holes[None, :, 1])
                      & (p[:, None, 1] >= holes[None, :, 2]) & (p[:, None, 1] <= holes[None, :, 3]))
            rows = inside.any(axis=1)
            if rows.any():
                lo = np.stack([holes[:, 0], holes[:, 2], -holes[:, 4]], axis=1)
                hi = np.stack([holes[:, 1], holes[:, 3], np.zeros(len(holes))], axis=1)
                sel = idx[rows]
                t_exit = ray_aabb_exit(o[sel], d[sel], lo, hi)
                t_exit = np.where(inside[rows], t_exit, np.inf).min(axis=1)
                t_floor[sel] = t_exit
    return np.minimum(t_floor, t_ceil)


def box_corners(centers, half, yaw):
    """The 8 corners (M, 8, 3) of upright oriented boxes."""
    centers = np.asarray(centers, float)
    half = np.asarray(half, float)
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)
    local = signs[None] * half[:, None, :]
    cs, sn = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    x = cs * local[..., 0] - sn * local[..., 1]
    y = sn * local[..., 0] + cs * local[..., 1]
    return np.stack([x, y, local[..., 2]], axis=-1) + centers[:, None, :]


def pixel_rays(width, height, fx, fy, cx, cy):
    """Optical-frame ray directions (height, width, 3) with z = 1 (so t = depth)."""
    u = (np.arange(width, dtype=float) - cx) / fx
    v = (np.arange(height, dtype=float) - cy) / fy
    uu, vv = np.meshgrid(u, v)
    return np.stack([uu, vv, np.ones_like(uu)], axis=-1)


def _one_box_from_point(rel, d, inv, half):
    """Distances (n,) from one origin (``rel`` = origin - box centre, in the box's
    frame) along directions d (n, 3) (with inv = 1 / d, zeros replaced by 1) to
    one box.  Same result as ``ray_boxes`` but with scalar slab bounds per axis,
    which makes a camera frame (a single origin) several times cheaper."""
    tnear = np.full(len(d), -np.inf)
    tfar = np.full(len(d), np.inf)
    for a in range(3):
        t1 = (-half[a] - rel[a]) * inv[:, a]
        t2 = (half[a] - rel[a]) * inv[:, a]
        lo = np.minimum(t1, t2)
        hi = np.maximum(t1, t2)
        zero = d[:, a] == 0.0
        if zero.any():
            inside = -half[a] <= rel[a] <= half[a]
            lo[zero] = -np.inf if inside else np.inf
            hi[zero] = np.inf
        np.maximum(tnear, lo, out=tnear)
        np.minimum(tfar, hi, out=tfar)
    hit = (tnear <= tfar) & (tfar > EPS)
    return np.where(hit, np.where(tnear > EPS, tnear, tfar), np.inf)


def _pixel_window(corners_cam, fx, fy, cx, cy, width, height, near):
    """Pixel rectangle that holds the projection of a convex solid, or None.

    Returns (u0, u1, v0, v1) inclusive, the whole image when part of the solid is
    behind the camera (no safe projection), or None when all of it is behind.
    """
    z = corners_cam[:, 2]
    if np.all(z <= near):
        return None
    if np.any(z <= near):
        return 0, width - 1, 0, height - 1
    u = fx * corners_cam[:, 0] / z + cx
    v = fy * corners_cam[:, 1] / z + cy
    u0, u1 = int(np.floor(u.min())), int(np.ceil(u.max()))
    v0, v1 = int(np.floor(v.min())), int(np.ceil(v.max()))
    if u1 < 0 or v1 < 0 or u0 > width - 1 or v0 > height - 1:
        return None
    return max(u0, 0), min(u1, width - 1), max(v0, 0), min(v1, height - 1)


def render_depth(solids, floor_holes, ceiling, cam_rotation, cam_position, intrinsics,
                 width, height, max_depth, rays=None):
    """Noise-free depth image (height, width) of a pinhole camera, +inf where nothing.

    solids: dict with ``box_c, box_h, box_yaw`` and ``cyl_xy, cyl_r, cyl_z0, cyl_z1``
    arrays (world frame, at the frame's time).  cam_rotation (3, 3) maps optical
    frame vectors into the world; cam_position (3,).  intrinsics: (fx, fy, cx, cy).
    Each solid is only tested against the pixels of its projected bounding box,
    which keeps a 52,000-pixel frame of a ~150-primitive world at a few ms.
    """
    fx, fy, cx, cy = intrinsics
    if rays is None:
        rays = pixel_rays(width, height, fx, fy, cx, cy)
    dirs = rays.reshape(-1, 3) @ cam_rotation.T
    dirs_img = dirs.reshape(height, width, 3)
    origin = np.asarray(cam_position, float)[None, :]
    origins = np.broadcast_to(origin, dirs.shape)
    depth = ray_floor_ceiling(origins, dirs, floor_holes, ceiling).reshape(height, width)

    # Bounding corners of every solid in the camera frame, to pick the pixels to test.
    corners = []
    if len(solids["box_c"]):
        corners.append(box_corners(solids["box_c"], solids["box_h"], solids["box_yaw"]))
    if len(solids["cyl_r"]):
        r = solids["cyl_r"]
        cc = np.column_stack([solids["cyl_xy"], 0.5 * (solids["cyl_z0"] + solids["cyl_z1"])])
        hh = np.column_stack([r, r, 0.5 * (solids["cyl_z1"] - solids["cyl_z0"])])
        corners.append(box_corners(cc, hh, np.zeros(len(r))))
    if not corners:
        return np.where(depth <= max_depth, depth, np.inf)
    corners = np.concatenate(corners, axis=0)
    corners_cam = (corners - origin[None]) @ cam_rotation  # world -> optical
    n_box = len(solids["box_c"])
    # A solid wholly beyond the maximum depth cannot appear.
    visible = corners_cam[..., 2].min(axis=1) <= max_depth
    for k in np.nonzero(visible)[0]:
        win = _pixel_window(corners_cam[k], fx, fy, cx, cy, width, height, 1e-3)
        if win is None:
            continue
        u0, u1, v0, v1 = win
        sub = dirs_img[v0:v1 + 1, u0:u1 + 1].reshape(-1, 3)
        o = np.broadcast_to(origin, sub.shape)
        if k < n_box:
            yaw = solids["box_yaw"][k]
            rel = origin[0] - solids["box_c"][k]
            if yaw != 0.0:
                cs, sn = np.cos(yaw), np.sin(yaw)
                rel = np.array([cs * rel[0] + sn * rel[1], -sn * rel[0] + cs * rel[1], rel[2]])
                sub = np.column_stack([cs * sub[:, 0] + sn * sub[:, 1],
                                       -sn * sub[:, 0] + cs * sub[:, 1], sub[:, 2]])
            inv = 1.0 / np.where(sub == 0.0, 1.0, sub)
            t = _one_box_from_point(rel, sub, inv, solids["box_h"][k])
        else:
            j = k - n_box
            t = ray_vcylinders(o, sub, solids["cyl_xy"][j:j + 1], solids["cyl_r"][j:j + 1],
                               solids["cyl_z0"][j:j + 1], solids["cyl_z1"][j:j + 1])[:, 0]
        region = depth[v0:v1 + 1, u0:u1 + 1]
        np.minimum(region, t.reshape(region.shape), out=region)
    return np.where(depth <= max_depth, depth, np.inf)
