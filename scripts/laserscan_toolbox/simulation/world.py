"""The simulated world: upright boxes, vertical cylinders, floor holes, walking people, glass.

All heights are above the floor (z = 0); the world frame is ``map``.  A world is
plain data (``to_dict`` / ``from_dict`` round-trip exactly) plus packed numpy
arrays for the ray caster.  ``shop_floor()`` builds the built-in 20 x 15 m scene.

Glass panes (walls, doors) are upright boxes that light passes through: lidars and depth
cameras see what is behind them, ultrasonic sensors (``cast(..., see_glass=True)``) and the
ground truth (``band_scan``, ``occupancy``) see the pane itself.
"""
import math
from dataclasses import dataclass, field, asdict
from typing import List, Tuple

import numpy as np

from . import raycast


@dataclass
class Box:
    """Upright box: centre (x, y, z), full size (sx, sy, sz), yaw around z (rad)."""
    name: str
    center: Tuple[float, float, float]
    size: Tuple[float, float, float]
    yaw: float = 0.0


@dataclass
class Cylinder:
    """Vertical cylinder: axis at (x, y), radius, from z0 to z1."""
    name: str
    xy: Tuple[float, float]
    radius: float
    z0: float
    z1: float


@dataclass
class Hole:
    """Rectangle [x0, x1] x [y0, y1] where the floor is ``depth`` metres lower."""
    name: str
    x0: float
    x1: float
    y0: float
    y1: float
    depth: float


@dataclass
class Person:
    """Vertical cylinder walking back and forth along ``path`` at ``speed`` (m/s).

    At time t (s, relative to the scenario start) the person is at arc length
    ``phase + speed * t`` along the path walked there and back (ping-pong).
    """
    name: str
    path: List[Tuple[float, float]]
    speed: float
    phase: float = 0.0
    radius: float = 0.2
    height: float = 1.75


