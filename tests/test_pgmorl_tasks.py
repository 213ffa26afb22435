"""PGMORL's and COLA's tasks (`wcac_jax/envs/pgmorl*.py`): their models against MuJoCo
2.3.3's compile of the published files, their steps against the published step restated
here on raw `mujoco`, rewards worked out by hand, and HalfCheetah's speed cap.

The published environments (mit-gfx/PGMORL `environments/*.py`; yeshenpy/COLA's
`new_half_cheetah.py` and `ant_v3.py`) are gym 0.15 `MujocoEnv`s on mujoco-py 2.0, which
cannot run here. `REFERENCE` restates each one's `step` on raw MuJoCo as gym 0.15 runs it:
the state set as `set_state` sets it (`qpos`, `qvel`, then `mj_forward`), what the step
reads before simulating (`qpos[0]`, the torso's `xpos`, the centre of mass from `xipos`),
the action clipped as the step clips it, the controls held for `frame_skip` `mj_step`s,
then its observation, reward and termination formulas. Each reference step starts from
fresh `MjData` (the constraint solver from zero, as our engine's does each step).

Conformance: one step from each of 320 states of our own random-action rollouts (16
environments x 20 steps; the hopper's 800, 16 x 50), with actions up to 1.5 times the
action range so the clip is exercised, on both sides; observations and rewards within
1e-5 of the reference relative to `max(|reference|, 1)`, terminations identical. Measured
errors are in `CASES`. The tasks whose speeds read MuJoCo's body positions (the ants, the
humanoid) are also followed along whole trajectories, where those positions carry over
from step to step. The module took 4 min 20 s on the 2-core CPU under a load of ~13 (1 min
40 s of CPU time; MJX's hopper is most of it).
"""

import json
import math
import os

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from gym_states import our_steps, own_states
from pgmorl_models import PUBLISHED, compiled

from wcac_jax import envs, pareto
from wcac_jax.envs import base
from wcac_jax.envs.mujoco_base import asset, load_model

N_ENVS, N_STEPS = 16, 20  # 320 steps
TOLERANCE = 1e-5
FIXTURE = os.path.join(os.path.dirname(__file__), "fixtures", "pgmorl_models_mujoco233.json")


# ----------------------------------------------------------------- the published steps


def _simulate(model, data, ctrl, frame_skip):
    """gym 0.15's `do_simulation`: the controls held for `frame_skip` `mj_step`s."""
    data.ctrl[:] = ctrl
    for _ in range(frame_skip):
        mujoco.mj_step(model, data)


def _walker2d(model, data, action):
    dt = model.opt.timestep * 4
    posbefore = data.qpos[0]
    a = np.clip(action, -1.0, 1.0)
    _simulate(model, data, a, 4)
    posafter, height, ang = data.qpos[0:3]
    reward_speed = (posafter - posbefore) / dt + 1.0
    reward_energy = 4.0 - 1.0 * np.square(a).sum() + 1.0
    done = not (height > 0.8 and height < 2.0 and ang > -1.0 and ang < 1.0)
    obs = np.concatenate([data.qpos[1:], np.clip(data.qvel, -10, 10)])
    return obs, [reward_speed, reward_energy], done


def _halfcheetah(cola):
    def step(model, data, action):
        dt = model.opt.timestep * 5
        xposbefore = data.qpos[0]
        a = np.clip(action, -1.0, 1.0)
        _simulate(model, data, a, 5)
        xposafter, ang = data.qpos[0], data.qpos[2]
        if cola:  # MO-New-HalfCheetah-v2
            reward_run = 0.5 * (xposafter - xposbefore) / dt + 1.0
        else:
            reward_run = min(4.0, (xposafter - xposbefore) / dt) + 1.0
        reward_energy = 4.0 - 1.0 * np.square(a).sum() + 1.0
        done = not (abs(ang) < np.deg2rad(50))
        obs = np.concatenate([data.qpos[1:], data.qvel])
        return obs, [reward_run, reward_energy], done

    return step


def _hopper(three):
    def step(model, data, action):
        dt = model.opt.timestep * 5
        init_z = model.qpos0[1]
        posbefore = data.qpos[0]
        a = np.clip(action, [-2.0, -2.0, -4.0], [2.0, 2.0, 4.0])
        _simulate(model, data, a, 5)
        posafter, height = data.qpos[0:2]
        if three:  # MO-Hopper-v3
            reward = [
                1.5 * (posafter - posbefore) / dt + 1.0,
                12.0 * (height - init_z) + 1.0,
                4.0 - 1.0 * np.square(a).sum() + 1.0,
            ]
        else:
            others = 1.0 - 2e-4 * np.square(a).sum()
            reward = [
                1.5 * (posafter - posbefore) / dt + others,
                12.0 * (height - init_z) + others,
            ]
        s = np.concatenate([data.qpos, data.qvel])  # gym's state_vector()
        done = not (s[1] > 0.4 and all(abs(s[i]) < np.deg2rad(90) for i in (2, 3, 4, 5)))
        obs = np.concatenate([data.qpos[1:], np.clip(data.qvel, -10, 10)])
        return obs, reward, done

    return step


