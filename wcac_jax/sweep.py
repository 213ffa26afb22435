"""A whole Pareto front in one compiled program: `run_sweep` and `python -m wcac_jax.sweep`.

All preferences (and their `N` environments each) train in ONE compiled program,
`jit(vmap(chunk))` over the preference axis, with keys and preferences as traced
arguments. This module is the one impure edge of the package: it owns the host loop
over chunks, the orbax checkpoints after every chunk, the progress bar, the clocks and
every file written.

Chunking does not change the numbers: iteration `t` of preference `i` draws its
randomness from `fold_in(fold_in(key(seed), i), t)`, and every chunk is the same
compiled program of `ceil(T / chunks)` iterations whose iterations past `T` leave the
state untouched. `--resume` restores the last checkpoint and continues bit for bit.

Devices: the preference axis is sharded over all local devices (a 1-D mesh named
`"prefs"`); a preference count that does not divide evenly is padded by repeating the
last preference, and the padding is dropped from the results. On several hosts, call
`jax.distributed.initialize()` first on every host (same command, same flags); the mesh
then spans `jax.devices()` of all hosts, each host feeds its addressable shards, and only
process 0 should write `--out` (pass a host-local `--out` elsewhere).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import io
import json
import math
import os
import sys
import tempfile
import textwrap
import time
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from wcac_jax import envs, pareto, presets, trainers
from wcac_jax.config import TrainConfig
from wcac_jax.presets import PAPER_PREFS
from wcac_jax.train import Trainer, TrainState, resolve_j_ub, with_env_steps
from wcac_jax.trainers import make_evaluate, make_trainer
from wcac_jax.utopia import PREF_AXIS

PAPER_STEPS_PER_PREF = 1_000_000
MAX_ITERATIONS = 2**31 - 1  # `TrainState.iteration` is int32


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
      train: the per-preference training configuration, the paper's (`TrainConfig`)
        or the practical one (`ppo.PPOConfig`); its `num_iterations` is derived from
        `steps_per_pref`.
      steps_per_pref: environment steps per preference (rounded up to whole iterations).
      seed: base seed; preference `i` uses `fold_in(key(seed), i)`.
      eval_episodes: episodes of the mean policy evaluated per preference at the end.
      hv_ref: hypervolume reference point (`None`: the environment's default).
      device_count: devices the preference axis is sharded over (`None`: every device
        JAX has; `run_sweep` records the count it used). Results are bit-identical for
        the same config, device count included, and any chunking; across device counts
        they differ by rounding (XLA compiles different per-device batch shapes).
    """

    prefs: tuple[tuple[float, ...], ...]
    env: str = "walker2d"
    env_options: dict = field(default_factory=dict)
    train: trainers.AnyConfig = field(default_factory=TrainConfig)
    steps_per_pref: int = 100_000
    seed: int = 0
    eval_episodes: int = 8
    hv_ref: tuple[float, ...] | None = None
    device_count: int | None = None

    def __post_init__(self):
        for name in ("steps_per_pref", "eval_episodes"):
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

    @property
    def num_iterations(self) -> int:
        """Outer iterations `T` per preference."""
        return max(1, math.ceil(self.steps_per_pref / self.train.env_steps_per_iteration))

    def train_config(self) -> trainers.AnyConfig:
        return self.train.replace(num_iterations=self.num_iterations)

    def to_dict(self) -> dict:
        return {
            "prefs": [list(p) for p in self.prefs],
            "env": self.env,
            "env_options": dict(self.env_options),
            "train": trainers.to_dict(self.train_config()),
            "steps_per_pref": self.steps_per_pref,
            "seed": self.seed,
            "eval_episodes": self.eval_episodes,
            "hv_ref": None if self.hv_ref is None else list(self.hv_ref),
            "device_count": self.device_count,
        }

    @classmethod
    def from_dict(cls, d: dict) -> SweepConfig:
        """The inverse of `to_dict` (e.g. a run's `config.json`)."""
        return cls(
            prefs=tuple(tuple(float(x) for x in p) for p in d["prefs"]),
            env=d["env"],
            env_options=dict(d["env_options"]),
            train=trainers.from_dict(d["train"]),
            steps_per_pref=int(d["steps_per_pref"]),
            seed=int(d["seed"]),
            eval_episodes=int(d["eval_episodes"]),
            hv_ref=None if d["hv_ref"] is None else tuple(d["hv_ref"]),
            device_count=d.get("device_count"),
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


def _make_env(config: SweepConfig):
    try:
        return envs.make(config.env, **config.env_options)
    except (ValueError, TypeError) as err:
        raise SweepError(str(err)) from None


def _write_atomic(path: str, data: bytes) -> None:
    """Writes `data` to a temporary file beside `path`, then renames it over `path`."""
    directory = os.path.dirname(path) or "."
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=".tmp-", suffix=os.path.basename(path))
    umask = os.umask(0)
    os.umask(umask)
    os.fchmod(fd, 0o666 & ~umask)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _json_bytes(obj) -> bytes:
    return (json.dumps(obj, indent=2, allow_nan=True) + "\n").encode()


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
        new = _flatten(json.loads(_json_bytes(config.to_dict())))
        if "device_count" not in saved:  # written before the device count was recorded
            new.pop("device_count", None)
        elif new.get("device_count") is None:  # `None`: every device, as `run_sweep` fills in
            new["device_count"] = jax.device_count()
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
    parent = os.path.dirname(os.path.abspath(out))
    while not os.path.exists(parent):
        parent = os.path.dirname(parent)
    if not os.path.isdir(parent) or not os.access(parent, os.W_OK | os.X_OK):
        raise SweepError(f"--out {out!r} can't be written ({parent!r} is not a writable directory)")


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


