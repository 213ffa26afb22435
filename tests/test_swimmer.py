"""Swimmer (`swimmer`): conformance with MO-Gymnasium's mo-swimmer-v5 from our own states, and
jitted smoke tests on both engines (the MJX one compiles MJX: slow)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from gym_states import mo_gymnasium_steps, our_steps, own_states

from wcac_jax import envs
from wcac_jax.envs import base
from wcac_jax.envs.wrappers import EpisodeWrapper

N_ENVS, N_STEPS = 16, 20  # 320 steps


def test_conformance_with_mo_gymnasium():
    """One step from each of our 320 states matches MO-Gymnasium's: the same C engine,
    model and solver, so what is left is float32 rounding (measured max 2.1e-7
    on observations, 1.2e-7 on rewards). It never terminates."""
    qpos, qvel, actions = own_states("swimmer", N_ENVS, N_STEPS)
    out = our_steps("swimmer", qpos, qvel, actions)
    ref_obs, ref_reward, ref_term = mo_gymnasium_steps("mo-swimmer-v5", qpos, qvel, actions)
    assert ref_reward.shape == (N_ENVS * N_STEPS, 2)
    assert np.abs(ref_reward[:, 0]).max() > 0.1  # it moves
    np.testing.assert_allclose(out.obs, ref_obs, rtol=0, atol=1e-6)
    np.testing.assert_allclose(out.reward, ref_reward, rtol=0, atol=5e-7)
    np.testing.assert_array_equal(out.done, ref_term)
    assert not ref_term.any()


def _smoke(env, steps, batch):
    wrapped = EpisodeWrapper(env, env.episode_length)

    @jax.jit
    def rollout(key):
        state = jax.vmap(wrapped.reset)(jax.random.split(key, batch))

        def body(state, k):
            action = jax.random.uniform(k, (batch, 2), minval=-1.0, maxval=1.0)
            state = jax.vmap(wrapped.step)(state, action)
            return state, state

        return jax.lax.scan(body, state, jax.random.split(key, steps))[1]

    traj = rollout(jax.random.key(0))
    assert traj.obs.shape == (steps, batch, 8) and traj.obs.dtype == jnp.float32
    assert traj.reward.shape == (steps, batch, 2) and traj.reward.dtype == jnp.float32
    for leaf in (traj.obs, traj.reward, traj.pipeline_state.qpos):
        assert bool(jnp.all(jnp.isfinite(leaf)))
    # no falls: only the time limit ends its episodes
    assert not np.asarray(traj.info["terminal"]).any()
    assert np.asarray(traj.info["truncation"]).sum() == batch * (steps // env.episode_length)


def test_declarations_and_jitted_smoke_on_mujoco_engine():
    env = envs.make("swimmer", episode_length=10)
    base.check(env)
    assert env.observation_size == 8 and env.action_size == 2 and env.backend == "mujoco"
    _smoke(env, steps=25, batch=4)


@pytest.mark.slow
def test_jitted_smoke_on_mjx():
    env = envs.make("swimmer", engine="mjx", episode_length=10)
    assert env.backend == "mjx"
    _smoke(env, steps=20, batch=2)
