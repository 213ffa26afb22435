"""The package's shape, read from its source: every module in a room, no import cycle
between modules, rooms that import only the rooms below them (the method's `core` imports
nothing outside itself), the one-way promises within them, and no function longer than
150 lines."""

from __future__ import annotations

import ast
import os
import subprocess
import sys

import pytest

ROOT = os.path.join(os.path.dirname(__file__), os.pardir)
PACKAGE = os.path.join(ROOT, "wcac_jax")
MAX_FUNCTION_LINES = 150


def _modules() -> dict[str, str]:
    """`{"wcac_jax.sweep.run": path, ...}` for every module of the package."""
    out = {}
    for root, _, files in os.walk(PACKAGE):
        for f in files:
            if f.endswith(".py"):
                path = os.path.join(root, f)
                rel = os.path.relpath(path, ROOT)[: -len(".py")].split(os.sep)
                if rel[-1] == "__init__":
                    rel = rel[:-1]
                out[".".join(rel)] = path
    return out


MODULES = _modules()


def _targets(node) -> list[str]:
    """The package modules an import statement names: `from wcac_jax.core import runtime`
    names `wcac_jax.core.runtime`; `from wcac_jax import make_train` (a name the package
    re-exports) names `wcac_jax` itself."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names if a.name in MODULES]
    if not (isinstance(node, ast.ImportFrom) and node.module and node.level == 0):
        return []
    if node.module not in MODULES:
        return []
    subs = [f"{node.module}.{a.name}" for a in node.names]
    return [t for t in subs if t in MODULES] + (
        [node.module] if any(t not in MODULES for t in subs) else []
    )


def _imports(name: str) -> set[str]:
    """The package modules `name` imports at module level or in any function."""
    tree = ast.parse(open(MODULES[name]).read())
    found = {t for node in ast.walk(tree) for t in _targets(node) if t != name}
    # a module imports its package's __init__ too; the top one's only for a re-exported name
    return {t for t in found if t == "wcac_jax" or not name.startswith(t + ".")}


GRAPH = {name: _imports(name) for name in MODULES}


# each room, and the rooms below it that it may import (besides itself): the method's
# pieces at the bottom; the tasks and the updates on them; the numpy-only front metrics and
# protocols apart; the host side (files, clocks, processes, command lines) on top
ROOMS = {
    "wcac_jax.core": (),
    "wcac_jax.envs": ("wcac_jax.core",),
    "wcac_jax.algos": ("wcac_jax.core",),
    "wcac_jax.pareto": (),
    "wcac_jax.protocols": ("wcac_jax.pareto",),
    "wcac_jax.sweep": (
        "wcac_jax.core",
        "wcac_jax.envs",
        "wcac_jax.algos",
        "wcac_jax.pareto",
        "wcac_jax.protocols",
    ),
    "wcac_jax.evaluate": (
        "wcac_jax.core",
        "wcac_jax.envs",
        "wcac_jax.algos",
        "wcac_jax.protocols",
        "wcac_jax.sweep",
    ),
    "wcac_jax.recsys": ("wcac_jax.core", "wcac_jax.sweep"),
}
HOST = ("wcac_jax.sweep", "wcac_jax.evaluate", "wcac_jax.recsys")


def _room(name: str) -> str | None:
    return next((r for r in ROOMS if name == r or name.startswith(r + ".")), None)


def test_the_package_is_read():
    assert {"wcac_jax.sweep.run", "wcac_jax.core.runtime", "wcac_jax.envs.base"} <= set(MODULES)
    assert "wcac_jax.core.runtime" in GRAPH["wcac_jax.algos.practical"]
    assert "wcac_jax.core.scalarize" in GRAPH["wcac_jax.envs.tabular"]


def test_every_module_is_in_a_room():
    """The top level holds the lazy `__init__` and the rooms, nothing else."""
    assert [name for name in MODULES if name != "wcac_jax" and _room(name) is None] == []


def test_rooms_import_only_the_rooms_below_them():
    """A module imports modules of its own room and of the rooms `ROOMS` puts below it,
    by their own path (not the names `wcac_jax` re-exports for users): `core` imports
    nothing of the package outside itself, so the method never depends on the tasks,
    the updates or the host side."""
    offenders = [
        f"{name}: {target}"
        for name, targets in GRAPH.items()
        if name != "wcac_jax"
        for target in targets
        if _room(target) != _room(name) and _room(target) not in ROOMS[_room(name)]
    ]
    assert not offenders


def test_the_rooms_stack():
    """The rooms' own graph has no cycle, and nothing below the host side imports it."""
    order = []  # rooms, each after every room it may import
    while len(order) < len(ROOMS):
        ready = [r for r in ROOMS if r not in order and set(ROOMS[r]) <= set(order)]
        assert ready, f"a cycle among {sorted(set(ROOMS) - set(order))}"
        order += ready
    for room in set(ROOMS) - set(HOST):
        assert not set(ROOMS[room]) & set(HOST), room


