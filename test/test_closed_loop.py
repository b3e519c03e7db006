"""The closed-loop simulator's core (ROS-free): the base integrates its commands within its limits,
collisions of the robot's shape are found against analytic shapes, the same seed gives the same
run, and a run record survives JSON."""
import math

import numpy as np
import pytest

from laserscan_toolbox.simulation import closed_loop as cl
from laserscan_toolbox.simulation.robot import Robot
from laserscan_toolbox.simulation.world import Box, Cylinder, Person, World


# ----- kinematics ---------------------------------------------------------------------------------
def test_a_constant_command_within_limits_is_integrated_exactly():
    robot = Robot()
    base = cl.OmniBase(robot, 1.0, 2.0, 0.3)
    dt = 0.02
    # Below the acceleration limit every step reaches the command: 0.3 m/s sideways, 0.2 rad/s.
    base.acc_v, base.acc_w = 100.0, 100.0
    for _ in range(100):
        base.step((0.0, 0.3, 0.2), dt)
    # Constant body velocity (0, v) and yaw rate w: an arc of radius v / w around a fixed centre.
    v, w, T = 0.3, 0.2, 2.0
    yaw_end = 0.3 + w * T
    x = 1.0 + v / w * (math.cos(yaw_end) - math.cos(0.3))
    y = 2.0 + v / w * (math.sin(yaw_end) - math.sin(0.3))
    assert base.yaw == pytest.approx(yaw_end, abs=1e-12)
    assert (base.x, base.y) == pytest.approx((x, y), abs=1e-5)


def test_velocity_and_acceleration_limits_hold():
    robot = Robot()
    base = cl.OmniBase(robot, 0.0, 0.0, 0.0)
    dt = 0.02
    speeds = []
    for _ in range(200):
        base.step((2.0, 2.0, 5.0), dt)  # far beyond every limit
        speeds.append((math.hypot(base.vx, base.vy), base.w))
    speeds = np.array(speeds)
    # Accelerating at acc_v: 0.4 m/s^2 * 0.02 s per step, then held at v_max along (1, 1).
    assert speeds[0, 0] == pytest.approx(robot.acc_v * dt)
    assert np.all(np.diff(speeds[:, 0]) <= robot.acc_v * dt + 1e-12)
    assert speeds[-1, 0] == pytest.approx(robot.v_max)
    assert base.vx == pytest.approx(base.vy)
    assert speeds[-1, 1] == pytest.approx(robot.w_max)
    assert speeds[0, 1] == pytest.approx(robot.acc_w * dt)
    # Braking to a stop obeys the same limit.
    v0 = math.hypot(base.vx, base.vy)
    base.step((0.0, 0.0, 0.0), dt)
    assert math.hypot(base.vx, base.vy) == pytest.approx(v0 - robot.acc_v * dt)


# ----- collisions against analytic shapes ---------------------------------------------------------
def test_rectangle_distances_are_analytic():
    z = np.zeros(1)
    one = np.array([[1.0, 1.0]])
    # Axis-aligned squares of half size 1, 3 m apart between their centres: 1 m gap.
    assert cl.rect_rect_distance(np.array([[0.0, 0.0]]), one, z, np.array([[3.0, 0.0]]), one, z)[0] == \
        pytest.approx(1.0)
    # Turned by 45 degrees, the second one's corner points at the first: gap 3 - 1 - sqrt(2).
    assert cl.rect_rect_distance(np.array([[0.0, 0.0]]), one, z, np.array([[3.0, 0.0]]), one,
                                 np.array([math.pi / 4]))[0] == pytest.approx(2.0 - math.sqrt(2.0))
    # Crossing bars (a plus sign): no corner inside the other, they still overlap.
    assert cl.rect_rect_distance(np.array([[0.0, 0.0]]), np.array([[2.0, 0.1]]), z,
                                 np.array([[0.0, 0.0]]), np.array([[0.1, 2.0]]), z)[0] == 0.0
    # A circle 0.5 m beyond a corner diagonally.
    d = cl.rect_circle_distance(np.array([0.0, 0.0]), np.array([1.0, 1.0]), 0.0,
                                np.array([2.0, 2.0]), 0.2)
    assert d == pytest.approx(math.sqrt(2.0) - 0.2)


