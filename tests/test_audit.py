"""The audit (`tests/audit.py`): every committed number that README.md, docs/ and the
results' summaries state is what the raw returns and lengths give; the auditor's own
definitions by hand; and planted errors in a copy of the results, each of which the
audit must catch."""

from __future__ import annotations

import json
import math
import os
import re
import shutil

import audit
import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


# ---------------------------------------------------------------------- the repository


def test_every_committed_number_is_what_its_data_give():
    findings = audit.audit(ROOT)
    assert findings == [], "\n".join(findings[:40])


def test_the_audit_walks_every_front_and_reads_every_generated_block():
    repo = audit.Repo(ROOT)
    fronts = repo.fronts()
    # the walk finds fronts by their content, whatever the file's name
    assert f"{audit.RESULTS}/bench_cli_paper_mujoco_v5_100k/front_loaded.json" in fronts
    named = {p for p in fronts if os.path.basename(p) == "front.json"}
    assert named == set(repo.glob(f"{audit.RESULTS}/**/front.json"))
    tables, values = audit.doc_blocks(repo)
    assert {name for _, name in tables} <= set(audit.DOC_TABLES)
    assert {name for _, name in values} <= set(audit.DOC_VALUES)
    # the headline blocks are recomputed, not waved through
    for name in ("glance", "conditioned", "mo_mujoco", "mo_mujoco_seeds", "cli_default"):
        assert callable(audit.DOC_TABLES[name]), name
    # so are the problems with known answers, from their raw angles, returns and gaps
    for name in ("exploration_bandit", "exploration_dst", "convergence"):
        assert callable(audit.DOC_TABLES[name]), name
    # MO-Gymnasium's evaluations hold evaluated returns: walked, and claimed by a family
    # that checks them as evaluations (no reference of their own), their table recomputed
    assert f"{audit.RESULTS}/mo_gymnasium_eval/hopper.json" in fronts
    (evaluations,) = [f for f in audit.FAMILIES if "mo_gymnasium_eval/*.json" in f.fronts]
    assert evaluations.hv_ref is None and evaluations.own is audit.check_reevaluation
    assert callable(audit.DOC_TABLES["mo_gymnasium_eval"])
    # the field's tables in the documents are recomputed from the fronts, and the
    # MO-Gymnasium evaluation beside a field front is claimed as an evaluation of it
    for name in ("field", "field_glance", "field_ablation"):
        assert callable(audit.DOC_TABLES[name]), name
    (beside,) = [f for f in audit.FAMILIES if f.own is audit.check_field_reevaluation]
    assert beside.hv_ref is None
    assert f"field/*/*/seed*/{audit.FIELD_EVALUATION}" in beside.fronts


# ---------------------------------------------------------------------- by hand


def test_hypervolume_and_dominance_by_hand():
    # a staircase from (0, 0): 3 x 1 + 2 x (2 - 1) + 1 x (3 - 2)
    pts = [[3.0, 1.0], [2.0, 2.0], [1.0, 3.0], [1.0, 1.0], [2.0, 2.0]]
    assert audit.hypervolume(pts, [0.0, 0.0]) == pytest.approx(6.0)
    # (1, 1) is dominated; the second (2, 2) repeats the first
    assert audit.nondominated(pts).tolist() == [True, True, True, False, False]
    # points not strictly above the reference add nothing
    assert audit.hypervolume([[3.0, 0.0], [-1.0, 5.0]], [0.0, 0.0]) == 0.0
    assert audit.outside([[3.0, 0.0], [1.0, 1.0]], [0.0, 0.0]) == [0]
    # three objectives: two unit boxes overlapping in a 1 x 1 x 1 cube of 2 x 2 x 1
    assert audit.hypervolume([[2, 1, 1], [1, 2, 1]], [0, 0, 0]) == pytest.approx(3.0)


def test_expected_utility_and_weight_grids_by_hand():
    assert len(audit.weight_grid(2, 0.01)) == 101 and len(audit.weight_grid(3, 0.1)) == 66
    np.testing.assert_allclose(audit.weight_grid(3, 0.1).sum(axis=1), 1.0)
    # weights (1, 0), (0.5, 0.5), (0, 1) over points (2, 0), (0, 2): max 2, 1, 2
    assert audit.expected_utility([[2, 0], [0, 2]], audit.weight_grid(2, 0.5)) == pytest.approx(
        5 / 3
    )
    w = audit.front_json_weights(3)
    assert w.shape == (101, 3) and {tuple(r) for r in np.eye(3)} <= {tuple(r) for r in w}
    assert len({tuple(r) for r in w}) == 101  # 105 lattice points (step 1/13), 4 dropped


def test_sparsity_and_rank_correlation_by_hand():
    # non-dominated (0, 3), (1, 1), (3, 0): gaps per objective 1, 2 and 1, 2: 10 / 2
    assert audit.sparsity([[0, 3], [1, 1], [3, 0], [0, 0]]) == pytest.approx(5.0)
    assert audit.spearman([1, 2, 3], [3, 2, 1]) == pytest.approx(-1.0)


