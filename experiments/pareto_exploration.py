"""Does varying the preference reach the whole front? Each actor direction on a problem
whose exact Pareto front is known.

For each direction (`smooth_wc`, `wc`, `linear`, `mgda`), trains `--n-prefs` evenly spaced
preferences (the three scalarizations together in ONE `jit(vmap(train))` over preferences
x directions, MGDA in its own) and reports: the number of distinct front points
reached (more than `--distinct` apart), each point's distance to the exact front, the
hypervolume relative to the exact front's, and how evenly the points cover the front (the
largest gap between neighbouring points, measured by the angle theta that produces them,
counting the two ends 0 and pi/2). Writes `exploration.json` and `exploration.png`.

    python experiments/pareto_exploration.py --out experiments/results/exploration
    python experiments/pareto_exploration.py --quick --out /tmp/exploration

Problems so far: `concave_bandit` (non-convex front).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

import jax
import jax.numpy as jnp
import numpy as np

from wcac_jax import envs, pareto
from wcac_jax.config import TrainConfig
from wcac_jax.envs import concave_bandit as cb
from wcac_jax.train import TRACED_DIRECTIONS, make_trainer

DIRECTIONS = ("smooth_wc", "wc", "linear", "mgda")
# The bandit's settings (as in the tests): a fixed small policy noise, because with a
# learned std the expected-return front of stochastic policies is the convex hull.
BANDIT = TrainConfig(
    num_envs=32,
    critic_steps=2,
    rollout_steps=4,
    num_iterations=600,
    mu=0.002,
    network="mlp",
    width=32,
    depth=1,
    actor_lr=0.1,
    critic_lr=0.1,
    actor_optimizer="normalized_harmonic",
    log_std_init=math.log(0.05),
    learn_log_std=False,
    normalize_obs=False,
)


def count_distinct(points: np.ndarray, min_dist: float) -> int:
    """Greedy count of points more than `min_dist` apart (Euclidean)."""
    kept: list[np.ndarray] = []
    for p in points:
        if all(np.linalg.norm(p - q) > min_dist for q in kept):
            kept.append(p)
    return len(kept)


def distance_to_curve(points: np.ndarray, curve: np.ndarray) -> np.ndarray:
    """Distance of each point `[n, m]` to a densely sampled curve `[k, m]`."""
    return np.min(np.linalg.norm(points[:, None] - curve[None], axis=-1), axis=1)


def bandit_directions(directions, prefs: np.ndarray, iterations: int, seed: int) -> dict:
    """Trains every (direction, preference) pair; the scalarizations share ONE compiled
    program (a traced direction index, vmapped with the preferences); MGDA, which needs
    per-objective gradients, is its own program. Preference `i` uses the same key under
    every direction."""
    env = envs.make("concave_bandit")
    keys = jax.random.split(jax.random.key(seed), prefs.shape[0])
    prefs_j = jnp.asarray(prefs, jnp.float32)
    out = {}
    traced = [d for d in directions if d in TRACED_DIRECTIONS]
    if traced:
        config = BANDIT.replace(num_iterations=iterations)
        trainer = make_trainer(config, env)
        index = jnp.asarray([TRACED_DIRECTIONS.index(d) for d in traced])
        n_p, n_d = prefs.shape[0], len(traced)

        def train(key, pref, direction):
            return trainer.run(trainer.init(key, pref), pref, iterations, direction)

        states, metrics = jax.jit(jax.vmap(train))(
            jnp.tile(keys, n_d), jnp.tile(prefs_j, (n_d, 1)), jnp.repeat(index, n_p)
        )
        action = jax.vmap(lambda s: trainer.mean_action(s, jnp.ones((1,))))(states)[:, 0]
        for k, direction in enumerate(traced):
            sl = slice(k * n_p, (k + 1) * n_p)
            out[direction] = _result(action[sl], metrics["train/weights"][sl])
    if "mgda" in directions:
        config = BANDIT.replace(scalarization="mgda", num_iterations=iterations)
        trainer = make_trainer(config, env)

        def train_mgda(key, pref):
            return trainer.run(trainer.init(key, pref), pref, iterations)

        states, metrics = jax.jit(jax.vmap(train_mgda))(keys, prefs_j)
        action = jax.vmap(lambda s: trainer.mean_action(s, jnp.ones((1,))))(states)[:, 0]
        out["mgda"] = _result(action, metrics["train/weights"])
    return out


def _result(action, weights) -> dict:
    theta = np.asarray(cb.action_to_theta(action), np.float64)
    points = np.asarray(cb.reward(jnp.asarray(theta)), np.float64)
    return {"theta": theta, "points": points, "weights": np.asarray(weights)}


def summarise(theta, points, exact, exact_hv, ref, min_dist) -> dict:
    gaps = np.diff(np.sort(np.concatenate([[0.0, math.pi / 2], theta])))
    dist = distance_to_curve(points, exact)
    return {
        "distinct_points": count_distinct(points, min_dist),
        "max_distance_to_front": float(dist.max()),
        "hypervolume": pareto.hypervolume(points, ref),
        "hypervolume_ratio": pareto.hypervolume(points, ref) / exact_hv,
        "largest_theta_gap": float(gaps.max()),
        "theta": theta.tolist(),
        "points": points.tolist(),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-prefs", type=int, default=11)
    parser.add_argument("--directions", nargs="+", default=list(DIRECTIONS), choices=DIRECTIONS)
    parser.add_argument("--iterations", type=int, default=BANDIT.num_iterations)
    parser.add_argument("--distinct", type=float, default=0.02, help="distinctness radius")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true", help="a tiny run for tests")
    parser.add_argument("--out", default="exploration")
    args = parser.parse_args(argv)
    if args.quick:
        args.n_prefs, args.iterations = 3, 5

    prefs = pareto.simplex_lattice(2, args.n_prefs)
    exact = cb.exact_front(2001)
    ref = np.zeros(2)
    exact_hv = pareto.hypervolume(exact, ref)
    targets = np.asarray(jax.vmap(cb.wc_optimum, (0, None))(prefs, cb.DEFAULT_J_UB))
    result = {
        "problem": "concave_bandit",
        "prefs": prefs.tolist(),
        "j_ub": list(cb.DEFAULT_J_UB),
        "hv_ref": ref.tolist(),
        "exact_front_hypervolume": exact_hv,
        "wc_optimum_theta": targets.tolist(),
        "config": BANDIT.replace(num_iterations=args.iterations).to_dict(),
        "directions": {},
    }
    runs = bandit_directions(args.directions, prefs, args.iterations, args.seed)
    for direction in args.directions:
        run = runs[direction]
        summary = summarise(run["theta"], run["points"], exact, exact_hv, ref, args.distinct)
        result["directions"][direction] = summary
        print(
            f"{direction:>10}: {summary['distinct_points']:>2} distinct points, "
            f"HV {summary['hypervolume_ratio']:.3f} of the exact front's, largest theta gap "
            f"{summary['largest_theta_gap']:.3f} rad, max distance to front "
            f"{summary['max_distance_to_front']:.2e}",
            flush=True,
        )

    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "exploration.json"), "w") as f:
        json.dump(result, f, indent=2)
    _figure(result, exact, os.path.join(args.out, "exploration.png"))
    return 0


def _figure(result, exact, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(result["directions"])
    fig, axes = plt.subplots(1, len(names), figsize=(3.6 * len(names), 3.6), squeeze=False)
    prefs = np.asarray(result["prefs"])
    for ax, name in zip(axes[0], names, strict=True):
        pts = np.asarray(result["directions"][name]["points"])
        ax.plot(exact[:, 0], exact[:, 1], "k--", lw=1, label="exact front")
        sc = ax.scatter(
            pts[:, 0],
            pts[:, 1],
            c=prefs[:, 0],
            cmap="viridis",
            vmin=0,
            vmax=1,
            s=50,
            zorder=3,
            edgecolors="k",
            linewidths=0.5,
        )
        s = result["directions"][name]
        ax.set_title(
            f"{name}: {s['distinct_points']} points, HV {s['hypervolume_ratio']:.2f}", fontsize=9
        )
        ax.set_xlabel("1 - sin(theta)")
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("1 - cos(theta)")
    axes[0, 0].legend(fontsize=7, loc="upper right")
    fig.colorbar(sc, ax=axes[0, -1], label="preference p[0]")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
