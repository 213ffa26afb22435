"""PGMORL's `MO-HalfCheetah-v2` (`halfcheetah-pgmorl`) and COLA's `MO-New-HalfCheetah-v2`
(`halfcheetah-cola`): their model, observation, reward vectors and termination
(`pgmorl.PGMORLTask` does the rest: the reset, the action clip, the engines).

The model, `half_cheetah_pgmorl.xml` (PGMORL's `half_cheetah.xml`, unchanged; Euler,
0.01 s timestep, total mass set to 14), is Gymnasium's v5 cheetah in all but the floor's
drawn size. One step clips the action (6 torques) to `[-1, 1]` and holds it for 5
substeps (`dt = 0.05`), and returns

- observation (17): `qpos[1:]` (the root's z slide, its angle, 6 joint angles) and
  `qvel` (9, unclipped);
- reward vector (2), with `x_velocity` the change of `qpos[0]` over the step divided by
  `dt`, and an alive bonus of 1 in both objectives on every step:
  - `halfcheetah-pgmorl`: `[min(4, x_velocity) + 1, 5 - sum(a^2)]`: running faster than
    4 m/s earns nothing more, so no 500-step return exceeds 2,500 on either objective;
  - `halfcheetah-cola`: `[0.5 x_velocity + 1, 5 - sum(a^2)]` (no cap);
- `done = 1` once the torso's angle `qpos[2]` reaches 50 degrees either way (a flip).

Resets put the initial state exactly; the time limit is 500 steps. Engines: `"mujoco"`
(default) or `"mjx"` (solver capped as `mujoco_base` says).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp

from wcac_jax.envs.pgmorl import PGMORLTask

ALIVE_BONUS = 1.0
ENERGY_BASE = 4.0  # the energy objective is 4 - sum(a^2) + the alive bonus
SPEED_CAP = 4.0  # PGMORL's: the forward objective is min(4, x_velocity) + 1
MAX_ANGLE = math.radians(50.0)


class HalfCheetahPGMORL(PGMORLTask):
    """`MO-HalfCheetah-v2`: capped forward speed and energy efficiency; see the module
    docstring. Options as `pgmorl.PGMORLTask`'s."""

    model_file = "half_cheetah_pgmorl.xml"
    objective_names = ("forward_velocity", "energy")
    frame_skip = 5

    def _declare(self, t: float) -> None:
        # utopia, per step times the time limit: forward 6 (its reward is at most 5, the
        # cap 4 + the alive bonus), energy 6 (at most 5, at zero torque)
        # hypervolume reference, per step times the time limit: forward -9 (no physical
        # floor: running backwards at 10 m/s the whole episode, as `halfcheetah`'s),
        # energy -1 (its least: 5 - 6, sum a^2 <= 6 for clipped actions)
        self.default_j_ub = (6.0 * t, 6.0 * t)
        self.default_hv_ref = (float(self.forward(-10.0)) * t, -1.0 * t)

    def forward(self, x_velocity):
        """The forward objective at `x_velocity` (m/s): `min(4, v) + 1`."""
        return jnp.minimum(SPEED_CAP, x_velocity) + ALIVE_BONUS

    def outcome(self, data, dqpos: jax.Array, action: jax.Array):
        x_velocity = dqpos[0] / self.dt
        energy = jnp.sum(jnp.square(action))
        reward = jnp.stack([self.forward(x_velocity), ENERGY_BASE - energy + ALIVE_BONUS])
        done = 1.0 - (jnp.abs(data.qpos[2]) < MAX_ANGLE).astype(jnp.float32)
        return reward, done, _metrics(x_velocity, -energy, data.qpos[0])

    def reset_metrics(self, data) -> dict:
        zero = jnp.zeros((), jnp.float32)
        return _metrics(zero, zero, data.qpos[0])

    def observation(self, data) -> jax.Array:
        return jnp.concatenate([data.qpos[1:], data.qvel])

    @property
    def observation_size(self) -> int:
        return 17


class HalfCheetahCOLA(HalfCheetahPGMORL):
    """`MO-New-HalfCheetah-v2`: half the forward speed, uncapped, and energy efficiency;
    see the module docstring. Options as `pgmorl.PGMORLTask`'s."""

    def _declare(self, t: float) -> None:
        # utopia, per step times the time limit: forward 8.5 (15 m/s, above the ~12 m/s
        # the fastest HalfCheetah policies run: 0.5 * 15 + 1), energy 6 (at most 5)
        # hypervolume reference: forward -4 per step (backwards at 10 m/s), energy -1
        self.default_j_ub = (float(self.forward(15.0)) * t, 6.0 * t)
        self.default_hv_ref = (float(self.forward(-10.0)) * t, -1.0 * t)

    def forward(self, x_velocity):
        """The forward objective at `x_velocity` (m/s): `0.5 v + 1`."""
        return 0.5 * x_velocity + ALIVE_BONUS


def _metrics(x_velocity, ctrl, x_position) -> dict:
    """The reward terms (in `State.metrics`); `reward_ctrl` is `-sum(a^2)`."""
    return {"reward_ctrl": ctrl, "x_position": x_position, "x_velocity": x_velocity}
