"""Glass in the simulator and the ultrasonic sensors that see it, against analytic ray casting.

Light (lidars, depth cameras) passes through glass panes; sound (the ultrasonic sensors) and the
ground truth stop at them. A sonar reads the closest surface anywhere in its cone, max_range when
nothing echoes.
"""
import math

import numpy as np
import pytest

from laserscan_toolbox.simulation import raycast
from laserscan_toolbox.simulation.robot import Robot, Sonar, Lidar, Camera
from laserscan_toolbox.simulation.scenario import Scenario, TOPICS
from laserscan_toolbox.simulation.world import World, Box, Cylinder

PANE_X, WALL_X = 3.0, 6.0


def glass_room(extra_cylinders=()):
    """A glass pane across the x axis at x = 3 (2 cm thick, 2 m high) and a wall at x = 6."""
    return World(bounds=(-1.0, 10.0, -5.0, 5.0), ceiling=3.0,
                 boxes=[Box("wall", (WALL_X + 0.1, 0.0, 1.5), (0.2, 10.0, 3.0))],
                 cylinders=list(extra_cylinders),
                 glass=[Box("pane", (PANE_X + 0.01, 0.0, 1.0), (0.02, 4.0, 2.0))])


def level_rays(origin, angles, z):
    o = np.tile([origin[0], origin[1], z], (len(angles), 1))
    d = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(len(angles))])
    return o, d


def test_light_passes_through_glass_sound_does_not():
    w = glass_room()
    angles = np.radians([-20.0, 0.0, 20.0])
    o, d = level_rays((0.0, 0.0), angles, 0.3)
    np.testing.assert_allclose(w.cast(o, d, 0.0), WALL_X / np.cos(angles))
    np.testing.assert_allclose(w.cast(o, d, 0.0, see_glass=True), PANE_X / np.cos(angles))
    # Above the pane (2 m high) sound passes too.
    o, d = level_rays((0.0, 0.0), angles, 2.5)
    np.testing.assert_allclose(w.cast(o, d, 0.0, see_glass=True), WALL_X / np.cos(angles))
    # The same as ray casting against the pane as an ordinary box.
    o, d = level_rays((0.0, 0.0), np.radians(np.linspace(-40, 40, 81)), 1.0)
    pane = raycast.ray_boxes(o, d, w.glass_c, w.glass_h, w.glass_yaw)[:, 0]
    np.testing.assert_allclose(w.cast(o, d, 0.0, see_glass=True), np.minimum(pane, w.cast(o, d, 0.0)))


def test_ground_truth_sees_glass_unless_asked_not_to():
    w = glass_room()
    angles = np.radians([-10.0, 0.0, 10.0])
    np.testing.assert_allclose(w.band_scan((0.0, 0.0), angles, 0.05, 1.0, 0.0), PANE_X / np.cos(angles))
    np.testing.assert_allclose(w.band_scan((0.0, 0.0), angles, 0.05, 1.0, 0.0, glass=False),
                               WALL_X / np.cos(angles))
    # A band above the pane does not see it.
    np.testing.assert_allclose(w.band_scan((0.0, 0.0), angles, 2.1, 2.5, 0.0), WALL_X / np.cos(angles))
    grid, (x0, y0) = w.occupancy(0.05, 0.05, 1.0)
    col = int((PANE_X + 0.01 - x0) / 0.05)
    row = int((0.0 - y0) / 0.05)
    assert grid[row, col], "the pane is an obstacle of the ground-truth grid"


def test_glass_round_trips_and_depth_cameras_see_through_it():
    w = glass_room()
    assert World.from_dict(w.to_dict()).to_dict() == w.to_dict()
    # A camera looking along +x at 1 m height: the centre pixel sees the wall, not the pane.
    rot = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])  # optical -> world
    depth = raycast.render_depth(w.solids(0.0), w.hole_arr, w.ceiling, rot, np.array([0.0, 0.0, 1.0]),
                                 (20.0, 20.0, 10.0, 10.0), 21, 21, 10.0)
    assert depth[10, 10] == pytest.approx(WALL_X)


def one_sonar_scenario(world, sonar, route=((0.0, 0.0), (0.4, 0.0))):
    robot = Robot(lidars=[Lidar("lidar", "lidar_link", (0.0, 0.0, 0.2), 0.0)],
                  cameras=[Camera("cam", "cam_tilt", "cam_optical", (0.3, 0.0, 0.5), 0.0, width=8, height=6)],
                  sonars=[sonar])
    return Scenario(world, robot, list(route), laps=1, duration=0.5, seed=0)


