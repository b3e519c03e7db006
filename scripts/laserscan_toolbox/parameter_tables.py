"""The nodes' parameter tables, as the C++ structs declare them (laserscan_common/parameter_table.hpp).

Each parameter struct has one field table in C++ (name, type, unit, default, limits, meaning).
``export()`` reads them from the built pybind11 modules; ``parameter_tables.json`` beside this
file is that export, checked in, so that check_config's schema (config_check.py) is built from it
without a build; the package READMEs' parameter tables are rendered from it too. After changing
a table, regenerate both with ``scripts/export_parameters --write``; test/test_parameter_tables.py
fails while either is stale.
"""

import json
import math
import os
import re

JSON_PATH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "parameter_tables.json")
REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# Which README table shows which struct: (README, the line the table follows, table kind, the
# prefix its names are shown with). The first line of that text after the anchor that starts
# with "|" begins the table.
README_TABLES = [
    ("depth_filter_scan_converter/README.md", "## Depth converters", "### Parameters", "converter", ""),
    ("depth_filter_scan_converter/README.md", "## range_scan_converter", "### Parameters", "range", ""),
    ("multi_laserscan_merger/README.md", "", "### Parameters", "merger", ""),
    ("multi_laserscan_merger/README.md", "", "Each entry of `sources`:", "source", ""),
    ("laserscan_common/README.md", "## Self filter", "| parameter | type | unit | default | meaning |",
     "self_filter", "self_filter/"),
    ("reactive_navigator/README.md", "", "## Parameters", "navigator", ""),
]
README_TYPES = {"double": "double", "int": "int", "bool": "bool", "string": "string",
                "polygon": "list of `[x, y]`", "string list": "list of strings", "shape list": "list of dicts"}


def export():
    """{kind: [field dicts]} from the built modules (source devel/setup.bash first)."""
    import depth_filter_scan_converter_core as converter_core
    import depth_filter_scan_converter_range_core as range_core
    import multi_laserscan_merger_core as merger_core
    import reactive_navigator_core as navigator_core
    tables = {"converter": converter_core.parameter_table(), "range": range_core.parameter_table(),
              "merger": merger_core.parameter_table(), "source": merger_core.source_parameter_table(),
              "self_filter": converter_core.self_filter_parameter_table(),
              # Not a field table: a listed shape's keys ("*": every type's), for check_config.
              "self_filter_shape_keys": converter_core.self_filter_shape_keys(),
              # One README table and one check_config block for the node's and the core's structs.
              "navigator": list(navigator_core.node_parameter_table()) + list(navigator_core.parameter_table())}
    return {kind: [dict(field) for field in fields] for kind, fields in tables.items()}


def dumps(tables):
    return json.dumps(tables, indent=1, sort_keys=True) + "\n"


def load():
    with open(JSON_PATH) as f:
        return json.load(f)


def default_text(field):
    if field["default_text"]:
        return field["default_text"]
    v = field["default"]
    if isinstance(v, bool):
        return "`%s`" % ("true" if v else "false")
    if isinstance(v, str):
        return "`%s`" % v if v else '`""`'
    if isinstance(v, float) and math.isinf(v):
        return "`%sinf`" % ("-" if v < 0 else "+")
    return "`%r`" % (v,)


def readme_row(field, prefix=""):
    cells = ["`%s%s`" % (prefix, field["name"]), README_TYPES[field["type"]], field["unit"], default_text(field),
             field["meaning"]]
    return "|" + "|".join(" %s " % c if c else " " for c in cells) + "|"


def _row_names(line):
    """The parameter names a table row's first cell holds ("`a`, `b`" holds two)."""
    first = re.split(r"(?<!\\)\|", line)[1]
    return re.findall(r"`([^`]+)`", first)


def render_readme(text, kind_rows):
    """`text` with each table of README_TABLES rewritten: the header, one row per field in table
    order, then the rows of parameters read outside the tables (self_filter, sources) as they
    were. kind_rows: {(section, anchor, kind, prefix): [fields]}, for the tables this README holds."""
    lines = text.split("\n")
    for section, anchor, kind, prefix in kind_rows:
        start = lines.index(section) if section else 0
        at = next(i for i in range(start, len(lines)) if lines[i] == anchor)
        top = next(i for i in range(at, len(lines)) if lines[i].startswith("|"))
        end = next(i for i in range(top, len(lines)) if not lines[i].startswith("|"))
        fields = kind_rows[(section, anchor, kind, prefix)]
        names = {prefix + f["name"] for f in fields}
        others = [line for line in lines[top + 2:end] if not set(_row_names(line)) & names]
        rows = [readme_row(f, prefix) for f in fields]
        lines[top + 2:end] = rows + others
    return "\n".join(lines)


def readmes(tables):
    """{README path: its text with the tables rendered from `tables`}."""
    out = {}
    for path in sorted({t[0] for t in README_TABLES}):
        full = os.path.join(REPO, path)
        with open(full) as f:
            text = f.read()
        kind_rows = {(s, a, k, x): tables[k] for p, s, a, k, x in README_TABLES if p == path}
        out[full] = render_readme(text, kind_rows)
    return out


def main(argv=None):
    import argparse
    p = argparse.ArgumentParser(
        prog="export_parameters",
        description="Export the C++ parameter tables (from the built pybind11 modules) to "
                    "scripts/laserscan_toolbox/parameter_tables.json and the package READMEs' "
                    "parameter tables. Without --write: print the export; exit 1 if a file is stale.")
    p.add_argument("--write", action="store_true", help="rewrite the JSON and the README tables")
    args = p.parse_args(argv)
    tables = export()
    wanted = {JSON_PATH: dumps(tables)}
    wanted.update(readmes(tables))
    stale = []
    for path, text in wanted.items():
        with open(path) as f:
            if f.read() == text:
                continue
        stale.append(path)
        if args.write:
            with open(path, "w") as f:
                f.write(text)
    if not args.write:
        print(dumps(tables), end="")
    for path in stale:
        print("%s %s" % ("rewrote" if args.write else "stale:", os.path.relpath(path, REPO)))
    return 1 if stale and not args.write else 0
