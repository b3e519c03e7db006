"""Markdown reports and PNG plots of the evaluation (matplotlib, Agg backend) from its
``EvaluationResult``, and figures as JSON (results.json, the experiments' files)."""

import json
import math
import os

import numpy as np

from .results import EvaluationResult, NotRun, ran


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def json_default(o):
    """JSON for what json.dump does not know: numpy scalars and arrays, sets; else str."""
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, set):
        return list(o)
    return str(o)


def write_json(data, path):
    """Figures to a JSON file (results.json and the experiments' ones)."""
    with open(path, "w") as f:
        json.dump(data, f, indent=1, default=json_default)


def fmt(v, scale=1.0, digits=1):
    if v is None or (isinstance(v, float) and (math.isnan(v) or math.isinf(v))):
        return "n/a"
    return "%.*f" % (digits, v * scale)


def table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def dropped_cell(output):
    """Dropped inputs (%), and those a merger put into a later output, where its diagnostics say."""
    if not output["inputs"]:
        return "n/a"
    cell = "%d (%s)" % (output["dropped"], fmt(output["dropped_fraction"], 100))
    if output.get("merged_later"):
        cell += "; %d merged into a later output" % output["merged_later"]
    return cell


def outputs_table(results):
    rows = []
    for t, o in sorted(results.outputs.items()):
        ins = ", ".join("%s %d/%d" % (i["topic"], i["matched"], i["inputs"]) for i in o["inputs"])
        rows.append([t, o["count"], fmt(o["rate_hz"]), fmt(o["latency_median_s"], 1000),
                     fmt(o["latency_p95_s"], 1000),
                     "%s / %s" % (fmt(o.get("delay_after_input_median_s"), 1000),
                                  fmt(o.get("delay_after_input_p95_s"), 1000)),
                     fmt(o["bytes_per_s"], 1e-3),
                     dropped_cell(o), ins or "n/a", fmt(o["coverage"], 100)])
    return table(["output", "messages", "rate Hz", "latency median ms", "latency p95 ms",
                  "delay after input median / p95 ms", "kB/s", "dropped (%)",
                  "inputs matched by stamp", "coverage %"], rows)


def stamps_ahead_note(results):
    """Markdown lines explaining negative latencies, or [] when there are none. Latency is
    receipt on the bag clock minus the stamp; below zero, either the stamps are ahead of
    the bag's clock, or a node stamps its output later than its inputs, or the receipt was
    timed with a stale /clock (measurement)."""
    outs = [(t, o) for t, o in sorted(results.outputs.items())
            if (o.get("latency_min_s") or 0) < 0]
    ahead = [(t, v["age_min_s"], v.get("age_median_s")) for t, v in
             sorted(results.inputs.items()) if (v.get("age_min_s") or 0) < 0]
    if not outs and not ahead:
        return []
    lines = ["**Negative latencies.** Latency is the time of receipt on the bag clock (the "
             "time each message was recorded, replayed by `rosbag play --clock`) minus the "
             "header stamp, and the pipeline's outputs carry their inputs' stamps. It goes "
             "below zero when a stamp is ahead of the bag's clock: a sensor or driver whose "
             "clock runs ahead of the recording machine's (no time sync between machines), "
             "a driver that stamps the end of a sweep or a predicted time, a bag whose stamps "
             "were rewritten; then every latency is short by that offset. That is not a "
             "pipeline fault. The pipeline's own delay is \"delay after input\": receipt "
             "minus the bag time at which the input with the same stamp was played, which "
             "does not depend on the stamping clock. If that is below zero too, the receipt "
             "was timed with a stale simulated clock (the recorder reads `/clock`, which "
             "`rosbag play` publishes at 200 Hz; on a busy machine it arrives late): a "
             "measurement error of that size, not data from the future.", ""]
    for t, age_min, age_median in ahead:
        lines.append("- input `%s`: stamps up to %s ms ahead of the bag time (median age "
                     "%s ms)." % (t, fmt(-age_min, 1000), fmt(age_median, 1000)))
    for t, o in outs:
        d_min = o.get("delay_after_input_min_s")
        cause = ("stamps ahead of the bag clock" if ahead else
                 "the receiving clock read stale (delay after input below zero too)"
                 if d_min is not None and d_min < 0 else
                 "output stamped later than its inputs' stamps, or inputs not in the bag")
        lines.append("- `%s`: %s %% of the messages below zero, minimum %s ms; delay after "
                     "input median %s ms, p95 %s ms, minimum %s ms; likely cause: %s." % (
                         t, fmt(o.get("negative_latency_fraction"), 100, 2),
                         fmt(o["latency_min_s"], 1000), fmt(o.get("delay_after_input_median_s"),
                                                             1000),
                         fmt(o.get("delay_after_input_p95_s"), 1000), fmt(d_min, 1000), cause))
    return lines + [""]