def test_speed_from_a_walker_return_by_hand():
    # 500 steps, never below the limit: 0 falls, or one on the last step of each episode
    lo, hi = audit.walker_speed(2000.0, 500.0)
    assert (lo, hi) == pytest.approx(((2000 - 500) / 500, (2000 - 500 + 1) / 500))
    # mean 250 over 8 episodes: at most 3 lasted 500 (4 x 500 + 4 x 1 > 2000)
    assert audit.falls(250.0) == (5 / 8, 1.0)
    # every episode fell: 8 x 20 < 500
    assert audit.falls(20.0) == (1.0, 1.0)
    lo, hi = audit.walker_control(-100.0, 20.0)
    assert lo == hi == pytest.approx((20 - 1 + 100) / 20)


def test_the_published_grids_by_hand():
    """The field's grids as its published code builds them: every point of the lattice
    for two objectives; for three, the float sum of `arange`'s values drops the points
    with 0.1 beside 0.2 and 0.7 or 0.3 and 0.6 (`0.30000000000000004`, ...)."""
    assert len(audit.published_grid(2, 0.01)) == 101 and len(audit.published_grid(2, 0.005)) == 201
    assert len(audit.published_grid(3, 0.1)) == 62 and len(audit.published_grid(3, 0.05)) == 217
    kept = {tuple(np.round(w, 6)) for w in audit.published_grid(3, 0.1)}
    dropped = {tuple(np.round(w, 6)) for w in audit.weight_grid(3, 0.1)} - kept
    assert dropped == {(0.2, 0.7, 0.1), (0.3, 0.6, 0.1), (0.6, 0.3, 0.1), (0.7, 0.2, 0.1)}
    # the evaluated preferences of a protocol are its grid, in the order written
    assert audit.FIELD_PROTOCOLS["cmorl"].prefs(2)[:2].tolist() == [[0.0, 1.0], [0.01, 0.99]]


def test_protocol_scores_by_hand():
    """C-MORL's scores from -100 over every point; PGMORL's drop a point with a negative
    objective, and one on an axis adds no volume; the Student-t interval of two values
    is `mean +- t sd / sqrt(2)`, `t` the 97.5% quantile of one degree of freedom (the
    Cauchy distribution's, `tan(0.475 pi)`)."""
    pts = [[3.0, 1.0], [1.0, 3.0], [4.0, -1.0], [0.0, 5.0]]
    c = audit.C_MORL.score(pts)
    assert (c["kept"], c["nondominated"]) == (4, 4)
    # from (-100, -100), by decreasing first objective: 104 x 99, 103 x 2, 101 x 2, 100 x 2
    assert c["hv"] == pytest.approx(104 * 99 + 103 * 2 + 101 * 2 + 100 * 2)
    w = np.linspace(0, 1, 101)
    best = np.max([3 * w + (1 - w), w + 3 * (1 - w), 4 * w - (1 - w), 5 * (1 - w)], axis=0)
    assert c["eu"] == pytest.approx(best.mean())
    p = audit.PGMORL.score(pts)
    assert (p["kept"], p["nondominated"]) == (3, 2)  # (0, 5) does not dominate the origin
    assert p["hv"] == pytest.approx(3 * 1 + 1 * 2)
    w = np.linspace(0, 1, 201)
    best = np.max([3 * w + (1 - w), w + 3 * (1 - w), 5 * (1 - w)], axis=0)
    assert p["eu"] == pytest.approx(best.mean())
    assert audit.PGMORL.score([[-1.0, 2.0]]) == {"hv": 0.0, "eu": 0.0, "nondominated": 0, "kept": 0}
    # [1, 3]: sd sqrt(2), so the half width is t itself
    t = math.tan(0.475 * math.pi)
    assert audit.t_interval([1.0, 3.0]) == pytest.approx((2.0, 2.0 - t, 2.0 + t))
    assert audit.t_interval([5.0]) == (5.0, 5.0, 5.0)


