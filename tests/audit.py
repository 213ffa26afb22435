"""Every stated number of the committed results, recomputed from raw returns and lengths.

The audit reads every `front.json` under `experiments/results/` (found by walking the
tree; each must belong to one entry of `FAMILIES`), the summaries and tables written
beside them, and the numbers that README.md and docs/*.md print, and checks each stated
number against its own recomputation from the raw data: the evaluated returns
(undiscounted and discounted), the mean episode lengths, the preferences and the
recorded measurements (mean x velocity, wall seconds, env steps). It computes with numpy,
scipy's Spearman correlation, Student-t quantile, root finding, convex hull and
least-squares line, pymoo's hypervolume and the definitions written here (the field's
protocols, `FIELD_PROTOCOLS`, as docs/protocols.md states them, their weight grids built
as the published code builds them, `published_grid`; the published numbers as COLA's
and D3PO's tables print them, `COLA_TABLE_1` and `D3PO_TABLE`); it imports nothing of
`wcac_jax`, `experiments/` or `docs/tables.py`, so a wrong number in a summary, or a
summariser that drifts from the definitions, cannot pass by agreeing with itself.

`audit(root)` returns one line per stated number its data does not give (empty when
all agree); `tests/test_audit.py` runs it on the repository and on copies with planted
errors. A new family of results is one `Family` entry: the glob of its fronts, the
reference point each `front.json` states its own hypervolume at, and `(glob, check)`
pairs for the files its numbers feed; a check scores the fronts under a `Convention`
(`C_MORL`, `PGMORL`, or a new one) and compares what the file states, e.g.

    Family("field.py: ...", ("field/*/*/seed*/front.json", ...), V5_TASKS | PGMORL_TASKS,
           (("field/table.json", check_field_table), ...), own=check_protocol_front)

where `own` is what each front states of itself (`check_front`, and here its protocol's
scores too). A file of evaluated returns that is not a training's front (an evaluation
of a run's policies elsewhere, `mo_gymnasium_eval/`) belongs to a family with no
reference (`hv_ref=None`) and a check of its own kind.

The problems with known answers are recomputed from their raw data too
(`check_known_answers`): exploration.json from the concave bandit's learned angles and
Deep Sea Treasure's learned policies' exact returns, with each problem's answers (its
preferences' optima, its front and the front's hypervolume) derived here from the
problem's definition; convergence.json from its measured gaps.

A front that no family claims, or a generated block of the documents that no entry of
`DOC_TABLES` / `DOC_VALUES` names, is itself a finding. One count is accepted short of
what its data give on the fronts named, and only there: the field's first fronts state a
conditioned network's evaluation env steps as the earlier code counted them, truncated
by up to one step per episode; `EARLIER_EVAL_STEPS` lists each by path with the steps it
states fewer (`eval_steps`, `check_earlier_eval_steps`).
"""

from __future__ import annotations

import glob
import itertools
import json
import math
import os
import re
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from functools import cache, cached_property

import numpy as np
from pymoo.indicators.hv import HV
from scipy.optimize import brentq
from scipy.spatial import ConvexHull
from scipy.stats import linregress, spearmanr
from scipy.stats import t as student_t

RESULTS = "experiments/results"
# float64 sums of the same JSON values in another order
RTOL = 1e-9

# ---------------------------------------------------------------------- metrics


def nondominated(points) -> np.ndarray:
    """`[n]` mask of the non-dominated rows of `points` `[n, m]` (maximised); of identical
    non-dominated points the first row counts."""
    pts = np.asarray(points, np.float64)
    keep = np.ones(len(pts), dtype=bool)
    for i, p in enumerate(pts):
        dominated = np.all(pts >= p, axis=1) & np.any(pts > p, axis=1)
        repeated = np.all(pts[:i] == p, axis=1)
        keep[i] = not (dominated.any() or repeated.any())
    return keep


def hypervolume(points, ref) -> float:
    """pymoo's exact hypervolume of the points that strictly dominate `ref` (maximised)."""
    pts, ref = np.asarray(points, np.float64), np.asarray(ref, np.float64)
    inside = pts[np.all(pts > ref, axis=1)]
    return 0.0 if len(inside) == 0 else float(HV(ref_point=-ref)(-inside))


def outside(points, ref) -> list[int]:
    """The rows that do not strictly dominate `ref` (they add nothing to the volume)."""
    pts = np.asarray(points, np.float64)
    return [i for i, p in enumerate(pts) if not np.all(p > np.asarray(ref))]


def spearman(x, y) -> float:
    return float(spearmanr(x, y).statistic)


def expected_utility(points, weights) -> float:
    """The mean over the weight vectors `w` of `max_j w . J_j`."""
    return float(np.mean(np.max(np.asarray(weights) @ np.asarray(points, np.float64).T, axis=1)))


def weight_grid(m: int, step: float) -> np.ndarray:
    """Every weight vector on the `m`-simplex whose entries are multiples of `step`."""
    h = round(1 / step)
    rows = [c for c in itertools.product(range(h + 1), repeat=m) if sum(c) == h]
    return np.array(rows, np.float64) / h


@cache
def published_grid(m: int, step: float) -> np.ndarray:
    """The grid of weights (or preferences) as the field's published code builds it: every
    combination of `np.arange(0, 1 + step, step)` over the `m` objectives whose float
    sum, left to right, is exactly 1 (the lattice points whose rounded coordinates do not
    add up to 1 exactly are dropped: 62 of 66 for three objectives at step 0.1), in
    lexicographic order."""
    axis = np.arange(0.0, 1.0 + step, step).tolist()
    grid = np.array([c for c in itertools.product(axis, repeat=m) if sum(c) == 1.0], np.float64)
    grid.flags.writeable = False  # one array for every caller
    return grid


def front_json_weights(m: int, n: int = 101) -> np.ndarray:
    """The weights of `front.json`'s `expected_utility`, as docs/outputs.md defines them:
    `n` evenly spaced vectors for two objectives; for more, the smallest simplex lattice
    (step `1/h`) with at least `n` points, thinned to `n` by farthest-point sampling that
    keeps the corners (lattice in reverse lexicographic order, ties to the first)."""
    if m == 2:
        t = np.linspace(1.0, 0.0, n)
        return np.stack([t, 1 - t], axis=1)
    h = 1
    while math.comb(h + m - 1, m - 1) < n:
        h += 1
    grid = weight_grid(m, 1 / h)[::-1]
    chosen = [i for i, w in enumerate(grid) if np.isclose(w.max(), 1.0)][:n]
    while len(chosen) < n:
        gaps = np.linalg.norm(grid[:, None] - grid[chosen][None], axis=-1).min(axis=1)
        chosen.append(int(np.argmax(gaps)))
    return grid[sorted(chosen)]


def sparsity(points) -> float:
    """PGMORL's sparsity of the non-dominated set: per objective the squared gaps between
    sorted neighbours, summed, over `n - 1`."""
    front = np.asarray(points, np.float64)[nondominated(points)]
    if len(front) < 2:
        return 0.0
    return float(np.sum(np.diff(np.sort(front, axis=0), axis=0) ** 2) / (len(front) - 1))


# ---------------------------------------------------------------------- fronts

# Every evaluation of the committed fronts cuts its episodes at 500 steps; 8 episodes per
# preference where a front records no other (`config.eval_episodes`).
EPISODES, T = 8, 500


@dataclass
class Front:
    """One `front.json`: its raw data, read once."""

    path: str  # relative to the repository
    data: dict

    @cached_property
    def prefs(self) -> np.ndarray:
        return np.array([r["pref"] for r in self.data["prefs"]], np.float64)

    @cached_property
    def returns(self) -> np.ndarray:
        return np.array([r["return"] for r in self.data["prefs"]], np.float64)

    @cached_property
    def discounted(self) -> np.ndarray:
        return np.array([r["discounted_return"] for r in self.data["prefs"]], np.float64)

    @cached_property
    def lengths(self) -> np.ndarray:
        return np.array([r["episode_length"] for r in self.data["prefs"]], np.float64)

    @property
    def env(self) -> str:
        return self.data["env"]

    @property
    def episodes(self) -> int:
        """The evaluation's episodes per preference (`EPISODES` where none is recorded)."""
        return int(self.data.get("config", {}).get("eval_episodes", EPISODES))

    @cached_property
    def nd(self) -> np.ndarray:
        return nondominated(self.returns)

    def hv(self, ref) -> float:
        return hypervolume(self.returns, ref)

    @cached_property
    def rho(self) -> float:
        """Spearman's rank correlation of `p0` with the first objective's return."""
        return spearman(self.prefs[:, 0], self.returns[:, 0])

    def row(self, pref) -> int:
        return [list(p) for p in self.prefs.tolist()].index([float(v) for v in pref])

    @property
    def forward(self) -> int:
        """The forward end: the preference with all weight on the first objective."""
        return self.row([1.0] + [0.0] * (self.prefs.shape[1] - 1))

    @property
    def control(self) -> int:
        return self.row([0.0, 1.0])

    def speed(self, i: int) -> tuple[float, float]:
        return walker_speed(self.returns[i, 0], self.lengths[i], self.episodes)

    def control_per_step(self, i: int) -> tuple[float, float]:
        return walker_control(self.returns[i, 1], self.lengths[i], self.episodes)

    def mean_x_velocity(self, i: int) -> float:
        return float(self.data["prefs"][i]["mean_x_velocity"])

    def final(self) -> Front:
        """The same training's final policies (a front that chose among its last ones)."""
        sel = self.data["selection"]
        rows = [
            {**r, "return": ret, "episode_length": n}
            for r, ret, n in zip(
                self.data["prefs"], sel["final_return"], sel["final_length"], strict=True
            )
        ]
        return Front(self.path + " (final)", {**self.data, "prefs": rows})


def falls(length: float, episodes: int = EPISODES) -> tuple[float, float]:
    """The range of falls per episode that a mean length over `episodes` episodes allows:
    at least the episodes that cannot have lasted `T`, at most one each (an episode may
    fall on its last step and still last `T`)."""
    full = min(episodes, math.floor((episodes * length - episodes) / (T - 1)))
    return (episodes - max(full, 0)) / episodes, 1.0


def walker_speed(forward: float, length: float, episodes: int = EPISODES) -> tuple[float, float]:
    """Mean x velocity from a forward return of MO-Gymnasium's Walker2d (and Hopper):
    each step pays `x_velocity + healthy`, healthy 1 on every step but a falling one, so
    `R0 = L v + L - f` with `f` falls per episode; the range over the allowed `f`."""
    lo, hi = falls(length, episodes)
    return (forward - length + lo) / length, (forward - length + hi) / length


def walker_control(control: float, length: float, episodes: int = EPISODES) -> tuple[float, float]:
    """Control energy per step `sum a^2` from Walker2d's control return
    `R1 = -L c + L - f`: `c = (L - f - R1) / L`, over the allowed `f`."""
    lo, hi = falls(length, episodes)
    return (length - hi - control) / length, (length - lo - control) / length


# ---------------------------------------------------------------------- conventions


@dataclass(frozen=True)
class Convention:
    """How a hypervolume (and expected utility) of the field is computed from a front.

    `discounted`: the discounted returns, else the undiscounted ones; `ref`: the
    reference point's value on every objective; `offsets`: per task, a constant per step
    added to each objective (`None`: that objective as it is), times the mean length;
    `eu_step`: the weight grid's step per number of objectives (none: no EU stated), the
    grid the published code's (`published_grid`) with `float_sum_grid`, else the whole
    lattice; `gamma`: the discount the discounted returns must have been taken at (a
    front's `eval_gamma`, else its training's; 1 for undiscounted); `drop_negative`:
    points with a negative objective are dropped before scoring."""

    name: str
    discounted: bool
    ref: float
    offsets: dict = field(default_factory=dict)
    eu_step: dict = field(default_factory=dict)
    gamma: float = 0.99
    drop_negative: bool = False
    float_sum_grid: bool = False

    @property
    def returns(self) -> str:
        """The rows' field scored."""
        return "discounted_return" if self.discounted else "return"

    def weights(self, m: int) -> np.ndarray:
        step = self.eu_step[m]
        return published_grid(m, step) if self.float_sum_grid else weight_grid(m, step)

    def points(self, front: Front) -> np.ndarray:
        if self.discounted:
            train = front.data.get("config", {}).get("train", {})
            gamma = front.data.get("eval_gamma", train.get("gamma", self.gamma))
            if gamma != self.gamma:
                raise ValueError(
                    f"{front.path}: discounted at {gamma}, {self.name} at {self.gamma}"
                )
        pts = (front.discounted if self.discounted else front.returns).copy()
        for j, c in enumerate(self.offsets.get(front.env, ())):
            if c is not None:
                pts[:, j] += c * front.lengths
        return pts

    def kept(self, points) -> np.ndarray:
        pts = np.asarray(points, np.float64)
        return pts[np.all(pts >= 0.0, axis=1)] if self.drop_negative else pts

    def hv(self, front: Front) -> float:
        pts = self.kept(self.points(front))
        return hypervolume(pts, [self.ref] * front.returns.shape[1]) if len(pts) else 0.0

    def eu(self, front: Front) -> float:
        return self.score(self.points(front))["eu"]

    def score(self, points) -> dict:
        """`{"hv", "eu", "nondominated", "kept"}` of the objective vectors `points` (no
        offsets): the hypervolume and expected utility of the points kept (none kept: 0
        and 0), the distinct non-dominated ones among those that strictly dominate the
        reference, and how many were kept."""
        pts = self.kept(points)
        if len(pts) == 0:
            return {"hv": 0.0, "eu": 0.0, "nondominated": 0, "kept": 0}
        ref = [self.ref] * pts.shape[1]
        inside = pts[np.all(pts > np.asarray(ref), axis=1)]
        return {
            "hv": hypervolume(pts, ref),
            "eu": expected_utility(pts, self.weights(pts.shape[1])),
            "nondominated": int(nondominated(inside).sum()) if len(inside) else 0,
            "kept": len(pts),
        }


# morl-baselines': discounted at 0.99, -100 per objective, EU over the lattice of step
# 0.01 (two objectives) or 0.1 (three).
MORL_BASELINES = Convention("morl-baselines", True, -100.0, eu_step={2: 0.01, 3: 0.1})
# C-MORL's: morl-baselines' points and reference, its EU over its code's grid of those
# steps (62 weights of the lattice's 66 for three objectives).
C_MORL = Convention("C-MORL", True, -100.0, eu_step={2: 0.01, 3: 0.1}, float_sum_grid=True)
# PGMORL's and COLA's: undiscounted, points with a negative objective dropped, reference at
# the origin; EU over COLA's evaluation grid (step 0.005 for two objectives, 0.05 for
# three).
PGMORL = Convention(
    "PGMORL",
    False,
    0.0,
    eu_step={2: 0.005, 3: 0.05},
    gamma=1.0,
    drop_negative=True,
    float_sum_grid=True,
)

# ---------------------------------------------------------------------- findings


class Findings(list):
    """The audit's lines, one per stated number its data does not give."""

    def close(self, where: str, stated, expected, rel: float = RTOL, abs_: float = 1e-9):
        if stated is None or expected is None:
            if stated is not expected:
                self.append(f"{where}: states {stated!r}, its data give {expected!r}")
            return
        if not math.isclose(float(stated), float(expected), rel_tol=rel, abs_tol=abs_):
            self.append(f"{where}: states {stated!r}, its data give {expected!r}")

    def within(self, where: str, stated, lo: float, hi: float, slack: float = 1e-9):
        if stated is None or not lo - slack <= float(stated) <= hi + slack:
            self.append(f"{where}: states {stated!r}, its data give [{lo!r}, {hi!r}]")

    def equal(self, where: str, stated, expected):
        if stated != expected:
            self.append(f"{where}: states {stated!r}, its data give {expected!r}")

    def each(self, where: str, stated, expected, abs_: float):
        """Arrays of one shape, each stated value within `abs_` of its recomputation (NaN
        of NaN): one line, at the first that is not."""
        s, e = np.asarray(stated, np.float64), np.asarray(expected, np.float64)
        if s.shape != e.shape:
            self.append(f"{where}: states shape {s.shape}, its data give {e.shape}")
            return
        bad = np.argwhere(~np.isclose(s, e, rtol=0.0, atol=abs_, equal_nan=True))
        if len(bad):
            i = tuple(int(k) for k in bad[0])
            self.append(f"{where} {list(i)}: states {float(s[i])!r}, its data give {float(e[i])!r}")


@dataclass
class Repo:
    """The files the audit reads, under `root`, each read once."""

    root: str
    _json: dict = field(default_factory=dict)
    _fronts: dict = field(default_factory=dict)

    def exists(self, rel: str) -> bool:
        return os.path.exists(os.path.join(self.root, rel))

    def json(self, rel: str):
        if rel not in self._json:
            with open(os.path.join(self.root, rel)) as f:
                self._json[rel] = json.load(f)
        return self._json[rel]

    def text(self, rel: str) -> str:
        with open(os.path.join(self.root, rel)) as f:
            return f.read()

    def front(self, rel: str) -> Front:
        if rel not in self._fronts:
            self._fronts[rel] = Front(rel, self.json(rel))
        return self._fronts[rel]

    def glob(self, pattern: str) -> list[str]:
        full = glob.glob(os.path.join(self.root, pattern), recursive=True)
        return sorted(os.path.relpath(p, self.root) for p in full)

    def fronts(self) -> list[str]:
        """Every committed front, found by walking the results: each JSON file that holds
        evaluated preferences (`prefs` rows with a `return`), whatever its name."""
        found = []
        for d, _, names in os.walk(os.path.join(self.root, RESULTS)):
            for name in names:
                rel = os.path.relpath(os.path.join(d, name), self.root)
                if name.endswith(".json") and _is_front(self.json(rel)):
                    found.append(rel)
        return sorted(found)


def _is_front(data) -> bool:
    rows = data.get("prefs") if isinstance(data, dict) else None
    return (
        isinstance(rows, list) and bool(rows) and isinstance(rows[0], dict) and "return" in rows[0]
    )


# ---------------------------------------------------------------------- every front


def check_front(repo: Repo, rel: str, hv_ref) -> Findings:
    """What a `front.json` states of itself: its hypervolumes at its reference (which must
    be its family's), the policies outside it, the non-dominated flags and count,
    sparsity, expected utility and env steps."""
    f, out = repo.front(rel), Findings()
    d = f.data
    out.equal(f"{rel} hv_ref", [float(v) for v in d["hv_ref"]], [float(v) for v in hv_ref])
    out.close(f"{rel} hypervolume", d["hypervolume"], f.hv(hv_ref))
    out.close(
        f"{rel} hypervolume_discounted",
        d["hypervolume_discounted"],
        hypervolume(f.discounted, hv_ref),
    )
    out.equal(f"{rel} nondominated flags", [r["nondominated"] for r in d["prefs"]], f.nd.tolist())
    out.equal(f"{rel} cardinality", d["cardinality"], int(f.nd.sum()))
    gone = outside(f.returns, hv_ref)
    if "outside_hv_ref" in d:  # fronts written before it was recorded lack it
        out.equal(f"{rel} outside_hv_ref", d["outside_hv_ref"], gone)
        inside = [r["inside_hv_ref"] for r in d["prefs"]]
        out.equal(f"{rel} inside_hv_ref", inside, [i not in gone for i in range(len(inside))])
    out.close(f"{rel} sparsity", d["sparsity"], sparsity(f.returns))
    weights = front_json_weights(f.returns.shape[1])
    out.close(
        f"{rel} expected_utility", d["expected_utility"], expected_utility(f.returns, weights)
    )
    if "conditioned" in d:  # one network: the training's own steps, the evaluation's beside
        out.equal(f"{rel} env_steps_per_pref", d["env_steps_per_pref"], None)
        out.equal(f"{rel} networks", d["conditioned"]["networks"], 1)
        out.equal(f"{rel} eval_prefs", d["conditioned"]["eval_prefs"], len(f.prefs))
    else:
        out.equal(
            f"{rel} env_steps_total", d["env_steps_total"], d["env_steps_per_pref"] * len(f.prefs)
        )
    if d.get("config", {}).get("train", {}).get("kind"):  # older fronts do not record it
        out.extend(
            check_env_steps(
                f, rel, d["env_steps_total"], d.get("conditioned", {}).get("eval_env_steps")
            )
        )
    for i, r in enumerate(d["prefs"]):
        if "mean_x_velocity" in r:
            out.extend(check_velocity(f, i))
    return out


# Tasks whose forward return gives the mean x velocity: `x_velocity` per step plus a
# healthy reward of 1 (MO-Gymnasium's walker2d_v5, hopper_v5 with 3 objectives), or
# nothing else (half_cheetah_v5, swimmer_v5); the others add control or contact costs.
FORWARD_IS_VELOCITY_PLUS = {"walker2d": 1.0, "hopper": 1.0, "halfcheetah": 0.0, "swimmer": 0.0}


def check_velocity(f: Front, i: int) -> Findings:
    """A recorded mean x velocity agrees with the row's forward return and length."""
    out = Findings()
    healthy = FORWARD_IS_VELOCITY_PLUS.get(f.env)
    if healthy is None:
        return out
    v, (n, r0) = f.mean_x_velocity(i), (f.lengths[i], f.returns[i, 0])
    where = f"{f.path} row {i} mean_x_velocity"
    if healthy:
        lo, hi = walker_speed(r0, n, f.episodes)
    else:
        lo = hi = r0 / n
    # float32 sums over the episodes' steps
    out.within(where, v, lo, hi, slack=1e-4 * max(1.0, abs(v)))
    return out


# ---------------------------------------------------------------------- summaries


