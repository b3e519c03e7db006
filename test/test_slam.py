"""The SLAM experiment's alignment and metrics on synthetic paths and maps with known
offsets (laserscan_toolbox.evaluation.slam); the MRPT runs themselves are in test_end_to_end.py."""
import dataclasses
import math
import os

import numpy as np
import pytest

from laserscan_toolbox.evaluation import mapping, slam
from laserscan_toolbox.evaluation.results import NotRun, SlamRun

RES = 0.05


def rot(theta):
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


def test_rigid_fit_recovers_a_known_rotation_and_translation():
    rng = np.random.default_rng(3)
    src = rng.uniform(-5, 5, (200, 2))
    theta, t = 0.37, np.array([2.0, -1.5])
    dst = src @ rot(theta).T + t
    th, tt = slam.fit_rigid_2d(src, dst)
    assert th == pytest.approx(theta, abs=1e-12)
    np.testing.assert_allclose(tt, t, atol=1e-12)
    rmse, _, _ = slam.aligned_rmse(src, dst)
    assert rmse == pytest.approx(0.0, abs=1e-12)


def test_aligned_rmse_is_the_noise_not_the_frame_offset():
    rng = np.random.default_rng(4)
    s = np.linspace(0, 20, 400)
    true = np.column_stack([s, np.sin(s / 3) * 3])
    noise = rng.normal(0, 0.05, true.shape)
    # an estimate in another frame (the SLAM's first pose), with 5 cm of noise
    est = (true + noise - [3, 2]) @ rot(-0.8).T
    rmse, theta, _ = slam.aligned_rmse(est, true)
    assert rmse == pytest.approx(np.sqrt(np.mean(np.sum(noise ** 2, 1))), rel=0.05)
    assert theta == pytest.approx(0.8, abs=0.01)
    # a path that drifts (odometry) keeps its error after the fit
    drift = true + np.column_stack([0.05 * s, 0.0 * s])
    assert slam.aligned_rmse(drift, true)[0] > 0.1


def room_refs():
    """A 6 x 4 m room (walls) with a table top above the lidars' plane."""
    shape = (int(5 / RES), int(8 / RES))  # y -1..4, x -1..7
    ys = -1 + (np.arange(shape[0]) + 0.5) * RES
    xs = -1 + (np.arange(shape[1]) + 0.5) * RES
    X, Y = np.meshgrid(xs, ys)
    walls = ((np.abs(X) < RES) | (np.abs(X - 6) < RES)) & (Y > -RES) & (Y < 3 + RES)
    walls |= ((np.abs(Y) < RES) | (np.abs(Y - 3) < RES)) & (X > -RES) & (X < 6 + RES)
    table = (X > 3.5) & (X < 4.5) & (Y > 1.0) & (Y < 2.0)
    reference = mapping.Grid((-1, -1), RES, shape)
    reference.hits[walls | table] = 1
    reference.misses[~(walls | table) & (X > 0) & (X < 6) & (Y > 0) & (Y < 3)] = 1
    return {"truth": walls | table, "plane": walls, "origin": (-1.0, -1.0), "resolution": RES,
            "reference": reference, "reference_3d": reference}, X, Y


def slam_map_of(occupied_world, theta, t, res=0.04):
    """P(occupied) grid in a frame where world = R(theta) p + t, as rbpf-slam writes it:
    returns (p_occ [row = y], limits)."""
    limits = (-8.0, 8.0, -8.0, 8.0)
    n = int(16 / res)
    c = -8 + (np.arange(n) + 0.5) * res
    PX, PY = np.meshgrid(c, c)
    world = np.column_stack([PX.ravel(), PY.ravel()]) @ rot(theta).T + t
    p = np.full(PX.size, 0.5)  # unknown outside the room, known free inside
    inside = (world[:, 0] > -0.5) & (world[:, 0] < 6.5) & (world[:, 1] > -0.5) & (world[:, 1] < 3.5)
    p[inside] = 0.3
    p[occupied_world(world[:, 0], world[:, 1])] = 0.9
    return p.reshape(n, n), limits


