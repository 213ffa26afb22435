"""The field's benchmark protocols (`wcac_jax.protocols`): the published grids, the scores
on hand-computed fronts, the budgets of every task's run, the deviations a run records,
and `--protocol` end to end on a toy protocol over the concave bandit."""

import json

import numpy as np
import pytest

from wcac_jax import protocols
from wcac_jax.algos import ConditionedConfig
from wcac_jax.sweep import cli, presets
from wcac_jax.sweep.protocol import protocol_sweep


def test_weight_grids_are_the_published_codes():
    # np.arange(0, 1 + step, step) per objective, kept where the float sum is exactly 1:
    # every point for 2 objectives; for 3, C-MORL's step-0.1 grid keeps 62 of the
    # lattice's 66 points and COLA's step-0.05 grid 217 of 231
    assert len(protocols.weight_grid(2, 0.01)) == 101
    assert len(protocols.weight_grid(2, 0.005)) == 201
    three = protocols.weight_grid(3, 0.1)
    assert len(three) == 62
    assert len(protocols.weight_grid(3, 0.05)) == 217
    assert np.all(three.sum(axis=1) == 1.0)
    # every kept point is on the lattice of step 0.1
    assert np.allclose(np.round(three * 10), three * 10, atol=1e-9)
    # the four dropped: arange's 0.3 is 0.30000000000000004 and its 0.6
    # 0.6000000000000001, so 0.3 + 0.6 + 0.1 = 1.0000000000000002 (and likewise with 0.2
    # and 0.7 = 0.7000000000000001), in any order with 0.1 last
    for dropped in ([0.2, 0.7, 0.1], [0.3, 0.6, 0.1], [0.6, 0.3, 0.1], [0.7, 0.2, 0.1]):
        assert not np.any(np.all(np.isclose(three, dropped), axis=1))
    assert np.any(np.all(np.isclose(three, [0.1, 0.3, 0.6]), axis=1))


def test_cmorl_score_by_hand():
    # reference (-100, -100): (0, 0) dominates a 100 x 100 box, (100, -50) a 200 x 50 one,
    # overlapping on 100 x 50: HV = 1e4 + 1e4 - 5e3 = 1.5e4. EU over w = (a, 1 - a),
    # a = k/100: max(0, 150 a - 50), positive for k >= 34:
    # (1.5 * (34 + ... + 100) - 50 * 67) / 101 = (1.5 * 4489 - 3350) / 101 = 33.5
    score = protocols.CMORL.score([[0.0, 0.0], [100.0, -50.0]])
    assert score["hv"] == pytest.approx(1.5e4)
    assert score["eu"] == pytest.approx(33.5)
    assert score["nondominated"] == 2 and score["kept"] == 2
    # a point that does not dominate the reference adds nothing
    assert protocols.CMORL.score([[0.0, 0.0], [500.0, -150.0]])["hv"] == pytest.approx(1e4)


def test_pgmorl_score_drops_negative_points():
    # (10, -1) has a negative objective and is dropped; (5, 5) against the origin: 25
    score = protocols.PGMORL.score([[10.0, -1.0], [5.0, 5.0]])
    assert score["hv"] == pytest.approx(25.0)
    assert score["kept"] == 1
    # EU over COLA's 201 preferences of (5, 5) alone: 5 at every preference
    assert score["eu"] == pytest.approx(5.0)
    assert protocols.PGMORL.score([[10.0, -1.0]]) == {
        "hv": 0.0,
        "eu": 0.0,
        "nondominated": 0,
        "kept": 0,
    }


@pytest.mark.parametrize(
    "protocol,task",
    [(p.name, t) for p in protocols.PROTOCOLS.values() for t in p.tasks],
    ids=lambda x: getattr(x, "env", x),
)
def test_every_tasks_run_trains_the_protocols_budget_in_whole_iterations(protocol, task):
    spec = protocols.get(protocol)
    config = protocol_sweep(task.env, protocol)
    budget = spec.budget(task.num_objectives)
    per = config.train.env_steps_per_iteration
    trained = config.num_iterations * per
    assert budget - per < trained <= budget
    assert config.eval_episodes == task.eval_episodes
    assert config.env_options["episode_length"] == task.episode_length
    assert len(config.prefs) == len(spec.eval_prefs(task.num_objectives))
    # every preset trains on one preference per environment for the whole run
    assert config.train.pref_draw == "environment"


