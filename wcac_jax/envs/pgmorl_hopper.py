"""PGMORL's `MO-Hopper-v2` (`hopper-pgmorl`, 2 objectives) and `MO-Hopper-v3`
(`hopper3-pgmorl`, 3 objectives): their model, observation, reward vectors and
termination (`pgmorl.PGMORLTask` does the rest: the reset, the action clip, the engines).

The model, `hopper_pgmorl.xml` (PGMORL's `hopper.xml` in local coordinates; RK4, 0.002 s
timestep), is not Gymnasium's v5 hopper: joint damping 40 (v5: 1), no joint limits,
control ranges `[-2, 2]`, `[-2, 2]`, `[-4, 4]` with gears 200, 200, 300 (v5: `[-1, 1]`
and 200 on every joint). One step clips the action (3 torques) to that box and holds it
for 5 substeps (`dt = 0.01`), and returns

- observation (11): `qpos[1:]` (torso height and angle, 3 joint angles) and
  `clip(qvel, -10, 10)` (6 velocities);
- reward vector, with `x_velocity` the change of `qpos[0]` over the step divided by
  `dt`, `height = 12 (z - z0)` with `z = qpos[1]` the torso height and `z0 = 1.25` its
  initial one, and an alive bonus of 1 in every objective on every step:
  - `hopper-pgmorl`: `[1.5 x_velocity, height] + 1 - 2e-4 sum(a^2)`;
  - `hopper3-pgmorl`: `[1.5 x_velocity + 1, height + 1, 5 - sum(a^2)]`;
- `done = 1` unless `z > 0.4` and each of the torso and joint angles `qpos[2:6]` is within
  90 degrees either way (strict).

Resets put the initial state exactly; the time limit is 500 steps. Engines: `"mujoco"`
(default) or `"mjx"` (solver capped as `mujoco_base` says).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp

from wcac_jax.envs.pgmorl import PGMORLTask

ALIVE_BONUS = 1.0
FORWARD_WEIGHT = 1.5
HEIGHT_WEIGHT = 12.0
CTRL_COST_WEIGHT = 2e-4  # the 2-objective version's control cost, in both objectives
ENERGY_BASE = 4.0  # the 3-objective version's energy objective is 4 - sum(a^2) + 1
HEALTHY_Z = 0.4
MAX_ANGLE = math.radians(90.0)
ACTION_BOUND = (2.0, 2.0, 4.0)  # the model's control ranges
MAX_ENERGY = sum(b * b for b in ACTION_BOUND)  # 24: the largest sum(a^2) of a clipped action


class HopperPGMORL(PGMORLTask):
    """`MO-Hopper-v2`: forward speed and jumping height, each less `2e-4 sum(a^2)`; see the
    module docstring. Options as `pgmorl.PGMORLTask`'s."""

    model_file = "hopper_pgmorl.xml"
    objective_names = ("forward_velocity", "height")
    frame_skip = 5
    action_bound = ACTION_BOUND

    def _declare(self, t: float) -> None:
        self._init_z = float(self.mj_model.qpos0[1])  # z0 = 1.25, the height term's origin
        # utopia, per step times the time limit: forward 15 and height 15 (9.3 m/s, or a
        # mean torso height 1.17 m above the start; a front with COLA's hypervolume
        # 2.11e7 reaches about 10 per step on each axis)
        # hypervolume reference, per step times the time limit: forward -2 (no physical
        # floor: backwards at 2 m/s the whole episode, as `hopper`'s) less the largest
        # control cost; height -9.2 on each step alive (z > 0.4) and -14 on the falling
        # one (the torso above the floor, z >= 0), each less the largest control cost
        cost = CTRL_COST_WEIGHT * MAX_ENERGY
        alive = self.height(HEALTHY_Z) + ALIVE_BONUS - cost
        fall = self.height(0.0) + ALIVE_BONUS - cost
        self.default_j_ub = (15.0 * t, 15.0 * t)
        self.default_hv_ref = (
            (FORWARD_WEIGHT * -2.0 + ALIVE_BONUS - cost) * t,
            alive * (t - 1.0) + fall,
        )

    def height(self, z):
        """The height term at torso height `z`: `12 (z - z0)`."""
        return HEIGHT_WEIGHT * (z - self._init_z)

    def rewards(self, forward, height, energy) -> jax.Array:
        """`[2]`: `[forward, height] + 1 - 2e-4 energy`, `energy = sum(a^2)`."""
        return jnp.stack([forward, height]) + ALIVE_BONUS - CTRL_COST_WEIGHT * energy

    def outcome(self, data, dqpos: jax.Array, action: jax.Array):
        x_velocity = dqpos[0] / self.dt
        qpos = data.qpos
        height = self.height(qpos[1])
        energy = jnp.sum(jnp.square(action))
        upright = jnp.all(jnp.abs(qpos[2:6]) < MAX_ANGLE)
        healthy = (qpos[1] > HEALTHY_Z) & upright
        reward = self.rewards(FORWARD_WEIGHT * x_velocity, height, energy)
        metrics = _metrics(x_velocity, height, -energy, qpos[0])
        return reward, 1.0 - healthy.astype(jnp.float32), metrics

    def reset_metrics(self, data) -> dict:
        zero = jnp.zeros((), jnp.float32)
        return _metrics(zero, self.height(data.qpos[1]), zero, data.qpos[0])

    def observation(self, data) -> jax.Array:
        return jnp.concatenate([data.qpos[1:], jnp.clip(data.qvel, -10.0, 10.0)])

    @property
    def observation_size(self) -> int:
        return 11


class Hopper3PGMORL(HopperPGMORL):
    """`MO-Hopper-v3`: forward speed, jumping height and energy efficiency; see the
    module docstring. Options as `pgmorl.PGMORLTask`'s."""

    objective_names = ("forward_velocity", "height", "energy")

    def _declare(self, t: float) -> None:
        super()._declare(t)
        # as the 2-objective version's without its control cost; energy: utopia 6 per
        # step (its reward is at most 5, at zero torque), reference -19 (its least,
        # 5 - 24)
        cost = CTRL_COST_WEIGHT * MAX_ENERGY
        forward_ref, height_ref = self.default_hv_ref
        self.default_j_ub = (*self.default_j_ub, 6.0 * t)
        self.default_hv_ref = (
            forward_ref + cost * t,
            height_ref + cost * t,
            (ENERGY_BASE - MAX_ENERGY + ALIVE_BONUS) * t,
        )

    def rewards(self, forward, height, energy) -> jax.Array:
        """`[3]`: `[forward, height, 4 - energy] + 1`, `energy = sum(a^2)`."""
        return jnp.stack([forward, height, ENERGY_BASE - energy]) + ALIVE_BONUS


def _metrics(x_velocity, height, ctrl, x_position) -> dict:
    """The reward terms (in `State.metrics`); `reward_ctrl` is `-sum(a^2)`."""
    return {
        "reward_height": height,
        "reward_ctrl": ctrl,
        "x_position": x_position,
        "x_velocity": x_velocity,
    }