def test_map_in_another_frame_matches_after_the_fit_and_not_without():
    refs, X, Y = room_refs()
    theta, t = 0.6, np.array([1.2, -0.7])

    def occupied(x, y):
        walls = ((np.abs(x) < RES) | (np.abs(x - 6) < RES)) & (y > -RES) & (y < 3 + RES)
        walls |= ((np.abs(y) < RES) | (np.abs(y - 3) < RES)) & (x > -RES) & (x < 6 + RES)
        return walls  # the lidar-only SLAM map: no table top

    p_occ, limits = slam_map_of(occupied, theta, t)
    grid = slam.ResampledMap(p_occ, limits, theta, t, refs)
    f = mapping.compare_maps({"m": grid}, refs["truth"], refs["plane"], refs["reference"],
                             tolerance_cells=2, reference_3d=refs["reference_3d"])["m"]
    assert f["precision"] > 0.99
    walls_share = refs["plane"].sum() / refs["truth"].sum()  # the table top's cells are missing
    assert f["found"] == pytest.approx(walls_share, abs=0.03)
    assert f["found_3d"] == pytest.approx(0.0, abs=0.01)
    # the same map placed 0.3 m off: most of its cells are now far from every obstacle
    off = slam.ResampledMap(p_occ, limits, theta, t + [0.3, 0.3], refs)
    f_off = mapping.compare_maps({"m": off}, refs["truth"], refs["plane"], refs["reference"],
                                 tolerance_cells=2)["m"]
    assert f_off["precision"] < 0.5


def test_table_tops_in_the_slam_map_count_as_3d_obstacles():
    refs, _, _ = room_refs()

    def occupied(x, y):
        return (x > 3.5) & (x < 4.5) & (y > 1.0) & (y < 2.0)

    p_occ, limits = slam_map_of(occupied, 0.0, np.zeros(2))
    grid = slam.ResampledMap(p_occ, limits, 0.0, np.zeros(2), refs)
    f = mapping.compare_maps({"m": grid}, refs["truth"], refs["plane"], refs["reference"],
                             tolerance_cells=2, reference_3d=refs["reference_3d"])["m"]
    assert f["found_3d"] > 0.9
    # unknown cells of the SLAM map (P = 0.5) are neither free nor occupied
    assert not grid.known()[0, 0] and not grid.occupied()[0, 0]


def test_ini_values_replace_existing_keys_and_append_missing_ones():
    text = "# c\n[A]\nx=1\ny = 2\n[B]\nx=3\n"
    out = slam.ini_with(text, {"A": {"y": 5, "z": 6}, "B": {"x": "p"}, "C": {"k": 1}})
    assert out.splitlines() == ["# c", "[A]", "x=1", "y=5", "z=6", "[B]", "x=p", "[C]", "k=1"]


def test_pf_estimates_are_read_from_the_log():
    lines = ["[12:00|INFO |MonteCarloLocalization_Rawlog] Step 3. Executing",
             "[12:00|INFO |MonteCarloLocalization_Rawlog] PDF estimation: (3.603,5.001,72.28deg), "
             "ESS (B.R.)= 0 tr(cov): 0.17",
             "PDF estimation: (-1.5e-01,2,-90.00deg), ESS (B.R.)= 0.4"]
    m = slam.parse_pf_estimates(lines)
    np.testing.assert_allclose(m, [[3.603, 5.001, math.radians(72.28)], [-0.15, 2, -math.pi / 2]])
    assert slam.parse_pf_estimates(["nothing"]).shape == (0, 3)


class LineScenario:
    def true_pose(self, t):
        return (float(t), 0.0, 0.0)


def test_map_path_is_the_most_likely_particles_at_the_map_updates():
    # rbpf-slam's files: the per-step mean path (stamp per step), log_times.txt (4th column:
    # filter and map updated at this step), most_likely_path.txt (initial pose + one per update)
    path = np.column_stack([100.0 + np.arange(6), np.arange(6.0), np.zeros(6), np.zeros(6)])
    times = np.array([[k, 1.0, 1, u] for k, u in enumerate([1, 0, 1, 0, 0, 1])], float)
    most_likely = np.array([[0, 0, 0], [0.01, 0, 0], [2.02, 0.1, 0.05], [5.03, 0.2, 0.1]])
    mp = slam.read_map_path(most_likely, times, path)
    np.testing.assert_allclose(mp[:, 0], [100.0, 102.0, 105.0])  # stamps of the update steps
    np.testing.assert_allclose(mp[:, 1:], most_likely[1:])       # the initial pose left out
    with pytest.raises(slam.SlamError, match="most_likely_path"):
        slam.read_map_path(most_likely[1:], times, path)