def test_the_lazy_names_point_at_their_rooms():
    """`wcac_jax` and `wcac_jax.sweep` load their names on first use (PEP 562) from the
    module that defines each: every entry of their tables is a module of the package."""
    import wcac_jax
    import wcac_jax.sweep

    assert set(wcac_jax._MODULES.values()) | set(wcac_jax._NAMES.values()) <= set(MODULES)
    sweep = {
        f"wcac_jax.sweep.{m}" for m in (*wcac_jax.sweep._MODULES, *wcac_jax.sweep._NAMES.values())
    }
    assert sweep <= set(MODULES)


def test_no_import_cycle():
    """`python -m wcac_jax.sweep` must not execute a module twice, and the rooms of the
    house stack: a cycle would tie two of them into one."""
    state: dict[str, int] = {}
    cycles = []

    def visit(node, path):
        state[node] = 1
        for nxt in sorted(GRAPH[node]):
            if state.get(nxt) == 1:
                cycles.append(path[path.index(nxt) :] + [nxt])
            elif nxt not in state:
                visit(nxt, path + [nxt])
        state[node] = 2

    for name in sorted(GRAPH):
        if name not in state:
            visit(name, [name])
    assert not cycles


@pytest.mark.parametrize(
    "low, high",
    [
        ("wcac_jax.core.scalarize", "flax"),
        ("wcac_jax.pareto", "jax"),
        ("wcac_jax.protocols", "jax"),
        ("wcac_jax.envs", "wcac_jax.core.runtime"),
        ("wcac_jax.envs", "wcac_jax.core.actor"),
        ("wcac_jax.envs", "wcac_jax.core.critic"),
        ("wcac_jax.sweep", "wcac_jax.sweep.cli"),
    ],
)
def test_dependencies_point_one_way(low, high):
    """Modules under `low` never import `high` (nor any module under it) unless they are
    `high`; a package's `__main__`, the command at the edge, may. Within the rooms: the
    scalarizations and the front's numbers stay light, the tasks use none of the method's
    training steps, and the command line is the sweep's edge."""
    offenders = []
    for name, path in MODULES.items():
        if name != low and not name.startswith(low + ".") or name.endswith(".__main__"):
            continue
        if name == high or name.startswith(high + "."):
            continue
        tree = ast.parse(open(path).read())
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                mods = [node.module]
            else:
                continue
            offenders += [f"{name}: {m}" for m in mods if m == high or m.startswith(high + ".")]
    assert not offenders


def test_no_function_over_150_lines():
    long = []
    for name, path in MODULES.items():
        for node in ast.walk(ast.parse(open(path).read())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                lines = node.end_lineno - node.lineno + 1
                if lines > MAX_FUNCTION_LINES:
                    long.append(f"{name}.{node.name}: {lines} lines")
    assert not long


def test_the_front_metrics_load_without_jax():
    """The package loads its names on first use: the numpy-only metrics import neither
    JAX nor a physics engine, so that scripts that read results stay light."""
    code = "import wcac_jax.pareto, sys; assert 'jax' not in sys.modules, 'jax'; " + (
        "assert 'mujoco' not in sys.modules, 'mujoco'"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout == done.stderr == ""


def test_docs_tables_computes_with_the_package_metrics():
    """`docs/tables.py` computes the non-dominated set, hypervolume and rank correlation
    with `wcac_jax.pareto`, not with copies of its own."""
    tree = ast.parse(open(os.path.join(ROOT, "docs", "tables.py")).read())
    imported = {
        (node.module, a.name)
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom)
        for a in node.names
    }
    assert ("wcac_jax", "pareto") in imported
    loops = [  # a module-level function of that name with a loop of its own
        node.name
        for node in tree.body
        if isinstance(node, ast.FunctionDef)
        and node.name in ("nondominated", "hypervolume", "spearman", "ranks")
        and any(isinstance(n, ast.For | ast.While | ast.comprehension) for n in ast.walk(node))
    ]
    assert not loops
