"""The paper's recommendation experiment (Table 2 and Fig. 2) on KuaiRand directories.

    python experiments/kuairand_table2.py --data DIR [DIR ...] --out OUT [--quick]
        [--seed S] [--seeds N] [--steps T] [--bc-weight W] [--version 27k|1k|pure]
        [--protocol default|tscac] [--overwrite]

reads each `DIR` (real KuaiRand-27K, -1K or -Pure files, found by their names, or `python
-m wcac_jax.recsys.synth`'s; one directory per data seed), builds the protocol's offline
transitions (`--protocol`: `wcac_jax.recsys.data.load`'s), and on each trains with
`--seeds` training seeds (one compiled program per method, vmapped over seeds):
Behavior-Clone, an independent behaviour model (another Behavior-Clone), the DDPG-style
actor-critics (MOAC, MOCHA, PDPG, wcac; `wcac_jax.recsys.offline`) and the paper's
Algorithm 1 (`wcac_jax.recsys.alg1`), all with the unified preference and the same budget
and behaviour-cloning term; on the first data set, Algorithm 1 also with 7 preferences
each leaning to one signal (Fig. 2). Every policy is scored on the test rows by NCIS
against the behaviour model and, when `DIR` holds the generator's response model, by its
true expected signals (each test row's candidates shown to its user in its logged session
context); the Oracle is the best Gaussian policy of the evaluation's width for the unified
objective under that model. Writes to `OUT`:

- `table.json`: `{"seeds", "data_seeds", "methods": {name: {"ncis", "ncis_ci95",
  "vs_bc", "vs_bc_ci95", "ess", "truth", "truth_ci95", "truth_vs_bc",
  "truth_vs_bc_ci95", "unified_truth", "unified_truth_ci95", "unified_vs_bc",
  "unified_vs_bc_ci95", "gap_share", "gap_share_ci95", "gap_share_by_data_set",
  "gap_share_ci95_data_sets"}}, "logged", "ncis_events", "min_ncis_events"}` (NCIS gives
  no verdict on a signal with fewer logged events among the test rows than
  `min_ncis_events`; the `truth` entries, the oracle's and the gap only on synthetic
  data), means over data sets and training seeds with 95% bootstrap intervals over test
  rows and seeds, conditional on the data sets (`wcac_jax.recsys.stats`); the gap share
  also per data set and with the data sets resampled too;
- `per_seed.json`: per data set, method and training seed, the estimates on all of the
  set's test rows (NCIS and the true value per signal, the unified true value), from
  which the point estimates and the data-set-level interval are recomputed;
- `table.md`: the Table 2 analogue; `fig2.png`, `fig2.json`: the Fig. 2 analogue;
- `curves.json`: per data set, method and seed, the critic loss and mean action in 40
  windows of the training steps;
- `run.json`: configuration, sizes, wall-clock and CPU seconds (`merged_parts`: whether
  the data sets were trained by `--part` processes, whose seconds `total` adds), peak
  memory (`max_rss_gib`: each process that trained a data set, then the one that wrote
  the table).

`OUT` must be new or empty unless `--overwrite` is given; then it is replaced whole (no
file of the previous results is kept). The results are written into a new directory
beside `OUT` and renamed into place, so an interrupted run leaves the previous results
as they were.

Bad input (a missing/malformed KuaiRand file, an unwritable or non-empty `--out`)
prints one `error:` line and exits 2 before anything is written; a non-finite training
loss (or mean action) prints one `error:` line naming the method and the first such
step, and exits 3 without writing anything.
"""

from __future__ import annotations

import json
import os
import pickle
import resource
import shutil
import sys
import tempfile
import time
from dataclasses import asdict, replace

import jax
import jax.numpy as jnp
import numpy as np

