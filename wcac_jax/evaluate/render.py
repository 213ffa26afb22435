"""Pictures of trained policies: each preference's deterministic policy rolled out from a
start state, and MuJoCo's renderer drawing the environment at the positions it reached.

Two steps, so that the rollout stays a pure function of the trained state:

- `make_rollout(trainer, env, steps)` -> `rollout(state, key) -> (qpos [steps + 1, nq],
  length [], fell [])`, one preference's episode (the deterministic policy `trainer.mean_action`,
  the raw environment without auto-reset); positions after the step the agent falls are
  held at the fallen pose. Vmap it over the sweep's preference axis.
- `render(env, qpos [T, nq])` -> RGB frames `uint8 [T, height, width, 3]` on the host,
  drawn as the environment's rendering hook says (`env.render_scene()`: its MuJoCo model
  and a camera following it); an environment without one has no pictures.

MuJoCo picks its OpenGL platform when it is first imported (`MUJOCO_GL`): on a machine
without a display, set `MUJOCO_GL=egl` before anything imports `mujoco` (as
`experiments/walker2d_film.py` does), or `render` raises naming the setting.
"""

from __future__ import annotations

import os
from collections.abc import Callable

import chex
import jax
import jax.numpy as jnp
import numpy as np

from wcac_jax.core.types import typed_key


def make_rollout(trainer, env, steps: int) -> Callable:
    """`rollout(state, key) -> (qpos [steps + 1, nq] float32, length [] int32, fell [] bool)`.

    `state`: ONE preference's training state (`trainer.init`'s tree, no preference
    axis); `key`: the start state's key (`env.reset(key)`). `qpos[0]` is the start,
    `qpos[t]` the positions after step `t` (the model's own coordinates, as its MuJoCo
    model reads them); `length` counts the steps up to and including the one the agent
    fell on (`steps` if it did not), `fell` whether it did, and `qpos[length:]` all equal
    `qpos[length]`.
    """

    def rollout(state, key: chex.PRNGKey):
        start = env.reset(typed_key(key))

        def step(carry, _):
            env_state, alive, length, held = carry
            env_state = env.step(env_state, trainer.mean_action(state, env_state.obs))
            qpos = jnp.where(alive, env_state.pipeline_state.qpos, held)
            length = length + alive.astype(jnp.int32)
            alive = alive & (env_state.done == 0)
            return (env_state, alive, length, qpos), qpos

        q0 = start.pipeline_state.qpos
        carry = (start, jnp.bool_(True), jnp.int32(0), q0)
        (_, alive, length, _), qpos = jax.lax.scan(step, carry, None, length=steps)
        return jnp.concatenate([q0[None], qpos]), length, ~alive

    return rollout


def render(env, qpos: np.ndarray, width: int = 240, height: int = 240) -> np.ndarray:
    """RGB frames `uint8 [T, height, width, 3]` of `env` at each row of `qpos [T, nq]`
    (its model's own coordinates, as `make_rollout` returns them), by the camera of
    `env.render_scene()`.

    Raises:
      ValueError: `env` has no rendering hook, or `qpos` is not `[T, nq]`.
      RuntimeError: no OpenGL context (MuJoCo's platform is `MUJOCO_GL`, read when
        `mujoco` is first imported).
    """
    import mujoco

    hook = getattr(env, "render_scene", None)
    scene = hook() if hook is not None else None
    if scene is None:
        raise ValueError(f"environment {type(env).__name__} has nothing to render")
    model = scene.model
    qpos = np.asarray(qpos, np.float64)
    if qpos.ndim != 2 or qpos.shape[1] != model.nq:
        raise ValueError(f"qpos must be [T, {model.nq}], got shape {qpos.shape}")
    data = mujoco.MjData(model)
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_TRACKING
    camera.trackbodyid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, scene.track_body)
    camera.distance, camera.elevation = scene.distance, scene.elevation
    camera.azimuth = scene.azimuth
    frames = np.empty((len(qpos), height, width, 3), np.uint8)
    try:
        renderer = mujoco.Renderer(model, height, width)
    except Exception as err:  # which error depends on the OpenGL platform:
        # FatalError (no context), AttributeError (MUJOCO_GL=disable, or osmesa without
        # libOSMesa), or whatever PyOpenGL raises: all mean no OpenGL context
        gl = os.environ.get("MUJOCO_GL")
        raise RuntimeError(
            f"MuJoCo's renderer found no OpenGL context (MUJOCO_GL={gl!r} when mujoco was "
            "imported; without a display set MUJOCO_GL=egl before importing it): "
            f"{type(err).__name__}: {err}"
        ) from None
    # no reflections, shadows or sky: plainer frames, which animations compress better
    for flag in ("mjRND_REFLECTION", "mjRND_SHADOW", "mjRND_SKYBOX"):
        renderer.scene.flags[getattr(mujoco.mjtRndFlag, flag)] = False
    try:
        for t, q in enumerate(qpos):
            data.qpos[:] = q
            mujoco.mj_forward(model, data)
            renderer.update_scene(data, camera=camera)
            frames[t] = renderer.render()
    finally:
        renderer.close()
    return frames
