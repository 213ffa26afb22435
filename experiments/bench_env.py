"""Raw Walker2d stepping speed per engine and model, and how far models and engines drift.

For each variant (engine x physics model x solver settings) and batch size: env-steps/s
of `jit(scan(vmap(step)))` with uniform random actions (after compilation), the compile
time and the cores kept busy (process CPU time / wall time). Then the drift in `qpos`
from the same start state under the same action sequence between the two models, and
between the two engines on the same model. Prints a table and writes JSON (`--out`,
default `runs/bench_env-<time>.json`).

    python experiments/bench_env.py                       # every variant, four batch sizes
    python experiments/bench_env.py --physics v5/mujoco v5/mjx --batches 144 1152
    python experiments/bench_env.py --batches --drift engines     # only the engine drift
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import time

import jax
import numpy as np
from script_io import refuse_existing

from wcac_jax import envs
from wcac_jax.core.episodes import EpisodeWrapper
from wcac_jax.sweep.outputs import json_bytes, write_atomic


def bench_stepping(env, batch: int, steps: int, seed: int = 0) -> dict:
    """Env-steps/s of random-action stepping of `batch` auto-resetting environments."""
    wrapped = EpisodeWrapper(env, env.episode_length)

    @jax.jit
    def rollout(key):
        state = jax.vmap(wrapped.reset)(jax.random.split(key, batch))

        def body(state, k):
            action = jax.random.uniform(k, (batch, env.action_size), minval=-1.0, maxval=1.0)
            state = jax.vmap(wrapped.step)(state, action)
            return state, state.reward

        return jax.lax.scan(body, state, jax.random.split(key, steps))[1]

    start = time.perf_counter()
    jax.block_until_ready(rollout(jax.random.key(seed)))
    compile_s = time.perf_counter() - start
    cpu = _cpu_s()
    start = time.perf_counter()
    jax.block_until_ready(rollout(jax.random.key(seed + 1)))
    run_s = time.perf_counter() - start
    return {
        "batch": batch,
        "steps": steps,
        "env_steps_per_s": batch * steps / run_s,
        "compile_plus_first_run_s": compile_s,
        "cores_busy": (_cpu_s() - cpu) / run_s,
    }


def _cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


VARIANTS = {
    "brax/mjx": {"physics": "brax", "engine": "mjx"},
    # MJX's default for the v5 model: solver capped at 4 iterations / 4 line-search steps
    "v5/mjx": {"physics": "gymnasium-v5", "engine": "mjx"},
    # MuJoCo's own solver settings (100 iterations, 50 line-search iterations)
    "v5/mjx-mujoco-solver": {
        "physics": "gymnasium-v5",
        "engine": "mjx",
        "solver_iterations": 100,
        "ls_iterations": 50,
    },
    "brax/mujoco": {"physics": "brax", "engine": "mujoco"},
    # MuJoCo's C engine keeps the model's solver settings (100 / 50), as MO-Gymnasium
    "v5/mujoco": {"physics": "gymnasium-v5", "engine": "mujoco"},
}
# the earlier names (MJX only)
VARIANTS |= {
    "brax": VARIANTS["brax/mjx"],
    "gymnasium-v5": VARIANTS["v5/mjx"],
    "gymnasium-v5-mujoco-solver": VARIANTS["v5/mjx-mujoco-solver"],
}
DRIFTS = {
    "models": [("brax/mjx", "v5/mjx"), ("v5/mjx", "v5/mjx-mujoco-solver")],
    # the same model and solver settings, float32 MJX vs float64 C
    "engines": [
        ("v5/mujoco", "v5/mjx-mujoco-solver"),
        ("v5/mujoco", "v5/mjx"),
        ("brax/mujoco", "brax/mjx"),
    ],
}


def qpos_drift(a: str, b: str, steps: int = 100, seed: int = 0):
    """Max |qpos_a - qpos_b| after each step, same start state and random actions.

    Both start from the same pose (each model's `rootz` is shifted by its offset so the
    torso heights agree); no resets, so the walker may fall and keep moving.
    """
    models = {a: envs.make("walker2d", **VARIANTS[a]), b: envs.make("walker2d", **VARIANTS[b])}
    key_q, key_a = jax.random.split(jax.random.key(seed))
    ref = envs.make("walker2d", physics="brax", engine="mujoco")
    start = ref.reset(key_q)
    actions = jax.random.uniform(key_a, (steps, 6), minval=-1.0, maxval=1.0)
    traj = {}
    for name, env in models.items():
        q0 = start.pipeline_state.qpos.at[1].add(ref._z_offset - env._z_offset)
        ps = env.pipeline_init(q0, start.pipeline_state.qvel)
        state = start.replace(pipeline_state=ps)

        @jax.jit
        def run(state, env=env):
            def body(s, a):
                s = env.step(s, a)
                return s, env.qpos(s.pipeline_state)

            return jax.lax.scan(body, state, actions)[1]

        traj[name] = np.asarray(run(state))
    diff = np.abs(traj[a] - traj[b]).max(axis=1)
    return {
        "pair": [a, b],
        "steps": steps,
        "max_abs_qpos_diff_at": {str(k): float(diff[k - 1]) for k in (1, 10, 50, steps)},
        f"torso_x_{a}": float(traj[a][-1, 0]),
        f"torso_x_{b}": float(traj[b][-1, 0]),
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batches", type=int, nargs="*", default=[1, 16, 144, 1024])
    parser.add_argument(
        "--steps",
        type=int,
        default=100,
        help="steps per timed rollout (capped so that one rollout is ~10k env steps)",
    )
    parser.add_argument(
        "--physics",
        nargs="+",
        default=["brax/mjx", "v5/mjx", "v5/mjx-mujoco-solver", "brax/mujoco", "v5/mujoco"],
        help="variants: " + ", ".join(VARIANTS),
    )
    parser.add_argument("--no-drift", action="store_true", help="skip every qpos drift")
    parser.add_argument(
        "--drift", nargs="*", default=list(DRIFTS), help="qpos drifts: " + ", ".join(DRIFTS)
    )
    parser.add_argument(
        "--out", default=None, help="JSON file (default: runs/bench_env-<time>.json)"
    )
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    args = parser.parse_args(argv)
    out = args.out or os.path.join("runs", time.strftime("bench_env-%Y%m%d-%H%M%S.json"))
    refuse_existing(out, args.overwrite)
    unknown = [v for v in args.physics if v not in VARIANTS]
    if unknown:
        parser.error(f"unknown variant(s) {unknown}; valid: {', '.join(VARIANTS)}")

    rows = []
    for physics in args.physics:
        env = envs.make("walker2d", **VARIANTS[physics])
        for batch in args.batches:
            steps = max(10, min(args.steps, 10_000 // batch))
            row = {"physics": physics, **bench_stepping(env, batch, steps)}
            rows.append(row)
            print(
                f"{physics:>20}  batch {batch:>5}  {row['env_steps_per_s']:>9.0f} env-steps/s"
                f"  (compile + first run {row['compile_plus_first_run_s']:.1f} s, "
                f"{row['cores_busy']:.2f} cores busy)",
                flush=True,
            )
    result = {
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs",
        "device": str(jax.devices()[0]),
        "variants": {k: VARIANTS[k] for k in args.physics},
        "stepping": rows,
        "qpos_drift": [],
    }
    for kind in [] if args.no_drift else args.drift:
        for a, b in DRIFTS[kind]:
            drift = {"kind": kind, **qpos_drift(a, b)}
            result["qpos_drift"].append(drift)
            print("qpos drift:", json.dumps(drift), flush=True)
    result["load_average_at_end"] = os.getloadavg()
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    write_atomic(out, json_bytes(result))


if __name__ == "__main__":
    main()
