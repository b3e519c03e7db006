"""The scenario in closed loop (ROS-free core): the robot driven by velocity commands in simulated
time, sensed from where it is, checked for collisions, recorded.

The world, the sensor models and the ray casting are the scenario's (``scenario.Scenario``); what
is new here is that the trajectory is not known ahead: an omnidirectional base (``OmniBase``)
integrates the commands with velocity and acceleration limits, the odometry is integrated step by
step (``robot.WheelOdometry``), and every sensor is measured from the current pose.

Time runs in fixed steps of integer nanoseconds (1 / odom_rate), so that a run depends only on its
configuration, its seed and the commands it is given, never on the machine's load::

    sim = ClosedLoopSim(ClosedLoopConfig(route="table", seed=0))
    while not sim.done:
        frame = sim.sense()               # what is published at sim.t (tf, odometry, sensors)
        if frame.control:                 # a control step t_k: the navigator answers it
            sim.command(vx, vy, w)        # base_link, held until the next control step
        sim.advance()                     # integrate one step, check collisions
    record = sim.record()                 # RunRecord: reached, collisions, ..., trajectory

The arm is held stowed over the body (a robot drives with its arm stowed), so the robot's shape
is the body box (0.74 x 0.48 x 0.60 m) plus the arm's links up to 0.90 m.  Collisions: that shape
against every solid (boxes, glass panes, cylinders, people where they are, floor holes) whose
height range overlaps a part's; an obstacle that no lidar's plane cuts (a table top, a shelf
board, a chair seat, the pallet, a hole) is a 3D obstacle, counted apart.
"""
import json
import math
import time
from dataclasses import dataclass, field, asdict
from typing import List, Optional, Tuple

import numpy as np

from . import raycast
from .robot import Arm, WheelOdometry, paper_robot
from .scenario import DEFAULT_START_TIME, Scenario
from .world import World, _table, shop_floor

#: Routes of the closed loop (in ``closed_loop_world``): start and goal (x, y) in map; the robot
#: starts facing the goal.  ``shop``: the paper's task, A to B past chairs and tables, along a shelf
#: whose boards overhang its plinth, among the walking people.  ``table``: the straight path runs
#: under table2's top between its legs (2.28 m apart: the base 0.48 m wide and 0.60 m high fits
#: under the 0.71 m top, the stowed arm up to 0.90 m does not).
ROUTES = {
    "shop": ((3.6, 5.0), (14.2, 5.6)),
    "table": ((6.3, 8.8), (11.8, 8.8)),
}

#: The stowed arm (shoulder, elbow at pi: over the body; gripper lifted 0.20 m), held still.
STOWED = (math.pi, math.pi, 0.20)

NS = 1_000_000_000


@dataclass
class ClosedLoopConfig:
    route: str = "shop"
    seed: int = 0
    camera_points: Optional[int] = None  # pixels per depth image (default about 52,000)
    control_rate: float = 10.0           # Hz, the navigator's steps t_k = k / control_rate
    sensor_rate: float = 10.0            # Hz, every lidar, camera and sonar (a multiple of the step grid)
    odom_rate: float = 50.0              # Hz, the simulation step (tf, odometry, collisions)
    goal_delay_s: float = 2.0            # s of warm-up before the goal is given
    timeout_s: float = 90.0              # s after the goal without reaching it: the run ends
    goal_tolerance_m: float = 0.25       # m, base_link within this of the goal: reached
    start: Optional[Tuple[float, float]] = None  # (x, y) in map instead of the route's
    goal: Optional[Tuple[float, float]] = None

    def endpoints(self):
        """(start, goal) (x, y) in map: the route's unless given."""
        start, goal = ROUTES[self.route]
        return tuple(self.start or start), tuple(self.goal or goal)

    def validate(self):
        """Raises ValueError naming the field and the reason."""
        if self.route not in ROUTES:
            raise ValueError(f"route: {self.route!r} is not one of {', '.join(sorted(ROUTES))}")
        if self.camera_points is not None and not 100 <= self.camera_points <= 2_000_000:
            raise ValueError(f"camera_points: {self.camera_points} is not within 100..2000000")
        if not 1.0 <= self.odom_rate <= 1000.0:
            raise ValueError(f"odom_rate: {self.odom_rate} Hz is not within 1..1000")
        self.steps_per("control_rate")
        self.steps_per("sensor_rate")
        if not self.goal_delay_s >= 0:
            raise ValueError(f"goal_delay_s: {self.goal_delay_s} is negative")
        for name in ("timeout_s", "goal_tolerance_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name}: {getattr(self, name)} is not positive")

    @property
    def step_ns(self):
        """The simulation step (ns): 1 / odom_rate."""
        return int(round(NS / self.odom_rate))

    def steps_per(self, name):
        """Simulation steps per period of the rate ``name`` (control_rate, sensor_rate); a
        ValueError unless it is a whole number (the rate's times must be on the step grid)."""
        rate = getattr(self, name)
        steps = NS / rate / self.step_ns if rate > 0 else 0.0
        if round(steps) < 1 or abs(steps - round(steps)) > 1e-9:
            raise ValueError(f"{name}: {rate} Hz is not 1 / (a whole number of simulation steps of "
                             f"{self.step_ns / 1e6:g} ms)")
        return int(round(steps))


