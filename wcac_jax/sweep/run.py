"""`run_sweep`: a sweep's host side, as the named steps its driver calls in order.

Check the input (`_prepare`), lay the preferences out over the devices (`_lay_out`),
build and lower the programs and check the metrics fit in memory (`_lower`), start from
scratch or from the last checkpoint (`_start`), compile, train chunk by chunk (`_train`:
calls of the program, the finite check, the selection's candidates, a checkpoint after
every chunk, the progress report), choose and evaluate the reported policies
(`_evaluate`), summarise and write (`_finish`).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import PartitionSpec as P

from wcac_jax import algos
from wcac_jax.algos import UpdateConfig, contract
from wcac_jax.core.runtime import TRACED_DIRECTIONS, resolve_j_ub, with_env_steps
from wcac_jax.core.utopia import DEVICE_AXIS
from wcac_jax.sweep import checkpoint, distributed, selection
from wcac_jax.sweep.config import (
    SweepConfig,
    SweepError,
    check_output_dir,
    default_hv_ref,
    make_env,
    read_json,
    validate_prefs,
)
from wcac_jax.sweep.outputs import (
    json_bytes,
    replace_dir,
    staging_dir,
    summarize,
    write_atomic,
    write_outputs,
)
from wcac_jax.sweep.progress import Pace, Progress, note
from wcac_jax.sweep.training import Programs, build_programs, state_bytes


class TrainingDiverged(RuntimeError):
    """NaN appeared during training; the last good checkpoint is kept."""


def run_sweep(
    config: SweepConfig,
    out: str | None = None,
    *,
    resume: bool = False,
    overwrite: bool = False,
    chunks: int = 4,
    progress: bool | None = None,
    stop_after_chunks: int | None = None,
    progress_fn: Callable[[int, dict], None] | None = None,
    network_factory=None,
) -> dict:
    """Trains every preference of `config` in one compiled program; returns the front.

    Args:
      config: the sweep.
      out: output directory (`None`: nothing is written and no checkpoints are kept).
      resume: continue the sweep checkpointed in `out`.
      overwrite: replace the results in a non-empty `out`. The new sweep runs in a
        directory beside it (`staging_dir(out)`) that replaces `out` once every file is
        written, so an interrupted run leaves `out` as it was.
      chunks: the number of pieces the run is split into, with a checkpoint after each
        (and, in a log, a progress line).
      progress: force the progress display on/off (`None`: on); a bar on a terminal,
        moved every few seconds (`wcac_jax.sweep.progress`), plain lines otherwise.
      stop_after_chunks: stop (as if interrupted) after this many chunks of this call.
      progress_fn: called on process 0 after each call of the training program as
        `progress_fn(env_steps, metrics)`: the env steps each preference has taken so
        far, and the per-iteration metrics of the iterations just run (host arrays
        `[P, n, ...]`, `train/env_steps` among them). Results do not depend on it.
      network_factory: the updates' networks (`algos.make_trainer`; `None`: those the
        configuration names). A sweep with a factory of its own is read back with the
        same factory (`load_sweep`).

    Returns:
      The `front.json` content as a dict (see README, "Outputs"). Resuming a sweep that
      has finished (its `front.json` is written) changes nothing: its `front.json` content,
      with `"finished": True` (on every process but 0, that mark alone).

    Raises:
      SweepError: bad input (nothing written).
      TrainingDiverged: NaN during training (the last good checkpoint is kept).
    """
    plan = _prepare(config, chunks)
    work = out  # where the run writes: `out`, or with `overwrite` a directory beside it
    if out is not None:
        if resume and overwrite:
            raise SweepError(
                "--resume continues the sweep in --out and --overwrite replaces it: give one"
            )
        _on_writer(lambda: check_output_dir(out, plan.config, resume, overwrite=overwrite))
        finished = _finished(out) if resume else None
        if finished is not None:
            return finished
        if overwrite:
            work = staging_dir(out)
            _on_writer(lambda: shutil.rmtree(work, ignore_errors=True))  # an earlier try's
    layout = _lay_out(plan)
    report = progress if distributed.is_writer() else False
    if jax.process_count() > 1 and progress is not False:
        _say_part(layout.sharding, plan.n_prefs, layout.n_pad)
    programs = build_programs(
        plan.train,
        plan.env,
        layout.mesh,
        plan.chunk_len,
        plan.config.eval_episodes,
        network_factory,
    )
    state = programs.init(layout.keys, layout.chunk_args[0])
    slow = plan.env.backend == "mjx" and jax.default_backend() == "cpu"
    note(
        f"[sweep] compiling the training program for {plan.n_prefs} preferences"
        + (" (MJX on a CPU: a minute or more)" if slow else ""),
        report,
    )
    lowered, lower_s = _lower(plan, layout, programs, state)
    run = _start(plan, layout, programs, state, lowered.out_info[1], work, resume)
    t0 = time.perf_counter()
    executable = lowered.compile()
    run.compile_s = lower_s + time.perf_counter() - t0
    run.wall_start = time.perf_counter()
    if distributed.is_writer():
        run.progress_fn = progress_fn
    if not _train(plan, layout, programs, executable, run, report, stop_after_chunks):
        return {"interrupted": True, "iterations_done": run.done}
    evaluation, chosen = _evaluate(plan, layout, programs, run)
    front = _finish(plan, work, run, evaluation, chosen, _timing(run))
    if work != out and distributed.is_writer():
        replace_dir(work, out)
    return front


class Plan(NamedTuple):
    """A sweep's checked input (`_prepare`)."""

    config: SweepConfig  # with its device count
    env: Any
    prefs: np.ndarray  # [P, m] float64, as asked for
    train: UpdateConfig  # with its `num_iterations`
    j_ub: tuple[float, ...]
    hv_ref: tuple[float, ...]
    chunk_len: int  # iterations per chunk (the compiled program's scan length)

    @property
    def n_prefs(self) -> int:
        return self.prefs.shape[0]

    @property
    def n_iters(self) -> int:
        return self.config.num_iterations

    @property
    def steps_per_iteration(self) -> int:
        """Env steps of one iteration of every preference."""
        return self.train.env_steps_per_iteration * self.n_prefs


