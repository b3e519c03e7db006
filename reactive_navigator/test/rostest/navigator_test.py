#!/usr/bin/python3
"""rostest node shared by navigator_node.test and navigator_nodelet.test.

Drives the navigator in lockstep on simulated time, as the closed-loop simulator does: for each
step time t it publishes /clock = t, the robot's tf at t, a LaserScan from a lidar 0.2 m above
base_link and a PointCloud2 from a camera 1 m up looking straight down, both stamped t, and waits
for ~step stamped t. Checks: a goal in gives cmd_vel towards it (and ~step carries the same
command) and ~plan the planner's path to it, a wall in the scan stops the forward motion, and the
cloud's points go through tf (only those the camera sees inside the height band count as
obstacles, /diagnostics says how many), read right from a float64 cloud with padded rows; a
malformed cloud or scan is dropped with a warning naming its defect, and the node runs on; a wall the
lidar saw and then sees gone (its beams return nothing) leaves the planner's grid (the scan's
origin comes through tf: its rays clear), while the camera's cells stay."""
import math
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, TransformStamped, Twist, TwistStamped
from nav_msgs.msg import Path
from rosgraph_msgs.msg import Clock, Log
from sensor_msgs.msg import LaserScan, PointCloud2, PointField
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

BEAMS = 360
STEP = 0.1  # s, the navigator's control_rate is 10 Hz
# The camera cloud: 40 points 0.5 m below the camera (0.5 m above the floor: obstacles) and 60
# points 0.98 m below it (0.02 m above the floor, under the height band's 0.05 m).
IN_BAND, BELOW_BAND = 40, 60


def transform(parent, child, t, x, y, z, qx=0.0, qy=0.0, qz=0.0, qw=1.0):
    m = TransformStamped()
    m.header.stamp = t
    m.header.frame_id = parent
    m.child_frame_id = child
    m.transform.translation.x, m.transform.translation.y, m.transform.translation.z = x, y, z
    m.transform.rotation.x, m.transform.rotation.y, m.transform.rotation.z, m.transform.rotation.w = qx, qy, qz, qw
    return m


