"""The docs stay true: every documented shell command is run somewhere or checked here.

Every command in a fenced shell block of README.md, CONTRIBUTING.md, docs/*.md and the package
READMEs must be in COMMANDS below, which names the test or script that runs it (or says that it
is only checked here). Every command is also checked cheaply: a script exists, is executable and
its options appear in its --help; the packages, files, launch files, rostest files, build
targets and executables it names exist; `name:=value` arguments exist in the launch file.
Launch includes in XML blocks, files named in the prose and every relative link (with its
#anchor) are checked too, and the package READMEs' parameter tables (name, type, unit, default)
and launch argument tables against check_config's schema and the launch files.
"""
import functools
import glob
import math
import os
import re
import shlex
import subprocess
import sys

import pytest

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Who runs each documented command. "checked" means: only the cheap checks of this file (the
# command costs minutes, needs a robot, a display or valgrind, or is a by-hand recipe).
# A runner is a file that must exist and mention the command's program.
CHECKED = "checked"
COMMANDS = {
    # --- the two commands, the demo and what it runs
    "scripts/demo": CHECKED,  # the demo itself: run by hand (minutes), its parts by the tests below
    "scripts/test": ".ci/run",
    "scripts/demo --laps 2 --output demo_2laps --no-build": CHECKED,
    "scripts/demo --laps 2 --output demo_2laps": CHECKED,
    "scripts/demo --no-slam --no-cpu": CHECKED,
    "scripts/check_config config/sim_robot/*.yaml": "scripts/demo",
    "scripts/check_config depth_filter_scan_converter/config/depth_filter_scan_converter.yaml "
    "multi_laserscan_merger/config/multi_laserscan_merger.yaml": "test/test_config_check.py",
    "scripts/check_config config/dual_lidar_demo/merger.yaml --bag test/data/real/dual_lidar_scans_demo.bag "
    "--tf-launch launch/dual_lidar_demo.launch": "test/test_config_check.py",
    "scripts/check_config config/dual_lidar_demo/merger.yaml --bag test/data/real/dual_lidar_scans_demo.bag "
    "--static-tf 0.23565 -0.0005 0.06795 0 0 0 base_link front_scanner "
    "--static-tf -0.23832 0.00542 0.09888 3.141592 0 0 base_link rear_scanner": "test/test_config_check.py",
    "scripts/simulate_scenario -o /tmp/shop.bag": "scripts/demo",
    "scripts/simulate_scenario -o /tmp/shop.bag --duration 20 --laps 1 --seed 0 --camera-points 52000 "
    "--no-progress": "test/test_scenario.py",
    "scripts/simulate_scenario --closed-loop --scripted --route table --camera-points 10000 "
    "--record /tmp/table_run.json": CHECKED,
    "scripts/simulate_scenario --closed-loop --route shop --camera-points 50000 --depth-output image "
    "--step-topic /reactive_navigator/step --state-topic /reactive_navigator/state "
    "--record /tmp/shop_run.json": "test/test_closed_loop_ros.py",
    "scripts/evaluate_bag /tmp/shop.bag --output /tmp/eval": "scripts/demo",
    "scripts/evaluate_bag /tmp/shop.bag --output /tmp/eval --map-topics /lidar_scan /merged_scan": "scripts/demo",
    "scripts/evaluate_bag /tmp/shop.bag --output /tmp/eval --map-topics --no-plots": CHECKED,
    "scripts/evaluate_bag /tmp/shop.bag --output /tmp/eval --map-topics --no-plots "
    "--no-self-filter-replay": CHECKED,
    "scripts/evaluate_bag /tmp/shop.bag --output /tmp/eval --map-topics --no-plots --cpu-replay 60": CHECKED,
    "scripts/evaluate_bag /tmp/shop.bag --output /tmp/eval --slam --max-slam-path-rmse 0.10 "
    "--min-slam-map-precision 0.90 --min-slam-3d-ratio 2 --max-localization-gap 0.02": "scripts/demo",
    "scripts/evaluate_bag test/data/real/dual_lidar_scans_demo.bag --launch launch/dual_lidar_demo.launch "
    "--output /tmp/dual --min-rate 15": "test/test_end_to_end.py",
    "scripts/evaluate_bag test/data/real/dual_lidar_scans_demo.bag --launch launch/dual_lidar_demo.launch "
    "--output /tmp/dual --rate 2": "test/test_end_to_end.py",
    "scripts/cpu_experiment --quick --output /tmp/cpu_quick": "scripts/demo",
    "scripts/navigation_experiment --output /tmp/navigation --quick": "scripts/demo",
    "scripts/navigation_experiment --output /tmp/navigation": CHECKED,  # the whole sweep: hours
    "scripts/cpu_experiment --duration 4 --output /tmp/cpu": CHECKED,
    "scripts/octomap_comparison --quick --output /tmp/octomap_quick": CHECKED,  # minutes
    "scripts/octomap_comparison --output /tmp/octomap": CHECKED,  # about 40 minutes
    "scripts/evaluate_bag /tmp/shop.bag --output /tmp/eval --octomap 0.05 0.10": "scripts/demo",
    "rosrun scan_evaluation_tools bag_to_octomap my.bag octomap_out --pose-topic /ground_truth/odom "
    "--depth-topic /camera_left/depth/image_rect --scan-topic /lidar_front/scan":
        "scan_evaluation_tools/test/test_bag_to_octomap.py",
    # --- rviz
    "roslaunch launch/rviz.launch": "test/test_rviz_screenshot.py",
    "roslaunch launch/rviz.launch fixed_frame:=base_link robot_frame:=base_link scans:=/front_scan /rear_scan "
    "merged:=/merged_scan clouds:=none": "test/test_rviz_screenshot.py",
    "scripts/rviz_config --fixed-frame base_link --robot-frame base_link --scans /front_scan /rear_scan "
    "--merged /merged_scan --clouds none --output my_robot.rviz": "test/test_rviz_screenshot.py",
    "scripts/rviz_screenshot test/data/real/dual_lidar_scans_demo.bag --launch launch/dual_lidar_demo.launch "
    "--fixed-frame base_link --robot-frame base_link --scans /front_scan /rear_scan --merged /merged_scan "
    "--clouds none --start 5 --output dual_lidar.png": "test/test_rviz_screenshot.py",
    # --- experiments and benchmarks (minutes each; their analysis is tested)
    "scripts/transport_experiment --duration 12 --repeat 3 --arg depth_input:=cloud --output /tmp/transport": CHECKED,
    "scripts/transport_experiment --duration 12 --repeat 3 --output /tmp/transport": CHECKED,
    "scripts/transport_experiment --output /tmp/transport": CHECKED,
    "scripts/camera_path_benchmark --repeat 3": "test/test_camera_path_benchmark.py",
    "scripts/camera_path_benchmark --repeat 3 --range-noise off": CHECKED,
    "scripts/camera_path_benchmark --repeat 3 --width 1280 --height 720 --frames 100 --range-noise off": CHECKED,
    "scripts/camera_path_benchmark --repeat 3 --source tcp --range-noise off": CHECKED,
    "scripts/camera_path_benchmark --width 640 --height 480 --frames 150 --rate 15 --repeat 2": CHECKED,
    "scripts/soak --quick --output soak_quick": CHECKED,
    "scripts/soak --output soak_30min": CHECKED,
    "/usr/bin/python3 depth_filter_scan_converter/bench/measure_node_cost.py --rate 3": CHECKED,
    "/usr/bin/python3 depth_filter_scan_converter/bench/measure_node_cost.py --rate 3 --executable "
    "per_point_reference_node _mode:=per_point": CHECKED,
    "/usr/bin/python3 depth_filter_scan_converter/bench/measure_node_cpu.py --clouds 100 --repeat 9":
    "depth_filter_scan_converter/test/test_per_point_reference.py",
    "/usr/bin/python3 multi_laserscan_merger/bench/measure_node_cost.py --seconds 20": CHECKED,
    # the merger node before and after issue 22, in instructions (valgrind; under an hour)
    "git worktree add ../before22 4a8646d": CHECKED,
    "cmake -S ../before22 -B ../before22_build -DCMAKE_BUILD_TYPE=Release -DCATKIN_ENABLE_TESTING=ON "
    "-DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3": CHECKED,
    "cmake --build ../before22_build --target multi_laserscan_merger_node -j2": CHECKED,
    "/usr/bin/python3 multi_laserscan_merger/bench/measure_node_cost.py --instructions --seconds 30 --rounds 3 "
    "--compare ../before22_build/devel": CHECKED,
    "/usr/bin/python3 multi_laserscan_merger/bench/measure_node_cost.py --instructions --rate-scale 0.25 "
    "--seconds 60 --rounds 3 --compare ../before22_build/devel": CHECKED,
    "/usr/bin/python3 multi_laserscan_merger/bench/shared_stamps_real_bag.py --windows 0 0.01": CHECKED,  # 3 min
    "cmake --build build --target depth_filter_scan_converter_benchmark": CHECKED,
    "cmake --build build --target multi_laserscan_merger_benchmark -j2": CHECKED,
    "taskset -c 1 build/devel/lib/depth_filter_scan_converter/depth_filter_scan_converter_benchmark "
    "--benchmark_repetitions=5": CHECKED,
    "taskset -c 1 build/devel/lib/depth_filter_scan_converter/depth_filter_scan_converter_benchmark "
    "--benchmark_filter=runArm --benchmark_repetitions=5 --benchmark_enable_random_interleaving=true": CHECKED,
    # the self filter's instruction counts (valgrind; minutes)
    "valgrind --tool=callgrind --callgrind-out-file=cg.out build/devel/lib/depth_filter_scan_converter/"
    "depth_filter_scan_converter_benchmark --benchmark_filter=runArm/WithSelfFilter --benchmark_min_time=0.05": CHECKED,
    "callgrind_annotate --inclusive=yes --tree=caller cg.out | grep -A1 runArmCloud.*x)": CHECKED,
    "taskset -c 1 build/devel/lib/multi_laserscan_merger/multi_laserscan_merger_benchmark "
    "--benchmark_repetitions=5": CHECKED,
    # --- tests
    "source build/devel/setup.bash": "scripts/lib/setup.bash",
    "cmake --build build --target tests -j2": "scripts/test",
    "cmake --build build --target run_tests -- -j1 && catkin_test_results build/test_results": "scripts/test",
    "cmake --build build --target run_tests_multi_laserscan_merger": "scripts/test",
    "cmake --build build --target run_tests_multi_laserscan_merger -- -j1": "scripts/test",
    "cmake --build build --target run_tests_depth_filter_scan_converter -- -j1": "scripts/test",
    "cmake --build build --target run_tests_laserscan_common -- -j1": "scripts/test",
    "build/devel/lib/depth_filter_scan_converter/depth_filter_scan_converter_core_test":
        "depth_filter_scan_converter/CMakeLists.txt",
    "rostest multi_laserscan_merger merger_nodelet.test": "multi_laserscan_merger/CMakeLists.txt",
    "rostest multi_laserscan_merger fuzz_nodelets.test": "multi_laserscan_merger/CMakeLists.txt",
    "rostest multi_laserscan_merger fault_recovery.test": "multi_laserscan_merger/CMakeLists.txt",
    "cmake --build build --target depth_filter_scan_converter_fuzz_test multi_laserscan_merger_fuzz_test":
        "depth_filter_scan_converter/CMakeLists.txt",
    "build/devel/lib/depth_filter_scan_converter/depth_filter_scan_converter_fuzz_test":
        "depth_filter_scan_converter/CMakeLists.txt",
    "FUZZ_SEED=7 FUZZ_CASES=1000000 build/devel/lib/multi_laserscan_merger/multi_laserscan_merger_fuzz_test":
        CHECKED,
    "/usr/bin/python3 -m pytest -q -p no:cacheprovider depth_filter_scan_converter/test "
    "multi_laserscan_merger/test scan_evaluation_tools/test test": "scripts/test",
    "/usr/bin/python3 -m pytest -q -p no:cacheprovider test/test_docs.py": "scripts/test",
    "/usr/bin/python3 -m pytest -q -p no:cacheprovider depth_filter_scan_converter/test": "scripts/test",
    "/usr/bin/python3 -m pytest -q -p no:cacheprovider multi_laserscan_merger/test": "scripts/test",
    "/usr/bin/python3 scripts/lib/check_format.py /tmp/clang_format.xml .": "scripts/test",
    # --- MRPT by hand (the SLAM experiment runs the same programs)
    "rosrun scan_evaluation_tools bag_to_rawlog my.bag merged.rawlog --scan-topic /merged_scan --odom-topic /odom "
    "--base-frame base_link --min-interval 0.1 --index merged.txt": "scan_evaluation_tools/test/test_bag_to_rawlog.py",
    "rosrun scan_evaluation_tools rawlog_dump merged.rawlog": "scan_evaluation_tools/test/test_bag_to_rawlog.py",
    "rosrun scan_evaluation_tools bag_to_rawlog my.bag merged.rawlog --scan-topic /merged_scan --min-interval 0.1":
        "scan_evaluation_tools/test/test_bag_to_rawlog.py",
    "sed -e s#^rawlog_file=.*#rawlog_file=$PWD/merged.rawlog# -e s#^logOutput_dir=.*#logOutput_dir=$PWD/slam# "
    "$(rospack find scan_evaluation_tools)/config/rbpf_slam.ini > slam.ini": CHECKED,
    "rbpf-slam slam.ini </dev/null": CHECKED,
    # --- a user's catkin workspace and its install space (the builds by hand: docs/testing.md)
    "cd ~/catkin_ws": CHECKED,
    "catkin_make -DCMAKE_BUILD_TYPE=Release": CHECKED,
    "catkin_make install": CHECKED,
    "catkin init": CHECKED,
    "catkin config --install --cmake-args -DCMAKE_BUILD_TYPE=Release": CHECKED,
    "catkin build": CHECKED,
    "source install/setup.bash": "test/test_install_space.py",
    "rosrun scan_evaluation_tools check_config ~/my_robot/merger.yaml": "test/test_install_space.py",
    # --- launch fragments
    "roslaunch multi_laserscan_merger multi_laserscan_merger.launch manager:=laser_manager":
        "multi_laserscan_merger/test/rostest/merger_nodelet.test",
    "roslaunch multi_laserscan_merger multi_laserscan_merger.launch standalone:=true config:=/path/to/my_robot.yaml "
    "merged_scan:=scan_merged": "multi_laserscan_merger/test/rostest/merger_node.test",
}

# The table's runners: scripts/test runs the gtests and rostests that a package's CMakeLists.txt
# registers (catkin run_tests), and every pytest file under the packages' test/ and test/.

# Programs that are not this repository's and need no more than their path arguments checked.
EXTERNAL = {"source", "cd", "catkin_test_results", "sed", "rbpf-slam", "rosbag", "catkin_lint", "catkin_make",
            "catkin", "git", "valgrind", "callgrind_annotate", "grep"}
SHELL_LANGS = {"sh", "bash", "shell", "console"}


def markdown_files():
    files = [os.path.join(REPO, "README.md"), os.path.join(REPO, "CONTRIBUTING.md")]
    files += sorted(glob.glob(os.path.join(REPO, "docs", "*.md")))
    files += sorted(os.path.join(REPO, d, "README.md") for d in os.listdir(REPO)
                    if os.path.isfile(os.path.join(REPO, d, "package.xml")))
    return files


def rel(path):
    return os.path.relpath(path, REPO)


def parse(path):
    """(fenced blocks as (lang, first line number, text), prose lines as (number, text))."""
    blocks, prose = [], []
    fence = None
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            stripped = line.rstrip("\n")
            if fence is None and stripped.startswith("```"):
                fence = (stripped[3:].strip().lower(), number, [])
            elif fence is not None and stripped.startswith("```"):
                blocks.append((fence[0], fence[1], "\n".join(fence[2])))
                fence = None
            elif fence is not None:
                fence[2].append(stripped)
            else:
                prose.append((number, stripped))
    assert fence is None, "%s: a fenced block opened at line %d is never closed" % (rel(path), fence[1])
    return blocks, prose


def commands_of(text):
    """The logical lines of a shell block, continuation lines joined, each as (line, tokens)."""
    out = []
    for line in text.replace("\\\n", " ").split("\n"):
        if not line.strip() or line.strip().startswith("#"):
            continue
        tokens = shlex.split(line, comments=True)
        out.append((" ".join(tokens), tokens))
    return out


@functools.lru_cache(maxsize=None)
def documented_commands():
    found = {}
    for path in markdown_files():
        for lang, number, text in parse(path)[0]:
            if lang in SHELL_LANGS:
                for command, tokens in commands_of(text):
                    found.setdefault(command, []).append(("%s:%d" % (rel(path), number), tokens))
    return found


# --- what the repository provides -----------------------------------------------------------

def packages():
    return {d for d in os.listdir(REPO) if os.path.isfile(os.path.join(REPO, d, "package.xml"))}


@functools.lru_cache(maxsize=None)
def cmakelists(package):
    with open(os.path.join(REPO, package, "CMakeLists.txt"), encoding="utf-8") as f:
        return f.read().replace("${PROJECT_NAME}", package)


@functools.lru_cache(maxsize=None)
def build_targets(package):
    """Executable and test targets a package's CMakeLists.txt declares, and the scripts it
    installs (catkin_install_python: rosrun runs them too)."""
    text = cmakelists(package)
    names = re.findall(r"\b(?:add_executable|catkin_add_gtest|sanitized_gtest|add_custom_target)\(\s*([\w.-]+)", text)
    for programs in re.findall(r"catkin_install_python\(PROGRAMS\s+([^)]*?)\s+DESTINATION", text):
        names += [os.path.basename(p) for p in programs.split()]
    return set(names)


def launch_dirs(package):
    """Where `roslaunch <package> <file>` finds a file: the package's launch/, and the
    repository's launch/ for the package that installs it (scan_evaluation_tools)."""
    dirs = [os.path.join(REPO, package, "launch")]
    if re.search(r"install\(DIRECTORY[^)]*\.\./launch\b", cmakelists(package)):
        dirs.append(os.path.join(REPO, "launch"))
    return dirs


def all_targets():
    names = {"all", "tests", "run_tests", "install"}
    for package in packages():
        names |= build_targets(package) | {"run_tests_" + package}
    return names


@functools.lru_cache(maxsize=None)
def launch_args(path):
    with open(path, encoding="utf-8") as f:
        return set(re.findall(r'<arg\s+name="([^"]+)"', f.read()))


@functools.lru_cache(maxsize=None)
def help_text(script):
    result = subprocess.run([os.path.join(REPO, script), "--help"], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, universal_newlines=True, timeout=120)
    assert result.returncode == 0, "%s --help exits %d:\n%s" % (script, result.returncode, result.stdout)
    return result.stdout


def option_in(option, text):
    return re.search(r"(?<![\w-])%s(?![\w-])" % re.escape(option), text) is not None


TOP_LEVEL = None


def repo_path_problems(tokens):
    """Tokens that name a file of this repository (by its top-level folder) must exist."""
    global TOP_LEVEL
    if TOP_LEVEL is None:
        TOP_LEVEL = {e for e in os.listdir(REPO) if not e.startswith(".") and e not in ("build", "demo_output")}
    problems = []
    skip_next = False
    for token in tokens:
        if skip_next:
            skip_next = False
            continue
        if token in ("-o", "--output"):
            skip_next = True  # written, not read
            continue
        value = token.split(":=", 1)[-1].split("=", 1)[-1] if token.startswith("-") or ":=" in token else token
        head = value.split("/", 1)[0]
        if "/" in value and head in TOP_LEVEL and not glob.glob(os.path.join(REPO, value)):
            problems.append("names %s, which does not exist" % value)
    return problems


# --- the cheap checks of one command ----------------------------------------------------------

def split_simple(tokens):
    """Split a command line at && || ; | & and drop redirections."""
    parts, current = [], []
    redirect = False
    for token in tokens:
        if redirect:
            redirect = False
            continue
        if token in ("&&", "||", ";", "|", "&"):
            parts.append(current)
            current = []
        elif token in (">", "<", ">>", "2>"):
            redirect = True
        elif token.startswith(("<", ">", "2>")):
            continue
        else:
            current.append(token)
    parts.append(current)
    return [p for p in parts if p]


def check_simple(tokens):
    while tokens and re.match(r"^[A-Z_][A-Z0-9_]*=", tokens[0]):
        tokens = tokens[1:]
    if tokens[:1] == ["taskset"]:
        tokens = tokens[3:]
    if not tokens:
        return ["an empty command"]
    program, args = tokens[0], tokens[1:]
    problems = repo_path_problems(args)
    if program.startswith("scripts/"):
        path = os.path.join(REPO, program)
        if not os.path.isfile(path):
            return ["%s does not exist" % program]
        if not os.access(path, os.X_OK):
            return ["%s is not executable" % program]
        options = [a.split("=", 1)[0] for a in args if a.startswith("-") and not re.match(r"^-\d", a)]
        if options:
            if program == "scripts/test":
                return ["scripts/test takes no options"]
            text = help_text(program)
            problems += ["%s: option %s is not in its --help" % (program, o) for o in options if not option_in(o, text)]
    elif program == "roslaunch":
        if args and args[0].endswith(".launch"):
            launch, rest = os.path.join(REPO, args[0]), args[1:]
        elif len(args) >= 2:
            if args[0] not in packages():
                return ["roslaunch: %s is not a package of this repository" % args[0]]
            found = [os.path.join(d, args[1]) for d in launch_dirs(args[0]) if os.path.isfile(os.path.join(d, args[1]))]
            launch, rest = (found or [os.path.join(REPO, args[0], "launch", args[1])])[0], args[2:]
        else:
            return ["roslaunch without a launch file"]
        if not os.path.isfile(launch):
            return ["roslaunch: %s does not exist" % rel(launch)]
        known = launch_args(launch)
        problems += ["roslaunch %s: no argument %s" % (rel(launch), a.split(":=")[0])
                     for a in rest if ":=" in a and a.split(":=")[0] not in known]
    elif program == "rostest":
        if len(args) < 2 or args[0] not in packages():
            return ["rostest: unknown package in %s" % " ".join(args)]
        if not glob.glob(os.path.join(REPO, args[0], "test", "**", args[1]), recursive=True):
            problems.append("rostest: %s has no %s" % (args[0], args[1]))
    elif program == "rosrun":
        if len(args) < 2 or args[0] not in packages():
            return ["rosrun: unknown package in %s" % " ".join(args)]
        if args[1] not in build_targets(args[0]):
            problems.append("rosrun: %s builds no %s" % (args[0], args[1]))
    elif program == "cmake":
        if "--target" in args:
            targets = []
            for a in args[args.index("--target") + 1:]:
                if a.startswith("-"):
                    break
                targets.append(a)
            known = all_targets()
            problems += ["cmake: no target %s" % t for t in targets if t not in known]
    elif program.startswith("build/devel/lib/"):
        parts = program.split("/")
        if len(parts) != 5 or parts[3] not in packages() or parts[4] not in build_targets(parts[3]):
            problems.append("%s is not built by this repository" % program)
    elif program == "/usr/bin/python3":
        if args[:2] == ["-m", "pytest"]:
            pass  # path arguments are checked above
        elif args and args[0].endswith(".py"):
            path = os.path.join(REPO, args[0])
            if os.path.isfile(path):
                with open(path, encoding="utf-8") as f:
                    source = f.read()
                problems += ["%s: no option %s" % (args[0], a) for a in args[1:]
                             if a.startswith("--") and ("'%s'" % a) not in source and ('"%s"' % a) not in source]
            else:
                problems.append("%s does not exist" % args[0])
        else:
            problems.append("python3: neither a script nor -m pytest")
    elif program not in EXTERNAL:
        problems.append("unknown program %s (add it to the checks of test/test_docs.py)" % program)
    return problems


def command_problems(tokens):
    problems = []
    for simple in split_simple(tokens):
        problems += check_simple(simple)
    return problems


# --- the tests ---------------------------------------------------------------------------------

def test_every_documented_command_is_in_the_table():
    documented = documented_commands()
    missing = ["%s (%s)" % (c, ", ".join(w for w, _ in where)) for c, where in documented.items() if c not in COMMANDS]
    assert not missing, ("documented commands that nobody runs: add each to COMMANDS in test/test_docs.py with "
                         "the test or script that runs it:\n  " + "\n  ".join(missing))


def test_the_table_lists_only_documented_commands():
    documented = documented_commands()
    stale = [c for c in COMMANDS if c not in documented]
    assert not stale, "COMMANDS entries no doc shows any more:\n  " + "\n  ".join(stale)


def subject(command):
    """The word a runner must mention to run `command`: the script, launch file, test file,
    executable or build target it is about."""
    words = [w for w in shlex.split(command, comments=True) if not re.match(r"^[A-Z_]+=", w)]
    if words[0] == "taskset":
        words = words[3:]
    program, args = words[0], [w for w in words[1:] if not w.startswith("-")]
    if program in ("rostest", "rosrun"):
        name = args[1]
    elif program in ("roslaunch", "source"):
        name = args[-1] if program == "source" else args[0] if args[0].endswith(".launch") else args[1]
    elif program == "cmake":
        name = words[words.index("--target") + 1]
        name = "run_tests" if name.startswith("run_tests") else name
    elif program == "/usr/bin/python3":
        name = "pytest" if words[1:3] == ["-m", "pytest"] else args[0]
    else:
        name = program
    return re.sub(r"\.(launch|test)$", "", os.path.basename(name))


def test_runners_exist_and_run_the_program():
    problems = []
    for command, runner in COMMANDS.items():
        if runner == CHECKED:
            continue
        path = os.path.join(REPO, runner)
        if not os.path.isfile(path):
            problems.append("%s: runner %s does not exist" % (command, runner))
            continue
        with open(path, encoding="utf-8", errors="replace") as f:
            text = f.read().replace("${PROJECT_NAME}", runner.split("/")[0])
        name = subject(command)
        if name not in text and name.replace("_", "-") not in text:
            problems.append("%s: %s does not mention %s" % (command, runner, name))
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("command", sorted(documented_commands()))
def test_command_is_true(command):
    """Every documented command, in the table or not."""
    where = documented_commands()[command]
    problems = command_problems(where[0][1])
    assert not problems, "%s (%s):\n  %s" % (command, ", ".join(w for w, _ in where), "\n  ".join(problems))


def test_no_command_outside_a_fenced_block():
    starts = ("scripts/", "roslaunch ", "rosrun ", "rostest ", "cmake ", "/usr/bin/python3 ")
    found = []
    for path in markdown_files():
        for number, line in parse(path)[1]:
            if line.startswith("    ") and line.strip().startswith(starts):
                found.append("%s:%d: %s" % (rel(path), number, line.strip()))
    assert not found, "commands in indented blocks (put them in ```sh blocks):\n  " + "\n  ".join(found)


def test_files_named_in_the_docs_exist():
    """`path/to/file` in the prose exists, relative to the repository, the markdown file or a
    package (package READMEs and CONTRIBUTING.md name files inside a package)."""
    roots = [REPO] + [os.path.join(REPO, p) for p in sorted(packages())]
    # Only names that start in a folder of the repository or of a package (not message types,
    # topics, or what the tools write, such as build/ and demo_output/).
    starts = {e for r in roots for e in os.listdir(r) if os.path.isdir(os.path.join(r, e))}
    starts -= {"build", "demo_output", ".git"}
    problems = []
    for path in markdown_files():
        for number, line in parse(path)[1]:
            for name in re.findall(r"`([\w.][\w.*/-]*/[\w.*/-]*)`", line):
                if name.split("/", 1)[0] not in starts:
                    continue
                head, _, last = name.rpartition("/")
                if head in packages() and re.match(r"^[A-Z]\w*$", last):
                    continue  # a nodelet class, pkg/ClassName
                in_package = os.path.dirname(path) != REPO and path != os.path.join(REPO, "docs", os.path.basename(path))
                where = [os.path.dirname(path), REPO] if in_package else roots
                if not any(glob.glob(os.path.join(r, name)) for r in where):
                    problems.append("%s:%d: %s does not exist" % (rel(path), number, name))
    assert not problems, "\n".join(problems)


def xml_includes(text):
    """(launch file, [arg names]) of each <include> whose file this repository holds."""
    for match in re.finditer(r'<include\s+file="([^"]+)"\s*>(.*?)</include>', text, re.S):
        file, body = match.group(1), match.group(2)
        found = re.match(r"\$\(find ([\w]+)\)/(.*)", file)
        if not found:
            continue
        package, path = found.group(1), found.group(2)
        launch = os.path.normpath(os.path.join(REPO, package, path))
        if not os.path.isfile(launch) and path.startswith("launch/") and package in packages():
            # a launch file the package installs from the repository's launch/
            launch = next((os.path.join(d, path[len("launch/"):]) for d in launch_dirs(package)
                           if os.path.isfile(os.path.join(d, path[len("launch/"):]))), launch)
        yield launch, package, re.findall(r'<arg\s+name="([^"]+)"', body)


def test_launch_includes_in_the_docs_exist_with_their_arguments():
    problems = []
    for path in markdown_files():
        for lang, number, text in parse(path)[0]:
            if lang != "xml":
                continue
            for launch, package, args in xml_includes(text):
                where = "%s:%d" % (rel(path), number)
                if package not in packages() and package != "my_robot":
                    problems.append("%s: unknown package %s" % (where, package))
                elif package in packages() and not os.path.isfile(launch):
                    problems.append("%s: %s does not exist" % (where, rel(launch)))
                elif package in packages():
                    problems += ["%s: %s has no argument %s" % (where, rel(launch), a)
                                 for a in args if a not in launch_args(launch)]
    assert not problems, "\n".join(problems)


def slug(heading):
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading.strip().lower())
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


