"""Running ROS pieces for the tools: a private master and the tool's own rospy node (``Session``),
a roslaunch, rosbag play, CPU meters.

Every tool starts its own ``roscore`` on a free port with ROS_HOME / ROS_LOG_DIR in a
temporary folder, so it never collides with a robot's master or with a test's. Child
processes get their own process group and are stopped by that id only.
"""

import contextlib
import os
import random
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
from urllib.parse import urlparse
from xmlrpc.client import ServerProxy

import psutil

from . import cpu_accounting


def _bring_up_folder():
    """The folder that holds the system bring-up, launch/ beside config/ (and scripts/ in a
    source tree): the repository when the toolbox runs from its source tree (also through a
    devel space, whose relay imports it from there); else scan_evaluation_tools' share folder,
    where the install space puts the same launch/ and config/ (that package owns the toolbox)."""
    source = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
    if os.path.isfile(os.path.join(source, "launch", "pipeline.launch")):
        return source
    from catkin.find_in_workspaces import find_in_workspaces
    found = find_in_workspaces(["share"], "scan_evaluation_tools", "launch/pipeline.launch",
                               first_match_only=True)
    return os.path.dirname(os.path.dirname(found[0])) if found else source


# launch/ and config/ are REPO's: the repository, or installed, scan_evaluation_tools' share folder.
REPO = _bring_up_folder()


class RunError(Exception):
    """The pipeline could not be run (launch failed, master did not start, ...)."""


# Tags of the nodelet processes in reports: a manager, and a loader client ("nodelet load" only
# asks the manager to load a nodelet and then idles: a process of the deployment all the same,
# counted, but tagged so that its share can be reported on its own).
MANAGER_TAG = " (manager)"
LOADER_TAG = " (loader)"
#: What process_role calls each process of a launch: a nodelet manager (the nodelets' work), a
#: loader client (idle), any other node (a standalone node, a static_transform_publisher).
ROLES = ("manager", "loader", "node")


def process_role(name):
    """"manager", "loader" or "node": the role of a process named by process_name."""
    if name.endswith(MANAGER_TAG):
        return "manager"
    return "loader" if name.endswith(LOADER_TAG) else "node"


def process_name(p):
    """How reports name a process (psutil.Process) of a launch: its ROS node name (__name:=),
    else its program's; nodelet managers and loader clients tagged. Its pid if it is gone."""
    import psutil
    try:
        cmd = p.cmdline()
    except psutil.Error:
        return str(p.pid)
    if not cmd:
        return str(p.pid)
    name = next((a.split(":=", 1)[1] for a in cmd if a.startswith("__name:=")), None)
    if name is None:
        name = os.path.basename(cmd[1] if len(cmd) > 1 and "python" in cmd[0] else cmd[0])
    # A manager started behind a launch-prefix (nice, gdb) is named after that program, untagged.
    if len(cmd) > 1 and os.path.basename(cmd[0]) == "nodelet":
        name += {"manager": MANAGER_TAG, "load": LOADER_TAG}.get(cmd[1], "")
    return name


def package_executable(env, package, name):
    """The path of a package's built program `name` (catkin_find in `env`'s workspaces), or a
    RunError saying to build it (test programs and benchmark nodes are built with the tests)."""
    found = subprocess.run(["catkin_find", "--libexec", package, name], env=env, capture_output=True,
                           text=True).stdout.split()
    if not found:
        raise RunError("%s of %s not found: build the package (and its tests) first" % (name, package))
    return found[0]


def _ephemeral_low():
    try:
        with open("/proc/sys/net/ipv4/ip_local_port_range") as f:
            return int(f.read().split()[0])
    except (OSError, ValueError, IndexError):
        return 32768


def free_port():
    """A port free on loopback now, below the kernel's ephemeral range: every ROS node binds its
    XML-RPC and TCPROS servers to port 0 (a port of that range), and one of them took a port that
    bind(0) had handed out here before the roscore meant for it had bound it (a long navigation
    sweep's master failed so)."""
    high = _ephemeral_low()
    low = max(1024, high - 12000)
    for _ in range(200):
        port = random.randrange(low, high)
        with socket.socket() as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                continue
            return port
    with socket.socket() as s:  # the range is full: let the kernel choose
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def stop_process(proc, timeout=10.0):
    """SIGINT the process group we created, then SIGTERM / SIGKILL if it lingers."""
    if proc is None or proc.poll() is not None:
        return
    for sig, wait in ((signal.SIGINT, timeout), (signal.SIGTERM, 3.0), (signal.SIGKILL, 3.0)):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            return
        try:
            proc.wait(wait)
            return
        except subprocess.TimeoutExpired:
            continue


