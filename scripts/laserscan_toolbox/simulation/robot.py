"""The simulated robot: body, sensor mounts, camera servos, trajectory, odometry.

Frames (REP 103/105): ``base_link`` lies on the floor at the centre of the
footprint, x forward, z up (so a converter's ``floor_height`` is 0).  The body is
the box x in [-0.37, 0.37], y in [-0.24, 0.24], z in [0, 0.60] (the paper's
0.74 x 0.48 x 0.60 m robot).  Lidar frames are level; a camera's
``<name>_tilt_link`` turns about its y axis with the servo (REP 103: a positive
pitch looks down), and ``<name>_optical_frame`` (z forward, x right, y down) is
fixed to it.
"""
import math
from dataclasses import dataclass, field, asdict
from typing import List, Tuple

import numpy as np

# optical (z forward, x right, y down) -> link (x forward, y left, z up)
R_LINK_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def rot_z(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rot_y(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def quat_from_matrix(m):
    """(x, y, z, w) of a rotation matrix (w >= 0)."""
    m = np.asarray(m, float)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = ((m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s)
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
        q = (0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s)
    elif m[1, 1] > m[2, 2]:
        s = math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
        q = ((m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s)
    else:
        s = math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
        q = ((m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s)
    q = np.array(q)
    q /= np.linalg.norm(q)
    return tuple(q if q[3] >= 0 else -q)


def quat_from_yaw(yaw):
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


@dataclass
class Lidar:
    """A level, rotating 2D lidar.  Beam i of a scan stamped t is measured at
    t + i * scan_time / beams from the robot's pose at that instant."""
    name: str
    frame: str
    xyz: Tuple[float, float, float]
    yaw: float
    rate: float = 8.0            # Hz (scan_time = 1 / rate)
    beams: int = 360             # 1 degree resolution over 360 degrees
    range_min: float = 0.15      # m; closer hits are reported as -inf (REP 117)
    range_max: float = 12.0      # m; farther: +inf
    noise_sigma: float = 0.003   # m, constant part of the range noise
    noise_per_m: float = 0.003   # m of noise std per metre of range
    dropout: float = 0.003       # probability of a lost return (+inf)
    phase: float = 0.0           # s, offset of the first scan from the start
    latency: float = 0.01        # s between the end of a scan and its bag time


@dataclass
class Sonar:
    """An ultrasonic range sensor (the paper's MaxBotix MB1403): one reading per ping, the
    distance to the closest surface anywhere in its cone (glass included), published as
    sensor_msgs/Range.  The cone is modelled in the sensor's horizontal plane."""
    name: str
    frame: str
    xyz: Tuple[float, float, float]
    yaw: float
    rate: float = 10.0           # Hz
    phase: float = 0.0           # s, first ping (in turn; off the 50 Hz odometry grid, see paper_robot)
    field_of_view: float = 0.6   # rad, full cone angle
    min_range: float = 0.3       # m; closer echoes read -inf (too close, REP 117)
    max_range: float = 5.0       # m; no echo reads exactly max_range
    rays: int = 25               # rays cast across the cone
    noise_sigma: float = 0.01    # m
    latency: float = 0.01        # s between the ping and its bag time


@dataclass
class Camera:
    """A depth camera on a tilt servo.  Depth std = noise_a + noise_b * depth^2."""
    name: str
    tilt_frame: str
    optical_frame: str
    xyz: Tuple[float, float, float]         # servo axis in base_link
    yaw: float                              # rad, mount yaw
    optical_offset: Tuple[float, float, float] = (0.025, 0.0, 0.03)  # in the tilt link
    hfov_deg: float = 82.0
    vfov_deg: float = 52.0
    width: int = 304
    height: int = 171
    rate: float = 14.0
    phase: float = 0.0
    pitch_center_deg: float = 15.0          # positive looks down (REP 103)
    pitch_amplitude_deg: float = 20.0
    servo_period: float = 4.0               # s
    servo_phase: float = 0.0                # rad
    min_depth: float = 0.2
    max_depth: float = 8.0
    noise_a: float = 0.001
    noise_b: float = 0.001
    dropout: float = 0.01                   # fraction of pixels without depth
    latency: float = 0.03

    def intrinsics(self):
        """(fx, fy, cx, cy) of the pinhole model for the field of view and size."""
        fx = (self.width / 2.0) / math.tan(math.radians(self.hfov_deg) / 2)
        fy = (self.height / 2.0) / math.tan(math.radians(self.vfov_deg) / 2)
        return fx, fy, (self.width - 1) / 2.0, (self.height - 1) / 2.0

    def pitch(self, rel_time):
        """Servo pitch (rad, positive down) at scenario-relative time(s)."""
        return np.radians(self.pitch_center_deg) + np.radians(self.pitch_amplitude_deg) * np.sin(
            2 * math.pi * np.asarray(rel_time) / self.servo_period + self.servo_phase)

    def tilt_rotation(self, rel_time):
        """Rotation base_link <- tilt link."""
        return rot_z(self.yaw) @ rot_y(float(self.pitch(rel_time)))

    def optical_in_base(self, rel_time):
        """(R, p): optical frame pose in base_link at the time."""
        r_tilt = self.tilt_rotation(rel_time)
        p = np.asarray(self.xyz, float) + r_tilt @ np.asarray(self.optical_offset, float)
        return r_tilt @ R_LINK_OPTICAL, p


def camera_resolution(points, hfov_deg=82.0, vfov_deg=52.0):
    """(width, height) with square pixels for about ``points`` pixels."""
    aspect = math.tan(math.radians(hfov_deg) / 2) / math.tan(math.radians(vfov_deg) / 2)
    h = max(2, int(round(math.sqrt(points / aspect))))
    return max(2, int(round(points / h))), h


@dataclass
class OdomNoise:
    """Wheel odometry errors: per-run scale errors drawn once from the seed (the
    source of drift), white noise per step proportional to the motion, and a
    heading bias while moving.  Standing still reads exactly zero motion."""
    rate: float = 50.0
    scale_sigma_v: float = 0.01      # 1-sigma of the linear scale error
    scale_sigma_w: float = 0.02      # 1-sigma of the angular scale error
    noise_v: float = 0.02            # relative std of each step's distance
    noise_w: float = 0.03            # relative std of each step's rotation
    noise_w_per_m: float = 0.005     # rad of rotation noise per metre driven
    bias_w: float = 0.004            # rad/s heading drift while moving


# ----- the arm -------------------------------------------------------------------------------
@dataclass
class ArmLink:
    """One link of the arm: a box (``size``: full x, y, z) centred at ``center`` in the link's
    frame, hung on its parent by a joint at ``joint_xyz`` in the parent's frame."""
    name: str
    parent: str
    joint: str                              # revolute_z | prismatic_z
    joint_xyz: Tuple[float, float, float]
    size: Tuple[float, float, float]
    center: Tuple[float, float, float]


def _smooth(u):
    return u * u * (3.0 - 2.0 * u)


@dataclass
class Arm:
    """The paper's arm above the base, simplified to a SCARA-style chain (shoulder and elbow
    turn about z, the gripper slides along z) so that every link stays level: the ray casts
    handle yawed boxes, and the poses still reach into the cameras' views (ahead-left of the
    robot) and the rear lidar's plane (lowered beside the robot's right side).

    ``keyframes``: (relative time s, shoulder rad, elbow rad, gripper lift m) repeated every
    ``period`` seconds; between two keyframes the joints move smoothly (zero speed at each)."""
    links: List[ArmLink] = field(default_factory=lambda: [
        ArmLink("arm_upper_link", "base_link", "revolute_z", (0.05, 0.0, 0.62),
                (0.46, 0.08, 0.08), (0.20, 0.0, 0.04)),
        ArmLink("arm_forearm_link", "arm_upper_link", "revolute_z", (0.40, 0.0, 0.08),
                (0.41, 0.06, 0.06), (0.175, 0.0, 0.03)),
        ArmLink("arm_gripper_link", "arm_forearm_link", "prismatic_z", (0.35, 0.0, 0.0),
                (0.07, 0.07, 0.20), (0.0, 0.0, -0.10)),
    ])
    period: float = 24.0
    keyframes: List[Tuple[float, float, float, float]] = field(default_factory=lambda: [
        (0.0, math.pi, math.pi, 0.20),     # stowed over the body
        (2.0, math.pi, math.pi, 0.20),
        (4.0, 0.05, 0.85, -0.05),          # ahead-left, in the left camera's view
        (6.0, 0.05, 0.85, -0.05),
        (8.5, -2.532, 1.187, -0.36),       # lowered beside the right side, in the rear lidar's
        (12.0, -2.532, 1.187, -0.36),      # plane (a shelf 4 cm beyond its padded box there)
        (15.0, -math.pi, math.pi, 0.20),   # stowed again (the same pose as +pi, +pi)
        (24.0, -math.pi, math.pi, 0.20),
    ])

    def joints(self, rel_time):
        """(shoulder, elbow, lift) arrays at scenario-relative time(s)."""
        t = np.mod(np.asarray(rel_time, float), self.period)
        k = np.array(self.keyframes, float)
        i = np.clip(np.searchsorted(k[:, 0], t, side="right") - 1, 0, len(k) - 2)
        u = _smooth(np.clip((t - k[i, 0]) / (k[i + 1, 0] - k[i, 0]), 0.0, 1.0))
        q = k[i, 1:] + (k[i + 1, 1:] - k[i, 1:]) * u[..., None]
        return q[..., 0], q[..., 1], q[..., 2]

    def joint_transforms(self, rel_time):
        """[(link, parent, xyz, yaw)] of each joint at one time (what /tf carries)."""
        values = self.joints(float(rel_time))
        out = []
        for link, q in zip(self.links, values):
            x, y, z = link.joint_xyz
            if link.joint == "prismatic_z":
                out.append((link.name, link.parent, (x, y, z + float(q)), 0.0))
            else:
                out.append((link.name, link.parent, (x, y, z), float(q)))
        return out

    def boxes(self, rel_time):
        """Boxes of the links in base_link at time(s): centres (..., L, 3), half sizes (L, 3),
        yaws (..., L)."""
        shoulder, elbow, lift = (np.asarray(v, float) for v in self.joints(rel_time))
        up, fore, grip = self.links
        yaw1 = shoulder
        yaw2 = shoulder + elbow
        p1 = np.stack(np.broadcast_arrays(*up.joint_xyz), -1) * np.ones(np.shape(yaw1) + (1,))

        def at(p, yaw, v):
            c, s = np.cos(yaw), np.sin(yaw)
            return np.stack([p[..., 0] + c * v[0] - s * v[1], p[..., 1] + s * v[0] + c * v[1],
                             p[..., 2] + v[2]], -1)
        p2 = at(p1, yaw1, fore.joint_xyz)
        p3 = at(p2, yaw2, grip.joint_xyz)
        p3 = p3 + np.stack([np.zeros_like(lift), np.zeros_like(lift), lift], -1)
        centers = np.stack([at(p1, yaw1, up.center), at(p2, yaw2, fore.center),
                            at(p3, yaw2, grip.center)], -2)
        half = 0.5 * np.array([lk.size for lk in self.links], float)
        return centers, half, np.stack([yaw1, yaw2, yaw2], -1)

    def urdf(self):
        """The robot description: base_link and the arm's links with box collisions (what
        config/sim_robot/robot.urdf holds; test_scenario checks that they agree)."""
        lines = ['<?xml version="1.0"?>',
                 '<!-- Written by laserscan_toolbox.simulation.robot.Arm.urdf(): the simulated robot\'s arm',
                 '     (config/sim_robot/*.yaml: self_filter/use_robot_description). Do not edit by hand. -->',
                 '<robot name="sim_robot">', '  <link name="base_link"/>']
        for lk in self.links:
            size = " ".join("%g" % v for v in lk.size)
            center = " ".join("%g" % v for v in lk.center)
            lines += ['  <link name="%s">' % lk.name,
                      '    <collision>', '      <origin xyz="%s" rpy="0 0 0"/>' % center,
                      '      <geometry><box size="%s"/></geometry>' % size, '    </collision>',
                      '  </link>']
            kind, limits = (("prismatic", 'lower="-0.4" upper="0.2"') if lk.joint == "prismatic_z"
                            else ("revolute", 'lower="-3.1416" upper="3.1416"'))
            joint_name = lk.name.replace("_link", "_joint")
            lines += ['  <joint name="%s" type="%s">' % (joint_name, kind),
                      '    <parent link="%s"/>' % lk.parent, '    <child link="%s"/>' % lk.name,
                      '    <origin xyz="%s" rpy="0 0 0"/>' % " ".join("%g" % v for v in lk.joint_xyz),
                      '    <axis xyz="0 0 1"/>',
                      '    <limit %s effort="100" velocity="2"/>' % limits, '  </joint>']
        lines.append('</robot>')
        return "\n".join(lines) + "\n"


@dataclass
class Robot:
    """Dimensions, sensors and motion limits of the simulated robot."""
    length: float = 0.74
    width: float = 0.48
    height: float = 0.60
    v_max: float = 0.6      # m/s
    w_max: float = 0.8      # rad/s
    acc_v: float = 0.4      # m/s^2
    acc_w: float = 1.2      # rad/s^2
    lidars: List[Lidar] = field(default_factory=list)
    cameras: List[Camera] = field(default_factory=list)
    sonars: List[Sonar] = field(default_factory=list)
    odom: OdomNoise = field(default_factory=OdomNoise)
    arm: Arm = field(default_factory=Arm)

    @property
    def body_half(self):
        return np.array([self.length / 2, self.width / 2, self.height / 2])

    @property
    def body_center(self):
        """Centre of the body box in base_link (base_link is on the floor)."""
        return np.array([0.0, 0.0, self.height / 2])

    def to_dict(self):
        return _clean(asdict(self))

    @classmethod
    def from_dict(cls, d):
        d = dict(d)
        lidars = [Lidar(**{**x, "xyz": tuple(x["xyz"])}) for x in d.pop("lidars", [])]
        cams = [Camera(**{**x, "xyz": tuple(x["xyz"]), "optical_offset": tuple(x["optical_offset"])})
                for x in d.pop("cameras", [])]
        sonars = [Sonar(**{**x, "xyz": tuple(x["xyz"])}) for x in d.pop("sonars", [])]
        odom = OdomNoise(**d.pop("odom", {}))
        arm = dict(d.pop("arm", {}))
        if "links" in arm:
            arm["links"] = [ArmLink(**{**x, "joint_xyz": tuple(x["joint_xyz"]), "size": tuple(x["size"]),
                                       "center": tuple(x["center"])}) for x in arm["links"]]
        if "keyframes" in arm:
            arm["keyframes"] = [tuple(k) for k in arm["keyframes"]]
        return cls(lidars=lidars, cameras=cams, sonars=sonars, odom=odom, arm=Arm(**arm), **d)


def _clean(v):
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    if isinstance(v, dict):
        return {k: _clean(x) for k, x in v.items()}
    if isinstance(v, (float, np.floating)):
        return float(v)
    if isinstance(v, (int, np.integer)) and not isinstance(v, bool):
        return int(v)
    return v


def paper_robot(camera_points=None):
    """The paper's robot: lidars at the front-left and rear-right corners (each
    mounted 3 cm outside the body's corner, yawed 45 degrees outwards, so the body
    hides a quarter of its view), depth cameras at the front corners yawed
    +-41 degrees (164 degrees together) on servos sweeping 15 +- 20 degrees down, and
    four ultrasonic sensors 0.3 m above the floor (two on the front face yawed +-5
    degrees, so that their cones' edges meet the aisle's sides beyond 2 m; one on each side), pinging in turn at 10 Hz each; their stamps stay off
    the odometry's 50 Hz grid so that matching output to input stamps tells them apart."""
    w, h = camera_resolution(camera_points) if camera_points else (304, 171)
    lidars = [
        Lidar("lidar_front", "lidar_front_link", (0.40, 0.27, 0.20), math.radians(45.0), phase=0.0),
        Lidar("lidar_rear", "lidar_rear_link", (-0.40, -0.27, 0.20), math.radians(-135.0),
              phase=0.0625),
    ]
    cameras = [
        Camera("camera_left", "camera_left_tilt_link", "camera_left_optical_frame",
               (0.40, 0.20, 0.63), math.radians(41.0), width=w, height=h, phase=0.0),
        Camera("camera_right", "camera_right_tilt_link", "camera_right_optical_frame",
               (0.40, -0.20, 0.63), math.radians(-41.0), width=w, height=h, phase=1.0 / 28.0,
               servo_phase=math.pi),
    ]
    sonars = [
        Sonar("sonar_front_left", "sonar_front_left_link", (0.37, 0.12, 0.30), math.radians(5.0), phase=0.007),
        Sonar("sonar_front_right", "sonar_front_right_link", (0.37, -0.12, 0.30), math.radians(-5.0), phase=0.057),
        Sonar("sonar_left", "sonar_left_link", (0.0, 0.24, 0.30), math.radians(90.0), phase=0.032),
        Sonar("sonar_right", "sonar_right_link", (0.0, -0.24, 0.30), math.radians(-90.0), phase=0.082),
    ]
    return Robot(lidars=lidars, cameras=cameras, sonars=sonars)


# ----- trajectory ----------------------------------------------------------------------------
def default_route():
    """Waypoints (map frame) from A to B; the robot drives A -> B -> A (one lap)."""
    return [(3.6, 5.0), (4.4, 7.5), (12.4, 7.5), (14.2, 5.6)]


def _wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def simulate_trajectory(robot, route, laps, duration, dt=0.005, wait=1.0, switch_radius=0.35):
    """Drive the route ``laps`` times there and back with smooth, limited velocity.

    A unicycle tracks the waypoints: yaw rate proportional to the heading error,
    speed reduced with the heading error and before sharp corners, both
    acceleration-limited (so velocity is continuous).  The robot waits ``wait``
    seconds at the start.  ``duration`` None: until the last lap ends plus
    ``wait`` seconds.  Returns dict of arrays t (relative s), x, y, yaw, v, w.
    """
    pts = [tuple(map(float, p)) for p in route]
    # ``laps`` counts round trips: A -> B -> A is one lap.
    seq = list(pts)
    for k in range(laps):
        seq += pts[-2::-1]
        if k + 1 < laps:
            seq += pts[1:]
    x, y = seq[0]
    first = seq[1]
    yaw = math.atan2(first[1] - y, first[0] - x)
    v = w = 0.0
    i = 1
    out = {k: [] for k in ("t", "x", "y", "yaw", "v", "w")}
    t = 0.0
    finished_at = None
    limit = duration if duration is not None else 3600.0
    while t <= limit + 1e-9:
        for k, val in zip(("t", "x", "y", "yaw", "v", "w"), (t, x, y, yaw, v, w)):
            out[k].append(val)
        if finished_at is not None and duration is None and t >= finished_at + wait:
            break
        v_des = w_des = 0.0
        if t >= wait and finished_at is None:
            tx, ty = seq[i]
            dist = math.hypot(tx - x, ty - y)
            last = i == len(seq) - 1
            if not last and dist < switch_radius:
                i += 1
                tx, ty = seq[i]
                dist = math.hypot(tx - x, ty - y)
                last = i == len(seq) - 1
            if last and dist < 0.03:
                finished_at = t
            else:
                err = _wrap(math.atan2(ty - y, tx - x) - yaw)
                w_des = max(-robot.w_max, min(robot.w_max, 2.0 * err))
                v_des = robot.v_max * max(0.0, math.cos(err)) ** 8 if abs(err) < 1.2 else 0.0
                if last:
                    v_des = min(v_des, math.sqrt(2 * 0.8 * robot.acc_v * max(dist - 0.02, 0.0)))
                else:
                    nx, ny = seq[i + 1]
                    turn = abs(_wrap(math.atan2(ny - ty, nx - tx) - math.atan2(ty - y, tx - x)))
                    v_turn = max(0.05, robot.v_max * (1 - turn / math.pi) ** 2)
                    v_des = min(v_des, math.sqrt(v_turn ** 2 + 2 * 0.8 * robot.acc_v
                                                 * max(dist - switch_radius, 0.0)))
        if finished_at is not None and t > finished_at:
            v_des = w_des = 0.0
        v += max(-robot.acc_v * dt, min(robot.acc_v * dt, v_des - v))
        w += max(-robot.acc_w * dt, min(robot.acc_w * dt, w_des - w))
        if finished_at is not None and abs(v) < 1e-3 and abs(w) < 1e-3:
            v = w = 0.0
        x += v * math.cos(yaw + 0.5 * w * dt) * dt
        y += v * math.sin(yaw + 0.5 * w * dt) * dt
        yaw = _wrap(yaw + w * dt)
        t += dt
    arr = {k: np.array(val) for k, val in out.items()}
    arr["yaw_unwrapped"] = np.unwrap(arr["yaw"])
    return arr


class WheelOdometry:
    """Wheel odometry integrated step by step from the true motion (the bag's route and the
    closed loop share it).  The per-run scale errors are drawn from ``rng`` at construction;
    every step's true motion, in the body frame, is corrupted (scale errors, white noise,
    heading bias while moving) and integrated from the identity pose (the odom frame starts at
    the robot's initial pose, REP 105).  Standing still reads exactly zero motion."""

    def __init__(self, noise, rng):
        self.noise = noise
        self.scale_v = 1.0 + rng.normal(0.0, noise.scale_sigma_v)
        self.scale_w = 1.0 + rng.normal(0.0, noise.scale_sigma_w)
        self.x = self.y = self.yaw = 0.0

    def step(self, ds, dth, dt, rng, lateral=0.0):
        """Integrate one step: ``ds`` forward and ``lateral`` (m, body frame at the step's
        start; lateral only for an omnidirectional base, its noise drawn only when non-zero),
        ``dth`` (rad) in ``dt`` s.  Returns the measured (vx, vy, w)."""
        noise = self.noise
        moving = abs(ds) > 1e-6 or abs(dth) > 1e-6 or abs(lateral) > 1e-6
        if moving:
            ds = ds * self.scale_v + rng.normal(0.0, noise.noise_v * abs(ds))
            if lateral != 0.0:
                lateral = lateral * self.scale_v + rng.normal(0.0, noise.noise_v * abs(lateral))
            dist = math.hypot(ds, lateral)  # as measured (noise included)
            dth = (dth * self.scale_w + noise.bias_w * dt
                   + rng.normal(0.0, noise.noise_w * abs(dth) + noise.noise_w_per_m * dist))
        else:
            ds = dth = lateral = 0.0
        mid = self.yaw + 0.5 * dth
        c, s = math.cos(mid), math.sin(mid)
        self.x += ds * c - lateral * s
        self.y += ds * s + lateral * c
        self.yaw += dth
        return ds / dt, lateral / dt, dth / dt


def simulate_odometry(traj, times, noise, rng):
    """Wheel odometry at ``times`` (relative s) from the true trajectory (``WheelOdometry``
    fed the forward motion between consecutive stamps).  Returns (x, y, yaw, v, w) arrays in
    odom."""
    tx = np.interp(times, traj["t"], traj["x"])
    ty = np.interp(times, traj["t"], traj["y"])
    tyaw = np.interp(times, traj["t"], traj["yaw_unwrapped"])
    odo = WheelOdometry(noise, rng)
    n = len(times)
    x = np.zeros(n)
    y = np.zeros(n)
    yaw = np.zeros(n)
    v = np.zeros(n)
    w = np.zeros(n)
    for k in range(1, n):
        c, s = math.cos(tyaw[k - 1]), math.sin(tyaw[k - 1])
        ds = c * (tx[k] - tx[k - 1]) + s * (ty[k] - ty[k - 1])  # forward motion in the body frame
        v[k], _, w[k] = odo.step(ds, tyaw[k] - tyaw[k - 1], times[k] - times[k - 1], rng)
        x[k], y[k], yaw[k] = odo.x, odo.y, odo.yaw
    return x, y, np.array([_wrap(a) for a in yaw]), v, w
