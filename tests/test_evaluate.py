"""`python -m wcac_jax.evaluate RUN --in mo-gymnasium` end to end on tiny Hopper runs: an
ordinary sweep (each preference's choice among its last two policies) and a conditioned
network under C-MORL's protocol; and its refusals.

The tiny runs reset WITHOUT noise (`reset_noise_scale = 0`, passed to MO-Gymnasium's
environment too) and end after 40 steps, so both evaluations start every episode from the
same state and run the same deterministic policy: what separates them is rounding, not
noise. The project's MuJoCo engine keeps its state in float32 between steps
(`wcac_jax.envs.engines`), MO-Gymnasium in float64; the returns are float32 sums on the
project's side; the policies agree within 2.4e-6 (`test_numpy_policy`), and one step of
the two environments within about 1e-6 relative (the conformance tests). Over 40 steps
the dynamics may amplify that, so the bound is `RELATIVE = 1e-3` of each objective's
return scale, with the same episode lengths: 3,000 times what was measured (at most
3.3e-7 of the scale, every episode 40 steps on both sides), and far below what another
episode length, task, reset or discount does to the returns (percents); the policy
itself is checked in `test_numpy_policy`.
"""

import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from wcac_jax import protocols
from wcac_jax.algos import ConditionedConfig, PracticalConfig
from wcac_jax.evaluate import cli, reference
from wcac_jax.sweep import SweepConfig, run_conditioned, run_sweep
from wcac_jax.sweep.protocol import protocol_sweep

pytest.importorskip("mo_gymnasium")

LENGTH = 40
OPTIONS = {"engine": "mujoco", "episode_length": LENGTH, "reset_noise_scale": 0.0}
SMALL = dict(num_envs=4, rollout_steps=16, num_minibatches=2, width=16, depth=1)
RELATIVE = 1e-3


@pytest.fixture(scope="module")
def sweep_run(tmp_path_factory):
    """Two preferences, 4 iterations each, each reporting the better of its last two."""
    out = str(tmp_path_factory.mktemp("evaluate") / "sweep")
    config = SweepConfig(
        prefs=((1.0, 0.0), (0.0, 1.0)),
        env="hopper-2obj",
        env_options=OPTIONS,
        train=PracticalConfig(**SMALL),
        steps_per_pref=4 * 64,
        eval_episodes=2,
        select_last=2,
        select_every=64,
    )
    run_sweep(config, out, progress=False)
    return out


@pytest.fixture(scope="module")
def protocol_run(tmp_path_factory):
    """A conditioned network under C-MORL's protocol, far below its budget."""
    out = str(tmp_path_factory.mktemp("evaluate") / "protocol")
    config = protocol_sweep(
        "hopper-2obj",
        "cmorl",
        train=ConditionedConfig(**SMALL),
        total_steps=4 * 64,
        env_options=OPTIONS,
    )
    run_conditioned(config, out, progress=False)
    return out


def _evaluate(run, *extra):
    out = os.path.join(run, "evaluation_mo_gymnasium.json")
    if os.path.exists(out):
        os.remove(out)
    assert cli.main([run, "--in", "mo-gymnasium", *extra]) == 0
    with open(out) as f:
        return json.load(f)


def _assert_agrees(result):
    """Every preference's means within `RELATIVE` of the return's scale (its largest
    magnitude over the preferences, per objective, at least 1), and the same episode
    lengths."""
    for kind in ("return", "discounted_return"):
        ours = np.array([row[kind] for row in result["prefs"]])
        theirs = np.array([row["project"][kind] for row in result["prefs"]])
        scale = np.maximum(np.abs(theirs).max(axis=0), 1.0)
        assert np.all(np.abs(ours - theirs) <= RELATIVE * scale), (kind, ours, theirs)
    for row in result["prefs"]:
        assert row["episode_length"] == row["project"]["episode_length"]


