"""bag_to_rawlog on a small bag with known poses, read back with rawlog_dump (MRPT's reader).

The bag: odometry at 50 Hz on a 2 m circle (yaw crosses +-pi), a laser 0.3 m ahead of
base_link turned by 0.5 rad on /tf_static, scans at 10 Hz stamped between odometry
messages, with no-return, invalid and too-close beams; one scan before the odometry starts
and one in a frame tf does not know.
"""
import math
import subprocess

import numpy as np
import pytest

import rosbag
from laserscan_toolbox.ros import bagio
from laserscan_toolbox.evaluation.slam import tool

RADIUS, OMEGA = 2.0, 0.5          # m, rad/s
MOUNT = (0.3, -0.1, 0.2, 0.5)     # x, y, z, yaw of the laser in base_link
ANGLE_MIN, INC, BEAMS = -1.5, 0.01, 401  # beam 400 at 2.5 rad: middle 0.5 rad
T0 = 1000.0


def true_pose(t):
    a = OMEGA * (t - T0)
    return RADIUS * math.sin(a), RADIUS * (1 - math.cos(a)), math.atan2(math.sin(a), math.cos(a))


def ranges():
    r = np.full(BEAMS, 3.0, np.float32)
    r[10:30] = np.inf    # no return: MRPT's invalid range at maxRange
    r[40] = np.nan       # invalid
    r[41] = -np.inf      # too close
    r[42] = 0.05         # below range_min
    r[43] = 25.0         # beyond range_max: no return too
    return r


def write_bag(path):
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import LaserScan
    from tf2_msgs.msg import TFMessage
    scans = []
    with rosbag.Bag(path, "w") as bag:
        q = (0.0, 0.0, math.sin(MOUNT[3] / 2), math.cos(MOUNT[3] / 2))
        mount = bagio.transform(T0, "base_link", "laser", MOUNT[:3], q)
        bag.write("/tf_static", TFMessage([mount]), bagio.stamp(T0))
        for k in range(501):  # 10 s at 50 Hz
            t = T0 + 0.02 * k
            x, y, yaw = true_pose(t)
            m = Odometry()
            m.header.stamp = bagio.stamp(t)
            m.header.frame_id, m.child_frame_id = "odom", "base_link"
            m.pose.pose.position.x, m.pose.pose.position.y = x, y
            orientation = m.pose.pose.orientation
            orientation.z, orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
            bag.write("/odom", m, bagio.stamp(t))
        stamps = [T0 - 0.5] + [T0 + 0.1 * k + 0.007 for k in range(95)]
        for i, t in enumerate(stamps):
            s = LaserScan()
            s.header.stamp = bagio.stamp(t)
            s.header.frame_id = "unknown_frame" if i == 50 else "laser"
            s.angle_min, s.angle_increment = ANGLE_MIN, INC
            s.angle_max = ANGLE_MIN + INC * (BEAMS - 1)
            s.range_min, s.range_max = 0.1, 20.0
            s.ranges = ranges().tolist()
            bag.write("/scan", s, bagio.stamp(t + 0.01))
            if i != 0 and i != 50:
                scans.append(t)
    return scans