def test_known_answers_by_hand():
    """The problems with known answers: the bandit's optimum at equal weights is the
    middle of the front, at `[1, 0]` its end, and its front's hypervolume; Deep Sea
    Treasure's front is the upper-right hull of its shortest paths (neither a point below
    the chord between two others nor the hull's lower-left side); the weighted-Chebyshev
    optimum on a segment is where the weighted terms cross; a distance to the front and a
    position along it; distinct points; and the log-log slope of `1 / t`."""
    z = (1.1, 1.1)
    assert audit.bandit_wc_theta((0.5, 0.5), z) == pytest.approx(math.pi / 4, abs=1e-12)
    assert audit.bandit_wc_theta((1.0, 0.0), z) == 0.0
    assert audit.bandit_wc_theta((0.0, 1.0), z) == math.pi / 2
    np.testing.assert_allclose(
        audit.bandit_reward([0.0, math.pi / 2]), [[1, 0], [0, 1]], atol=1e-15
    )
    # the area the bandit's front dominates above (0, 0): the unit square less the quarter
    # disc of radius 1 around (1, 1); a lower reference adds the strips below and left of it
    assert audit.bandit_front_hv((0.0, 0.0)) == pytest.approx(1 - math.pi / 4, abs=1e-10)
    below = 1 - math.pi / 4 + 0.25 * 1.0 + 0.5 * 1.25
    assert audit.bandit_front_hv((-0.5, -0.25)) == pytest.approx(below, abs=1e-10)
    # the shortest path to the first treasure: one step down, treasure 1 and time -1
    np.testing.assert_allclose(audit.dst_paths(0.99)[0], [1.0, -1.0])
    np.testing.assert_allclose(audit.dst_paths(0.5)[-1], [124 * 0.5**18, -(1 - 0.5**19) / 0.5])
    hull = audit.upper_right_hull([[0, 4], [1, 1], [2, 2.5], [4, 0], [3, 1.0]])
    # (1, 1) is a vertex of the hull, not of its front; (3, 1) lies below the chord from
    # (2, 2.5) to (4, 0)
    assert hull.tolist() == [[0, 4], [2, 2.5], [4, 0]]
    segment = np.array([[0.0, 10.0], [10.0, 0.0]])
    # p (z - J) equal on both objectives from utopia (10, 10): 0.2 (10 - x) = 0.8 x
    np.testing.assert_allclose(audit.front_wc_optimum((0.2, 0.8), segment, (10, 10)), [2, 8])
    # a utopia the segment's end already reaches on one objective: that end
    np.testing.assert_allclose(audit.front_wc_optimum((1.0, 0.0), segment, (10, 10)), [10, 0])
    dist, along = audit.to_front([[5.0, 5.0], [6.0, 6.0], [-1.0, 10.0]], segment)
    np.testing.assert_allclose(dist, [0.0, math.sqrt(2), 1.0], atol=1e-12)
    np.testing.assert_allclose(along, [0.5, 0.5, 0.0])
    assert audit.count_distinct([[0, 0], [0.5, 0], [1.2, 0], [1.6, 0]], 1.0) == 2
    assert audit.largest_gap([0.3, 0.5], 0.0, 1.0) == pytest.approx(0.5)
    t = np.arange(10.0, 1001.0, 10.0)
    assert audit.log_log_slope(t, 3.0 / t) == pytest.approx(-1.0)


def test_printed_numbers_are_read_with_their_precision():
    got = audit.numbers("8,687,214 → 8,811,925 | −1,807 | 4.65e6 | 0.98 | `hopper-2obj` 3M p₀")
    assert [v for v, _ in got] == [8687214, 8811925, -1807, 4.65e6, 0.98]
    assert [t for _, t in got] == pytest.approx([0.5, 0.5, 0.5, 0.005e6, 0.005], rel=1e-5)
    assert audit.compare("x", "3.40 m/s", [(3.395, 3.41)]) == []
    assert audit.compare("x", "3.40 m/s", [3.3949]) != []
    assert audit.compare("x", "7 of 9", [7, 9]) == [] and audit.compare("x", "7", [7, 9]) != []


def test_conventions_by_hand():
    """morl-baselines' convention on the discounted returns from -100; PGMORL's from the
    origin."""
    rows = [
        {"pref": [1.0, 0.0], "return": [300.0, -50.0], "discounted_return": [50.0, -20.0]},
        {"pref": [0.0, 1.0], "return": [100.0, 90.0], "discounted_return": [10.0, 30.0]},
    ]
    for r in rows:
        r["episode_length"] = 100.0
    f = audit.Front("x", {"env": "walker2d", "prefs": rows})
    # from (-100, -100): (150, 80) and (110, 130): 150 x 80 + 110 x 50
    assert audit.MORL_BASELINES.hv(f) == pytest.approx(150 * 80 + 110 * 50)
    # from the origin only (100, 90) counts
    assert audit.PGMORL.hv(f) == pytest.approx(100 * 90)
    # C-MORL's EU: weights (w, 1 - w) in steps of 0.01 over the discounted returns
    w = np.linspace(0, 1, 101)
    want = np.mean(np.maximum(50 * w - 20 * (1 - w), 10 * w + 30 * (1 - w)))
    assert audit.C_MORL.eu(f) == pytest.approx(want)


# ---------------------------------------------------------------------- planted errors


def _ignore(directory: str, names: list[str]) -> list[str]:
    """Files the audit does not read: images, arrays, and Markdown other than the field's
    tables."""
    skip = shutil.ignore_patterns("*.png", "*.csv", "*.npz", "*.pkl", "*.md")(directory, names)
    return [n for n in skip if n not in ("table.md", "ablation.md")]


def _copy(tmp_path) -> str:
    """The documents and the results' JSON files (and the field's Markdown tables), copied."""
    root = str(tmp_path / "repo")
    shutil.copytree(
        os.path.join(ROOT, audit.RESULTS), os.path.join(root, audit.RESULTS), ignore=_ignore
    )
    os.makedirs(os.path.join(root, "docs"))
    for doc in audit.DOCS:
        shutil.copy(os.path.join(ROOT, doc), os.path.join(root, doc))
    return root


def _edit_json(root: str, rel: str, change) -> None:
    path = os.path.join(root, rel)
    with open(path) as f:
        data = json.load(f)
    change(data)
    with open(path, "w") as f:
        json.dump(data, f)


def _edit_text(root: str, rel: str, old: str, new: str) -> None:
    path = os.path.join(root, rel)
    with open(path) as f:
        text = f.read()
    assert old in text, old
    with open(path, "w") as f:
        f.write(text.replace(old, new, 1))