def _ant(cola):
    def step(model, data, action):
        dt = model.opt.timestep * 5
        torso = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "torso")
        before = data.xpos[torso].copy()  # gym 0.15's get_body_com: the body's xpos
        a = np.clip(action, -1.0, 1.0)
        _simulate(model, data, a, 5)
        after = data.xpos[torso]
        vx, vy = (after[:2] - before[:2]) / dt
        if cola:  # MO-Ant-v3
            reward = [vx, vy, 4.0 - 0.5 * np.square(a).sum()]
        else:
            other = -0.5 * np.square(a).sum() + 1.0
            reward = [vx + other, vy + other]
        done = not np.isfinite(np.concatenate([data.qpos, data.qvel])).all()
        obs = np.concatenate([data.qpos[2:], data.qvel])
        return obs, reward, done

    return step


def _swimmer(model, data, action):
    dt = model.opt.timestep * 4
    xposbefore = data.qpos[0]
    a = np.clip(action, -1, 1)
    _simulate(model, data, a, 4)
    reward_fwd = (data.qpos[0] - xposbefore) / dt
    reward_ctrl = 0.3 - 0.15 * np.square(a).sum()
    obs = np.concatenate([data.qpos[2:], data.qvel])
    return obs, [reward_fwd, reward_ctrl], False


def _humanoid(model, data, action):
    dt = model.opt.timestep * 5
    mass = model.body_mass[:, None]

    def mass_center():
        return (np.sum(mass * data.xipos, 0) / np.sum(mass))[0]

    pos_before = mass_center()
    _simulate(model, data, action, 5)  # the published step does not clip
    pos_after = mass_center()
    obs = np.concatenate(
        [
            data.qpos[2:],
            data.qvel,
            data.cinert.ravel(),
            data.cvel.ravel(),
            data.qfrc_actuator.ravel(),
            data.cfrc_ext.ravel(),
        ]
    )
    # MuJoCo 2.0's mj_step clamped data.ctrl to the control range in place (MuJoCo 2.2.1
    # and later leave it as set), and the reward reads data.ctrl after the step
    lo, hi = model.actuator_ctrlrange[:, 0], model.actuator_ctrlrange[:, 1]
    ctrl = np.clip(data.ctrl, lo, hi)
    reward_run = 1.25 * (pos_after - pos_before) / dt + 3.0
    reward_energy = 3.0 - 4.0 * np.square(ctrl).sum() + 3.0
    done = bool((data.qpos[2] < 1.0) or (data.qpos[2] > 2.0))
    return obs, [reward_run, reward_energy], done


REFERENCE = {
    "walker2d-pgmorl": ("walker2d_pgmorl.xml", _walker2d),
    "halfcheetah-pgmorl": ("half_cheetah_pgmorl.xml", _halfcheetah(cola=False)),
    "halfcheetah-cola": ("half_cheetah_pgmorl.xml", _halfcheetah(cola=True)),
    "hopper-pgmorl": ("hopper_pgmorl.xml", _hopper(three=False)),
    "hopper3-pgmorl": ("hopper_pgmorl.xml", _hopper(three=True)),
    "ant-pgmorl": ("ant_pgmorl.xml", _ant(cola=False)),
    "ant3-cola": ("ant_pgmorl.xml", _ant(cola=True)),
    "swimmer-pgmorl": ("swimmer_pgmorl.xml", _swimmer),
    "humanoid-pgmorl": ("humanoid_pgmorl.xml", _humanoid),
}


def reference_steps(name, qpos, qvel, actions):
    """The published step of `name` from each float64 state: `(obs, reward, done)`."""
    model_file, step = REFERENCE[name]
    if model_file == "half_cheetah_pgmorl.xml":  # MuJoCo's own loader's model, unwarned
        model = load_model(asset(model_file))
    else:
        model = mujoco.MjModel.from_xml_path(asset(model_file))
    obs, reward, done = [], [], []
    for q, v, a in zip(qpos, qvel, actions, strict=True):
        data = mujoco.MjData(model)
        data.qpos[:], data.qvel[:] = q, v
        mujoco.mj_forward(model, data)  # gym 0.15's set_state
        o, r, d = step(model, data, np.asarray(a, np.float64))
        obs.append(o), reward.append(r), done.append(d)
    return np.array(obs), np.array(reward), np.array(done, np.float32)


# ----------------------------------------------------------------- conformance

