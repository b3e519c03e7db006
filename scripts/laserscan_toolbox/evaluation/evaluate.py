"""The evaluate_bag tool: play a bag through the pipeline and measure what comes out.

``evaluate`` inspects the bag, plays it through the launch and records the outputs
(``playback``), computes the figures (``analysis``: rate, latency, dropped messages, CPU
and, when the bag carries the scenario's ground truth, range error and false / missed
obstacles per scan topic), runs the mapping and SLAM experiments on the recorded streams
when asked, and writes ``results.json``, the Markdown report and its plots (``report``).
The steps hand each other one typed ``EvaluationResult`` (``results``).
"""

import os
import sys
import time

import numpy as np

from . import metrics, report, self_filter_eval
from ..ros.rosrun import CLOCK_HZ, REPO, RunError, Session
from .analysis import (BASE_FRAME, THRESHOLDS, band_from_configs, check_thresholds, cpu_stats,
                       default_threshold_topics, glass_stats, ground_truth_stats, input_stats,
                       output_stats, scan_snapshot)
from .playback import (DEFAULT_LAUNCH, BagError, bag_scans, inspect_bag, run_pipeline,
                       run_pipeline_on_wall_time, save_scan_records)
from .results import Check, EvaluationResult, NotRun, ran

GROUND_TRUTH_TOPIC = "/scenario"
#: Seconds of the bag replayed on wall time for the CPU a robot pays (evaluate_bag --cpu-replay).
CPU_REPLAY_S = 10.0
#: Topics judged for returns on the robot's own parts, with and without the self filter.
SELF_FILTER_TOPICS = ("/merged_scan",)


# SLAM targets (--slam): options of laserscan_toolbox.evaluation.slam.check_targets' targets
SLAM_THRESHOLDS = [
    # (option, target key, help)
    ("max_slam_path_rmse", "max_path_rmse", "SLAM path RMSE of both streams, m"),
    ("min_slam_map_precision", "min_map_precision",
     "share of the unified scan's SLAM map cells near a true obstacle"),
    ("min_slam_3d_ratio", "min_3d_ratio",
     "3D obstacles in the unified scan's SLAM map / in the lidar-only one's"),
    ("max_localization_gap", "max_localization_gap",
     "localization RMSE of the unified scan minus the lidar-only one's, m"),
]


# ---------------------------------------------------------------- whole evaluation