def _fails(root: str, *patterns: str) -> list[str]:
    """The audit of `root` fails, with a line matching each pattern."""
    findings = audit.audit(root)
    assert findings, "the planted error passed the audit"
    for pattern in patterns:
        assert any(re.search(pattern, line) for line in findings), (pattern, findings[:10])
    return findings


R = audit.RESULTS
COND = f"{R}/conditioned_walker2d/conditioned/seed0/front.json"
CLI = f"{R}/cli_default_front_select5/seed0/front.json"


def test_plant_a_return_changed(tmp_path):
    """One return of the first command's seed 0 (preference [0.625, 0.375], non-dominated)
    1% higher: its hypervolume and sparsity, the docs' table and the conditioned summary's
    9 x 1M arm no longer follow."""
    root = _copy(tmp_path)

    def change(d):
        d["prefs"][3]["return"][0] *= 1.01

    _edit_json(root, CLI, change)
    _fails(
        root,
        rf"{CLI} hypervolume: states",
        rf"{CLI} sparsity",
        r"docs/results.md table cli_default row 0 'HV, stated ref'",
        r"conditioned_walker2d/summary.json independent_9x1M seed 0 hv_project",
    )


def test_plant_a_length_changed(tmp_path):
    """The conditioned network's `[1, 0]` mean length 500 -> 490 (seed 0): its speed and
    its evaluation's env steps no longer follow."""
    root = _copy(tmp_path)
    _edit_json(root, COND, lambda d: d["prefs"][0].update(episode_length=490.0))
    _fails(
        root,
        r"conditioned seed 0 forward_end_length",
        rf"{COND} eval_env_steps",
        r"README.md table glance row 1 'what the front achieves'",
    )


def test_plant_a_reference_point_changed(tmp_path):
    """A front that states its hypervolume at another reference, consistently computed;
    and the suite's morl-baselines column computed at -50 instead of -100."""
    root = _copy(tmp_path)
    moved = (-400.0, -3000.0)

    def front(d):
        d["hv_ref"] = list(moved)
        d["hypervolume"] = audit.hypervolume([r["return"] for r in d["prefs"]], moved)
        d["hypervolume_discounted"] = audit.hypervolume(
            [r["discounted_return"] for r in d["prefs"]], moved
        )

    _edit_json(root, CLI, front)
    suite = f"{R}/mo_mujoco/table.json"
    halfcheetah = audit.Front(
        "x", audit.Repo(ROOT).json(f"{R}/mo_mujoco/halfcheetah/smooth_wc/front.json")
    )
    at_50 = audit.hypervolume(halfcheetah.discounted, [-50.0, -50.0])

    def table(d):
        row = next(
            r for r in d["rows"] if (r["env"], r["scalarization"]) == ("halfcheetah", "smooth_wc")
        )
        row["hv_morl_baselines"] = at_50

    _edit_json(root, suite, table)
    _fails(root, rf"{CLI} hv_ref", r"table.json halfcheetah smooth_wc hv_morl_baselines")


def test_plant_a_published_number_changed(tmp_path):
    """PGMORL's Hopper-2d hypervolume on C-MORL's protocol as the field's file cites it
    (D3PO's table: 1.20e5)."""
    root = _copy(tmp_path)

    def change(d):
        for p in d["entries"]:
            if (p["protocol"], p["task"], p["method"]) == ("cmorl", "hopper-2obj", "PGMORL"):
                p["hv"] = 1.30e5

    _edit_json(root, f"{R}/field/published.json", change)
    _fails(root, r"field/published.json .*hopper-2obj.*PGMORL")


def test_plant_a_fronts_preference_order_swapped(tmp_path):
    """Two preferences of the conditioned network's seed-0 front swapped (their returns
    stay): the order's rank correlation moves, in the summary and in the README."""
    root = _copy(tmp_path)

    def change(d):
        rows = d["prefs"]
        rows[3]["pref"], rows[20]["pref"] = rows[20]["pref"], rows[3]["pref"]

    _edit_json(root, COND, change)
    _fails(
        root,
        r"conditioned seed 0 spearman",
        r"README.md table glance row 1 'what the front achieves'",
    )


def test_plant_a_front_nobody_audits(tmp_path):
    root = _copy(tmp_path)
    os.makedirs(os.path.join(root, R, "new_experiment"))
    shutil.copy(os.path.join(ROOT, CLI), os.path.join(root, R, "new_experiment", "front.json"))
    _fails(root, r"new_experiment/front.json: no family audits it")


def test_plant_a_recommendation_value_changed(tmp_path):
    """One training seed's true unified value of Algorithm 1 on data set 1: the table's
    point estimate, its gap share and the interval over data sets no longer follow."""
    root = _copy(tmp_path)

    def change(d):
        d["data_sets"][1]["wcac (Algorithm 1)"]["unified_truth"][2] += 0.05

    _edit_json(root, f"{R}/kuairand/per_seed.json", change)
    _fails(
        root,
        r"wcac \(Algorithm 1\) unified_truth",
        r"wcac \(Algorithm 1\) gap_share:",
        r"wcac \(Algorithm 1\) gap share interval over data sets",
    )


