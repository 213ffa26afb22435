"""PGMORL's `MO-Swimmer-v2` (`swimmer-pgmorl`): its model, observation and reward vector
(`pgmorl.PGMORLTask` does the rest: the reset, the action clip, the engines).

The model, `swimmer_pgmorl.xml` (PGMORL's `swimmer.xml`, with MuJoCo 2's
`collision="predefined"` written as MuJoCo 4's contact flag, disabled; RK4, 0.01 s
timestep, a viscous fluid), is Gymnasium's v5 swimmer but for its motor gear, 300 (v5:
150). One step clips the action (2 torques) to `[-1, 1]` and holds it for 4 substeps
(`dt = 0.04`), and returns

- observation (8): `qpos[2:]` (the body's heading and 2 joint angles) and `qvel` (5,
  unclipped);
- reward vector (2): `[x_velocity, 0.3 - 0.15 sum(a^2)]`, with `x_velocity` the change of
  `qpos[0]` (the front segment's x slide) over the step divided by `dt`;
- `done = 0`: only the time limit, 500 steps, ends an episode.

Resets put the initial state exactly. Engines: `"mujoco"` (default) or `"mjx"` (solver
capped as `mujoco_base` says).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from wcac_jax.envs.base import Scene
from wcac_jax.envs.pgmorl import PGMORLTask

ENERGY_BASE = 0.3
CTRL_COST_WEIGHT = 0.15
MAX_ENERGY = 2.0  # the largest sum(a^2) of a clipped action


class SwimmerPGMORL(PGMORLTask):
    """`MO-Swimmer-v2`: forward speed and energy efficiency; see the module docstring.
    Options as `pgmorl.PGMORLTask`'s."""

    model_file = "swimmer_pgmorl.xml"
    objective_names = ("forward_velocity", "energy")
    frame_skip = 4

    def _declare(self, t: float) -> None:
        # utopia, per step times the time limit: forward 1 m/s (the model's motors are
        # twice v5's, whose best policies swim at ~0.35 m/s), energy 0.4 (its reward is at
        # most 0.3, at zero torque)
        # hypervolume reference, per step times the time limit: forward -1 (no physical
        # floor: swimming backwards at 1 m/s the whole episode), energy 0 (its least,
        # 0.3 - 0.15 * 2)
        self.default_j_ub = (1.0 * t, 0.4 * t)
        self.default_hv_ref = (-1.0 * t, (ENERGY_BASE - CTRL_COST_WEIGHT * MAX_ENERGY) * t)

    def outcome(self, data, dqpos: jax.Array, action: jax.Array):
        x_velocity = dqpos[0] / self.dt
        energy = jnp.sum(jnp.square(action))
        reward = jnp.stack([x_velocity, ENERGY_BASE - CTRL_COST_WEIGHT * energy])
        return reward, jnp.zeros((), jnp.float32), _metrics(x_velocity, -energy, data.qpos[0])

    def reset_metrics(self, data) -> dict:
        zero = jnp.zeros((), jnp.float32)
        return _metrics(zero, zero, data.qpos[0])

    def observation(self, data) -> jax.Array:
        return jnp.concatenate([data.qpos[2:], data.qvel])

    def render_scene(self) -> Scene:
        """Seen from above, tracking the front segment."""
        return Scene(self.mj_model, "torso", distance=4.0, elevation=-90.0, azimuth=90.0)

    @property
    def observation_size(self) -> int:
        return 8


def _metrics(x_velocity, ctrl, x_position) -> dict:
    """The reward terms (in `State.metrics`); `reward_ctrl` is `-sum(a^2)`."""
    return {"reward_ctrl": ctrl, "x_position": x_position, "x_velocity": x_velocity}