@dataclass
class RunRecord:
    """One closed-loop run (what the navigation experiment reads, JSON via to_json/from_json).

    Times are simulated seconds.  trajectory: [t, x, y, yaw] at every control step (t relative
    to the start, map frame).  collided_with: one entry per contact onset {name, kind, t,
    robot_speed}, kind "3d" (no lidar plane cuts the obstacle), "glass" or "2d".  people_waited_s:
    per person who gave way to the robot, the simulated seconds they stood."""
    route: str
    seed: int
    points_per_camera: int
    reached: bool = False
    collisions: int = 0
    collisions_3d: int = 0
    time_to_goal_s: Optional[float] = None
    path_length_m: float = 0.0
    min_clearance_m: float = math.inf
    timed_out: bool = False
    navigator_state: Optional[str] = None  # "reached" | "blocked": the navigator ended the run
    simulated_s: float = 0.0             # clock advanced from the start to the end (warm-up included)
    goal_delay_s: float = 0.0
    lockstep_timeouts: int = 0           # control steps the navigator did not answer in time
    wall_s: float = 0.0
    collided_with: List[dict] = field(default_factory=list)
    people_waited_s: dict = field(default_factory=dict)
    trajectory: List[Tuple[float, float, float, float]] = field(default_factory=list)

    def to_json(self):
        d = asdict(self)
        d["min_clearance_m"] = d["min_clearance_m"] if math.isfinite(d["min_clearance_m"]) else None
        return json.dumps(d, indent=1)

    @classmethod
    def from_json(cls, text):
        d = json.loads(text)
        if d.get("min_clearance_m") is None:
            d["min_clearance_m"] = math.inf
        d["trajectory"] = [tuple(p) for p in d.get("trajectory", [])]
        return cls(**d)


# ----- kinematics ---------------------------------------------------------------------------------
class OmniBase:
    """An omnidirectional base: commands (vx, vy, w) in base_link, speed |(vx, vy)| <= v_max and
    |w| <= w_max, accelerations (the change of the velocity vector) <= acc_v and acc_w."""

    def __init__(self, robot, x, y, yaw):
        self.v_max, self.w_max, self.acc_v, self.acc_w = robot.v_max, robot.w_max, robot.acc_v, robot.acc_w
        self.x, self.y, self.yaw = float(x), float(y), float(yaw)
        self.vx = self.vy = self.w = 0.0

    def step(self, cmd, dt):
        """Move for dt s towards the command (vx, vy, w); returns the body-frame motion of the
        step (forward, lateral, rotation) in the frame at its start."""
        vx, vy, w = (float(c) for c in cmd)
        speed = math.hypot(vx, vy)
        if speed > self.v_max:
            vx, vy = vx * self.v_max / speed, vy * self.v_max / speed
        w = max(-self.w_max, min(self.w_max, w))
        dvx, dvy = vx - self.vx, vy - self.vy
        dv = math.hypot(dvx, dvy)
        if dv > self.acc_v * dt:
            dvx, dvy = dvx * self.acc_v * dt / dv, dvy * self.acc_v * dt / dv
        self.vx += dvx
        self.vy += dvy
        self.w += max(-self.acc_w * dt, min(self.acc_w * dt, w - self.w))
        # The body velocity is held over the step; its direction turns with the midpoint heading.
        dth = self.w * dt
        c, s = math.cos(0.5 * dth), math.sin(0.5 * dth)
        fwd, lat = (c * self.vx - s * self.vy) * dt, (s * self.vx + c * self.vy) * dt
        cy, sy = math.cos(self.yaw), math.sin(self.yaw)
        self.x += cy * fwd - sy * lat
        self.y += sy * fwd + cy * lat
        self.yaw = (self.yaw + dth + math.pi) % (2 * math.pi) - math.pi
        return fwd, lat, dth