def test_plant_two_recommendation_seeds_swapped(tmp_path):
    """Two training seeds' values of Algorithm 1 on data set 2 exchanged (NCIS, true
    and unified values): every mean, gap share and point estimate stays, so only the
    interval with the data sets resampled, which draws the seeds by index for every
    method alike, can tell; its upper end no longer follows, and nothing else moves."""
    root = _copy(tmp_path)

    def change(d):
        row = d["data_sets"][2]["wcac (Algorithm 1)"]
        for key in ("ncis", "truth", "unified_truth"):
            row[key][0], row[key][1] = row[key][1], row[key][0]

    _edit_json(root, f"{R}/kuairand/per_seed.json", change)
    findings = _fails(
        root, r"wcac \(Algorithm 1\) gap share interval over data sets \(high\): states "
    )
    assert len(findings) == 1, findings


def test_plant_a_summary_number_changed(tmp_path):
    """The one summary without per-direction entries (the conditioned one) is audited, not
    skipped: its seed-0 hypervolume (morl-baselines) 0.1% higher fails; so does a
    walker2d_front.py summary emptied of its directions."""
    root = _copy(tmp_path)

    def change(d):
        d["runs"]["conditioned"]["0"]["hv_morl_baselines"] *= 1.001

    _edit_json(root, f"{R}/conditioned_walker2d/summary.json", change)
    _fails(root, r"summary.json conditioned seed 0 hv_morl_baselines")
    root = _copy(tmp_path / "again")
    summary = f"{R}/walker2d_front_practical_v5_e5x16/seed3/summary.json"
    _edit_json(root, summary, lambda d: d.update(directions={}))
    _fails(root, rf"{summary}: states no direction")


FIELD = f"{R}/field"
FIELD_FRONT = f"{FIELD}/cmorl/hopper-2obj/seed0/front.json"


def test_plant_a_field_return_changed(tmp_path):
    """The discounted return of hopper-2obj's seed-0 front that runs furthest forward, 1%
    higher: the front's protocol HV and EU (C-MORL's, over the discounted returns from
    -100), its own discounted hypervolume and the table's seed, mean and ratio no longer
    follow."""
    root = _copy(tmp_path)

    def change(d):
        row = max(d["prefs"], key=lambda r: r["discounted_return"][0])
        row["discounted_return"][0] *= 1.01

    _edit_json(root, FIELD_FRONT, change)
    _fails(
        root,
        rf"{FIELD_FRONT} protocol hv:",
        rf"{FIELD_FRONT} protocol eu:",
        rf"{FIELD_FRONT} hypervolume_discounted",
        r"field/table.json cmorl hopper-2obj seed 0 hv:",
        r"field/table.json cmorl hopper-2obj hv mean",
        r"field/table.json cmorl hopper-2obj ratio_to_best",
    )


HOPPER = "hopper-2obj"


def _committed_row(rel: str, *cells: str) -> list[str]:
    """The cells of the first row of a committed Markdown table (`rel`, from the
    repository's root) that has each of `cells` as a whole cell, so that a planted
    change edits what the committed tables print now, whatever the seeds."""
    with open(os.path.join(ROOT, rel)) as f:
        for line in f:
            row = [c.strip() for c in line.strip().strip("|").split("|")]
            if line.startswith("|") and all(c in row for c in cells):
                return row
    raise AssertionError(f"{rel} has no row with {cells}")


def test_plant_the_field_tables_mean_changed(tmp_path):
    """hopper-2obj's HV mean 0.1% higher in table.json, and its printed mean in table.md
    changed to 9.9e+05: each no longer what its fronts give."""
    root = _copy(tmp_path)
    with open(os.path.join(ROOT, FIELD, "table.json")) as f:
        rows = json.load(f)["rows"]
    i = next(i for i, r in enumerate(rows) if (r["protocol"], r["task"]) == ("cmorl", HOPPER))
    planted = float(round(rows[i]["hv"]["mean"] * 1.001))
    _edit_json(root, f"{FIELD}/table.json", lambda d: d["rows"][i]["hv"].update(mean=planted))
    cell = _committed_row(f"{FIELD}/table.md", "cmorl", "hopper-2obj")[3]
    mean = cell.split(" ")[0]
    _edit_text(root, f"{FIELD}/table.md", f"| {cell} |", f"| 9.9e+05{cell[len(mean) :]} |")
    _fails(
        root,
        rf"field/table.json cmorl hopper-2obj hv mean: states {int(planted)}",
        r"field/table.md cmorl hopper-2obj 'HV mean \[95%\]': prints '9.9e\+05",
    )


def _ablation_ratio(task: str, variant: str) -> tuple[float, str]:
    """The committed ratio of `variant` to the defaults on `task`, and the seeds it pairs
    as ablation.md prints them (`0, 1`)."""
    with open(os.path.join(ROOT, FIELD, "ablation.json")) as f:
        row = next(r for r in json.load(f)["rows"] if (r["task"], r["variant"]) == (task, variant))
    return row["ratio_to_default"], ", ".join(map(str, row["paired_seeds"]))


