"""rviz configurations for any robot: the pipeline's view with a given fixed frame and topics.

config/rviz/pipeline.rviz shows the simulated robot (fixed frame odom, its eight topics). On
another robot or bag those frames and topics do not exist and rviz reports "Global Status:
Error" with nothing drawn. ``make_config`` keeps that file's look (grid, tf, view, window) and
rebuilds its topic displays from the user's lists: input scans, merged scans and clouds, each
in a colour of its own. ``launch/rviz.launch`` runs this module as rviz's launch-prefix, so
the configuration is written when rviz starts.
"""

import argparse
import hashlib
import os
import sys

import yaml

from .rosrun import REPO

TEMPLATE = os.path.join(REPO, "config", "rviz", "pipeline.rviz")
# Defaults: the simulated robot of launch/pipeline.launch (what the template shows).
SIM_VIEW = {"fixed_frame": "odom", "robot_frame": "base_link",
            "scans": ["/lidar_front/scan", "/lidar_rear/scan", "/camera_left/scan",
                      "/camera_right/scan"],
            "merged": ["/merged_scan"],
            "clouds": ["/camera_left/filtered_cloud", "/camera_right/filtered_cloud"]}
# RGB as rviz writes it; the first ones are the template's, the rest tell more topics apart.
SCAN_COLOURS = ["0; 255; 0", "0; 200; 120", "0; 160; 255", "160; 80; 255", "0; 255; 255",
                "255; 120; 200", "200; 255; 120", "120; 120; 255"]
MERGED_COLOURS = ["255; 40; 40", "255; 200; 0", "255; 128; 0", "255; 255; 255"]
CLOUD_COLOURS = ["120; 200; 255", "180; 140; 255", "200; 200; 120", "255; 180; 140"]


def _colour(palette, i):
    return palette[i % len(palette)]


def _scan_display(name, topic, colour, size_m, size_px):
    return {"Alpha": 1, "Class": "rviz/LaserScan", "Color": colour,
            "Color Transformer": "FlatColor", "Decay Time": 0, "Enabled": True, "Name": name,
            "Position Transformer": "XYZ", "Queue Size": 10, "Selectable": False,
            "Size (Pixels)": size_px, "Size (m)": size_m, "Style": "Flat Squares",
            "Topic": topic, "Unreliable": False, "Use Fixed Frame": True, "Value": True}


def _cloud_display(name, topic, colour):
    return {"Alpha": 0.5, "Class": "rviz/PointCloud2", "Color": colour,
            "Color Transformer": "FlatColor", "Decay Time": 0, "Enabled": True, "Name": name,
            "Position Transformer": "XYZ", "Queue Size": 5, "Selectable": False,
            "Size (Pixels)": 3, "Style": "Points", "Topic": topic, "Unreliable": False,
            "Use Fixed Frame": True, "Value": True}


def make_config(fixed_frame, robot_frame, scans, merged, clouds, template=TEMPLATE):
    """The template's configuration (a dict) with the given fixed frame, robot frame and
    topic displays: clouds first, then input scans, then merged scans (drawn larger, so an
    input point on a merged one leaves a rim of the merged colour)."""
    for what, frame in (("fixed frame", fixed_frame), ("robot frame", robot_frame)):
        if not frame or not frame.strip("/"):
            raise ValueError("the %s must not be empty" % what)
    with open(template) as f:
        cfg = yaml.safe_load(f)
    vm = cfg["Visualization Manager"]
    displays = []
    for d in vm["Displays"]:
        if "Topic" in d:
            continue
        if d.get("Class") == "rviz/Axes":
            d["Reference Frame"] = robot_frame
            d["Name"] = "robot (%s)" % robot_frame
        displays.append(d)
    displays += [_cloud_display("cloud %s" % t, t, _colour(CLOUD_COLOURS, i))
                 for i, t in enumerate(clouds)]
    displays += [_scan_display("scan %s" % t, t, _colour(SCAN_COLOURS, i), 0.04, 4)
                 for i, t in enumerate(scans)]
    displays += [_scan_display("merged %s" % t, t, _colour(MERGED_COLOURS, i), 0.09, 5)
                 for i, t in enumerate(merged)]
    vm["Displays"] = displays
    vm["Global Options"]["Fixed Frame"] = fixed_frame.lstrip("/")
    vm["Views"]["Current"]["Target Frame"] = robot_frame.lstrip("/")
    return cfg