def log_tail(path, n=25):
    try:
        with open(path, errors="replace") as f:
            return "".join(f.readlines()[-n:])
    except OSError:
        return ""


def _exit_on_sigterm(signum, _frame):
    sys.exit(128 + signum)


class Roscore:
    """A private ``roscore`` on a free port, its ROS_HOME and ROS_LOG_DIR in ``workdir``; the one
    way every tool and test starts a master. ``env`` is the environment that reaches it (``base_env``,
    default os.environ, with the ROS variables set), ``master`` a rosgraph.Master on it, ``uri`` and
    ``port`` its address. Returns from ``__enter__`` once the master answers (RunError if it does
    not within ``timeout`` s); stops roscore's process group on leaving.

    sim_time: sets /use_sim_time to it when not None. command: turns an argument list into the
    command line that runs it (e.g. through an install space's setup.bash); roscore is started
    with it in its own session, ``cwd`` its working folder."""

    def __init__(self, workdir, sim_time=None, base_env=None, command=None, cwd=None, timeout=30.0):
        self.workdir = workdir
        self.sim_time = sim_time
        self.base_env = base_env
        self.command = command or (lambda args: args)
        self.cwd = cwd
        self.timeout = timeout
        self.proc = None
        self.port = None
        self.uri = None
        self.env = None
        self.master = None

    def __enter__(self):
        os.makedirs(self.workdir, exist_ok=True)
        # A port can still be taken between free_port() and roscore's bind (roscore then exits or
        # never answers): another port is tried.
        for attempt in range(3):
            try:
                return self._start()
            except RunError:
                if attempt == 2:
                    raise

    def _start(self):
        self.port = free_port()
        self.uri = "http://127.0.0.1:%d" % self.port
        self.env = dict(os.environ if self.base_env is None else self.base_env,
                        ROS_MASTER_URI=self.uri, ROS_HOME=self.workdir,
                        ROS_LOG_DIR=os.path.join(self.workdir, "log"), ROS_IP="127.0.0.1")
        self.env.pop("ROS_HOSTNAME", None)  # ROS_IP must decide the address
        self.log = os.path.join(self.workdir, "roscore.log")
        with open(self.log, "w") as f:
            self.proc = subprocess.Popen(self.command(["roscore", "-p", str(self.port)]), env=self.env,
                                         cwd=self.cwd, stdout=f, stderr=subprocess.STDOUT,
                                         start_new_session=True)
        import rosgraph
        master = rosgraph.Master("/laserscan_toolbox", master_uri=self.uri)
        deadline = time.time() + self.timeout
        while True:
            try:
                # Only once our roscore's master listens on the port is it asked: whatever else
                # holds the port may never answer (the call has no timeout), or answer getPid as
                # any ROS node's API does.
                if not self._listening():
                    raise RunError("not listening yet")
                master.getPid()
                if self.sim_time is not None:
                    master.setParam("/use_sim_time", self.sim_time)
                break
            except Exception:
                if self.proc.poll() is not None or time.time() > deadline:
                    self.__exit__(None, None, None)
                    raise RunError("roscore did not start:\n" + log_tail(self.log))
                time.sleep(0.1)
        self.master = master
        return self

    def _listening(self):
        """Whether a process of our roscore's tree listens on self.port."""
        for p in cpu_accounting.tree_processes(self.proc.pid, include_root=True):
            try:
                if any(c.status == psutil.CONN_LISTEN and c.laddr and c.laddr.port == self.port
                       for c in p.connections(kind="tcp")):
                    return True
            except psutil.Error:
                continue
        return False

    def __exit__(self, *exc):
        stop_process(self.proc)


class Master(Roscore):
    """A private roscore (``Roscore``) that this process's own node uses too: it sets
    ROS_MASTER_URI etc. in os.environ. /use_sim_time is set to ``sim_time``.

    The children run in their own sessions (a Ctrl-C meant for the tool must not kill them
    before the tool has saved its results), so the tool itself must stop them: SIGTERM is
    turned into SystemExit, which runs every ``__exit__`` and leaves no roscore behind.
    """

    def __init__(self, workdir, sim_time=True):
        super().__init__(workdir, sim_time=sim_time)

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, _exit_on_sigterm)
        super().__enter__()
        for k in ("ROS_MASTER_URI", "ROS_HOME", "ROS_LOG_DIR", "ROS_IP"):
            os.environ[k] = self.env[k]
        os.environ.pop("ROS_HOSTNAME", None)
        return self


