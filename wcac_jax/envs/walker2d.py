"""Multi-objective Walker2d with the semantics of MO-Gymnasium's `mo-walker2d-v5`: the
models, the objectives and the health check (`mujoco_base.MujocoEnv` does the rest: model
loading, the engines, resets, frame skip, the height convention, rendering).

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

- `"gymnasium-v5"` (default): Gymnasium's `walker2d_v5.xml`, shipped in `assets/` with
  its MIT notice (RK4 integrator, friction 1.9 on both feet): the model the paper and
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
- `"brax"` (fast on MJX): Brax's walker2d model (Euler integrator, 4 solver iterations,
  right-foot friction 0.9), MJX's default line search.

`"brax"` and `"gymnasium-v5"` are different models: from the same state under the same
random actions their `qpos` differ by 0.009 after one step and by ~1 after 100 steps.

Two engines (`engine=`), either model with either engine (`engines` explains them):

- `"mujoco"` (default): MuJoCo's C engine in float64, every environment of a step in one
  multi-threaded `mujoco.rollout` call from inside the compiled program; several times
  faster on a CPU. It keeps the model's own solver settings (for `"gymnasium-v5"`:
  MuJoCo's 100 iterations and 50 line-search iterations, as MO-Gymnasium), so with
  `physics="gymnasium-v5"` it is MO-Gymnasium's environment up to float32 rounding of
  observations and rewards.
- `"mjx"`: MJX in float32 through Brax's MJX pipeline; the path for accelerators.

Until the command line's defaults became these, the constructor's were `"brax"` on
`"mjx"` (`envs.EARLIER_DEFAULTS`: what a run that recorded neither option ran with).
"""

from __future__ import annotations

import os

import jax
import jax.numpy as jnp
import mujoco

from wcac_jax.envs.mujoco_base import MujocoEnv, asset, load_model

PHYSICS = ("brax", "gymnasium-v5")
OBJECTIVE_NAMES = ("forward_velocity", "control")
DEFAULT_J_UB = (2000.0, 1000.0)  # the paper's utopia point for this task


def model_path(physics: str) -> str:
    """Path of the MJCF file behind a `physics` name."""
    if physics == "brax":
        import brax

        return os.path.join(os.path.dirname(brax.__file__), "envs", "assets", "walker2d.xml")
    if physics == "gymnasium-v5":
        return asset("walker2d_v5.xml")
    raise ValueError(f"unknown physics {physics!r}; valid: {', '.join(PHYSICS)}")


def load_mj_model(
    physics: str, solver_iterations: int | None = None, ls_iterations: int | None = None
) -> mujoco.MjModel:
    """The MuJoCo model of `physics`, with optional solver overrides."""
    return load_model(model_path(physics), solver_iterations, ls_iterations)


class Walker2d(MujocoEnv):
    """Multi-objective Walker2d; see the module docstring.

    Args:
      physics: `"gymnasium-v5"` or `"brax"`.
      episode_length: time limit in steps, `>= 1` (applied by `EpisodeWrapper`).
      engine: `"mujoco"` or `"mjx"`.
      reset_noise_scale: half-width of the uniform reset noise.
      solver_iterations: MuJoCo's `opt.iterations` (`None`: 4 for `"gymnasium-v5"` on
        MJX, otherwise the model's own: 4 for `"brax"`, 100 for `"gymnasium-v5"`).
      ls_iterations: MuJoCo's `opt.ls_iterations` (`None`: 4 for `"gymnasium-v5"` on
        MJX, otherwise the model's own).
    """

    objective_names = OBJECTIVE_NAMES
    default_j_ub = DEFAULT_J_UB
    frame_skip = 4
    height_body = "torso"

    def __init__(
        self,
        physics: str = "gymnasium-v5",
        episode_length: int = 500,
        engine: str = "mujoco",
        reset_noise_scale: float = 5e-3,
        solver_iterations: int | None = None,
        ls_iterations: int | None = None,
    ):
        if physics not in PHYSICS:
            raise ValueError(f"unknown physics {physics!r}; valid: {', '.join(PHYSICS)}")
        super().__init__(
            model_path(physics),
            engine,
            episode_length,
            reset_noise_scale,
            solver_iterations,
            ls_iterations,
            cap_mjx_solver=physics == "gymnasium-v5",
        )
        self.physics = physics
        # hypervolume reference, per objective a floor per step times the time limit:
        # control -6 (its least reward: sum a^2 <= 6, healthy reward >= 0); forward -1
        # (x_velocity + healthy has no physical floor: -1 is walking backwards at 2 m/s
        # for the whole episode, far below any policy's return so far)
        self.default_hv_ref = (-1.0 * episode_length, -6.0 * episode_length)

    def outcome(self, data, dqpos: jax.Array, action: jax.Array):
        x_velocity = dqpos[0] / self.dt
        healthy = self.is_healthy(self.qpos(data)).astype(jnp.float32)
        ctrl = -jnp.sum(jnp.square(action))
        reward = jnp.stack([x_velocity, ctrl]) + healthy
        return reward, 1.0 - healthy, self._metrics(x_velocity, ctrl, healthy, data.qpos[0])

    def reset_metrics(self, data) -> dict:
        zero = jnp.zeros((), jnp.float32)
        return self._metrics(zero, zero, zero, data.qpos[0])

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

    def observation(self, data) -> jax.Array:
        qvel = jnp.clip(data.qvel, -10.0, 10.0)
        return jnp.concatenate([self.qpos(data)[1:], qvel])

    @property
    def observation_size(self) -> int:
        return 17

    @property
    def action_size(self) -> int:
        return 6