@functools.lru_cache(maxsize=None)
def anchors(path):
    seen, out = {}, set()
    for _, line in parse(path)[1]:
        match = re.match(r"^#{1,6}\s+(.*)$", line)
        if match:
            base = slug(match.group(1))
            n = seen.get(base, 0)
            out.add(base if n == 0 else "%s-%d" % (base, n))
            seen[base] = n + 1
    return out


def test_relative_links_resolve():
    problems = []
    for path in markdown_files():
        for number, line in parse(path)[1]:
            for target in re.findall(r"\]\(([^)\s]+)\)", line):
                if re.match(r"^[a-z]+:", target):
                    continue
                file, _, anchor = target.partition("#")
                resolved = os.path.normpath(os.path.join(os.path.dirname(path), file)) if file else path
                where = "%s:%d: %s" % (rel(path), number, target)
                if not os.path.exists(resolved):
                    problems.append(where + ": no such file")
                elif anchor and resolved.endswith(".md") and anchor not in anchors(resolved):
                    problems.append(where + ": no heading with that anchor")
    assert not problems, "\n".join(problems)


# --- parameter tables against check_config's schema (itself tied to the C++ structs) -----------

def config_schema():
    from laserscan_toolbox import config_check
    return config_check


def parameter_table(readme, section, first_column="parameter", nth=0):
    """{name: (type, unit, default)} of the nth table headed `first_column` in `section`."""
    with open(os.path.join(REPO, readme), encoding="utf-8") as f:
        text = f.read()
    start = text.index(section)
    tables = [m.start() for m in re.finditer(r"^\| %s \| type \| unit \| default \| meaning \|$" % first_column,
                                             text[start:], re.M)]
    assert len(tables) > nth, "%s: no '%s' table after %r" % (readme, first_column, section)
    rows = {}
    for line in text[start + tables[nth]:].split("\n")[2:]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        names = re.findall(r"`(\w+)`", cells[0])
        defaults = [d.strip() for d in cells[3].split(",")] if len(names) > 1 else [cells[3]]
        for name, default in zip(names, defaults if len(defaults) == len(names) else defaults * len(names)):
            rows[name] = (cells[1], cells[2], default)
    return rows


