"""The built-in scenario: ground truth, determinism, and a short simulated bag."""
import math
import os

import numpy as np
import pytest
import yaml

from laserscan_toolbox.simulation.scenario import Scenario, TOPICS

import rosbag

DURATION = 3.0


@pytest.fixture(scope="module")
def short_bag(tmp_path_factory):
    sc = Scenario.default(seed=3, duration=DURATION, camera_points=3000)
    path = str(tmp_path_factory.mktemp("sim") / "short.bag")
    stats = sc.simulate(path, progress=False)
    msgs = {}
    with rosbag.Bag(path) as bag:
        for topic, msg, t in bag.read_messages():
            msgs.setdefault(topic, []).append((msg, t.to_sec()))
        conns = {c.topic: c for c in bag._get_connections()}
    return sc, path, stats, msgs, conns


def test_yaml_round_trip_is_exact():
    sc = Scenario.default(seed=5, duration=4.0, camera_points=5000)
    text = sc.to_yaml()
    sc2 = Scenario.from_yaml(text)
    assert sc2.to_yaml() == text
    assert sc2.duration == sc.duration and sc2.start_time == sc.start_time
    t = sc.start_time + np.linspace(0, 4, 17)
    assert np.array_equal(np.array(sc.true_pose(t)), np.array(sc2.true_pose(t)))


def test_default_lap_and_motion_limits():
    sc = Scenario.default()
    assert 40.0 <= sc.duration <= 65.0
    t = sc.start_time + np.arange(0, sc.duration, 0.01)
    x, y, yaw = sc.true_pose(t)
    v = np.hypot(np.diff(x), np.diff(y)) / 0.01
    w = np.abs(np.diff(np.unwrap(yaw))) / 0.01
    assert v.max() <= 0.6 + 1e-3 and w.max() <= 0.8 + 1e-3
    # there and back: ends where it started, after going more than 10 m away
    assert math.hypot(x[-1] - x[0], y[-1] - y[0]) < 0.1
    assert np.hypot(x - x[0], y - y[0]).max() > 10.0
    # with turns: the heading covers more than 180 degrees
    assert np.ptp(np.unwrap(yaw)) > math.pi


def test_ideal_scan_geometry():
    sc = Scenario.default()
    # At (10, 7.5) facing +x, 0.05..1 m band: straight down -y the crosser may pass, so
    # use a pose and time away from people: at (2, 7.5) facing west the west wall is 2 m away.
    r = sc.ideal_scan(sc.start_time, -math.pi, math.pi, math.radians(1), 0.0, 30.0, 0.05, 1.0,
                      pose=(2.0, 7.5, math.pi))
    assert len(r) == 361
    assert r[180] == pytest.approx(2.0, abs=1e-9)            # beam 0 rad = facing the wall
    # Table 1 (top 5.4..6.6 x 5.9..6.7 at 0.71..0.75): from (6, 7.5) looking -y (beam -90 deg,
    # robot facing +x) the top's edge is 0.8 m away in a 0.05..1 m band; in a lidar band
    # 0.15..0.25 m only the far shelf/wall remain (legs are at x = 5.46 and 6.54).
    pose = (6.0, 7.5, 0.0)
    band = sc.ideal_scan(sc.start_time, -math.pi / 2, -math.pi / 2, 1.0, 0.0, 30.0, 0.05, 1.0, pose=pose)
    low = sc.ideal_scan(sc.start_time, -math.pi / 2, -math.pi / 2, 1.0, 0.0, 30.0, 0.15, 0.25, pose=pose)
    assert band[0] == pytest.approx(0.8, abs=1e-9)
    assert low[0] > 1.5
    # range limits: +inf beyond range_max, -inf inside range_min
    r = sc.ideal_scan(sc.start_time, 0.0, 0.0, 1.0, 2.5, 30.0, 0.05, 1.0, pose=(2.0, 7.5, math.pi))
    assert r[0] == -np.inf
    r = sc.ideal_scan(sc.start_time, 0.0, 0.0, 1.0, 0.0, 1.5, 0.05, 1.0, pose=(2.0, 7.5, math.pi))
    assert r[0] == np.inf


