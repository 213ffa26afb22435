"""Multi-objective Walker2d with the semantics of MO-Gymnasium's `mo-walker2d-v5`: the
model, the objectives and the health check; a physics engine (`engines`) steps it.

A Brax-style `Env` (`reset`, `step`, one unbatched copy). One step applies the action (6 torques in
`[-1, 1]`) for 4 physics substeps of 0.002 s (`dt = 0.008`), and returns

- observation (17): `qpos[1:]` (torso height and angle, 6 joint angles) and
  `clip(qvel, -10, 10)` (9 velocities), as Gymnasium v5; the torso height is the world
  height in both models (Brax's model measures `rootz` from 1.25 m, v5's from 0);
- reward vector (2): `[x_velocity, -sum(a^2)] + healthy_reward`, where `x_velocity` is the
  torso's forward speed in m/s over the step, `-sum(a^2)` the (negated) control energy,
  and `healthy_reward = 1` while the walker is healthy and 0 on the step it falls (the v5
  fix; Brax's own walker pays it on that step too). Falling therefore costs every
  objective. Reward terms are also in `State.metrics`;
- `done = 1` when the walker is unhealthy: torso height outside `(0.8, 2.0)` or
  torso angle `qpos[2]` outside `(-1, 1)` (strict, as Gymnasium). The time limit
  (`episode_length`, default 500 as in the paper; MO-Gymnasium uses 1000) is applied by
  `EpisodeWrapper`, which training wraps every environment with.

Resets add uniform noise in `[-5e-3, 5e-3]` to the initial positions and velocities.

Two physics models (`physics=`):

- `"brax"` (default, fast): Brax's walker2d model (Euler integrator, 4 solver
  iterations, right-foot friction 0.9), MJX's default line search.
- `"gymnasium-v5"`: Gymnasium's `walker2d_v5.xml`, shipped in `assets/` with its MIT
  notice (RK4 integrator, friction 1.9 on both feet): the model the paper and
  MO-Gymnasium use. On MJX its solver is capped at 4 iterations and 4 line-search
  iterations (MuJoCo's defaults are 100 and 50; the `"mujoco"` engine keeps those).
  Measured on the 2-core CPU with `experiments/bench_env.py`, the cap makes MJX
  2.3-4.7x faster (batch 16: 1,386 vs 604 env-steps/s; batch 1,024: 1,634 vs 347) and
  costs no measurable fidelity: MuJoCo's Newton solver converges within a few
  iterations on this model, so `qpos` under the same random actions is bit-identical
  for 50 steps and within 1.4e-6 after 100, and the one-step conformance test against
  `mo_gymnasium.make("mo-walker2d-v5")` passes with the cap (positions within 5.5e-6,
  velocities within 1e-4 on 99% of 320 states and 6.6e-4 at worst, rewards within
  4.8e-5). `solver_iterations=100, ls_iterations=50` restores MuJoCo's settings.

`"brax"` and `"gymnasium-v5"` are different models: from the same state under the same
random actions their `qpos` differ by 0.009 after one step and by ~1 after 100 steps.

Two engines (`engine=`), either model with either engine (`engines` explains them):

- `"mjx"` (default): MJX in float32 through Brax's MJX pipeline; the path for
  accelerators.
- `"mujoco"`: MuJoCo's C engine in float64, every environment of a step in one
  multi-threaded `mujoco.rollout` call from inside the compiled program; several times
  faster on a CPU. It keeps the model's own solver settings (for `"gymnasium-v5"`:
  MuJoCo's 100 iterations and 50 line-search iterations, as MO-Gymnasium), so with
  `physics="gymnasium-v5"` it is MO-Gymnasium's environment up to float32 rounding of
  observations and rewards.
"""

from __future__ import annotations

import os

import jax
import jax.numpy as jnp
import mujoco
from brax.envs.base import Env, State

from wcac_jax.envs import engines
from wcac_jax.envs.engines import ENGINES

PHYSICS = ("brax", "gymnasium-v5")
OBJECTIVE_NAMES = ("forward_velocity", "control")
DEFAULT_J_UB = (2000.0, 1000.0)  # the paper's utopia point for this task


def model_path(physics: str) -> str:
    """Path of the MJCF file behind a `physics` name."""
    if physics == "brax":
        import brax

        return os.path.join(os.path.dirname(brax.__file__), "envs", "assets", "walker2d.xml")
    if physics == "gymnasium-v5":
        return os.path.join(os.path.dirname(__file__), "assets", "walker2d_v5.xml")
    raise ValueError(f"unknown physics {physics!r}; valid: {', '.join(PHYSICS)}")


def load_mj_model(
    physics: str, solver_iterations: int | None = None, ls_iterations: int | None = None
) -> mujoco.MjModel:
    """The MuJoCo model of `physics`, with optional solver overrides."""
    model = mujoco.MjModel.from_xml_path(model_path(physics))
    if solver_iterations is not None:
        model.opt.iterations = solver_iterations
    if ls_iterations is not None:
        model.opt.ls_iterations = ls_iterations
    return model


