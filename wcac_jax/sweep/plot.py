"""Figures from saved sweep results (`front.json`, `curves.npz`); never trains.

Every function takes a sweep output directory (or its parsed `front.json` dict /
loaded `curves.npz`), returns a matplotlib `Figure`, and leaves saving to the caller.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence

import matplotlib

if os.environ.get("MPLBACKEND") is None and not os.environ.get("DISPLAY"):
    matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.ticker import EngFormatter  # noqa: E402

from wcac_jax import pareto  # noqa: E402


def load_front(run) -> dict:
    """`front.json` of a run: a directory path, a path to the file, or an already-parsed dict."""
    if isinstance(run, Mapping):
        return dict(run)
    path = os.path.join(run, "front.json") if os.path.isdir(run) else run
    with open(path) as f:
        return json.load(f)


def load_curves(run) -> dict:
    """`curves.npz` of a run as a dict of arrays (a directory, a file path, or a mapping)."""
    if isinstance(run, Mapping):
        return dict(run)
    path = os.path.join(run, "curves.npz") if os.path.isdir(run) else run
    with np.load(path) as data:
        return {k: data[k] for k in data.files}


def _points(front: dict, key: str = "return") -> tuple[np.ndarray, np.ndarray]:
    prefs = np.array([row["pref"] for row in front["prefs"]], dtype=float)
    points = np.array([row[key] for row in front["prefs"]], dtype=float)
    return prefs, points


def plot_front(
    runs,
    labels: Sequence[str] | None = None,
    key: str = "return",
    rays: bool = False,
    exact_front: np.ndarray | None = None,
    ax=None,
) -> Figure:
    """The front(s): points coloured by preference, the non-dominated staircase, the HV.

    Args:
      runs: one run or a list of runs (directories or parsed `front.json` dicts);
        several runs are overlaid with one marker per run and a legend.
      labels: legend labels (default: each run's scalarization).
      key: `"return"` (undiscounted) or `"discounted_return"`.
      rays: draw each preference's direction from the utopia point (the ray a weighted
        Chebyshev solution lies on: `J = J_ub - t / p`).
      exact_front: optional `[k, 2]` points of a known front, drawn as a line.
      ax: an existing axes to draw into.
    """
    if isinstance(runs, str | os.PathLike | Mapping):
        runs = [runs]
    fronts = [load_front(r) for r in runs]
    if len(fronts) == 1 and len(fronts[0]["prefs"][0]["pref"]) == 3 and ax is None:
        return plot_front_3d(fronts[0], key)
    labels = labels or [
        f.get("config", {}).get("train", {}).get("scalarization", "run") for f in fronts
    ]
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(6.4, 4.8))
    markers = "osD^vP*X"
    scatter = None
    for i, (front, label) in enumerate(zip(fronts, labels, strict=True)):
        prefs, points = _points(front, key)
        if points.shape[1] != 2:
            raise ValueError(f"plot_front draws 2 objectives; this run has {points.shape[1]}")
        mask = pareto.nondominated(points)
        stair = points[mask][np.argsort(-points[mask][:, 0])]
        hv = front.get("hypervolume")
        hv_txt = f", HV {hv:.4g}" if hv is not None and key == "return" else ""
        if len(stair):
            xs = np.repeat(stair[:, 0], 2)[1:]
            ys = np.repeat(stair[:, 1], 2)[:-1]
            ax.plot(xs, ys, "-", color=f"C{i}", alpha=0.5, lw=1)
        scatter = ax.scatter(
            points[:, 0],
            points[:, 1],
            c=prefs[:, 0],
            cmap="viridis",
            vmin=0,
            vmax=1,
            marker=markers[i % len(markers)],
            s=60,
            edgecolors=f"C{i}",
            linewidths=1.2,
            label=f"{label} ({int(mask.sum())} non-dominated{hv_txt})",
            zorder=3,
        )
        if rays and "j_ub" in front:
            j_ub = np.asarray(front["j_ub"], dtype=float)
            span = np.ptp(points, axis=0).max() + 1e-9
            for p in prefs:
                d = -1.0 / np.maximum(p, 1e-3)
                d = d / np.linalg.norm(d) * span * 3
                ax.plot(
                    [j_ub[0], j_ub[0] + d[0]], [j_ub[1], j_ub[1] + d[1]], ":", color="grey", lw=0.6
                )
    if exact_front is not None:
        ax.plot(exact_front[:, 0], exact_front[:, 1], "k--", lw=1, label="exact front")
    names = fronts[0].get("objective_names", ["objective 0", "objective 1"])
    kind = "undiscounted" if key == "return" else "discounted"
    ax.set_xlabel(f"{names[0]} ({kind} return)")
    ax.set_ylabel(f"{names[1]} ({kind} return)")
    if rays:
        _, pts = _points(fronts[0], key)
        pad = 0.1 * (np.ptp(pts, axis=0) + 1e-6)
        ax.set_xlim(pts[:, 0].min() - pad[0], pts[:, 0].max() + pad[0])
        ax.set_ylim(pts[:, 1].min() - pad[1], pts[:, 1].max() + pad[1])
    cbar = fig.colorbar(scatter, ax=ax)
    cbar.set_label(f"preference p[0] ({names[0]})")
    ax.legend(fontsize=8, loc="best")
    ax.set_title(f"Pareto front ({fronts[0].get('env', '')})")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def plot_front_3d(run, key: str = "return") -> Figure:
    """A 3-objective front as its three pairwise projections, each point coloured by its
    preference (red, green, blue: the weights of objectives 0, 1, 2), non-dominated
    points filled and dominated ones hollow; a fourth panel shows the preferences on the
    simplex in the same colours. `plot_front` draws one 3-objective run this way.

    Args:
      run: a directory or a parsed `front.json` dict with 3 objectives.
      key: `"return"` (undiscounted) or `"discounted_return"`.
    """
    front = load_front(run)
    prefs, points = _points(front, key)
    if points.shape[1] != 3:
        raise ValueError(f"plot_front_3d draws 3 objectives; this run has {points.shape[1]}")
    colours = np.clip(prefs, 0.0, 1.0)
    mask = pareto.nondominated(points)
    names = front.get("objective_names", [f"objective {j}" for j in range(3)])
    kind = "undiscounted" if key == "return" else "discounted"
    fig, axes = plt.subplots(2, 2, figsize=(9.6, 8.4))
    for ax, (a, b) in zip(axes.flat[:3], [(0, 1), (0, 2), (1, 2)], strict=True):
        for filled in (False, True):
            sel = mask == filled
            ax.scatter(
                points[sel, a],
                points[sel, b],
                c=colours[sel] if filled else "none",
                edgecolors=colours[sel],
                s=55,
                linewidths=1.4,
                label="non-dominated" if filled else "dominated",
                zorder=3,
            )
        ax.set_xlabel(f"{names[a]} ({kind} return)")
        ax.set_ylabel(f"{names[b]} ({kind} return)")
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8, loc="best")
    simplex = axes[1, 1]
    # barycentric coordinates: objective 0 at the lower left, 1 lower right, 2 on top
    corners = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]])
    xy = prefs @ corners
    simplex.fill(corners[:, 0], corners[:, 1], facecolor="none", edgecolor="grey", lw=0.8)
    simplex.scatter(xy[:, 0], xy[:, 1], c=colours, s=55, edgecolors="k", linewidths=0.4)
    for j, (cx, cy) in enumerate(corners):
        simplex.annotate(names[j], (cx, cy), ha="center", va="bottom" if j == 2 else "top")
    simplex.set_aspect("equal")
    simplex.axis("off")
    simplex.set_title("preferences", fontsize=9, pad=18)
    hv = front.get("hypervolume")
    hv_txt = f", HV {hv:.4g}" if hv is not None and key == "return" else ""
    fig.suptitle(
        f"Pareto front ({front.get('env', '')}): {int(mask.sum())} of {len(points)} "
        f"non-dominated{hv_txt}"
    )
    fig.tight_layout()
    return fig


def _pref_colours(prefs: np.ndarray):
    cmap = plt.get_cmap("viridis")
    return [cmap(float(p[0])) for p in prefs]


def moving_average(y, window: int) -> np.ndarray:
    """Trailing moving average of a 1-D `y [T]` over `window` entries -> `[T - window + 1]`
    (`window <= 1`, or `y` shorter than `window`: `y` unchanged)."""
    y = np.asarray(y, dtype=float)
    if window <= 1 or len(y) < window:
        return y
    return np.convolve(y, np.ones(window) / window, mode="valid")


def plot_curves(run, metric: str = "train/episode_return", smooth: int = 1) -> Figure:
    """Learning curves: per-objective `metric` against environment steps, one line per
    preference (coloured by `p[0]`), one panel per objective.

    Args:
      run: a run directory, or a mapping with `curves.npz`'s arrays.
      metric: a `[P, T, m]` metric of `curves.npz`.
      smooth: moving-average window in iterations.
    """
    curves = load_curves(run)
    values, steps, prefs = curves[metric], curves["train/env_steps"], curves["prefs"]
    names = [str(n) for n in curves.get("objective_names", range(values.shape[-1]))]
    fig, axes = plt.subplots(1, values.shape[-1], figsize=(5 * values.shape[-1], 3.8))
    axes = np.atleast_1d(axes)
    for j, ax in enumerate(axes):
        for i, colour in enumerate(_pref_colours(prefs)):
            y = moving_average(values[i, :, j], smooth)
            ax.plot(
                steps[i, -len(y) :],
                y,
                color=colour,
                lw=1.2,
                label=f"p = {np.array2string(prefs[i], precision=2)}",
            )
        ax.set_xlabel("environment steps per preference")
        ax.xaxis.set_major_formatter(EngFormatter())  # 200k, not 200000 (ticks collide)
        ax.set_ylabel(f"{metric} [{names[j]}]")
        ax.grid(alpha=0.3)
    axes[-1].legend(fontsize=7, loc="best")
    fig.tight_layout()
    return fig


def plot_weights(run) -> Figure:
    """The scalarization's objective weights `lambda` over training, per preference."""
    return plot_curves(run, metric="train/weights")
