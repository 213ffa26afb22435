"""The paper's Walker2d Pareto front (its Fig. 3): nine preferences, one sweep per actor
direction (`smooth_wc`, the method, and `linear`, the baseline) at the same budget.

Each direction is one `run_sweep` (all nine preferences in one compiled program) and
writes the sweep's own outputs to `OUT/<direction>/`. Then this script writes
`OUT/front.png` (both fronts overlaid, with the hypervolume of each),
`OUT/curves.png` (per-objective training returns of `smooth_wc` against env steps) and
`OUT/summary.json`: per direction and preference the evaluated returns, episode length,
mean forward speed (m/s) and control energy per step; the hypervolume; the rank
correlation between `p[0]` and the forward return (does the front keep the preferences'
order?); wall and compile seconds; the machine.

    python experiments/walker2d_front.py                       # paper scale: 1M steps/pref
    python experiments/walker2d_front.py --scale 0.2 --out experiments/results/walker2d_front
    python experiments/walker2d_front.py --config mlp-adam     # a named departure
    python experiments/walker2d_front.py --config practical --out runs/walker2d_practical

`--scale` multiplies the paper's 1,000,000 env steps per preference. See
`walker2d_common.py` for the named configurations.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import walker2d_common as common  # noqa: E402

from wcac_jax import plot  # noqa: E402
from wcac_jax.sweep import PAPER_PREFS, SweepConfig  # noqa: E402


def write_figures(out: str, summary: dict) -> None:
    """`front.png` and `curves.png` from the sweeps saved in `out/<direction>/`."""
    directions = list(summary["directions"])
    runs = [os.path.join(out, d) for d in directions]
    fig = plot.plot_front(runs, labels=directions)
    fig.axes[0].set_title(
        f"Walker2d front, config '{summary['config_name']}', "
        f"{summary['steps_per_pref']:,} env steps per preference"
    )
    fig.savefig(os.path.join(out, "front.png"), dpi=120)
    plot.plt.close(fig)
    fig = plot.plot_curves(runs[0], smooth=summary["smoothing_iterations"])
    fig.suptitle(f"{directions[0]}: training episode returns (smoothed over ~500 steps)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "curves.png"), dpi=110)
    plot.plt.close(fig)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    common.add_run_args(p, out="runs/walker2d_front")
    p.add_argument("--directions", nargs="+", default=["smooth_wc", "linear"])
    p.add_argument("--width", type=int, default=None, help="(default: the config's)")
    p.add_argument("--depth", type=int, default=None, help="(default: the config's)")
    args = p.parse_args(argv)
    if args.plot_only:
        with open(os.path.join(args.out, "summary.json")) as f:
            summary = json.load(f)
        curves = os.path.join(args.out, next(iter(summary["directions"])), "curves.npz")
        if not os.path.isfile(curves):
            common.fail(f"{curves!r} is missing (committed results omit the curves; rerun)")
        write_figures(args.out, summary)
        print(f"redrew the figures in {args.out}")
        return 0

    base = common.train_config(
        args.config, num_envs=args.envs_per_pref, width=args.width, depth=args.depth
    )
    steps = common.steps_per_pref(args.scale, args.steps_per_pref)
    common.make_out(args.out, args.resume)

    summary = {
        "config_name": args.config,
        "scale": steps / common.PAPER_STEPS_PER_PREF,
        "steps_per_pref": steps,
        "physics": args.physics,
        "smoothing_iterations": common.smoothing_window(base.env_steps_per_iteration),
        "machine": common.machine(),
        # a resumed run's wall_s counts this process only (0 for sweeps read back)
        "resumed": args.resume,
        "directions": {},
    }
    for direction in args.directions:
        config = SweepConfig(
            prefs=PAPER_PREFS,
            env="walker2d",
            env_options={"physics": args.physics},
            train=base.replace(scalarization=direction),
            steps_per_pref=steps,
            seed=args.seed,
            eval_episodes=args.eval_episodes,
        )
        run_dir = os.path.join(args.out, direction)
        print(f"[walker2d_front] {direction}: 9 preferences x {steps:,} env steps", flush=True)
        t0 = time.perf_counter()
        front = common.sweep(config, run_dir, args.chunks, args.resume)
        wall = time.perf_counter() - t0
        policies = [common.policy_summary(row) for row in front["prefs"]]
        forward = [pol["forward_return"] for pol in policies]
        summary["directions"][direction] = {
            "hypervolume": front["hypervolume"],
            "hv_ref": front["hv_ref"],
            "cardinality": front["cardinality"],
            "distinct_points": int(len(np.unique(np.round(forward, 3)))),
            "pref0_forward_rank_correlation": common.rank_correlation(
                [pol["pref"][0] for pol in policies], forward
            ),
            "policies": policies,
            "lambda": [row["lambda"] for row in front["prefs"]],
            "env_steps_per_s": front["env_steps_per_s"],
            "compile_s": front["compile_s"],
            "wall_s": wall,
        }
        print(f"[walker2d_front] {direction}: HV {front['hypervolume']:.4g}, {wall:.0f} s")
        for pol in policies:
            print(
                f"  p={pol['pref']}: returns ({pol['forward_return']:8.1f}, "
                f"{pol['control_return']:8.1f}), length {pol['episode_length']:5.1f}, "
                f"speed {pol['mean_speed_m_per_s']:+.3f} m/s, "
                f"control {pol['mean_control_per_step']:.3f}/step"
            )

    write_figures(args.out, summary)
    with open(os.path.join(args.out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