def check_walker2d_front_summary(repo: Repo, rel: str) -> Findings:
    """A `walker2d_front.py` summary: per direction, from `<direction>/front.json`."""
    s, out = repo.json(rel), Findings()
    base = os.path.dirname(rel)
    directions = s.get("directions", {})
    if not directions:
        out.append(f"{rel}: states no direction")
    fronts = {}
    for name, d in directions.items():
        path = f"{base}/{name}/front.json"
        if not repo.exists(path):
            out.append(f"{rel} {name}: no {path}")
            continue
        f = fronts[name] = repo.front(path)
        where = f"{rel} {name}"
        out.close(f"{where} hypervolume", d["hypervolume"], f.hv(d["hv_ref"]))
        out.equal(f"{where} hv_ref", d["hv_ref"], f.data["hv_ref"])
        out.equal(f"{where} outside_hv_ref", d["outside_hv_ref"], outside(f.returns, d["hv_ref"]))
        for entry in d.get("hypervolume_by_ref", []):
            out.close(
                f"{where} HV at {entry['hv_ref']}", entry["hypervolume"], f.hv(entry["hv_ref"])
            )
            out.equal(
                f"{where} outside {entry['hv_ref']}",
                entry["outside"],
                outside(f.returns, entry["hv_ref"]),
            )
        out.equal(f"{where} cardinality", d["cardinality"], int(f.nd.sum()))
        out.equal(
            f"{where} distinct_points", d["distinct_points"], len(np.unique(f.returns, axis=0))
        )
        out.close(f"{where} rank correlation", d["pref0_forward_rank_correlation"], f.rho)
        out.equal(f"{where} policies", len(d["policies"]), len(f.prefs))
        for i, pol in enumerate(d["policies"]):
            w = f"{where} policy {i}"
            out.equal(f"{w} pref", pol["pref"], f.prefs[i].tolist())
            out.equal(
                f"{w} returns",
                [pol["forward_return"], pol["control_return"]],
                f.returns[i].tolist(),
            )
            out.equal(f"{w} length", pol["episode_length"], f.lengths[i])
            out.extend(check_speed_fields(w, pol, f.returns[i], f.lengths[i]))
    if "union_nondominated" in s and len(fronts) == 2:
        (a, fa), (b, fb) = fronts.items()
        nd = nondominated(np.vstack([fa.returns, fb.returns]))
        want = {a: int(nd[: len(fa.prefs)].sum()), b: int(nd[len(fa.prefs) :].sum())}
        out.equal(f"{rel} union_nondominated", s["union_nondominated"], want)
    return out


def check_speed_fields(where: str, pol: dict, ret, length) -> Findings:
    """The speed, control per step and falls a summary states of one evaluated policy:
    exact where its length fixes the falls, else a range inside the one its data allow."""
    out = Findings()
    speed, ctrl, (f_lo, f_hi) = (
        walker_speed(ret[0], length),
        walker_control(ret[1], length),
        falls(length),
    )
    if pol.get("falls_per_episode") is not None:
        out.within(f"{where} falls", pol["falls_per_episode"], f_lo, f_hi)
        f = pol["falls_per_episode"]
        out.close(f"{where} speed", pol["mean_speed_m_per_s"], (ret[0] - length + f) / length)
        out.close(
            f"{where} control/step", pol["mean_control_per_step"], (length - f - ret[1]) / length
        )
    else:
        for key, (lo, hi) in (
            ("mean_speed_m_per_s_range", speed),
            ("mean_control_per_step_range", ctrl),
        ):
            for v in pol.get(key) or ():
                out.within(f"{where} {key}", v, lo, hi)
    return out


def check_ablation(repo: Repo, rel: str) -> Findings:
    """A depth/width ablation (`walker2d_ablation.py`): per size, its seeds' evaluated
    returns, lengths, speeds and their mean and spread, from `<size>/front.json`."""
    s, out = repo.json(rel), Findings()
    for size in s["sizes"]:
        path = f"{os.path.dirname(rel)}/{size['name']}/front.json"
        f, where = repo.front(path), f"{rel} {size['name']}"
        out.equal(f"{where} forward returns", size["eval_forward_return"], f.returns[:, 0].tolist())
        out.equal(f"{where} control returns", size["eval_control_return"], f.returns[:, 1].tolist())
        out.equal(f"{where} lengths", size["eval_episode_length"], f.lengths.tolist())
        out.close(f"{where} forward mean", size["eval_forward_mean"], f.returns[:, 0].mean())
        out.close(f"{where} forward sd", size["eval_forward_std"], f.returns[:, 0].std(ddof=1))
        for i in range(len(f.prefs)):
            pol = {
                "falls_per_episode": size["eval_falls_per_episode"][i],
                "mean_speed_m_per_s": size["eval_speed_m_per_s"][i],
                "mean_control_per_step": size["eval_control_per_step"][i],
            }
            out.extend(check_speed_fields(f"{where} seed {i}", pol, f.returns[i], f.lengths[i]))
    return out


def check_curves(repo: Repo, rel: str) -> Findings:
    """A `walker2d_curves.py` record: per preset, its seeds' evaluated policies and their
    mean speed and length, from `<preset>/front.json` (the paper preset's may be read
    from another record's)."""
    s, out = repo.json(rel), Findings()
    for name, c in s["configs"].items():
        path = f"{os.path.dirname(rel)}/{name}/front.json"
        if not repo.exists(path):
            continue  # kept by the record named in `docs`
        f, where = repo.front(path), f"{rel} {name}"
        out.equal(f"{where} policies", len(c["policies"]), len(f.prefs))
        mids = []
        for i, pol in enumerate(c["policies"]):
            out.equal(
                f"{where} seed {i} returns",
                [pol["forward_return"], pol["control_return"]],
                f.returns[i].tolist(),
            )
            out.equal(f"{where} seed {i} length", pol["episode_length"], f.lengths[i])
            out.extend(check_speed_fields(f"{where} seed {i}", pol, f.returns[i], f.lengths[i]))
            mids.append(f.speed(i))
        lo, hi = (sum(v) / len(v) for v in zip(*mids, strict=True))
        out.within(f"{where} mean speed", c["eval_speed_mean"], lo, hi)
        out.close(f"{where} mean length", c["eval_length_mean"], f.lengths.mean())
    return out


# COLA (Li et al., NeurIPS 2025), Table 1, 3M env steps, mean ± sd of 5 runs: per task
# and method ((HV, sd), (UT, sd)); its PGMORL column is COLA's run of PGMORL's code.
COLA_TABLE_1 = {
    "HalfCheetah-2d": {
        "Envelope SAC": ((5.54e6, 0.47e6), (2190, 110)),
        "PGMORL": ((5.13e6, 0.06e6), (2140, 30)),
        "Q-Pensieve": ((5.66e6, 0.16e6), (2220, 60)),
        "CAPQL": ((5.84e6, 0.14e6), (2240, 30)),
        "COLA": ((7.91e6, 0.06e6), (2900, 70)),
    },
    "Hopper-2d": {
        "Envelope SAC": ((2.00e7, 0.10e7), (4150, 90)),
        "PGMORL": ((1.90e7, 0.07e7), (4120, 70)),
        "Q-Pensieve": ((2.06e7, 0.08e7), (4210, 70)),
        "CAPQL": ((1.65e7, 0.07e7), (3950, 90)),
        "COLA": ((2.11e7, 0.03e7), (4280, 20)),
    },
    "Ant-2d": {
        "Envelope SAC": ((6.90e6, 0.06e6), (2380, 10)),
        "PGMORL": ((5.40e6, 0.62e6), (2120, 110)),
        "Q-Pensieve": ((6.93e6, 0.16e6), (2390, 30)),
        "CAPQL": ((7.07e6, 0.98e6), (2430, 150)),
        "COLA": ((1.133e7, 0.276e7), (3040, 400)),
    },
    "Walker-2d": {
        "Envelope SAC": ((4.47e6, 0.08e6), (1950, 30)),
        "PGMORL": ((4.50e6, 0.16e6), (1940, 50)),
        "Q-Pensieve": ((4.37e6, 0.19e6), (1910, 40)),
        "CAPQL": ((3.35e6, 0.26e6), (1780, 50)),
        "COLA": ((4.87e6, 0.05e6), (2020, 30)),
    },
    "Hopper-3d": {
        "Envelope SAC": ((3.29e10, 0.27e10), (3210, 40)),
        "PGMORL": ((3.35e10, 0.07e10), (3210, 10)),
        "Q-Pensieve": ((3.29e10, 0.20e10), (3200, 40)),
        "CAPQL": ((1.92e10, 0.23e10), (2700, 110)),
        "COLA": ((3.41e10, 0.04e10), (3220, 60)),
    },
    "Ant-3d": {
        "Envelope SAC": ((5.76e9, 0.09e9), (1600, 10)),
        "PGMORL": ((7.80e9, 0.52e9), (1900, 20)),
        "Q-Pensieve": ((7.32e9, 2.97e9), (1820, 240)),
        "CAPQL": ((9.88e9, 0.89e9), (2020, 60)),
        "COLA": ((1.858e10, 0.076e10), (2680, 40)),
    },
}


# D3PO (arXiv 2602.07764), its table of MO-Gymnasium v5 results on C-MORL's protocol
# (1.5M env steps for 2 objectives, 2M for 3), mean of 5 seeds: per task, each method's
# hypervolume; its C-MORL column is C-MORL's code re-run on v5.
D3PO_SEEDS = 5
D3PO_TABLE = {
    "Hopper-2d": {"PGMORL": 1.20e5, "GPI-LS": 1.19e5, "C-MORL": 1.37e5, "D3PO": 1.30e5},
    "Hopper-3d": {"PGMORL": 1.59e7, "GPI-LS": 1.70e7, "C-MORL": 2.19e7, "D3PO": 2.12e7},
    "Ant-2d": {"PGMORL": 0.35e5, "GPI-LS": 1.17e5, "C-MORL": 1.31e5, "D3PO": 1.91e5},
    "Ant-3d": {"PGMORL": 0.94e7, "GPI-LS": 0.55e7, "C-MORL": 2.61e7, "D3PO": 2.68e7},
    "Humanoid-2d": {"PGMORL": 2.62e5, "GPI-LS": 1.98e5, "C-MORL": 3.43e5, "D3PO": 3.76e5},
}


def check_conditioned(repo: Repo, rel: str) -> Findings:
    """`conditioned_front.py`'s summary: each arm and seed from its `front.json`, the
    means and the cost of more front points."""
    s, out = repo.json(rel), Findings()
    base = os.path.dirname(rel)
    dirs = {
        "conditioned": f"{base}/conditioned",
        "independent_9x333k": f"{base}/independent_9x333k",
        "independent_9x1M": s["reused_9x1M"],
    }
    if not s["runs"]:
        out.append(f"{rel}: states no run")
    for arm, runs in s["runs"].items():
        found = sorted(
            int(p.split("/")[-2][4:]) for p in repo.glob(f"{dirs[arm]}/seed*/front.json")
        )
        out.equal(f"{rel} {arm} seeds", sorted(int(k) for k in runs), found)
        for seed, r in runs.items():
            f = repo.front(f"{dirs[arm]}/seed{seed}/front.json")
            w = f"{rel} {arm} seed {seed}"
            fwd, ctrl = f.forward, f.control
            out.equal(f"{w} n_prefs", r["n_prefs"], len(f.prefs))
            out.close(f"{w} hv_morl_baselines", r["hv_morl_baselines"], MORL_BASELINES.hv(f))
            out.close(f"{w} hv_project", r["hv_project"], f.hv((-500.0, -3000.0)))
            out.close(
                f"{w} expected_utility",
                r["expected_utility"],
                expected_utility(f.returns, front_json_weights(2)),
            )
            out.equal(f"{w} nondominated", r["nondominated"], int(f.nd.sum()))
            out.close(f"{w} spearman", r["spearman_p0_forward"], f.rho)
            out.within(f"{w} forward_end_speed", r["forward_end_speed"], *f.speed(fwd))
            out.close(f"{w} forward_end_length", r["forward_end_length"], f.lengths[fwd])
            out.close(
                f"{w} control_end_control_return",
                r["control_end_control_return"],
                f.returns[ctrl, 1],
            )
            out.extend(check_env_steps(f, w, r["env_steps_total"], r["eval_env_steps"]))
            for key in ("wall_s", "train_s", "compile_s"):
                out.close(f"{w} {key}", r[key], f.data[key])
        for key, mean in s["means"][arm].items():
            values = [r[key] for r in runs.values() if r[key] is not None]
            out.close(f"{rel} {arm} mean {key}", mean, float(np.mean(values)))
    if "published_hv_3M" in s:  # PGMORL's walker is another robot: no number beside v5's
        out.append(f"{rel}: sets published numbers of another task beside its fronts")
    return out


_FIELD_DIR = f"{RESULTS}/field"
# The fronts whose evaluation env steps the earlier code counted: it truncated the summed
# mean lengths (float32) to a whole number before multiplying by the episodes, so each
# states its count short by less than one step per episode. Each is listed with the
# steps it states fewer than the count (found by recomputing every conditioned front's
# count, `eval_steps`); every other front states the count itself.
EARLIER_EVAL_STEPS = {
    f"{_FIELD_DIR}/ablation/cmorl/ant-2obj/default/seed0/front.json": 6,
    f"{_FIELD_DIR}/ablation/cmorl/ant-2obj/e10m32-logstd-1/seed0/front.json": 4,
    f"{_FIELD_DIR}/ablation/cmorl/ant-2obj/logstd-1/seed0/front.json": 9,
    f"{_FIELD_DIR}/ablation/cmorl/ant-2obj/m32-logstd-1/seed0/front.json": 7,
    f"{_FIELD_DIR}/ablation/cmorl/ant-2obj/m64-logstd-1/seed0/front.json": 6,
    f"{_FIELD_DIR}/ablation/cmorl/hopper-2obj/default/seed0/front.json": 2,
    f"{_FIELD_DIR}/ablation/cmorl/hopper-2obj/default/seed1/front.json": 2,
    f"{_FIELD_DIR}/ablation/cmorl/hopper-2obj/e10m32-alpha0.5/seed0/front.json": 5,
    f"{_FIELD_DIR}/ablation/cmorl/hopper-2obj/e10m32-film/seed0/front.json": 4,
    f"{_FIELD_DIR}/ablation/cmorl/hopper-2obj/e10m32-mu10/seed0/front.json": 4,
    f"{_FIELD_DIR}/ablation/cmorl/hopper-2obj/e10m32-sel3/seed0/front.json": 3,
    f"{_FIELD_DIR}/ablation/cmorl/hopper-2obj/e10m32-w256/seed0/front.json": 3,
    f"{_FIELD_DIR}/ablation/cmorl/hopper-2obj/e10m32/seed0/front.json": 1,
    f"{_FIELD_DIR}/ablation/cmorl/hopper-2obj/e10m32/seed1/front.json": 2,
    f"{_FIELD_DIR}/ablation/cmorl/hopper/e10m32/seed0/front.json": 9,
    f"{_FIELD_DIR}/ablation/cmorl/humanoid/default/seed0/front.json": 8,
    f"{_FIELD_DIR}/ablation/cmorl/humanoid/e10m32/seed0/front.json": 5,
    f"{_FIELD_DIR}/cmorl/humanoid/seed0/front.json": 8,
}


def eval_count(f: Front) -> tuple[int, int]:
    """One network's evaluation env steps, `(count, extra)`: the episodes times the
    summed mean lengths, and where it chose each preference's policy among its last
    ones, `extra`, the episodes times every candidate's mean lengths."""
    e = f.episodes
    chosen = f.data.get("selection", {}).get("candidate_length")
    extra = int(round(e * float(np.sum(chosen)))) if chosen is not None else 0
    return int(round(e * float(f.lengths.sum()))) + extra, extra


def eval_steps(f: Front) -> int:
    """One network's evaluation env steps as its front states them: the count
    (`eval_count`), less the steps `EARLIER_EVAL_STEPS` lists for a front the earlier
    code counted."""
    return eval_count(f)[0] - EARLIER_EVAL_STEPS.get(f.path, 0)


def check_earlier_eval_steps(repo: Repo) -> Findings:
    """Each front `EARLIER_EVAL_STEPS` lists is a conditioned network's, and the steps
    listed are what the earlier code's truncation leaves out: the episodes times the
    whole part of the summed mean lengths (within 1e-3 of their float64 sum: the code
    summed float32) is the count less them."""
    out = Findings()
    for rel, short in EARLIER_EVAL_STEPS.items():
        where = f"EARLIER_EVAL_STEPS {rel}"
        if not repo.exists(rel) or "conditioned" not in repo.json(rel):
            out.append(f"{where}: no conditioned network's front there")
            continue
        f = repo.front(rel)
        (count, extra), total = eval_count(f), float(f.lengths.sum())
        truncated = {f.episodes * math.floor(total + d) + extra for d in (-1e-3, 1e-3)}
        if count - short not in truncated - {count}:
            out.append(
                f"{where}: lists {short} steps short of {count}, the earlier code's "
                f"truncation gives {sorted(count - t for t in truncated)}"
            )
    return out


def check_env_steps(f: Front, where: str, total, eval_env_steps) -> Findings:
    """A front's training env steps (iterations x envs x rollout steps, per preference or
    for the one network) and, for one network, its evaluation's (`eval_steps`)."""
    out, train = Findings(), f.data["config"]["train"]
    # per iteration: the rollout's steps, and for the paper's update (Algorithm 2) also
    # the critics' K TD steps on every environment
    per_iteration = train["rollout_steps"] + (
        train["critic_steps"] if train.get("kind") == "paper" else 0
    )
    per_program = train["num_iterations"] * train["num_envs"] * per_iteration
    if "conditioned" in f.data:
        out.equal(f"{where} env_steps_total", total, per_program)
        out.equal(f"{where} eval_env_steps", eval_env_steps, eval_steps(f))
    else:
        out.equal(f"{where} env_steps_total", total, per_program * len(f.prefs))
        out.equal(f"{where} eval_env_steps", eval_env_steps, None)
    return out


def forward_row(f: Front) -> dict:
    return f.data["prefs"][f.forward]


def check_mo_mujoco(repo: Repo, rel: str) -> Findings:
    """`mo_mujoco.py table`'s `table.json`: per task and direction (seed 0) from its
    `front.json` and the task's PPO reference; per task with seeds, each seed's and the
    mean's numbers and the winner."""
    s, out = repo.json(rel), Findings()
    base = os.path.dirname(rel)
    rows = {(r["env"], r["scalarization"]): r for r in s["rows"]}
    found = {tuple(p.split("/")[-3:-1]) for p in repo.glob(f"{base}/*/*/front.json")}
    found = {(e, d) for e, d in found if d in ("smooth_wc", "linear")}
    out.equal(f"{rel} rows", sorted(rows), sorted(found))
    for (env, scal), r in rows.items():
        f = repo.front(f"{base}/{env}/{scal}/front.json")
        ref = repo.json(f"{base}/{env}/reference_ppo.json")
        w = f"{rel} {env} {scal}"
        end = forward_row(f)
        out.equal(f"{w} n_prefs", r["n_prefs"], len(f.prefs))
        out.equal(f"{w} env_steps_per_pref", r["env_steps_per_pref"], f.data["env_steps_per_pref"])
        out.close(f"{w} hv_morl_baselines", r["hv_morl_baselines"], MORL_BASELINES.hv(f))
        if "hv_pgmorl" in r:  # PGMORL's tasks are other tasks: no such column on v5's
            out.append(f"{w}: an HV (PGMORL) of a v5 front")
        out.close(
            f"{w} expected_utility",
            r["expected_utility"],
            expected_utility(f.returns, front_json_weights(f.returns.shape[1])),
        )
        out.equal(f"{w} nondominated", r["nondominated"], int(f.nd.sum()))
        out.equal(f"{w} forward_end_pref", r["forward_end_pref"], end["pref"])
        out.close(
            f"{w} forward end speed", r["forward_end_mean_x_velocity"], end["mean_x_velocity"]
        )
        out.close(f"{w} forward end length", r["forward_end_episode_length"], end["episode_length"])
        out.close(f"{w} wall_s", r["wall_s"], f.data["wall_s"])
        budget = f.data["config"]["steps_per_pref"]
        out.equal(
            f"{w} PPO's env steps against the front's per preference", ref["env_steps"], budget
        )
        out.close(f"{w} PPO speed", r["reference_mean_x_velocity"], ref["mean_x_velocity"])
        out.close(f"{w} PPO wall", r["reference_wall_s"], ref["wall_s"])
        out.close(
            f"{w} speed_ratio", r["speed_ratio"], end["mean_x_velocity"] / ref["mean_x_velocity"]
        )
        # one program for the front against P separate PPO runs, with a margin of 1.5
        out.close(
            f"{w} wall_ratio",
            r["wall_ratio"],
            f.data["wall_s"] * 1.5 / (len(f.prefs) * ref["wall_s"]),
        )
    for env, c in s["seeds"].items():
        out.extend(check_mo_mujoco_seeds(repo, f"{rel} seeds {env}", f"{base}/{env}", c))
    if "published" in s:  # published numbers stand beside the field's protocols only
        out.append(f"{rel}: sets published numbers beside fronts of other budgets")
    return out


def mo_mujoco_seeds(repo: Repo, task: str) -> list[int]:
    """The seeds with both directions' fronts (seed 0 at the task's top)."""
    seeds = [0] + sorted(int(p.split("/")[-1][4:]) for p in repo.glob(f"{task}/seed*"))
    return [
        s
        for s in seeds
        if all(
            repo.exists(f"{task}{'' if s == 0 else f'/seed{s}'}/{d}/front.json")
            for d in ("smooth_wc", "linear")
        )
    ]


