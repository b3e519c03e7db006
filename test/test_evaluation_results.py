"""The evaluation's typed result against results.json (laserscan_toolbox.evaluation.results).

Machines read results.json: its top-level keys are the ones docs/tools.md lists, a step that did
not run is spelt {"skipped": reason} or {"error": reason} where its figures would be, and the
SLAM experiment keeps its three entries; the JSON reads back into the same typed result.
"""
import json
import os
import re
from dataclasses import replace as dataclass_replace

import numpy as np
import pytest

from laserscan_toolbox.evaluation import report
from laserscan_toolbox.evaluation.results import Check, EvaluationResult, NotRun, SlamRun, ran

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SLAM = {"/lidar_scan": {"path_rmse_m": 0.05}, "/slam_scan": {"path_rmse_m": 0.04}}
LOCALIZATION = {"/lidar_scan": {"rmse_m": 0.03}, "/slam_scan": {"rmse_m": 0.02}}


def common():
    return dict(bag="/x/scenario.bag", bag_duration_s=60.0, bag_size_bytes=1000,
                launch=["roslaunch", "pipeline.launch"], player=["rosbag", "play"],
                inputs={"/front_scan": {"count": 600}}, outputs={"/merged_scan": {"count": 599}},
                cpu={"manager (manager)": {"cpu_percent": 8.0}}, cpu_summary={"clock": "wall"},
                cpu_whole_playback_sim_clock={"manager (manager)": {"cpu_percent": 9.0}},
                playback_wall_s=61.0, unrecorded_outputs={"/diagnostics": "diagnostic_msgs/DiagnosticArray"},
                thresholds=[Check(True, "/merged_scan rate_hz: 10 >= 8"), Check(False, "pipeline cpu_percent: 8 <= 5")],
                passed=False, evaluation_wall_s=120.0)


def with_ground_truth(slam=None, octomap=None):
    return EvaluationResult(
        ground_truth=True, band=[0.0, 0.05, 1.0],
        accuracy={"/merged_scan": {"median_error": 0.01, "z_band": [0.05, 1.0]},
                  "/upside_down": NotRun("frame 'cam' is upside down")},
        glass={"/merged_scan": {"glass_beams": 20}}, self_filter={"/merged_scan": {"returns_on_robot": 0}},
        mapping={"/merged_scan": {"iou": 0.8}, "files": {"/merged_scan": "merged_scan.png"}},
        slam=slam or SlamRun(slam=SLAM, localization=LOCALIZATION, figures={"maps": "slam_maps.png"},
                             min_interval_s=0.2, seed=0, tolerance_m=0.1),
        octomap=octomap or {"runs": [{"method": "unified"}], "targets": []},
        navigation={"runs": [{"mode": "unified", "reached": True}]}, **common())


def documented_keys():
    """The keys docs/tools.md names in its paragraph on results.json's top-level keys."""
    with open(os.path.join(REPO, "docs", "tools.md")) as f:
        text = f.read()
    start = text.index("results.json's top-level keys:")
    paragraph = text[start:text.index("A step that did not run", start)]
    return set(re.findall(r"`([a-z_0-9]+)`", paragraph)) - {"ok", "check"}


def json_round_trip(result, tmp_path):
    path = str(tmp_path / "results.json")
    report.write_json(result.to_json(), path)
    with open(path) as f:
        return json.load(f)


def test_the_json_keeps_the_documented_keys(tmp_path):
    full = json_round_trip(with_ground_truth(), tmp_path)
    plain = json_round_trip(EvaluationResult(scan_plot={"topic": "/merged_scan"}, **common()), tmp_path)
    assert set(full) | set(plain) == documented_keys()
    # without ground truth none of its steps has a key, and with it there is no scan plot
    assert set(plain) - set(full) == {"scan_plot"}
    assert not {"band", "accuracy", "mapping", "slam", "octomap"} & set(plain)
    assert full["thresholds"] == [{"ok": True, "check": "/merged_scan rate_hz: 10 >= 8"},
                                  {"ok": False, "check": "pipeline cpu_percent: 8 <= 5"}]
    # the SLAM experiment: figures per topic in "slam" and "localization", the settings apart
    assert full["slam"] == SLAM and full["localization"] == LOCALIZATION
    assert full["slam_experiment"] == {"figures": {"maps": "slam_maps.png"}, "min_interval_s": 0.2,
                                       "seed": 0, "tolerance_m": 0.1}


