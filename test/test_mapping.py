"""Occupancy mapping against a small analytic world (walls and a table top)."""
import math
import os

import numpy as np
import pytest

from laserscan_toolbox.evaluation import mapping

RES = 0.05


class FakeScenario:
    """A 6 x 4 m room; a table top (0.7-0.75 m) at x 3.5..4.5, y 1.5..2.5 that the lidar
    plane (0.2 m) passes under."""

    def __init__(self):
        self.origin = (-1.0, -1.0)
        self.shape = (int(6 / RES), int(8 / RES))  # y: -1..5, x: -1..7

    def _grid(self, table):
        g = np.zeros(self.shape, bool)
        ys = self.origin[1] + (np.arange(self.shape[0]) + 0.5) * RES
        xs = self.origin[0] + (np.arange(self.shape[1]) + 0.5) * RES
        X, Y = np.meshgrid(xs, ys)
        g |= (np.abs(X - 0.0) < RES) | (np.abs(X - 6.0) < RES)
        g |= (np.abs(Y - 0.0) < RES) | (np.abs(Y - 4.0) < RES)
        g &= (X > -RES) & (X < 6 + RES) & (Y > -RES) & (Y < 4 + RES)
        if table:
            g |= (X > 3.5) & (X < 4.5) & (Y > 1.5) & (Y < 2.5)
        return g

    def ground_truth_grid(self, resolution, z_min, z_max, static_only=True):
        assert resolution == RES
        return self._grid(z_min <= 0.75 and z_max >= 0.7), self.origin

    def true_pose(self, t):
        return (1.0 + 0.1 * t, 1.0 + 0.05 * t, 0.2 * t)

    def scan(self, t, table, n=720):
        x, y, yaw = self.true_pose(t)
        g = self._grid(table)
        a = -math.pi + 2 * math.pi / n * np.arange(n)
        r = np.full(n, np.inf)
        for i, ang in enumerate(a):
            for d in np.arange(0.05, 8.0, RES / 4):
                px, py = x + d * math.cos(yaw + ang), y + d * math.sin(yaw + ang)
                ix = int((px - self.origin[0]) // RES)
                iy = int((py - self.origin[1]) // RES)
                if 0 <= iy < self.shape[0] and 0 <= ix < self.shape[1] and g[iy, ix]:
                    r[i] = d
                    break
        return {"stamp": t, "angle_min": -math.pi, "angle_increment": 2 * math.pi / n,
                "ranges": r}


@pytest.fixture(scope="module")
def world():
    sc = FakeScenario()
    times = np.arange(0.0, 10.0, 1.0)
    return sc, {"lidar only": [sc.scan(t, False) for t in times],
                "lidar + cameras": [sc.scan(t, True) for t in times]}


def test_grid_marks_hit_and_free_cells():
    g = mapping.Grid((0, 0), 0.1, (50, 50))
    g.integrate((1.0, 1.0, 0.0), 0.0, 0.1, [2.0])
    occ = g.occupied()
    assert occ[10, 30] and occ.sum() == 1
    assert g.known()[10, 11:29].all() and not g.occupied()[10, 11:29].any()


def test_a_cell_is_occupied_when_a_quarter_of_its_visits_are_hits():
    g = mapping.Grid((0, 0), 0.1, (50, 50))
    for _ in range(3):  # a table top seen three times by a camera ...
        g.integrate((1.0, 1.0, 0.0), 0.0, 0.1, [2.0])
    for _ in range(9):  # ... and passed under nine times by a lidar beam
        g.integrate((1.0, 1.0, 0.0), 0.0, 0.1, [3.0])
    assert g.occupied()[10, 30]
    g.integrate((1.0, 1.0, 0.0), 0.0, 0.1, [3.0])
    assert not g.occupied()[10, 30]  # 3 hits of 13 visits


def test_no_return_clears_nothing():
    g = mapping.Grid((0, 0), 0.1, (20, 20))
    g.integrate((1.0, 1.0, 0.0), 0.0, 0.1, [np.inf, np.nan, -np.inf])
    assert not g.known().any()


def test_maps_match_the_truth_and_only_the_fused_one_has_the_table(world, tmp_path):
    sc, streams = world
    ideal = streams["lidar + cameras"]  # the fake cameras see exactly the ideal scan
    f = mapping.mapping_experiment(streams, sc, str(tmp_path), resolution=RES,
                                   band=(0.05, 1.0), plane_band=(0.18, 0.22), ideal_scans=ideal)
    a, b = f["lidar only"], f["lidar + cameras"]
    assert f["reference_3d_cells"] > 20
    assert b["found_3d"] > 0.95 and b["iou"] > 0.95
    assert a["found_3d"] < 0.1 and a["iou"] < b["iou"]
    assert a["found"] > 0.5  # the walls are there
    assert a["false_cells"] == 0 and b["false_cells"] == 0
    assert os.path.getsize(tmp_path / "maps.png") > 10000
    assert (tmp_path / "map_0.pgm").read_bytes().startswith(b"P5\n160 120\n255\n")
    assert "resolution: 0.05" in (tmp_path / "map_1.yaml").read_text()


def test_compare_maps_counts_false_cells():
    truth = np.zeros((20, 20), bool)
    truth[10, :] = True
    g = mapping.Grid((0, 0), 1.0, (20, 20))
    g.misses[:] = 1
    g.hits[10, :] = 1
    g.hits[2, 2] = 1  # a ghost obstacle
    f = mapping.compare_maps({"m": g}, truth, np.zeros_like(truth))
    assert f["m"]["false_cells"] == 1
    assert f["m"]["found"] == 1.0
    assert f["m"]["iou_truth"] == pytest.approx(20 / 21)
