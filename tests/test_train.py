"""The whole program on the concave bandit: learning, one trace, chunking, metrics.

Each compiled program is built once per session (module fixtures)."""

import functools
import math

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from wcac_jax import envs
from wcac_jax.config import TrainConfig
from wcac_jax.envs import concave_bandit as cb
from wcac_jax.train import make_evaluate, make_train, make_trainer

PREFS = jnp.array([[0.8, 0.2], [0.5, 0.5], [0.2, 0.8]])
# A fixed small policy noise: with a learned std the expected-return front of stochastic
# policies is the convex hull of the bandit's front, not the front itself.
BANDIT = TrainConfig(
    num_envs=32,
    critic_steps=2,
    rollout_steps=4,
    num_iterations=600,
    mu=0.002,
    network="mlp",
    width=32,
    depth=1,
    actor_lr=0.1,
    critic_lr=0.1,
    actor_optimizer="normalized_harmonic",
    log_std_init=math.log(0.05),
    learn_log_std=False,
    normalize_obs=False,
)


def _learned_theta(config, env, states):
    trainer = make_trainer(config, env)
    action = jax.vmap(lambda s: trainer.mean_action(s, jnp.ones((1,))))(states)
    return np.asarray(cb.action_to_theta(action[:, 0]))


@pytest.fixture(scope="module")
def env():
    return envs.make("concave_bandit")


@pytest.fixture(scope="module")
def smooth_run(env):
    train = chex.assert_max_traces(make_train(BANDIT, env), n=1)
    sweep = jax.jit(jax.vmap(train))
    keys = jax.random.split(jax.random.key(0), len(PREFS))
    out = sweep(keys, PREFS)
    # a second call with other preferences must reuse the compiled program (no retrace)
    sweep(keys, PREFS[::-1])
    return out


def test_smooth_wc_reaches_the_weighted_chebyshev_optimum(env, smooth_run):
    states, _ = smooth_run
    theta = _learned_theta(BANDIT, env, states)
    target = np.asarray(jax.vmap(cb.wc_optimum, (0, None))(PREFS, cb.DEFAULT_J_UB))
    np.testing.assert_allclose(theta, target, atol=0.05)
    assert len(set(np.round(theta, 2))) == 3


def test_linear_ends_at_the_ends_of_the_front(env):
    config = BANDIT.replace(scalarization="linear")
    states, _ = jax.jit(jax.vmap(make_train(config, env)))(
        jax.random.split(jax.random.key(0), len(PREFS)), PREFS
    )
    theta = _learned_theta(config, env, states)
    dist_to_end = np.minimum(np.abs(theta), np.abs(theta - math.pi / 2))
    assert np.all(dist_to_end < 0.05), theta


def test_metrics_shapes_and_consistency(smooth_run):
    states, metrics = smooth_run
    p, t = len(PREFS), BANDIT.num_iterations
    for name in ("train/j_hat", "train/weights", "train/episode_return", "train/td_error"):
        assert metrics[name].shape == (p, t, 2), name
    for name in ("train/g_mu", "train/scalarized", "train/env_steps", "train/direction_norm"):
        assert metrics[name].shape == (p, t), name
    assert all(bool(jnp.all(jnp.isfinite(v))) for v in jax.tree.leaves(metrics))
    np.testing.assert_allclose(jnp.sum(metrics["train/weights"], -1), 1.0, rtol=1e-5)
    np.testing.assert_array_equal(metrics["train/env_steps"][0, -1], BANDIT.total_env_steps)
    assert int(states.iteration[0]) == t
    # every bandit step ends an episode: all N * (K + L) of them are counted
    np.testing.assert_array_equal(metrics["train/episodes"], BANDIT.env_steps_per_iteration)
    # Jhat tracks the learned policy's true expected reward
    final = metrics["train/j_hat"][:, -1]
    np.testing.assert_allclose(final, metrics["train/episode_return"][:, -1], atol=0.02)


def test_chunking_does_not_change_the_numbers(env):
    config = BANDIT.replace(num_iterations=10)
    trainer = make_trainer(config, env)
    pref = PREFS[1]
    state0 = trainer.init(jax.random.key(3), pref)
    whole, m_whole = jax.jit(functools.partial(trainer.run, num_iterations=10))(state0, pref)
    run4 = jax.jit(functools.partial(trainer.run, num_iterations=4))
    run6 = jax.jit(functools.partial(trainer.run, num_iterations=6))
    part, m1 = run4(state0, pref)
    part, m2 = run6(part, pref)
    jax.tree.map(np.testing.assert_array_equal, whole, part)
    joined = jax.tree.map(lambda a, b: jnp.concatenate([a, b]), m1, m2)
    jax.tree.map(np.testing.assert_array_equal, m_whole, joined)


def test_evaluate_reports_the_mean_policy_return(env, smooth_run):
    states, _ = smooth_run
    evaluate = jax.jit(jax.vmap(make_evaluate(BANDIT, env, num_episodes=4)))
    out = evaluate(states, jax.random.split(jax.random.key(5), len(PREFS)))
    theta = _learned_theta(BANDIT, env, states)
    np.testing.assert_allclose(out["eval/return"], cb.reward(jnp.asarray(theta)), rtol=1e-5)
    np.testing.assert_allclose(out["eval/discounted_return"], out["eval/return"])
    np.testing.assert_allclose(out["eval/length"], 1.0)


def test_wrong_j_ub_length_is_rejected(env):
    with pytest.raises(ValueError, match=r"j_ub \[1.0, 2.0, 3.0\] has 3 entries"):
        make_train(BANDIT.replace(j_ub=(1.0, 2.0, 3.0)), env)


@pytest.mark.parametrize(
    "field,value",
    [
        ("num_envs", 0),
        ("mu", 0.0),
        ("mu", float("nan")),
        ("gamma", 1.0),
        ("scalarization", "max"),
        ("network", "cnn"),
        ("actor_optimizer", "lbfgs"),
    ],
)
def test_config_rejects_bad_values(field, value):
    with pytest.raises(ValueError, match=field):
        TrainConfig(**{field: value})


def test_mgda_direction_trains_in_the_same_program_shape(env):
    config = BANDIT.replace(scalarization="mgda", num_iterations=50)
    states, metrics = jax.jit(jax.vmap(make_train(config, env)))(
        jax.random.split(jax.random.key(0), len(PREFS)), PREFS
    )
    assert bool(jnp.all(jnp.isfinite(metrics["train/j_hat"])))
    np.testing.assert_allclose(jnp.sum(metrics["train/weights"], -1), 1.0, rtol=1e-4)
    theta = _learned_theta(config, env, states)
    assert np.all((theta >= 0) & (theta <= math.pi / 2))
