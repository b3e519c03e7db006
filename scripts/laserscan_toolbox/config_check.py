"""Validate converter and merger YAML files before a robot uses them.

The schema is built from the C++ parameter tables (laserscan_common/parameter_table.hpp),
exported to parameter_tables.json (scripts/export_parameters), so names, types, units,
defaults and limits are declared once, in the structs; the cross-field rules below follow
the structs' validate(). A problem is reported as ``path.to.key: reason``.

A YAML may hold the parameters directly (as loaded with ``rosparam`` into the node's
private namespace) or nested under one or more node names, e.g.
``front_camera_converter: {min_height: ...}``; each nested block is checked on its own.
"""

import difflib
import math
import os

import yaml

from laserscan_toolbox import parameter_tables

PI_TOL = 1e-6  # the nodes' own tolerance above a limit of pi or 2 pi


class Key:
    """One parameter: type ('float', 'int', 'bool', 'str'), default, unit and limits."""

    def __init__(self, kind, default, unit="", lo=None, hi=None, lo_open=False,
                 angle=None, nonempty=False, doc="", finite=False, frame_id=False):
        self.kind = kind
        self.default = default
        self.unit = unit
        self.lo = lo
        self.hi = hi
        self.lo_open = lo_open
        self.angle = angle  # None: any finite angle; else the largest |angle| the node accepts
        self.nonempty = nonempty
        self.doc = doc
        self.finite = finite  # +-inf is not a value either
        self.frame_id = frame_id  # a tf2 frame id: no leading '/'


INF = float("inf")
# The C++ tables' types as the checker names them.
_KINDS = {"double": "float", "int": "int", "bool": "bool", "string": "str", "polygon": "polygon",
          "string list": "str_list", "shape list": "shape_list"}


def _key(field):
    """A Key from one field of the C++ tables' export (parameter_tables.json)."""
    return Key(_KINDS[field["type"]], field["default"], field["unit"],
               lo=None if field["lo"] == -INF else field["lo"],
               hi=None if field["hi"] == INF else field["hi"], lo_open=field["lo_open"],
               angle=field["angle"] or None, nonempty=field["nonempty"], doc=field["meaning"],
               finite=field["finite"], frame_id=field["frame_id"])


_TABLES = parameter_tables.load()
SELF_FILTER_KEY = Key("self_filter", {}, doc="the robot's own parts (laserscan_common's self filter)")

# Each node's private parameters: its struct's table, plus the blocks read outside it.
CONVERTER = {f["name"]: _key(f) for f in _TABLES["converter"]}
CONVERTER["self_filter"] = SELF_FILTER_KEY
CONVERTER_PAIRS = [("min_height", "max_height"), ("angle_min", "angle_max"),
                   ("range_min", "range_max")]

MERGER = {f["name"]: _key(f) for f in _TABLES["merger"]}
MERGER["self_filter"] = SELF_FILTER_KEY
MERGER["sources"] = None  # checked by check_sources
MERGER_PAIRS = [("angle_min", "angle_max"), ("range_min", "range_max")]

SOURCE = {f["name"]: _key(f) for f in _TABLES["source"]}
SOURCE_REQUIRED = ("name", "topic")
# angle_min > angle_max is allowed for a source mask: it wraps around +-pi.
SOURCE_PAIRS = [("range_min", "range_max")]

# range_scan_converter (depth_filter_scan_converter's RangeScanConverterNodelet): sensor_msgs/Range
# -> LaserScan arc. The sensor's own limits come with each message; these shape the arc.
RANGE = {f["name"]: _key(f) for f in _TABLES["range"]}
SCHEMAS = {"converter": CONVERTER, "merger": MERGER, "range": RANGE}
RANGE_KEYS_ONLY = {"arc_width_scale", "arc_width", "min_consecutive_readings"}


# reactive_navigator (its own package: MRPT's navigators): its node's and its core's tables, plus
# the structured parameters read outside them; its topic lists are checked as topics (no empty
# name, none twice: NodeParameters::validate).
NAVIGATOR = {f["name"]: _key(f) for f in _TABLES["navigator"]}
for _name in ("scan_topics", "cloud_topics"):
    NAVIGATOR[_name].kind = "topic_list"
