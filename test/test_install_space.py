"""The install space: what a robot runs after `catkin_make install`, with only
`install/setup.bash` sourced.

The existing build is installed into <build>/install (scripts/lib/setup.bash configures that
prefix; the install step copies files and compiles nothing, well under a second). Every check
then runs in a clean environment that sources only <build>/install/setup.bash, from a folder
outside the repository, so that neither the devel space nor the source tree can stand in for a
missing install rule: the packages are found there, every node starts through rosrun (and stops
on a bad configuration with the FATAL parameter message), every nodelet loads into a manager
through pluginlib, every launch file parses (its configs and the check_config it runs found)
and the package fragments and a system launch start their nodes, and every installed tool runs.
"""
import glob
import os
import re
import shutil
import subprocess
import time

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
from laserscan_toolbox.ros.rosrun import Roscore, stop_process

PACKAGES = ["laserscan_common", "depth_filter_scan_converter", "multi_laserscan_merger",
            "scan_evaluation_tools", "reactive_navigator"]
# The tools a user runs on a robot (scan_evaluation_tools/CMakeLists.txt installs them).
TOOLS = {"check_config", "evaluate_bag", "rviz_config"}
# Each node with private parameters it must refuse, and the parameter its FATAL message names.
NODES = [
    ("depth_filter_scan_converter", "depth_filter_scan_converter_node",
     ["_min_height:=1.5", "_max_height:=1.0"], "min_height"),
    ("depth_filter_scan_converter", "depth_image_scan_converter_node",
     ["_min_height:=1.5", "_max_height:=1.0"], "min_height"),
    ("depth_filter_scan_converter", "range_scan_converter_node",
     ["_min_consecutive_readings:=0"], "min_consecutive_readings"),
    ("multi_laserscan_merger", "multi_laserscan_merger_node", [], "sources"),  # no sources given
    ("reactive_navigator", "reactive_navigator_node", ["_scan_topics:=[scan]", "_mode:=4d"], "mode"),
]
# Each nodelet with the installed YAML (package, file in its config/) it starts on (None: its
# defaults).
NODELETS = [
    ("depth_filter_scan_converter/DepthFilterScanConverterNodelet",
     "depth_filter_scan_converter", "depth_filter_scan_converter.yaml"),
    ("depth_filter_scan_converter/DepthImageScanConverterNodelet",
     "depth_filter_scan_converter", "depth_filter_scan_converter.yaml"),
    ("depth_filter_scan_converter/RangeScanConverterNodelet",
     "depth_filter_scan_converter", "range_scan_converter.yaml"),
    ("multi_laserscan_merger/MultiLaserScanMergerNodelet",
     "multi_laserscan_merger", "multi_laserscan_merger.yaml"),
    ("reactive_navigator/ReactiveNavigatorNodelet", "reactive_navigator", "reactive_navigator.yaml"),
    # The benchmark's camera stand-in (scripts/camera_path_benchmark), installed with the converters.
    ("depth_filter_scan_converter/DepthReplayNodelet", None, None),
]
# Every launch file the install space holds; the last test starts those in STARTED, the others
# are parsed (roslaunch --nodes), with their configs and checks, since they need a robot or rviz.
LAUNCH_FILES = [("depth_filter_scan_converter", "depth_filter_scan_converter.launch"),
                ("depth_filter_scan_converter", "range_scan_converter.launch"),
                ("multi_laserscan_merger", "multi_laserscan_merger.launch"),
                ("reactive_navigator", "reactive_navigator.launch"),
                ("scan_evaluation_tools", "check_config.launch"),
                ("scan_evaluation_tools", "dual_lidar_demo.launch"),
                ("scan_evaluation_tools", "pipeline.launch"),
                ("scan_evaluation_tools", "rviz.launch")]
STARTED = {"depth_filter_scan_converter.launch", "range_scan_converter.launch",
           "multi_laserscan_merger.launch", "reactive_navigator.launch", "dual_lidar_demo.launch"}
MANAGER = "install_manager"


def build_dir():
    """The build whose devel space this test runs against (scripts/test sources it)."""
    for prefix in os.environ.get("CMAKE_PREFIX_PATH", "").split(os.pathsep):
        if os.path.basename(prefix) == "devel" and os.path.isfile(
                os.path.join(os.path.dirname(prefix), "CMakeCache.txt")):
            return os.path.dirname(prefix)
    pytest.fail("no build found: source build/devel/setup.bash after a build")


