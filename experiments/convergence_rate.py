"""How fast does Algorithm 1+2 close the gap `G_mu(theta_t) - G_mu(theta*)`? Measured
exactly on the tabular MOMDP.

For each setting (actor step schedule `alpha/(t+1)` or constant `alpha`, smoothing `mu`,
critic width and depth), trains the preferences in one `jit(vmap(train))`, and every
`--every` iterations evaluates the learned policy's exact objectives (linear Bellman
solve) and its exact gap to the best tabular softmax policy (`optimal_scalarized`).
Reports per preference the initial and final gap and their ratio, and the slope of a
least-squares line through `log gap` against `log t` over the second half of the run
(`-1` would be the paper's `O(1/T)`). Writes `convergence.json` and `convergence.png`.

    python experiments/convergence_rate.py --out experiments/results/convergence
    python experiments/convergence_rate.py --quick --out /tmp/convergence
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import os
import shutil
import sys

import jax
import jax.numpy as jnp
import numpy as np

from wcac_jax import envs, scalarize
from wcac_jax.algos import PaperConfig, make_trainer
from wcac_jax.sweep.outputs import out_refusal, replace_dir, staging_dir

PREFS = ((0.2, 0.8), (0.5, 0.5), (0.8, 0.2))
BASE = PaperConfig(
    num_envs=16,
    critic_steps=10,
    rollout_steps=10,
    num_iterations=1,
    gamma=0.9,
    network="mlp",
    width=32,
    depth=1,
    critic_lr=0.1,
    normalize_obs=False,
    critic_warm_start=True,  # as this study was run (the warm critics, no projection)
    projection_radius=math.inf,
)


def settings(quick: bool) -> list[dict]:
    """(name, config changes) of every setting studied."""
    out = []
    for mu in (0.1, 1.0):
        out.append(
            {
                "name": f"alpha/(t+1), mu={mu}",
                "mu": mu,
                "actor_optimizer": "normalized_harmonic",
                "actor_lr": 1.0,
            }
        )
        out.append(
            {
                "name": f"constant alpha, mu={mu}",
                "mu": mu,
                "actor_optimizer": "normalized",
                "actor_lr": 0.05,
            }
        )
    for width, depth in ((8, 1), (128, 2)):  # Remark 5: network size (actor and critics)
        out.append(
            {
                "name": f"alpha/(t+1), mu=0.1, nets w={width} D={depth}",
                "mu": 0.1,
                "actor_optimizer": "normalized_harmonic",
                "actor_lr": 1.0,
                "width": width,
                "depth": depth,
            }
        )
    return out[:2] if quick else out


def fitted_slope(t: np.ndarray, gap: np.ndarray) -> float:
    """Slope of `log gap` against `log t` over the second half of the run."""
    half = t >= t[-1] / 2
    keep = half & (gap > 0)
    if keep.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(t[keep]), np.log(gap[keep]), 1)[0])


def run_setting(env, setting: dict, prefs: np.ndarray, iterations: int, every: int, seed: int):
    changes = {k: v for k, v in setting.items() if k != "name"}
    config = BASE.replace(**changes)
    trainer = make_trainer(config, env)
    j_ub = jnp.asarray(env.default_j_ub, jnp.float32)
    prefs_j = jnp.asarray(prefs, jnp.float32)
    states = jax.jit(jax.vmap(trainer.init))(
        jax.random.split(jax.random.key(seed), len(prefs)), prefs_j
    )
    chunk = jax.jit(jax.vmap(functools.partial(trainer.run, num_iterations=every)))
    optimum = jax.jit(jax.vmap(lambda p: env.optimal_scalarized(p, j_ub, config.mu)[1]))
    g_star = np.asarray(optimum(prefs_j))
    eye = jnp.eye(env.num_states)

    @jax.jit
    @jax.vmap
    def exact_g(state, pref):
        logits = trainer.policy.apply(state.actor, eye)
        j = env.exact_objectives(jax.nn.softmax(logits, axis=-1))
        return scalarize.smooth_wc(j, pref, j_ub, config.mu)

    ts, gaps = [0], [np.asarray(exact_g(states, prefs_j)) - g_star]
    for t in range(every, iterations + 1, every):
        states, _ = chunk(states, prefs_j)
        ts.append(t)
        gaps.append(np.asarray(exact_g(states, prefs_j)) - g_star)
    t_arr, gap_arr = np.asarray(ts, np.float64), np.stack(gaps, axis=1)  # [P, n]
    per_pref = []
    for i, pref in enumerate(prefs):
        per_pref.append(
            {
                "pref": pref.tolist(),
                "g_star": float(g_star[i]),
                "initial_gap": float(gap_arr[i, 0]),
                "final_gap": float(gap_arr[i, -1]),
                "final_over_initial": float(gap_arr[i, -1] / gap_arr[i, 0]),
                "slope": fitted_slope(t_arr[1:], gap_arr[i, 1:]),
                "gap": gap_arr[i].tolist(),
            }
        )
    return {"setting": setting, "t": ts, "prefs": per_pref, "config": config.to_dict()}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=1000)
    parser.add_argument("--every", type=int, default=10, help="iterations between measurements")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true", help="a tiny run for tests")
    parser.add_argument("--out", default="runs/convergence")
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the results in a non-empty --out (refused without it); they are "
        "replaced only once the new ones are written",
    )
    args = parser.parse_args(argv)
    refusal = out_refusal(args.out, args.overwrite)  # before any work
    if refusal:
        print(f"error: {refusal}", file=sys.stderr)
        return 2
    if args.quick:
        args.iterations, args.every = 4, 2

    env = envs.make("tabular_momdp")
    prefs = np.asarray(PREFS)
    results = []
    for setting in settings(args.quick):
        res = run_setting(env, setting, prefs, args.iterations, args.every, args.seed)
        results.append(res)
        worst = max(p["final_over_initial"] for p in res["prefs"])
        slopes = ", ".join(f"{p['slope']:.2f}" for p in res["prefs"])
        print(
            f"{setting['name']:>42}: final gap <= {100 * worst:.2f}% of the initial gap; "
            f"log-log slopes {slopes}",
            flush=True,
        )
    out = {
        "env": {
            "name": "tabular_momdp",
            "num_states": env.num_states,
            "num_actions": env.num_actions,
            "num_objectives": env.num_objectives,
            "gamma": env.gamma,
            "j_ub": list(env.default_j_ub),
        },
        "iterations": args.iterations,
        "results": results,
    }
    # written beside --out, then renamed over it: an interrupted run leaves --out whole
    work = staging_dir(args.out)
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    with open(os.path.join(work, "convergence.json"), "w") as f:
        json.dump(out, f, indent=2)
    _figure(results, os.path.join(work, "convergence.png"))
    replace_dir(work, args.out)
    return 0


def _figure(results, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = min(3, len(results))
    rows = -(-len(results) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.4 * rows), squeeze=False)
    for ax, res in zip(axes.flat, results, strict=False):
        t = np.asarray(res["t"][1:], np.float64)
        for i, p in enumerate(res["prefs"]):
            gap = np.maximum(np.asarray(p["gap"][1:]), 1e-9)
            ax.loglog(t, gap, color=f"C{i}", lw=1, label=f"p={p['pref']}, slope {p['slope']:.2f}")
        ax.loglog(t, res["prefs"][0]["gap"][1] * t[0] / t, "k:", lw=0.8, label="1/t")
        ax.set_title(res["setting"]["name"], fontsize=9)
        ax.set_xlabel("iteration t")
        ax.set_ylabel("G(theta_t) - G(theta*)")
        ax.legend(fontsize=6)
        ax.grid(alpha=0.3, which="both")
    for ax in list(axes.flat)[len(results) :]:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