NAVIGATOR.update({
    "height_band": Key("band", [0.05, 0.90], "m", doc="cloud points kept: [min, max] in robot_frame"),
    "footprint": Key("polygon", None, "m", doc="the robot's outline (2d); default the paper's 0.74 x 0.48 m"),
    "shape_3d": Key("shape_levels", None, "m", doc="prisms stacked from the floor: {height, polygon} (3d)"),
})
NAVIGATOR_OUTSIDE_TABLES = {"height_band", "footprint", "shape_3d"}
SCHEMAS["navigator"] = NAVIGATOR
NAVIGATOR_KEYS_ONLY = {"scan_topics", "cloud_topics", "shape_3d", "lockstep", "goal_tolerance"}


def _check_navigator_value(path, key, value):
    """The navigator's own kinds of value (lists of topics, the band, the 3D shape)."""
    if key.kind == "topic_list":
        if not (isinstance(value, list) and all(isinstance(t, str) and t.strip() for t in value)):
            return ["%s: must be a list of topic names" % path]
        if len(set(value)) != len(value):
            return ["%s: a topic is listed twice" % path]
        return []
    if key.kind == "band":
        if not (isinstance(value, list) and len(value) == 2 and all(_num(v) and math.isfinite(v) for v in value)):
            return ["%s: must be [min, max] (m)" % path]
        return [] if value[0] < value[1] else ["%s: min must be below max, got %r" % (path, value)]
    if key.kind == "shape_levels":
        if not (isinstance(value, list) and value):
            return ["%s: must be a list of {height, polygon} levels" % path]
        problems = []
        for i, level in enumerate(value):
            p = "%s[%d]" % (path, i)
            if not (isinstance(level, dict) and set(level) == {"height", "polygon"}):
                problems.append("%s: must be {height: m, polygon: [[x, y], ...]}" % p)
                continue
            h = level["height"]
            if not (_num(h) and math.isfinite(h) and h > 0):
                problems.append("%s.height: must be a finite number > 0 (m)" % p)
            problems += _check_polygon(p + ".polygon", level["polygon"]) or (
                [] if len(level["polygon"]) >= 3 else ["%s.polygon: needs at least 3 [x, y] points" % p])
        return problems
    return check_value(path, key, value)


def check_navigator(params, prefix=""):
    """Problems of a reactive_navigator block."""
    problems = []
    for k in params:
        if k not in NAVIGATOR:
            close = difflib.get_close_matches(str(k), list(NAVIGATOR), n=1)
            problems.append("%s: unknown parameter%s" % (_join(prefix, k), " (did you mean '%s'?)" % close[0]
                                                         if close else ""))
    for k, key in NAVIGATOR.items():
        if k in params:
            problems += _check_navigator_value(_join(prefix, k), key, params[k])
    if params.get("mode", "2d") not in ("2d", "3d"):
        problems.append("%s: must be '2d' or '3d', got %r" % (_join(prefix, "mode"), params.get("mode")))
    if "footprint" in params and isinstance(params["footprint"], list) and len(params["footprint"]) < 3:
        problems.append("%s: needs at least 3 [x, y] points" % _join(prefix, "footprint"))
    if not params.get("scan_topics") and not params.get("cloud_topics"):
        problems.append("%s: no obstacle source: give scan_topics and/or cloud_topics" % _join(prefix, "scan_topics"))
    # A topic in both lists (one listed twice within a list is check_value's).
    scans, clouds = ({t for t in params.get(k) or [] if isinstance(t, str)} if isinstance(params.get(k), list)
                     else set() for k in ("scan_topics", "cloud_topics"))
    if scans & clouds:
        problems.append("%s: topic '%s' is in scan_topics too" % (_join(prefix, "cloud_topics"),
                                                                  sorted(scans & clouds)[0]))
    if params.get("robot_frame", NAVIGATOR["robot_frame"].default) == params.get("odom_frame",
                                                                                  NAVIGATOR["odom_frame"].default):
        problems.append("%s: must differ from odom_frame" % _join(prefix, "robot_frame"))
    return problems


def check_range(params, prefix=""):
    """Problems of a range_scan_converter block (no cross-field rule: each key stands alone)."""
    return _check_block(params, RANGE, [], prefix)


def _type_name(v):
    if v is None:
        return "nothing (null)"
    return {bool: "bool", int: "int", float: "float", str: "string", list: "list",
            dict: "mapping"}.get(type(v), type(v).__name__)