def _monitor(**world):
    robot = cl.closed_loop_robot(cl.ClosedLoopConfig())
    return cl.CollisionMonitor(World(bounds=(0, 10, 0, 10), ceiling=3.0, **world), robot), robot


def _parts_at(robot, x, y, yaw):
    sim = cl.ClosedLoopSim.__new__(cl.ClosedLoopSim)  # parts() needs only the robot and the pose
    sim.robot, sim.k, sim.step_ns = robot, 0, 20_000_000
    sim.base = cl.OmniBase(robot, x, y, yaw)
    return sim.parts()


def test_a_box_ahead_is_hit_when_reached_and_clearance_is_its_distance():
    mon, robot = _monitor(boxes=[Box("crate", (3.0, 5.0, 0.4), (0.8, 0.8, 0.8))])
    # The body's front at x + 0.37; the crate's face at 2.6.
    assert mon.check(_parts_at(robot, 2.0, 5.0, 0.0), 0.0) == pytest.approx(2.6 - 2.37)
    assert mon.onsets == []
    assert mon.check(_parts_at(robot, 2.24, 5.0, 0.0), 0.1) == 0.0
    assert mon.onsets == [("crate", "2d", 0.1, 0.0)]
    mon.check(_parts_at(robot, 2.25, 5.0, 0.0), 0.2)  # still touching: the same contact
    assert len(mon.onsets) == 1


def test_a_table_top_above_the_base_hits_the_arm_and_counts_as_3d():
    top = Box("table/top", (5.0, 5.0, 0.73), (1.2, 0.8, 0.04))
    mon, robot = _monitor(boxes=[top])
    # Under the top: the body (to 0.60 m) passes, the stowed arm (0.62..0.90 m) does not.
    assert mon.check(_parts_at(robot, 5.0, 5.0, 0.0), 0.0) == 0.0
    assert mon.onsets == [("table/top", "3d", 0.0, 0.0)]
    # A top above the arm would be no obstacle at all (nothing overlaps its height).
    high, _ = _monitor(boxes=[Box("shelf/board", (5.0, 5.0, 1.2), (1.2, 0.8, 0.04))])
    assert high.check(_parts_at(robot, 5.0, 5.0, 0.0), 0.0) == math.inf
    # The body alone, under a top at 0.65 m (between body and arm... none: the arm starts at 0.62).
    low, _ = _monitor(boxes=[Box("low/top", (5.0, 5.0, 0.61), (1.2, 0.8, 0.01))])
    assert low.check(_parts_at(robot, 5.0, 5.0, 0.0), 0.0) == math.inf


def test_a_walking_person_is_hit_where_they_are_at_the_time():
    walker = Person("walker", [(5.0, 0.0), (5.0, 10.0)], 1.0, phase=0.0, radius=0.2)
    mon, robot = _monitor(people=[walker], cylinders=[Cylinder("post", (8.0, 8.0), 0.1, 0.0, 1.0)])
    parts = _parts_at(robot, 5.0, 5.0, 0.0)  # the robot stands across the person's path
    # At t = 2 s the person is at y = 2: 2.8 m from the body's side at y 4.76.
    assert mon.check(parts, 2.0) == pytest.approx(min(4.76 - 2.2, math.hypot(8.0 - 5.37, 8.0 - 5.24) - 0.1))
    assert mon.onsets == []
    assert mon.check(parts, 4.6) == 0.0  # at y 4.6: its 0.2 m radius reaches the body's side
    assert mon.onsets == [("walker", "2d", 4.6, 0.0)]  # it walked into the robot


