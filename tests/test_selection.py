"""`wcac_jax.sweep.selection`: the weighted-Chebyshev choice among each preference's last
policies, by hand; and in a tiny bandit sweep: training untouched, the choice the
recorded regrets give, chunking and resume invariant, `load_sweep` returning it."""

import json
import os
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from sweep_args import TINY_BANDIT

from wcac_jax import scalarize, sweep
from wcac_jax.sweep import cli, selection


def test_candidate_iterations():
    assert selection.candidate_iterations(10, 3, 2) == (6, 8, 10)
    assert selection.candidate_iterations(10, 1, 0) == (10,)
    assert selection.candidate_iterations(7, 4, 2) == (1, 3, 5, 7)
    with pytest.raises(ValueError, match="select_last must be >= 1, got 0"):
        selection.candidate_iterations(10, 0, 1)
    with pytest.raises(ValueError, match="select_every must be >= 1"):
        selection.candidate_iterations(10, 2, 0)
    with pytest.raises(ValueError, match="the sweep has 7"):
        selection.candidate_iterations(7, 5, 2)  # would start at iteration -1


def test_regret_by_hand():
    # p = (0.25, 0.75), z = (10, 4): J = (6, 3) -> max(0.25 * 4, 0.75 * 1) = 1.0
    #                                J = (9, 1) -> max(0.25 * 1, 0.75 * 3) = 2.25
    returns = jnp.array([[6.0, 3.0], [9.0, 1.0]])
    # the regret `selection.choose` takes from `scalarize.wc`
    regret = jax.vmap(scalarize.wc, in_axes=(0, None, None))
    got = regret(returns, jnp.array([0.25, 0.75]), jnp.array([10.0, 4.0]))
    np.testing.assert_allclose(got, [1.0, 2.25])


def test_utopia_point_by_hand():
    # objective 0: max 9, min 1 -> 9 + 0.1 * 8 = 9.8
    # objective 1: max 3, min 2.5 -> spread 0.5 < min_spread 1 -> 3 + 0.1 * 1 = 3.1
    returns = jnp.array([[[1.0, 3.0], [9.0, 2.5]], [[4.0, 2.5], [5.0, 3.0]]])  # [K, P, m]
    np.testing.assert_allclose(selection.utopia_point(returns), [9.8, 3.1], rtol=1e-6)
    np.testing.assert_allclose(
        selection.utopia_point(returns, margin=0.5, min_spread=0.0), [13.0, 3.25], rtol=1e-6
    )


def test_choose_by_hand():
    # K = 3 candidates of P = 3 preferences, m = 2, margin 0 and spread floor 0: z = the
    # componentwise max over all = (10, 10)
    returns = jnp.array(
        [
            [[10.0, 0.0], [5.0, 5.0], [0.0, 10.0]],  # candidate 0
            [[8.0, 2.0], [6.0, 6.0], [0.0, 9.0]],  # candidate 1
            [[10.0, 1.0], [6.0, 6.0], [1.0, 8.0]],  # candidate 2
        ]
    )
    prefs = jnp.array([[1.0, 0.0], [0.5, 0.5], [0.0, 1.0]])
    index, z, regrets = selection.choose(returns, prefs, margin=0.0, min_spread=0.0)
    np.testing.assert_allclose(z, [10.0, 10.0])
    # p = (1, 0): regrets 10 - J_0 = 0, 2, 0 -> candidates 0 and 2 tie: the later, 2
    # p = (.5, .5): max(.5 (10 - J_0), .5 (10 - J_1)) = 2.5, 2, 2 -> tie 1, 2: 2
    # p = (0, 1): 10 - J_1 = 0, 1, 2 -> 0
    np.testing.assert_allclose(regrets, [[0, 2.5, 0], [2, 2, 1], [0, 2, 2]])
    np.testing.assert_array_equal(index, [2, 2, 0])
    # take: leaf [K, P, ...] -> [P, ...], row p from candidate index[p]
    stacked = {"w": np.arange(3 * 3 * 2).reshape(3, 3, 2)}
    np.testing.assert_array_equal(
        selection.take(stacked, index)["w"], [stacked["w"][2, 0], stacked["w"][2, 1], [4, 5]]
    )