@dataclass
class World:
    """A world of primitives.  ``bounds`` = (x_min, x_max, y_min, y_max) of the floor."""
    bounds: Tuple[float, float, float, float]
    ceiling: float
    boxes: List[Box] = field(default_factory=list)
    cylinders: List[Cylinder] = field(default_factory=list)
    holes: List[Hole] = field(default_factory=list)
    people: List[Person] = field(default_factory=list)
    glass: List[Box] = field(default_factory=list)

    def __post_init__(self):
        self._pack()

    # ----- serialisation -------------------------------------------------------------
    def to_dict(self):
        """Plain dict of Python floats/lists (YAML-safe, exact round trip)."""
        def clean(v):
            if isinstance(v, (list, tuple)):
                return [clean(x) for x in v]
            if isinstance(v, dict):
                return {k: clean(x) for k, x in v.items()}
            if isinstance(v, (float, np.floating)):
                return float(v)
            if isinstance(v, (int, np.integer)) and not isinstance(v, bool):
                return int(v)
            return v
        return clean({
            "bounds": list(self.bounds), "ceiling": self.ceiling,
            "boxes": [asdict(b) for b in self.boxes],
            "cylinders": [asdict(c) for c in self.cylinders],
            "holes": [asdict(h) for h in self.holes],
            "people": [asdict(p) for p in self.people],
            "glass": [asdict(g) for g in self.glass],
        })

    @classmethod
    def from_dict(cls, d):
        return cls(
            bounds=tuple(float(v) for v in d["bounds"]), ceiling=float(d["ceiling"]),
            boxes=[Box(b["name"], tuple(b["center"]), tuple(b["size"]), float(b.get("yaw", 0.0)))
                   for b in d.get("boxes", [])],
            cylinders=[Cylinder(c["name"], tuple(c["xy"]), c["radius"], c["z0"], c["z1"])
                       for c in d.get("cylinders", [])],
            holes=[Hole(**h) for h in d.get("holes", [])],
            people=[Person(p["name"], [tuple(q) for q in p["path"]], p["speed"], p.get("phase", 0.0),
                           p.get("radius", 0.2), p.get("height", 1.75)) for p in d.get("people", [])],
            glass=[Box(g["name"], tuple(g["center"]), tuple(g["size"]), float(g.get("yaw", 0.0)))
                   for g in d.get("glass", [])],
        )

    # ----- packed arrays ---------------------------------------------------------------
    def _pack(self):
        b = self.boxes
        self.box_c = np.array([x.center for x in b], float).reshape(-1, 3)
        self.box_h = 0.5 * np.array([x.size for x in b], float).reshape(-1, 3)
        self.box_yaw = np.array([x.yaw for x in b], float)
        self.glass_c = np.array([g.center for g in self.glass], float).reshape(-1, 3)
        self.glass_h = 0.5 * np.array([g.size for g in self.glass], float).reshape(-1, 3)
        self.glass_yaw = np.array([g.yaw for g in self.glass], float)
        c = self.cylinders
        self.cyl_xy = np.array([x.xy for x in c], float).reshape(-1, 2)
        self.cyl_r = np.array([x.radius for x in c], float)
        self.cyl_z0 = np.array([x.z0 for x in c], float)
        self.cyl_z1 = np.array([x.z1 for x in c], float)
        self.hole_arr = np.array([[h.x0, h.x1, h.y0, h.y1, h.depth] for h in self.holes],
                                 float).reshape(-1, 5)
        # The obstacles of a 2D band scan as rectangles: boxes, then floor holes (at their
        # rim, whatever the band: z range +-inf), then glass panes.
        ha = self.hole_arr
        hole_c = np.column_stack([(ha[:, 0] + ha[:, 1]) / 2, (ha[:, 2] + ha[:, 3]) / 2])
        hole_h = np.column_stack([(ha[:, 1] - ha[:, 0]) / 2, (ha[:, 3] - ha[:, 2]) / 2])
        self._rect_c = np.vstack([self.box_c[:, :2], hole_c, self.glass_c[:, :2]])
        self._rect_h = np.vstack([self.box_h[:, :2], hole_h, self.glass_h[:, :2]])
        self._rect_yaw = np.concatenate([self.box_yaw, np.zeros(len(ha)), self.glass_yaw])
        inf = np.full(len(ha), np.inf)
        self._rect_z0 = np.concatenate([self.box_c[:, 2] - self.box_h[:, 2], -inf,
                                        self.glass_c[:, 2] - self.glass_h[:, 2]])
        self._rect_z1 = np.concatenate([self.box_c[:, 2] + self.box_h[:, 2], inf,
                                        self.glass_c[:, 2] + self.glass_h[:, 2]])
        self._rect_glass = np.arange(len(self._rect_yaw)) >= len(self.box_yaw) + len(ha)
        self._rect_reach = np.hypot(self._rect_h[:, 0], self._rect_h[:, 1])  # bounding circles
        self.person_r = np.array([p.radius for p in self.people], float)
        self.person_h = np.array([p.height for p in self.people], float)
        # Closed loop only (``hold``): arc length each person lost waiting before the current
        # wait, and when the current wait began (NaN: walking). Zero and NaN: the open loop's people.
        self._held = np.zeros(len(self.people))
        self._hold_since = np.full(len(self.people), math.nan)
        self._paths = []
        for p in self.people:
            pts = np.array(p.path, float)
            seg = np.hypot(*np.diff(pts, axis=0).T)
            self._paths.append((pts, np.concatenate([[0.0], np.cumsum(seg)])))

    # ----- people ----------------------------------------------------------------------
    def _arc(self, times):
        """Arc length (len(times), P) each person has walked by scenario-relative times: phase +
        speed * t, less what waiting (``hold``) took; unfolded (the ping-pong is ``_at_arc``'s)."""
        times = np.atleast_1d(np.asarray(times, float))
        out = np.zeros((len(times), len(self.people)))
        for j, p in enumerate(self.people):
            arc = p.phase + p.speed * times
            since = self._hold_since[j]
            if not math.isnan(since):
                arc = arc - (self._held[j] + p.speed * np.maximum(times - since, 0.0))
            elif self._held[j]:
                arc = arc - self._held[j]
            out[:, j] = arc
        return out

    def _at_arc(self, arcs):
        """Positions (..., P, 2) at unfolded arc lengths (..., P), walked there and back."""
        out = np.zeros(arcs.shape + (2,))
        for j, (pts, cum) in enumerate(self._paths):
            length = cum[-1]
            s = np.mod(arcs[..., j], 2.0 * length)
            s = np.where(s > length, 2.0 * length - s, s)  # walk back along the path
            out[..., j, 0] = np.interp(s, cum, pts[:, 0])
            out[..., j, 1] = np.interp(s, cum, pts[:, 1])
        return out

    def people_xy(self, times):
        """Positions of the people at scenario-relative times: (len(times), P, 2)."""
        return self._at_arc(self._arc(times))

    def people_ahead(self, rel_time, distances):
        """Where each person will be after walking ``distances`` (D,) m more from where they are
        at ``rel_time``: (D, P, 2)."""
        arc = self._arc([rel_time])[0]
        return self._at_arc(arc[None, :] + np.asarray(distances, float)[:, None])

    def hold(self, rel_time, waiting):
        """Closed loop: from ``rel_time`` on, person j stands where they are while waiting[j], and
        walks on from there once it is false (a pedestrian giving way).  Times before the last
        change are not kept apart: ask for positions from ``rel_time`` on."""
        for j, (p, wait) in enumerate(zip(self.people, waiting)):
            since = self._hold_since[j]
            if wait and math.isnan(since):
                self._hold_since[j] = rel_time
            elif not wait and not math.isnan(since):
                self._held[j] += p.speed * max(rel_time - since, 0.0)
                self._hold_since[j] = math.nan

    def waiting(self):
        """Whether each person is standing, giving way (``hold``)."""
        return ~np.isnan(self._hold_since)

    def solids(self, rel_time, static_only=False):
        """Arrays of all solids (boxes, static cylinders, people at ``rel_time``)."""
        xy, r, z0, z1 = self.cyl_xy, self.cyl_r, self.cyl_z0, self.cyl_z1
        if self.people and not static_only:
            pxy = self.people_xy([rel_time])[0]
            xy = np.concatenate([xy, pxy])
            r = np.concatenate([r, self.person_r])
            z0 = np.concatenate([z0, np.zeros(len(self.people))])
            z1 = np.concatenate([z1, self.person_h])
        return {"box_c": self.box_c, "box_h": self.box_h, "box_yaw": self.box_yaw,
                "cyl_xy": xy, "cyl_r": r, "cyl_z0": z0, "cyl_z1": z1}

    # ----- ray casting -----------------------------------------------------------------
    def cast(self, origins, directions, rel_times, see_glass=False):
        """Distance along each ray (N,) to the first surface, +inf if none.

        rel_times: scalar or (N,) scenario-relative times at which each ray sees
        the people (a swept lidar casts every beam at its own time).  see_glass:
        glass panes stop the ray (sound); otherwise it passes through them (light).
        """
        origins = np.asarray(origins, float)
        directions = np.asarray(directions, float)
        t = raycast.ray_floor_ceiling(origins, directions, self.hole_arr, self.ceiling)
        boxes = np.ones(len(self.boxes), bool)
        cyls = np.ones(len(self.cylinders), bool)
        z = origins[:, 2]
        if len(origins) and np.all(directions[:, 2] == 0.0) and np.all(z == z[0]):
            # Level rays at one height (a 2D lidar) can only meet solids spanning that height.
            boxes = np.abs(self.box_c[:, 2] - z[0]) <= self.box_h[:, 2]
            cyls = (self.cyl_z0 <= z[0]) & (self.cyl_z1 >= z[0])
        if boxes.any():
            t = np.minimum(t, raycast.ray_boxes(origins, directions, self.box_c[boxes], self.box_h[boxes],
                                                self.box_yaw[boxes]).min(axis=1))
        if cyls.any():
            t = np.minimum(t, raycast.ray_vcylinders(origins, directions, self.cyl_xy[cyls], self.cyl_r[cyls],
                                                     self.cyl_z0[cyls], self.cyl_z1[cyls]).min(axis=1))
        if self.people:
            rel_times = np.broadcast_to(np.asarray(rel_times, float), (len(origins),))
            uniq, inv = np.unique(rel_times, return_inverse=True)
            pxy = self.people_xy(uniq)[inv]  # (N, P, 2)
            tp = raycast.ray_vcylinders(origins, directions, pxy, self.person_r,
                                        np.zeros(len(self.people)), self.person_h)
            t = np.minimum(t, tp.min(axis=1))
        if see_glass and len(self.glass):
            t = np.minimum(t, raycast.ray_boxes(origins, directions, self.glass_c, self.glass_h,
                                                self.glass_yaw).min(axis=1))
        return t

    def band_scan(self, origin_xy, angles, z_min, z_max, rel_time, max_range=np.inf,
                  static_only=False, glass=True):
        """2D ranges (len(angles),) from ``origin_xy`` along world ``angles`` to the
        closest obstacle whose height overlaps [z_min, z_max]; holes count at their
        rim; glass panes count unless ``glass`` is False; +inf where nothing within
        ``max_range``."""
        with_glass, without_glass = self.band_scans(origin_xy, angles, z_min, z_max, rel_time,
                                                    max_range, static_only)
        t = with_glass if glass else without_glass
        return np.where(t <= max_range, t, np.inf)

    def band_scans(self, origin_xy, angles, z_min, z_max, rel_time, max_range=np.inf,
                   static_only=False):
        """``band_scan`` with and without the glass panes in one pass: (with, without).

        Not clipped to ``max_range``: a range within it is exact, a larger one may be
        too large (obstacles that cannot come within ``max_range`` are left out).
        """
        angles = np.asarray(angles, float)
        o = np.asarray(origin_xy, float)[:2]
        d = np.column_stack([np.cos(angles), np.sin(angles)])
        without_glass = np.full(len(angles), np.inf)
        t_glass = np.full(len(angles), np.inf)
        # Only the ray / obstacle pairs that can meet are cast: obstacles in the band,
        # within max_range, beams in the sector under which each is seen.
        band = np.flatnonzero((self._rect_z1 >= z_min) & (self._rect_z0 <= z_max))
        rays, k = raycast.pairs_in_reach(o, angles, self._rect_c[band], self._rect_reach[band],
                                         max_range)
        shapes = band[k]
        t = raycast.ray_rects_from_point(o, d, self._rect_c, self._rect_h, self._rect_yaw,
                                         pairs=(rays, shapes))
        pane = self._rect_glass[shapes]
        np.minimum.at(without_glass, rays[~pane], t[~pane])
        np.minimum.at(t_glass, rays[pane], t[pane])
        solids = self.solids(rel_time, static_only=static_only)
        band = np.flatnonzero((solids["cyl_z1"] >= z_min) & (solids["cyl_z0"] <= z_max))
        rays, k = raycast.pairs_in_reach(o, angles, solids["cyl_xy"][band], solids["cyl_r"][band],
                                         max_range)
        t = raycast.ray_circles_from_point(o, d, solids["cyl_xy"], solids["cyl_r"],
                                           pairs=(rays, band[k]))
        np.minimum.at(without_glass, rays, t)
        return np.minimum(without_glass, t_glass), without_glass

    def occupancy(self, resolution, z_min, z_max, rel_time=0.0, static_only=True, margin=0.5):
        """Cells whose area meets an obstacle overlapping [z_min, z_max] (holes: their
        whole area).  Returns (grid[row=y, col=x] bool, (x0, y0) of cell (0, 0)'s corner)."""
        x0, x1, y0, y1 = self.bounds
        ox, oy = x0 - margin, y0 - margin
        nx = int(math.ceil((x1 - x0 + 2 * margin) / resolution))
        ny = int(math.ceil((y1 - y0 + 2 * margin) / resolution))
        grid = np.zeros((ny, nx), bool)
        step = resolution / 3.0  # dense enough that a 2 cm leg lands in its cells

        def mark(px, py):
            ix = np.floor((px - ox) / resolution).astype(int)
            iy = np.floor((py - oy) / resolution).astype(int)
            ok = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
            grid[iy[ok], ix[ok]] = True

        def rect_samples(hx, hy):
            gx = np.linspace(-hx, hx, max(2, int(math.ceil(2 * hx / step)) + 1))
            gy = np.linspace(-hy, hy, max(2, int(math.ceil(2 * hy / step)) + 1))
            return np.meshgrid(gx, gy)

        for b in self.boxes + self.glass:
            if b.center[2] + b.size[2] / 2 < z_min or b.center[2] - b.size[2] / 2 > z_max:
                continue
            lx, ly = rect_samples(b.size[0] / 2, b.size[1] / 2)
            cs, sn = math.cos(b.yaw), math.sin(b.yaw)
            mark(b.center[0] + cs * lx - sn * ly, b.center[1] + sn * lx + cs * ly)
        for h in self.holes:
            lx, ly = rect_samples((h.x1 - h.x0) / 2, (h.y1 - h.y0) / 2)
            mark((h.x0 + h.x1) / 2 + lx, (h.y0 + h.y1) / 2 + ly)
        solids = self.solids(rel_time, static_only=static_only)
        for (cx, cy), r, z0, z1 in zip(solids["cyl_xy"], solids["cyl_r"], solids["cyl_z0"],
                                       solids["cyl_z1"]):
            if z1 < z_min or z0 > z_max:
                continue
            lx, ly = rect_samples(r, r)
            inside = lx * lx + ly * ly <= r * r
            ang = np.linspace(0, 2 * math.pi, max(8, int(2 * math.pi * r / step) + 1))
            mark(np.concatenate([cx + lx[inside], cx + r * np.cos(ang)]),
                 np.concatenate([cy + ly[inside], cy + r * np.sin(ang)]))
        return grid, (ox, oy)