def test_plant_the_ablations_ratio_changed(tmp_path):
    """hopper-2obj's 10 x 32 variant against the defaults: its ratio 0.05 higher in
    ablation.json and 0.10 higher in ablation.md than its HVs give."""
    root = _copy(tmp_path)
    ratio, seeds = _ablation_ratio("hopper-2obj", "e10m32")

    def change(d):
        for r in d["rows"]:
            if (r["task"], r["variant"]) == ("hopper-2obj", "e10m32"):
                r["ratio_to_default"] = ratio + 0.05

    _edit_json(root, f"{FIELD}/ablation.json", change)
    _edit_text(
        root,
        f"{FIELD}/ablation.md",
        f"| {ratio:.2f} ({seeds}) |",
        f"| {ratio + 0.1:.2f} ({seeds}) |",
    )
    _fails(
        root,
        rf"field/ablation.json cmorl hopper-2obj e10m32 ratio_to_default: states {ratio + 0.05:.4}",
        r"field/ablation.md cmorl hopper-2obj e10m32 'vs default \(same seeds\)': prints "
        rf"'{ratio + 0.1:.2f}",
    )


def test_plant_a_field_departure_and_a_published_budget(tmp_path):
    """The table's front evaluated on 10 episodes per preference (C-MORL's Hopper-2d asks
    5): a departure its `deviations` do not state, and a front the table must refuse;
    and a published number filed at another budget."""
    root = _copy(tmp_path)
    _edit_json(root, FIELD_FRONT, lambda d: d["config"].update(eval_episodes=10))
    _edit_json(root, f"{FIELD}/published.json", lambda d: d["entries"][0].update(budget=3_000_000))
    _fails(
        root,
        rf"{FIELD_FRONT} protocol deviations: states \[\], its data give \[\('evaluation episodes'",
        r"field/table.json cmorl hopper-2obj seed 0: departs from the protocol",
        r"field/published.json entry 0 \('cmorl', 'hopper-2obj', 'PGMORL'\) budget",
    )


def test_plant_an_mo_gymnasium_agreement_changed(tmp_path):
    """The MO-Gymnasium evaluations' agreement: hopper's largest difference stated at 2.1
    standard errors (its means and standard deviations give 2.0); one standard deviation
    of the humanoid's returns 10% higher (its standard error and the agreement at that
    preference no longer follow); and docs/protocols.md printing ant's largest z 17.0 for
    17.6."""
    root = _copy(tmp_path)
    hopper, humanoid = f"{R}/mo_gymnasium_eval/hopper.json", f"{R}/mo_gymnasium_eval/humanoid.json"
    _edit_json(
        root, hopper, lambda d: d["agreement"]["return"]["largest_difference"].update(z=-2.1)
    )

    def change(d):
        big = d["agreement"]["return"]["largest_difference"]
        row = next(r for r in d["prefs"] if r["pref"] == big["pref"])
        row["return_std"][big["objective"]] *= 1.1

    _edit_json(root, humanoid, change)
    _edit_text(root, "docs/protocols.md", "| 7.2 | 17.6 |", "| 7.2 | 17.0 |")
    _fails(
        root,
        rf"{hopper} agreement return largest_difference z: states -2.1,",
        rf"{humanoid} pref \d+ return_se \[1\]",
        rf"{humanoid} agreement return largest_difference se:",
        r"docs/protocols.md table mo_gymnasium_eval row 5 'SE of difference'",
        r"docs/protocols.md table mo_gymnasium_eval row 0 'largest z': prints '17.0'",
    )


def test_plant_the_field_tables_in_the_documents_changed(tmp_path):
    """The README's glance at the field printing hopper-2obj's ratio to C-MORL 0.10
    higher than committed, docs/results.md's field table printing PGMORL's published
    Hopper-2d HV 1.30e5 for 1.20e5, and its ablation printing the 10 x 32 variant's ratio
    to the defaults 0.10 higher than its HVs give."""
    root = _copy(tmp_path)
    ratio, seeds = _ablation_ratio("hopper-2obj", "e10m32")
    with open(os.path.join(ROOT, "README.md")) as f:
        text = f.read()
    glance = re.search(r"`hopper-2obj`\]\([^)]*\) (\S+) \(C-MORL 1.37e5: (\d\.\d\d)[ ;]", text)
    hv, printed = glance.groups()
    _edit_text(
        root,
        "README.md",
        f"{hv} (C-MORL 1.37e5: {printed}",
        f"{hv} (C-MORL 1.37e5: {float(printed) + 0.1:.2f}",
    )
    row = _committed_row("docs/results.md", "cmorl", "Hopper-2d")
    assert row[5] == "1.20e5", row
    _edit_text(root, "docs/results.md", f"| {row[4]} | 1.20e5 |", f"| {row[4]} | 1.30e5 |")
    _edit_text(
        root,
        "docs/results.md",
        f"| {ratio:.2f} (seeds {seeds}) |",
        f"| {ratio + 0.1:.2f} (seeds {seeds}) |",
    )
    findings = _fails(
        root,
        r"README.md table field_glance row 0 .*: prints '.*`hopper-2obj` "
        rf"{re.escape(hv)} \(C-MORL 1.37e5: {float(printed) + 0.1:.2f}[ ;]",
        r"docs/results.md table field row 0 'PGMORL': prints '1.30e5', its data give \[120000.0\]",
        r"docs/results.md table field_ablation row \d+ 'vs default \(same seeds\)': prints "
        rf"'{ratio + 0.1:.2f} \(seeds {seeds}\)'",
    )
    assert len(findings) == 3, findings


