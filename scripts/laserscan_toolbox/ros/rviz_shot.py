"""Screenshots of rviz under a virtual X server (xvfb-run, software GL, imagemagick)."""

import os
import subprocess

import numpy as np
import yaml

from .rosrun import REPO


def displays(config):
    """(class, topic, colour RGB) of every display with a topic in an .rviz file."""
    with open(config) as f:
        cfg = yaml.safe_load(f)
    out = []

    def walk(items):
        for d in items or []:
            if d.get("Class") == "rviz/Group":
                walk(d.get("Displays"))
            elif "Topic" in d:
                colour = tuple(int(c) for c in str(d.get("Color", "255; 255; 255")).split(";"))
                out.append((d["Class"], d["Topic"], colour, bool(d.get("Enabled", True))))
    walk(cfg["Visualization Manager"]["Displays"])
    return out


def screenshot(config, out_png, delay=10.0, size=(960, 720), env=None, log=None, command=None):
    """Starts rviz with ``config`` (or ``command``, e.g. a roslaunch of rviz.launch) on a fresh
    virtual display, waits ``delay`` s, saves the whole screen to ``out_png`` and stops rviz.
    Raises RuntimeError when no image came."""
    out_png = os.path.abspath(out_png)
    log = log or os.path.splitext(out_png)[0] + "_rviz.log"
    command = list(command or ["rviz", "-d", os.path.abspath(config)])
    script = ('log=$1; delay=$2; png=$3; shift 3; "$@" >"$log" 2>&1 & pid=$!; sleep "$delay"; '
              'import -window root "$png"; status=$?; kill -INT $pid; wait $pid; exit $status')
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 %dx%dx24" % size, "bash", "-c", script, "rviz_shot",
           log, str(delay), out_png] + command
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=delay + 60)
    if not os.path.isfile(out_png):
        raise RuntimeError("no screenshot (status %d): %s\n%s" % (p.returncode, p.stderr[-2000:],
                                                                  _tail(log)))
    return out_png


def _tail(path, n=20):
    try:
        with open(path, errors="replace") as f:
            return "".join(f.readlines()[-n:])
    except OSError:
        return ""


def image_stats(png, colours=()):
    """Pixel standard deviation and, per RGB colour, how many pixels are close to it."""
    import matplotlib.image as mpimg
    img = mpimg.imread(png)[..., :3]
    if img.dtype != np.uint8:
        img = (img * 255).round().astype(np.int16)
    else:
        img = img.astype(np.int16)
    stats = {"std": float(img.std()), "shape": img.shape, "counts": {}}
    for c in colours:
        d = np.abs(img - np.asarray(c, np.int16)[None, None, :]).max(axis=-1)
        stats["counts"][tuple(c)] = int((d <= 40).sum())
    return stats


def error_icons(png, column=(0, 60), min_pixels=100):
    """Rows (y) of rviz's error icons (a filled red disc) in the Displays panel at the left
    of a screenshot; "Global Status: Error" and each failing display show one. Thin red
    lines (the scan displays' own icons) are not counted."""
    import matplotlib.image as mpimg
    img = mpimg.imread(png)[..., :3]
    if img.dtype != np.uint8:
        img = (img * 255).round()
    band = img[:, column[0]:column[1]].astype(np.int16)
    per_row = ((band[..., 0] > 170) & (band[..., 1] < 90) & (band[..., 2] < 90)).sum(axis=1)
    icons = []
    y = 0
    while y < len(per_row):
        if per_row[y] == 0:
            y += 1
            continue
        end = y
        while end < len(per_row) and per_row[end] > 0:
            end += 1
        if per_row[y:end].sum() >= min_pixels and per_row[y:end].max() >= 13:
            icons.append(int(y))
        y = end
    return icons


def bag_screenshot(bag, launch_file, config, out_png, start=0.0, play=6.0, launch_args=(),
                   warmup=8.0, workdir=None, command=None):
    """Plays ``play`` s of ``bag`` (from ``start`` s) through the launch while rviz shows
    ``config`` (or runs ``command``), and saves a screenshot at the end (for the README,
    the demo and the tests)."""
    import threading
    import time
    from .rosrun import BagPlayer, Session
    err = []
    with Session(workdir=workdir) as session, session.launched(launch_file, launch_args, "shot"):
        th = threading.Thread(target=lambda: _shot(config, out_png, warmup + play + 1.0, err, command))
        th.start()
        time.sleep(warmup)
        player = BagPlayer(bag, os.path.join(session.workdir, "shot_play.log"),
                           extra=["-s", str(start), "-u", str(play)]).start()
        player.proc.wait(timeout=play + 60)
        th.join()
    if err:
        raise err[0]
    return out_png


def _shot(config, out_png, delay, err, command=None):
    try:
        screenshot(config, out_png, delay=delay, env=dict(os.environ), command=command)
    except Exception as e:  # reported by the caller's thread
        err.append(e)


RVIZ_LAUNCH = os.path.join(REPO, "launch", "rviz.launch")


def rviz_launch_command(view):
    """roslaunch of launch/rviz.launch showing ``view`` (rviz_config.view_from_args)."""
    from .rviz_config import NO_TOPICS
    return ["roslaunch", RVIZ_LAUNCH] + [
        "%s:=%s" % (k, v if isinstance(v, str) else " ".join(v) or NO_TOPICS)
        for k, v in sorted(view.items())]


def main(argv=None):
    import argparse
    import sys
    from .rviz_config import add_view_arguments, view_from_args
    p = argparse.ArgumentParser(
        prog="rviz_screenshot",
        description="Play part of a bag through a launch file and save a screenshot of "
                    "launch/rviz.launch showing the given fixed frame and topics "
                    "(virtual X server: no display needed).")
    p.add_argument("bag")
    p.add_argument("--launch", default=os.path.join(REPO, "launch", "pipeline.launch"),
                   help="the pipeline to run (default launch/pipeline.launch)")
    p.add_argument("--arg", action="append", default=[], metavar="NAME:=VALUE",
                   help="argument for that launch file")
    add_view_arguments(p)
    p.add_argument("--start", type=float, default=0.0, help="seconds into the bag to start at (default 0)")
    p.add_argument("--play", type=float, default=6.0, help="seconds of bag to play")
    p.add_argument("--output", default="rviz.png", help="PNG to write (default %(default)s)")
    try:
        args = p.parse_args(argv)
    except SystemExit as e:
        return 2 if e.code else 0
    if not os.path.isfile(args.bag):
        print("rviz_screenshot: %s: no such bag" % args.bag, file=sys.stderr)
        return 2
    if not (args.play > 0 and args.start >= 0):
        print("rviz_screenshot: --play must be > 0 and --start >= 0", file=sys.stderr)
        return 2
    try:
        bag_screenshot(args.bag, args.launch, None, args.output, start=args.start,
                       play=args.play, launch_args=args.arg,
                       command=rviz_launch_command(view_from_args(args)))
    except Exception as e:  # rviz, the launch or the bag failed: say which, no traceback
        print("rviz_screenshot: %s" % e, file=sys.stderr)
        return 1
    print(os.path.abspath(args.output))
    return 0
