"""The field's benchmark protocols (`wcac_jax.protocols`): every task's front at the
protocol's budget, and one table that sets each published number beside ours on the same
definition only.

Two commands, writing under `--results` (default `experiments/results/field`):

- `run --protocol P --env T --seeds S [S ...]`: for each seed, `python -m wcac_jax.sweep
  --env T --protocol P --seed S --out <results>/P/T/seedS` (the protocol's preset for the
  task: one preference-conditioned network trained on the protocol's budget, evaluated
  and scored as the protocol says). A non-empty seed directory is refused unless
  `--resume` (the sweep continues it; a finished one is left as it is) or `--overwrite`.
  Seeds run one after another, each alone in its process. On C-MORL's protocol (tasks
  of MO-Gymnasium itself) each finished run is then evaluated again in MO-Gymnasium's own
  environment (`python -m wcac_jax.evaluate RUN --in mo-gymnasium`, numpy inference, the
  protocol's preferences, episodes and discount) into the run's
  `evaluation_mo_gymnasium.json`, unless `--no-reference-eval`; mo-gymnasium is an
  optional extra.
- `ablation --protocol P --env T --variants V [V ...] --seeds S [S ...]`: the choices
  around the method measured, not argued: each variant (`VARIANTS`: the conditioned
  update's defaults with named fields changed) trained and scored as the protocol says
  into `<results>/ablation/P/T/V/seedS`, one run at a time in this process; finished
  runs are kept, unfinished ones continued. `ablation-table` writes `ablation.json` and
  `ablation.md`: per task and variant each seed's HV and EU, their mean and interval,
  and the ratio of its mean to the `default` variant's on the seeds both ran.
- `table`: reads every `<results>/P/T/seedS/front.json` and `<results>/published.json`
  and writes `table.json` and `table.md`: per protocol and task, each seed's protocol HV
  and EU (recomputed from the front's returns by `protocols.front_scores`, and checked
  against what the run wrote), their mean with a 95% Student-t interval over the seeds,
  the env steps trained (whole iterations, at most the budget) and evaluated, the wall
  time per seed, and the published numbers of the same protocol, task definition and
  budget beside them, with the ratio of our mean to the best; where every seed of a task
  was evaluated in MO-Gymnasium too, that evaluation's HV (mean and interval) beside the
  project's, and its ratio to the best. A published number whose
  definition (the environment it was measured on) or budget differs from the protocol's
  task is refused, naming both; so is a run that deviates from its protocol.

No number is typed here: ours are read from the runs, the published ones from
`published.json`, each with its source.
"""

from __future__ import annotations

import argparse
import glob
import json
import math
import os
import subprocess
import sys

import numpy as np
from script_io import refuse_existing

from wcac_jax import protocols
from wcac_jax.sweep import presets
from wcac_jax.sweep.outputs import json_bytes, write_atomic