def _prepare(config: SweepConfig, chunks: int) -> Plan:
    """Checks everything about `config` that needs its environment, raising `SweepError`."""
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
    train = config.train_config()
    try:
        j_ub = resolve_j_ub(train, env)
    except ValueError as err:
        raise SweepError(str(err)) from None
    hv_ref = config.hv_ref if config.hv_ref is not None else default_hv_ref(env)
    if len(hv_ref) != m:
        raise SweepError(f"hv_ref {list(hv_ref)} has {len(hv_ref)} entries, expected {m}")
    if not isinstance(chunks, int) or chunks < 1:
        raise SweepError(f"chunks must be a positive integer, got {chunks!r}")
    chunk_len = math.ceil(config.num_iterations / chunks)
    return Plan(config, env, prefs, train, j_ub, hv_ref, chunk_len)


class Layout(NamedTuple):
    """The preferences laid out over every device: `P' = P + n_pad` rows, the last
    preference repeated to a multiple of the device count; global arrays are sharded
    over the mesh's one axis, `DEVICE_AXIS`."""

    mesh: jax.sharding.Mesh
    sharding: jax.sharding.NamedSharding
    n_pad: int
    prefs: np.ndarray  # [P', m] float32, on the host
    keys: jax.Array  # [P', 2] uint32 key data: preference i's `fold_in(key(seed), i)`
    eval_keys: jax.Array  # [P', 2]: the reported evaluation's
    select_keys: jax.Array  # [P', 2]: the selection candidates' evaluation's
    chunk_args: tuple  # `(prefs [P', m][, direction [P'] int32])`, global

    def stop_at(self, iteration: int) -> jax.Array:
        """`make_chunk`'s `stop` `[P']`, the same `iteration` on every preference."""
        rows = self.prefs.shape[0]
        return distributed.to_global(np.full(rows, iteration, np.int32), self.sharding)