def write_config(cfg, path=None):
    """Writes the configuration; without a path, to $ROS_HOME/laserscan_toolbox/ under a name
    made from its content (the same view reuses its file, two rviz never share one)."""
    text = yaml.safe_dump(cfg, sort_keys=False, default_flow_style=False)
    if path is None:
        import rospkg
        folder = os.path.join(rospkg.get_ros_home(), "laserscan_toolbox")
        os.makedirs(folder, exist_ok=True)
        path = os.path.join(folder, "rviz_%s.rviz" % hashlib.sha1(text.encode()).hexdigest()[:12])
    tmp = "%s.%d.tmp" % (path, os.getpid())
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)
    return path


NO_TOPICS = "none"  # roslaunch drops an empty NAME:= from its command line, so a word says it


def topic_list(values):
    """Topics from repeated options, each possibly a space- or comma-separated list;
    "none" (or an empty string) stands for no topic."""
    out = []
    for v in values or []:
        out += [t for t in v.replace(",", " ").split() if t and t.lower() != NO_TOPICS]
    return out


def add_view_arguments(p):
    """The options that say what to show (shared with rviz_shot's command line)."""
    p.add_argument("--fixed-frame", default=SIM_VIEW["fixed_frame"],
                   help="rviz's fixed frame (default %(default)s; on a robot without "
                        "odometry, e.g. a bag without tf, its base frame)")
    p.add_argument("--robot-frame", default=SIM_VIEW["robot_frame"],
                   help="frame the view follows and marks with axes (default %(default)s)")
    for opt, what in (("scans", "input LaserScan topics"), ("merged", "merged LaserScan topics"),
                      ("clouds", "PointCloud2 topics")):
        p.add_argument("--" + opt, action="append", metavar="TOPICS",
                       help="%s, space or comma separated, or the option repeated; 'none' "
                            "for none (default: %s)" % (what, " ".join(SIM_VIEW[opt])))


def view_from_args(args):
    def topics(opt):
        given = getattr(args, opt)
        return SIM_VIEW[opt] if given is None else topic_list(given)
    return {"fixed_frame": args.fixed_frame, "robot_frame": args.robot_frame,
            "scans": topics("scans"), "merged": topics("merged"), "clouds": topics("clouds")}


def rviz_command(command, config_path, fixed_frame):
    """rviz's command line with our -d and -f in place of any it had."""
    out = []
    skip = False
    for a in command:
        if skip:
            skip = False
            continue
        if a in ("-d", "--display-config", "-f", "--fixed-frame"):
            skip = True
            continue
        if a.startswith(("--display-config=", "--fixed-frame=")):
            continue
        out.append(a)
    return out[:1] + ["-d", config_path, "-f", fixed_frame.lstrip("/")] + out[1:]


def main(argv=None):
    p = argparse.ArgumentParser(
        prog="rviz_config",
        description="Write the pipeline's rviz view for a robot's fixed frame and topics. "
                    "With --exec (rviz.launch's launch-prefix), start that rviz command on it.")
    add_view_arguments(p)
    p.add_argument("--template", default=TEMPLATE, help="rviz file whose look is kept")
    p.add_argument("--output", help="file to write (default: stdout, or with --exec a file "
                                    "under $ROS_HOME/laserscan_toolbox/)")
    p.add_argument("--exec", nargs=argparse.REMAINDER, dest="command",
                   help="the rviz command to run on the written file (the rest of the line)")
    try:
        args = p.parse_args(argv)
    except SystemExit as e:
        return 2 if e.code else 0
    view = view_from_args(args)
    try:
        cfg = make_config(template=args.template, **view)
    except (OSError, ValueError, KeyError, yaml.YAMLError) as e:
        print("rviz_config: %s" % e, file=sys.stderr)
        return 2
    if args.command:
        path = write_config(cfg, args.output)
        cmd = rviz_command(args.command, path, view["fixed_frame"])
        os.execvp(cmd[0], cmd)
    if args.output:
        write_config(cfg, args.output)
    else:
        sys.stdout.write(yaml.safe_dump(cfg, sort_keys=False, default_flow_style=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
