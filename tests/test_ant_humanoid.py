"""Ant (`ant`, `ant-2obj`) and Humanoid (`humanoid`): declarations and jitted smoke tests on
both engines (the MJX ones compile MJX: slow); conformance with MO-Gymnasium is in
`test_mo_mujoco_conformance`."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from wcac_jax import envs, networks
from wcac_jax.core.episodes import EpisodeWrapper
from wcac_jax.envs import base

SIZES = {"ant": (3, 105, 8), "ant-2obj": (2, 105, 8), "humanoid": (2, 348, 17)}


@pytest.mark.parametrize("name", list(SIZES))
def test_declarations(name):
    env = envs.make(name, episode_length=200)
    base.check(env)
    m, obs, act = SIZES[name]
    assert env.num_objectives == m and env.episode_length == 200
    assert env.observation_size == obs and env.action_size == act
    assert env.dt == pytest.approx(0.05 if name != "humanoid" else 0.015)
    assert envs.make(name).episode_length == 500


def _smoke(env, steps, batch):
    wrapped = EpisodeWrapper(env, env.episode_length)
    bound = getattr(env, "action_bound", 1.0)

    @jax.jit
    def rollout(key):
        state = jax.vmap(wrapped.reset)(jax.random.split(key, batch))

        def body(state, k):
            action = jax.random.uniform(k, (batch, env.action_size), minval=-bound, maxval=bound)
            state = jax.vmap(wrapped.step)(state, action)
            return state, state

        return jax.lax.scan(body, state, jax.random.split(key, steps))[1]

    traj = rollout(jax.random.key(0))
    m, obs = env.num_objectives, env.observation_size
    assert traj.obs.shape == (steps, batch, obs) and traj.obs.dtype == jnp.float32
    assert traj.reward.shape == (steps, batch, m) and traj.reward.dtype == jnp.float32
    for leaf in (traj.obs, traj.reward, traj.done, traj.pipeline_state.qpos):
        assert bool(jnp.all(jnp.isfinite(leaf)))
    # the time limit ends episodes; a fall earns no healthy reward
    assert np.asarray(traj.done).sum() >= batch * (steps // env.episode_length)
    fell = np.asarray(traj.info["terminal"]) > 0
    assert np.all(np.asarray(traj.metrics["reward_healthy"])[fell] == 0.0)
    assert np.asarray(traj.metrics["x_velocity"]).shape == (steps, batch)
    return traj


@pytest.mark.parametrize("name", ["ant", "humanoid"])  # ant-2obj: ant's but for the reward
def test_jitted_smoke_on_mujoco_engine(name):
    traj = _smoke(envs.make(name, episode_length=10), steps=25, batch=4)
    # a reset's contact forces read zero, as Gymnasium's
    first = np.asarray(traj.info["first_obs"])[-1]
    assert np.all(first[:, -78:] == 0.0)


@pytest.mark.slow
def test_jitted_smoke_on_mjx():
    """MJX's ant, its contact forces included: a reset and three jitted steps of two
    copies, the reset and the step compiled apart (`_smoke`'s episode loop, whose
    auto-reset puts both in one program, took 10 min on the 2-core CPU under load; this
    takes 6.5 min there, nearly all compilation)."""
    env = envs.make("ant", engine="mjx", episode_length=10)
    assert env.backend == "mjx" and env.mj_model.opt.iterations == 4
    state = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(0), 2))
    assert np.all(np.asarray(state.obs)[:, -78:] == 0.0)
    step = jax.jit(jax.vmap(env.step))
    for k in jax.random.split(jax.random.key(1), 3):
        state = step(state, jax.random.uniform(k, (2, 8), minval=-1.0, maxval=1.0))
    assert state.obs.shape == (2, 105) and state.reward.shape == (2, 3)
    for leaf in (state.obs, state.reward, state.pipeline_state.qpos):
        assert bool(jnp.all(jnp.isfinite(leaf)))
    # the torso moved and MJX filled the contact forces (the legs touch the floor)
    assert np.abs(np.asarray(state.metrics["x_velocity"])).max() > 0
    assert np.abs(np.asarray(state.obs)[:, -78:]).max() > 0


def test_humanoid_on_mjx_is_refused_in_one_line():
    with pytest.raises(ValueError, match=r"engine='mujoco' only: MJX cannot load.*PGS"):
        envs.make("humanoid", engine="mjx")


def test_the_policy_acts_in_humanoids_own_action_box():
    """The Gaussian's `[-1, 1]` reaches the environment as humanoid's `[-0.4, 0.4]`."""
    from wcac_jax import runtime

    env = envs.make("humanoid")
    policy = runtime.make_policy(env, lambda out: networks.paper_network(4, out, 4, 1), 0.0, True)
    action = policy.to_env(jnp.full((env.action_size,), 5.0))
    np.testing.assert_allclose(action, np.full(env.action_size, 0.4), rtol=1e-7)
