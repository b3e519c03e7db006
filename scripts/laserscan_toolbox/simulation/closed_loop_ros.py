"""The closed loop on ROS (thin glue over ``closed_loop``): owns /clock, publishes every sensor as
the scenario's bag does (same topics, types and frames: launch/pipeline.launch runs on it
unchanged), drives the robot from the navigator's commands, waits for the navigator's answer to
every control step (lockstep: NAV_CONTRACT of issue 19) and writes the run record.

Per simulation step t (1 / odom_rate): /clock = t; /tf (map -> odom: perfect localization;
odom -> base_link from the noisy odometry; camera tilt links; arm joints), /odom,
/ground_truth/odom; at sensor times the lidars, sonars and cameras stamped t (depth image +
camera_info and/or the organized cloud /camera_X/depth/points); at the goal step the goal on
move_base_simple/goal (map).  At a control step t_k, with a step topic: /clock does not move past
t_k until the navigator's ``~step`` (geometry_msgs/TwistStamped) stamped t_k came, and its twist
drives the base over [t_k, t_k+1).  Without one: free running at wall pace from ``cmd_vel``.
"""
import math
import sys
import threading
import time


from .closed_loop import ClosedLoopSim, depth_points
from .scenario import FRAMES, TOPICS, stamped

DEPTH_OUTPUTS = ("image", "cloud", "both")
GOAL_TOPIC = "move_base_simple/goal"
#: The navigator's ~state values after which it does not move again (the run ends there).
FINAL_STATES = ("reached", "blocked")
#: Control steps in a row without the navigator's answer after which the run is abandoned.
MAX_MISSED_STEPS = 3


class _Answers:
    """The navigator's answers (~step stamps -> twist), its state, the latest cmd_vel."""

    def __init__(self):
        self.cond = threading.Condition()
        self.steps = {}
        self.state = None
        self.cmd_vel = (0.0, 0.0, 0.0)

    def on_step(self, msg):
        with self.cond:
            t = msg.twist
            self.steps[msg.header.stamp.to_nsec()] = (t.linear.x, t.linear.y, t.angular.z)
            self.cond.notify_all()

    def on_state(self, msg):
        with self.cond:
            self.state = msg.data
            self.cond.notify_all()

    def on_cmd_vel(self, msg):
        with self.cond:
            self.cmd_vel = (msg.linear.x, msg.linear.y, msg.angular.z)

    def wait(self, predicate, timeout):
        """Wait (wall seconds) until predicate() holds; returns whether it does."""
        import rospy
        end = time.monotonic() + timeout
        with self.cond:
            while not predicate():
                left = end - time.monotonic()
                if left <= 0 or rospy.is_shutdown():
                    return predicate()
                self.cond.wait(min(left, 0.5))
            return True

    def step_at(self, t_ns):
        """The twist answered for step t_ns (an answer within 1 us counts, as the navigator's
        grid does), or None."""
        for stamp, twist in self.steps.items():
            if abs(stamp - t_ns) <= 1000:
                return twist
        return None


def _cloud_msg(cam, t, depth, rays):
    from sensor_msgs.msg import PointCloud2, PointField
    pts = depth_points(depth, rays)
    m = stamped(PointCloud2(), t, cam.optical_frame)
    m.height, m.width = depth.shape
    m.fields = [PointField(name=n, offset=4 * i, datatype=PointField.FLOAT32, count=1)
                for i, n in enumerate("xyz")]
    m.is_bigendian = False
    m.point_step, m.row_step = 12, 12 * depth.shape[1]
    m.is_dense = False
    m.data = pts.astype("<f4").tobytes()
    return m


def _map_to_odom(truth, odom):
    """(x, y, yaw) of odom in map, so that map -> odom -> base_link is the true pose."""
    tx, ty, tyaw = truth
    ox, oy, oyaw = odom
    yaw = tyaw - oyaw
    c, s = math.cos(yaw), math.sin(yaw)
    return tx - (c * ox - s * oy), ty - (s * ox + c * oy), yaw


