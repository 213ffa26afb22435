"""Walker2d's physics engines: MuJoCo's C engine (`engine="mujoco"`) against
mo-walker2d-v5, both models on it, its float64 state, determinism across chunking and
`--resume`, a sweep sharded over two host devices, bad engine values.

The `"mujoco"` engine compiles in seconds (the physics is a host callback), so these tests
are cheap; nothing here compiles an MJX program.
"""

import json
import os
import subprocess
import sys

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from gym_states import gymnasium_states

from wcac_jax import envs, sweep
from wcac_jax.algos import PaperConfig
from wcac_jax.core.episodes import EpisodeWrapper
from wcac_jax.envs.engines.mujoco import MujocoEngine, f32_to_f64_bits
from wcac_jax.envs.walker2d import load_mj_model

# ----------------------------------------------------------------- float64 bit patterns


def test_f32_to_f64_bits_hand_values():
    x = np.array([1.0, -2.5, 0.0, -0.0, 2.0**-149, 2.0**-128, np.inf, 1.0 + 2.0**-23], np.float32)
    # (low word, high word) of each float64, worked out by hand: sign | 11-bit exponent
    # (bias 1023) | top 20 mantissa bits, then the low 32 mantissa bits
    expected = [
        (0, 0x3FF00000),  # 1.0 = 1.0 * 2^0
        (0, 0xC0040000),  # -2.5 = -1.25 * 2^1: exponent 0x400, mantissa .25 = bit 18
        (0, 0),
        (0, 0x80000000),
        (0, 0x36A00000),  # smallest float32 subnormal 2^-149: exponent 1023 - 149
        (0, 0x37F00000),  # subnormal 2^-128: exponent 1023 - 128
        (0, 0x7FF00000),
        (1 << 29, 0x3FF00000),  # 1 + 2^-23: mantissa bit 52 - 23 = 29 (low word)
    ]
    got = np.asarray(jax.jit(f32_to_f64_bits)(jnp.asarray(x))).reshape(-1, 2)
    np.testing.assert_array_equal(got, np.array(expected, np.uint32))


def test_f32_to_f64_bits_matches_numpy_on_random_bit_patterns():
    bits = np.random.default_rng(0).integers(0, 2**32, 20_000, dtype=np.uint64)
    x = bits.astype(np.uint32).view(np.float32)
    x = x[~np.isnan(x)]
    got = np.asarray(jax.jit(f32_to_f64_bits)(jnp.asarray(x)))
    np.testing.assert_array_equal(got, x.astype(np.float64).view(np.uint32))


# ----------------------------------------------------------------- against MO-Gymnasium


def test_mujoco_engine_matches_mo_walker2d_v5():
    """One step from the same float64 (qpos, qvel) and action matches mo-walker2d-v5 to
    2e-6: it is the same C engine with the same model and solver, so what is left is the
    float32 rounding of observations and rewards (measured max 4.62e-7 on observations,
    4.77e-7 on rewards, half a float32 ulp of values up to 8; the tolerance is about 4x
    that; 68 of the 320 steps terminate)."""
    genv, states, actions = gymnasium_states(320, float32_actions=True)
    reference = []
    for (qpos, qvel), action in zip(states, actions, strict=True):
        genv.unwrapped.set_state(qpos, qvel)
        obs, reward, terminated, _, _ = genv.step(action)
        reference.append((obs, reward, terminated))
    ref_obs = np.array([r[0] for r in reference])
    ref_reward = np.array([r[1] for r in reference])
    ref_term = np.array([r[2] for r in reference], dtype=np.float32)
    assert ref_term.sum() >= 20  # states near and past the healthy limits are covered

    env = envs.make("walker2d", physics="gymnasium-v5", engine="mujoco")
    data = env.engine.host_data(np.array([s[0] for s in states]), np.array([s[1] for s in states]))
    start = jax.vmap(env.reset)(jax.random.split(jax.random.key(0), len(states)))
    out = jax.jit(jax.vmap(env.step))(
        start.replace(pipeline_state=data), jnp.asarray(np.array(actions), jnp.float32)
    )
    np.testing.assert_allclose(out.obs, ref_obs, rtol=0, atol=2e-6)
    np.testing.assert_allclose(out.reward, ref_reward, rtol=0, atol=2e-6)
    np.testing.assert_array_equal(out.done, ref_term)


# ----------------------------------------------------------------- both models, the state