class Installed:
    """Runs commands in a clean environment that sources only the install space."""

    def __init__(self, prefix, workdir):
        self.prefix = prefix
        self.workdir = workdir
        # The ROS variables (master, ROS_HOME in workdir) are added by the fixture's Roscore.
        self.env = {"HOME": workdir, "PATH": "/usr/bin:/bin", "LANG": "C.UTF-8",
                    "ROSCONSOLE_FORMAT": "[${severity}] ${message}",
                    "ROSCONSOLE_STDOUT_LINE_BUFFERED": "1"}

    def command(self, args):
        # setup.bash reads the positional parameters (its own options): none reach it.
        return ["bash", "-c", 'cmd=("$@"); set --; source "$0" && exec "${cmd[@]}"',
                os.path.join(self.prefix, "setup.bash")] + args

    def run(self, *args, timeout=60):
        p = subprocess.run(self.command(list(args)), env=self.env, cwd=self.workdir,
                           capture_output=True, text=True, timeout=timeout)
        return p.returncode, p.stdout + p.stderr

    def run_all(self, commands, timeout=60):
        """Runs the commands (argument lists) at once; [(exit code, output)] in their order."""
        procs = [self.start(*args) for args in commands]
        results = []
        for p in procs:
            try:
                out, _ = p.communicate(timeout=timeout)
            except subprocess.TimeoutExpired:
                out = output_of(p)
            results.append((p.returncode, out))
        return results

    def start(self, *args):
        return subprocess.Popen(self.command(list(args)), env=self.env, cwd=self.workdir,
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                start_new_session=True)


