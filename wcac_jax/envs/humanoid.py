"""Multi-objective Humanoid with the semantics of MO-Gymnasium's `mo-humanoid-v5`: the
model, the observation, the reward vector and the health check (`mujoco_base.MujocoEnv`
does the rest).

Gymnasium's `humanoid_v5.xml` (in `assets/`, MIT notice in `assets/NOTICE`; RK4, 0.003 s
timestep). One step applies the action (17 motor controls in `[-0.4, 0.4]`, the model's
control range: `step` takes actions in MO-Gymnasium's own space, and MuJoCo clamps what
lies outside) for 5 substeps (`dt = 0.015`), and returns

- observation (348): `qpos[2:]` (22), `qvel` (23), and of the 13 bodies after the world
  `cinert` (130), `cvel` (78), then `qfrc_actuator[6:]` (17) and `cfrc_ext` (78), as
  Gymnasium's Humanoid-v5 with its defaults (MuJoCo's values as it leaves them after a
  step: the step's last force evaluation);
- reward vector (2): `[x_velocity, -sum(a^2)] + healthy - contact`, with `x_velocity` the
  speed of the centre of mass along x over the step (m/s), `healthy = 5` while healthy
  and 0 on the step it falls, and `contact = min(5e-7 sum(cfrc_ext^2), 10)`;
- `done = 1` when the humanoid is unhealthy: torso height `qpos[2]` outside `(1, 2)`.

Resets add uniform noise in `[-0.01, 0.01]` to the initial positions and velocities; a
reset's contact forces are zero, as Gymnasium's. The time limit (`episode_length`,
default 500; MO-Gymnasium's is 1000) is `EpisodeWrapper`'s. Engine: `"mujoco"` only
(MO-Gymnasium's environment up to float32 rounding); MJX cannot load the model, whose PGS
constraint solver it does not implement, so `engine="mjx"` is refused.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from wcac_jax.envs.mujoco_base import MujocoEnv, asset

HEALTHY_REWARD = 5.0
HEALTHY_Z = (1.0, 2.0)
CONTACT_COST_WEIGHT = 5e-7
CONTACT_COST_MAX = 10.0
ACTION_BOUND = 0.4  # the model's control range


class Humanoid(MujocoEnv):
    """`mo-humanoid-v5`: forward velocity and control; see the module docstring.

    Args:
      episode_length: time limit in steps, `>= 1` (applied by `EpisodeWrapper`).
      engine: `"mujoco"` (`"mjx"` raises `ValueError`: see the module docstring).
      reset_noise_scale: half-width of the uniform reset noise.
      solver_iterations, ls_iterations: MuJoCo's solver settings (`None`: the model's).
    """

    objective_names = ("forward_velocity", "control")
    frame_skip = 5
    height_body = None  # a free joint: qpos[2] is the torso's height already
    fields = ("xipos", "cinert", "cvel", "qfrc_actuator", "cfrc_ext")
    action_bound = ACTION_BOUND

    def __init__(
        self,
        episode_length: int = 500,
        engine: str = "mujoco",
        reset_noise_scale: float = 1e-2,
        solver_iterations: int | None = None,
        ls_iterations: int | None = None,
    ):
        if engine == "mjx":
            raise ValueError(
                "humanoid runs on engine='mujoco' only: MJX cannot load Gymnasium's humanoid "
                "model (MJX does not implement its PGS constraint solver)"
            )
        super().__init__(
            asset("humanoid_v5.xml"),
            engine,
            episode_length,
            reset_noise_scale,
            solver_iterations,
            ls_iterations,
        )
        mass = np.asarray(self.mj_model.body_mass, np.float32)
        self._mass_share = jnp.asarray(mass / mass.sum())  # [nbody]
        t = float(episode_length)
        # utopia, per step times the time limit: forward 10 (5 m/s, above the speeds
        # Humanoid-v5 policies reach, + healthy), control 6 (its reward is at most 5)
        # hypervolume reference, stated floors: forward -13 per step (backwards at 3 m/s
        # and the largest contact cost, 10), control -13 (sum a^2 <= 2.72 within the
        # control range, and the contact cost)
        self.default_j_ub = (10.0 * t, 6.0 * t)
        self.default_hv_ref = (-13.0 * t, -13.0 * t)

    def is_healthy(self, data) -> jax.Array:
        """Gymnasium's Humanoid-v5 health check on `data`'s float32 state."""
        z = data.qpos[2]
        return (z > HEALTHY_Z[0]) & (z < HEALTHY_Z[1])

    def transition(self, old, data, dqpos: jax.Array, action: jax.Array):
        del dqpos  # Gymnasium measures the centre of mass, not qpos
        dxipos = self.engine.field_change(old, data, "xipos")  # [nbody, 3]
        x_velocity = jnp.dot(self._mass_share, dxipos[:, 0]) / self.dt
        energy = jnp.sum(jnp.square(action))
        cfrc = self.engine.field(data, "cfrc_ext")
        contact = jnp.minimum(CONTACT_COST_WEIGHT * jnp.sum(jnp.square(cfrc)), CONTACT_COST_MAX)
        healthy = HEALTHY_REWARD * self.is_healthy(data).astype(jnp.float32)
        metrics = {
            "reward_ctrl": -energy,
            "reward_healthy": healthy,
            "reward_contact": -contact,
            "x_position": data.qpos[0],
            "x_velocity": x_velocity,
        }
        reward = jnp.stack([x_velocity, -energy]) + healthy - contact
        return reward, (healthy == 0).astype(jnp.float32), metrics

    def reset_metrics(self, data) -> dict:
        zero = jnp.zeros((), jnp.float32)
        return {
            "reward_ctrl": zero,
            "reward_healthy": zero,
            "reward_contact": zero,
            "x_position": data.qpos[0],
            "x_velocity": zero,
        }

    def observation(self, data) -> jax.Array:
        field = self.engine.field
        return jnp.concatenate(
            [
                data.qpos[2:],
                data.qvel,
                field(data, "cinert")[1:].reshape(-1),
                field(data, "cvel")[1:].reshape(-1),
                field(data, "qfrc_actuator")[6:],
                field(data, "cfrc_ext")[1:].reshape(-1),
            ]
        )

    @property
    def observation_size(self) -> int:
        return 348

    @property
    def action_size(self) -> int:
        return 17
