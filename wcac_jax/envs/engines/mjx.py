"""The MJX engine: MuJoCo in JAX (float32) through Brax's MJX pipeline.

`data` is Brax's MJX pipeline state (an `mjx.Data` with `qpos`, `qvel`, and Brax's `q`,
`qd`, `x`, `xd`); `step` scans `n_frames` pipeline steps with the action held, exactly as
Brax's `PipelineEnv.pipeline_step`, so the numbers are those of the earlier
`PipelineEnv`-based Walker2d bit for bit. Fast on accelerators; on a CPU the `"mujoco"`
engine is several times faster. The `mjData` fields a task names are MJX's own (`cfrc_ext`
filled by `mjx.rne_postconstraint` after a step, as Gymnasium calls its C counterpart).
"""

from __future__ import annotations

import contextlib
import warnings

import jax
import mujoco
import numpy as np
from brax.io import mjcf
from brax.mjx import pipeline
from mujoco import mjx


@contextlib.contextmanager
def _local_device_first():
    """Inside, `jax.devices()` lists this process's devices only.

    MJX's `put_model` (called by Brax's `mjcf.load_model`, which takes no device) places
    the model on `jax.devices()[0]`: in a multi-process run that is process 0's first
    device, so every other process would hold a model it cannot read ("closing over a
    jax.Array that spans non-addressable devices" when the sweep compiles). Each process
    builds its environment on its own first device instead; one process: no change.
    """
    if jax.process_count() == 1:
        yield
        return
    real = jax.devices
    jax.devices = lambda backend=None: jax.local_devices(backend=backend)
    try:
        yield
    finally:
        jax.devices = real


class MjxEngine:
    """Steps `mj_model` with MJX; see the module docstring and `engines`."""

    name = "mjx"

    def __init__(self, mj_model: mujoco.MjModel, n_frames: int, fields: tuple[str, ...] = ()):
        with warnings.catch_warnings():
            # Brax's note that its own pipelines and environments are unmaintained: we
            # use only its MJX pipeline (MJX itself is maintained)
            warnings.filterwarnings(
                "ignore",
                message="Brax System, piplines and environments are not actively",
                category=UserWarning,
            )
            with _local_device_first():
                self.sys = mjcf.load_model(mj_model)
        self.n_frames = int(n_frames)
        self.dt = float(mj_model.opt.timestep) * self.n_frames
        self.init_qpos = np.asarray(mj_model.qpos0, np.float32)
        self.nq, self.nv = int(mj_model.nq), int(mj_model.nv)
        self.fields = tuple(fields)

    def init(self, qpos: jax.Array, qvel: jax.Array):
        """`qpos [nq]`, `qvel [nv]` -> Brax MJX pipeline state (after `mj_forward`)."""
        return pipeline.init(self.sys, qpos, qvel)

    def step(self, data, action: jax.Array):
        """`n_frames` substeps with `action [nu]` held -> `(data, dqpos [nq])`."""

        def substep(d, _):
            return pipeline.step(self.sys, d, action), None

        new = jax.lax.scan(substep, data, (), self.n_frames)[0]
        if "cfrc_ext" in self.fields:
            new = mjx.rne_postconstraint(self.sys, new)
        return new, new.qpos - data.qpos

    def field(self, data, name: str) -> jax.Array:
        """The `mjData` field `name` (one of `fields`) of `data`, float32."""
        return getattr(data, name)

    def field_change(self, old, new, name: str) -> jax.Array:
        """`name`'s change from `old` to `new` (float32 difference)."""
        return getattr(new, name) - getattr(old, name)
