"""rviz starts under Xvfb and draws the scans it is fed.

The first test starts its own roscore, publishes tf (odom -> base_link) and one scan or cloud
on every topic config/rviz/pipeline.rviz shows (each a ring at its own radius), takes a
screenshot with imagemagick and checks that the picture is not blank and that the enabled
scan displays' colours are on it. The second is a user's case: a real bag with other frames
and topics (test/data/real/dual_lidar_scans_demo.bag through launch/dual_lidar_demo.launch),
shown by launch/rviz.launch given that robot's fixed frame and topics. Set
RVIZ_SCREENSHOT_OUT to keep the first picture.
"""
import math
import os
import shutil
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
CONFIG = os.path.join(REPO, "config", "rviz", "pipeline.rviz")
DUAL_BAG = os.path.join(HERE, "data", "real", "dual_lidar_scans_demo.bag")
DUAL_LAUNCH = os.path.join(REPO, "launch", "dual_lidar_demo.launch")
# the dual-lidar robot: no odometry, so its base frame is the fixed frame
USER_VIEW = {"fixed_frame": "base_link", "robot_frame": "base_link",
             "scans": ["/front_scan", "/rear_scan"], "merged": ["/merged_scan"], "clouds": []}


def publish(config):
    """Runs in a subprocess: tf and a ring per display topic, 5 Hz, until killed."""
    import numpy as np
    import rospy
    import tf2_ros
    from geometry_msgs.msg import TransformStamped
    from sensor_msgs import point_cloud2
    from sensor_msgs.msg import LaserScan, PointCloud2
    from laserscan_toolbox.ros.rviz_shot import displays
    rospy.init_node("fake_pipeline")
    pubs = []
    for i, (cls, topic, _, _) in enumerate(displays(config)):
        kind = LaserScan if cls == "rviz/LaserScan" else PointCloud2
        pubs.append((kind, rospy.Publisher(topic, kind, queue_size=2), 1.0 + 0.6 * i))
    br = tf2_ros.TransformBroadcaster()
    rate = rospy.Rate(5)
    while not rospy.is_shutdown():
        now = rospy.Time.now()
        t = TransformStamped()
        t.header.stamp = now
        t.header.frame_id = "odom"
        t.child_frame_id = "base_link"
        t.transform.rotation.w = 1.0
        br.sendTransform(t)
        for kind, pub, radius in pubs:
            if kind is LaserScan:
                m = LaserScan()
                m.header.stamp = now
                m.header.frame_id = "base_link"
                m.angle_min, m.angle_max = -math.pi, math.pi
                m.angle_increment = math.pi / 180
                m.range_max = 30.0
                m.ranges = [radius] * 361
                pub.publish(m)
            else:
                a = np.linspace(-math.pi, math.pi, 2000)
                pts = np.stack([radius * np.cos(a), radius * np.sin(a), 0.3 + 0 * a], 1)
                h = rospy.Header(stamp=now, frame_id="base_link")
                pub.publish(point_cloud2.create_cloud_xyz32(h, pts.tolist()))
        rate.sleep()


def test_rviz_draws_the_pipeline(tmp_path):
    for tool in ("xvfb-run", "rviz", "import", "roscore"):
        assert shutil.which(tool), "%s is missing (Debian packages xvfb, rviz, imagemagick)" % tool
    from laserscan_toolbox.ros.rosrun import Roscore, stop_process
    from laserscan_toolbox.ros.rviz_shot import displays, image_stats, screenshot
    with Roscore(str(tmp_path / "ros")) as core:
        pub = subprocess.Popen([sys.executable, __file__, "--publish", CONFIG], env=core.env,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                               start_new_session=True)
        try:
            shot = screenshot(CONFIG, str(tmp_path / "rviz.png"), delay=12.0, env=core.env)
        finally:
            stop_process(pub)
    colours = [c for _, _, c, enabled in displays(CONFIG) if enabled]
    st = image_stats(shot, colours)
    keep = os.environ.get("RVIZ_SCREENSHOT_OUT")
    if keep:
        shutil.copy(shot, keep)
    assert st["std"] > 10, "the screenshot is blank"
    for c, n in st["counts"].items():
        assert n > 200, "display colour %s barely on screen (%d pixels): %s" % (c, n, st)


