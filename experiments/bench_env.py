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


def qpos_drift(steps: int = 100, seed: int = 0) -> dict:
    """Max |qpos_brax - qpos_v5| after each step, same start state and actions.

    Both start from the v5 convention's `qpos` (torso height as the world height); the
    Brax model's `rootz` is shifted by its offset so both describe the same pose.
    """
    models = {p: envs.make("walker2d", physics=p) for p in ("brax", "gymnasium-v5")}
    key_q, key_a = jax.random.split(jax.random.key(seed))
    start = models["brax"].reset(key_q)
    actions = jax.random.uniform(key_a, (steps, 6), minval=-1.0, maxval=1.0)
    traj = {}
    for name, env in models.items():
        q0 = start.pipeline_state.q.at[1].add(models["brax"]._z_offset - env._z_offset)
        ps = env.pipeline_init(q0, start.pipeline_state.qd)
        state = start.replace(pipeline_state=ps)

        @jax.jit
        def run(state, env=env):
            def body(s, a):
                s = env.step(s, a)
                return s, env._qpos(s.pipeline_state)

            return jax.lax.scan(body, state, actions)[1]

        traj[name] = np.asarray(run(state))
    diff = np.abs(traj["brax"] - traj["gymnasium-v5"]).max(axis=1)
    return {
        "steps": steps,
        "max_abs_qpos_diff_at": {str(k): float(diff[k - 1]) for k in (1, 10, 50, steps)},
        "torso_x_brax": float(traj["brax"][-1, 0]),
        "torso_x_v5": float(traj["gymnasium-v5"][-1, 0]),
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batches", type=int, nargs="+", default=[1, 16, 144, 1024])
    parser.add_argument(
        "--steps",
        type=int,
        default=100,
        help="steps per timed rollout (capped so that one rollout is ~10k env steps)",
    )
    parser.add_argument(
        "--physics",
        nargs="+",
        default=["brax", "gymnasium-v5", "gymnasium-v5-fast"],
        help="gymnasium-v5-fast = v5 with solver_iterations=4, ls_iterations=4",
    )
    parser.add_argument("--no-drift", action="store_true", help="skip the qpos drift")
    parser.add_argument("--out", default="bench_env.json")
    args = parser.parse_args(argv)

    rows = []
    for physics in args.physics:
        kwargs = {"physics": physics}
        if physics == "gymnasium-v5-fast":
            kwargs = {"physics": "gymnasium-v5", "solver_iterations": 4, "ls_iterations": 4}
        env = envs.make("walker2d", **kwargs)
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
        result["qpos_drift"] = qpos_drift()
        print("qpos drift brax vs gymnasium-v5:", json.dumps(result["qpos_drift"]))
    with open(args.out, "w") as f:
        json.dump(result, f, indent=2)


if __name__ == "__main__":
    main()
