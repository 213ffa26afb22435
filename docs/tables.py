"""Writes every measured number of README.md and docs/*.md from the committed results.

Each table sits between `<!-- table:NAME -->` and `<!-- /table -->`, each number in prose
between `<!-- value:NAME -->` and `<!-- /value -->`; this script rewrites what lies between
them from `experiments/results/` and nothing else, so a number in the documentation is
always the one a committed result holds, with a link to it.

    python docs/tables.py           # rewrite the blocks in place
    python docs/tables.py --check   # exit 1, naming each block that differs

It reads JSON only, and computes with the package's front metrics (`wcac_jax.pareto`,
numpy only: no JAX is loaded), so it runs anywhere in a second.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import re
import sys
from collections.abc import Callable
from functools import cache, partial

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)  # this checkout's package, beside the results it reads

from wcac_jax import pareto  # noqa: E402

RES = "experiments/results"

# Results by what they are; every input path of this script is here.
W = f"{RES}/walker2d_front_practical_v5"
R = {
    # the first command (`wcac-sweep --n-prefs 9`), under today's default and the earlier one
    "cli_default": [f"{RES}/cli_default_front_select5/seed{s}" for s in range(3)],
    "cli_final_default": [f"{RES}/cli_default_front_final/seed{s}" for s in range(3)],
    # the practical front on Walker2d (walker2d_front.py), the paper's nine preferences
    "front_default": f"{W}_e5x16_select5_with_linear",
    "front_preset": f"{W}_e5x16/seed0",
    "preset_seeds": [f"{W}_e5x16/seed{s}" for s in range(17)],
    "select5_seeds": [f"{W}_e5x16_select5/seed{s}" for s in range(17)],
    "linear_seeds": [f"{W}_e5x16/seed0"] + [f"{W}_e5x16_linear/seed{s}" for s in (1, 2)],
    "margin002": [f"{W}_e5x16_margin002/seed{s}" for s in range(3)],
    "margin005": [f"{W}_e5x16_margin005/seed{s}" for s in range(17)],
    "mu5": [f"{W}_e5x16_mu5/seed{s}" for s in range(17)],
    "anneal": [f"{W}_e5x16_anneal/seed{s}" for s in range(3)],
    "n32": [f"{W}_e5x16_n32/seed{s}" for s in range(3)],
    "aug001": [f"{W}_e5x16_aug001"],
    "aug005": [f"{W}_e5x16_aug005/seed{s}" for s in range(3)],
    "fixed_utopia": [f"{W}_e5x16_fixed_utopia"],
    "e5x32": [f"{W}_e5x32"],
    "front_w128": f"{W}_e10x8_w128/seed0",
    "front_w128_seed1": f"{W}_e10x8_w128/seed1",
    "front_w128_fixed": f"{W}_e10x8_w128_fixed_utopia",
    "front_w64": f"{W}_e10x8_w64",
    # the paper's recipe on Walker2d
    "front_paper_v5": f"{RES}/walker2d_front_paper_v5",
    "front_paper_warm_1M": f"{RES}/walker2d_front_paper_warm_brax_1M",
    "front_paper_warm_20pct": f"{RES}/walker2d_front_paper_warm_brax_20pct",
    # [1, 0] curves (the last one also holds the paper preset's) and depth/width ablations
    "curves": [
        f"{RES}/walker2d_curves_v5_e5x16_w128",
        f"{RES}/walker2d_curves_v5_e10x8_w128",
        f"{RES}/walker2d_curves_v5_e5x32_w128",
        f"{RES}/walker2d_curves_v5_e10x8_w64",
    ],
    "ablation_practical": f"{RES}/walker2d_ablation_practical_v5_e5x16",
    "ablation_practical_10x8": f"{RES}/walker2d_ablation_practical_v5_e10x8",
    "ablation_paper_v5": f"{RES}/walker2d_ablation_paper_v5",
    "ablation_paper_v5_10pct": f"{RES}/walker2d_ablation_paper_v5_10pct",
    "ablation_paper_warm_1M": f"{RES}/walker2d_ablation_paper_warm_brax_1M",
    "ablation_paper_warm_10pct": f"{RES}/walker2d_ablation_paper_warm_brax_10pct",
    # problems with known answers
    "exploration": f"{RES}/exploration/exploration.json",
    "convergence": f"{RES}/convergence/convergence.json",
    # benchmarks
    "bench_practical": [
        f"{RES}/bench_practical_e5x16_w128_mujoco_v5_9x16_repeat{s}.json" for s in range(1, 5)
    ]
    + [
        f"{RES}/bench_practical_e10x8_w128_mujoco_v5_9x16.json",
        f"{RES}/bench_practical_e10x8_w64_mujoco_v5_9x16_repeat1.json",
        f"{RES}/bench_practical_e10x8_w64_mujoco_v5_9x16_repeat2.json",
    ],
    "reference_ppo": [
        f"{RES}/reference_ppo_repeat1_seed0.json",
        f"{RES}/reference_ppo_repeat1_seed1.json",
    ]
    + [f"{RES}/reference_ppo_repeat2_seed{s}.json" for s in range(4)]
    + [f"{RES}/reference_ppo_repeat3_seed0.json"],
    "bench_env": f"{RES}/bench_env_mjx_models.json",
    "bench_env_engines": f"{RES}/bench_env_drift_engines.json",
    "bench_engines": f"{RES}/bench_paper_engine_grid.json",
    "bench_mjx_9x128": f"{RES}/bench_paper_mjx_v5_9x128.json",
    "bench_throughput": f"{RES}/bench_paper_mjx_brax_9x16.json",
    "bench_processes": f"{RES}/bench_processes_cpu.json",
    "bench_cli_v5": f"{RES}/bench_cli_paper_mujoco_v5_100k/front.json",
    "bench_cli_v5_loaded": f"{RES}/bench_cli_paper_mujoco_v5_100k/front_loaded.json",
    # the recommendation experiment
    "kuairand": f"{RES}/kuairand",
    "kuairand_headroom": f"{RES}/kuairand_headroom",
    "kuairand_no_bc": f"{RES}/kuairand_no_bc",
    "conditioned": f"{RES}/conditioned_walker2d",
    "mo_mujoco": f"{RES}/mo_mujoco",
    # one run per task family re-evaluated in MO-Gymnasium (`python -m wcac_jax.evaluate`)
    "mo_gymnasium_eval": f"{RES}/mo_gymnasium_eval",
    # the field's protocols (`experiments/field.py`)
    "field": f"{RES}/field",
    "kuairand_paper_scale": f"{RES}/kuairand_paper_scale",
}

STATED_REF = (-500.0, -3000.0)  # Walker2d's default_hv_ref at T = 500
EPISODES, T = 8, 500  # the Walker2d evaluations' episodes and time limit
MINUS = "\u2212"


# ---------------------------------------------------------------- reading and formatting


def load(path: str) -> dict:
    """A results file by its path in the repository (`ROOT`)."""
    return _load(os.path.join(ROOT, path))


@cache
def _load(full: str) -> dict:
    with open(full) as f:
        return json.load(f)


def find(pattern: str) -> list[str]:
    """The paths under the repository that match `pattern`, relative to it, sorted."""
    return sorted(os.path.relpath(p, ROOT) for p in glob.glob(os.path.join(ROOT, pattern)))


def num(x: float | None, digits: int = 0) -> str:
    """`1,234.5` with a typographic minus; `–` for a missing value."""
    if x is None:
        return "–"
    s = f"{x:,.{digits}f}"
    if s.lstrip("-").strip("0.,") == "":
        s = s.lstrip("-")  # no "-0.00"
    return s.replace("-", MINUS)


def pct(x: float, digits: int = 1) -> str:
    s = num(x, digits)
    return ("" if s.startswith(MINUS) else "+") + s + "%"


def pref_str(p) -> str:
    return "[" + ", ".join(f"{v:g}" for v in p) + "]"


class Doc:
    """Where a block is written: links are made relative to this file."""

    def __init__(self, path: str):
        self.dir = os.path.dirname(path)

    def link(self, text: str, target: str) -> str:
        return f"[{text}]({os.path.relpath(target, self.dir or '.')})"


# ---------------------------------------------------------------- fronts


def speed_and_control(forward: float, control: float, length: float) -> tuple[float, float]:
    """Mean forward speed (m/s) and control energy per step of one evaluated policy.

    The reward per step is `[x_velocity, -sum(a^2)] + healthy`, healthy 1 on every step but
    a falling one, so with `f` falls per episode the healthy steps are `L - f` and the
    speed is `(R0 - L + f) / L`. Where the mean length leaves `f` open, the middle of its
    range (its ends differ by less than `1 / L`), as `experiments/walker2d_common.py` does.
    """
    total = round(EPISODES * length)
    if total - EPISODES < T - 1:
        lo = hi = 1.0  # every episode fell
    else:
        s_max = (EPISODES * length - EPISODES) // (T - 1)
        lo = max(0.0, 1.0 - s_max / EPISODES)
        hi = min(1.0, max(lo, length - control))
    f = (lo + hi) / 2
    return (forward - length + f) / length, (length - f - control) / length


def nondominated(points) -> list[bool]:
    """Which of `points` `[n, 2]` no other point dominates (`pareto.nondominated`)."""
    return pareto.nondominated(points).tolist()


def hypervolume(points, ref=STATED_REF) -> float:
    return pareto.hypervolume(points, ref)


class Front:
    """One evaluated front: preferences, undiscounted returns, mean lengths."""

    def __init__(self, prefs, returns, lengths, source: str, meta: dict):
        self.prefs = [list(p) for p in prefs]
        self.returns = [tuple(float(v) for v in r) for r in returns]
        self.lengths = [float(v) for v in lengths]
        self.source = source  # the file it was read from
        self.meta = meta  # the run's front.json (wall_s, env_steps_per_s, selection, ...)

    @property
    def nd(self) -> list[bool]:
        return nondominated(self.returns)

    @property
    def n_nd(self) -> int:
        return sum(self.nd)

    @property
    def spearman(self) -> float:
        return pareto.rank_correlation([p[0] for p in self.prefs], [r[0] for r in self.returns])

    def hv(self, ref=STATED_REF) -> float:
        return hypervolume(self.returns, ref)

    def outside(self, ref) -> int:
        return sum(1 for r in self.returns if not (r[0] > ref[0] and r[1] > ref[1]))

    def row(self, pref) -> int:
        return self.prefs.index(list(pref))

    def sc(self, i: int) -> tuple[float, float]:
        return speed_and_control(*self.returns[i], self.lengths[i])

    @property
    def forward_end(self) -> tuple[float, float]:
        """`[1, 0]`'s speed and mean length."""
        i = self.row([1.0, 0.0])
        return self.sc(i)[0], self.lengths[i]

    @property
    def walks(self) -> bool:
        speed, length = self.forward_end
        return speed >= 2.5 and length >= 450

    @property
    def control_end(self) -> float:
        return self.returns[self.row([0.0, 1.0])][1]

    def final(self) -> Front:
        """The same training's final policies (a run that chose among its last ones)."""
        sel = self.meta["selection"]
        return Front(self.prefs, sel["final_return"], sel["final_length"], self.source, {})


