"""The configuration checker and the nodes' own parameter checks must agree.

The checker keeps a Python schema so that it can run before anything is built or started;
the C++ cores (reached through their pybind11 modules) are the authority. These tests tie the
two together: same defaults, and the same verdict on each single-parameter change.
"""
import math

import pytest

from laserscan_toolbox import config_check as cc

import depth_filter_scan_converter_core as converter_core  # (built modules: source devel/setup.bash)
import multi_laserscan_merger_core as merger_core

# Keys the ROS glue reads outside the core's parameter struct (queue depth of the tf filter; the
# self_filter block, read by laserscan_common's glue: its verdicts are compared with the node's
# in depth_filter_scan_converter/test/test_startup_and_tuning.py).
CONVERTER_ROS_ONLY = {"queue_size", "self_filter"}


def same(a, b):
    if isinstance(a, float) or isinstance(b, float):
        return math.isclose(float(a), float(b), rel_tol=1e-12, abs_tol=1e-12)
    return a == b


def test_converter_schema_has_the_core_defaults():
    core = converter_core.Parameters()
    for name, key in cc.CONVERTER.items():
        if name in CONVERTER_ROS_ONLY:
            continue
        assert hasattr(core, name), "checker knows '%s', the converter core does not" % name
        assert same(key.default, getattr(core, name)), \
            "default of '%s': checker %r, core %r" % (name, key.default, getattr(core, name))


CONVERTER_CHANGES = [
    ("min_height", 1.0), ("min_height", 2.0), ("min_height", -math.inf), ("max_height", math.inf),
    ("angle_min", 3.2), ("angle_min", -3.2), ("angle_min", -7.0), ("angle_max", 7.0),
    ("angle_max", -math.pi), ("angle_increment", 0.0),
    ("angle_increment", -0.01), ("range_min", -0.1), ("range_min", 10.0), ("range_max", 0.0),
    ("range_max", math.inf), ("hole_depth", 0.0), ("hole_depth", -0.05),
    ("transform_tolerance", -1.0), ("transform_tolerance", 0.0), ("row_stride", 0),
    ("column_stride", 0), ("inf_epsilon", -1.0), ("tf_buffer_duration", 0.0),
    ("reference_frame", ""), ("reference_frame", "/base_link"), ("angle_min", math.nan), ("angle_max", math.inf),
    ("range_noise_std", 0.002), ("range_noise_std", -0.001), ("range_noise_std", math.inf),
    ("range_noise_std_per_m2", 0.001), ("range_noise_std_per_m2", -0.001), ("range_noise_std_per_m2", math.nan),
]


@pytest.mark.parametrize("name,value", CONVERTER_CHANGES)
def test_converter_verdicts_agree(name, value):
    checker_ok = not cc.check_converter({name: value})
    core = converter_core.Parameters()
    setattr(core, name, value)
    try:
        core.validate()
        core_ok = True
    except ValueError:
        core_ok = False
    assert checker_ok == core_ok, "%s = %r: checker %s, converter core %s" % (
        name, value, "accepts" if checker_ok else "rejects", "accepts" if core_ok else "rejects")


SOURCE = {"name": "front", "topic": "front/scan"}
MERGER_OUTPUT_CHANGES = [
    ("angle_min", -2 * math.pi), ("angle_min", -7.0), ("angle_max", 2 * math.pi),
    ("angle_min", -3.1416), ("angle_min", math.nan),
    ("angle_max", -math.pi), ("angle_increment", 0.0), ("range_min", -1.0), ("range_min", 40.0),
    ("range_max", math.inf), ("inf_epsilon", -1.0),
    ("output_frame", "/base_link"), ("finite_only", True),
    ("footprint", [[0.3, 0.2], [-0.3, 0.2]]), ("footprint", [[0.3, 0.2], [-0.3, 0.2], [0.0, math.nan]]),
    ("footprint", [[0.3, 0.2], [-0.3, 0.2], [0.0, -0.2]]), ("footprint", []),
]
# Several parameters changed together (finite_only's rules).
MERGER_OUTPUT_COMBINATIONS = [
    dict(use_inf=False, finite_only=True), dict(use_inf=False, finite_only=True, range_min=0.05),
    dict(use_inf=True, finite_only=True, range_min=0.05),
]
MERGER_SOURCE_CHANGES = [
    ("timeout", 0.0), ("timeout", -1.0), ("angle_min", 2.5), ("angle_min", 4.0),
    ("angle_max", -4.0), ("angle_max", 3.1416), ("angle_max", 3.14159), ("range_min", -0.5), ("range_min", 2.0), ("range_max", 0.0),
    ("topic", ""), ("name", ""), ("too_close_is_obstacle", False), ("footprint_filter", False),
    ("self_filter", False),
    ("drop_explained_within", 0.15), ("drop_explained_within", 0.0), ("drop_explained_within", -0.1),
    ("drop_explained_within", math.inf), ("drop_explained_within", math.nan),
]