# The ablation's variants: fields of the conditioned update changed from its defaults
# (`ConditionedConfig()`), each a choice around the method (its direction, smooth_wc,
# stays); `select`: `(K, env steps)`, each preference's best of the network's last K
# policies (`wcac_jax.sweep.conditioned.choose_policies`), else the final network.
VARIANTS: dict[str, dict] = {
    "default": {},
    "m32": {"num_minibatches": 32},
    "e10": {"num_epochs": 10},
    "e10m32": {"num_epochs": 10, "num_minibatches": 32},
    "n32": {"num_envs": 32},
    "logstd-0.5": {"log_std_init": -0.5},
    "logstd-1": {"log_std_init": -1.0},
    "anneal": {"anneal_lr": True},
    "e10m32-alpha0.5": {"num_epochs": 10, "num_minibatches": 32, "pref_alpha": 0.5},
    "e10m32-w256": {"num_epochs": 10, "num_minibatches": 32, "width": 256},
    "e10m32-logstd-1": {"num_epochs": 10, "num_minibatches": 32, "log_std_init": -1.0},
    "e10-logstd-1": {"num_epochs": 10, "log_std_init": -1.0},
    "m32-logstd-1": {"num_minibatches": 32, "log_std_init": -1.0},
    "m64-logstd-1": {"num_minibatches": 64, "log_std_init": -1.0},
    "m32-logstd-1-film": {"num_minibatches": 32, "log_std_init": -1.0, "conditioning": "film"},
    "e10m32-mu10": {"num_epochs": 10, "num_minibatches": 32, "mu": 10.0},
    "e10m32-mu3": {"num_epochs": 10, "num_minibatches": 32, "mu": 3.0},
    "e10m32-mu30": {"num_epochs": 10, "num_minibatches": 32, "mu": 30.0},
    "e10m32-sel3": {"num_epochs": 10, "num_minibatches": 32, "select": (3, 81_920)},
    "m32-logstd-1-sel3": {"num_minibatches": 32, "log_std_init": -1.0, "select": (3, 81_920)},
    "m32-logstd-1-sel2": {"num_minibatches": 32, "log_std_init": -1.0, "select": (2, 81_920)},
    "e10m32-g995": {"num_epochs": 10, "num_minibatches": 32, "gamma": 0.995},
    "e10m32-logstd-1-alpha0.5": {
        "num_epochs": 10,
        "num_minibatches": 32,
        "log_std_init": -1.0,
        "pref_alpha": 0.5,
    },
    "m32-logstd-1-alpha0.5": {"num_minibatches": 32, "log_std_init": -1.0, "pref_alpha": 0.5},
    "m32-logstd-1-alpha2": {"num_minibatches": 32, "log_std_init": -1.0, "pref_alpha": 2.0},
    "e10m32-alpha0.3": {"num_epochs": 10, "num_minibatches": 32, "pref_alpha": 0.3},
    "e10m32-logstd-1-alpha0.3": {
        "num_epochs": 10,
        "num_minibatches": 32,
        "log_std_init": -1.0,
        "pref_alpha": 0.3,
    },
    "e10m32-alpha0.05": {"num_epochs": 10, "num_minibatches": 32, "pref_alpha": 0.05},
    "e10m32-logstd-1-alpha0.05": {
        "num_epochs": 10,
        "num_minibatches": 32,
        "log_std_init": -1.0,
        "pref_alpha": 0.05,
    },
    "e20m32": {"num_epochs": 20, "num_minibatches": 32},
    "e10m64": {"num_epochs": 10, "num_minibatches": 64},
    "e10m32-film": {"num_epochs": 10, "num_minibatches": 32, "conditioning": "film"},
    "e10m32-logstd-1-film": {
        "num_epochs": 10,
        "num_minibatches": 32,
        "log_std_init": -1.0,
        "conditioning": "film",
    },
}

# Variants named `<base>-<choice>[-<choice>]`: a variant above with one or more
# choices, tried on the tasks whose fronts fall short of PGMORL's: each preference's best
# of the last five policies (`presets.BEST_OF_LAST`), a log-std per vertex of the
# simplex, PGMORL's gamma, a step size decayed linearly to 0 or doubled, networks twice
# as wide, or twice the environments (each its own preference) for half as many steps an
# iteration; and one preference per environment for the whole run instead of one per
# episode (`env`, `pref_draw`), or, stated where the presets draw per environment, one
# per episode (`episode`, the defaults' draw); and the smoother direction C-MORL's hoppers
# took (`mu30`) at other presets' choices: the ants' and the tasks still short of PGMORL's
CHOICES: dict[str, dict] = {
    "sel5": {"select": presets.BEST_OF_LAST},
    "stdp": {"log_std_by_pref": True},
    "g995": {"gamma": 0.995},
    "anneal": {"anneal_lr": True},
    "w256": {"width": 256},
    "lr6e-4": {"learning_rate": 6e-4},
    "n128": {"num_envs": 128, "rollout_steps": 64},
    "env": {"pref_draw": "environment"},
    "episode": {"pref_draw": "episode"},
    "mu30": {"mu": 30.0},
}
_SHORT_OF_PGMORL = ("e10m32-alpha0.5", "e10m32-logstd-1-alpha0.05", "m32-logstd-1")
_ON_TOP_OF_BEST = ("anneal", "w256", "lr6e-4", "n128")
for _base, _chosen in (
    *((b, (c,)) for b in _SHORT_OF_PGMORL for c in ("sel5", "stdp", "g995")),
    *((b, ("sel5", c)) for b in _SHORT_OF_PGMORL for c in _ON_TOP_OF_BEST),
    ("e10m32", ("sel5",)),
    ("e10m32", ("env",)),
    ("e10m32-logstd-1-alpha0.05", ("sel5", "env")),
    ("e10m32", ("episode",)),
    ("e10m32-mu30", ("env",)),
    ("e10m32-logstd-1-alpha0.05", ("sel5", "episode")),
    ("e10m32-alpha0.5", ("sel5", "env", "mu30")),
    ("e10m32-logstd-1-alpha0.05", ("sel5", "env", "mu30")),
    ("m32-logstd-1", ("sel5", "env", "mu30")),
    ("m32-logstd-1", ("env", "mu30")),
    ("m32-logstd-1", ("env",)),
    ("default", ("env", "mu30")),
    ("e10m32-alpha0.5", ("sel5", "env")),
):
    VARIANTS["-".join((_base, *_chosen))] = {
        **VARIANTS[_base],
        **{k: v for c in _chosen for k, v in CHOICES[c].items()},
    }

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, "experiments", "results", "field")