def output_of(proc):
    stop_process(proc)
    return proc.stdout.read()


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    build = build_dir()
    prefix = os.path.join(build, "install")
    with open(os.path.join(build, "CMakeCache.txt")) as f:
        cache = f.read()
    assert "CMAKE_INSTALL_PREFIX:PATH=%s\n" % prefix in cache, (
        "%s is not configured to install into %s: configure it with build_workspace "
        "(scripts/lib/setup.bash)" % (build, prefix))
    # From scratch: files left by an earlier install must not hide a rule that went missing.
    shutil.rmtree(prefix, ignore_errors=True)
    p = subprocess.run(["cmake", "--install", build], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stdout + p.stderr
    workdir = str(tmp_path_factory.mktemp("install_space"))
    inst = Installed(prefix, workdir)
    # roscore from the install space's environment too
    with Roscore(workdir, base_env=inst.env, command=inst.command, cwd=workdir) as core:
        inst.env = core.env
        inst.master = core.master
        yield inst


def wait_for(condition, procs, what, timeout=30.0):
    """Waits until condition() holds; fails naming `what` if it does not, or if one of procs
    (a dict name -> Popen) ends first."""
    deadline = time.time() + timeout
    while not condition():
        ended = {n: p for n, p in procs.items() if p.poll() is not None}
        if ended or time.time() > deadline:
            logs = "\n".join("--- %s:\n%s" % (n, output_of(p)) for n, p in procs.items())
            pytest.fail("%s (%s)\n%s" % (what, "ended: %s" % sorted(ended) if ended else "timed out", logs))
        time.sleep(0.2)


def publishers(master, topic):
    return next((nodes for t, nodes in master.getSystemState()[0] if t == topic), [])


def test_the_environment_holds_the_install_space_only(installed):
    """What setup.bash of the install space sets points into it or outside the repository."""
    code, out = installed.run("bash", "-c", 'echo "$CMAKE_PREFIX_PATH:$ROS_PACKAGE_PATH:$PYTHONPATH:'
                                            '$LD_LIBRARY_PATH:$PATH"')
    assert code == 0, out
    for entry in filter(None, out.strip().split(":")):
        inside = os.path.realpath(entry).startswith(os.path.realpath(installed.prefix))
        assert inside or not os.path.realpath(entry).startswith(REPO + os.sep), entry


def test_packages_are_found_in_the_install_space(installed):
    code, out = installed.run("bash", "-c", 'for p in "$@"; do rospack find "$p"; done', "find", *PACKAGES)
    assert code == 0, out
    assert out.split() == [os.path.join(installed.prefix, "share", p) for p in PACKAGES], out


def executables(prefix, package):
    """The compiled programs (ELF files) an install space holds for `package` (where rosrun looks),
    without the benchmarks a developer may have built and installed (built on request only)."""
    found = set()
    for path in glob.glob(os.path.join(prefix, "lib", package, "*")):
        with open(path, "rb") as f:
            if f.read(4) == b"\x7fELF" and not path.endswith("_benchmark"):
                found.add(os.path.basename(path))
    return found


def test_the_lists_above_hold_every_installed_node_and_nodelet(installed):
    """Every compiled node of the node packages is in NODES and every nodelet class the installed
    plugin files declare is in NODELETS, so that the tests below start them all."""
    for package in PACKAGES:
        if package != "scan_evaluation_tools":  # its programs are tools (the last test runs them)
            assert executables(installed.prefix, package) == {n for p, n, _, _ in NODES if p == package}, package
    declared = set()
    for path in glob.glob(os.path.join(installed.prefix, "share", "*", "nodelet_plugins.xml")):
        with open(path) as f:
            declared.update(re.findall(r'<class name="([^"]+)"', f.read()))
    assert declared == {cls for cls, _, _ in NODELETS}


def test_every_node_starts_through_rosrun_and_refuses_a_bad_config(installed):
    procs = {node: installed.start("rosrun", pkg, node, "__name:=install_" + node, *params)
             for pkg, node, params, _ in NODES}
    for pkg, node, _, parameter in NODES:
        try:
            out, _ = procs[node].communicate(timeout=30)
        except subprocess.TimeoutExpired:
            pytest.fail("%s kept running with a bad configuration:\n%s" % (node, output_of(procs[node])))
        assert procs[node].returncode == 1, out
        assert "FATAL" in out and "parameter '%s'" % parameter in out, out


def test_every_nodelet_loads_into_a_manager(installed):
    """pluginlib finds every class through the installed package.xml exports and plugin xml;
    each nodelet starts on the installed commented YAML of its package."""
    manager = installed.start("rosrun", "nodelet", "nodelet", "manager", "__name:=" + MANAGER)
    loaders = {}
    try:
        for cls, pkg, yaml_file in NODELETS:
            name = "install_" + cls.split("/")[1]
            if yaml_file is not None:
                config = os.path.join(installed.prefix, "share", pkg, "config", yaml_file)
                code, out = installed.run("rosparam", "load", config, "/" + name)
                assert code == 0, out
            loaders[name] = installed.start("rosrun", "nodelet", "nodelet", "load", cls, MANAGER,
                                            "__name:=" + name, "scan:=/%s/scan" % name)
        loaded = set()

        def all_loaded():
            code, out = installed.run("rosservice", "call", "/%s/list" % MANAGER)
            loaded.update(re.findall(r"/[\w/]+", out))
            return code == 0 and {"/" + n for n in loaders} <= loaded

        wait_for(all_loaded, dict(loaders, manager=manager), "every nodelet in the manager's list")
        out = output_of(manager)
        assert "FATAL" not in out and "ERROR" not in out, out
        assert "merging 4 sources" in out, out  # the merger read the installed YAML
    finally:
        for p in list(loaders.values()) + [manager]:
            stop_process(p)


def test_every_launch_file_is_installed_and_parses_with_its_configs_and_checks(installed):
    """roslaunch <package> <file> finds each file; its YAMLs ($(dirname)/../config,
    $(find ...)) are read and pipeline.launch's check_config runs on each
    ($(find scan_evaluation_tools)/check_config: the installed tool)."""
    share = os.path.join(installed.prefix, "share")
    found = sorted((os.path.basename(os.path.dirname(os.path.dirname(p))), os.path.basename(p))
                   for p in glob.glob(os.path.join(share, "*", "launch", "*.launch")))
    assert found == sorted(LAUNCH_FILES), found
    config = os.path.join(share, "scan_evaluation_tools", "config", "dual_lidar_demo", "merger.yaml")
    parsed = [(pkg, launch) for pkg, launch in LAUNCH_FILES if launch not in STARTED]
    results = installed.run_all([["roslaunch", "--nodes", pkg, launch]
                                 + (["config:=" + config] if launch == "check_config.launch" else [])
                                 for pkg, launch in parsed])
    for (pkg, launch), (code, out) in zip(parsed, results):
        assert code == 0 and out.strip(), (pkg, launch, out)
        if launch == "pipeline.launch":
            assert out.count(": ok") == 6 and "/merged_scan_merger" in out, out


def test_launch_fragments_and_a_system_launch_start_their_nodes(installed):
    """The package fragments (standalone nodes and a nodelet in a manager) and
    dual_lidar_demo.launch (its check_config, mounts, manager and merger) start from the install
    space and advertise their outputs, which they do only after their configuration passed."""
    launches = {
        "depth": installed.start("roslaunch", "depth_filter_scan_converter", "depth_filter_scan_converter.launch",
                                 "standalone:=true", "input:=image", "name:=install_depth", "scan:=/install/depth_scan"),
        "range_manager": installed.start("rosrun", "nodelet", "nodelet", "manager", "__name:=install_range_manager"),
        "range": installed.start("roslaunch", "depth_filter_scan_converter", "range_scan_converter.launch",
                                 "manager:=install_range_manager", "name:=install_range", "scan:=/install/range_scan"),
        "merger": installed.start("roslaunch", "multi_laserscan_merger", "multi_laserscan_merger.launch",
                                  "standalone:=true", "name:=install_merger", "merged_scan:=/install/merged_scan"),
        "navigator": installed.start("roslaunch", "reactive_navigator", "reactive_navigator.launch",
                                     "name:=install_navigator", "cmd_vel:=/install/cmd_vel"),
        "dual_lidar_demo": installed.start("roslaunch", "scan_evaluation_tools", "dual_lidar_demo.launch",
                                           "manager:=install_dual_manager"),
    }
    outputs = {"/install/depth_scan": "/install_depth", "/install/range_scan": "/install_range_manager",
               "/install/merged_scan": "/install_merger", "/install/cmd_vel": "/install_navigator",
               "/merged_scan": "/install_dual_manager"}
    try:
        wait_for(lambda: all(node in publishers(installed.master, topic) for topic, node in outputs.items()),
                 launches, "every launch's output advertised")
    finally:
        logs = {n: output_of(p) for n, p in launches.items()}
    assert "merger.yaml: ok" in logs["dual_lidar_demo"], logs["dual_lidar_demo"]
    for name, log in logs.items():
        assert "FATAL" not in log and "ERROR" not in log, (name, log)


def test_installed_tools_run_from_the_install_space(installed, tmp_path):
    tool_dir = os.path.join(installed.prefix, "lib", "scan_evaluation_tools")
    python_tools = set()
    for path in glob.glob(os.path.join(tool_dir, "*")):
        with open(path, "rb") as f:
            if b"python" in f.readline():
                python_tools.add(os.path.basename(path))
    assert TOOLS <= python_tools, python_tools
    # and the compiled ones (bag_to_rawlog, rawlog_dump, bag_to_octomap: MRPT and OctoMap)
    compiled = executables(installed.prefix, "scan_evaluation_tools")
    assert {"bag_to_octomap", "bag_to_rawlog", "rawlog_dump"} <= compiled, compiled
    programs = sorted(python_tools) + sorted(compiled)
    results = installed.run_all([["rosrun", "scan_evaluation_tools", p, "--help"] for p in programs])
    for program, (code, out) in zip(programs, results):
        # the C++ programs (found, linked) print their usage with a non-zero status
        assert (code == 0 or program not in python_tools) and "usage" in out, (program, out)
    # The toolbox comes from the install space's Python folder, and finds launch/ and config/
    # in scan_evaluation_tools' share folder.
    code, out = installed.run("python3", "-c", "import laserscan_toolbox.ros.rosrun as r; print(r.__file__); print(r.REPO)")
    assert code == 0, out
    assert out.split() == [os.path.join(installed.prefix, "lib", "python3", "dist-packages", "laserscan_toolbox",
                                        "ros", "rosrun.py"),
                           os.path.join(installed.prefix, "share", "scan_evaluation_tools")], out
    # check_config passes every installed YAML, and names the key of a bad one.
    yamls = sorted(glob.glob(os.path.join(installed.prefix, "share", "*", "config", "**", "*.yaml"), recursive=True))
    assert len(yamls) >= 10, yamls
    code, out = installed.run("rosrun", "scan_evaluation_tools", "check_config", *yamls)
    assert code == 0 and out.count(": ok") == len(yamls), out
    bad = tmp_path / "bad.yaml"
    bad.write_text("reference_frame: base_link\nmin_height: 1.5\nmax_height: 1.0\n")
    code, out = installed.run("rosrun", "scan_evaluation_tools", "check_config", str(bad))
    assert code == 1 and "max_height" in out, out
    # rviz_config writes a view from the installed template.
    view = tmp_path / "robot.rviz"
    code, out = installed.run("rosrun", "scan_evaluation_tools", "rviz_config", "--fixed-frame", "base_link",
                              "--output", str(view))
    assert code == 0 and "Fixed Frame: base_link" in view.read_text(), out