def _to_checkpoint(tree) -> dict:
    """The non-empty leaves of `tree` by position (orbax cannot save zero-size arrays,
    such as MJX's actuator activations of a model without activation dynamics)."""
    return {str(i): x for i, x in enumerate(jax.tree.leaves(tree)) if np.size(x) > 0}


def _from_checkpoint(saved: dict, template):
    leaves, treedef = jax.tree.flatten(template)
    return treedef.unflatten([saved.get(str(i), x) for i, x in enumerate(leaves)])


def _metric_template(trainer, state, pref) -> dict:
    shapes = jax.eval_shape(trainer.step, state, pref)[1]
    return jax.tree.map(lambda s: jnp.zeros(s.shape, s.dtype), shapes)


class LoadedSweep(NamedTuple):
    """A sweep restored from its output directory (see `load_sweep`).

    Attributes:
      config: the sweep's configuration (from `config.json`).
      trainer: the pure `init`/`step`/`run`/`mean_action` of its training setup.
      state: the last checkpointed `TrainState`, every leaf with the preference axis
        first (`[P, ...]`); `state.iteration[i]` iterations are done.
      metrics: per-iteration metrics `[P, T, ...]` (zeros past `state.iteration`), with
        `train/env_steps` (int64) counted on the host from `train/iteration`.
    """

    config: SweepConfig
    trainer: Trainer
    state: TrainState
    metrics: dict


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
    import orbax.checkpoint as ocp

    manager = ocp.CheckpointManager(os.path.abspath(os.path.join(out, "checkpoint")))
    step = manager.latest_step()
    if step is None:
        raise SweepError(f"no checkpoint in {out!r}")
    env = _make_env(config)
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
    restored = manager.restore(step, args=ocp.args.StandardRestore(_to_checkpoint(template)))
    restored = _from_checkpoint(restored, template)
    state = jax.tree.map(jnp.asarray, restored["state"])
    metrics = with_env_steps(config.train_config(), restored["metrics"])
    return LoadedSweep(config, trainer, state, metrics)


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
    env = _make_env(config)
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
        check_output_dir(out, config, resume)

    n_prefs, n_iters = prefs.shape[0], config.num_iterations
    n_dev = jax.device_count()
    n_pad = -n_prefs % n_dev
    prefs_pad = np.concatenate([prefs, np.repeat(prefs[-1:], n_pad, axis=0)]).astype(np.float32)
    base = jax.random.key(config.seed)
    keys = jax.vmap(lambda i: jax.random.fold_in(base, i))(
        jnp.minimum(jnp.arange(n_prefs + n_pad), n_prefs - 1)
    )
    # Auto axes (GSPMD): preferences never communicate, so XLA just splits the batch.
    mesh = jax.make_mesh((n_dev,), ("prefs",), axis_types=(jax.sharding.AxisType.Auto,))
    sharded = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec("prefs"))
    prefs_dev = jax.device_put(jnp.asarray(prefs_pad), sharded)
    keys_dev = jax.device_put(keys, sharded)

    trainer = make_trainer(train_cfg, env)
    chunk_len = math.ceil(n_iters / chunks)

    def chunk(state, pref):
        def body(state, _):
            active = state.iteration < n_iters
            template = _metric_template(trainer, state, pref)
            return jax.lax.cond(active, trainer.step, lambda s, p: (s, template), state, pref)

        return jax.lax.scan(body, state, None, length=chunk_len)

    # every leaf of the state and metrics carries the preference axis first: shard it
    init_fn = jax.jit(jax.vmap(trainer.init), out_shardings=sharded)
    # the preference axis is named so that a trainer may share values across it (the
    # practical update's estimated utopia point, `wcac_jax.utopia`)
    chunk_fn = jax.jit(
        jax.vmap(chunk, axis_name=PREF_AXIS), donate_argnums=0, out_shardings=(sharded, sharded)
    )
    state = init_fn(keys_dev, prefs_dev)
    abstract = jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype), (state, prefs_dev))
    template = jax.eval_shape(jax.vmap(trainer.step, axis_name=PREF_AXIS), *abstract)[1]
    metrics_bytes = sum(
        n_prefs * n_iters * math.prod(s.shape[1:]) * np.dtype(s.dtype).itemsize
        for s in template.values()
    )
    if metrics_bytes > _host_memory_bytes():
        raise SweepError(
            f"steps_per_pref {config.steps_per_pref} needs {metrics_bytes / 2**30:,.1f} GiB of "
            f"per-iteration metrics ({n_iters:,} iterations x {n_prefs} preferences); this "
            f"machine has {_host_memory_bytes() / 2**30:,.1f} GiB"
        )
    metrics = {k: np.zeros((n_prefs, n_iters, *s.shape[1:]), s.dtype) for k, s in template.items()}

    manager = None
    if out is not None:
        import orbax.checkpoint as ocp

        os.makedirs(out, exist_ok=True)
        if not resume:
            _write_atomic(os.path.join(out, "config.json"), _json_bytes(config.to_dict()))
        manager = ocp.CheckpointManager(
            os.path.abspath(os.path.join(out, "checkpoint")),
            options=ocp.CheckpointManagerOptions(
                max_to_keep=1, create=True, enable_async_checkpointing=False
            ),
        )
        if resume and manager.latest_step() is not None:
            template = {"state": state, "metrics": metrics}
            restored = manager.restore(
                manager.latest_step(),
                args=ocp.args.StandardRestore(_to_checkpoint(template)),
            )
            restored = _from_checkpoint(restored, template)
            state, metrics = restored["state"], restored["metrics"]

    done_iters = int(np.asarray(jax.device_get(state.iteration))[0])
    if progress is not False:
        print(
            f"[sweep] compiling the training program for {n_prefs} preferences "
            f"(a minute or two on a 2-core CPU)",
            file=sys.stderr,
            flush=True,
        )
    t0 = time.perf_counter()
    chunk_exec = chunk_fn.lower(state, prefs_dev).compile()
    compile_s = time.perf_counter() - t0
    steps_per_iter = train_cfg.env_steps_per_iteration
    bar = _Progress(n_iters * steps_per_iter * n_prefs, progress)
    wall_start = time.perf_counter()
    train_s, steps_this_run = 0.0, 0
    chunks_run = 0
    try:
        while done_iters < n_iters:
            if stop_after_chunks is not None and chunks_run >= stop_after_chunks:
                return {"interrupted": True, "iterations_done": done_iters}
            t0 = time.perf_counter()
            state, chunk_metrics = chunk_exec(state, prefs_dev)
            chunk_metrics = jax.device_get(chunk_metrics)
            dt = time.perf_counter() - t0
            train_s += dt
            hi = min(done_iters + chunk_len, n_iters)
            chunk_steps = (hi - done_iters) * steps_per_iter * n_prefs
            steps_this_run += chunk_steps
            for k, v in chunk_metrics.items():
                metrics[k][:, done_iters:hi] = np.asarray(v)[:n_prefs, : hi - done_iters]
            _check_finite(metrics, done_iters, hi, prefs, manager)
            done_iters = hi
            chunks_run += 1
            if manager is not None:
                import orbax.checkpoint as ocp

                payload = _to_checkpoint({"state": state, "metrics": metrics})
                manager.save(done_iters, args=ocp.args.StandardSave(payload))
                manager.wait_until_finished()
            bar.update(done_iters * steps_per_iter * n_prefs, dt, chunk_steps)
    finally:
        bar.close()

    evaluate = jax.jit(jax.vmap(make_evaluate(train_cfg, env, config.eval_episodes)))
    eval_keys = jax.vmap(lambda k: jax.random.fold_in(k, 1 << 30))(keys_dev)
    evaluation = jax.device_get(evaluate(state, eval_keys))
    wall = time.perf_counter() - wall_start

    timing = {
        "compile_s": compile_s,
        "train_s": train_s,
        "wall_s": wall + compile_s,
        "steps_this_run": steps_this_run,
    }
    metrics = with_env_steps(train_cfg, metrics)  # int64, counted on the host
    front = _front(config, env, prefs, j_ub, hv_ref, metrics, evaluation, timing)
    if out is not None:
        _write_outputs(out, front, metrics, prefs, env)
    return front


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