class Session:
    """A private master and this process's rospy node, shared by several runs."""

    def __init__(self, workdir=None, keep=False):
        self.own_dir = workdir is None
        self.workdir = workdir or tempfile.mkdtemp(prefix="laserscan_eval_")
        self.keep = keep
        self.master = None

    def __enter__(self):
        self.master = Master(os.path.join(self.workdir, "ros")).__enter__()
        import rospy
        rospy.init_node("laserscan_evaluate", anonymous=True, disable_signals=True,
                        disable_rosout=True)
        return self

    @contextlib.contextmanager
    def launched(self, launch_file, args=(), label="run", wall_time=False):
        """``roslaunch launch_file args...`` on this session's master, logging to
        <workdir>/<label>_roslaunch.log. Yields (the Launch, {topic: [publisher nodes]} of what its
        nodes publish) once those publications have settled; stops the launch on leaving.

        wall_time: the nodes run on wall time, as on a robot (/use_sim_time false on the master
        and ``use_sim_time:=false`` where the launch declares it, ``wall_time_args``), to be fed
        by a ``WallClockPlayer``; the session's own node stays on simulated time."""
        if wall_time:
            self.master.master.setParam("/use_sim_time", False)
            args = wall_time_args(launch_file, args)
        try:
            launch = Launch(launch_file, args, os.path.join(self.workdir, label + "_roslaunch.log")).start()
            try:
                yield launch, launch.wait_ready(self.master.master, ignore_nodes=(own_node_name(),))
            finally:
                launch.stop()
        finally:
            if wall_time:
                self.master.master.setParam("/use_sim_time", self.master.sim_time)

    def __exit__(self, *exc):
        import rospy
        rospy.signal_shutdown("evaluation done")
        self.master.__exit__(*exc)
        if self.own_dir and not self.keep:
            shutil.rmtree(self.workdir, ignore_errors=True)


def wall_time_args(launch_file, launch_args):
    """launch_args with ``use_sim_time:=false`` in place of any use_sim_time given, when the
    launch file declares that argument (roslaunch refuses an argument a file does not declare;
    such a launch leaves /use_sim_time to the master)."""
    import xml.etree.ElementTree as ET
    args = [a for a in launch_args if not a.startswith("use_sim_time:=")]
    try:
        root = ET.parse(launch_file).getroot()
    except (ET.ParseError, OSError):
        return args
    if any(e.get("name") == "use_sim_time" for e in root.findall("arg")):
        args.append("use_sim_time:=false")
    return args


def own_node_name():
    """This process's rospy node name (a Session's)."""
    import rospy
    return rospy.get_name()


def wait_connected(subscribers, timeout=5.0):
    """Waits until every rospy subscriber (or publisher) has a connection; True if they all do
    within timeout (wall time: with use_sim_time the clock stands still before playback)."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        if all(s.get_num_connections() > 0 for s in subscribers):
            return True
        time.sleep(0.05)
    return False


@contextlib.contextmanager
def rostopic_pub(env, topic, msg_type, msg, *options):
    """``rostopic pub [options] topic msg_type msg`` on the master of ``env`` while the block runs
    (in its own session, stopped on leaving). Without ``-r`` the message is latched: it reaches
    every subscriber whenever it connects."""
    proc = subprocess.Popen(["rostopic", "pub"] + list(options) + [topic, msg_type, msg], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        yield proc
    finally:
        stop_process(proc)


class OutputLines:
    """A child process's output (``stdout=PIPE, text=True``), read line by line in a thread, so
    that a caller waits for the line it needs instead of sleeping for a fixed time."""

    def __init__(self, proc):
        self.proc = proc
        self._lines = []
        self._ended = False
        self._changed = threading.Condition()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self):
        for line in self.proc.stdout:
            with self._changed:
                self._lines.append(line)
                self._changed.notify_all()
        with self._changed:
            self._ended = True
            self._changed.notify_all()

    def wait_for(self, *parts, timeout=30.0):
        """True once a line holds every one of ``parts``; False when the output ends (the process
        exited) or ``timeout`` s pass first."""
        deadline = time.time() + timeout
        with self._changed:
            while True:
                if any(all(p in line for p in parts) for line in self._lines):
                    return True
                left = deadline - time.time()
                if self._ended or left <= 0:
                    return False
                self._changed.wait(left)

    @property
    def text(self):
        """What was read so far."""
        with self._changed:
            return "".join(self._lines)

    def stop(self, timeout=20.0):
        """SIGINT to the process if it still runs (ROS nodes shut down cleanly on it), then its
        whole output once it has exited."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        try:
            self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(5)
        self._reader.join(5)
        return self.text


