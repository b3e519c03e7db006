"""ros/cpu_accounting: the CPU of real processes, process trees and threads, and the window between
two snapshots. Every figure is CPU time, which load on the machine does not inflate: a busy loop
runs until its own process has spent a given CPU time, so the measured time has that as an exact
lower bound, and the upper bounds leave room for what an interpreter does around the loop."""
import os
import subprocess
import sys
import threading
import time

import psutil
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts"))
from laserscan_toolbox.ros import cpu_accounting as ca  # noqa: E402

BUSY_S = 0.3
# What a process may spend besides its busy loop inside a window (waking up, one print): well
# under 1 ms; the bound is generous for a loaded machine (cache misses, page faults).
SLACK_S = 0.05

# Spins the CPU seconds of its own CPU time (the clock this module reads) written on each line
# of stdin, then answers "done"; with "tree", a grandchild (named like a ROS node) spins instead.
SPIN = r"""
import subprocess, sys, time
def spin(seconds):
    start = time.process_time()
    while time.process_time() - start < seconds:
        pass
worker = None
if "tree" in sys.argv[1:]:
    worker = subprocess.Popen([sys.executable, "-c", sys.argv[1], "__name:=worker"],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert worker.stdout.readline() == "ready\n"
print("ready", flush=True)
for line in sys.stdin:
    if worker:
        worker.stdin.write(line); worker.stdin.flush()
        print(worker.stdout.readline(), end="", flush=True)
    else:
        spin(float(line))
        print("done", flush=True)
"""


class Spinner:
    """A process (with a grandchild doing the work when ``tree``) that spends the CPU seconds
    asked by spin() and then waits."""

    def __init__(self, tree=False):
        self.proc = subprocess.Popen([sys.executable, "-c", SPIN, SPIN] + (["tree"] if tree else []),
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        assert self.proc.stdout.readline() == "ready\n"

    def spin(self, seconds):
        self.proc.stdin.write("%r\n" % seconds)
        self.proc.stdin.flush()
        assert self.proc.stdout.readline() == "done\n"

    def close(self):
        self.proc.stdin.close()
        self.proc.wait(30)


@pytest.fixture
def spinner():
    s = Spinner()
    yield s
    s.close()


@pytest.fixture
def tree():
    s = Spinner(tree=True)
    yield s
    s.close()


def test_the_nanosecond_clock_is_in_use_on_linux():
    assert ca.SOURCE == ca.NANOSECONDS


def test_process_cpu_of_a_busy_child(spinner):
    before = ca.process_cpu_s(spinner.proc.pid)
    spinner.spin(BUSY_S)
    spent = ca.process_cpu_s(spinner.proc.pid) - before
    assert BUSY_S <= spent < BUSY_S + SLACK_S


def test_a_process_that_ended_is_no_such_process():
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    proc = psutil.Process(p.pid)
    p.wait(30)
    with pytest.raises(psutil.NoSuchProcess):
        ca.process_cpu_s(p.pid)
    assert ca.snapshot([proc]) == {}


def test_threads_count_also_one_that_ended():
    def burn(seconds):
        start = time.thread_time()
        while time.thread_time() - start < seconds:
            pass
    before = ca.process_cpu_s(os.getpid())
    worker = threading.Thread(target=burn, args=(0.2,))
    worker.start()
    burn(0.1)
    worker.join()  # it has ended: its CPU is still the process's
    spent = ca.process_cpu_s(os.getpid()) - before
    assert 0.3 <= spent < 0.3 + SLACK_S


def test_one_threads_cpu_apart_from_the_others():
    def burn(seconds):
        start = time.thread_time()
        while time.thread_time() - start < seconds:
            pass
    tid = threading.get_native_id()
    before = ca.thread_cpu_s(os.getpid(), tid)
    worker = threading.Thread(target=burn, args=(0.2,))
    worker.start()
    worker.join()  # the other thread's CPU is not this one's
    burn(0.1)
    spent = ca.thread_cpu_s(os.getpid(), tid) - before
    assert 0.1 <= spent < 0.1 + SLACK_S
    with pytest.raises(psutil.NoSuchProcess):
        ca.thread_cpu_s(os.getpid(), worker.native_id)  # it has ended


def test_tick_fallback_reads_the_same_time(spinner, monkeypatch):
    spinner.spin(BUSY_S)  # the child now waits: its CPU time stands still
    ns = ca.process_cpu_s(spinner.proc.pid)
    monkeypatch.setattr(ca, "SOURCE", ca.CLOCK_TICKS)
    ticks = ca.process_cpu_s(spinner.proc.pid)
    assert abs(ticks - ns) <= 0.03  # user and system, each cut to whole 10 ms ticks
    assert ca.spent({}, ca.snapshot([psutil.Process(spinner.proc.pid)]))["source"] == ca.CLOCK_TICKS


def test_tree_lists_descendants_and_the_root_if_asked(tree):
    procs = ca.tree_processes(tree.proc.pid)
    assert len(procs) == 1 and procs[0].ppid() == tree.proc.pid  # the grandchild
    assert [p.pid for p in ca.tree_processes(tree.proc.pid, include_root=True)] == \
        [tree.proc.pid, procs[0].pid]
    assert ca.tree_processes(2 ** 22 + 1) == []  # beyond pid_max: no such root


def test_window_over_a_tree_counts_the_grandchild(tree):
    procs = ca.tree_processes(tree.proc.pid, include_root=True)
    before = ca.snapshot(procs, lambda p: "root" if p.pid == tree.proc.pid else "worker")
    tree.spin(BUSY_S)
    after = ca.snapshot(ca.tree_processes(tree.proc.pid, include_root=True),
                        lambda p: "root" if p.pid == tree.proc.pid else "worker")
    d = ca.spent(before, after)
    worker = ca.label("worker", procs[1].pid)
    assert set(d["per_process"]) == {ca.label("root", tree.proc.pid), worker}
    assert BUSY_S <= d["per_process"][worker] < BUSY_S + SLACK_S
    assert d["per_process"][ca.label("root", tree.proc.pid)] < SLACK_S  # it only relayed
    assert d["total_s"] == pytest.approx(sum(d["per_process"].values()))
    # the window only: both processes had spent CPU before it (their start-up)
    assert d["total_s"] == pytest.approx(sum(c for _, c in after.values())
                                         - sum(c for _, c in before.values()))
    assert d["lost"] == [] and d["source"] == ca.NANOSECONDS


def test_window_with_processes_started_and_ended_inside():
    before = {(10, 1.0): ("a", 2.0), (11, 1.0): ("gone", 5.0)}
    after = {(10, 1.0): ("a", 2.5), (12, 3.0): ("new", 0.25), (11, 9.0): ("recycled", 1.0)}
    d = ca.spent(before, after)
    # a new process counts all its CPU; pid 11 with another create_time is another process
    assert d["per_process"] == {"a[10]": 0.5, "new[12]": 0.25, "recycled[11]": 1.0}
    assert d["total_s"] == pytest.approx(1.75)
    assert d["lost"] == ["gone[11]"]
