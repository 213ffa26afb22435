"""The native engine: MuJoCo's C engine in float64, called from inside the compiled program.

`step` is a `jax.pure_callback` with `vmap_method="broadcast_all"`: however many `vmap`s
wrap it (the `N` environments, the `P` preferences), the host function receives the whole
batch of a step at once and hands it to ONE `mujoco.rollout` call, which steps every
environment `n_frames` substeps on a thread pool of `os.cpu_count()` threads. The call is
a pure function of its inputs, so `jit`, `scan`, chunking, checkpoints and sharding keep
working and a sweep stays one compiled program.

The state is exact: JAX runs in float32 (x64 off), so `MujocoData.physics` holds MuJoCo's
float64 full-physics state (`mjSTATE_FULLPHYSICS`: time, qpos, qvel, ...) bit-cast to
pairs of uint32 words, which the callback views back as float64. `qpos` and `qvel` are
float32 copies (rounded to nearest) for observations and health checks; `dqpos` (the
change of `qpos` over a step) is differenced in float64 before rounding.

`init` runs no host code: float32 positions and velocities are exactly representable in
float64, so their float64 bit patterns are built in JAX with integer operations.

Each step starts MuJoCo's constraint solver from a zero warm start (`rollout`'s default),
so a step depends on `(qpos, qvel, action)` only, never on which thread ran the
environment before; the solver's tolerance (1e-8) makes this invisible at float32 (one
step from MO-Gymnasium's states, whose warm start carries over: max 2.3e-13 apart on
observations).

A task that names `mjData` fields (`fields`, see `engines`) is stepped differently: the
data is `MujocoFieldsData`, which also carries those fields (float64 bits, a float32 copy
and their float32-rounded float64 change over the step), and the callback steps each
environment with `mj_step` then `mj_rnePostConstraint`, as Gymnasium does (its thread
pool's workers release the GIL inside MuJoCo), because `rollout` returns states and
sensors, not the derived quantities such tasks observe. A reset's fields come from
`mj_forward` on freshly reset data (one host call), so contact forces read zero there, as
Gymnasium's do.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct
from mujoco import rollout

_FULL = int(mujoco.mjtState.mjSTATE_FULLPHYSICS)


@struct.dataclass
class MujocoData:
    """One environment's physics state.

    Attributes:
      physics: `[2 * nstate]` uint32, MuJoCo's float64 full-physics state bit-cast
        (little-endian word pairs, as `np.ndarray.view(np.uint32)` gives).
      qpos: `[nq]` float32, the positions rounded from `physics`.
      qvel: `[nv]` float32, the velocities rounded from `physics`.
    """

    physics: jax.Array
    qpos: jax.Array
    qvel: jax.Array


@struct.dataclass
class MujocoFieldsData:
    """One environment's physics state with the `mjData` fields a task reads.

    Attributes:
      physics, qpos, qvel: as `MujocoData`'s.
      field_bits: `[2k]` uint32, the fields' float64 values bit-cast (`k` their total size).
      fields: `[k]` float32, the fields rounded.
      change: `[k]` float32, the fields' change over the step that led here, differenced in
        float64 (zero after a reset).
    """

    physics: jax.Array
    qpos: jax.Array
    qvel: jax.Array
    field_bits: jax.Array
    fields: jax.Array
    change: jax.Array


def _state_offset(mj_model: mujoco.MjModel, element: int) -> int:
    """Index of `element` (an `mjSTATE_*` bit) in the full-physics state vector."""
    offset, bit, element = 0, 1, int(element)
    while bit < element:
        if bit & _FULL:
            offset += mujoco.mj_stateSize(mj_model, bit)
        bit <<= 1
    return offset


def f32_to_f64_bits(x: jax.Array) -> jax.Array:
    """The float64 bit patterns of float32 values `x [k]`, as uint32 `[2k]` (low word
    first). Exact for every float32, subnormals, infinities and NaNs included."""
    b = jax.lax.bitcast_convert_type(jnp.asarray(x, jnp.float32), jnp.uint32)
    sign = b & jnp.uint32(0x80000000)
    exp = (b >> 23) & jnp.uint32(0xFF)
    man = b & jnp.uint32(0x7FFFFF)
    subnormal = (exp == 0) & (man != 0)
    # a float32 subnormal is a normal float64: move its leading one to bit 23
    shift = jax.lax.clz(man) - jnp.uint32(8)
    man = jnp.where(subnormal, (man << shift) & jnp.uint32(0x7FFFFF), man)
    exp64 = jnp.where(
        subnormal,
        jnp.uint32(897) - shift,
        jnp.where(exp == 0, 0, jnp.where(exp == 255, 2047, exp + 896)).astype(jnp.uint32),
    )
    hi = sign | (exp64 << 20) | (man >> 3)
    lo = man << 29
    return jnp.stack([lo, hi], axis=-1).reshape(-1)


class MujocoEngine:
    """Steps `mj_model` with MuJoCo's C engine; see the module docstring and `engines`.

    Args:
      mj_model: the model (kept; the engine owns its thread pool and `MjData`s).
      n_frames: physics substeps per environment step, the action held.
      nthread: threads of the rollout pool (`None`: `os.cpu_count()`). Results do not
        depend on it: every environment is stepped on its own.
    """

    name = "mujoco"

    def __init__(
        self,
        mj_model: mujoco.MjModel,
        n_frames: int,
        nthread: int | None = None,
        fields: tuple[str, ...] = (),
    ):
        self.model = mj_model
        self.n_frames = int(n_frames)
        self.dt = float(mj_model.opt.timestep) * self.n_frames
        self.init_qpos = np.asarray(mj_model.qpos0, np.float32)
        self.nq, self.nv, self.nu = int(mj_model.nq), int(mj_model.nv), int(mj_model.nu)
        self.nstate = mujoco.mj_stateSize(mj_model, _FULL)
        self._qpos_at = _state_offset(mj_model, mujoco.mjtState.mjSTATE_QPOS)
        self._qvel_at = _state_offset(mj_model, mujoco.mjtState.mjSTATE_QVEL)
        data = mujoco.MjData(mj_model)
        default = np.empty(self.nstate, np.float64)
        mujoco.mj_getState(mj_model, data, default, _FULL)
        self._default = default  # time 0, qpos0, zero velocities, the model's mocap, ...
        self.nthread = max(1, (os.cpu_count() or 1) if nthread is None else int(nthread))
        self._pool = None
        self._datas = None
        # one rollout at a time per engine: the pool and its MjData are shared (callbacks
        # of several devices may arrive concurrently)
        self._lock = threading.Lock()
        self.fields = tuple(fields)
        self._layout = {}  # field -> (offset, shape) in the flat `[k]` vector
        offset = 0
        for name in self.fields:
            shape = getattr(data, name).shape
            self._layout[name] = (offset, shape)
            offset += int(np.prod(shape))
        self.nfields = offset
        self._executor = None
        self._field_datas = None

    # ------------------------------------------------------------------ pure JAX side

    def init(self, qpos: jax.Array, qvel: jax.Array) -> MujocoData:
        """`qpos [nq]`, `qvel [nv]` (float32) -> the state at time 0 with those values."""
        qpos = jnp.asarray(qpos, jnp.float32)
        qvel = jnp.asarray(qvel, jnp.float32)
        physics = jnp.asarray(self._default.view(np.uint32))
        physics = physics.at[2 * self._qpos_at : 2 * (self._qpos_at + self.nq)].set(
            f32_to_f64_bits(qpos)
        )
        physics = physics.at[2 * self._qvel_at : 2 * (self._qvel_at + self.nv)].set(
            f32_to_f64_bits(qvel)
        )
        if not self.fields:
            return MujocoData(physics=physics, qpos=qpos, qvel=qvel)
        k = self.nfields
        bits, values = jax.pure_callback(
            self._host_forward,
            (
                jax.ShapeDtypeStruct((2 * k,), jnp.uint32),
                jax.ShapeDtypeStruct((k,), jnp.float32),
            ),
            physics,
            vmap_method="broadcast_all",
        )
        zero = jnp.zeros((k,), jnp.float32)
        return MujocoFieldsData(physics, qpos, qvel, bits, values, zero)

    def field(self, data: MujocoFieldsData, name: str) -> jax.Array:
        """The `mjData` field `name` (one of `fields`) of `data`, float32, its own shape."""
        offset, shape = self._layout[name]
        return data.fields[offset : offset + int(np.prod(shape))].reshape(shape)

    def field_change(self, old: MujocoFieldsData, new: MujocoFieldsData, name: str) -> jax.Array:
        """`name`'s change over the step from `old` to `new`, differenced in float64."""
        del old  # the step differenced it already, before rounding
        offset, shape = self._layout[name]
        return new.change[offset : offset + int(np.prod(shape))].reshape(shape)

    def step(self, data: MujocoData, action: jax.Array) -> tuple[MujocoData, jax.Array]:
        """`n_frames` substeps with `action [nu]` held -> `(data, dqpos [nq])`."""
        if self.fields:
            return self._step_fields(data, action)
        shapes = (
            jax.ShapeDtypeStruct((2 * self.nstate,), jnp.uint32),
            jax.ShapeDtypeStruct((self.nq,), jnp.float32),
            jax.ShapeDtypeStruct((self.nv,), jnp.float32),
            jax.ShapeDtypeStruct((self.nq,), jnp.float32),
        )
        physics, qpos, qvel, dqpos = jax.pure_callback(
            self._host_step,
            shapes,
            data.physics,
            jnp.asarray(action, jnp.float32),
            vmap_method="broadcast_all",
        )
        return MujocoData(physics=physics, qpos=qpos, qvel=qvel), dqpos

    def _step_fields(self, data: MujocoFieldsData, action: jax.Array):
        k = self.nfields
        shapes = (
            jax.ShapeDtypeStruct((2 * self.nstate,), jnp.uint32),
            jax.ShapeDtypeStruct((self.nq,), jnp.float32),
            jax.ShapeDtypeStruct((self.nv,), jnp.float32),
            jax.ShapeDtypeStruct((self.nq,), jnp.float32),
            jax.ShapeDtypeStruct((2 * k,), jnp.uint32),
            jax.ShapeDtypeStruct((k,), jnp.float32),
            jax.ShapeDtypeStruct((k,), jnp.float32),
        )
        physics, qpos, qvel, dqpos, bits, values, change = jax.pure_callback(
            self._host_step_fields,
            shapes,
            data.physics,
            data.field_bits,
            jnp.asarray(action, jnp.float32),
            vmap_method="broadcast_all",
        )
        return MujocoFieldsData(physics, qpos, qvel, bits, values, change), dqpos

    # ------------------------------------------------------------------ host side

    def host_data(self, qpos: np.ndarray, qvel: np.ndarray) -> MujocoData:
        """A (batch of) state(s) from float64 `qpos [..., nq]`, `qvel [..., nv]`, exactly
        (e.g. to start from a MuJoCo or Gymnasium state)."""
        qpos = np.asarray(qpos, np.float64)
        qvel = np.asarray(qvel, np.float64)
        batch = qpos.shape[:-1]
        full = np.tile(self._default, (*batch, 1))
        full[..., self._qpos_at : self._qpos_at + self.nq] = qpos
        full[..., self._qvel_at : self._qvel_at + self.nv] = qvel
        base = MujocoData(
            physics=jnp.asarray(full.view(np.uint32)),
            qpos=jnp.asarray(qpos, jnp.float32),
            qvel=jnp.asarray(qvel, jnp.float32),
        )
        if not self.fields:
            return base
        bits, values = self._host_forward(full.view(np.uint32))
        change = jnp.zeros(values.shape, jnp.float32)
        return MujocoFieldsData(
            base.physics, base.qpos, base.qvel, jnp.asarray(bits), jnp.asarray(values), change
        )

    def _read_fields(self, data: mujoco.MjData) -> np.ndarray:
        return np.concatenate([getattr(data, name).ravel() for name in self.fields])

    def _host_forward(self, physics: np.ndarray):
        """`physics [..., 2 * nstate]` -> the fields after `mj_forward` on freshly reset
        data: `(bits [..., 2k] uint32, values [..., k] float32)`."""
        batch = physics.shape[:-1]
        state = np.ascontiguousarray(physics).reshape(-1, 2 * self.nstate).view(np.float64)
        out = np.empty((len(state), self.nfields), np.float64)
        data = mujoco.MjData(self.model)
        for i, s in enumerate(state):
            mujoco.mj_resetData(self.model, data)
            mujoco.mj_setState(self.model, data, s, _FULL)
            mujoco.mj_forward(self.model, data)
            out[i] = self._read_fields(data)
        return (
            out.view(np.uint32).reshape(*batch, 2 * self.nfields),
            out.astype(np.float32).reshape(*batch, self.nfields),
        )

    def _host_step_fields(self, physics: np.ndarray, bits: np.ndarray, action: np.ndarray):
        """The callback of a task with fields: `physics [..., 2 * nstate]`, `bits [..., 2k]`
        uint32 and `action [..., nu]` -> `(physics, qpos, qvel, dqpos, bits, values,
        change)` with the same leading batch axes."""
        batch = physics.shape[:-1]
        state = np.ascontiguousarray(physics).reshape(-1, 2 * self.nstate).view(np.float64)
        old = np.ascontiguousarray(bits).reshape(-1, 2 * self.nfields).view(np.float64)
        control = np.asarray(action, np.float64).reshape(-1, self.nu)
        n = len(state)
        new = np.empty_like(state)
        out = np.empty((n, self.nfields), np.float64)

        def work(t: int) -> None:
            data = self._field_datas[t]
            for i in range(t, n, self.nthread):
                mujoco.mj_setState(self.model, data, state[i], _FULL)
                data.qacc_warmstart[:] = 0.0  # as rollout: a step depends on its inputs only
                data.ctrl[:] = control[i]
                mujoco.mj_step(self.model, data, nstep=self.n_frames)
                mujoco.mj_rnePostConstraint(self.model, data)
                mujoco.mj_getState(self.model, data, new[i], _FULL)
                out[i] = self._read_fields(data)

        with self._lock:
            if self._executor is None:
                self._executor = ThreadPoolExecutor(max_workers=self.nthread)
                self._field_datas = [mujoco.MjData(self.model) for _ in range(self.nthread)]
            list(self._executor.map(work, range(self.nthread)))
        qpos = new[:, self._qpos_at : self._qpos_at + self.nq]
        qvel = new[:, self._qvel_at : self._qvel_at + self.nv]
        dqpos = qpos - state[:, self._qpos_at : self._qpos_at + self.nq]
        k = self.nfields
        return (
            np.ascontiguousarray(new).view(np.uint32).reshape(*batch, 2 * self.nstate),
            qpos.astype(np.float32).reshape(*batch, self.nq),
            qvel.astype(np.float32).reshape(*batch, self.nv),
            dqpos.astype(np.float32).reshape(*batch, self.nq),
            out.view(np.uint32).reshape(*batch, 2 * k),
            out.astype(np.float32).reshape(*batch, k),
            (out - old).astype(np.float32).reshape(*batch, k),
        )

    def _rollout(self, state: np.ndarray, control: np.ndarray) -> np.ndarray:
        with self._lock:
            if self._pool is None:
                self._pool = rollout.Rollout(nthread=self.nthread)
                self._datas = [mujoco.MjData(self.model) for _ in range(max(1, self.nthread))]
            out, _ = self._pool.rollout(
                self.model, self._datas, state, control, nstep=self.n_frames
            )
        return out[:, -1]

    def _host_step(self, physics: np.ndarray, action: np.ndarray):
        """The callback: `physics [..., 2 * nstate]` uint32, `action [..., nu]` ->
        `(physics, qpos, qvel, dqpos)` with the same leading batch axes."""
        batch = physics.shape[:-1]
        state = np.ascontiguousarray(physics).reshape(-1, 2 * self.nstate).view(np.float64)
        control = np.asarray(action, np.float64).reshape(-1, 1, self.nu)
        new = self._rollout(state, control)
        qpos = new[:, self._qpos_at : self._qpos_at + self.nq]
        qvel = new[:, self._qvel_at : self._qvel_at + self.nv]
        dqpos = qpos - state[:, self._qpos_at : self._qpos_at + self.nq]
        return (
            np.ascontiguousarray(new).view(np.uint32).reshape(*batch, 2 * self.nstate),
            qpos.astype(np.float32).reshape(*batch, self.nq),
            qvel.astype(np.float32).reshape(*batch, self.nv),
            dqpos.astype(np.float32).reshape(*batch, self.nq),
        )
