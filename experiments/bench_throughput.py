"""How close the one-program sweep comes to raw environment stepping, and to the
alternative of training each preference on its own.

At the same batch (`P` preferences x `N` environments), measures after compilation:

  (a) raw stepping: uniform random actions, the same physics, `jit(scan(vmap(step)))`,
      no learning: the ceiling;
  (b) the sweep's training: `jit(vmap(train chunk))` over the `P` preferences;
  (c) what a user without this engine would run: `P` single-preference trainings
      (`jit(train chunk)` on one preference), one after another;

and prints env-steps/s of each, the ratios (b)/(a) and (b)/(c), compile times, how many
cores were busy while each ran (process CPU time / wall time), how an env step's time
splits between the physics (a) and the networks ((b) minus (a)), peak host memory and (on
a GPU) peak device memory; the same goes to a JSON file (`--out`, default
`runs/bench_throughput-<time>.json`). It asserts nothing about speed.

`--grid` runs one subprocess per engine x physics x `N` (each its own peak memory, all
with the paper's networks), and writes all rows to one JSON.

    python experiments/bench_throughput.py                  # default sweep size
    python experiments/bench_throughput.py --quick          # < 5 minutes on a 2-core CPU
    python experiments/bench_throughput.py --engine mujoco --physics gymnasium-v5
    python experiments/bench_throughput.py --grid --iterations 4 \
        --out experiments/results/bench_paper_engine_grid.json
    python experiments/bench_throughput.py --prefs 9 --envs-per-pref 1024   # on a GPU
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import platform
import resource
import subprocess
import sys
import time

import jax
import jax.numpy as jnp
from script_io import refuse_existing

from wcac_jax import envs, pareto
from wcac_jax.algos import PaperConfig, PracticalConfig, make_trainer
from wcac_jax.core.episodes import EpisodeWrapper
from wcac_jax.core.utopia import PREF_AXIS
from wcac_jax.sweep.outputs import json_bytes, write_atomic

_LAST_CORES = {}


def _cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _timed(fn, *args):
    """`fn(*args)` to completion; its wall time. The cores it kept busy (process CPU time
    over wall time, rollout threads included) go to `_LAST_CORES["busy"]`."""
    cpu, start = _cpu_s(), time.perf_counter()
    out = jax.block_until_ready(fn(*args))
    wall = time.perf_counter() - start
    _LAST_CORES["busy"] = (_cpu_s() - cpu) / max(wall, 1e-9)
    return out, wall


def _compile(jitted, *args):
    start = time.perf_counter()
    compiled = jitted.lower(*args).compile()
    return compiled, time.perf_counter() - start


def bench_raw(env, batch: int, steps: int) -> dict:
    """(a): random-action stepping of `batch` auto-resetting environments."""
    wrapped = EpisodeWrapper(env, env.episode_length)

    def rollout(state, key):
        def body(state, k):
            action = jax.random.uniform(k, (batch, env.action_size), minval=-1.0, maxval=1.0)
            state = jax.vmap(wrapped.step)(state, action)
            return state, state.reward[:, 0]

        return jax.lax.scan(body, state, jax.random.split(key, steps))

    state = jax.jit(jax.vmap(wrapped.reset))(jax.random.split(jax.random.key(0), batch))
    fn, compile_s = _compile(jax.jit(rollout), state, jax.random.key(1))
    _timed(fn, state, jax.random.key(2))  # warm-up
    _, run_s = _timed(fn, state, jax.random.key(3))
    return {
        "env_steps_per_s": batch * steps / run_s,
        "compile_s": compile_s,
        "run_s": run_s,
        "cores_busy": _LAST_CORES["busy"],
    }


def bench_sweep(trainer, config, prefs, iters: int) -> dict:
    """(b): all preferences in one `jit(vmap(run))`."""
    keys = jax.random.split(jax.random.key(0), prefs.shape[0])
    state = jax.jit(jax.vmap(trainer.init))(keys, prefs)
    # the preference axis is named, as in the sweep (the practical update shares its
    # estimated utopia point over it)
    run = functools.partial(trainer.run, num_iterations=iters)
    fn, compile_s = _compile(jax.jit(jax.vmap(run, axis_name=PREF_AXIS)), state, prefs)
    (state, _), _ = _timed(fn, state, prefs)  # warm-up chunk (moves off the start state)
    _, run_s = _timed(fn, state, prefs)
    steps = prefs.shape[0] * iters * config.env_steps_per_iteration
    return {
        "env_steps_per_s": steps / run_s,
        "compile_s": compile_s,
        "run_s": run_s,
        "cores_busy": _LAST_CORES["busy"],
    }


def bench_sequential(trainer, config, prefs, iters: int) -> dict:
    """(c): one preference at a time, each its own `jit(run)` call."""
    run = jax.jit(functools.partial(trainer.run, num_iterations=iters))
    init = jax.jit(trainer.init)
    state = init(jax.random.key(0), prefs[0])
    fn, compile_s = _compile(run, state, prefs[0])
    total = 0.0
    for i in range(prefs.shape[0]):
        state = init(jax.random.key(i), prefs[i])
        (state, _), _ = _timed(fn, state, prefs[i])  # warm-up
        _, run_s = _timed(fn, state, prefs[i])
        total += run_s
    steps = prefs.shape[0] * iters * config.env_steps_per_iteration
    return {
        "env_steps_per_s": steps / total,
        "compile_s": compile_s,
        "run_s": total,
        "note": "compiled once; separate processes would compile once per preference",
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="walker2d")
    parser.add_argument("--physics", default="brax", help="walker2d physics")
    parser.add_argument("--engine", default="mjx", help="walker2d engine: mjx or mujoco")
    parser.add_argument(
        "--devices",
        type=int,
        default=None,
        help="host devices (sets XLA_FLAGS before JAX starts; default: JAX's own, 1 on CPU); "
        "the sweep (b) is not sharded, so this only changes how XLA runs",
    )
    parser.add_argument(
        "--grid",
        action="store_true",
        help="every engine x physics at N = 16 and 128 (P = --prefs), one subprocess each",
    )
    parser.add_argument(
        "--update",
        choices=["paper", "practical"],
        default="paper",
        help="the paper's update (PaperConfig: the size flags below) or the practical one "
        "(PracticalConfig's defaults; its shared utopia point rules out the sequential baseline)",
    )
    parser.add_argument("--prefs", type=int, default=9, help="P")
    parser.add_argument("--envs-per-pref", type=int, default=16, help="N")
    parser.add_argument("--critic-steps", type=int, default=10, help="K")
    parser.add_argument("--rollout-steps", type=int, default=10, help="L")
    parser.add_argument(
        "--width",
        type=int,
        default=None,
        help="hidden width (default: PaperConfig's or PracticalConfig's)",
    )
    parser.add_argument("--depth", type=int, default=2)
    parser.add_argument("--network", default="paper")
    parser.add_argument("--iterations", type=int, default=20, help="timed iterations")
    parser.add_argument("--quick", action="store_true", help="small sizes, < 5 min on CPU")
    parser.add_argument("--skip", nargs="*", default=[], choices=["raw", "sweep", "sequential"])
    parser.add_argument(
        "--out", default=None, help="JSON file (default: runs/bench_throughput-<time>.json)"
    )
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    args = parser.parse_args(argv)
    out = args.out or os.path.join("runs", time.strftime("bench_throughput-%Y%m%d-%H%M%S.json"))
    refuse_existing(out, args.overwrite)
    if args.grid:
        return run_grid(args, out)
    if args.devices is not None:
        os.environ["XLA_FLAGS"] = f"--xla_force_host_platform_device_count={args.devices}"
    if args.quick:
        args.prefs, args.envs_per_pref, args.iterations = min(args.prefs, 3), 4, 3
        args.width, args.critic_steps, args.rollout_steps = 64, 4, 4

    env_kwargs = {"physics": args.physics, "engine": args.engine} if args.env == "walker2d" else {}
    env = envs.make(args.env, **env_kwargs)
    if args.update == "practical":  # PracticalConfig's own sizes but N; no sequential baseline
        config = PracticalConfig(num_envs=args.envs_per_pref)
        config = config.replace(width=args.width or config.width)
        args.skip = sorted({*args.skip, "sequential"})
    else:
        config = PaperConfig(
            num_envs=args.envs_per_pref,
            critic_steps=args.critic_steps,
            rollout_steps=args.rollout_steps,
            width=args.width or PaperConfig.width,
            depth=args.depth,
            network=args.network,
            normalize_obs=args.env != "concave_bandit",
        )
    trainer = make_trainer(config, env)
    prefs = jnp.asarray(pareto.simplex_lattice(env.num_objectives, args.prefs), jnp.float32)
    batch = args.prefs * args.envs_per_pref
    raw_steps = args.iterations * config.env_steps_per_iteration // config.num_envs

    result = {
        "machine": f"{platform.machine()}, {os.cpu_count()} CPUs",
        "device": str(jax.devices()[0]),
        "device_kind": jax.devices()[0].device_kind,
        "jax": jax.__version__,
        "env": args.env,
        "physics": args.physics if args.env == "walker2d" else None,
        "engine": args.engine if args.env == "walker2d" else None,
        "device_count": jax.device_count(),
        "P": args.prefs,
        "N": args.envs_per_pref,
        "update": args.update,
        "K": getattr(config, "critic_steps", None),
        "L": config.rollout_steps,
        "width": config.width,
        "depth": config.depth,
        "network": getattr(config, "network", "practical"),
        "timed_iterations": args.iterations,
    }
    for name, fn in (
        ("raw", lambda: bench_raw(env, batch, raw_steps)),
        ("sweep", lambda: bench_sweep(trainer, config, prefs, args.iterations)),
        ("sequential", lambda: bench_sequential(trainer, config, prefs, args.iterations)),
    ):
        if name in args.skip:
            result[name] = None
            continue
        result[name] = fn()
        print(
            f"{name:>10}: {result[name]['env_steps_per_s']:>10,.0f} env-steps/s   "
            f"compile {result[name]['compile_s']:.1f} s",
            flush=True,
        )

    def ratio(a, b):
        if result.get(a) and result.get(b):
            return result[a]["env_steps_per_s"] / result[b]["env_steps_per_s"]
        return None

    result["sweep_over_raw"] = ratio("sweep", "raw")
    if result.get("raw") and result.get("sweep"):
        # an env step's time in the sweep: the physics' (raw stepping) + the networks' rest
        physics_ms = 1e3 / result["raw"]["env_steps_per_s"]
        result["ms_per_env_step"] = {
            "physics": physics_ms,
            "networks": 1e3 / result["sweep"]["env_steps_per_s"] - physics_ms,
        }
    result["sweep_over_sequential"] = ratio("sweep", "sequential")
    result["peak_host_memory_gib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    stats = jax.devices()[0].memory_stats() or {}
    result["peak_device_memory_gib"] = (
        stats["peak_bytes_in_use"] / 2**30 if "peak_bytes_in_use" in stats else None
    )
    fmt = lambda x: "n/a" if x is None else f"{x:.2f}"  # noqa: E731
    print(
        f"(b)/(a) sweep / raw = {fmt(result['sweep_over_raw'])}    "
        f"(b)/(c) sweep / sequential = {fmt(result['sweep_over_sequential'])}    "
        f"peak host memory {result['peak_host_memory_gib']:.2f} GiB    "
        f"peak device memory {fmt(result['peak_device_memory_gib'])} GiB"
    )
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    write_atomic(out, json_bytes(result))
    return result


GRID_ENGINES = ("mjx", "mujoco")
GRID_PHYSICS = ("brax", "gymnasium-v5")
GRID_N = (16, 128)


def run_grid(args, out: str) -> dict:
    """One subprocess per engine x physics x N (so each row has its own compile and
    peak memory); raw stepping and the sweep, no sequential baseline. Timed iterations:
    `--iterations` at N = 16, a quarter of them (at least 2) at N = 128."""
    rows = []
    directory = os.path.dirname(os.path.abspath(out))
    os.makedirs(directory, exist_ok=True)
    for n in GRID_N:
        iters = args.iterations if n == GRID_N[0] else max(2, args.iterations // 4)
        for physics in GRID_PHYSICS:
            for engine in GRID_ENGINES:
                row_out = os.path.join(directory, f".grid-{engine}-{physics}-{n}.json")
                cmd = [
                    sys.executable,
                    os.path.abspath(__file__),
                    *("--engine", engine, "--physics", physics, "--prefs", str(args.prefs)),
                    *("--envs-per-pref", str(n), "--iterations", str(iters)),
                    *("--critic-steps", str(args.critic_steps)),
                    *("--rollout-steps", str(args.rollout_steps)),
                    *("--width", str(args.width or PaperConfig.width), "--depth", str(args.depth)),
                    *("--network", args.network, "--skip", "sequential", "--out", row_out),
                    "--overwrite",  # the row file of an earlier, interrupted grid
                ]
                if args.devices is not None:
                    cmd += ["--devices", str(args.devices)]
                print(f"== {engine} / {physics} / P x N = {args.prefs} x {n}", flush=True)
                start = time.perf_counter()
                subprocess.run(cmd, check=True)
                with open(row_out) as f:
                    row = json.load(f)
                os.unlink(row_out)
                row["process_wall_s"] = time.perf_counter() - start
                row["load_average_after"] = os.getloadavg()
                rows.append(row)
                result = {"machine": f"{platform.machine()}, {os.cpu_count()} CPUs", "rows": rows}
                # after every row: a stopped grid keeps its rows
                write_atomic(out, json_bytes(result))
    print(f"wrote {out}")
    return result


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
