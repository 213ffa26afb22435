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
    python experiments/walker2d_front.py --config paper --physics gymnasium-v5 --engine mujoco \
        --chunks 50 --out experiments/results/walker2d_front_paper_v5
    python experiments/walker2d_front.py --config mlp-adam     # a named departure
    python experiments/walker2d_front.py --config practical --out runs/walker2d_practical
    python experiments/walker2d_front.py --config practical --anneal-lr --out runs/annealed
    python experiments/walker2d_front.py --config practical --select-last 1 \
        --out runs/final    # report the final policies instead

With `--config practical`, each preference reports its best of its last 5 policies,
20,480 env steps apart, as the sweep CLI's Walker2d default does (`wcac_jax.sweep.selection`;
the final policy when `--scale` leaves no room for them); `--select-last 1` reports
the final policies, as the committed `walker2d_front_practical_*` results without
`select5` in their name did (experiments/README.md: the command behind each result).

`--scale` multiplies the paper's 1,000,000 env steps per preference. See
`walker2d_common.py` for the named configurations; the sweep CLI's training flags
(`python -m wcac_jax.sweep --help`) change one, and `summary.json` records what they
changed (`config_changes`).
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

from wcac_jax import pareto, plot, presets  # noqa: E402
from wcac_jax.sweep import PAPER_PREFS, SweepError, cli  # noqa: E402
from wcac_jax.sweep.outputs import write_atomic  # noqa: E402

HV_REF_RULE = (
    "hypervolume of the undiscounted evaluated returns; reference point per objective a "
    "floor per step times the time limit T: -6 on control (its least reward), -1 on "
    "forward (no physical floor; walking backwards at 2 m/s all episode), so (-T, -6T); "
    "hypervolume_by_ref shows other reference points and the policies outside each box"
)


def write_figures(out: str, summary: dict) -> None:
    """`front.png` and, when the curves were kept, `curves.png` from the sweeps saved in
    `out/<direction>/`."""
    directions = list(summary["directions"])
    runs = [os.path.join(out, d) for d in directions]
    fig = plot.plot_front(runs, labels=directions)
    fig.axes[0].set_title(
        f"Walker2d front, config '{summary['config_name']}', "
        f"{summary['steps_per_pref']:,} env steps per preference"
    )
    fig.savefig(os.path.join(out, "front.png"), dpi=120)
    plot.plt.close(fig)
    if not os.path.isfile(os.path.join(runs[0], "curves.npz")):
        return
    fig = plot.plot_curves(runs[0], smooth=summary["smoothing_iterations"])
    fig.suptitle(f"{directions[0]}: training episode returns (smoothed over ~500 steps)")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "curves.png"), dpi=110)
    plot.plt.close(fig)


def direction_summary(front: dict) -> dict:
    """What `summary.json` records of one direction's sweep (its `front.json`)."""
    episode_length, episodes = common.evaluation_setup(front)
    policies = [common.policy_summary(row, episode_length, episodes) for row in front["prefs"]]
    forward = [pol["forward_return"] for pol in policies]
    points = np.array([row["return"] for row in front["prefs"]])
    return {
        "hypervolume": front["hypervolume"],
        "hv_ref": front["hv_ref"],
        "outside_hv_ref": front["outside_hv_ref"],
        "hypervolume_by_ref": common.hypervolume_table(points, common.hv_refs(front)),
        "cardinality": front["cardinality"],
        "distinct_points": int(len(np.unique(np.round(forward, 3)))),
        "pref0_forward_rank_correlation": pareto.rank_correlation(
            [pol["pref"][0] for pol in policies], forward
        ),
        "policies": policies,
        "lambda": [row["lambda"] for row in front["prefs"]],
        "env_steps_per_s": front["env_steps_per_s"],
        "compile_s": front["compile_s"],
        # with --select-last > 1: the iteration of each reported policy, the candidates'
        # evaluated returns and the env steps their evaluation took (`wcac_jax.sweep.selection`)
        **({"selection": front["selection"]} if "selection" in front else {}),
    }


def union_nondominated(summary: dict) -> dict:
    """Per direction, how many of its policies are non-dominated in the union of all
    directions' policies."""
    points, owner = [], []
    for direction, res in summary["directions"].items():
        for pol in res["policies"]:
            points.append([pol["forward_return"], pol["control_return"]])
            owner.append(direction)
    nd = pareto.nondominated(np.array(points))
    return {
        d: int(sum(f for f, o in zip(nd, owner, strict=True) if o == d))
        for d in summary["directions"]
    }


def finish(out: str, summary: dict) -> None:
    """Adds the cross-direction comparison, writes `summary.json` and the figures."""
    summary["hv_ref_rule"] = HV_REF_RULE
    summary["union_nondominated"] = union_nondominated(summary)
    write_figures(out, summary)
    # atomic: an interrupted write leaves the file as it was
    write_atomic(os.path.join(out, "summary.json"), json.dumps(summary, indent=2).encode())


