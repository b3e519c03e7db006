"""The OctoMap comparison's metrics on synthetic maps with known overlap: a projected map read
back from map_server files and put on the ground truth's grid, judged with the mapping
experiment's figures beside a 2D grid, and the targets of issue 20 on known runs."""
import os

import numpy as np
import pytest

from laserscan_toolbox.evaluation import mapping
from laserscan_toolbox.evaluation import octomap_comparison as oc

RES = 0.05
ORIGIN = (-0.5, 1.0)
SHAPE = (20, 20)  # 1 m x 1 m


def grid(occupied, resolution=RES, shape=SHAPE):
    """A map that knows every cell and has ``occupied`` ([row, col] list) occupied."""
    g = mapping.Grid(ORIGIN, resolution, shape)
    g.misses[:] = 1
    for r, c in occupied:
        g.hits[r, c], g.misses[r, c] = 1, 0
    return g


WALL = [(5, c) for c in range(2, 18)]    # in the lidars' plane
TABLE = [(12, c) for c in range(5, 10)]  # above it: a 3D obstacle


@pytest.fixture
def refs():
    truth = np.zeros(SHAPE, bool)
    plane = np.zeros(SHAPE, bool)
    for r, c in WALL:
        truth[r, c] = plane[r, c] = True
    for r, c in TABLE:
        truth[r, c] = True
    reference = grid(WALL + TABLE)
    return {"truth": truth, "plane": plane, "origin": ORIGIN, "resolution": RES,
            "reference": reference, "reference_3d": reference}


def projected(tmp_path, g):
    """The map as bag_to_octomap writes it (map_server files), back on the truth's grid."""
    g.save_pgm(str(tmp_path / "projected_map"))
    return str(tmp_path)


def test_map_server_files_read_back(tmp_path):
    g = grid([(3, 4)], shape=(6, 8))
    g.hits[0, 0] = g.misses[0, 0] = 0  # unknown
    p, limits = oc.read_map_server(os.path.join(projected(tmp_path, g), "projected_map.yaml"))
    assert p.shape == (6, 8)
    assert p[3, 4] == 1.0 and p[0, 0] == 0.5 and p[1, 1] == 0.0
    assert (p == 1.0).sum() == 1 and (p == 0.5).sum() == 1
    assert limits == pytest.approx((ORIGIN[0], ORIGIN[0] + 8 * RES, ORIGIN[1], ORIGIN[1] + 6 * RES))


def test_a_coarser_projection_covers_its_cells_on_the_truth_grid(tmp_path, refs):
    coarse = grid([(6, 3)], resolution=0.10, shape=(10, 10))
    m = oc.projected_grid(projected(tmp_path, coarse), refs)
    occ = m.occupied()
    assert occ.shape == SHAPE
    assert set(zip(*np.nonzero(occ))) == {(12, 6), (12, 7), (13, 6), (13, 7)}
    assert m.known().all()


def test_figures_of_maps_with_known_overlap(tmp_path, refs):
    false = [(18, 1), (0, 19)]  # far from every obstacle
    octomap = oc.projected_grid(projected(tmp_path, grid(WALL + TABLE + false)), refs)
    unified = grid(WALL + TABLE[:2])  # the table's first two cells: 3 of 5 within one cell
    f = mapping.compare_maps({"unified": unified, "octomap": octomap}, refs["truth"],
                             refs["plane"], refs["reference"], reference_3d=refs["reference_3d"])
    assert f["octomap"]["precision"] == pytest.approx(21 / 23)
    assert f["octomap"]["false_cells"] == 2
    assert f["octomap"]["found"] == pytest.approx(1.0)
    assert f["octomap"]["found_3d"] == pytest.approx(1.0)
    assert f["unified"]["precision"] == pytest.approx(1.0)
    assert f["unified"]["found_3d"] == pytest.approx(3 / 5)
    assert f["unified"]["found"] == pytest.approx(19 / 21)
    assert oc.grid_memory_mb(unified) == pytest.approx(400 / 1e6)


