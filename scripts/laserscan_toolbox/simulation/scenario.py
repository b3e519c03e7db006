"""The built-in scenario: world + robot + route + seed, its ground truth, and the
simulator that writes it as a ROS 1 bag.

API used by the evaluation tools (names and signatures are stable)::

    from laserscan_toolbox.simulation.scenario import Scenario, TOPICS
    sc = Scenario.default(seed=0, duration=None, camera_points=None)
    text = sc.to_yaml(); sc2 = Scenario.from_yaml(text)      # exact round trip
    sc3 = Scenario.from_bag("shop_floor.bag")                # reads the /scenario topic
    x, y, yaw = sc.true_pose(t)                              # map frame, t = ROS time (s)
    ranges = sc.ideal_scan(t, angle_min, angle_max, angle_increment,
                           range_min, range_max, z_min, z_max, pose=None)
    grid, (x0, y0) = sc.ground_truth_grid(resolution, z_min, z_max, static_only=True)
    sc.world, sc.robot, sc.duration, sc.start_time

Times: every ``t`` argument is absolute ROS time in seconds (the bag's clock);
the scenario starts at ``start_time`` (default 1000 s) and lasts ``duration`` s.
Heights are above the floor; ``base_link`` is on the floor at the robot's centre.
"""
import collections
import math
import time

import numpy as np
import yaml

from . import raycast
from .robot import (Robot, paper_robot, default_route, simulate_trajectory, simulate_odometry,
                    quat_from_matrix, quat_from_yaw, rot_z, R_LINK_OPTICAL, _clean)
from .world import World, shop_floor

#: Topic names written by the simulator and used by the pipeline and the evaluation.
TOPICS = {
    "lidar_front": "/lidar_front/scan",
    "lidar_rear": "/lidar_rear/scan",
    "camera_left_depth": "/camera_left/depth/image_rect",
    "camera_left_info": "/camera_left/depth/camera_info",
    "camera_left_points": "/camera_left/depth/points",      # made by depth_image_proc
    "camera_left_scan": "/camera_left/scan",                # made by the converter
    "camera_right_depth": "/camera_right/depth/image_rect",
    "camera_right_info": "/camera_right/depth/camera_info",
    "camera_right_points": "/camera_right/depth/points",
    "camera_right_scan": "/camera_right/scan",
    "odom": "/odom",
    "tf": "/tf",
    "tf_static": "/tf_static",
    "ground_truth": "/ground_truth/odom",
    "scenario": "/scenario",
    "merged_scan": "/merged_scan",                          # lidars + cameras + sonar arcs merger
    "slam_scan": "/slam_scan",                              # lidars + cameras merger (SLAM's feed)
    "lidar_scan": "/lidar_scan",                            # lidar-only merger
}
# Ultrasonic sensors: sensor_msgs/Range in, a LaserScan arc out (range converters).
for _sonar in ("sonar_front_left", "sonar_front_right", "sonar_left", "sonar_right"):
    TOPICS[_sonar] = "/%s/range" % _sonar
    TOPICS[_sonar + "_scan"] = "/%s/scan" % _sonar

#: Frame names.
FRAMES = {"map": "map", "odom": "odom", "base": "base_link"}

DEFAULT_START_TIME = 1000.0


def stamped(msg, t, frame):
    """``msg`` with its header stamped t (float s or rospy.Time) in ``frame``."""
    from ..ros import bagio
    msg.header.stamp = bagio.stamp(t)
    msg.header.frame_id = frame
    return msg