# name -> the rollout its states come from (variants of one model share them) and its
# length: the hopper's joints are damped (40) and it falls later, so its rollouts run 50
# steps (30 of 800 steps then end). Measured on the 2-core CPU, relative to
# max(|reference|, 1): observations 5.9e-8 at most on every task (float32 rounding);
# rewards 4.7e-7 (walker2d, halfcheetah), 7.2e-7 (hopper), 6.8e-8 (swimmer), 3.5e-7
# (ant), 1.0e-6 (humanoid); terminations identical: walker2d 3, halfcheetah 9 (flips),
# humanoid 31 of 320
CASES = {
    "walker2d-pgmorl": ("walker2d-pgmorl", N_STEPS),
    "halfcheetah-pgmorl": ("halfcheetah-pgmorl", N_STEPS),
    "halfcheetah-cola": ("halfcheetah-pgmorl", N_STEPS),
    "hopper-pgmorl": ("hopper-pgmorl", 50),
    "hopper3-pgmorl": ("hopper-pgmorl", 50),
    "ant-pgmorl": ("ant-pgmorl", N_STEPS),
    "ant3-cola": ("ant-pgmorl", N_STEPS),
    "swimmer-pgmorl": ("swimmer-pgmorl", N_STEPS),
    "humanoid-pgmorl": ("humanoid-pgmorl", N_STEPS),
}
_ROLLOUTS: dict = {}


def _rollout(name):
    """Our states for `name`'s rollout source, computed once per test run."""
    source, n_steps = CASES[name]
    if source not in _ROLLOUTS:
        _ROLLOUTS[source] = own_states(source, N_ENVS, n_steps, action_scale=1.5)
    return _ROLLOUTS[source]


def _relative(ours, theirs):
    return np.abs(np.asarray(ours, np.float64) - theirs) / np.maximum(np.abs(theirs), 1.0)


@pytest.fixture(scope="module", params=list(CASES))
def stepped(request):
    """`(name, states, our step, the reference step)` from every state of the rollout."""
    name = request.param
    qpos, qvel, actions = _rollout(name)
    ours = our_steps(name, qpos, qvel, actions)
    return name, (qpos, qvel, actions), ours, reference_steps(name, qpos, qvel, actions)


def test_conformance_with_the_published_step(stepped):
    name, (_, _, actions), ours, (obs, reward, done) = stepped
    env = envs.make(name)
    n = N_ENVS * CASES[name][1]
    assert obs.shape == (n, env.observation_size) and reward.shape == (n, env.num_objectives)
    bound = np.asarray(env.action_bound)
    assert np.any(np.abs(actions) > bound)  # the clip is exercised
    assert np.abs(reward[:, 0] - reward[:, 0].mean()).max() > 0.1  # it moves
    assert _relative(ours.obs, obs).max() <= TOLERANCE
    assert _relative(ours.reward, reward).max() <= TOLERANCE
    np.testing.assert_array_equal(ours.done, done)


def test_terminations_happen_where_the_task_has_them(stepped):
    """The rollouts reach the published terminations (falls, the cheetah's flips), so
    their rule is compared on both sides; the swimmer and the ants never end early."""
    name, _, _, (_, _, done) = stepped
    if name in ("swimmer-pgmorl", "ant-pgmorl", "ant3-cola"):
        assert not done.any()
    else:
        assert 1 <= done.sum() <= len(done) - 1


@pytest.mark.parametrize("name", ["ant-pgmorl", "ant3-cola", "humanoid-pgmorl"])
def test_a_whole_trajectory_matches_the_published_one(name):
    """The ant's and the humanoid's speeds come from body positions as MuJoCo leaves them
    after a step (`xpos`, `xipos`: the step's last force evaluation, a substep behind), so
    along a trajectory the published step measures from the previous step's value, not
    from a fresh one as after `set_state` (on the ant the two differ by up to 0.06 in a
    reward). 4 episodes of 30 steps from our resets, the reference carrying its `MjData`
    from step to step as gym does: measured, rewards within 5e-7 and observations within
    1.2e-6 (the humanoid's after 30 steps: its PGS solver stops short of convergence and
    the published one starts from the previous step's solution, ours from zero, 1.6e-6
    apart in one step), terminations identical."""
    n_envs, n_steps = 4, 30
    env = envs.make(name)
    bound = 1.5 * np.asarray(env.action_bound, np.float32)

    @jax.jit
    def run(key):
        key_reset, key_act = jax.random.split(key)
        start = jax.vmap(env.reset)(jax.random.split(key_reset, n_envs))
        shape = (n_steps, n_envs, env.action_size)
        actions = jax.random.uniform(key_act, shape, minval=-bound, maxval=bound)

        def body(state, action):
            state = jax.vmap(env.step)(state, action)
            return state, (state.obs, state.reward, state.done)

        return start.pipeline_state.physics, actions, jax.lax.scan(body, start, actions)[1]

    physics, actions, (obs, reward, done) = jax.tree.map(np.asarray, run(jax.random.key(0)))
    model_file, step = REFERENCE[name]
    model = mujoco.MjModel.from_xml_path(asset(model_file))
    engine = env.engine
    state = physics.view(np.float64)
    for i in range(n_envs):
        data = mujoco.MjData(model)
        data.qpos[:] = state[i, engine._qpos_at : engine._qpos_at + engine.nq]
        data.qvel[:] = state[i, engine._qvel_at : engine._qvel_at + engine.nv]
        mujoco.mj_forward(model, data)  # the reset's set_state
        for t in range(n_steps):
            ref_obs, ref_reward, ref_done = step(model, data, actions[t, i].astype(np.float64))
            assert _relative(obs[t, i], ref_obs).max() <= TOLERANCE, (i, t)
            assert _relative(reward[t, i], np.asarray(ref_reward)).max() <= TOLERANCE, (i, t)
            assert done[t, i] == ref_done, (i, t)


