"""transport_experiment: process-tree CPU accounting, result table, CLI usage errors.
No timing assertions: only that CPU spent by a child is seen, and arithmetic on known numbers."""
import math
import os
import subprocess
import sys
import time

import psutil
import pytest

SCRIPTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts")
sys.path.insert(0, SCRIPTS)
from laserscan_toolbox.experiments import transport as te  # noqa: E402

# A child that starts a grandchild; both spin on the CPU until told to stop (stdin closed),
# like roslaunch -> nodes. The grandchild has a __name:= argument like a ROS node.
TREE = r"""
import subprocess, sys, time
spin = "import sys,select\nwhile not select.select([sys.stdin],[],[],0)[0]: pass"
g = subprocess.Popen([sys.executable, "-c", spin, "__name:=worker"], stdin=subprocess.PIPE)
print("ready", flush=True)
while not __import__("select").select([sys.stdin], [], [], 0)[0]:
    pass
g.stdin.close(); g.wait()
"""


@pytest.fixture
def tree():
    p = subprocess.Popen([sys.executable, "-c", TREE], stdin=subprocess.PIPE,
                         stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "ready"
    yield p
    p.stdin.close()
    p.wait(10)


def _busy_until(procs, seconds):
    """Waits until every process has spent `seconds` more CPU (not a timing assertion:
    only a way to be sure the snapshots differ). Bounded to keep the test short."""
    start = {p.pid: sum(p.cpu_times()[:2]) for p in procs}
    deadline = time.time() + 15
    while time.time() < deadline:
        if all(sum(p.cpu_times()[:2]) - start[p.pid] >= seconds for p in procs):
            return
        time.sleep(0.02)
    pytest.fail("the child processes did not use the CPU")


def test_tree_lists_descendants_only(tree):
    procs = te.tree_processes(tree.pid)
    assert len(procs) == 1  # the grandchild; the root is excluded by default
    assert procs[0].ppid() == tree.pid
    assert len(te.tree_processes(tree.pid, include_root=True)) == 2


def test_cpu_delta_counts_the_window_of_every_process(tree):
    procs = te.tree_processes(tree.pid, include_root=True)
    # Both processes must have spent CPU before the window opens: under load a freshly
    # started process may not have run a whole clock tick yet, and then "the window only"
    # (below) could not be told from "the whole life".
    _busy_until(procs, 0.05)
    before = te.cpu_snapshot(procs)
    assert len(before) == 2
    assert all(c > 0 for _, c in before.values())
    _busy_until(procs, 0.05)
    after = te.cpu_snapshot(procs)
    d = te.cpu_delta(before, after)
    assert set(d["per_process"]) == {"%s[%d]" % (n, k[0]) for k, (n, _) in after.items()}
    assert "worker[%d]" % procs[1].pid in d["per_process"]  # named from __name:=
    assert all(v >= 0.05 for v in d["per_process"].values())
    assert d["total_s"] == pytest.approx(sum(d["per_process"].values()))
    # the window only: the processes' whole CPU since start less what they spent before it
    assert d["total_s"] == pytest.approx(sum(c for _, c in after.values())
                                         - sum(c for _, c in before.values()))
    assert d["total_s"] < sum(c for _, c in after.values())
    assert d["lost"] == []
    assert d["loader_s"] == 0.0


def test_nodelet_clients_are_tagged_and_their_cpu_summed():
    before = {(1, 0.0): ("mgr (manager)", 1.0), (2, 0.0): ("cam" + te.LOADER_TAG, 0.5),
              (3, 0.0): ("conv" + te.LOADER_TAG, 0.5)}
    after = {(1, 0.0): ("mgr (manager)", 3.0), (2, 0.0): ("cam" + te.LOADER_TAG, 0.75),
             (3, 0.0): ("conv" + te.LOADER_TAG, 0.5)}
    d = te.cpu_delta(before, after)
    assert d["total_s"] == pytest.approx(2.25)
    assert d["loader_s"] == pytest.approx(0.25)


def test_cpu_delta_new_and_exited_processes():
    before = {(10, 1.0): ("a", 2.0), (11, 1.0): ("gone", 5.0)}
    after = {(10, 1.0): ("a", 2.5), (12, 3.0): ("new", 0.25), (11, 9.0): ("recycled", 1.0)}
    d = te.cpu_delta(before, after)
    # a new process counts all its CPU; pid 11 with another create_time is another process
    assert d["per_process"] == {"a[10]": 0.5, "new[12]": 0.25, "recycled[11]": 1.0}
    assert d["total_s"] == pytest.approx(1.75)
    assert d["lost"] == ["gone[11]"]


def test_snapshot_skips_exited_process():
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    proc = psutil.Process(p.pid)
    p.wait(10)
    assert te.cpu_snapshot([proc]) == {}


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
