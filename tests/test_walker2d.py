"""Walker2d on MJX: a jitted smoke test, conformance with mo-walker2d-v5, bad options.

Each physics model compiles once per session (module fixtures): ~35 s for "brax" and
~45 s for "gymnasium-v5" on a 2-core CPU.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from gym_states import gymnasium_states

from wcac_jax import envs
from wcac_jax.core.episodes import EpisodeWrapper

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def smoke_rollout():
    env = envs.make("walker2d", physics="brax", engine="mjx", episode_length=30)
    wrapped = EpisodeWrapper(env, env.episode_length)
    batch, steps = 8, 200

    @jax.jit
    def rollout(key):
        state = jax.vmap(wrapped.reset)(jax.random.split(key, batch))

        def body(state, k):
            # half the batch acts randomly (falls), half stands still (hits the time limit)
            action = jax.random.uniform(k, (batch, 6), minval=-1.0, maxval=1.0)
            action = action * (jnp.arange(batch) < batch // 2)[:, None]
            state = jax.vmap(wrapped.step)(state, action)
            return state, (state, action)

        return jax.lax.scan(body, state, jax.random.split(key, steps))

    final, (traj, actions) = rollout(jax.random.key(0))
    return env, (final, traj), actions


def test_smoke_shapes_dtypes_finite(smoke_rollout):
    env, (final, traj), actions = smoke_rollout
    assert env.observation_size == 17 and env.action_size == 6 and env.num_objectives == 2
    assert traj.obs.shape == (200, 8, 17) and traj.obs.dtype == jnp.float32
    assert traj.reward.shape == (200, 8, 2) and traj.reward.dtype == jnp.float32
    assert traj.done.shape == (200, 8)
    for leaf in (traj.obs, traj.reward, traj.done, final.pipeline_state.q):
        assert bool(jnp.all(jnp.isfinite(leaf)))
    for name in ("reward_forward", "reward_ctrl", "reward_healthy", "x_position", "x_velocity"):
        assert traj.metrics[name].shape == (200, 8), name

    # reward = [x_velocity, -sum a^2] + healthy, each term from what it is defined by:
    # x_velocity is the torso's x displacement over the step / dt (steps whose previous
    # step did not end an episode, so both positions are of one episode); the control
    # term is -sum(a^2) of the actions passed in; healthy is 0 exactly on a fall
    assert env.dt == pytest.approx(4 * 0.002)
    x = np.asarray(traj.metrics["x_position"])
    same_episode = np.asarray(traj.done[:-1]) == 0
    speed = (x[1:] - x[:-1]) / 0.008
    reward = np.asarray(traj.reward)
    healthy = 1.0 - np.asarray(traj.info["terminal"])
    assert np.abs(speed[same_episode]).max() > 0.1  # the random half moves
    np.testing.assert_allclose(
        reward[1:, :, 0][same_episode], speed[same_episode] + healthy[1:][same_episode], atol=1e-4
    )
    ctrl = -np.sum(np.square(np.asarray(actions)), axis=-1)
    assert ctrl.min() < -0.5  # the random half pays for its torques
    np.testing.assert_allclose(reward[..., 1], ctrl + healthy, rtol=1e-6, atol=1e-6)


def test_smoke_auto_resets_after_falls_and_time_limit(smoke_rollout):
    _, (_, traj), _ = smoke_rollout
    terminal, trunc, done = traj.info["terminal"], traj.info["truncation"], traj.done
    random_half, still_half = slice(0, 4), slice(4, 8)
    assert float(terminal[:, random_half].sum()) >= 4  # random actions make it fall
    assert float(trunc[:, still_half].sum()) >= 4 * 6  # standing still: 30-step limit
    np.testing.assert_array_equal(done, jnp.maximum(terminal, trunc))
    # after every episode end the observation is a fresh start state (torso ~1.25 m)
    ended = np.asarray(done[:-1]) > 0
    heights = np.asarray(traj.obs[:-1, :, 0])[ended]
    np.testing.assert_allclose(heights, 1.25, atol=0.01)
    # on a fall, the final observation is the fallen one and the healthy reward is 0
    fell = np.asarray(terminal) > 0
    assert np.all(np.asarray(traj.metrics["reward_healthy"])[fell] == 0.0)
    z = np.asarray(traj.info["final_obs"][..., 0])[fell]
    angle = np.asarray(traj.info["final_obs"][..., 1])[fell]
    assert np.all((z <= 0.8) | (z >= 2.0) | (np.abs(angle) >= 1.0))


def test_conformance_with_mo_gymnasium_walker2d_v5():
    """One step from the same (qpos, qvel) and action matches mo-walker2d-v5.

    MJX runs in float32 while MuJoCo runs in float64, and velocities reach ~10 (and
    beyond, before clipping), so float32 rounding through 4 RK4 substeps gives errors of
    1e-6..1e-4, which the tolerances below bound as measured; a modelling difference
    (friction, integrator, reward terms) differs by 1e-2 or more.
    """
    genv, states, actions = gymnasium_states(320)
    reference = []
    for (qpos, qvel), action in zip(states, actions, strict=True):
        genv.unwrapped.set_state(qpos, qvel)
        obs, reward, terminated, _, _ = genv.step(action)
        reference.append((obs, reward, terminated))
    ref_obs = np.array([r[0] for r in reference])
    ref_reward = np.array([r[1] for r in reference])
    ref_term = np.array([r[2] for r in reference], dtype=np.float32)
    assert ref_term.sum() >= 20  # states near and past the healthy limits are covered

    env = envs.make("walker2d", physics="gymnasium-v5", engine="mjx")

    @jax.jit
    @jax.vmap
    def one_step(qpos, qvel, action):
        state = env.reset(jax.random.key(0))
        ps = env.pipeline_init(qpos, qvel)
        return env.step(state.replace(pipeline_state=ps), action)

    out = one_step(
        jnp.asarray(np.array([s[0] for s in states]), jnp.float32),
        jnp.asarray(np.array([s[1] for s in states]), jnp.float32),
        jnp.asarray(np.array(actions), jnp.float32),
    )
    obs_err = np.abs(np.asarray(out.obs) - ref_obs)
    reward_err = np.abs(np.asarray(out.reward) - ref_reward)
    # what the README and the module docstring claim, measured: positions within 5.5e-6;
    # velocities within 1e-4 on 99% of the states (the worst, 6.6e-4, on a state with a
    # joint at 22.8 rad/s); forward reward within 4.8e-5 (float32 x displacement / dt),
    # control reward within 4.8e-7
    np.testing.assert_array_less(obs_err[:, :8], 1e-5)
    assert np.quantile(obs_err[:, 8:].max(axis=1), 0.99) < 1e-4
    np.testing.assert_array_less(obs_err[:, 8:], 1e-3)
    np.testing.assert_array_less(reward_err[:, 0], 1e-4)
    np.testing.assert_array_less(reward_err[:, 1], 1e-6)
    np.testing.assert_array_equal(out.done, ref_term)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"physics": "bullet"}, r"'bullet'.*brax, gymnasium-v5"),
        ({"episode_length": 0}, "episode_length.*0"),
        ({"episode_length": -5}, "episode_length.*-5"),
        ({"ls_iterations": 0}, "ls_iterations"),
        ({"frame_skip": 4}, r"'frame_skip'.*physics, episode_length"),
    ],
)
def test_bad_options_name_the_value(kwargs, match):
    with pytest.raises(ValueError, match=match):
        envs.make("walker2d", **kwargs)