from wcac_jax.recsys import alg1, offline, stats
from wcac_jax.recsys import ncis as ncis_lib
from wcac_jax.recsys.cli import ArgumentParser
from wcac_jax.recsys.data import PROTOCOLS, SIGNALS, DataError, load
from wcac_jax.recsys.kuairand import VERSIONS
from wcac_jax.recsys.synth import MODEL_FILE, ResponseModel
from wcac_jax.recsys.table2 import (
    CURVE_POINTS,
    NAMES,
    UNIFIED,
    fig2_scores,
    leaning_prefs,
    logged_contexts,
    per_seed,
    score_rows,
    signals,
    summarise,
    train_data_set,
    truth_tables,
)
from wcac_jax.sweep.outputs import unwritable_dir, write_atomic

# Table 2's column scales, as the paper prints them
COLUMNS = (
    ("click", "Click↑", 1.0),
    ("like", "Like↑ (e-2)", 1e2),
    ("follow", "Follow↑ (e-4)", 1e4),
    ("comment", "Comment↑ (e-3)", 1e3),
    ("forward", "Forward↑ (e-3)", 1e3),
    ("hate", "Dislike↓ (e-4)", 1e4),
    ("watch_time", "WatchTime↑", 1.0),
)
N_BOOT = 1000


QUICK = offline.OfflineConfig(steps=40, batch_size=32, width=16, critic_warmup=0.25)
DEFAULT = offline.OfflineConfig(steps=2000, batch_size=256, width=64)


def _fmt(v: float, scale: float) -> str:
    return f"{v * scale:.3f}"


# Fewer logged events of a signal among the test rows than this (over all data sets) and
# NCIS gives no verdict on it: a bootstrap over the test rows resamples those same few
# events, so its interval cannot show how little they say (on the synthetic sets, forward's
# dozen events gave an interval excluding 0 around a change ten times the true one).
MIN_NCIS_EVENTS = 30


def ncis_events(parts: list) -> dict:
    """`{signal: events}`: the logged test rows' count of each 0/1 signal, summed over the
    data sets (watch time, not a count, is left out)."""
    return {
        s: int(round(sum(p["logged"]["mean"][s] * p["size"]["test_rows"] for p in parts)))
        for s in SIGNALS
        if s != "watch_time"
    }


def _cell(
    row: dict, kind: str, sig: str, scale: float, is_bc: bool, events: dict | None = None
) -> str:
    """`mean [lo, hi]` and, off Behavior-Clone, the change vs BC where its interval
    excludes 0 (else `n.s.`); for NCIS, `few events` where the test rows hold fewer than
    `MIN_NCIS_EVENTS` of the signal (`events`)."""
    lo, hi = row[f"{kind}_ci95"][sig]
    cell = f"{_fmt(row[kind][sig], scale)} [{_fmt(lo, scale)}, {_fmt(hi, scale)}]"
    if is_bc:
        return cell
    if kind == "ncis" and events is not None and events.get(sig, MIN_NCIS_EVENTS) < MIN_NCIS_EVENTS:
        return cell + f" (few events: {events[sig]})"
    rel = row["vs_bc" if kind == "ncis" else "truth_vs_bc"][sig]
    rel_ci = row["vs_bc_ci95" if kind == "ncis" else "truth_vs_bc_ci95"][sig]
    if rel is None or rel_ci[0] is None:
        return cell + " (n/a)"
    verdict = stats.verdict(rel_ci)
    if sig == "hate":  # fewer dislikes is better
        verdict = {"better": "worse", "worse": "better"}.get(verdict, verdict)
    shown = f"{rel:+.1f}%" if verdict != "n.s." else "n.s."
    return cell + f" ({shown})"


