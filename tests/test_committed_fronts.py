"""Every committed front's numbers, recomputed from its raw returns by code that shares
nothing with the summariser (`wcac_jax.pareto`, `outputs.summarize`, the experiments'
summaries): pymoo's hypervolume, scipy's Spearman correlation and a pairwise dominance
check written here. A wrong committed number, or a summariser that drifts from the
definitions, fails here.
"""

from __future__ import annotations

import glob
import json
import os

import numpy as np
import pytest
from pymoo.indicators.hv import HV
from scipy.stats import spearmanr

RESULTS = os.path.join(os.path.dirname(__file__), os.pardir, "experiments", "results")
FRONTS = sorted(
    os.path.relpath(p, RESULTS)
    for p in glob.glob(os.path.join(RESULTS, "**", "front.json"), recursive=True)
)
SUMMARIES = sorted(
    os.path.relpath(p, RESULTS)
    for p in glob.glob(os.path.join(RESULTS, "**", "summary.json"), recursive=True)
)
# float64 sums of the same JSON values in another order
RTOL = 1e-9


def _load(rel: str) -> dict:
    with open(os.path.join(RESULTS, rel)) as f:
        return json.load(f)


def _nondominated(points: np.ndarray) -> np.ndarray:
    """Maximisation; of identical non-dominated points the first row counts."""
    n = len(points)
    keep = np.ones(n, dtype=bool)
    for i in range(n):
        for j in range(n):
            if i == j:
                continue
            if np.all(points[j] >= points[i]) and np.any(points[j] > points[i]):
                keep[i] = False
            elif j < i and np.array_equal(points[j], points[i]):
                keep[i] = False
    return keep


def _hypervolume(points: np.ndarray, ref) -> float:
    ref = np.asarray(ref, dtype=np.float64)
    inside = points[np.all(points > ref, axis=1)]
    if len(inside) == 0:
        return 0.0
    return float(HV(ref_point=-ref)(-inside))


def _expected_utility_2d(points: np.ndarray) -> float:
    # 101 evenly spaced weight vectors (w, 1 - w) on the 2-simplex
    w = np.linspace(0.0, 1.0, 101)
    weights = np.stack([w, 1.0 - w], axis=1)
    return float(np.mean(np.max(weights @ points.T, axis=1)))


def _sparsity(points: np.ndarray) -> float:
    front = points[_nondominated(points)]
    if len(front) < 2:
        return 0.0
    total = sum(np.sum(np.diff(np.sort(front[:, j])) ** 2) for j in range(front.shape[1]))
    return float(total / (len(front) - 1))


def test_results_hold_fronts():
    assert len(FRONTS) >= 100 and len(SUMMARIES) >= 50


@pytest.mark.parametrize("rel", FRONTS)
def test_front_numbers_are_what_its_returns_give(rel):
    front = _load(rel)
    returns = np.array([row["return"] for row in front["prefs"]], dtype=np.float64)
    disc = np.array([row["discounted_return"] for row in front["prefs"]], dtype=np.float64)
    ref = front["hv_ref"]
    nd = _nondominated(returns)
    assert [row["nondominated"] for row in front["prefs"]] == nd.tolist()
    assert front["cardinality"] == int(nd.sum())
    outside = [i for i, r in enumerate(returns) if not np.all(r > np.asarray(ref))]
    if "outside_hv_ref" in front:  # fronts written before it was recorded lack it
        assert front["outside_hv_ref"] == outside
        assert [row["inside_hv_ref"] for row in front["prefs"]] == [
            i not in outside for i in range(len(returns))
        ]
    assert front["hypervolume"] == pytest.approx(_hypervolume(returns, ref), rel=RTOL)
    assert front["hypervolume_discounted"] == pytest.approx(_hypervolume(disc, ref), rel=RTOL)
    assert front["sparsity"] == pytest.approx(_sparsity(returns), rel=RTOL, abs=1e-9)
    if returns.shape[1] == 2:
        assert front["expected_utility"] == pytest.approx(_expected_utility_2d(returns), rel=RTOL)
    if "conditioned" in front:  # one network for every preference: the training's steps
        assert front["env_steps_per_pref"] is None and front["conditioned"]["networks"] == 1
    else:
        assert front["env_steps_total"] == front["env_steps_per_pref"] * len(returns)


def _direction_front(summary_rel: str, direction: str) -> dict | None:
    rel = os.path.join(os.path.dirname(summary_rel), direction, "front.json")
    return _load(rel) if os.path.exists(os.path.join(RESULTS, rel)) else None


@pytest.mark.parametrize("rel", SUMMARIES)
def test_summary_numbers_are_what_its_fronts_returns_give(rel):
    summary = _load(rel)
    checked = 0
    for direction, s in summary.get("directions", {}).items():
        front = _direction_front(rel, direction)
        if front is None:
            continue
        checked += 1
        returns = np.array([row["return"] for row in front["prefs"]], dtype=np.float64)
        prefs = np.array([row["pref"] for row in front["prefs"]], dtype=np.float64)
        assert s["hypervolume"] == pytest.approx(_hypervolume(returns, s["hv_ref"]), rel=RTOL)
        for entry in s.get("hypervolume_by_ref", []):
            assert entry["hypervolume"] == pytest.approx(
                _hypervolume(returns, entry["hv_ref"]), rel=RTOL
            )
            assert entry["outside"] == [
                i for i, r in enumerate(returns) if not np.all(r > np.asarray(entry["hv_ref"]))
            ]
        assert s["cardinality"] == int(_nondominated(returns).sum())
        if "distinct_points" in s:
            assert s["distinct_points"] == len(np.unique(returns, axis=0))
        if "pref0_forward_rank_correlation" in s:
            rho = spearmanr(prefs[:, 0], returns[:, 0]).statistic
            assert s["pref0_forward_rank_correlation"] == pytest.approx(rho, rel=RTOL)
        for policy, row in zip(s.get("policies", []), front["prefs"], strict=True):
            assert policy["pref"] == row["pref"]
            assert [policy["forward_return"], policy["control_return"]] == row["return"]
            assert policy["episode_length"] == row["episode_length"]
    assert checked == len(summary.get("directions", {})), "a direction has no front.json"
