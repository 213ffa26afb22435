"""The paper's depth/width ablation on Walker2d (its Fig. 4): preference `[0.9, 0.1]`,
depth `D in {1, 2, 4}` at width 256 and width `w in {64, 128, 256}` at depth 2.

Each network size is its own compiled program (shapes differ); inside it the seeds are
vmapped, as a sweep over `--seeds` copies of the preference (copy `i` trains with key
`fold_in(key(seed), i)`). Each size writes its sweep outputs to `OUT/D<d>_w<w>/`. Then
this script writes `OUT/ablation.json` (per size: the evaluated forward and control
returns of the mean policy per seed, their mean and standard deviation, the final
training forward return, and the smoothed forward-return curve averaged over seeds),
`OUT/ablation.png` (forward-return learning curves, smoothed over 500 env steps as the
paper, mean over seeds with the min-max band; one panel for depth, one for width) and
prints the table.

    python experiments/walker2d_ablation.py                    # paper scale: 1M steps
    python experiments/walker2d_ablation.py --config paper --physics gymnasium-v5 --engine mujoco \
        --scale 0.1 --chunks 5 --out experiments/results/walker2d_ablation_paper_v5_10pct
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

PREF = (0.9, 0.1)


def grid(depths, widths, fixed_width, fixed_depth) -> list[tuple[int, int]]:
    """`(depth, width)` of every program: the depth sweep at `fixed_width`, then the
    width sweep at `fixed_depth`, without repeating the size they share."""
    sizes = [(d, fixed_width) for d in depths] + [(fixed_depth, w) for w in widths]
    return list(dict.fromkeys(sizes))


def write_figure(out: str, result: dict, fixed_width: int, fixed_depth: int) -> None:
    """`ablation.png`: forward-return curves, mean over seeds with the min-max band; one
    panel for the depth sweep (at `fixed_width`), one for the width sweep."""
    fig, axes = plot.plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, key in zip(axes, ("depth", "width"), strict=True):
        other, fixed = ("width", fixed_width) if key == "depth" else ("depth", fixed_depth)
        sizes = sorted((s for s in result["sizes"] if s[other] == fixed), key=lambda s: s[key])
        for i, s in enumerate(sizes):
            x = np.asarray(s["curve_steps"])
            ax.plot(x, s["curve_forward_mean"], color=f"C{i}", label=f"{key} {s[key]}")
            ax.fill_between(
                x, s["curve_forward_min"], s["curve_forward_max"], color=f"C{i}", alpha=0.2
            )
        ax.set_title(f"{key} ({other} {fixed}), p = {result['pref']}, {result['seeds']} seeds")
        ax.set_xlabel("environment steps")
        ax.xaxis.set_major_formatter(EngFormatter())
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set_ylabel("training forward return (smoothed over 500 steps)")
    fig.suptitle(f"Walker2d depth/width ablation, config '{result['config_name']}'")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "ablation.png"), dpi=110)
    plot.plt.close(fig)


def evaluation_summary(front: dict) -> dict:
    """What `ablation.json` records of a size's evaluated policies (its `front.json`)."""
    episode_length, episodes = common.evaluation_setup(front)
    policies = [common.policy_summary(row, episode_length, episodes) for row in front["prefs"]]
    eval_fwd = np.array([pol["forward_return"] for pol in policies])
    return {
        "eval_forward_return": eval_fwd.tolist(),
        "eval_forward_mean": float(eval_fwd.mean()),
        "eval_forward_std": float(eval_fwd.std(ddof=1)) if len(eval_fwd) > 1 else 0.0,
        "eval_control_return": [pol["control_return"] for pol in policies],
        "eval_episode_length": [pol["episode_length"] for pol in policies],
        "eval_falls_per_episode": [pol["falls_per_episode"] for pol in policies],
        "eval_speed_m_per_s": [pol["mean_speed_m_per_s"] for pol in policies],
        "eval_control_per_step": [pol["mean_control_per_step"] for pol in policies],
    }