def front_of(run: str, direction: str = "smooth_wc") -> Front:
    """A front from a sweep directory (`front.json`) or a `walker2d_front.py` output."""
    path = f"{run}/front.json"
    if not os.path.exists(os.path.join(ROOT, path)):
        path = f"{run}/{direction}/front.json"
    d = load(path)
    rows = d["prefs"]
    return Front(
        [r["pref"] for r in rows],
        [r["return"] for r in rows],
        [r["episode_length"] for r in rows],
        path,
        d,
    )


def union_nd(a: Front, b: Front) -> tuple[int, int]:
    nd = nondominated(a.returns + b.returns)
    return sum(nd[: len(a.returns)]), sum(nd[len(a.returns) :])


# ---------------------------------------------------------------- tables


def md(header: list[str], rows: list[list[str]], align: str | None = None) -> str:
    align = align or "-" * len(header)
    sep = ["---:" if a == "r" else "---" for a in align]
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(sep) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def conditioned_glance(doc: Doc) -> list[str]:
    """The glance row of the one conditioned network (`conditioned_walker2d`'s seeds)."""
    path = f"{R['conditioned']}/summary.json"
    summary = d9 = load(path)
    runs = sorted(summary["runs"]["conditioned"].items(), key=lambda kv: int(kv[0]))
    cell = lambda key, fmt: ", ".join(doc.link(fmt(r[key]), path) for _, r in runs)  # noqa: E731
    nine = d9["means"]["independent_9x1M"]["hv_morl_baselines"]
    return [
        "`walker2d --conditioned`",
        "one preference-conditioned network, 3M env steps in all, 33 preferences evaluated",
        f"seeds {', '.join(s for s, _ in runs)}: HV (morl-baselines) "
        f"{cell('hv_morl_baselines', sci)} (nine policies of 1M each: "
        f"{doc.link(sci(nine), path)}); `[1, 0]` walks at "
        f"{cell('forward_end_speed', lambda v: num(v, 2))} m/s; "
        f"Spearman {cell('spearman_p0_forward', lambda v: num(v, 2))}",
        f"{cell('wall_s', lambda v: num(v / 60, 1))} min",
    ]


def t_glance(doc: Doc) -> str:
    fronts = [front_of(r) for r in R["cli_default"]]
    nd = ", ".join(doc.link(str(f.n_nd), f.source) for f in fronts)
    sp = ", ".join(doc.link(num(f.forward_end[0], 2), f.source) for f in fronts)
    rho = ", ".join(doc.link(num(f.spearman, 2), f.source) for f in fronts)
    wall = ", ".join(doc.link(num(f.meta["wall_s"] / 60, 1), f.source) for f in fronts)
    ex = load(R["exploration"])["problems"]
    bandit, dst = ex["concave_bandit"]["directions"], ex["deep_sea_treasure"]["directions"]
    conv = load(R["convergence"])["results"]
    worst = max(p["final_over_initial"] for p in conv[0]["prefs"])
    ln = lambda text: doc.link(text, R["exploration"])  # noqa: E731
    rows = [
        [
            "`walker2d`",
            "practical update, 1M env steps per preference, best of the last 5 policies",
            f"seeds 0, 1, 2: {nd} of 9 points non-dominated; `[1, 0]` walks at {sp} m/s; "
            f"Spearman(`p₀`, forward) {rho}",
            f"{wall} min",
        ],
        conditioned_glance(doc),
        [
            "`concave_bandit`",
            "paper's update tuned for the bandit, `--n-prefs 11`",
            f"{ln(str(bandit['smooth_wc']['distinct_points']))} distinct points on the exact "
            f"non-convex front, largest gap {ln(num(bandit['smooth_wc']['largest_theta_gap'], 3))}"
            f" rad (linear: {ln(str(bandit['linear']['distinct_points']))}, the two ends)",
            "not recorded",
        ],
        [
            "`deep_sea_treasure`",
            "paper's update with Adam on `d`",
            f"{ln(str(dst['smooth_wc']['points_near_front']))} of 11 points on the convex "
            f"front, {ln(str(dst['smooth_wc']['distinct_points']))} distinct (linear: "
            f"{ln(str(dst['linear']['distinct_points']))})",
            "not recorded",
        ],
        [
            "`tabular_momdp`",
            "paper's update, `α/(t+1)`",
            "gap to the exact smoothed-WC optimum: "
            f"{doc.link(num(100 * worst, 2) + '%', R['convergence'])} of the initial gap",
            "not recorded",
        ],
    ]
    return md(["`--env`", "default", "what the front achieves", "wall, 2-core CPU"], rows)


def fallen_prefs(f) -> str:
    """The preferences of front `f` whose mean episode length is under the time limit,
    each with that length (empty when every policy lasts its episodes)."""
    return ", ".join(
        f"`{pref_str(p)}` ({num(length, 0)})"
        for p, length in zip(f.prefs, f.lengths, strict=True)
        if length < T
    )


def t_cli_default(doc: Doc) -> str:
    rows = []
    for seed, run in enumerate(R["cli_default"]):
        f = front_of(run)
        g = f.final()
        s, n = f.forward_end
        gs, gn = g.forward_end
        falls = fallen_prefs(f)
        rows.append(
            [
                doc.link(str(seed), f.source),
                f"{g.n_nd} → **{f.n_nd}** of 9",
                f"{num(g.spearman, 2)} → **{num(f.spearman, 2)}**",
                f"{num(gs, 2)} / {num(gn)} → **{num(s, 2)} m/s, {num(n)}**",
                f"{num(g.control_end)} → {num(f.control_end)}",
                falls or "none",
                f"{num(g.hv())} → {num(f.hv())}",
                num(f.meta["wall_s"]),
            ]
        )
    head = [
        "seed",
        "non-dominated: final → chosen",
        "Spearman (`p₀`, forward)",
        "`[1, 0]`: speed, mean length",
        "`[0, 1]` control return",
        "falls in some episodes (mean length), chosen",
        "HV, stated ref",
        "wall s",
    ]
    return md(head, rows, "llllllrr")


def t_cli_final_default(doc: Doc) -> str:
    rows = []
    for seed, run in enumerate(R["cli_final_default"]):
        f = front_of(run)
        s, n = f.forward_end
        falls = fallen_prefs(f)
        rows.append(
            [
                doc.link(str(seed), f.source),
                f"{f.n_nd} of 9",
                num(f.spearman, 2),
                f"{num(s, 2)} m/s, {num(n)}",
                num(f.control_end),
                falls or "none",
                num(f.hv()),
                num(f.meta["wall_s"]),
            ]
        )
    head = ["seed", "non-dominated", "Spearman", "`[1, 0]`: speed, mean length"]
    head += ["`[0, 1]` control", "falls in some episodes (mean length)", "HV, stated ref"]
    return md(head + ["wall s"], rows, "lrrlrlrr")


def t_cli_film(doc: Doc) -> str:
    run = R["cli_final_default"][1]
    f = front_of(run)
    film = load(f"{run}/film.json")["policies"]
    rows = []
    for i, p in enumerate(f.prefs):
        s, c = f.sc(i)
        fp = film[i]
        seen = "falls" if fp["fell"] else f"{num(fp['distance_m'], 2)} m"
        r = f.returns[i]
        rows.append(
            [f"`{pref_str(p)}`", f"{num(r[0])}, {num(r[1])}", num(f.lengths[i], 1)]
            + [num(s, 2), num(c, 2), seen]
        )
    head = ["`p`", "forward, control return", "length", "speed m/s", "control/step"]
    return md(head + [doc.link("in the film (300 steps)", f"{run}/film.json")], rows, "lrrrrl")


def per_pref(doc: Doc, run: str, directions=("smooth_wc", "linear")) -> str:
    fronts = [front_of(run, d) for d in directions]
    head = ["`p`"]
    for d, f in zip(directions, fronts, strict=True):
        head += [f"{doc.link(f'`{d}`', f.source)}: forward, control", "length", "m/s", "ctrl/step"]
    rows = []
    for i, p in enumerate(fronts[0].prefs):
        row = [pref_str(p)]
        for f in fronts:
            s, c = f.sc(i)
            row += [f"{num(f.returns[i][0])}, {num(f.returns[i][1])}", num(f.lengths[i], 1)]
            row += [num(s, 2), num(c, 2)]
        rows.append(row)
    return md(head, rows, "l" + "lrrr" * len(fronts))


HV_REFS = (STATED_REF, (-100.0, -300.0), (-100.0, -100.0))


def summary_rows(doc: Doc, named: list[tuple[str, Front, Front | None]]) -> str:
    head = ["front", "HV (−500, −3000), the stated ref", "HV (−100, −300)", "HV (−100, −100)"]
    head += ["non-dominated (own; in the union)", "Spearman `p₀` vs forward", "wall s"]
    rows = []
    for name, f, other in named:
        hv = [
            num(f.hv(ref)) + (f" ({f.outside(ref)} outside)" if f.outside(ref) else "")
            for ref in HV_REFS
        ]
        own = f"{f.n_nd} of 9" + (f"; {union_nd(f, other)[0]}" if other else "")
        rows.append(
            [doc.link(name, f.source)] + hv + [own, num(f.spearman, 2), num(f.meta.get("wall_s"))]
        )
    return md(head, rows, "lrrrrrr")


def two_directions(doc: Doc, run: str, paper: bool = False) -> str:
    s, lin = front_of(run, "smooth_wc"), front_of(run, "linear")
    named = [("`smooth_wc`", s, lin), ("`linear`", lin, s)]
    if paper:
        ps, pl = front_of(R["front_paper_v5"], "smooth_wc"), front_of(R["front_paper_v5"], "linear")
        named += [("paper preset, `smooth_wc`", ps, pl), ("paper preset, `linear`", pl, ps)]
    return summary_rows(doc, named)


