"""bag_to_octomap on a small bag with known geometry.

The robot stands at (1, 2) turned by 90 degrees (it looks along the map's +y) for 1 s; a depth
camera 0.5 m above base_link looks straight ahead and sees, 2 m in front of it, the face of a
box (0.2-0.8 m high) with a table top's edge above it (0.68-0.74 m is in the box too, so the
table is the box's upper part) and, 3 m in front, a shelf board at 1.40-1.50 m, above the
robot's band; a lidar 0.2 m above base_link sees one wall point 2 m to the robot's right. One
depth image has no camera_info of its stamp.
"""
import json
import math
import os
import subprocess

import numpy as np
import pytest

import rosbag
from laserscan_toolbox.ros import bagio
from laserscan_toolbox.evaluation.slam import tool
from laserscan_toolbox.evaluation.octomap_comparison import read_map_server

T0 = 1000.0
ROBOT = (1.0, 2.0, math.pi / 2)
CAMERA_Z, LIDAR_Z = 0.5, 0.2
W, H, F = 80, 60, 40.0         # pixels, focal length in pixels
CX, CY = (W - 1) / 2.0, (H - 1) / 2.0
BOX = (2.02, -0.3, 0.15, 0.2, 0.8)     # depth, lateral (robot's left +) lo/hi, height lo/hi: not symmetric
SHELF = (3.02, -0.4, 0.4, 1.40, 1.50)
RES = 0.05
BAND = (0.05, 1.0)


def depth_image():
    """mm depths: per pixel, the nearer of the box face and the shelf board it sees, else 0."""
    u, v = np.meshgrid(np.arange(W), np.arange(H))
    depth = np.zeros((H, W))
    for d, lo, hi, zlo, zhi in (SHELF, BOX):  # the box last: it is nearer
        lateral = -(u - CX) / F * d            # optical x right = robot's -y
        height = CAMERA_Z - (v - CY) / F * d   # optical y down
        hit = (lateral >= lo) & (lateral <= hi) & (height >= zlo) & (height <= zhi)
        depth[hit] = d
    return np.round(depth * 1000).astype("<u2")