def test_shipped_rbpf_config_updates_filter_and_map_together():
    """read_map_path stamps the most likely particle's poses by the map updates: the shipped
    rbpf-slam config must run the filter at exactly those steps."""
    import configparser
    ini = configparser.ConfigParser(inline_comment_prefixes=("#", ";"), strict=False)
    ini.read(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..",
                          "scan_evaluation_tools", "config", "rbpf_slam.ini"))
    app = ini["MappingApplication"]
    assert float(app["localizeLinDistance"]) == float(app["insertionLinDistance"])
    assert float(app["localizeAngDistance_deg"]) == float(app["insertionAngDistance_deg"])


class LoopScenario:
    """Drives around the room of room_refs: (1, 1) -> (5, 1) -> (5, 2) -> (1, 2), 1 m/s."""
    corners = np.array([[1.0, 1.0], [5.0, 1.0], [5.0, 2.0], [1.0, 2.0]])

    def true_pose(self, t):
        d = np.r_[0.0, np.cumsum(np.hypot(*np.diff(self.corners, axis=0).T))]
        i = min(int(np.searchsorted(d, t, side="right")) - 1, len(self.corners) - 2)
        a, b = self.corners[i], self.corners[i + 1]
        f = min(max((t - d[i]) / (d[i + 1] - d[i]), 0.0), 1.0)
        x, y = a + f * (b - a)
        return (float(x), float(y), math.atan2(*(b - a)[::-1]))


def test_the_map_is_placed_by_its_own_particles_path_not_by_the_mean_path():
    """rbpf-slam saves the most likely particle's map; the per-step path is the particles'
    mean, which can be turned against it (the heading spread of the particles). Placed by
    the mean path, a correct map looks turned (thick walls); placed by its own path it fits."""
    refs, _, _ = room_refs()
    theta, t = 0.4, np.array([0.5, -0.3])   # SLAM frame -> world: world = R(theta) p + t

    def walls(x, y):
        w = ((np.abs(x) < RES) | (np.abs(x - 6) < RES)) & (y > -RES) & (y < 3 + RES)
        return w | (((np.abs(y) < RES) | (np.abs(y - 3) < RES)) & (x > -RES) & (x < 6 + RES))

    p_occ, limits = slam_map_of(walls, theta, t)
    sc = LoopScenario()
    stamps = np.linspace(0.0, 9.0, 91)
    true = np.array([sc.true_pose(s) for s in stamps])
    own = (true[:, :2] - t) @ rot(theta)               # the particle's path, in the SLAM frame
    c = own.mean(0)
    turn = 6.0  # degrees: in this 6 m room as much as a degree or two in the 30 m shop floor
    mean = (own - c) @ rot(math.radians(turn)).T + c   # the mean path, turned
    path = np.column_stack([stamps, mean, true[:, 2] - theta])
    updates = np.arange(0, 91, 5)
    run = {"path": path, "map_path": np.column_stack([stamps[updates], own[updates],
                                                      true[updates, 2] - theta]),
           "map": p_occ, "limits": limits, "wall_s": 1.0}
    index = np.column_stack([np.arange(91), stamps, true])
    fig, _ = slam.evaluate_slam(run, index, sc, refs)
    assert fig["map_precision"] > 0.99, fig
    assert fig["map_path_rmse_m"] == pytest.approx(0.0, abs=1e-9)
    assert fig["map_alignment_deg"] == pytest.approx(math.degrees(theta), abs=1e-6)
    assert fig["alignment_deg"] == pytest.approx(math.degrees(theta) - turn, abs=1e-6)
    # the same map placed by the mean path's fit: turned, walls off by up to 30 cm
    r, th, tt = slam.aligned_rmse(mean, true[:, :2])
    off = slam.ResampledMap(p_occ, limits, th, tt, refs)
    f_off = mapping.compare_maps({"m": off}, refs["truth"], refs["plane"], refs["reference"],
                                 tolerance_cells=2)["m"]
    assert f_off["precision"] < 0.8, f_off