ROLE_LABELS = {"manager": "nodelet manager", "loader": "nodelet loader clients",
               "node": "other processes"}


def cpu_table(results):
    """Per process and per role: the CPU a robot pays (wall-time replay) beside that under
    rosbag's /clock and the difference (``analysis.cpu_stats``)."""
    cpu = results.cpu
    summary = results.cpu_summary
    wall = summary.get("clock") == "wall"
    rows = [[n, fmt(c["cpu_percent"]), fmt(c.get("sim_clock_cpu_percent")),
             fmt(c.get("clock_share_percent")), fmt(c["rss_mb"])] for n, c in sorted(cpu.items())]
    for role, label in ROLE_LABELS.items():
        n = summary.get("processes", {}).get(role)
        if n:
            members = [c for c in cpu.values() if c.get("role") == role]
            rows.append(["%s (%d)" % (label, n), fmt(summary["by_role"][role]),
                         fmt(sum(c.get("sim_clock_cpu_percent") or 0 for c in members)),
                         fmt(sum(c.get("clock_share_percent") or 0 for c in members)
                             if summary.get("clock_share_percent") is not None else None), ""])
    total = sum(c["cpu_percent"] for c in cpu.values())
    rows.append(["**all launched processes**", "**%s**" % fmt(total),
                 fmt(summary.get("sim_clock_total_percent")),
                 fmt(summary.get("clock_share_percent")), ""])
    return table(["process", "CPU %% of one core, %s" % ("on wall time (what a robot pays)" if wall
                                                      else "under the simulated clock"),
                  "under rosbag's /clock", "/clock share", "memory MB"], rows)


def cpu_section(results):
    summary = results.cpu_summary
    lines = ["## CPU", ""]
    if summary.get("clock") == "wall":
        lines.append(
            "CPU seconds per second of bag data, in percent of one core, of every process the "
            "launch started, on the bag's first %.1f s. First column: replayed on wall time as a "
            "robot runs (use_sim_time false, no /clock, every stamp moved to now: "
            "`scripts/laserscan_toolbox/ros/wall_clock_play.py`). Second: "
            "the same data in the simulated-time playback (`rosbag play --clock --hz=%d`), where "
            "every ROS process also takes /clock %d times a second; the difference is that "
            "clock's share, which a robot does not pay (a few tenths either way are run-to-run "
            "noise)." % (summary["window_s"], summary["clock_hz"], summary["clock_hz"]))
        if summary.get("clock_share_percent") is None:
            lines[-1] += (" The playback ran at rate %g, the replay at rate 1: no /clock share "
                          "is given." % summary["rate"])
    else:
        lines.append(
            "CPU seconds per second of bag data, in percent of one core (the measuring window, "
            "%.1f s of wall time, also holds rosbag's start delay and the last outputs), under "
            "rosbag's /clock: every ROS process takes it, a robot on wall time does not "
            "(evaluate_bag replays the bag on wall time for the CPU unless --cpu-replay 0%s)." % (
                results.playback_wall_s, "; here: " + summary["wall_replay_problem"]
                if summary.get("wall_replay_problem") else ""))
    return lines + ["", cpu_table(results), ""]


def accuracy_table(results):
    rows = []
    for t, a in sorted((results.accuracy or {}).items()):
        if isinstance(a, NotRun):
            rows.append([t, "skipped: " + a.reason] + [""] * 7)
            continue
        rows.append([t + (" (bag input)" if a.get("input") else ""), a["scans"],
                     "%.2f..%.2f" % tuple(a["z_band"]),
                     fmt(a["median_error"], 100, 2), fmt(a["p95_error"], 100, 1),
                     fmt(a["false_rate"], 100, 2), fmt(a["missed_rate"], 100, 1),
                     fmt(a["coverage"], 100), "%d/%d" % (a["field_of_view_beams"],
                                                         a["beams_per_scan"])])
    return table(["scan", "scans", "band m", "median error cm", "p95 error cm",
                  "false obstacles %", "missed obstacles %", "coverage %", "beams in view"], rows)


