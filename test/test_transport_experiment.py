"""transport_experiment: loader clients' CPU, result table, CLI usage errors (the process-tree CPU
accounting it uses is tested in test_cpu_accounting.py, process names in test_rosrun.py). No
timing assertions."""
import math
import os
import subprocess
import sys

import pytest

SCRIPTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts")
from laserscan_toolbox.experiments import transport as te
from laserscan_toolbox.ros.rosrun import LOADER_TAG, MANAGER_TAG


def test_nodelet_loader_clients_cpu_is_summed():
    per_process = {"mgr" + MANAGER_TAG + "[1]": 2.0, "cam" + LOADER_TAG + "[2]": 0.25,
                   "conv" + LOADER_TAG + "[3]": 0.0, "loader_like[4]": 1.0}
    assert te.loader_cpu_s(per_process) == pytest.approx(0.25)


def test_run_figures_and_summary_from_known_numbers():
    assert te.run_figures(2.0, 10.0, 100, 0.5) == {
        "cpu_s": 2.0, "loader_s": 0.5, "window_s": 10.0, "outputs": 100,
        "cpu_ms_per_output": 20.0, "cpu_percent": 20.0, "work_ms_per_output": 15.0}
    assert math.isnan(te.run_figures(1.0, 10.0, 0)["cpu_ms_per_output"])

    def run(mode, cpu_s, outputs, procs, loader_s=0.0):
        r = te.run_figures(cpu_s, 10.0, outputs, loader_s)
        r.update(mode=mode, processes=procs)
        return r

    runs = [run("manager", 2.0, 100, 1, 1.0), run("standalone", 5.0, 100, 6),
            run("standalone", 3.0, 100, 6), run("manager", 1.0, 100, 1, 0.5),
            run("manager", 1.5, 100, 1, 0.75)]
    s = te.summarize(runs)
    assert s["manager"]["cpu_ms_per_output"] == pytest.approx(15.0)  # median of 20, 10, 15
    assert s["manager"]["cpu_percent"] == pytest.approx(15.0)
    assert s["manager"]["runs"] == 3
    assert s["standalone"]["cpu_ms_per_output"] == pytest.approx(40.0)  # median of 50, 30
    assert s["standalone"]["processes"] == 6
    assert s["ratio"]["cpu_ms_per_output"] == pytest.approx(40.0 / 15.0)
    assert s["ratio"]["cpu_percent"] == pytest.approx(40.0 / 15.0)
    assert s["manager"]["work_ms_per_output"] == pytest.approx(7.5)  # median of 10, 5, 7.5
    assert s["ratio"]["work_ms_per_output"] == pytest.approx(40.0 / 7.5)

    text = te.markdown_table(s)
    lines = text.splitlines()
    assert len(lines) == 5  # header, rule, two modes, ratio
    assert "| one nodelet manager (zero-copy) | 1 | 15.00 | 15.0 | 7.50 | 100 | 3 |" in lines
    assert "| standalone nodes | 6 | 40.00 | 40.0 | 40.00 | 100 | 2 |" in lines
    assert lines[-1] == "| ratio standalone / manager |  | 2.67 | 2.67 | 5.33 |  |  |"


def test_summary_of_one_mode_has_no_ratio():
    r = te.run_figures(1.0, 10.0, 50)
    r.update(mode="manager", processes=1)
    s = te.summarize([r])
    assert "ratio" not in s and "standalone" not in s
    assert "ratio" not in te.markdown_table(s)


@pytest.mark.parametrize("args", [["--duration", "0.5"], ["--repeat", "0"],
                                  ["--camera-points", "5"], ["--arg", "standalone:=true"],
                                  ["--no-such-option"]])
def test_cli_usage_errors_exit_2(args):
    p = subprocess.run([sys.executable, os.path.join(SCRIPTS, "transport_experiment")] + args,
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 2, p.stderr
    assert p.stderr.strip()


def test_cli_help_exits_0():
    p = subprocess.run([sys.executable, os.path.join(SCRIPTS, "transport_experiment"), "--help"],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 0
    for opt in ("--duration", "--camera-points", "--output", "--repeat"):
        assert opt in p.stdout