class Launch:
    """``roslaunch FILE args...`` in its own process group."""

    def __init__(self, launch_file, args, log_path):
        if not os.path.isfile(launch_file):
            raise RunError("%s: no such launch file" % launch_file)
        self.cmd = ["roslaunch", launch_file] + list(args)
        self.log_path = log_path
        self.proc = None

    def start(self):
        with open(self.log_path, "w") as f:
            self.proc = subprocess.Popen(self.cmd, stdout=f, stderr=subprocess.STDOUT,
                                         start_new_session=True)
        return self

    def wait_ready(self, master, settle=2.0, timeout=40.0, ignore_nodes=()):
        """Waits until the launched nodes' publications stop changing. Returns
        {topic: [publisher nodes]} of what the launch publishes."""
        start = time.time()
        last = None
        stable_since = None
        while True:
            if self.proc.poll() is not None:
                raise RunError("roslaunch exited with status %d:\n%s"
                               % (self.proc.returncode, log_tail(self.log_path)))
            pubs = {}
            try:
                state = master.getSystemState()
                for topic, nodes in state[0]:
                    nodes = [n for n in nodes if n != "/rosout" and n not in ignore_nodes]
                    if nodes:
                        pubs[topic] = nodes
            except Exception:
                pass
            now = time.time()
            if pubs and pubs == last:
                if stable_since is not None and now - stable_since >= settle:
                    return pubs
            else:
                stable_since = now
            last = pubs
            if now - start > timeout:
                if pubs:
                    return pubs
                raise RunError("the launch published nothing within %.0f s:\n%s"
                               % (timeout, log_tail(self.log_path)))
            time.sleep(0.25)

    def processes(self):
        """(name, psutil.Process) of every process the launch started, named by process_name."""
        return [(process_name(p), p) for p in cpu_accounting.tree_processes(self.proc.pid)]

    def raise_if_stopped(self, what="the pipeline"):
        """RunError naming what died if roslaunch has ended or its log says that a node died:
        roslaunch outlives a node that is not required."""
        with open(self.log_path, errors="replace") as f:
            died = [l for l in f if "has died" in l or "terminate called" in l or "what()" in l]
        if self.proc.poll() is not None or died:
            raise RunError("%s stopped during playback:\n%s%s" % (what, "".join(died), log_tail(self.log_path)))

    def stop(self):
        stop_process(self.proc)


def peak_rss_mb(pid):
    """The process's peak resident memory (VmHWM of /proc/<pid>/status), MB; None if unknown."""
    try:
        with open("/proc/%d/status" % pid) as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024 / 1e6
    except OSError:
        pass
    return None


class CpuMeter:
    """CPU time of processes between start() and stop(), as percent of one core; ``snapshot``
    and ``figures`` measure any other window over the same processes."""

    def __init__(self, named_procs):
        self.procs = [p for _, p in named_procs]
        self.names = {p.pid: name for name, p in named_procs}
        self.t0 = None
        self.before = {}

    def snapshot(self):
        return cpu_accounting.snapshot(self.procs, lambda p: self.names[p.pid])

    def figures(self, before, after, seconds):
        """{process name: {"cpu_percent" (CPU seconds per ``seconds``, in percent of one core),
        "cpu_seconds", "rss_mb"}} between two snapshots; a process that ended is left out."""
        import psutil
        per_process = cpu_accounting.spent(before, after)["per_process"]
        res = {}
        for p in self.procs:
            name = self.names[p.pid]
            cpu_s = per_process.get(cpu_accounting.label(name, p.pid))
            if cpu_s is None:
                continue  # ended before the window's end
            try:
                rss = p.memory_info().rss
            except psutil.Error:
                continue
            res[name] = {"cpu_percent": 100.0 * cpu_s / seconds if seconds > 0 else float("nan"),
                         "cpu_seconds": cpu_s, "rss_mb": rss / 1e6}
            peak = peak_rss_mb(p.pid)
            if peak is not None:
                res[name]["peak_rss_mb"] = peak
        return res

    def start(self):
        self.t0 = time.time()
        self.before = self.snapshot()

    def stop(self):
        wall = time.time() - self.t0
        return self.figures(self.before, self.snapshot(), wall), wall