def limit_text(v):
    """A limit as the reasons write it: %g, and pi or 2 pi for those (as laserscan_common's limitText)."""
    for multiple, text in ((1.0, "pi"), (2.0, "2 pi")):
        if abs(abs(v) - multiple * math.pi) <= 2e-6:
            return ("-" if v < 0 else "") + text
    return "%g" % v


def limit_fault(key, v):
    """Why the number v breaks the key's limits ("" when it does not): the nodes' own words
    (laserscan_common's limitFault in parameter_table.hpp; test_config_check_agrees_with_nodes.py
    compares the two)."""
    unit = (" " + key.unit) if key.unit else ""
    got = ", got " + limit_text(v)
    if math.isnan(v):
        return "must not be NaN"
    if (key.finite or key.angle) and not math.isfinite(v):
        return "must be finite" + got
    if key.angle:
        if abs(v) <= key.angle + PI_TOL:
            return ""
        return "must be within [%s, %s]%s%s" % (limit_text(-key.angle), limit_text(key.angle), unit, got)
    above_lo = key.lo is None or (v > key.lo if key.lo_open else v >= key.lo)
    if above_lo and (key.hi is None or v <= key.hi):
        return ""
    if key.lo is not None and key.hi is not None:
        return "must be within %s%s, %s]%s%s" % ("(" if key.lo_open else "[", limit_text(key.lo),
                                                 limit_text(key.hi), unit, got)
    if key.lo is not None:
        return "must be %s %s%s%s" % (">" if key.lo_open else ">=", limit_text(key.lo), unit, got)
    return "must be <= %s%s%s" % (limit_text(key.hi), unit, got)


def check_value(path, key, value):
    """Problems of one value against its Key; returns a list of strings."""
    if key.kind == "float":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return ["%s: expected a number in %s, got %s %r" % (path, key.unit or "units",
                                                              _type_name(value), value)]
    elif key.kind == "int":
        # The nodes' one rule for numbers: 2.0 is the whole number 2, 2.5 is not.
        whole_float = isinstance(value, float) and value.is_integer()
        if isinstance(value, bool) or not (isinstance(value, int) or whole_float):
            return ["%s: expected a whole number, got %s %r" % (path, _type_name(value), value)]
    elif key.kind == "bool":
        if not isinstance(value, bool):
            return ["%s: expected true or false, got %s %r" % (path, _type_name(value), value)]
        return []
    elif key.kind == "polygon":
        return _check_polygon(path, value, key.nonempty)
    elif key.kind == "self_filter":
        return _check_self_filter(path, value)
    elif key.kind == "str_list":
        if not (isinstance(value, list) and all(isinstance(x, str) for x in value)):
            return ["%s: must be a list of strings" % path]
        return []
    else:
        if not isinstance(value, str):
            return ["%s: expected a string, got %s %r" % (path, _type_name(value), value)]
        if key.nonempty and not value:
            return ["%s: must not be empty" % path]
        if key.frame_id and value.startswith("/"):
            return ["%s: must not start with '/' (tf2 frame ids have none)" % path]
        return []
    fault = limit_fault(key, float(value))
    return ["%s: %s" % (path, fault)] if fault else []


# The self filter block (laserscan_common's SelfFilterParams, the same for converters and merger);
# a shape's own keys (a dictionary whose required keys depend on its type) are checked below.
SELF_FILTER = {f["name"]: _key(f) for f in _TABLES["self_filter"]}
SHAPE_SIZES = {e["type"]: set(e["keys"]) for e in _TABLES["self_filter_shape_keys"] if e["type"] != "*"}
# Every type's sizes in the export's order (the order the node names a wrong one in).
SHAPE_SIZE_ORDER = list(dict.fromkeys(k for e in _TABLES["self_filter_shape_keys"] if e["type"] != "*"
                                      for k in e["keys"]))
SHAPE_KEYS = set().union(*SHAPE_SIZES.values(),
                         *(e["keys"] for e in _TABLES["self_filter_shape_keys"] if e["type"] == "*"))


def _positive_numbers(path, value, count):
    if count > 1 and not (isinstance(value, list) and len(value) == count):
        return ["%s: must be a list of %d numbers" % (path, count)]
    values = value if count > 1 else [value]
    if not all(_num(v) for v in values):
        return ["%s: must be %s" % (path, "numbers" if count > 1 else "a number")]
    if not all(math.isfinite(v) and v > 0 for v in values):
        return ["%s: sizes must be finite and > 0 (m)" % path]
    return []