def seeds_table(doc: Doc, key: str, selection: bool = False) -> str:
    rows, fronts = [], [front_of(r) for r in R[key]]
    for seed, f in enumerate(fronts):
        s, n = f.forward_end
        row = [doc.link(str(seed), f.source)]
        if selection:
            g = f.final()
            gs, gn = g.forward_end
            chosen = f.meta["selection"]["chosen_iteration"]
            last = max(f.meta["selection"]["candidate_iterations"])
            row += [
                f"{g.n_nd} → **{f.n_nd}**",
                str(sum(c != last for c in chosen)),
                f"{num(gs, 2)} / {num(gn)} → {num(s, 2)} / {num(n)}",
                f"{num(g.spearman, 2)} → {num(f.spearman, 2)}",
                f"{num(g.hv())} → {num(f.hv())}",
            ]
        else:
            row += [
                f"{num(s, 2)} m/s, {num(n, 1)}",
                num(f.control_end),
                f"{f.n_nd} of 9",
                num(f.spearman, 2),
                num(f.hv()),
                num(f.hv((-100.0, -100.0))),
            ]
        rows.append(row + [num(f.meta["wall_s"])])
    if selection:
        head = ["seed", "non-dominated: final → chosen", "choices not the final policy"]
        head += ["`[1, 0]` m/s / length", "Spearman", "HV, stated ref", "wall s"]
        return md(head, rows, "llrlllr")
    head = ["seed", "`[1, 0]`: speed, length", "`[0, 1]` control", "non-dominated"]
    head += ["Spearman", "HV (stated ref)", "HV (−100, −100)", "wall s"]
    return md(head, rows, "llrrrrrr")


def rule_row(name: str, fronts: list[Front]) -> list[str]:
    nds = [f.n_nd for f in fronts]
    mean = lambda xs: sum(xs) / len(xs)  # noqa: E731
    return [
        name,
        str(len(fronts)),
        ", ".join(map(str, nds)),
        str(sum(n >= 7 for n in nds)),
        f"{sum(nds)} of {9 * len(fronts)}",
        str(sum(f.walks for f in fronts)),
        str(sum(f.spearman >= 0.9 - 1e-9 for f in fronts)),
        str(sum(f.control_end >= 400 for f in fronts)),
        num(mean([f.hv() for f in fronts])),
        num(mean([f.hv((-100.0, -100.0)) for f in fronts])),
    ]


RULE_HEAD = [
    "configuration",
    "seeds",
    "non-dominated, per seed",
    "≥ 7 of 9",
    "total",
    "`[1, 0]` walks",
    "Spearman ≥ 0.9",
    "`[0, 1]` control ≥ 400",
    "HV, stated ref, mean",
    "HV (−100, −100), mean",
]


def variants(doc: Doc, named: list[tuple], direction: str = "smooth_wc") -> str:
    """One row per configuration: `(label, key of R, first n seeds or None for all[,
    direction])`."""
    rows = []
    for label, key, n, *d in named:
        runs = R[key][:n] if n else R[key]
        fronts = [front_of(r, d[0] if d else direction) for r in runs]
        rows.append(rule_row(doc.link(label, fronts[0].source), fronts))
    return md(RULE_HEAD, rows, "lrlrrrrrrr")


def t_selection_rule(doc: Doc) -> str:
    fronts = [front_of(r) for r in R["select5_seeds"]]
    rows = [
        rule_row(
            doc.link("preset, final policies (committed)", R["preset_seeds"][0]),
            [front_of(r) for r in R["preset_seeds"]],
        ),
        rule_row("the same trainings' final policies", [f.final() for f in fronts]),
        rule_row(doc.link("**best of the last 5 (the default)**", fronts[0].source), fronts),
    ]
    return md(RULE_HEAD, rows, "lrlrrrrrrr")


def t_fixed_utopia_w128(doc: Doc) -> str:
    f = front_of(R["front_w128_fixed"])
    rows = [
        [
            pref_str(p),
            f"{num(r[0])}, {num(r[1])}, {num(n)}",
            "(" + ", ".join(num(x, 2) for x in row["lambda"]) + ")",
        ]
        for p, r, n, row in zip(f.prefs, f.returns, f.lengths, f.meta["prefs"], strict=True)
    ]
    return md(
        ["`p`", doc.link("forward, control return, length", f.source), "`λ` at the end"], rows
    )


def t_w128_seed1(doc: Doc) -> str:
    f = front_of(R["front_w128_seed1"])
    head = [doc.link("`p`", f.source)] + [pref_str(p) for p in f.prefs]
    r1 = ["forward, control return"] + [f"{num(r[0])}, {num(r[1])}" for r in f.returns]
    r2 = ["length; speed m/s"] + [
        f"{num(n)}; {num(f.sc(i)[0], 2)}" for i, n in enumerate(f.lengths)
    ]
    return md(head, [r1, r2])


def t_curves(doc: Doc) -> str:
    labels = {
        "walker2d_curves_v5_e5x16_w128": "practical (128 × 128, 5 × 16)",
        "walker2d_curves_v5_e10x8_w128": "practical, 10 × 8",
        "walker2d_curves_v5_e5x32_w128": "practical, 5 × 32",
        "walker2d_curves_v5_e10x8_w64": "practical, 64 × 64 and 10 × 8",
    }
    rows = []
    for run in R["curves"]:
        path = f"{run}/curves.json"
        d = load(path)
        for name, c in d["configs"].items():
            if name == "paper" and run != R["curves"][-1]:
                continue  # the paper preset's sweep is one, read back by the others
            cells = []
            for pol in c["policies"]:
                s, _ = speed_and_control(
                    pol["forward_return"], pol["control_return"], pol["episode_length"]
                )
                forward, length = pol["forward_return"], pol["episode_length"]
                cells.append(f"{num(forward, 1)}, {num(s, 2)} m/s, {num(length, 1)}")
            label = labels[os.path.basename(run)] if name != "paper" else "paper"
            mean = f"{num(c['eval_speed_mean'], 2)} m/s, {num(c['eval_length_mean'])}"
            rows.append([doc.link(label, path)] + cells + [mean, num(c.get("wall_s"))])
    head = [
        "preset",
        "seed 0: forward, speed, length",
        "seed 1",
        "seed 2",
        "mean speed, length",
        "wall s",
    ]
    return md(head, rows, "lllllr")


def ablation(doc: Doc, key: str, long: bool = True) -> str:
    path = f"{R[key]}/ablation.json"
    rows = []
    for s in load(path)["sizes"]:
        tf = s["train_forward_final"]
        mean = sum(tf) / len(tf)
        sd = (sum((x - mean) ** 2 for x in tf) / (len(tf) - 1)) ** 0.5  # over seeds, ddof 1
        small = abs(s["eval_forward_mean"]) < 100  # returns of walkers that fall at once
        dg = 1 if small else 0
        row = [str(s["depth"]), str(s["width"])]
        row += [f"{num(s['eval_forward_mean'], dg)} ± {num(s['eval_forward_std'], dg)}"]
        row += [
            ", ".join(num(v, dg) for v in s["eval_episode_length"]),
            f"{num(mean, dg)} ± {num(sd, dg)}",
        ]
        if long:
            speeds = [
                num(speed_and_control(f, c, n)[0], 2)
                for f, c, n in zip(
                    s["eval_forward_return"],
                    s["eval_control_return"],
                    s["eval_episode_length"],
                    strict=True,
                )
            ]
            row += [", ".join(speeds), num(s["env_steps_per_s"]), num(s["wall_s"])]
        rows.append(row)
    head = ["depth", "width", doc.link("eval forward return (mean ± sd)", path)]
    head += ["eval episode length per seed", "train forward return (last 5%)"]
    if long:
        head += ["eval speed m/s", "env-steps/s", "wall s"]
    return md(head, rows, "rrrlrlrr" if long else "rrrlr")


def t_paper_fronts(doc: Doc) -> str:
    named = []
    for label, key in (
        ("Algorithm 2, v5 model, 1M", "front_paper_v5"),
        ("warm critics, Brax model, 1M", "front_paper_warm_1M"),
        ("warm critics, Brax model, 200k", "front_paper_warm_20pct"),
    ):
        s, lin = front_of(R[key], "smooth_wc"), front_of(R[key], "linear")
        named += [(f"{label}, `smooth_wc`", s, lin), (f"{label}, `linear`", lin, s)]
    head = ["front", "HV, stated ref", "HV (−100, −100)", "non-dominated", "Spearman"]
    head += ["`[1, 0]`: forward, mean length", "`[0, 1]`: control per step, mean length", "wall s"]
    rows = []
    for name, f, _ in named:
        i, j = f.row([1.0, 0.0]), f.row([0.0, 1.0])
        ref = (-100.0, -100.0)
        rows.append(
            [
                doc.link(name, f.source),
                num(f.hv()),
                num(f.hv(ref)) + f" ({f.outside(ref)} outside)",
                f"{f.n_nd} of 9",
                num(f.spearman, 2),
                f"{num(f.returns[i][0], 1)}, {num(f.lengths[i], 1)}",
                f"{num(f.sc(j)[1], 2)}, {num(f.lengths[j], 1)}",
                num(f.meta["wall_s"]),
            ]
        )
    return md(head, rows, "lrrrrllr")


def t_exploration_bandit(doc: Doc) -> str:
    path = R["exploration"]
    d = load(path)["problems"]["concave_bandit"]["directions"]
    rows = [
        [
            doc.link(f"`{k}`", path),
            str(v["distinct_points"]),
            f"{num(v['median_theta_error'], 3)}, {num(v['max_theta_error'], 3)}",
            num(v["hypervolume_ratio"], 3),
            num(v["largest_theta_gap"], 3),
        ]
        for k, v in d.items()
    ]
    head = ["direction", "distinct points", "`|θ − θ*(p)|` median, max (rad)"]
    return md(head + ["HV / exact front's HV", "largest gap in θ (rad)"], rows, "lrrrr")


def t_exploration_dst(doc: Doc) -> str:
    path = R["exploration"]
    d = load(path)["problems"]["deep_sea_treasure"]["directions"]
    rows = []
    for k, v in d.items():
        near_opt = sum(x <= 1.0 for x in v["distance_to_wc_optimum"])
        rows.append(
            [
                doc.link(f"`{k}`", path),
                str(v["distinct_points"]),
                f"{v['points_near_front']} of 11",
                f"{near_opt} of 11",
                num(v["hypervolume_ratio"], 3),
                num(v["largest_gap_along_front"], 2),
            ]
        )
    head = ["direction", "distinct points", "on the front (within 1)", "within 1 of `p`'s optimum"]
    return md(head + ["HV / exact front's HV", "largest gap along the front"], rows, "lrrrrr")