def _evaluation_of(front: dict, scale: float = 0.98) -> dict:
    """A consistent MO-Gymnasium evaluation of a C-MORL-protocol front: its returns
    `scale` times the front's, every episode the full 500 steps, 1.0 the standard
    deviation of every return; the agreement and protocol scores as they follow."""
    config, k = front["config"], front["config"]["eval_episodes"]
    rows = []
    for r in front["prefs"]:
        row = {"pref": r["pref"], "episode_lengths": [500] * k}
        row.update(episode_length=500.0, episode_length_std=0.0)
        for kind in ("return", "discounted_return"):
            row[kind] = [scale * v for v in r[kind]]
            row[f"{kind}_std"] = [1.0] * len(r[kind])
            row[f"{kind}_se"] = [1.0 / math.sqrt(k)] * len(r[kind])
        row["project"] = {key: r[key] for key in ("return", "discounted_return", "episode_length")}
        rows.append(row)
    d = {
        "env": front["env"],
        "objective_names": front["objective_names"],
        "mo_gymnasium_id": audit.MO_GYMNASIUM_IDS[front["env"]],
        "mo_gymnasium_kwargs": {"max_episode_steps": 500},
        "policies": "conditioned",
        "episodes": k,
        "project_episodes": k,
        "project_source": "front.json",
        "gamma": 0.99,
        "run_config": {**config, "env_steps_total": front["env_steps_total"]},
        "prefs": rows,
    }
    d["agreement"] = audit.reevaluation_agreement(d)
    conv, scores = audit.C_MORL, {}
    for side, pts in (
        ("mo_gymnasium", [r["discounted_return"] for r in rows]),
        ("project", [r["project"]["discounted_return"] for r in rows]),
    ):
        scores[side] = {key: conv.score(pts)[key] for key in ("hv", "eu", "nondominated", "kept")}
    d["protocol"] = {"protocol": "cmorl", "returns": conv.returns, **scores, "deviations": []}
    return d


def test_plant_a_field_evaluation_the_tables_leave_out(tmp_path):
    """hopper-2obj's seed-0 MO-Gymnasium evaluation removed: table.json, table.md and
    docs/results.md still set it beside the front; then, with it back, its project side
    no longer the front's returns; then a consistent evaluation of other returns (0.98 of
    the front's) in its place, which the tables do not give."""
    root = _copy(tmp_path)
    evaluation = f"{os.path.dirname(FIELD_FRONT)}/{audit.FIELD_EVALUATION}"
    os.remove(os.path.join(root, evaluation))
    _fails(
        root,
        r"field/table.json cmorl hopper-2obj seed 0 mo_gymnasium: states .*, its data give None",
        r"field/table.json cmorl hopper-2obj hv_mo_gymnasium: states ",
        r"docs/results.md table field row 0 'in MO-Gymnasium: HV, ratio': prints "
        + re.escape(repr(_committed_row("docs/results.md", "cmorl", "Hopper-2d")[8])),
    )
    shutil.copy(os.path.join(ROOT, evaluation), os.path.join(root, evaluation))

    def change(d):
        d["prefs"][5]["project"]["discounted_return"][0] += 1.0

    _edit_json(root, evaluation, change)
    _fails(root, rf"{evaluation} project discounted_return: not the returns of {FIELD_FRONT}")
    with open(os.path.join(root, FIELD_FRONT)) as f:
        front = json.load(f)
    with open(os.path.join(root, evaluation), "w") as f:
        json.dump(_evaluation_of(front), f)
    findings = _fails(root, r"field/table.json cmorl hopper-2obj hv_mo_gymnasium .*: states ")
    assert not [line for line in findings if line.startswith(evaluation)], findings


EXPLORATION = f"{R}/exploration/exploration.json"


def test_plant_a_bandit_angle_changed(tmp_path):
    """The concave bandit's learned angle of `smooth_wc` at the sixth preference 0.1 rad
    larger: its point, its distance from its optimum, the hypervolume and the largest gap
    in angle that exploration.json states no longer follow, nor the docs' table and the
    README's glance that print them."""
    root = _copy(tmp_path)

    def change(d):
        d["problems"]["concave_bandit"]["directions"]["smooth_wc"]["theta"][5] += 0.1

    _edit_json(root, EXPLORATION, change)
    w = f"{EXPLORATION} concave_bandit smooth_wc"
    _fails(
        root,
        rf"{w} points \[5, 0\]: states",
        rf"{w} theta_error \[5\]: states",
        rf"{w} hypervolume: states",
        rf"{w} largest_theta_gap: states 0.229\d*, its data give 0.32",
        r"docs/results.md table exploration_bandit row 0 'largest gap in θ \(rad\)': "
        r"prints '0.229'",
        r"README.md table glance row \d+ 'what the front achieves': prints '9 distinct points .*"
        r"largest gap 0.229 rad",
    )


