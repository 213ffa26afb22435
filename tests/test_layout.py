"""The package's shape, read from its source: no import cycle between its modules, the
one-way dependencies its modules promise, and no function longer than 150 lines."""

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


def _imports(name: str) -> set[str]:
    """The package modules `name` imports at module level or in any function."""
    tree = ast.parse(open(MODULES[name]).read())
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            targets = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
        else:
            continue
        found.update(t for t in targets if t in MODULES and t != name)
    # a module imports its package's __init__ too
    return {t for t in found if not name.startswith(t + ".")}


GRAPH = {name: _imports(name) for name in MODULES}


def test_the_package_is_read():
    assert {"wcac_jax.sweep.run", "wcac_jax.core.runtime", "wcac_jax.envs.base"} <= set(MODULES)
    assert "wcac_jax.core.runtime" in GRAPH["wcac_jax.algos.practical"]


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
        ("wcac_jax.envs", "wcac_jax.algos"),
        ("wcac_jax.envs", "wcac_jax.core.runtime"),
        ("wcac_jax.envs", "wcac_jax.sweep"),
        ("wcac_jax.core.runtime", "wcac_jax.algos"),
        ("wcac_jax.core.runtime", "wcac_jax.sweep"),
        ("wcac_jax.algos", "wcac_jax.sweep"),
        ("wcac_jax.sweep", "wcac_jax.sweep.cli"),
    ],
)
def test_dependencies_point_one_way(low, high):
    """Modules under `low` never import `high` (nor any module under it); a package's
    `__main__`, the command at the edge, may."""
    offenders = []
    for name, path in MODULES.items():
        if name != low and not name.startswith(low + ".") or name.endswith(".__main__"):
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
