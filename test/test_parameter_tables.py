"""A parameter is declared once, in its struct's C++ field table (laserscan_common/parameter_table.hpp).

check_config's schema is built from the table's export (scripts/laserscan_toolbox/parameter_tables.json),
the package READMEs' parameter tables are rendered from it, and dynamic_reconfigure's .cfg must
agree with it: each of these fails when the C++ table changes and the copy is not regenerated
(`scripts/export_parameters --write`) or the .cfg not edited. Needs the built pybind11 modules.
"""
import math
import os
import re
import sys
import types

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
from laserscan_toolbox import config_check as cc
from laserscan_toolbox import parameter_tables as pt

CFG = os.path.join(REPO, "depth_filter_scan_converter", "cfg", "DepthFilterScanConverter.cfg")


def test_checked_in_export_is_the_tables_of_the_built_modules():
    assert pt.load() == pt.export(), "parameter_tables.json is stale: run scripts/export_parameters --write"


def test_check_config_schema_is_the_export():
    tables = pt.export()
    # The navigator's topic lists are the checker's topic_list (no empty name, none twice).
    topic_lists = {"scan_topics", "cloud_topics"}
    for kind, schema, outside in (("converter", cc.CONVERTER, {"self_filter"}), ("range", cc.RANGE, set()),
                                  ("merger", cc.MERGER, {"self_filter", "sources"}), ("source", cc.SOURCE, set()),
                                  ("navigator", cc.NAVIGATOR, cc.NAVIGATOR_OUTSIDE_TABLES)):
        names = [f["name"] for f in tables[kind]]
        # Only the blocks read outside the tables are the checker's own.
        assert set(schema) - set(names) == outside, kind
        for f in tables[kind]:
            key = schema[f["name"]]
            wanted = "topic_list" if kind == "navigator" and f["name"] in topic_lists else cc._KINDS[f["type"]]
            assert (key.kind, key.unit, key.doc) == (wanted, f["unit"], f["meaning"]), f["name"]
            assert (key.lo, key.hi, key.lo_open, key.finite, key.nonempty) == (
                None if f["lo"] == -math.inf else f["lo"], None if f["hi"] == math.inf else f["hi"], f["lo_open"],
                f["finite"], f["nonempty"]), f["name"]
            assert key.default == f["default"] or (
                isinstance(key.default, float) and math.isclose(key.default, f["default"])), f["name"]


@pytest.mark.parametrize("path", sorted({t[0] for t in pt.README_TABLES}))
def test_readme_tables_are_rendered_from_the_tables(path):
    full = os.path.join(REPO, path)
    with open(full) as f:
        text = f.read()
    assert pt.readmes(pt.export())[full] == text, \
        "%s: a parameter table differs from the C++ table: run scripts/export_parameters --write" % path


def test_readme_rendering_sees_a_changed_meaning():
    # The check above can fail: a table whose meaning changed renders another README.
    tables = pt.export()
    tables["converter"][0] = dict(tables["converter"][0], meaning="something else")
    full = os.path.join(REPO, "depth_filter_scan_converter", "README.md")
    with open(full) as f:
        assert "something else" in pt.readmes(tables)[full] != f.read()


def cfg_entries():
    """gen.add(...) calls of the .cfg, run against a stand-in for dynamic_reconfigure's generator."""
    added = []

    class Generator:
        def add(self, name, kind, level, description, default=None, lo=None, hi=None):
            added.append(dict(name=name, kind=kind, description=description, default=default, lo=lo, hi=hi))

        def generate(self, *args):
            return 0

    module = types.ModuleType("dynamic_reconfigure.parameter_generator_catkin")
    module.ParameterGenerator = Generator
    module.bool_t, module.int_t, module.double_t, module.str_t = "bool", "int", "double", "string"
    saved = {k: sys.modules.get(k) for k in ("dynamic_reconfigure", module.__name__)}
    sys.modules["dynamic_reconfigure"] = types.ModuleType("dynamic_reconfigure")
    sys.modules[module.__name__] = module
    try:
        with open(CFG) as f:
            code = compile(f.read(), CFG, "exec")
        with pytest.raises(SystemExit):
            exec(code, {"__name__": "__main__"})
    finally:
        for k, v in saved.items():
            if v is None:
                sys.modules.pop(k, None)
            else:
                sys.modules[k] = v
    return added