def merger_core_accepts(output, sources):
    try:
        merger_core.Merger(output, sources)
        return True
    except (ValueError, merger_core.ParameterError):
        return False


@pytest.mark.parametrize("name,value", MERGER_OUTPUT_CHANGES)
def test_merger_output_verdicts_agree(name, value):
    checker_ok = not cc.check_merger({name: value, "sources": [dict(SOURCE)]})
    core_ok = merger_core_accepts({name: value}, [dict(SOURCE)])
    assert checker_ok == core_ok, "%s = %r: checker %s, merger core %s" % (
        name, value, "accepts" if checker_ok else "rejects", "accepts" if core_ok else "rejects")


# Parameters the merger core takes beside its output and sources.
MERGER_NODE_CHANGES = [("publish_rate", r) for r in (0.0, 1e-9, 1e-6, 10.0, -1.0)] + [
    ("odom_queue_size", n) for n in (0, 1, 2, 100)] + [
    ("sync_window", w) for w in (0.0, 0.01, 1.0, 1.5, -0.01, math.inf, math.nan)]
# sync_window against publish_rate: shorter than the publish period.
MERGER_NODE_COMBINATIONS = [dict(publish_rate=50.0, sync_window=0.019), dict(publish_rate=50.0, sync_window=0.02),
                            dict(publish_rate=200.0), dict(publish_rate=200.0, sync_window=0.0)]


@pytest.mark.parametrize("name,value", MERGER_NODE_CHANGES)
def test_merger_node_verdicts_agree(name, value):
    checker_ok = not cc.check_merger({name: value, "sources": [dict(SOURCE)]})
    try:
        merger_core.Merger({}, [dict(SOURCE)], **{name: value})
        core_ok = True
    except (ValueError, merger_core.ParameterError):
        core_ok = False
    assert checker_ok == core_ok, "%s = %r" % (name, value)


@pytest.mark.parametrize("params", MERGER_NODE_COMBINATIONS)
def test_merger_node_combinations_agree(params):
    checker_ok = not cc.check_merger(dict(params, sources=[dict(SOURCE)]))
    try:
        merger_core.Merger({}, [dict(SOURCE)], **params)
        core_ok = True
    except (ValueError, merger_core.ParameterError):
        core_ok = False
    assert checker_ok == core_ok, params


def test_merger_schema_has_the_core_default_sync_window():
    assert same(cc.MERGER["sync_window"].default, merger_core.DEFAULT_SYNC_WINDOW)


@pytest.mark.parametrize("output", MERGER_OUTPUT_COMBINATIONS)
def test_merger_output_combinations_agree(output):
    checker_ok = not cc.check_merger(dict(output, sources=[dict(SOURCE)]))
    assert checker_ok == merger_core_accepts(output, [dict(SOURCE)]), output


@pytest.mark.parametrize("name,value", MERGER_SOURCE_CHANGES)
def test_merger_source_verdicts_agree(name, value):
    source = dict(SOURCE, **{name: value})
    checker_ok = not cc.check_merger({"sources": [source]})
    core_ok = merger_core_accepts({}, [source])
    assert checker_ok == core_ok, "sources[0].%s = %r: checker %s, merger core %s" % (
        name, value, "accepts" if checker_ok else "rejects", "accepts" if core_ok else "rejects")


def test_merger_span_rule_agrees():
    output = {"angle_min": -2 * math.pi, "angle_max": 0.0}
    assert not cc.check_merger(dict(output, sources=[dict(SOURCE)]))
    assert merger_core_accepts(output, [dict(SOURCE)])
    output = {"angle_min": -2 * math.pi, "angle_max": 0.5}
    assert cc.check_merger(dict(output, sources=[dict(SOURCE)]))
    assert not merger_core_accepts(output, [dict(SOURCE)])


def test_merger_rejects_duplicate_names_like_the_checker():
    sources = [dict(SOURCE), dict(SOURCE, topic="other/scan")]
    assert cc.check_merger({"sources": sources})
    assert not merger_core_accepts({}, sources)


# ---- range_scan_converter: the checker's RANGE schema against its C++ core ----
import depth_filter_scan_converter_range_core as range_core

RANGE_ROS_ONLY = {"queue_size"}


def test_range_schema_has_the_core_defaults():
    core = range_core.RangeScanParameters()
    for name, key in cc.RANGE.items():
        if name in RANGE_ROS_ONLY:
            continue
        assert hasattr(core, name), "checker knows '%s', the range core does not" % name
        assert same(key.default, getattr(core, name)), \
            "default of '%s': checker %r, core %r" % (name, key.default, getattr(core, name))