class Scenario:
    """A fully determined simulation: the same parameters give the same bag."""

    def __init__(self, world, robot, route, laps=1, duration=None, seed=0,
                 start_time=DEFAULT_START_TIME):
        self.world = world
        self.robot = robot
        self.route = [tuple(map(float, p)) for p in route]
        self.seed = int(seed)
        self.start_time = float(start_time)
        self.laps = int(laps)
        self._traj = simulate_trajectory(robot, self.route, self.laps, duration)
        #: Length of the scenario in seconds (None at construction: one lap + rest).
        self.duration = float(self._traj["t"][-1]) if duration is None else float(duration)
        self._ideal_cache = collections.OrderedDict()  # see _band_scans
        self._ideal_cache_bytes = 0

    # ----- construction ----------------------------------------------------------------
    @classmethod
    def default(cls, seed=0, duration=None, camera_points=None, laps=None):
        """The built-in shop-floor scenario.

        seed: noise of every sensor and of odometry.  duration (s): None drives
        A -> B -> A once (about 56 s); a longer one repeats the lap, a shorter one
        cuts it.  camera_points: pixels per depth image (default about 52,000).
        laps: round trips A -> B -> A to drive (revisits: loop closures for SLAM);
        with a duration too, the shorter of the two ends the scenario.
        """
        robot = paper_robot(camera_points)
        route = default_route()
        if laps is None:
            laps = 1
            if duration is not None:
                lap = simulate_trajectory(robot, route, 1, None)["t"][-1]
                laps = max(1, int(math.ceil(float(duration) / lap)))
        return cls(shop_floor(), robot, route, laps, duration, seed)

    def to_dict(self):
        return _clean({"seed": self.seed, "start_time": self.start_time,
                       "duration": self.duration, "laps": self.laps,
                       "route": [list(p) for p in self.route],
                       "robot": self.robot.to_dict(), "world": self.world.to_dict()})

    def to_yaml(self):
        """YAML text of every parameter (what the bag's /scenario topic holds)."""
        return yaml.safe_dump(self.to_dict(), sort_keys=False)

    @classmethod
    def from_dict(cls, d):
        return cls(World.from_dict(d["world"]), Robot.from_dict(d["robot"]), d["route"],
                   d["laps"], d["duration"], d["seed"], d["start_time"])

    @classmethod
    def from_yaml(cls, text):
        """Rebuild the scenario exactly from ``to_yaml()`` output."""
        return cls.from_dict(yaml.safe_load(text))

    @classmethod
    def from_bag(cls, path):
        """Rebuild the scenario from the latched ``/scenario`` topic of a bag."""
        import rosbag
        with rosbag.Bag(path) as bag:
            for _, msg, _ in bag.read_messages(topics=[TOPICS["scenario"]]):
                return cls.from_yaml(msg.data)
        raise ValueError(f"{path}: no {TOPICS['scenario']} message; not a simulated bag?")

    # ----- ground truth ----------------------------------------------------------------
    def true_pose(self, t):
        """True (x, y, yaw) of base_link in ``map`` at ROS time t (float or array);
        clamped to the first/last pose outside the scenario."""
        rel = np.asarray(t, float) - self.start_time
        tr = self._traj
        x = np.interp(rel, tr["t"], tr["x"])
        y = np.interp(rel, tr["t"], tr["y"])
        yaw = np.interp(rel, tr["t"], tr["yaw_unwrapped"])
        yaw = (yaw + np.pi) % (2 * np.pi) - np.pi
        if np.ndim(rel) == 0:
            return float(x), float(y), float(yaw)
        return x, y, yaw

    def true_velocity(self, t):
        """True (v, w) in base_link at ROS time t."""
        rel = float(t) - self.start_time
        return (float(np.interp(rel, self._traj["t"], self._traj["v"])),
                float(np.interp(rel, self._traj["t"], self._traj["w"])))

    def ideal_scan(self, t, angle_min, angle_max, angle_increment, range_min, range_max,
                   z_min, z_max, pose=None, glass=True):
        """Ground-truth ranges (n,) with n = round((angle_max - angle_min) / angle_increment) + 1.

        Beam i points at angle_min + i * angle_increment in base_link; its range is
        the distance from base_link's origin (at the true pose at time t, or at
        ``pose`` = (x, y, yaw) in map) to the closest obstacle of the world at time
        t (people where they are then) whose height overlaps [z_min, z_max] above
        the floor.  Floor holes count at their rim, glass panes count unless ``glass``
        is False; the robot's own body does not count.  +inf: nothing within
        range_max; -inf: closer than range_min.
        """
        n = int(round((angle_max - angle_min) / angle_increment)) + 1
        pose = self.true_pose(t) if pose is None else pose
        with_glass, without_glass = self._band_scans(t, pose, angle_min, angle_increment, n,
                                                     z_min, z_max, range_max)
        r = with_glass if glass else without_glass
        r = np.where(r <= range_max, r, np.inf)
        return np.where(r < range_min, -np.inf, r)

    #: Memory the ideal scans kept for reuse may take (bytes).
    IDEAL_SCAN_CACHE_BYTES = 64 << 20

    def _band_scans(self, t, pose, angle_min, angle_increment, n, z_min, z_max, reach):
        """World.band_scans (with, without glass) of an ideal scan, exact up to ``reach``.

        The evaluation asks for the same scan several times (with and without glass, to
        its range_max and a little beyond): the last ones are kept, least recently used
        out first, and serve every call whose reach is not larger (the world does not
        change once the scenario is made).
        """
        x, y, yaw = (float(v) for v in pose)
        key = (float(t), x, y, yaw, float(angle_min), float(angle_increment), int(n),
               float(z_min), float(z_max))
        cache = self._ideal_cache
        kept = cache.get(key)
        if kept is not None and kept[0] >= reach:
            cache.move_to_end(key)
            return kept[1]
        angles = angle_min + np.arange(n) * angle_increment
        scans = self.world.band_scans((x, y), angles + yaw, z_min, z_max, float(t) - self.start_time,
                                      max_range=reach)
        if kept is not None:
            del cache[key]
            self._ideal_cache_bytes -= kept[2]
        size = sum(s.nbytes for s in scans)
        cache[key] = (reach, scans, size)
        self._ideal_cache_bytes += size
        while self._ideal_cache_bytes > self.IDEAL_SCAN_CACHE_BYTES and len(cache) > 1:
            self._ideal_cache_bytes -= cache.popitem(last=False)[1][2]
        return scans

    def ground_truth_grid(self, resolution, z_min, z_max, static_only=True, t=None):
        """Occupancy of the obstacles overlapping [z_min, z_max] (floor holes: their area).

        Returns (grid, (x0, y0)): bool array indexed [row = y, column = x], cell
        (0, 0)'s lower-left corner at (x0, y0) in map, cells of ``resolution`` m.
        With static_only False, people are included at time t (default start).
        """
        rel = 0.0 if t is None else float(t) - self.start_time
        return self.world.occupancy(resolution, z_min, z_max, rel, static_only)

    # ----- sensor models ---------------------------------------------------------------
    def _lidar_angles(self, lidar):
        inc = 2 * math.pi / lidar.beams
        return -math.pi + np.arange(lidar.beams) * inc, inc

    def body_ranges(self, lidar):
        """Range (per beam, in the lidar frame) at which the robot's own body blocks
        the beam, +inf where it does not (static: the body moves with the lidar)."""
        angles, _ = self._lidar_angles(lidar)
        a = angles + lidar.yaw
        o = np.tile(np.asarray(lidar.xyz, float), (len(a), 1))
        d = np.column_stack([np.cos(a), np.sin(a), np.zeros(len(a))])
        return raycast.ray_boxes(o, d, self.robot.body_center[None], self.robot.body_half[None])[:, 0]

    def arm_ranges(self, lidar, rel):
        """Range (per beam, from the lidar) at which the arm blocks the beam measured at
        relative time rel[i], +inf where it does not."""
        angles, _ = self._lidar_angles(lidar)
        a = angles + lidar.yaw
        o = np.tile(np.asarray(lidar.xyz, float), (len(a), 1))
        d = np.column_stack([np.cos(a), np.sin(a), np.zeros(len(a))])
        centers, half, yaw = self.robot.arm.boxes(rel)
        return raycast.ray_own_boxes(o, d, centers, half, yaw)

    def lidar_scan(self, lidar, rel_stamp, rng, body=None, pose=None):
        """Noisy ranges (beams,) of one swept scan starting at rel_stamp (relative s); with
        ``pose`` (x, y, yaw in map) an instantaneous scan from there (the closed loop, whose
        trajectory is not known ahead)."""
        angles, _ = self._lidar_angles(lidar)
        if pose is None:
            scan_time = 1.0 / lidar.rate
            rel = rel_stamp + np.arange(lidar.beams) * (scan_time / lidar.beams)
            x, y, yaw = self.true_pose(rel + self.start_time)
        else:
            rel = np.full(lidar.beams, float(rel_stamp))
            x, y, yaw = (np.full(lidar.beams, float(v)) for v in pose)
        c, s = np.cos(yaw), np.sin(yaw)
        lx, ly, lz = lidar.xyz
        o = np.column_stack([x + c * lx - s * ly, y + s * lx + c * ly, np.full(len(rel), lz)])
        a = yaw + lidar.yaw + angles
        d = np.column_stack([np.cos(a), np.sin(a), np.zeros(len(a))])
        r = self.world.cast(o, d, rel)
        if body is None:
            body = self.body_ranges(lidar)
        r = np.minimum(r, np.minimum(body, self.arm_ranges(lidar, rel)))
        finite = np.isfinite(r)
        sigma = lidar.noise_sigma + lidar.noise_per_m * np.where(finite, r, 0.0)
        r = np.where(finite, r + rng.normal(0.0, 1.0, len(r)) * sigma, r)
        r = np.where(rng.random(len(r)) < lidar.dropout, np.inf, r)
        r = np.where(r > lidar.range_max, np.inf, r)
        return np.where(r < lidar.range_min, -np.inf, r)

    def sonar_range(self, sonar, rel, rng, pose=None):
        """One noisy ultrasonic reading (m) at relative time rel: the closest surface in
        the cone (glass included), ``max_range`` when nothing echoes within it, -inf when
        it is closer than ``min_range``.  ``pose``: the robot's (x, y, yaw) in map instead of
        the scenario's trajectory at rel (the closed loop)."""
        x, y, yaw = self.true_pose(rel + self.start_time) if pose is None else pose
        c, s = math.cos(yaw), math.sin(yaw)
        sx, sy, sz = sonar.xyz
        half = 0.5 * sonar.field_of_view
        a = yaw + sonar.yaw + np.linspace(-half, half, sonar.rays)
        o = np.tile([x + c * sx - s * sy, y + s * sx + c * sy, sz], (len(a), 1))
        d = np.column_stack([np.cos(a), np.sin(a), np.zeros(len(a))])
        r = float(self.world.cast(o, d, rel, see_glass=True).min())
        if not r < sonar.max_range:
            return float(sonar.max_range)
        if r < sonar.min_range:
            return -math.inf  # REP 117 driver: too close (a finite value there is an error code)
        return r + float(rng.normal(0.0, sonar.noise_sigma))

    def depth_image(self, cam, rel, rng, rays=None, pose=None):
        """Noisy depth (height, width) float metres of one frame, 0 = no depth.  ``pose``: as
        ``sonar_range``."""
        x, y, yaw = self.true_pose(rel + self.start_time) if pose is None else pose
        r_bo, p_bo = cam.optical_in_base(rel)
        r_wb = rot_z(yaw)
        r_wo = r_wb @ r_bo
        p_wo = np.array([x, y, 0.0]) + r_wb @ p_bo
        solids = dict(self.world.solids(rel))
        # The robot's own body is an obstacle for its cameras too.
        body_c = np.array([x, y, 0.0]) + r_wb @ self.robot.body_center
        solids["box_c"] = np.vstack([solids["box_c"], body_c])
        solids["box_h"] = np.vstack([solids["box_h"], self.robot.body_half])
        solids["box_yaw"] = np.append(solids["box_yaw"], yaw)
        # And so is its arm, where it is at the frame's time.
        arm_c, arm_h, arm_yaw = self.robot.arm.boxes(rel)
        solids["box_c"] = np.vstack([solids["box_c"], np.array([x, y, 0.0]) + arm_c @ r_wb.T])
        solids["box_h"] = np.vstack([solids["box_h"], arm_h])
        solids["box_yaw"] = np.append(solids["box_yaw"], yaw + arm_yaw)
        depth = raycast.render_depth(solids, self.world.hole_arr, self.world.ceiling, r_wo, p_wo,
                                     cam.intrinsics(), cam.width, cam.height, cam.max_depth, rays)
        finite = np.isfinite(depth)
        dz = np.where(finite, depth, 0.0)
        noisy = dz + rng.normal(0.0, 1.0, dz.shape) * (cam.noise_a + cam.noise_b * dz * dz)
        valid = finite & (noisy >= cam.min_depth) & (noisy <= cam.max_depth)
        valid &= rng.random(dz.shape) >= cam.dropout
        return np.where(valid, noisy, 0.0)

    # ----- the bag ---------------------------------------------------------------------
    def schedule(self):
        """Relative stamps of every sensor: dict name -> array (s)."""
        d = self.duration
        out = {}
        for L in self.robot.lidars:
            st = 1.0 / L.rate
            out[L.name] = np.arange(L.phase, d - st + 1e-9, st)
        for C in self.robot.cameras:
            out[C.name] = np.arange(C.phase, d + 1e-9, 1.0 / C.rate)
        for S in self.robot.sonars:
            out[S.name] = np.arange(S.phase, d + 1e-9, 1.0 / S.rate)
        out["odom"] = np.arange(0.0, d + 1e-9, 1.0 / self.robot.odom.rate)
        return out

    def simulate(self, output, progress=True, compression="lz4"):
        """Write the scenario as a bag; returns a dict of figures (seconds, bytes, counts).

        Topics: see TOPICS.  Messages are stamped in sim time (start_time + ...);
        each message's bag time is when it would be published (a scan after its
        last beam plus latency, an image after its latency), so playback is causal.
        """
        import os
        import rosbag
        from ..ros import bagio
        from nav_msgs.msg import Odometry
        from sensor_msgs.msg import CameraInfo
        from std_msgs.msg import String

        t_wall = time.time()
        rng = np.random.default_rng(self.seed)
        sched = self.schedule()
        t0 = self.start_time
        odom_rel = sched["odom"]
        ox, oy, oyaw, ov, ow = simulate_odometry(self._traj, odom_rel, self.robot.odom, rng)

        events = []
        for L in self.robot.lidars:
            for k, s in enumerate(sched[L.name]):
                events.append((s + 1.0 / L.rate + L.latency, L.name, k))
        for C in self.robot.cameras:
            for k, s in enumerate(sched[C.name]):
                events.append((s + C.latency, C.name, k))
        for S in self.robot.sonars:
            for k, s in enumerate(sched[S.name]):
                events.append((s + S.latency, S.name, k))
        for k, s in enumerate(odom_rel):
            events.append((s, "odom", k))
        events.sort(key=lambda e: (e[0], e[1]))

        lidars = {L.name: L for L in self.robot.lidars}
        cams = {C.name: C for C in self.robot.cameras}
        sonars = {S.name: S for S in self.robot.sonars}
        body = {L.name: self.body_ranges(L) for L in self.robot.lidars}
        rays = {C.name: raycast.pixel_rays(C.width, C.height, *C.intrinsics()) for C in self.robot.cameras}
        counts = {}
        bar = None
        if progress:
            from tqdm import tqdm
            bar = tqdm(total=len(events), unit="msg", desc="simulating")
        os.makedirs(os.path.dirname(os.path.abspath(output)), exist_ok=True)
        with rosbag.Bag(output, "w", compression=compression) as bag:
            bagio.write_latched(bag, TOPICS["scenario"], String(data=self.to_yaml()), t0)
            bagio.write_latched(bag, TOPICS["tf_static"], bagio.tf_message(self.static_transforms(t0)), t0)
            for bag_rel, name, k in events:
                bt = bagio.stamp(t0 + bag_rel)
                if name == "odom":
                    s = t0 + odom_rel[k]
                    bag.write(TOPICS["tf"], self.tf_msg(s, (ox[k], oy[k], oyaw[k]), odom_rel[k]), bt)
                    bag.write(TOPICS["odom"], self._odom_msg(Odometry, s, FRAMES["odom"],
                                                             (ox[k], oy[k], oyaw[k]), (ov[k], ow[k]), True), bt)
                    gt = self.true_pose(s)
                    bag.write(TOPICS["ground_truth"], self._odom_msg(Odometry, s, FRAMES["map"], gt,
                                                                     self.true_velocity(s), False), bt)
                elif name in lidars:
                    L = lidars[name]
                    rel = sched[name][k]
                    ranges = self.lidar_scan(L, rel, rng, body[name])
                    bag.write(TOPICS[name], self.lidar_msg(L, t0 + rel, ranges), bt)
                elif name in sonars:
                    S = sonars[name]
                    rel = sched[name][k]
                    bag.write(TOPICS[name], self.sonar_msg(S, t0 + rel, self.sonar_range(S, rel, rng)), bt)
                else:
                    C = cams[name]
                    rel = sched[name][k]
                    img = self.depth_msg(C, t0 + rel, self.depth_image(C, rel, rng, rays[name]))
                    bag.write(TOPICS[name + "_depth"], img, bt)
                    bag.write(TOPICS[name + "_info"], self.camera_info(C, img.header, CameraInfo), bt)
                counts[name] = counts.get(name, 0) + 1
                if bar is not None:
                    bar.update(1)
        if bar is not None:
            bar.close()
        return {"seconds": time.time() - t_wall, "bytes": os.path.getsize(output),
                "duration": self.duration, "messages": counts}

    # ----- messages (the bag's and the closed loop's) ---------------------------------------
    def tf_msg(self, t, odom_pose, rel):
        """/tf at ROS time t: odom -> base_link at ``odom_pose`` (x, y, yaw), the camera servos
        and the arm's joints at relative time rel."""
        from ..ros import bagio
        tfs = [bagio.transform(t, FRAMES["odom"], FRAMES["base"], (odom_pose[0], odom_pose[1], 0.0),
                               quat_from_yaw(odom_pose[2]))]
        for C in self.robot.cameras:
            tfs.append(bagio.transform(t, FRAMES["base"], C.tilt_frame, C.xyz,
                                       quat_from_matrix(C.tilt_rotation(rel))))
        for link, parent, xyz, yaw in self.robot.arm.joint_transforms(rel):
            tfs.append(bagio.transform(t, parent, link, xyz, quat_from_yaw(yaw)))
        return bagio.tf_message(tfs)

    def lidar_msg(self, lidar, t, ranges, swept=True):
        """sensor_msgs/LaserScan of ``lidar`` stamped t (beams swept over the scan time, or
        all measured at t: ``swept`` False)."""
        from sensor_msgs.msg import LaserScan
        m = stamped(LaserScan(), t, lidar.frame)
        angles, inc = self._lidar_angles(lidar)
        m.angle_min, m.angle_max, m.angle_increment = float(angles[0]), float(angles[-1]), inc
        m.scan_time = 1.0 / lidar.rate
        m.time_increment = m.scan_time / lidar.beams if swept else 0.0
        m.range_min, m.range_max = lidar.range_min, lidar.range_max
        m.ranges = np.asarray(ranges).astype(np.float32).tolist()
        return m

    @staticmethod
    def sonar_msg(sonar, t, reading):
        """sensor_msgs/Range of ``sonar`` stamped t."""
        from sensor_msgs.msg import Range
        m = stamped(Range(), t, sonar.frame)
        m.radiation_type = Range.ULTRASOUND
        m.field_of_view = sonar.field_of_view
        m.min_range, m.max_range = sonar.min_range, sonar.max_range
        m.range = reading
        return m

    @staticmethod
    def depth_msg(cam, t, depth):
        """sensor_msgs/Image (16UC1, mm, 0 = no depth) of a depth frame (metres) stamped t."""
        from sensor_msgs.msg import Image
        img = stamped(Image(), t, cam.optical_frame)
        img.height, img.width = cam.height, cam.width
        img.encoding = "16UC1"
        img.is_bigendian = 0
        img.step = 2 * cam.width
        img.data = np.round(depth * 1000.0).astype("<u2").tobytes()
        return img

    @staticmethod
    def camera_info(cam, header, cls):
        fx, fy, cx, cy = cam.intrinsics()
        m = cls()
        m.header = header
        m.height, m.width = cam.height, cam.width
        m.distortion_model = "plumb_bob"
        m.D = [0.0] * 5
        m.K = [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]
        m.R = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        m.P = [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0]
        return m

    def _odom_msg(self, cls, t, frame, pose, twist, noisy):
        from ..ros import bagio
        m = cls()
        m.header.stamp = bagio.stamp(t)
        m.header.frame_id = frame
        m.child_frame_id = FRAMES["base"]
        p = m.pose.pose
        p.position.x, p.position.y = float(pose[0]), float(pose[1])
        q = quat_from_yaw(float(pose[2]))
        p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w = q
        # twist: (v, w) of the unicycle route, or (vx, vy, w) of the omnidirectional closed loop.
        m.twist.twist.linear.x, m.twist.twist.angular.z = float(twist[0]), float(twist[-1])
        if len(twist) == 3:
            m.twist.twist.linear.y = float(twist[1])
        if noisy:
            cov = [0.0] * 36
            cov[0] = cov[7] = 0.01
            cov[14] = cov[21] = cov[28] = 1e6  # not measured (planar robot)
            cov[35] = 0.02
            m.pose.covariance = cov
            tw = [0.0] * 36
            tw[0], tw[35] = 0.0004, 0.001
            tw[7] = tw[14] = tw[21] = tw[28] = 1e6
            m.twist.covariance = tw
        return m

    def static_transforms(self, t):
        """Fixed mounts: base_link -> lidar and sonar frames, tilt links -> optical frames."""
        from ..ros import bagio
        out = [bagio.transform(t, FRAMES["base"], L.frame, L.xyz, quat_from_yaw(L.yaw))
               for L in self.robot.lidars + self.robot.sonars]
        out += [bagio.transform(t, C.tilt_frame, C.optical_frame, C.optical_offset,
                                quat_from_matrix(R_LINK_OPTICAL)) for C in self.robot.cameras]
        return out