def t_convergence(doc: Doc) -> str:
    path = R["convergence"]
    rows = []
    for r in load(path)["results"]:
        worst = max(p["final_over_initial"] for p in r["prefs"])
        slopes = ", ".join(("+" if p["slope"] > 0 else "") + num(p["slope"], 2) for p in r["prefs"])
        rows.append(
            [doc.link(f"`{r['setting']['name']}`", path), num(100 * worst, 2) + "%", slopes]
        )
    head = ["setting", "final gap / initial gap (worst of 3)", "log-log slope, 2nd half"]
    return md(head, rows, "lrl")


# ---------------------------------------------------------------- benchmarks


PRACTICAL_BENCH = {  # what each benchmark run of the practical update was
    "bench_practical_e5x16_w128_mujoco_v5_9x16_repeat1": "5 × 16, 128 × 128 (the preset)",
    "bench_practical_e5x16_w128_mujoco_v5_9x16_repeat2": "the same, another machine, 6 iterations",
    "bench_practical_e5x16_w128_mujoco_v5_9x16_repeat3": "the same, after three fronts",
    "bench_practical_e5x16_w128_mujoco_v5_9x16_repeat4": "the same, a slow day",
    "bench_practical_e10x8_w128_mujoco_v5_9x16": "10 × 8, 128 × 128 (the earlier preset)",
    "bench_practical_e10x8_w64_mujoco_v5_9x16_repeat1": "10 × 8, 64 × 64 (the first preset)",
    "bench_practical_e10x8_w64_mujoco_v5_9x16_repeat2": "10 × 8, 64 × 64, again",
}


def t_bench_practical(doc: Doc) -> str:
    rows = []
    for path in R["bench_practical"]:
        d = load(path)
        ms = d.get("ms_per_env_step") or {}
        name = os.path.basename(path).removesuffix(".json")
        rows.append(
            [
                doc.link(PRACTICAL_BENCH.get(name, name), path),
                num(d["raw"]["env_steps_per_s"]),
                num(d["sweep"]["env_steps_per_s"]),
                num(d["sweep_over_raw"], 2) + "×",
                f"{num(ms.get('physics'), 3)}, {num(ms.get('networks'), 3)}",
                num(d["sweep"].get("cores_busy"), 2),
            ]
        )
    head = ["update and run", "raw, 9 × 16 envs", "practical sweep", "sweep / raw"]
    head += ["physics, networks ms per env step", "cores busy (sweep)"]
    return md(head, rows, "lrrrlr")


def t_reference_ppo(doc: Doc) -> str:
    rows = []
    for path in R["reference_ppo"]:
        d = load(path)
        rows.append(
            [
                doc.link(os.path.basename(path).removesuffix(".json"), path),
                num(d["train_s"]),
                num(d["env_steps_per_s"]),
                num(d.get("cores_busy"), 2),
                f"{num(d['eval_mean_speed_m_per_s'], 2)} m/s, {num(d['eval_mean_length'])}",
            ]
        )
    head = [
        "run",
        "train s (1M env steps)",
        "env-steps/s",
        "cores busy",
        "policy: speed, mean length",
    ]
    return md(head, rows, "lrrrl")


def t_fronts_wall(doc: Doc) -> str:
    rows = []
    for label, key in (
        ("preset, final policies", "preset_seeds"),
        ("best of the last 5", "select5_seeds"),
    ):
        for seed, run in enumerate(R[key]):
            f = front_of(run)
            rows.append(
                [
                    label,
                    doc.link(str(seed), f.source),
                    num(f.meta["wall_s"]),
                    num(f.meta["env_steps_per_s"]),
                ]
            )
    return md(["front", "seed", "wall s", "env-steps/s"], rows, "llrr")


def t_bench_env(doc: Doc) -> str:
    path = R["bench_env"]
    d = load(path)
    by: dict[str, dict[int, float]] = {}
    for s in d["stepping"]:
        name = s["physics"].replace("-mujoco-solver", ", MuJoCo's solver (100/50)")
        by.setdefault(name, {})[s["batch"]] = s["env_steps_per_s"]
    batches = sorted({b for v in by.values() for b in v})
    rows = [[doc.link(f"`{k}`", path)] + [num(v.get(b)) for b in batches] for k, v in by.items()]
    return md(["physics (MJX)"] + [f"batch {b}" for b in batches], rows, "l" + "r" * len(batches))


def t_drift(doc: Doc) -> str:
    rows = []
    for key in ("bench_env", "bench_env_engines"):
        path = R[key]
        for q in load(path)["qpos_drift"]:
            at = q["max_abs_qpos_diff_at"]
            rows.append(
                [doc.link(" vs ".join(q["pair"]), path)]
                + [f"{at[k]:.1e}" for k in ("1", "10", "50", "100")]
            )
    return md(["pair", "after 1 step", "10", "50", "100"], rows, "lrrrr")


def t_bench_engines(doc: Doc) -> str:
    path = R["bench_engines"]
    d = load(path)
    rows = []
    for r in d["rows"] + [load(R["bench_mjx_9x128"])]:
        ms = r.get("ms_per_env_step") or {}
        raw, sw = r.get("raw") or {}, r.get("sweep") or {}
        rows.append(
            [
                f"`{r['engine']}`",
                f"`{r['physics']}`",
                f"{r['P']} × {r['N']}",
                num(raw.get("env_steps_per_s")),
                num(raw.get("cores_busy"), 2),
                num(sw.get("env_steps_per_s")),
                num(sw.get("cores_busy"), 2),
                f"{num(ms.get('physics'), 2)} / {num(ms.get('networks'), 2)}",
                r.get("source", os.path.basename(R["bench_mjx_9x128"])),
            ]
        )
    head = ["engine", "model", "P × N", "(a) raw", "cores (a)", "(b) sweep", "cores (b)"]
    head += ["physics / networks ms per env step", doc.link("source", path)]
    return md(head, rows, "lllrrrrll")


def t_quiet_raw(doc: Doc) -> str:
    path = R["bench_engines"]
    by: dict[str, dict[str, dict]] = {}
    for r in load(path)["quiet_raw_9x16"]:
        by.setdefault(r["physics"], {})[r["engine"]] = r["raw"]
    rows = []
    for model, v in by.items():
        mj, mx = v["mujoco"], v["mjx"]
        rows.append(
            [
                doc.link(f"`{model}`", path),
                f"{num(mj['env_steps_per_s'])} ({num(mj.get('cores_busy'), 2)})",
                f"{num(mx['env_steps_per_s'])} ({num(mx.get('cores_busy'), 2)})",
                num(mj["env_steps_per_s"] / mx["env_steps_per_s"], 1) + "×",
            ]
        )
    return md(["model", "`mujoco` (cores busy)", "`mjx` (cores busy)", "ratio"], rows, "lrrr")


def t_bench_throughput(doc: Doc) -> str:
    path = R["bench_throughput"]
    d = load(path)
    row = [
        doc.link(
            f"2-core CPU, `{d['physics']}`, w={d['width']}, D={d['depth']}, K=L={d['K']}", path
        ),
        f"{d['P']} × {d['N']}",
        num(d["raw"]["env_steps_per_s"]),
        num(d["sweep"]["env_steps_per_s"]),
        num(d["sequential"]["env_steps_per_s"]),
        num(d["sweep_over_raw"], 2),
        num(d["sweep_over_sequential"], 2),
        num(d["sweep"]["compile_s"]) + " s",
        num(d["peak_host_memory_gib"], 1) + " GiB",
    ]
    head = ["machine", "P × N", "(a) raw", "(b) sweep", "(c) sequential", "(b)/(a)", "(b)/(c)"]
    return md(head + ["compile (b)", "peak host memory"], [row], "llrrrrrrr")


def t_bench_processes(doc: Doc) -> str:
    path = R["bench_processes"]
    rows = []
    for r in load(path)["results"]:
        runs = r["runs"]
        cells = [
            f"{num(v['env_steps_per_s'])} env-steps/s, compile {num(v['compile_s'])} s"
            for v in (runs["1 process x 2 devices"], runs["2 processes x 1 device"])
        ]
        same = "identical" if r["fronts_identical"] else "differ"
        rows.append([doc.link(f"`{r['sweep']}`", path)] + cells + [same])
    return md(["sweep", "1 process × 2 devices", "2 processes × 1 device", "fronts"], rows, "lrrl")


def t_bench_cli(doc: Doc) -> str:
    rows = []
    for label, key in (
        ("quiet machine", "bench_cli_v5"),
        ("loaded machine", "bench_cli_v5_loaded"),
    ):
        d = load(R[key])
        rows.append(
            [
                doc.link(label, R[key]),
                num(d["env_steps_per_s"]),
                num(d["compile_s"], 1),
                num(d["wall_s"]),
                num(d["hypervolume"]),
            ]
        )
    return md(["run", "env-steps/s", "compile s", "wall s", "HV"], rows, "lrrrr")


# ---------------------------------------------------------------- recommendation

SIGNALS = ("click", "like", "follow", "comment", "forward", "hate", "watch_time")
SCALE = {"like": 1e2, "follow": 1e4, "comment": 1e3, "forward": 1e3, "hate": 1e4}
HEADS = ("Click↑", "Like↑ (e-2)", "Follow↑ (e-4)", "Comment↑ (e-3)", "Forward↑ (e-3)")
HEADS += ("Dislike↓ (e-4)", "WatchTime↑")


def ncis_few(d: dict) -> dict:
    """`{signal: logged events}` of the signals NCIS gives no verdict on: fewer logged
    events among the test rows than `min_ncis_events` (`kuairand_table2.py`)."""
    events = d.get("ncis_events", {})
    return {s: n for s, n in events.items() if n < d["min_ncis_events"]}