def _walk(mon, robot_parts, seconds, dt=0.02):
    """Steps the people as ClosedLoopSim.advance does (give way, then contacts) with the robot
    standing at robot_parts; returns the people's positions per step."""
    positions = []
    for k in range(1, int(round(seconds / dt)) + 1):
        rel = k * dt
        mon.world.hold(rel, cl.people_giving_way(mon.world, robot_parts, rel))
        mon.check(robot_parts, rel)
        positions.append(mon.world.people_xy([rel])[0].copy())
    return np.array(positions)


def test_a_person_whose_way_the_robot_blocks_waits_and_never_touches_it():
    walker = Person("walker", [(5.0, 0.0), (5.0, 10.0)], 1.0, phase=0.0, radius=0.2)
    mon, robot = _monitor(people=[walker])
    parts = _parts_at(robot, 5.0, 5.0, 0.0)  # across the person's path: the body's side at y 4.76
    positions = _walk(mon, parts, 10.0)
    assert mon.onsets == []
    y = positions[:, 0, 1]
    # Stopped where walking YIELD_AHEAD (0.5 m) on would bring them within YIELD_CLEARANCE (0.3 m)
    # of the body's side (a step is 2 cm of walking).
    assert y.max() == pytest.approx(4.76 - 0.2 - cl.YIELD_CLEARANCE - cl.YIELD_AHEAD, abs=0.021)
    assert y[-1] == y.max() and mon.world.waiting()[0]
    # The robot goes: the person walks on from where they stood, at their speed.
    free = _parts_at(robot, 1.0, 5.0, 0.0)
    mon.world.hold(10.02, cl.people_giving_way(mon.world, free, 10.02))
    assert not mon.world.waiting()[0]
    after = mon.world.people_xy([10.02, 11.02])[:, 0, 1]
    assert after[0] == pytest.approx(y[-1], abs=1e-9) and after[1] - after[0] == pytest.approx(1.0)


def test_a_person_with_a_free_way_is_not_slowed_and_the_open_loop_people_are_unchanged():
    walker = Person("walker", [(5.0, 0.0), (5.0, 10.0)], 1.0, phase=0.0, radius=0.2)
    # The robot beside the path (its front 0.35 m from the person's side as they pass: more than
    # YIELD_CLEARANCE), and right behind them (0.06 m, closer than that, but they walk away): no
    # waiting.
    _, robot = _monitor()
    for parts in (_parts_at(robot, 5.0 + 0.2 + 0.37 + 0.35, 5.0, 0.0), _parts_at(robot, 5.0, -0.5, 0.0)):
        mon, _ = _monitor(people=[Person(**vars(walker))])
        positions = _walk(mon, parts, 8.0)
        fresh = World(bounds=(0, 10, 0, 10), ceiling=3.0, people=[Person(**vars(walker))])
        assert np.array_equal(positions, fresh.people_xy(0.02 * np.arange(1, 401)))
        assert not mon.world.waiting().any()


# ----- runs ---------------------------------------------------------------------------------------
def _run(seed, timeout=2.0, **kw):
    config = dict(route="table", seed=seed, camera_points=2000, sensor_rate=5.0, goal_delay_s=0.2,
                  timeout_s=timeout)
    sim = cl.ClosedLoopSim(cl.ClosedLoopConfig(**{**config, **kw}))
    lidar_sums = []
    speed, sensed = 1.0, None
    while not sim.done:
        frame = sim.sense()
        if frame.lidars:
            sensed = frame
            # A deterministic controller that reads the sensors: slower when the lidars see less room.
            ranges = np.concatenate(list(frame.lidars.values()))
            lidar_sums.append(float(np.sum(ranges[np.isfinite(ranges)])))
            speed = min(1.0, float(np.median(np.where(np.isfinite(ranges), np.abs(ranges), 12.0))) / 12.0)
        if frame.control and sim.k >= sim.goal_step:
            vx, vy, w = cl.pursue(sim)
            sim.command(vx * speed, vy * speed, w)
        sim.advance()
    return sim.record(), lidar_sums, sensed