# ----- collisions and clearance -------------------------------------------------------------------
def _rect_corners(c, h, yaw):
    """Corners (..., 4, 2) of rectangles centre c (..., 2), half extents h (..., 2), yaw (...)."""
    sx = np.array([-1.0, 1.0, 1.0, -1.0])
    sy = np.array([-1.0, -1.0, 1.0, 1.0])
    lx, ly = sx * h[..., :1], sy * h[..., 1:2]
    cs, sn = np.cos(yaw)[..., None], np.sin(yaw)[..., None]
    return np.stack([c[..., :1] + cs * lx - sn * ly, c[..., 1:2] + sn * lx + cs * ly], -1)


def _point_segment_distance(p, a, b):
    """Distance from points p (..., 2) to segments a-b (..., 2) (broadcast)."""
    ab = b - a
    u = np.clip(np.sum((p - a) * ab, -1) / np.maximum(np.sum(ab * ab, -1), 1e-18), 0.0, 1.0)
    return np.linalg.norm(p - (a + u[..., None] * ab), axis=-1)


def rect_rect_distance(c1, h1, yaw1, c2, h2, yaw2):
    """Distance (broadcast shape) between oriented rectangles, 0 where they overlap or touch.

    Overlap by separating axes (the four edge normals); separated rectangles are as far apart
    as the closest vertex of one from an edge of the other."""
    p1, p2 = _rect_corners(c1, h1, yaw1), _rect_corners(c2, h2, yaw2)
    p1, p2 = np.broadcast_arrays(p1, p2)
    separated = np.zeros(p1.shape[:-2], bool)
    for yaw in (yaw1, yaw2):
        yaw = np.broadcast_to(yaw, separated.shape)
        for axis in (np.stack([np.cos(yaw), np.sin(yaw)], -1), np.stack([-np.sin(yaw), np.cos(yaw)], -1)):
            a = np.sum(p1 * axis[..., None, :], -1)
            b = np.sum(p2 * axis[..., None, :], -1)
            separated |= (a.max(-1) < b.min(-1)) | (b.max(-1) < a.min(-1))
    d = np.full(separated.shape, np.inf)
    for pa, pb in ((p1, p2), (p2, p1)):
        seg_a, seg_b = pb, np.roll(pb, -1, axis=-2)
        dist = _point_segment_distance(pa[..., :, None, :], seg_a[..., None, :, :], seg_b[..., None, :, :])
        d = np.minimum(d, dist.min(axis=(-1, -2)))
    return np.where(separated, d, 0.0)


def rect_circle_distance(c, h, yaw, centre, radius):
    """Distance (broadcast shape) between oriented rectangles and circles, 0 where they overlap."""
    rel = centre - c
    cs, sn = np.cos(yaw), np.sin(yaw)
    lx = np.abs(cs * rel[..., 0] + sn * rel[..., 1]) - h[..., 0]
    ly = np.abs(-sn * rel[..., 0] + cs * rel[..., 1]) - h[..., 1]
    return np.maximum(np.hypot(np.maximum(lx, 0.0), np.maximum(ly, 0.0)) - radius, 0.0)