def slam_table(results):
    """SLAM and localization figures per stream, side by side (rows: figures)."""
    slam, loc = results.slam_figures()
    topics = list(slam)
    rows = []
    for label, section, key, scale, digits in (
            ("SLAM path RMSE, m", slam, "path_rmse_m", 1, 3),
            ("odometry alone, path RMSE, m", slam, "odometry_rmse_m", 1, 3),
            ("SLAM map precision (occupied cells within 0.10 m of an obstacle), %", slam,
             "map_precision", 100, 1),
            ("SLAM map recall (reference obstacle cells found), %", slam, "map_recall", 100, 1),
            ("3D obstacles found in the SLAM map, %", slam, "obstacles_3d_found", 100, 1),
            ("localization on the ground-truth map, RMSE, m", loc, "rmse_m", 1, 3),
            ("scans used", slam, "scans", 1, 0)):
        rows.append([label] + [fmt(section.get(t, {}).get(key), scale, digits) for t in topics])
    return table(["figure"] + topics, rows)


def slam_section(results):
    exp = results.slam
    if exp is None:
        return []
    lines = ["## SLAM and localization", ""]
    if isinstance(exp, NotRun):
        return lines + ["Not run: %s" % exp.reason, ""]
    lines += ["MRPT's `rbpf-slam` (Rao-Blackwellised particle filter grid SLAM, seed %d) on each "
              "stream with the wheel odometry (one scan per %.1f s at most), its path fitted to "
              "the ground truth by the rigid 2D fit of the paths, its map (the most likely "
              "particle's) by that of the particle's own path; `pf-localization` "
              "on the ground-truth obstacle grid from the true initial pose (RMSE of the "
              "weighted particle mean). Method and reproduction: docs/slam.md." % (
                  exp.seed, exp.min_interval_s), "", slam_table(results), "",
              "![SLAM maps](%s)" % exp.figures["maps"], "",
              "![paths](%s)" % exp.figures["paths"], ""]
    return lines


def octomap_table(runs):
    """Markdown table of the runs, one row per method, point count and resolution."""
    rows = []
    for r in runs:
        slam = r.get("slam")
        rows.append([r["method"], r["points_per_camera"], "%.2f" % r["resolution_m"],
                     fmt(r["cpu_s_per_s"], 1, 3), fmt(r["map_memory_mb"], 1, 3),
                     fmt(r["peak_memory_mb"], 1, 0), fmt(r["obstacles_3d_found"], 100),
                     fmt(r["map_precision"], 100), fmt(r["map_recall"], 100),
                     ("SLAM: precision %s %%, 3D %s %%, rbpf-slam %s s wall per s" % (
                         fmt(slam["map_precision"], 100), fmt(slam["obstacles_3d_found"], 100),
                         fmt(slam["wall_s_per_s"], 1, 3))) if slam else ""])
    return table(["method", "depth points per camera", "resolution m", "CPU s per s of data",
                  "map memory MB", "peak memory MB", "3D obstacles found %", "map precision %",
                  "map recall %", "unified + SLAM"], rows)


def octomap_section(res, link="octomap"):
    """The report's section on the comparison (report.md of evaluate_bag and the demo): ``res``
    is its step (figures, NotRun, or None)."""
    if not ran(res):
        return ["## The unified scan against OctoMap", "",
                "Not run: %s" % (res.reason if res else "no ground truth"), ""]
    lines = ["## The unified scan against OctoMap", "",
             "OctoMap OcTree from the bag's depth images and lidar scans at the true poses "
             "(`bag_to_octomap`), its map projected from the band %.2f-%.2f m, judged with the "
             "mapping experiment's figures; OctoMap's CPU is its process CPU time per second of "
             "data with every message of the first %.0f s, its map from one message per topic "
             "per %.1f s; the unified CPU is the pipeline manager's (under simulated time) plus "
             "the 2D grid. Method: docs/octomap.md." % (res["band_m"][0], res["band_m"][1],
                                                        res["cost_window_s"],
                                                        res["accuracy_interval_s"]), "",
             octomap_table(res["runs"]), ""]
    lines += ["- %s %s" % ("met:" if t["ok"] else "**missed:**", t["check"]) for t in res["targets"]]
    lines += ["", "![OctoMap against the unified scan](%s/%s)" % (link, res["figure"]), ""]
    return lines