def test_ideal_scans_kept_for_reuse_are_the_scans_cast_anew():
    """The evaluation asks for the same ideal scan with and without glass, to two maximum
    ranges, at the true pose given or not: every answer is what the world casts anew, also
    when a kept scan was cast to a shorter range, and the kept scans stay within their bound."""
    sc = Scenario.default()
    n, inc = 360, 2 * math.pi / 360
    t = sc.start_time + 20.0
    x, y, yaw = sc.true_pose(t)
    rel = t - sc.start_time

    def cast_anew(range_min, range_max, z_min, z_max, glass):
        r = sc.world.band_scan((x, y), -math.pi + np.arange(n) * inc + yaw, z_min, z_max, rel,
                               max_range=range_max, glass=glass)
        return np.where(r < range_min, -np.inf, r)

    calls = [(0.1, 4.0, True, None), (0.1, 4.0, False, (x, y, yaw)), (0.3, 12.0, True, None),
             (0.3, 12.0, False, None), (0.1, 3.0, True, (x, y, yaw)), (0.0, np.inf, False, None)]
    for z_min, z_max in ((0.05, 1.0), (0.18, 0.22)):
        for range_min, range_max, glass, pose in calls:
            got = sc.ideal_scan(t, -math.pi, math.pi - inc, inc, range_min, range_max, z_min, z_max,
                                pose=pose, glass=glass)
            assert np.array_equal(got, cast_anew(range_min, range_max, z_min, z_max, glass)), \
                (z_min, range_max, glass)
    far = sc.ideal_scan(t, -math.pi, math.pi - inc, inc, 0.0, np.inf, 0.05, 1.0)
    assert np.nanmax(far[np.isfinite(far)]) > 12.0  # the case above that a short cast would miss
    # A bound of three scans: the oldest go, what is asked is still right.
    sc.IDEAL_SCAN_CACHE_BYTES = 3 * 2 * 8 * n
    for k in range(6):
        sc.ideal_scan(t + k, -math.pi, math.pi - inc, inc, 0.1, 12.0, 0.05, 1.0)
        assert sc._ideal_cache_bytes <= sc.IDEAL_SCAN_CACHE_BYTES
    assert [key[0] for key in sc._ideal_cache] == [t + 3, t + 4, t + 5]
    x, y, yaw = sc.true_pose(t)
    assert np.array_equal(sc.ideal_scan(t, -math.pi, math.pi - inc, inc, 0.1, 12.0, 0.05, 1.0),
                          cast_anew(0.1, 12.0, 0.05, 1.0, True))


def test_ground_truth_grid_has_table_tops_only_in_their_band():
    sc = Scenario.default()
    res = 0.05
    high, (x0, y0) = sc.ground_truth_grid(res, 0.05, 1.0)
    low, _ = sc.ground_truth_grid(res, 0.15, 0.25)
    cx, cy = int((6.0 - x0) / res), int((6.3 - y0) / res)   # centre of table 1's top
    assert high[cy, cx] and not low[cy, cx]
    wx = int((10.0 - x0) / res)
    assert high[int((-0.05 - y0) / res), wx] and low[int((-0.05 - y0) / res), wx]  # south wall


def test_same_seed_same_data_other_seed_differs():
    rng = np.random.default_rng
    a = Scenario.default(seed=1, duration=2.0, camera_points=2000)
    b = Scenario.default(seed=1, duration=2.0, camera_points=2000)
    la, lb = a.robot.lidars[0], b.robot.lidars[0]
    assert np.array_equal(a.lidar_scan(la, 1.0, rng(1)), b.lidar_scan(lb, 1.0, rng(1)))
    ca, cb = a.robot.cameras[0], b.robot.cameras[0]
    assert np.array_equal(a.depth_image(ca, 1.0, rng(1)), b.depth_image(cb, 1.0, rng(1)))
    assert not np.array_equal(a.lidar_scan(la, 1.0, rng(1)), a.lidar_scan(la, 1.0, rng(2)))


def test_bag_topics_and_rates(short_bag):
    sc, path, stats, msgs, conns = short_bag
    for key in ("lidar_front", "lidar_rear", "camera_left_depth", "camera_left_info",
                "camera_right_depth", "camera_right_info", "odom", "tf", "tf_static",
                "ground_truth", "scenario"):
        assert TOPICS[key] in msgs, key

    def rate(topic):
        st = np.array([m.header.stamp.to_sec() for m, _ in msgs[topic]])
        return 1.0 / np.median(np.diff(st))
    assert rate(TOPICS["lidar_front"]) == pytest.approx(8.0, rel=1e-3)
    assert rate(TOPICS["lidar_rear"]) == pytest.approx(8.0, rel=1e-3)
    assert rate(TOPICS["camera_left_depth"]) == pytest.approx(14.0, rel=1e-3)
    assert rate(TOPICS["camera_right_depth"]) == pytest.approx(14.0, rel=1e-3)
    assert rate(TOPICS["odom"]) == pytest.approx(50.0, rel=1e-3)
    # messages are stamped in sim time from the scenario's start
    first = min(t for v in msgs.values() for _, t in v)
    assert first == pytest.approx(sc.start_time)


