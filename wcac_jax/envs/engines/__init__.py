"""Physics engines that step a MuJoCo model inside a compiled JAX program.

An engine is built from a `mujoco.MjModel` and the number of physics substeps per
environment step (`n_frames`), and offers two pure functions on one unbatched copy
(the caller vmaps; both run under `jit`, `vmap`, `scan` and sharding):

- `init(qpos [nq], qvel [nv]) -> data`: the physics state at those positions and
  velocities (float32 inputs; no host call);
- `step(data, action [nu]) -> (data, dqpos [nq])`: `n_frames` substeps with the action
  held, and the change of `qpos` over them computed at the engine's own precision
  (float32 differences of positions lose ~1e-5 m/s of velocity at x ~ 1 m).

Every `data` exposes float32 `qpos [nq]` and `qvel [nv]`. A task whose observation or
reward reads more of MuJoCo's state than `qpos` and `qvel` (contact forces, body
positions, centre-of-mass quantities) names those `mjData` fields (`fields`, e.g.
`("xpos", "cfrc_ext")`); both engines then keep them as Gymnasium's tasks see them after
a step (`mj_step` then `mj_rnePostConstraint`: the values of the step's last force
evaluation, not recomputed at the final positions) and after a reset (`mj_forward`; the
contact forces zero), read with `engine.field(data, name)` (float32, the field's shape)
and `engine.field_change(old, new, name)` (the change over a step, at the engine's
precision). Engines:

- `"mjx"` (`engines.mjx`): MJX, MuJoCo rewritten in JAX (float32), through Brax's MJX
  pipeline; the path for accelerators.
- `"mujoco"` (`engines.mujoco`): MuJoCo's own C engine in float64, called from inside the
  program through `jax.pure_callback`; every environment of a step (all `P x N`) goes to
  `mujoco.rollout` in one multi-threaded call. Many times faster on CPU.
"""

from __future__ import annotations

import mujoco

ENGINES = ("mjx", "mujoco")


def make(name: str, mj_model: mujoco.MjModel, n_frames: int, fields: tuple[str, ...] = ()):
    """The engine `name` stepping `mj_model` `n_frames` substeps per step, keeping the
    `mjData` `fields` (see the module docstring).

    Raises:
      ValueError: an unknown `name` (naming the valid ones).
    """
    if name == "mjx":
        from wcac_jax.envs.engines.mjx import MjxEngine

        return MjxEngine(mj_model, n_frames, fields)
    if name == "mujoco":
        from wcac_jax.envs.engines.mujoco import MujocoEngine

        return MujocoEngine(mj_model, n_frames, fields=fields)
    raise ValueError(f"unknown engine {name!r}; valid: {', '.join(ENGINES)}")


__all__ = ["ENGINES", "make"]