def markdown(table: dict, has_truth: bool) -> str:
    """The Table 2 analogue: NCIS and, on synthetic data, the true value, each with its
    95% interval and its change vs Behavior-Clone where that change's interval excludes 0;
    then the unified objective's true value and the share of the BC -> oracle gap."""
    kinds = ("ncis", "truth") if has_truth else ("ncis",)
    lines = []
    for kind in kinds:
        label = {"ncis": "NCIS", "truth": "true value"}[kind]
        lines += [f"| {label} | " + " | ".join(c[1] for c in COLUMNS) + " |"]
        lines += ["|---" * (len(COLUMNS) + 1) + "|"]
        for name, row in table["methods"].items():
            is_bc = name == NAMES["bc"]
            events = table.get("ncis_events")
            cells = [_cell(row, kind, s, sc, is_bc, events) for s, _, sc in COLUMNS]
            lines.append(f"| {name} | " + " | ".join(cells) + " |")
        lines.append("")
    if has_truth:
        lines += ["| method | unified true value | vs BC | share of BC → oracle gap | NCIS ESS |"]
        lines += ["|---|---|---|---|---|"]
        for name, row in table["methods"].items():
            u, (lo, hi) = row["unified_truth"], row["unified_truth_ci95"]
            d, (dlo, dhi) = row["unified_vs_bc"], row["unified_vs_bc_ci95"]
            g, (glo, ghi) = row["gap_share"], row["gap_share_ci95"]
            lines.append(
                f"| {name} | {u:.4f} [{lo:.4f}, {hi:.4f}] | {d:+.4f} [{dlo:+.4f}, {dhi:+.4f}] "
                f"| {g:+.2f} [{glo:+.2f}, {ghi:+.2f}] | {row['ess']:.0f} |"
            )
    return "\n".join(lines).rstrip() + "\n"


def plot_fig2(fig2: dict, path: str) -> None:
    """Heatmaps: improvement (%) of each leaning policy over the unified one, per signal."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kinds = [k for k in ("ncis", "truth") if k in fig2["improvement"]]
    fig, axes = plt.subplots(1, len(kinds), figsize=(6.2 * len(kinds), 5.2), squeeze=False)
    for ax, kind in zip(axes[0], kinds, strict=True):
        m = np.array(fig2["improvement"][kind], dtype=float)  # None -> nan
        lim = max(np.nanmax(np.abs(m), initial=0.0), 1e-9)
        im = ax.imshow(m, cmap="RdBu", vmin=-lim, vmax=lim)
        for i in range(7):
            for j in range(7):
                label = "n/a" if np.isnan(m[i, j]) else f"{m[i, j]:+.1f}"
                ax.text(j, i, label, ha="center", va="center", fontsize=7)
        ax.set_xticks(range(7), [c[1].split(" ")[0] for c in COLUMNS], rotation=45)
        ax.set_xlabel("signal")
        ax.set_yticks(range(7), [f"leans to {c[1].split(' ')[0][:-1]}" for c in COLUMNS])
        ax.set_title({"ncis": "NCIS estimate", "truth": "true value (response model)"}[kind])
        fig.colorbar(im, ax=ax, shrink=0.8, label="improvement over unified (%)")
    fig.suptitle(
        "Fig. 2 analogue: wcac with 7 leaning preferences vs the unified preference\n"
        "(improvement %: higher is better; for Dislike, the reduction)",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path + ".tmp.png", dpi=120)
    plt.close(fig)
    os.replace(path + ".tmp.png", path)


def data_set_part(
    d: int, data_dir: str, cfg, acfg, seed: int, seeds: int, version, log, protocol="default"
):
    """Everything the table needs from data set `d` (host numpy; picklable): the per-row
    scores of every method, the training curves, times, sizes and the logged values."""
    t = time.perf_counter()
    data = load(data_dir, version=version, protocol=protocol)
    log(
        f"data set {d} ({data_dir}): {data.n_rows} rows ({data.n_train} train), "
        f"state {data.state_dim} dims, {time.perf_counter() - t:.1f}s"
    )
    model_path = os.path.join(data_dir, MODEL_FILE)
    model = ResponseModel.load(model_path) if os.path.isfile(model_path) else None
    key = jax.random.fold_in(jax.random.key(seed), d)
    actions, curves, behaviour, obj, times = train_data_set(
        data, cfg, acfg, key, seeds, lean=(d == 0), log=log
    )
    truth_table = truth_tables(model, data) if model is not None else None
    # the unified objective per step as the methods see it: p . scale / (1 - gamma)
    coeff = UNIFIED * np.asarray(obj.scale, np.float64) / (1.0 - cfg.gamma)
    if truth_table is not None:
        actions["oracle"] = np.asarray(
            ncis_lib.oracle_actions(truth_table, jnp.asarray(coeff, jnp.float32))
        )[None]
    else:  # without a response model there is no oracle: Behavior-Clone stands in
        actions["oracle"] = actions["bc"][:1]
    leaning = actions["alg1"][seeds:]
    actions["alg1"] = actions["alg1"][:seeds]
    fig2 = None
    if d == 0:
        fig2 = fig2_scores(leaning, actions["alg1"][0], behaviour, data, truth_table)
    test_reward = np.asarray(data.reward[data.n_train :])
    logged = {"mean": signals(test_reward.mean(0))}
    if model is not None:
        users = np.asarray(data.user_index[data.n_train :])
        vids = data.video_ids[np.asarray(data.action[data.n_train :])]
        ctx = logged_contexts(model, data)
        logged["truth"] = signals(model.expected(data.user_ids[users], vids, ctx).mean(axis=0))
    size = {
        "data": os.path.abspath(data_dir),
        "rows": data.n_rows,
        "train_rows": data.n_train,
        "test_rows": data.n_rows - data.n_train,
        "users": len(data.user_ids),
        "candidates": data.n_candidates,
        "state_dim": data.state_dim,
        "j_ub": np.asarray(obj.j_ub).tolist(),
        "reward_scale": np.asarray(obj.scale).tolist(),
    }
    return {
        "name": os.path.basename(os.path.normpath(data_dir)),
        "protocol": protocol,
        "scores": score_rows(actions, behaviour, data, truth_table, coeff),
        "curves": curves,
        "times": {k: round(v, 1) for k, v in times.items()},
        "logged": logged,
        "size": size,
        "fig2": fig2,
        "has_truth": model is not None,
        "cpu_seconds": round(sum(resource.getrusage(resource.RUSAGE_SELF)[:2]), 1),
        "max_rss_gib": max_rss_gib(),
    }


def max_rss_gib() -> float:
    """This process's peak resident memory so far, GiB (Linux reports it in KiB)."""
    return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20, 3)