def write_report(results, examples, run, outdir, title="Pipeline evaluation"):
    plots = make_plots(results, examples, run, outdir)
    lines = ["# %s" % title, "",
             "Bag `%s` (%.1f s, %.1f MB), played with `%s`; pipeline `%s`." % (
                 results.bag, results.bag_duration_s, results.bag_size_bytes / 1e6,
                 " ".join(results.player), " ".join(results.launch)), "",
             "Evaluation took %.0f s of wall time." % results.evaluation_wall_s, ""]
    lines += ["## Verdict", ""]
    if results.thresholds:
        for c in results.thresholds:
            lines.append("- %s %s" % ("PASS" if c.ok else "**FAIL**", c.check))
    else:
        lines.append("No thresholds given.")
    lines += ["", "## Outputs", "",
              "Rate from the stamps; latency = time of receipt (bag clock) minus stamp; "
              "delay after input = time of receipt minus the bag time of the input that "
              "carries the same stamp; an input is dropped when its stamp never reappears "
              "on the output, except where a merger's diagnostics count it as received and not "
              "dropped: a merger stamps each output with its newest input's time, so an input "
              "that comes after a newer one is merged into a later output under that stamp.", "",
              outputs_table(results), ""] + stamps_ahead_note(results) + cpu_section(results)
    if results.accuracy:
        lines += ["## Accuracy against the ideal scan", "",
                  "Ground truth: the scenario's ideal scan at the true pose (closest obstacle "
                  "in the band). Error on beams where both see something (nearest of +-1 "
                  "beam); false obstacle: a return with nothing in the ideal scan at or "
                  "before it (+5 cm); missed: an ideal return with nothing in the output at "
                  "or before it. Only beams that returned at least once in the run count "
                  "(the sensor's field of view); beams whose closest obstacle is glass are "
                  "judged in the glass section instead.", "", accuracy_table(results), ""]
    lines += glass_section(results)
    lines += self_filter_section(results)
    m = results.mapping
    if ran(m):
        lines += ["## Mapping at the true poses (paper Fig. 6)", "",
                  "Occupancy grids (%.2f m cells) from each scan stream at the true poses, "
                  "against the ground-truth obstacles of the band %.2f-%.2f m. IoU: occupied "
                  "cells against the map a perfect 360-degree sensor in that band would build "
                  "along the same path (a cell matches within one cell); 3D obstacles: the "
                  "cells above the lidars' plane (table tops, overhangs) that such a sensor "
                  "looking where the cameras look (their scans' angular spans) maps, found in "
                  "the map; false cells: "
                  "occupied with no obstacle within one cell in the ground truth." % (
                      0.05, m["band"][0], m["band"][1]), "",
                  table(["scan", "IoU", "IoU vs filled truth", "obstacles found %",
                         "3D obstacles found %", "false cells", "map file"],
                        [[n, fmt(v["iou"], 1, 2), fmt(v["iou_truth"], 1, 2),
                          fmt(v["found"], 100), fmt(v["found_3d"], 100), v["false_cells"],
                          "maps/" + m["files"][n]]
                         for n, v in m.items() if isinstance(v, dict) and "iou" in v]),
                  "", "![maps](maps/maps.png)", ""]
    lines += slam_section(results)
    if results.octomap is not None:
        lines += octomap_section(results.octomap)
    lines += ["## Inputs (bag)", "",
              "Age: bag time minus header stamp, i.e. how old a message already was when "
              "recorded; an output's latency includes its inputs' age.", "",
              table(["topic", "type", "messages", "rate Hz", "kB/s", "age median ms"],
                    [[t, v["type"], v["count"], fmt(v["rate_hz"]), fmt(v["bytes_per_s"], 1e-3),
                      fmt(v.get("age_median_s"), 1000)]
                     for t, v in sorted(results.inputs.items())]), ""]
    if plots:
        lines += ["## Plots", ""] + ["![%s](%s)" % (k, v) for k, v in plots.items()] + [""]
    with open(os.path.join(outdir, "report.md"), "w") as f:
        f.write("\n".join(lines))