# ----- the built-in shop floor ------------------------------------------------------------
TABLE_TOP = 0.75  # m, top surface of every table


def _table(name, x, y, yaw=0.0, length=1.2, width=0.8, leg=0.04):
    """Table top 0.04 m thick with its top at 0.75 m, on four thin square legs."""
    parts = [Box(name + "/top", (x, y, TABLE_TOP - 0.02), (length, width, 0.04), yaw)]
    cs, sn = math.cos(yaw), math.sin(yaw)
    for sx in (-1, 1):
        for sy in (-1, 1):
            lx, ly = sx * (length / 2 - 0.06), sy * (width / 2 - 0.06)
            parts.append(Box(f"{name}/leg{len(parts)}", (x + cs * lx - sn * ly, y + sn * lx + cs * ly,
                                                          (TABLE_TOP - 0.04) / 2),
                             (leg, leg, TABLE_TOP - 0.04), yaw))
    return parts


def _chair(name, x, y, yaw=0.0):
    """Seat at 0.45 m, thin legs, a back rest up to 0.9 m on the side opposite ``yaw``."""
    parts = [Box(name + "/seat", (x, y, 0.44), (0.45, 0.45, 0.03), yaw)]
    cs, sn = math.cos(yaw), math.sin(yaw)

    def at(lx, ly):
        return x + cs * lx - sn * ly, y + sn * lx + cs * ly
    for sx in (-1, 1):
        for sy in (-1, 1):
            px, py = at(sx * 0.2, sy * 0.2)
            parts.append(Box(f"{name}/leg{len(parts)}", (px, py, 0.215), (0.025, 0.025, 0.43), yaw))
    bx, by = at(-0.21, 0.0)
    parts.append(Box(name + "/back", (bx, by, 0.68), (0.03, 0.45, 0.45), yaw))
    return parts


