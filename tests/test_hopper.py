"""Hopper (`hopper`, `hopper-2obj`): jitted smoke tests on both engines, declarations
(conformance with MO-Gymnasium: `test_mo_mujoco_conformance`).

The `"mujoco"` smoke test takes seconds (the physics is a host callback); the MJX smoke
test compiles MJX (slow).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from wcac_jax import envs
from wcac_jax.core.episodes import EpisodeWrapper
from wcac_jax.envs import base


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