def evaluate(bag, launch_file=DEFAULT_LAUNCH, launch_args=(), config_dir=None, output=None,
             rate=1.0, progress=True, thresholds=None, threshold_topics=None,
             band=None, tol=0.05, beam_window=1, max_scans=300, plots=True, workdir=None,
             rel_tol=0.03,
             log=print, map_topics=("/lidar_scan", "/slam_scan", "/merged_scan"), map_resolution=0.05,
             save_scans=False, slam=False, slam_targets=None, slam_seed=0, cpu_replay=CPU_REPLAY_S,
             octomap=None, octomap_interval=None, self_filter_replay=True):
    """Runs everything, returns the ``EvaluationResult`` and writes it to results.json (+
    report.md and plots when ``plots``).

    cpu_replay: seconds of the bag (from its start) played once more on wall time, without
    /clock, for the CPU figures (``measure_cpu``); 0: none, the CPU figures are then those
    under the simulated clock.
    slam: also run the SLAM and localization experiment (``evaluation.slam``) on the first
    two ``map_topics`` (lidar-only, unified); slam_targets: its targets (``slam.TARGETS``'
    keys) joined to the thresholds; octomap: resolutions (m) at which to compare the unified
    scan with OctoMap on the same bag (``evaluation.octomap_comparison``, results' "octomap");
    octomap_interval: seconds between two messages of a topic in OctoMap's map (default its
    ACCURACY_INTERVAL); self_filter_replay: with ground truth and configs that use the self
    filter, play the bag once more without it (``self_filter_eval``, results' "self_filter")."""
    t_start = time.time()
    thresholds = thresholds or {}
    log("inspecting %s" % bag)
    info = inspect_bag(bag)  # BagError: the caller says why
    scenario = None
    if GROUND_TRUTH_TOPIC in info["topics"]:
        from ..simulation.scenario import Scenario
        scenario = Scenario.from_bag(bag)
    args = list(launch_args)
    if config_dir:
        args.append("config_dir:=%s" % os.path.abspath(config_dir))
    window = min(cpu_replay, info["end"] - info["start"]) if cpu_replay > 0 else None
    configs = config_dir or os.path.join(REPO, "config", "sim_robot")
    padding = None
    if scenario is not None and os.path.isfile(os.path.join(configs, self_filter_eval.PADDING_CONFIG)):
        padding = self_filter_eval.config_padding(configs)
    unfiltered = None
    label = os.path.splitext(os.path.basename(bag))[0]
    with Session(workdir=workdir) as session:
        try:
            run = run_pipeline(session, info, launch_file, args, rate=rate, progress=progress,
                               label=label, cpu_window=window)
            if run.get("player_unconnected"):
                log("the playback began before these subscribers had connected; the first inputs "
                    "of their topics may never have reached them (lost by the playback, not "
                    "dropped by the pipeline): %s" % run["player_unconnected"])
            wall = None
            if window:
                log("replaying the bag's first %.1f s on wall time (no /clock) for the CPU a "
                    "robot pays" % window)
                wall = run_pipeline_on_wall_time(
                    session, info, launch_file, args, duration=window, label=label + "_wall",
                    topics={t: d["type"] for t, d in run["records"].items()})
            if self_filter_replay and padding is not None:
                log("replaying the bag without the self filter (returns on the robot's own parts)")
                plain = self_filter_eval.unfiltered_config_dir(
                    configs, os.path.join(session.workdir, "config_without_self_filter"))
                # A launch loads its YAMLs onto the same master, which still holds the first
                # launch's self_filter blocks: without this the nodes would read them again.
                self_filter_eval.delete_self_filter_params(session.master.master)
                unfiltered = run_pipeline(
                    session, info, launch_file,
                    [a for a in args if not a.startswith("config_dir:=")] + ["config_dir:=" + plain],
                    rate=rate, progress=progress, label=label + "_without_self_filter",
                    select=lambda topic, _type: topic in SELF_FILTER_TOPICS)
        except RunError as e:
            session.keep = True  # the logs say why (a node that died, a bad config)
            raise RunError("%s\n(logs kept in %s)" % (e, session.workdir))
    cpu, cpu_summary = measure_cpu(run, wall, rate)
    results = EvaluationResult(
        bag=info["path"], bag_duration_s=info["end"] - info["start"], bag_size_bytes=info["size"],
        launch=run["launch"], player=run["player"], ground_truth=scenario is not None,
        inputs=input_stats(info), outputs=output_stats(run, info), cpu=cpu,
        cpu_summary=cpu_summary, cpu_whole_playback_sim_clock=run["cpu"],
        playback_wall_s=run["wall"],
        unrecorded_outputs={t: ty for t, ty in run["outputs"].items() if t not in run["records"]})
    examples = {}
    if scenario is not None:
        if band is None:
            band = band_from_configs(config_dir or os.path.join(REPO, "config", "sim_robot"))
        band = band or (0.0, 0.05, 1.0)
        results.band = list(band)
        results.accuracy, examples = ground_truth_stats(
            run, info, scenario, band, tol=tol, beam_window=beam_window, max_scans=max_scans,
            rel_tol=rel_tol)
        # the sources that come straight from the bag (lidars), judged the same way
        inputs = [t for t, v in info["topics"].items()
                  if v["type"] == "sensor_msgs/LaserScan" and t not in run["records"]]
        if inputs:
            acc_in, _ = ground_truth_stats({"records": bag_scans(bag, inputs)}, info, scenario,
                                           band, tol=tol, beam_window=beam_window,
                                           max_scans=max_scans, rel_tol=rel_tol)
            for t, a in acc_in.items():
                if ran(a):
                    a["input"] = True
                results.accuracy[t] = a
        results.glass = glass_stats(run, info, scenario, band, max_scans=max_scans)
        if padding is not None:
            def scans_of(r):
                return {t: [s for s in r["records"].get(t, {}).get("scans", [])
                            if info["start"] <= s["stamp"] <= info["end"]] for t in SELF_FILTER_TOPICS
                        if r["records"].get(t, {}).get("scans")}
            results.self_filter = self_filter_eval.self_filter_stats(
                scans_of(run), scans_of(unfiltered) if unfiltered else {}, scenario, padding, band,
                tol=tol, rel_tol=rel_tol)
        refs = None
        if output and map_topics:
            results.mapping, refs = run_mapping(run, info, scenario, results, map_topics,
                                                os.path.join(output, "maps"), log=log)
        if slam and refs is not None:
            results.slam = run_slam(run, info, scenario, refs, map_topics, output, seed=slam_seed,
                                    log=log)
        if octomap and refs is not None:
            from . import octomap_comparison
            results.octomap = octomap_comparison.compare(
                bag, info, scenario, results, refs, run, os.path.join(output, "octomap"),
                resolutions=octomap, log=log,
                **({"accuracy_interval": octomap_interval} if octomap_interval else {}))
    elif output and plots:
        run["snapshot"] = scan_snapshot(bag, info, run)
        if run["snapshot"]:
            results.scan_plot = {
                "topic": run["snapshot"]["topic"], "stamp": run["snapshot"]["stamp"],
                "frame": run["snapshot"]["frame"],
                "scans": {t: {"frame": v["frame"], "input": v["input"],
                              "mounted": v["mount"] is not None,
                              "returns": int(np.count_nonzero(metrics.is_return(v["ranges"])))}
                          for t, v in run["snapshot"]["scans"].items()}}
    topics = threshold_topics or default_threshold_topics(results)
    checks = check_thresholds(results, thresholds, topics)
    if slam_targets:
        from . import slam as slam_module
        checks += slam_module.check_targets(results.slam, slam_targets, *(map_topics or ())[:2])
    results.thresholds = [Check(ok, text) for ok, text in checks]
    results.passed = all(ok for ok, _ in checks)
    results.evaluation_wall_s = time.time() - t_start
    if output:
        os.makedirs(output, exist_ok=True)
        report.write_json(results.to_json(), os.path.join(output, "results.json"))
        if save_scans:
            save_scan_records(run, os.path.join(output, "scans.npz"))
        if plots:
            report.write_report(results, examples, run, output)
    return results


