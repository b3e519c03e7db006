"""Markdown reports and PNG plots of the evaluation (matplotlib, Agg backend)."""

import math
import os

import numpy as np


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def fmt(v, scale=1.0, digits=1):
    if v is None or (isinstance(v, float) and (math.isnan(v) or math.isinf(v))):
        return "n/a"
    return "%.*f" % (digits, v * scale)


def table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def outputs_table(results):
    rows = []
    for t, o in sorted(results["outputs"].items()):
        ins = ", ".join("%s %d/%d" % (i["topic"], i["matched"], i["inputs"]) for i in o["inputs"])
        rows.append([t, o["count"], fmt(o["rate_hz"]), fmt(o["latency_median_s"], 1000),
                     fmt(o["latency_p95_s"], 1000), fmt(o["bytes_per_s"], 1e-3),
                     "%d (%s)" % (o["dropped"], fmt(o["dropped_fraction"], 100)) if o["inputs"]
                     else "n/a", ins or "n/a", fmt(o["coverage"], 100)])
    return table(["output", "messages", "rate Hz", "latency median ms", "latency p95 ms",
                  "kB/s", "dropped (%)", "inputs matched by stamp", "coverage %"], rows)


def cpu_table(results):
    rows = [[n, fmt(c["cpu_percent"]), fmt(c["rss_mb"])]
            for n, c in sorted(results["cpu"].items())]
    total = sum(c["cpu_percent"] for c in results["cpu"].values())
    rows.append(["**all launched processes**", "**%s**" % fmt(total), ""])
    return table(["process", "CPU % of one core", "memory MB"], rows)


def accuracy_table(results):
    rows = []
    for t, a in sorted(results.get("accuracy", {}).items()):
        if "skipped" in a and isinstance(a["skipped"], str):
            rows.append([t, "skipped: " + a["skipped"]] + [""] * 7)
            continue
        rows.append([t + (" (bag input)" if a.get("input") else ""), a["scans"],
                     "%.2f..%.2f" % tuple(a["z_band"]),
                     fmt(a["median_error"], 100, 2), fmt(a["p95_error"], 100, 1),
                     fmt(a["false_rate"], 100, 2), fmt(a["missed_rate"], 100, 1),
                     fmt(a["coverage"], 100), "%d/%d" % (a["field_of_view_beams"],
                                                         a["beams_per_scan"])])
    return table(["scan", "scans", "band m", "median error cm", "p95 error cm",
                  "false obstacles %", "missed obstacles %", "coverage %", "beams in view"], rows)


def write_report(results, examples, run, outdir, title="Pipeline evaluation"):
    plots = make_plots(results, examples, run, outdir)
    lines = ["# %s" % title, "",
             "Bag `%s` (%.1f s, %.1f MB), played with `%s`; pipeline `%s`." % (
                 results["bag"], results["bag_duration_s"], results["bag_size_bytes"] / 1e6,
                 " ".join(results["player"]), " ".join(results["launch"])), "",
             "Evaluation took %.0f s of wall time." % results.get("evaluation_wall_s", 0), ""]
    lines += ["## Verdict", ""]
    if results["thresholds"]:
        for c in results["thresholds"]:
            lines.append("- %s %s" % ("PASS" if c["ok"] else "**FAIL**", c["check"]))
    else:
        lines.append("No thresholds given.")
    lines += ["", "## Outputs", "",
              "Rate from the stamps; latency = time of receipt (bag clock) minus stamp; "
              "an input is dropped when its stamp never reappears on the output.", "",
              outputs_table(results), "", "## CPU", "",
              "CPU seconds per second of bag data, in percent of one core (the measuring "
              "window, %.1f s of wall time, also holds rosbag's start delay and the last "
              "outputs)." % results["playback_wall_s"], "",
              cpu_table(results), ""]
    if results.get("accuracy"):
        lines += ["## Accuracy against the ideal scan", "",
                  "Ground truth: the scenario's ideal scan at the true pose (closest obstacle "
                  "in the band). Error on beams where both see something (nearest of +-1 "
                  "beam); false obstacle: a return with nothing in the ideal scan at or "
                  "before it (+5 cm); missed: an ideal return with nothing in the output at "
                  "or before it. Only beams that returned at least once in the run count "
                  "(the sensor's field of view); beams whose closest obstacle is glass are "
                  "judged in the glass section instead.", "", accuracy_table(results), ""]
    lines += glass_section(results)
    m = results.get("mapping")
    if m and "skipped" not in m:
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
    lines += ["## Inputs (bag)", "",
              "Age: bag time minus header stamp, i.e. how old a message already was when "
              "recorded; an output's latency includes its inputs' age.", "",
              table(["topic", "type", "messages", "rate Hz", "kB/s", "age median ms"],
                    [[t, v["type"], v["count"], fmt(v["rate_hz"]), fmt(v["bytes_per_s"], 1e-3),
                      fmt(v.get("age_median_s"), 1000)]
                     for t, v in sorted(results["inputs"].items())]), ""]
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
        for t in sorted(scan_topics):
            d = recs[t]
            lat = np.asarray(d["recv_sim"]) - np.asarray([s or np.nan for s in d["stamp"]])
            ax.plot(np.asarray(d["recv_sim"]) - min(d["recv_sim"]), lat * 1000, ".", ms=2, label=t)
        ax.set_xlabel("bag time, s")
        ax.set_ylabel("latency, ms")
        ax.set_title("Latency of each output")
        ax.legend(fontsize=6, markerscale=4)
        fig.tight_layout()
        fig.savefig(os.path.join(outdir, "latency.png"), dpi=90)
        plt.close(fig)
        files["latency"] = "latency.png"
    if results["cpu"]:
        fig, ax = plt.subplots(figsize=(6, 2.8))
        names = sorted(results["cpu"])
        ax.barh(names, [results["cpu"][n]["cpu_percent"] for n in names], color="tab:blue")
        ax.set_xlabel("CPU, % of one core")
        ax.tick_params(axis="y", labelsize=7)
        fig.tight_layout()
        fig.savefig(os.path.join(outdir, "cpu.png"), dpi=90)
        plt.close(fig)
        files["cpu"] = "cpu.png"
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