# ----------------------------------------------------------------- rewards by hand


def _hand_step(name, qpos=None, qvel=None, move=0.0, action=None):
    """`(reward, done)` of `name`'s reward function from a state set by hand: `qpos`,
    `qvel` updates `{index: value}` to the initial state, a forward move over the step
    (`move`: the change of `qpos[0]`; for the ant the torso's `(dx, dy)`; for the
    humanoid every body's dx), and the (already clipped) action."""
    env = envs.make(name)
    q = np.array(env.mj_model.qpos0, np.float64)
    v = np.zeros(env.mj_model.nv)
    for i, x in (qpos or {}).items():
        q[i] = x
    data = env.engine.host_data(q, v)
    for i, x in (qvel or {}).items():
        data = data.replace(qvel=data.qvel.at[i].set(x))
    action = jnp.asarray(np.zeros(env.action_size) if action is None else action, jnp.float32)
    dqpos = jnp.zeros(env.mj_model.nq, jnp.float32)
    if name.startswith("ant"):
        change = np.zeros(data.change.shape, np.float32).reshape(-1, 3)
        change[1, :2] = move  # body 1, the torso
        data = data.replace(change=jnp.asarray(change.ravel()))
    elif name.startswith("humanoid"):
        change = np.zeros(data.change.shape, np.float32)
        change[: 3 * env.mj_model.nbody : 3] = move  # xipos's x column, every body
        data = data.replace(change=jnp.asarray(change))
    else:
        dqpos = dqpos.at[0].set(move)
    reward, done, _ = env.transition(data, data, dqpos, action)
    return np.asarray(reward), float(done)