def _check_shape(path, shape):
    if not isinstance(shape, dict):
        return ["%s: must be a dictionary (frame, type, sizes, origin, padding)" % path]
    problems = ["%s: unknown key" % _join(path, k) for k in shape if k not in SHAPE_KEYS]
    frame = shape.get("frame")
    if not isinstance(frame, str) or not frame:
        problems.append("%s: is required (the tf frame the shape moves with)" % _join(path, "frame"))
    elif frame.startswith("/"):
        problems.append("%s: must not start with '/' (tf2 frame ids have none)" % _join(path, "frame"))
    kind = shape.get("type")
    if kind not in SHAPE_SIZES:
        return problems + ["%s: must be box, cylinder or sphere" % _join(path, "type")]
    for size in SHAPE_SIZE_ORDER:
        wanted = size in SHAPE_SIZES[kind]
        if (size in shape) != wanted:
            problems.append("%s: %s for a %s" % (_join(path, size), "is required" if wanted else "is not used", kind))
        elif wanted:
            problems += _positive_numbers(_join(path, size), shape[size], 3 if size == "size" else 1)
    if "origin" in shape and not (isinstance(shape["origin"], list) and len(shape["origin"]) == 6
                                  and all(_num(v) and math.isfinite(v) for v in shape["origin"])):
        problems.append("%s: must be a list of 6 numbers (x, y, z, roll, pitch, yaw)" % _join(path, "origin"))
    if "padding" in shape:
        problems += check_value(_join(path, "padding"), SELF_FILTER["padding"], shape["padding"])
    return problems


def _check_self_filter(path, value):
    if not isinstance(value, dict):
        return ["%s: must be a dictionary (use_robot_description, links, padding, shapes)" % path]
    problems = []
    for k, v in value.items():
        key = SELF_FILTER.get(k)
        if key is None:
            problems.append(_unknown(_join(path, k), k, SELF_FILTER, "key"))
        elif key.kind == "shape_list":
            if not isinstance(v, list):
                problems.append("%s: must be a list of shapes" % _join(path, k))
            else:
                for i, shape in enumerate(v):
                    problems += _check_shape("%s[%d]" % (_join(path, k), i), shape)
        else:
            problems += check_value(_join(path, k), key, v)
    if value.get("links") and value.get("use_robot_description") is not True:
        problems.append("%s: needs use_robot_description: true (the links are the description's)"
                        % _join(path, "links"))
    return problems


def _unknown(path, name, known, what="parameter"):
    """'<path>: unknown <what>', with the closest known name (as the nodes write it)."""
    close = difflib.get_close_matches(str(name), list(known), n=1)
    return "%s: unknown %s%s" % (path, what, " (did you mean '%s'?)" % close[0] if close else "")


def _check_polygon(path, value, required=False):
    """A list of [x, y] points, every coordinate finite: at least 3, or none (no polygon) unless
    it is required (laserscan_common's limitFault of a polygon)."""
    if not isinstance(value, list):
        return ["%s: expected a list of [x, y] points, got %s %r" % (path, _type_name(value), value)]
    for i, p in enumerate(value):
        if not (isinstance(p, list) and len(p) == 2 and all(_is_number(c) for c in p)):
            return ["%s: point %d is not a pair of numbers [x, y]: %r" % (path, i, p)]
    for i, p in enumerate(value):
        if not all(math.isfinite(c) for c in p):
            return ["%s: point %d is not finite" % (path, i)]
    if len(value) < 3 and (required or value):
        return ["%s: needs %s 3 [x, y] points, got %d" % (path, "at least" if required else "none or at least",
                                                          len(value))]
    return []


def _is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _join(prefix, key):
    return "%s.%s" % (prefix, key) if prefix else str(key)


def _check_block(params, schema, pairs, prefix):
    problems = []
    for k in params:
        if k not in schema:
            problems.append(_unknown(_join(prefix, k), k, schema))
    for k, key in schema.items():
        if key is not None and k in params:
            problems += check_value(_join(prefix, k), key, params[k])
    for lo, hi in pairs:
        vlo = params.get(lo, schema[lo].default)
        vhi = params.get(hi, schema[hi].default)
        if _num(vlo) and _num(vhi) and not float(vlo) < float(vhi):
            problems.append("%s: must be greater than %s (%g <= %g)"
                            % (_join(prefix, hi), lo, float(vhi), float(vlo)))
    return problems


