"""Multi-objective Swimmer with the semantics of MO-Gymnasium's `mo-swimmer-v5`: the model,
the observation and the reward vector (`mujoco_base.MujocoEnv` does the rest).

Gymnasium's `swimmer_v5.xml` (in `assets/`, MIT notice in `assets/NOTICE`; RK4, 0.01 s
timestep, a viscous fluid). One step applies the action (2 torques in `[-1, 1]`) for 4
substeps (`dt = 0.04`), and returns

- observation (8): `qpos[2:]` (the body's heading and 2 joint angles) and `qvel` (5,
  unclipped), as Gymnasium's Swimmer-v5;
- reward vector (2): `[x_velocity, -sum(a^2)]`, the front tip's speed along x over the
  step (m/s) and the (negated) control energy;
- `done = 0`: only the time limit (`episode_length`, default 500; MO-Gymnasium's is
  1000) ends an episode.

Resets add uniform noise in `[-0.1, 0.1]` to the initial positions and velocities. The
swimmer lies in the plane, so pictures look down on it. Engines: `"mujoco"` (default) or
`"mjx"`.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from wcac_jax.envs.base import Scene
from wcac_jax.envs.mujoco_base import MujocoEnv, asset


class Swimmer(MujocoEnv):
    """`mo-swimmer-v5`: forward velocity and control; see the module docstring.

    Args:
      episode_length: time limit in steps, `>= 1` (applied by `EpisodeWrapper`).
      engine: `"mujoco"` or `"mjx"`.
      reset_noise_scale: half-width of the uniform reset noise.
      solver_iterations, ls_iterations: MuJoCo's solver settings (`None`: the model's
        own on `"mujoco"`, 4 and 4 on `"mjx"`).
    """

    objective_names = ("forward_velocity", "control")
    frame_skip = 4
    height_body = None  # it swims in the plane: qpos[:2] is its position in it

    def __init__(
        self,
        episode_length: int = 500,
        engine: str = "mujoco",
        reset_noise_scale: float = 0.1,
        solver_iterations: int | None = None,
        ls_iterations: int | None = None,
    ):
        super().__init__(
            asset("swimmer_v5.xml"),
            engine,
            episode_length,
            reset_noise_scale,
            solver_iterations,
            ls_iterations,
        )
        t = float(episode_length)
        # utopia, per step times the time limit: forward 0.5 m/s (above the ~0.35 m/s
        # the best Swimmer-v5 policies reach), control 0.1 (its reward is at most 0)
        self.default_j_ub = (0.5 * t, 0.1 * t)
        # hypervolume reference: forward has no physical floor, so a stated one,
        # swimming backwards at 0.5 m/s for the whole episode; control -2 per step, its
        # least (sum a^2 <= 2 for actions in [-1, 1])
        self.default_hv_ref = (-0.5 * t, -2.0 * t)

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
        return jnp.concatenate([data.qpos[2:], data.qvel])

    def render_scene(self) -> Scene:
        """Seen from above, tracking the front segment."""
        return Scene(self.mj_model, "torso", distance=4.0, elevation=-90.0, azimuth=90.0)

    @property
    def observation_size(self) -> int:
        return 8

    @property
    def action_size(self) -> int:
        return 2
