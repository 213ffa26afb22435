"""States to compare our MuJoCo tasks with MO-Gymnasium's from, and one step of each side
from them: mo-walker2d-v5's own states (shared by the MJX and the MuJoCo-engine Walker2d
conformance tests), and our own environments' states (`own_states`, `our_steps`,
`mo_gymnasium_steps`: the hopper, halfcheetah and swimmer tests)."""

import numpy as np
import pytest


def gymnasium_states(n_states, seed=0, float32_actions=False):
    """States (float64 qpos, qvel) and actions from random-action rollouts of
    mo-walker2d-v5, continuing a few steps past each fall so states beyond the healthy
    limits appear. `float32_actions`: actions representable in float32 (for an exact
    float64 comparison). Returns `(env, states, actions)`."""
    mo_gym = pytest.importorskip("mo_gymnasium")
    genv = mo_gym.make("mo-walker2d-v5")
    rng = np.random.default_rng(seed)
    genv.reset(seed=seed)
    states, actions, past_fall = [], [], 0
    while len(states) < n_states:
        action = rng.uniform(-1.0, 1.0, 6)
        if float32_actions:
            action = action.astype(np.float32).astype(np.float64)
        data = genv.unwrapped.data
        states.append((data.qpos.copy(), data.qvel.copy()))
        actions.append(action)
        _, _, terminated, _, _ = genv.step(action)
        past_fall += bool(terminated) or past_fall > 0
        if past_fall > 5:
            genv.reset(seed=int(rng.integers(1 << 30)))
            past_fall = 0
    return genv, states, actions


def own_states(name, n_envs, n_steps, seed=0, action_scale=1.0):
    """Float64 states `qpos [n, nq]`, `qvel [n, nv]` and float32 actions `[n, nu]`
    (`n = n_envs * n_steps`) of our environment `name` on MuJoCo's C engine: random-action
    rollouts without resets (an agent that fell keeps moving, so states past the health
    limits appear), each step's exact start state and action; actions uniform in the
    task's action range (`action_bound`, 1 unless the task declares its own; a half-width
    or one per action) times `action_scale` (above 1: some actions outside the range)."""
    import jax

    from wcac_jax import envs

    env = envs.make(name, engine="mujoco")
    nu = env.action_size
    bound = action_scale * np.asarray(getattr(env, "action_bound", 1.0), np.float32)

    @jax.jit
    def rollout(key):
        start = jax.vmap(env.reset)(jax.random.split(key, n_envs))

        def body(state, k):
            action = jax.random.uniform(k, (n_envs, nu), minval=-bound, maxval=bound)
            return jax.vmap(env.step)(state, action), (state.pipeline_state.physics, action)

        return jax.lax.scan(body, start, jax.random.split(key, n_steps))[1]

    physics, actions = (np.asarray(x) for x in rollout(jax.random.key(seed)))
    engine = env.engine
    full = physics.reshape(n_envs * n_steps, -1).view(np.float64)
    qpos = full[:, engine._qpos_at : engine._qpos_at + engine.nq]
    qvel = full[:, engine._qvel_at : engine._qvel_at + engine.nv]
    return qpos, qvel, actions.reshape(-1, nu)


def our_steps(name, qpos, qvel, actions):
    """One step of our `name` (MuJoCo's C engine) from each float64 state, set exactly."""
    import jax
    import jax.numpy as jnp

    from wcac_jax import envs

    env = envs.make(name, engine="mujoco")
    start = jax.vmap(env.reset)(jax.random.split(jax.random.key(1), len(qpos)))
    start = start.replace(pipeline_state=env.engine.host_data(qpos, qvel))
    return jax.jit(jax.vmap(env.step))(start, jnp.asarray(actions))


def mo_gymnasium_steps(gym_id, qpos, qvel, actions, zero_warmstart=False):
    """One step of MO-Gymnasium's `gym_id` from each state: `(obs, reward, terminated)`.
    `zero_warmstart`: its constraint solver starts each step from zero, as our engine's
    does, instead of from the previous (unrelated) test state's solution."""
    mo_gym = pytest.importorskip("mo_gymnasium")
    genv = mo_gym.make(gym_id)
    genv.reset(seed=0)
    obs, reward, term = [], [], []
    for q, v, a in zip(qpos, qvel, actions, strict=True):
        genv.unwrapped.set_state(q, v)
        if zero_warmstart:
            genv.unwrapped.data.qacc_warmstart[:] = 0.0
        o, r, t, _, _ = genv.step(np.asarray(a, np.float64))
        obs.append(o), reward.append(r), term.append(t)
    return np.array(obs), np.array(reward), np.array(term, np.float32)
