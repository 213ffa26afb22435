"""`runtime.make_evaluate`'s `eval/x_velocity`: the mean of the environment's own
`x_velocity` over every evaluation step (falls end an episode's steps: the hopper's
episodes fall), for the tasks that report it, and absent for the others."""

import types

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from wcac_jax import envs, runtime


def _evaluate(env, episodes, action):
    trainer = types.SimpleNamespace(
        mean_action=lambda state, obs: jnp.full((obs.shape[0], env.action_size), action)
    )
    config = types.SimpleNamespace(gamma=0.99)
    return jax.jit(runtime.make_evaluate(config, env, episodes, trainer))(None, jax.random.key(0))


def _by_hand(env, episodes, action):
    venv = runtime.vectorize(env)
    state = venv.reset(jax.random.split(runtime.typed_key(jax.random.key(0)), episodes))
    step = jax.jit(venv.step)
    alive, total, steps = np.ones(episodes), 0.0, 0.0
    for _ in range(env.episode_length):
        state = step(state, jnp.full((episodes, env.action_size), action))
        total += float(np.sum(np.asarray(state.metrics["x_velocity"]) * alive))
        steps += alive.sum()
        alive = alive * (1.0 - np.asarray(state.done))
    return total / steps, steps / episodes


# one task measuring qpos, one measuring a body position (the others are alike)
@pytest.mark.parametrize("name", ["halfcheetah", "ant"])
def test_mean_x_velocity_over_the_evaluation_steps(name):
    env = envs.make(name, episode_length=12)
    out = _evaluate(env, 3, 0.7)
    speed, length = _by_hand(env, 3, 0.7)
    assert float(out["eval/length"]) == pytest.approx(length)
    assert float(out["eval/x_velocity"]) == pytest.approx(speed, rel=1e-5, abs=1e-6)
    assert abs(speed) > 1e-3  # the constant torque moves it


def test_falls_end_an_episodes_steps():
    """The hopper under full torque: its three episodes fall, at different steps, so the
    evaluation's length is the mean of the falls' steps and its speed leaves out every
    step after a fall (a mean over the limit's steps, or the shortest episode's, is
    another number)."""
    env = envs.make("hopper", episode_length=40)
    venv = runtime.vectorize(env)
    state = venv.reset(jax.random.split(runtime.typed_key(jax.random.key(0)), 3))
    step, fell_at = jax.jit(venv.step), np.zeros(3)
    for t in range(1, 41):
        state = step(state, jnp.full((3, env.action_size), 1.0))
        fell_at = np.where((fell_at == 0) & np.asarray(state.done, bool), t, fell_at)
    assert (fell_at > 0).all() and len(set(fell_at.tolist())) > 1
    out = _evaluate(env, 3, 1.0)
    assert float(out["eval/length"]) == pytest.approx(fell_at.mean())
    speed, _ = _by_hand(env, 3, 1.0)
    assert float(out["eval/x_velocity"]) == pytest.approx(speed, rel=1e-5, abs=1e-6)


def test_absent_without_an_engine_speed():
    out = _evaluate(envs.make("concave_bandit"), 2, 0.0)
    assert "eval/x_velocity" not in out and "eval/return" in out
