"""scripts/camera_path_benchmark: its figures, and one short real run of its three paths."""
import math
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "scripts"))
from laserscan_toolbox.experiments import camera_path as cpb  # noqa: E402


def test_figures_are_medians_and_ratios():
    runs = [{"path": "baseline", "cpu_ms_per_frame": 1.0}, {"path": "baseline", "cpu_ms_per_frame": 3.0},
            {"path": "image", "cpu_ms_per_frame": 2.0}, {"path": "image", "cpu_ms_per_frame": 4.0},
            {"path": "cloud", "cpu_ms_per_frame": 8.0}, {"path": "cloud", "cpu_ms_per_frame": float("nan")}]
    f = cpb.figures(runs)
    assert f["baseline"] == 2.0 and f["image"] == 3.0 and f["cloud"] == 8.0
    assert f["ratio"] == 8.0 / 3.0
    assert f["ratio_above_baseline"] == 6.0
    assert math.isnan(cpb.figures([{"path": "image", "cpu_ms_per_frame": 1.0}])["ratio"])


def test_rendered_frames_are_16uc1_millimetres():
    _, cam, frames = cpb.render_frames(64, 48, 2)
    depth, _ = frames[0]
    assert depth.shape == (48, 64) and depth.dtype.str == "<u2"
    assert cam.width == 64 and (depth > 0).sum() > 100 and depth.max() <= 8000


def test_short_run_of_every_path_and_usage_errors():
    exe = os.path.join(os.path.dirname(HERE), "scripts", "camera_path_benchmark")
    out = subprocess.run([exe, "--frames", "0"], capture_output=True, text=True, timeout=30)
    assert out.returncode == 2 and "frames" in out.stderr
    out = subprocess.run([exe, "--width", "64", "--height", "48", "--frames", "5", "--repeat", "1", "--rate", "10"],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    for path in ("baseline", "image", "cloud"):
        assert "%s path, run 1:" % path in out.stderr
    assert "cloud path / image path" in out.stdout and "above the baseline" in out.stdout