RANGE_CHANGES = [
    ("arc_width_scale", 0.0), ("arc_width_scale", -1.0), ("arc_width_scale", 3.0), ("arc_width_scale", 4.5),
    ("arc_width_scale", math.inf), ("arc_width_scale", math.nan), ("arc_width", -0.1), ("arc_width", 0.0),
    ("arc_width", 2 * math.pi), ("arc_width", 6.3), ("arc_width", math.inf), ("angle_increment", 0.0),
    ("angle_increment", 1e-5), ("angle_increment", 1e-4), ("angle_increment", -0.01),
    ("min_consecutive_readings", 0), ("min_consecutive_readings", 5),
]


def range_core_accepts(name, value):
    core = range_core.RangeScanParameters()
    setattr(core, name, value)
    try:
        core.validate()
    except ValueError:
        return False
    return True


@pytest.mark.parametrize("name,value", RANGE_CHANGES)
def test_range_verdicts_agree(name, value):
    checker_ok = not cc.check_range({name: value})
    core_ok = range_core_accepts(name, value)
    assert checker_ok == core_ok, "%s = %r: the checker %s it, the range core %s it" % (
        name, value, "accepts" if checker_ok else "rejects", "accepts" if core_ok else "rejects")


# reactive_navigator: its node's and its core's parameters (height_band, footprint and shape_3d,
# read outside the tables by the ROS glue, are compared with the node in test_unknown_parameters.py
# and test_navigation.py).
NAVIGATOR_ROS_ONLY = {"height_band", "footprint", "shape_3d"}


def navigator_structs():
    import reactive_navigator_core as navigator_core  # (built module: source devel/setup.bash)
    node = navigator_core.NodeParameters()
    node.scan_topics = ["scan"]
    return navigator_core.NavigatorParameters(), node


def test_navigator_schema_has_the_core_defaults():
    core, node = navigator_structs()
    node.scan_topics = []
    for name, key in cc.NAVIGATOR.items():
        if name in NAVIGATOR_ROS_ONLY:
            continue
        struct = core if hasattr(core, name) else node
        assert hasattr(struct, name), "checker knows '%s', the navigator does not" % name
        assert same(key.default, getattr(struct, name)), \
            "default of '%s': checker %r, core %r" % (name, key.default, getattr(struct, name))


NAVIGATOR_CHANGES = [
    ("mode", "3d"), ("mode", "2.5d"), ("mode", ""), ("scan_topics", []), ("scan_topics", ["a", "a"]),
    ("scan_topics", ["a", "b"]), ("cloud_topics", ["scan"]), ("cloud_topics", [""]), ("odom_frame", ""),
    ("robot_frame", ""), ("robot_frame", "odom"), ("robot_frame", "base_footprint"),
    ("control_rate", 0.0), ("control_rate", math.inf), ("control_rate", math.nan), ("control_rate", 1e-3),
    ("lockstep_timeout", 0.0), ("lockstep_timeout", 0.5), ("max_linear_speed", 0.0), ("max_linear_speed", -1.0),
    ("max_linear_speed", math.inf), ("max_angular_speed", 0.0), ("linear_acceleration", 0.0),
    ("goal_tolerance", 0.0), ("lookahead", math.inf), ("path_count", 2), ("path_count", 3), ("path_count", 1001),
    ("path_count", 1002), ("blocked_timeout", 0.0), ("self_padding", 0.0), ("self_padding", -0.01),
    ("self_padding", math.inf), ("obstacle_memory", 0.0), ("obstacle_memory", -1.0), ("planner_rate", 0.0),
    ("planner_resolution", 1.0), ("planner_resolution", 1.5), ("planner_resolution", 0.0),
    ("planner_memory", 0.0), ("planner_clearing_range", 0.0), ("planner_clearing_range", -1.0),
    ("planner_clearing_range", math.inf), ("planner_inflation", 0.0), ("planner_inflation", -0.1), ("planner_clearance", -0.1),
    ("planner_clearance", math.nan), ("planner_margin", 0.0), ("carrot_distance", 0.0), ("carrot_distance", 0.5),
]


@pytest.mark.parametrize("name,value", NAVIGATOR_CHANGES)
def test_navigator_verdicts_and_reasons_agree(name, value):
    problems = cc.check_navigator({"scan_topics": ["scan"], name: value})
    core, node = navigator_structs()
    setattr(core if hasattr(core, name) else node, name, value)
    reason = None
    try:
        core.validate()
        node.validate()
    except ValueError as e:
        reason = str(e)
    assert (not problems) == (reason is None), "%s = %r: the checker says %s, the navigator %s" % (
        name, value, problems, reason)
    # A limit of the table is written alike (laserscan_common's limitFault and check_value).
    if reason is not None and "must be" in reason and any(c in reason for c in "<>[]("):
        assert reason in problems, (reason, problems)