def parse_default(cell):
    if cell.startswith("(required"):
        return ""  # a required string: the struct's default is empty
    if cell.startswith("("):  # "(the paper's robot)": no value of its own
        return None
    text = re.sub(r"\s*\(.*\)$", "", cell.replace("`", "")).strip()
    words = {"pi": math.pi, "-pi": -math.pi, "pi/720": math.pi / 720, "+inf": math.inf, ".inf": math.inf,
             "true": True, "false": False, '""': "", "[]": [], "absent": {}}
    if text in words:
        return words[text]
    if text.startswith("[") and text.endswith("]"):
        import yaml
        return yaml.safe_load(text)
    try:
        return float(text)
    except ValueError:
        return text


TYPES = {"topic_list": "list of strings", "band": "[min, max]", "shape_levels": "list of {height, polygon}",
         "float": "double", "int": "int", "whole": "int", "bool": "bool", "str": "string", "polygon": "list of `[x, y]`",
         "self_filter": "dict"}


@pytest.mark.parametrize("readme, section, column, nth, schema", [
    ("depth_filter_scan_converter/README.md", "## Depth converters", "parameter", 0, "CONVERTER"),
    ("depth_filter_scan_converter/README.md", "## range_scan_converter", "parameter", 0, "RANGE"),
    ("multi_laserscan_merger/README.md", "### Parameters", "parameter", 0, "MERGER"),
    ("multi_laserscan_merger/README.md", "### Parameters", "key", 0, "SOURCE"),
    ("reactive_navigator/README.md", "## Parameters", "parameter", 0, "NAVIGATOR"),
])
def test_parameter_tables_match_the_schema(readme, section, column, nth, schema):
    keys = getattr(config_schema(), schema)
    table = parameter_table(readme, section, column, nth)
    problems = ["%s: not in the README's table" % k for k in keys if k not in table]
    problems += ["%s: in the README, not in check_config's schema" % k for k in table if k not in keys]
    for name, key in keys.items():
        if key is None or name not in table:
            continue
        kind, unit, default = table[name]
        if kind != TYPES[key.kind]:
            problems.append("%s: type %s, schema says %s" % (name, kind, key.kind))
        if key.unit and unit != key.unit:
            problems.append("%s: unit %r, schema says %r" % (name, unit, key.unit))
        value = parse_default(default)
        same = value == key.default or (isinstance(value, float) and isinstance(key.default, (int, float))
                                        and not isinstance(key.default, bool)
                                        and math.isclose(value, key.default, rel_tol=1e-6))
        if not same:
            problems.append("%s: default %s, schema says %r" % (name, default, key.default))
    assert not problems, "%s %s:\n  %s" % (readme, schema, "\n  ".join(problems))