def run(config, depth_output="image", step_topic=None, state_topic=None, wait_for=(),
        lockstep_timeout=30.0, state_timeout=5.0, start_timeout=60.0, log=None):
    """Run one closed-loop episode on the ROS master of ROS_MASTER_URI; returns its RunRecord.

    wait_for: topics that must have a subscriber before the clock starts (the pipeline's or the
    navigator's inputs), beside the step topic's publisher.  log: where warnings go (stderr).
    RuntimeError: the navigator did not come, or stopped answering (MAX_MISSED_STEPS)."""
    import rospy
    from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
    from nav_msgs.msg import Odometry
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import CameraInfo, Image, LaserScan, PointCloud2, Range
    from std_msgs.msg import String
    from tf2_msgs.msg import TFMessage
    from ..ros import bagio
    from .robot import quat_from_yaw

    if log is None:
        def log(text):
            print(text, file=sys.stderr, flush=True)
    if depth_output not in DEPTH_OUTPUTS:
        raise ValueError(f"depth_output: {depth_output!r} is not one of {', '.join(DEPTH_OUTPUTS)}")
    sim = ClosedLoopSim(config)
    if step_topic and sim.control_every % sim.sensor_every:
        # The navigator steps at t_k once it has data stamped t_k: every control step needs sensors.
        raise ValueError(f"sensor_rate: {config.sensor_rate} Hz is not a multiple of control_rate "
                         f"{config.control_rate} Hz (lockstep needs data at every control step)")
    sc, robot = sim.scenario, sim.robot
    rospy.set_param("/use_sim_time", True)
    rospy.init_node("closed_loop_simulator", disable_signals=True)
    answers = _Answers()

    def pub(topic, cls, latch=False):
        return rospy.Publisher(topic, cls, queue_size=100, latch=latch)
    clock = pub("/clock", Clock)
    tf, tf_static = pub(TOPICS["tf"], TFMessage), pub(TOPICS["tf_static"], TFMessage, latch=True)
    odom, truth = pub(TOPICS["odom"], Odometry), pub(TOPICS["ground_truth"], Odometry)
    goal = pub(GOAL_TOPIC, PoseStamped, latch=True)
    lidars = {L.name: pub(TOPICS[L.name], LaserScan) for L in robot.lidars}
    sonars = {S.name: pub(TOPICS[S.name], Range) for S in robot.sonars}
    images = {C.name: (pub(TOPICS[C.name + "_depth"], Image), pub(TOPICS[C.name + "_info"], CameraInfo))
              for C in robot.cameras} if depth_output != "cloud" else {}
    clouds = {C.name: pub(TOPICS[C.name + "_points"], PointCloud2)
              for C in robot.cameras} if depth_output != "image" else {}
    subs = [rospy.Subscriber("cmd_vel", Twist, answers.on_cmd_vel)]
    if step_topic:
        subs.append(rospy.Subscriber(step_topic, TwistStamped, answers.on_step, queue_size=100))
    if state_topic:
        subs.append(rospy.Subscriber(state_topic, String, answers.on_state))

    def stamp(t_ns):
        return rospy.Time(nsecs=t_ns)

    tf_static.publish(bagio.tf_message(sc.static_transforms(stamp(sim.t_ns))))
    # Start only once the navigator (and what the caller names) is connected.
    end = time.monotonic() + start_timeout
    publishers = {p.resolved_name: p for p in [clock, tf, odom, goal] + list(lidars.values())
                  + list(sonars.values()) + [i for pair in images.values() for i in pair]
                  + list(clouds.values())}
    for topic in wait_for:
        p = publishers.get(rospy.resolve_name(topic))
        if p is None:
            raise ValueError(f"wait_for: {topic} is not a topic the simulator publishes")
        while p.get_num_connections() == 0 and time.monotonic() < end and not rospy.is_shutdown():
            time.sleep(0.05)
        if p.get_num_connections() == 0:
            raise RuntimeError(f"no subscriber on {topic} within {start_timeout} s")
    if step_topic:
        while subs[1].get_num_connections() == 0 and time.monotonic() < end and not rospy.is_shutdown():
            time.sleep(0.05)
        if subs[1].get_num_connections() == 0:
            raise RuntimeError(f"no publisher of {step_topic} within {start_timeout} s")

    wall0 = time.monotonic()
    missed = 0  # control steps in a row without an answer
    while not sim.done and not rospy.is_shutdown():
        frame = sim.sense()
        t = stamp(frame.t_ns)
        if frame.goal is not None:
            # Stamped at the previous step, whose tf (map -> odom) the navigator already has.
            g = stamped(PoseStamped(), stamp(frame.t_ns - sim.step_ns), FRAMES["map"])
            g.pose.position.x, g.pose.position.y = frame.goal[:2]
            (g.pose.orientation.x, g.pose.orientation.y, g.pose.orientation.z,
             g.pose.orientation.w) = quat_from_yaw(frame.goal[2])
            # Before the step's clock and data, so that the goal's first control step has it.
            goal.publish(g)
            if state_topic and not answers.wait(lambda: answers.state not in (None, "idle"), state_timeout):
                log(f"closed loop: {state_topic} still {answers.state!r} {state_timeout} s after the goal")
        clock.publish(Clock(clock=t))
        tfm = sc.tf_msg(t, frame.odom, frame.rel)
        mx, my, myaw = _map_to_odom(frame.truth, frame.odom)
        tfm.transforms.insert(0, bagio.transform(t, FRAMES["map"], FRAMES["odom"], (mx, my, 0.0),
                                                 quat_from_yaw(myaw)))
        tf.publish(tfm)
        odom.publish(sc._odom_msg(Odometry, t, FRAMES["odom"], frame.odom, frame.odom_twist, True))
        truth.publish(sc._odom_msg(Odometry, t, FRAMES["map"], frame.truth, frame.truth_twist, False))
        for L in robot.lidars:
            if L.name in frame.lidars:
                lidars[L.name].publish(sc.lidar_msg(L, t, frame.lidars[L.name], swept=False))
        for S in robot.sonars:
            if S.name in frame.sonars:
                sonars[S.name].publish(sc.sonar_msg(S, t, frame.sonars[S.name]))
        for C in robot.cameras:
            if C.name not in frame.depth:
                continue
            depth = frame.depth[C.name]
            if C.name in images:
                img = sc.depth_msg(C, t, depth)
                images[C.name][0].publish(img)
                images[C.name][1].publish(sc.camera_info(C, img.header, CameraInfo))
            if C.name in clouds:
                clouds[C.name].publish(_cloud_msg(C, t, depth, sim.rays[C.name]))
        if frame.control:
            if step_topic:
                got = answers.wait(lambda: answers.step_at(frame.t_ns) is not None, lockstep_timeout)
                if got:
                    sim.command(*answers.step_at(frame.t_ns))
                    with answers.cond:  # answers of past steps are not needed again
                        answers.steps = {s: v for s, v in answers.steps.items() if s > frame.t_ns + 1000}
                    missed = 0
                else:
                    sim.run_record.lockstep_timeouts += 1
                    missed += 1
                    log(f"closed loop: no {step_topic} for t = {frame.t:.3f} within {lockstep_timeout} "
                        "s wall; the command is held (the run is no longer repeatable)")
                    # A navigator that is gone or stuck would hold the run for hours: give up.
                    if subs[1].get_num_connections() == 0 or missed >= MAX_MISSED_STEPS:
                        raise RuntimeError(f"the navigator stopped answering {step_topic} (t = "
                                           f"{frame.t:.3f}, {missed} steps in a row, publishers "
                                           f"{subs[1].get_num_connections()})")
            else:
                sim.command(*answers.cmd_vel)
        if not step_topic:  # free running: simulated time at wall pace
            time.sleep(max(0.0, wall0 + frame.rel - time.monotonic()))
        if frame.control and sim.k > sim.goal_step and answers.state in FINAL_STATES:
            # The navigator has stopped for good: its robot stands still until the timeout. (Its
            # state comes apart from ~step: the run may end one control step later or sooner.)
            sim.end(answers.state)
            break
        sim.advance()
    clock.publish(Clock(clock=stamp(sim.t_ns)))
    rec = sim.record()
    for s in subs:
        s.unregister()
    return rec