class Walker2d(Env):
    """Multi-objective Walker2d; see the module docstring.

    Args:
      physics: `"brax"` or `"gymnasium-v5"`.
      episode_length: time limit in steps, `>= 1` (applied by `EpisodeWrapper`).
      engine: `"mjx"` or `"mujoco"`.
      reset_noise_scale: half-width of the uniform reset noise.
      solver_iterations: MuJoCo's `opt.iterations` (`None`: 4 for `"gymnasium-v5"` on
        MJX, otherwise the model's own: 4 for `"brax"`, 100 for `"gymnasium-v5"`).
      ls_iterations: MuJoCo's `opt.ls_iterations` (`None`: 4 for `"gymnasium-v5"` on
        MJX, otherwise the model's own).
    """

    num_objectives = 2
    objective_names = OBJECTIVE_NAMES
    default_j_ub = DEFAULT_J_UB

    def __init__(
        self,
        physics: str = "brax",
        episode_length: int = 500,
        engine: str = "mjx",
        reset_noise_scale: float = 5e-3,
        solver_iterations: int | None = None,
        ls_iterations: int | None = None,
    ):
        if physics not in PHYSICS:
            raise ValueError(f"unknown physics {physics!r}; valid: {', '.join(PHYSICS)}")
        if engine not in ENGINES:
            raise ValueError(f"unknown engine {engine!r}; valid: {', '.join(ENGINES)}")
        if isinstance(episode_length, bool) or not isinstance(episode_length, int):
            raise ValueError(f"episode_length must be a positive integer, got {episode_length!r}")
        if episode_length < 1:
            raise ValueError(f"episode_length must be a positive integer, got {episode_length!r}")
        for name, value in (
            ("solver_iterations", solver_iterations),
            ("ls_iterations", ls_iterations),
        ):
            if value is not None and (not isinstance(value, int) or value < 1):
                raise ValueError(f"{name} must be a positive integer or None, got {value!r}")
        if not reset_noise_scale >= 0:
            raise ValueError(f"reset_noise_scale must be >= 0, got {reset_noise_scale!r}")
        if physics == "gymnasium-v5" and engine == "mjx":
            solver_iterations = 4 if solver_iterations is None else solver_iterations
            ls_iterations = 4 if ls_iterations is None else ls_iterations
        self.physics = physics
        self.episode_length = episode_length
        # hypervolume reference, per objective a floor per step times the time limit:
        # control -6 (its least reward: sum a^2 <= 6, healthy reward >= 0); forward -1
        # (x_velocity + healthy has no physical floor: -1 is walking backwards at 2 m/s
        # for the whole episode, far below any policy's return so far)
        self.default_hv_ref = (-1.0 * episode_length, -6.0 * episode_length)
        self._noise = float(reset_noise_scale)
        mj_model = load_mj_model(physics, solver_iterations, ls_iterations)
        data = mujoco.MjData(mj_model)
        mujoco.mj_forward(mj_model, data)
        torso = mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_BODY, "torso")
        # world torso height minus the rootz coordinate: 1.25 for Brax's model, 0 for v5
        self._z_offset = float(data.xpos[torso, 2] - data.qpos[1])
        self.engine = engines.make(engine, mj_model, n_frames=4)
        self.dt = self.engine.dt

    def reset(self, rng: jax.Array) -> State:
        key_q, key_qd = jax.random.split(rng)
        lo, hi = -self._noise, self._noise
        nq, nv = self.engine.nq, self.engine.nv
        qpos = jnp.asarray(self.engine.init_qpos) + jax.random.uniform(
            key_q, (nq,), minval=lo, maxval=hi
        )
        qvel = jax.random.uniform(key_qd, (nv,), minval=lo, maxval=hi)
        data = self.engine.init(qpos, qvel)
        zero = jnp.zeros((), jnp.float32)
        metrics = self._metrics(zero, zero, zero, data.qpos[0])
        return State(data, self._obs(data), jnp.zeros(2, jnp.float32), zero, metrics)

    def step(self, state: State, action: jax.Array) -> State:
        data, dqpos = self.engine.step(state.pipeline_state, action)
        x_velocity = dqpos[0] / self.dt
        healthy = self.is_healthy(self._qpos(data)).astype(jnp.float32)
        ctrl = -jnp.sum(jnp.square(action))
        reward = jnp.stack([x_velocity, ctrl]) + healthy
        metrics = self._metrics(x_velocity, ctrl, healthy, data.qpos[0])
        return state.replace(
            pipeline_state=data,
            obs=self._obs(data),
            reward=reward,
            done=1.0 - healthy,
            metrics=metrics,
        )

    def pipeline_init(self, qpos: jax.Array, qvel: jax.Array):
        """The engine's physics state at `qpos [9]`, `qvel [9]` (in the model's own
        `rootz` convention), e.g. to step from a given state."""
        return self.engine.init(qpos, qvel)

    @staticmethod
    def _metrics(x_velocity, ctrl, healthy, x_position) -> dict:
        """Each reward term separately (in `State.metrics`)."""
        return {
            "reward_forward": x_velocity,
            "reward_ctrl": ctrl,
            "reward_healthy": healthy,
            "x_position": x_position,
            "x_velocity": x_velocity,
        }

    @staticmethod
    def is_healthy(qpos: jax.Array) -> jax.Array:
        """Torso height `qpos[1]` in `(0.8, 2.0)` and angle `qpos[2]` in `(-1, 1)`.

        `qpos` `[9]` in Gymnasium v5's convention (`qpos[1]` is the world height).
        """
        z, angle = qpos[1], qpos[2]
        return (z > 0.8) & (z < 2.0) & (angle > -1.0) & (angle < 1.0)

    def _qpos(self, data) -> jax.Array:
        """`qpos` in v5's convention: `rootz` as the torso's world height."""
        return data.qpos.at[1].add(self._z_offset)

    def _obs(self, data) -> jax.Array:
        qvel = jnp.clip(data.qvel, -10.0, 10.0)
        return jnp.concatenate([self._qpos(data)[1:], qvel])

    @property
    def observation_size(self) -> int:
        return 17

    @property
    def action_size(self) -> int:
        return 6

    @property
    def backend(self) -> str:
        return self.engine.name