def test_localization_rmse_of_the_particle_mean():
    index = np.column_stack([np.arange(5), np.arange(5.0), np.zeros((5, 3))])
    mean = np.column_stack([np.arange(5.0), [0.0, 0.1, -0.1, 0.1, -0.1], np.zeros(5)])
    f = slam.evaluate_localization({"mean": mean, "wall_s": 1.0}, index, LineScenario())
    assert f["rmse_m"] == pytest.approx(math.sqrt(4 * 0.01 / 5))
    assert f["steps"] == 5 and f["max_error_m"] == pytest.approx(0.1)


def results(rmse_l=0.05, rmse_u=0.06, prec=0.95, f3l=0.1, f3u=0.3, loc_l=0.05, loc_u=0.06):
    return SlamRun(slam={"/lidar_scan": {"path_rmse_m": rmse_l, "map_precision": 0.97,
                                         "obstacles_3d_found": f3l},
                         "/slam_scan": {"path_rmse_m": rmse_u, "map_precision": prec,
                                        "obstacles_3d_found": f3u}},
                   localization={"/lidar_scan": {"rmse_m": loc_l}, "/slam_scan": {"rmse_m": loc_u}},
                   figures={}, min_interval_s=slam.MIN_INTERVAL, seed=0, tolerance_m=slam.MAP_TOLERANCE)


def test_targets_pass_and_fail_on_the_right_figures():
    assert all(ok for ok, _ in slam.check_targets(results()))
    cases = {"/lidar_scan path_rmse_m": results(rmse_l=0.2),
             "/slam_scan path_rmse_m": results(rmse_u=0.11),
             "map_precision": results(prec=0.85),
             "obstacles_3d_found": results(f3u=0.19),
             "localization": results(loc_u=0.071)}
    for word, res in cases.items():
        failed = [text for ok, text in slam.check_targets(res) if not ok]
        assert len(failed) == 1 and word in failed[0], (word, failed)
    # missing figures fail (NaN compares false), and so does every target of a SLAM run that
    # failed or was not run
    for run in (dataclasses.replace(results(), slam={}, localization={}), NotRun("rbpf-slam died", failed=True),
                None):
        failed = [text for ok, text in slam.check_targets(run) if not ok]
        assert len(failed) == 4, (run, failed)
    # no 3D obstacles in either map is not "twice as many"
    assert not all(ok for ok, _ in slam.check_targets(results(f3l=0.0, f3u=0.0)))


def test_map_figure_puts_each_slam_map_under_its_own_scans_known_pose_map(tmp_path):
    assert slam.map_columns({"/lidar_scan": 0, "/slam_scan": 0, "/merged_scan": 0},
                            {"/slam_scan": 0, "/lidar_scan": 0}) == ["/lidar_scan", "/slam_scan", "/merged_scan"]
    assert slam.map_columns({"/lidar_scan": 0}, {"/lidar_scan": 0, "/x": 0}) == ["/lidar_scan", "/x"]
    refs, _, _ = room_refs()
    p_occ, limits = slam_map_of(lambda x, y: (np.abs(x) < RES) & (y > 0) & (y < 3), 0.0, np.zeros(2))
    grid = slam.ResampledMap(p_occ, limits, 0.0, np.zeros(2), refs)
    refs["maps"] = {"/lidar_scan": refs["reference"], "/slam_scan": refs["reference"],
                    "/merged_scan": refs["reference"]}
    figures = {"/lidar_scan": {"path_rmse_m": 0.01, "map_precision": 0.9, "obstacles_3d_found": 0.1}}
    out = tmp_path / "slam_maps.png"
    assert slam.plot_maps(figures, {"/lidar_scan": {"grid": grid}}, refs, str(out)) == "slam_maps.png"
    assert out.stat().st_size > 1000