def test_sonar_reads_the_pane_ahead_and_max_range_beyond():
    sonar = Sonar("sonar", "sonar_link", (0.37, 0.0, 0.3), 0.0, noise_sigma=0.0)
    sc = one_sonar_scenario(glass_room(), sonar)
    rng = np.random.default_rng(0)
    x, y, yaw = sc.true_pose(sc.start_time)  # standing still at the start (the robot waits 1 s)
    assert (x, y, yaw) == pytest.approx((0.0, 0.0, 0.0))
    assert sc.sonar_range(sonar, 0.0, rng) == pytest.approx(PANE_X - 0.37, abs=1e-9)
    # The lidar at the same place sees the wall through the pane.
    r = sc.lidar_scan(sc.robot.lidars[0], 0.0, rng, body=np.full(360, np.inf))  # no body around it
    assert r[180] == pytest.approx(WALL_X, abs=0.05)
    # Facing away from everything within 5 m: no echo = max_range.
    away = Sonar("away", "away_link", (-0.37, 0.0, 0.3), math.pi, noise_sigma=0.0)
    assert sc.sonar_range(away, 0.0, rng) == sonar.max_range


def test_sonar_cone_sees_off_axis_obstacles_inside_it_only():
    half = 0.3  # rad, half of the default 0.6 rad cone
    sonar = Sonar("sonar", "sonar_link", (0.0, 0.0, 0.3), 0.0, noise_sigma=0.0, rays=61)
    for off_axis, inside in ((0.8 * half, True), (1.3 * half, False)):
        d = 2.0
        post = Cylinder("post", (d * math.cos(off_axis), d * math.sin(off_axis)), 0.02, 0.0, 1.0)
        w = World(bounds=(-1.0, 10.0, -5.0, 5.0), ceiling=3.0, cylinders=[post])
        sc = one_sonar_scenario(w, sonar)
        r = sc.sonar_range(sonar, 0.0, np.random.default_rng(0))
        if inside:
            # The closest point of the post along the cone's rays: within its radius of 2 m.
            assert 2.0 - 0.021 <= r <= 2.0 + 0.005, r
        else:
            assert r == sonar.max_range


def test_shop_floor_has_glass_the_route_passes():
    sc = Scenario.default(seed=0)
    assert {g.name for g in sc.world.glass} == {"glass_wall", "glass_door"}
    assert len(sc.robot.sonars) == 4
    rng = np.random.default_rng(0)
    # Driving east along the aisle, the right sonar hears the glass wall that the lidar misses.
    right = next(s for s in sc.robot.sonars if s.name == "sonar_right")
    heard = []
    for rel in np.arange(10.0, 16.0, 0.5):
        x, y, yaw = sc.true_pose(rel + sc.start_time)
        if 7.0 < x < 9.7:
            heard.append(sc.sonar_range(right, rel, rng))
    assert heard and np.all(np.abs(np.array(heard) - (7.5 - 0.24 - 6.46)) < 0.15), heard


@pytest.fixture(scope="module")
def sonar_bag(tmp_path_factory):
    import rosbag
    sc = Scenario.default(seed=2, duration=2.0, camera_points=500)
    path = str(tmp_path_factory.mktemp("sonar") / "sonar.bag")
    sc.simulate(path, progress=False)
    msgs = {}
    with rosbag.Bag(path) as bag:
        for topic, msg, t in bag.read_messages():
            msgs.setdefault(topic, []).append((msg, t.to_sec()))
    return sc, msgs


def test_bag_has_ranges_with_their_frames_in_tf_static(sonar_bag):
    sc, msgs = sonar_bag
    static = {(t.header.frame_id, t.child_frame_id): t for m, _ in msgs[TOPICS["tf_static"]] for t in m.transforms}
    for s in sc.robot.sonars:
        ranges = msgs[TOPICS[s.name]]
        stamps = np.array([m.header.stamp.to_sec() for m, _ in ranges])
        assert 1.0 / np.median(np.diff(stamps)) == pytest.approx(s.rate, rel=1e-3)
        m, bag_t = ranges[0]
        assert m.header.frame_id == s.frame and m.radiation_type == m.ULTRASOUND
        assert (m.min_range, m.max_range) == pytest.approx((0.3, 5.0))
        assert m.field_of_view == pytest.approx(0.6)
        assert bag_t >= m.header.stamp.to_sec()
        assert all(m.min_range * 0.5 < x.range <= m.max_range for x, _ in ranges)
        tf = static[("base_link", s.frame)]
        assert (tf.transform.translation.x, tf.transform.translation.y) == pytest.approx(s.xyz[:2])
        assert 2 * math.atan2(tf.transform.rotation.z, tf.transform.rotation.w) == pytest.approx(s.yaw)