def glass_section(results):
    """Report lines on glass (walls, doors) found with and without the ultrasonic sensors."""
    g = results.get("glass")
    if not g:
        return []
    rows = [[t, v["glass_beams"], v["scans_with_glass"], fmt(v["found_rate"], 100)] for t, v in sorted(g.items())]
    sonars = [[t, fmt(a["false_rate"], 100, 1), fmt(a["median_error"], 100, 1), a["scans"]]
              for t, a in sorted(results.get("accuracy", {}).items())
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
    lines = ["bag %s: %.1f s" % (os.path.basename(res["bag"]), res["bag_duration_s"])]
    for t, o in sorted(res["outputs"].items()):
        lines.append("  %-28s %5d msgs %6s Hz  latency p95 %6s ms  dropped %s" % (
            t, o["count"], fmt(o["rate_hz"]), fmt(o["latency_p95_s"], 1000),
            o["dropped"] if o["inputs"] else "n/a"))
    total = sum(c["cpu_percent"] for c in res["cpu"].values())
    lines.append("  CPU of the pipeline: %s%% of one core (%s)" % (fmt(total), ", ".join(
        "%s %s%%" % (n, fmt(c["cpu_percent"])) for n, c in sorted(res["cpu"].items()))))
    for t, a in sorted(res.get("accuracy", {}).items()):
        if isinstance(a.get("skipped"), str):
            continue
        lines.append("  %-28s median error %s cm, p95 %s cm, false %s%%, missed %s%%" % (
            t, fmt(a["median_error"], 100, 2), fmt(a["p95_error"], 100, 1),
            fmt(a["false_rate"], 100, 2), fmt(a["missed_rate"], 100, 1)))
    for t, v in sorted(res.get("glass", {}).items()):
        lines.append("  %-28s glass found on %s%% of %d glass beams" % (t, fmt(v["found_rate"], 100), v["glass_beams"]))
    m = res.get("mapping")
    if m and "skipped" not in m:
        for n, v in m.items():
            if isinstance(v, dict) and "iou" in v:
                lines.append("  map from %-19s IoU %s, 3D obstacles found %s%%, false cells %d"
                             % (n, fmt(v["iou"], 1, 2), fmt(v["found_3d"], 100), v["false_cells"]))
    for c in res["thresholds"]:
        lines.append("  %s %s" % ("PASS" if c["ok"] else "FAIL", c["check"]))
    return "\n".join(lines)


def demo_summary(outdir, timing=""):
    """Key figures of a demo run; also links the CPU experiment from report.md."""
    import json
    with open(os.path.join(outdir, "results.json")) as f:
        res = json.load(f)
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
        report = os.path.join(outdir, "report.md")
        with open(report) as f:
            text = f.read()
        if "cpu/cpu_experiment.md" not in text:
            with open(report, "a") as f:
                f.write("\n## CPU against depth points (paper Fig. 8)\n\nSee "
                        "[cpu/cpu_experiment.md](cpu/cpu_experiment.md).\n\n"
                        "![cpu against points](cpu/cpu_vs_points.png)\n")
    report = os.path.join(outdir, "report.md")
    if os.path.isfile(os.path.join(outdir, "rviz.png")) and os.path.isfile(report):
        with open(report) as f:
            text = f.read()
        if "(rviz.png)" not in text:
            with open(report, "a") as f:
                f.write("\n## rviz\n\nconfig/rviz/pipeline.rviz while the scenario plays "
                        "(merged scan red, lidars green, cameras blue/violet).\n\n"
                        "![rviz](rviz.png)\n")
    return "\n".join(lines)


if __name__ == "__main__":
    import argparse
    p = argparse.ArgumentParser(description="Print the key figures of a demo output folder.")
    p.add_argument("--demo-summary", metavar="DIR", required=True)
    p.add_argument("--timing", default="")
    a = p.parse_args()
    print(demo_summary(a.demo_summary, a.timing))
