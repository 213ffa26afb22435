"""`MujocoEnv`: the part every MuJoCo locomotion task shares, so that a task is its
observation, its reward vector and its health check.

The base owns

- the model: an MJCF file (`asset(name)` for the ones shipped in `assets/`, each with its
  licence in `assets/NOTICE`), loaded with optional solver overrides (`load_model`);
- the physics engine (`engines`): `"mujoco"` (MuJoCo's C engine in float64 inside the
  compiled program) or `"mjx"` (MJX in float32). On MJX a Gymnasium model's constraint
  solver is capped at `MJX_SOLVER_CAP` iterations and line-search iterations unless the
  task is given its own (Gymnasium's models ask for MuJoCo's 100 and 50, which MJX pays
  for on every step whether it needs them or not; `walker2d` measures what the cap
  costs); the `"mujoco"` engine keeps the model's settings, as Gymnasium does;
- `frame_skip` physics substeps per step (`dt = frame_skip * timestep`);
- resets: the model's initial positions plus uniform noise in `[-s, s]`
  (`reset_noise_scale`), velocities uniform in `[-s, s]` (or `s` times a standard normal,
  `velocity_noise = "normal"`, as HalfCheetah), as Gymnasium's v5 tasks;
- the height convention: when `height_body` is set, `qpos(data)` reports `qpos[1]` (the
  root's slide along z) as that body's world height, whatever the model's own `rootz`
  origin (Brax's walker measures it from 1.25 m, Gymnasium's models from the floor);
- the rendering hook: the model and a side camera tracking `height_body`.

A task subclass declares `objective_names`, `observation_size`, `action_size` (and
`frame_skip`, `height_body`, `velocity_noise` if they differ), sets `default_j_ub` and
`default_hv_ref` (as class attributes, or in its constructor when they depend on
`episode_length`), and implements

- `observation(data) -> [observation_size]`;
- `outcome(data, dqpos, action) -> (reward [m], done [], metrics)`: the step's reward
  vector, whether it is terminal (a fall) and its reward terms by name, from the state
  after the step, the change of `qpos` over it (`dqpos`, at the engine's precision) and
  the action taken;
- `reset_metrics(data)`: the same metrics' values at a reset.

A task that reads more of MuJoCo's state than `qpos` and `qvel` names those `mjData`
fields in `fields` (read with `self.engine.field(data, name)`, see `engines`) and may
override `transition(old, data, dqpos, action)`, which sees the state before the step too
(`self.engine.field_change(old, data, name)`), instead of `outcome`.

`data` is the engine's state: float32 `data.qpos [nq]` and `data.qvel [nv]` in the model's
own coordinates (`qpos(data)` in the task's).
"""

from __future__ import annotations

import os

import jax
import jax.numpy as jnp
import mujoco
from brax.envs.base import State

from wcac_jax.envs import engines
from wcac_jax.envs.base import MOEnv, Scene, positive_int
from wcac_jax.envs.engines import ENGINES

MJX_SOLVER_CAP = 4
ASSETS = os.path.join(os.path.dirname(__file__), "assets")


def asset(name: str) -> str:
    """Path of the MJCF file `name` shipped in `wcac_jax/envs/assets`."""
    return os.path.join(ASSETS, name)


def load_model(
    path: str, solver_iterations: int | None = None, ls_iterations: int | None = None
) -> mujoco.MjModel:
    """The MuJoCo model at `path`, with optional solver overrides (`opt.iterations`,
    `opt.ls_iterations`).

    A model whose compiler sets the total mass (`settotalmass`, as Gymnasium's
    HalfCheetah does; deprecated since MuJoCo 4) compiles without it and is then scaled
    by `mj_setTotalmass` and `mj_setConst`, MuJoCo's named replacement: the same model
    as MuJoCo's own loader gives, without the deprecation warning."""
    spec = mujoco.MjSpec.from_file(path)
    total_mass = spec.compiler.settotalmass
    spec.compiler.settotalmass = -1.0
    model = spec.compile()
    if total_mass > 0:
        mujoco.mj_setTotalmass(model, total_mass)
        mujoco.mj_setConst(model, mujoco.MjData(model))
    if solver_iterations is not None:
        model.opt.iterations = solver_iterations
    if ls_iterations is not None:
        model.opt.ls_iterations = ls_iterations
    return model


