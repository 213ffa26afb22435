"""Raw Walker2d stepping speed on MJX, and how far the two physics models drift apart.

For each physics model and batch size: env-steps/s of `jit(scan(vmap(step)))` with
uniform random actions (after compilation), and the compile time. Then the drift in
`qpos` between `"brax"` and `"gymnasium-v5"` physics from the same start state under
the same action sequence. Prints a table and writes JSON (`--out`).

    python experiments/bench_env.py                       # all four batch sizes
    python experiments/bench_env.py --batches 16 --steps 50 --quick
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

import jax
import numpy as np

from wcac_jax import envs
from wcac_jax.envs.wrappers import EpisodeWrapper


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
    start = time.perf_counter()
    jax.block_until_ready(rollout(jax.random.key(seed + 1)))
    run_s = time.perf_counter() - start
    return {
        "batch": batch,
        "steps": steps,
        "env_steps_per_s": batch * steps / run_s,
        "compile_plus_first_run_s": compile_s,
    }


VARIANTS = {
    "brax": {"physics": "brax"},
    # our default for the v5 model: solver capped at 4 iterations / 4 line-search steps
    "gymnasium-v5": {"physics": "gymnasium-v5"},
    # MuJoCo's own solver settings (100 iterations, 50 line-search iterations)
    "gymnasium-v5-mujoco-solver": {
        "physics": "gymnasium-v5",
        "solver_iterations": 100,
        "ls_iterations": 50,
    },
}


def qpos_drift(a: str = "brax", b: str = "gymnasium-v5", steps: int = 100, seed: int = 0):
    """Max |qpos_a - qpos_b| after each step, same start state and random actions.

    Both start from the same pose (each model's `rootz` is shifted by its offset so the
    torso heights agree); no resets, so the walker may fall and keep moving.
    """
    models = {a: envs.make("walker2d", **VARIANTS[a]), b: envs.make("walker2d", **VARIANTS[b])}
    key_q, key_a = jax.random.split(jax.random.key(seed))
    ref = envs.make("walker2d", physics="brax")
    start = ref.reset(key_q)
    actions = jax.random.uniform(key_a, (steps, 6), minval=-1.0, maxval=1.0)
    traj = {}
    for name, env in models.items():
        q0 = start.pipeline_state.q.at[1].add(ref._z_offset - env._z_offset)
        ps = env.pipeline_init(q0, start.pipeline_state.qd)
        state = start.replace(pipeline_state=ps)

        @jax.jit
        def run(state, env=env):
            def body(s, a):
                s = env.step(s, a)
                return s, env._qpos(s.pipeline_state)

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
        default=list(VARIANTS),
        help="variants: " + ", ".join(VARIANTS),
    )
    parser.add_argument("--no-drift", action="store_true", help="skip the qpos drift")
    parser.add_argument("--out", default="bench_env.json")
    args = parser.parse_args(argv)

    rows = []
    for physics in args.physics:
        kwargs = {"physics": physics}
        env = envs.make("walker2d", **VARIANTS.get(physics, kwargs))
        for batch in args.batches:
            steps = max(10, min(args.steps, 10_000 // batch))
            row = {"physics": physics, **bench_stepping(env, batch, steps)}
            rows.append(row)
            print(
                f"{physics:>18}  batch {batch:>5}  {row['env_steps_per_s']:>9.0f} env-steps/s"
                f"  (compile + first run {row['compile_plus_first_run_s']:.1f} s)",
                flush=True,
            )
    result = {
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs",
        "device": str(jax.devices()[0]),
        "stepping": rows,
    }
    if not args.no_drift:
        result["qpos_drift"] = [
            qpos_drift("brax", "gymnasium-v5"),
            qpos_drift("gymnasium-v5", "gymnasium-v5-mujoco-solver"),
        ]
        for drift in result["qpos_drift"]:
            print("qpos drift:", json.dumps(drift), flush=True)
    with open(args.out, "w") as f:
        json.dump(result, f, indent=2)


if __name__ == "__main__":
    main()
