"""PGMORL's `MO-Humanoid-v2` (`humanoid-pgmorl`): its model, observation, reward vector
and termination (`pgmorl.PGMORLTask` does the rest: the reset, the action clip, the
engine).

The model, `humanoid_pgmorl.xml` (PGMORL's `humanoid.xml`, unchanged; RK4, 0.003 s
timestep, PGS solver of 50 iterations), is Gymnasium's v5 humanoid in all but the floor's
drawn size. One step holds the action (17 motor controls) for 5 substeps
(`dt = 0.015`), and returns

- observation (376): `qpos[2:]` (22), `qvel` (23), and of all 14 bodies, the world's
  included, `cinert` (140) and `cvel` (84), then `qfrc_actuator` (23) and `cfrc_ext`
  (84), as MuJoCo leaves them after a step (the step's last force evaluation). The
  contact forces are zero: MuJoCo computes `cfrc_ext` only on request
  (`mj_rnePostConstraint`), which neither mujoco-py 2.0's step nor MuJoCo's own makes for
  a model without force sensors, so the published observation's last 84 entries were
  always zero, and are here;
- reward vector (2): `[1.25 x_velocity + 3, 6 - 4 sum(u^2)]`, with `x_velocity` the
  speed of the centre of mass along x over the step (m/s) and `u` the controls. The
  published step does not clip the action; MuJoCo 2.0 clamped the controls to the
  model's range, `[-0.4, 0.4]`, in place, before the reward read them (MuJoCo 2.2.1 and
  later leave them as given), so `u` is the action clipped to that range, as here;
- `done = 1` when the torso height `qpos[2]` is below 1 or above 2; the alive bonus of 3
  is in both objectives on every step, the falling one included.

Resets add uniform noise in `[-0.01, 0.01]` to the initial positions and velocities; the
time limit is 1,000 steps. Engine: `"mujoco"` only; MJX cannot load the model, whose PGS
constraint solver it does not implement, so `engine="mjx"` is refused.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from wcac_jax.envs.pgmorl import PGMORLTask

ALIVE_BONUS = 3.0
FORWARD_WEIGHT = 1.25
ENERGY_BASE = 3.0  # the energy objective is 3 - 4 sum(u^2) + the alive bonus
CTRL_COST_WEIGHT = 4.0
ACTION_BOUND = 0.4  # the model's control range
HEALTHY_Z = (1.0, 2.0)
EPISODE_LENGTH = 1000


class HumanoidPGMORL(PGMORLTask):
    """`MO-Humanoid-v2`: forward speed and energy efficiency; see the module docstring.

    Args:
      episode_length: time limit in steps, `>= 1` (applied by `EpisodeWrapper`).
      engine: `"mujoco"` (`"mjx"` raises `ValueError`: see the module docstring).
      reset_noise_scale: half-width of the uniform reset noise (0.01: the published one).
      solver_iterations, ls_iterations: MuJoCo's solver settings (`None`: the model's).
    """

    model_file = "humanoid_pgmorl.xml"
    objective_names = ("forward_velocity", "energy")
    frame_skip = 5
    action_bound = ACTION_BOUND
    fields = ("xipos", "cinert", "cvel", "qfrc_actuator")

    def __init__(
        self,
        episode_length: int = EPISODE_LENGTH,
        engine: str = "mujoco",
        reset_noise_scale: float = 1e-2,
        solver_iterations: int | None = None,
        ls_iterations: int | None = None,
    ):
        if engine == "mjx":
            raise ValueError(
                "humanoid-pgmorl runs on engine='mujoco' only: MJX cannot load its model "
                "(MJX does not implement its PGS constraint solver)"
            )
        super().__init__(
            episode_length, engine, reset_noise_scale, solver_iterations, ls_iterations
        )
        mass = np.asarray(self.mj_model.body_mass, np.float64)
        self._mass_share = jnp.asarray(mass / mass.sum(), jnp.float32)  # [nbody]
        self._contact_size = 6 * int(self.mj_model.nbody)

    def _declare(self, t: float) -> None:
        # utopia, per step times the time limit: forward 10 (5.6 m/s, above the speeds
        # humanoid policies reach, + 3), energy 7 (its reward is at most 6, at zero control)
        # hypervolume reference, per step times the time limit: forward -0.75 (no physical
        # floor: the centre of mass backwards at 3 m/s the whole episode, as `humanoid`'s),
        # energy -4.88 (its least: 6 - 4 * 17 * 0.4^2)
        most = self.action_size * ACTION_BOUND**2  # the largest sum(u^2), 2.72
        least_energy = ENERGY_BASE + ALIVE_BONUS - CTRL_COST_WEIGHT * most
        self.default_j_ub = (10.0 * t, 7.0 * t)
        self.default_hv_ref = ((FORWARD_WEIGHT * -3.0 + ALIVE_BONUS) * t, least_energy * t)

    def transition(self, old, data, dqpos: jax.Array, action: jax.Array):
        del dqpos  # the published step measures the centre of mass, not qpos
        dxipos = self.engine.field_change(old, data, "xipos")  # [nbody, 3]
        x_velocity = jnp.dot(self._mass_share, dxipos[:, 0]) / self.dt
        energy = jnp.sum(jnp.square(action))
        reward = jnp.stack([FORWARD_WEIGHT * x_velocity, ENERGY_BASE - CTRL_COST_WEIGHT * energy])
        z = data.qpos[2]
        done = ((z < HEALTHY_Z[0]) | (z > HEALTHY_Z[1])).astype(jnp.float32)
        return reward + ALIVE_BONUS, done, _metrics(x_velocity, -energy, data.qpos[0])

    def reset_metrics(self, data) -> dict:
        zero = jnp.zeros((), jnp.float32)
        return _metrics(zero, zero, data.qpos[0])

    def observation(self, data) -> jax.Array:
        field = self.engine.field
        return jnp.concatenate(
            [
                data.qpos[2:],
                data.qvel,
                field(data, "cinert").reshape(-1),
                field(data, "cvel").reshape(-1),
                field(data, "qfrc_actuator"),
                jnp.zeros((self._contact_size,), jnp.float32),  # cfrc_ext, never computed
            ]
        )

    @property
    def observation_size(self) -> int:
        return 376


def _metrics(x_velocity, ctrl, x_position) -> dict:
    """The reward terms (in `State.metrics`); `reward_ctrl` is `-sum(u^2)`."""
    return {"reward_ctrl": ctrl, "x_position": x_position, "x_velocity": x_velocity}