def _lay_out(plan: Plan) -> Layout:
    """Pads the preferences to the devices, derives every key, and puts the
    per-preference inputs on the mesh (host values, the same on every process, laid out
    over every process's devices)."""
    n_prefs, n_dev = plan.n_prefs, jax.device_count()
    n_pad = -n_prefs % n_dev
    prefs_pad = np.concatenate([plan.prefs, np.repeat(plan.prefs[-1:], n_pad, axis=0)])
    prefs_pad = prefs_pad.astype(np.float32)
    base = jax.random.key(plan.config.seed)
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
    if plan.train.scalarization in TRACED_DIRECTIONS:
        index = TRACED_DIRECTIONS.index(plan.train.scalarization)
        per_pref.append(np.full(n_prefs + n_pad, index, np.int32))
    keys_dev, eval_keys_dev, select_keys_dev, *chunk_args = distributed.to_global(
        tuple(jax.random.key_data(k) for k in (keys, eval_keys, select_keys)) + (*per_pref,),
        sharded,
    )
    return Layout(
        mesh, sharded, n_pad, prefs_pad, keys_dev, eval_keys_dev, select_keys_dev, (*chunk_args,)
    )


def _lower(plan: Plan, layout: Layout, programs: Programs, state) -> tuple[Any, float]:
    """The chunk program lowered (traced; compiled later), and the seconds it took.

    Raises:
      SweepError: the update's metrics do not meet the contract (`algos.contract`), or
        the per-iteration metrics of the whole run would not fit in this host's memory.
    """
    t0 = time.perf_counter()
    lowered = programs.chunk.lower(state, layout.stop_at(plan.n_iters), *layout.chunk_args)
    lower_s = time.perf_counter() - t0
    # per-iteration metrics, shaped as the program returns them (`[P', chunk_len, ...]`):
    # what the summary reads must be there before anything compiles
    template = lowered.out_info[1]
    try:
        contract.check_metrics(
            algos.kind(plan.train),
            {k: s.shape[2:] for k, s in template.items()},
            int(plan.env.num_objectives),
        )
    except contract.ContractError as err:
        raise SweepError(str(err)) from None
    metrics_bytes = sum(
        plan.n_prefs * plan.n_iters * math.prod(s.shape[2:]) * np.dtype(s.dtype).itemsize
        for s in template.values()
    )
    if metrics_bytes > _host_memory_bytes():
        raise SweepError(
            f"steps_per_pref {plan.config.steps_per_pref} needs {metrics_bytes / 2**30:,.1f} "
            f"GiB of per-iteration metrics ({plan.n_iters:,} iterations x {plan.n_prefs} "
            f"preferences); this machine has {_host_memory_bytes() / 2**30:,.1f} GiB"
        )
    return lowered, lower_s


@dataclass
class _Run:
    """What the host loop carries from chunk to chunk."""

    state: Any  # `UpdateState`, global, `[P', ...]`
    metrics: dict  # per-iteration metrics on the host, `[P, T, ...]`
    pool: selection.Pool | None  # the policies `wcac_jax.sweep.selection` chooses among
    manager: Any  # orbax's checkpoint manager: process 0 of a sweep with `out`
    out: str | None
    done: int  # iterations done (every preference is at the same one)
    train_s: float = 0.0  # this run's seconds in the training program
    steps_this_run: int = 0  # this run's env steps (all preferences)
    compile_s: float = 0.0  # this run's seconds lowering and compiling
    wall_start: float = 0.0  # `time.perf_counter()` when this run's training began
    progress_fn: Callable | None = None  # `run_sweep`'s, on process 0
    # the clocks of the earlier parts of a resumed sweep (`TIMING`), counted from
    # iteration `timed_from`; empty when this run started the sweep
    before: dict = field(default_factory=dict)
    timed_from: int = 0