def test_sweep_evaluated_in_mo_gymnasium_agrees_with_the_project(sweep_run, capsys):
    result = _evaluate(sweep_run, "--episodes", "1")
    assert "wrote" in capsys.readouterr().out
    assert result["mo_gymnasium_id"] == "mo-hopper-2obj-v5"
    assert result["mo_gymnasium_kwargs"] == {"max_episode_steps": LENGTH, "reset_noise_scale": 0}
    assert result["policies"] == "chosen"
    assert result["episodes"] == 1 and result["project_episodes"] == 2
    assert result["project_source"] == "front.json"
    with open(os.path.join(sweep_run, "front.json")) as f:
        front = json.load(f)
    assert [row["pref"] for row in result["prefs"]] == [row["pref"] for row in front["prefs"]]
    for row, theirs in zip(result["prefs"], front["prefs"], strict=True):
        assert row["project"]["return"] == theirs["return"]  # front.json's, beside ours
        assert len(row["return"]) == 2 and row["return_std"] == [None, None]  # one episode
        assert 1 <= row["episode_length"] <= LENGTH
    assert result["gamma"] == 0.99  # the training's: an ordinary sweep records no other
    assert "protocol" not in result
    _assert_agrees(result)


def test_the_projects_evaluation_rerun_with_more_episodes(sweep_run):
    """Without reset noise every episode is the same one, so the project's evaluation of
    the reported policies re-run on 3 fresh episodes gives `front.json`'s numbers again."""
    result = _evaluate(sweep_run, "--episodes", "1", "--project-episodes", "3")
    assert result["project_episodes"] == 3
    assert result["project_source"].startswith("re-evaluated")
    with open(os.path.join(sweep_run, "front.json")) as f:
        front = json.load(f)
    for row, theirs in zip(result["prefs"], front["prefs"], strict=True):
        for kind in ("return", "discounted_return", "episode_length"):
            np.testing.assert_allclose(row["project"][kind], theirs[kind], rtol=1e-6)
    _assert_agrees(result)


def test_a_subset_of_the_sweeps_preferences(sweep_run):
    result = _evaluate(sweep_run, "--episodes", "1", "--prefs", "0,1")
    assert [row["pref"] for row in result["prefs"]] == [[0.0, 1.0]]


def test_protocol_run_at_the_protocols_preferences_episodes_and_discount(protocol_run):
    result = _evaluate(protocol_run)
    grid = protocols.CMORL.eval_prefs(2)
    np.testing.assert_allclose([row["pref"] for row in result["prefs"]], grid)
    assert result["policies"] == "conditioned"
    assert result["episodes"] == result["project_episodes"] == 5  # Hopper-2d's
    assert result["gamma"] == 0.99
    # no reset noise: every episode of a preference is the same one
    assert result["agreement"]["return"]["no_noise"] == 2 * len(grid)
    _assert_agrees(result)
    score = result["protocol"]
    assert score["protocol"] == "cmorl" and score["returns"] == "discounted_return"
    assert score["deviations"] == []
    ours = [row["discounted_return"] for row in result["prefs"]]
    assert score["mo_gymnasium"] == protocols.CMORL.score(ours)
    with open(os.path.join(protocol_run, "front.json")) as f:
        front = json.load(f)
    assert score["project"]["hv"] == pytest.approx(front["protocol"]["hv"])
    assert score["mo_gymnasium"]["hv"] == pytest.approx(front["protocol"]["hv"], rel=RELATIVE)


def test_conditioned_network_off_its_grid_is_evaluated_by_both(protocol_run):
    """A preference the front did not evaluate: the project evaluates its network there
    too, and the protocol's scores say the preferences are not its grid."""
    result = _evaluate(protocol_run, "--prefs", "0.333,0.667;0.5,0.5", "--episodes", "2")
    assert [row["pref"] for row in result["prefs"]] == [[0.333, 0.667], [0.5, 0.5]]
    _assert_agrees(result)
    assert result["protocol"]["deviations"][0].startswith("2 preferences")


def _refused(capsys, argv, message):
    assert cli.main(argv) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], captured.err
    assert captured.out == ""