def check_mo_mujoco_seeds(repo: Repo, where: str, task: str, c: dict) -> Findings:
    out = Findings()
    seeds = mo_mujoco_seeds(repo, task)
    out.equal(f"{where} seeds", c["seeds"], seeds)
    fronts = {
        d: [repo.front(f"{task}{'' if s == 0 else f'/seed{s}'}/{d}/front.json") for s in seeds]
        for d in ("smooth_wc", "linear")
    }
    measures = {
        "hv_morl_baselines": MORL_BASELINES.hv,
        "forward": lambda f: forward_row(f)["mean_x_velocity"],
    }
    entries = {**c["hypervolume"], "forward": c["forward_speed"]}
    for key, e in entries.items():
        values = {d: [measures[key](f) for f in fronts[d]] for d in fronts}
        for d in fronts:
            for i, (a, b) in enumerate(zip(e[d], values[d], strict=True)):
                out.close(f"{where} {key} {d} seed {seeds[i]}", a, b)
            out.close(f"{where} {key} {d} mean", e["mean"][d], float(np.mean(values[d])))
        a, b = values["smooth_wc"], values["linear"]
        winner = "smooth_wc" if min(a) > max(b) else "linear" if min(b) > max(a) else None
        out.equal(f"{where} {key} winner", e["winner"], winner)
    out.equal(f"{where} prefs", c["prefs"], fronts["smooth_wc"][0].prefs.tolist())
    for d in fronts:
        mean = np.mean([f.returns for f in fronts[d]], axis=0)
        for i, (a, b) in enumerate(zip(np.ravel(c["mean_return"][d]), mean.ravel(), strict=True)):
            out.close(f"{where} mean return {d} [{i}]", a, b)
    return out


# ---------------------------------------------------------------------- the field's protocols

FIELD = f"{RESULTS}/field"


@dataclass(frozen=True)
class ProtocolTask:
    """A task of one of the field's protocols: its name in the protocol's papers, the
    environment it was measured on there, its objectives, evaluation episodes per
    preference and episode length."""

    published: str
    definition: str
    m: int
    episodes: int
    length: int = T


@dataclass(frozen=True)
class FieldProtocol:
    """One of the field's benchmark protocols as docs/protocols.md states it: how a front
    is scored (`convention`), the env steps of training in all per number of objectives,
    the step of the preference grid a conditioned network is evaluated at (the published
    code's, `published_grid`) and the tasks."""

    name: str
    convention: Convention
    budget: dict
    pref_step: dict
    tasks: dict

    def prefs(self, m: int) -> np.ndarray:
        return published_grid(m, self.pref_step[m])


FIELD_PROTOCOLS = {
    "cmorl": FieldProtocol(
        "cmorl",
        C_MORL,
        {2: 1_500_000, 3: 2_000_000},
        {2: 0.01, 3: 0.1},
        {
            "hopper-2obj": ProtocolTask("Hopper-2d", "mo-hopper-2obj-v5", 2, 5),
            "hopper": ProtocolTask("Hopper-3d", "mo-hopper-v5", 3, 10),
            "ant-2obj": ProtocolTask("Ant-2d", "mo-ant-2obj-v5", 2, 10),
            "ant": ProtocolTask("Ant-3d", "mo-ant-v5", 3, 10),
            "humanoid": ProtocolTask("Humanoid-2d", "mo-humanoid-v5", 2, 10),
            "walker2d": ProtocolTask("Walker-2d", "mo-walker2d-v5", 2, 10),
            "halfcheetah": ProtocolTask("HalfCheetah-2d", "mo-halfcheetah-v5", 2, 10),
            "swimmer": ProtocolTask("Swimmer-2d", "mo-swimmer-v5", 2, 10),
        },
    ),
    "pgmorl": FieldProtocol(
        "pgmorl",
        PGMORL,
        {2: 3_000_000, 3: 3_000_000},
        {2: 0.005, 3: 0.05},
        {
            "walker2d-pgmorl": ProtocolTask("Walker-2d", "MO-Walker2d-v2", 2, 3),
            "halfcheetah-pgmorl": ProtocolTask(
                "HalfCheetah-2d (PGMORL)", "MO-HalfCheetah-v2", 2, 3
            ),
            "hopper-pgmorl": ProtocolTask("Hopper-2d", "MO-Hopper-v2", 2, 3),
            "hopper3-pgmorl": ProtocolTask("Hopper-3d", "MO-Hopper-v3", 3, 3),
            "ant-pgmorl": ProtocolTask("Ant-2d", "MO-Ant-v2", 2, 3),
            "swimmer-pgmorl": ProtocolTask("Swimmer-2d", "MO-Swimmer-v2", 2, 3),
            "humanoid-pgmorl": ProtocolTask("Humanoid-2d", "MO-Humanoid-v2", 2, 3, 1000),
            "halfcheetah-cola": ProtocolTask("HalfCheetah-2d", "MO-New-HalfCheetah-v2", 2, 3),
            "ant3-cola": ProtocolTask("Ant-3d", "MO-Ant-v3", 3, 3),
        },
    ),
}
# MO-Gymnasium's id of each v5 task (C-MORL's protocol lists every one)
MO_GYMNASIUM_IDS = {env: t.definition for env, t in FIELD_PROTOCOLS["cmorl"].tasks.items()}


def t_interval(values) -> tuple[float, float, float]:
    """`(mean, lo, hi)`: the mean and its 95% Student-t interval (one value: itself)."""
    x = np.asarray(values, np.float64)
    mean = float(np.mean(x))
    if len(x) < 2:
        return mean, mean, mean
    half = float(student_t.ppf(0.975, len(x) - 1) * np.std(x, ddof=1) / math.sqrt(len(x)))
    return mean, mean - half, mean + half


def field_run(rel: str) -> tuple[str, str, str | None, int]:
    """`(protocol, task, variant or None, seed)` of a front's path under `FIELD`."""
    parts = rel[len(FIELD) + 1 :].split("/")
    if parts[0] == "ablation":
        return parts[1], parts[2], parts[3], int(parts[4][4:])
    return parts[0], parts[1], None, int(parts[2][4:])


def field_fronts(repo: Repo, protocol: str, task: str, variant: str | None = None) -> dict:
    """`{seed: path}` of one protocol task's fronts (of one variant of the ablation)."""
    base = f"{FIELD}/{protocol}/{task}"
    if variant is not None:
        base = f"{FIELD}/ablation/{protocol}/{task}/{variant}"
    return {int(p.split("/")[-2][4:]): p for p in repo.glob(f"{base}/seed*/front.json")}


def protocol_task(protocol: str, env: str) -> ProtocolTask | None:
    """The task `env` of the field's protocol `protocol`, or `None`."""
    p = FIELD_PROTOCOLS.get(protocol)
    return None if p is None else p.tasks.get(env)


def protocol_of(f: Front) -> FieldProtocol:
    return FIELD_PROTOCOLS[f.data["config"]["protocol"]]


def protocol_score(f: Front) -> dict:
    """The front's scores under its protocol, from its evaluated returns."""
    conv = protocol_of(f).convention
    return conv.score(f.discounted if conv.discounted else f.returns)


def protocol_departures(f: Front) -> list[tuple[str, list]]:
    """How a front departs from its protocol, in the order its `deviations` name them:
    `(a word its line holds, the numbers its line prints)` each."""
    p, config = protocol_of(f), f.data["config"]
    task, m = p.tasks[config["env"]], f.returns.shape[1]
    train, out = config["train"], []
    trained, budget = f.data["env_steps_total"], p.budget[m]
    per_iteration = train["num_envs"] * train["rollout_steps"]
    if not budget - per_iteration < trained <= budget:
        out.append(("env steps", [trained, budget, per_iteration]))
    if f.episodes != task.episodes:
        out.append(("evaluation episodes", [f.episodes, task.episodes]))
    grid = p.prefs(m)
    if f.prefs.shape != grid.shape or not np.allclose(f.prefs, grid, atol=1e-6):
        out.append(("preferences", [len(f.prefs), len(grid)]))
    length = config.get("env_options", {}).get("episode_length", task.length)
    if length != task.length:
        out.append(("episode length", [length, task.length]))
    gamma = f.data.get("eval_gamma")
    if p.convention.discounted and gamma != p.convention.gamma:
        out.append(("discounted", [gamma, p.convention.gamma]))
    return out


def check_departures(where: str, stated: list, wanted: list[tuple[str, list]]) -> Findings:
    """A `deviations` list: one line per departure its data give, each naming it (a word)
    and printing its numbers."""
    out = Findings()
    if len(stated) != len(wanted):
        out.append(f"{where}: states {stated!r}, its data give {wanted!r}")
        return out
    for line, (word, numbers_) in zip(stated, wanted, strict=True):
        if word not in line:
            out.append(f"{where}: states {line!r}, its data give a departure of {word!r}")
        out.extend(compare(where, line, [v for v in numbers_ if v is not None]))
    return out


