"""One preference-conditioned network against independent policies on Walker2d (v5
model, MuJoCo's C engine, 500-step episodes), at the same 3M env steps and at 9M.

Arms, each a command-line sweep per seed:
  (a) `conditioned`: `python -m wcac_jax.sweep --conditioned --total-steps 3000000
      --eval-prefs 33 --seed S` (one network, 3M env steps in all);
  (b) `independent_9x333k`: `python -m wcac_jax.sweep --n-prefs 9 --steps-per-pref 333334
      --seed S` (today's default update and choice of policies, 3M env steps in all);
  (c) `independent_9x1M`: today's default, `python -m wcac_jax.sweep --n-prefs 9 --seed S`,
      read from `--reuse-9x1m` (the committed `cli_default_front_select5`) when its seeds
      are there.

For every front: the hypervolume under morl-baselines' convention (the discounted
returns at gamma 0.99, reference -100 per objective, as C-MORL's protocol scores the v5
tasks; no published front of Walker2d v5 exists to set beside it), the project's own
hypervolume and expected utility (`front.json`), the non-dominated count, Spearman's rank
correlation between
`p0` and the forward return, and the forward end's speed and length and the control
end's control return. Then the cost of more front points: the seed-0 network evaluated
at 9, 33 and 101 preferences (its env steps and seconds) against P independent policies.

Writes to `--out`: each run's `front.json`, `front.csv`, `front.png`, `config.json`
under `<arm>/seedS/`, seed 0's conditioned front as `front.json` (and `front.png`) at the
top, `summary.json` and `summary.md`. Runs one training at a time; the machine's load
(`os.getloadavg`) is recorded with each.

A non-empty `--out` is refused unless `--resume` (add seeds to it, keeping the runs it
records) or `--overwrite` (the run writes beside it and replaces it when finished) is
given; every file is written atomically.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np
import walker2d_common
from mo_mujoco import MORL_BASELINES_REF  # the suite's convention: one constant
from script_io import fail, finish_out, make_out

ARMS = {
    "conditioned": ["--conditioned", "--total-steps", "3000000", "--eval-prefs", "33"],
    "independent_9x333k": ["--n-prefs", "9", "--steps-per-pref", "333334"],
    "independent_9x1M": ["--n-prefs", "9"],
}
KEPT = ("front.json", "front.csv", "front.png", "config.json")


def forward_speed(front: dict, i: int) -> float:
    """Row `i`'s mean x velocity from its forward return `R0 = sum(v_x + healthy)`, the
    healthy reward withheld on a falling step: exact where the mean length fixes the
    falls, else the middle of the range they allow (`walker2d_common.policy_summary`)."""
    summary = walker2d_common.policy_summary(
        front["prefs"][i], *walker2d_common.evaluation_setup(front)
    )
    if summary["falls_per_episode"] is not None:
        return float(summary["mean_speed_m_per_s"])
    return float(np.mean(summary["mean_speed_m_per_s_range"]))


def front_metrics(front: dict) -> dict:
    """What the tables report of one front."""
    from wcac_jax import pareto

    rows = front["prefs"]
    prefs = np.array([r["pref"] for r in rows])
    ret = np.array([r["return"] for r in rows])
    length = np.array([r["episode_length"] for r in rows])
    fwd = int(np.argmax(prefs[:, 0]))
    ctrl = int(np.argmax(prefs[:, 1]))
    cond = front.get("conditioned", {})
    return {
        "n_prefs": len(rows),
        "hv_morl_baselines": pareto.hypervolume(
            np.array([r["discounted_return"] for r in rows]), [MORL_BASELINES_REF] * 2
        ),
        "hv_project": front["hypervolume"],
        "expected_utility": front["expected_utility"],
        "nondominated": int(sum(r["nondominated"] for r in rows)),
        "spearman_p0_forward": pareto.rank_correlation(prefs[:, 0], ret[:, 0]),
        "forward_end_speed": forward_speed(front, fwd),
        "forward_end_length": float(length[fwd]),
        "control_end_control_return": float(ret[ctrl, 1]),
        "env_steps_total": front["env_steps_total"],
        "eval_env_steps": cond.get("eval_env_steps"),
        "wall_s": front["wall_s"],
        "train_s": front["train_s"],
        "compile_s": front["compile_s"],
    }


def run_arm(arm: str, seed: int, work: str, out: str) -> dict:
    """One command-line sweep of `arm` at `seed` in `work`, its small files copied to
    `out/<arm>/seed<seed>`; returns what the command's front says, with the load."""
    from wcac_jax.sweep import cli

    run_dir = os.path.join(work, arm, f"seed{seed}")
    dest = os.path.join(out, arm, f"seed{seed}")
    recorded = os.path.join(dest, "machine.json")
    if os.path.isfile(os.path.join(run_dir, "front.json")) and os.path.isfile(recorded):
        with open(recorded) as f:  # trained before: its own record stands
            return json.load(f)
    load_before = os.getloadavg()
    t0 = time.perf_counter()
    status = cli.main(
        [*ARMS[arm], "--seed", str(seed), "--out", run_dir, "--quiet"]
        + (["--resume"] if os.path.isfile(os.path.join(run_dir, "config.json")) else [])
    )
    seconds = time.perf_counter() - t0
    if status != 0:
        raise SystemExit(f"{arm} seed {seed}: the sweep exited with status {status}")
    os.makedirs(dest, exist_ok=True)
    for name in KEPT:
        if os.path.isfile(os.path.join(run_dir, name)):
            copy_atomic(os.path.join(run_dir, name), dest)
    machine = {
        "load_before": load_before,
        "load_after": os.getloadavg(),
        "process_s": seconds,
        "cpus": os.cpu_count(),
    }
    from wcac_jax.sweep.outputs import write_atomic  # imported late, as every wcac_jax module here

    write_atomic(recorded, (json.dumps(machine, indent=1)).encode())
    return machine