# (name, qpos updates, qvel updates, move, action, reward, done), the rewards worked out
HAND = [
    # walker2d-pgmorl, dt = 0.008: [v + 1, 4 - sum(a^2) + 1]
    # 0.02 m in a step: v = 2.5; sum a^2 = 0.25 + 0.25 = 0.5
    ("walker2d-pgmorl", {}, {}, 0.02, [0.5, -0.5, 0, 0, 0, 0], [3.5, 4.5], 0),
    # height 0.75 < 0.8: a fall, still paid the alive bonus; v = -1
    ("walker2d-pgmorl", {1: 0.75}, {}, -0.008, None, [0.0, 5.0], 1),
    # angle -1.2 < -1: a fall; every torque at 1: sum a^2 = 6, energy 5 - 6 = -1
    ("walker2d-pgmorl", {2: -1.2}, {}, 0.0, [1] * 6, [1.0, -1.0], 1),
    # halfcheetah-pgmorl, dt = 0.05: [min(4, v) + 1, 5 - sum(a^2)]
    # v = 0.1 / 0.05 = 2; sum a^2 = 1 + 0.25 = 1.25; angle 0.5 rad = 28.6 degrees
    ("halfcheetah-pgmorl", {2: 0.5}, {}, 0.1, [1, 0, 0, 0, 0, -0.5], [3.0, 3.75], 0),
    # v = 6 earns the cap: 4 + 1; angle 0.9 rad = 51.6 degrees: a flip
    ("halfcheetah-pgmorl", {2: 0.9}, {}, 0.3, None, [5.0, 5.0], 1),
    # v = -3: -3 + 1; angle -0.87 rad = -49.8 degrees: not yet; sum a^2 = 6
    ("halfcheetah-pgmorl", {2: -0.87}, {}, -0.15, [1] * 6, [-2.0, -1.0], 0),
    # halfcheetah-cola: [0.5 v + 1, 5 - sum(a^2)], the same three states
    ("halfcheetah-cola", {2: 0.5}, {}, 0.1, [1, 0, 0, 0, 0, -0.5], [2.0, 3.75], 0),
    ("halfcheetah-cola", {2: 0.9}, {}, 0.3, None, [4.0, 5.0], 1),  # 0.5 * 6 + 1, no cap
    ("halfcheetah-cola", {2: -0.87}, {}, -0.15, [1] * 6, [-0.5, -1.0], 0),
    # hopper-pgmorl, dt = 0.01, z0 = 1.25: [1.5 v, 12 (z - z0)] + 1 - 2e-4 sum(a^2)
    # v = 2, z = 1.5; a at the box's corner: sum a^2 = 4 + 4 + 16 = 24, cost 0.0048:
    # [3 + 1 - 0.0048, 3 + 1 - 0.0048]
    ("hopper-pgmorl", {1: 1.5}, {}, 0.02, [2, -2, 4], [3.9952, 3.9952], 0),
    # z = 0.39 <= 0.4: a fall; 12 * (0.39 - 1.25) + 1 = -9.32
    ("hopper-pgmorl", {1: 0.39}, {}, 0.0, None, [1.0, -9.32], 1),
    # z = 0.41 > 0.4: still up (v5's hopper ends below 0.7); 12 * (0.41 - 1.25) + 1
    ("hopper-pgmorl", {1: 0.41}, {}, 0.0, None, [1.0, -9.08], 0),
    # the leg joint at -1.6 rad, past 90 degrees: ended; v = -1: -1.5 + 1 - 0.0002
    ("hopper-pgmorl", {4: -1.6}, {}, -0.01, [1, 0, 0], [-0.5002, 0.9998], 1),
    # hopper3-pgmorl: [1.5 v + 1, 12 (z - z0) + 1, 5 - sum(a^2)], the same three states
    ("hopper3-pgmorl", {1: 1.5}, {}, 0.02, [2, -2, 4], [4.0, 4.0, -19.0], 0),
    ("hopper3-pgmorl", {1: 0.39}, {}, 0.0, None, [1.0, -9.32, 5.0], 1),
    ("hopper3-pgmorl", {1: 0.41}, {}, 0.0, None, [1.0, -9.08, 5.0], 0),
    ("hopper3-pgmorl", {4: -1.6}, {}, -0.01, [1, 0, 0], [-0.5, 1.0, 4.0], 1),
    # ant-pgmorl, dt = 0.05: [vx, vy] + 1 - 0.5 sum(a^2)
    # (vx, vy) = (2, 1); sum a^2 = 8 * 0.25 = 2, cost 1
    ("ant-pgmorl", {}, {}, (0.1, 0.05), [0.5] * 8, [2.0, 1.0], 0),
    # (vx, vy) = (-4, 0); sum a^2 = 8, cost 4; a torso 0.1 m up still goes on
    ("ant-pgmorl", {2: 0.1}, {}, (-0.2, 0.0), [1] * 8, [-7.0, -3.0], 0),
    # a non-finite velocity ends it; standing still, no torque: the survive reward
    ("ant-pgmorl", {}, {0: np.inf}, (0.0, 0.0), None, [1.0, 1.0], 1),
    # ant3-cola: [vx, vy, 4 - 0.5 sum(a^2)], the same three states
    ("ant3-cola", {}, {}, (0.1, 0.05), [0.5] * 8, [2.0, 1.0, 3.0], 0),
    ("ant3-cola", {2: 0.1}, {}, (-0.2, 0.0), [1] * 8, [-4.0, 0.0, 0.0], 0),
    ("ant3-cola", {}, {0: np.inf}, (0.0, 0.0), None, [0.0, 0.0, 4.0], 1),
    # swimmer-pgmorl, dt = 0.04: [v, 0.3 - 0.15 sum(a^2)], never done
    # v = 0.5; sum a^2 = 2: 0.3 - 0.3
    ("swimmer-pgmorl", {}, {}, 0.02, [1, -1], [0.5, 0.0], 0),
    # v = -0.1; sum a^2 = 0.25: 0.3 - 0.0375
    ("swimmer-pgmorl", {}, {}, -0.004, [0.5, 0], [-0.1, 0.2625], 0),
    ("swimmer-pgmorl", {2: 1.0}, {}, 0.0, None, [0.0, 0.3], 0),
    # humanoid-pgmorl, dt = 0.015: [1.25 v + 3, 6 - 4 sum(u^2)]
    # the centre of mass 0.03 m forward: v = 2, 2.5 + 3; sum u^2 = 17 * 0.04 = 0.68
    ("humanoid-pgmorl", {}, {}, 0.03, [0.2] * 17, [5.5, 3.28], 0),
    # torso height 0.9 < 1: a fall, still paid the alive bonus
    ("humanoid-pgmorl", {2: 0.9}, {}, 0.0, None, [3.0, 6.0], 1),
    # height 2.1 > 2 ends it too; v = -1: -1.25 + 3; every control at 0.4: 6 - 10.88
    ("humanoid-pgmorl", {2: 2.1}, {}, -0.015, [0.4] * 17, [1.75, -4.88], 1),
]