def launch_user_args(path):
    """Arguments a user can set: those with a default, or with neither default nor value."""
    with open(path, encoding="utf-8") as f:
        tags = re.findall(r"<arg\s[^>]*>", f.read())
    return {re.search(r'name="([^"]+)"', t).group(1) for t in tags if 'value="' not in t}


def test_launch_argument_tables_match_the_launch_files():
    """A package README's `| argument |` table lists exactly the user arguments of the launch
    file named last before it, with their defaults."""
    problems = []
    for package in sorted(packages()):
        readme = os.path.join(REPO, package, "README.md")
        with open(readme, encoding="utf-8") as f:
            text = f.read()
        for table in re.finditer(r"^\| argument \| default \| meaning \|\n\|[-|]+\|\n((?:\|.*\n)+)", text, re.M):
            launch = re.findall(r"`(launch/[\w.]+\.launch)`", text[:table.start()])[-1]
            path = os.path.join(REPO, package, launch)
            with open(path, encoding="utf-8") as f:
                source = f.read()
            documented = set()
            for row in table.group(1).strip().split("\n"):
                cells = [c.strip() for c in row.strip().strip("|").split("|")]
                names = re.findall(r"`(\w+)`", cells[0])
                defaults = re.findall(r"`([^`]*)`", cells[1])
                documented |= set(names)
                for name, default in zip(names, defaults if len(defaults) == len(names) else []):
                    found = re.search(r'<arg\s+name="%s"\s+default="([^"]*)"' % name, source)
                    if not found:
                        problems.append("%s: %s has no argument %s with a default" % (package, launch, name))
                    elif not (found.group(1).endswith("/" + default) if "/" in default
                              else found.group(1) == default):  # paths are written from the package
                        problems.append("%s: %s's %s defaults to %s, the README says %s"
                                        % (package, launch, name, found.group(1), default))
            missing = launch_user_args(path) - documented
            problems += ["%s: %s's argument %s is not in the README's table" % (package, launch, a) for a in missing]
    assert not problems, "\n".join(problems)


def test_the_checks_catch_a_stale_command():
    """The checks themselves: each kind of stale command is found."""
    stale = [
        "scripts/evaluate_bag x.bag --no-such-option",
        "scripts/no_such_tool --help",
        "roslaunch launch/rviz.launch no_such_arg:=1",
        "roslaunch launch/no_such.launch",
        "rostest multi_laserscan_merger no_such.test",
        "rosrun scan_evaluation_tools no_such_program",
        "cmake --build build --target no_such_target",
        "build/devel/lib/multi_laserscan_merger/no_such_binary",
        "/usr/bin/python3 -m pytest test/no_such_test.py",
        "scripts/check_config config/no_such.yaml",
        "scripts/test --verbose",
        "frobnicate now",
    ]
    for command in stale:
        assert command_problems(shlex.split(command)), command
    assert not command_problems(shlex.split("scripts/evaluate_bag x.bag --rate 2 --output /tmp/x"))


if __name__ == "__main__":
    sys.exit(pytest.main([__file__, "-q"]))