def make_plots(results, examples, run, outdir):
    plt = _plt()
    files = {}
    recs = run["records"]
    scan_topics = [t for t, d in recs.items() if d["type"] == "sensor_msgs/LaserScan" and d["stamp"]]
    if scan_topics:
        fig, ax = plt.subplots(figsize=(7, 3.5))
        shown = []
        for t in sorted(scan_topics):
            d = recs[t]
            lat = np.asarray(d["recv_sim"], float) - np.asarray(
                [np.nan if s is None else s for s in d["stamp"]], float)
            ax.plot(np.asarray(d["recv_sim"]) - min(d["recv_sim"]), lat * 1000, ".", ms=2, label=t)
            shown.append(lat[np.isfinite(lat)] * 1000)
        shown = np.concatenate(shown) if shown else np.zeros(0)
        title = "Latency of each output"
        if shown.size:
            # a few extreme stamps (e.g. unset or far-off clocks) must not flatten the rest
            lo, hi = np.percentile(shown, [1, 99])
            pad = max(0.1 * (hi - lo), 1.0)
            ax.set_ylim(lo - pad, hi + pad)
            outside = int(np.count_nonzero((shown < lo - pad) | (shown > hi + pad)))
            if outside:
                title += " (%d beyond the axis: min %.4g, max %.4g ms)" % (
                    outside, shown.min(), shown.max())
        ax.set_xlabel("bag time, s")
        ax.set_ylabel("latency, ms")
        ax.set_title(title, fontsize=9)
        ax.legend(fontsize=6, markerscale=4)
        fig.tight_layout()
        fig.savefig(os.path.join(outdir, "latency.png"), dpi=90)
        plt.close(fig)
        files["latency"] = "latency.png"
    if results.cpu:
        fig, ax = plt.subplots(figsize=(6, 2.8))
        names = sorted(results.cpu)
        y = np.arange(len(names))
        sim = [results.cpu[n].get("sim_clock_cpu_percent") for n in names]
        if results.cpu_summary.get("clock") == "wall" and None not in sim:
            ax.barh(y + 0.2, sim, height=0.4, color="tab:gray", label="under rosbag's /clock")
            ax.barh(y - 0.2, [results.cpu[n]["cpu_percent"] for n in names], height=0.4,
                    color="tab:blue", label="on wall time (a robot)")
            ax.legend(fontsize=6)
        else:
            ax.barh(y, [results.cpu[n]["cpu_percent"] for n in names], color="tab:blue")
        ax.set_yticks(y)
        ax.set_yticklabels(names)
        ax.set_xlabel("CPU, % of one core")
        ax.tick_params(axis="y", labelsize=7)
        fig.tight_layout()
        fig.savefig(os.path.join(outdir, "cpu.png"), dpi=90)
        plt.close(fig)
        files["cpu"] = "cpu.png"
    if run.get("snapshot"):
        plot_snapshot(run["snapshot"], os.path.join(outdir, "scans.png"))
        files["inputs and outputs at one moment"] = "scans.png"
    if examples:
        n = len(examples)
        fig, axes = plt.subplots(1, n, figsize=(3.3 * n, 3.5), squeeze=False)
        for ax, (t, e) in zip(axes[0], sorted(examples.items())):
            for key, style, lab in (("ideal", "k.", "ideal"), ("ranges", "r.", "output")):
                r = np.asarray(e[key], float)
                a = e["angle_min"] + e["angle_increment"] * np.arange(r.size)
                ok = np.isfinite(r) & (r > 0)
                ax.plot(r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok]), style,
                        ms=1.5 if key == "ideal" else 1.0, label=lab)
            ax.plot(0, 0, "b^")
            ax.set_aspect("equal")
            ax.set_title("%s\nt=%.1f s (%s)" % (t, e["stamp"], e["frame"]), fontsize=7)
            ax.tick_params(labelsize=6)
            lim = 6
            ax.set_xlim(-lim, lim)
            ax.set_ylim(-lim, lim)
        axes[0][0].legend(fontsize=6, markerscale=4)
        fig.tight_layout()
        fig.savefig(os.path.join(outdir, "scans.png"), dpi=90)
        plt.close(fig)
        files["example scans against the ideal scan"] = "scans.png"
    return files


def _scan_points(scan):
    """x, y (m) of a scan's returns in the snapshot's reference frame."""
    r = np.asarray(scan["ranges"], float)
    a = scan["angle_min"] + scan["angle_increment"] * np.arange(r.size)
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(r) & (r >= scan["range_min"]) & (r <= scan["range_max"]) & (r > 0)
    pts = np.stack([r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok]), np.zeros(ok.sum()),
                    np.ones(ok.sum())])
    if scan.get("mount") is not None:
        pts = np.asarray(scan["mount"], float) @ pts
    return pts[0], pts[1]