def kuairand(doc: Doc, key: str, kind: str) -> str:
    """Means over seeds and data sets; the change vs Behavior-Clone only where its 95%
    interval excludes 0 (else `n.s.`)."""
    path = f"{R[key]}/table.json"
    d = load(path)
    rel_key = "vs_bc" if kind == "ncis" else "truth_vs_bc"
    few = ncis_few(d) if kind == "ncis" else {}
    rows = []
    for name, m in d["methods"].items():
        cells = []
        for s in SIGNALS:
            cell = num(m[kind][s] * SCALE.get(s, 1.0), 3)
            lo, hi = m[f"{rel_key}_ci95"][s]
            if name != "Behavior-Clone" and s in few:
                cell += f" (few events: {few[s]})"
            elif name != "Behavior-Clone":
                ns = lo is None or lo <= 0 <= hi
                cell += " (n.s.)" if ns else f" ({pct(m[rel_key][s])})"
            cells.append(cell)
        rows.append([name] + cells)
    if kind == "truth":
        rows.append(
            ["logged policy (test rows)"]
            + [num(d["logged"]["truth"][s] * SCALE.get(s, 1.0), 3) for s in SIGNALS]
        )
    label = "NCIS (% vs BC)" if kind == "ncis" else "true value (% vs BC)"
    return md([doc.link(label, path), *HEADS], rows)


def t_kuairand_unified(doc: Doc, key: str = "kuairand") -> str:
    """The unified objective's true value, its change vs BC and the share of the
    BC -> oracle gap, with 95% intervals; NCIS's effective sample size."""
    path = f"{R[key]}/table.json"
    d = load(path)
    rows = []
    for name, m in d["methods"].items():
        lo, hi = m["unified_vs_bc_ci95"]
        glo, ghi = m["gap_share_ci95"]
        rows.append(
            [
                name,
                num(m["unified_truth"], 4),
                f"{num(m['unified_vs_bc'], 4)} [{num(lo, 4)}, {num(hi, 4)}]",
                f"{num(m['gap_share'], 2)} [{num(glo, 2)}, {num(ghi, 2)}]",
                num(m["ess"]),
            ]
        )
    head = [doc.link("unified preference, true value", path), "value", "vs BC [95%]"]
    return md(head + ["share of BC → oracle gap [95%]", "NCIS ESS"], rows, "lrrrr")


def t_kuairand_sets(doc: Doc) -> str:
    """Each method's share of the Behavior-Clone -> oracle gap on each data set, pooled
    (with its interval over test rows and seeds, conditional on the data sets), and with
    the data sets resampled as well."""
    path = f"{R['kuairand']}/table.json"
    d = load(path)
    values = load(f"{R['kuairand']}/per_seed.json")["data_sets"]
    mean = lambda ds, m: sum(ds[m]["unified_truth"]) / len(ds[m]["unified_truth"])  # noqa: E731
    gaps = [mean(ds, "Oracle") - mean(ds, "Behavior-Clone") for ds in values]
    rows = [["the gap itself (true unified value)", *(num(g, 3) for g in gaps), "", ""]]
    for name, m in d["methods"].items():
        if name in ("Behavior-Clone", "Oracle"):
            continue  # 0 and 1 by definition
        lo, hi = m["gap_share_ci95"]
        slo, shi = m["gap_share_ci95_data_sets"]
        rows.append(
            [name]
            + [num(v, 2) for v in m["gap_share_by_data_set"]]
            + [
                f"{num(m['gap_share'], 2)} [{num(lo, 2)}, {num(hi, 2)}]",
                f"[{num(slo, 2)}, {num(shi, 2)}]",
            ]
        )
    sets = [f"data set {i}" for i in range(len(d["data_seeds"]))]
    head = [doc.link("share of BC → oracle gap", path), *sets, "pooled [95%, given the sets]"]
    return md(head + ["[95%, sets resampled]"], rows, "l" + "r" * (len(sets) + 2))


def t_kuairand_fig2(doc: Doc) -> str:
    """Each leaning policy's true values relative to the unified preference's, in %."""
    path = f"{R['kuairand']}/fig2.json"
    d = load(path)
    unified = d["values"]["truth"]["unified"]
    rows = []
    for sig, lean in zip(d["signals"], d["values"]["truth"]["leaning"], strict=True):
        cells = [pct(100 * (v - u) / u) for v, u in zip(lean, unified, strict=True)]
        own = d["signals"].index(sig)
        cells[own] = f"**{cells[own]}**"
        rows.append([f"0.4 on {sig}"] + cells)
    return md([doc.link("leaning policy, true value vs unified", path), *HEADS], rows)


def t_kuairand_headroom(doc: Doc) -> str:
    """Behavior-Clone's and the oracle's true unified value against the Gaussian's width."""
    path = f"{R['kuairand_headroom']}/headroom.json"
    d = load(path)
    rows = [
        [f"σ = {float(sig):g}", num(v["bc"], 3), num(v["oracle"], 3), num(v["gap"], 3)]
        for sig, v in d["sigma"].items()
    ]
    rows.append(["logged actions (no Gaussian)", num(d["logged"], 3), "", ""])
    head = [doc.link("evaluation width", path), "Behavior-Clone", "Oracle", "gap"]
    return md(head, rows, "lrrr")


def t_kuairand_run(doc: Doc) -> str:
    path = f"{R['kuairand']}/run.json"
    d = load(path)
    rows = []
    for i, (ds, sec) in enumerate(zip(d["data_sets"], d["seconds"]["per_data_set"], strict=True)):
        rows.append(
            [
                doc.link(f"data set {i}", path),
                num(ds["rows"]),
                num(ds["train_rows"]),
                num(ds["test_rows"]),
                num(ds["users"]),
                num(ds["candidates"]),
                num(ds["state_dim"]),
                num(sum(sec.values())),
            ]
        )
    head = ["run", "rows used", "train rows", "test rows", "users", "candidates", "state dims"]
    return md(head + ["training wall s"], rows, "lrrrrrrr")


# ---------------------------------------------------------------- inline values


def v_default_wall_range(doc: Doc) -> str:
    walls = [front_of(r).meta["wall_s"] / 60 for r in R["cli_default"]]
    return doc.link(
        f"{num(min(walls), 0)}–{num(max(walls), 0)} minutes", R["cli_default"][0] + "/front.json"
    )


def v_selection_ge7(doc: Doc) -> str:
    fronts = [front_of(r) for r in R["select5_seeds"]]
    text = f"{sum(f.n_nd >= 7 for f in fronts)} of {len(fronts)}"
    return doc.link(text, os.path.dirname(R["select5_seeds"][0]))


# how `front.json`'s `conditioned.preferences` reads in the documents
_PREFERENCE_DRAWS = {
    "drawn per environment": "trained again with one preference per environment",
    "drawn per episode": "trained again with each episode's own preference",
}


def v_field_preferences(doc: Doc) -> str:
    """The field's tasks by how every seed's training drew its preferences (`front.json`'s
    `conditioned.preferences`), and the others: runs from before that was recorded, whose
    environments kept their first preference from every later episode's second step on
    (or, should a task's seeds record different draws, those seeds together)."""
    groups: dict[str, list[str]] = {label: [] for label in _PREFERENCE_DRAWS.values()}
    before = []
    for protocol in ("cmorl", "pgmorl"):
        for task_dir in sorted(glob.glob(os.path.join(ROOT, R["field"], protocol, "*"))):
            fronts = sorted(glob.glob(os.path.join(task_dir, "seed*", "front.json")))
            if not fronts:
                continue
            marks = {_load(f).get("conditioned", {}).get("preferences") for f in fronts}
            name = f"`{os.path.basename(task_dir)}` ({protocol})"
            (mark,) = marks if len(marks) == 1 else (None,)
            label = _PREFERENCE_DRAWS.get(mark)
            (groups[label] if label else before).append(name)
    drawn = [f"{label}: {', '.join(names)}" for label, names in groups.items() if names]
    return "; ".join(
        [
            *(drawn or ["trained again: none yet"]),
            f"still from before: {', '.join(before) or 'none'}",
        ]
    )


def t_conditioned(doc: Doc) -> str:
    """Each arm's fronts per seed and their mean: morl-baselines' and the project's hypervolume,
    expected utility, non-dominated count, order, the ends, budget and wall time."""
    path = f"{R['conditioned']}/summary.json"
    d = load(path)
    arms = {
        "conditioned": "one conditioned network, 3M",
        "independent_9x333k": "9 independent, 333k each (3M)",
        "independent_9x1M": "9 independent, 1M each (9M)",
    }
    rows = []
    for arm, label in arms.items():
        runs = d["runs"].get(arm, {})
        for seed, r in sorted(runs.items(), key=lambda kv: int(kv[0])) + [("mean", None)]:
            r = d["means"][arm] if r is None else r
            rows.append(
                [
                    doc.link(label, path) if seed in ("0", "mean") else label,
                    seed,
                    sci(r["hv_morl_baselines"]),
                    f"{r['hv_project'] / 1e6:.2f}e6",
                    num(r["expected_utility"]),
                    num(r["nondominated"], 1 if seed == "mean" else 0),
                    num(r["spearman_p0_forward"], 2),
                    num(r["forward_end_speed"], 2),
                    num(r["control_end_control_return"]),
                    num(r["env_steps_total"]),
                    num(r["wall_s"]),
                ]
            )
    head = ["front", "seed", "HV (morl-baselines)", "HV (project)", "EU", "non-dom."]
    head += ["Spearman", "`[1, 0]` m/s", "`[0, 1]` control", "train env steps", "wall s"]
    return md(head, rows, "llrrrrrrrrr")


def sci(x: float) -> str:
    """`5.54e6`: three significant digits, the exponent without sign padding."""
    mantissa, exponent = f"{x:.2e}".split("e")
    return f"{mantissa}e{int(exponent)}".replace("-", MINUS)


def t_mo_mujoco(doc: Doc) -> str:
    """The MuJoCo suite's fronts (`mo_mujoco.py table`'s `table.json`): per task and
    scalarization, morl-baselines' hypervolume, EU, the non-dominated count, the
    forward end's speed against the PPO reference's, and the wall times."""
    path = f"{R['mo_mujoco']}/table.json"
    rows = []
    for r in load(path)["rows"]:
        rows.append(
            [
                doc.link(f"`{r['env']}`", path),
                r["scalarization"],
                f"{r['n_prefs']} x {num(r['env_steps_per_pref'])}",
                sci(r["hv_morl_baselines"]),
                num(r["expected_utility"], 1),
                str(r["nondominated"]),
                num(r["forward_end_mean_x_velocity"], 2),
                num(r.get("reference_mean_x_velocity"), 2),
                num(r.get("speed_ratio"), 2),
                num(r["wall_s"]),
                num(r.get("reference_wall_s")),
                num(r.get("wall_ratio"), 2),
            ]
        )
    head = ["task", "direction", "P x steps", "HV (morl-baselines)", "EU"]
    head += ["non-dom.", "forward end m/s", "PPO m/s", "speed ratio", "wall s", "PPO wall s"]
    head += ["wall ratio"]
    return md(head, rows, "lllrrrrrrrrr")


