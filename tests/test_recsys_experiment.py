"""The Table 2 / Fig. 2 experiment end to end at `--quick`, and its bad input."""

import dataclasses
import json
import math
import os
import shutil
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from wcac_jax.recsys import synth, table2
from wcac_jax.recsys.data import SIGNALS, load

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "experiments"))

import kuairand_table2  # noqa: E402

METHODS = (
    "Behavior-Clone",
    "MOAC (linear)",
    "MOCHA (linear)",
    "PDPG (DNN)",
    "wcac (DDPG-style)",
    "wcac (Algorithm 1)",
    "Oracle",
)
ROW_KEYS = {
    "ncis", "ncis_ci95", "vs_bc", "vs_bc_ci95", "ess", "truth", "truth_ci95", "truth_vs_bc",
    "truth_vs_bc_ci95", "unified_truth", "unified_truth_ci95", "unified_vs_bc",
    "unified_vs_bc_ci95", "gap_share", "gap_share_ci95", "gap_share_by_data_set",
    "gap_share_ci95_data_sets",
}  # fmt: skip


WALL = {}  # the module fixture's wall seconds


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    data = str(tmp_path_factory.mktemp("kuairand"))
    synth.write(synth.SynthConfig(users=40, videos=200, rows=4000, seed=2), data)
    out = str(tmp_path_factory.mktemp("out") / "results" / "table2")  # parents made as needed
    start = time.perf_counter()
    assert kuairand_table2.main(["--data", data, "--out", out, "--quick", "--seeds", "2"]) == 0
    WALL["run"] = time.perf_counter() - start
    return data, out


def test_table_json_schema(run):
    _, out = run
    table = json.load(open(os.path.join(out, "table.json")))
    assert list(table["methods"]) == list(METHODS)
    assert table["seeds"] == [0, 1] and len(table["data_seeds"]) == 1
    for name, row in table["methods"].items():
        assert set(row) == ROW_KEYS, name
        for part in ("ncis", "truth"):
            assert list(row[part]) == list(SIGNALS)
            assert all(math.isfinite(v) for v in row[part].values())
            for s in SIGNALS:  # the estimate lies in its bootstrap interval
                lo, hi = row[f"{part}_ci95"][s]
                assert lo - 1e-9 <= row[part][s] <= hi + 1e-9, (name, part, s)
        assert list(row["vs_bc"]) == list(SIGNALS)
        assert row["ess"] > 0


def test_table_is_what_the_per_seed_values_give(run):
    """Every point estimate, change against Behavior-Clone and gap share of `table.json`,
    and the gap share's interval with the data sets resampled, recomputed by the audit
    (`tests/audit.py`, its own numpy) from `per_seed.json`: each training seed's NCIS and
    true values on all of its data set's test rows."""
    import audit

    _, out = run
    root = os.path.dirname(os.path.dirname(out))
    base = os.path.relpath(out, root)
    values = json.load(open(os.path.join(out, "per_seed.json")))
    assert values["seeds"] == [0, 1] and len(values["data_sets"]) == 1
    assert list(values["data_sets"][0]) == ["name", *METHODS]
    assert np.shape(values["data_sets"][0]["Oracle"]["truth"]) == (1, 7)  # one policy
    assert audit.check_kuairand(audit.Repo(root), base) == []


def _raised(values: list) -> None:
    values[0] += 0.05


def test_a_per_seed_value_changed_is_caught(run, tmp_path):
    """The check above is not vacuous: in a copy of the run, the first training seed's
    true unified value of Algorithm 1 0.05 higher fails its point estimate, its gap share
    and the interval over data sets; its two training seeds' true unified values
    exchanged (every mean stays) fail that interval alone."""
    import audit

    _, out = run
    base = os.path.join("results", "table2")
    for name, change in (("raised", _raised), ("exchanged", list.reverse)):
        root = str(tmp_path / name)
        shutil.copytree(out, os.path.join(root, base))
        path = os.path.join(root, base, "per_seed.json")
        values = json.load(open(path))
        change(values["data_sets"][0]["wcac (Algorithm 1)"]["unified_truth"])
        json.dump(values, open(path, "w"))
        findings = audit.check_kuairand(audit.Repo(root), base)
        interval = [f for f in findings if "wcac (Algorithm 1) gap share interval over" in f]
        assert interval, (name, findings)
        if name == "raised":
            for key in ("unified_truth:", "gap_share:"):
                assert any(f"wcac (Algorithm 1) {key}" in f for f in findings), (key, findings)
        else:
            assert findings == interval, findings