class TableError(ValueError):
    """A comparison the table refuses (another definition or budget, a deviating run)."""


def seed_dir(results: str, protocol: str, env: str, seed: int) -> str:
    return os.path.join(results, protocol, env, f"seed{seed}")


REFERENCE_EVAL = "evaluation_mo_gymnasium.json"
# the protocols whose tasks are MO-Gymnasium's own: their runs are evaluated there too
REFERENCE_PROTOCOLS = ("cmorl",)


def reference_eval(out: str) -> int:
    """`python -m wcac_jax.evaluate out --in mo-gymnasium` unless done; its status."""
    if os.path.isfile(os.path.join(out, REFERENCE_EVAL)):
        return 0
    cmd = [sys.executable, "-m", "wcac_jax.evaluate", out, "--in", "mo-gymnasium", "--quiet"]
    print(" ".join(cmd[1:]), flush=True)
    return subprocess.call(cmd, cwd=ROOT)


def _scored(out: str) -> bool:
    """Whether the run in `out` has finished: its `front.json` holds the protocol's
    scores (a conditioned run writes its training's front first and replaces it once
    evaluated, so a run stopped in between has a `front.json` without them)."""
    try:
        with open(os.path.join(out, "front.json")) as f:
            return "protocol" in json.load(f)
    except (OSError, ValueError):
        return False


def run(
    results: str,
    protocol: str,
    env: str,
    seeds,
    resume: bool,
    overwrite: bool,
    reference: bool = True,
) -> int:
    """Trains and scores each seed in its own process, then (C-MORL's protocol, unless
    `reference` is false) evaluates it in MO-Gymnasium (see the module docstring)."""
    reference = reference and protocol in REFERENCE_PROTOCOLS
    for seed in seeds:
        out = seed_dir(results, protocol, env, seed)
        if _scored(out) and resume:
            print(f"{out} is finished", flush=True)
            status = reference_eval(out) if reference else 0
            if status:
                return status
            continue
        cmd = [sys.executable, "-m", "wcac_jax.sweep", "--env", env, "--protocol", protocol]
        cmd += ["--seed", str(seed), "--out", out]
        if resume and os.path.isdir(out):
            cmd.append("--resume")
        elif overwrite:
            cmd.append("--overwrite")
        print(" ".join(cmd[1:]), flush=True)
        status = subprocess.call(cmd, cwd=ROOT)
        if not status and reference:
            status = reference_eval(out)
        if status:
            return status
    return 0


def ablation_dir(results: str, protocol: str, env: str, variant: str, seed: int) -> str:
    return os.path.join(results, "ablation", protocol, env, variant, f"seed{seed}")


def ablation(results: str, protocol: str, env: str, variants, seeds) -> int:
    """Trains and scores each variant and seed (see the module docstring)."""
    from wcac_jax.algos import ConditionedConfig
    from wcac_jax.sweep import run_conditioned
    from wcac_jax.sweep.protocol import protocol_sweep

    for variant in variants:
        for seed in seeds:
            out = ablation_dir(results, protocol, env, variant, seed)
            if os.path.isfile(os.path.join(out, "front.json")):
                print(f"{out} is finished", flush=True)
                continue
            changes = dict(VARIANTS[variant])
            select = changes.pop("select", (1, 0))
            config = protocol_sweep(
                env, protocol, seed, ConditionedConfig(**changes), selection=select
            )
            print(f"{out}: {VARIANTS[variant] or 'the defaults'}", flush=True)
            front = run_conditioned(config, out, resume=os.path.isdir(out), chunks=10)
            if front.get("interrupted"):
                return 1
            score = front["protocol"]
            print(f"  HV {score['hv']:.4g}, EU {score['eu']:.4g}, {front['wall_s']:.0f} s")
    return 0


