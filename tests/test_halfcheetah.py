"""HalfCheetah (`halfcheetah`): jitted smoke tests on both engines (the MJX one compiles
MJX: slow); conformance with mo-halfcheetah-v5 is in `test_mo_mujoco_conformance`."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from wcac_jax import envs
from wcac_jax.core.episodes import EpisodeWrapper
from wcac_jax.envs import base


def _smoke(env, steps, batch):
    wrapped = EpisodeWrapper(env, env.episode_length)

    @jax.jit
    def rollout(key):
        state = jax.vmap(wrapped.reset)(jax.random.split(key, batch))

        def body(state, k):
            action = jax.random.uniform(k, (batch, 6), minval=-1.0, maxval=1.0)
            state = jax.vmap(wrapped.step)(state, action)
            return state, state

        return jax.lax.scan(body, state, jax.random.split(key, steps))[1]

    traj = rollout(jax.random.key(0))
    assert traj.obs.shape == (steps, batch, 17) and traj.obs.dtype == jnp.float32
    assert traj.reward.shape == (steps, batch, 2) and traj.reward.dtype == jnp.float32
    for leaf in (traj.obs, traj.reward, traj.pipeline_state.qpos):
        assert bool(jnp.all(jnp.isfinite(leaf)))
    # no falls: only the time limit ends its episodes
    assert not np.asarray(traj.info["terminal"]).any()
    assert np.asarray(traj.info["truncation"]).sum() == batch * (steps // env.episode_length)


def test_declarations_and_jitted_smoke_on_mujoco_engine():
    env = envs.make("halfcheetah", episode_length=10)
    base.check(env)
    assert env.observation_size == 17 and env.action_size == 6 and env.backend == "mujoco"
    _smoke(env, steps=25, batch=4)


@pytest.mark.slow
def test_jitted_smoke_on_mjx():
    env = envs.make("halfcheetah", engine="mjx", episode_length=10)
    assert env.backend == "mjx"
    _smoke(env, steps=20, batch=2)