def test_a_step_that_did_not_run_is_spelt_skipped_or_error(tmp_path):
    out = json_round_trip(with_ground_truth(slam=NotRun("rbpf-slam exited with 1", failed=True),
                                            octomap=NotRun("needs depth images")), tmp_path)
    assert out["slam_experiment"] == {"error": "rbpf-slam exited with 1"}
    assert "slam" not in out and "localization" not in out
    assert out["octomap"] == {"skipped": "needs depth images"}
    assert out["accuracy"]["/upside_down"] == {"skipped": "frame 'cam' is upside down"}
    skipped = EvaluationResult(ground_truth=True, band=[0.0, 0.05, 1.0], mapping=NotRun("none recorded"),
                               slam=NotRun("no SLAM topic"), **common())
    out = json_round_trip(skipped, tmp_path)
    assert out["mapping"] == {"skipped": "none recorded"}
    assert out["slam_experiment"] == {"skipped": "no SLAM topic"}


@pytest.mark.parametrize("result", [
    with_ground_truth(),
    with_ground_truth(slam=NotRun("rbpf-slam exited with 1", failed=True), octomap=NotRun("no depth")),
    EvaluationResult(scan_plot={"topic": "/merged_scan"}, **common()),
])
def test_results_json_reads_back_into_the_same_result(result, tmp_path):
    back = EvaluationResult.from_json(json_round_trip(result, tmp_path))
    assert back == result
    assert ran(back.octomap) == ran(result.octomap) and ran(back.slam) == ran(result.slam)


def test_figures_of_steps_that_ran_leave_out_those_that_did_not():
    r = with_ground_truth(slam=NotRun("failed", failed=True))
    assert list(r.accuracy_figures()) == ["/merged_scan"]
    assert r.slam_figures() == ({}, {})
    assert with_ground_truth().slam_figures() == (SLAM, LOCALIZATION)
    # a dict of figures is never mistaken for a NotRun, even one with a single key
    assert NotRun.from_json({"skipped_scans": 3}) is None and NotRun.from_json({"skipped": 3}) is None
    assert NotRun.from_json({"skipped": "frame 'x' is upside down", "input": True}) == NotRun("frame 'x' is upside down")
    assert not ran(None) and not ran(NotRun("x")) and ran({})


def test_an_unknown_key_in_results_json_is_named():
    with pytest.raises(TypeError, match="medians"):
        EvaluationResult.from_json(dict(EvaluationResult().to_json(), medians={}))


def test_numpy_figures_are_written_as_json_numbers(tmp_path):
    r = EvaluationResult(bag_duration_s=np.float64(6.0), cpu={"m": {"cpu_percent": np.float32(12.5)}})
    out = json_round_trip(r, tmp_path)
    assert out["bag_duration_s"] == 6.0 and out["cpu"]["m"]["cpu_percent"] == 12.5


def test_the_octomap_sweep_resumes_from_a_results_json_with_the_same_settings(tmp_path):
    """octomap_comparison --resume reads an earlier results.json back (``done_before``)."""
    from laserscan_toolbox.experiments.octomap_sweep import done_before
    runs = [{"method": "unified", "resolution_m": 0.05}, {"method": "octomap", "resolution_m": 0.05},
            {"method": "octomap", "resolution_m": 0.1}]
    octomap = {"runs": runs, "targets": []}
    result = with_ground_truth(octomap=octomap)
    report.write_json(dataclass_replace(result, bag_duration_s=20.2).to_json(), str(tmp_path / "results.json"))
    assert done_before(str(tmp_path), (0.05, 0.1), 20.0) == octomap
    assert done_before(str(tmp_path), (0.05,), 20.0) is None  # other resolutions
    assert done_before(str(tmp_path), (0.05, 0.1), 30.0) is None  # another bag length
    report.write_json(dataclass_replace(result, octomap=NotRun("no depth")).to_json(), str(tmp_path / "results.json"))
    assert done_before(str(tmp_path), (0.05, 0.1), 60.0) is None  # not run: run it again
    assert done_before(str(tmp_path / "none"), (0.05, 0.1), 60.0) is None