def _front(config, env, prefs, j_ub, hv_ref, metrics, evaluation, timing) -> dict:
    n = prefs.shape[0]
    returns = np.asarray(evaluation["eval/return"])[:n]
    disc = np.asarray(evaluation["eval/discounted_return"])[:n]
    length = np.asarray(evaluation["eval/length"])[:n]
    nd = pareto.nondominated(returns)
    outside = pareto.outside_reference(returns, hv_ref)
    steps = int(metrics["train/env_steps"][0, -1])
    rows = []
    for i in range(n):
        rows.append(
            {
                "pref": prefs[i].tolist(),
                "return": returns[i].tolist(),
                "discounted_return": disc[i].tolist(),
                "episode_length": float(length[i]),
                "lambda": metrics["train/weights"][i, -1].tolist(),
                "g_mu": float(metrics["train/g_mu"][i, -1]),
                "scalarized": float(metrics["train/scalarized"][i, -1]),
                "j_hat": metrics["train/j_hat"][i, -1].tolist(),
                "train_episode_return": metrics["train/episode_return"][i, -1].tolist(),
                "nondominated": bool(nd[i]),
                "inside_hv_ref": not bool(outside[i]),
            }
        )
    return {
        "env": config.env,
        "objective_names": list(env.objective_names),
        # the utopia point in use at the end (the sweep's own estimate, if it made one)
        "j_ub": (
            metrics["train/utopia"][0, -1].tolist() if "train/utopia" in metrics else list(j_ub)
        ),
        "prefs": rows,
        "hypervolume": pareto.hypervolume(returns, hv_ref),
        "hypervolume_discounted": pareto.hypervolume(disc, hv_ref),
        "hv_ref": list(hv_ref),
        # preferences whose (undiscounted) returns do not strictly dominate hv_ref: they
        # add nothing to the hypervolume
        "outside_hv_ref": [i for i in range(n) if outside[i]],
        "cardinality": pareto.cardinality(returns),
        "sparsity": pareto.sparsity(returns),
        "expected_utility": pareto.expected_utility(
            returns, pareto.simplex_lattice(len(j_ub), 101)
        ),
        "env_steps_per_pref": steps,
        "env_steps_total": steps * n,
        "compile_s": timing["compile_s"],
        "train_s": timing["train_s"],
        "wall_s": timing["wall_s"],
        # training throughput of this run (all preferences, compilation excluded); the
        # steps of this process only, so a resumed run reports its own part
        "env_steps_per_s": timing["steps_this_run"] / max(timing["train_s"], 1e-9),
        "devices": [str(d) for d in jax.devices()],
        "config": config.to_dict(),
    }