#: People give way to the robot (closed loop): a person stops while walking on would bring them
#: closer than YIELD_CLEARANCE m to the robot's shape within the next YIELD_AHEAD m, and walks on
#: once it would not (the people of the paper's experiment are people: they do not walk into a
#: robot, as the pedestrian models of social-navigation simulators do not): half a second's walk
#: ahead, so a person stops 0.3 - 0.8 m from the robot.
YIELD_AHEAD = 0.5
YIELD_CLEARANCE = 0.3
_YIELD_SAMPLES = np.linspace(0.05, YIELD_AHEAD, 10)  # every 5 cm of the way ahead


def people_giving_way(world, parts, rel):
    """Whether each person must wait at ``rel`` for the robot's parts (map; as
    ``ClosedLoopSim.parts``): a sample of their next YIELD_AHEAD m of walking comes closer than
    YIELD_CLEARANCE to the robot, and closer than they are now (a person walking away from the
    robot, or past it, walks on).  (P,) bool."""
    if not world.people:
        return np.zeros(0, bool)
    pc, ph, pyaw = parts
    now = world.people_ahead(rel, [0.0])          # (1, P, 2)
    ahead = world.people_ahead(rel, _YIELD_SAMPLES)  # (D, P, 2)

    def gap(points):  # (n, P): distance of each person's disc from the closest robot part
        return rect_circle_distance(pc[:, None, None, :2], ph[:, None, None, :2], pyaw[:, None, None],
                                    points[None], world.person_r[None, None, :]).min(axis=0)
    closest = gap(ahead).min(axis=0)
    return (closest < YIELD_CLEARANCE) & (closest < gap(now)[0])


class CollisionMonitor:
    """The robot's shape against the world's solids: distances per obstacle, contact onsets,
    the minimum clearance.  Obstacles (names and kinds fixed at construction): boxes and glass
    panes, static cylinders, the people, floor holes (the footprint over a hole: the robot
    drops into it)."""

    def __init__(self, world, robot):
        self.world = world
        lidar_z = [L.xyz[2] for L in robot.lidars]

        def kind(z0, z1):
            return "2d" if any(z0 <= z <= z1 for z in lidar_z) else "3d"
        rects = [(b.name, b.center, b.size, b.yaw) for b in world.boxes]
        self.glass_from = len(rects)
        rects += [(g.name, g.center, g.size, g.yaw) for g in world.glass]
        rects += [(h.name, ((h.x0 + h.x1) / 2, (h.y0 + h.y1) / 2, -h.depth / 2),
                   (h.x1 - h.x0, h.y1 - h.y0, h.depth), 0.0) for h in world.holes]
        self.hole_from = len(rects) - len(world.holes)
        self.rect_c = np.array([r[1][:2] for r in rects], float).reshape(-1, 2)
        self.rect_h = 0.5 * np.array([r[2][:2] for r in rects], float).reshape(-1, 2)
        self.rect_yaw = np.array([r[3] for r in rects], float)
        self.rect_reach = np.hypot(self.rect_h[:, 0], self.rect_h[:, 1])
        self.rect_z0 = np.array([r[1][2] - r[2][2] / 2 for r in rects], float)
        self.rect_z1 = np.array([r[1][2] + r[2][2] / 2 for r in rects], float)
        self.rect_z1[self.hole_from:] = 0.0  # a hole reaches up to the floor, where the base stands
        names = [r[0] for r in rects]
        kinds = [kind(z0, z1) for z0, z1 in zip(self.rect_z0[:self.glass_from],
                                                self.rect_z1[:self.glass_from])]
        kinds += ["glass"] * len(world.glass) + ["3d"] * len(world.holes)
        names += [c.name for c in world.cylinders] + [p.name for p in world.people]
        kinds += [kind(c.z0, c.z1) for c in world.cylinders] + [kind(0.0, p.height) for p in world.people]
        self.names, self.kinds = names, kinds
        self.touching = np.zeros(len(names), bool)
        self.onsets = []  # (name, kind, t)

    #: Obstacles farther than this (m, a lower bound from bounding circles) are not measured
    #: exactly: their distance is given as that bound (exact clearances below it, cheap steps).
    NEAR = 2.0

    def distances(self, parts, rel):
        """Distance (m, 2D, >= 0) of every obstacle from the closest robot part that overlaps it
        in height (+inf: none does; a lower bound beyond NEAR).  parts: (centres (K, 3), half
        (K, 3), yaw (K,)) in map."""
        pc, ph, pyaw = parts
        p_z0, p_z1 = pc[:, 2] - ph[:, 2], pc[:, 2] + ph[:, 2]
        zr = (p_z0[:, None] <= self.rect_z1[None]) & (p_z1[:, None] >= self.rect_z0[None])
        bound = (np.linalg.norm(pc[:, None, :2] - self.rect_c[None], axis=-1)
                 - np.hypot(ph[:, 0], ph[:, 1])[:, None] - self.rect_reach[None])
        d_rect = np.maximum(bound, 0.0)
        near = np.flatnonzero((np.where(zr, bound, np.inf) < self.NEAR).any(axis=0))
        d_rect[:, near] = rect_rect_distance(pc[:, None, :2], ph[:, None, :2], pyaw[:, None],
                                             self.rect_c[None, near], self.rect_h[None, near],
                                             self.rect_yaw[None, near])
        d_rect = np.where(zr, d_rect, np.inf).min(axis=0)
        solids = self.world.solids(rel)
        zc = (p_z0[:, None] <= solids["cyl_z1"][None]) & (p_z1[:, None] >= solids["cyl_z0"][None])
        d_cyl = rect_circle_distance(pc[:, None, :2], ph[:, None, :2], pyaw[:, None],
                                     solids["cyl_xy"][None], solids["cyl_r"][None])
        d_cyl = np.where(zc, d_cyl, np.inf).min(axis=0)
        return np.concatenate([d_rect, d_cyl])

    def check(self, parts, rel, speed=0.0):
        """Record the contacts that begin at relative time rel (with the robot's speed then, m/s:
        0 when a person walked into a robot standing still); returns the clearance (m, the
        distance to the closest obstacle, 0 in contact)."""
        d = self.distances(parts, rel)
        touching = d <= 0.0
        self.onsets += [(self.names[i], self.kinds[i], float(rel), float(speed))
                        for i in np.flatnonzero(touching & ~self.touching)]
        self.touching = touching
        return float(d.min())