@pytest.mark.parametrize("case", HAND, ids=lambda c: c[0])
def test_rewards_by_hand(case):
    name, qpos, qvel, move, action, reward, done = case
    got, got_done = _hand_step(name, qpos, qvel, move, action)
    np.testing.assert_allclose(got, reward, rtol=1e-6, atol=1e-6)
    assert got_done == done


@pytest.mark.parametrize("name", list(CASES))
def test_a_step_clips_the_action_to_the_box(name):
    """An action outside the box steps and pays as the clipped one: the same state and
    rewards, and the energy term of the clipped action (worked out per task below)."""
    env = envs.make(name)
    bound = np.broadcast_to(np.asarray(env.action_bound, np.float32), (env.action_size,))
    sign = np.where(np.arange(env.action_size) % 2 == 0, 1.0, -1.0).astype(np.float32)
    start = jax.jit(env.reset)(jax.random.key(0))
    step = jax.jit(env.step)
    wild, clipped = step(start, 3.0 * bound * sign), step(start, bound * sign)
    np.testing.assert_array_equal(wild.obs, clipped.obs)
    np.testing.assert_array_equal(wild.reward, clipped.reward)
    # the energy reward at the box's corner: sum a^2 = 6 (walker2d, halfcheetah), 24
    # (hopper: 4 + 4 + 16), 8 (ant), 2 (swimmer), 17 * 0.16 = 2.72 (humanoid)
    corner = {
        "walker2d-pgmorl": 5.0 - 6.0,
        "halfcheetah-pgmorl": 5.0 - 6.0,
        "halfcheetah-cola": 5.0 - 6.0,
        "hopper3-pgmorl": 5.0 - 24.0,
        "ant3-cola": 4.0 - 0.5 * 8.0,
        "swimmer-pgmorl": 0.3 - 0.15 * 2.0,
        "humanoid-pgmorl": 6.0 - 4.0 * 2.72,
    }
    if name in corner:
        assert float(wild.reward[-1]) == pytest.approx(corner[name], abs=1e-5)
    assert float(wild.metrics["reward_ctrl"]) == pytest.approx(-float(np.sum(bound**2)))


# ----------------------------------------------------------------- the models

# MuJoCo's XML writer (`mj_saveLastXML`, which converted three of the files) prints six
# significant digits: joint ranges written in degrees become radians rounded to six digits
# (walker2d's -150 degrees, -2.6179939, is written -2.61799: 1.5e-6 relative), at most
# half a unit in the sixth digit, 5e-6 relative. Every other compiled value is written
# exactly (decimal lengths, positions, densities) and agrees to float64 rounding.
JOINT_RANGE_RTOL = 5e-6
RTOL = 1e-12


@pytest.fixture(scope="module")
def published_compile():
    with open(FIXTURE) as f:
        return json.load(f)


def test_the_fixture_is_mujoco_233s_compile(published_compile):
    assert published_compile["mujoco"] == "2.3.3"
    assert sorted(k for k in published_compile if k != "mujoco") == sorted(PUBLISHED)


@pytest.mark.parametrize("shipped", sorted(PUBLISHED))
def test_shipped_model_compiles_as_the_published_one_did(shipped, published_compile):
    """MuJoCo 4's compile of each shipped file against MuJoCo 2.3.3's of the published
    file: masses, inertias, body frames, joints (damping, armature, stiffness, ranges),
    gears and control ranges, friction, geom sizes, solver and fluid settings; and the
    swimmer finds no contact, as `collision="predefined"` without pairs gave it."""
    theirs = published_compile[shipped]
    ours = compiled(load_model(asset(shipped)))
    assert set(ours) == set(theirs)
    for field, value in theirs.items():
        if field == "max_contacts":
            assert (ours[field] == 0) == (value == 0), field
            continue
        rtol = JOINT_RANGE_RTOL if field == "jnt_range" else RTOL
        np.testing.assert_allclose(ours[field], value, rtol=rtol, atol=1e-15, err_msg=field)
    if shipped == "swimmer_pgmorl.xml":
        assert ours["max_contacts"] == value == 0