def t_mo_mujoco_seeds(doc: Doc) -> str:
    """smooth_wc against linear over seeds (`table.json`'s `seeds`): per task and
    measure, each direction's mean and seed range, and the winner where the ranges do
    not overlap."""
    path = f"{R['mo_mujoco']}/table.json"
    names = {
        "hv_morl_baselines": ("HV (morl-baselines)", sci),
        "forward": ("forward end m/s", lambda x: num(x, 2)),
    }
    rows = []
    for env, c in load(path)["seeds"].items():
        entries = {**c["hypervolume"], "forward": c["forward_speed"]}
        seeds = ", ".join(map(str, c["seeds"]))
        for key, e in entries.items():
            name, fmt = names[key]
            cells = [
                f"{fmt(e['mean'][s])} [{fmt(min(e[s]))}, {fmt(max(e[s]))}]"
                for s in ("smooth_wc", "linear")
            ]
            rows.append(
                [doc.link(f"`{env}`", path), seeds, name, *cells, e["winner"] or "within spread"]
            )
    head = ["task", "seeds", "measure", "smooth_wc mean [range]", "linear mean [range]"]
    return md([*head, "winner"], rows, "lllrrl")


def t_mo_mujoco_seed_prefs(doc: Doc) -> str:
    """Where on the front the two directions differ: per task with seeds and per
    preference, each direction's mean undiscounted return over the seeds."""
    path = f"{R['mo_mujoco']}/table.json"
    rows = []
    for env, c in load(path)["seeds"].items():
        means = c["mean_return"]
        for i, pref in enumerate(c["prefs"]):
            cells = [
                "(" + ", ".join(num(v) for v in means[s][i]) + ")" for s in ("smooth_wc", "linear")
            ]
            rows.append([doc.link(f"`{env}`", path), pref_str(pref), *cells])
    head = ["task", "preference", "smooth_wc mean return", "linear mean return"]
    return md(head, rows, "llrr")


def t_conditioned_cost(doc: Doc) -> str:
    """The cost of more front points: seed 0's network evaluated at P preferences (its
    training once, plus each evaluation) against P independent 1M-step policies, whose
    seconds are the 9 x 1M fronts' mean wall per preference times P (extrapolated). The
    run's wall time holds its own 33-preference evaluation: the training alone is that
    wall less the evaluation's seconds (`front.json`'s `conditioned.eval_s`), so each
    evaluation counts once."""
    path = f"{R['conditioned']}/summary.json"
    d = load(path)
    train = d["runs"]["conditioned"]["0"]
    own_eval_s = load(f"{R['conditioned']}/conditioned/seed0/front.json")["conditioned"]["eval_s"]
    per_pref = d["means"]["independent_9x1M"]
    steps_pp = per_pref["env_steps_total"] / 9
    wall_pp = per_pref["wall_s"] / 9
    rows = []
    for c in d["cost_growth"]:
        p = c["eval_prefs"]
        rows.append(
            [
                doc.link(str(p), path),
                num(train["env_steps_total"] + c["eval_env_steps"]),
                num(train["wall_s"] - own_eval_s + c["eval_s"]),
                num(p * steps_pp),
                num(p * wall_pp),
            ]
        )
    head = ["front points P", "conditioned: env steps", "conditioned: s"]
    head += ["P independent x 1M: env steps", "P independent x 1M: s (extrapolated)"]
    return md(head, rows, "lrrrr")


def t_mo_gymnasium_eval(doc: Doc) -> str:
    """Per task family, the MO-Gymnasium evaluation of one run against the project's
    (`evaluation_mo_gymnasium.json`'s `agreement`): the largest difference of mean
    undiscounted returns over the preferences and objectives, the standard errors of the
    episode mean and of the difference there, and how many differences pass 2 and 3
    standard errors."""
    rows = []
    for path in sorted(find(f"{R['mo_gymnasium_eval']}/*.json")):
        d = load(path)
        a = d["agreement"]["return"]
        big = a["largest_difference"]
        rows.append(
            [
                doc.link(os.path.basename(path).removesuffix(".json"), path),
                f"`{d['env']}`",
                d["policies"],
                f"{len(d['prefs'])} x {d['episodes']} ({d['project_episodes']})",
                f"{num(big['difference'], 1)} ({d['objective_names'][big['objective']]}, "
                f"{pref_str(big['pref'])})",
                num(big["se_of_mean"], 1),
                num(big["se"], 1),
                num(None if big["z"] is None else abs(big["z"]), 1),
                num(a["max_abs_z"], 1),
                f"{a['beyond_2se']} / {a['beyond_3se']} of {a['n']}",
                _protocol_hv(d.get("protocol")),
            ]
        )
    head = ["result", "task", "policies", "prefs x episodes (project's)", "largest difference"]
    head += ["SE of mean", "SE of difference", "its z", "largest z", "beyond 2 / 3 SE"]
    head += ["protocol HV: MO-Gymnasium / project"]
    return md(head, rows, "llllrrrrrrr")


def _protocol_hv(score: dict | None) -> str:
    """`2.52e6 / 2.82e6`: the protocol's HV of both evaluations (`–` without one, or at
    preferences other than the protocol's grid)."""
    if score is None or any("preferences" in d for d in score["deviations"]):
        return "–"
    return f"{sci(score['mo_gymnasium']['hv'])} / {sci(score['project']['hv'])}"


def _published(row: dict, method: str) -> dict | None:
    return next((p for p in row["published"] if p["method"] == method), None)


def t_field(doc: Doc, short: bool = False) -> str:
    """The field's protocols (`field.py table`'s `table.json`): per protocol and task our
    protocol HV (mean and 95% Student-t interval over the seeds), PGMORL's published
    number (the floor), the best published one and our mean's ratio to it with its
    interval, the env steps trained and evaluated, and the wall time per seed. `short`:
    the task, the HV, the best published number and the ratio."""
    path = f"{R['field']}/table.json"
    rows = []
    for r in load(path)["rows"]:
        hv, best = r["hv"], r["best_published"]
        pgmorl = _published(r, "PGMORL")
        seeds = ", ".join(str(s["seed"]) for s in r["seeds"])
        ours = f"{sci(hv['mean'])} [{sci(hv['ci95'][0])}, {sci(hv['ci95'][1])}]"
        if len(r["seeds"]) == 1:
            ours = sci(hv["mean"])
        ratio = "none published"
        if best is not None:
            lo, hi = r["ratio_ci95"]
            ratio = num(r["ratio_to_best"], 2) + (
                f" [{num(lo, 2)}, {num(hi, 2)}]" if len(r["seeds"]) > 1 else ""
            )
        best_cell = "–" if best is None else f"{best['method']} {sci(best['hv'])}"
        task = doc.link(f"`{r['task']}`", path)
        walls = [s["wall_s"] for s in r["seeds"]]
        if short:
            against = "no published number" if best is None else f"{best_cell}: {ratio}"
            rows.append([r["protocol"], f"{task} {sci(hv['mean'])} ({against}; seeds {seeds})"])
            continue
        rows.append(
            [
                r["protocol"],
                task,
                r["published_task"],
                seeds,
                ours,
                "–" if pgmorl is None else sci(pgmorl["hv"]),
                best_cell,
                ratio,
                _mo_gymnasium(r),
                num(r["seeds"][0]["env_steps_trained"]),
                _span([s["eval_env_steps"] for s in r["seeds"]]),
                _span(walls),
            ]
        )
    if short:  # one row per protocol
        merged = {}
        for protocol, cell in rows:
            merged.setdefault(protocol, []).append(cell)
        rows = [[p, "; ".join(cells)] for p, cells in merged.items()]
        return md(["protocol", "task: our mean HV (best published: ratio; seeds)"], rows, "ll")
    head = ["protocol", "task", "published as", "seeds", "HV mean [95%]", "PGMORL"]
    head += ["best published", "ratio [95%]", "in MO-Gymnasium: HV, ratio"]
    head += ["env steps trained", "eval env steps", "wall s per seed"]
    return md(head, rows, "llllrrrrrrrr")


def _span(values: list) -> str:
    """`lo–hi` over the seeds, or the one seed's value."""
    lo, hi = min(values), max(values)
    return num(lo) if lo == hi else f"{num(lo)}–{num(hi)}"


def _mo_gymnasium(r: dict) -> str:
    """The same policies evaluated in MO-Gymnasium: the HV's mean over the seeds and its
    ratio to the best published (`–`: not evaluated there)."""
    ref = r.get("hv_mo_gymnasium")
    if ref is None:
        return "–"
    return sci(ref["mean"]) + (
        f", {num(ref['ratio_to_best'], 2)}" if "ratio_to_best" in ref else ""
    )


def t_field_ablation(doc: Doc) -> str:
    """The ablation (`field.py ablation-table`'s `ablation.json`): per task and variant
    its changes from the conditioned update's defaults, the seeds, the HV's mean and
    interval, and its ratio to the `default` variant on the seeds both ran."""
    path = f"{R['field']}/ablation.json"
    rows = []
    for r in load(path)["rows"]:
        hv = r["hv"]
        changes = ", ".join(f"{k}={_value(v)}" for k, v in r["changes"].items()) or "–"
        ours = sci(hv["mean"])
        if len(r["seeds"]) > 1:
            ours += f" [{sci(hv['ci95'][0])}, {sci(hv['ci95'][1])}]"
        ratio = "–"
        if r["ratio_to_default"] is not None:
            paired = ", ".join(map(str, r["paired_seeds"]))
            ratio = f"{num(r['ratio_to_default'], 2)} (seeds {paired})"
        rows.append(
            [
                r["protocol"],
                doc.link(f"`{r['task']}`", path),
                f"`{r['variant']}`",
                changes,
                ", ".join(str(s["seed"]) for s in r["seeds"]),
                ours,
                ratio,
                ", ".join(num(s["wall_s"]) for s in r["seeds"]),
            ]
        )
    head = ["protocol", "task", "variant", "changes", "seeds", "HV mean [95%]"]
    head += ["vs default (same seeds)", "wall s"]
    return md(head, rows, "llllrrrr")


def _value(v) -> str:
    """A configuration value as a flag takes it: `(3, 81920)` as `3,81920`."""
    if isinstance(v, list | tuple):
        return ",".join(str(x) for x in v)
    return str(v)