#: How often rosbag play publishes /clock (per second of wall time): the simulated clock's
#: resolution, e.g. of the evaluation's latencies.
CLOCK_HZ = 200


class BagPlayer:
    """``rosbag play --clock``: the bag on simulated time (/clock at CLOCK_HZ).

    ``start()`` returns once the player plays: it starts paused and is let go only when each of
    its topics is connected to every subscriber the master lists for it (or after
    ``connect_timeout`` s of wall time, with a warning naming the missing connections). rosbag's
    own ``-d`` (a fixed sleep after advertising) is not enough: a node connects to a new
    publisher only after the master has told it about one, and on a loaded machine that took
    more than a second, so the bag's first messages went to no one (at a load of 15-19 the first
    reading of some sonars and the first camera_info of the cameras: the pipeline never received
    them, and the evaluation counted their frames as dropped)."""

    def __init__(self, bag, log_path, rate=1.0, extra=(), connect_timeout=60.0):
        self.cmd = ["rosbag", "play", "--clock", "--hz=%d" % CLOCK_HZ, "-q", "--pause", "-r",
                    str(rate)] + list(extra) + [bag]
        self.log_path = log_path
        self.connect_timeout = connect_timeout
        self.proc = None
        self.unconnected = {}  # {topic: subscriber nodes} not connected when playback began
        self.connect_wait_s = None  # wall time from the player's start to its playing

    def start(self):
        with open(self.log_path, "w") as f:
            self.proc = subprocess.Popen(self.cmd, stdout=f, stderr=subprocess.STDOUT,
                                         stdin=subprocess.DEVNULL, start_new_session=True)
        try:
            self._play_when_connected()
        except BaseException:
            self.stop()
            raise
        return self

    def _player_node(self, master, deadline):
        """(node name, XML-RPC URI, pause service) of this player (rosbag's ``play`` binary, a
        child of the ``rosbag`` script), once it offers its pause service."""
        while time.time() < deadline:
            if self.proc.poll() is not None:
                raise RunError("rosbag play ended (status %d) before playing:\n%s"
                               % (self.proc.returncode, log_tail(self.log_path)))
            try:
                services = master.getSystemState()[2]
            except Exception:
                services = []
            for service, nodes in services:
                if not service.endswith("/pause_playback"):
                    continue
                for node in nodes:
                    try:
                        uri = master.lookupNode(node)
                        pid = ServerProxy(uri).getPid("/evaluation")[2]
                        ours = cpu_accounting.tree_processes(self.proc.pid, include_root=True)
                        if pid in {p.pid for p in ours}:
                            return node, uri, service
                    except Exception:
                        continue
            time.sleep(0.05)
        raise RunError("rosbag play did not come up within %.0f s:\n%s"
                       % (self.connect_timeout, log_tail(self.log_path)))

    def _play_when_connected(self):
        import rosgraph
        master = rosgraph.Master("/evaluation_bag_player")
        t0 = time.time()
        deadline = t0 + self.connect_timeout
        node, uri, service = self._player_node(master, deadline)
        api = ServerProxy(uri)
        missing = {}
        while time.time() < deadline:
            try:
                missing = unconnected_subscribers(master, api, node)
            except Exception as e:  # a node going away between the two calls: ask again
                missing = {"?": [str(e)]}
            if not missing:
                break
            time.sleep(0.05)
        self.unconnected = missing
        if missing:
            sys.stderr.write("rosbag play starts although, after %.0f s, these subscribers are not "
                             "connected (their first messages may be lost): %s\n"
                             % (self.connect_timeout, missing))
        call_set_bool(master, service, False)  # False: do not pause, play
        self.connect_wait_s = time.time() - t0

    def running(self):
        return self.proc.poll() is None

    def stop(self):
        stop_process(self.proc, timeout=5)