# ----- the closed loop ----------------------------------------------------------------------------
@dataclass
class Frame:
    """What the simulator publishes at one step (ROS time ``t_ns``; ``rel`` s since the start).

    odom: (x, y, yaw) of base_link in odom and its measured (vx, vy, w); truth: (x, y, yaw) in
    map and the true (vx, vy, w).  Sensor readings only at sensor times (else empty): lidar ranges
    (instantaneous scans), sonar readings, depth frames (metres, 0 = no depth).  goal: (x, y, yaw)
    in map when the goal is given at this step."""
    t_ns: int
    rel: float
    control: bool
    odom: Tuple[float, float, float]
    odom_twist: Tuple[float, float, float]
    truth: Tuple[float, float, float]
    truth_twist: Tuple[float, float, float]
    lidars: dict = field(default_factory=dict)
    sonars: dict = field(default_factory=dict)
    depth: dict = field(default_factory=dict)
    goal: Optional[Tuple[float, float, float]] = None

    @property
    def t(self):
        return self.t_ns / NS


def closed_loop_robot(config):
    """The paper's robot for the closed loop: every sensor at sensor_rate on the step grid (phase
    0), the arm held stowed."""
    robot = paper_robot(config.camera_points)
    for s in robot.lidars + robot.cameras + robot.sonars:
        s.rate, s.phase = config.sensor_rate, 0.0
    robot.arm = Arm(keyframes=[(0.0,) + STOWED, (robot.arm.period,) + STOWED])
    return robot


