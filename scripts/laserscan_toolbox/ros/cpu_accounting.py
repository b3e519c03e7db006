"""CPU time (user + system) that processes and process trees spend, for every tool that measures
CPU: the experiments, evaluate_bag and the node benchmarks.

A process's CPU is read from its CPU-time clock (clock_getcpuclockid + clock_gettime): the
scheduler's nanosecond count of all its threads, the ones that have ended included (the same
counter as /proc/<pid>/task/*/schedstat, but a sum over live threads there would lose e.g. a
rospy connection thread that ended when rosbag play did). /proc/<pid>/stat, what psutil reads,
holds the same time in 10 ms clock ticks, too coarse for runs of a few hundred ms of CPU; it is
the fallback where the clock cannot be read, and ``SOURCE`` says which of the two is in use.

A measurement window is two ``snapshot``s and ``spent`` between them.
"""

import ctypes
import errno
import os
import time
import warnings

import psutil

NANOSECONDS = "CPU-time clock, ns"
CLOCK_TICKS = "/proc/<pid>/stat, 10 ms ticks"

_LIBC = ctypes.CDLL(None)


def _clock_cpu_s(pid):
    clock = ctypes.c_int()
    status = _LIBC.clock_getcpuclockid(pid, ctypes.byref(clock))
    if status == errno.ESRCH:
        raise psutil.NoSuchProcess(pid)
    if status != 0:
        raise OSError(status, os.strerror(status))
    try:
        return time.clock_gettime_ns(clock.value) / 1e9
    except OSError as e:
        if e.errno == errno.EINVAL:  # the clock's process ended after the id was made
            raise psutil.NoSuchProcess(pid) from None
        raise


def _probe_source():
    try:
        _clock_cpu_s(os.getpid())
        return NANOSECONDS
    except (AttributeError, OSError):
        warnings.warn("no process CPU-time clock here: CPU is read from /proc/<pid>/stat in "
                      "10 ms ticks", RuntimeWarning)
        return CLOCK_TICKS


SOURCE = _probe_source()


def process_cpu_s(pid):
    """CPU seconds process ``pid`` has spent since it started, all its threads (read from
    ``SOURCE``). Raises psutil.NoSuchProcess when there is no such process (any more)."""
    if SOURCE == NANOSECONDS:
        return _clock_cpu_s(pid)
    t = psutil.Process(pid).cpu_times()
    return t.user + t.system


def thread_cpu_s(pid, tid):
    """CPU seconds thread ``tid`` of process ``pid`` has spent (the scheduler's ns count in
    /proc/<pid>/task/<tid>/schedstat). Raises psutil.NoSuchProcess when it has ended."""
    try:
        with open("/proc/%d/task/%d/schedstat" % (pid, tid)) as f:
            return int(f.read().split()[0]) / 1e9
    except FileNotFoundError:
        raise psutil.NoSuchProcess(tid) from None


def tree_processes(root_pid, include_root=False):
    """psutil.Process of every live descendant of root_pid (children, grandchildren, ...) and of
    root itself if asked; [] when root has ended."""
    try:
        root = psutil.Process(root_pid)
        procs = root.children(recursive=True)
    except psutil.Error:
        return []
    return ([root] if include_root else []) + procs


def snapshot(procs, name=lambda p: str(p.pid)):
    """{(pid, create_time): (name(p), CPU seconds)} of the psutil.Process ``procs`` still alive.
    Keyed with create_time so a recycled pid is never taken for the same process."""
    snap = {}
    for p in procs:
        try:
            with p.oneshot():
                key = (p.pid, p.create_time())
                snap[key] = (name(p), process_cpu_s(p.pid))
        except psutil.Error:
            continue  # exited meanwhile: nothing to account
    return snap


def label(name, pid):
    """How a process is named in ``spent``'s results: names repeat, pids tell them apart."""
    return "%s[%d]" % (name, pid)


def spent(before, after):
    """CPU seconds spent between two snapshots, per process (by ``label``) and in total.

    A process present only in ``after`` started inside the window: all its CPU counts.
    A process present only in ``before`` ended inside the window: its last CPU is unknown,
    so it is listed in ``lost`` (the total is then a lower bound)."""
    per = {}
    for key, (name, c1) in after.items():
        c0 = before[key][1] if key in before else 0.0
        per[label(name, key[0])] = max(c1 - c0, 0.0)
    lost = [label(before[k][0], k[0]) for k in before if k not in after]
    return {"per_process": per, "total_s": sum(per.values()), "lost": lost, "source": SOURCE}
