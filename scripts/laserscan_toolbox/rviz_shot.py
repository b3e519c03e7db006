"""Screenshots of rviz under a virtual X server (xvfb-run, software GL, imagemagick)."""

import os
import subprocess

import numpy as np
import yaml


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


def screenshot(config, out_png, delay=10.0, size=(960, 720), env=None, log=None):
    """Starts rviz with ``config`` on a fresh virtual display, waits ``delay`` s, saves the
    whole screen to ``out_png`` and stops rviz. Raises RuntimeError when no image came."""
    out_png = os.path.abspath(out_png)
    log = log or os.path.splitext(out_png)[0] + "_rviz.log"
    script = ('rviz -d "$1" >"$2" 2>&1 & pid=$!; sleep "$3"; '
              'import -window root "$4"; status=$?; kill $pid; wait $pid; exit $status')
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 %dx%dx24" % size, "bash", "-c", script, "rviz_shot",
           os.path.abspath(config), log, str(delay), out_png]
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


def bag_screenshot(bag, launch_file, config, out_png, start=0.0, play=6.0, launch_args=(),
                   warmup=8.0, workdir=None):
    """Plays ``play`` s of ``bag`` (from ``start`` s) through the launch while rviz shows
    ``config``, and saves a screenshot at the end (for the README and the demo)."""
    import threading
    import time
    from .evaluate import Session
    from .rosrun import BagPlayer, Launch
    err = []
    with Session(workdir=workdir) as session:
        launch = Launch(launch_file, launch_args,
                        os.path.join(session.workdir, "shot_roslaunch.log")).start()
        try:
            launch.wait_ready(session.master.master)
            th = threading.Thread(target=lambda: _shot(config, out_png, warmup + play + 1.0, err))
            th.start()
            time.sleep(warmup)
            player = BagPlayer(bag, os.path.join(session.workdir, "shot_play.log"),
                               extra=["-s", str(start), "-u", str(play)]).start()
            player.proc.wait(timeout=play + 60)
            th.join()
        finally:
            launch.stop()
    if err:
        raise err[0]
    return out_png


def _shot(config, out_png, delay, err):
    try:
        screenshot(config, out_png, delay=delay, env=dict(os.environ))
    except Exception as e:  # reported by the caller's thread
        err.append(e)