def test_the_same_seed_gives_the_same_run_and_another_seed_other_sensor_noise():
    a, sums_a, _ = _run(1)
    b, sums_b, _ = _run(1)
    c, sums_c, _ = _run(2)
    assert a.trajectory == b.trajectory and sums_a == sums_b
    assert a.to_json().replace(str(a.wall_s), "") == b.to_json().replace(str(b.wall_s), "")
    assert sums_c != sums_a and a.trajectory != c.trajectory
    # One entry per control step, the last where the run ended (the timeout, 2 s after the goal).
    assert a.timed_out and not a.reached and a.simulated_s == pytest.approx(2.2)
    assert [round(p[0], 9) for p in a.trajectory] == [round(0.1 * k, 9) for k in range(23)]
    assert a.trajectory[-1][1] > a.trajectory[0][1] + 0.3  # it moved towards the goal (+x)


def test_driving_under_the_table_counts_a_3d_collision_and_the_record_round_trips():
    # Straight through table2 (8.4..9.6 m) between its legs, under its top: sensors at 2 Hz suffice.
    rec, _, frame = _run(0, timeout=8.0, start=(7.6, 8.8), goal=(10.4, 8.8), sensor_rate=2.0)
    assert rec.reached and rec.time_to_goal_s == pytest.approx(rec.simulated_s - rec.goal_delay_s)
    names = [c["name"] for c in rec.collided_with]
    assert "table2/top" in names and not any("leg" in n for n in names)
    top = next(c for c in rec.collided_with if c["name"] == "table2/top")
    assert 0.1 < top["robot_speed"] <= 0.6  # the robot drove into it
    assert rec.collisions_3d == sum(1 for c in rec.collided_with if c["kind"] == "3d") >= 1
    assert rec.min_clearance_m == 0.0
    assert rec.path_length_m == pytest.approx(2.8 - 0.25, abs=0.02)
    back = cl.RunRecord.from_json(rec.to_json())
    assert back == rec
    # The depth frames as organized clouds: NaN exactly where there is no depth, z = the depth.
    depth = frame.depth["camera_left"]
    cam = next(C for C in cl.closed_loop_robot(cl.ClosedLoopConfig(camera_points=2000)).cameras)
    rays = cl.raycast.pixel_rays(cam.width, cam.height, *cam.intrinsics())
    pts = cl.depth_points(depth, rays)
    assert np.array_equal(np.isnan(pts[..., 2]), depth == 0.0) and (depth > 0).any()
    assert np.allclose(pts[..., 2][depth > 0], depth[depth > 0])


def test_the_table_route_is_free_at_the_lidars_height_and_blocked_under_the_arm():
    # A navigator taking the robot as its circumscribed circle (0.44 m) must see room at the
    # lidars' height (0.20 m) along the straight path, 1 m wide; its height band sees the top.
    world = cl.closed_loop_world()
    (x0, y0), (x1, _) = cl.ROUTES["table"]
    for dy in np.linspace(-0.5, 0.5, 21):
        ahead = world.band_scan((x0, y0 + dy), [0.0], 0.2, 0.2, 0.0, static_only=True)[0]
        assert ahead > x1 - x0
    top = world.band_scan((x0, y0), [0.0], 0.0, 0.9, 0.0, static_only=True)[0]
    assert top == pytest.approx(9.0 - 0.6 - x0)  # table2's top, 1.2 m long, centred at x = 9.0


def test_a_bad_configuration_names_its_field():
    with pytest.raises(ValueError, match="route"):
        cl.ClosedLoopSim(cl.ClosedLoopConfig(route="moon"))
    with pytest.raises(ValueError, match="sensor_rate"):
        cl.ClosedLoopSim(cl.ClosedLoopConfig(sensor_rate=7.0))  # 142.86 ms: not on the 20 ms grid
    with pytest.raises(ValueError, match="control_rate"):
        cl.ClosedLoopSim(cl.ClosedLoopConfig(control_rate=0.0))
    with pytest.raises(ValueError, match="timeout_s"):
        cl.ClosedLoopSim(cl.ClosedLoopConfig(timeout_s=-1.0))
