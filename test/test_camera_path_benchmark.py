"""scripts/camera_path_benchmark: its figures and one short real run of its three paths from both
sources (the replay nodelet inside the manager, and TCP). Its CPU accounting is
ros/cpu_accounting.py's (test_cpu_accounting.py)."""
import math
import os
import subprocess

HERE = os.path.dirname(os.path.abspath(__file__))
from laserscan_toolbox.experiments import camera_path as cpb


def test_figures_are_medians_and_ratios():
    runs = [{"path": "baseline", "cpu_ms_per_frame": 1.0}, {"path": "baseline", "cpu_ms_per_frame": 3.0},
            {"path": "image", "cpu_ms_per_frame": 2.0}, {"path": "image", "cpu_ms_per_frame": 4.0},
            {"path": "cloud", "cpu_ms_per_frame": 8.0}, {"path": "cloud", "cpu_ms_per_frame": float("nan")}]
    f = cpb.figures(runs)
    assert f["baseline"] == 2.0 and f["image"] == 3.0 and f["cloud"] == 8.0
    assert f["ratio"] == 8.0 / 3.0
    assert f["ratio_above_baseline"] == 6.0
    assert math.isnan(cpb.figures([{"path": "image", "cpu_ms_per_frame": 1.0}])["ratio"])
    # The manager source's baseline is the replay nodelet alone.
    f = cpb.figures([{"path": "source", "cpu_ms_per_frame": 0.5}, {"path": "image", "cpu_ms_per_frame": 1.0},
                     {"path": "cloud", "cpu_ms_per_frame": 2.5}], cpb.MANAGER_PATHS)
    assert f["baseline"] == 0.5 and f["ratio"] == 2.5 and f["ratio_above_baseline"] == 4.0


def test_rendered_frames_are_16uc1_millimetres():
    _, cam, frames = cpb.render_frames(64, 48, 2)
    depth, _ = frames[0]
    assert depth.shape == (48, 64) and depth.dtype.str == "<u2"
    assert cam.width == 64 and (depth > 0).sum() > 100 and depth.max() <= 8000


def test_converter_params_keep_or_switch_off_the_range_noise_model():
    with_noise = cpb.converter_params(cpb.CONFIG, "image")
    assert with_noise["range_noise_std"] > 0 and with_noise["publish_filtered_cloud"] is False
    without = cpb.converter_params(cpb.CONFIG, "image", range_noise=False)
    assert without["range_noise_std"] == 0 and without["range_noise_std_per_m2"] == 0
    assert without["max_height"] == with_noise["max_height"]  # nothing else changes
    baseline = cpb.converter_params(cpb.CONFIG, "baseline")
    assert baseline["row_stride"] >= 1000000 and baseline["column_stride"] >= 1000000


def test_short_run_of_every_path_and_usage_errors():
    exe = os.path.join(os.path.dirname(HERE), "scripts", "camera_path_benchmark")
    out = subprocess.run([exe, "--frames", "0"], capture_output=True, text=True, timeout=30)
    assert out.returncode == 2 and "frames" in out.stderr
    out = subprocess.run([exe, "--range-noise", "maybe"], capture_output=True, text=True, timeout=30)
    assert out.returncode == 2 and "--range-noise" in out.stderr
    out = subprocess.run([exe, "--width", "64", "--height", "48", "--frames", "5", "--repeat", "1", "--rate", "10"],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    for source, paths in cpb.SOURCES.items():
        for path in paths:
            line = [ln for ln in out.stderr.splitlines() if ln.startswith("%s source, %s path, run 1:" % (source, path))]
            assert len(line) == 1, out.stderr[-3000:]
            if path in ("image", "cloud"):
                assert not line[0].split(":")[1].startswith(" 0 scans"), line  # the path converted frames
    assert out.stdout.count("cloud path / image path") == 2 and "frames published inside the manager" in out.stdout
    assert "replay nodelet alone" in out.stdout and "image path reading one pixel" in out.stdout