class MujocoEnv(MOEnv):
    """A MuJoCo task on either engine; see the module docstring.

    Args:
      model_path: the MJCF file.
      engine: `"mujoco"` or `"mjx"`.
      episode_length: time limit in steps, `>= 1` (applied by `EpisodeWrapper`).
      reset_noise_scale: half-width of the uniform reset noise, `>= 0`.
      solver_iterations, ls_iterations: MuJoCo's `opt.iterations` and
        `opt.ls_iterations` (`None`: `MJX_SOLVER_CAP` on MJX if `cap_mjx_solver`,
        otherwise the model's own).
      cap_mjx_solver: whether MJX caps the model's solver by default (a Gymnasium model
        asks for more iterations than MJX needs; Brax's own models do not).
    """

    frame_skip: int = 4
    height_body: str | None = "torso"
    velocity_noise: str = "uniform"
    fields: tuple[str, ...] = ()

    def __init__(
        self,
        model_path: str,
        engine: str,
        episode_length: int,
        reset_noise_scale: float,
        solver_iterations: int | None = None,
        ls_iterations: int | None = None,
        cap_mjx_solver: bool = True,
    ):
        if engine not in ENGINES:
            raise ValueError(f"unknown engine {engine!r}; valid: {', '.join(ENGINES)}")
        positive_int("episode_length", episode_length)
        for name, value in (
            ("solver_iterations", solver_iterations),
            ("ls_iterations", ls_iterations),
        ):
            if value is not None and (not isinstance(value, int) or value < 1):
                raise ValueError(f"{name} must be a positive integer or None, got {value!r}")
        if not reset_noise_scale >= 0:
            raise ValueError(f"reset_noise_scale must be >= 0, got {reset_noise_scale!r}")
        if cap_mjx_solver and engine == "mjx":
            solver_iterations = MJX_SOLVER_CAP if solver_iterations is None else solver_iterations
            ls_iterations = MJX_SOLVER_CAP if ls_iterations is None else ls_iterations
        self.episode_length = episode_length
        self._noise = float(reset_noise_scale)
        self.mj_model = load_model(model_path, solver_iterations, ls_iterations)
        self._z_offset = self._height_offset(self.mj_model)
        self.engine = engines.make(engine, self.mj_model, self.frame_skip, self.fields)
        self.dt = self.engine.dt

    def _height_offset(self, mj_model: mujoco.MjModel) -> float | None:
        """`height_body`'s world height minus `qpos[1]` at the model's initial positions
        (0 for Gymnasium's models, 1.25 for Brax's walker); `None` without `height_body`."""
        if self.height_body is None:
            return None
        data = mujoco.MjData(mj_model)
        mujoco.mj_forward(mj_model, data)
        body = mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_BODY, self.height_body)
        return float(data.xpos[body, 2] - data.qpos[1])

    # ------------------------------------------------------------------ the task's part

    def observation(self, data) -> jax.Array:
        raise NotImplementedError

    def outcome(self, data, dqpos: jax.Array, action: jax.Array):
        raise NotImplementedError

    def reset_metrics(self, data) -> dict:
        raise NotImplementedError

    def transition(self, old, data, dqpos: jax.Array, action: jax.Array):
        """`outcome` of the step from `old` to `data` (a task with `fields` may read
        their change over the step here)."""
        del old
        return self.outcome(data, dqpos, action)

    # ------------------------------------------------------------------ every task

    def reset(self, rng: jax.Array) -> State:
        key_q, key_qd = jax.random.split(rng)
        lo, hi = -self._noise, self._noise
        nq, nv = self.engine.nq, self.engine.nv
        qpos = jnp.asarray(self.engine.init_qpos) + jax.random.uniform(
            key_q, (nq,), minval=lo, maxval=hi
        )
        if self.velocity_noise == "normal":
            qvel = self._noise * jax.random.normal(key_qd, (nv,))
        else:
            qvel = jax.random.uniform(key_qd, (nv,), minval=lo, maxval=hi)
        data = self.engine.init(qpos, qvel)
        zero = jnp.zeros((), jnp.float32)
        reward = jnp.zeros(self.num_objectives, jnp.float32)
        return State(data, self.observation(data), reward, zero, self.reset_metrics(data))

    def step(self, state: State, action: jax.Array) -> State:
        data, dqpos = self.engine.step(state.pipeline_state, action)
        reward, done, metrics = self.transition(state.pipeline_state, data, dqpos, action)
        return state.replace(
            pipeline_state=data,
            obs=self.observation(data),
            reward=reward,
            done=done,
            metrics=metrics,
        )

    def pipeline_init(self, qpos: jax.Array, qvel: jax.Array):
        """The engine's physics state at `qpos [nq]`, `qvel [nv]` (in the model's own
        coordinates), e.g. to step from a given state."""
        return self.engine.init(qpos, qvel)

    def qpos(self, data) -> jax.Array:
        """`qpos [nq]` in the task's convention: `qpos[1]` is `height_body`'s world
        height (unchanged without `height_body`)."""
        if self._z_offset is None:
            return data.qpos
        return data.qpos.at[1].add(self._z_offset)

    def render_scene(self) -> Scene:
        """A side view tracking `height_body` (the first body without one)."""
        body = self.height_body or mujoco.mj_id2name(self.mj_model, mujoco.mjtObj.mjOBJ_BODY, 1)
        return Scene(self.mj_model, body, distance=3.0, elevation=-10.0, azimuth=90.0)

    @property
    def backend(self) -> str:
        return self.engine.name