def _num(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and not math.isnan(v)


def _check_one_turn(params, schema, prefix):
    """Both nodes: a scan covers at most one turn (also catches limits written in degrees)."""
    lo = params.get("angle_min", schema["angle_min"].default)
    hi = params.get("angle_max", schema["angle_max"].default)
    if _num(lo) and _num(hi) and float(hi) - float(lo) > 2 * math.pi + PI_TOL:
        return ["%s: angle_max - angle_min must not exceed 2 pi (%g rad)"
                % (_join(prefix, "angle_max"), float(hi) - float(lo))]
    return []


def check_converter(params, prefix=""):
    return _check_block(params, CONVERTER, CONVERTER_PAIRS, prefix) + _check_one_turn(params, CONVERTER, prefix)


def _check_merger_output(params, prefix):
    """The merger's cross-field rules beyond min < max (same as OutputParams::validate)."""
    problems = []
    get = lambda k: params.get(k, MERGER[k].default)  # noqa: E731
    if get("finite_only") is True:
        if get("use_inf") is True:
            problems.append("%s: needs use_inf: false (no return is then range_max + inf_epsilon)"
                            % _join(prefix, "finite_only"))
        elif _num(get("range_min")) and not float(get("range_min")) > 0.0:
            problems.append("%s: must be > 0 when finite_only is true (invalid and too-close bins are "
                            "written as 0, below range_min)" % _join(prefix, "range_min"))
    rate = get("publish_rate")
    if _num(rate) and 0.0 < float(rate) < 1e-6:
        problems.append("%s: must be 0 or at least 1e-6 Hz (a period must fit a ros::Duration)"
                        % _join(prefix, "publish_rate"))
    window = get("sync_window")
    if _num(rate) and _num(window) and float(rate) > 0.0 and float(window) * float(rate) >= 1.0:
        problems.append("%s: must be shorter than the publish period 1 / publish_rate" % _join(prefix, "sync_window"))
    return problems


def check_merger(params, prefix=""):
    problems = _check_block(params, MERGER, MERGER_PAIRS, prefix)
    problems += _check_one_turn(params, MERGER, prefix)
    problems += _check_merger_output(params, prefix)
    path = _join(prefix, "sources")
    sources = params.get("sources")
    if sources is None:
        return problems + ["%s: missing; the merger needs at least one source" % path]
    if not isinstance(sources, list):
        return problems + ["%s: expected a list of sources, got %s" % (path, _type_name(sources))]
    if not sources:
        return problems + ["%s: empty; the merger needs at least one source" % path]
    names = {}
    for i, src in enumerate(sources):
        sp = "%s[%d]" % (path, i)
        if not isinstance(src, dict):
            problems.append("%s: expected a mapping with name and topic, got %s"
                            % (sp, _type_name(src)))
            continue
        for k in SOURCE_REQUIRED:
            if k not in src:
                problems.append("%s: missing (required)" % _join(sp, k))
        problems += _check_block(src, SOURCE, SOURCE_PAIRS, sp)
        if src.get("topic") == "merged_scan":
            problems.append("%s: 'merged_scan' is the merger's own output topic: the merger would read "
                            "itself" % _join(sp, "topic"))
        name = src.get("name")
        if isinstance(name, str) and name:
            if name in names:
                problems.append("%s: duplicate source name '%s' (also %s[%d])"
                                % (_join(sp, "name"), name, path, names[name]))
            else:
                names[name] = i
    return problems


def guess_kind(params):
    if not isinstance(params, dict):
        return None
    if "sources" in params or "output_frame" in params or "odom_topic" in params:
        return "merger"
    if set(params) & NAVIGATOR_KEYS_ONLY:
        return "navigator"
    if set(params) & RANGE_KEYS_ONLY:
        return "range"
    if set(params) & {"reference_frame", "min_height", "max_height", "floor_height",
                      "hole_detection", "row_stride", "column_stride"}:
        return "converter"
    return None


def find_blocks(data, kind=None, prefix=""):
    """(path prefix, kind, params) for each node's parameter block in a loaded YAML."""
    if not isinstance(data, dict):
        return []
    k = kind if kind and (guess_kind(data) or not _all_mappings(data)) else guess_kind(data)
    if k:
        return [(prefix, k, data)]
    blocks = []
    for name, sub in data.items():
        if isinstance(sub, dict):
            blocks += find_blocks(sub, kind, _join(prefix, name))
    return blocks


def _all_mappings(d):
    return bool(d) and all(isinstance(v, dict) for v in d.values())


def frames_of(prefix, kind, params):
    """(key path, frame) pairs the configuration names."""
    if kind == "range":
        return []  # the arc is in the frame each Range message names
    if kind == "navigator":
        return [(_join(prefix, k), params.get(k, NAVIGATOR[k].default)) for k in ("odom_frame", "robot_frame")]
    key = "reference_frame" if kind == "converter" else "output_frame"
    return [(_join(prefix, key), params.get(key, SCHEMAS[kind][key].default))]


def topics_of(prefix, kind, params):
    """(key path, topic) pairs of a merger's sources."""
    out = []
    if kind == "merger" and isinstance(params.get("sources"), list):
        for i, s in enumerate(params["sources"]):
            if isinstance(s, dict) and isinstance(s.get("topic"), str) and s["topic"]:
                out.append(("%s[%d].topic" % (_join(prefix, "sources"), i), s["topic"]))
    return out


class UsageError(Exception):
    """Bad command line or unreadable file (exit status 2)."""


def load_yaml(path):
    if not os.path.isfile(path):
        raise UsageError("%s: no such file" % path)
    try:
        with open(path) as f:
            return yaml.safe_load(f)
    except yaml.YAMLError as e:
        return _YamlBroken(str(e).replace("\n", " "))


class _YamlBroken:
    def __init__(self, msg):
        self.msg = msg


def check_data(data, kind=None, tf_tree=None, topic_frames=None):
    """All problems of one loaded YAML document.

    tf_tree: optional TfTree; when given every frame the config names must be in it and
    connected to the others. topic_frames: optional {topic: frame_id} from a bag; a
    merger source's frame must then be connected to the output frame.
    """
    if isinstance(data, _YamlBroken):
        return ["(file): not valid YAML: %s" % data.msg]
    if data is None:
        return ["(file): empty"]
    if not isinstance(data, dict):
        return ["(file): expected a mapping of parameters, got %s" % _type_name(data)]
    blocks = find_blocks(data, kind)
    if not blocks:
        return ["(file): no converter or merger parameters found (use --kind to say which)"]
    problems = []
    for prefix, k, params in blocks:
        problems += {"converter": check_converter, "merger": check_merger, "range": check_range,
                     "navigator": check_navigator}[k](params, prefix)
        if tf_tree is not None:
            for path, frame in frames_of(prefix, k, params):
                if isinstance(frame, str) and frame and not tf_tree.has(frame):
                    known = sorted(tf_tree.frames())
                    problems.append("%s: frame '%s' is not in the tf tree (%s)" % (
                        path, frame, "frames: " + ", ".join(known[:12]) if known
                        else "the tree is empty: no /tf or /tf_static; give the sensor "
                        "mounts with --static-tf or --tf-launch"))
            if k == "merger" and topic_frames is not None:
                out_frame = params.get("output_frame", "base_link")
                for path, topic in topics_of(prefix, k, params):
                    t = "/" + topic.lstrip("/")
                    if t not in topic_frames:
                        problems.append("%s: topic '%s' is not in the bag" % (path, topic))
                        continue
                    frame = topic_frames[t]
                    if frame and tf_tree.has(out_frame) and not tf_tree.connected(frame, out_frame):
                        problems.append("%s: its frame '%s' has no tf path to output_frame '%s'"
                                        % (path, frame, out_frame))
    return problems


def check_file(path, kind=None, tf_tree=None, topic_frames=None):
    return check_data(load_yaml(path), kind, tf_tree, topic_frames)


class TfTree:
    """Frames and parent links, from a bag or a live tf buffer."""

    def __init__(self, edges=()):
        self._adj = {}
        for parent, child in edges:
            self.add(parent, child)

    def add(self, parent, child):
        parent = parent.lstrip("/")
        child = child.lstrip("/")
        self._adj.setdefault(parent, set()).add(child)
        self._adj.setdefault(child, set()).add(parent)

    def frames(self):
        return set(self._adj)

    def has(self, frame):
        return frame.lstrip("/") in self._adj

    def connected(self, a, b):
        a = a.lstrip("/")
        b = b.lstrip("/")
        if a == b:
            return True
        seen = {a}
        todo = [a]
        while todo:
            f = todo.pop()
            for n in self._adj.get(f, ()):
                if n == b:
                    return True
                if n not in seen:
                    seen.add(n)
                    todo.append(n)
        return False


def tf_tree_from_bag(path, max_header_messages=1):
    """TfTree from /tf and /tf_static, and {topic: frame_id} of every topic with a header."""
    import rosbag
    if not os.path.isfile(path):
        raise UsageError("%s: no such bag" % path)
    tree = TfTree()
    topic_frames = {}
    with rosbag.Bag(path) as bag:
        info = bag.get_type_and_topic_info().topics
        for _, msg, _ in bag.read_messages(topics=["/tf", "/tf_static"]):
            for t in msg.transforms:
                tree.add(t.header.frame_id, t.child_frame_id)
        others = [t for t in info if t not in ("/tf", "/tf_static")]
        for topic in others:
            for _, msg, _ in bag.read_messages(topics=[topic]):
                header = getattr(msg, "header", None)
                if header is not None:
                    topic_frames[topic] = header.frame_id.lstrip("/")
                break
    return tree, topic_frames


def tf_tree_live(wait=2.0, clock_timeout=5.0):
    """TfTree of a running system (listens to tf for ``wait`` seconds of wall time).

    Raises UsageError when there is no master, or when /use_sim_time is true and no /clock
    arrives within ``clock_timeout`` s (rospy would otherwise wait for it forever)."""
    import time

    import rosgraph
    if not rosgraph.is_master_online():
        raise UsageError("--live: no ROS master at %s: start the robot (or roscore) first, "
                         "or set ROS_MASTER_URI to the robot's master"
                         % rosgraph.get_master_uri())
    import rospy
    import tf2_ros
    rospy.init_node("check_config", anonymous=True, disable_signals=True)
    if rospy.get_param("/use_sim_time", False):
        deadline = time.monotonic() + clock_timeout
        while rospy.Time.now().is_zero():
            if time.monotonic() > deadline:
                raise UsageError(
                    "--live: /use_sim_time is true but nothing published /clock within %g s. "
                    "Start what provides the simulated clock (e.g. `rosbag play --clock BAG` "
                    "or the simulator), or, if the robot runs on wall time, "
                    "`rosparam set /use_sim_time false` before starting its nodes"
                    % clock_timeout)
            time.sleep(0.05)
    buf = tf2_ros.Buffer()
    tf2_ros.TransformListener(buf)
    time.sleep(wait)  # wall time: a paused or slow simulated clock must not stretch it
    frames = yaml.safe_load(buf.all_frames_as_yaml()) or {}
    tree = TfTree()
    for child, info in frames.items():
        tree.add(info.get("parent", ""), child)
    return tree


def _numbers(tokens, what):
    try:
        values = [float(t) for t in tokens]
    except ValueError:
        raise UsageError("%s: expected numbers before the frames, got %s"
                         % (what, " ".join(tokens))) from None
    if not all(math.isfinite(v) for v in values):
        raise UsageError("%s: the pose must be finite" % what)
    return values


def static_tf_edge(spec, what=None, trailing_period=False):
    """(parent, child) of a mount written like static_transform_publisher's arguments:
    "x y z yaw pitch roll parent child" or "x y z qx qy qz qw parent child".
    trailing_period: the tf (not tf2_ros) publisher's last argument, a period in ms."""
    what = what or "--static-tf '%s'" % spec
    tokens = spec.split() if isinstance(spec, str) else list(spec)
    if trailing_period and tokens:
        _numbers(tokens[-1:], what)
        tokens = tokens[:-1]
    if len(tokens) not in (8, 9):
        raise UsageError("%s: expected 'x y z yaw pitch roll parent child' or "
                         "'x y z qx qy qz qw parent child' (%d words given)"
                         % (what, len(tokens)))
    pose = _numbers(tokens[:-2], what)
    if len(pose) == 7 and not math.isclose(sum(q * q for q in pose[3:]), 1.0, abs_tol=1e-3):
        raise UsageError("%s: the quaternion is not normalized" % what)
    parent, child = (t.lstrip("/") for t in tokens[-2:])
    if not parent or not child or parent == child:
        raise UsageError("%s: parent and child must be two different frames" % what)
    return parent, child


STATIC_TF_NODES = {("tf2_ros", "static_transform_publisher"): False,
                   ("tf", "static_transform_publisher"): True}  # True: has a period argument


def static_tf_edges_from_launch(path):
    """(parent, child) of every static_transform_publisher node a launch file starts
    (its includes and default arguments resolved as roslaunch does)."""
    import roslaunch.config
    import roslaunch.xmlloader
    if not os.path.isfile(path):
        raise UsageError("%s: no such launch file" % path)
    config = roslaunch.config.ROSLaunchConfig()
    try:
        roslaunch.xmlloader.XmlLoader().load(path, config, verbose=False, argv=["check_config"])
    except Exception as e:  # roslaunch raises several types for a bad or unresolved file
        hint = ""
        if isinstance(e, roslaunch.xmlloader.XmlParseException) or "ROS path" in str(e):
            # $(find pkg) of the project's own packages needs the workspace on ROS_PACKAGE_PATH.
            hint = " (a package it names is not found: source the workspace, build/devel/setup.bash)"
        raise UsageError("--tf-launch %s: cannot load it: %s%s" % (path, e, hint)) from None
    edges = []
    for node in config.nodes:
        period = STATIC_TF_NODES.get((node.package, node.type))
        if period is not None:
            edges.append(static_tf_edge(node.args, "--tf-launch %s: node %s" % (path, node.name),
                                        trailing_period=period))
    if not edges:
        raise UsageError("--tf-launch %s: it starts no static_transform_publisher" % path)
    return edges


def main(argv=None):
    import argparse
    import sys
    p = argparse.ArgumentParser(
        prog="check_config",
        description="Validate depth_filter_scan_converter / range_scan_converter / multi_laserscan_merger YAML "
                    "files. Prints each problem as 'path.to.key: reason'. Exit status: "
                    "0 all files usable, 1 a file has problems, 2 usage error or missing file.")
    p.add_argument("files", nargs="+", metavar="FILE")
    p.add_argument("--kind", choices=["converter", "merger", "range", "navigator"],
                   help="what the files configure (default: guessed from the keys)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--bag", help="check frames (and merger source topics) against this bag's "
                                 "/tf and /tf_static")
    g.add_argument("--live", action="store_true",
                   help="check frames against the tf tree of the running system")
    p.add_argument("--static-tf", action="append", default=[], metavar="'X Y Z YAW PITCH ROLL "
                   "PARENT CHILD'", help="a sensor mount the bag or system lacks, written as "
                   "static_transform_publisher's arguments (also X Y Z QX QY QZ QW PARENT "
                   "CHILD); repeat it for each mount. Alone, frames are checked against "
                   "these mounts only")
    p.add_argument("--tf-launch", action="append", default=[], metavar="LAUNCH",
                   help="take the mounts from the static_transform_publisher nodes of this "
                        "launch file (its default arguments); may be repeated")
    p.add_argument("--listen", type=float, default=2.0, metavar="S",
                   help="--live: seconds of listening to tf (default 2)")
    p.add_argument("--clock-timeout", type=float, default=5.0, metavar="S",
                   help="--live with /use_sim_time true: give up when no /clock arrives "
                        "within S seconds (default 5)")
    p.add_argument("--stderr", action="store_true",
                   help="print problems on stderr (used from launch files, whose "
                        "<param command=...> keeps stdout)")
    p.add_argument("-q", "--quiet", action="store_true", help="print problems only")
    try:
        args = p.parse_args(argv)
    except SystemExit as e:
        return 2 if e.code else 0
    out = sys.stderr if args.stderr else sys.stdout
    try:
        if not (args.listen > 0 and args.clock_timeout > 0):
            raise UsageError("--listen and --clock-timeout must be > 0 seconds")
        mounts = [static_tf_edge(spec) for spec in args.static_tf]
        for launch in args.tf_launch:
            mounts += static_tf_edges_from_launch(launch)
        tree = topic_frames = None
        if args.bag:
            tree, topic_frames = tf_tree_from_bag(args.bag)
        elif args.live:
            tree = tf_tree_live(args.listen, args.clock_timeout)
        elif mounts:
            tree = TfTree()
        for parent, child in mounts:
            tree.add(parent, child)
        bad = False
        for f in args.files:
            problems = check_file(f, args.kind, tree, topic_frames)
            if problems:
                bad = True
                print("%s: %d problem(s), not usable" % (f, len(problems)), file=out)
            for pr in problems:
                print("  " + pr, file=out)
            if not problems and not args.quiet:
                print("%s: ok" % f, file=out)
    except UsageError as e:
        print("check_config: %s" % e, file=sys.stderr)
        return 2
    return 1 if bad else 0
