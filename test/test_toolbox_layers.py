"""The Python toolbox (scripts/laserscan_toolbox) is layered: ``ros``, ``parameter_tables`` and
``config_check`` (on ``parameter_tables``) at the bottom, ``simulation`` on ``ros``, ``evaluation`` on those, ``experiments`` on top. Every import of
a toolbox module (at module level or inside a function) goes to its own part or a lower one, no
modules import each other round a cycle, and every module imports."""
import ast
import importlib
import os

import pytest

SCRIPTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts")
PACKAGE = "laserscan_toolbox"

# part -> the other parts its modules may import
ALLOWED = {
    "ros": set(),
    "parameter_tables": set(),
    "config_check": {"parameter_tables"},
    "simulation": {"ros"},
    "evaluation": {"simulation", "ros", "config_check", "parameter_tables"},
    "experiments": {"evaluation", "simulation", "ros", "config_check", "parameter_tables"},
}


def toolbox_sources():
    """{module name: (source, is_package)} of every module of the toolbox."""
    out = {}
    for folder, _, files in os.walk(os.path.join(SCRIPTS, PACKAGE)):
        for f in files:
            if f.endswith(".py"):
                path = os.path.join(folder, f)
                name = os.path.relpath(path, SCRIPTS)[:-3].split(os.sep)
                is_package = name[-1] == "__init__"
                with open(path) as src:
                    out[".".join(name[:-1] if is_package else name)] = (src.read(), is_package)
    return out


def dependencies(sources):
    """{module: toolbox modules it imports anywhere} from toolbox_sources()' layout."""
    deps = {}
    for name, (source, is_package) in sources.items():
        package = name if is_package else name.rpartition(".")[0]
        found = set()
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.Import):
                found.update(a.name for a in node.names)
            elif isinstance(node, ast.ImportFrom):
                target = node.module
                if node.level:
                    base = package.split(".")[:package.count(".") + 2 - node.level]
                    target = ".".join(base + ([node.module] if node.module else []))
                for a in node.names:  # "from package import module" imports package.module
                    sub = target + "." + a.name
                    found.add(sub if sub in sources else target)
        deps[name] = {m for m in found if m.split(".")[0] == PACKAGE} - {name}
    return deps


def part_of(module):
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


def layer_errors(deps):
    """(module, imported module) pairs where a part imports one it may not."""
    return sorted((m, d) for m, ds in deps.items() for d in ds
                  if part_of(d) != part_of(m) and part_of(d) not in ALLOWED.get(part_of(m), ()))


def find_cycle(deps):
    """One import cycle as a list of modules (first == last), or None."""
    done, path = set(), []

    def visit(m):
        if m in path:
            return path[path.index(m):] + [m]
        if m in done:
            return None
        path.append(m)
        for d in sorted(deps.get(m, ())):
            cycle = visit(d)
            if cycle:
                return cycle
        path.pop()
        done.add(m)
        return None

    for m in sorted(deps):
        cycle = visit(m)
        if cycle:
            return cycle
    return None


def test_every_module_is_in_a_part():
    assert {part_of(m) for m in toolbox_sources()} - {None} == set(ALLOWED)


def test_imports_go_down_the_layers_only():
    deps = dependencies(toolbox_sources())
    assert any(deps.values())  # the scan found the toolbox's imports
    assert layer_errors(deps) == []


def test_no_import_cycles():
    assert find_cycle(dependencies(toolbox_sources())) is None


def test_the_checks_see_upward_imports_and_cycles():
    # What the tests above rely on: relative and absolute imports resolved, imports inside
    # functions seen, "from package import module" taken as the module.
    sources = {
        PACKAGE: ("", True),
        PACKAGE + ".ros": ("", True),
        PACKAGE + ".ros.rosrun": ("def f():\n    from ..evaluation import playback\n", False),
        PACKAGE + ".simulation.scenario": ("from ..ros import rosrun\nfrom . import world\n", False),
        PACKAGE + ".simulation.world": ("from .scenario import Scenario\n", False),
        PACKAGE + ".evaluation.playback": ("from ..experiments.cpu import simulate\n", False),
        PACKAGE + ".experiments.cpu": ("import laserscan_toolbox.evaluation.playback\n", False),
    }
    deps = dependencies(sources)
    assert deps[PACKAGE + ".simulation.scenario"] == {PACKAGE + ".ros.rosrun",
                                                      PACKAGE + ".simulation.world"}
    assert layer_errors(deps) == [
        (PACKAGE + ".evaluation.playback", PACKAGE + ".experiments.cpu"),
        (PACKAGE + ".ros.rosrun", PACKAGE + ".evaluation.playback")]
    assert find_cycle(deps) in ([PACKAGE + ".evaluation.playback", PACKAGE + ".experiments.cpu",
                                 PACKAGE + ".evaluation.playback"],
                                [PACKAGE + ".simulation.scenario", PACKAGE + ".simulation.world",
                                 PACKAGE + ".simulation.scenario"])


@pytest.mark.parametrize("module", sorted(toolbox_sources()))
def test_every_module_imports(module):
    importlib.import_module(module)
