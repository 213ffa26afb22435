"""Multi-objective HalfCheetah with the semantics of MO-Gymnasium's `mo-halfcheetah-v5`:
the model, the observation and the reward vector (`mujoco_base.MujocoEnv` does the rest).

Gymnasium's `half_cheetah_v5.xml` (in `assets/`, MIT notice in `assets/NOTICE`; Euler,
0.01 s timestep). One step applies the action (6 torques in `[-1, 1]`) for 5 substeps
(`dt = 0.05`), and returns

- observation (17): `qpos[1:]` (the root's z slide, measured from the torso's initial
  0.7 m as the model does, its angle and 6 joint angles) and `qvel` (9, unclipped), as
  Gymnasium's HalfCheetah-v5;
- reward vector (2): `[x_velocity, -sum(a^2)]`, the torso's forward speed over the step
  (m/s) and the (negated) control energy; no healthy reward;
- `done = 0`: the cheetah never terminates; only the time limit (`episode_length`,
  default 500; MO-Gymnasium's is 1000) ends an episode.

Resets add uniform noise in `[-0.1, 0.1]` to the initial positions and `0.1` times a
standard normal to the (zero) velocities. Engines: `"mujoco"` (default) or `"mjx"`.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from wcac_jax.envs.mujoco_base import MujocoEnv, asset


class HalfCheetah(MujocoEnv):
    """`mo-halfcheetah-v5`: forward velocity and control; see the module docstring.

    Args:
      episode_length: time limit in steps, `>= 1` (applied by `EpisodeWrapper`).
      engine: `"mujoco"` or `"mjx"`.
      reset_noise_scale: scale of the reset noise.
      solver_iterations, ls_iterations: MuJoCo's solver settings (`None`: the model's
        own on `"mujoco"`, 4 and 4 on `"mjx"`).
    """

    objective_names = ("forward_velocity", "control")
    frame_skip = 5
    height_body = None  # observations keep the model's own z slide
    velocity_noise = "normal"

    def __init__(
        self,
        episode_length: int = 500,
        engine: str = "mujoco",
        reset_noise_scale: float = 0.1,
        solver_iterations: int | None = None,
        ls_iterations: int | None = None,
    ):
        super().__init__(
            asset("half_cheetah_v5.xml"),
            engine,
            episode_length,
            reset_noise_scale,
            solver_iterations,
            ls_iterations,
        )
        t = float(episode_length)
        # utopia, per step times the time limit: forward 15 m/s (above the ~12 m/s the
        # fastest HalfCheetah-v5 policies run), control 0.5 (its reward is at most 0)
        self.default_j_ub = (15.0 * t, 0.5 * t)
        # hypervolume reference: forward has no physical floor, so a stated one, running
        # backwards at 10 m/s for the whole episode; control -6 per step, its least
        # (sum a^2 <= 6 for actions in [-1, 1])
        self.default_hv_ref = (-10.0 * t, -6.0 * t)

    def outcome(self, data, dqpos: jax.Array, action: jax.Array):
        x_velocity = dqpos[0] / self.dt
        ctrl = -jnp.sum(jnp.square(action))
        metrics = {
            "reward_forward": x_velocity,
            "reward_ctrl": ctrl,
            "x_position": data.qpos[0],
            "x_velocity": x_velocity,
        }
        return jnp.stack([x_velocity, ctrl]), jnp.zeros((), jnp.float32), metrics

    def reset_metrics(self, data) -> dict:
        zero = jnp.zeros((), jnp.float32)
        return {
            "reward_forward": zero,
            "reward_ctrl": zero,
            "x_position": data.qpos[0],
            "x_velocity": zero,
        }

    def observation(self, data) -> jax.Array:
        return jnp.concatenate([data.qpos[1:], data.qvel])

    @property
    def observation_size(self) -> int:
        return 17

    @property
    def action_size(self) -> int:
        return 6
