"""Presets and per-environment defaults on the command line, a tiny end-to-end sweep with
the practical preset, and the notebook finding that run on its own."""

import json
import os
import re
import shutil

import jax
import nbformat
import numpy as np
import pytest
from nbclient import NotebookClient

from wcac_jax import algos, envs, presets, sweep, utopia
from wcac_jax.algos import PaperConfig, PracticalConfig
from wcac_jax.sweep import cli

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _config(*args):
    return cli.config_from_args(cli.build_parser().parse_args(list(args)))


def test_every_environment_has_a_default_and_help_shows_it(capsys):
    for name in envs.names():
        assert name in presets.ENV_DEFAULTS
    with pytest.raises(SystemExit):
        cli.main(["--help"])
    table = capsys.readouterr().out.split("each --env's default")[1].split("\n", 1)[1]
    shown = {}  # environments sharing a default share a line: "a, b: preset, steps"
    entries = re.split(r"\n  (?=\S)", "\n" + table.rstrip())[1:]
    for entry in entries:
        names, text = " ".join(entry.split()).split(": ", 1)
        for name in names.split(", "):
            shown[name] = text
    assert set(shown) == set(envs.names())
    for name in envs.names():
        d = presets.ENV_DEFAULTS[name]
        assert shown[name].startswith(f"{d.preset}") and f"{d.steps_per_pref:,}" in shown[name]


def test_environment_defaults_without_flags():
    walker = _config("--env", "walker2d")
    assert walker.train == PracticalConfig().replace(num_iterations=walker.train.num_iterations)
    assert walker.steps_per_pref == 1_000_000
    assert len(walker.prefs) == presets.DEFAULT_N_PREFS  # evenly spaced
    np.testing.assert_allclose(walker.prefs[1], [0.875, 0.125])
    # the paper's own model in MuJoCo's C engine unless a flag says otherwise
    assert walker.env_options == {"physics": "gymnasium-v5", "engine": "mujoco"}
    mjx = _config("--env", "walker2d", "--engine", "mjx", "--physics", "brax")
    assert mjx.env_options == {"physics": "brax", "engine": "mjx"}
    assert _config("--env", "concave_bandit").env_options == {}
    bandit = _config("--env", "concave_bandit", "--n-prefs", "11")
    assert bandit.train == presets.BANDIT and len(bandit.prefs) == 11
    assert bandit.num_iterations == 600


def test_ant_and_halfcheetah_defaults_start_from_a_smaller_policy_noise():
    """The ant tasks' default is the practical preset with initial log-std -1 (their
    control cost under a unit Gaussian exceeds the healthy reward), and HalfCheetah's (its
    forward end finds the fast gait); the other MuJoCo tasks keep the practical preset as
    it is."""
    for name in ("ant", "ant-2obj", "halfcheetah"):
        c = _config("--env", name)
        assert c.train == PracticalConfig(log_std_init=-1.0).replace(
            num_iterations=c.train.num_iterations
        )
        assert c.steps_per_pref == 1_000_000 and c.env_options == {"engine": "mujoco"}
        assert _config("--env", name, "--log-std-init", "0").train.log_std_init == 0.0
    hopper = _config("--env", "hopper")
    assert hopper.train == PracticalConfig().replace(num_iterations=hopper.train.num_iterations)


def test_humanoid_default_trains_three_million_steps_per_preference():
    """The humanoid keeps the practical preset as it is, at 3M env steps per preference
    (at 1M neither its forward end nor PPO walks), and its note says why."""
    humanoid = _config("--env", "humanoid")
    assert humanoid.train == PracticalConfig().replace(num_iterations=humanoid.train.num_iterations)
    assert humanoid.steps_per_pref == 3_000_000 == presets.HUMANOID_STEPS
    assert humanoid.num_iterations == 1465  # ceil(3M / 2,048)
    note = presets.ENV_DEFAULTS["humanoid"].note
    assert note.startswith("the practical preset at 3M env steps per preference")
    assert note.endswith(presets.HUMANOID_WHY)