def cfg_problems(entries, table):
    fields = {f["name"]: f for f in table}
    problems = []
    for e in entries:
        f = fields.get(e["name"])
        if f is None:
            problems.append("%s: not in the converter's table" % e["name"])
            continue
        if e["kind"] != f["type"]:
            problems.append("%s: type %s, table %s" % (e["name"], e["kind"], f["type"]))
        if e["default"] != f["default"]:
            problems.append("%s: default %r, table %r" % (e["name"], e["default"], f["default"]))
        if f["unit"] and "[%s]" % f["unit"] not in e["description"]:
            problems.append("%s: the description does not give the unit [%s]" % (e["name"], f["unit"]))
        if e["lo"] is not None and (e["lo"] < f["lo"] or e["hi"] > f["hi"]):
            problems.append("%s: slider [%g, %g] leaves the table's limits" % (e["name"], e["lo"], e["hi"]))
    return problems


def test_dynamic_reconfigure_cfg_agrees_with_the_table():
    entries = cfg_entries()
    assert len(entries) >= 5  # the stand-in saw the .cfg's parameters
    assert cfg_problems(entries, pt.export()["converter"]) == []


def test_cfg_check_sees_a_wrong_default_type_and_name():
    entries = cfg_entries()
    table = pt.export()["converter"]
    wrong = [dict(entries[0], default=entries[0]["default"] + 1.0), dict(entries[1], kind="int"),
             dict(entries[2], name="min_hieght")]
    assert len(cfg_problems(wrong, table)) == 3


# Each node's commented example YAML (config/<node>.yaml of its package) and the tables it shows.
EXAMPLE_YAMLS = {
    "depth_filter_scan_converter/config/depth_filter_scan_converter.yaml": ("converter",),
    "depth_filter_scan_converter/config/range_scan_converter.yaml": ("range",),
    "multi_laserscan_merger/config/multi_laserscan_merger.yaml": ("merger", "source"),
    "reactive_navigator/config/reactive_navigator.yaml": ("navigator",),
}


def yaml_keys(text):
    """Every `key:` of a YAML text, set or commented out (`# key: value`), in blocks and flow maps."""
    return set(re.findall(r"(?:^|[{,\s])([a-z_][a-z0-9_]*):(?=\s)", text, re.M))


@pytest.mark.parametrize("path", sorted(EXAMPLE_YAMLS))
def test_every_parameter_is_in_its_nodes_example_yaml(path):
    with open(os.path.join(REPO, path)) as f:
        keys = yaml_keys(f.read())
    tables = pt.load()
    missing = [f["name"] for kind in EXAMPLE_YAMLS[path] for f in tables[kind] if f["name"] not in keys]
    assert missing == [], "%s does not show %s" % (path, missing)


def test_yaml_keys_see_a_missing_parameter():
    assert yaml_keys("a: 1\n# b: 2\nc: [{d: 1, e_f: 2}]\n# meaning: not a key\n") >= {"a", "b", "c", "d", "e_f"}
    assert "range_noise_std" not in yaml_keys("# range_noise_std_per_m2: 0.0\n")


def test_one_rule_for_whole_numbers_in_the_checker():
    # An int parameter takes 2.0 (the nodes read it as 2), never 2.5; a double takes 2.
    assert cc.check_converter({"row_stride": 2.0}) == []
    assert cc.check_converter({"row_stride": 2.5})
    assert cc.check_merger({"odom_queue_size": 100.0, "sources": [{"name": "a", "topic": "a/scan"}]}) == []
    assert cc.check_merger({"odom_queue_size": 100.5, "sources": [{"name": "a", "topic": "a/scan"}]})
    assert cc.check_converter({"range_max": 10}) == []