@pytest.fixture(scope="module")
def converted(tmp_path_factory):
    d = tmp_path_factory.mktemp("rawlog")
    bag = str(d / "known.bag")
    expected = write_bag(bag)
    rawlog, index = str(d / "known.rawlog"), str(d / "known.index")
    run = subprocess.run([tool("bag_to_rawlog"), bag, rawlog, "--scan-topic", "/scan",
                          "--index", index], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    dump = subprocess.run([tool("rawlog_dump"), rawlog], capture_output=True, text=True,
                          timeout=60, check=True).stdout
    rows = np.loadtxt(dump.splitlines(), ndmin=2)
    return {"expected": expected, "rows": rows, "index": np.loadtxt(index, ndmin=2),
            "stderr": run.stderr, "bag": bag, "dir": d}


def test_every_usable_scan_is_in_the_rawlog_and_the_others_are_reported(converted):
    rows = converted["rows"]
    assert len(rows) == len(converted["expected"]) == 94
    np.testing.assert_allclose(rows[:, 1], converted["expected"], atol=1e-6)
    np.testing.assert_array_equal(rows[:, 0], np.arange(94))
    assert "1 scan(s) left out: outside the odometry's time span" in converted["stderr"]
    assert "1 scan(s) left out: no transform 'unknown_frame' -> 'base_link'" in converted["stderr"]


def test_odometry_increments_compose_back_to_the_bags_poses(converted):
    rows = converted["rows"]
    x, y, yaw = true_pose(rows[0, 1])
    assert rows[0, 2:5] == pytest.approx([0, 0, 0], abs=1e-12)  # the first action moves nothing
    worst = 0.0
    for r in rows:
        dx, dy, dyaw = r[2:5]
        c, s = math.cos(yaw), math.sin(yaw)
        x, y = x + c * dx - s * dy, y + s * dx + c * dy
        yaw += dyaw
        tx, ty, tyaw = true_pose(r[1])
        worst = max(worst, math.hypot(x - tx, y - ty))
        assert math.remainder(yaw - tyaw, 2 * math.pi) == pytest.approx(0, abs=1e-3)
    assert worst < 1e-3
    # the index holds the same odometry poses, for the evaluation
    for (_, stamp, ox, oy, oyaw) in converted["index"]:
        tx, ty, tyaw = true_pose(stamp)
        assert math.hypot(ox - tx, oy - ty) < 1e-3
        assert math.remainder(oyaw - tyaw, 2 * math.pi) == pytest.approx(0, abs=1e-3)


def test_sensor_pose_comes_from_tf_turned_to_the_scans_middle_beam(converted):
    rows = converted["rows"]
    # columns: beams aperture max_range valid no_return sensor_x sensor_y sensor_z sensor_yaw
    # first_angle last_angle
    np.testing.assert_array_equal(rows[:, 5], BEAMS)
    np.testing.assert_allclose(rows[:, 6], INC * (BEAMS - 1), atol=1e-6)
    np.testing.assert_allclose(rows[:, 7], 20.0)
    np.testing.assert_allclose(rows[:, 10:13], np.tile(MOUNT[:3], (len(rows), 1)), atol=1e-9)
    middle = ANGLE_MIN + INC * (BEAMS - 1) / 2
    np.testing.assert_allclose(rows[:, 13], MOUNT[3] + middle, atol=1e-9)
    # MRPT's own beam directions (getScanAngle) in base_link are the ROS beams' directions
    np.testing.assert_allclose(rows[:, 13] + rows[:, 14], MOUNT[3] + ANGLE_MIN, atol=1e-6)
    np.testing.assert_allclose(rows[:, 13] + rows[:, 15], MOUNT[3] + ANGLE_MIN + INC * (BEAMS - 1),
                               atol=1e-6)


def test_rep117_values_become_invalid_ranges(converted):
    rows = converted["rows"]
    r = ranges()
    measured = np.isfinite(r) & (r >= 0.1) & (r <= 20.0)
    np.testing.assert_array_equal(rows[:, 8], measured.sum())
    np.testing.assert_array_equal(rows[:, 9], 21)  # 20 x +Inf and 25 m: no return at range_max


def test_min_interval_thins_the_scans(converted):
    d = converted["dir"]
    rawlog = str(d / "thin.rawlog")
    subprocess.run([tool("bag_to_rawlog"), converted["bag"], rawlog, "--scan-topic", "/scan",
                    "--min-interval", "0.25"], capture_output=True, timeout=60, check=True)
    dump = subprocess.run([tool("rawlog_dump"), rawlog], capture_output=True, text=True,
                          timeout=60, check=True).stdout
    stamps = np.loadtxt(dump.splitlines(), ndmin=2)[:, 1]
    assert np.all(np.diff(stamps) >= 0.25 - 1e-9)
    assert 30 <= len(stamps) <= 33


def test_bad_usage_and_unusable_bags(converted, tmp_path):
    exe = tool("bag_to_rawlog")
    out = str(tmp_path / "x.rawlog")
    bad = subprocess.run([exe, converted["bag"], out], capture_output=True, text=True)
    assert bad.returncode == 2 and "--scan-topic is required" in bad.stderr
    bad = subprocess.run([exe, converted["bag"], out, "--scan-topic", "/scan", "--min-interval",
                          "-1"], capture_output=True, text=True)
    assert bad.returncode == 2 and "--min-interval" in bad.stderr
    none = subprocess.run([exe, converted["bag"], out, "--scan-topic", "/nothing"],
                          capture_output=True, text=True)
    assert none.returncode == 1 and "0 LaserScans on /nothing" in none.stderr
    missing = subprocess.run([exe, str(tmp_path / "missing.bag"), out, "--scan-topic", "/scan"],
                             capture_output=True, text=True)
    assert missing.returncode == 1 and "missing.bag" in missing.stderr


def test_a_tf_stamp_near_2_to_the_32_is_skipped_with_a_warning(converted, tmp_path):
    # tf2 throws std::runtime_error (ros::Time out of range), not a TransformException, on such a
    # stamp: the conversion used to stop with exit 1.
    import genpy
    from geometry_msgs.msg import TransformStamped
    from tf2_msgs.msg import TFMessage
    bag = str(tmp_path / "far_tf.bag")
    with rosbag.Bag(converted["bag"]) as src, rosbag.Bag(bag, "w") as dst:
        for topic, msg, t in src.read_messages(raw=True):
            dst.write(topic, msg, t, raw=True)
        far = TransformStamped()
        far.header.stamp, far.header.frame_id, far.child_frame_id = genpy.Time(4294967290, 0), "base_link", "junk"
        far.transform.rotation.w = 1.0
        dst.write("/tf", TFMessage([far]), bagio.stamp(T0 + 1.0))
    rawlog = str(tmp_path / "far_tf.rawlog")
    run = subprocess.run([tool("bag_to_rawlog"), bag, rawlog, "--scan-topic", "/scan"], capture_output=True,
                         text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    assert "warning: 1 malformed transform(s) ignored" in run.stderr, run.stderr
    # Named as the nodes name it, against the time the bag recorded it.
    assert "'base_link' -> 'junk' on /tf with stamp 4294967290.000000000" in run.stderr, run.stderr
    assert "ahead of the clock" in run.stderr, run.stderr
    dump = subprocess.run([tool("rawlog_dump"), rawlog], capture_output=True, text=True, timeout=60, check=True)
    assert len(np.loadtxt(dump.stdout.splitlines(), ndmin=2)) == 94


def test_an_index_file_that_cannot_be_written_fails(converted, tmp_path):
    run = subprocess.run([tool("bag_to_rawlog"), converted["bag"], str(tmp_path / "x.rawlog"), "--scan-topic",
                          "/scan", "--index", str(tmp_path / "no_such_dir" / "x.index")],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 1 and "cannot write" in run.stderr and "x.index" in run.stderr, run.stderr


def test_a_truncated_rawlog_makes_rawlog_dump_fail(converted, tmp_path):
    with open(str(converted["dir"] / "known.rawlog"), "rb") as f:
        data = f.read()
    for cut in (len(data) // 2, len(data) - 100):
        broken = str(tmp_path / ("cut_%d.rawlog" % cut))
        with open(broken, "wb") as f:
            f.write(data[:cut])
        dump = subprocess.run([tool("rawlog_dump"), broken], capture_output=True, text=True, timeout=60)
        assert dump.returncode == 1, (cut, dump.stderr)
        assert "rawlog_dump: " + broken in dump.stderr, dump.stderr