def test_the_oracle_is_best_on_the_unified_objective(run):
    _, out = run
    methods = json.load(open(os.path.join(out, "table.json")))["methods"]
    best = max(methods, key=lambda name: methods[name]["unified_truth"])
    assert best == "Oracle"


def test_behavior_clone_is_scored_against_an_independent_behaviour_model(run):
    """The behaviour model is another Behavior-Clone (its own key): its importance weights
    are not all 1, so Behavior-Clone's NCIS is an estimate (ESS below the test rows), not
    the logged test means by construction."""
    data_dir, out = run
    table = json.load(open(os.path.join(out, "table.json")))
    data = load(data_dir)
    n_test = data.n_rows - data.n_train
    assert table["methods"]["Behavior-Clone"]["ess"] < n_test


def test_markdown_figure_curves_and_run_record(run):
    _, out = run
    md = open(os.path.join(out, "table.md")).read().splitlines()
    assert md[0].startswith("| NCIS | Click↑ | Like↑ (e-2)")
    for name in METHODS:
        assert sum(line.startswith(f"| {name} |") for line in md) == 3, name
    assert os.path.getsize(os.path.join(out, "fig2.png")) > 10_000
    fig2 = json.load(open(os.path.join(out, "fig2.json")))
    assert np.array(fig2["values"]["ncis"]["leaning"]).shape == (7, 7)
    assert len(fig2["improvement"]["truth"]) == 7
    info = json.load(open(os.path.join(out, "run.json")))
    assert info["data_sets"][0]["state_dim"] == 1044 and info["synthetic"] is True
    # the whole run's seconds, each counted once: no more than the call's wall time
    assert 0 < info["seconds"]["total"] <= WALL["run"]
    assert info["merged_parts"] is False  # one process: its total is its own wall time
    # one data set trained here, and this process: its peak memory, above what numpy
    # and jax alone take and far below the machine's
    assert len(info["max_rss_gib"]) == 2 and 0.1 < info["max_rss_gib"][-1] < 24
    curves = json.load(open(os.path.join(out, "curves.json")))
    for method in ("moac", "mocha", "pdpg", "wcac", "alg1"):
        c = curves["data_sets"][0][method]
        assert np.array(c["critic_loss"]).shape[0] == 2  # one curve per seed
        assert np.isfinite(np.array(c["mean_action"])).all()


