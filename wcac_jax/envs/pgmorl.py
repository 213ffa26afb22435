"""What the tasks of PGMORL's benchmark share, so that each task's file is its
observation, its reward vector and its termination.

PGMORL (Xu et al., ICML 2020; code mit-gfx/PGMORL, MIT) published seven multi-objective
MuJoCo tasks, `MO-{Walker2d,HalfCheetah,Hopper,Ant,Swimmer,Humanoid}-v2` and the
three-objective `MO-Hopper-v3`; COLA (NeurIPS 2025; code yeshenpy/COLA, MIT) benchmarks
on them and adds two of its own on the same models, `MO-New-HalfCheetah-v2` and
`MO-Ant-v3`. Each is a gym 0.15 `MujocoEnv` on mujoco-py 2.0 (MuJoCo 2.0), and so:

- a reset puts the model's initial positions and zero velocities, exactly: no noise
  (the humanoid alone adds uniform noise in `[-0.01, 0.01]`, its own `reset_noise_scale`);
- a step clips the action to the task's box (`action_bound`: `[-1, 1]` but for the
  hopper's `[-2, 2] x [-2, 2] x [-4, 4]` and the humanoid's `[-0.4, 0.4]`, each the
  model's control range), sets it as the controls and takes `frame_skip` MuJoCo steps;
  the rewards read the clipped action;
- the time limit, gym's, is 500 steps (`EPISODE_LENGTH`; the humanoid's 1000).

`PGMORLTask` is `mujoco_base.MujocoEnv` with those defaults and the clip; its subclasses
(`pgmorl_walker2d`, `pgmorl_halfcheetah`, `pgmorl_hopper`, `pgmorl_ant`,
`pgmorl_swimmer`, `pgmorl_humanoid`) name their model in `assets/` (`*_pgmorl.xml`: the
published files, three of them converted to MuJoCo 4's local coordinates; `assets/NOTICE`
says how and carries both licences) and declare the rest. The published environments ran
MuJoCo 2.0 and these run MuJoCo 4 (`docs/environments.md` lists what differs).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from brax.envs.base import State

from wcac_jax.envs.mujoco_base import MujocoEnv, asset

EPISODE_LENGTH = 500


class PGMORLTask(MujocoEnv):
    """A task of PGMORL's benchmark on either engine; see the module docstring.

    A subclass sets `model_file` (in `assets/`), `objective_names`, `frame_skip`,
    `action_bound` if not 1, and implements `_declare(t)` (its utopia point and hypervolume
    reference for the time limit `t`) besides `MujocoEnv`'s `observation`, `outcome` (or
    `transition`) and `reset_metrics`.

    Args:
      episode_length: time limit in steps, `>= 1` (applied by `EpisodeWrapper`).
      engine: `"mujoco"` or `"mjx"`.
      reset_noise_scale: half-width of the uniform reset noise (0: the published reset).
      solver_iterations, ls_iterations: MuJoCo's solver settings (`None`: the model's
        own on `"mujoco"`, 4 and 4 on `"mjx"`).
    """

    model_file: str
    action_bound: float | tuple[float, ...] = 1.0
    height_body = None  # observations and terminations read the model's own qpos

    def __init__(
        self,
        episode_length: int = EPISODE_LENGTH,
        engine: str = "mujoco",
        reset_noise_scale: float = 0.0,
        solver_iterations: int | None = None,
        ls_iterations: int | None = None,
    ):
        super().__init__(
            asset(self.model_file),
            engine,
            episode_length,
            reset_noise_scale,
            solver_iterations,
            ls_iterations,
        )
        self._declare(float(episode_length))

    def _declare(self, t: float) -> None:
        raise NotImplementedError

    def clip(self, action: jax.Array) -> jax.Array:
        """`action [act]` clipped to the task's box, `[-action_bound, action_bound]`."""
        bound = np.asarray(self.action_bound, np.float32)
        return jnp.clip(action, -bound, bound)

    def step(self, state: State, action: jax.Array) -> State:
        return super().step(state, self.clip(action))

    @property
    def action_size(self) -> int:
        return int(self.mj_model.nu)