def test_lidar_scan_fields(short_bag):
    sc, _, _, msgs, _ = short_bag
    m, bag_t = msgs[TOPICS["lidar_front"]][3]
    assert len(m.ranges) == round((m.angle_max - m.angle_min) / m.angle_increment) + 1 == 360
    assert m.scan_time == pytest.approx(0.125)
    assert m.time_increment == pytest.approx(0.125 / 360)
    assert bag_t >= m.header.stamp.to_sec() + m.scan_time  # published after its last beam
    r = np.array(m.ranges)
    # the body hides the sector behind the corner lidar (|angle| > ~137 deg in its frame)
    ang = m.angle_min + np.arange(360) * m.angle_increment
    behind = np.abs(ang) > math.radians(139.5)
    assert np.all(r[behind] < 0.6)   # the body, never the world
    assert np.isneginf(r[behind]).any()          # beams into the corner: closer than range_min
    front = np.abs(ang) < math.radians(130)
    assert not np.isneginf(r[front]).any() and (r[front] > 0.9).mean() > 0.95


def test_depth_image_and_info(short_bag):
    _, _, _, msgs, _ = short_bag
    img, _ = msgs[TOPICS["camera_left_depth"]][0]
    info, _ = msgs[TOPICS["camera_left_info"]][0]
    assert img.encoding == "16UC1" and img.step == 2 * img.width
    assert info.header.stamp == img.header.stamp and info.header.frame_id == img.header.frame_id
    assert abs(img.width * img.height - 3000) < 100
    d = np.frombuffer(img.data, "<u2").reshape(img.height, img.width)
    assert (d > 0).mean() > 0.8 and d.max() <= 8000


def test_tf_chain_and_latched_static(short_bag):
    sc, _, _, msgs, conns = short_bag
    assert conns[TOPICS["tf_static"]].header.get("latching") in ("1", b"1")
    assert conns[TOPICS["scenario"]].header.get("latching") in ("1", b"1")
    static = {(t.header.frame_id, t.child_frame_id) for m, _ in msgs[TOPICS["tf_static"]] for t in m.transforms}
    dynamic = {(t.header.frame_id, t.child_frame_id) for m, _ in msgs[TOPICS["tf"]] for t in m.transforms}
    assert ("odom", "base_link") in dynamic
    for L in sc.robot.lidars:
        assert ("base_link", L.frame) in static
    for C in sc.robot.cameras:
        assert ("base_link", C.tilt_frame) in dynamic        # the servo moves
        assert (C.tilt_frame, C.optical_frame) in static
    # the servo's pitch really changes over the bag
    qs = [t.transform.rotation.y for m, _ in msgs[TOPICS["tf"]] for t in m.transforms
          if t.child_frame_id == sc.robot.cameras[0].tilt_frame]
    assert np.ptp(qs) > 0.05
    # the arm's joints are on /tf, each link under its parent, base_link first
    for link in sc.robot.arm.links:
        assert (link.parent, link.name) in dynamic
    # every sensor frame is reachable from odom
    reach = {"odom"}
    for _ in range(3):
        reach |= {c for p, c in static | dynamic if p in reach}
    frames = {m.header.frame_id for k in ("lidar_front", "camera_left_depth") for m, _ in msgs[TOPICS[k]]}
    assert frames <= reach


def test_odometry_drifts_but_tracks(short_bag):
    sc, _, _, msgs, _ = short_bag
    odom = msgs[TOPICS["odom"]]
    gt = msgs[TOPICS["ground_truth"]]
    assert odom[0][0].header.frame_id == "odom" and gt[0][0].header.frame_id == "map"
    # odom starts at the identity; its displacement matches the truth within a few percent
    x0, y0, _ = sc.true_pose(sc.start_time)
    m, _ = odom[-1]
    g = sc.true_pose(m.header.stamp.to_sec())
    true_d = math.hypot(g[0] - x0, g[1] - y0)
    odo_d = math.hypot(m.pose.pose.position.x, m.pose.pose.position.y)
    assert true_d > 0.3
    assert odo_d == pytest.approx(true_d, rel=0.1)
    assert odo_d != true_d


