"""PGMORL's `MO-Ant-v2` (`ant-pgmorl`, 2 objectives) and COLA's `MO-Ant-v3` (`ant3-cola`,
3 objectives): their model, observation, reward vectors and termination
(`pgmorl.PGMORLTask` does the rest: the reset, the action clip, the engines).

The model, `ant_pgmorl.xml` (PGMORL's `ant.xml`, unchanged; RK4, 0.01 s timestep), is
Gymnasium's v5 ant but for its motor gear, 100 (v5: 150), and the floor's drawn size. One
step clips the action (8 torques) to `[-1, 1]` and holds it for 5 substeps
(`dt = 0.05`), and returns

- observation (27): `qpos[2:]` (torso height, orientation quaternion, 8 joint angles) and
  `qvel` (14); no contact forces;
- reward vector, with `x_velocity`, `y_velocity` the torso's speed over the step (m/s),
  measured as gym 0.15's `get_body_com` reads it: the torso's `xpos` as MuJoCo leaves it
  after a step (the step's last force evaluation, not recomputed at the final positions):
  - `ant-pgmorl`: `[x_velocity, y_velocity] + 1 - 0.5 sum(a^2)` (the survive reward and
    the control cost in both objectives; no contact cost);
  - `ant3-cola`: `[x_velocity, y_velocity, 4 - 0.5 sum(a^2)]`;
- `done = 1` only on a non-finite position or velocity: the ant may flip, jump or lie
  down and the episode goes on.

Resets put the initial state exactly (the torso 0.75 m up, every joint at 0); the
time limit is 500 steps. Engines: `"mujoco"` (default) or `"mjx"` (solver capped as
`mujoco_base` says).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from wcac_jax.envs.pgmorl import PGMORLTask

SURVIVE_REWARD = 1.0
CTRL_COST_WEIGHT = 0.5
ENERGY_BASE = 4.0  # COLA's third objective is 4 - 0.5 sum(a^2)
MAX_ENERGY = 8.0  # the largest sum(a^2) of a clipped action
TORSO = 1  # the torso's body index


class AntPGMORL(PGMORLTask):
    """`MO-Ant-v2`: x and y speed, each with the survive reward less `0.5 sum(a^2)`; see
    the module docstring. Options as `pgmorl.PGMORLTask`'s."""

    model_file = "ant_pgmorl.xml"
    objective_names = ("x_velocity", "y_velocity")
    frame_skip = 5
    fields = ("xpos",)

    def _declare(self, t: float) -> None:
        # utopia, per step times the time limit: each direction 10 (9 m/s + the survive
        # reward; a front with COLA's hypervolume 1.133e7 reaches about 7.6 per step on
        # each axis)
        # hypervolume reference, per step times the time limit: each direction -7 (no
        # physical floor: backwards at 4 m/s, as `ant`'s, + 1 - the largest control
        # cost, 0.5 * 8)
        floor = -4.0 + SURVIVE_REWARD - CTRL_COST_WEIGHT * MAX_ENERGY
        self.default_j_ub = (10.0 * t, 10.0 * t)
        self.default_hv_ref = (floor * t, floor * t)

    def rewards(self, velocity, energy) -> jax.Array:
        """`[2]`: `velocity + 1 - 0.5 energy`, `velocity [2]`, `energy = sum(a^2)`."""
        return velocity + SURVIVE_REWARD - CTRL_COST_WEIGHT * energy

    def transition(self, old, data, dqpos: jax.Array, action: jax.Array):
        del dqpos  # gym 0.15 measures the torso's xpos, not qpos
        velocity = self.engine.field_change(old, data, "xpos")[TORSO, :2] / self.dt
        energy = jnp.sum(jnp.square(action))
        finite = jnp.all(jnp.isfinite(data.qpos)) & jnp.all(jnp.isfinite(data.qvel))
        metrics = _metrics(velocity, -energy, data.qpos[0])
        return self.rewards(velocity, energy), 1.0 - finite.astype(jnp.float32), metrics

    def reset_metrics(self, data) -> dict:
        zero = jnp.zeros((), jnp.float32)
        return _metrics(jnp.zeros(2), zero, data.qpos[0])

    def observation(self, data) -> jax.Array:
        return jnp.concatenate([data.qpos[2:], data.qvel])

    @property
    def observation_size(self) -> int:
        return 27


class Ant3COLA(AntPGMORL):
    """`MO-Ant-v3`: x speed, y speed and energy efficiency; see the module docstring.
    Options as `pgmorl.PGMORLTask`'s."""

    objective_names = ("x_velocity", "y_velocity", "energy")

    def _declare(self, t: float) -> None:
        # utopia, per step times the time limit: each direction 9 (9 m/s; a front with
        # COLA's hypervolume 1.858e10 reaches about 6.1 per step on each), energy 5 (its
        # reward is at most 4, at zero torque)
        # hypervolume reference, per step times the time limit: each direction -4 (no
        # physical floor: backwards at 4 m/s, as `ant`'s), energy 0 (its least, 4 - 4)
        least_energy = ENERGY_BASE - CTRL_COST_WEIGHT * MAX_ENERGY
        self.default_j_ub = (9.0 * t, 9.0 * t, 5.0 * t)
        self.default_hv_ref = (-4.0 * t, -4.0 * t, least_energy * t)

    def rewards(self, velocity, energy) -> jax.Array:
        """`[3]`: `[x_velocity, y_velocity, 4 - 0.5 energy]`, `energy = sum(a^2)`."""
        return jnp.concatenate([velocity, (ENERGY_BASE - CTRL_COST_WEIGHT * energy)[None]])


def _metrics(velocity, ctrl, x_position) -> dict:
    """The reward terms (in `State.metrics`); `reward_ctrl` is `-sum(a^2)`."""
    return {
        "reward_ctrl": ctrl,
        "x_position": x_position,
        "x_velocity": velocity[0],
        "y_velocity": velocity[1],
    }