def camera_cloud(stamp, in_band=IN_BAND, dtype=np.float32, rows=1, row_padding=0):
    """`in_band` points 0.5 m below the camera, the others (of 100) 0.98 m below, as `rows` rows
    of x, y, z of `dtype`, each row followed by `row_padding` bytes that, read as a point, would be
    one in the band (0.5 m below the camera)."""
    depth = np.concatenate([np.full(in_band, 0.5), np.full(IN_BAND + BELOW_BAND - in_band, 0.98)])
    xs = np.linspace(0.5, 1.5, depth.size)
    # Camera y = 1.5 m is robot y = -1.5 m (the camera is upside down): beside the way.
    points = np.stack([xs, np.full_like(xs, 1.5), depth], axis=1).astype(dtype).reshape(rows, -1, 3)
    size = np.dtype(dtype).itemsize
    filler = np.full(row_padding // size, 0.5, dtype=dtype).tobytes().ljust(row_padding, b'\0')
    m = PointCloud2()
    m.header.stamp = stamp
    m.header.frame_id = 'camera'
    m.height, m.width = rows, points.shape[1]
    datatype = PointField.FLOAT32 if size == 4 else PointField.FLOAT64
    m.fields = [PointField(n, size * i, datatype, 1) for i, n in enumerate('xyz')]
    m.point_step = 3 * size
    m.row_step = m.point_step * m.width + row_padding
    m.is_dense = True
    m.data = b''.join(row.tobytes() + filler for row in points)
    return m


def lidar_scan(stamp, wall_x=None, wall_half_width=None):
    a = -math.pi + 2 * math.pi / BEAMS * np.arange(BEAMS)
    ranges = np.full(BEAMS, np.inf, dtype=np.float32)
    if wall_x is not None:
        ahead = np.cos(a) > 0.1
        if wall_half_width is not None:
            ahead &= np.abs(np.tan(a)) * wall_x <= wall_half_width
        ranges[ahead] = (wall_x / np.cos(a[ahead])).astype(np.float32)
        ranges[ranges > 30.0] = np.inf
    m = LaserScan()
    m.header.stamp = stamp
    m.header.frame_id = 'lidar'
    m.angle_min, m.angle_increment, m.angle_max = -math.pi, 2 * math.pi / BEAMS, math.pi - 2 * math.pi / BEAMS
    m.range_min, m.range_max = 0.05, 30.0
    m.ranges = ranges.tolist()
    return m


class NavigatorTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('navigator_test')
        cls.cond = threading.Condition()
        cls.steps, cls.cmds, cls.states, cls.diagnostics, cls.logs, cls.plans = {}, [], [], [], [], []
        cls.clock = rospy.Publisher('/clock', Clock, queue_size=10)
        cls.tf = rospy.Publisher('/tf', TFMessage, queue_size=10)
        cls.tf_static = rospy.Publisher('/tf_static', TFMessage, queue_size=1, latch=True)
        cls.scan = rospy.Publisher('scan', LaserScan, queue_size=10)
        cls.cloud = rospy.Publisher('cloud', PointCloud2, queue_size=10)
        cls.goal = rospy.Publisher('move_base_simple/goal', PoseStamped, queue_size=1, latch=True)
        rospy.Subscriber('navigator/step', TwistStamped, cls.keep('steps'))
        rospy.Subscriber('cmd_vel', Twist, cls.keep('cmds'))
        rospy.Subscriber('navigator/state', String, cls.keep('states'))
        rospy.Subscriber('/diagnostics', DiagnosticArray, cls.keep('diagnostics'))
        rospy.Subscriber('navigator/plan', Path, cls.keep('plans'))
        rospy.Subscriber('/rosout', Log, cls.keep('logs'))
        cls.t = 1.0
        cls.publish_clock(cls.t)
        # The camera 1 m above base_link, turned 180 degrees about x: its z axis points down.
        cls.tf_static.publish(TFMessage([
            transform('base_link', 'lidar', rospy.Time(0), 0.0, 0.0, 0.2),
            transform('base_link', 'camera', rospy.Time(0), 0.3, 0.0, 1.0, qx=1.0, qw=0.0)]))
        for pub in (cls.scan, cls.cloud, cls.tf, cls.goal):
            cls.wait_for(lambda p=pub: p.get_num_connections() > 0, 'the navigator to subscribe')

    @classmethod
    def keep(cls, name):
        def callback(m):
            with cls.cond:
                if name == 'steps':
                    cls.steps[round(m.header.stamp.to_sec() / STEP)] = m
                else:
                    getattr(cls, name).append(m)
                cls.cond.notify_all()
        return callback

    @classmethod
    def wait_for(cls, condition, what, timeout=20.0):
        with cls.cond:
            ok = cls.cond.wait_for(condition, timeout)
        assert ok, 'timed out waiting for ' + what

    @classmethod
    def publish_clock(cls, t):
        m = Clock()
        m.clock = rospy.Time.from_sec(t)
        cls.clock.publish(m)

    def step(self, wall_x=None, clouds=(camera_cloud,), wall_half_width=None):
        """One lockstep step at the next grid time; returns the navigator's command for it. The
        camera publishes each of `clouds` (functions of the stamp) in turn."""
        cls = type(self)
        cls.t = round(cls.t + STEP, 6)
        stamp = rospy.Time.from_sec(cls.t)
        cls.publish_clock(cls.t)
        cls.tf.publish(TFMessage([transform('odom', 'base_link', stamp, 0.0, 0.0, 0.0)]))
        cls.scan.publish(lidar_scan(stamp, wall_x, wall_half_width))
        for cloud in clouds:
            cls.cloud.publish(cloud(stamp))
        k = round(cls.t / STEP)
        cls.wait_for(lambda: k in cls.steps, 'the step at %.1f s' % cls.t)
        return cls.steps[k]

    def send_goal(self, x, y):
        m = PoseStamped()
        m.header.frame_id = 'odom'
        m.pose.position.x, m.pose.position.y = x, y
        m.pose.orientation.w = 1.0
        self.goal.publish(m)

    def test_a_goal_in_gives_cmd_vel_towards_it(self):
        self.send_goal(3.0, 0.0)
        for _ in range(100):  # the goal arrives while steps run
            self.step()
            with self.cond:
                if self.states and self.states[-1].data == 'navigating':
                    break
        self.assertEqual(self.states[-1].data, 'navigating')
        for _ in range(5):
            step = self.step()
        self.assertGreater(step.twist.linear.x, 0.1)
        self.assertLess(abs(step.twist.linear.y), 0.5 * step.twist.linear.x)
        # cmd_vel carries the same command as ~step.
        self.wait_for(lambda: self.cmds and self.cmds[-1].linear.x == step.twist.linear.x, 'cmd_vel')
        # ~plan: the planner's path in the odometry frame, from the robot to the goal.
        self.wait_for(lambda: self.plans and self.plans[-1].poses, '~plan')
        plan = self.plans[-1]
        self.assertEqual(plan.header.frame_id, 'odom')
        first, last = plan.poses[0].pose.position, plan.poses[-1].pose.position
        self.assertLess(math.hypot(first.x, first.y), 0.2)
        self.assertLess(math.hypot(last.x - 3.0, last.y), 0.2)

    def test_b_a_wall_in_the_scan_stops_the_forward_motion(self):
        self.send_goal(3.0, 0.0)
        for _ in range(10):
            step = self.step(wall_x=0.75)
        for _ in range(5):
            step = self.step(wall_x=0.75)
            self.assertLess(step.twist.linear.x, 0.05)

    def reported(self, key):
        """The values of `key` in the diagnostics received since they were last cleared (call
        with self.cond held)."""
        return [v.value for a in self.diagnostics for st in a.status for v in st.values if v.key == key]

    def step_until(self, found, **scene):
        """Steps with `scene` (step()'s arguments) until found() (called with self.cond held)
        returns something true, for at most 20 s (the diagnostics come every wall second);
        returns its last result."""
        deadline = time.monotonic() + 20.0
        result = None
        while time.monotonic() < deadline:
            self.step(**scene)
            with self.cond:
                result = found()
            if result:
                break
        return result

    def obstacle_points_reported(self, expected, clouds=(camera_cloud,)):
        """Steps with no wall (the scan adds no point) until a diagnostics report covers only them;
        asserts it counts `expected` obstacle points per step."""
        key = 'obstacle points per step'
        with self.cond:
            del self.diagnostics[:]
        found = self.step_until(lambda: str(expected) in self.reported(key), clouds=clouds)
        with self.cond:
            seen = self.reported(key)
        self.assertTrue(found, 'no report of %d obstacle points per step: %s' % (expected, seen))

    def test_c_cloud_points_go_through_tf_and_the_height_band(self):
        self.obstacle_points_reported(IN_BAND)

    def test_d_a_float64_cloud_with_padded_rows_gives_its_points(self):
        # 30 in the band, not the other clouds' 40: the report is this cloud's.
        self.obstacle_points_reported(30, clouds=(
            lambda stamp: camera_cloud(stamp, in_band=30, dtype=np.float64, rows=4, row_padding=24),))

    def test_e_a_malformed_cloud_is_dropped_with_its_reason_and_the_node_runs_on(self):
        def overlapping_rows(stamp):
            m = camera_cloud(stamp, rows=2)
            m.row_step -= 1
            return m
        with self.cond:
            del self.logs[:]
        # The malformed cloud, then a good one with the same stamp: the step runs on the good one.
        self.step(clouds=(overlapping_rows, camera_cloud))

        def warned():
            return any(m.level == Log.WARN and "dropped a malformed cloud on 'cloud'" in m.msg and
                       'row_step 599 is smaller than width*point_step 600' in m.msg for m in self.logs)
        self.wait_for(warned, 'the warning about the malformed cloud')
        self.step()
        self.obstacle_points_reported(IN_BAND, clouds=(overlapping_rows, camera_cloud))

    def test_e_a_malformed_scan_is_dropped_with_its_reason_and_the_node_runs_on(self):
        # The merger's check (laserscan_common::scanFault): 300 ranges where the angles give 360.
        bad = lidar_scan(rospy.Time.from_sec(round(type(self).t + STEP, 6)))
        bad.ranges = bad.ranges[:300]
        with self.cond:
            del self.logs[:]
        type(self).scan.publish(bad)
        self.step()  # the good scan of the same stamp: the step runs on it

        def warned():
            return any(m.level == Log.WARN and "dropped a malformed scan on 'scan'" in m.msg and
                       'ranges length does not match' in m.msg for m in self.logs)
        self.wait_for(warned, 'the warning about the malformed scan')
        self.step()

    def planner_cells(self, **scene):
        """Steps with `scene` (step()'s arguments) until a diagnostics report made after the first
        of them arrives; returns its planner obstacle cells."""
        for _ in range(3):
            self.step(**scene)
        with self.cond:
            del self.diagnostics[:]
        cells = self.step_until(lambda: self.reported('planner obstacle cells'), **scene)
        if not cells:
            self.fail('no diagnostics report of the planner obstacle cells')
        return int(cells[0])

    def test_f_a_wall_seen_gone_leaves_the_planners_grid_and_the_cameras_cells_stay(self):
        camera_only = self.planner_cells()
        self.assertGreater(camera_only, 0)  # the cloud's points in the band
        with_wall = self.planner_cells(wall_x=2.0, wall_half_width=1.0)
        self.assertGreaterEqual(with_wall, camera_only + 15)  # 2 m of wall in 0.1 m cells
        # The lidar's beams now return nothing (+Inf): they clear its wall, not the camera's cells.
        self.assertEqual(self.planner_cells(), camera_only)


if __name__ == '__main__':
    rostest.rosrun('reactive_navigator', 'navigator_test', NavigatorTest)
