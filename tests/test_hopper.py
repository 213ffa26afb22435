"""Hopper (`hopper`, `hopper-2obj`): conformance with MO-Gymnasium's mo-hopper-v5 and
mo-hopper-2obj-v5 from our own states, jitted smoke tests on both engines, declarations.

The conformance test and the `"mujoco"` smoke test take seconds (the physics is a host
callback); the MJX smoke test compiles MJX (slow).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from gym_states import mo_gymnasium_steps, our_steps, own_states

from wcac_jax import envs
from wcac_jax.envs import base
from wcac_jax.envs.wrappers import EpisodeWrapper

N_ENVS, N_STEPS = 16, 20  # 320 steps


@pytest.fixture(scope="module")
def own_rollout():
    return own_states("hopper", N_ENVS, N_STEPS)


@pytest.mark.parametrize(
    "name,gym_id", [("hopper", "mo-hopper-v5"), ("hopper-2obj", "mo-hopper-2obj-v5")]
)
def test_conformance_with_mo_gymnasium(own_rollout, name, gym_id):
    """One step from each of our 320 states matches MO-Gymnasium's: the same C engine,
    model and solver, so what is left is float32 rounding. Measured max errors, on both
    versions: observations 2.4e-7, rewards 6.0e-7 (the height objective, ten times a
    rounded height; forward 1.2e-7, control 2.4e-7); 63 of the steps terminate. A
    modelling difference (a wrong weight, a missing healthy reward) is 1e-3 or more."""
    qpos, qvel, actions = own_rollout
    out = our_steps(name, qpos, qvel, actions)
    ref_obs, ref_reward, ref_term = mo_gymnasium_steps(gym_id, qpos, qvel, actions)
    assert ref_reward.shape == (N_ENVS * N_STEPS, envs.make(name).num_objectives)
    # falls, and states past the health limits, are covered
    assert 20 <= ref_term.sum() <= len(ref_term) - 20
    np.testing.assert_allclose(out.obs, ref_obs, rtol=0, atol=1e-6)
    np.testing.assert_allclose(out.reward, ref_reward, rtol=0, atol=2e-6)
    np.testing.assert_array_equal(out.done, ref_term)


@pytest.mark.parametrize("name", ["hopper", "hopper-2obj"])
def test_declarations(name):
    env = envs.make(name, episode_length=200)
    base.check(env)
    m = 3 if name == "hopper" else 2
    assert env.num_objectives == m and env.episode_length == 200
    assert env.observation_size == 11 and env.action_size == 3
    assert env.dt == pytest.approx(0.008) and env.backend == "mujoco"
    # the reference point is the least return: 199 healthy steps at z just above 0.7
    # (10 (0.7 - 1.25) + 1 = -4.5 each) then a fall to the floor (10 (0 - 1.25))
    ctrl = 0.0 if m == 3 else 3e-3 * 200
    assert env.default_hv_ref[1] == pytest.approx(-4.5 * 199 - 12.5 - ctrl)
    assert env.render_scene().model.nq == 6


def _smoke(env, steps=30, batch=4):
    wrapped = EpisodeWrapper(env, env.episode_length)

    @jax.jit
    def rollout(key):
        state = jax.vmap(wrapped.reset)(jax.random.split(key, batch))

        def body(state, k):
            action = jax.random.uniform(k, (batch, 3), minval=-1.0, maxval=1.0)
            state = jax.vmap(wrapped.step)(state, action)
            return state, state

        return jax.lax.scan(body, state, jax.random.split(key, steps))[1]

    traj = rollout(jax.random.key(0))
    m = env.num_objectives
    assert traj.obs.shape == (steps, batch, 11) and traj.obs.dtype == jnp.float32
    assert traj.reward.shape == (steps, batch, m) and traj.reward.dtype == jnp.float32
    for leaf in (traj.obs, traj.reward, traj.done, traj.pipeline_state.qpos):
        assert bool(jnp.all(jnp.isfinite(leaf)))
    # random torques make it fall; a fall earns no healthy reward
    fell = np.asarray(traj.info["terminal"]) > 0
    assert fell.any()
    assert np.all(np.asarray(traj.metrics["reward_healthy"])[fell] == 0.0)
    return traj


@pytest.mark.parametrize("name", ["hopper", "hopper-2obj"])
def test_jitted_smoke_on_mujoco_engine(name):
    _smoke(envs.make(name, episode_length=25))


@pytest.mark.slow
def test_jitted_smoke_on_mjx():
    env = envs.make("hopper", engine="mjx", episode_length=25)
    assert env.backend == "mjx" and env.mj_model.opt.iterations == 4
    _smoke(env, steps=20, batch=2)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"engine": "warp"}, r"unknown engine 'warp'; valid: mjx, mujoco"),
        ({"episode_length": 0}, "episode_length.*0"),
        ({"physics": "brax"}, r"'physics'.*episode_length, engine"),
    ],
)
def test_bad_options_name_the_value(kwargs, match):
    with pytest.raises(ValueError, match=match):
        envs.make("hopper", **kwargs)