def resummarize(out: str) -> None:
    """Recomputes the evaluation fields of a finished `out`'s `ablation.json` from the
    returns its sweeps saved (curves and timings kept)."""
    path = os.path.join(out, "ablation.json")
    with open(path) as f:
        result = json.load(f)
    for size in result["sizes"]:
        with open(os.path.join(out, size["name"], "front.json")) as f:
            size.update(evaluation_summary(json.load(f)))
    with open(path, "w") as f:
        json.dump(result, f, indent=2)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    common.add_run_args(p, out="runs/walker2d_ablation")
    p.add_argument("--seeds", type=int, default=3, help="seeds per size (vmapped)")
    p.add_argument("--depths", type=int, nargs="+", default=[1, 2, 4])
    p.add_argument("--widths", type=int, nargs="+", default=[64, 128, 256])
    p.add_argument("--fixed-width", type=int, default=256, help="width of the depth sweep")
    p.add_argument("--fixed-depth", type=int, default=2, help="depth of the width sweep")
    p.add_argument(
        "--resummarize",
        action="store_true",
        help="recompute the evaluation fields of a finished --out from its saved returns",
    )
    args = p.parse_args(argv)
    if args.resummarize:
        if not os.path.isfile(os.path.join(args.out, "ablation.json")):
            common.fail(f"--resummarize: no ablation.json in --out {args.out!r}")
        resummarize(args.out)
        print(f"recomputed the evaluation fields in {args.out}")
        return 0
    if args.plot_only:
        with open(os.path.join(args.out, "ablation.json")) as f:
            result = json.load(f)
        write_figure(args.out, result, result["fixed_width"], result["fixed_depth"])
        print(f"redrew {os.path.join(args.out, 'ablation.png')}")
        return 0

    if args.seeds < 1:
        common.fail(f"--seeds must be >= 1, got {args.seeds}")
    base = common.train_config(args.config, num_envs=args.envs_per_pref)
    steps = common.steps_per_pref(args.scale, args.steps_per_pref)
    out = common.make_out(args.out, args.resume, args.overwrite)
    window = common.smoothing_window(base.env_steps_per_iteration)

    result = {
        "config_name": args.config,
        "pref": list(PREF),
        "seeds": args.seeds,
        "scale": steps / common.PAPER_STEPS_PER_PREF,
        "steps_per_pref": steps,
        "physics": args.physics,
        "engine": args.engine,
        "smoothing_iterations": window,
        "fixed_width": args.fixed_width,
        "fixed_depth": args.fixed_depth,
        "machine": common.machine(),
        # a resumed run's wall_s counts this process only (0 for sweeps read back)
        "resumed": args.resume,
        "sizes": [],
    }
    for depth, width in grid(args.depths, args.widths, args.fixed_width, args.fixed_depth):
        name = f"D{depth}_w{width}"
        config = SweepConfig(
            prefs=(PREF,) * args.seeds,
            env="walker2d",
            env_options={"physics": args.physics, "engine": args.engine},
            train=base.replace(depth=depth, width=width),
            steps_per_pref=steps,
            seed=args.seed,
            eval_episodes=args.eval_episodes,
        )
        print(f"[walker2d_ablation] {name}: {args.seeds} seeds x {steps:,} env steps", flush=True)
        t0 = time.perf_counter()
        front = common.sweep(config, os.path.join(out, name), args.chunks, args.resume)
        wall = time.perf_counter() - t0
        curves = np.load(os.path.join(out, name, "curves.npz"))
        fwd = curves["train/episode_return"][..., 0]  # [seeds, T]
        smoothed = np.stack([plot.moving_average(y, window) for y in fwd])
        tail = max(1, fwd.shape[1] // 20)  # the last 5% of iterations
        result["sizes"].append(
            {
                "name": name,
                "depth": depth,
                "width": width,
                **evaluation_summary(front),
                "train_forward_final": fwd[:, -tail:].mean(axis=1).tolist(),
                "curve_steps": curves["train/env_steps"][0, -smoothed.shape[1] :].tolist(),
                "curve_forward_mean": smoothed.mean(axis=0).tolist(),
                "curve_forward_min": smoothed.min(axis=0).tolist(),
                "curve_forward_max": smoothed.max(axis=0).tolist(),
                "env_steps_per_s": front["env_steps_per_s"],
                "compile_s": front["compile_s"],
                "wall_s": wall,
            }
        )

    write_figure(out, result, args.fixed_width, args.fixed_depth)
    # atomic: an interrupted write leaves the file as it was
    write_atomic(os.path.join(out, "ablation.json"), json.dumps(result, indent=2).encode())

    print("| depth | width | eval forward return (mean ± sd) | train forward (last 5%) |")
    print("|---|---|---|---|")
    for s in result["sizes"]:
        tf = np.asarray(s["train_forward_final"])
        print(
            f"| {s['depth']} | {s['width']} | {s['eval_forward_mean']:.1f} ± "
            f"{s['eval_forward_std']:.1f} | {tf.mean():.1f} ± "
            f"{tf.std(ddof=1) if len(tf) > 1 else 0.0:.1f} |"
        )
    common.finish_out(out, args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
