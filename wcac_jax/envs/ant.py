"""Multi-objective Ant with the semantics of MO-Gymnasium's `mo-ant-v5` (`ant`, 3
objectives) and `mo-ant-2obj-v5` (`ant-2obj`, 2 objectives): the model, the observation,
the reward vector and the health check (`mujoco_base.MujocoEnv` does the rest).

Gymnasium's `ant_v5.xml` (in `assets/`, MIT notice in `assets/NOTICE`; RK4, 0.01 s
timestep). One step applies the action (8 torques in `[-1, 1]`) for 5 substeps
(`dt = 0.05`), and returns

- observation (105): `qpos[2:]` (torso height, orientation quaternion, 8 joint angles),
  `qvel` (14) and the external contact forces of the 13 bodies, `cfrc_ext[1:]` clipped to
  `[-1, 1]` (78), as Gymnasium's Ant-v5 with its defaults;
- reward vector, with `x_velocity`, `y_velocity` the torso's speed over the step (m/s)
  measured as Gymnasium does (the torso's `xpos` as MuJoCo leaves it after a step: the
  step's last force evaluation), `healthy = 1` while healthy and 0 on the step it falls,
  and `contact = 5e-4 sum(clip(cfrc_ext, -1, 1)^2)` over every body:
  - `ant`: `[x_velocity, y_velocity, -sum(a^2)] + healthy - contact`;
  - `ant-2obj`: `[x_velocity, y_velocity] - 0.5 sum(a^2) + healthy - contact` (the control
    cost at Ant-v5's weight enters both objectives, as MO-Gymnasium's 2-objective version);
- `done = 1` when the ant is unhealthy: torso height `qpos[2]` outside `[0.2, 1.0]`, or a
  non-finite position or velocity.

Resets add uniform noise in `[-0.1, 0.1]` to the initial positions and `0.1` times a
standard normal to the (zero) velocities; the contact forces of a reset's observation are
zero, as Gymnasium's. The time limit (`episode_length`, default 500; MO-Gymnasium's is
1000) is `EpisodeWrapper`'s. Engines: `"mujoco"` (default; MO-Gymnasium's environment up
to float32 rounding) or `"mjx"` (solver capped as `mujoco_base` says).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from wcac_jax.envs.mujoco_base import MujocoEnv, asset

CTRL_COST_WEIGHT = 0.5  # Ant-v5's, with which control enters the 2-objective rewards
CONTACT_COST_WEIGHT = 5e-4
CONTACT_FORCE_RANGE = 1.0
HEALTHY_Z = (0.2, 1.0)
TORSO = 1  # the torso's body index (Ant-v5's `main_body`)


class Ant(MujocoEnv):
    """`mo-ant-v5`: x velocity, y velocity, control; see the module docstring.

    Args:
      episode_length: time limit in steps, `>= 1` (applied by `EpisodeWrapper`).
      engine: `"mujoco"` or `"mjx"`.
      reset_noise_scale: scale of the reset noise.
      solver_iterations, ls_iterations: MuJoCo's solver settings (`None`: the model's
        own on `"mujoco"`, 4 and 4 on `"mjx"`).
    """

    objective_names = ("x_velocity", "y_velocity", "control")
    frame_skip = 5
    height_body = None  # a free joint: qpos[2] is the torso's height already
    velocity_noise = "normal"
    fields = ("xpos", "cfrc_ext")

    def __init__(
        self,
        episode_length: int = 500,
        engine: str = "mujoco",
        reset_noise_scale: float = 0.1,
        solver_iterations: int | None = None,
        ls_iterations: int | None = None,
    ):
        super().__init__(
            asset("ant_v5.xml"),
            engine,
            episode_length,
            reset_noise_scale,
            solver_iterations,
            ls_iterations,
        )
        t = float(episode_length)
        # utopia, per step times the time limit: each direction 7 (6 m/s, above the
        # speeds Ant-v5 policies reach, + healthy), control 2 (its reward is at most 1)
        # hypervolume reference, stated floors (a velocity has no physical one): each
        # direction -5 per step (backwards at 4 m/s less the largest contact cost, 0.042),
        # control -9 (sum a^2 <= 8 for actions in [-1, 1], and the contact cost)
        self._declare(j_ub=(7.0 * t, 7.0 * t, 2.0 * t), hv_ref=(-5.0 * t, -5.0 * t, -9.0 * t))

    def _declare(self, j_ub, hv_ref) -> None:
        self.default_j_ub = tuple(j_ub)
        self.default_hv_ref = tuple(hv_ref)

    def is_healthy(self, data) -> jax.Array:
        """Gymnasium's Ant-v5 health check on `data`'s float32 state."""
        finite = jnp.all(jnp.isfinite(data.qpos)) & jnp.all(jnp.isfinite(data.qvel))
        z = data.qpos[2]
        return finite & (z >= HEALTHY_Z[0]) & (z <= HEALTHY_Z[1])

    def contact_forces(self, data) -> jax.Array:
        """`[nbody, 6]`: `cfrc_ext` clipped to `[-1, 1]`."""
        cfrc = self.engine.field(data, "cfrc_ext")
        return jnp.clip(cfrc, -CONTACT_FORCE_RANGE, CONTACT_FORCE_RANGE)

    def rewards(self, velocity, energy, healthy, contact) -> jax.Array:
        """`[3]`: `[x_velocity, y_velocity, -energy] + healthy - contact`."""
        return jnp.concatenate([velocity, -energy[None]]) + healthy - contact

    def transition(self, old, data, dqpos: jax.Array, action: jax.Array):
        del dqpos  # Gymnasium measures the torso's xpos, not qpos
        velocity = self.engine.field_change(old, data, "xpos")[TORSO, :2] / self.dt
        energy = jnp.sum(jnp.square(action))
        contact = CONTACT_COST_WEIGHT * jnp.sum(jnp.square(self.contact_forces(data)))
        healthy = self.is_healthy(data).astype(jnp.float32)
        metrics = self._metrics(velocity, -energy, healthy, -contact, data.qpos[0])
        reward = self.rewards(velocity, energy, healthy, contact)
        return reward, 1.0 - healthy, metrics

    def reset_metrics(self, data) -> dict:
        zero = jnp.zeros((), jnp.float32)
        return self._metrics(jnp.zeros(2), zero, zero, zero, data.qpos[0])

    @staticmethod
    def _metrics(velocity, ctrl, healthy, contact, x_position) -> dict:
        """Each reward term separately (in `State.metrics`); `reward_ctrl` is `-sum(a^2)`."""
        return {
            "reward_ctrl": ctrl,
            "reward_healthy": healthy,
            "reward_contact": contact,
            "x_position": x_position,
            "x_velocity": velocity[0],
            "y_velocity": velocity[1],
        }

    def observation(self, data) -> jax.Array:
        contact = self.contact_forces(data)[1:].reshape(-1)
        return jnp.concatenate([data.qpos[2:], data.qvel, contact])

    @property
    def observation_size(self) -> int:
        return 105

    @property
    def action_size(self) -> int:
        return 8


class AntTwoObjectives(Ant):
    """`mo-ant-2obj-v5`: x and y velocity, each less `0.5 sum(a^2)`; see the module
    docstring. Options as `Ant`'s."""

    objective_names = ("x_velocity", "y_velocity")

    def _declare(self, j_ub, hv_ref) -> None:
        # the control cost costs each objective at most 4 per step
        t = float(self.episode_length)
        self.default_j_ub = tuple(j_ub[:2])
        self.default_hv_ref = (hv_ref[0] - 4.0 * t, hv_ref[1] - 4.0 * t)

    def rewards(self, velocity, energy, healthy, contact) -> jax.Array:
        """`[2]`: `[x_velocity, y_velocity] - 0.5 energy + healthy - contact`."""
        return velocity - CTRL_COST_WEIGHT * energy + healthy - contact