def run(method, n, res, cpu, mem, found3d, precision):
    return {"method": method, "points_per_camera": n, "resolution_m": res, "cpu_s_per_s": cpu,
            "map_memory_mb": mem, "obstacles_3d_found": found3d, "map_precision": precision}


def test_targets_on_known_runs():
    runs = [run("unified", 10000, 0.05, 0.10, 0.05, 0.70, 0.85),
            run("octomap", 10000, 0.05, 2.0, 10.0, 0.72, 0.88),
            run("octomap", 10000, 0.10, 0.5, 2.0, 0.90, 0.20),
            run("unified", 100000, 0.05, 0.12, 0.05, 0.60, 0.80),
            run("octomap", 100000, 0.05, 1.0, 0.4, 0.80, 0.90)]
    checks = oc.check_targets(runs)
    assert [ok for ok, _ in checks] == [
        True, True,            # 10k: 0.70 >= 0.9 x 0.72; 0.85 >= 0.88 - 0.05 (no CPU target below 100k)
        True,                  # 10k: memory 10 / 0.05 = 200
        False, False,          # 100k: 0.60 < 0.9 x 0.80; 0.80 < 0.90 - 0.05
        False,                 # 100k: CPU 1.0 / 0.12 = 8.3 < 10
        False,                 # 100k: memory 0.4 / 0.05 = 8 < 10
        True,                  # unified CPU 0.12 / 0.10 = 1.2 < 1.5: flat
        False]                 # OctoMap CPU 1.0 / 2.0: does not grow
    assert any("100k points: OctoMap CPU / unified CPU 8.3" in t for _, t in checks)
    assert oc.check_targets([runs[0]]) == []  # nothing to compare with


def test_voxel_band_raises_the_floor_to_a_voxel_boundary():
    assert oc.voxel_band((0.05, 1.0), 0.05)[0] == pytest.approx(0.05, abs=1e-5)
    assert oc.voxel_band((0.05, 1.0), 0.10)[0] == pytest.approx(0.10, abs=1e-5)
    assert oc.voxel_band((0.05, 1.0), 0.10)[1] == 1.0


def test_report_section_lists_every_run_and_target():
    from laserscan_toolbox.evaluation import report
    from laserscan_toolbox.evaluation.results import NotRun
    u = dict(run("unified", 100000, 0.05, 0.12, 0.11, 0.61, 0.945), map_recall=0.81,
             peak_memory_mb=25.0, slam={"map_precision": 0.979, "map_recall": 0.8,
                                        "obstacles_3d_found": 0.513, "wall_s_per_s": 0.138})
    o = dict(run("octomap", 100000, 0.05, 14.5, 58.7, 0.846, 0.846), map_recall=0.877,
             peak_memory_mb=162.0)
    res = {"runs": [u, o], "band_m": [0.05, 1.0], "cost_window_s": 2.0,
           "accuracy_interval_s": 1.0, "figure": "octomap_maps.png",
           "targets": [{"ok": ok, "check": c} for ok, c in oc.check_targets([u, o])]}
    text = "\n".join(report.octomap_section(res))
    assert "| unified | 100000 | 0.05 | 0.120 | 0.110 | 25 | 61.0 | 94.5 | 81.0 |" in text
    assert "SLAM: precision 97.9 %, 3D 51.3 %, rbpf-slam 0.138 s wall per s" in text
    assert "| octomap | 100000 | 0.05 | 14.500 | 58.700 | 162 | 84.6 | 84.6 | 87.7 |" in text
    assert "**missed:** 100k points: unified 3D obstacles found" in text
    assert "met: 100k points: OctoMap CPU / unified CPU 120.8 >= 10" in text
    assert "(octomap/octomap_maps.png)" in text
    assert "Not run: no depth" in "\n".join(report.octomap_section(NotRun("no depth")))
    assert "Not run: no ground truth" in "\n".join(report.octomap_section(None))