def _write_outputs(out, front, metrics, prefs, env):
    _write_atomic(os.path.join(out, "front.json"), _json_bytes(front))
    buf = io.StringIO()
    names = front["objective_names"]
    writer = csv.writer(buf)
    writer.writerow(
        [f"pref_{n}" for n in names]
        + [f"return_{n}" for n in names]
        + [f"discounted_return_{n}" for n in names]
        + [f"lambda_{n}" for n in names]
        + ["g_mu", "nondominated"]
    )
    for row in front["prefs"]:
        writer.writerow(
            row["pref"]
            + row["return"]
            + row["discounted_return"]
            + row["lambda"]
            + [row["g_mu"], int(row["nondominated"])]
        )
    _write_atomic(os.path.join(out, "front.csv"), buf.getvalue().encode())
    npz = io.BytesIO()
    np.savez(npz, prefs=prefs, objective_names=np.array(names), **metrics)
    _write_atomic(os.path.join(out, "curves.npz"), npz.getvalue())
    from wcac_jax import plot

    fig = plot.plot_front(front)
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=120)
    plot.plt.close(fig)
    _write_atomic(os.path.join(out, "front.png"), png.getvalue())


# ----------------------------------------------------------------------------- CLI


def _parse_prefs(text: str) -> tuple[tuple[float, ...], ...]:
    try:
        return tuple(
            tuple(float(x) for x in part.split(",")) for part in text.split(";") if part.strip()
        )
    except ValueError:
        raise SweepError(
            f"--prefs {text!r} is not a ';'-separated list of ','-separated "
            "numbers, e.g. '1,0;0.5,0.5;0,1'"
        ) from None