def test_plant_a_treasure_point_and_a_printed_ratio_changed(tmp_path):
    """Deep Sea Treasure: a point of `smooth_wc` that lies on the front moved 3 along the
    time objective (7 of 11 points within 1 of the front become 6), and the docs' table
    printing `wc`'s hypervolume ratio 0.651 for 0.641."""
    root = _copy(tmp_path)
    with open(os.path.join(ROOT, EXPLORATION)) as f:
        stated = json.load(f)["problems"]["deep_sea_treasure"]["directions"]["smooth_wc"]
    i = int(np.argmin(stated["distance_to_front"]))

    def change(d):
        d["problems"]["deep_sea_treasure"]["directions"]["smooth_wc"]["points"][i][1] -= 3.0

    _edit_json(root, EXPLORATION, change)
    _edit_text(root, "docs/results.md", "| 6 of 11 | 0.641 |", "| 6 of 11 | 0.651 |")
    w = f"{EXPLORATION} deep_sea_treasure smooth_wc"
    _fails(
        root,
        rf"{w} distance_to_front \[{i}\]: states",
        rf"{w} points_near_front: states 7, its data give 6",
        r"docs/results.md table exploration_dst row 0 'on the front \(within 1\)': "
        r"prints '7 of 11'",
        r"README.md table glance row \d+ 'what the front achieves': prints '7 of 11 points",
        r"docs/results.md table exploration_dst row 1 'HV / exact front's HV': prints '0.651'",
    )


def test_plant_a_convergence_gap_changed(tmp_path):
    """The tabular MOMDP's last measured gap of the default setting's first preference
    (its worst ratio, 0.13% of the initial gap) doubled: the final gap, its ratio and the
    slope that convergence.json states no longer follow, nor the docs' table and the
    README's glance."""
    root = _copy(tmp_path)
    conv = f"{R}/convergence/convergence.json"

    def change(d):
        d["results"][0]["prefs"][0]["gap"][-1] *= 2.0

    _edit_json(root, conv, change)
    w = rf"{conv} alpha/\(t\+1\), mu=0.1 pref \[0.2, 0.8\]"
    _fails(
        root,
        rf"{w} final_gap: states",
        rf"{w} final_over_initial: states",
        rf"{w} slope: states",
        r"docs/results.md table convergence row 0 'final gap / initial gap \(worst of 3\)': "
        r"prints '0.13%'",
        r"README.md table glance row \d+ 'what the front achieves': prints .*0.13%",
    )


def _lengths_and_count(rel: str) -> tuple[float, int, int]:
    """A conditioned network's committed front: its summed mean lengths, its episodes per
    preference and its evaluation env steps as counted (the episodes times the summed
    mean lengths, and times each candidate's where it chose among its last policies)."""
    with open(os.path.join(ROOT, rel)) as f:
        d = json.load(f)
    total, e = sum(r["episode_length"] for r in d["prefs"]), d["config"].get("eval_episodes", 8)
    chosen = d.get("selection", {}).get("candidate_length")
    extra = round(e * float(np.sum(chosen))) if chosen is not None else 0
    return total, e, round(e * total) + extra


def test_plant_evaluation_steps_short_where_no_list_allows_it(tmp_path, monkeypatch):
    """Evaluation env steps short of the count are accepted only on the fronts
    `EARLIER_EVAL_STEPS` lists, by exactly the steps listed. Planted: the conditioned
    network's seed-0 front (and its summary) stating the count as the earlier code
    would have truncated it (8 x the whole part of its summed mean lengths); a field
    front of the ablation (its summed mean lengths a hair above a whole number) one step
    per episode short; an ablation front of hopper-2obj, listed 1 short, stating the full
    count; and a listed shortfall the truncation does not give."""
    root = _copy(tmp_path)
    total, e, count = _lengths_and_count(COND)
    truncated = e * math.floor(total)
    assert 0 < count - truncated < e  # what the previous audit accepted here
    _edit_json(root, COND, lambda d: d["conditioned"].update(eval_env_steps=truncated))
    summary = f"{R}/conditioned_walker2d/summary.json"
    _edit_json(
        root, summary, lambda d: d["runs"]["conditioned"]["0"].update(eval_env_steps=truncated)
    )
    sel3 = f"{FIELD}/ablation/cmorl/hopper-2obj/e10m32-sel3/seed1/front.json"
    _, e3, count3 = _lengths_and_count(sel3)

    def short(d):
        d["conditioned"]["eval_env_steps"] = count3 - e3
        d["protocol"]["eval_env_steps"] = count3 - e3

    _edit_json(root, sel3, short)
    listed = f"{FIELD}/ablation/cmorl/hopper-2obj/e10m32/seed0/front.json"
    assert audit.EARLIER_EVAL_STEPS[listed] == 1
    _, _, full = _lengths_and_count(listed)
    _edit_json(root, listed, lambda d: d["conditioned"].update(eval_env_steps=full))
    wrong = f"{FIELD}/cmorl/humanoid/seed0/front.json"
    monkeypatch.setitem(audit.EARLIER_EVAL_STEPS, wrong, audit.EARLIER_EVAL_STEPS[wrong] + 2)
    _fails(
        root,
        rf"{COND} eval_env_steps: states {truncated}, its data give {count}$",
        rf"conditioned_walker2d/summary.json conditioned seed 0 eval_env_steps: states {truncated}",
        rf"{sel3} eval_env_steps: states {count3 - e3}, its data give {count3}$",
        rf"{sel3} protocol eval_env_steps: states {count3 - e3}, its data give {count3}$",
        rf"{listed} eval_env_steps: states {full}, its data give {full - 1}$",
        rf"EARLIER_EVAL_STEPS {wrong}: lists 10 steps short of \d+, the earlier code's "
        r"truncation gives \[8\]",
    )