def test_scenario_round_trips_from_bag(short_bag):
    sc, path, _, _, _ = short_bag
    sc2 = Scenario.from_bag(path)
    assert sc2.to_yaml() == sc.to_yaml()


REPO = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


@pytest.mark.parametrize("depth_input", ["image", "cloud"])
@pytest.mark.parametrize("standalone,expected_manager", [("false", True), ("true", False)])
def test_pipeline_launch_nodes(standalone, expected_manager, depth_input):
    """launch/pipeline.launch parses (its configs pass check_config) and starts two
    converters (reading depth images, or with depth_input:=cloud the clouds of two
    depth_image_proc nodelets) four range converters and three mergers, with one manager unless standalone.
    Needs the workspace's devel/setup.bash sourced."""
    import subprocess
    out = subprocess.run(["roslaunch", "--nodes", os.path.join(REPO, "launch", "pipeline.launch"),
                          f"standalone:={standalone}", f"depth_input:={depth_input}"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    nodes = set(out.stdout.split())
    for n in ("/camera_left_converter", "/camera_right_converter", "/merged_scan_merger", "/slam_scan_merger",
              "/lidar_scan_merger"):
        assert n in nodes
    for n in ("/camera_left_points", "/camera_right_points"):
        assert (n in nodes) == (depth_input == "cloud")
    for sonar in ("front_left", "front_right", "left", "right"):
        assert "/sonar_%s_converter" % sonar in nodes
    assert ("/pipeline_manager" in nodes) == expected_manager
    # The converters read what depth_input says.
    args = subprocess.run(["roslaunch", "--args", "/camera_left_converter",
                           os.path.join(REPO, "launch", "pipeline.launch"), f"standalone:={standalone}",
                           f"depth_input:={depth_input}"], capture_output=True, text=True, timeout=60)
    assert args.returncode == 0, args.stderr
    image_node = "DepthImageScanConverterNodelet" in args.stdout or "depth_image_scan_converter_node" in args.stdout
    assert image_node == (depth_input == "image"), args.stdout


def test_sim_configs_match_the_simulated_robot():
    """The merger masks hide exactly the lidars' body shadow, and topics are the
    simulator's, so a change on one side cannot silently break the other."""
    sc = Scenario.default(duration=2.0, camera_points=1000)
    with open(os.path.join(REPO, "config", "sim_robot", "merged_scan.yaml")) as f:
        merged = yaml.safe_load(f)
    with open(os.path.join(REPO, "config", "sim_robot", "lidar_scan.yaml")) as f:
        lidar_only = yaml.safe_load(f)
    topics = {s["topic"] for s in merged["sources"]}
    sonar_scans = {TOPICS[s.name + "_scan"] for s in sc.robot.sonars}
    assert len(sonar_scans) == 4
    assert topics == {TOPICS["lidar_front"], TOPICS["lidar_rear"], TOPICS["camera_left_scan"],
                      TOPICS["camera_right_scan"]} | sonar_scans
    for src in merged["sources"]:
        if src["topic"] in sonar_scans:  # the arcs' reach is within the sensors' own limit
            assert 0.0 < src.get("range_max", math.inf) <= sc.robot.sonars[0].max_range
    # The SLAM feed is the merged scan without the arcs, source for source (same masks, timeouts).
    with open(os.path.join(REPO, "config", "sim_robot", "slam_scan.yaml")) as f:
        slam_feed = yaml.safe_load(f)
    assert slam_feed["sources"] == [s for s in merged["sources"] if s["topic"] not in sonar_scans]
    assert {k: v for k, v in slam_feed.items() if k != "sources"} == \
        {k: v for k, v in merged.items() if k != "sources"}
    assert {s["topic"] for s in lidar_only["sources"]} == {TOPICS["lidar_front"], TOPICS["lidar_rear"]}
    for src in lidar_only["sources"]:
        lidar = next(L for L in sc.robot.lidars if TOPICS[L.name] == src["topic"])
        body = sc.body_ranges(lidar)
        ang = -math.pi + np.arange(lidar.beams) * 2 * math.pi / lidar.beams
        kept = (ang >= src["angle_min"]) & (ang <= src["angle_max"])
        assert np.all(np.isinf(body[kept]))          # no kept beam sees the body
        assert np.all(np.isfinite(body[~kept]))      # the mask hides nothing else
    for side in ("left", "right"):
        with open(os.path.join(REPO, "config", "sim_robot", f"camera_{side}_converter.yaml")) as f:
            conv = yaml.safe_load(f)
        assert conv["reference_frame"] == "base_link" and conv["floor_height"] == 0.0
        assert conv["min_height"] < 0.75 < conv["max_height"]   # table tops are obstacles


def test_cli_help_and_clear_errors(tmp_path):
    import subprocess
    exe = os.path.join(REPO, "scripts", "simulate_scenario")
    out = subprocess.run([exe, "--help"], capture_output=True, text=True, timeout=30)
    assert out.returncode == 0 and "--camera-points" in out.stdout
    out = subprocess.run([exe, "--duration", "0.5", "-o", str(tmp_path / "x.bag")],
                         capture_output=True, text=True, timeout=30)
    assert out.returncode == 2 and "--duration" in out.stderr
    out = subprocess.run([exe, "-o", str(tmp_path / "missing" / "x.bag")], capture_output=True, text=True,
                         timeout=30)
    assert out.returncode == 2 and "does not exist" in out.stderr
    out = subprocess.run([exe, "--duration", "1.5", "--camera-points", "500", "--no-progress",
                          "-o", str(tmp_path / "ok.bag")], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert Scenario.from_bag(str(tmp_path / "ok.bag")).duration == 1.5


def _yaw_matrix(yaw):
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_arm_description_tf_and_boxes_agree():
    """The shipped URDF is the arm's, and its collision boxes placed by the joints' /tf
    transforms are the boxes the simulator casts rays on (what the self filter rebuilds)."""
    import xml.etree.ElementTree as ET
    from laserscan_toolbox.simulation.robot import Arm
    arm = Arm()
    with open(os.path.join(REPO, "config", "sim_robot", "robot.urdf")) as f:
        text = f.read()
    assert text == arm.urdf()
    root = ET.fromstring(text)
    collision = {}
    for link in root.findall("link"):
        c = link.find("collision")
        if c is not None:
            collision[link.get("name")] = (
                np.array([float(v) for v in c.find("origin").get("xyz").split()]),
                np.array([float(v) for v in c.find("geometry/box").get("size").split()]))
    assert set(collision) == {lk.name for lk in arm.links}
    for t in (0.0, 5.5, 8.0, 11.7, 14.0, 30.0):
        pose = {"base_link": (np.eye(3), np.zeros(3))}
        for link, parent, xyz, yaw in arm.joint_transforms(t):
            r, p = pose[parent]
            pose[link] = (r @ _yaw_matrix(yaw), p + r @ np.asarray(xyz))
        centers, half, yaws = arm.boxes(t)
        for k, lk in enumerate(arm.links):
            r, p = pose[lk.name]
            origin, size = collision[lk.name]
            assert np.allclose(p + r @ origin, centers[k], atol=1e-9)
            assert np.allclose(size / 2, half[k])
            assert abs(math.remainder(math.atan2(r[1, 0], r[0, 0]) - yaws[k], 2 * math.pi)) < 1e-9


def test_the_arm_enters_the_cameras_and_the_lidars_views():
    """Ahead-left it is in the left camera's image (near pixels the world alone does not
    have); lowered beside the robot it blocks beams of the rear lidar; stowed neither."""
    sc = Scenario.default(duration=20.0, camera_points=3000)
    lidar = next(L for L in sc.robot.lidars if L.name == "lidar_rear")
    cam = next(C for C in sc.robot.cameras if C.name == "camera_left")
    stowed, ahead, beside = 1.0, 5.0, 10.0
    assert np.isinf(sc.arm_ranges(lidar, np.full(lidar.beams, stowed))).all()
    hit = np.isfinite(sc.arm_ranges(lidar, np.full(lidar.beams, beside)))
    assert 3 <= hit.sum() <= 20
    r = sc.lidar_scan(lidar, beside, np.random.default_rng(0))
    assert np.all(r[hit] < 1.0)       # the scan reads the arm there (noise, dropout aside)
    near = [((sc.depth_image(cam, t, np.random.default_rng(0)) > 0)
             & (sc.depth_image(cam, t, np.random.default_rng(0)) < 0.4)).sum() for t in (stowed, ahead)]
    assert near[0] == 0 and near[1] > 100