def _start(plan: Plan, layout: Layout, programs: Programs, state, template, out, resume) -> _Run:
    """Zero metrics, the selection's pool, the checkpoint manager (process 0 writes
    `config.json` of a new sweep), and, on resume, the last checkpoint on every process
    (process 0 reads it; the others receive it: no shared file system)."""
    n_prefs, n_iters = plan.n_prefs, plan.n_iters
    metrics = {k: np.zeros((n_prefs, n_iters, *s.shape[2:]), s.dtype) for k, s in template.items()}
    pool = None
    if plan.config.select_last > 1:
        pool = selection.Pool(
            plan.config.candidate_iterations,
            jax.tree.map(lambda x: np.zeros(x.shape, x.dtype), state),
            jax.eval_shape(programs.evaluate, state, layout.eval_keys),
        )
    manager = None
    if out is not None and distributed.is_writer():  # only process 0 touches `out`
        os.makedirs(out, exist_ok=True)
        if not resume:
            write_atomic(os.path.join(out, "config.json"), json_bytes(plan.config.to_dict()))
        manager = checkpoint.manager(out)
    if out is not None and resume:
        host = {"state": jax.tree.map(lambda x: np.zeros(x.shape, x.dtype), state)}
        host["metrics"] = metrics
        if pool is not None:
            host["selection"] = pool.tree
        found = manager is not None and manager.latest_step() is not None
        if found:
            host = checkpoint.restore(manager, host)
        if distributed.all_ok(found):
            host = distributed.broadcast(host)
            state = distributed.to_global(host["state"], layout.sharding)
            metrics = {k: np.array(v) for k, v in host["metrics"].items()}  # writable
            if pool is not None:
                pool.tree = jax.tree.map(np.array, host["selection"])
    done = int(np.asarray(state.iteration.addressable_shards[0].data)[0])
    run = _Run(state, metrics, pool, manager, out, done)
    if manager is not None and done > 0:  # the earlier parts' clocks, if they match
        before = _read_timing(out)
        if before.get("iteration") == done:
            run.before = before
        else:
            run.timed_from = done
    return run


def _train(
    plan: Plan,
    layout: Layout,
    programs: Programs,
    executable,
    run: _Run,
    report: bool | None,
    stop_after_chunks: int | None,
) -> bool:
    """Trains chunk by chunk to the last iteration, each chunk ending at `chunk_len`
    iterations or at the next selection candidate, with a checkpoint after it. Returns
    `False` when stopped after `stop_after_chunks` chunks, as if interrupted."""
    steps = plan.steps_per_iteration
    progress = Progress(plan.n_iters * steps, run.done * steps, report)
    # the bar moves between calls: on a terminal, calls of a few seconds each; every
    # process cuts the chunk alike (process 0's terminal decides)
    pace = Pace() if distributed.all_ok(progress.live) else None
    chunks_run = 0
    try:
        while run.done < plan.n_iters:
            if stop_after_chunks is not None and chunks_run >= stop_after_chunks:
                return False
            stop = run.pool.next_stop(run.done, plan.n_iters) if run.pool else plan.n_iters
            hi = min(run.done + plan.chunk_len, stop)
            _train_to(hi, plan, layout, executable, run, pace, progress)
            chunks_run += 1
            _keep(layout, programs, run)
            progress.chunk_done()
    finally:
        progress.close()
    return True


def _train_to(
    hi: int, plan: Plan, layout: Layout, executable, run: _Run, pace: Pace | None, progress
) -> None:
    """Trains every preference from `run.done` to iteration `hi`: one call of the chunk
    program, or (with `pace`) calls of a few seconds each; copies each call's metrics to
    the host and checks them."""
    while run.done < hi:
        lo = run.done
        n = pace.iterations(hi - lo) if pace is not None else hi - lo
        t0 = time.perf_counter()
        run.state, chunk_metrics = executable(run.state, layout.stop_at(lo + n), *layout.chunk_args)
        chunk_metrics = distributed.to_host(chunk_metrics)
        dt = time.perf_counter() - t0
        if pace is not None:
            pace.record(n, dt)
        run.train_s += dt
        run.steps_this_run += n * plan.steps_per_iteration
        for k, v in chunk_metrics.items():
            run.metrics[k][:, lo : lo + n] = np.asarray(v)[: plan.n_prefs, :n]
        _check_finite(run.metrics, lo, lo + n, plan.prefs, run.manager)
        run.done = lo + n
        progress.advance(n * plan.steps_per_iteration, dt)
        if run.progress_fn is not None:
            done = {k: v[:, lo : lo + n] for k, v in run.metrics.items()}
            run.progress_fn(
                int(run.done * plan.train.env_steps_per_iteration),
                with_env_steps(plan.train, done),
            )


def _keep(layout: Layout, programs: Programs, run: _Run) -> None:
    """After a chunk: the selection's candidate, if this iteration is one (evaluated on
    its own episodes), and the checkpoint (process 0 of a sweep with `out`)."""
    candidate = run.pool is not None and run.done in run.pool.iterations
    if run.out is not None or candidate:
        host_state = distributed.to_host(run.state)  # every process takes part
    if candidate:
        found = distributed.to_host(programs.evaluate(run.state, layout.select_keys))
        run.pool.add(run.done, host_state, found)
    if run.manager is not None:
        saved = {"state": host_state, "metrics": run.metrics}
        if run.pool is not None:
            saved["selection"] = run.pool.tree
        checkpoint.save(run.manager, run.done, saved)
        write_atomic(os.path.join(run.out, TIMING), json_bytes(_timing(run)))