def _copy(run, tmp_path, name, edit=None, drop=()):
    """A copy of `run` with its front's config edited and some files dropped."""
    copy = tmp_path / name
    shutil.copytree(run, copy)
    for file in drop:
        (copy / file).unlink()
    if edit is not None:
        front = json.loads((copy / "front.json").read_text())
        edit(front["config"])
        (copy / "front.json").write_text(json.dumps(front))
    return copy


def test_refusals_write_nothing(sweep_run, tmp_path, capsys):
    def to_bandit(config):
        config.update(env="concave_bandit", env_options={})

    def to_brax(config):
        config.update(env="walker2d", env_options={"physics": "brax"})

    cases = [
        ([str(tmp_path / "nothing")], "no run in"),
        ([str(_copy(sweep_run, tmp_path, "unfinished", drop=["front.json"]))], "not finished"),
        ([str(_copy(sweep_run, tmp_path, "bandit", edit=to_bandit))], "not one of MO-Gym"),
        ([str(_copy(sweep_run, tmp_path, "brax", edit=to_brax))], "not Gymnasium's v5"),
        ([sweep_run, "--prefs", "0.5,0.5"], "no policy at the preference"),
        ([sweep_run, "--prefs", "1,0,0"], "2 entries"),
        ([sweep_run, "--episodes", "0"], "--episodes must be at least 1"),
        ([sweep_run, "--project-episodes", "0"], "--project-episodes must be at least 1"),
    ]
    for run, message in cases:
        out = tmp_path / "out.json"
        _refused(capsys, [*run, "--in", "mo-gymnasium", "--out", str(out)], message)
        assert not out.exists()
    _refused(capsys, [sweep_run, "--in", "gymnasium"], "invalid choice")


def test_an_existing_result_is_refused_unless_overwrite(sweep_run, tmp_path, capsys):
    out = tmp_path / "result.json"
    out.write_text("kept")
    argv = [sweep_run, "--in", "mo-gymnasium", "--episodes", "1", "--out", str(out)]
    _refused(capsys, argv, "exists (--overwrite replaces it)")
    assert out.read_text() == "kept"
    assert cli.main([*argv, "--overwrite"]) == 0
    assert json.loads(out.read_text())["env"] == "hopper-2obj"


def test_without_mo_gymnasium_one_line_exit_2(sweep_run, tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "mo_gymnasium", None)  # `import mo_gymnasium` fails
    out = tmp_path / "out.json"
    _refused(capsys, [sweep_run, "--in", "mo-gymnasium", "--out", str(out)], "pip install")
    assert not out.exists()


def test_importing_the_package_needs_no_mo_gymnasium():
    code = (
        "import sys; sys.modules['mo_gymnasium'] = None; "
        "import wcac_jax.evaluate.cli, wcac_jax.evaluate.reference, wcac_jax.evaluate.numpy_policy"
    )
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)


def test_agreement_by_hand():
    """Two preferences of one objective, 4 episodes against the project's 2: se = s *
    sqrt(1/4 + 1/2)."""
    rows = [
        {"pref": [1.0], "return": [10.0], "return_std": [2.0], "project": {"return": [12.0]}},
        {"pref": [0.5], "return": [5.0], "return_std": [0.0], "project": {"return": [5.0]}},
    ]
    for row in rows:
        row["discounted_return"], row["discounted_return_std"] = row["return"], row["return_std"]
        row["project"]["discounted_return"] = row["project"]["return"]
    found = reference.agreement(rows, episodes=4, project_episodes=2)["return"]
    se = 2.0 * np.sqrt(0.75)
    assert found["largest_difference"] == {
        "pref": [1.0],
        "objective": 0,
        "difference": -2.0,
        "se": pytest.approx(se),
        "z": pytest.approx(-2.0 / se),
        "se_of_mean": pytest.approx(1.0),
    }
    assert found["max_abs_z"] == pytest.approx(2.0 / se)  # 1.15
    assert (found["beyond_2se"], found["beyond_3se"], found["n"], found["no_noise"]) == (
        0,
        0,
        1,
        1,
    )
