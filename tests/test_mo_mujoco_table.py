"""experiments/mo_mujoco.py's table writer on tiny made-up results (no training), its
numbers by hand; and its commands' bad input."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(__file__)), "experiments"))

import mo_mujoco  # noqa: E402


def _front(scalarization, returns, discounted, speeds):
    prefs = [[1.0, 0.0], [0.0, 1.0]]
    return {
        "env": "halfcheetah",
        "objective_names": ["forward_velocity", "control"],
        "prefs": [
            {
                "pref": p,
                "return": r,
                "discounted_return": d,
                "episode_length": 500.0,
                "mean_x_velocity": v,
            }
            for p, r, d, v in zip(prefs, returns, discounted, speeds, strict=True)
        ],
        "cardinality": 2,
        "expected_utility": 12.5,
        "env_steps_per_pref": 1000,
        "wall_s": 30.0,
        "config": {"train": {"gamma": 0.99, "scalarization": scalarization}},
    }


@pytest.fixture
def results(tmp_path):
    task = tmp_path / "halfcheetah"
    for scal in ("smooth_wc", "linear"):
        (task / scal).mkdir(parents=True)
        front = _front(scal, [[100, -50], [10, -5]], [[50, -20], [5, -2]], [2.0, 0.1])
        (task / scal / "front.json").write_text(json.dumps(front))
    reference = {"mean_x_velocity": 2.5, "wall_s": 10.0, "env_steps": 1000}
    (task / "reference_ppo.json").write_text(json.dumps(reference))
    return str(tmp_path)


def test_table_numbers_by_hand(results):
    summary = mo_mujoco.summarize(results)
    assert [r["scalarization"] for r in summary["rows"]] == ["smooth_wc", "linear"]
    row = summary["rows"][0]
    # discounted (50, -20), (5, -2) from (-100, -100): 150 * 80 + 105 * 18
    assert row["hv_morl_baselines"] == pytest.approx(12000 + 1890)
    assert row["forward_end_pref"] == [1.0, 0.0]
    assert row["forward_end_mean_x_velocity"] == 2.0
    assert row["speed_ratio"] == pytest.approx(0.8)
    # the front's 30 s against 2 preferences x PPO's 10 s, with the margin of 1.5: 45 / 20
    assert row["wall_ratio"] == pytest.approx(2.25)
    assert row["nondominated"] == 2 and row["expected_utility"] == 12.5


def test_table_files(results):
    mo_mujoco.main(["table", "--results", results])
    md = open(os.path.join(results, "table.md")).read()
    assert "| halfcheetah | smooth_wc | 2 | 1,000 | 0.99 | 1.389e+04 | 12.5 |" in md
    saved = json.load(open(os.path.join(results, "table.json")))
    assert len(saved["rows"]) == 2 and "published" not in saved


def test_bad_commands_are_refused(capsys):
    with pytest.raises(SystemExit):
        mo_mujoco.main(["fronts", "--envs", "hopper,nope"])
    assert "unknown task(s) ['nope']" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        mo_mujoco.main(["ppo"])
    assert "ppo needs --env" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        mo_mujoco.main(["fronts", "--envs", "hopper", "--directions", "smooth_wc,chebyshev"])
    assert "--directions 'smooth_wc,chebyshev'" in capsys.readouterr().err


def test_smoke_sweep_command():
    cmd = mo_mujoco.sweep_command("ant", "linear", "/tmp/x", 3, smoke=True)
    assert cmd[1:] == [
        "-m", "wcac_jax.sweep", "--env", "ant", "--scalarization", "linear", "--seed", "3",
        "--out", "/tmp/x", "--n-prefs", "3", "--steps-per-pref", "20480", "--eval-episodes", "1",
    ]  # fmt: skip


def _files(root):
    return {
        os.path.relpath(os.path.join(d, n), root): open(os.path.join(d, n), "rb").read()
        for d, _, names in os.walk(root)
        for n in names
    }


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["fronts", "--envs", "hopper,halfcheetah"], "halfcheetah/smooth_wc"),
        (["ppo", "--env", "halfcheetah"], "halfcheetah/reference_ppo.json"),
        (["table"], "table.md"),
    ],
)
def test_existing_results_are_refused(results, capsys, monkeypatch, args, named):
    """Without --resume or --overwrite: exit 2, one line naming the path, every file as
    it was, and nothing run (a sweep started would fail the test)."""
    with open(os.path.join(results, "table.md"), "w") as f:
        f.write("mine")
    before = _files(results)
    monkeypatch.setattr(mo_mujoco.subprocess, "run", lambda *a, **k: pytest.fail("ran"))
    with pytest.raises(SystemExit) as exc:
        mo_mujoco.main([*args, "--results", results])
    assert exc.value.code == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("error: ")
    assert repr(os.path.join(results, named)) in err[0]
    assert _files(results) == before


def test_fronts_continue_or_replace_what_is_there(results, monkeypatch):
    """--resume and --overwrite reach the sweeps of the fronts already there; a new front
    gets neither."""
    ran = []

    def run(cmd, **kwargs):
        ran.append(cmd)
        return subprocess.CompletedProcess(cmd, 0)

    monkeypatch.setattr(mo_mujoco.subprocess, "run", run)
    for flag in ("--resume", "--overwrite"):
        ran.clear()
        assert (
            mo_mujoco.main(["fronts", "--envs", "halfcheetah,hopper", flag, "--results", results])
            == 0
        )
        envs = [cmd[cmd.index("--env") + 1] for cmd in ran]
        assert envs == ["halfcheetah", "halfcheetah", "hopper", "hopper"]
        assert [cmd[-1] == flag for cmd in ran] == [True, True, False, False]
        assert not any({"--resume", "--overwrite"} & set(cmd) for cmd in ran[2:])


def test_fronts_of_one_direction(tmp_path, monkeypatch):
    """--directions runs only the fronts named, into their own directories."""
    ran = []
    monkeypatch.setattr(
        mo_mujoco.subprocess,
        "run",
        lambda cmd, **k: ran.append(cmd) or subprocess.CompletedProcess(cmd, 0),
    )
    args = ["fronts", "--envs", "ant,hopper", "--directions", "linear", "--results", str(tmp_path)]
    assert mo_mujoco.main(args) == 0
    assert [(c[c.index("--env") + 1], c[c.index("--scalarization") + 1]) for c in ran] == [
        ("ant", "linear"), ("hopper", "linear"),
    ]  # fmt: skip
    assert ran[0][ran[0].index("--out") + 1] == os.path.join(str(tmp_path), "ant", "linear")


def _seeded(tmp_path, forward_ends):
    """halfcheetah fronts of both scalarizations on seeds 0, 1, 2: the forward end's
    discounted forward return per (scalarization, seed), everything else equal."""
    for scal, ends in forward_ends.items():
        for seed, end in enumerate(ends):
            out = mo_mujoco.front_dir(str(tmp_path), "halfcheetah", scal, seed)
            os.makedirs(out)
            front = _front(scal, [[2 * end, -50], [10, -5]], [[end, -20], [5, -2]], [end / 25, 0.1])
            with open(os.path.join(out, "front.json"), "w") as f:
                json.dump(front, f)
    return str(tmp_path)


def test_seeds_live_beside_seed_zero(tmp_path):
    assert mo_mujoco.front_dir("r", "ant", "linear") == os.path.join("r", "ant", "linear")
    assert mo_mujoco.front_dir("r", "ant", "linear", 2) == os.path.join(
        "r", "ant", "seed2", "linear"
    )


def test_seed_comparison_by_hand(tmp_path):
    results = _seeded(tmp_path, {"smooth_wc": [50, 60, 55], "linear": [20, 30, 45]})
    c = mo_mujoco.summarize(results)["seeds"]["halfcheetah"]
    assert c["seeds"] == [0, 1, 2]
    hv = c["hypervolume"]["hv_morl_baselines"]
    # (end, -20), (5, -2) from (-100, -100): (end + 100) * 80 + 105 * 18
    assert hv["smooth_wc"] == pytest.approx([150 * 80 + 1890, 160 * 80 + 1890, 155 * 80 + 1890])
    assert hv["linear"] == pytest.approx([120 * 80 + 1890, 130 * 80 + 1890, 145 * 80 + 1890])
    assert hv["mean"]["linear"] == pytest.approx(np.mean([120, 130, 145]) * 80 + 1890)
    # smooth_wc's worst seed (150) above linear's best (145)
    assert hv["winner"] == "smooth_wc"
    assert c["forward_speed"]["smooth_wc"] == pytest.approx([2.0, 2.4, 2.2])
    # undiscounted forward returns 2 * end: smooth_wc's mean 110, linear's 63.33
    assert c["mean_return"]["smooth_wc"][0] == pytest.approx([110, -50])
    assert c["mean_return"]["linear"][0] == pytest.approx([190 / 3, -50])
    assert c["mean_return"]["linear"][1] == pytest.approx([10, -5])


def test_overlapping_seeds_name_no_winner_and_two_seeds_no_comparison(tmp_path):
    results = _seeded(tmp_path, {"smooth_wc": [50, 60, 40], "linear": [20, 30, 45]})
    summary = mo_mujoco.summarize(results)
    for entry in summary["seeds"]["halfcheetah"]["hypervolume"].values():
        assert entry["winner"] is None  # linear's 45 above smooth_wc's 40
    mo_mujoco.write_table(summary, results)
    md = open(os.path.join(results, "table.md")).read()
    assert "### halfcheetah (seeds 0, 1, 2)" in md and "| within the spread |" in md
    # seed 2 of linear removed: two seeds with both fronts, no comparison
    os.remove(os.path.join(mo_mujoco.front_dir(results, "halfcheetah", "linear", 2), "front.json"))
    assert mo_mujoco.summarize(results)["seeds"] == {}


def _edit(path, change):
    """Rewrites the JSON file at `path` with `change` applied to its contents."""
    with open(path) as f:
        data = json.load(f)
    change(data)
    with open(path, "w") as f:
        json.dump(data, f)


def _refused(results, capsys, match, named):
    """`summarize` raises a ValueError matching `match`, and the `table` command refuses:
    one line naming `named`, exit 2, no table written."""
    with pytest.raises(ValueError, match=match):
        mo_mujoco.summarize(results)
    with pytest.raises(SystemExit) as exc:
        mo_mujoco.main(["table", "--results", results])
    assert exc.value.code == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and named in err[0]
    assert not os.path.exists(os.path.join(results, "table.md"))


def test_seeds_trained_otherwise_are_not_compared(tmp_path, capsys):
    """A seed whose front was trained with another setting (here a default changed
    between seeds) stops the comparison with a message naming what differs."""
    results = _seeded(tmp_path, {"smooth_wc": [50, 60, 55], "linear": [20, 30, 45]})
    path = os.path.join(mo_mujoco.front_dir(results, "halfcheetah", "linear", 2), "front.json")
    _edit(path, lambda front: front["config"]["train"].update(log_std_init=-1.0))
    match = r"halfcheetah linear seed 2: .*\(train\.log_std_init\)"
    _refused(results, capsys, match, "train.log_std_init")


def test_a_reference_at_another_budget_is_refused(results, capsys):
    """PPO is compared with a front only at the front's budget per preference: a reference
    that ran another number of env steps stops the table with one line naming both."""
    path = os.path.join(results, "halfcheetah", "reference_ppo.json")
    _edit(path, lambda reference: reference.update(env_steps=3000))
    _refused(results, capsys, r"halfcheetah smooth_wc: .* 1,000 .* 3,000", "--steps 1000")


def test_ppo_runs_each_tasks_budget_per_preference(tmp_path, monkeypatch):
    """`ppo`'s default env-step budget is the task's front's (its preset's), so the table
    compares the two at one budget: the humanoid's 3M, the others' 1M."""
    from wcac_jax import presets

    assert mo_mujoco.BUDGET == {
        env: presets.ENV_DEFAULTS[env].steps_per_pref for env in mo_mujoco.SINGLE_OBJECTIVE
    }
    ran = {}
    monkeypatch.setattr(
        mo_mujoco, "run_ppo", lambda env, out, steps, *_: ran.setdefault(env, steps)
    )
    for env in ("humanoid", "hopper"):
        mo_mujoco.main(["ppo", "--env", env, "--results", str(tmp_path)])
    mo_mujoco.main(["ppo", "--env", "ant", "--steps", "5000", "--results", str(tmp_path)])
    assert ran == {"humanoid": 3_000_000, "hopper": 1_000_000, "ant": 5000}