# the clocks of a sweep's parts so far (`_timing`), beside its checkpoint
TIMING = "timing.json"


def _timing(run: _Run) -> dict:
    """The whole sweep's clocks: this run's added to the earlier parts' (`run.before`);
    `iteration`: the iterations they cover, `timed_from` on."""
    before = run.before
    return {
        "iteration": run.done,
        "timed_from_iteration": before.get("timed_from_iteration", run.timed_from),
        "parts": before.get("parts", 0) + 1,
        "compile_s": before.get("compile_s", 0.0) + run.compile_s,
        "train_s": before.get("train_s", 0.0) + run.train_s,
        "wall_s": before.get("wall_s", 0.0)
        + run.compile_s
        + (time.perf_counter() - run.wall_start),
        "env_steps_timed": before.get("env_steps_timed", 0) + run.steps_this_run,
    }


def _read_timing(out: str) -> dict:
    """The clocks `out` holds (`TIMING`), or `{}` if it holds none readable."""
    try:
        with open(os.path.join(out, TIMING)) as f:
            saved = json.load(f)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return {}
    return saved if isinstance(saved, dict) else {}


def _evaluate(plan: Plan, layout: Layout, programs: Programs, run: _Run) -> tuple[dict, Any]:
    """`(evaluation, selection)`: the reported policies evaluated on fresh episodes, and
    with `select_last > 1` what `front.json` records of the choice (else `None`)."""
    state, chosen = run.state, None
    if run.pool is not None:  # each preference's reported policy, on fresh episodes
        by = selection.criterion(plan.train)
        index, z, regrets, picked = run.pool.choose(layout.prefs, by)
        final = distributed.to_host(programs.evaluate(state, layout.eval_keys))  # no choice
        chosen = run.pool.summary(
            index, z, regrets, plan.n_prefs, plan.config.eval_episodes, final, by
        )
        state = distributed.to_global(picked, layout.sharding)
    return distributed.to_host(programs.evaluate(state, layout.eval_keys)), chosen


def _finish(plan: Plan, out, run: _Run, evaluation, chosen, timing) -> dict:
    """`front.json`'s content; process 0 of a sweep with `out` writes every file."""
    metrics = with_env_steps(plan.train, run.metrics)  # int64, counted on the host
    front = summarize(
        plan.config,
        plan.env,
        plan.prefs,
        plan.j_ub,
        plan.hv_ref,
        metrics,
        evaluation,
        timing,
        selection=chosen,
    )
    if out is not None and distributed.is_writer():
        write_outputs(out, front, metrics, plan.prefs)
    return front


def _finished(out: str) -> dict | None:
    """The saved front of the sweep in `out` if it has finished (`front.json` is written
    last), marked `"finished": True`, on every process (process 0 reads it; the others
    get the mark alone); else `None`."""
    saved = {}

    def read():
        saved.update(read_json(os.path.join(out, "front.json"), "--resume: ", "front") or {})

    _on_writer(read)
    if not distributed.all_ok(bool(saved)):
        return None
    return {**saved, "finished": True}


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


def check_pref_count(n_prefs: int, train: UpdateConfig, env, flag: str = "--n-prefs") -> None:
    """Checks, before anything is allocated, that `n_prefs` preferences' training states
    alone (`state_bytes`, a lower bound of what a sweep holds) fit in this host's memory.

    Raises:
      SweepError: naming `flag`, the count, the memory it needs and the memory there is.
    """
    per_pref = state_bytes(train, env)
    need, have = n_prefs * per_pref, _host_memory_bytes()
    if need > have:
        raise SweepError(
            f"{flag} {n_prefs:,} needs at least {need / 2**30:,.1f} GiB for the training "
            f"states ({per_pref:,} bytes per preference); this machine has "
            f"{have / 2**30:,.1f} GiB (at most {have // per_pref:,} preferences)"
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