def _parse_floats(text: str, flag: str) -> tuple[float, ...]:
    try:
        return tuple(float(x) for x in text.split(","))
    except ValueError:
        raise SweepError(f"{flag} {text!r} is not a ','-separated list of numbers") from None


# (flag dest, config field, meaning): flags that set a field of the training config; each
# defaults to None, i.e. the preset's (or the environment's default's) value
_CONFIG_FLAGS = (
    ("envs_per_pref", "num_envs", "parallel environments N per preference"),
    ("scalarization", "scalarization", "actor direction: smooth_wc, wc, linear (or mgda, paper)"),
    ("mu", "mu", "smoothing temperature mu"),
    ("j_ub", "j_ub", "fixed utopia point, e.g. '2000,1000' (default: the environment's)"),
    ("gamma", "gamma", "discount"),
    ("width", "width", "network width w"),
    ("depth", "depth", "network depth D"),
    ("rollout_steps", "rollout_steps", "L: rollout steps per iteration"),
    ("critic_steps", "critic_steps", "paper: K TD steps per iteration"),
    ("network", "network", "paper: 'paper' or 'mlp' (actor and critics)"),
    ("actor_lr", "actor_lr", "paper: alpha"),
    ("critic_lr", "critic_lr", "paper: beta"),
    ("actor_optimizer", "actor_optimizer", "paper: normalized, normalized_harmonic, adam, sgd"),
    ("utopia", "utopia", "practical: 'estimated' (by the sweep) or 'fixed' (--j-ub)"),
    ("learning_rate", "learning_rate", "practical: Adam's step size"),
    ("num_epochs", "num_epochs", "practical: epochs per rollout"),
    ("num_minibatches", "num_minibatches", "practical: minibatches per epoch"),
)
_FLAG_TYPES = {
    "envs_per_pref": int,
    "mu": float,
    "gamma": float,
    "width": int,
    "depth": int,
    "rollout_steps": int,
    "critic_steps": int,
    "actor_lr": float,
    "critic_lr": float,
    "learning_rate": float,
    "num_epochs": int,
    "num_minibatches": int,
}