def test_walker2d_default_chooses_among_the_last_policies_when_they_fit(capsys):
    walker = _config("--env", "walker2d")
    assert (walker.select_last, walker.select_every) == (5, 20_480)
    # 10 iterations of 2,048 env steps apart: iterations 449, 459, ..., 489 of 489
    assert walker.candidate_iterations == (449, 459, 469, 479, 489)
    # the choice fits without a word; only the budget's rounding to whole iterations is said
    assert capsys.readouterr().err == (
        "note: 1,000,000 env steps per preference round up to 489 iterations of 2,048: "
        "training runs 1,001,472\n"
    )
    # a flag sets the choice; the other keeps the default's value
    assert _config("--select-last", "1").select_last == 1
    three = _config("--select-last", "3")
    assert (three.select_last, three.select_every) == (3, 20_480)
    assert _config("--select-every", "40960").candidate_iterations[0] == 409
    # the same configuration by name chooses too; another preset reports the final policy
    assert _config("--preset", "practical").select_last == 5
    assert _config("--preset", "paper", "--env", "walker2d").select_last == 1
    assert _config("--env", "concave_bandit").select_last == 1
    # 5 candidates 10 iterations apart need 41 iterations: 40 of 2,048 env steps report
    # the final policies, and say so; explicitly asked-for candidates that don't fit fail
    small = _config("--steps-per-pref", str(40 * 2048))
    assert (small.select_last, small.select_every) == (1, 0)
    assert "leave no room" in capsys.readouterr().err
    assert _config("--steps-per-pref", str(41 * 2048)).candidate_iterations[0] == 1
    with pytest.raises(sweep.SweepError, match="need more than 40 iterations"):
        _config("--steps-per-pref", str(40 * 2048), "--select-last", "5")
    _config("--steps-per-pref", str(40 * 2048), "--quiet")
    assert capsys.readouterr().err == ""


def test_paper_preset_gives_the_papers_recipe_and_preferences_on_any_env():
    for env in ("walker2d", "concave_bandit"):
        config = _config("--env", env, "--preset", "paper")
        assert config.train == PaperConfig() and config.prefs == presets.PAPER_PREFS
    assert len(_config("--preset", "paper", "--n-prefs", "3").prefs) == 3


def test_explicit_flags_override_the_preset():
    config = _config("--env", "concave_bandit", "--mu", "0.01", "--scalarization", "linear")
    assert config.train == presets.BANDIT.replace(mu=0.01, scalarization="linear")
    config = _config("--preset", "practical", "--utopia", "fixed", "--j-ub", "1,2")
    assert config.train == PracticalConfig(utopia="fixed", j_ub=(1.0, 2.0))
    assert _config("--utopia-margin", "0.02").train == PracticalConfig(utopia_margin=0.02)
    assert _config("--augment", "0.01").train == PracticalConfig(augment=0.01)
    # on the practical update a fixed point means a fixed utopia: --j-ub alone says so
    assert _config("--j-ub", "3,4").train == PracticalConfig(utopia="fixed", j_ub=(3.0, 4.0))
    assert _config("--preset", "paper", "--j-ub", "3,4").train == PaperConfig(j_ub=(3.0, 4.0))
    assert _config("--steps-per-pref", "5").steps_per_pref == 5