def test_parts_merged_give_the_one_process_table(tmp_path, capsys, run):
    """`--part 0` in its own call, then `--merge` of its file: the same table, figure
    data and curves as the fixture's one-process run of the same data, seed and seeds;
    an existing part file is kept unless `--overwrite`, and a part index outside
    `--data` is refused."""
    data_dir, out = run
    part, merged = tmp_path / "parts" / "p0.pkl", tmp_path / "merged"
    quick = ["--data", data_dir, "--quick", "--seeds", "2"]
    assert kuairand_table2.main([*quick, "--part", "0", "--out", str(part)]) == 0
    before = part.read_bytes()
    capsys.readouterr()
    assert kuairand_table2.main([*quick, "--part", "0", "--out", str(part)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "exists" in err[0] and part.read_bytes() == before
    assert kuairand_table2.main([*quick, "--part", "1", "--out", str(tmp_path / "p1")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--part 1" in err[0] and not (tmp_path / "p1").exists()
    assert kuairand_table2.main([*quick, "--merge", str(part), "--out", str(merged)]) == 0
    for name in ("table.json", "table.md", "fig2.json", "curves.json"):
        assert (merged / name).read_text() == open(os.path.join(out, name)).read(), name
    info = json.load(open(merged / "run.json"))
    assert info["merged_parts"] is True


def test_bad_input_one_line_exit_2_nothing_written(tmp_path, capsys, run):
    data_dir, _ = run
    out = tmp_path / "out"
    assert (
        kuairand_table2.main(["--data", str(tmp_path / "nope"), "--out", str(out), "--quick"]) == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and "nope" in err[0]
    assert not out.exists()
    broken = tmp_path / "broken"
    os.makedirs(broken)
    for name in os.listdir(data_dir):
        df_path = os.path.join(data_dir, name)
        if name == synth.FILES["video_basic"]:
            pd.read_csv(df_path).drop(columns=["music_type"]).to_csv(broken / name, index=False)
        elif not name.endswith(".npz"):
            os.symlink(df_path, broken / name)
    assert kuairand_table2.main(["--data", str(broken), "--out", str(out), "--quick"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "video_features_basic_27k.csv" in err[0] and "music_type" in err[0]
    assert not out.exists()
    a_file = tmp_path / "a_file"
    a_file.write_text("")
    assert kuairand_table2.main(["--data", data_dir, "--out", str(a_file / "out"), "--quick"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{str(a_file)!r} is not a directory" in err[0]
    assert a_file.read_text() == ""


def test_non_finite_training_loss_exit_3_nothing_written(tmp_path, capsys, monkeypatch, run):
    """A step size far too large makes Behavior-Clone's loss NaN at its second step: the
    run stops with one line naming it, exit status 3, and writes no table."""
    data_dir, _ = run
    monkeypatch.setattr(
        kuairand_table2, "QUICK", dataclasses.replace(kuairand_table2.QUICK, critic_lr=1e30)
    )
    out = tmp_path / "out"
    assert kuairand_table2.main(["--data", data_dir, "--out", str(out), "--quick"]) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["error: Behavior-Clone: loss is nan at step 2 of 40; nothing written"]
    assert not out.exists()


def _tree(d):
    return {p.relative_to(d): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


@pytest.fixture
def old_results(tmp_path):
    """A results directory of an earlier run, with a seed sub-directory."""
    out = tmp_path / "results" / "kuairand"
    (out / "seed1").mkdir(parents=True)
    (out / "table.json").write_text('{"old": 1}\n')
    (out / "seed1" / "table.json").write_text('{"old": 2}\n')
    return out


def test_non_empty_out_refused_unless_overwrite(run, old_results, capsys):
    data_dir, _ = run
    before = _tree(old_results)
    assert kuairand_table2.main(["--data", data_dir, "--out", str(old_results), "--quick"]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"error: --out {str(old_results)!r} is not empty (holds seed1, table.json); "
        "pass --overwrite to replace it whole"
    ]
    assert _tree(old_results) == before


def test_overwrite_replaces_out_whole(run, old_results, monkeypatch):
    data_dir, out = run
    fig2 = json.load(open(os.path.join(out, "fig2.json")))
    calls = []

    def fake_run(data, out, cfg, seed, version=None, **kw):  # the write of a finished run
        calls.append(data)
        kuairand_table2.write_results(out, {"table.json": '{"new": 1}\n'}, fig2)

    monkeypatch.setattr(kuairand_table2, "run", fake_run)
    argv = ["--data", data_dir, "--out", str(old_results), "--quick", "--overwrite"]
    assert kuairand_table2.main(argv) == 0 and calls == [[data_dir]]
    assert set(_tree(old_results)) == {Path("table.json"), Path("fig2.png")}  # no seed1
    assert (old_results / "table.json").read_text() == '{"new": 1}\n'
    assert os.listdir(old_results.parent) == ["kuairand"]  # no temporary directory left


def test_interrupted_write_leaves_the_old_results_whole(run, old_results, monkeypatch):
    _, out = run
    fig2 = json.load(open(os.path.join(out, "fig2.json")))
    before = _tree(old_results)

    def interrupted(fig2, path):
        raise KeyboardInterrupt

    monkeypatch.setattr(kuairand_table2, "plot_fig2", interrupted)
    with pytest.raises(KeyboardInterrupt):
        kuairand_table2.write_results(str(old_results), {"table.json": "{}\n"}, fig2)
    assert _tree(old_results) == before
    assert os.listdir(old_results.parent) == ["kuairand"]


def test_truth_is_each_test_rows_candidates_in_its_logged_session_context(run):
    """`_truth_tables[i, j]`: candidate `j` shown to test row `i`'s user after the videos
    logged earlier in that row's session; checked by hand (P(click) from the model's
    logit and bias) on a few rows, and different from a first view where the session
    has begun."""
    data_dir, _ = run
    data = load(data_dir)
    model = synth.ResponseModel.load(os.path.join(data_dir, synth.MODEL_FILE))
    table = np.asarray(table2.truth_tables(model, data, chunk=7))
    n_test = data.n_rows - data.n_train
    assert table.shape == (n_test, data.n_candidates, 7)
    rows = np.asarray(data.log_row[data.n_train :])
    ctx = model.log_context[rows]  # [n_test, K] video ids, -1 none
    begun = np.flatnonzero((ctx >= 0).any(axis=1))
    fresh = np.flatnonzero((ctx < 0).all(axis=1))
    assert begun.size > 0 and fresh.size > 0
    users = data.user_ids[np.asarray(data.user_index[data.n_train :])]
    for i in (*begun[:3], fresh[0]):
        ui = np.searchsorted(model.user_ids, users[i])
        ci = np.array([np.searchsorted(model.video_ids, v) if v >= 0 else -1 for v in ctx[i]])
        for j in (0, 5, data.n_candidates - 1):
            vi = np.searchsorted(model.video_ids, data.video_ids[j])
            logit, _ = model.logits(np.array(ui), np.array(vi), ci)
            click = 1.0 / (1.0 + math.exp(-(model.bias[0] + float(logit["is_click"]))))
            assert table[i, j, 0] == pytest.approx(click, rel=1e-5)
            want = model.expected(users[i], data.video_ids[j], ctx[i])
            np.testing.assert_allclose(table[i, j], want, rtol=1e-5)
    first = model.expected(users[:, None], data.video_ids[None, :])  # first views
    np.testing.assert_allclose(table[fresh], first[fresh], rtol=1e-5)
    assert not np.allclose(table[begun], first[begun], rtol=1e-3)


def test_tscac_protocol_runs_and_is_recorded(run, tmp_path):
    data_dir, out = run
    assert json.load(open(os.path.join(out, "run.json")))["protocol"] == "default"
    out_t = str(tmp_path / "tscac")
    argv = ["--data", data_dir, "--out", out_t, "--quick", "--seeds", "1", "--protocol", "tscac"]
    assert kuairand_table2.main(argv) == 0
    info = json.load(open(os.path.join(out_t, "run.json")))
    assert info["protocol"] == "tscac"
    assert info["data_sets"][0]["reward_scale"] == [1.0, 1.0, 1.0, 1.0, 1.0, -1.0, 1.0]
    table = json.load(open(os.path.join(out_t, "table.json")))
    assert list(table["methods"]) == list(METHODS)
    for row in table["methods"].values():
        assert all(math.isfinite(v) for v in row["truth"].values())


def test_ncis_events_are_the_logged_test_rows_events(run):
    """The events NCIS's verdicts rest on: each 0/1 signal's count among the test rows,
    recounted here from the loaded data."""
    data_dir, out = run
    table = json.load(open(os.path.join(out, "table.json")))
    data = load(data_dir)
    test = np.asarray(data.reward[data.n_train :])
    want = {s: int((test[:, i] > 0).sum()) for i, s in enumerate(SIGNALS) if s != "watch_time"}
    assert table["ncis_events"] == want
    assert table["min_ncis_events"] == kuairand_table2.MIN_NCIS_EVENTS


def test_ncis_gives_no_verdict_on_a_signal_with_few_events():
    row = {
        "ncis": {"forward": 0.002, "comment": 0.003},
        "ncis_ci95": {"forward": [0.001, 0.003], "comment": [0.002, 0.004]},
        "vs_bc": {"forward": -60.0, "comment": -30.0},
        "vs_bc_ci95": {"forward": [-80.0, -40.0], "comment": [-45.0, -15.0]},
    }
    events = {"forward": 12, "comment": 52}
    cell = kuairand_table2._cell(row, "ncis", "forward", 1e3, False, events)
    assert cell == "2.000 [1.000, 3.000] (few events: 12)"
    cell = kuairand_table2._cell(row, "ncis", "comment", 1e3, False, events)
    assert cell == "3.000 [2.000, 4.000] (-30.0%)"
