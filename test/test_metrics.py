"""Metrics on scans whose errors are known by construction."""

import numpy as np
import pytest

from laserscan_toolbox.evaluation import metrics


def wall(n=360, d=2.0):
    return np.full(n, d)


def test_exact_scan_has_no_error():
    s = metrics.scan_metrics(wall(), wall())
    assert s["median_error"] == 0.0 and s["p95_error"] == 0.0
    assert s["false"] == 0 and s["missed"] == 0 and s["coverage"] == 1.0


def test_known_gaussian_noise_gives_known_median_and_p95():
    rng = np.random.default_rng(1)
    sigma = 0.02
    n = 200000
    ideal = np.full(n, 5.0)
    out = ideal + rng.normal(0.0, sigma, n)
    s = metrics.scan_metrics(out, ideal, tol=1.0, beam_window=0)
    # |N(0, sigma)|: median 0.6745 sigma, 95th percentile 1.96 sigma
    assert s["median_error"] == pytest.approx(0.6745 * sigma, rel=0.02)
    assert s["p95_error"] == pytest.approx(1.96 * sigma, rel=0.02)


def test_constant_offset():
    s = metrics.scan_metrics(wall(d=3.03), wall(d=3.0), beam_window=0)
    assert s["median_error"] == pytest.approx(0.03)
    assert s["p95_error"] == pytest.approx(0.03)


def test_false_obstacles_counted_where_ideal_is_empty_or_farther():
    ideal = np.full(100, np.inf)
    ideal[50:] = 4.0
    out = ideal.copy()
    out[10:20] = 1.0      # ghost where the ideal sees nothing
    out[60:65] = 2.0      # ghost in front of a real wall
    out[70:72] = 4.03     # within tolerance: not false
    s = metrics.scan_metrics(out, ideal, tol=0.05, beam_window=1)
    assert s["false"] == 15
    assert s["missed"] == 0
    assert s["false_rate"] == pytest.approx(15 / 60)  # 50 wall + 10 ghost returns


def test_missed_obstacles_and_see_through():
    ideal = wall(100, 2.0)
    out = ideal.copy()
    out[0:30] = np.inf    # nothing seen
    out[40:45] = 6.0      # sees through the obstacle
    out[50:55] = np.nan   # invalid is not a return
    out[60:62] = -np.inf  # too close is not a return either
    s = metrics.scan_metrics(out, ideal, tol=0.05, beam_window=0)
    assert s["missed"] == 30 + 5 + 5 + 2
    assert s["coverage"] == pytest.approx((100 - 37) / 100)
    assert s["false"] == 0


def test_no_return_never_counts_as_obstacle():
    out = np.full(50, np.inf)
    ideal = np.full(50, np.inf)
    s = metrics.scan_metrics(out, ideal)
    assert s["false"] == 0 and s["missed"] == 0 and s["compared"] == 0
    assert np.isnan(s["median_error"])


def test_beam_window_forgives_one_beam_edge_shift():
    ideal = np.full(100, 5.0)
    ideal[40:60] = 1.0
    out = np.full(100, 5.0)
    out[41:61] = 1.0  # the object edge one beam off
    strict = metrics.scan_metrics(out, ideal, beam_window=0)
    loose = metrics.scan_metrics(out, ideal, beam_window=1)
    assert strict["p95_error"] > 1.0 or strict["false"] + strict["missed"] > 0
    assert loose["median_error"] == 0.0 and loose["false"] == 0 and loose["missed"] == 0


def test_mask_restricts_counts():
    ideal = wall(100, 2.0)
    out = np.full(100, np.inf)
    out[:20] = 2.0
    mask = np.zeros(100, bool)
    mask[:20] = True
    s = metrics.scan_metrics(out, ideal, mask=mask)
    assert s["missed"] == 0 and s["coverage"] == 1.0 and s["beams"] == 20


def test_scanstats_accumulates_over_scans():
    st = metrics.ScanStats()
    st.add(metrics.compare_scan(wall(10, 1.01), wall(10, 1.0), beam_window=0))
    st.add(metrics.compare_scan(wall(10, 1.03), wall(10, 1.0), beam_window=0))
    s = st.summary()
    assert s["scans"] == 2 and s["compared"] == 20
    assert s["median_error"] == pytest.approx(0.02)


def test_shape_mismatch_is_an_error():
    with pytest.raises(ValueError):
        metrics.compare_scan(np.ones(3), np.ones(4))


def test_angular_mask_wraps():
    n = 8
    inc = 2 * np.pi / n
    m = metrics.angular_mask(n, -np.pi, inc, 2.0, -2.0)  # the back of the robot
    angles = -np.pi + inc * np.arange(n)
    assert list(m) == [abs(a) >= 2.0 for a in angles]


def test_rate_latency_and_iou():
    r = metrics.rate_stats(np.arange(0, 10.0, 0.1))
    assert r["rate"] == pytest.approx(10.0) and r["max_gap"] == pytest.approx(0.1)
    lat = metrics.latency_stats([1.05, 2.05], [1.0, 2.0])
    assert lat["median"] == pytest.approx(0.05)
    a = np.zeros((4, 4), bool)
    b = np.zeros((4, 4), bool)
    a[0, :2] = True
    b[0, 1:3] = True
    assert metrics.grid_iou(a, b) == pytest.approx(1 / 3)


def test_relative_tolerance_and_range_limit():
    ideal = np.full(10, 8.0)
    out = np.full(10, 7.8)  # 20 cm short at 8 m: range noise, not a phantom
    assert metrics.scan_metrics(out, ideal, tol=0.05, beam_window=0)["false"] == 10
    assert metrics.scan_metrics(out, ideal, tol=0.05, rel_tol=0.03, beam_window=0)["false"] == 0
    out[0] = 2.0  # a phantom stays one
    assert metrics.scan_metrics(out, ideal, tol=0.05, rel_tol=0.03, beam_window=0)["false"] == 1
    # a wall at 8.1 m beyond an 8 m range limit: the output seeing nothing did not miss it
    s = metrics.scan_metrics(np.full(10, np.inf), np.full(10, 8.1), range_max=8.0)
    assert s["missed"] == 0 and s["ideal_returns"] == 0


def test_glass_beams_and_found():
    inf = np.inf
    ideal = np.array([1.0, 1.0, 2.0, inf, 6.0, 1.0])
    without = np.array([3.0, 1.02, 2.0, inf, inf, inf])
    glass = metrics.glass_beams(ideal, without, tol=0.05, max_range=5.0)
    # beam 0: glass before a wall; 1: the same obstacle; 2: no glass; 3: nothing; 4: beyond reach;
    # 5: glass with nothing behind
    assert glass.tolist() == [True, False, False, False, False, True]
    # the output sees the wall behind the glass on beam 0 (missed), a closer arc on beam 5 (found)
    assert metrics.glass_found([3.0, 1.0, 2.0, inf, inf, 0.7], ideal, glass, tol=0.05) == (2, 1)
    assert metrics.glass_found([1.04, 1.0, 2.0, inf, inf, inf], ideal, glass, tol=0.05) == (2, 1)
    assert metrics.glass_found([np.nan, 1.0, 2.0, inf, inf, -inf], ideal, glass, tol=0.05) == (2, 0)