TABLES: dict[str, Callable[[Doc], str]] = {
    "glance": t_glance,
    "cli_default": t_cli_default,
    "cli_final_default": t_cli_final_default,
    "cli_film": t_cli_film,
    "front_default": lambda doc: per_pref(doc, R["front_default"]),
    "front_default_summary": lambda doc: two_directions(doc, R["front_default"]),
    "front_preset": lambda doc: per_pref(doc, R["front_preset"]),
    "front_preset_summary": lambda doc: two_directions(doc, R["front_preset"], paper=True),
    "linear_seeds": lambda doc: variants(
        doc,
        [
            ("`smooth_wc`, preset", "preset_seeds", 3),
            ("`linear`, preset", "linear_seeds", None, "linear"),
        ],
    ),
    "preset_seeds": lambda doc: seeds_table(doc, "preset_seeds"),
    "select5_seeds": lambda doc: seeds_table(doc, "select5_seeds", selection=True),
    "selection_rule": t_selection_rule,
    "variants_3": lambda doc: variants(
        doc,
        [
            ("preset (margin 0.1, μ 1, 16 × 128, constant step)", "preset_seeds", 3),
            ("`--utopia-margin 0.02`", "margin002", None),
            ("`--anneal-lr`", "anneal", None),
            ("`--envs-per-pref 32 --rollout-steps 64`", "n32", None),
            ("`--augment 0.05`", "aug005", None),
        ],
    ),
    "variants_1": lambda doc: variants(
        doc,
        [
            ("preset", "preset_seeds", 1),
            ("`--augment 0.01`", "aug001", None),
            ("`--j-ub 400,100` (fixed utopia)", "fixed_utopia", None),
            ("5 epochs × 32 minibatches", "e5x32", None),
        ],
    ),
    "variants_17": lambda doc: variants(
        doc,
        [
            ("preset (margin 0.1, μ 1)", "preset_seeds", None),
            ("`--utopia-margin 0.05`", "margin005", None),
            ("`--mu 5`", "mu5", None),
            ("best of the last 5 (today's default)", "select5_seeds", None),
        ],
    ),
    "front_w128": lambda doc: per_pref(doc, R["front_w128"]),
    "front_w128_summary": lambda doc: two_directions(doc, R["front_w128"], paper=True),
    "front_w128_fixed": t_fixed_utopia_w128,
    "front_w128_fixed_summary": lambda doc: summary_rows(
        doc,
        [
            ("estimated utopia", front_of(R["front_w128"]), None),
            ("fixed (400, 100)", front_of(R["front_w128_fixed"]), None),
        ],
    ),
    "front_w128_seed1": t_w128_seed1,
    "front_w64": lambda doc: per_pref(doc, R["front_w64"]),
    "front_w64_summary": lambda doc: two_directions(doc, R["front_w64"], paper=True),
    "curves": t_curves,
    "ablation_practical": lambda doc: ablation(doc, "ablation_practical"),
    "ablation_practical_10x8": lambda doc: ablation(doc, "ablation_practical_10x8"),
    "ablation_paper_v5": lambda doc: ablation(doc, "ablation_paper_v5"),
    "ablation_paper_v5_10pct": lambda doc: ablation(doc, "ablation_paper_v5_10pct", long=False),
    "ablation_paper_warm_1M": lambda doc: ablation(doc, "ablation_paper_warm_1M"),
    "ablation_paper_warm_10pct": lambda doc: ablation(doc, "ablation_paper_warm_10pct", long=False),
    "paper_fronts": t_paper_fronts,
    "exploration_bandit": t_exploration_bandit,
    "exploration_dst": t_exploration_dst,
    "convergence": t_convergence,
    "bench_practical": t_bench_practical,
    "reference_ppo": t_reference_ppo,
    "fronts_wall": t_fronts_wall,
    "bench_env": t_bench_env,
    "drift": t_drift,
    "bench_engines": t_bench_engines,
    "quiet_raw": t_quiet_raw,
    "bench_throughput": t_bench_throughput,
    "bench_processes": t_bench_processes,
    "bench_cli": t_bench_cli,
    "kuairand_ncis": lambda doc: kuairand(doc, "kuairand", "ncis"),
    "kuairand_truth": lambda doc: kuairand(doc, "kuairand", "truth"),
    "kuairand_unified": t_kuairand_unified,
    "conditioned": t_conditioned,
    "conditioned_cost": t_conditioned_cost,
    "mo_mujoco": t_mo_mujoco,
    "mo_gymnasium_eval": t_mo_gymnasium_eval,
    "field": lambda doc: t_field(doc),
    "field_glance": lambda doc: t_field(doc, short=True),
    "field_ablation": t_field_ablation,
    "mo_mujoco_seeds": t_mo_mujoco_seeds,
    "mo_mujoco_seed_prefs": t_mo_mujoco_seed_prefs,
    "kuairand_paper_scale_unified": lambda doc: t_kuairand_unified(doc, "kuairand_paper_scale"),
    "kuairand_headroom": t_kuairand_headroom,
    "kuairand_fig2": t_kuairand_fig2,
    "kuairand_sets": t_kuairand_sets,
    "kuairand_run": t_kuairand_run,
}


def v_kuairand_training(doc: Doc) -> str:
    path = f"{R['kuairand']}/run.json"
    c = load(path)["config"]
    return doc.link(f"{num(c['steps'])} steps of {c['batch_size']} logged transitions", path)


def v_kuairand_alg1_gap(doc: Doc) -> str:
    path = f"{R['kuairand']}/table.json"
    m = load(path)["methods"]["wcac (Algorithm 1)"]
    lo, hi = m["gap_share_ci95"]
    return doc.link(f"{num(100 * m['gap_share'])}% [95%: {num(100 * lo)}–{num(100 * hi)}%]", path)


def v_kuairand_alg1_gap_sets(doc: Doc) -> str:
    """Algorithm 1's share of the gap on each data set, and its interval with the data
    sets resampled as well (data sets, then training seeds within each)."""
    path = f"{R['kuairand']}/table.json"
    m = load(path)["methods"]["wcac (Algorithm 1)"]
    each = _and([f"{num(100 * v)}%" for v in m["gap_share_by_data_set"]])
    lo, hi = m["gap_share_ci95_data_sets"]
    return doc.link(
        f"{each} on the {len(m['gap_share_by_data_set'])} data sets, and {num(100 * lo)}% to "
        f"{num(100 * hi)}% with the data sets resampled too",
        path,
    )


def v_kuairand_no_bc_ddpg_gaps(doc: Doc) -> str:
    """The DDPG-style actor-critics' shares of the gap without the behaviour-cloning term."""
    path = f"{R['kuairand_no_bc']}/table.json"
    m = load(path)["methods"]
    names = ("MOAC (linear)", "MOCHA (linear)", "PDPG (DNN)", "wcac (DDPG-style)")
    shares = [100 * m[n]["gap_share"] for n in names]
    return doc.link(f"{num(min(shares))}–{num(max(shares))}%", path)


def v_kuairand_no_bc_alg1_gap(doc: Doc) -> str:
    path = f"{R['kuairand_no_bc']}/table.json"
    m = load(path)["methods"]["wcac (Algorithm 1)"]
    lo, hi = m["gap_share_ci95"]
    share = f"{num(100 * m['gap_share'])}% [95%: {num(100 * lo)}% to {num(100 * hi)}%]"
    return doc.link(share, path)


def _end_action(doc: Doc, key: str, methods: tuple[str, ...]) -> str:
    """The mean action of the last window of `methods`' curves, over data sets and seeds."""
    path = f"{R[key]}/curves.json"
    sets = load(path)["data_sets"]
    ends = [seed[-1] for ds in sets for m in methods for seed in ds[m]["mean_action"]]
    return doc.link(f"about {num(sum(ends) / len(ends))}", path)


def _quarters(doc: Doc, key: str):
    """Per actor-critic, its curves' third and last quarters: `{method: (a3, a4, a0, l3,
    l4)}`, the mean action's level in each quarter and at the start `[sets, seeds]`, and
    the critic loss's level in each quarter over every data set and seed."""
    sets = load(f"{R[key]}/curves.json")["data_sets"]
    out = {}
    for m in sets[0]:
        a = np.array([ds[m]["mean_action"] for ds in sets])  # [sets, seeds, points]
        loss = np.array([ds[m]["critic_loss"] for ds in sets])
        q = a.shape[-1] // 4
        out[m] = (
            a[..., 2 * q : 3 * q].mean(-1),
            a[..., 3 * q :].mean(-1),
            a[..., 0],
            loss[..., 2 * q : 3 * q].mean(),
            loss[..., 3 * q :].mean(),
        )
    return out


def v_kuairand_action_levels(doc: Doc) -> str:
    """How far each actor's mean action still moves between the last two quarters of the
    steps, against how far it moved from its start."""
    q = _quarters(doc, "kuairand")
    late = max(float(np.abs(a4 - a3).max()) for a3, a4, *_ in q.values())
    moved = min(float(np.abs(a4 - a0).min()) for _, a4, a0, *_ in q.values())
    return doc.link(
        f"at most {num(late, 1)} index units, against a move of at least {num(moved)} from "
        "its initial index",
        f"{R['kuairand']}/curves.json",
    )


def v_kuairand_loss_levels(doc: Doc) -> str:
    """The largest relative change of a method's mean critic loss between the last two
    quarters of the steps."""
    q = _quarters(doc, "kuairand")
    change = max(abs(l4 - l3) / l3 for *_, l3, l4 in q.values())
    return doc.link(f"at most {num(100 * change)}%", f"{R['kuairand']}/curves.json")


SIGNAL_NAMES = {"hate": "dislike", "watch_time": "watch time"}


def _and(words: list[str]) -> str:
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def v_kuairand_ncis_judged(doc: Doc) -> str:
    """The signals NCIS can judge: enough logged events among the test rows (watch time
    is a duration, logged on every row)."""
    path = f"{R['kuairand']}/table.json"
    d = load(path)
    few = ncis_few(d)
    names = [SIGNAL_NAMES.get(s, s) for s in d["ncis_events"] if s not in few]
    return doc.link(_and(names + ["watch time"]), path)


def v_kuairand_ncis_few(doc: Doc) -> str:
    """The signals NCIS cannot judge, with their logged events among the test rows."""
    path = f"{R['kuairand']}/table.json"
    few = ncis_few(load(path))
    names = _and([SIGNAL_NAMES.get(s, s) for s in few])
    return doc.link(f"{names} ({_and([num(n) for n in few.values()])} logged events)", path)


