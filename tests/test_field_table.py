"""experiments/field.py's table: each task's seeds against the published numbers of the same
protocol, definition and budget, the mean and interval by hand, and its refusals (another
definition, another budget, a run off its protocol, a written score that is not the
front's)."""

import copy
import importlib.util
import json
import os
import sys

import numpy as np
import pytest

from wcac_jax import protocols

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "experiments"))  # the scripts' shared script_io
_spec = importlib.util.spec_from_file_location(
    "field", os.path.join(ROOT, "experiments", "field.py")
)
field = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(field)

# a front of two points per seed, discounted returns (a, b): against (-100, -100) its
# HV is (a + 100)(b + 100) for one point; two points (100, 0) and (0, 100) give
# 200 * 100 + 100 * 200 - 100 * 100 = 3e4, and (200, 0), (0, 200) 300 * 100 * 2 - 1e4 = 5e4
FRONTS = {0: [[100.0, 0.0], [0.0, 100.0]], 1: [[200.0, 0.0], [0.0, 200.0]]}


def _front(seed: int, points) -> dict:
    prefs = protocols.CMORL.eval_prefs(2)
    rows = [
        {"pref": p.tolist(), "discounted_return": points[0] if p[0] >= 0.5 else points[1]}
        for p in prefs
    ]
    front = {
        "config": {
            "protocol": "cmorl",
            "env": "hopper-2obj",
            "seed": seed,
            "eval_episodes": 5,
            "env_options": {"episode_length": 500},
            "train": {"num_iterations": 183},
        },
        "prefs": rows,
        "env_steps_total": 183 * 8192,
        "eval_gamma": 0.99,
        "wall_s": 100.0 + seed,
        "conditioned": {"eval_env_steps": 252_500},
    }
    front["protocol"] = protocols.front_scores(front)
    return front


def _published(**changes) -> dict:
    entry = {
        "protocol": "cmorl",
        "task": "hopper-2obj",
        "definition": "mo-hopper-2obj-v5",
        "budget": 1_500_000,
        "method": "X",
        "hv": 5e4,
        "seeds": 5,
        "source": "a test",
    }
    return {"entries": [{**entry, **changes}]}


@pytest.fixture
def results(tmp_path):
    for seed, points in FRONTS.items():
        d = tmp_path / "cmorl" / "hopper-2obj" / f"seed{seed}"
        d.mkdir(parents=True)
        (d / "front.json").write_text(json.dumps(_front(seed, points)))
    (tmp_path / "published.json").write_text(json.dumps(_published()))
    return tmp_path


def test_table_row_by_hand(results):
    summary = field.summarize(str(results))
    (row,) = summary["rows"]
    assert [s["hv"] for s in row["seeds"]] == pytest.approx([3e4, 5e4])
    assert row["hv"]["mean"] == pytest.approx(4e4)
    # Student-t, 1 degree of freedom: 12.706 * std (1.414e4) / sqrt(2) = 12.706e4
    assert row["hv"]["ci95"] == pytest.approx([4e4 - 12.7062e4, 4e4 + 12.7062e4], rel=1e-4)
    assert row["best_published"] == {"method": "X", "hv": 5e4}
    assert row["ratio_to_best"] == pytest.approx(0.8)
    assert [s["wall_s"] for s in row["seeds"]] == [100.0, 101.0]
    assert row["seeds"][0]["env_steps_trained"] == 1_499_136 <= row["budget"]
    field.write_table(summary, str(results))
    table = (results / "table.md").read_text()
    assert "| cmorl | hopper-2obj | 2 | 4e+04" in table and "| X 5e+04 | 0.80" in table


@pytest.mark.parametrize(
    "changes,message",
    [
        ({"definition": "mo-hopper-2d-v4"}, "another task definition"),
        ({"budget": 3_000_000}, "another budget"),
    ],
)
def test_table_refuses_another_definition_or_budget(results, changes, message):
    (results / "published.json").write_text(json.dumps(_published(**changes)))
    with pytest.raises(field.TableError, match=message):
        field.summarize(str(results))
    assert field.main(["--results", str(results), "table"]) == 2
    assert not (results / "table.json").exists()