def test_published_facts_of_the_models():
    """What the tasks are known by, read from the compiled models: walker2d's density
    1500 (total mass 35.5 kg), damping 3, right-foot friction 0.9; the hopper's damping
    40, no joint limits, gears 200/200/300 and control ranges 2/2/4; the ant's gear 100;
    the swimmer's gear 300."""
    walker = load_model(asset("walker2d_pgmorl.xml"))
    assert mujoco.mj_getTotalmass(walker) == pytest.approx(35.5157, abs=1e-4)
    hinge = walker.jnt_type == mujoco.mjtJoint.mjJNT_HINGE
    assert np.all(walker.dof_damping[3:] == 3.0) and np.all(walker.jnt_limited[hinge][1:])
    foot = mujoco.mj_name2id(walker, mujoco.mjtObj.mjOBJ_GEOM, "foot_geom")
    foot_left = mujoco.mj_name2id(walker, mujoco.mjtObj.mjOBJ_GEOM, "foot_left_geom")
    assert walker.geom_friction[foot, 0] == 0.9 and walker.geom_friction[foot_left, 0] == 1.9
    hopper = load_model(asset("hopper_pgmorl.xml"))
    assert np.all(hopper.dof_damping[3:] == 40.0) and not hopper.jnt_limited.any()
    np.testing.assert_array_equal(hopper.actuator_gear[:, 0], [200, 200, 300])
    np.testing.assert_array_equal(hopper.actuator_ctrlrange[:, 1], [2, 2, 4])
    assert np.all(load_model(asset("ant_pgmorl.xml")).actuator_gear[:, 0] == 100)
    assert np.all(load_model(asset("swimmer_pgmorl.xml")).actuator_gear[:, 0] == 300)


@pytest.mark.parametrize("name", list(CASES))
def test_declarations(name):
    """Sizes, frame skips, time limits and resets as published; the clip box is the
    model's control range; the utopia and reference points agree with each other."""
    env = envs.make(name)
    base.check(env)
    sizes = {
        "walker2d": (17, 6, 0.008),
        "halfcheetah": (17, 6, 0.05),
        "hopper": (11, 3, 0.01),
        "hopper3": (11, 3, 0.01),
        "ant": (27, 8, 0.05),
        "ant3": (27, 8, 0.05),
        "swimmer": (8, 2, 0.04),
        "humanoid": (376, 17, 0.015),
    }[name.split("-")[0]]
    assert (env.observation_size, env.action_size) == sizes[:2]
    assert env.dt == pytest.approx(sizes[2])
    assert env.num_objectives == (3 if name in ("hopper3-pgmorl", "ant3-cola") else 2)
    assert env.episode_length == (1000 if name == "humanoid-pgmorl" else 500)
    bound = np.broadcast_to(env.action_bound, (env.action_size,))
    np.testing.assert_array_equal(env.mj_model.actuator_ctrlrange[:, 1], bound)
    np.testing.assert_array_equal(env.mj_model.actuator_ctrlrange[:, 0], -bound)
    # resets: the initial state exactly, but for the humanoid's noise of 0.01
    states = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(0), 4))
    qpos = np.asarray(states.pipeline_state.qpos)
    offset = np.abs(qpos - env.mj_model.qpos0.astype(np.float32)).max()
    if name == "humanoid-pgmorl":
        assert 0.005 < offset <= 0.01
    else:
        assert offset == 0.0 and not np.asarray(states.pipeline_state.qvel).any()
    assert states.obs.shape == (4, env.observation_size)


# ----------------------------------------------------------------- HalfCheetah's cap


def test_halfcheetah_pgmorl_pays_no_more_than_4_m_per_s():
    """Running faster than 4 m/s earns what 4 m/s earns, so no 500-step return exceeds
    2,500 on either objective and no front's hypervolume from the origin exceeds
    2,500 x 2,500 = 6.25e6; COLA's cheetah has no cap."""
    at_4, _ = _hand_step("halfcheetah-pgmorl", move=0.2)  # 4 m/s: 4 + 1
    at_6, _ = _hand_step("halfcheetah-pgmorl", move=0.3)  # 6 m/s: min(4, 6) + 1
    at_10, _ = _hand_step("halfcheetah-pgmorl", move=0.5)
    assert at_4[0] == at_6[0] == at_10[0] == pytest.approx(5.0)
    cola_4, _ = _hand_step("halfcheetah-cola", move=0.2)  # 0.5 * 4 + 1 = 3
    cola_6, _ = _hand_step("halfcheetah-cola", move=0.3)  # 0.5 * 6 + 1 = 4
    assert cola_4[0] == pytest.approx(3.0) and cola_6[0] == pytest.approx(4.0)
    # a cheetah sliding forward at 8 m/s: its step's speed is above 4, its reward the cap
    env = envs.make("halfcheetah-pgmorl")
    qvel = np.zeros((1, env.mj_model.nv))
    qvel[0, 0] = 8.0
    fast = our_steps("halfcheetah-pgmorl", env.mj_model.qpos0[None], qvel, np.zeros((1, 6)))
    assert float(fast.metrics["x_velocity"][0]) > 4.0
    assert float(fast.reward[0, 0]) == 5.0
    # each objective pays at most 5 a step, at any speed and any action
    forward = [_hand_step("halfcheetah-pgmorl", move=0.05 * v)[0][0] for v in range(-10, 21)]
    assert max(forward) == pytest.approx(5.0) and np.all(np.asarray(forward) <= 5.0)
    rng = np.random.default_rng(0)
    for action in rng.uniform(-1.0, 1.0, (10, 6)):
        assert _hand_step("halfcheetah-pgmorl", action=action)[0][1] <= 5.0
    # so a 500-step return is at most 2,500 on each, and every front is dominated by
    # (2,500, 2,500), whose hypervolume from the origin is 6.25e6
    best = 5.0 * env.episode_length
    assert env.episode_length == 500 and env.default_j_ub[0] > best
    assert pareto.hypervolume([[best, best]], [0.0, 0.0]) == 6.25e6