def plot_snapshot(snapshot, path):
    """Top-down plots of a bag without ground truth at one moment, side by side on the same
    axes: the inputs (each in its colour, moved into the reference scan's frame by their
    mounts), and the outputs. A scan whose mount is unknown gets a panel of its own, in
    its own frame."""
    plt = _plt()
    scans = snapshot["scans"]
    placed = [t for t in sorted(scans) if scans[t].get("mount") is not None]
    panels = [("inputs", snapshot["frame"], [t for t in placed if scans[t]["input"]]),
              ("outputs", snapshot["frame"], [t for t in placed if not scans[t]["input"]])]
    panels = [p for p in panels if p[2]]
    panels += [("no mount to %s" % snapshot["frame"], scans[t]["frame"], [t])
               for t in sorted(scans) if scans[t].get("mount") is None]
    points = {t: _scan_points(scans[t]) for t in scans}
    xy = [np.abs(np.concatenate(points[t])) for t in placed if points[t][0].size]
    lim = min(max(2.0, float(np.percentile(np.concatenate(xy), 99)) if xy else 2.0) * 1.05, 40.0)
    fig, axes = plt.subplots(1, len(panels), figsize=(4.6 * len(panels), 4.9), squeeze=False)
    colours = plt.get_cmap("tab10").colors
    for ax, (title, frame, topics) in zip(axes[0], panels):
        for t in topics:
            s = scans[t]
            x, y = points[t]
            ax.plot(x, y, ".", ms=1.5, color=colours[sorted(scans).index(t) % len(colours)],
                    label="%s (%s%s, %+.0f ms)" % (
                        t, "input" if s["input"] else "output",
                        "" if s["frame"] == frame else " from " + s["frame"],
                        1000 * (s["stamp"] - snapshot["stamp"])))
        ax.plot(0, 0, "k^", ms=6)
        ax.set_aspect("equal")
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_title(title, fontsize=8)
        ax.set_xlabel("x in %s, m" % frame, fontsize=7)
        ax.set_ylabel("y in %s, m" % frame, fontsize=7)
        ax.tick_params(labelsize=6)
        ax.legend(fontsize=6, markerscale=4, loc="upper right")
    fig.suptitle("scans near stamp %.3f s (%s), in %s" % (snapshot["stamp"], snapshot["topic"],
                                                           snapshot["frame"]), fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def self_filter_section(results):
    """Report lines on returns on the robot's own parts (the arm), with and without the filter."""
    sf = results.self_filter
    if not sf:
        return []
    rows = [[t, v["returns_on_robot"], "n/a" if v["returns_on_robot_unfiltered"] is None
             else v["returns_on_robot_unfiltered"], v["near_robot_obstacles"],
             fmt(v["kept_near_robot_percent"])] for t, v in sorted(sf.items())]
    padding = next(iter(sf.values()))["padding_m"]
    return ["## Self filter (the robot's arm)", "",
            "Returns inside the simulated arm's boxes padded by %.2f m (seen from above, where the "
            "scenario puts the arm at each scan's stamp), summed over the run: with the self filter, "
            "and from a second playback of the bag with every config's `self_filter` block removed. "
            "Obstacles near it: returns without the filter within %.2f m outside the padded boxes "
            "that the ideal scan confirms as the world's; kept: the filtered scan of the same "
            "stamp reads them." % (padding, next(iter(sf.values()))["near_m"]), "",
            table(["scan", "returns on the robot", "without the filter", "obstacles near it",
                   "kept %"], rows), ""]


def glass_section(results):
    """Report lines on glass (walls, doors) found with and without the ultrasonic sensors."""
    g = results.glass
    if not g:
        return []
    rows = [[t, v["glass_beams"], v["scans_with_glass"], fmt(v["found_rate"], 100)] for t, v in sorted(g.items())]
    sonars = [[t, fmt(a["false_rate"], 100, 1), fmt(a["median_error"], 100, 1), a["scans"]]
              for t, a in sorted(results.accuracy_figures().items())
              if "sonar" in t and "false_rate" in a]
    lines = ["## Glass (ultrasonic sensors)", "",
             "Beams of the robot's band whose closest obstacle is a glass pane within %.1f m: lidars and "
             "depth cameras see through it, the ultrasonic sensors hear it. Found: the scan has an "
             "obstacle at or before the pane (+5 cm + 3 %%). /merged_scan takes the four sonar arcs, "
             "/lidar_scan and the camera scans do not." % next(iter(g.values()))["reach"], "",
             table(["scan", "glass beams", "scans with glass", "found %"], rows), ""]
    if sonars:
        lines += ["Each sonar's arc against the ideal scan at the sensor (its height): the cone widening "
                  "shows as false obstacles (the whole cone is marked at the closest echo's range).", "",
                  table(["sonar arc", "false obstacles %", "median error cm", "scans"], sonars), ""]
    return lines


def summary_text(res):
    """The figures evaluate_bag prints, of an ``EvaluationResult``."""
    lines = ["bag %s: %.1f s" % (os.path.basename(res.bag), res.bag_duration_s)]
    for t, o in sorted(res.outputs.items()):
        lines.append("  %-28s %5d msgs %6s Hz  latency p95 %6s ms  dropped %s" % (
            t, o["count"], fmt(o["rate_hz"]), fmt(o["latency_p95_s"], 1000),
            ("%d%s" % (o["dropped"], " (%d merged later)" % o["merged_later"] if o.get("merged_later") else ""))
            if o["inputs"] else "n/a"))
    if stamps_ahead_note(res):
        lines.append("  negative latencies: stamps ahead of the bag clock (see the report); "
                     "the pipeline's own delay is 'delay after input'")
    lines += cpu_summary_lines(res)
    for t, a in sorted(res.accuracy_figures().items()):
        lines.append("  %-28s median error %s cm, p95 %s cm, false %s%%, missed %s%%" % (
            t, fmt(a["median_error"], 100, 2), fmt(a["p95_error"], 100, 1),
            fmt(a["false_rate"], 100, 2), fmt(a["missed_rate"], 100, 1)))
    for t, v in sorted((res.self_filter or {}).items()):
        lines.append("  %-28s returns on the robot's arm %d (without the self filter %s), "
                     "obstacles near it kept %s%% of %d" % (
                         t, v["returns_on_robot"], "n/a" if v["returns_on_robot_unfiltered"] is None
                         else v["returns_on_robot_unfiltered"], fmt(v["kept_near_robot_percent"]),
                         v["near_robot_obstacles"]))
    for t, v in sorted((res.glass or {}).items()):
        lines.append("  %-28s glass found on %s%% of %d glass beams" % (t, fmt(v["found_rate"], 100), v["glass_beams"]))
    m = res.mapping
    if ran(m):
        for n, v in m.items():
            if isinstance(v, dict) and "iou" in v:
                lines.append("  map from %-19s IoU %s, 3D obstacles found %s%%, false cells %d"
                             % (n, fmt(v["iou"], 1, 2), fmt(v["found_3d"], 100), v["false_cells"]))
    slam, localization = res.slam_figures()
    for t, v in slam.items():
        loc = localization.get(t, {})
        lines.append("  slam on %-19s path RMSE %s m (odometry %s m), map precision %s%%, "
                     "recall %s%%, 3D obstacles found %s%%; localization RMSE %s m" % (
                         t, fmt(v["path_rmse_m"], 1, 3), fmt(v["odometry_rmse_m"], 1, 3),
                         fmt(v["map_precision"], 100), fmt(v["map_recall"], 100),
                         fmt(v["obstacles_3d_found"], 100), fmt(loc.get("rmse_m"), 1, 3)))
    for r in res.octomap["runs"] if ran(res.octomap) else []:
        lines.append("  %-8s %5.2f m: CPU %s s per s of data, map %s MB, peak %s MB, 3D obstacles "
                     "found %s%%, precision %s%%" % (
                         r["method"], r["resolution_m"], fmt(r["cpu_s_per_s"], 1, 3),
                         fmt(r["map_memory_mb"], 1, 3), fmt(r["peak_memory_mb"], 1, 0),
                         fmt(r["obstacles_3d_found"], 100), fmt(r["map_precision"], 100)))
    lines += navigation_summary_lines(res.navigation)
    for c in res.thresholds:
        lines.append("  %s %s" % ("PASS" if c.ok else "FAIL", c.check))
    return "\n".join(lines)


def navigation_summary_lines(nav):
    """The closed-loop navigation run (scripts/navigation_experiment's navigation.json): each run,
    then the issue's targets met or missed (reported, as OctoMap's; its --check is the threshold)."""
    if not nav:
        return []
    lines = []
    for r in nav["runs"]:
        lines.append("  navigation %-10s %3dk: reached %s, time to goal %s s, collisions %d (3D %d), "
                     "navigator CPU %s%%, system %s%%" % (
                         r["mode"], r["points_per_camera"] // 1000, "yes" if r["reached"] else "no",
                         fmt(r["time_to_goal_s"]), r["collisions"], r["collisions_3d"],
                         fmt(r["navigator_cpu_percent"]), fmt(r["system_cpu_percent"])))
    for name, t in nav.get("targets", {}).items():
        lines.append("  navigation target %s: %s" % (name, {True: "met", False: "missed", None: "n/a"}[t["met"]]))
    return lines


def cpu_summary_lines(res):
    """The CPU lines of summary_text: total, by role and per process, on wall time when the
    bag was replayed so, and the simulated clock's share."""
    summary = res.cpu_summary
    total = sum(c["cpu_percent"] for c in res.cpu.values())
    wall = summary.get("clock") == "wall"
    roles = ", ".join("%s %s%%" % ("%d %s" % (summary["processes"][r], ROLE_LABELS[r])
                                   if r == "loader" else ROLE_LABELS[r], fmt(summary["by_role"][r]))
                      for r in ROLE_LABELS if summary.get("processes", {}).get(r))
    lines = ["  CPU of the pipeline: %s%% of one core %s (%s)" % (
        fmt(total), "on wall time, as a robot pays it" if wall else "under the simulated clock",
        ", ".join("%s %s%%" % (n, fmt(c["cpu_percent"])) for n, c in sorted(res.cpu.items())))]
    if roles:
        lines.append("    by role: " + roles)
    if wall:
        share = summary.get("clock_share_percent")
        lines.append("    the same %.1f s under rosbag's %d Hz /clock: %s%%%s" % (
            summary["window_s"], summary["clock_hz"], fmt(summary["sim_clock_total_percent"]),
            " (the /clock share, not paid on a robot: %s%%)" % fmt(share) if share is not None
            else ""))
    elif summary.get("wall_replay_problem"):
        lines.append("    " + summary["wall_replay_problem"])
    return lines


def demo_summary(outdir, timing=""):
    """Key figures of a demo run; also links the CPU experiment from report.md."""
    with open(os.path.join(outdir, "results.json")) as f:
        res = EvaluationResult.from_json(json.load(f))
    lines = ["Demo figures (%s)" % timing if timing else "Demo figures", summary_text(res)]
    cpu_json = os.path.join(outdir, "cpu", "cpu_results.json")
    if os.path.isfile(cpu_json):
        with open(cpu_json) as f:
            cpu = json.load(f)
        lines.append("  CPU against depth points per camera (manager, merged-scan consumer):")
        for r in cpu["rows"]:
            m, w = r["merged"], r["raw"]
            lines.append("    %6dk points: manager %s%%; consumer receives %s kB/s merged vs "
                         "%s MB/s raw" % (r["points_per_camera"] // 1000,
                                          fmt(m["manager_cpu_percent"]),
                                          fmt(m["bytes_per_s"], 1e-3), fmt(w["bytes_per_s"], 1e-6, 2)))
        _append_once(os.path.join(outdir, "report.md"), "cpu/cpu_experiment.md",
                     "\n## CPU against depth points (paper Fig. 8)\n\nSee "
                     "[cpu/cpu_experiment.md](cpu/cpu_experiment.md).\n\n"
                     "![cpu against points](cpu/cpu_vs_points.png)\n")
    report = os.path.join(outdir, "report.md")
    if os.path.isfile(os.path.join(outdir, "rviz.png")) and os.path.isfile(report):
        _append_once(report, "(rviz.png)",
                     "\n## rviz\n\nconfig/rviz/pipeline.rviz while the scenario plays "
                     "(merged scan red, lidars green, cameras blue/violet).\n\n"
                     "![rviz](rviz.png)\n")
    return "\n".join(lines)


def _append_once(path, marker, section):
    """Appends ``section`` to the file unless ``marker`` is in it already (a rerun)."""
    with open(path) as f:
        if marker in f.read():
            return
    with open(path, "a") as f:
        f.write(section)


if __name__ == "__main__":
    import argparse
    p = argparse.ArgumentParser(description="Print the key figures of a demo output folder.")
    p.add_argument("--demo-summary", metavar="DIR", required=True)
    p.add_argument("--timing", default="")
    a = p.parse_args()
    print(demo_summary(a.demo_summary, a.timing))
