"""The paper's recommendation experiment (Table 2 and Fig. 2) on a KuaiRand directory.

    python experiments/kuairand_table2.py --data DIR --out OUT [--quick] [--seed S]
        [--version 27k|1k|pure] [--overwrite]

reads `DIR` (real KuaiRand-27K, -1K or -Pure files, found by their names, or
`python -m wcac_jax.recsys.synth`'s), builds the protocol's offline transitions,
trains Behavior-Clone and the four actor-critics (the paper's method `wcac`, PDPG,
MOAC, MOCHA; `wcac_jax.recsys.offline`) with the unified preference, and the paper's
method with 7 preferences each leaning to one signal (Fig. 2) in the same compiled
program, then scores every policy on the test rows by NCIS against Behavior-Clone and,
when `DIR` holds the generator's response model, by its true expected signals. Writes to `OUT`:

- `table.json`: `{"methods": {name: {"ncis": {signal: v}, "vs_bc": {signal: %},
  "truth": {signal: v}}}, "logged": {...}}` (`truth` only on synthetic data);
- `table.md`: the Table 2 analogue; `fig2.png`, `fig2.json`: the Fig. 2 analogue;
- `run.json`: configuration, sizes and wall-clock times.

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
import resource
import shutil
import sys
import tempfile
import time
from dataclasses import asdict, replace

import jax
import jax.numpy as jnp
import numpy as np

from wcac_jax.outputs import unwritable_dir
from wcac_jax.recsys import ncis as ncis_lib
from wcac_jax.recsys import offline
from wcac_jax.recsys.cli import ArgumentParser
from wcac_jax.recsys.data import SIGNALS, DataError, Protocol, load
from wcac_jax.recsys.kuairand import VERSIONS
from wcac_jax.recsys.synth import MODEL_FILE, ResponseModel

NAMES = {
    "bc": "Behavior-Clone",
    "moac": "MOAC (linear)",
    "mocha": "MOCHA (linear)",
    "pdpg": "PDPG (DNN)",
    "wcac": "wcac (DNN, the paper's method)",
}
ORDER = ("bc", "moac", "mocha", "pdpg", "wcac")
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
UNIFIED = np.full(7, 1.0 / 7)
LEAN = 0.4  # a leaning preference: 0.4 on its signal, 0.1 on each of the six others


def leaning_prefs() -> np.ndarray:
    """`[7, 7]`: row `i` puts `LEAN` on signal `i` and the rest evenly on the others."""
    p = np.full((7, 7), (1.0 - LEAN) / 6)
    np.fill_diagonal(p, LEAN)
    return p


QUICK = offline.OfflineConfig(steps=40, batch_size=32, width=16, critic_warmup=0.25)


def _test_actions(act, params, data: Protocol, prefs_axis: bool, chunk: int = 4096):
    """The policy's `action(s)` on every test row: `[P, n_test]` (or `[n_test]`)."""
    fn = jax.jit(jax.vmap(act, in_axes=(0, None)) if prefs_axis else act)
    out = []
    for start in range(data.n_train, data.n_rows, chunk):
        rows = jnp.arange(start, min(start + chunk, data.n_rows))
        out.append(np.asarray(fn(params, offline.net_input(data, rows))))
    return np.concatenate(out, axis=-1)


def _truth_tables(model: ResponseModel, data: Protocol):
    """`[n_test, C, 7]` true expected signals of each candidate for each test row's user."""
    users = np.asarray(data.user_index[data.n_train :])
    uniq, inv = np.unique(users, return_inverse=True)
    table = model.expected(data.user_ids[uniq][:, None], data.video_ids[None, :])
    return jnp.asarray(table[inv], jnp.float32)


def _percent(diff: float, ref: float):
    """`100 diff / |ref|`, or None (JSON null) when `ref` is 0."""
    return None if ref == 0 else 100.0 * float(diff) / abs(float(ref))


def _fmt(v: float, scale: float) -> str:
    return f"{v * scale:.3f}"