def ablation_summary(results: str) -> dict:
    """`ablation.json`'s content: per protocol, task and variant, each seed's scores."""
    rows = []
    for path in sorted(glob.glob(os.path.join(results, "ablation", "*", "*", "*"))):
        protocol, env, variant = path.split(os.sep)[-3:]
        seeds = []
        for front_path in sorted(glob.glob(os.path.join(path, "seed*", "front.json"))):
            with open(front_path) as f:
                front = json.load(f)
            score = protocols.front_scores(front)
            seeds.append(
                {
                    "seed": int(front["config"]["seed"]),
                    "hv": score["hv"],
                    "eu": score["eu"],
                    "wall_s": front["wall_s"],
                    "deviations": score["deviations"],
                }
            )
        if not seeds:
            continue
        hv = mean_interval([s["hv"] for s in seeds])
        rows.append(
            {
                "protocol": protocol,
                "task": env,
                "variant": variant,
                "changes": VARIANTS.get(variant),
                "seeds": seeds,
                "hv": {"mean": hv[0], "ci95": [hv[1], hv[2]]},
                "eu_mean": float(np.mean([s["eu"] for s in seeds])),
            }
        )
    # each variant against the defaults on the seeds both ran (paired)
    base = {
        (r["protocol"], r["task"]): {s["seed"]: s["hv"] for s in r["seeds"]}
        for r in rows
        if r["variant"] == "default"
    }
    for r in rows:
        ref = base.get((r["protocol"], r["task"]), {})
        common = [s for s in r["seeds"] if s["seed"] in ref]
        r["paired_seeds"] = [s["seed"] for s in common]
        r["ratio_to_default"] = (
            float(np.mean([s["hv"] for s in common]) / np.mean([ref[s["seed"]] for s in common]))
            if common
            else None
        )
    return {"rows": rows}