@pytest.mark.parametrize(
    "args,message",
    [
        (["--critic-steps", "3"], "--critic-steps does not apply to walker2d's default"),
        (["--preset", "paper", "--num-epochs", "3"], "--num-epochs does not apply to the paper"),
        (["--utopia", "guess"], "utopia must be one of fixed, estimated; got 'guess'"),
        (["--num-minibatches", "7"], "--num-minibatches 7 must divide"),
        (["--utopia-margin", "-0.1"], "--utopia-margin must be >= 0 and finite, got -0.1"),
        (["--augment", "-0.1"], "augment must be >= 0 and finite, got -0.1"),
        (["--preset", "paper", "--augment", "0.01"], "--augment does not apply to the paper"),
        # flags the configuration would silently ignore
        (["--j-ub", "3,4", "--utopia", "estimated"], "--utopia estimated ignores it"),
        (["--utopia", "fixed", "--utopia-margin", "0.2"], "a fixed one (--j-ub / --utopia"),
        (["--j-ub", "3,4", "--utopia-margin", "0.2"], "--utopia-margin applies to the est"),
    ],
)
def test_flags_that_do_not_fit_exit_2(args, message, tmp_path, capsys):
    out = tmp_path / "out"
    assert cli.main([*args, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and message in err, err
    assert not out.exists()


TINY_PRACTICAL = [
    *("--preset", "practical", "--env", "concave_bandit", "--n-prefs", "3"),
    *("--envs-per-pref", "8", "--rollout-steps", "8", "--num-minibatches", "2"),
    *("--num-epochs", "2", "--steps-per-pref", "640", "--eval-episodes", "2", "--quiet"),
]


@pytest.fixture(scope="module")
def practical_run(tmp_path_factory):
    base = tmp_path_factory.mktemp("repo")
    out = str(base / "runs" / "20260101-000000")
    assert cli.main([*TINY_PRACTICAL, "--chunks", "3", "--out", out]) == 0
    return base, out


def test_tiny_practical_sweep_end_to_end(practical_run, tmp_path):
    _, out = practical_run
    with open(os.path.join(out, "front.json")) as f:
        front = json.load(f)
    assert front["config"]["train"]["kind"] == "practical"
    assert len(front["prefs"]) == 3 and front["env_steps_per_pref"] == 640
    # the shared utopia: one estimate for all preferences, above every Jhat
    with np.load(os.path.join(out, "curves.npz")) as curves:
        z, j_hat = curves["train/utopia"], curves["train/j_hat"]
    np.testing.assert_array_equal(z, np.broadcast_to(z[:1], z.shape))
    assert np.all(z > j_hat)
    np.testing.assert_allclose(front["j_ub"], z[0, -1])  # front.json names the point used
    # chunking does not change the numbers
    config = sweep.SweepConfig.from_dict(front["config"])
    assert algos.kind(config.train) == "practical"
    one = sweep.run_sweep(config, str(tmp_path / "one"), chunks=1, progress=False)
    assert [r["return"] for r in one["prefs"]] == [r["return"] for r in front["prefs"]]
    # the checkpoint restores, and replays one iteration under the named preference axis
    run = sweep.load_sweep(out)
    assert run.config == config
    state, metrics = jax.jit(jax.vmap(run.trainer.step, axis_name=utopia.PREF_AXIS))(
        run.state, np.asarray(run.config.prefs, np.float32)
    )
    np.testing.assert_array_equal(state.iteration, [run.config.num_iterations + 1] * 3)
    assert all(np.isfinite(np.asarray(v)).all() for v in metrics.values())


def test_notebook_shows_the_newest_run_without_edits(practical_run):
    base, _ = practical_run
    notebooks = base / "notebooks"
    notebooks.mkdir(exist_ok=True)
    shutil.copy(os.path.join(ROOT, "notebooks", "pareto_front.ipynb"), notebooks)
    nb = nbformat.read(str(notebooks / "pareto_front.ipynb"), as_version=4)
    NotebookClient(
        nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(notebooks)}}
    ).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.output_type == "error"]
    assert any("20260101-000000" in o.get("text", "") for o in outputs)
    assert any("image/png" in o.get("data", {}) for o in outputs)


def test_an_environment_without_defaults_gets_the_practical_update_and_says_so():
    d = presets.env_defaults("an_environment_without_an_entry")
    assert d.fallback and d.preset == "practical" and d.config == PracticalConfig()
    assert "no tuned defaults" in d.note and "practical" in d.note
    assert not any(presets.env_defaults(name).fallback for name in envs.names())


def test_config_flags_come_from_every_field_with_its_doc_and_true_defaults(capsys):
    flags = {field: dest for dest, field, _ in cli.CONFIG_FLAGS}
    for algo in algos.ALGOS.values():
        for name in algo.config.field_docs():
            if name != "num_iterations":  # --steps-per-pref sets it
                assert name in flags
    assert flags["num_envs"] == "envs_per_pref"
    with pytest.raises(SystemExit):
        cli.main(["--help-all"])
    out = " ".join(capsys.readouterr().out.split())
    assert "discount (preset default: paper 0.99, practical 0.99, conditioned 0.99)" in out
    # Walker2d's command-line defaults: Gymnasium's v5 model on MuJoCo's C engine
    assert "gymnasium-v5 or brax (gymnasium-v5)" in out and "(for accelerators) (mujoco)" in out
    # a flag of the other update's field is refused, naming it
    with pytest.raises(sweep.SweepError, match="--clip-eps does not apply"):
        _config("--preset", "paper", "--clip-eps", "0.1")
    assert _config("--preset", "paper", "--no-critic-warm-start").train == PaperConfig()