def test_bad_selection_config_is_a_sweep_error():
    config = cli.config_from_args(cli.build_parser().parse_args([*TINY_BANDIT, "--n-prefs", "2"]))
    with pytest.raises(sweep.SweepError, match="select_last 2 needs select_every >= 1"):
        sweep.SweepConfig(prefs=config.prefs, env=config.env, train=config.train, select_last=2)
    with pytest.raises(sweep.SweepError, match="select_every must be a non-negative integer"):
        sweep.SweepConfig(prefs=config.prefs, select_last=2, select_every=-5)
    with pytest.raises(sweep.SweepError, match="select_last must be a positive integer"):
        sweep.SweepConfig(prefs=config.prefs, select_last=0)


# 1200 env steps of N (K + L) = 8 (2 + 4) = 48 per iteration: 25 iterations; candidates
# 160 env steps apart, rounded up to 4 iterations: 17, 21, 25
SELECT = ["--select-last", "3", "--select-every", "160"]


def _config(*extra):
    # an actor step large enough that the middle preferences' policies get worse in the
    # last iterations (their earlier ones are chosen; at the tiny default every final
    # policy is the best)
    args = cli.build_parser().parse_args(
        [*TINY_BANDIT, "--n-prefs", "4", "--actor-lr", "0.05", *extra]
    )
    return cli.config_from_args(args)


@pytest.fixture(scope="module")
def chosen_run(tmp_path_factory):
    """The same tiny sweep without and with the choice (3 chunks)."""
    root = tmp_path_factory.mktemp("selection")
    plain = sweep.run_sweep(_config(), str(root / "plain"), chunks=3, progress=False)
    out = str(root / "chosen")
    front = sweep.run_sweep(_config(*SELECT), out, chunks=3, progress=False)
    return plain, front, out


def test_the_choice_is_the_least_recorded_regret(chosen_run):
    plain, front, out = chosen_run
    sel = front["selection"]
    assert sel["candidate_iterations"] == [17, 21, 25]
    returns = np.array(sel["candidate_return"])  # [K, P, m]
    prefs = np.array([row["pref"] for row in front["prefs"]])
    z = returns.reshape(-1, 2).max(0) + 0.1 * np.maximum(np.ptp(returns.reshape(-1, 2), 0), 1.0)
    np.testing.assert_allclose(sel["utopia"], z, rtol=1e-6)
    regrets = np.max(prefs[None] * (z - returns), axis=-1)
    np.testing.assert_allclose(sel["regret"], regrets, rtol=1e-5, atol=1e-6)
    for p, it in enumerate(sel["chosen_iteration"]):
        k = sel["candidate_iterations"].index(it)
        assert regrets[k, p] == pytest.approx(regrets[:, p].min(), abs=1e-6)
        assert not np.any(regrets[k + 1 :, p] <= regrets[k, p] - 1e-12), p
    # 2 episodes of length 1 per candidate
    assert sel["env_steps_per_pref"] == [3 * 2 * 1] * 4
    # training is untouched; a preference whose final policy was chosen is evaluated as
    # without the choice (same keys), one that chose another policy as that policy
    with np.load(os.path.join(out, "curves.npz")) as a:
        curves = {k: a[k] for k in a.files}
    assert front["selection_utopia"] == sel["utopia"]
    assert front["chosen_iteration"] == sel["chosen_iteration"]
    for p, (row, base) in enumerate(zip(front["prefs"], plain["prefs"], strict=True)):
        # each row's training metrics are its chosen iteration's, beside its returns
        t = sel["chosen_iteration"][p]
        assert row["iteration"] == t and base["iteration"] == 25
        assert row["lambda"] == curves["train/weights"][p, t - 1].tolist()
        assert row["j_hat"] == curves["train/j_hat"][p, t - 1].tolist()
        assert row["g_mu"] == float(curves["train/g_mu"][p, t - 1])
        assert row["train_episode_return"] == curves["train/episode_return"][p, t - 1].tolist()
        if t == 25:
            assert row["j_hat"] == base["j_hat"] and row["lambda"] == base["lambda"]
        else:
            assert row["j_hat"] != base["j_hat"], p  # not the final iteration's
        assert sel["final_return"][p] == base["return"], p  # the front without the choice
        assert sel["final_length"][p] == base["episode_length"], p
        if sel["chosen_iteration"][p] == 25:
            assert row["return"] == base["return"], p
    assert curves["train/weights"].shape[1] == 25
    # the choice is not the final policy everywhere (else this test checks nothing)
    assert sel["chosen_iteration"] != [25] * 4, sel["chosen_iteration"]


