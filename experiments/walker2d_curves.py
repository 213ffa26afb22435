"""Learning curves of the Walker2d `[1, 0]` end: forward return against env steps, several
seeds, for each named configuration (by default the practical preset against the paper's).

Each configuration is one sweep (its seeds vmapped as copies of the preference; copy `i`
trains with key `fold_in(key(seed), i)`) written to `OUT/<config>/`. Then this script
writes `OUT/curves.png` (training forward return, smoothed over ~500 env steps as the
paper, mean over seeds with the min-max band, one line per configuration) and
`OUT/curves.json` (per configuration: the evaluated forward return, speed and episode
length of each seed's deterministic policy, and the smoothed mean curve).

    python experiments/walker2d_curves.py --physics gymnasium-v5 --engine mujoco --chunks 10 \
        --out experiments/results/walker2d_curves_v5_e5x16_w128
    python experiments/walker2d_curves.py --configs practical paper --seeds 3 --scale 1.0

For `p = [1, 0]` the practical preset's estimated utopia point does not couple the seeds:
the scalarized advantage is `lambda_0 sigma_0 A_0`, normalised per minibatch, whatever `z`.
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
from matplotlib.ticker import EngFormatter  # noqa: E402

from wcac_jax import plot  # noqa: E402
from wcac_jax.sweep import SweepConfig  # noqa: E402
from wcac_jax.sweep.outputs import write_atomic  # noqa: E402

PREF = (1.0, 0.0)


def write_figure(out: str, result: dict) -> None:
    fig, ax = plot.plt.subplots(figsize=(7, 4.2))
    for name, run in result["configs"].items():
        steps = np.asarray(run["env_steps"])
        curves = np.asarray(run["smoothed_forward_return"])  # [seeds, T]
        (line,) = ax.plot(steps, curves.mean(0), label=f"{name} ({len(curves)} seeds)")
        ax.fill_between(steps, curves.min(0), curves.max(0), color=line.get_color(), alpha=0.2)
    ax.set_xlabel("environment steps")
    ax.set_ylabel("training forward return (smoothed over ~500 steps)")
    ax.xaxis.set_major_formatter(EngFormatter())
    ax.set_title(f"Walker2d p = {list(PREF)}, {result['physics']} physics")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(out, "curves.png"), dpi=110)
    plot.plt.close(fig)


def _speed(policy: dict) -> float:
    """Mean forward speed (m/s); where the evaluation leaves the number of falls open,
    the middle of its range (`common.policy_summary`; the ends differ by < 1/length)."""
    if policy["mean_speed_m_per_s"] is not None:
        return policy["mean_speed_m_per_s"]
    return float(np.mean(policy["mean_speed_m_per_s_range"]))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    common.add_run_args(p, out="runs/walker2d_curves")
    p.add_argument("--configs", nargs="+", default=["practical", "paper"])
    p.add_argument("--seeds", type=int, default=3, help="seeds per configuration (vmapped)")
    args = p.parse_args(argv)
    if args.plot_only:
        with open(os.path.join(args.out, "curves.json")) as f:
            write_figure(args.out, json.load(f))
        print(f"redrew {os.path.join(args.out, 'curves.png')}")
        return 0
    if args.seeds < 1:
        common.fail(f"--seeds must be >= 1, got {args.seeds}")
    bases = {name: common.train_config(name, num_envs=args.envs_per_pref) for name in args.configs}
    steps = common.steps_per_pref(args.scale, args.steps_per_pref)
    out = common.make_out(args.out, args.resume, args.overwrite)

    result = {
        "pref": list(PREF),
        "seeds": args.seeds,
        "steps_per_pref": steps,
        "physics": args.physics,
        "engine": args.engine,
        "machine": common.machine(),
        "resumed": args.resume,
        "configs": {},
    }
    for name, base in bases.items():
        config = SweepConfig(
            prefs=(PREF,) * args.seeds,
            env="walker2d",
            env_options={"physics": args.physics, "engine": args.engine},
            train=base,
            steps_per_pref=steps,
            seed=args.seed,
            eval_episodes=args.eval_episodes,
        )
        print(f"[walker2d_curves] {name}: {args.seeds} seeds x {steps:,} env steps", flush=True)
        t0 = time.perf_counter()
        front = common.sweep(config, os.path.join(out, name), args.chunks, args.resume)
        wall = time.perf_counter() - t0
        with np.load(os.path.join(out, name, "curves.npz")) as curves:
            forward = curves["train/episode_return"][..., 0]  # [seeds, T]
            env_steps = curves["train/env_steps"][0]
        window = common.smoothing_window(base.env_steps_per_iteration)
        smoothed = np.stack([plot.moving_average(y, window) for y in forward])
        episode_length, episodes = common.evaluation_setup(front)
        policies = [common.policy_summary(row, episode_length, episodes) for row in front["prefs"]]
        speeds = [_speed(pol) for pol in policies]
        result["configs"][name] = {
            "config": front["config"]["train"],
            "policies": policies,
            "eval_speed_mean": float(np.mean(speeds)),
            "eval_length_mean": float(np.mean([pol["episode_length"] for pol in policies])),
            "env_steps": env_steps[len(env_steps) - smoothed.shape[1] :].tolist(),
            "smoothed_forward_return": smoothed.tolist(),
            "env_steps_per_s": front["env_steps_per_s"],
            "wall_s": wall,
        }
        for pol, speed in zip(policies, speeds, strict=True):
            print(
                f"  forward return {pol['forward_return']:8.1f}, length "
                f"{pol['episode_length']:5.1f}, speed {speed:+.3f} m/s"
            )
    # atomic: an interrupted write leaves the file as it was
    write_atomic(os.path.join(out, "curves.json"), json.dumps(result, indent=2).encode())
    write_figure(out, result)
    common.finish_out(out, args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
