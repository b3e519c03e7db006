"""Pure parts of the soak benchmark (scripts/laserscan_toolbox/experiments/soak.py): slope,
warm-up, growth and stalls."""

import pytest

from laserscan_toolbox.experiments import soak

MB = soak.MB


def test_slope_of_a_line_and_of_degenerate_inputs():
    assert soak.slope([0, 10, 20, 30], [5, 25, 45, 65]) == pytest.approx(2.0)
    assert soak.slope([0, 10, 20], [7, 7, 7]) == 0.0
    assert soak.slope([3], [1]) == 0.0
    assert soak.slope([4, 4], [1, 9]) == 0.0  # no spread in time: no slope


def test_growth_ignores_the_warm_up():
    # Memory climbs by 50 MB during the warm-up, then stays flat with noise.
    flat = [(t, (150 + (0.1 if t % 20 else -0.1)) * MB) for t in range(20, 130, 10)]
    samples = [(0, 100 * MB), (10, 150 * MB)] + flat
    s, g = soak.growth_after_warmup(samples, warmup=20)
    assert abs(g) < 0.2 * MB
    s_all, g_all = soak.growth_after_warmup(samples, warmup=0)
    assert g_all > 10 * MB


def test_growth_after_warm_up_is_slope_times_span():
    samples = [(t, (100 + 0.01 * t) * MB) for t in range(0, 1800, 10)]
    s, g = soak.growth_after_warmup(samples, warmup=300)
    assert s * 3600 / MB == pytest.approx(36.0)
    assert g / MB == pytest.approx(0.01 * (1790 - 300))
    assert soak.growth_after_warmup(samples[:1], warmup=0) == (0.0, 0.0)


def test_warm_up_is_a_third_of_a_short_run_and_five_minutes_of_a_long_one():
    assert soak.warmup_seconds(60) == 20
    assert soak.warmup_seconds(1800) == 300


def test_stalls_found_inside_and_at_both_ends():
    arrivals = [10.5, 10.9, 11.3, 13.0, 13.2]
    assert soak.stalls(arrivals, start=10.0, end=13.5, threshold=1.0) == [(11.3, pytest.approx(1.7))]
    # Nothing for a long time after the start, and nothing before the end.
    assert soak.stalls([12.0], start=10.0, end=14.5, threshold=1.0) == [(10.0, 2.0), (12.0, 2.5)]
    assert soak.stalls([], start=0.0, end=0.5) == []
    assert soak.stalls([], start=0.0, end=3.0) == [(0.0, 3.0)]


def test_summary_meets_the_target_only_without_growth_or_stall():
    rss = {"manager[1]": [(t, 60 * MB) for t in range(0, 70, 10)],
           "loader[2]": [(t, 15 * MB) for t in range(0, 70, 10)]}
    steady = {"/merged_scan": [0.1 * i for i in range(601)]}
    s = soak.summarize(rss, steady, start=0.0, end=60.0)
    assert s["target_met"] and s["stalls"] == 0
    assert s["total"]["start_mb"] == pytest.approx(75.0)
    assert s["outputs"]["/merged_scan"]["rate_hz"] == pytest.approx(601 / 60)

    gap = {"/merged_scan": [t for t in steady["/merged_scan"] if not 30 < t < 32]}
    assert not soak.summarize(rss, gap, start=0.0, end=60.0)["target_met"]

    leaking = dict(rss, **{"manager[1]": [(t, (60 + 0.05 * t) * MB) for t in range(0, 70, 10)]})
    s = soak.summarize(leaking, steady, start=0.0, end=60.0)
    assert s["total"]["growth_after_warmup_mb"] == pytest.approx(2.0)
    assert not s["target_met"]

    silent = dict(steady, **{"/lidar_scan": []})
    assert not soak.summarize(rss, silent, start=0.0, end=60.0)["target_met"]


def test_soak_usage_errors_exit_2(capsys):
    assert soak.main(["--duration", "5"]) == 2
    assert soak.main(["--rate", "0"]) == 2
    assert soak.main(["--camera-points", "5"]) == 2
    assert "--duration" in capsys.readouterr().err
