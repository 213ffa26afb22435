"""Does varying the preference reach the whole front? Each actor direction on a problem
whose exact Pareto front is known.

For each direction (`smooth_wc`, `wc`, `linear`, `mgda`), trains `--n-prefs` evenly spaced
preferences (the three scalarizations together in ONE `jit(vmap(train))` over preferences
x directions, MGDA in its own) and reports: the number of distinct front points
reached, each point's distance to ITS PREFERENCE'S weighted-Chebyshev optimum (the point
the preference asks for: on the bandit every learned point is `reward(theta)` and so lies
on the front by construction, so a distance to the front would measure nothing), the
hypervolume relative to the exact front's, and how evenly the points cover the front (the
largest gap between neighbouring points, along the front). On Deep Sea Treasure the
points are expected returns of stochastic policies, which can lie inside the front, so
their distance to the front is reported too. Writes `exploration.json` and
`exploration.png`.

    python experiments/pareto_exploration.py --out experiments/results/exploration
    python experiments/pareto_exploration.py --quick --out /tmp/exploration

Problems: `concave_bandit` (non-convex front of deterministic policies, exact optima
known) and `deep_sea_treasure` (concave map; the exact front of stochastic policies is
the segment from treasure 1 to treasure 124, see `envs/deep_sea_treasure.py`).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import sys

import jax
import jax.numpy as jnp
import numpy as np

from wcac_jax import envs, pareto, presets
from wcac_jax.algos import make_trainer
from wcac_jax.core.runtime import TRACED_DIRECTIONS
from wcac_jax.envs import concave_bandit as cb
from wcac_jax.envs import deep_sea_treasure as dst_env
from wcac_jax.sweep.outputs import out_refusal, replace_dir, staging_dir

DIRECTIONS = ("smooth_wc", "wc", "linear", "mgda")
# The environments' own tuned settings (`wcac_jax.sweep.presets`, the CLI's defaults for them),
# for the iterations this study runs: the bandit with a fixed small policy noise (with a
# learned std the expected-return front of stochastic policies is the convex hull); Deep
# Sea Treasure with Adam on d and a smaller critic step.
BANDIT = presets.BANDIT.replace(num_iterations=600)
DST = presets.DEEP_SEA_TREASURE.replace(num_iterations=1500)
DST_HV_REF = (0.0, -20.0)
NEAR_FRONT = 1.0  # Deep Sea Treasure: "on the front" means within this distance of it


def dst_wc_optimum(pref: np.ndarray, front: np.ndarray, j_ub, n: int = 100001) -> np.ndarray:
    """The point of the segment `front` (`[2, 2]`) minimising `max_i p_i (z_i - J_i)`,
    by dense search along it (the objective is convex and piecewise linear in the
    position). Returns `[2]`."""
    s = np.linspace(0.0, 1.0, n)[:, None]
    points = front[0] + s * (front[-1] - front[0])
    return points[np.argmin(np.max(pref * (np.asarray(j_ub) - points), axis=1))]


def count_distinct(points: np.ndarray, min_dist: float) -> int:
    """Greedy count of points more than `min_dist` apart (Euclidean)."""
    kept: list[np.ndarray] = []
    for p in points:
        if all(np.linalg.norm(p - q) > min_dist for q in kept):
            kept.append(p)
    return len(kept)


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


def dst_directions(directions, prefs: np.ndarray, iterations: int, seed: int) -> dict:
    """As `bandit_directions`, on Deep Sea Treasure; points are the exact expected
    discounted returns of the learned stochastic policies."""
    env = envs.make("deep_sea_treasure")
    keys = jax.random.split(jax.random.key(seed), prefs.shape[0])
    prefs_j = jnp.asarray(prefs, jnp.float32)
    eye = jnp.eye(env.observation_size)
    out = {}

    def exact_points(trainer, states):
        def one(state):
            pi = jax.nn.softmax(trainer.policy.apply(state.actor, eye), axis=-1)
            return env.exact_objectives(pi, DST.gamma)

        return np.asarray(jax.jit(jax.vmap(one))(states), np.float64)

    traced = [d for d in directions if d in TRACED_DIRECTIONS]
    if traced:
        trainer = make_trainer(DST.replace(num_iterations=iterations), env)
        index = jnp.asarray([TRACED_DIRECTIONS.index(d) for d in traced])
        n_p, n_d = prefs.shape[0], len(traced)

        def train(key, pref, direction):
            return trainer.run(trainer.init(key, pref), pref, iterations, direction)

        states, _ = jax.jit(jax.vmap(train))(
            jnp.tile(keys, n_d), jnp.tile(prefs_j, (n_d, 1)), jnp.repeat(index, n_p)
        )
        points = exact_points(trainer, states)
        for k, direction in enumerate(traced):
            out[direction] = points[k * n_p : (k + 1) * n_p]
    if "mgda" in directions:
        trainer = make_trainer(DST.replace(scalarization="mgda", num_iterations=iterations), env)

        def train_mgda(key, pref):
            return trainer.run(trainer.init(key, pref), pref, iterations)

        states, _ = jax.jit(jax.vmap(train_mgda))(keys, prefs_j)
        out["mgda"] = exact_points(trainer, states)
    return out


def exact_front_hypervolume(front: np.ndarray, ref) -> float:
    """HV of the region the piecewise-linear front dominates (its edges densely sampled;
    the vertices alone would give a staircase that misses the triangles under the edges)."""
    t = np.linspace(0.0, 1.0, 20001)[:, None]
    dense = np.concatenate([a + t * (b - a) for a, b in zip(front[:-1], front[1:], strict=True)])
    return pareto.hypervolume(dense, ref)


def summarise_dst(points: np.ndarray, front: np.ndarray, targets: np.ndarray, exact_hv, min_dist):
    """Distinct points, each point's distance to the exact front and to its preference's
    weighted-Chebyshev optimum (`targets`, `[P, 2]`), HV ratio (to the exact front's
    `exact_hv`, see `exact_front_hypervolume`), and the largest gap
    between neighbouring points on the front (within `NEAR_FRONT` of it), along the
    front (fraction of its length, ends included)."""
    ref = np.asarray(DST_HV_REF)
    finite = np.all(np.isfinite(points), axis=1)
    pts = points[finite]
    seg = front[-1] - front[0]
    along = np.clip(((pts - front[0]) @ seg) / float(seg @ seg), 0.0, 1.0)
    to_front = dst_env.distance_to_front(pts, front)
    near = to_front < NEAR_FRONT
    gaps = np.diff(np.sort(np.concatenate([[0.0, 1.0], along[near]])))
    to_target = np.linalg.norm(points - targets, axis=1)
    return {
        "distinct_points": count_distinct(pts, min_dist),
        "points_near_front": int(near.sum()),
        "distance_to_front": dst_env.distance_to_front(points, front).tolist(),
        "max_distance_to_front": float(to_front.max()),
        "distance_to_wc_optimum": to_target.tolist(),
        "max_distance_to_wc_optimum": float(np.nanmax(to_target)),
        "median_distance_to_wc_optimum": float(np.nanmedian(to_target)),
        "hypervolume": pareto.hypervolume(pts, ref),
        "hypervolume_ratio": pareto.hypervolume(pts, ref) / exact_hv,
        "largest_gap_along_front": float(gaps.max()),
        "diverged": int((~finite).sum()),
        "points": points.tolist(),
    }


def _result(action, weights) -> dict:
    theta = np.asarray(cb.action_to_theta(action), np.float64)
    points = np.asarray(cb.reward(jnp.asarray(theta)), np.float64)
    return {"theta": theta, "points": points, "weights": np.asarray(weights)}


def summarise(theta, points, target_theta, exact_hv, ref, min_dist) -> dict:
    """Distinct points, each point's distance to its preference's weighted-Chebyshev
    optimum (in theta and in objective space), HV ratio, largest gap in theta."""
    gaps = np.diff(np.sort(np.concatenate([[0.0, math.pi / 2], theta])))
    theta_error = np.abs(theta - target_theta)
    target_points = np.asarray(cb.reward(jnp.asarray(target_theta)), np.float64)
    to_target = np.linalg.norm(points - target_points, axis=1)
    return {
        "distinct_points": count_distinct(points, min_dist),
        "theta_error": theta_error.tolist(),
        "max_theta_error": float(theta_error.max()),
        "median_theta_error": float(np.median(theta_error)),
        "max_distance_to_wc_optimum": float(to_target.max()),
        "hypervolume": pareto.hypervolume(points, ref),
        "hypervolume_ratio": pareto.hypervolume(points, ref) / exact_hv,
        "largest_theta_gap": float(gaps.max()),
        "theta": theta.tolist(),
        "points": points.tolist(),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--problems",
        nargs="+",
        default=["concave_bandit", "deep_sea_treasure"],
        choices=["concave_bandit", "deep_sea_treasure"],
    )
    parser.add_argument("--n-prefs", type=int, default=11)
    parser.add_argument("--directions", nargs="+", default=list(DIRECTIONS), choices=DIRECTIONS)
    parser.add_argument(
        "--iterations", type=int, default=None, help="per problem default: 600 (bandit), 1500 (DST)"
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true", help="a tiny run for tests")
    parser.add_argument("--out", default="runs/exploration")
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
        args.n_prefs, args.iterations = 3, 5

    prefs = pareto.simplex_lattice(2, args.n_prefs)
    result = {"prefs": prefs.tolist(), "problems": {}}
    if "concave_bandit" in args.problems:
        iters = args.iterations or BANDIT.num_iterations
        ref = np.zeros(2)
        exact_hv = cb.exact_front_hypervolume()  # 1 - pi/4, the exact front's, above `ref`
        targets = np.asarray(jax.vmap(cb.wc_optimum, (0, None))(prefs, cb.DEFAULT_J_UB))
        targets = targets.astype(np.float64)
        bandit = {
            "j_ub": list(cb.DEFAULT_J_UB),
            "hv_ref": ref.tolist(),
            "exact_front_hypervolume": exact_hv,
            "wc_optimum_theta": targets.tolist(),
            "config": BANDIT.replace(num_iterations=iters).to_dict(),
            "directions": {},
        }
        runs = bandit_directions(args.directions, prefs, iters, args.seed)
        for direction in args.directions:
            run = runs[direction]
            summary = summarise(run["theta"], run["points"], targets, exact_hv, ref, 0.02)
            bandit["directions"][direction] = summary
            print(
                f"concave_bandit {direction:>10}: {summary['distinct_points']:>2} distinct "
                f"points, HV {summary['hypervolume_ratio']:.3f} of the exact front's, largest "
                f"theta gap {summary['largest_theta_gap']:.3f} rad, |theta - wc optimum| "
                f"median {summary['median_theta_error']:.3f}, max "
                f"{summary['max_theta_error']:.3f} rad",
                flush=True,
            )
        result["problems"]["concave_bandit"] = bandit
    if "deep_sea_treasure" in args.problems:
        iters = args.iterations or DST.num_iterations
        front = dst_env.exact_front(DST.gamma)
        j_ub = dst_env.DeepSeaTreasure.default_j_ub
        targets = np.stack([dst_wc_optimum(p, front, j_ub) for p in prefs])
        exact_hv = exact_front_hypervolume(front, np.asarray(DST_HV_REF))
        dst = {
            "j_ub": list(dst_env.DeepSeaTreasure.default_j_ub),
            "hv_ref": list(DST_HV_REF),
            "exact_front": front.tolist(),
            "exact_front_hypervolume": exact_hv,
            "treasure_path_returns": dst_env.path_returns(DST.gamma).tolist(),
            "wc_optimum": targets.tolist(),
            "config": DST.replace(num_iterations=iters).to_dict(),
            "directions": {},
        }
        runs = dst_directions(args.directions, prefs, iters, args.seed)
        for direction in args.directions:
            summary = summarise_dst(runs[direction], front, targets, exact_hv, 1.0)
            dst["directions"][direction] = summary
            print(
                f"deep_sea_treasure {direction:>10}: {summary['distinct_points']:>2} distinct "
                f"points ({summary['points_near_front']} within 1 of the front), HV "
                f"{summary['hypervolume_ratio']:.3f} of the exact front's, largest gap along "
                f"the front {summary['largest_gap_along_front']:.2f}, distance to the wc "
                f"optimum median {summary['median_distance_to_wc_optimum']:.2f}",
                flush=True,
            )
        result["problems"]["deep_sea_treasure"] = dst

    # written beside --out, then renamed over it: an interrupted run leaves --out whole
    work = staging_dir(args.out)
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    with open(os.path.join(work, "exploration.json"), "w") as f:
        json.dump(result, f, indent=2)
    _figure(result, os.path.join(work, "exploration.png"))
    replace_dir(work, args.out)
    return 0


def _figure(result, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    problems = list(result["problems"])
    names = list(next(iter(result["problems"].values()))["directions"])
    fig, axes = plt.subplots(
        len(problems), len(names), figsize=(3.6 * len(names), 3.4 * len(problems)), squeeze=False
    )
    prefs = np.asarray(result["prefs"])
    for row, problem in enumerate(problems):
        data = result["problems"][problem]
        if problem == "concave_bandit":
            exact = cb.exact_front(400)
            labels = ("1 - sin(theta)", "1 - cos(theta)")
        else:
            exact = np.asarray(data["exact_front"])
            labels = ("treasure (discounted)", "time (discounted)")
        for ax, name in zip(axes[row], names, strict=True):
            summary = data["directions"][name]
            pts = np.asarray(summary["points"], dtype=np.float64)
            ax.plot(exact[:, 0], exact[:, 1], "k--", lw=1, label="exact front")
            if problem == "deep_sea_treasure":
                paths = np.asarray(data["treasure_path_returns"])
                ax.scatter(
                    paths[:, 0], paths[:, 1], marker="x", c="grey", s=20, label="treasure paths"
                )
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
            ax.set_title(
                f"{problem}: {name}\n{summary['distinct_points']} distinct points, "
                f"HV {summary['hypervolume_ratio']:.2f}",
                fontsize=8,
            )
            ax.set_xlabel(labels[0], fontsize=8)
            ax.grid(alpha=0.3)
        axes[row, 0].set_ylabel(labels[1], fontsize=8)
        axes[row, 0].legend(fontsize=6, loc="best")
    fig.colorbar(sc, ax=axes[:, -1].tolist(), label="preference p[0]")
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
