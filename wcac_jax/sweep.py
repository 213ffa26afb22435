"""A whole Pareto front in one compiled program: `run_sweep` (`python -m wcac_jax.sweep`
is its command line, `wcac_jax.cli`).

All preferences (and their `N` environments each) train in ONE compiled program,
`jit(vmap(chunk))` over the preference axis, with keys and preferences as traced
arguments. This module is the one impure edge of the package: it owns the host loop
over chunks, the orbax checkpoints after every chunk, the progress bar, the clocks and
every file written.

Chunking does not change the numbers: iteration `t` of preference `i` draws its
randomness from `fold_in(fold_in(key(seed), i), t)`, and every chunk is the same
compiled program of `ceil(T / chunks)` iterations whose iterations past `T` leave the
state untouched. `--resume` restores the last checkpoint and continues bit for bit.

Devices: the preference axis is split over every device (a 1-D mesh whose axis is
`utopia.DEVICE_AXIS`), and each device runs the vmapped program on its own preferences
(`jax.shard_map`); a preference count that does not divide evenly is padded by repeating
the last preference, and the padding is dropped from the results. Several processes
(`wcac_jax.distributed`; `--coordinator` on the command line): the mesh spans every
process's devices, each process runs its shards, and only process 0 reads and writes
`out`.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

import jax
import jax.extend
import jax.numpy as jnp
import numpy as np
from jax.sharding import PartitionSpec as P

from wcac_jax import algos, checkpoint, distributed, envs, selection
from wcac_jax.algos import PaperConfig, make_evaluate, make_trainer
from wcac_jax.outputs import json_bytes, summarize, unwritable_dir, write_atomic, write_outputs
from wcac_jax.presets import PAPER_PREFS
from wcac_jax.runtime import (
    TRACED_DIRECTIONS,
    Trainer,
    UpdateState,
    resolve_j_ub,
    with_env_steps,
)
from wcac_jax.utopia import DEVICE_AXIS, PREF_AXIS

PAPER_STEPS_PER_PREF = 1_000_000
MAX_ITERATIONS = 2**31 - 1  # `UpdateState.iteration` is int32


class SweepError(ValueError):
    """Bad input to a sweep; the CLI prints it as one line and exits with status 2."""


class TrainingDiverged(RuntimeError):
    """NaN appeared during training; the last good checkpoint is kept."""


@dataclass(frozen=True)
class SweepConfig:
    """Everything that determines a sweep's numbers.

    Attributes:
      prefs: `P` preference vectors, each on the simplex.
      env: registered environment name.
      env_options: keyword options of the environment (e.g. `physics`).
      train: the per-preference training configuration, the paper's (`PaperConfig`)
        or the practical one (`PracticalConfig`); its `num_iterations` is derived from
        `steps_per_pref`.
      steps_per_pref: environment steps per preference (rounded up to whole iterations).
      seed: base seed; preference `i` uses `fold_in(key(seed), i)`.
      eval_episodes: episodes of the mean policy evaluated per preference at the end.
      hv_ref: hypervolume reference point (`None`: the environment's default).
      device_count: devices the preference axis is sharded over (`None`: every device
        JAX has; `run_sweep` records the count it used). Results are bit-identical for
        the same config, device count included, and any chunking; across device counts
        they differ by rounding (XLA compiles different per-device batch shapes).
      select_last: each preference reports the best of its last `select_last` policies
        (`wcac_jax.selection`; 1: the final policy, no choice).
      select_every: environment steps between those candidates (rounded up to whole
        iterations; needed when `select_last > 1`).
    """

    prefs: tuple[tuple[float, ...], ...]
    env: str = "walker2d"
    env_options: dict = field(default_factory=dict)
    train: algos.AnyConfig = field(default_factory=PaperConfig)
    steps_per_pref: int = 100_000
    seed: int = 0
    eval_episodes: int = 8
    hv_ref: tuple[float, ...] | None = None
    device_count: int | None = None
    select_last: int = 1
    select_every: int = 0

    def __post_init__(self):
        for name in ("steps_per_pref", "eval_episodes", "select_last"):
            value = getattr(self, name)
            if not isinstance(value, int | np.integer) or isinstance(value, bool) or value < 1:
                raise SweepError(f"{name} must be a positive integer, got {value!r}")
        if self.num_iterations > MAX_ITERATIONS:
            raise SweepError(
                f"steps_per_pref {self.steps_per_pref} needs {self.num_iterations:,} iterations of "
                f"{self.train.env_steps_per_iteration:,} env steps; at most {MAX_ITERATIONS:,} "
                "(the iteration counter is int32)"
            )
        if not isinstance(self.seed, int | np.integer) or not -(2**63) <= self.seed < 2**63:
            raise SweepError(f"seed must be an integer in [-2**63, 2**63), got {self.seed!r}")
        if self.hv_ref is not None:
            try:
                hv_ref = tuple(float(v) for v in self.hv_ref)
            except (TypeError, ValueError):
                raise SweepError(f"hv_ref must be a list of numbers, got {self.hv_ref!r}") from None
            if not all(math.isfinite(v) for v in hv_ref):
                raise SweepError(f"hv_ref must be finite, got {list(hv_ref)}")
            object.__setattr__(self, "hv_ref", hv_ref)
        every = self.select_every
        if not isinstance(every, int | np.integer) or isinstance(every, bool) or every < 0:
            raise SweepError(f"select_every must be a non-negative integer, got {every!r}")
        if self.select_last > 1 and every < 1:
            raise SweepError(
                f"select_last {self.select_last} needs select_every >= 1 (env steps between "
                f"the candidates), got {every}"
            )
        try:
            self.candidate_iterations  # noqa: B018 (validates)
        except ValueError as err:
            raise SweepError(str(err)) from None

    @property
    def num_iterations(self) -> int:
        """Outer iterations `T` per preference."""
        return max(1, math.ceil(self.steps_per_pref / self.train.env_steps_per_iteration))

    @property
    def candidate_iterations(self) -> tuple[int, ...]:
        """The iterations whose policies `wcac_jax.selection` chooses among."""
        every = math.ceil(self.select_every / self.train.env_steps_per_iteration)
        return selection.candidate_iterations(self.num_iterations, self.select_last, every)

    def train_config(self) -> algos.AnyConfig:
        return self.train.replace(num_iterations=self.num_iterations)

    def to_dict(self) -> dict:
        return {
            "prefs": [list(p) for p in self.prefs],
            "env": self.env,
            "env_options": dict(self.env_options),
            "train": algos.to_dict(self.train_config()),
            "steps_per_pref": self.steps_per_pref,
            "seed": self.seed,
            "eval_episodes": self.eval_episodes,
            "hv_ref": None if self.hv_ref is None else list(self.hv_ref),
            "device_count": self.device_count,
            "select_last": self.select_last,
            "select_every": self.select_every,
        }

    @classmethod
    def from_dict(cls, d: dict) -> SweepConfig:
        """The inverse of `to_dict` (e.g. a run's `config.json`)."""
        return cls(
            prefs=tuple(tuple(float(x) for x in p) for p in d["prefs"]),
            env=d["env"],
            env_options=dict(d["env_options"]),
            train=algos.from_dict(d["train"]),
            steps_per_pref=int(d["steps_per_pref"]),
            seed=int(d["seed"]),
            eval_episodes=int(d["eval_episodes"]),
            hv_ref=None if d["hv_ref"] is None else tuple(d["hv_ref"]),
            device_count=d.get("device_count"),
            select_last=int(d.get("select_last", 1)),
            select_every=int(d.get("select_every", 0)),
        )


def validate_prefs(prefs, m: int) -> np.ndarray:
    """Checks `P` preference vectors: length `m`, finite, non-negative, summing to 1
    within 1e-6 (they are not normalised, so that what runs is what was asked for)."""
    if len(prefs) < 1:
        raise SweepError(f"preferences must be a non-empty list of vectors, got {prefs!r}")
    for i, p in enumerate(prefs):
        p = np.asarray(p, dtype=np.float64).reshape(-1)
        if p.shape[0] != m:
            raise SweepError(
                f"preference #{i} {p.tolist()} has {p.shape[0]} entries; "
                f"the environment has {m} objectives"
            )
        if not np.all(np.isfinite(p)):
            raise SweepError(f"preference #{i} {p.tolist()} is not finite")
        if np.any(p < 0):
            raise SweepError(f"preference #{i} {p.tolist()} has a negative entry")
        if abs(p.sum() - 1.0) > 1e-6:
            raise SweepError(f"preference #{i} {p.tolist()} sums to {p.sum():.6g}, not 1")
    return np.asarray(prefs, dtype=np.float64)


def default_hv_ref(env) -> tuple[float, ...]:
    """The environment's hypervolume reference point, `env.default_hv_ref`.

    The rule every environment follows: per objective, the least return an episode can
    have (for an unbounded objective, a stated floor far below any return seen), so that
    every policy's point lies in the reference box and counts; `front.json` lists any
    policy that does not (`outside_hv_ref`).
    """
    ref = getattr(env, "default_hv_ref", None)
    if ref is None:
        raise SweepError(
            f"environment {type(env).__name__} has no default_hv_ref; pass hv_ref (--hv-ref)"
        )
    return tuple(float(v) for v in ref)


def make_env(config: SweepConfig):
    """The environment of `config`; a bad name or option is a `SweepError`."""
    try:
        return envs.make(config.env, **config.env_options)
    except (ValueError, TypeError) as err:
        raise SweepError(str(err)) from None


def _flatten(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(_flatten(v, key + "."))
        else:
            out[key] = v
    return out


def check_output_dir(out: str, config: SweepConfig, resume: bool) -> None:
    """Checks `out` can be written (creating nothing); on resume, that the config matches."""
    if resume:
        path = os.path.join(out, "config.json")
        if not os.path.isfile(path):
            raise SweepError(f"--resume: no sweep to resume in {out!r} (no config.json)")
        try:
            with open(path) as f:
                saved = json.load(f)
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
            raise SweepError(f"--resume: {path!r} is not readable JSON ({err})") from None
        if not isinstance(saved, dict):
            raise SweepError(f"--resume: {path!r} holds no sweep config (a {type(saved).__name__})")
        saved = _flatten(saved)
        new = _flatten(json.loads(json_bytes(config.to_dict())))
        if "device_count" not in saved:  # written before the device count was recorded
            new.pop("device_count", None)
        elif new.get("device_count") is None:  # `None`: every device, as `run_sweep` fills in
            new["device_count"] = jax.device_count()
        for k, default in (("select_last", 1), ("select_every", 0)):  # before selection
            if k not in saved and new.get(k) == default:
                new.pop(k)
        differ = sorted(k for k in set(saved) | set(new) if saved.get(k) != new.get(k))
        if differ:
            details = ", ".join(f"{k} (saved {saved.get(k)!r}, now {new.get(k)!r})" for k in differ)
            raise SweepError(f"--resume: the config in {out!r} differs: {details}")
        for path in (out, os.path.join(out, "checkpoint")):
            if os.path.exists(path) and not os.access(path, os.W_OK | os.X_OK):
                raise SweepError(f"--resume: {path!r} is not writable")
        return
    if os.path.exists(out):
        if not os.path.isdir(out):
            raise SweepError(f"--out {out!r} exists and is not a directory")
        if os.listdir(out):
            raise SweepError(f"--out {out!r} is not empty (use --resume to continue a sweep)")
        if not os.access(out, os.W_OK | os.X_OK):
            raise SweepError(f"--out {out!r} is not writable")
        return
    problem = unwritable_dir(out)
    if problem:
        raise SweepError(f"--out {out!r} can't be written ({problem})")


class _Progress:
    """A tqdm bar on a terminal; plain lines otherwise."""

    def __init__(self, total_steps: int, enabled: bool | None):
        self.total = total_steps
        tty = sys.stderr.isatty()
        self.enabled = True if enabled is None else enabled
        self.bar = None
        if self.enabled and tty:
            from tqdm.auto import tqdm

            self.bar = tqdm(total=total_steps, unit="step", unit_scale=True, desc="sweep")

    def update(self, done: int, chunk_s: float, chunk_steps: int):
        rate = chunk_steps / max(chunk_s, 1e-9)
        if self.bar is not None:
            self.bar.update(done - self.bar.n)
            self.bar.set_postfix_str(f"{rate:,.0f} env-steps/s")
        elif self.enabled:
            eta = (self.total - done) / max(rate, 1e-9)
            print(
                f"[sweep] {done:,}/{self.total:,} env steps, {rate:,.0f} env-steps/s, "
                f"ETA {eta:,.0f} s",
                file=sys.stderr,
                flush=True,
            )

    def close(self):
        if self.bar is not None:
            self.bar.close()


def make_chunk(trainer: Trainer, chunk_len: int):
    """`chunk(state, stop, pref[, direction]) -> (state, metrics [chunk_len, ...])`:
    `chunk_len` iterations of `trainer.step` (given the optional traced index `direction`
    into `TRACED_DIRECTIONS`), to be called under `jax.vmap(..., axis_name=PREF_AXIS)`.

    Iterations at or past `stop` (a traced int32, the same for every preference: the
    sweep's last iteration, or the next one whose policy `wcac_jax.selection` keeps) leave
    the state as it is and give zero metrics, and cost nothing: every preference is at
    the same iteration, so the predicate is reduced over the preference axis to ONE
    scalar and `cond` runs one branch. (A per-preference predicate would be batched, and
    `vmap` turns a batched `cond` into a `select` that runs both branches: the padding
    was trained in full and thrown away.)
    """

    def chunk(state, stop, pref, *direction):
        def body(state, _):
            active = jax.lax.pmin(state.iteration - stop, PREF_AXIS) < 0
            # the step traced once (slow for MJX): `cond` replays its jaxpr, and a skipped
            # iteration gives zeros of the shapes that trace found
            jaxpr, shapes = jax.make_jaxpr(
                lambda s, p: trainer.step(s, p, *direction), return_shape=True
            )(state, pref)
            replay = jax.extend.core.jaxpr_as_fun(jaxpr)
            tree = jax.tree.structure(shapes)
            return jax.lax.cond(
                active,
                lambda s, p: tree.unflatten(replay(*jax.tree.leaves((s, p)))),
                lambda s, p: (s, jax.tree.map(lambda x: jnp.zeros(x.shape, x.dtype), shapes[1])),
                state,
                pref,
            )

        return jax.lax.scan(body, state, None, length=chunk_len)

    return chunk


class LoadedSweep(NamedTuple):
    """A sweep restored from its output directory (see `load_sweep`).

    Attributes:
      config: the sweep's configuration (from `config.json`).
      env: its environment (`make_env(config)`), the one `trainer` was built for.
      trainer: the pure `init`/`step`/`run`/`mean_action` of its training setup.
      state: the last checkpointed `UpdateState`, every leaf with the preference axis
        first (`[P, ...]`); `state.iteration[i]` iterations are done.
      metrics: per-iteration metrics `[P, T, ...]` (zeros past `state.iteration`), with
        `train/env_steps` (int64) counted on the host from `train/iteration`.
      chosen: with `config.select_last > 1` and the sweep finished, each preference's
        reported policy (`wcac_jax.selection`, leaves `[P, ...]`), the one `front.json`
        evaluated; else `None` (the reported policy is `state`'s).
    """

    config: SweepConfig
    env: Any
    trainer: Trainer
    state: UpdateState
    metrics: dict
    chosen: UpdateState | None = None


def load_sweep(out: str) -> LoadedSweep:
    """Restores the last checkpoint of the sweep in `out`, finished or interrupted.

    The trained policies and critics, to evaluate, render or inspect; or, after a
    `TrainingDiverged`, the last good state, to replay iteration by iteration:

        run = load_sweep("runs/x")
        state_i = jax.tree.map(lambda leaf: leaf[i], run.state)  # preference i
        state_i, metrics_i = jax.jit(run.trainer.step)(state_i, run.config.prefs[i])

    Raises:
      SweepError: `out` holds no sweep configuration or no checkpoint.
    """
    path = os.path.join(out, "config.json")
    if not os.path.isfile(path):
        raise SweepError(f"no sweep in {out!r} (no config.json)")
    try:
        with open(path) as f:
            config = SweepConfig.from_dict(json.load(f))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, KeyError, TypeError) as err:
        raise SweepError(f"{path!r} holds no readable sweep config ({err!r})") from None
    manager = checkpoint.manager(out)
    if manager.latest_step() is None:
        raise SweepError(f"no checkpoint in {out!r}")
    env = make_env(config)
    trainer = make_trainer(config.train_config(), env)
    n_prefs, n_iters = len(config.prefs), config.num_iterations
    prefs = jnp.asarray(np.asarray(config.prefs, np.float32))
    keys = jax.vmap(lambda i: jax.random.fold_in(jax.random.key(config.seed), i))(
        jnp.arange(n_prefs)
    )
    # shapes only: nothing is initialised or traced through the environment twice
    state = jax.eval_shape(jax.vmap(trainer.init), keys, prefs)
    shapes = jax.eval_shape(jax.vmap(trainer.step, axis_name=PREF_AXIS), state, prefs)[1]
    template = {
        "state": jax.tree.map(lambda s: np.zeros(s.shape, s.dtype), state),
        "metrics": {
            k: np.zeros((n_prefs, n_iters, *s.shape[1:]), s.dtype) for k, s in shapes.items()
        },
    }
    pool = None
    if config.select_last > 1:
        evaluate = make_evaluate(config.train_config(), env, config.eval_episodes)
        found = jax.eval_shape(jax.vmap(evaluate), state, keys)
        pool = selection.Pool(config.candidate_iterations, template["state"], found)
        template["selection"] = pool.tree
    restored = checkpoint.restore(manager, template)
    state = jax.tree.map(jnp.asarray, restored["state"])
    metrics = with_env_steps(config.train_config(), restored["metrics"])
    chosen = None
    if pool is not None and int(restored["state"].iteration[0]) >= n_iters:
        pool.tree = restored["selection"]
        chosen = jax.tree.map(jnp.asarray, pool.choose(np.asarray(prefs))[3])
    return LoadedSweep(config, env, trainer, state, metrics, chosen)


def run_sweep(
    config: SweepConfig,
    out: str | None = None,
    *,
    resume: bool = False,
    chunks: int = 4,
    progress: bool | None = None,
    stop_after_chunks: int | None = None,
) -> dict:
    """Trains every preference of `config` in one compiled program; returns the front.

    Args:
      config: the sweep.
      out: output directory (`None`: nothing is written and no checkpoints are kept).
      resume: continue the sweep checkpointed in `out`.
      chunks: number of host round-trips (checkpoint, progress) the run is split into.
      progress: force the progress display on/off (`None`: on for a terminal).
      stop_after_chunks: stop (as if interrupted) after this many chunks of this call.

    Returns:
      The `front.json` content as a dict (see README, "Outputs").

    Raises:
      SweepError: bad input (nothing written).
      TrainingDiverged: NaN during training (the last good checkpoint is kept).
    """
    if config.device_count is None:
        config = replace(config, device_count=jax.device_count())
    elif config.device_count != jax.device_count():
        raise SweepError(
            f"device_count {config.device_count}, but JAX has {jax.device_count()} device(s) "
            f"(on a CPU: XLA_FLAGS=--xla_force_host_platform_device_count="
            f"{config.device_count} before JAX starts)"
        )
    env = make_env(config)
    m = int(env.num_objectives)
    prefs = validate_prefs(config.prefs, m)
    train_cfg = config.train_config()
    try:
        j_ub = resolve_j_ub(train_cfg, env)
    except ValueError as err:
        raise SweepError(str(err)) from None
    hv_ref = config.hv_ref if config.hv_ref is not None else default_hv_ref(env)
    if len(hv_ref) != m:
        raise SweepError(f"hv_ref {list(hv_ref)} has {len(hv_ref)} entries, expected {m}")
    if not isinstance(chunks, int) or chunks < 1:
        raise SweepError(f"chunks must be a positive integer, got {chunks!r}")
    if out is not None:
        _on_writer(lambda: check_output_dir(out, config, resume))

    n_prefs, n_iters = prefs.shape[0], config.num_iterations
    n_dev = jax.device_count()
    n_pad = -n_prefs % n_dev
    prefs_pad = np.concatenate([prefs, np.repeat(prefs[-1:], n_pad, axis=0)]).astype(np.float32)
    base = jax.random.key(config.seed)
    keys = jax.vmap(lambda i: jax.random.fold_in(base, i))(
        jnp.minimum(jnp.arange(n_prefs + n_pad), n_prefs - 1)
    )
    eval_keys = jax.vmap(lambda k: jax.random.fold_in(k, 1 << 30))(keys)
    # the candidates' evaluation episodes (`select_last > 1`): not the final evaluation's
    select_keys = jax.vmap(lambda k: jax.random.fold_in(k, (1 << 30) + 1))(keys)
    mesh = jax.make_mesh((n_dev,), (DEVICE_AXIS,), axis_types=(jax.sharding.AxisType.Auto,))
    sharded = jax.sharding.NamedSharding(mesh, P(DEVICE_AXIS))
    # the scalarization as a traced index (mgda has none): a configuration's sweeps in
    # each direction are then one program (the persistent compilation cache serves it,
    # unless it has host callbacks, as MuJoCo's C engine does: JAX caches none of those)
    per_pref = [prefs_pad]
    if train_cfg.scalarization in TRACED_DIRECTIONS:
        index = TRACED_DIRECTIONS.index(train_cfg.scalarization)
        per_pref.append(np.full(n_prefs + n_pad, index, np.int32))
    # host values, the same on every process, laid out over every process's devices
    keys_dev, eval_keys_dev, select_keys_dev, *chunk_args = distributed.to_global(
        tuple(jax.random.key_data(k) for k in (keys, eval_keys, select_keys)) + (*per_pref,),
        sharded,
    )
    prefs_dev = chunk_args[0]
    writer = distributed.is_writer()
    if jax.process_count() > 1 and progress is not False:
        _say_part(sharded, n_prefs, n_pad)

    trainer = make_trainer(train_cfg, env)
    chunk_len = math.ceil(n_iters / chunks)
    chunk = make_chunk(trainer, chunk_len)

    # Every leaf of the state and metrics carries the preference axis first; each device
    # runs the vmapped program on its own preferences (`shard_map`), so host callbacks
    # (MuJoCo's C engine) step each device's environments where they are, in every
    # process. The preference axis is named so that a trainer may share values across it
    # (the practical update's estimated utopia point, `wcac_jax.utopia`, which spans the
    # device axis too).
    # (`check_vma=False`: values computed from constants, e.g. an episode's first flags,
    # are the same on every device, and the scan's carry types must not tell them apart)
    def per_device(f):
        spec = P(DEVICE_AXIS)
        return jax.shard_map(f, mesh=mesh, in_specs=spec, out_specs=spec, check_vma=False)

    init_fn = jax.jit(
        per_device(jax.vmap(lambda k, p: trainer.init(jax.random.wrap_key_data(k), p)))
    )
    chunk_fn = jax.jit(per_device(jax.vmap(chunk, axis_name=PREF_AXIS)), donate_argnums=0)
    evaluate_one = make_evaluate(train_cfg, env, config.eval_episodes)
    evaluate = jax.jit(
        per_device(jax.vmap(lambda s, k: evaluate_one(s, jax.random.wrap_key_data(k))))
    )

    def stop_at(iteration: int):  # `make_chunk`'s `stop`, on every preference
        return distributed.to_global(np.full(n_prefs + n_pad, iteration, np.int32), sharded)

    state = init_fn(keys_dev, prefs_dev)
    if progress is not False and writer:
        slow = env.backend == "mjx" and jax.default_backend() == "cpu"
        print(
            f"[sweep] compiling the training program for {n_prefs} preferences"
            + (" (MJX on a CPU: a minute or more)" if slow else ""),
            file=sys.stderr,
            flush=True,
        )
    t0 = time.perf_counter()
    lowered = chunk_fn.lower(state, stop_at(n_iters), *chunk_args)  # traces the step
    lower_s = time.perf_counter() - t0
    # per-iteration metrics, shaped as the program returns them (`[P, chunk_len, ...]`)
    template = lowered.out_info[1]
    metrics_bytes = sum(
        n_prefs * n_iters * math.prod(s.shape[2:]) * np.dtype(s.dtype).itemsize
        for s in template.values()
    )
    if metrics_bytes > _host_memory_bytes():
        raise SweepError(
            f"steps_per_pref {config.steps_per_pref} needs {metrics_bytes / 2**30:,.1f} GiB of "
            f"per-iteration metrics ({n_iters:,} iterations x {n_prefs} preferences); this "
            f"machine has {_host_memory_bytes() / 2**30:,.1f} GiB"
        )
    metrics = {k: np.zeros((n_prefs, n_iters, *s.shape[2:]), s.dtype) for k, s in template.items()}
    pool = None  # the policies `wcac_jax.selection` chooses among
    if config.select_last > 1:
        pool = selection.Pool(
            config.candidate_iterations,
            jax.tree.map(lambda x: np.zeros(x.shape, x.dtype), state),
            jax.eval_shape(evaluate, state, eval_keys_dev),
        )

    manager = None
    if out is not None and writer:  # only process 0 touches `out`
        os.makedirs(out, exist_ok=True)
        if not resume:
            write_atomic(os.path.join(out, "config.json"), json_bytes(config.to_dict()))
        manager = checkpoint.manager(out)
    if out is not None and resume:
        # process 0 reads the checkpoint; the others receive it (no shared file system)
        host = {"state": jax.tree.map(lambda x: np.zeros(x.shape, x.dtype), state)}
        host["metrics"] = metrics
        if pool is not None:
            host["selection"] = pool.tree
        found = manager is not None and manager.latest_step() is not None
        if found:
            host = checkpoint.restore(manager, host)
        if distributed.all_ok(found):
            host = distributed.broadcast(host)
            state = distributed.to_global(host["state"], sharded)
            metrics = {k: np.array(v) for k, v in host["metrics"].items()}  # writable
            if pool is not None:
                pool.tree = jax.tree.map(np.array, host["selection"])

    done_iters = int(np.asarray(state.iteration.addressable_shards[0].data)[0])
    t0 = time.perf_counter()
    chunk_exec = lowered.compile()
    compile_s = lower_s + time.perf_counter() - t0
    steps_per_iter = train_cfg.env_steps_per_iteration
    bar = _Progress(n_iters * steps_per_iter * n_prefs, progress if writer else False)
    wall_start = time.perf_counter()
    train_s, steps_this_run = 0.0, 0
    chunks_run = 0
    try:
        while done_iters < n_iters:
            if stop_after_chunks is not None and chunks_run >= stop_after_chunks:
                return {"interrupted": True, "iterations_done": done_iters}
            t0 = time.perf_counter()
            hi = min(
                done_iters + chunk_len, pool.next_stop(done_iters, n_iters) if pool else n_iters
            )
            state, chunk_metrics = chunk_exec(state, stop_at(hi), *chunk_args)
            chunk_metrics = distributed.to_host(chunk_metrics)
            dt = time.perf_counter() - t0
            train_s += dt
            chunk_steps = (hi - done_iters) * steps_per_iter * n_prefs
            steps_this_run += chunk_steps
            for k, v in chunk_metrics.items():
                metrics[k][:, done_iters:hi] = np.asarray(v)[:n_prefs, : hi - done_iters]
            _check_finite(metrics, done_iters, hi, prefs, manager)
            done_iters = hi
            chunks_run += 1
            candidate = pool is not None and done_iters in pool.iterations
            if out is not None or candidate:
                host_state = distributed.to_host(state)  # every process takes part
            if candidate:
                found = distributed.to_host(evaluate(state, select_keys_dev))
                pool.add(done_iters, host_state, found)
            if manager is not None:  # process 0 of a sweep with `out`
                saved = {"state": host_state, "metrics": metrics}
                if pool is not None:
                    saved["selection"] = pool.tree
                checkpoint.save(manager, done_iters, saved)
            bar.update(done_iters * steps_per_iter * n_prefs, dt, chunk_steps)
    finally:
        bar.close()

    chosen = None
    if pool is not None:  # each preference's reported policy, on fresh episodes
        index, z, regrets, picked = pool.choose(prefs_pad)
        final = distributed.to_host(evaluate(state, eval_keys_dev))  # what no choice gives
        chosen = pool.summary(index, z, regrets, n_prefs, config.eval_episodes, final)
        state = distributed.to_global(picked, sharded)
    evaluation = distributed.to_host(evaluate(state, eval_keys_dev))
    wall = time.perf_counter() - wall_start

    timing = {
        "compile_s": compile_s,
        "train_s": train_s,
        "wall_s": wall + compile_s,
        "steps_this_run": steps_this_run,
    }
    metrics = with_env_steps(train_cfg, metrics)  # int64, counted on the host
    front = summarize(config, env, prefs, j_ub, hv_ref, metrics, evaluation, timing)
    if chosen is not None:
        front["selection"] = chosen
    if out is not None and writer:
        write_outputs(out, front, metrics, prefs)
    return front


def _on_writer(check) -> None:
    """Runs `check` on process 0 only; if it raises `SweepError`, every process raises."""
    err = None
    if distributed.is_writer():
        try:
            check()
        except SweepError as e:
            err = e
    if jax.process_count() > 1 and not distributed.all_ok(err is None) and err is None:
        raise SweepError("process 0 stopped the sweep (its error says why)")
    if err is not None:
        raise err


def _say_part(sharding, n_prefs: int, n_pad: int) -> None:
    rows = [i for i in distributed.local_rows(sharding, n_prefs + n_pad) if i < n_prefs]
    part = f"preferences #{rows[0]}-#{rows[-1]}" if rows else "only padding"
    devices = ", ".join(str(d) for d in jax.local_devices())
    print(
        f"[process {jax.process_index()}/{jax.process_count()}] {part} of {n_prefs} "
        f"on {devices}" + ("; writes the outputs" if distributed.is_writer() else ""),
        file=sys.stderr,
        flush=True,
    )


def _host_memory_bytes() -> int:
    """Physical memory of this host."""
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def _check_finite(metrics, lo, hi, prefs, manager):
    for k, v in metrics.items():
        bad = ~np.isfinite(v[:, lo:hi].reshape(v.shape[0], hi - lo, -1)).all(axis=-1)
        if bad.any():
            i, t = (int(x) for x in np.argwhere(bad)[0])
            kept = manager.latest_step() if manager is not None else None
            where = (
                f"; the last good checkpoint (iteration {kept}) is kept" if kept is not None else ""
            )
            raise TrainingDiverged(
                f"NaN in {k} at preference #{i} {prefs[i].tolist()}, iteration {lo + t}{where}"
            )


if __name__ == "__main__":  # the command line lives in `wcac_jax.cli`
    from wcac_jax.cli import main

    sys.exit(main(every_core=True))


__all__ = [
    "PAPER_PREFS",
    "SweepConfig",
    "SweepError",
    "LoadedSweep",
    "TrainingDiverged",
    "load_sweep",
    "run_sweep",
    "validate_prefs",
]