def run(
    data_dirs: list[str],
    out: str,
    cfg: offline.OfflineConfig,
    seed: int,
    log=print,
    version: str | None = None,
    seeds: int = 5,
    acfg: alg1.Alg1Config | None = None,
    n_boot: int = N_BOOT,
    parts: list | None = None,
    protocol: str = "default",
) -> dict:
    """The whole experiment; returns `table.json`'s content.

    Each of `data_dirs` is one data set (one data seed); on each, every method is trained
    with `seeds` training seeds. `version` is the KuaiRand layout (`27k`, `1k`, `pure`;
    by default found from the file names); `protocol` is `load`'s. `parts` (from
    `data_set_part`, e.g. run in separate processes) replace the training."""
    acfg = alg1.Alg1Config() if acfg is None else acfg
    t0 = time.perf_counter()
    merged = parts is not None
    if parts is None:
        parts = [
            data_set_part(d, p, cfg, acfg, seed, seeds, version, log, protocol)
            for d, p in enumerate(data_dirs)
        ]
    protocols = sorted({p.get("protocol", "default") for p in parts})
    if len(protocols) != 1:
        raise DataError(f"the parts were made under different protocols: {protocols}")
    rng = np.random.default_rng(seed)
    draws = [stats.draw(rng, p["size"]["test_rows"], seeds, n_boot) for p in parts]
    # the data sets resampled as well, from a generator of their own (the draws above,
    # and so every interval conditional on the data sets, stay as they were)
    set_draws = stats.draw_sets(np.random.default_rng([seed, 1]), len(parts), seeds, n_boot)
    has_truth = all(p["has_truth"] for p in parts)
    logged = [p["logged"] for p in parts]
    table = {
        "seeds": list(range(seeds)),
        "data_seeds": [p["name"] for p in parts],
        "unified_preference": UNIFIED.tolist(),
        "bootstrap": {
            "replicates": n_boot,
            "resampled": "test rows and training seeds within each data set",
            "data_sets_resampled": "gap_share_ci95_data_sets: data sets, then training "
            "seeds within each (from per_seed.json, generator numpy default_rng([seed, 1]): "
            "sets = integers(0, D, (B, D)), then seeds = integers(0, S, (B, D, S)))",
        },
        "methods": summarise([p["scores"] for p in parts], draws, has_truth, set_draws),
        "ncis_events": ncis_events(parts),
        "min_ncis_events": MIN_NCIS_EVENTS,
        "logged": {
            k: signals(np.mean([[li[k][s] for s in SIGNALS] for li in logged], axis=0))
            for k in logged[0]
        },
    }
    fig2 = {"prefs": leaning_prefs().tolist(), "signals": list(SIGNALS), **parts[0]["fig2"]}
    # this process's wall time; merged parts ran elsewhere (maybe side by side), and
    # their methods' seconds are added as they were measured
    total = time.perf_counter() - t0
    if merged:
        total += sum(sum(p["times"].values()) for p in parts)
    run_info = {
        "synthetic": has_truth,
        "protocol": protocols[0],
        "data_sets": [p["size"] for p in parts],
        "seeds": seeds,
        "config": asdict(cfg),
        "alg1_config": asdict(acfg),
        "seed": seed,
        "seconds": {"per_data_set": [p["times"] for p in parts], "total": round(total, 1)},
        # True: the data sets were trained in other processes (`--part`) and merged here,
        # so `total` adds times measured elsewhere; False: `total` is this one process's
        "merged_parts": merged,
        # CPU seconds of the processes: with other jobs on the machine, wall time
        # overstates what the run itself needs
        "cpu_seconds": [p["cpu_seconds"] for p in parts],
        # the peak resident memory of each process that held a data set, and of this one
        "max_rss_gib": [p.get("max_rss_gib") for p in parts] + [max_rss_gib()],
        "cpu_count": os.cpu_count(),
        "load_average_at_end": list(os.getloadavg()),
    }
    curves = {"points": CURVE_POINTS, "steps": cfg.steps, "data_sets": [p["curves"] for p in parts]}
    values = {
        "seed": seed,
        "seeds": list(range(seeds)),
        "data_sets": [{"name": p["name"], **per_seed(p["scores"])} for p in parts],
    }
    files = {
        "table.json": json.dumps(table, indent=2) + "\n",
        "per_seed.json": json.dumps(values) + "\n",
        "table.md": markdown(table, has_truth),
        "fig2.json": json.dumps(fig2, indent=2) + "\n",
        "run.json": json.dumps(run_info, indent=2) + "\n",
        "curves.json": json.dumps(curves) + "\n",
    }
    write_results(out, files, fig2)
    log(f"done in {total:.1f}s; wrote {out}")
    return table