def test_table_refuses_a_run_off_its_protocol_or_a_stale_score(results):
    path = results / "cmorl" / "hopper-2obj" / "seed1" / "front.json"
    good = json.loads(path.read_text())
    off = copy.deepcopy(good)
    off["config"]["eval_episodes"] = 8
    path.write_text(json.dumps(off))
    with pytest.raises(field.TableError, match="8 evaluation episodes"):
        field.summarize(str(results))
    stale = copy.deepcopy(good)
    stale["prefs"][0]["discounted_return"] = [300.0, 0.0]  # a return changed after scoring
    path.write_text(json.dumps(stale))
    with pytest.raises(field.TableError, match="written hv"):
        field.summarize(str(results))


def _reference(results, seed: int, hv: float, deviations=()) -> None:
    d = results / "cmorl" / "hopper-2obj" / f"seed{seed}"
    score = {"hv": hv, "eu": 1.0, "nondominated": 2, "kept": 101}
    evaluated = {"mo_gymnasium": score, "project": score, "deviations": list(deviations)}
    (d / field.REFERENCE_EVAL).write_text(json.dumps({"protocol": evaluated}))


def test_table_sets_the_mo_gymnasium_evaluation_beside(results):
    """With every seed evaluated in MO-Gymnasium too: that HV's mean (3.5e4 and 4.5e4:
    4e4) and its ratio to the best published (5e4: 0.8) beside the project's; with one
    seed missing it, none; an evaluation off the protocol is refused."""
    _reference(results, 0, 3.5e4)
    (row,) = field.summarize(str(results))["rows"]
    assert row["hv_mo_gymnasium"] is None and row["seeds"][0]["mo_gymnasium"]["hv"] == 3.5e4
    _reference(results, 1, 4.5e4)
    (row,) = field.summarize(str(results))["rows"]
    assert row["hv_mo_gymnasium"]["mean"] == pytest.approx(4e4)
    assert row["hv_mo_gymnasium"]["ratio_to_best"] == pytest.approx(0.8)
    # Student-t, 1 degree of freedom: 12.706 * std (7,071) / sqrt(2) = 63,531
    lo, hi = row["hv_mo_gymnasium"]["ci95"]
    assert (lo, hi) == pytest.approx([4e4 - 63531, 4e4 + 63531], rel=1e-4)
    _reference(results, 1, 4.5e4, ["8 evaluation episodes, not 5"])
    with pytest.raises(field.TableError, match="evaluation_mo_gymnasium.json departs"):
        field.summarize(str(results))


def test_published_numbers_are_filed_on_their_definitions():
    """Every committed published number names a protocol's task, its definition and the
    protocol's budget: the committed table can set each beside ours."""
    with open(os.path.join(ROOT, "experiments", "results", "field", "published.json")) as f:
        entries = json.load(f)["entries"]
    assert entries
    for protocol in protocols.PROTOCOLS.values():
        for task in protocol.tasks:
            field.published_for(entries, protocol, task)  # raises on a mismatch
    keys = {(e["protocol"], e["task"]) for e in entries}
    tasks = {(p.name, t.env) for p in protocols.PROTOCOLS.values() for t in p.tasks}
    assert keys <= tasks
    assert np.all([e["hv"] > 0 for e in entries])


def test_run_resumes_a_front_written_before_its_evaluation(tmp_path, monkeypatch):
    """A conditioned run stopped between its training's `front.json` and the evaluation
    that replaces it goes back to the sweep with --resume; a scored run is left as it is."""
    calls = []
    monkeypatch.setattr(field.subprocess, "call", lambda cmd, cwd=None: calls.append(cmd) or 0)
    for seed, front in ((0, {"prefs": [], "env_steps_total": 8192}), (1, _front(1, FRONTS[1]))):
        d = tmp_path / "cmorl" / "hopper-2obj" / f"seed{seed}"
        d.mkdir(parents=True)
        (d / "front.json").write_text(json.dumps(front))
        (d / field.REFERENCE_EVAL).write_text("{}")
    status = field.run(str(tmp_path), "cmorl", "hopper-2obj", [0, 1], resume=True, overwrite=False)
    assert status == 0
    assert len(calls) == 1, calls
    out = str(tmp_path / "cmorl" / "hopper-2obj" / "seed0")
    assert calls[0][calls[0].index("--out") + 1] == out
    assert "--resume" in calls[0]