def write_bag(path):
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import CameraInfo, Image, LaserScan
    with rosbag.Bag(path, "w") as bag:
        optical = (-0.5, 0.5, -0.5, 0.5)  # z forward, x right, y down in base_link
        bagio.write_latched(bag, "/tf_static", bagio.tf_message([
            bagio.transform(T0, "base_link", "camera_optical", (0.0, 0.0, CAMERA_Z), optical),
            bagio.transform(T0, "base_link", "laser", (0.0, 0.0, LIDAR_Z), (0, 0, 0, 1))]), T0)
        for k in range(11):
            t = T0 + 0.1 * k
            m = Odometry()
            m.header.stamp = bagio.stamp(t)
            m.header.frame_id, m.child_frame_id = "map", "base_link"
            m.pose.pose.position.x, m.pose.pose.position.y = ROBOT[:2]
            m.pose.pose.orientation.z = math.sin(ROBOT[2] / 2)
            m.pose.pose.orientation.w = math.cos(ROBOT[2] / 2)
            bag.write("/ground_truth/odom", m, bagio.stamp(t))
        data = depth_image().tobytes()
        for k in range(5):
            t = T0 + 0.1 + 0.2 * k
            img = Image()
            img.header.stamp = bagio.stamp(t)
            img.header.frame_id = "camera_optical"
            img.height, img.width, img.encoding, img.step = H, W, "16UC1", 2 * W
            img.data = data
            bag.write("/camera/depth/image_rect", img, bagio.stamp(t))
            if k != 4:  # the last image has no camera_info of its stamp
                info = CameraInfo()
                info.header = img.header
                info.height, info.width = H, W
                info.P = [F, 0, CX, 0, 0, F, CY, 0, 0, 0, 1, 0]
                bag.write("/camera/depth/camera_info", info, bagio.stamp(t))
            s = LaserScan()
            s.header.stamp = bagio.stamp(t)
            s.header.frame_id = "laser"
            s.angle_min, s.angle_increment = -math.pi / 2, math.pi / 2
            s.angle_max = math.pi / 2
            s.range_min, s.range_max = 0.1, 10.0
            s.ranges = [2.02, float("inf"), float("nan")]  # right: a wall point; ahead, left: nothing
            bag.write("/scan", s, bagio.stamp(t))


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    d = tmp_path_factory.mktemp("octomap")
    bag = str(d / "known.bag")
    write_bag(bag)
    out = str(d / "out")
    p = subprocess.run([tool("bag_to_octomap"), bag, out, "--pose-topic", "/ground_truth/odom",
                        "--depth-topic", "/camera/depth/image_rect", "--scan-topic", "/scan",
                        "--band-min", str(BAND[0]), "--band-max", str(BAND[1]),
                        "--voxels", str(d / "voxels.txt")], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    voxels = np.loadtxt(str(d / "voxels.txt"), ndmin=2)
    with open(os.path.join(out, "figures.json")) as f:
        figures = json.load(f)
    return {"dir": d, "bag": bag, "out": out, "voxels": voxels, "figures": figures,
            "stderr": p.stderr}


def to_map(depth, lateral):
    """Robot-frame (forward, left) -> map (x, y) for the robot's pose."""
    x, y, yaw = ROBOT
    return (x + depth * math.cos(yaw) - lateral * math.sin(yaw),
            y + depth * math.sin(yaw) + lateral * math.cos(yaw))


def test_occupied_voxels_are_at_the_box_shelf_and_wall_within_one_voxel(built):
    v = built["voxels"]
    occ = v[v[:, 4] == 1]
    assert len(occ) > 50
    box_y = to_map(BOX[0], 0)[1]
    shelf_y = to_map(SHELF[0], 0)[1]
    wall = to_map(0.0, -2.02)  # 2 m to the robot's right
    x_lo, x_hi = sorted((to_map(BOX[0], BOX[1])[0], to_map(BOX[0], BOX[2])[0]))
    at_box = (np.abs(occ[:, 1] - box_y) <= RES) & (occ[:, 0] >= x_lo - RES) & (occ[:, 0] <= x_hi + RES) \
        & (occ[:, 2] >= BOX[3] - RES) & (occ[:, 2] <= BOX[4] + RES)
    at_shelf = (np.abs(occ[:, 1] - shelf_y) <= RES) & (occ[:, 2] >= SHELF[3] - RES) \
        & (occ[:, 2] <= SHELF[4] + RES)
    at_wall = (np.abs(occ[:, 0] - wall[0]) <= RES) & (np.abs(occ[:, 1] - wall[1]) <= RES) \
        & (np.abs(occ[:, 2] - LIDAR_Z) <= RES)
    assert np.all(at_box | at_shelf | at_wall), occ[~(at_box | at_shelf | at_wall)][:5]
    assert at_box.sum() > 20 and at_shelf.sum() > 5 and at_wall.sum() == 1
    # the whole face of the box is there: every 5 cm of its width and height
    for lateral in np.arange(BOX[1] + 0.025, BOX[2], RES):
        for z in np.arange(BOX[3] + 0.025, BOX[4], RES):
            x, _ = to_map(BOX[0], lateral)
            near = at_box & (np.abs(occ[:, 0] - x) <= RES) & (np.abs(occ[:, 2] - z) <= RES)
            assert near.any(), (lateral, z)


def test_free_voxels_in_front_of_the_box(built):
    v = built["voxels"]
    def leaf(depth, lateral, z):  # probes off the voxel boundaries
        x, y = to_map(depth, lateral)
        half = v[:, 3] / 2
        return v[(np.abs(v[:, 0] - x) < half) & (np.abs(v[:, 1] - y) < half)
                 & (np.abs(v[:, 2] - z) < half)]

    for depth in (0.51, 1.01, 1.51, 1.91):
        f = depth / BOX[0]  # on rays to the box face's middle and towards two of its corners
        for lateral, z in ((0.01, CAMERA_Z + 0.01), (0.12 * f, CAMERA_Z - 0.22 * f),
                           (-0.22 * f, CAMERA_Z + 0.22 * f)):
            found = leaf(depth, lateral, z)
            assert len(found) == 1 and found[0, 4] == 0, (depth, lateral, z)
    assert len(leaf(2.51, 0.01, CAMERA_Z + 0.01)) == 0  # behind the box: never seen


def test_projection_keeps_the_table_and_drops_the_shelf_above_the_band(built):
    p, (x0, x1, y0, y1) = read_map_server(os.path.join(built["out"], "projected_map.yaml"))
    res = (x1 - x0) / p.shape[1]
    assert res == pytest.approx(RES)

    def cell(x, y):
        return p[int((y - y0) // res), int((x - x0) // res)]

    bx, by = to_map(BOX[0] + 0.02, 0.0)
    assert cell(bx, by) == 1.0                       # box and table top: in the band
    sx, sy = to_map(SHELF[0] + 0.02, 0.0)
    assert cell(sx, sy) != 1.0                       # shelf board above the band: dropped
    fx, fy = to_map(1.0, 0.0)
    assert cell(fx, fy) == 0.0                       # in front of the box: free
    wx, wy = to_map(0.0, -2.02)
    assert cell(wx, wy) == 1.0                       # the lidar's wall point
    occupied_rows = np.unique(np.nonzero(p == 1.0)[0])
    assert len(occupied_rows) <= 3                   # only the box's row (+-1) and the wall's
    assert built["figures"]["projected_map"]["occupied_cells"] == int((p == 1.0).sum())


def test_figures_file_is_complete(built):
    f = built["figures"]
    n_images, n_scans = 4, 5
    returns = int(np.count_nonzero(depth_image()))
    assert f["depth_messages_inserted"] == n_images and f["scans_inserted"] == n_scans
    assert f["points_inserted"] == n_images * returns + n_scans * 1
    assert f["left_out"] == {"depth image without a camera_info of its stamp on "
                             "/camera/depth/camera_info": 1}
    assert f["resolution_m"] == RES and f["band_m"] == list(BAND)
    for key in ("cpu_s", "cpu_s_per_s", "octomap_cpu_s", "octomap_cpu_s_per_s", "insert_cpu_s",
                "update_cpu_s", "peak_rss_mb", "tree_memory_mb", "data_s"):
        assert f[key] is not None and f[key] > 0, key
    assert f["cpu_s_per_s"] == pytest.approx(f["cpu_s"] / f["data_s"])
    assert f["tree_nodes"] >= f["tree_leaves"] == len(built["voxels"])
    assert f["octomap_cpu_s"] == pytest.approx(f["insert_cpu_s"] + f["update_cpu_s"], rel=1e-6)
    assert os.path.getsize(os.path.join(built["out"], "octomap.bt")) > 100


def test_thinning_and_window(built, tmp_path):
    out = str(tmp_path / "thin")
    p = subprocess.run([tool("bag_to_octomap"), built["bag"], out, "--pose-topic",
                        "/ground_truth/odom", "--depth-topic", "/camera/depth/image_rect",
                        "--scan-topic", "/scan", "--min-interval", "0.35", "--duration", "0.6"],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    with open(os.path.join(out, "figures.json")) as f:
        f = json.load(f)
    # messages at 0.1, 0.3, 0.5 s within the 0.6 s window; one per topic per 0.35 s: 0.1 and 0.5
    assert f["depth_messages_inserted"] == 2 and f["scans_inserted"] == 2
    assert f["messages_thinned"] == 2
    assert f["data_s"] == pytest.approx(0.6)


@pytest.mark.parametrize("args, status", [
    ([], 2),
    (["--depth-topic", "/camera/depth/image_rect"], 2),                      # no pose source
    (["--pose-topic", "/ground_truth/odom"], 2),                             # no data topic
    (["--pose-topic", "/x", "--poses", "f", "--scan-topic", "/scan"], 2),    # two pose sources
    (["--pose-topic", "/ground_truth/odom", "--scan-topic", "/scan", "--resolution", "0"], 2),
    (["--pose-topic", "/nothing", "--scan-topic", "/scan"], 1),              # no poses
    (["--pose-topic", "/ground_truth/odom", "--scan-topic", "/nothing"], 1),  # nothing inserted
])
def test_bad_usage_and_unusable_input(built, tmp_path, args, status):
    p = subprocess.run([tool("bag_to_octomap"), built["bag"], str(tmp_path / "o")] + args,
                       capture_output=True, text=True)
    assert p.returncode == status, p.stderr
    assert "bag_to_octomap: " in p.stderr


def test_poses_from_a_path_file(built, tmp_path):
    path = tmp_path / "path.txt"
    path.write_text("# stamp x y yaw\n%.17g %.17g %.17g %.17g\n%.17g %.17g %.17g %.17g\n" % (
        (T0,) + ROBOT + (T0 + 1.0,) + ROBOT))
    out = str(tmp_path / "p")
    p = subprocess.run([tool("bag_to_octomap"), built["bag"], out, "--poses", str(path),
                        "--depth-topic", "/camera/depth/image_rect", "--scan-topic", "/scan"],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    with open(os.path.join(out, "figures.json")) as f:
        assert json.load(f)["points_inserted"] == built["figures"]["points_inserted"]
    assert open(os.path.join(out, "projected_map.pgm"), "rb").read() == \
        open(os.path.join(built["out"], "projected_map.pgm"), "rb").read()