def write_results(out: str, files: dict[str, str], fig2: dict) -> None:
    """Writes `files` (`{name: text}`) and `fig2.png` into a new directory beside `out`,
    then renames it to `out`, replacing a previous `out` whole (nothing of it is kept).

    Until the final renames the previous results stay as they were, so an interrupted
    write leaves them whole (and removes its own partial directory when it can).
    Missing parents of `out` are made.
    """
    out = os.path.abspath(out)
    parent, name = os.path.split(out)
    os.makedirs(parent, exist_ok=True)
    tmp = tempfile.mkdtemp(dir=parent, prefix=f".{name}.tmp-")
    try:
        for fname, text in files.items():
            with open(os.path.join(tmp, fname), "w") as f:
                f.write(text)
        plot_fig2(fig2, os.path.join(tmp, "fig2.png"))
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o777 & ~umask)  # as os.makedirs would have made it
        if os.path.lexists(out):
            # renaming a directory onto an empty one replaces it: the old results move
            # aside in one step, and go only once the new ones are in place
            old = tempfile.mkdtemp(dir=parent, prefix=f".{name}.old-")
            os.rename(out, old)
            os.rename(tmp, out)
            shutil.rmtree(old)
        else:
            os.rename(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def main(argv=None) -> int:
    parser = ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--data",
        required=True,
        nargs="+",
        help="KuaiRand directories (real or synthetic), one per data seed",
    )
    parser.add_argument(
        "--out", required=True, help="output directory (new or empty, unless --overwrite)"
    )
    parser.add_argument("--overwrite", action="store_true", help="replace a non-empty --out whole")
    parser.add_argument(
        "--version",
        choices=VERSIONS,
        default=None,
        help="the KuaiRand layout (default: found from the file names)",
    )
    parser.add_argument(
        "--protocol",
        choices=PROTOCOLS,
        default="default",
        help="how the offline transitions are built (wcac_jax.recsys.data.load)",
    )
    parser.add_argument("--quick", action="store_true", help="tiny settings (tests)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--steps", type=int, default=None, help="override the update steps")
    parser.add_argument("--seeds", type=int, default=5, help="training seeds per data set")
    parser.add_argument(
        "--part",
        type=int,
        default=None,
        help="train data set PART of --data only and save its scores to OUT, a file (new, "
        "unless --overwrite)",
    )
    parser.add_argument(
        "--merge", nargs="+", default=None, help="make the table from --part files, in order"
    )
    parser.add_argument(
        "--bc-weight",
        type=float,
        default=None,
        help="the behaviour-cloning term of every actor (0: the ablation without it)",
    )
    args = parser.parse_args(argv)
    cfg = QUICK if args.quick else DEFAULT
    try:
        if args.steps is not None:
            cfg = replace(cfg, steps=args.steps)
        if args.bc_weight is not None:
            cfg = replace(cfg, bc_weight=args.bc_weight)
        if args.seeds < 1:
            raise ValueError(f"--seeds must be >= 1, got {args.seeds}")
        if args.part is not None:  # --out is the part's file
            if not 0 <= args.part < len(args.data):
                n = len(args.data)
                raise ValueError(f"--part {args.part} is not an index of the {n} --data")
            if os.path.isdir(args.out):
                raise ValueError(f"--out {args.out!r} is a directory; --part writes a file")
            if os.path.lexists(args.out) and not args.overwrite:
                raise ValueError(f"--out {args.out!r} exists; pass --overwrite to replace it")
            problem = unwritable_dir(os.path.dirname(os.path.abspath(args.out)))
        else:
            problem = unwritable_dir(args.out)
        if problem:
            raise ValueError(f"--out {args.out!r} can't be written: {problem}")
        held = sorted(os.listdir(args.out)) if os.path.isdir(args.out) else []
        if held and not args.overwrite:
            shown = ", ".join(held[:3]) + (", ..." if len(held) > 3 else "")
            raise ValueError(
                f"--out {args.out!r} is not empty (holds {shown}); "
                "pass --overwrite to replace it whole"
            )
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    try:
        if args.part is not None:
            part = data_set_part(
                args.part,
                args.data[args.part],
                cfg,
                alg1.Alg1Config(),
                args.seed,
                args.seeds,
                args.version,
                print,
                args.protocol,
            )
            os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
            write_atomic(args.out, pickle.dumps(part))
            return 0
        parts = None
        if args.merge is not None:
            parts = []
            for path in args.merge:
                with open(path, "rb") as f:
                    parts.append(pickle.load(f))
        run(
            args.data,
            args.out,
            cfg,
            args.seed,
            version=args.version,
            seeds=args.seeds,
            n_boot=50 if args.quick else N_BOOT,
            parts=parts,
            protocol=args.protocol,
        )
    except DataError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except offline.TrainingError as err:
        print(f"error: {err}; nothing written", file=sys.stderr)
        return 3
    return 0


if __name__ == "__main__":
    sys.exit(main())