def call_set_bool(master, service, value, timeout=30.0):
    """Calls a std_srvs/SetBool service (rosbag's ``pause_playback``) over TCPROS by hand:
    Debian packages the service's definition (ros-std-srvs), not its Python module, and rospy's
    client would tie the call to this process's node (refused once a session has shut it down).
    Returns the response's ``success``."""
    def framed(fields):
        body = b"".join(struct.pack("<I", len(f)) + f for f in (("%s=%s" % kv).encode() for kv in fields))
        return struct.pack("<I", len(body)) + body

    def read(sock, n):
        data = b""
        while len(data) < n:
            chunk = sock.recv(n - len(data))
            if not chunk:
                raise RunError("the service %s closed the connection" % service)
            data += chunk
        return data

    uri = urlparse(master.lookupService(service))
    with socket.create_connection((uri.hostname, uri.port), timeout=timeout) as sock:
        sock.sendall(framed([("callerid", "/evaluation_bag_player"), ("service", service),
                             ("md5sum", "09fb03525b03e7ea1fd3992bafd87e16")]))
        (n,) = struct.unpack("<I", read(sock, 4))
        header = read(sock, n)
        if b"error=" in header:
            raise RunError("the service %s refused the call: %r" % (service, header))
        sock.sendall(struct.pack("<IB", 1, 1 if value else 0))
        ok, n = struct.unpack("<BI", read(sock, 5))
        payload = read(sock, n)
        if ok != 1:
            raise RunError("the service %s failed: %r" % (service, payload))
        return bool(payload[:1] == b"\x01")


def unconnected_subscribers(master, api, node):
    """{topic: [subscriber nodes]}: the subscribers the master lists for a topic that ``node``
    (whose XML-RPC server is ``api``) publishes and that it has no connection to yet."""
    state = master.getSystemState()
    published = {t for t, nodes in state[0] if node in nodes}
    subscribers = {t: set(nodes) - {node} for t, nodes in state[1] if t in published}
    connected = {}
    for link in api.getBusInfo(node)[2]:
        # [connection id, the other end's node, direction, transport, topic, connected, ...]
        if len(link) > 5 and link[2] == "o" and link[5]:
            connected.setdefault(link[4], set()).add(link[1])
    missing = {t: sorted(subs - connected.get(t, set())) for t, subs in subscribers.items()}
    return {t: m for t, m in missing.items() if m}


class WallClockPlayer:
    """The bag on wall time, stamps moved to now (``wall_clock_play``): no /clock. ``start()``
    returns once the player has connected to the pipeline and begun; ``offset_s`` is what it
    added to every stamp; after ``wait()``, ``sent`` messages spanning ``data_s`` seconds of
    the bag were played."""

    def __init__(self, bag, log_path, duration=None):
        # Run by its path: the player imports nothing of the toolbox, so the child needs no
        # Python path of its own (source tree, devel or install space alike).
        player = os.path.join(os.path.dirname(os.path.abspath(__file__)), "wall_clock_play.py")
        self.cmd = [sys.executable, player, bag] + (
            ["--duration", "%.9g" % duration] if duration is not None else [])
        self.log_path = log_path
        self.proc = None
        self.offset_s = None
        self.sent = None
        self.data_s = None

    def start(self, timeout=60.0):
        """Starts the player; returns when it has begun playing (RunError if it could not)."""
        self._log = open(self.log_path, "w")
        self.proc = subprocess.Popen(self.cmd, stdout=subprocess.PIPE, stderr=self._log, text=True,
                                     stdin=subprocess.DEVNULL, start_new_session=True)
        line = self._line(timeout)
        if not line.startswith("started "):
            self.stop()
            raise RunError("the wall-clock player did not start:\n%s" % log_tail(self.log_path))
        self.offset_s = float(line.split()[1])
        return self

    def _line(self, timeout):
        got = []
        reader = threading.Thread(target=lambda: got.append(self.proc.stdout.readline()), daemon=True)
        reader.start()
        reader.join(timeout)
        return got[0] if got else ""

    def wait(self, timeout):
        """Waits for the end of playback; returns the number of messages sent."""
        line = self._line(timeout)
        try:
            self.proc.wait(10 if line else 0.1)
        except subprocess.TimeoutExpired:
            self.stop()
        self._log.close()
        if not line.startswith("done ") or self.proc.returncode != 0:
            raise RunError("the wall-clock player failed (status %s):\n%s"
                           % (self.proc.returncode, log_tail(self.log_path)))
        self.sent, self.data_s = int(line.split()[1]), float(line.split()[2])
        return self.sent

    def stop(self):
        stop_process(self.proc, timeout=5)
        if getattr(self, "_log", None) is not None and not self._log.closed:
            self._log.close()
