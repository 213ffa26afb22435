"""`wcac_jax.selection`: the weighted-Chebyshev choice among each preference's last
policies, by hand; and in a tiny bandit sweep: training untouched, the choice the
recorded regrets give, chunking and resume invariant, `load_sweep` returning it."""

import json
import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from sweep_args import TINY_BANDIT

from wcac_jax import cli, scalarize, selection, sweep


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
    for p, (row, base) in enumerate(zip(front["prefs"], plain["prefs"], strict=True)):
        assert row["j_hat"] == base["j_hat"] and row["lambda"] == base["lambda"]
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
    resumed = sweep.run_sweep(_config(*SELECT), out, chunks=7, resume=True, progress=False)
    for other in (one, resumed):
        assert other["selection"] == front["selection"]
        assert [r["return"] for r in other["prefs"]] == [r["return"] for r in front["prefs"]]


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