def test_the_choice_is_the_same_however_chunked_or_resumed(chosen_run, tmp_path):
    _, front, _ = chosen_run
    one = sweep.run_sweep(_config(*SELECT), None, chunks=1, progress=False)
    out = str(tmp_path / "resumed")
    first = sweep.run_sweep(_config(*SELECT), out, chunks=7, progress=False, stop_after_chunks=6)
    assert first["interrupted"] and 17 <= first["iterations_done"] < 25  # mid-candidates
    with open(os.path.join(out, "timing.json")) as f:
        part = json.load(f)  # the first part's clocks, as its last checkpoint left them
    assert part["iteration"] == first["iterations_done"] and part["parts"] == 1
    assert part["env_steps_timed"] == first["iterations_done"] * 48 * 4 and part["train_s"] > 0
    resumed = sweep.run_sweep(_config(*SELECT), out, chunks=7, resume=True, progress=False)
    for other in (one, resumed):
        assert other["selection"] == front["selection"]
        assert [r["return"] for r in other["prefs"]] == [r["return"] for r in front["prefs"]]
    # the whole run's clocks: both parts, every env step timed
    assert (resumed["parts"], resumed["timed_from_iteration"]) == (2, 0)
    assert resumed["train_s"] > part["train_s"] and resumed["wall_s"] > part["wall_s"]
    assert resumed["compile_s"] > part["compile_s"]
    steps = resumed["env_steps_total"]
    assert resumed["env_steps_per_s"] * resumed["train_s"] == pytest.approx(steps, rel=1e-9)
    assert (one["parts"], one["timed_from_iteration"]) == (1, 0)


def test_load_sweep_returns_the_chosen_policies(chosen_run):
    _, front, out = chosen_run
    run = sweep.load_sweep(out)
    np.testing.assert_array_equal(run.state.iteration, [25] * 4)
    np.testing.assert_array_equal(run.chosen.iteration, front["selection"]["chosen_iteration"])
    # the chosen policies, evaluated as the sweep did, give front.json's returns
    from wcac_jax.algos import make_evaluate

    evaluate = make_evaluate(run.config.train_config(), run.env, run.config.eval_episodes)
    keys = jax.vmap(lambda i: jax.random.fold_in(jax.random.key(run.config.seed), i))(jnp.arange(4))
    keys = jax.vmap(lambda k: jax.random.fold_in(k, 1 << 30))(keys)
    got = jax.jit(jax.vmap(evaluate))(run.chosen, keys)["eval/return"]
    np.testing.assert_allclose(got, [r["return"] for r in front["prefs"]], rtol=1e-6)
    with open(os.path.join(out, "config.json")) as f:
        assert json.load(f)["select_last"] == 3


def test_the_criterion_is_the_runs_own():
    paper = _config().train
    assert selection.criterion(paper) == selection.Criterion("wc", 0.1, 1.0, paper.mu)
    practical = cli.config_from_args(
        cli.build_parser().parse_args(
            ["--env", "concave_bandit", "--preset", "practical", "--utopia-margin", "0.02"]
            + ["--utopia-min-spread", "3", "--scalarization", "linear", "--quiet"]
        )
    ).train
    assert selection.criterion(practical) == selection.Criterion("linear", 0.02, 3.0, practical.mu)
    assert selection.criterion(practical.replace(scalarization="smooth_wc")).score == "wc"
    # linear: the candidate of the largest p . J, whatever the utopia point
    returns = jnp.array([[[4.0, 0.0]], [[1.0, 2.5]], [[2.0, 2.0]]])  # [K, P, m]
    index, _, scores = selection.choose(returns, jnp.array([[0.5, 0.5]]), score="linear")
    np.testing.assert_allclose(scores[:, 0], [-2.0, -1.75, -2.0])
    assert int(index[0]) == 2  # a tie of candidates 0 and 2: the later
    index, _, _ = selection.choose(returns, jnp.array([[0.5, 0.5]]))  # wc: (2, 2) closest
    assert int(index[0]) == 2