def _defaults_table() -> str:
    lines = ["each environment's default run (flags override it):"]
    for name in envs.names():
        d = presets.env_defaults(name)
        text = (
            f"{name}: {d.preset} ({trainers.kind(d.config)} update), "
            f"{d.steps_per_pref:,} env steps per preference; {d.note}"
        )
        lines.append(textwrap.fill(text, 79, initial_indent="  ", subsequent_indent="    "))
    return "\n".join(lines)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m wcac_jax.sweep",
        description=textwrap.fill(
            "Train a whole Pareto front (one policy per preference) in one compiled "
            "program and write front.json, front.csv, front.png, curves.npz, config.json "
            "and a checkpoint to --out. With no flag but --env (and --n-prefs), each "
            f"environment runs its default (below) on {presets.DEFAULT_N_PREFS} evenly "
            "spaced preferences. --preset paper applies the paper's recipe (and its nine "
            "preferences [1,0] [0.9,0.1] [0.8,0.2] [0.7,0.3] [0.5,0.5] [0.3,0.7] [0.2,0.8] "
            "[0.1,0.9] [0,1]) to any environment; --preset practical the practical update. "
            "Explicit flags override the preset's values.",
            79,
        ),
        epilog=_defaults_table(),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    g = p.add_mutually_exclusive_group()
    g.add_argument(
        "--n-prefs",
        type=int,
        default=None,
        help=f"N preferences evenly spread on the simplex (default: {presets.DEFAULT_N_PREFS}, "
        "or the paper's nine with --preset paper)",
    )
    g.add_argument("--prefs", default=None, help="explicit preferences, e.g. '1,0;0.5,0.5;0,1'")
    p.add_argument(
        "--preset",
        choices=presets.PRESETS,
        default=None,
        help="training configuration: paper (the paper's recipe and preferences) or "
        "practical (default: the environment's, see below)",
    )
    p.add_argument("--env", default="walker2d", help=f"environment: {', '.join(envs.names())}")
    p.add_argument(
        "--physics", default=None, help="walker2d physics: brax (fast, default) or gymnasium-v5"
    )
    p.add_argument(
        "--engine",
        default=None,
        help="walker2d physics engine: mjx (default; for accelerators) or mujoco (MuJoCo's "
        "C engine, multi-threaded; several times faster on a CPU)",
    )
    p.add_argument(
        "--episode-length",
        type=int,
        default=None,
        help="walker2d time limit in steps (default 500, as the paper)",
    )
    p.add_argument(
        "--steps-per-pref",
        type=int,
        default=None,
        help="environment steps per preference (default: the environment's, see below)",
    )
    for dest, _, meaning in _CONFIG_FLAGS:
        p.add_argument(
            "--" + dest.replace("_", "-"),
            dest=dest,
            type=_FLAG_TYPES.get(dest, str),
            default=None,
            help=f"{meaning} (default: the preset's)",
        )
    p.add_argument(
        "--hv-ref",
        default=None,
        help="hypervolume reference point, e.g. '-500,-3000' (default: the environment's "
        "default_hv_ref, per objective the least return an episode can have)",
    )
    p.add_argument(
        "--eval-episodes", type=int, default=8, help="evaluation episodes per preference (8)"
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (0)")
    p.add_argument("--out", default=None, help="output directory (default: a new runs/<time>)")
    p.add_argument("--resume", action="store_true", help="continue the sweep in --out")
    p.add_argument(
        "--chunks",
        type=int,
        default=10,
        help="host round-trips (checkpoint + progress); does not change results (10)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress output")
    return p


def config_from_args(args) -> SweepConfig:
    """Builds (and validates) a `SweepConfig` from parsed CLI arguments: the preset's (or
    the environment's default) configuration, with every flag given applied over it."""
    defaults = presets.env_defaults(args.env)
    if args.preset is not None:
        try:
            train = presets.preset(args.preset)
        except ValueError as err:
            raise SweepError(str(err)) from None
        name = f"the {args.preset} preset"
    else:
        train, name = defaults.config, f"{args.env}'s default ({defaults.preset})"
    fields = {f.name for f in dataclasses.fields(train)}
    changes = {}
    for dest, field_name, _ in _CONFIG_FLAGS:
        value = getattr(args, dest)
        if value is None:
            continue
        flag = "--" + dest.replace("_", "-")
        if field_name not in fields:
            raise SweepError(
                f"{flag} does not apply to {name}, a {trainers.kind(train)} configuration"
            )
        changes[field_name] = _parse_floats(value, flag) if dest == "j_ub" else value
    try:
        train = train.replace(**changes)
    except ValueError as err:
        raise SweepError(str(err)) from None

    if args.prefs is not None:
        prefs = _parse_prefs(args.prefs)
    elif args.n_prefs is None and args.preset == "paper":
        prefs = PAPER_PREFS
    else:
        n = presets.DEFAULT_N_PREFS if args.n_prefs is None else args.n_prefs
        if n < 1:
            raise SweepError(f"--n-prefs must be >= 1, got {n}")
        m = int(_make_env(SweepConfig(prefs=(), env=args.env)).num_objectives)
        prefs = tuple(tuple(float(x) for x in p) for p in pareto.simplex_lattice(m, n))
    env_options = dict(defaults.env_options)
    if args.physics is not None:
        env_options["physics"] = args.physics
    if args.episode_length is not None:
        env_options["episode_length"] = args.episode_length
    if args.engine is not None:
        env_options["engine"] = args.engine
    steps = defaults.steps_per_pref if args.steps_per_pref is None else args.steps_per_pref
    return SweepConfig(
        prefs=prefs,
        env=args.env,
        env_options=env_options,
        train=train,
        steps_per_pref=steps,
        seed=args.seed,
        eval_episodes=args.eval_episodes,
        hv_ref=None if args.hv_ref is None else _parse_floats(args.hv_ref, "--hv-ref"),
    )


def use_every_core(engine: str | None = None) -> str:
    """Keeps every core busy; returns a line saying how. Unless the user set `XLA_FLAGS`,
    splits the host CPU into one XLA device per core (the preference axis is sharded over
    devices, so every core trains) — except with `engine="mujoco"`, whose C engine
    already steps on one thread per core: its host callback takes the whole batch on one
    device, and XLA warns at length about gathering a sharded batch for it. Only before JAX
    initialises its backend (the device count is fixed then)."""
    from jax._src import xla_bridge

    cores = os.cpu_count() or 1
    if xla_bridge.backends_are_initialized():
        return f"[devices] JAX already initialised: {jax.device_count()} device(s)"
    if "XLA_FLAGS" in os.environ:
        return f"[devices] XLA_FLAGS={os.environ['XLA_FLAGS']!r} (yours): devices as it says"
    if engine == "mujoco":
        return f"[devices] engine mujoco: MuJoCo steps on {cores} threads, one per core"
    os.environ["XLA_FLAGS"] = f"--xla_force_host_platform_device_count={cores}"
    return (
        f"[devices] {cores} host devices, one per core (XLA_FLAGS={os.environ['XLA_FLAGS']}; "
        "set XLA_FLAGS to choose otherwise)"
    )


def main(argv=None, *, every_core: bool = False) -> int:
    """The command line (`every_core=True` from `python -m wcac_jax.sweep`: one host device
    per core unless `XLA_FLAGS` is set, said on the first line; see `use_every_core`)."""
    args = build_parser().parse_args(argv)
    if every_core:
        engine = args.engine or dict(presets.env_defaults(args.env).env_options).get("engine")
        note = use_every_core(engine)
        if not args.quiet:
            print(note, file=sys.stderr, flush=True)
    try:
        config = config_from_args(args)
        out = args.out or os.path.join("runs", time.strftime("%Y%m%d-%H%M%S"))
        if args.resume and args.out is None:
            raise SweepError("--resume needs --out DIR")
        front = run_sweep(
            config,
            out,
            resume=args.resume,
            chunks=args.chunks,
            progress=False if args.quiet else None,
        )
    except SweepError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except TrainingDiverged as err:
        print(f"error: {err}", file=sys.stderr)
        return 3
    if not args.quiet:
        print(
            f"wrote {out}: {len(front['prefs'])} preferences, hypervolume "
            f"{front['hypervolume']:.4g}, {front['env_steps_per_s']:,.0f} env-steps/s, "
            f"{front['wall_s']:.0f} s"
        )
    outside = front["outside_hv_ref"]
    if outside:
        print(
            f"warning: {len(outside)} of {len(front['prefs'])} policies lie outside the "
            f"hypervolume reference box {front['hv_ref']} and add nothing to it: "
            + ", ".join(f"#{i} {front['prefs'][i]['pref']}" for i in outside),
            file=sys.stderr,
        )
    return 0


if __name__ == "__main__":
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
    "main",
]