@pytest.fixture(scope="module")
def brax_model_rollout():
    """Brax's model on MuJoCo's C engine: 8 auto-resetting environments, 150 steps,
    half acting randomly (they fall), half standing still (30-step time limit)."""
    env = envs.make("walker2d", physics="brax", engine="mujoco", episode_length=30)
    wrapped = EpisodeWrapper(env, env.episode_length)
    batch, steps = 8, 150

    @jax.jit
    def rollout(key):
        state = jax.vmap(wrapped.reset)(jax.random.split(key, batch))

        def body(state, k):
            action = jax.random.uniform(k, (batch, 6), minval=-1.0, maxval=1.0)
            action = action * (jnp.arange(batch) < batch // 2)[:, None]
            state = jax.vmap(wrapped.step)(state, action)
            return state, state

        return jax.lax.scan(body, state, jax.random.split(key, steps))

    return env, rollout(jax.random.key(0))


def test_brax_model_on_mujoco_engine_steps_falls_and_resets(brax_model_rollout):
    env, (final, traj) = brax_model_rollout
    assert env.backend == "mujoco" and env.dt == pytest.approx(0.008)
    assert traj.obs.shape == (150, 8, 17) and traj.obs.dtype == jnp.float32
    assert traj.reward.shape == (150, 8, 2)
    for leaf in (traj.obs, traj.reward, final.pipeline_state.qpos, final.pipeline_state.qvel):
        assert bool(jnp.all(jnp.isfinite(leaf)))
    terminal, trunc = traj.info["terminal"], traj.info["truncation"]
    assert float(terminal[:, :4].sum()) >= 4  # random torques make it fall
    assert float(trunc[:, 4:].sum()) >= 4 * 4  # standing still reaches the time limit
    # a fall earns no healthy reward and is the fallen observation
    fell = np.asarray(terminal) > 0
    assert np.all(np.asarray(traj.metrics["reward_healthy"])[fell] == 0.0)
    z = np.asarray(traj.info["final_obs"][..., 0])[fell]
    angle = np.asarray(traj.info["final_obs"][..., 1])[fell]
    assert np.all((z <= 0.8) | (z >= 2.0) | (np.abs(angle) >= 1.0))


def test_float32_views_are_the_rounded_float64_state(brax_model_rollout):
    env, (final, _) = brax_model_rollout
    engine = env.engine
    full = np.asarray(final.pipeline_state.physics).reshape(8, -1).view(np.float64)
    assert full.shape == (8, engine.nstate)
    qpos = full[:, engine._qpos_at : engine._qpos_at + engine.nq]
    qvel = full[:, engine._qvel_at : engine._qvel_at + engine.nv]
    np.testing.assert_array_equal(final.pipeline_state.qpos, qpos.astype(np.float32))
    np.testing.assert_array_equal(final.pipeline_state.qvel, qvel.astype(np.float32))
    # the model's clock counts 0.008 s per step since the environment's last reset
    steps = np.asarray(final.info["steps"])
    assert steps.max() > 0
    np.testing.assert_allclose(full[:, 0], steps * 0.008, rtol=0, atol=1e-12)


def test_results_do_not_depend_on_the_thread_count():
    model = load_mj_model("gymnasium-v5")
    rng = np.random.default_rng(1)
    qpos = model.qpos0 + rng.uniform(-0.1, 0.1, (64, model.nq))
    qvel = rng.uniform(-1.0, 1.0, (64, model.nv))
    action = rng.uniform(-1.0, 1.0, (4, 16, model.nu)).astype(np.float32)  # [P, N, nu]
    one, many = MujocoEngine(model, 4, nthread=1), MujocoEngine(model, 4, nthread=4)
    physics = np.asarray(one.host_data(qpos, qvel).physics).reshape(4, 16, -1)
    for a, b in zip(one._host_step(physics, action), many._host_step(physics, action), strict=True):
        assert a.shape[:2] == (4, 16)
        np.testing.assert_array_equal(a, b)
    # and one step is what mj_step gives from the same state, 4 substeps
    data = mujoco.MjData(model)
    data.qpos, data.qvel, data.ctrl = qpos[5], qvel[5], action[0, 5]
    mujoco.mj_step(model, data, nstep=4)
    new_physics = one._host_step(physics, action)[0].reshape(64, -1).view(np.float64)
    np.testing.assert_array_equal(new_physics[5, 1 : 1 + model.nq], data.qpos)


# ----------------------------------------------------------------- sweeps


def _tiny_config(**env_options):
    return sweep.SweepConfig(
        prefs=((1.0, 0.0), (0.5, 0.5), (0.0, 1.0)),
        env="walker2d",
        env_options={
            "physics": "gymnasium-v5",
            "engine": "mujoco",
            "episode_length": 40,
            **env_options,
        },
        train=PaperConfig(num_envs=4, critic_steps=2, rollout_steps=3, width=16, depth=1),
        steps_per_pref=4 * 5 * 6,
        eval_episodes=1,
    )


def _outputs(out):
    with open(os.path.join(out, "front.json")) as f:
        front = json.load(f)
    with np.load(os.path.join(out, "curves.npz")) as data:
        curves = {k: data[k] for k in data.files}
    return front, curves


def test_mujoco_sweep_bit_identical_across_chunking_and_resume(tmp_path):
    """One chunk vs three chunks stopped after the first and resumed from its checkpoint."""
    config = _tiny_config()
    whole, resumed = str(tmp_path / "whole"), str(tmp_path / "resumed")
    sweep.run_sweep(config, whole, chunks=1, progress=False)
    stopped = sweep.run_sweep(config, resumed, chunks=3, progress=False, stop_after_chunks=1)
    assert stopped["interrupted"] and stopped["iterations_done"] == 2
    sweep.run_sweep(config, resumed, chunks=3, progress=False, resume=True)

    front, curves = _outputs(whole)
    assert front["env_steps_per_pref"] == 120
    assert np.isfinite(curves["train/episode_return"]).all()
    with open(os.path.join(whole, "config.json")) as f:
        assert json.load(f)["device_count"] == jax.device_count()
    front_r, curves_r = _outputs(resumed)
    assert [r["return"] for r in front_r["prefs"]] == [r["return"] for r in front["prefs"]]
    assert curves_r.keys() == curves.keys()
    for k in curves:
        np.testing.assert_array_equal(curves_r[k], curves[k], err_msg=k)


TINY_WALKER_CLI = [
    *("--preset", "paper", "--env", "walker2d", "--physics", "gymnasium-v5", "--engine", "mujoco"),
    *("--episode-length", "40", "--n-prefs", "3", "--envs-per-pref", "4"),
    *("--critic-steps", "2", "--rollout-steps", "3", "--network", "mlp", "--width", "16"),
    *("--depth", "1", "--steps-per-pref", "120", "--eval-episodes", "1", "--chunks", "2"),
]


def _cli(args, env):
    base = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    return subprocess.run(
        [sys.executable, "-m", "wcac_jax.sweep", *args],
        capture_output=True,
        text=True,
        env={**base, **env},
        timeout=600,
    )


@pytest.mark.slow
def test_mujoco_sweep_sharded_over_two_host_devices(tmp_path):
    """The device count is fixed when JAX starts, hence a subprocess. Each device steps
    its own preferences' environments (the sweep's `shard_map`): XLA gathers nothing for
    the host callback (it used to, warning "Involuntary full rematerialization")."""
    out = tmp_path / "two"
    flags = "--xla_force_host_platform_device_count=2"
    run = _cli([*TINY_WALKER_CLI, "--out", str(out)], {"XLA_FLAGS": flags})
    assert run.returncode == 0, run.stderr
    assert (
        run.stderr.splitlines()[0] == f"[devices] XLA_FLAGS='{flags}' (yours): devices as it says"
    )
    assert "rematerialization" not in run.stderr
    front, curves = _outputs(out)
    assert len(front["devices"]) == 2 and len(front["prefs"]) == 3
    with open(out / "config.json") as f:
        assert json.load(f)["device_count"] == 2
    assert front["env_steps_per_pref"] == 120
    assert np.isfinite(np.array([r["return"] for r in front["prefs"]])).all()
    assert np.isfinite(curves["train/g_mu"]).all()


# ----------------------------------------------------------------- bad values


@pytest.mark.parametrize("engine", ["warp", "MuJoCo", "", None])
def test_bad_engine_names_the_valid_ones(engine):
    with pytest.raises(ValueError, match=rf"unknown engine {engine!r}; valid: mjx, mujoco"):
        envs.make("walker2d", engine=engine)


def test_cli_bad_engine_is_one_line_and_writes_nothing(tmp_path):
    out = tmp_path / "never"
    run = _cli([*TINY_WALKER_CLI[:4], "--engine", "warp", "--out", str(out)], {})
    assert run.returncode == 2
    lines = run.stderr.splitlines()
    cores = os.cpu_count()
    assert lines[0].startswith(f"[devices] {cores} host devices, one per core")
    assert lines[1:] == ["error: unknown engine 'warp'; valid: mjx, mujoco"]
    assert run.stdout == "" and not out.exists()