# the practical update on the bandit: 640 env steps per iteration, 8 iterations
PRACTICAL = ["--env", "concave_bandit", "--preset", "practical", "--envs-per-pref", "8"]
PRACTICAL += ["--steps-per-pref", "5120", "--eval-episodes", "2", "--n-prefs", "5", "--quiet"]


def test_a_linear_run_chooses_by_its_linear_score_and_its_own_utopia(tmp_path):
    args = [*PRACTICAL, "--scalarization", "linear", "--utopia-margin", "0.5"]
    args += ["--utopia-min-spread", "2", "--select-last", "4", "--select-every", "640"]
    config = cli.config_from_args(cli.build_parser().parse_args(args))
    front = sweep.run_sweep(config, str(tmp_path / "run"), chunks=2, progress=False)
    sel = front["selection"]
    assert (sel["score"], sel["margin"], sel["min_spread"]) == ("linear", 0.5, 2.0)
    returns = np.array(sel["candidate_return"])  # [K, P, m]
    flat = returns.reshape(-1, 2)
    z = flat.max(0) + 0.5 * np.maximum(np.ptp(flat, 0), 2.0)
    np.testing.assert_allclose(sel["utopia"], z, rtol=1e-6)
    assert front["selection_utopia"] == sel["utopia"]
    prefs = np.array([row["pref"] for row in front["prefs"]])
    score = -np.sum(prefs[None] * returns, axis=-1)  # [K, P]
    np.testing.assert_allclose(sel["regret"], score, rtol=1e-5, atol=1e-6)
    for p, it in enumerate(sel["chosen_iteration"]):
        k = sel["candidate_iterations"].index(it)
        assert score[k, p] <= score[:, p].min() + 1e-6
    # the weighted-Chebyshev choice would differ on this run (else this checks nothing)
    wc = np.max(prefs[None] * (z - returns), axis=-1)
    by_wc = [len(wc) - 1 - int(np.argmin(wc[::-1, p])) for p in range(len(prefs))]
    chosen = [sel["candidate_iterations"].index(it) for it in sel["chosen_iteration"]]
    assert chosen != by_wc, (chosen, by_wc)


def test_load_sweep_of_a_padded_two_device_run_with_a_choice(tmp_path):
    """3 preferences on 2 devices run 4 rows (the last repeated): `load_sweep` chooses
    over the rows the sweep ran, as it did, and returns the 3 real ones."""
    out = str(tmp_path / "run")
    proc = subprocess.run(
        [sys.executable, "-m", "wcac_jax.sweep", *TINY_BANDIT, "--n-prefs", "3"]
        + ["--actor-lr", "0.05", *SELECT, "--quiet", "--out", out],
        capture_output=True,
        text=True,
        env={**os.environ, "XLA_FLAGS": "--xla_force_host_platform_device_count=2"},
    )
    assert proc.returncode == 0, proc.stderr
    with open(os.path.join(out, "front.json")) as f:
        front = json.load(f)
    assert len(front["devices"]) == 2 and len(front["prefs"]) == 3
    run = sweep.load_sweep(out)
    np.testing.assert_array_equal(run.state.iteration, [25] * 3)
    np.testing.assert_array_equal(run.chosen.iteration, front["chosen_iteration"])
    assert jax.tree.leaves(run.chosen)[0].shape[0] == 3
    from wcac_jax.algos import make_evaluate

    evaluate = make_evaluate(run.config.train_config(), run.env, run.config.eval_episodes)
    keys = jax.vmap(lambda i: jax.random.fold_in(jax.random.key(run.config.seed), i))(jnp.arange(3))
    keys = jax.vmap(lambda k: jax.random.fold_in(k, 1 << 30))(keys)
    got = jax.jit(jax.vmap(evaluate))(run.chosen, keys)["eval/return"]
    np.testing.assert_allclose(got, [r["return"] for r in front["prefs"]], rtol=1e-5)