def test_generated_view_of_the_simulated_robot_is_the_shipped_one(tmp_path):
    """rviz.launch's defaults write what config/rviz/pipeline.rviz shows (enabled displays)."""
    from laserscan_toolbox.ros import rviz_config as rc
    from laserscan_toolbox.ros.rviz_shot import displays
    path = rc.write_config(rc.make_config(**rc.SIM_VIEW), str(tmp_path / "sim.rviz"))
    assert sorted(displays(path)) == sorted(d for d in displays(CONFIG) if d[3])
    path = rc.write_config(rc.make_config(**USER_VIEW), str(tmp_path / "user.rviz"))
    assert [d[1] for d in displays(path)] == ["/front_scan", "/rear_scan", "/merged_scan"]
    assert len({d[2] for d in displays(path)}) == 3  # a colour each
    with open(path) as f:
        text = f.read()
    assert "Fixed Frame: base_link" in text and "odom" not in text
    assert rc.rviz_command(["/usr/bin/rviz", "-d", "old.rviz", "__name:=rviz"], path, "base_link") \
        == ["/usr/bin/rviz", "-d", path, "-f", "base_link", "__name:=rviz"]
    assert rc.topic_list(["/a /b,/c", "none", ""]) == ["/a", "/b", "/c"]
    with pytest.raises(ValueError):
        rc.make_config("", "base_link", [], [], [])


def test_command_lines(tmp_path):
    tools = os.path.join(REPO, "scripts")

    def run(*args):
        return subprocess.run([sys.executable] + list(args), capture_output=True, text=True,
                              timeout=60)
    out = tmp_path / "mine.rviz"
    p = run(os.path.join(tools, "rviz_config"), "--fixed-frame", "map", "--scans", "/a,/b",
            "--merged", "none", "--clouds", "none", "--output", str(out))
    assert p.returncode == 0, p.stderr
    from laserscan_toolbox.ros.rviz_shot import displays
    assert [d[1] for d in displays(str(out))] == ["/a", "/b"]
    assert "Fixed Frame: map" in out.read_text()
    p = run(os.path.join(tools, "rviz_config"), "--template", str(tmp_path / "none.rviz"))
    assert p.returncode == 2 and "none.rviz" in p.stderr
    p = run(os.path.join(tools, "rviz_config"), "--fixed-frame", "")
    assert p.returncode == 2 and "fixed frame" in p.stderr
    p = run(os.path.join(tools, "rviz_screenshot"), str(tmp_path / "none.bag"))
    assert p.returncode == 2 and "no such bag" in p.stderr
    p = run(os.path.join(tools, "rviz_screenshot"), DUAL_BAG, "--play", "0")
    assert p.returncode == 2
    p = run(os.path.join(tools, "rviz_screenshot"), "--help")
    assert p.returncode == 0 and "--fixed-frame" in p.stdout


def test_rviz_launch_shows_a_users_bag(tmp_path):
    """launch/rviz.launch with the dual-lidar robot's fixed frame and topics, while its real
    bag plays through dual_lidar_demo.launch: no display in error (the panel shows no red
    error icon) and every scan drawn. The control, the simulated robot's view on the same
    bag, shows errors and no input scan: the check can fail."""
    for tool in ("xvfb-run", "rviz", "import", "roscore"):
        assert shutil.which(tool), "%s is missing (Debian packages xvfb, rviz, imagemagick)" % tool
    from laserscan_toolbox.ros import rviz_config as rc
    from laserscan_toolbox.ros.rviz_shot import (bag_screenshot, displays, error_icons, image_stats,
                                             rviz_launch_command)
    user_config = rc.write_config(rc.make_config(**USER_VIEW), str(tmp_path / "user.rviz"))
    colours = [c for _, _, c, _ in displays(user_config)]
    shot = bag_screenshot(DUAL_BAG, DUAL_LAUNCH, None, str(tmp_path / "user.png"), start=5.0,
                          workdir=str(tmp_path / "user"), command=rviz_launch_command(USER_VIEW))
    st = image_stats(shot, colours)
    assert error_icons(shot) == [], "rviz reports an error: %s" % shot
    for c, n in st["counts"].items():
        assert n > 200, "display colour %s barely on screen (%d pixels): %s" % (c, n, st)

    control = bag_screenshot(DUAL_BAG, DUAL_LAUNCH, CONFIG, str(tmp_path / "sim_view.png"),
                             start=5.0, workdir=str(tmp_path / "control"))
    assert len(error_icons(control)) >= 2  # Global Status and the merged scan's display
    inputs = image_stats(control, colours[:2])["counts"]
    assert all(n < 100 for n in inputs.values()), inputs


if __name__ == "__main__" and sys.argv[1:2] == ["--publish"]:
    publish(sys.argv[2])