def measure_cpu(run, wall, rate):
    """CPU per process and summary (``analysis.cpu_stats``) from the simulated-time run and the
    wall-time replay (None: not replayed). A replay in which no recorded output published
    anything (a launch that forces use_sim_time, say) is not what a robot pays: its figures are
    left out and the summary says why."""
    sim = run.get("cpu_window", run["cpu"])
    problem = None
    if wall is not None:
        produced = any(d["stamp"] for d in run["records"].values())
        if produced and not any(d["stamp"] for d in wall["records"].values()):
            problem = ("no output on wall time (does the launch set /use_sim_time true "
                       "whatever its arguments?): CPU under the simulated clock instead")
            wall = None
    per, summary = cpu_stats(sim, wall["cpu"] if wall else None, rate)
    summary.update(window_s=run.get("cpu_window_s"), rate=rate, clock_hz=CLOCK_HZ,
                   wall_replay_problem=problem)
    if wall is not None:
        summary.update(wall_replay_player=wall["player"], wall_replay_data_s=wall["data_s"],
                       wall_replay_stamp_offset_s=wall["stamp_offset_s"],
                       wall_replay_outputs={t: len(d["stamp"]) for t, d in wall["records"].items()})
    return per, summary


def run_mapping(run, info, scenario, results, map_topics, outdir, resolution=0.05,
                min_dt=0.2, log=print):
    """The mapping experiment on the recorded scans (true poses, ground-truth grid)."""
    from . import mapping
    streams = {}
    for t in map_topics:
        scans = run["records"].get(t, {}).get("scans")
        if scans:
            streams["%s" % t] = [s for s in scans if info["start"] <= s["stamp"] <= info["end"]]
    if not streams:
        return NotRun("none of %s was recorded" % ", ".join(map_topics)), None
    log("mapping experiment on %s" % ", ".join(streams))
    floor, zlo, zhi = results.band
    plane = None
    for a in results.accuracy_figures().values():
        if a.get("frame", BASE_FRAME) != BASE_FRAME and "z_band" in a:
            plane = tuple(a["z_band"])
            break
    # Reference: ideal scans in the robot's band along the path, at the fused stream's
    # stamps, over the directions the 3D sensors look (the camera scans' angular spans in
    # base_link): what perfect cameras would have put in the map.
    last_topic = list(streams)[-1]
    spans = []
    for t, d in run["records"].items():
        sc0 = d["scans"][0] if d.get("scans") else None
        if sc0 and sc0["frame"].lstrip("/") == BASE_FRAME and t not in map_topics \
                and t not in ("/merged_scan", "/slam_scan", "/lidar_scan"):
            spans.append((sc0["angle_min"], sc0["angle_max"]))
    ideal, ideal_view, last = [], [], -1e18
    for s in streams[last_topic]:
        if s["stamp"] - last < min_dt:
            continue
        last = s["stamp"]
        r = np.asarray(scenario.ideal_scan(
            s["stamp"], s["angle_min"], s["angle_max"], s["angle_increment"], s["range_min"],
            s["range_max"], zlo, zhi, pose=scenario.true_pose(s["stamp"])), float)
        ideal.append(dict(s, ranges=r))
        if spans:
            view = np.zeros(r.size, bool)
            for lo, hi in spans:
                view |= metrics.angular_mask(r.size, s["angle_min"], s["angle_increment"], lo, hi)
            ideal_view.append(dict(s, ranges=np.where(view, r, np.inf)))
    ts = np.arange(info["start"], info["end"], 0.1)
    traj = np.array([scenario.true_pose(t)[:2] for t in ts])
    fig, refs = mapping.mapping_experiment(streams, scenario, outdir, resolution=resolution,
                                           band=(zlo, zhi), plane_band=plane, trajectory=traj,
                                           ideal_scans=ideal, ideal_scans_3d=ideal_view or None,
                                           return_grids=True)
    fig["plane_band"] = plane
    fig["band"] = (zlo, zhi)
    fig["reference_spans"] = spans
    return fig, refs