def write_ablation(summary: dict, results: str) -> None:
    lines = [
        "| protocol | task | variant | changes | seeds | HV mean [95%] | EU mean | vs default "
        "(same seeds) | wall s per seed |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in summary["rows"]:
        ratio = (
            "—"
            if r["ratio_to_default"] is None
            else f"{r['ratio_to_default']:.2f} ({', '.join(map(str, r['paired_seeds']))})"
        )
        lo, hi = r["hv"]["ci95"]
        lines.append(
            f"| {r['protocol']} | {r['task']} | {r['variant']} | {r['changes']} "
            f"| {', '.join(str(s['seed']) for s in r['seeds'])} "
            f"| {_e(r['hv']['mean'])} [{_e(lo)}, {_e(hi)}] | {r['eu_mean']:.4g} | {ratio} | "
            + ", ".join(f"{s['wall_s']:.0f}" for s in r["seeds"])
            + " |"
        )
    write_atomic(os.path.join(results, "ablation.md"), ("\n".join(lines) + "\n").encode())
    write_atomic(os.path.join(results, "ablation.json"), json_bytes(summary))


# ----------------------------------------------------------------------------- the table


def mean_interval(values) -> tuple[float, float, float]:
    """`(mean, lo, hi)`: the mean and its 95% Student-t interval over the values (one
    value: the interval is the value itself)."""
    x = np.asarray(values, np.float64)
    mean = float(np.mean(x))
    if len(x) < 2:
        return mean, mean, mean
    from scipy import stats

    half = float(stats.t.ppf(0.975, len(x) - 1) * np.std(x, ddof=1) / math.sqrt(len(x)))
    return mean, mean - half, mean + half


def load_published(results: str) -> list[dict]:
    with open(os.path.join(results, "published.json")) as f:
        return json.load(f)["entries"]


def published_for(entries: list[dict], protocol: protocols.Protocol, task) -> list[dict]:
    """The published entries set beside `task` under `protocol`, each checked: the same
    protocol, task definition (the environment it was measured on) and budget.

    Raises:
      TableError: an entry filed under this protocol and task whose definition or budget
        differs, naming both.
    """
    budget = protocol.budget(task.num_objectives)
    out = []
    for entry in entries:
        if entry["protocol"] != protocol.name or entry["task"] != task.env:
            continue
        if entry["definition"] != task.reference:
            raise TableError(
                f"{entry['method']} on {task.env} ({protocol.name}) was measured on "
                f"{entry['definition']}, not {task.reference}: another task definition"
            )
        if entry["budget"] != budget:
            raise TableError(
                f"{entry['method']} on {task.env} ({protocol.name}) trained "
                f"{entry['budget']:,} env steps, not the protocol's {budget:,}: another budget"
            )
        out.append(entry)
    return out


def task_row(results: str, protocol: protocols.Protocol, task, entries) -> dict | None:
    """One task's row (see the module docstring), or `None` without runs."""
    paths = sorted(
        glob.glob(os.path.join(results, protocol.name, task.env, "seed*", "front.json")),
        key=lambda p: int(os.path.basename(os.path.dirname(p))[4:]),
    )
    published = published_for(entries, protocol, task)
    if not paths:
        return None
    seeds = []
    for path in paths:
        with open(path) as f:
            front = json.load(f)
        score = protocols.front_scores(front)
        if score["deviations"]:
            departs = "; ".join(score["deviations"])
            raise TableError(f"{path} departs from the {protocol.name} protocol: {departs}")
        written = front["protocol"]
        for key in ("hv", "eu"):
            if not math.isclose(written[key], score[key], rel_tol=1e-9):
                raise TableError(f"{path}: its written {key} {written[key]} is not {score[key]}")
        ref_path = os.path.join(os.path.dirname(path), REFERENCE_EVAL)
        reference = None
        if os.path.isfile(ref_path):
            with open(ref_path) as f:
                evaluated = json.load(f)["protocol"]
            if evaluated["deviations"]:
                departs = "; ".join(evaluated["deviations"])
                raise TableError(f"{ref_path} departs from the {protocol.name} protocol: {departs}")
            reference = {k: evaluated["mo_gymnasium"][k] for k in ("hv", "eu", "nondominated")}
        seeds.append(
            {
                "seed": int(front["config"]["seed"]),
                "mo_gymnasium": reference,
                "hv": score["hv"],
                "eu": score["eu"],
                "nondominated": score["nondominated"],
                "env_steps_trained": score["env_steps_trained"],
                "eval_env_steps": score["eval_env_steps"],
                "wall_s": front["wall_s"],
                "path": os.path.relpath(path, ROOT),
            }
        )
    hv = mean_interval([s["hv"] for s in seeds])
    eu = mean_interval([s["eu"] for s in seeds])
    best = max(published, key=lambda e: e["hv"]) if published else None
    hv_ref = None  # MO-Gymnasium's evaluation, where every seed has one
    if all(s["mo_gymnasium"] is not None for s in seeds):
        m = mean_interval([s["mo_gymnasium"]["hv"] for s in seeds])
        hv_ref = {"mean": m[0], "ci95": [m[1], m[2]]}
        if best is not None:
            hv_ref["ratio_to_best"] = m[0] / best["hv"]
            hv_ref["ratio_ci95"] = [m[1] / best["hv"], m[2] / best["hv"]]
    return {
        "protocol": protocol.name,
        "task": task.env,
        "published_task": task.published,
        "definition": task.reference,
        "budget": protocol.budget(task.num_objectives),
        "seeds": seeds,
        "hv": {"mean": hv[0], "ci95": [hv[1], hv[2]]},
        "eu": {"mean": eu[0], "ci95": [eu[1], eu[2]]},
        "published": published,
        "best_published": None if best is None else {"method": best["method"], "hv": best["hv"]},
        "ratio_to_best": None if best is None else hv[0] / best["hv"],
        "ratio_ci95": None if best is None else [hv[1] / best["hv"], hv[2] / best["hv"]],
        "hv_mo_gymnasium": hv_ref,
    }


def summarize(results: str) -> dict:
    entries = load_published(results)
    rows = []
    for protocol in protocols.PROTOCOLS.values():
        for task in protocol.tasks:
            row = task_row(results, protocol, task, entries)
            if row is not None:
                rows.append(row)
    return {
        "protocols": {
            p.name: {
                "title": p.title,
                "gamma": p.gamma,
                "ref_value": p.ref_value,
                "drop_negative": p.drop_negative,
                "budget_by_m": {str(k): v for k, v in p.budget_by_m.items()},
            }
            for p in protocols.PROTOCOLS.values()
        },
        "rows": rows,
    }


def _e(x: float) -> str:
    return f"{x:.3g}"


def write_table(summary: dict, results: str) -> None:
    lines = [
        "| protocol | task | seeds | HV mean [95%] | EU mean | best published (HV) | ratio "
        "[95%] | HV in MO-Gymnasium [95%] | env steps trained | eval env steps | wall s per "
        "seed |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in summary["rows"]:
        best = r["best_published"]
        lines.append(
            f"| {r['protocol']} | {r['task']} | {len(r['seeds'])} "
            f"| {_e(r['hv']['mean'])} [{_e(r['hv']['ci95'][0])}, {_e(r['hv']['ci95'][1])}] "
            f"| {r['eu']['mean']:.4g} "
            + (
                f"| {best['method']} {_e(best['hv'])} | {r['ratio_to_best']:.2f} "
                f"[{r['ratio_ci95'][0]:.2f}, {r['ratio_ci95'][1]:.2f}] "
                if best
                else "| none published | — "
            )
            + (
                f"| {_e(ref['mean'])} [{_e(ref['ci95'][0])}, {_e(ref['ci95'][1])}] "
                if (ref := r["hv_mo_gymnasium"])
                else "| — "
            )
            + f"| {r['seeds'][0]['env_steps_trained']:,} "
            + "| "
            + ", ".join(f"{s['eval_env_steps']:,}" for s in r["seeds"])
            + " | "
            + ", ".join(f"{s['wall_s']:.0f}" for s in r["seeds"])
            + " |"
        )
    write_atomic(os.path.join(results, "table.md"), ("\n".join(lines) + "\n").encode())
    write_atomic(os.path.join(results, "table.json"), json_bytes(summary))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--results", default=RESULTS)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("run", help="train and score seeds of one task under one protocol")
    p.add_argument("--protocol", required=True, choices=tuple(protocols.PROTOCOLS))
    p.add_argument("--env", required=True)
    p.add_argument("--seeds", type=int, nargs="+", default=[0])
    g = p.add_mutually_exclusive_group()
    g.add_argument("--resume", action="store_true")
    g.add_argument("--overwrite", action="store_true")
    p.add_argument(
        "--no-reference-eval",
        action="store_true",
        help="C-MORL's protocol: do not evaluate the runs in MO-Gymnasium afterwards",
    )
    p = sub.add_parser("ablation", help="train and score variants of the conditioned update")
    p.add_argument("--protocol", required=True, choices=tuple(protocols.PROTOCOLS))
    p.add_argument("--env", required=True)
    p.add_argument("--variants", nargs="+", required=True, choices=tuple(VARIANTS))
    p.add_argument("--seeds", type=int, nargs="+", default=[0])
    sub.add_parser("ablation-table", help="write ablation.json and ablation.md")
    p = sub.add_parser("table", help="write table.json and table.md from the runs")
    p.add_argument("--overwrite", action="store_true")
    args = parser.parse_args(argv)
    if args.command == "ablation":
        return ablation(args.results, args.protocol, args.env, args.variants, args.seeds)
    if args.command == "ablation-table":
        summary = ablation_summary(args.results)
        write_ablation(summary, args.results)
        print(f"wrote {os.path.join(args.results, 'ablation.json')}: {len(summary['rows'])} rows")
        return 0
    if args.command == "run":
        try:
            protocols.get(args.protocol).task(args.env)
        except ValueError as err:
            print(f"error: {err}", file=sys.stderr)
            return 2
        return run(
            args.results,
            args.protocol,
            args.env,
            args.seeds,
            args.resume,
            args.overwrite,
            not args.no_reference_eval,
        )
    target = os.path.join(args.results, "table.json")
    refuse_existing(target, args.overwrite, flag="")
    try:
        summary = summarize(args.results)
    except TableError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    write_table(summary, args.results)
    print(f"wrote {target}: {len(summary['rows'])} tasks")
    return 0


if __name__ == "__main__":
    sys.exit(main())