def markdown(table: dict, has_truth: bool) -> str:
    """The Table 2 analogue: NCIS (% vs Behavior-Clone), and the true value below."""
    head = "| | " + " | ".join(c[1] for c in COLUMNS) + " |"
    lines = [head, "|---" * (len(COLUMNS) + 1) + "|"]
    for key in ORDER:
        name = NAMES[key]
        row = table["methods"][name]
        cells = []
        for sig, _, scale in COLUMNS:
            cell = _fmt(row["ncis"][sig], scale)
            if key != "bc":
                pct = row["vs_bc"][sig]
                cell += " (n/a)" if pct is None else f" ({pct:+.1f}%)"
            if has_truth:
                cell += f" <br>true {_fmt(row['truth'][sig], scale)}"
            cells.append(cell)
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    if has_truth:
        logged = table["logged"]["truth"]
        cells = [_fmt(logged[s], scale) for s, _, scale in COLUMNS]
        lines.append("| (logged policy, true) | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


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


def run(
    data_dir: str,
    out: str,
    cfg: offline.OfflineConfig,
    seed: int,
    log=print,
    version: str | None = None,
) -> dict:
    """The whole experiment; returns `table.json`'s content. `version` is the KuaiRand
    layout (`27k`, `1k`, `pure`; by default found from the file names)."""
    t0 = time.perf_counter()
    data = load(data_dir, version=version)
    t_load = time.perf_counter() - t0
    log(
        f"loaded {data.n_rows} rows ({data.n_train} train), state {data.state_dim} dims "
        f"in {t_load:.1f}s"
    )
    obj = offline.objectives(data, cfg.gamma, cfg.ub_margin)
    model_path = os.path.join(data_dir, MODEL_FILE)
    model = ResponseModel.load(model_path) if os.path.isfile(model_path) else None
    keys = jax.random.split(jax.random.key(seed), len(ORDER))
    times = {"load": t_load}

    test_reward = data.reward[data.n_train :]
    logged = data.action[data.n_train :].astype(jnp.float32)

    t = time.perf_counter()
    bc_train, bc_act = offline.make_train_bc(cfg, data)
    bc_params, bc_losses = jax.jit(bc_train)(keys[0], data)
    offline.check_finite(NAMES["bc"], "loss", bc_losses)
    behaviour = _test_actions(bc_act, bc_params, data, prefs_axis=False)
    times["bc"] = time.perf_counter() - t
    log(
        f"Behavior-Clone: loss {float(bc_losses[0]):.3f} -> {float(bc_losses[-1]):.3f}, "
        f"{times['bc']:.1f}s"
    )

    actions = {"bc": behaviour[None]}
    curves = {}
    for i, method in enumerate(ORDER[1:], 1):
        prefs = np.vstack([UNIFIED, leaning_prefs()]) if method == "wcac" else UNIFIED[None]
        t = time.perf_counter()
        train, act = offline.make_train(method, cfg, data)
        sweep = jax.jit(jax.vmap(train, in_axes=(0, 0, None, None)))
        pkeys = jax.random.split(keys[i], prefs.shape[0])
        state, metrics = sweep(pkeys, jnp.asarray(prefs, jnp.float32), data, obj)
        jax.block_until_ready(state)
        offline.check_finite(NAMES[method], "critic loss", metrics["train/critic_loss"])
        offline.check_finite(NAMES[method], "mean action", metrics["train/mean_action"])
        actions[method] = _test_actions(act, state.actor, data, prefs_axis=True)
        times[method] = time.perf_counter() - t
        curves[method] = {
            "critic_loss_first_last": [
                float(metrics["train/critic_loss"][0, 0]),
                float(metrics["train/critic_loss"][0, -1]),
            ],
            "final_weights": np.asarray(state.weights[0]).round(4).tolist(),
            "mean_test_action": float(actions[method][0].mean()),
        }
        log(
            f"{method}: P={prefs.shape[0]}, {times[method]:.1f}s, mean test action "
            f"{actions[method][0].mean():.1f} (logged {float(logged.mean()):.1f})"
        )

    truth_table = _truth_tables(model, data) if model is not None else None
    beh = jnp.asarray(behaviour)

    def score(target):
        target = jnp.asarray(target, jnp.float32)
        est = np.asarray(ncis_lib.ncis(target, beh, logged, test_reward))
        out = {"ncis": dict(zip(SIGNALS, est.tolist(), strict=True))}
        if truth_table is not None:
            true = np.asarray(ncis_lib.true_value(target, truth_table))
            out["truth"] = dict(zip(SIGNALS, true.tolist(), strict=True))
        return out

    table = {"methods": {}}
    scores = {k: score(actions[k][0]) for k in ORDER}
    bc_ncis = scores["bc"]["ncis"]
    for key in ORDER:
        s = scores[key]
        s["vs_bc"] = {sig: _percent(s["ncis"][sig] - bc_ncis[sig], bc_ncis[sig]) for sig in SIGNALS}
        table["methods"][NAMES[key]] = {k: s[k] for k in ("ncis", "vs_bc", "truth") if k in s}
    table["logged"] = {
        "mean": dict(zip(SIGNALS, np.asarray(test_reward.mean(0)).tolist(), strict=True))
    }
    if truth_table is not None:
        users = np.asarray(data.user_index[data.n_train :])
        vids = data.video_ids[np.asarray(data.action[data.n_train :])]
        true_logged = model.expected(data.user_ids[users], vids).mean(axis=0)
        table["logged"]["truth"] = dict(zip(SIGNALS, true_logged.tolist(), strict=True))

    # Fig. 2: the 7 leaning policies (rows 1..7 of wcac's sweep) against the unified (row 0)
    fig2 = {
        "prefs": leaning_prefs().tolist(),
        "signals": list(SIGNALS),
        "values": {},
        "improvement": {},
    }
    lean_scores = [score(a) for a in actions["wcac"]]
    sign = np.array([-1.0 if s == "hate" else 1.0 for s in SIGNALS])
    for kind in ("ncis", "truth"):
        if kind not in lean_scores[0]:
            continue
        vals = np.array([[sc[kind][s] for s in SIGNALS] for sc in lean_scores])  # [8, 7]
        ref = vals[0]
        fig2["values"][kind] = {"unified": ref.tolist(), "leaning": vals[1:].tolist()}
        # a reference of 0 (no event in the test rows) has no relative change: null
        rel = [[_percent(sign[j] * (v[j] - ref[j]), ref[j]) for j in range(7)] for v in vals[1:]]
        fig2["improvement"][kind] = rel

    total = time.perf_counter() - t0
    times["total"] = total
    run_info = {
        "data": os.path.abspath(data_dir),
        "synthetic": model is not None,
        "rows": data.n_rows,
        "train_rows": data.n_train,
        "test_rows": data.n_rows - data.n_train,
        "users": len(data.user_ids),
        "candidates": data.n_candidates,
        "state_dim": data.state_dim,
        "config": asdict(cfg),
        "seed": seed,
        "j_ub": np.asarray(obj.j_ub).tolist(),
        "reward_scale": np.asarray(obj.scale).tolist(),
        "training": curves,
        "seconds": {k: round(v, 1) for k, v in times.items()},
        # CPU seconds of this process: with other jobs on the machine, wall time overstates
        # what the run itself needs
        "cpu_seconds": round(sum(resource.getrusage(resource.RUSAGE_SELF)[:2]), 1),
        "cpu_count": os.cpu_count(),
        "load_average_at_end": list(os.getloadavg()),
    }
    files = {
        "table.json": json.dumps(table, indent=2) + "\n",
        "table.md": markdown(table, truth_table is not None),
        "fig2.json": json.dumps(fig2, indent=2) + "\n",
        "run.json": json.dumps(run_info, indent=2) + "\n",
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
    parser.add_argument("--data", required=True, help="a KuaiRand directory (real or synthetic)")
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
    parser.add_argument("--quick", action="store_true", help="tiny settings (tests)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--steps", type=int, default=None, help="override the update steps")
    args = parser.parse_args(argv)
    cfg = QUICK if args.quick else offline.OfflineConfig()
    try:
        if args.steps is not None:
            cfg = replace(cfg, steps=args.steps)
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
        run(args.data, args.out, cfg, args.seed, version=args.version)
    except DataError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except offline.TrainingError as err:
        print(f"error: {err}; nothing written", file=sys.stderr)
        return 3
    return 0


if __name__ == "__main__":
    sys.exit(main())