def copy_atomic(src: str, directory: str) -> None:
    """`src` copied into `directory` under its own name, atomically."""
    from wcac_jax.sweep.outputs import write_atomic

    with open(src, "rb") as f:
        write_atomic(os.path.join(directory, os.path.basename(src)), f.read())


def cost_growth(run_dir: str, counts) -> list[dict]:
    """The trained network of `run_dir` evaluated at each of `counts` evenly spread
    preferences: env steps and seconds of each evaluation (compilation included)."""
    from wcac_jax import pareto
    from wcac_jax.sweep import load_sweep
    from wcac_jax.sweep.conditioned import evaluate_at

    run = load_sweep(run_dir)
    rows = []
    for k in counts:
        prefs = pareto.simplex_lattice(2, k)
        t0 = time.perf_counter()
        ev = evaluate_at(run, prefs)
        # each preference's mean length times the episodes (the sum is not truncated first)
        steps = float(np.sum(np.asarray(ev["eval/length"], np.float64))) * run.config.eval_episodes
        rows.append(
            {
                "eval_prefs": k,
                "eval_env_steps": int(round(steps)),
                "eval_s": time.perf_counter() - t0,
                "load": os.getloadavg(),
            }
        )
    return rows


def read_fronts(out: str, reuse_9x1m: str | None) -> dict:
    """`{arm: {seed: front}}` of every front in `out` (and the reused 9 x 1M ones)."""
    fronts: dict = {}
    for arm in ARMS:
        base = os.path.join(out, arm)
        if arm == "independent_9x1M" and not os.path.isdir(base) and reuse_9x1m:
            base = reuse_9x1m
        if not os.path.isdir(base):
            continue
        for name in sorted(os.listdir(base)):
            path = os.path.join(base, name, "front.json")
            if name.startswith("seed") and os.path.isfile(path):
                with open(path) as f:
                    fronts.setdefault(arm, {})[int(name[4:])] = json.load(f)
    return fronts


def summarize(out: str, reuse_9x1m: str | None, cost: list | None) -> dict:
    from wcac_jax.sweep.outputs import write_atomic

    fronts = read_fronts(out, reuse_9x1m)
    per_run = {
        arm: {seed: front_metrics(f) for seed, f in by_seed.items()}
        for arm, by_seed in fronts.items()
    }
    means = {
        arm: {
            k: float(np.mean([r[k] for r in runs.values() if r[k] is not None]))
            for k in next(iter(runs.values()))
            if any(r[k] is not None for r in runs.values())
        }
        for arm, runs in per_run.items()
    }
    summary = {
        "runs": per_run,
        "means": means,
        "reused_9x1M": reuse_9x1m if "independent_9x1M" in fronts else None,
    }
    if cost is not None:
        summary["cost_growth"] = cost
    write_atomic(os.path.join(out, "summary.json"), json.dumps(summary, indent=1).encode())
    write_atomic(os.path.join(out, "summary.md"), markdown(summary).encode())
    return summary