def closed_loop_world():
    """The shop floor of the closed loop: the bag's (``world.shop_floor``) with table2 a large table
    (1.2 m along the aisle, 2.4 m across: legs 2.28 m apart, its centre at y = 9.0, 0.2 m north of
    the table route) and chair2 gone.  A navigator that sees only the legs finds the way between
    them open: MRPT's holonomic trajectories take the robot as its circumscribed circle (0.44 m),
    and with legs 1.24 m or 1.64 m apart they turned it round the table, not showing what it
    misses; the top covers y = 7.8 - 10.2 m, which leaves 1.35 m south of it to the glass wall
    (y = 6.45 m) and keeps the legs clear of the walker's aisle (y = 10.4 m)."""
    w = shop_floor()
    boxes = [b for b in w.boxes if not b.name.startswith(("table2/", "chair2/"))]
    boxes += _table("table2", 9.0, 9.0, width=2.4)
    return World(bounds=w.bounds, ceiling=w.ceiling, boxes=boxes, cylinders=w.cylinders, holes=w.holes,
                 people=w.people, glass=w.glass)


class ClosedLoopSim:
    def __init__(self, config):
        config.validate()
        self.config = config
        self.robot = closed_loop_robot(config)
        start, goal = config.endpoints()
        yaw0 = math.atan2(goal[1] - start[1], goal[0] - start[0])
        # The scenario gives the world, the sensor models and the messages; its own route is unused.
        self.scenario = Scenario(closed_loop_world(), self.robot, [start, goal], duration=1.0,
                                 seed=config.seed)
        self.world = self.scenario.world
        self.goal = (float(goal[0]), float(goal[1]), yaw0)
        self.base = OmniBase(self.robot, start[0], start[1], yaw0)
        self.rng = np.random.default_rng(config.seed)
        self.odometry = WheelOdometry(self.robot.odom, self.rng)
        self.odom_twist = (0.0, 0.0, 0.0)
        self.monitor = CollisionMonitor(self.world, self.robot)
        self.step_ns = config.step_ns
        self.control_every = config.steps_per("control_rate")
        self.sensor_every = config.steps_per("sensor_rate")
        self.goal_step = int(math.ceil(config.goal_delay_s * NS / self.step_ns / self.control_every)) \
            * self.control_every
        self.start_ns = int(round(DEFAULT_START_TIME * NS))
        self.k = 0
        self.cmd = (0.0, 0.0, 0.0)
        self.rays = {C.name: raycast.pixel_rays(C.width, C.height, *C.intrinsics())
                     for C in self.robot.cameras}
        self.body = {L.name: self.scenario.body_ranges(L) for L in self.robot.lidars}
        cam = self.robot.cameras[0]
        self.run_record = RunRecord(config.route, config.seed, cam.width * cam.height,
                                 min_clearance_m=math.inf, goal_delay_s=self.goal_step * self.step_ns / NS)
        self.done = False
        self._wall = time.monotonic()
        self.monitor.check(self.parts(), 0.0)

    @property
    def t_ns(self):
        return self.start_ns + self.k * self.step_ns

    @property
    def rel(self):
        return self.k * self.step_ns / NS

    @property
    def pose(self):
        return self.base.x, self.base.y, self.base.yaw

    def parts(self):
        """The robot's boxes in map at the current pose: centres (K, 3), half (K, 3), yaw (K,)."""
        x, y, yaw = self.pose
        arm_c, arm_h, arm_yaw = self.robot.arm.boxes(self.rel)
        local_c = np.vstack([self.robot.body_center[None], arm_c])
        half = np.vstack([self.robot.body_half[None], arm_h])
        cs, sn = math.cos(yaw), math.sin(yaw)
        c = np.column_stack([x + cs * local_c[:, 0] - sn * local_c[:, 1],
                             y + sn * local_c[:, 0] + cs * local_c[:, 1], local_c[:, 2]])
        return c, half, np.concatenate([[yaw], yaw + arm_yaw])

    def sense(self):
        """The frame to publish at the current step (sensors measured from the current pose)."""
        pose, rel = self.pose, self.rel
        b = self.base
        frame = Frame(self.t_ns, rel, self.k % self.control_every == 0,
                      (self.odometry.x, self.odometry.y, self.odometry.yaw), self.odom_twist, pose,
                      (b.vx, b.vy, b.w), goal=self.goal if self.k == self.goal_step else None)
        if self.k % self.sensor_every == 0:
            sc, rng = self.scenario, self.rng
            frame.lidars = {L.name: sc.lidar_scan(L, rel, rng, self.body[L.name], pose=pose)
                            for L in self.robot.lidars}
            frame.sonars = {S.name: sc.sonar_range(S, rel, rng, pose=pose) for S in self.robot.sonars}
            frame.depth = {C.name: sc.depth_image(C, rel, rng, self.rays[C.name], pose=pose)
                           for C in self.robot.cameras}
        if frame.control:
            self.run_record.trajectory.append((rel,) + tuple(float(v) for v in pose))
        return frame

    def command(self, vx, vy, w):
        """The velocity command (base_link) from now until the next one."""
        self.cmd = (float(vx), float(vy), float(w))

    def advance(self):
        """Integrate one step, check collisions and the goal, advance the clock."""
        if self.done:
            return
        dt = self.step_ns / NS
        x0, y0 = self.base.x, self.base.y
        fwd, lat, dth = self.base.step(self.cmd, dt)
        self.odom_twist = self.odometry.step(fwd, dth, dt, self.rng, lateral=lat)
        self.k += 1
        rec, rel = self.run_record, self.rel
        parts = self.parts()
        # The people decide at the step whether to give way; the robot moved first (the contacts
        # are judged after both).
        self.world.hold(rel, people_giving_way(self.world, parts, rel))
        for person, waiting in zip(self.world.people, self.world.waiting()):
            if waiting:
                rec.people_waited_s[person.name] = rec.people_waited_s.get(person.name, 0.0) + dt
        clearance = self.monitor.check(parts, rel, math.hypot(self.base.vx, self.base.vy))
        if self.k > self.goal_step:  # path and clearance count from the goal on
            rec.path_length_m += math.hypot(self.base.x - x0, self.base.y - y0)
            rec.min_clearance_m = min(rec.min_clearance_m, clearance)
            since_goal = (self.k - self.goal_step) * self.step_ns / NS
            left = math.hypot(self.base.x - self.goal[0], self.base.y - self.goal[1])
            if left <= self.config.goal_tolerance_m:
                rec.reached, rec.time_to_goal_s, self.done = True, since_goal, True
            elif since_goal >= self.config.timeout_s:
                rec.timed_out, self.done = True, True
        rec.simulated_s = rel
        if self.done:  # the trajectory ends where the run did
            rec.trajectory.append((rel,) + tuple(float(v) for v in self.pose))

    def end(self, navigator_state):
        """End the run at the current step: the navigator stopped for good (its state
        ``reached`` or ``blocked``), so the rest would only be the timeout's wait."""
        self.done = True
        self.run_record.navigator_state = navigator_state
        self.run_record.trajectory.append((self.rel,) + tuple(float(v) for v in self.pose))

    def record(self):
        rec = self.run_record
        rec.collided_with = [{"name": n, "kind": k, "t": t, "robot_speed": v}
                             for n, k, t, v in self.monitor.onsets]
        rec.collisions = len(rec.collided_with)
        rec.collisions_3d = sum(1 for c in rec.collided_with if c["kind"] == "3d")
        rec.wall_s = time.monotonic() - self._wall
        return rec


def depth_points(depth, rays):
    """Organized cloud (height, width, 3) float32 in the optical frame from a depth frame (m,
    0 = none) and its pixel rays (``raycast.pixel_rays``, z = 1): NaN where there is no depth
    (what depth_image_proc's point_cloud_xyz makes)."""
    d = np.where(depth > 0.0, depth, np.nan)
    return (rays * d[..., None]).astype(np.float32)


def pursue(sim, gain=1.0):
    """A scripted controller for tests and examples (no obstacle avoidance): straight at the
    goal in base_link, speed limited by the distance left.  Returns (vx, vy, w)."""
    x, y, yaw = sim.pose
    gx, gy, gyaw = sim.goal
    dx, dy = gx - x, gy - y
    c, s = math.cos(yaw), math.sin(yaw)
    bx, by = c * dx + s * dy, -s * dx + c * dy
    dist = math.hypot(bx, by)
    speed = min(sim.robot.v_max, gain * dist)
    scale = speed / dist if dist > 1e-9 else 0.0
    return bx * scale, by * scale, gain * ((gyaw - yaw + math.pi) % (2 * math.pi) - math.pi)