def check_choice(f: Front, where: str) -> Findings:
    """A conditioned network's choice among its last policies (`selection`): the
    candidates (the last `select_last` iterations, `select_every` env steps apart, the
    final one last), each one's weighted-Chebyshev regret `max_i p_i (z_i - J_i)` at
    every preference from its evaluated returns `J` and the stated utopia `z` (float32
    sums: relative 1e-5), the choice of least regret, and its evaluation's env steps."""
    out, sel, config = Findings(), f.data["selection"], f.data["config"]
    train, conv = config["train"], protocol_of(f).convention
    k, every = config["select_last"], config["select_every"]
    per_iteration = train["num_envs"] * train["rollout_steps"]
    last = train["num_iterations"]
    want = [last - (k - 1 - i) * every // per_iteration for i in range(k)]
    out.equal(f"{where} candidate_iterations", sel["candidate_iterations"], want)
    out.equal(f"{where} selection returns", sel["returns"], conv.returns)
    ret = np.asarray(sel["candidate_return"], np.float64)  # [K, P, m]
    regret = np.max(f.prefs[None] * (np.asarray(sel["utopia"], np.float64) - ret), axis=2)
    stated = np.asarray(sel["regret"], np.float64)
    scale = 1e-5 * max(1.0, float(np.abs(regret).max()))
    if stated.shape != regret.shape or not np.allclose(stated, regret, rtol=1e-5, atol=scale):
        out.append(f"{where} regret: states other regrets than its returns and utopia give")
    iterations = list(sel["candidate_iterations"])
    for j, it in enumerate(sel["chosen_iteration"]):
        if it not in iterations or regret[iterations.index(it), j] > regret[:, j].min() + scale:
            out.append(
                f"{where} chosen_iteration [{j}]: states {it}, its regrets give "
                f"{iterations[int(np.argmin(regret[:, j]))]}"
            )
    steps = int(round(f.episodes * float(np.sum(sel["candidate_length"]))))
    out.equal(f"{where} selection env_steps", sel["env_steps"], steps)
    return out


def check_protocol_front(repo: Repo, rel: str, hv_ref) -> Findings:
    """A front trained under one of the field's protocols: what every front states
    (`check_front`), that it is the run its path names, and its `protocol` block: the
    protocol's HV, EU, non-dominated count and points kept from the returns the
    protocol scores, the reference, budget, env steps trained (at most the budget) and
    evaluated, the preferences, the departures from the protocol, and with a choice
    among the network's last policies the choice and the final network's own scores."""
    out, f = check_front(repo, rel, hv_ref), repo.front(rel)
    d, config = f.data, f.data["config"]
    name, env, _, seed = field_run(rel)
    out.equal(
        f"{rel} protocol, task and seed",
        [config.get("protocol"), f.env, config["seed"]],
        [name, env, seed],
    )
    s, task = d.get("protocol"), protocol_task(name, env)
    if task is None or s is None or config.get("protocol") != name:
        out.append(f"{rel}: no score of the {name} protocol's task {env!r}")
        return out
    p = FIELD_PROTOCOLS[name]
    conv, m = p.convention, f.returns.shape[1]
    w = f"{rel} protocol"
    out.equal(
        f"{w} name, task and returns",
        [s["protocol"], s["task"], s["returns"]],
        [name, task.published, conv.returns],
    )
    out.close(f"{w} gamma", s["gamma"], conv.gamma)
    out.equal(f"{w} ref_point", [float(v) for v in s["ref_point"]], [conv.ref] * m)
    score = protocol_score(f)
    out.close(f"{w} hv", s["hv"], score["hv"])
    out.close(f"{w} eu", s["eu"], score["eu"])
    out.equal(f"{w} nondominated", s["nondominated"], score["nondominated"])
    out.equal(f"{w} kept", s["kept"], score["kept"])
    out.equal(f"{w} budget", s["budget"], p.budget[m])
    out.equal(f"{w} env_steps_trained", s["env_steps_trained"], d["env_steps_total"])
    if d["env_steps_total"] > p.budget[m]:
        out.append(f"{w}: trained {d['env_steps_total']} env steps, past the budget")
    out.equal(f"{w} eval_prefs", s["eval_prefs"], len(f.prefs))
    out.equal(f"{w} eval_env_steps", s["eval_env_steps"], eval_steps(f))
    out.extend(check_departures(f"{w} deviations", s["deviations"], protocol_departures(f)))
    if "selection" not in d:  # fronts written before it was recorded lack it
        out.equal(f"{w} final_network", s.get("final_network"), None)
        return out
    out.extend(check_choice(f, rel))
    final = conv.score(d["selection"]["candidate_return"][-1])
    stated = s.get("final_network") or {}
    for key in ("hv", "eu"):
        out.close(f"{w} final_network {key}", stated.get(key), final[key])
    return out


# the MO-Gymnasium evaluation `field.py run` writes beside a front of C-MORL's protocol
FIELD_EVALUATION = "evaluation_mo_gymnasium.json"


def field_evaluation(repo: Repo, front: str) -> str | None:
    """The path of the MO-Gymnasium evaluation beside the front `front`, or `None`."""
    rel = f"{os.path.dirname(front)}/{FIELD_EVALUATION}"
    return rel if repo.exists(rel) else None


def evaluation_score(d: dict, protocol: str) -> dict:
    """An MO-Gymnasium evaluation's scores under `protocol`, from its own returns."""
    conv = FIELD_PROTOCOLS[protocol].convention
    return conv.score([row[conv.returns] for row in d["prefs"]])


def field_row(repo: Repo, protocol: str, task: str, entries: list) -> dict:
    """One protocol task's row of the field's table, from its fronts, the MO-Gymnasium
    evaluations beside them and the published entries of the same protocol and task:
    the HV's mean and interval over the seeds and its ratio to the best published, and
    where every seed has an evaluation in MO-Gymnasium the same of its HV."""
    paths = field_fronts(repo, protocol, task)
    seeds = sorted(paths)
    fronts = [repo.front(paths[s]) for s in seeds]
    scores = [protocol_score(f) for f in fronts]
    hv = t_interval([s["hv"] for s in scores])
    published = [e for e in entries if (e["protocol"], e["task"]) == (protocol, task)]
    best = max(published, key=lambda e: e["hv"]) if published else None
    evaluations = [field_evaluation(repo, paths[s]) for s in seeds]
    mo_gymnasium = [
        None if e is None else evaluation_score(repo.json(e), protocol) for e in evaluations
    ]
    hv_mo_gymnasium = None
    if all(x is not None for x in mo_gymnasium):
        hv_mo_gymnasium = t_interval([x["hv"] for x in mo_gymnasium])
    return {
        "seeds": seeds,
        "fronts": fronts,
        "scores": scores,
        "hv": hv,
        "eu": t_interval([s["eu"] for s in scores]),
        "published": published,
        "best": best,
        "ratio": None if best is None else [v / best["hv"] for v in hv],
        "evaluations": evaluations,
        "mo_gymnasium": mo_gymnasium,
        "hv_mo_gymnasium": hv_mo_gymnasium,
        "ratio_mo_gymnasium": None
        if best is None or hv_mo_gymnasium is None
        else [v / best["hv"] for v in hv_mo_gymnasium],
    }


def field_entries(repo: Repo, base: str) -> list:
    rel = f"{base}/published.json"
    return repo.json(rel)["entries"] if repo.exists(rel) else []


def field_tasks(repo: Repo, base: str) -> list[tuple[str, str]]:
    """Every (protocol, task) with fronts under `base`, in the protocols' order."""
    found = {tuple(p.split("/")[-4:-2]) for p in repo.glob(f"{base}/*/*/seed*/front.json")}
    order = [(p, t) for p in FIELD_PROTOCOLS for t in FIELD_PROTOCOLS[p].tasks]
    return sorted(found, key=lambda k: order.index(k) if k in order else len(order))


def check_field_table(repo: Repo, rel: str) -> Findings:
    """`field.py table`'s `table.json`: the protocols as stated, and per protocol task
    each seed's protocol HV and EU, non-dominated count, env steps and seconds from its
    front (none departing from the protocol), the mean and 95% Student-t interval over
    the seeds, the published entries of the same protocol and task, the best of them
    and the ratio of the mean (and its interval) to it; each seed's MO-Gymnasium HV, EU
    and non-dominated count from the evaluation beside its front (none departing from
    the protocol), and where every seed has one, that HV's mean, interval and ratio to
    the best published."""
    s, out, base = repo.json(rel), Findings(), os.path.dirname(rel)
    for name, p in FIELD_PROTOCOLS.items():
        got, conv = s["protocols"].get(name, {}), p.convention
        out.equal(
            f"{rel} protocol {name}",
            [got.get("gamma"), got.get("ref_value"), got.get("drop_negative")],
            [conv.gamma, conv.ref, conv.drop_negative],
        )
        out.equal(
            f"{rel} protocol {name} budget_by_m",
            got.get("budget_by_m"),
            {str(k): v for k, v in p.budget.items()},
        )
    entries = field_entries(repo, base)
    rows = {(r["protocol"], r["task"]): r for r in s["rows"]}
    tasks = field_tasks(repo, base)
    out.equal(f"{rel} rows", sorted(rows), sorted(tasks))
    for (name, env), r in rows.items():
        w, task = f"{rel} {name} {env}", protocol_task(name, env)
        if (name, env) not in tasks or task is None:
            continue
        p = FIELD_PROTOCOLS[name]
        row = field_row(repo, name, env, entries)
        by_seed = dict(
            zip(
                row["seeds"],
                zip(
                    row["fronts"],
                    row["scores"],
                    row["evaluations"],
                    row["mo_gymnasium"],
                    strict=True,
                ),
                strict=True,
            )
        )
        out.equal(
            f"{w} task, definition and budget",
            [r["published_task"], r["definition"], r["budget"]],
            [task.published, task.definition, p.budget[task.m]],
        )
        out.equal(f"{w} seeds", [x["seed"] for x in r["seeds"]], row["seeds"])
        for x in r["seeds"]:
            if x["seed"] not in by_seed:
                continue
            (f, score, evaluation, mg), ws = by_seed[x["seed"]], f"{w} seed {x['seed']}"
            out.equal(f"{ws} path", x["path"], f.path)
            out.close(f"{ws} hv", x["hv"], score["hv"])
            out.close(f"{ws} eu", x["eu"], score["eu"])
            out.equal(f"{ws} nondominated", x["nondominated"], score["nondominated"])
            out.equal(f"{ws} env_steps_trained", x["env_steps_trained"], f.data["env_steps_total"])
            out.equal(f"{ws} eval_env_steps", x["eval_env_steps"], eval_steps(f))
            out.close(f"{ws} wall_s", x["wall_s"], f.data["wall_s"])
            if protocol_departures(f):
                out.append(f"{ws}: departs from the protocol, yet stands in the table")
            stated = x.get("mo_gymnasium")
            if (stated is None) != (mg is None):
                beside = evaluation or f"no {FIELD_EVALUATION} beside the front"
                out.append(f"{ws} mo_gymnasium: states {stated!r}, its data give {mg!r} ({beside})")
            elif mg is not None:
                out.close(f"{ws} mo_gymnasium hv", stated.get("hv"), mg["hv"])
                out.close(f"{ws} mo_gymnasium eu", stated.get("eu"), mg["eu"])
                out.equal(
                    f"{ws} mo_gymnasium nondominated",
                    stated.get("nondominated"),
                    mg["nondominated"],
                )
                if reevaluation_departures(repo.json(evaluation)):
                    out.append(
                        f"{ws}: {evaluation} departs from the protocol, yet stands in the table"
                    )
        for key in ("hv", "eu"):
            mean, lo, hi = row[key]
            out.close(f"{w} {key} mean", r[key]["mean"], mean)
            out.close(f"{w} {key} ci95 low", r[key]["ci95"][0], lo)
            out.close(f"{w} {key} ci95 high", r[key]["ci95"][1], hi)
        out.equal(f"{w} published", r["published"], row["published"])
        best = row["best"]
        out.equal(
            f"{w} best_published",
            r["best_published"],
            None if best is None else {"method": best["method"], "hv": best["hv"]},
        )
        ratio = row["ratio"] or [None, None, None]
        out.close(f"{w} ratio_to_best", r["ratio_to_best"], ratio[0])
        stated = r["ratio_ci95"] or [None, None]
        out.close(f"{w} ratio_ci95 low", stated[0], ratio[1])
        out.close(f"{w} ratio_ci95 high", stated[1], ratio[2])
        out.extend(check_hv_mo_gymnasium(f"{w} hv_mo_gymnasium", r.get("hv_mo_gymnasium"), row))
    return out


def check_hv_mo_gymnasium(where: str, stated: dict | None, row: dict) -> Findings:
    """A row's `hv_mo_gymnasium`: `None` unless every seed has an MO-Gymnasium
    evaluation; then the mean and interval of their HVs and, with a published number,
    their ratio to the best (without one, no ratio)."""
    out, want = Findings(), row["hv_mo_gymnasium"]
    if stated is None or want is None:
        if (stated is None) != (want is None):
            out.append(f"{where}: states {stated!r}, its evaluations give {want!r}")
        return out
    out.close(f"{where} mean", stated.get("mean"), want[0])
    ci = stated.get("ci95") or [None, None]
    out.close(f"{where} ci95 low", ci[0], want[1])
    out.close(f"{where} ci95 high", ci[1], want[2])
    ratio = row["ratio_mo_gymnasium"]
    if ratio is None:
        out.equal(
            f"{where} ratio", [stated.get("ratio_to_best"), stated.get("ratio_ci95")], [None, None]
        )
        return out
    out.close(f"{where} ratio_to_best", stated.get("ratio_to_best"), ratio[0])
    ci = stated.get("ratio_ci95") or [None, None]
    out.close(f"{where} ratio_ci95 low", ci[0], ratio[1])
    out.close(f"{where} ratio_ci95 high", ci[1], ratio[2])
    return out


def md_table(repo: Repo, rel: str) -> tuple[list[str], list[list[str]]]:
    """A Markdown file's one table: its header and its rows' cells."""
    lines = [ln for ln in repo.text(rel).splitlines() if ln.startswith("|")]
    return _cells(lines[0], rel)[0], [_cells(ln, rel)[0] for ln in lines[2:]]


def check_md_rows(rel: str, header: list, rows: list, wants: dict, labels: int) -> Findings:
    """Each row of a results file's Markdown table, keyed by its first `labels` cells,
    prints what `wants[key]` (`{column header: what the cell must print}`) gives; every
    other column is named there."""
    out = Findings()
    keys = [tuple(r[:labels]) for r in rows]
    for head in header[labels:]:
        if any(head not in w for w in wants.values()):
            out.append(f"{rel} column {head!r}: not audited")
    if sorted(keys) != sorted(wants):
        out.append(f"{rel}: rows {sorted(keys)}, its data give {sorted(wants)}")
    for key, row in zip(keys, rows, strict=True):
        for head, want in wants.get(key, {}).items():
            col = header.index(head) if head in header else None
            if col is None:
                out.append(f"{rel}: no column {head!r}")
                continue
            out.extend(compare(f"{rel} {' '.join(key)} '{head}'", row[col], want))
    return out


def check_field_table_md(repo: Repo, rel: str) -> Findings:
    """`table.md`: each protocol task's row, from its fronts and the published entries
    (the first seed's env steps, its evaluation's as its front states them,
    `eval_steps`)."""
    base, wants = os.path.dirname(rel), {}
    entries = field_entries(repo, base)
    for name, env in field_tasks(repo, base):
        if protocol_task(name, env) is None:
            continue
        row = field_row(repo, name, env, entries)
        first = row["fronts"][0]
        best = row["best"]
        wants[(name, env)] = {
            "seeds": [len(row["seeds"])],
            "HV mean [95%]": list(row["hv"]),
            "EU mean": [row["eu"][0]],
            "best published (HV)": ["none published"]
            if best is None
            else [best["method"], best["hv"]],
            "ratio [95%]": ["—"] if best is None else list(row["ratio"]),
            "env steps trained": [first.data["env_steps_total"]],
            "eval env steps": [eval_steps(f) for f in row["fronts"]],
            "wall s per seed": [f.data["wall_s"] for f in row["fronts"]],
        }
        hv_mo_gymnasium = row["hv_mo_gymnasium"]
        wants[(name, env)][MD_MO_GYMNASIUM] = (
            ["—"] if hv_mo_gymnasium is None else list(hv_mo_gymnasium)
        )
    header, rows = md_table(repo, rel)
    if MD_MO_GYMNASIUM not in header:  # written before the evaluations were
        for w in wants.values():
            del w[MD_MO_GYMNASIUM]
    return check_md_rows(rel, header, rows, wants, 2)


MD_MO_GYMNASIUM = "HV in MO-Gymnasium [95%]"


def ablation_rows(repo: Repo, base: str) -> dict:
    """Per (protocol, task, variant) of the ablation: its seeds' fronts and scores, the
    mean and interval of the HV, the mean EU, and against the `default` variant's runs
    of the same task the seeds both ran and the ratio of the HV means on them."""
    found = {
        tuple(p.split("/")[-5:-2]) for p in repo.glob(f"{base}/ablation/*/*/*/seed*/front.json")
    }
    rows = {}
    for key in sorted(found):
        paths = field_fronts(repo, *key)
        seeds = sorted(paths)
        fronts = [repo.front(paths[s]) for s in seeds]
        scores = [protocol_score(f) for f in fronts]
        rows[key] = {
            "seeds": seeds,
            "fronts": fronts,
            "hv_by_seed": dict(zip(seeds, (s["hv"] for s in scores), strict=True)),
            "eu_by_seed": dict(zip(seeds, (s["eu"] for s in scores), strict=True)),
            "hv": t_interval([s["hv"] for s in scores]),
            "eu_mean": float(np.mean([s["eu"] for s in scores])),
        }
    for (protocol, task, _), r in rows.items():
        ref = rows.get((protocol, task, "default"), {}).get("hv_by_seed", {})
        paired = [s for s in r["seeds"] if s in ref]
        r["paired"] = paired
        r["ratio"] = (
            float(np.mean([r["hv_by_seed"][s] for s in paired]) / np.mean([ref[s] for s in paired]))
            if paired
            else None
        )
    return rows


def _trained(front: dict, key: str):
    """The value of the conditioned update's field `key` that `front`'s run trained: its
    configuration's; a run from before `pref_draw` existed states its draw in
    `front.json`'s `conditioned.preferences` alone (`drawn per episode`; runs from before
    that record state neither)."""
    train = front["config"]["train"]
    if key in train or key != "pref_draw":
        return train.get(key)
    mark = front.get("conditioned", {}).get("preferences", "")
    return mark.removeprefix("drawn per ") or None


def check_changes(where: str, changes, fronts: list, defaults: list) -> Findings:
    """A variant's stated changes are what its runs trained: each named field of the
    conditioned update as stated (`select`: `[select_last, select_every]`; without it,
    the final network), and against the `default` variant's runs of the task, no other
    field that both record changed."""
    out = Findings()
    if changes is None:
        out.append(f"{where} changes: states none")
        return out
    named = sorted(k for k in changes if k != "select")
    for f in fronts:
        config, train = f.data["config"], f.data["config"]["train"]
        w = f"{where} seed {config['seed']}"
        out.equal(
            f"{w} select",
            [config["select_last"], config["select_every"]],
            list(changes.get("select", [1, 0])),
        )
        out.equal(
            f"{w} changes", {k: _trained(f.data, k) for k in named}, {k: changes[k] for k in named}
        )
        for g in defaults:
            base = g.data["config"]["train"]
            # a field one of them predates (written before it existed) is not compared
            differ = sorted(k for k in set(train) & set(base) if train[k] != base[k])
            recorded = [k for k in named if k in base]
            out.equal(f"{w} fields other than the defaults'", differ, recorded)
    return out


def check_field_ablation(repo: Repo, rel: str) -> Findings:
    """`field.py ablation-table`'s `ablation.json`: per protocol, task and variant, its
    changes against the runs' configurations, each seed's protocol HV and EU, seconds and
    departures from its front, the HV's mean and interval, the mean EU, and the ratio to
    the `default` variant's HV on the seeds both ran."""
    s, out, base = repo.json(rel), Findings(), os.path.dirname(rel)
    rows = ablation_rows(repo, base)
    stated = {(r["protocol"], r["task"], r["variant"]): r for r in s["rows"]}
    out.equal(f"{rel} rows", sorted(stated), sorted(rows))
    for key, r in stated.items():
        if key not in rows:
            continue
        want, w = rows[key], f"{rel} {' '.join(key)}"
        defaults = rows.get((*key[:2], "default"), {}).get("fronts", [])
        out.extend(check_changes(w, r["changes"], want["fronts"], defaults))
        out.equal(f"{w} seeds", sorted(x["seed"] for x in r["seeds"]), want["seeds"])
        by_seed = dict(zip(want["seeds"], want["fronts"], strict=True))
        for x in r["seeds"]:
            f = by_seed.get(x["seed"])
            if f is None:
                continue
            ws = f"{w} seed {x['seed']}"
            out.close(f"{ws} hv", x["hv"], want["hv_by_seed"][x["seed"]])
            out.close(f"{ws} eu", x["eu"], want["eu_by_seed"][x["seed"]])
            out.close(f"{ws} wall_s", x["wall_s"], f.data["wall_s"])
            out.extend(
                check_departures(f"{ws} deviations", x["deviations"], protocol_departures(f))
            )
        mean, lo, hi = want["hv"]
        out.close(f"{w} hv mean", r["hv"]["mean"], mean)
        out.close(f"{w} hv ci95 low", r["hv"]["ci95"][0], lo)
        out.close(f"{w} hv ci95 high", r["hv"]["ci95"][1], hi)
        out.close(f"{w} eu_mean", r["eu_mean"], want["eu_mean"])
        out.equal(f"{w} paired_seeds", sorted(r["paired_seeds"]), want["paired"])
        out.close(f"{w} ratio_to_default", r["ratio_to_default"], want["ratio"])
    return out


def change_wants(changes: dict) -> list:
    """What a variant's changes print: each changed field's name and value."""
    numbers_, words = [], []
    for k, c in changes.items():
        words.append(k)
        for v in c if isinstance(c, list) else [c]:
            if isinstance(v, int | float) and not isinstance(v, bool):
                numbers_.append(v)
            else:
                words.append(str(v))
    return [*numbers_, *words]


def check_field_ablation_md(repo: Repo, rel: str) -> Findings:
    """`ablation.md`: each variant's row from its fronts (its changes as `ablation.json`
    states them, checked there against the runs)."""
    base = os.path.dirname(rel)
    stated = {
        (r["protocol"], r["task"], r["variant"]): r["changes"] or {}
        for r in repo.json(f"{base}/ablation.json")["rows"]
    }
    wants = {}
    for key, r in ablation_rows(repo, base).items():
        wants[key] = {
            "changes": change_wants(stated.get(key, {})),
            "seeds": r["seeds"],
            "HV mean [95%]": list(r["hv"]),
            "EU mean": [r["eu_mean"]],
            "vs default (same seeds)": ["—"] if r["ratio"] is None else [r["ratio"], *r["paired"]],
            "wall s per seed": [f.data["wall_s"] for f in r["fronts"]],
        }
    header, rows = md_table(repo, rel)
    return check_md_rows(rel, header, rows, wants, 3)


def check_field_published(repo: Repo, rel: str) -> Findings:
    """`published.json`: each entry a task of its protocol, on the task's definition and
    the protocol's budget, with a method, a positive hypervolume, its seeds and its
    source, none twice; those from COLA's Table 1 as `COLA_TABLE_1` prints them, and on
    C-MORL's protocol every one of D3PO's table (`D3PO_TABLE`), as it prints them, none
    left out and no other."""
    out, seen = Findings(), set()
    d3po = {
        (env, method)
        for env, task in FIELD_PROTOCOLS["cmorl"].tasks.items()
        for method in D3PO_TABLE.get(task.published, {})
    }
    for i, e in enumerate(repo.json(rel)["entries"]):
        key = (e.get("protocol"), e.get("task"), e.get("method"))
        w = f"{rel} entry {i} {key}"
        task = protocol_task(key[0], key[1])
        if task is None:
            out.append(f"{w}: not a task of a protocol")
            continue
        out.equal(f"{w} definition", e.get("definition"), task.definition)
        out.equal(f"{w} budget", e.get("budget"), FIELD_PROTOCOLS[key[0]].budget[task.m])
        hv, seeds, source = e.get("hv"), e.get("seeds"), e.get("source")
        if not (isinstance(hv, int | float) and math.isfinite(hv) and hv > 0):
            out.append(f"{w} hv: states {hv!r}, not a positive number")
        if not (isinstance(seeds, int) and seeds >= 1):
            out.append(f"{w} seeds: states {seeds!r}, not a number of runs")
        if not (isinstance(source, str) and source.strip() and isinstance(key[2], str)):
            out.append(f"{w}: states no method or source")
        if key in seen:
            out.append(f"{w}: stated twice")
        seen.add(key)
        if isinstance(source, str) and source.startswith("COLA"):
            method = str(key[2]).replace("Envelope-SAC", "Envelope SAC")
            printed = COLA_TABLE_1.get(task.published, {}).get(method)
            if printed is None:
                out.append(f"{w}: not in COLA's Table 1")
            else:
                out.close(f"{w} hv", hv, printed[0][0])
        if key[0] != "cmorl":
            continue
        printed = D3PO_TABLE.get(task.published, {}).get(key[2])
        if printed is None:
            out.append(f"{w}: not in D3PO's table")
            continue
        if not (isinstance(source, str) and source.startswith("D3PO")):
            out.append(f"{w} source: states {source!r}, the number is D3PO's table's")
        if not isinstance(hv, int | float) or not math.isclose(hv, printed, rel_tol=RTOL):
            out.append(f"{w} hv: states {hv!r}, D3PO's table prints {printed!r}")
        out.equal(f"{w} seeds", seeds, D3PO_SEEDS)
    stated = {(env, m) for p, env, m in seen if p == "cmorl"}
    if d3po - stated:
        out.append(f"{rel}: leaves out D3PO's {sorted(d3po - stated)}")
    return out


# ---------------------------------------------------------------------- MO-Gymnasium


def reevaluation_agreement(d: dict) -> dict:
    """An MO-Gymnasium evaluation's agreement with the project's, per kind of return, from
    its per-preference means and standard deviations: every difference `ours - project`
    against `s * sqrt(1/K + 1/K')`; the largest `|d|` (the first of equal ones), the
    largest `|z|`, how many pass 2 and 3 standard errors, how many have one, how many
    did not vary."""
    k, k2 = d["episodes"], d["project_episodes"]
    factor, out = math.sqrt(1.0 / k + 1.0 / k2), {}
    for kind in ("return", "discounted_return"):
        diffs = []
        for row in d["prefs"]:
            for j, (ours, theirs) in enumerate(zip(row[kind], row["project"][kind], strict=True)):
                s = row[f"{kind}_std"][j]
                se = None if s is None else s * factor
                diffs.append(
                    {
                        "pref": row["pref"],
                        "objective": j,
                        "difference": ours - theirs,
                        "se": se,
                        "z": (ours - theirs) / se if se else None,
                        "se_of_mean": None if s is None else s / math.sqrt(k),
                    }
                )
        zs = [abs(x["z"]) for x in diffs if x["z"] is not None]
        out[kind] = {
            "largest_difference": max(diffs, key=lambda x: abs(x["difference"])),
            "max_abs_z": max(zs) if zs else None,
            "beyond_2se": sum(z > 2 for z in zs),
            "beyond_3se": sum(z > 3 for z in zs),
            "n": len(zs),
            "no_noise": sum(x["se"] == 0 for x in diffs),
        }
    return out


def reevaluation_departures(d: dict) -> list[tuple[str, list]]:
    p = FIELD_PROTOCOLS[d["run_config"]["protocol"]]
    task, out = p.tasks[d["env"]], []
    prefs = np.asarray([row["pref"] for row in d["prefs"]], np.float64)
    grid = p.prefs(task.m)
    if prefs.shape != grid.shape or not np.allclose(prefs, grid, atol=1e-6):
        out.append(("preferences", [len(prefs), len(grid)]))
    if d["episodes"] != task.episodes:
        out.append(("episodes", [d["episodes"], task.episodes]))
    if p.convention.discounted and d["gamma"] != p.convention.gamma:
        out.append(("discounted", [d["gamma"], p.convention.gamma]))
    return out


def check_reevaluation(repo: Repo, rel: str, hv_ref=None) -> Findings:
    """`python -m wcac_jax.evaluate RUN --in mo-gymnasium`'s record: a finished run's
    policies re-run in MO-Gymnasium, beside the project's evaluation of them. Not a
    front: it states no hypervolume of its own at a reference and trains nothing; it is
    claimed here because its rows hold evaluated returns.

    What its committed data give: the task's MO-Gymnasium id and time limit, which
    policies, the discount, each preference's mean episode length and its standard
    deviation from the episodes' lengths (each within the limit), the standard errors
    `std / sqrt(K)`, the whole `agreement` (differences, their standard errors and `z`,
    the largest, the counts past 2 and 3) from the means and standard deviations, and
    for a protocol's run both evaluations' protocol scores and the departures. What they
    do not: the MO-Gymnasium side's means and standard deviations of the returns (the
    record keeps no per-episode returns) and the project's side (the runs, under `runs/`,
    are not committed), so neither is recomputed here."""
    d, out = repo.json(rel), Findings()
    config, env, m = d["run_config"], d["env"], len(d["objective_names"])
    k = d["episodes"]
    out.equal(f"{rel} env", config["env"], env)
    out.equal(f"{rel} mo_gymnasium_id", d["mo_gymnasium_id"], MO_GYMNASIUM_IDS.get(env))
    limit = config.get("env_options", {}).get("episode_length", T)
    out.equal(f"{rel} max_episode_steps", d["mo_gymnasium_kwargs"].get("max_episode_steps"), limit)
    conditioned = config["train"].get("kind") == "conditioned"
    policies = "conditioned" if conditioned else "chosen" if config["select_last"] > 1 else "final"
    out.equal(f"{rel} policies", d["policies"], policies)
    if d.get("project_source", "front.json") == "front.json":
        out.equal(f"{rel} project_episodes", d["project_episodes"], config["eval_episodes"])
    name = config.get("protocol")
    if name is not None and FIELD_PROTOCOLS[name].convention.discounted:
        out.close(f"{rel} gamma", d["gamma"], FIELD_PROTOCOLS[name].convention.gamma)
    else:
        out.close(f"{rel} gamma", d["gamma"], config["train"]["gamma"])
    for i, row in enumerate(d["prefs"]):
        w = f"{rel} pref {i}"
        lengths = np.asarray(row["episode_lengths"], np.float64)
        out.equal(f"{w} episodes", len(lengths), k)
        out.close(f"{w} episode_length", row["episode_length"], float(lengths.mean()))
        std = float(np.std(lengths, ddof=1)) if k > 1 else None
        out.close(f"{w} episode_length_std", row["episode_length_std"], std)
        if len(lengths) and not 1 <= lengths.min() <= lengths.max() <= limit:
            out.append(f"{w} episode_lengths: outside 1 to {limit}")
        for kind in ("return", "discounted_return"):
            out.equal(f"{w} {kind} objectives", [len(row[kind]), len(row["project"][kind])], [m, m])
            for j, (s, se) in enumerate(zip(row[f"{kind}_std"], row[f"{kind}_se"], strict=True)):
                out.close(f"{w} {kind}_se [{j}]", se, None if s is None else s / math.sqrt(k))
    want = reevaluation_agreement(d)
    out.equal(f"{rel} agreement kinds", sorted(d["agreement"]), sorted(want))
    for kind, b in want.items():
        w, a = f"{rel} agreement {kind}", d["agreement"].get(kind)
        if a is None:
            continue
        big, stated = b["largest_difference"], a["largest_difference"]
        out.equal(
            f"{w} largest_difference at",
            [stated["pref"], stated["objective"]],
            [big["pref"], big["objective"]],
        )
        for key in ("difference", "se", "z", "se_of_mean"):
            out.close(f"{w} largest_difference {key}", stated[key], big[key])
        out.close(f"{w} max_abs_z", a["max_abs_z"], b["max_abs_z"])
        for key in ("beyond_2se", "beyond_3se", "n", "no_noise"):
            out.equal(f"{w} {key}", a[key], b[key])
    s = d.get("protocol")
    if (s is None) != (name is None):
        out.append(f"{rel} protocol: states {s!r} for a run of protocol {name!r}")
    if s is None or name is None:
        return out
    conv = FIELD_PROTOCOLS[name].convention
    out.equal(
        f"{rel} protocol name and returns", [s["protocol"], s["returns"]], [name, conv.returns]
    )
    for side, pts in (
        ("mo_gymnasium", [row[conv.returns] for row in d["prefs"]]),
        ("project", [row["project"][conv.returns] for row in d["prefs"]]),
    ):
        score = conv.score(pts)
        for key in ("hv", "eu"):
            out.close(f"{rel} protocol {side} {key}", s[side][key], score[key])
        for key in ("nondominated", "kept"):
            out.equal(f"{rel} protocol {side} {key}", s[side][key], score[key])
    out.extend(
        check_departures(f"{rel} protocol deviations", s["deviations"], reevaluation_departures(d))
    )
    return out


def check_field_reevaluation(repo: Repo, rel: str, hv_ref=None) -> Findings:
    """The MO-Gymnasium evaluation `field.py run` writes beside a front: what every
    evaluation states (`check_reevaluation`), and that it evaluated that front's run: its
    configuration (with the env steps trained), and on the project's side the front's
    own preferences, returns and lengths."""
    out = check_reevaluation(repo, rel, hv_ref)
    front = f"{os.path.dirname(rel)}/front.json"
    if not repo.exists(front):
        out.append(f"{rel}: no front beside it")
        return out
    d, f = repo.json(rel), repo.front(front)
    want = {**f.data["config"], "env_steps_total": f.data["env_steps_total"]}
    out.equal(f"{rel} run_config", d["run_config"], want)
    out.equal(f"{rel} project_source", d.get("project_source"), "front.json")
    out.equal(f"{rel} prefs", [row["pref"] for row in d["prefs"]], f.prefs.tolist())
    for key, theirs in (("return", f.returns), ("discounted_return", f.discounted)):
        ours = np.asarray([row["project"][key] for row in d["prefs"]], np.float64)
        if ours.shape != theirs.shape or not np.allclose(ours, theirs, rtol=RTOL, atol=0):
            out.append(f"{rel} project {key}: not the returns of {front}")
    lengths = np.asarray([row["project"]["episode_length"] for row in d["prefs"]], np.float64)
    if lengths.shape != f.lengths.shape or not np.allclose(lengths, f.lengths, rtol=RTOL):
        out.append(f"{rel} project episode_length: not the lengths of {front}")
    return out


# ---------------------------------------------------------------------- families


@dataclass(frozen=True)
class Family:
    """One kind of committed result: where its fronts are, the reference point each
    `front.json` states its hypervolume at (per task), and the files its numbers feed,
    each with its check (`(glob, check(repo, path))`, every glob relative to the
    results). The docs' numbers are checked by `DOC_TABLES` and `DOC_VALUES`."""

    name: str
    fronts: tuple[str, ...]
    hv_ref: dict | None
    feeds: tuple[tuple[str, Callable[[Repo, str], Findings]], ...] = ()
    # what each of its files states of itself: `check_front` at the family's reference
    # (`own(repo, path, hv_ref[env])`), or with `hv_ref` None a check of its own kind
    own: Callable[[Repo, str, tuple | None], Findings] = check_front


WALKER2D = {"walker2d": (-500.0, -3000.0)}  # (-T, -6T): Walker2d's stated reference
BRAX_WALKER2D = {"walker2d": (-100.0, -100.0)}  # the earlier default, on Brax's model
# each v5 task's stated reference (`default_hv_ref`): per objective a floor per step
# times T, written into every front.json
V5_TASKS = WALKER2D | {
    "halfcheetah": (-5000.0, -3000.0),
    "hopper": (-500.0, -2258.0, -1500.0),
    "hopper-2obj": (-501.5, -2259.5),
    "swimmer": (-250.0, -1000.0),
    "ant": (-2500.0, -2500.0, -4500.0),
    "ant-2obj": (-4500.0, -4500.0),
    "humanoid": (-6500.0, -6500.0),
}
# PGMORL's and COLA's tasks (`*-pgmorl`, `*-cola`), each per objective a floor per step
# times the episode's steps, as each environment states it
_HOPPER_COST = 2e-4 * 24.0  # the largest control cost per step
_HOPPER_ALIVE = 12.0 * (0.4 - 1.25) + 1.0 - _HOPPER_COST  # height term at z = 0.4
_HOPPER_FALL = 12.0 * (0.0 - 1.25) + 1.0 - _HOPPER_COST  # and at z = 0, the falling step
_HOPPER_2 = ((1.5 * -2.0 + 1.0 - _HOPPER_COST) * 500.0, _HOPPER_ALIVE * 499.0 + _HOPPER_FALL)
PGMORL_TASKS = {
    "walker2d-pgmorl": (-500.0, -500.0),
    "halfcheetah-pgmorl": (-4500.0, -500.0),
    "hopper-pgmorl": _HOPPER_2,
    "hopper3-pgmorl": (
        _HOPPER_2[0] + _HOPPER_COST * 500.0,
        _HOPPER_2[1] + _HOPPER_COST * 500.0,
        (4.0 - 24.0 + 1.0) * 500.0,
    ),
    "ant-pgmorl": (-3500.0, -3500.0),
    "swimmer-pgmorl": (-500.0, 0.0),
    "humanoid-pgmorl": ((1.25 * -3.0 + 3.0) * 1000.0, (3.0 + 3.0 - 4.0 * (17 * 0.4**2)) * 1000.0),
    "halfcheetah-cola": (-2000.0, -500.0),
    "ant3-cola": (-2000.0, -2000.0, 0.0),
}


FAMILIES = (
    Family(
        "the first command (`wcac-sweep --n-prefs 9`), chosen and final policies",
        ("cli_default_front_select5/seed*/front.json", "cli_default_front_final/seed*/front.json"),
        WALKER2D,
    ),
    Family(
        "walker2d_front.py: both directions on the paper's nine preferences",
        (
            "walker2d_front_practical_v5*/**/front.json",
            "walker2d_front_paper_v5/*/front.json",
            "walker2d_front_paper_warm_brax_*/*/front.json",
        ),
        WALKER2D,
        (("walker2d_front_*/**/summary.json", check_walker2d_front_summary),),
    ),
    Family(
        "walker2d_curves.py: the [1, 0] end over three seeds",
        ("walker2d_curves_*/*/front.json",),
        WALKER2D,
        (("walker2d_curves_*/curves.json", check_curves),),
    ),
    Family(
        "walker2d_ablation.py on the v5 model: depth and width",
        ("walker2d_ablation_practical_*/*/front.json", "walker2d_ablation_paper_v5*/*/front.json"),
        WALKER2D,
        (
            ("walker2d_ablation_practical_*/ablation.json", check_ablation),
            ("walker2d_ablation_paper_v5*/ablation.json", check_ablation),
        ),
    ),
    Family(
        "walker2d_ablation.py on Brax's model",
        ("walker2d_ablation_paper_warm_brax_*/*/front.json",),
        BRAX_WALKER2D,
        (("walker2d_ablation_paper_warm_brax_*/ablation.json", check_ablation),),
    ),
    Family(
        "conditioned_front.py: one network against independent policies",
        ("conditioned_walker2d/**/front.json",),
        WALKER2D,
        (("conditioned_walker2d/summary.json", check_conditioned),),
    ),
    Family(
        "mo_mujoco.py: the MO-Gymnasium MuJoCo suite",
        ("mo_mujoco/**/front.json",),
        V5_TASKS,
        (("mo_mujoco/table.json", check_mo_mujoco),),
    ),
    Family(
        "forward-end probes: independent runs of one task's [1, 0]",
        ("*_forward_end_practical_v5/*/front.json",),
        V5_TASKS,
    ),
    Family(
        "the sweep command's benchmarks",
        ("bench_cli_*/front*.json",),
        BRAX_WALKER2D,
    ),
    Family(
        "field.py: the field's protocols, their table and the ablation",
        ("field/*/*/seed*/front.json", "field/ablation/*/*/*/seed*/front.json"),
        V5_TASKS | PGMORL_TASKS,
        (
            ("field/table.json", check_field_table),
            ("field/table.md", check_field_table_md),
            ("field/ablation.json", check_field_ablation),
            ("field/ablation.md", check_field_ablation_md),
            ("field/published.json", check_field_published),
        ),
        own=check_protocol_front,
    ),
    Family(
        "wcac_jax.evaluate: finished runs' policies re-run in MO-Gymnasium (not fronts)",
        ("mo_gymnasium_eval/*.json",),
        None,
        own=check_reevaluation,
    ),
    Family(
        "field.py run: each C-MORL-protocol run re-run in MO-Gymnasium beside its front",
        (
            f"field/*/*/seed*/{FIELD_EVALUATION}",
            f"field/ablation/*/*/*/seed*/{FIELD_EVALUATION}",
        ),
        None,
        own=check_field_reevaluation,
    ),
)


def check_families(repo: Repo, families=FAMILIES) -> Findings:
    """Every committed front belongs to exactly one family and states what its data give;
    every file a family feeds states what its fronts give."""
    out, owner = Findings(), {}
    for fam in families:
        for pattern in fam.fronts:
            for rel in repo.glob(f"{RESULTS}/{pattern}"):
                if rel in owner and owner[rel] != fam.name:
                    out.append(f"{rel}: claimed by {owner[rel]!r} and {fam.name!r}")
                owner[rel] = fam.name
    walked = repo.fronts()
    for rel in walked:
        if rel not in owner:
            out.append(f"{rel}: no family audits it (add one to FAMILIES)")
    by_name = {fam.name: fam for fam in families}
    for rel in walked:
        if rel not in owner:
            continue
        fam, env = by_name[owner[rel]], repo.front(rel).env
        if fam.hv_ref is None:
            out.extend(fam.own(repo, rel, None))
            continue
        if env not in fam.hv_ref:
            out.append(f"{rel}: {fam.name!r} states no reference for {env!r}")
            continue
        out.extend(fam.own(repo, rel, fam.hv_ref[env]))
    for fam in families:
        for pattern, check in fam.feeds:
            paths = repo.glob(f"{RESULTS}/{pattern}")
            if not paths:
                out.append(f"{fam.name}: no {pattern}")
            for rel in paths:
                out.extend(check(repo, rel))
    return out


# ---------------------------------------------------------------------- problems with known answers

EXPLORATION = f"{RESULTS}/exploration/exploration.json"
CONVERGENCE = f"{RESULTS}/convergence/convergence.json"
# what the float32 arithmetic of the scripts that wrote them leaves: their sines, bisection
# and divisions (measured: at most 9e-8 on an angle, 5e-9 relative on an area)
F32 = 1e-6
# a least-squares slope through float32 logs (measured: at most 4e-7 from float64's)
SLOPE_TOL = 1e-5
# points closer than this count as one: the bandit's (objectives in [0, 1]) and Deep Sea
# Treasure's (treasure up to 124), as experiments/pareto_exploration.py counts them
BANDIT_DISTINCT, DST_DISTINCT = 0.02, 1.0
# the exact fronts' hypervolumes the ratios divide by. The bandit's is the area its front
# dominates, integrated here (`bandit_front_hv`) by the trapezoid rule along the front at
# this many evenly spaced angles: its chords lie above the arc by about 1e-11 of area in
# all, far inside the 1e-9 it is checked to. Deep Sea Treasure's, as the script takes it:
# each edge of its front at this many evenly spaced points (the staircase lies under the
# front, by 0.004% of its area)
BANDIT_FRONT_ANGLES, DST_EDGE_SAMPLES = 200_001, 20001
# the script's search for Deep Sea Treasure's optima: 100,001 evenly spaced points of the
# front, so each lies within one step of the exact optimum
DST_SEARCH_STEPS = 100_000
# Deep Sea Treasure's "on the front" and "within 1 of `p`'s optimum": this distance
NEAR = 1.0
# the treasures of Deep Sea Treasure's concave map (Vamplew et al.; MO-Gymnasium's
# `deep-sea-treasure-concave-v0`), one per column from the start's: (row, value)
DST_TREASURES = (
    (1, 1.0),
    (2, 2.0),
    (3, 3.0),
    (4, 5.0),
    (4, 8.0),
    (4, 16.0),
    (7, 24.0),
    (7, 50.0),
    (9, 74.0),
    (10, 124.0),
)
# the tabular MOMDP's default, the setting the README's glance names: the harmonic step
# `alpha/(t+1)`, mu 0.1, networks of width 32 and depth 1 (wcac_jax/sweep/presets.py)
TABULAR_DEFAULT = {"actor_optimizer": "normalized_harmonic", "mu": 0.1, "width": 32, "depth": 1}


def bandit_reward(theta) -> np.ndarray:
    """The concave bandit's rewards `(1 - sin t, 1 - cos t)` `[n, 2]` of the angles `[n]`."""
    theta = np.asarray(theta, np.float64)
    return np.stack([1.0 - np.sin(theta), 1.0 - np.cos(theta)], axis=-1)


def bandit_front_hv(ref) -> float:
    """The hypervolume of the region the bandit's exact front dominates above `ref` (at or
    below `(0, 0)`, where the front's least values lie), by the trapezoid rule: the front
    at `BANDIT_FRONT_ANGLES` evenly spaced angles, from `(1, 0)` (`t = 0`, `x` decreasing
    with `t`) to `(0, 1)`, the area under each chord down to `ref[1]`, and the box that
    `(0, 1)` dominates left of the front."""
    x, y = bandit_reward(np.linspace(0.0, math.pi / 2, BANDIT_FRONT_ANGLES)).T
    under = float(np.sum((x[:-1] - x[1:]) * (0.5 * (y[:-1] + y[1:]) - ref[1])))
    return under + float((x[-1] - ref[0]) * (y[-1] - ref[1]))


def bandit_wc_theta(pref, z) -> float:
    """The angle of the bandit's front that minimises `max_i p_i (z_i - r_i(t))`: where
    `p_0 (z_0 - 1 + sin t) = p_1 (z_1 - 1 + cos t)` (the left side minus the right
    increases with `t`), by scipy's brentq; an end of `[0, pi/2]` where they do not
    cross."""

    def f(t: float) -> float:
        return pref[0] * (z[0] - 1.0 + math.sin(t)) - pref[1] * (z[1] - 1.0 + math.cos(t))

    if f(0.0) >= 0.0:
        return 0.0
    if f(math.pi / 2) <= 0.0:
        return math.pi / 2
    return float(brentq(f, 0.0, math.pi / 2, xtol=1e-14))


def count_distinct(points, min_dist: float) -> int:
    """How many of the points, taken in order, lie more than `min_dist` (Euclidean) from
    every one counted before."""
    kept: list[np.ndarray] = []
    for p in np.asarray(points, np.float64):
        if all(np.linalg.norm(p - q) > min_dist for q in kept):
            kept.append(p)
    return len(kept)


def largest_gap(positions, lo: float, hi: float) -> float:
    """The largest gap between neighbouring positions in `[lo, hi]`, the ends included."""
    return float(np.max(np.diff(np.sort(np.concatenate([[lo, hi], positions])))))


def dst_paths(gamma: float) -> np.ndarray:
    """`[10, 2]`: the discounted returns of the shortest path to each treasure of
    `DST_TREASURES`, `n = row + column` steps: the treasure on the last step, -1 on each."""
    n = np.array([row + c for c, (row, _) in enumerate(DST_TREASURES)], np.float64)
    value = np.array([v for _, v in DST_TREASURES])
    return np.stack([value * gamma ** (n - 1), -(1.0 - gamma**n) / (1.0 - gamma)], axis=1)


def upper_right_hull(points) -> np.ndarray:
    """The vertices of the front of the convex hull of `points` `[n, 2]` (maximised), by
    increasing first objective: scipy's hull's vertices (counterclockwise) from the one
    with the largest first objective to the one with the largest second."""
    pts = np.asarray(points, np.float64)
    ring = [int(i) for i in ConvexHull(pts).vertices]
    right = max(ring, key=lambda i: (pts[i, 0], pts[i, 1]))
    top = max(ring, key=lambda i: (pts[i, 1], pts[i, 0]))
    k, chain = ring.index(right), [right]
    while chain[-1] != top:
        k = (k + 1) % len(ring)
        chain.append(ring[k])
    return pts[chain[::-1]]


def _edges(front: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    return list(zip(front[:-1], front[1:], strict=True)) or [(front[0], front[0])]


def to_front(points, front) -> tuple[np.ndarray, np.ndarray]:
    """Each point's distance to the piecewise-linear front `[k, 2]`, and where along the
    front (a fraction of its length) its nearest point of the front lies."""
    pts, front = np.asarray(points, np.float64), np.asarray(front, np.float64)
    edges = _edges(front)
    lengths = np.array([np.linalg.norm(b - a) for a, b in edges])
    starts = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    dist, along = np.full(len(pts), np.inf), np.zeros(len(pts))
    for (a, b), start, length in zip(edges, starts, lengths, strict=True):
        t = np.clip((pts - a) @ (b - a) / max(length**2, 1e-300), 0.0, 1.0)
        d = np.linalg.norm(pts - (a + t[:, None] * (b - a)), axis=1)
        nearer = d < dist
        dist[nearer], along[nearer] = d[nearer], (start + t * length)[nearer]
    return dist, along / max(float(lengths.sum()), 1e-300)


def front_wc_optimum(pref, front, z) -> np.ndarray:
    """The point of the piecewise-linear front `[k, 2]` that minimises
    `max_i p_i (z_i - J_i)`: along each edge the larger of two linear functions of the
    position, least at an end or where the two cross."""
    pref, front, z = (np.asarray(v, np.float64) for v in (pref, front, z))
    best, least = front[0], math.inf
    for a, b in _edges(front):
        c, k = pref * (z - a), pref * (b - a)  # objective i's term at position s: c_i - s k_i
        positions = [0.0, 1.0]
        if k[0] != k[1]:
            positions.append(min(max((c[0] - c[1]) / (k[0] - k[1]), 0.0), 1.0))
        for s in positions:
            value = float(np.max(c - s * k))
            if value < least:
                best, least = a + s * (b - a), value
    return best


@dataclass
class Bandit:
    """One direction's result on the concave bandit, from its learned angles."""

    theta: np.ndarray  # [P]
    target: np.ndarray  # [P] each preference's optimum (`bandit_wc_theta`)
    exact_hv: float  # the exact front's (`bandit_front_hv`)
    ref: np.ndarray

    @cached_property
    def points(self) -> np.ndarray:
        return bandit_reward(self.theta)

    @cached_property
    def error(self) -> np.ndarray:
        return np.abs(self.theta - self.target)

    @property
    def distinct(self) -> int:
        return count_distinct(self.points, BANDIT_DISTINCT)

    @property
    def hv(self) -> float:
        return hypervolume(self.points, self.ref)

    @property
    def gap(self) -> float:
        return largest_gap(self.theta, 0.0, math.pi / 2)


def bandit_results(d: dict) -> dict[str, Bandit]:
    """`{direction: Bandit}` of exploration.json's concave bandit."""
    b = d["problems"]["concave_bandit"]
    ref = np.asarray(b["hv_ref"], np.float64)
    target = np.array([bandit_wc_theta(p, b["j_ub"]) for p in d["prefs"]])
    exact = bandit_front_hv(ref)
    return {
        k: Bandit(np.asarray(v["theta"], np.float64), target, exact, ref)
        for k, v in b["directions"].items()
    }


@dataclass
class Treasure:
    """One direction's result on Deep Sea Treasure, from its points (the learned
    policies' exact expected returns, NaN where training diverged)."""

    points: np.ndarray  # [P, 2]
    front: np.ndarray  # [k, 2] the exact front (`upper_right_hull` of `dst_paths`)
    target: np.ndarray  # [P, 2] each preference's optimum on it (`front_wc_optimum`)
    exact_hv: float  # the sampled exact front's
    ref: np.ndarray

    @cached_property
    def finite(self) -> np.ndarray:
        return self.points[np.all(np.isfinite(self.points), axis=1)]

    @cached_property
    def to_front(self) -> tuple[np.ndarray, np.ndarray]:
        return to_front(self.finite, self.front)

    @property
    def near(self) -> int:
        return int(np.sum(self.to_front[0] < NEAR))

    def near_target(self, target) -> int:
        return int(np.sum(np.linalg.norm(self.points - target, axis=1) <= NEAR))

    @property
    def distinct(self) -> int:
        return count_distinct(self.finite, DST_DISTINCT)

    @property
    def hv(self) -> float:
        return hypervolume(self.finite, self.ref) if len(self.finite) else 0.0

    @property
    def gap(self) -> float:
        dist, along = self.to_front
        return largest_gap(along[dist < NEAR], 0.0, 1.0)


def treasure_results(d: dict) -> dict[str, Treasure]:
    """`{direction: Treasure}` of exploration.json's Deep Sea Treasure."""
    s = d["problems"]["deep_sea_treasure"]
    ref = np.asarray(s["hv_ref"], np.float64)
    front = upper_right_hull(dst_paths(s["config"]["gamma"]))
    target = np.array([front_wc_optimum(p, front, s["j_ub"]) for p in d["prefs"]])
    s_ = np.linspace(0.0, 1.0, DST_EDGE_SAMPLES)[:, None]
    exact = hypervolume(np.concatenate([a + s_ * (b - a) for a, b in _edges(front)]), ref)
    return {
        k: Treasure(np.asarray(v["points"], np.float64), front, target, exact, ref)
        for k, v in s["directions"].items()
    }


def check_exploration(repo: Repo, rel: str = EXPLORATION) -> Findings:
    """exploration.json: every number it states, from the learned angles (the concave
    bandit) and the learned policies' exact returns (Deep Sea Treasure), each problem's
    exact answers recomputed here: the bandit's optima (root finding) and its front's
    hypervolume; Deep Sea Treasure's shortest paths, front, optima and front's
    hypervolume."""
    out, d = Findings(), repo.json(rel)
    out.each(f"{rel} prefs", d["prefs"], front_json_weights(2, len(d["prefs"])), 1e-12)
    b, w = d["problems"]["concave_bandit"], f"{rel} concave_bandit"
    bandit = bandit_results(d)
    first = next(iter(bandit.values()))
    out.each(f"{w} wc_optimum_theta", b["wc_optimum_theta"], first.target, F32)
    out.close(f"{w} exact_front_hypervolume", b["exact_front_hypervolume"], first.exact_hv, 1e-9)
    for k, v in b["directions"].items():
        r, wk = bandit[k], f"{w} {k}"
        target_points = bandit_reward(r.target)
        out.each(f"{wk} points", v["points"], r.points, F32)
        out.each(f"{wk} theta_error", v["theta_error"], r.error, F32)
        out.close(f"{wk} max_theta_error", v["max_theta_error"], r.error.max(), 0.0, F32)
        out.close(f"{wk} median_theta_error", v["median_theta_error"], np.median(r.error), 0, F32)
        out.close(
            f"{wk} max_distance_to_wc_optimum",
            v["max_distance_to_wc_optimum"],
            np.linalg.norm(r.points - target_points, axis=1).max(),
            0.0,
            F32,
        )
        out.equal(f"{wk} distinct_points", v["distinct_points"], r.distinct)
        out.close(f"{wk} hypervolume", v["hypervolume"], r.hv, F32)
        out.close(f"{wk} hypervolume_ratio", v["hypervolume_ratio"], r.hv / r.exact_hv, F32)
        out.close(f"{wk} largest_theta_gap", v["largest_theta_gap"], r.gap)
    s, w = d["problems"]["deep_sea_treasure"], f"{rel} deep_sea_treasure"
    treasure = treasure_results(d)
    first = next(iter(treasure.values()))
    paths = dst_paths(s["config"]["gamma"])
    out.each(f"{w} treasure_path_returns", s["treasure_path_returns"], paths, 1e-9)
    out.each(f"{w} exact_front", s["exact_front"], first.front, 1e-9)
    out.close(f"{w} exact_front_hypervolume", s["exact_front_hypervolume"], first.exact_hv)
    step = float(np.sum(np.linalg.norm(np.diff(first.front, axis=0), axis=1))) / DST_SEARCH_STEPS
    out.each(f"{w} wc_optimum", s["wc_optimum"], first.target, step)
    stated_target = np.asarray(s["wc_optimum"], np.float64)
    for k, v in s["directions"].items():
        r, wk = treasure[k], f"{w} {k}"
        dist = np.full(len(r.points), np.nan)  # NaN where training diverged, as stated
        dist[np.all(np.isfinite(r.points), axis=1)] = r.to_front[0]
        to_target = np.linalg.norm(r.points - stated_target, axis=1)
        out.equal(f"{wk} diverged", v["diverged"], len(r.points) - len(r.finite))
        out.each(f"{wk} distance_to_front", v["distance_to_front"], dist, 1e-9)
        out.close(f"{wk} max_distance_to_front", v["max_distance_to_front"], r.to_front[0].max())
        out.equal(f"{wk} points_near_front", v["points_near_front"], r.near)
        out.each(f"{wk} distance_to_wc_optimum", v["distance_to_wc_optimum"], to_target, 1e-9)
        out.close(
            f"{wk} max_distance_to_wc_optimum",
            v["max_distance_to_wc_optimum"],
            np.nanmax(to_target),
        )
        out.close(
            f"{wk} median_distance_to_wc_optimum",
            v["median_distance_to_wc_optimum"],
            np.nanmedian(to_target),
        )
        out.equal(f"{wk} distinct_points", v["distinct_points"], r.distinct)
        out.close(f"{wk} hypervolume", v["hypervolume"], r.hv)
        out.close(f"{wk} hypervolume_ratio", v["hypervolume_ratio"], r.hv / r.exact_hv)
        out.close(f"{wk} largest_gap_along_front", v["largest_gap_along_front"], r.gap)
    return out


def setting_name(config: dict) -> str:
    """A convergence setting's name as convergence_rate.py writes it, from its config."""
    step = {"normalized_harmonic": "alpha/(t+1)", "normalized": "constant alpha"}
    name = f"{step[config['actor_optimizer']]}, mu={config['mu']}"
    nets = (config["width"], config["depth"]) != (32, 1)
    return name + (f", nets w={config['width']} D={config['depth']}" if nets else "")


def log_log_slope(t, gap) -> float:
    """The least-squares slope of `log gap` against `log t` over the second half of the
    run (`t >= t_last / 2`), where the gap is positive (NaN with fewer than two such)."""
    t, gap = np.asarray(t, np.float64), np.asarray(gap, np.float64)
    keep = (t >= t[-1] / 2) & (gap > 0)
    if keep.sum() < 2:
        return math.nan
    return float(linregress(np.log(t[keep]), np.log(gap[keep])).slope)


def check_convergence(repo: Repo, rel: str = CONVERGENCE) -> Findings:
    """convergence.json: per setting, its name is its config's, its measurements run from
    iteration 0 to the last evenly; per preference the initial and final gaps, their
    ratio and the log-log slope of the second half (of the measurements after the
    first), from the measured gaps."""
    out, d = Findings(), repo.json(rel)
    for r in d["results"]:
        name, w = r["setting"]["name"], f"{rel} {r['setting']['name']}"
        out.equal(f"{w} name", name, setting_name(r["config"]))
        for key, value in r["setting"].items():
            if key != "name":
                out.equal(f"{w} config {key}", r["config"].get(key), value)
        t = np.asarray(r["t"], np.float64)
        steps = np.diff(t)
        if t[0] != 0 or t[-1] != d["iterations"] or len(set(steps.tolist())) != 1:
            out.append(f"{w} t: from {t[0]} to {t[-1]}, not 0 to {d['iterations']} evenly")
        for p in r["prefs"]:
            gap, wp = np.asarray(p["gap"], np.float64), f"{w} pref {p['pref']}"
            out.equal(f"{wp} measurements", len(gap), len(t))
            out.close(f"{wp} initial_gap", p["initial_gap"], gap[0])
            out.close(f"{wp} final_gap", p["final_gap"], gap[-1])
            out.close(f"{wp} final_over_initial", p["final_over_initial"], gap[-1] / gap[0], F32)
            out.close(f"{wp} slope", p["slope"], log_log_slope(t[1:], gap[1:]), 0.0, SLOPE_TOL)
    return out


def convergence_results(repo: Repo, rel: str) -> dict[str, dict]:
    """`{name: {"worst": worst final / initial gap, "slopes": [...]}}` per setting of
    convergence.json, from its measured gaps (its name from its config)."""
    out = {}
    for r in repo.json(rel)["results"]:
        gaps = [np.asarray(p["gap"], np.float64) for p in r["prefs"]]
        out[setting_name(r["config"])] = {
            "config": r["config"],
            "worst": float(max(g[-1] / g[0] for g in gaps)),
            "slopes": [log_log_slope(r["t"][1:], g[1:]) for g in gaps],
        }
    return out


def check_known_answers(repo: Repo) -> Findings:
    """exploration.json and convergence.json, each present and what its data give."""
    out = Findings()
    for rel, check in ((EXPLORATION, check_exploration), (CONVERGENCE, check_convergence)):
        if not repo.exists(rel):
            out.append(f"{rel}: missing")
        else:
            out.extend(check(repo, rel))
    return out


def exploration_bandit_wants(t: Table, repo: Repo) -> Iterator:
    """The concave bandit's table, per direction from its learned angles: the distinct
    points, the median and largest distance of the angles from each preference's optimum,
    the hypervolume's share of the exact front's and the largest gap in angle."""
    printed = []
    for i, row in enumerate(t.rows):
        d = repo.json(t.links[i][0])
        direction = row[0].strip("`")
        printed.append(direction)
        r = bandit_results(d)[direction]
        yield i, "direction", None
        yield i, "distinct points", [r.distinct]
        yield (
            i,
            "`|θ − θ*(p)|` median, max (rad)",
            [float(np.median(r.error)), float(r.error.max())],
        )
        yield i, "HV / exact front's HV", [r.hv / r.exact_hv]
        yield i, "largest gap in θ (rad)", [r.gap]
    yield from unprinted(repo, EXPLORATION, "concave_bandit", printed)


def exploration_dst_wants(t: Table, repo: Repo) -> Iterator:
    """Deep Sea Treasure's table, per direction from its points: the distinct points,
    those within 1 of the exact front and of their preference's optimum on it, the
    hypervolume's share of the exact front's and the largest gap along the front."""
    printed = []
    for i, row in enumerate(t.rows):
        d = repo.json(t.links[i][0])
        direction = row[0].strip("`")
        printed.append(direction)
        r = treasure_results(d)[direction]
        n = len(d["prefs"])
        yield i, "direction", None
        yield i, "distinct points", [r.distinct]
        yield i, "on the front (within 1)", [r.near, n]
        yield i, "within 1 of `p`'s optimum", [r.near_target(r.target), n]
        yield i, "HV / exact front's HV", [r.hv / r.exact_hv]
        yield i, "largest gap along the front", [r.gap]
    yield from unprinted(repo, EXPLORATION, "deep_sea_treasure", printed)


def unprinted(repo: Repo, rel: str, problem: str, printed: list[str]) -> Iterator[str]:
    for direction in repo.json(rel)["problems"][problem]["directions"]:
        if printed.count(direction) != 1:
            yield f"{problem} {direction}: printed in {printed.count(direction)} rows, not one"


def convergence_wants(t: Table, repo: Repo) -> Iterator:
    """The tabular MOMDP's table, per setting (named by its config) from its measured
    gaps: the largest final / initial gap over its preferences (as many as the header
    says), and each preference's log-log slope of the second half."""
    printed = [row[0].strip("`") for row in t.rows]
    for i, name in enumerate(printed):
        r = convergence_results(repo, t.links[i][0])[name]
        yield -1, "final gap / initial gap (worst of 3)", [len(r["slopes"])]
        yield i, "setting", None
        yield i, "final gap / initial gap (worst of 3)", [100 * r["worst"]]
        yield i, "log-log slope, 2nd half", r["slopes"]
    for name in convergence_results(repo, CONVERGENCE):
        if printed.count(name) != 1:
            yield f"{name}: printed in {printed.count(name)} rows, not one"


# ---------------------------------------------------------------------- the documents

DOCS = ("README.md", "docs/algorithm.md", "docs/environments.md", "docs/performance.md")
DOCS += ("docs/results.md", "docs/recsys.md", "docs/distributed.md", "docs/protocols.md")
BLOCK = re.compile(r"<!-- table:([\w-]+) -->\n(.*?)<!-- /table -->", re.S)
VALUE = re.compile(r"<!-- value:([\w-]+) -->(.*?)<!-- /value -->", re.S)
LINK = re.compile(r"\[((?:[^\]\[]|\[[^\]]*\])*)\]\(([^)\s]+)\)")
# a number as the documents print it: thousands commas, a typographic minus, a mantissa
# and exponent (`4.65e6`); not the digits of a name (`hopper-2obj`, `3M`, `p₀`)
NUMBER = re.compile(r"(?<![\w.])[−+-]?\d+(?:,\d{3})*(?:\.\d+)?(?:e[−+-]?\d+)?(?![\w.]\d|[\w])")


def numbers(text: str) -> list[tuple[float, float]]:
    """Each number printed in `text`, with half a unit of its last printed digit."""
    out = []
    for m in NUMBER.finditer(text):
        s = m.group(0).replace("−", "-").replace(",", "")
        mantissa, _, exponent = s.partition("e")
        digits = len(mantissa.partition(".")[2])
        scale = 10.0 ** int(exponent or 0)
        out.append((float(s), 0.5 * 10.0**-digits * scale * (1 + 1e-6) + 1e-12))
    return out


@dataclass
class Table:
    """A generated table of a document: its cells with links replaced by their text,
    and each cell's first link target (relative to the repository)."""

    doc: str
    name: str
    header: list[str]
    header_links: list[str | None]
    rows: list[list[str]]
    links: list[list[str | None]]
    raw_rows: list[str]

    def column(self, header: str) -> int:
        return self.header.index(header)


def _cells(line: str, doc: str) -> tuple[list[str], list[str | None]]:
    cells = [c.strip() for c in line.strip().strip("|").split(" | ")]
    texts, links = [], []
    for c in cells:
        m = LINK.search(c)
        links.append(
            os.path.normpath(os.path.join(os.path.dirname(doc), m.group(2))) if m else None
        )
        texts.append(LINK.sub(lambda k: k.group(1), c))
    return texts, links


def doc_blocks(repo: Repo):
    """`({(doc, name): Table}, {(doc, name): (text, links)})` of every generated block."""
    tables, values = {}, {}
    for doc in DOCS:
        if not repo.exists(doc):
            continue
        text = repo.text(doc)
        for name, body in BLOCK.findall(text):
            lines = [ln for ln in body.strip().splitlines() if ln.startswith("|")]
            header, header_links = _cells(lines[0], doc)
            rows = [_cells(ln, doc) for ln in lines[2:]]
            tables[(doc, name)] = Table(
                doc,
                name,
                header,
                header_links,
                [r[0] for r in rows],
                [r[1] for r in rows],
                lines[2:],
            )
        for name, body in VALUE.findall(text):
            links = [
                os.path.normpath(os.path.join(os.path.dirname(doc), m.group(2)))
                for m in LINK.finditer(body)
            ]
            values[(doc, name)] = (LINK.sub(lambda k: k.group(1), body), links)
    return tables, values


# What a cell must print, in order: a number (equal to the printed digits), an interval
# `(lo, hi)` of what the data allow (a speed with unknown falls) or a string it contains.
Want = float | tuple | str


def compare(where: str, text: str, wants: list) -> Findings:
    out, printed = Findings(), numbers(text)
    expected = [w for w in wants if not isinstance(w, str)]
    for w in wants:
        if isinstance(w, str) and w not in text:
            out.append(f"{where}: prints {text!r}, its data give {w!r}")
    if len(printed) != len(expected):
        out.append(f"{where}: prints {text!r}, its data give {len(expected)} numbers {expected}")
        return out
    for (value, tol), w in zip(printed, expected, strict=True):
        lo, hi = (w, w) if not isinstance(w, tuple) else w
        if not lo - tol <= value <= hi + tol:
            out.append(f"{where}: prints {text!r}, its data give {expected}")
            break
    return out


def check_table(t: Table, wants: Iterable[tuple[int, str | int, list | None] | str]) -> Findings:
    """`wants`: `(row, column header or index, what the cell must print)` (`None`: a label,
    or a number of another kind of result, said where yielded), or a finding of the
    table as a whole (a row its data give that it leaves out); every cell of every row
    must be named (row -1 is the header row)."""
    out, seen = Findings(), set()
    for item in wants:
        if isinstance(item, str):
            out.append(f"{t.doc} table {t.name}: {item}")
            continue
        i, head, want = item
        if isinstance(head, str) and head not in t.header:
            continue  # a column the table no longer has
        col = head if isinstance(head, int) else t.column(head)
        seen.add((i, col))
        if want is None:
            continue
        text = t.header[col] if i < 0 else t.rows[i][col]
        out.extend(compare(f"{t.doc} table {t.name} row {i} '{t.header[col]}'", text, want))
    for i in range(len(t.rows)):
        for col, head in enumerate(t.header):
            if (i, col) not in seen:
                out.append(f"{t.doc} table {t.name} row {i} '{head}': not audited")
    return out


def speed_end(f: Front) -> list:
    """`[1, 0]`'s speed range and mean length."""
    return [f.speed(f.forward), f.lengths[f.forward]]


def fallen(f: Front) -> list:
    """Each preference whose mean length is under the time limit, with that length."""
    return [v for i in range(len(f.prefs)) if f.lengths[i] < T for v in (*f.prefs[i], f.lengths[i])]


def cli_default_wants(t: Table, repo: Repo) -> Iterator:
    for i, link in enumerate(t.links):
        f = repo.front(link[0])
        g = f.final()
        yield i, "seed", [float(re.search(r"seed(\d+)", f.path).group(1))]
        yield i, "non-dominated: final → chosen", [g.nd.sum(), f.nd.sum(), len(f.prefs)]
        yield i, "Spearman (`p₀`, forward)", [g.rho, f.rho]
        yield i, "`[1, 0]`: speed, mean length", [*speed_end(g), *speed_end(f)]
        yield i, "`[0, 1]` control return", [g.returns[g.control, 1], f.returns[f.control, 1]]
        yield i, "falls in some episodes (mean length), chosen", fallen(f)
        yield i, "HV, stated ref", [g.hv(WALKER2D["walker2d"]), f.hv(WALKER2D["walker2d"])]
        yield i, "wall s", [f.data["wall_s"]]


def cli_final_wants(t: Table, repo: Repo) -> Iterator:
    for i, link in enumerate(t.links):
        f = repo.front(link[0])
        yield i, "seed", [float(re.search(r"seed(\d+)", f.path).group(1))]
        yield i, "non-dominated", [f.nd.sum(), len(f.prefs)]
        yield i, "Spearman", [f.rho]
        yield i, "`[1, 0]`: speed, mean length", speed_end(f)
        yield i, "`[0, 1]` control", [f.returns[f.control, 1]]
        yield i, "falls in some episodes (mean length)", fallen(f)
        yield i, "HV, stated ref", [f.hv(WALKER2D["walker2d"])]
        yield i, "wall s", [f.data["wall_s"]]


def film_wants(t: Table, repo: Repo) -> Iterator:
    run = os.path.dirname(t.header_links[-1])
    f = repo.front(f"{run}/front.json")
    for i in range(len(t.rows)):
        yield i, "`p`", list(f.prefs[i])
        yield i, "forward, control return", list(f.returns[i])
        yield i, "length", [f.lengths[i]]
        yield i, "speed m/s", [f.speed(i)]
        yield i, "control/step", [f.control_per_step(i)]
        yield i, len(t.header) - 1, None  # film.json: distances measured in the film


def per_pref_wants(t: Table, repo: Repo) -> Iterator:
    """Two fronts side by side, one row per preference: each front's columns follow the
    header cell that links to it."""
    groups = [(j, repo.front(link)) for j, link in enumerate(t.header_links) if link]
    for i in range(len(t.rows)):
        yield i, "`p`", list(groups[0][1].prefs[i])
        for j, f in groups:
            assert f.prefs[i].tolist() == groups[0][1].prefs[i].tolist()
            cells = [list(f.returns[i]), [f.lengths[i]], [f.speed(i)], [f.control_per_step(i)]]
            for k, want in enumerate(cells):
                yield i, j + k, want


def header_ref(head: str) -> tuple[float, float]:
    return tuple(v for v, _ in numbers(head))


def summary_wants(t: Table, repo: Repo) -> Iterator:
    """Per front: its hypervolume under each reference in the headers (and the policies
    outside it), its non-dominated points (and, for a pair of directions, in their union),
    order and wall time."""
    fronts = [repo.front(link[0]) for link in t.links]
    for i, f in enumerate(fronts):
        for head in t.header:
            if head.startswith("HV ("):
                ref = header_ref(head)
                gone = len(outside(f.returns, ref))
                yield i, head, [f.hv(ref)] + ([gone] if gone else [])
        own = [f.nd.sum(), len(f.prefs)]
        head = "non-dominated (own; in the union)"
        if len(numbers(t.rows[i][t.column(head)])) == 3:  # rows come in pairs of directions
            other = fronts[i ^ 1]
            union = nondominated(np.vstack([f.returns, other.returns]))[: len(f.prefs)]
            own.append(union.sum())
        yield i, head, own
        yield i, "front", None
        yield i, "Spearman `p₀` vs forward", [f.rho]
        yield i, "wall s", [f.data["wall_s"]]


W = f"{RESULTS}/walker2d_front_practical_v5"
# The fronts behind each row of the tables that judge configurations over seeds: the
# row's label -> (the glob of its seeds' fronts, how many of the first seeds, whether
# the final policies of fronts that chose among their last ones).
RULE_ROWS = {
    "preset": (f"{W}_e5x16/seed*/smooth_wc", None, False),
    "`smooth_wc`, preset": (f"{W}_e5x16/seed*/smooth_wc", 3, False),
    "`linear`, preset": (f"{W}_e5x16{{,_linear}}/seed*/linear", None, False),
    "preset, final policies (committed)": (f"{W}_e5x16/seed*/smooth_wc", None, False),
    "the same trainings' final policies": (f"{W}_e5x16_select5/seed*/smooth_wc", None, True),
    "**best of the last 5 (the default)**": (f"{W}_e5x16_select5/seed*/smooth_wc", None, False),
    "best of the last 5 (today's default)": (f"{W}_e5x16_select5/seed*/smooth_wc", None, False),
    "preset (margin 0.1, μ 1)": (f"{W}_e5x16/seed*/smooth_wc", None, False),
    "`--utopia-margin 0.05`": (f"{W}_e5x16_margin005/seed*/smooth_wc", None, False),
    "`--mu 5`": (f"{W}_e5x16_mu5/seed*/smooth_wc", None, False),
    "preset (margin 0.1, μ 1, 16 × 128, constant step)": (f"{W}_e5x16/seed*/smooth_wc", 3, False),
    "`--utopia-margin 0.02`": (f"{W}_e5x16_margin002/seed*/smooth_wc", None, False),
    "`--anneal-lr`": (f"{W}_e5x16_anneal/seed*/smooth_wc", None, False),
    "`--envs-per-pref 32 --rollout-steps 64`": (f"{W}_e5x16_n32/seed*/smooth_wc", None, False),
    "`--augment 0.05`": (f"{W}_e5x16_aug005/seed*/smooth_wc", None, False),
    "`--augment 0.01`": (f"{W}_e5x16_aug001/smooth_wc", None, False),
    "`--j-ub 400,100` (fixed utopia)": (f"{W}_e5x16_fixed_utopia/smooth_wc", None, False),
    "5 epochs × 32 minibatches": (f"{W}_e5x32/smooth_wc", None, False),
}
# per table, the rows whose label means another set than `RULE_ROWS`' (the one-seed table)
RULE_ROWS_IN = {"variants_1": {"preset": (f"{W}_e5x16/seed0/smooth_wc", None, False)}}


def seed_of(path: str) -> int:
    m = re.search(r"/seed(\d+)/", path)
    return int(m.group(1)) if m else 0


def rule_fronts(repo: Repo, table: str, label: str) -> list[Front]:
    pattern, n, final = RULE_ROWS_IN.get(table, {}).get(label) or RULE_ROWS[label]
    heads, tail = pattern.split("{", 1) if "{" in pattern else (pattern, None)
    patterns = [pattern]
    if tail is not None:  # one brace group of alternatives
        choices, rest = tail.split("}", 1)
        patterns = [heads + c + rest for c in choices.split(",")]
    paths = sorted({p for q in patterns for p in repo.glob(f"{q}/front.json")}, key=seed_of)
    fronts = [repo.front(p) for p in paths[:n]]
    return [f.final() for f in fronts] if final else fronts


def walks(f: Front) -> tuple[int, int]:
    """Whether `[1, 0]` walks (2.5 m/s or faster over 450 steps or more): `(1, 1)` surely,
    `(0, 0)` surely not, `(0, 1)` where the unknown falls leave it open."""
    (lo, hi), n = f.speed(f.forward), f.lengths[f.forward]
    return int(lo >= 2.5 and n >= 450), int(hi >= 2.5 and n >= 450)


def rule_wants(t: Table, repo: Repo) -> Iterator:
    ref = WALKER2D["walker2d"]
    for i, row in enumerate(t.rows):
        fronts = rule_fronts(repo, t.name, row[0])
        yield i, "configuration", None
        nds = [int(f.nd.sum()) for f in fronts]
        walk = [walks(f) for f in fronts]
        yield i, "seeds", [len(fronts)]
        yield i, "non-dominated, per seed", nds
        yield i, "≥ 7 of 9", [sum(n >= 7 for n in nds)]
        yield i, "total", [sum(nds), sum(len(f.prefs) for f in fronts)]
        yield i, "`[1, 0]` walks", [(sum(a for a, _ in walk), sum(b for _, b in walk))]
        yield i, "Spearman ≥ 0.9", [sum(f.rho >= 0.9 - 1e-9 for f in fronts)]
        yield i, "`[0, 1]` control ≥ 400", [sum(f.returns[f.control, 1] >= 400 for f in fronts)]
        yield i, "HV, stated ref, mean", [np.mean([f.hv(ref) for f in fronts])]
        yield i, "HV (−100, −100), mean", [np.mean([f.hv((-100.0, -100.0)) for f in fronts])]


def seeds_wants(t: Table, repo: Repo) -> Iterator:
    ref = WALKER2D["walker2d"]
    for i, link in enumerate(t.links):
        f = repo.front(link[0])
        yield i, "seed", [seed_of(f.path)]
        yield i, "wall s", [f.data["wall_s"]]
        yield i, "`[1, 0]`: speed, length", speed_end(f)
        yield i, "`[0, 1]` control", [f.returns[f.control, 1]]
        yield i, "non-dominated", [f.nd.sum(), len(f.prefs)]
        if "selection" not in f.data:
            yield i, "Spearman", [f.rho]
        yield i, "HV (stated ref)", [f.hv(ref)]
        yield i, "HV (−100, −100)", [f.hv((-100.0, -100.0))]
        if "selection" in f.data:
            g, sel = f.final(), f.data["selection"]
            last = max(sel["candidate_iterations"])
            yield i, "non-dominated: final → chosen", [g.nd.sum(), f.nd.sum()]
            yield (
                i,
                "choices not the final policy",
                [sum(c != last for c in sel["chosen_iteration"])],
            )
            yield i, "`[1, 0]` m/s / length", [*speed_end(g), *speed_end(f)]
            yield i, "Spearman", [g.rho, f.rho]
            yield i, "HV, stated ref", [g.hv(ref), f.hv(ref)]


def transposed_wants(t: Table, repo: Repo) -> Iterator:
    f = repo.front(t.header_links[0])
    for j, head in enumerate(t.header[1:]):
        yield -1, head, list(f.prefs[j])  # the header row itself
        yield 0, head, list(f.returns[j])
        yield 1, head, [f.lengths[j], f.speed(j)]
    yield 0, 0, None
    yield 1, 0, None


def fixed_utopia_wants(t: Table, repo: Repo) -> Iterator:
    f = repo.front(t.header_links[1])
    for i in range(len(t.rows)):
        yield i, "`p`", list(f.prefs[i])
        yield i, t.header[1], [*f.returns[i], f.lengths[i]]
        yield i, "`λ` at the end", None  # the training's last weights, not a return


def curves_wants(t: Table, repo: Repo) -> Iterator:
    for i, row in enumerate(t.rows):
        preset = "paper" if row[0] == "paper" else "practical"
        record = t.links[i][0]
        f = repo.front(f"{os.path.dirname(record)}/{preset}/front.json")
        yield i, "preset", None
        for s in range(len(f.prefs)):
            head = "seed 0: forward, speed, length" if s == 0 else f"seed {s}"
            yield i, head, [f.returns[s, 0], f.speed(s), f.lengths[s]]
        lo, hi = (np.mean(v) for v in zip(*[f.speed(s) for s in range(len(f.prefs))], strict=True))
        yield i, "mean speed, length", [(lo, hi), f.lengths.mean()]
        yield i, "wall s", [repo.json(record)["configs"][preset]["wall_s"]]


def ablation_wants(t: Table, repo: Repo) -> Iterator:
    record = t.header_links[2]
    sizes = {(s["depth"], s["width"]): s for s in repo.json(record)["sizes"]}
    for i, row in enumerate(t.rows):
        depth, width = int(row[0]), int(row[1])
        size = sizes[(depth, width)]
        f = repo.front(f"{os.path.dirname(record)}/{size['name']}/front.json")
        trained = np.array(size["train_forward_final"])  # the training's own last returns
        yield i, "depth", [depth]
        yield i, "width", [width]
        yield i, t.header[2], [f.returns[:, 0].mean(), f.returns[:, 0].std(ddof=1)]
        yield i, "eval episode length per seed", list(f.lengths)
        yield i, "train forward return (last 5%)", [trained.mean(), trained.std(ddof=1)]
        yield i, "eval speed m/s", [f.speed(s) for s in range(len(f.prefs))]
        yield i, "env-steps/s", [size["env_steps_per_s"]]
        yield i, "wall s", [size["wall_s"]]


def paper_fronts_wants(t: Table, repo: Repo) -> Iterator:
    for i, link in enumerate(t.links):
        f = repo.front(link[0])
        gone = len(outside(f.returns, (-100.0, -100.0)))
        fwd, ctrl = f.forward, f.control
        yield i, "front", None
        yield i, "HV, stated ref", [f.hv(WALKER2D["walker2d"])]
        yield i, "HV (−100, −100)", [f.hv((-100.0, -100.0)), gone]
        yield i, "non-dominated", [f.nd.sum(), len(f.prefs)]
        yield i, "Spearman", [f.rho]
        yield i, "`[1, 0]`: forward, mean length", [f.returns[fwd, 0], f.lengths[fwd]]
        yield (
            i,
            "`[0, 1]`: control per step, mean length",
            [f.control_per_step(ctrl), f.lengths[ctrl]],
        )
        yield i, "wall s", [f.data["wall_s"]]


CONDITIONED_ARMS = {
    "one conditioned network, 3M": "conditioned",
    "9 independent, 333k each (3M)": "independent_9x333k",
    "9 independent, 1M each (9M)": "independent_9x1M",
}


def conditioned_fronts(repo: Repo, summary: str) -> dict[str, dict[int, Front]]:
    base, s = os.path.dirname(summary), repo.json(summary)
    dirs = {
        "conditioned": f"{base}/conditioned",
        "independent_9x333k": f"{base}/independent_9x333k",
        "independent_9x1M": s["reused_9x1M"],
    }
    return {
        arm: {seed_of(p): repo.front(p) for p in repo.glob(f"{d}/seed*/front.json")}
        for arm, d in dirs.items()
    }


def conditioned_row(f: Front) -> list:
    return [
        MORL_BASELINES.hv(f),
        f.hv(WALKER2D["walker2d"]),
        expected_utility(f.returns, front_json_weights(2)),
        f.nd.sum(),
        f.rho,
        f.speed(f.forward),
        f.returns[f.control, 1],
        f.data["env_steps_total"],
        f.data["wall_s"],
    ]


def conditioned_wants(t: Table, repo: Repo) -> Iterator:
    summary = next(link for row in t.links for link in row if link)
    fronts = conditioned_fronts(repo, summary)
    heads = t.header[2:]
    for i, row in enumerate(t.rows):
        by_seed = fronts[CONDITIONED_ARMS[row[0]]]
        if row[1] == "mean":
            cells = [conditioned_row(f) for f in by_seed.values()]
            want = [
                tuple(np.mean([c[k][j] for c in cells]) for j in (0, 1))
                if isinstance(cells[0][k], tuple)
                else float(np.mean([c[k] for c in cells]))
                for k in range(len(heads))
            ]
        else:
            want = conditioned_row(by_seed[int(row[1])])
        yield i, "front", None
        yield i, "seed", [] if row[1] == "mean" else [int(row[1])]
        for head, w in zip(heads, want, strict=True):
            yield i, head, [w]


def conditioned_cost_wants(t: Table, repo: Repo) -> Iterator:
    """Seed 0's network trained once (its training alone: the run's wall less its own
    evaluation) and evaluated at P preferences, against P independent 1M-step policies
    at the 9 x 1M fronts' mean per preference."""
    summary = t.links[0][0]
    fronts = conditioned_fronts(repo, summary)
    f = fronts["conditioned"][0]
    train_s = f.data["wall_s"] - f.data["conditioned"]["eval_s"]
    nine = list(fronts["independent_9x1M"].values())
    steps_pp = np.mean([g.data["env_steps_total"] / len(g.prefs) for g in nine])
    wall_pp = np.mean([g.data["wall_s"] / len(g.prefs) for g in nine])
    growth = {c["eval_prefs"]: c for c in repo.json(summary)["cost_growth"]}
    for i, row in enumerate(t.rows):
        p = int(row[0])
        c = growth[p]
        yield i, "front points P", [p]
        yield i, "conditioned: env steps", [f.data["env_steps_total"] + c["eval_env_steps"]]
        yield i, "conditioned: s", [train_s + c["eval_s"]]
        yield i, "P independent x 1M: env steps", [p * steps_pp]
        yield i, "P independent x 1M: s (extrapolated)", [p * wall_pp]


def suite_front(t: Table, i: int, repo: Repo) -> Front:
    env = t.rows[i][0].strip("`")
    return repo.front(f"{os.path.dirname(t.links[i][0])}/{env}/{t.rows[i][1]}/front.json")


def mo_mujoco_wants(t: Table, repo: Repo) -> Iterator:
    for i in range(len(t.rows)):
        f = suite_front(t, i, repo)
        ref = repo.json(f"{os.path.dirname(os.path.dirname(f.path))}/reference_ppo.json")
        v, n = forward_row(f)["mean_x_velocity"], len(f.prefs)
        yield i, "task", None
        yield i, "direction", [f.data["config"]["train"]["scalarization"]]
        yield i, "P x steps", [n, f.data["env_steps_per_pref"]]
        yield i, "HV (morl-baselines)", [MORL_BASELINES.hv(f)]
        yield i, "EU", [expected_utility(f.returns, front_json_weights(f.returns.shape[1]))]
        yield i, "non-dom.", [f.nd.sum()]
        yield i, "forward end m/s", [v]
        yield i, "PPO m/s", [ref["mean_x_velocity"]]
        yield i, "speed ratio", [v / ref["mean_x_velocity"]]
        yield i, "wall s", [f.data["wall_s"]]
        yield i, "PPO wall s", [ref["wall_s"]]
        yield i, "wall ratio", [f.data["wall_s"] * 1.5 / (n * ref["wall_s"])]


SUITE_MEASURES = {
    "HV (morl-baselines)": MORL_BASELINES.hv,
    "forward end m/s": lambda f: forward_row(f)["mean_x_velocity"],
}


def suite_seed_fronts(repo: Repo, t: Table, i: int) -> tuple[list[int], dict]:
    task = f"{os.path.dirname(t.links[i][0])}/{t.rows[i][0].strip('`')}"
    seeds = mo_mujoco_seeds(repo, task)
    return seeds, {
        d: [repo.front(f"{task}{'' if s == 0 else f'/seed{s}'}/{d}/front.json") for s in seeds]
        for d in ("smooth_wc", "linear")
    }


def mo_mujoco_seeds_wants(t: Table, repo: Repo) -> Iterator:
    for i, row in enumerate(t.rows):
        seeds, fronts = suite_seed_fronts(repo, t, i)
        values = {d: [SUITE_MEASURES[row[2]](f) for f in fronts[d]] for d in fronts}
        a, b = values["smooth_wc"], values["linear"]
        winner = (
            "smooth_wc" if min(a) > max(b) else "linear" if min(b) > max(a) else "within spread"
        )
        yield i, "task", None
        yield i, "seeds", seeds
        yield i, "measure", [row[2]]
        for d in fronts:
            yield i, f"{d} mean [range]", [np.mean(values[d]), min(values[d]), max(values[d])]
        yield i, "winner", [winner]


def mo_mujoco_seed_prefs_wants(t: Table, repo: Repo) -> Iterator:
    for i in range(len(t.rows)):
        _, fronts = suite_seed_fronts(repo, t, i)
        p = [v for v, _ in numbers(t.rows[i][1])]
        j = fronts["smooth_wc"][0].row(p)
        yield i, "task", None
        yield i, "preference", list(fronts["smooth_wc"][0].prefs[j])
        for d in fronts:
            yield i, f"{d} mean return", list(np.mean([f.returns[j] for f in fronts[d]], axis=0))


def fronts_wall_wants(t: Table, repo: Repo) -> Iterator:
    for i, link in enumerate(t.links):
        f = repo.front(link[1])
        yield i, "front", None
        yield i, "seed", [seed_of(f.path)]
        yield i, "wall s", [f.data["wall_s"]]
        yield i, "env-steps/s", [f.data["env_steps_per_s"]]


def bench_cli_wants(t: Table, repo: Repo) -> Iterator:
    for i, link in enumerate(t.links):
        f = repo.front(link[0])
        yield i, "run", None
        yield i, "env-steps/s", [f.data["env_steps_per_s"]]
        yield i, "compile s", [f.data["compile_s"]]
        yield i, "wall s", [f.data["wall_s"]]
        yield i, "HV", [f.hv(BRAX_WALKER2D["walker2d"])]


def glance_wants(t: Table, repo: Repo) -> Iterator:
    for i, row in enumerate(t.rows):
        links = [link for link in t.links[i] if link]
        if row[0] == "`walker2d`":
            fronts = [repo.front(p) for p in dict.fromkeys(row_links(t, i))]
            yield i, "`--env`", None
            yield i, "default", [fronts[0].data["config"]["select_last"]]
            yield (
                i,
                "what the front achieves",
                [
                    *(seed_of(f.path) for f in fronts),
                    *(f.nd.sum() for f in fronts),
                    len(fronts[0].prefs),
                    *fronts[0].prefs[fronts[0].forward],
                    *(f.speed(f.forward) for f in fronts),
                    *(f.rho for f in fronts),
                ],
            )
            yield i, "wall, 2-core CPU", [f.data["wall_s"] / 60 for f in fronts]
        elif row[0] == "`walker2d --conditioned`":
            by_seed = conditioned_fronts(repo, links[0])["conditioned"]
            fronts = [by_seed[s] for s in sorted(by_seed)]
            nine = conditioned_fronts(repo, links[0])["independent_9x1M"]
            yield i, "`--env`", None
            yield i, "default", [len(fronts[0].prefs)]
            yield (
                i,
                "what the front achieves",
                [
                    *sorted(by_seed),
                    *(MORL_BASELINES.hv(f) for f in fronts),
                    float(np.mean([MORL_BASELINES.hv(f) for f in nine.values()])),
                    *fronts[0].prefs[fronts[0].forward],
                    *(f.speed(f.forward) for f in fronts),
                    *(f.rho for f in fronts),
                ],
            )
            yield i, "wall, 2-core CPU", [f.data["wall_s"] / 60 for f in fronts]
        elif row[0] == "`concave_bandit`":
            d = repo.json(links[0])
            bandit = bandit_results(d)
            yield i, "`--env`", None
            yield i, "default", [len(d["prefs"])]
            yield (
                i,
                "what the front achieves",
                [bandit["smooth_wc"].distinct, bandit["smooth_wc"].gap, bandit["linear"].distinct],
            )
            yield i, "wall, 2-core CPU", ["not recorded"]
        elif row[0] == "`deep_sea_treasure`":
            d = repo.json(links[0])
            treasure = treasure_results(d)
            optimizer = d["problems"]["deep_sea_treasure"]["config"]["actor_optimizer"]
            yield i, "`--env`", None
            yield i, "default", ["Adam" if optimizer == "adam" else optimizer]
            yield (
                i,
                "what the front achieves",
                [
                    treasure["smooth_wc"].near,
                    len(d["prefs"]),
                    treasure["smooth_wc"].distinct,
                    treasure["linear"].distinct,
                ],
            )
            yield i, "wall, 2-core CPU", ["not recorded"]
        elif row[0] == "`tabular_momdp`":
            results = convergence_results(repo, links[0]).values()
            (default,) = [
                r for r in results if all(r["config"][k] == v for k, v in TABULAR_DEFAULT.items())
            ]
            yield i, "`--env`", None
            yield i, "default", None
            yield i, "what the front achieves", [100 * default["worst"]]
            yield i, "wall, 2-core CPU", ["not recorded"]
        else:
            yield f"row {i} {row[0]}: no recomputation of its numbers"
            for head in t.header:
                yield i, head, None


def mo_gymnasium_eval_wants(t: Table, repo: Repo) -> Iterator:
    """Per MO-Gymnasium evaluation, its agreement on the undiscounted returns as its
    means and standard deviations give it (`reevaluation_agreement`), and the protocol's
    HV of both sides at the protocol's preferences."""
    for i, link in enumerate(t.links):
        d = repo.json(link[0])
        a = reevaluation_agreement(d)["return"]
        big = a["largest_difference"]
        yield i, "result", None
        yield i, "task", [f"`{d['env']}`"]
        yield i, "policies", [d["policies"]]
        yield (
            i,
            "prefs x episodes (project's)",
            [len(d["prefs"]), d["episodes"], d["project_episodes"]],
        )
        yield (
            i,
            "largest difference",
            [big["difference"], d["objective_names"][big["objective"]], *big["pref"]],
        )
        for head, v in (
            ("SE of mean", big["se_of_mean"]),
            ("SE of difference", big["se"]),
            ("its z", None if big["z"] is None else abs(big["z"])),
            ("largest z", a["max_abs_z"]),
        ):
            yield i, head, ["–"] if v is None else [v]
        yield i, "beyond 2 / 3 SE", [a["beyond_2se"], a["beyond_3se"], a["n"]]
        name = d["run_config"].get("protocol")
        if name is None or any(w == "preferences" for w, _ in reevaluation_departures(d)):
            yield i, "protocol HV: MO-Gymnasium / project", ["–"]
        else:
            conv, key = FIELD_PROTOCOLS[name].convention, FIELD_PROTOCOLS[name].convention.returns
            yield (
                i,
                "protocol HV: MO-Gymnasium / project",
                [
                    conv.score([r[key] for r in d["prefs"]])["hv"],
                    conv.score([r["project"][key] for r in d["prefs"]])["hv"],
                ],
            )


def field_table_rows(repo: Repo) -> dict:
    """`{(protocol, task): field_row}` of every protocol task with fronts under `FIELD`."""
    entries = field_entries(repo, FIELD)
    return {
        (name, env): field_row(repo, name, env, entries)
        for name, env in field_tasks(repo, FIELD)
        if protocol_task(name, env) is not None
    }


def interval_want(values: tuple, n: int) -> list:
    """A mean with its interval as the documents print it: the interval only over more
    than one seed."""
    return list(values) if n > 1 else [values[0]]


def field_wants(t: Table, repo: Repo) -> Iterator:
    """The field's table in docs/results.md, one row per protocol task with fronts, each
    recomputed from its fronts, the MO-Gymnasium evaluations beside them and the
    published entries: the seeds, the HV's mean (its interval over more than one seed),
    PGMORL's published HV, the best published one and the ratio to it, the evaluations'
    mean HV and its ratio, the first seed's env steps trained, and the env steps
    evaluated and seconds per seed (their range over more than one)."""
    rows, printed = field_table_rows(repo), []
    for i, cells in enumerate(t.rows):
        key = (cells[t.column("protocol")], cells[t.column("task")].strip("`"))
        printed.append(key)
        yield i, "protocol", None
        yield i, "task", None
        row = rows.get(key)
        if row is None:
            yield f"row {i} {' '.join(key)}: no fronts of that protocol and task"
            for head in t.header[2:]:
                yield i, head, None
            continue
        n, first = len(row["seeds"]), row["fronts"][0]
        best, mg, mg_ratio = row["best"], row["hv_mo_gymnasium"], row["ratio_mo_gymnasium"]
        pgmorl = next((e for e in row["published"] if e["method"] == "PGMORL"), None)
        walls = [f.data["wall_s"] for f in row["fronts"]]
        yield i, "published as", [protocol_task(*key).published]
        yield i, "seeds", row["seeds"]
        yield i, "HV mean [95%]", interval_want(row["hv"], n)
        yield i, "PGMORL", ["–"] if pgmorl is None else [pgmorl["hv"]]
        yield i, "best published", ["–"] if best is None else [best["method"], best["hv"]]
        yield (
            i,
            "ratio [95%]",
            ["none published"] if best is None else interval_want(row["ratio"], n),
        )
        yield (
            i,
            "in MO-Gymnasium: HV, ratio",
            ["–"] if mg is None else [mg[0], *([] if mg_ratio is None else [mg_ratio[0]])],
        )
        yield i, "env steps trained", [first.data["env_steps_total"]]
        steps = [eval_steps(f) for f in row["fronts"]]
        yield i, "eval env steps", sorted({min(steps), max(steps)})
        yield i, "wall s per seed", sorted({min(walls), max(walls)})
    for key in rows:
        if printed.count(key) != 1:
            yield f"{' '.join(key)} has fronts: printed in {printed.count(key)} rows, not one"


def field_glance_wants(t: Table, repo: Repo) -> Iterator:
    """The field at a glance in the README, one row per protocol: per task it names (each
    with fronts, none left out) the HV's mean, the best published number and the ratio
    to it (its interval over more than one seed), and the seeds."""
    rows, printed = field_table_rows(repo), set()
    for i, cells in enumerate(t.rows):
        name = cells[0]
        printed.add(name)
        names = re.findall(r"`([\w-]+)`", cells[1])
        want = []
        for env in names:
            row = rows.get((name, env))
            if row is None:
                yield f"row {i} prints {name} {env}, which has no fronts"
                continue
            want += [f"`{env}`", row["hv"][0]]
            best = row["best"]
            if best is None:
                want.append("no published number")
            else:
                want += [
                    best["method"],
                    best["hv"],
                    *interval_want(row["ratio"], len(row["seeds"])),
                ]
            want += row["seeds"]
        for p, env in rows:
            if p == name and env not in names:
                yield f"row {i} leaves out {name} {env}, which has fronts"
        yield i, 0, None
        yield i, 1, want
    for p in sorted({p for p, _ in rows} - printed):
        yield f"leaves out the protocol {p}, which has fronts"


def field_ablation_wants(t: Table, repo: Repo) -> Iterator:
    """The ablation in docs/results.md, one row per task and variant with fronts, each
    recomputed from its fronts (`ablation_rows`; its changes as `ablation.json` states
    them, checked there against the runs): the seeds, the HV's mean (its interval over
    more than one seed), the ratio to the `default` variant on the seeds both ran and
    the seconds per seed."""
    rows, printed = ablation_rows(repo, FIELD), []
    stated = {
        (r["protocol"], r["task"], r["variant"]): r["changes"] or {}
        for r in repo.json(f"{FIELD}/ablation.json")["rows"]
    }
    for i, cells in enumerate(t.rows):
        key = tuple(cells[t.column(h)].strip("`") for h in ("protocol", "task", "variant"))
        printed.append(key)
        for head in ("protocol", "task", "variant"):
            yield i, head, None
        r = rows.get(key)
        if r is None:
            yield f"row {i} {' '.join(key)}: no fronts of that variant"
            for head in t.header[3:]:
                yield i, head, None
            continue
        yield i, "changes", change_wants(stated.get(key, {})) or ["–"]
        yield i, "seeds", r["seeds"]
        yield i, "HV mean [95%]", interval_want(r["hv"], len(r["seeds"]))
        yield (
            i,
            "vs default (same seeds)",
            ["–"] if r["ratio"] is None else [r["ratio"], *r["paired"]],
        )
        yield i, "wall s", [f.data["wall_s"] for f in r["fronts"]]
    for key in rows:
        if printed.count(key) != 1:
            yield f"{' '.join(key)} has fronts: printed in {printed.count(key)} rows, not one"


def row_links(t: Table, i: int) -> list[str]:
    """Every front row `i` of `t` links to, in order (a cell may hold several links)."""
    targets = [m.group(2) for m in LINK.finditer(t.raw_rows[i])]
    paths = [os.path.normpath(os.path.join(os.path.dirname(t.doc), p)) for p in targets]
    return [p for p in paths if os.path.basename(p).startswith("front") and p.endswith(".json")]


# Every generated table: how its cells are recomputed, or why they are not (another
# kind of result, whose numbers are not evaluated returns).
DOC_TABLES: dict[str, Callable[[Table, Repo], Iterator] | str] = {
    "glance": glance_wants,
    "cli_default": cli_default_wants,
    "cli_final_default": cli_final_wants,
    "cli_film": film_wants,
    "front_default": per_pref_wants,
    "front_preset": per_pref_wants,
    "front_w128": per_pref_wants,
    "front_w64": per_pref_wants,
    "front_default_summary": summary_wants,
    "front_preset_summary": summary_wants,
    "front_w128_summary": summary_wants,
    "front_w128_fixed_summary": summary_wants,
    "front_w64_summary": summary_wants,
    "linear_seeds": rule_wants,
    "selection_rule": rule_wants,
    "variants_17": rule_wants,
    "variants_3": rule_wants,
    "variants_1": rule_wants,
    "preset_seeds": seeds_wants,
    "select5_seeds": seeds_wants,
    "front_w128_seed1": transposed_wants,
    "front_w128_fixed": fixed_utopia_wants,
    "curves": curves_wants,
    "ablation_practical": ablation_wants,
    "ablation_practical_10x8": ablation_wants,
    "ablation_paper_v5": ablation_wants,
    "ablation_paper_v5_10pct": ablation_wants,
    "ablation_paper_warm_1M": ablation_wants,
    "ablation_paper_warm_10pct": ablation_wants,
    "paper_fronts": paper_fronts_wants,
    "conditioned": conditioned_wants,
    "conditioned_cost": conditioned_cost_wants,
    "mo_mujoco": mo_mujoco_wants,
    "mo_mujoco_seeds": mo_mujoco_seeds_wants,
    "mo_mujoco_seed_prefs": mo_mujoco_seed_prefs_wants,
    "fronts_wall": fronts_wall_wants,
    "bench_cli": bench_cli_wants,
    "mo_gymnasium_eval": mo_gymnasium_eval_wants,
    "field": field_wants,
    "field_glance": field_glance_wants,
    "field_ablation": field_ablation_wants,
    "exploration_bandit": exploration_bandit_wants,
    "exploration_dst": exploration_dst_wants,
    "convergence": convergence_wants,
    "bench_practical": "throughput benchmarks: measured rates",
    "reference_ppo": "PPO reference runs: measured rates and speeds",
    "bench_env": "throughput benchmarks: measured rates",
    "drift": "engine comparisons: measured state differences",
    "bench_engines": "throughput benchmarks: measured rates",
    "quiet_raw": "throughput benchmarks: measured rates",
    "bench_throughput": "throughput benchmarks: measured rates",
    "bench_processes": "throughput benchmarks: measured rates",
    "kuairand_ncis": "the recommendation experiment: check_kuairand",
    "kuairand_truth": "the recommendation experiment: check_kuairand",
    "kuairand_unified": "the recommendation experiment: check_kuairand",
    "kuairand_sets": "the recommendation experiment: check_kuairand",
    "kuairand_paper_scale_unified": "the recommendation table at full size (no per-seed values)",
    "kuairand_headroom": "the recommendation experiment's evaluation widths",
    "kuairand_fig2": "the recommendation experiment's leaning preferences",
    "kuairand_run": "the recommendation experiment's sizes and seconds",
}


def v_default_wall_range(repo: Repo, text: str, links: list) -> Findings:
    fronts = [
        repo.front(p)
        for p in repo.glob(f"{os.path.dirname(os.path.dirname(links[0]))}/seed*/front.json")
    ]
    walls = [f.data["wall_s"] / 60 for f in fronts]
    return compare("default_wall_range", text, [min(walls), max(walls)])


def v_selection_ge7(repo: Repo, text: str, links: list) -> Findings:
    fronts = [repo.front(p) for p in repo.glob(f"{links[0]}/seed*/smooth_wc/front.json")]
    return compare("selection_ge7", text, [sum(f.nd.sum() >= 7 for f in fronts), len(fronts)])


SPEED_FLOOR = 0.8  # the suite's criterion: a forward end at 0.8 x PPO's speed or more


def ppo_reference(repo: Repo, task: str, steps: int, seed: int) -> dict:
    """The PPO run of `task` at `steps` env steps on `seed`, among the suite's and the
    task's own probes."""
    paths = repo.glob(f"{RESULTS}/mo_mujoco/{task}/reference_ppo.json")
    paths += repo.glob(f"{RESULTS}/reference_ppo_{task}_v5/*/reference_ppo.json")
    found = [
        repo.json(p)
        for p in paths
        if (repo.json(p)["env_steps"], repo.json(p)["seed"]) == (steps, seed)
    ]
    assert len(found) == 1, (task, steps, seed, paths)
    return found[0]


def v_forward_end(repo: Repo, text: str, links: list) -> Findings:
    f = repo.front(links[0])
    task = f.env
    config = f.data["config"]
    ppo = ppo_reference(repo, task, config["steps_per_pref"], config["seed"])["mean_x_velocity"]
    assert all(p.tolist() == [1.0, 0.0] for p in f.prefs)
    speeds = [f.mean_x_velocity(i) for i in range(len(f.prefs))]
    fast = sum(v >= SPEED_FLOOR * ppo for v in speeds)
    return compare(
        f"forward-end probe {links[0]}",
        text,
        [min(speeds), max(speeds), fast, len(speeds), SPEED_FLOOR],
    )


def v_ppo(repo: Repo, text: str, links: list) -> Findings:
    """A PPO reference's speed (and episode length, where the text gives one)."""
    want = []
    for p in links:
        d = repo.json(p)
        want.append(d["mean_x_velocity"])
        if "episodes of" in text:
            want.append(d["episode_length"])
    if "at seeds" in text:
        want += [repo.json(p)["seed"] for p in links]
    return compare(f"PPO reference {links}", text, want)


def v_thresholds(repo: Repo, text: str, links: list) -> Findings:
    """The suite's claim over every front of its table: each wall ratio below 1 and each
    forward end at 0.8 x PPO's speed or more, or the exceptions named."""
    out, base = Findings(), os.path.dirname(links[0]) if links else f"{RESULTS}/mo_mujoco"
    tasks = sorted({p.split("/")[-3] for p in repo.glob(f"{base}/*/smooth_wc/front.json")})
    for task in tasks:
        if f"`{task}`" not in text:
            out.append(f"mo_mujoco_thresholds: {task} not named")
        ref = repo.json(f"{base}/{task}/reference_ppo.json")
        for d in ("smooth_wc", "linear"):
            f = repo.front(f"{base}/{task}/{d}/front.json")
            wall = f.data["wall_s"] * 1.5 / (len(f.prefs) * ref["wall_s"])
            speed = forward_row(f)["mean_x_velocity"] / ref["mean_x_velocity"]
            named = f"`{task}`'s `{d}`" in text
            if (wall >= 1.0 or speed < SPEED_FLOOR) != named:
                out.append(
                    f"mo_mujoco_thresholds: {task} {d} wall ratio {wall:.3f}, speed ratio "
                    f"{speed:.3f}: named {named}"
                )
    return out


DOC_VALUES: dict[str, Callable[[Repo, str, list], Findings] | str] = {
    "default_wall_range": v_default_wall_range,
    "selection_ge7": v_selection_ge7,
    "mo_mujoco_thresholds": v_thresholds,
    "halfcheetah_forward_end_ls0": v_forward_end,
    "halfcheetah_forward_end_ls-1": v_forward_end,
    "humanoid_forward_end_ls0": v_forward_end,
    "humanoid_forward_end_ls-1": v_forward_end,
    "humanoid_forward_end_e10x8": v_forward_end,
    "halfcheetah_ppo_speed": v_ppo,
    "humanoid_ppo_speed": v_ppo,
    "humanoid_ppo_3M": v_ppo,
    "humanoid_ppo_seeds": v_ppo,
    "field_preferences": "the field's tasks by how their runs drew preferences (names only)",
    "kuairand_alg1_gap": "the recommendation experiment: check_kuairand",
    "kuairand_alg1_gap_sets": "the recommendation experiment: check_kuairand",
    "kuairand_training": "the recommendation experiment's configuration",
    "kuairand_no_bc_ddpg_gaps": "the recommendation ablation (no per-seed values)",
    "kuairand_no_bc_alg1_gap": "the recommendation ablation (no per-seed values)",
    "kuairand_no_bc_ddpg_action": "the recommendation ablation's training curves",
    "kuairand_no_bc_alg1_action": "the recommendation ablation's training curves",
    "kuairand_action_levels": "the recommendation experiment's training curves",
    "kuairand_loss_levels": "the recommendation experiment's training curves",
    "kuairand_wall": "the recommendation experiment's seconds",
    "kuairand_ncis_judged": "the test rows' logged event counts (table.json's ncis_events)",
    "kuairand_ncis_few": "the test rows' logged event counts (table.json's ncis_events)",
}


def check_docs(repo: Repo) -> Findings:
    """Every generated number of the documents that comes from evaluated returns, against
    its recomputation; every generated block is known here."""
    out = Findings()
    tables, values = doc_blocks(repo)
    for (doc, name), t in tables.items():
        spec = DOC_TABLES.get(name)
        if spec is None:
            out.append(f"{doc} table {name}: not audited (add it to DOC_TABLES)")
        elif not isinstance(spec, str):
            try:
                out.extend(check_table(t, spec(t, repo)))
            except (KeyError, ValueError, IndexError, AssertionError, FileNotFoundError) as e:
                out.append(f"{doc} table {name}: cannot be recomputed ({type(e).__name__}: {e})")
    for (doc, name), (text, links) in values.items():
        spec = DOC_VALUES.get(name)
        if spec is None:
            out.append(f"{doc} value {name}: not audited (add it to DOC_VALUES)")
        elif not isinstance(spec, str):
            try:
                out.extend(f"{doc}: {line}" for line in spec(repo, text, links))
            except (KeyError, ValueError, IndexError, AssertionError, FileNotFoundError) as e:
                out.append(f"{doc} value {name}: cannot be recomputed ({type(e).__name__}: {e})")
    return out


# ---------------------------------------------------------------------- recommendation


def kuairand_points(values: dict, method: str, key: str) -> np.ndarray:
    """The point estimate of `key` for `method`: each data set's mean over its training
    seeds, then the mean over the data sets. `[k]` (or a scalar)."""
    return np.mean(
        [np.mean(np.asarray(ds[method][key], np.float64), axis=0) for ds in values["data_sets"]],
        axis=0,
    )


def kuairand_set_interval(values: dict, method: str, replicates: int) -> tuple[float, float]:
    """The share of the Behavior-Clone -> oracle gap with the data sets resampled too: per
    replicate, the data sets drawn with replacement and within each drawn set the training
    seeds (shared by every method; the oracle's one policy whatever the draw), numpy's
    `default_rng([seed, 1])` drawing the sets `[B, D]` and then the seeds `[B, D, S]`;
    the 2.5 and 97.5 percentiles."""
    sets = values["data_sets"]
    rng = np.random.default_rng([values["seed"], 1])
    drawn = rng.integers(0, len(sets), (replicates, len(sets)))
    seeds = rng.integers(0, len(values["seeds"]), (replicates, len(sets), len(values["seeds"])))

    def replicate(name: str) -> np.ndarray:
        u = np.array([ds[name]["unified_truth"] for ds in sets], np.float64)  # [D, S]
        return u[drawn[:, :, None], seeds % u.shape[1]].mean(axis=(1, 2))

    bc, oracle = replicate("Behavior-Clone"), replicate("Oracle")
    share = (replicate(method) - bc) / (oracle - bc)
    lo, hi = np.percentile(share, [2.5, 97.5])
    return float(lo), float(hi)


def check_kuairand(repo: Repo, base: str = f"{RESULTS}/kuairand") -> Findings:
    """The recommendation table's point estimates and gap shares from the committed values
    of each data set and training seed (`per_seed.json`), and the documents' numbers."""
    out = Findings()
    table, rel = repo.json(f"{base}/table.json"), f"{base}/per_seed.json"
    if not repo.exists(rel):
        out.append(f"{base}: no per_seed.json to recompute table.json from")
        return out
    values = repo.json(rel)
    out.equal(f"{rel} data sets", [ds["name"] for ds in values["data_sets"]], table["data_seeds"])
    out.equal(f"{rel} seeds", values["seeds"], table["seeds"])
    signals = list(table["methods"]["Behavior-Clone"]["ncis"])
    bc = "Behavior-Clone"
    u = {m: float(kuairand_points(values, m, "unified_truth")) for m in table["methods"]}
    for m, row in table["methods"].items():
        w = f"{base}/table.json {m}"
        for kind in ("ncis", "truth"):
            point = kuairand_points(values, m, kind)
            ref = kuairand_points(values, bc, kind)
            for j, s in enumerate(signals):
                out.close(f"{w} {kind} {s}", row[kind][s], point[j])
                rel_key = "vs_bc" if kind == "ncis" else "truth_vs_bc"
                want = None if ref[j] == 0 else 100 * (point[j] - ref[j]) / abs(ref[j])
                out.close(f"{w} {rel_key} {s}", row[rel_key][s], want)
        out.close(f"{w} unified_truth", row["unified_truth"], u[m])
        out.close(f"{w} unified_vs_bc", row["unified_vs_bc"], u[m] - u[bc])
        out.close(f"{w} gap_share", row["gap_share"], (u[m] - u[bc]) / (u["Oracle"] - u[bc]))
        per_set = kuairand_set_shares(values, m)
        for d, (a, b) in enumerate(zip(row["gap_share_by_data_set"], per_set, strict=True)):
            out.close(f"{w} gap share on data set {d}", a, b)
        lo, hi = kuairand_set_interval(values, m, table["bootstrap"]["replicates"])
        out.close(
            f"{w} gap share interval over data sets (low)", row["gap_share_ci95_data_sets"][0], lo
        )
        out.close(
            f"{w} gap share interval over data sets (high)", row["gap_share_ci95_data_sets"][1], hi
        )
    out.extend(check_kuairand_docs(repo, base, table, values))
    return out


def kuairand_share(values: dict, method: str) -> float:
    """The pooled share of the Behavior-Clone -> oracle gap: of the point estimates."""
    u = {
        m: float(kuairand_points(values, m, "unified_truth"))
        for m in (method, "Behavior-Clone", "Oracle")
    }
    return (u[method] - u["Behavior-Clone"]) / (u["Oracle"] - u["Behavior-Clone"])


def kuairand_set_shares(values: dict, method: str) -> list[float]:
    """The share of the gap on each data set, from its seeds' mean values."""
    out = []
    for ds in values["data_sets"]:
        u = {m: np.mean(ds[m]["unified_truth"]) for m in (method, "Behavior-Clone", "Oracle")}
        out.append(float((u[method] - u["Behavior-Clone"]) / (u["Oracle"] - u["Behavior-Clone"])))
    return out


def check_kuairand_docs(repo: Repo, base: str, table: dict, values: dict) -> Findings:
    """The documents' point estimates and gap shares of the recommendation table (their
    intervals over test rows are the table's, which per-seed values cannot redo)."""
    out = Findings()
    tables, doc_values = doc_blocks(repo)
    signals = list(table["methods"]["Behavior-Clone"]["ncis"])
    for (doc, name), t in tables.items():
        if name in ("kuairand_ncis", "kuairand_truth") and t.header_links[0].startswith(base + "/"):
            kind = "ncis" if name == "kuairand_ncis" else "truth"
            ref = kuairand_points(values, "Behavior-Clone", kind)
            for row in t.rows:
                if row[0] not in table["methods"]:
                    continue  # the logged policy's row: the test rows' logged means
                point = kuairand_points(values, row[0], kind)
                for j, s in enumerate(signals):
                    text = row[1 + j]
                    shown = re.search(r"\(e-(\d+)\)", t.header[1 + j])  # printed x 10^k
                    scale = 10.0 ** int(shown.group(1)) if shown else 1.0
                    want = [point[j] * scale]
                    if "few events" in text:
                        want.append(table["ncis_events"][s])
                    elif "%" in text:
                        want.append(100 * (point[j] - ref[j]) / abs(ref[j]))
                    out.extend(compare(f"{doc} table {name} {row[0]} {s}", text, want))
        if name == "kuairand_sets" and t.header_links[0].startswith(base + "/"):
            for row in t.rows:
                m = row[0]
                if m not in table["methods"]:  # the gap itself, per data set
                    for d, ds in enumerate(values["data_sets"]):
                        gap = np.mean(ds["Oracle"]["unified_truth"]) - np.mean(
                            ds["Behavior-Clone"]["unified_truth"]
                        )
                        out.extend(
                            compare(f"{doc} table {name} gap on data set {d}", row[1 + d], [gap])
                        )
                    continue
                per_set = kuairand_set_shares(values, m)
                for d, share in enumerate(per_set):
                    out.extend(compare(f"{doc} table {name} {m} data set {d}", row[1 + d], [share]))
                pooled = row[1 + len(per_set)].split("[")[0]
                out.extend(
                    compare(f"{doc} table {name} {m} pooled", pooled, [kuairand_share(values, m)])
                )
                lo, hi = kuairand_set_interval(values, m, table["bootstrap"]["replicates"])
                out.extend(compare(f"{doc} table {name} {m} sets resampled", row[-1], [lo, hi]))
        if name == "kuairand_unified" and t.header_links[0].startswith(base + "/"):
            u = {m: float(kuairand_points(values, m, "unified_truth")) for m in table["methods"]}
            bc, oracle = u["Behavior-Clone"], u["Oracle"]
            for row in t.rows:
                m = row[0]
                out.extend(compare(f"{doc} table {name} {m} value", row[1], [u[m]]))
                out.extend(
                    compare(f"{doc} table {name} {m} vs BC", row[2].split("[")[0], [u[m] - bc])
                )
                share = (u[m] - bc) / (oracle - bc)
                out.extend(
                    compare(f"{doc} table {name} {m} gap share", row[3].split("[")[0], [share])
                )
    alg1 = "wcac (Algorithm 1)"
    for (doc, name), (text, links) in doc_values.items():
        if not links or not links[0].startswith(base + "/"):
            continue
        if name == "kuairand_alg1_gap":  # its interval is over the test rows: the table's
            out.extend(
                compare(
                    f"{doc} value {name}", text.split("[")[0], [100 * kuairand_share(values, alg1)]
                )
            )
        if name == "kuairand_alg1_gap_sets":
            per_set = [100 * v for v in kuairand_set_shares(values, alg1)]
            lo, hi = kuairand_set_interval(values, alg1, table["bootstrap"]["replicates"])
            out.extend(
                compare(f"{doc} value {name}", text, [*per_set, len(per_set), 100 * lo, 100 * hi])
            )
    return out


# ---------------------------------------------------------------------- the audit


def audit(root: str) -> list[str]:
    """Every stated number of the results under `root` that its data do not give."""
    repo = Repo(root)
    return [
        *check_families(repo),
        *check_docs(repo),
        *check_kuairand(repo),
        *check_known_answers(repo),
        *check_earlier_eval_steps(repo),
    ]