def v_kuairand_wall(doc: Doc) -> str:
    """The default experiment's wall time as one process, with the machine's load at its
    end and the process's CPU time (the wall time of a run beside other work is not the
    program's)."""
    path = f"{R['kuairand']}/run.json"
    info = load(path)
    if info.get("merged_parts", True):
        raise ValueError(f"{path}: trained in --part processes; its total is no one wall time")
    wall, cpu = info["seconds"]["total"] / 60, info["cpu_seconds"][-1] / 60
    load_end = info["load_average_at_end"][0]
    return doc.link(
        f"{num(wall)} minutes (load average {num(load_end)} at its end; {num(cpu)} CPU minutes)",
        path,
    )


def v_kuairand_no_bc_ddpg_action(doc: Doc) -> str:
    return _end_action(doc, "kuairand_no_bc", ("moac", "mocha", "pdpg", "wcac"))


def v_kuairand_no_bc_alg1_action(doc: Doc) -> str:
    return _end_action(doc, "kuairand_no_bc", ("alg1",))


def _ppo_speed(env: str, steps: int | None = None, seed: int = 0) -> tuple[str, float]:
    """A MuJoCo-suite task's PPO reference: its file and mean x velocity. By default the
    suite's own (`mo_mujoco/<env>/reference_ppo.json`, at the task's budget); with `steps`,
    the one run `steps` env steps on `seed`, among the suite's and
    `reference_ppo_<env>_v5/*/`."""
    own = f"{R['mo_mujoco']}/{env}/reference_ppo.json"
    if steps is None:
        return own, load(own)["mean_x_velocity"]
    paths = find(own) + find(f"{RES}/reference_ppo_{env}_v5/*/reference_ppo.json")
    found = [p for p in paths if (load(p)["env_steps"], load(p)["seed"]) == (steps, seed)]
    if len(found) != 1:
        raise ValueError(
            f"{env}: {len(found)} PPO references at {steps:,} env steps on seed {seed} "
            f"({', '.join(found) or 'none'}); one is compared"
        )
    return found[0], load(found[0])["mean_x_velocity"]


# the suite's speed criterion: a forward end at this fraction of PPO's speed or more
SPEED_FLOOR = 0.8


def _forward_end(doc: Doc, env: str, variant: str) -> str:
    """The range of a task's independent forward-end runs' speeds under one variant of its
    configuration (`<env>_forward_end_practical_v5/<variant>`), and how many reach 0.8 x
    PPO's."""
    path = f"{RES}/{env}_forward_end_practical_v5/{variant}/front.json"
    runs = load(path)["prefs"]
    if any(p["pref"] != [1.0, 0.0] for p in runs):
        raise ValueError(f"{path}: not every run is the forward end [1, 0]")
    speeds = [p["mean_x_velocity"] for p in runs]
    # PPO at the probe's own budget per policy and seed
    config = load(f"{RES}/{env}_forward_end_practical_v5/{variant}/config.json")
    _, ppo = _ppo_speed(env, config["steps_per_pref"], config["seed"])
    fast = sum(v >= SPEED_FLOOR * ppo for v in speeds)
    text = f"{num(min(speeds), 2)}–{num(max(speeds), 2)} m/s"
    share = f"{fast} of {len(speeds)} at {SPEED_FLOOR} × PPO's speed or more"
    return doc.link(f"{text} ({share})", path)


def _ppo_speed_value(doc: Doc, env: str, steps: int) -> str:
    path, speed = _ppo_speed(env, steps)
    return doc.link(f"{num(speed, 2)} m/s", path)


def _ppo_run_value(doc: Doc, env: str, steps: int) -> str:
    """PPO's speed at `steps` on seed 0 and how long its evaluation episodes last."""
    path, speed = _ppo_speed(env, steps)
    length = load(path)["episode_length"]
    return doc.link(f"{num(speed, 2)} m/s in episodes of {num(length, 0)} steps", path)


def v_mo_mujoco_thresholds(doc: Doc) -> str:
    """The suite's two thresholds over every front of `table.json` (seed 0): the tasks,
    whether each front's wall ratio is below 1 (one program beats P separate PPO runs by
    1.5x) and each forward end reaches 0.8 x PPO's speed, naming every front that does not."""
    path = f"{R['mo_mujoco']}/table.json"
    rows = load(path)["rows"]
    envs = list(dict.fromkeys(r["env"] for r in rows))

    def misses(key: str, ok: Callable[[float], bool]) -> str:
        bad = [r for r in rows if r.get(key) is None or not ok(r[key])]
        if not bad:
            return ""
        kind = key.split("_")[0]
        named = [
            f"`{r['env']}`'s `{r['scalarization']}` ({kind} ratio {num(r.get(key), 2)})"
            for r in bad
        ]
        return f" but {_and(named)}"

    wall = misses("wall_ratio", lambda x: x < 1.0)
    speed = misses("speed_ratio", lambda x: x >= SPEED_FLOOR)
    return (
        f"on {_and([f'`{e}`' for e in envs])}, every front{wall} trains in one program in "
        "under two thirds of the time of its separate single-objective PPO runs (wall "
        f"ratio below 1), and every forward end{speed} runs at {SPEED_FLOOR} × PPO's speed or "
        "faster (speed ratio)"
    )


def v_humanoid_ppo_seeds(doc: Doc) -> str:
    """The humanoid's PPO reference speed at 1M env steps on every seed run
    (`reference_ppo_humanoid_v5/seed<N>`)."""
    paths = find(f"{RES}/reference_ppo_humanoid_v5/seed*/reference_ppo.json")
    if not paths or any(load(p)["env_steps"] != 1_000_000 for p in paths):
        raise ValueError(f"{RES}/reference_ppo_humanoid_v5: not every seed at 1M env steps")
    runs = sorted((load(p)["seed"], load(p)["mean_x_velocity"], p) for p in paths)
    speeds = _and([doc.link(f"{num(v, 2)} m/s", p) for _, v, p in runs])
    return f"{speeds} at seeds {_and([str(seed) for seed, _, _ in runs])}"


# the probes of a task's forward end: value name -> the variant's results directory
# (initial log-std 0 and -1 on both; the humanoid also with PPO's 10 epochs of batches of 256)
_LOG_STDS = {"ls0": "logstd0", "ls-1": "logstd-1"}
FORWARD_END_PROBES = {
    "halfcheetah": _LOG_STDS,
    "humanoid": _LOG_STDS | {"e10x8": "e10x8"},
}

# PPO's speed on seed 0 as the docs quote it: value name -> (task, env steps)
PPO_SPEEDS = {
    "halfcheetah_ppo_speed": ("halfcheetah", 1_000_000),
    "humanoid_ppo_speed": ("humanoid", 1_000_000),
}

VALUES: dict[str, Callable[[Doc], str]] = {
    **{
        f"{env}_forward_end_{name}": partial(_forward_end, env=env, variant=variant)
        for env, variants in FORWARD_END_PROBES.items()
        for name, variant in variants.items()
    },
    **{
        name: partial(_ppo_speed_value, env=env, steps=steps)
        for name, (env, steps) in PPO_SPEEDS.items()
    },
    "humanoid_ppo_3M": partial(_ppo_run_value, env="humanoid", steps=3_000_000),
    "kuairand_training": v_kuairand_training,
    "kuairand_alg1_gap": v_kuairand_alg1_gap,
    "kuairand_alg1_gap_sets": v_kuairand_alg1_gap_sets,
    "kuairand_no_bc_ddpg_gaps": v_kuairand_no_bc_ddpg_gaps,
    "kuairand_no_bc_alg1_gap": v_kuairand_no_bc_alg1_gap,
    "kuairand_no_bc_ddpg_action": v_kuairand_no_bc_ddpg_action,
    "kuairand_no_bc_alg1_action": v_kuairand_no_bc_alg1_action,
    "kuairand_action_levels": v_kuairand_action_levels,
    "kuairand_loss_levels": v_kuairand_loss_levels,
    "kuairand_wall": v_kuairand_wall,
    "kuairand_ncis_judged": v_kuairand_ncis_judged,
    "kuairand_ncis_few": v_kuairand_ncis_few,
    "default_wall_range": v_default_wall_range,
    "selection_ge7": v_selection_ge7,
    "field_preferences": v_field_preferences,
    "mo_mujoco_thresholds": v_mo_mujoco_thresholds,
    "humanoid_ppo_seeds": v_humanoid_ppo_seeds,
}

BLOCK = re.compile(r"(<!-- table:([\w-]+) -->\n)(.*?)(<!-- /table -->)", re.S)
INLINE = re.compile(r"(<!-- value:([\w-]+) -->)(.*?)(<!-- /value -->)", re.S)


def documents(root: str = ROOT) -> list[str]:
    paths = ["README.md"] + sorted(
        os.path.relpath(p, root) for p in glob.glob(os.path.join(root, "docs", "*.md"))
    )
    return [p for p in paths if os.path.exists(os.path.join(root, p))]


def render(text: str, path: str) -> tuple[str, list[str]]:
    """`text` with every block regenerated, and the names of unknown blocks."""
    doc, unknown = Doc(path), []

    def table(m: re.Match) -> str:
        fn = TABLES.get(m.group(2))
        if fn is None:
            unknown.append(m.group(2))
            return m.group(0)
        return f"{m.group(1)}{fn(doc)}\n{m.group(4)}"

    def value(m: re.Match) -> str:
        fn = VALUES.get(m.group(2))
        if fn is None:
            unknown.append(m.group(2))
            return m.group(0)
        return f"{m.group(1)}{fn(doc)}{m.group(4)}"

    return INLINE.sub(value, BLOCK.sub(table, text)), unknown


def main(argv=None) -> int:
    global ROOT
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--check", action="store_true", help="write nothing; exit 1 if a block differs")
    p.add_argument(
        "--root", default=ROOT, help="the repository to read and write (default: this one)"
    )
    args = p.parse_args(argv)
    ROOT = os.path.abspath(args.root)
    _load.cache_clear()
    stale, bad = [], []
    for path in documents(ROOT):
        full = os.path.join(ROOT, path)
        with open(full) as f:
            text = f.read()
        new, unknown = render(text, path)
        bad += [f"{path}: unknown block {name!r}" for name in unknown]
        if new != text:
            stale.append(path)
            if not args.check:
                with open(full, "w") as f:
                    f.write(new)
    for line in bad:
        print(f"error: {line}", file=sys.stderr)
    if args.check and stale:
        print(
            f"error: generated blocks differ in {', '.join(stale)}; run python docs/tables.py",
            file=sys.stderr,
        )
    return 1 if bad or (args.check and stale) else 0


if __name__ == "__main__":
    sys.exit(main())