def _shelf(name, x0, x1, y_back, facing):
    """Shelf unit along x from x0 to x1, back at ``y_back``, open towards ``facing``
    (+1: +y, -1: -y).  A 0.25 m high, 0.3 m deep plinth stands on the floor (what a
    lidar at 0.2 m sees); the boards are 0.6 m deep, so they overhang the plinth by
    0.3 m at 0.5, 0.95 and 1.4 m; two 3 cm uprights carry them."""
    xc, length = (x0 + x1) / 2, x1 - x0

    def yc(depth):
        return y_back + facing * depth / 2
    parts = [Box(name + "/plinth", (xc, yc(0.3), 0.125), (length, 0.3, 0.25))]
    for k, top in enumerate((0.5, 0.95, 1.4)):
        parts.append(Box(f"{name}/board{k}", (xc, yc(0.6), top - 0.015), (length, 0.6, 0.03)))
    for k, ux in enumerate((x0 + 0.015, x1 - 0.015)):
        parts.append(Box(f"{name}/upright{k}", (ux, yc(0.6), 0.9), (0.03, 0.6, 1.8)))
    return parts


def shop_floor():
    """The built-in shop floor: 20 x 15 m, walls 3 m high under a 3 m ceiling,
    four tables (tops at 0.75 m), chairs, three shelf units with overhanging
    boards, a pillar, a low pallet (below lidar height), a 0.3 m deep loading pit,
    four people walking, a glass wall along the aisle (in front of shelf1) and a
    closed glass door ahead of the route's far end.  The robot's route (see
    ``robot.default_route``) runs along the aisle at y = 7.5 m."""
    X, Y, H, T = 20.0, 15.0, 3.0, 0.2
    boxes = [
        Box("wall_south", (X / 2, -T / 2, H / 2), (X + 2 * T, T, H)),
        Box("wall_north", (X / 2, Y + T / 2, H / 2), (X + 2 * T, T, H)),
        Box("wall_west", (-T / 2, Y / 2, H / 2), (T, Y, H)),
        Box("wall_east", (X + T / 2, Y / 2, H / 2), (T, Y, H)),
        Box("pillar", (8.0, 11.5, H / 2), (0.4, 0.4, H)),
        Box("pallet", (12.5, 11.0, 0.075), (1.2, 0.8, 0.15)),
        Box("crate", (18.5, 12.5, 0.4), (0.8, 0.8, 0.8), 0.4),
    ]
    boxes += _table("table1", 6.0, 6.3)
    boxes += _table("table2", 9.0, 8.8)
    boxes += _table("table3", 11.5, 6.1, yaw=0.3)
    boxes += _table("table4", 4.0, 11.0, yaw=math.pi / 2)
    boxes += _chair("chair1", 6.0, 5.45, yaw=math.pi / 2)
    boxes += _chair("chair2", 9.0, 9.65, yaw=-math.pi / 2)
    boxes += _chair("chair3", 11.2, 5.2, yaw=0.3 + math.pi / 2)
    boxes += _chair("chair4", 4.9, 11.0, yaw=math.pi)
    boxes += _shelf("shelf1", 7.0, 9.5, 4.3, +1)
    boxes += _shelf("shelf2", 2.0, 6.0, Y, -1)
    boxes += _shelf("shelf3", 13.8, 16.2, 9.75, -1)
    cylinders = [Cylinder("bin", (14.0, 2.0), 0.25, 0.0, 0.9),
                 Cylinder("post", (2.0, 13.0), 0.06, 0.0, 1.1)]
    holes = [Hole("loading_pit", 16.2, 18.4, 3.4, 5.6, 0.3)]
    people = [
        Person("walker_aisle", [(2.0, 10.4), (13.0, 10.4)], 0.9, phase=3.0),
        Person("crosser", [(10.2, 1.0), (10.2, 13.5)], 1.0, phase=8.0),
        Person("picker", [(17.3, 7.0), (17.3, 13.0)], 0.6, phase=1.0, radius=0.22),
        Person("south", [(3.0, 2.2), (13.0, 2.2), (13.0, 3.2)], 0.8, phase=5.0),
    ]
    # 2 cm panes, 2.2 m high, that lidars and depth cameras see through.
    glass = [Box("glass_wall", (8.35, 6.45, 1.1), (2.9, 0.02, 2.2)),
             Box("glass_door", (15.4, 4.55, 1.1), (0.02, 1.1, 2.2))]
    return World(bounds=(0.0, X, 0.0, Y), ceiling=H, boxes=boxes, cylinders=cylinders,
                 holes=holes, people=people, glass=glass)