def resummarize(out: str) -> None:
    """Recomputes every metric of a finished `out` from the returns its sweeps saved:
    each `front.json`'s hypervolume fields (the environment's default reference point)
    and `summary.json` (timings kept); redraws the figures."""
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    for direction, old in summary["directions"].items():
        path = os.path.join(out, direction, "front.json")
        with open(path) as f:
            front = common.rescore_front(json.load(f))
        with open(path, "w") as f:
            f.write(json.dumps(front, indent=2) + "\n")  # as run_sweep writes it
        summary["directions"][direction] = {**direction_summary(front), "wall_s": old["wall_s"]}
    finish(out, summary)


def config_changes(named, config) -> dict:
    """`{field: value}` of `config` where it differs from `named` (JSON-friendly)."""
    before, after = named.to_dict(), config.to_dict()
    return {k: v for k, v in after.items() if before[k] != v}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    common.add_run_args(p, out="runs/walker2d_front")
    p.add_argument("--directions", nargs="+", default=["smooth_wc", "linear"])
    # the sweep CLI's training-config flags (--width, --depth, --j-ub, --utopia-margin,
    # --learning-rate, ...): each changes the named --config (recorded in summary.json)
    cli.add_config_flags(p, skip=("envs_per_pref", "scalarization"))
    cli.add_selection_flags(p)  # wcac_jax.sweep.selection
    p.add_argument(
        "--resummarize",
        action="store_true",
        help="recompute the metrics of a finished --out from its saved returns, no training",
    )
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
    if args.resummarize:
        if not os.path.isfile(os.path.join(args.out, "summary.json")):
            common.fail(f"--resummarize: no summary.json in --out {args.out!r}")
        resummarize(args.out)
        print(f"recomputed the metrics in {args.out}")
        return 0

    base = common.config_with_flags(args.config, args, num_envs=args.envs_per_pref)
    steps = common.steps_per_pref(args.scale, args.steps_per_pref)
    # --config practical (Walker2d's default configuration): the sweep CLI's choice of
    # each preference's reported policy among its last ones, unless a flag sets it; the
    # other configurations report the final policies
    selection = presets.env_defaults("walker2d").selection_for(args.config)
    configs = {}  # every direction's, validated before anything is written
    for direction in args.directions:
        config = common.sweep_config(
            prefs=PAPER_PREFS,
            env="walker2d",
            env_options={"physics": args.physics, "engine": args.engine},
            train=base.replace(scalarization=direction),
            steps_per_pref=steps,
            seed=args.seed,
            eval_episodes=args.eval_episodes,
        )
        try:
            configs[direction], note = cli.apply_selection_flags(args, config, selection)
        except SweepError as err:
            common.fail(err)
    if note is not None:
        print(f"[walker2d_front] note: {note}", flush=True)
    out = common.make_out(args.out, args.resume, args.overwrite)

    summary = {
        "config_name": args.config,
        # the fields the flags changed from the named config (the full config is in each
        # direction's config.json)
        "config_changes": config_changes(common.CONFIGS[args.config], base),
        "scale": steps / common.PAPER_STEPS_PER_PREF,
        "steps_per_pref": steps,
        "physics": args.physics,
        "engine": args.engine,
        "smoothing_iterations": common.smoothing_window(base.env_steps_per_iteration),
        "machine": common.machine(),
        # a resumed run's wall_s counts this process only (0 for sweeps read back)
        "resumed": args.resume,
        "directions": {},
    }
    for direction, config in configs.items():
        run_dir = os.path.join(out, direction)
        print(f"[walker2d_front] {direction}: 9 preferences x {steps:,} env steps", flush=True)
        t0 = time.perf_counter()
        front = common.sweep(config, run_dir, args.chunks, args.resume)
        wall = time.perf_counter() - t0
        res = {**direction_summary(front), "wall_s": wall}
        summary["directions"][direction] = res
        outside = [front["prefs"][i]["pref"] for i in front["outside_hv_ref"]]
        print(
            f"[walker2d_front] {direction}: HV {front['hypervolume']:,.0f} (ref "
            f"{front['hv_ref']}; outside the box: {outside or 'none'}), {wall:.0f} s"
        )
        for pol in res["policies"]:
            speed, ctrl = pol["mean_speed_m_per_s"], pol["mean_control_per_step"]
            print(
                f"  p={pol['pref']}: returns ({pol['forward_return']:8.1f}, "
                f"{pol['control_return']:8.1f}), length {pol['episode_length']:5.1f}, "
                + (
                    "speed, control per step: falls unknown"
                    if speed is None
                    else f"speed {speed:+.3f} m/s, control {ctrl:.3f}/step"
                )
            )

    finish(out, summary)
    common.finish_out(out, args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