# how a protocol preset's note says each field it changes from the conditioned defaults
_SAID = {
    "num_epochs": "{:g} epochs",
    "num_minibatches": "{:g} minibatches",
    "log_std_init": "initial log-std {:g}",
    "pref_alpha": "Dirichlet({:g})",
    "mu": "mu {:g}",
    "pref_draw": "one preference per {}",
}


@pytest.mark.parametrize(
    "protocol,env", [(p.name, t.env) for p in protocols.PROTOCOLS.values() for t in p.tasks]
)
def test_every_protocol_presets_note_says_what_it_changes(protocol, env):
    """A task's preset note names each field its configuration changes from the
    conditioned update's defaults, with the value, and its choice among the last
    policies; a task without a preset of its own (the humanoids) trains the defaults but
    for the draw."""
    preset = presets.protocol_preset(protocol, env)
    defaults = ConditionedConfig()
    changed = {
        name: getattr(preset.config, name)
        for name in defaults.field_docs()
        if getattr(preset.config, name) != getattr(defaults, name)
    }
    assert set(changed) <= set(_SAID), changed
    for name, value in changed.items():
        assert _SAID[name].format(value) in preset.note, (name, value, preset.note)
    best_of = f"best of the last {preset.selection[0]} policies"
    assert (best_of in preset.note) == (preset.selection != (1, 0)), preset.note
    if (protocol, env) not in presets.PROTOCOL_PRESETS:
        assert changed == {"pref_draw": "environment"}


def test_published_budgets_and_episodes():
    assert protocols.CMORL.budget(2) == 1_500_000 and protocols.CMORL.budget(3) == 2_000_000
    assert protocols.PGMORL.budget(2) == protocols.PGMORL.budget(3) == 3_000_000
    assert protocols.CMORL.task("hopper-2obj").eval_episodes == 5
    assert {t.eval_episodes for t in protocols.CMORL.tasks if t.env != "hopper-2obj"} == {10}
    assert protocols.PGMORL.task("humanoid-pgmorl").episode_length == 1000
    with pytest.raises(ValueError, match="not a task of the cmorl protocol"):
        protocols.CMORL.task("walker2d-pgmorl")
    with pytest.raises(ValueError, match="unknown protocol 'nope'"):
        protocols.get("nope")


def _fake_front(**changes) -> dict:
    prefs = protocols.CMORL.eval_prefs(2)
    front = {
        "config": {
            "protocol": "cmorl",
            "env": "hopper-2obj",
            "eval_episodes": 5,
            "env_options": {"episode_length": 500},
            "train": {"num_iterations": 183},
        },
        "prefs": [
            {"pref": p.tolist(), "discounted_return": [100 * p[0], 100 * p[1]], "return": [0, 0]}
            for p in prefs
        ],
        "env_steps_total": 183 * 8192,
        "eval_gamma": 0.99,
        "conditioned": {"eval_env_steps": 101 * 5 * 500},
    }
    for key, value in changes.items():
        if key in front["config"]:
            front["config"][key] = value
        else:
            front[key] = value
    return front


def test_front_scores_meets_or_names_each_deviation():
    score = protocols.front_scores(_fake_front())
    assert score["deviations"] == []
    assert score["env_steps_trained"] == 1_499_136 and score["budget"] == 1_500_000
    # the points (100 a, 100 (1 - a)) against (-100, -100)
    assert score["hv"] == pytest.approx(
        protocols.CMORL.score([[100 * a, 100 - 100 * a] for a in np.arange(0, 1.001, 0.01)])["hv"]
    )
    cases = {
        "env_steps_total": (184 * 8192, "budget is 1,500,000"),
        "eval_episodes": (8, "8 evaluation episodes"),
        "eval_gamma": (0.995, "discounted at 0.995"),
        "env_options": ({"episode_length": 1000}, "episode length 1000"),
    }
    for key, (value, text) in cases.items():
        if key == "env_steps_total":
            front = _fake_front(env_steps_total=value)
            front["config"]["train"]["num_iterations"] = 184
        else:
            front = _fake_front(**{key: value})
        deviations = protocols.front_scores(front)["deviations"]
        assert len(deviations) == 1 and text in deviations[0], (key, deviations)
    front = _fake_front()
    front["prefs"] = front["prefs"][::2]
    assert "51 preferences" in protocols.front_scores(front)["deviations"][0]


# ----------------------------------------------------------------------------- end to end