def test_the_policy_reaches_the_hoppers_whole_box():
    """The Gaussian's `[-1, 1]^3` reaches `hopper-pgmorl` as its `[-2, 2] x [-2, 2] x
    [-4, 4]`."""
    from wcac_jax import networks, runtime

    env = envs.make("hopper-pgmorl")
    policy = runtime.make_policy(env, lambda out: networks.paper_network(4, out, 4, 1), 0.0, True)
    np.testing.assert_allclose(policy.to_env(jnp.array([5.0, -5.0, 5.0])), [2.0, -2.0, 4.0])


def _capsule_rule_20(model) -> float:
    """The model's total mass under MuJoCo 2.0's rule (before 2.1.1): each capsule of radius
    `r` and half-length `h` as a cylinder of length `2h + r`, `pi r^2 (2h + r)`, instead of
    its exact volume `pi r^2 (2h + 4r/3)`; one density per model, as in these files."""
    exact = old = 0.0
    for g in np.flatnonzero(model.geom_bodyid > 0):
        r, h = model.geom_size[g, :2]
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE:
            exact += math.pi * r * r * (2 * h + 4 * r / 3)
            old += math.pi * r * r * (2 * h + r)
        else:  # spheres are exact in both
            assert model.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE
            exact += 4 / 3 * math.pi * r**3
            old += 4 / 3 * math.pi * r**3
    return mujoco.mj_getTotalmass(model) * old / exact


def test_the_papers_robots_were_lighter_under_mujoco_20():
    """The masses `docs/environments.md` states for MuJoCo 2.0. The walker by hand,
    density 1500, capsules (r, h): torso (0.05, 0.2), thighs (0.05, 0.225), legs (0.04,
    0.25), feet (0.06, 0.1); under the cylinder rule 1500 pi r^2 (2h + r) gives 5.3014 +
    2 (5.8905 + 4.0715 + 4.4107) = 34.047 kg, against 35.516 exactly."""
    stated = {
        "walker2d_pgmorl.xml": (34.047, 35.516),
        "hopper_pgmorl.xml": (15.265, 15.820),
        "ant_pgmorl.xml": (0.8787, 0.9109),
        "swimmer_pgmorl.xml": (103.67, 106.814),
        "humanoid_pgmorl.xml": (39.646, 42.116),
    }
    for shipped, (then, now) in stated.items():
        model = load_model(asset(shipped))
        assert mujoco.mj_getTotalmass(model) == pytest.approx(now, abs=1e-3), shipped
        assert _capsule_rule_20(model) == pytest.approx(then, rel=1e-4), shipped


@pytest.mark.slow
def test_hopper_pgmorl_on_mjx_steps_as_on_mujocos_engine():
    """MJX (float32, solver capped at 4 iterations) against MuJoCo's C engine on the
    model furthest from v5's: 2 copies, 3 random steps of the whole box from the exact
    reset. Measured: observations 4.8e-7 apart, rewards 2.9e-6."""
    mjx_env = envs.make("hopper-pgmorl", engine="mjx")
    c_env = envs.make("hopper-pgmorl")
    assert mjx_env.backend == "mjx" and mjx_env.mj_model.opt.iterations == 4
    keys = jax.random.split(jax.random.key(0), 2)
    on_mjx, on_c = jax.jit(jax.vmap(mjx_env.reset))(keys), jax.jit(jax.vmap(c_env.reset))(keys)
    step_mjx, step_c = jax.jit(jax.vmap(mjx_env.step)), jax.jit(jax.vmap(c_env.step))
    bound = np.asarray(c_env.action_bound, np.float32)
    for k in jax.random.split(jax.random.key(1), 3):
        action = jax.random.uniform(k, (2, 3), minval=-bound, maxval=bound)
        on_mjx, on_c = step_mjx(on_mjx, action), step_c(on_c, action)
    np.testing.assert_allclose(on_mjx.obs, on_c.obs, rtol=0, atol=1e-5)
    np.testing.assert_allclose(on_mjx.reward, on_c.reward, rtol=0, atol=2e-5)
    assert np.abs(np.asarray(on_c.metrics["x_velocity"])).max() > 0.01  # it moved


def test_humanoid_pgmorl_on_mjx_is_refused_in_one_line():
    with pytest.raises(ValueError, match=r"engine='mujoco' only: MJX cannot load.*PGS"):
        envs.make("humanoid-pgmorl", engine="mjx")