def run_slam(run, info, scenario, refs, map_topics, output, seed=0, log=print):
    """The SLAM and localization experiment on the recorded streams: a ``SlamRun``, or
    ``NotRun`` (skipped, or failed: the reason is logged)."""
    from . import slam
    scans = {t: [s for s in run["records"].get(t, {}).get("scans", [])
                 if info["start"] <= s["stamp"] <= info["end"]] for t in map_topics[:2]}
    try:
        res = slam.slam_experiment(scans, info["path"], scenario, refs, output,
                                   topics=tuple(map_topics[:2]), seed=seed, log=log)
    except slam.SlamError as e:
        log("SLAM experiment failed: %s" % e)
        return NotRun(str(e), failed=True)
    return res


def main(argv=None):
    import argparse
    p = argparse.ArgumentParser(
        prog="evaluate_bag",
        description="Play BAG through the laser-scan pipeline (private roscore, use_sim_time, "
                    "rosbag play --clock) and report rate, latency, CPU, dropped messages and, "
                    "when the bag carries the scenario's ground truth, range error and "
                    "false / missed obstacles per scan topic. Exit status: 0 all thresholds "
                    "met, 1 a threshold not met, 2 usage error, missing file or unusable bag, 3 the "
                    "pipeline could not be run.")
    p.add_argument("bag")
    p.add_argument("--launch", default=DEFAULT_LAUNCH,
                   help="launch file of the pipeline (default: launch/pipeline.launch)")
    p.add_argument("--config", metavar="DIR",
                   help="configuration folder, passed to the launch as config_dir:=DIR")
    p.add_argument("--arg", action="append", default=[], metavar="NAME:=VALUE",
                   help="extra roslaunch argument (repeatable)")
    p.add_argument("--output", metavar="DIR", help="write report.md, results.json, plots here")
    p.add_argument("--rate", type=float, default=1.0, help="playback rate factor (default 1)")
    p.add_argument("--topic", action="append", dest="threshold_topics", metavar="TOPIC",
                   help="topics the thresholds apply to (default /merged_scan if published, "
                        "else every scan)")
    p.add_argument("--band", type=float, nargs=3, metavar=("FLOOR", "ZMIN", "ZMAX"),
                   help="obstacle band for the ideal scan: floor z in base_link and band "
                        "above the floor, m (default: from the converter YAML)")
    p.add_argument("--tolerance", type=float, default=0.05,
                   help="range tolerance for false/missed obstacles, m (default 0.05) ...")
    p.add_argument("--relative-tolerance", type=float, default=0.03,
                   help="... plus this fraction of the range (default 0.03)")
    p.add_argument("--beam-window", type=int, default=1,
                   help="beams either side searched when matching ranges (default 1)")
    p.add_argument("--max-scans", type=int, default=300,
                   help="scans per topic compared with ground truth (evenly spaced)")
    p.add_argument("--map-topics", nargs="*", default=["/lidar_scan", "/slam_scan", "/merged_scan"],
                   metavar="TOPIC", help="scan topics mapped at the true poses when the bag has "
                   "ground truth (default: /lidar_scan /slam_scan /merged_scan; none to skip)")
    p.add_argument("--slam", action="store_true",
                   help="also run real 2D SLAM (MRPT rbpf-slam) and localization "
                   "(pf-localization on the ground-truth map) on the first two --map-topics "
                   "(lidar-only, unified): docs/slam.md")
    p.add_argument("--slam-seed", type=int, default=0, help="rbpf-slam's random seed")
    for opt, _, hlp in SLAM_THRESHOLDS:
        p.add_argument("--" + opt.replace("_", "-"), type=float, help="threshold (--slam): " + hlp)
    p.add_argument("--octomap", type=float, nargs="*", metavar="RESOLUTION",
                   help="also compare the unified scan with OctoMap (bag_to_octomap) on the same "
                   "bag at these resolutions, m (default 0.05): docs/octomap.md")
    p.add_argument("--octomap-interval", type=float, metavar="S",
                   help="with --octomap: one message per topic per S seconds in OctoMap's map "
                   "(default 1; its CPU is measured on every message)")
    p.add_argument("--no-self-filter-replay", action="store_true",
                   help="do not play the bag once more without the self filter (results' "
                   "self_filter then has no returns_on_robot_unfiltered)")
    p.add_argument("--save-scans", action="store_true",
                   help="also write every recorded scan to OUTPUT/scans.npz")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--no-plots", action="store_true")
    for opt, _, _, _, hlp in THRESHOLDS:
        p.add_argument("--" + opt.replace("_", "-"), type=float, help="threshold: " + hlp)
    p.add_argument("--max-cpu", type=float,
                   help="threshold: CPU of all launched processes, percent of one core (on wall "
                        "time, see --cpu-replay)")
    p.add_argument("--cpu-replay", type=float, default=CPU_REPLAY_S, metavar="S",
                   help="replay the bag's first S seconds once more on wall time (no /clock, "
                        "use_sim_time false, stamps moved to now) for the CPU a robot pays "
                        "(default %g; 0: none, CPU then under rosbag's %d Hz /clock, which "
                        "every ROS process pays)" % (CPU_REPLAY_S, CLOCK_HZ))
    try:
        a = p.parse_args(argv)
    except SystemExit as e:
        return 2 if e.code else 0
    if not os.path.isfile(a.bag):
        print("evaluate_bag: %s: no such bag" % a.bag, file=sys.stderr)
        return 2
    if a.save_scans and not a.output:
        print("evaluate_bag: --save-scans needs --output", file=sys.stderr)
        return 2
    if not os.path.isfile(a.launch):
        print("evaluate_bag: %s: no such launch file" % a.launch, file=sys.stderr)
        return 2
    if a.config and not os.path.isdir(a.config):
        print("evaluate_bag: %s: no such folder" % a.config, file=sys.stderr)
        return 2
    if a.cpu_replay < 0:
        print("evaluate_bag: --cpu-replay must be >= 0", file=sys.stderr)
        return 2
    if a.slam and not a.output:
        print("evaluate_bag: --slam needs --output", file=sys.stderr)
        return 2
    if a.octomap is not None and (not a.output or any(r <= 0 for r in a.octomap)
                                  or (a.octomap_interval is not None and a.octomap_interval <= 0)):
        print("evaluate_bag: --octomap needs --output, resolutions > 0 and an interval > 0",
              file=sys.stderr)
        return 2
    thresholds = {opt: getattr(a, opt) for opt, *_ in THRESHOLDS}
    slam_targets = {key: getattr(a, opt) for opt, key, _ in SLAM_THRESHOLDS
                    if getattr(a, opt) is not None}
    thresholds["max_cpu"] = a.max_cpu
    try:
        res = evaluate(a.bag, a.launch, a.arg, a.config, a.output, a.rate, not a.no_progress,
                       thresholds, a.threshold_topics, a.band, a.tolerance, a.beam_window,
                       a.max_scans, plots=not a.no_plots,
                       log=lambda m: print(m, file=sys.stderr), map_topics=a.map_topics,
                       save_scans=a.save_scans, rel_tol=a.relative_tolerance, slam=a.slam,
                       slam_targets=slam_targets if a.slam else None, slam_seed=a.slam_seed,
                       cpu_replay=a.cpu_replay,
                       octomap=(a.octomap or [0.05]) if a.octomap is not None else None,
                       octomap_interval=a.octomap_interval,
                       self_filter_replay=not a.no_self_filter_replay)
    except BagError as e:
        print("evaluate_bag: %s" % e, file=sys.stderr)
        return 2
    except RunError as e:
        print("evaluate_bag: %s" % e, file=sys.stderr)
        return 3
    print(report.summary_text(res))
    if a.output:
        print("report: %s" % os.path.join(a.output, "report.md"))
    return 0 if res.passed else 1