TOY = protocols.Protocol(
    name="toy",
    title="a toy protocol on the concave bandit",
    tasks=(protocols.Task("concave_bandit", "Bandit-2d", "concave_bandit", 2, 2, 1),),
    gamma=0.99,
    ref_value=-1.0,
    drop_negative=False,
    budget_by_m={2: 4096},
    eu_step_by_m={2: 0.1},
    pref_step_by_m={2: 0.25},
)
TINY = ["--envs-per-pref", "8", "--rollout-steps", "8", "--num-minibatches", "4"]
TINY += ["--width", "16", "--depth", "1", "--quiet"]


@pytest.fixture
def toy_protocol(monkeypatch):
    monkeypatch.setitem(protocols.PROTOCOLS, "toy", TOY)


def test_protocol_run_end_to_end(toy_protocol, tmp_path, capsys):
    out = tmp_path / "run"
    argv = ["--env", "concave_bandit", "--protocol", "toy", "--out", str(out), *TINY]
    assert cli.main(argv) == 0
    front = json.loads((out / "front.json").read_text())
    score = front["protocol"]
    assert score["deviations"] == []
    # 4096 env steps of 64 per iteration: 64 iterations, exactly the budget
    assert score["env_steps_trained"] == 4096 == front["env_steps_total"]
    assert score["eval_prefs"] == 5 and front["config"]["eval_episodes"] == 2
    assert front["eval_gamma"] == 0.99
    # a task without a preset of its own trains the defaults, one preference per environment
    assert front["conditioned"]["preferences"] == "drawn per environment"
    returns = [row["discounted_return"] for row in front["prefs"]]
    assert score["hv"] == pytest.approx(TOY.score(returns)["hv"])
    # a finished training whose front was not written: `--resume` alone evaluates it at
    # the protocol's preferences (config.json records the training's one row), the same
    # front again
    for name in ("front.json", "front.csv", "front.png"):
        (out / name).unlink()
    assert cli.main(["--out", str(out), "--resume", "--quiet"]) == 0
    again = json.loads((out / "front.json").read_text())
    assert again["protocol"]["deviations"] == [] and again["protocol"]["eval_prefs"] == 5
    assert again["prefs"] == front["prefs"]


@pytest.mark.parametrize(
    "extra,message",
    [
        (["--total-steps", "9000"], "add --off-budget"),
        (["--prefs", "1,0;0,1"], "--prefs does not apply to --protocol"),
        (["--eval-episodes", "3"], "--eval-episodes does not apply to --protocol"),
        (["--env", "walker2d"], "not a task of the toy protocol"),
    ],
)
def test_protocol_refusals_exit_2(toy_protocol, extra, message, tmp_path, capsys):
    argv = ["--env", "concave_bandit", "--protocol", "toy", "--out", str(tmp_path / "r")]
    assert cli.main([*argv, *TINY, *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
    assert not (tmp_path / "r").exists()


def test_off_budget_needs_a_protocol(tmp_path, capsys):
    assert cli.main(["--env", "concave_bandit", "--off-budget", "--out", str(tmp_path)]) == 2
    assert "--off-budget needs --protocol" in capsys.readouterr().err


def test_protocol_run_chooses_among_the_last_policies(toy_protocol, tmp_path):
    from wcac_jax.algos import ConditionedConfig
    from wcac_jax.sweep import run_conditioned
    from wcac_jax.sweep.protocol import protocol_sweep

    train = ConditionedConfig(
        num_envs=8, rollout_steps=8, num_minibatches=4, width=16, depth=1
    )  # 64 env steps per iteration: candidates at iterations 48 and 64
    config = protocol_sweep("concave_bandit", "toy", 0, train, selection=(2, 1024))
    front = run_conditioned(config, str(tmp_path / "run"), chunks=2)
    record = front["selection"]
    assert record["candidate_iterations"] == [48, 64]
    returns = np.asarray(record["candidate_return"])  # [K, P, m], discounted at 0.99
    assert returns.shape == (2, 5, 2) and record["returns"] == "discounted_return"
    # each preference's choice is its candidate of least max_i p_i (z_i - J_i)
    z = np.asarray(record["utopia"])
    prefs = np.asarray([row["pref"] for row in front["prefs"]])
    regret = np.max(prefs[None] * (z - returns), axis=-1)  # [K, P]
    best = [48 if regret[0, p] < regret[1, p] else 64 for p in range(5)]
    assert record["chosen_iteration"] == best
    # the candidates' evaluation is counted: 2 candidates x 5 preferences x 2 episodes of 1
    assert record["env_steps"] == 20
    assert front["conditioned"]["eval_env_steps"] == 20 + 10
    score = front["protocol"]
    assert score["deviations"] == []
    assert score["final_network"]["hv"] == pytest.approx(TOY.score(returns[-1])["hv"])
