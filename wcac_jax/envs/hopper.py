"""Multi-objective Hopper with the semantics of MO-Gymnasium's `mo-hopper-v5` (`hopper`,
3 objectives) and `mo-hopper-2obj-v5` (`hopper-2obj`, 2 objectives): the model, the
observation, the reward vector and the health check (`mujoco_base.MujocoEnv` does the
rest: the engines, resets, frame skip, rendering).

Gymnasium's `hopper_v5.xml` (in `assets/`, MIT notice in `assets/NOTICE`; RK4, 0.002 s
timestep). One step applies the action (3 torques in `[-1, 1]`) for 4 substeps
(`dt = 0.008`), and returns

- observation (11): `qpos[1:]` (torso height and angle, 3 joint angles) and
  `clip(qvel, -10, 10)` (6 velocities), as Gymnasium's Hopper-v5;
- reward vector, with `x_velocity` the torso's forward speed over the step (m/s),
  `height = 10 (z - 1.25)` ten times the torso's height above its initial 1.25 m,
  `healthy = 1` while healthy and 0 on the step it falls:
  - `hopper`: `[x_velocity, height, -sum(a^2)] + healthy`;
  - `hopper-2obj`: `[x_velocity, height] - 1e-3 sum(a^2) + healthy` (the control cost at
    Hopper-v5's weight enters both objectives, as MO-Gymnasium's 2-objective version);
- `done = 1` when the hopper is unhealthy: torso height `z <= 0.7`, torso angle
  `qpos[2]` outside `(-0.2, 0.2)`, or any of `qpos[2:]` and the (unclipped) `qvel`
  outside `(-100, 100)` (strict, as Gymnasium).

Resets add uniform noise in `[-5e-3, 5e-3]` to the initial positions and velocities. The
time limit (`episode_length`, default 500 as Walker2d's here; MO-Gymnasium's is 1000) is
`EpisodeWrapper`'s. Engines: `"mujoco"` (default; MO-Gymnasium's environment up to float32
rounding of observations and rewards) or `"mjx"` (solver capped as `mujoco_base` says).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from wcac_jax.envs.mujoco_base import MujocoEnv, asset

CTRL_COST_WEIGHT = 1e-3  # Hopper-v5's, with which control enters the 2-objective rewards
HEIGHT_WEIGHT = 10.0  # MO-Gymnasium's scale of the height objective
HEALTHY_Z = 0.7
HEALTHY_ANGLE = 0.2
HEALTHY_STATE = 100.0


class Hopper(MujocoEnv):
    """`mo-hopper-v5`: forward velocity, height, control; see the module docstring.

    Args:
      episode_length: time limit in steps, `>= 1` (applied by `EpisodeWrapper`).
      engine: `"mujoco"` or `"mjx"`.
      reset_noise_scale: half-width of the uniform reset noise.
      solver_iterations, ls_iterations: MuJoCo's solver settings (`None`: the model's
        100 and 50 on `"mujoco"`, 4 and 4 on `"mjx"`).
    """

    objective_names = ("forward_velocity", "height", "control")
    frame_skip = 4
    height_body = "torso"

    def __init__(
        self,
        episode_length: int = 500,
        engine: str = "mujoco",
        reset_noise_scale: float = 5e-3,
        solver_iterations: int | None = None,
        ls_iterations: int | None = None,
    ):
        super().__init__(
            asset("hopper_v5.xml"),
            engine,
            episode_length,
            reset_noise_scale,
            solver_iterations,
            ls_iterations,
        )
        self._init_z = float(self.engine.init_qpos[1]) + self._z_offset
        t = float(episode_length)
        # utopia, per step times the time limit: forward 5 (x_velocity + healthy: about
        # 4 m/s, above the speeds Hopper-v5 policies reach), height 5 (a hop's mean
        # torso height 0.4 m above the start, above sustained hopping), control 2 (its
        # reward is at most 1: no torque, healthy)
        # hypervolume reference, the least return of an episode, or a floor: forward
        # -1 per step (x_velocity + healthy has no physical floor: backwards at 2 m/s
        # for the whole episode); height -4.5 per healthy step (z > 0.7) and -12.5 on the
        # falling step (z >= 0, the torso above the floor); control -3 per step
        # (sum a^2 <= 3 for actions in [-1, 1], healthy >= 0)
        height_floor = HEIGHT_WEIGHT * (HEALTHY_Z - self._init_z) + 1.0
        height_fall = HEIGHT_WEIGHT * (0.0 - self._init_z)
        self._declare(
            j_ub=(5.0 * t, 5.0 * t, 2.0 * t),
            hv_ref=(-1.0 * t, height_floor * (t - 1.0) + height_fall, -3.0 * t),
        )

    def _declare(self, j_ub, hv_ref) -> None:
        self.default_j_ub = tuple(j_ub)
        self.default_hv_ref = tuple(hv_ref)

    def is_healthy(self, data) -> jax.Array:
        """Gymnasium's Hopper-v5 health check on `data`'s float32 state."""
        qpos = self.qpos(data)
        z, angle = qpos[1], qpos[2]
        state = jnp.concatenate([qpos[2:], data.qvel])
        return (
            jnp.all((state > -HEALTHY_STATE) & (state < HEALTHY_STATE))
            & (z > HEALTHY_Z)
            & (z < jnp.inf)
            & (angle > -HEALTHY_ANGLE)
            & (angle < HEALTHY_ANGLE)
        )

    def rewards(self, x_velocity, height, energy, healthy) -> jax.Array:
        """`[3]`: `[x_velocity, height, -energy] + healthy`, `energy = sum(a^2)`."""
        return jnp.stack([x_velocity, height, -energy]) + healthy

    def outcome(self, data, dqpos: jax.Array, action: jax.Array):
        x_velocity = dqpos[0] / self.dt
        height = HEIGHT_WEIGHT * (self.qpos(data)[1] - self._init_z)
        energy = jnp.sum(jnp.square(action))
        healthy = self.is_healthy(data).astype(jnp.float32)
        metrics = self._metrics(x_velocity, height, -energy, healthy, data.qpos[0])
        return self.rewards(x_velocity, height, energy, healthy), 1.0 - healthy, metrics

    def reset_metrics(self, data) -> dict:
        zero = jnp.zeros((), jnp.float32)
        height = HEIGHT_WEIGHT * (self.qpos(data)[1] - self._init_z)
        return self._metrics(zero, height, zero, zero, data.qpos[0])

    @staticmethod
    def _metrics(x_velocity, height, ctrl, healthy, x_position) -> dict:
        """Each reward term separately (in `State.metrics`); `reward_ctrl` is `-sum(a^2)`."""
        return {
            "reward_forward": x_velocity,
            "reward_height": height,
            "reward_ctrl": ctrl,
            "reward_healthy": healthy,
            "x_position": x_position,
            "x_velocity": x_velocity,
        }

    def observation(self, data) -> jax.Array:
        qvel = jnp.clip(data.qvel, -10.0, 10.0)
        return jnp.concatenate([self.qpos(data)[1:], qvel])

    @property
    def observation_size(self) -> int:
        return 11

    @property
    def action_size(self) -> int:
        return 3


class HopperTwoObjectives(Hopper):
    """`mo-hopper-2obj-v5`: forward velocity and height, each less `1e-3 sum(a^2)`; see
    the module docstring. Options as `Hopper`'s."""

    objective_names = ("forward_velocity", "height")

    def _declare(self, j_ub, hv_ref) -> None:
        # the control cost costs each objective at most 3e-3 per step
        t = float(self.episode_length)
        self.default_j_ub = tuple(j_ub[:2])
        self.default_hv_ref = (
            hv_ref[0] - 3.0 * CTRL_COST_WEIGHT * t,
            hv_ref[1] - 3.0 * CTRL_COST_WEIGHT * t,
        )

    def rewards(self, x_velocity, height, energy, healthy) -> jax.Array:
        """`[2]`: `[x_velocity, height] - 1e-3 energy + healthy`, `energy = sum(a^2)`."""
        return jnp.stack([x_velocity, height]) - CTRL_COST_WEIGHT * energy + healthy