def markdown(summary: dict) -> str:
    cols = [
        ("hv_morl_baselines", "HV (morl-baselines)", "{:.3e}"),
        ("hv_project", "project HV", "{:.3e}"),
        ("expected_utility", "EU", "{:.0f}"),
        ("nondominated", "non-dom.", "{:.0f}"),
        ("spearman_p0_forward", "Spearman", "{:.2f}"),
        ("forward_end_speed", "fwd m/s", "{:.2f}"),
        ("forward_end_length", "fwd length", "{:.0f}"),
        ("control_end_control_return", "ctrl return", "{:.0f}"),
        ("env_steps_total", "train env steps", "{:,.0f}"),
        ("wall_s", "wall s", "{:.0f}"),
    ]
    lines = ["| arm | seed | " + " | ".join(c[1] for c in cols) + " |"]
    lines.append("|" + "---|" * (len(cols) + 2))
    for arm, runs in summary["runs"].items():
        for seed, r in sorted(runs.items()):
            cells = [fmt.format(r[k]) if r[k] is not None else "" for k, _, fmt in cols]
            lines.append(f"| {arm} | {seed} | " + " | ".join(cells) + " |")
        m = summary["means"][arm]
        cells = [fmt.format(m[k]) if k in m else "" for k, _, fmt in cols]
        lines.append(f"| {arm} | mean | " + " | ".join(cells) + " |")
    lines.append("")
    for row in summary.get("cost_growth", []):
        lines.append(
            f"- {row['eval_prefs']} preferences: {row['eval_env_steps']:,} evaluation env "
            f"steps, {row['eval_s']:.0f} s (load {row['load'][0]:.1f})"
        )
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default="experiments/results/conditioned_walker2d")
    p.add_argument("--work", default="runs/conditioned_walker2d", help="the sweeps' own dirs")
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    p.add_argument("--arms", nargs="+", default=["conditioned", "independent_9x333k"])
    p.add_argument(
        "--reuse-9x1m",
        default="experiments/results/cli_default_front_select5",
        help="the committed 9 x 1M fronts of today's default (seedS/front.json)",
    )
    p.add_argument("--cost-prefs", type=int, nargs="*", default=[9, 33, 101])
    p.add_argument("--summarize-only", action="store_true", help="resummarize --out only")
    p.add_argument(
        "--resume", action="store_true", help="add to a non-empty --out, keeping its runs"
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace a non-empty --out (written beside it, renamed into place when finished)",
    )
    args = p.parse_args(argv)
    if args.summarize_only and args.overwrite:  # it would replace --out by an empty summary
        fail(f"--out {args.out!r}: --summarize-only reads it and --overwrite replaces it")
    out = make_out(args.out, args.resume or args.summarize_only, args.overwrite, resume_adds=True)
    if not args.summarize_only:
        for seed in args.seeds:
            for arm in args.arms:
                print(f"[{arm} seed {seed}] {run_arm(arm, seed, args.work, out)}", flush=True)
    seed0 = os.path.join(out, "conditioned", "seed0")
    for name in ("front.json", "front.png"):
        if os.path.isfile(os.path.join(seed0, name)):
            copy_atomic(os.path.join(seed0, name), out)
    cost = None
    work0 = os.path.join(args.work, "conditioned", "seed0")
    if args.cost_prefs and os.path.isdir(work0):
        cost = cost_growth(work0, args.cost_prefs)
    elif os.path.isfile(os.path.join(out, "summary.json")):  # not measured again: kept
        with open(os.path.join(out, "summary.json")) as f:
            cost = json.load(f).get("cost_growth")
    summary = summarize(out, args.reuse_9x1m, cost)
    finish_out(out, args.out)
    print(markdown(summary))


if __name__ == "__main__":
    main()
