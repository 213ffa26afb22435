"""PGMORL's `MO-Walker2d-v2` (`walker2d-pgmorl`): its model, observation, reward vector and
termination (`pgmorl.PGMORLTask` does the rest: the reset, the action clip, the engines).

The model, `walker2d_pgmorl.xml` (PGMORL's `walker2d.xml` in local coordinates; RK4,
0.002 s timestep), is not Gymnasium's v5 walker: geom density 1500 (v5: 1000), joint
damping 3 (v5: 0.1), right-foot friction 0.9 (v5: 1.9). One step clips the action
(6 torques) to `[-1, 1]` and holds it for 4 substeps (`dt = 0.008`), and returns

- observation (17): `qpos[1:]` (torso height and angle, 6 joint angles) and
  `clip(qvel, -10, 10)` (9 velocities);
- reward vector (2): `[x_velocity + 1, 5 - sum(a^2)]`, with `x_velocity` the change of
  `qpos[0]` (the root's x slide) over the step divided by `dt`; the alive bonus of 1 is in
  both objectives on every step, the falling one included;
- `done = 1` unless the torso height `qpos[1]` is in `(0.8, 2)` and its angle `qpos[2]`
  in `(-1, 1)` (strict).

Resets put the initial state exactly; the time limit is 500 steps. Engines: `"mujoco"`
(default) or `"mjx"` (solver capped as `mujoco_base` says).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from wcac_jax.envs.pgmorl import PGMORLTask

ALIVE_BONUS = 1.0
ENERGY_BASE = 4.0  # the energy objective is 4 - sum(a^2) + the alive bonus


class Walker2dPGMORL(PGMORLTask):
    """`MO-Walker2d-v2`: forward speed and energy efficiency; see the module docstring.
    Options as `pgmorl.PGMORLTask`'s."""

    model_file = "walker2d_pgmorl.xml"
    objective_names = ("forward_velocity", "energy")
    frame_skip = 4

    def _declare(self, t: float) -> None:
        # utopia, per step times the time limit: forward 6 (5 m/s + the alive bonus, above
        # the speeds walkers reach: COLA's hypervolume 4.87e6 asks about 4.4 per step on
        # each axis), energy 6 (its reward is at most 5, at zero torque)
        self.default_j_ub = (6.0 * t, 6.0 * t)
        # hypervolume reference, per step times the time limit: forward -1 (no physical
        # floor: walking backwards at 2 m/s the whole episode, as `walker2d`'s), energy -1
        # (its least: 5 - 6, sum a^2 <= 6 for clipped actions)
        self.default_hv_ref = (-1.0 * t, -1.0 * t)

    def outcome(self, data, dqpos: jax.Array, action: jax.Array):
        x_velocity = dqpos[0] / self.dt
        energy = jnp.sum(jnp.square(action))
        height, angle = data.qpos[1], data.qpos[2]
        healthy = (height > 0.8) & (height < 2.0) & (angle > -1.0) & (angle < 1.0)
        reward = jnp.stack([x_velocity, ENERGY_BASE - energy]) + ALIVE_BONUS
        metrics = _metrics(x_velocity, -energy, data.qpos[0])
        return reward, 1.0 - healthy.astype(jnp.float32), metrics

    def reset_metrics(self, data) -> dict:
        zero = jnp.zeros((), jnp.float32)
        return _metrics(zero, zero, data.qpos[0])

    def observation(self, data) -> jax.Array:
        return jnp.concatenate([data.qpos[1:], jnp.clip(data.qvel, -10.0, 10.0)])

    @property
    def observation_size(self) -> int:
        return 17


def _metrics(x_velocity, ctrl, x_position) -> dict:
    """The reward terms (in `State.metrics`); `reward_ctrl` is `-sum(a^2)`."""
    return {"reward_ctrl": ctrl, "x_position": x_position, "x_velocity": x_velocity}
