"""Pareto-front metrics on `[n, m]` point sets (maximisation), numpy only.

`nondominated` (the mask of the front), `hypervolume` (exact: a sweep line for `m = 2`,
a recursive slicing algorithm (HSO) over the non-dominated set for `m >= 3`),
`outside_reference` (the points a reference point leaves out of the hypervolume),
`expected_utility` (EUM), `sparsity`, `cardinality`, `rank_correlation` (Spearman's, of a
preference against a return), `simplex_lattice` (a uniform preference grid of any size)
and `preference_lattice` (the sweep's `--n-prefs` grid, a full, even lattice for three
objectives and more). All points are maximised: `a` dominates `b` when
`a >= b` everywhere and `a > b` somewhere. NaN inputs and mismatched shapes raise
`ValueError`.
"""

from __future__ import annotations

import itertools
import math

import numpy as np


def _points(points, name: str = "points") -> np.ndarray:
    arr = np.asarray(points, dtype=np.float64)
    if arr.ndim == 1 and arr.size == 0:
        arr = arr.reshape(0, 0)
    if arr.ndim != 2:
        raise ValueError(f"{name} must be a 2-D array [n, m], got shape {arr.shape}")
    if np.isnan(arr).any():
        rows = np.unique(np.nonzero(np.isnan(arr))[0]).tolist()
        raise ValueError(f"{name} contain NaN (rows {rows})")
    return arr


def nondominated(points) -> np.ndarray:
    """Boolean mask `[n]` of the non-dominated rows of `points` `[n, m]`.

    Duplicated non-dominated points are kept once (the first occurrence). Two objectives
    take `O(n log n)` (a sort), more take `O(n^2)`.
    """
    pts = _points(points)
    if pts.shape[1] == 2:
        return _nondominated2d(pts)
    n = pts.shape[0]
    mask = np.ones(n, dtype=bool)
    for i in range(n):
        ge = np.all(pts >= pts[i], axis=1)
        gt = np.any(pts > pts[i], axis=1)
        if np.any(ge & gt):
            mask[i] = False
            continue
        same = np.all(pts == pts[i], axis=1)
        if np.any(same[:i]):
            mask[i] = False
    return mask


def _nondominated2d(pts: np.ndarray) -> np.ndarray:
    """`nondominated` for `[n, 2]` points, by one sort.

    In the order x descending, then y descending, then row: a point is dominated when a
    point of larger x (an earlier group of equal x) reaches its y, or when its own group's
    first point has a larger y; of equal points, the first row is kept.
    """
    n = pts.shape[0]
    x, y = pts[:, 0], pts[:, 1]
    order = np.lexsort((np.arange(n), -y, -x))  # the last key sorts first
    xs, ys = x[order], y[order]
    new_group = np.r_[True, xs[1:] != xs[:-1]]
    start = np.maximum.accumulate(np.where(new_group, np.arange(n), 0))  # of each group
    best_y = np.maximum.accumulate(ys)  # over this point and every one before it
    by_larger_x = (start > 0) & (best_y[start - 1] >= ys)
    dominated = by_larger_x | (ys < ys[start])
    repeat = np.r_[False, (xs[1:] == xs[:-1]) & (ys[1:] == ys[:-1])]
    mask = np.empty(n, dtype=bool)
    mask[order] = ~(dominated | repeat)
    return mask


def _hv2d(pts: np.ndarray, ref: np.ndarray) -> float:
    order = np.argsort(-pts[:, 0], kind="stable")
    volume, best_y = 0.0, ref[1]
    for x, y in pts[order]:
        if y > best_y:
            volume += (x - ref[0]) * (y - best_y)
            best_y = y
    return volume


def _hv(pts: np.ndarray, ref: np.ndarray) -> float:
    """Exact hypervolume of points that all strictly dominate `ref` (slicing on axis 0)."""
    n, m = pts.shape
    if n == 0:
        return 0.0
    if m == 1:
        return float(pts[:, 0].max() - ref[0])
    if m == 2:
        return _hv2d(pts, ref)
    # Slice along the last objective: between consecutive levels, the cross-section is
    # the (m-1)-D hypervolume of the points at or above the level.
    order = np.argsort(-pts[:, -1], kind="stable")
    pts = pts[order]
    volume = 0.0
    for i in range(n):
        upper = pts[i, -1]
        lower = pts[i + 1, -1] if i + 1 < n else ref[-1]
        if upper > lower:
            section = pts[: i + 1, :-1]
            section = section[nondominated(section)]
            volume += _hv(section, ref[:-1]) * (upper - lower)
    return volume


def hypervolume(points, ref) -> float:
    """Exact hypervolume dominated by `points` `[n, m]` and bounded below by `ref` `[m]`.

    Points that do not strictly dominate `ref` in every objective contribute nothing.

    >>> hypervolume([[1, 3], [2, 2], [3, 1]], [0, 0])
    6.0
    """
    pts = _points(points)
    ref = np.asarray(ref, dtype=np.float64)
    if ref.ndim != 1 or (pts.size and ref.shape[0] != pts.shape[1]):
        raise ValueError(f"ref has shape {ref.shape}; points have {pts.shape[-1]} objectives")
    if np.isnan(ref).any():
        raise ValueError(f"ref contains NaN: {ref.tolist()}")
    if pts.shape[0] == 0:
        return 0.0
    pts = pts[np.all(pts > ref, axis=1)]
    pts = pts[nondominated(pts)]
    return float(_hv(pts, ref))


def outside_reference(points, ref) -> np.ndarray:
    """Boolean mask `[n]` of the rows of `points` `[n, m]` that do not strictly dominate
    `ref` `[m]`: they lie outside the reference box and add nothing to `hypervolume`.

    >>> outside_reference([[1, 3], [2, -1], [0, 5]], [0, 0]).tolist()
    [False, True, True]
    """
    pts = _points(points)
    ref = np.asarray(ref, dtype=np.float64)
    if ref.ndim != 1 or (pts.size and ref.shape[0] != pts.shape[1]):
        raise ValueError(f"ref has shape {ref.shape}; points have {pts.shape[-1]} objectives")
    return ~np.all(pts > ref, axis=1)


def expected_utility(points, weights) -> float:
    """Expected utility metric: the mean over weight vectors `w` of `max_j w . J_j`.

    Args:
      points: `[n, m]` returns.
      weights: `[k, m]` weight vectors (e.g. `simplex_lattice(m, k)`).
    """
    pts = _points(points)
    w = _points(weights, "weights")
    if w.shape[1] != pts.shape[1]:
        raise ValueError(f"weights have {w.shape[1]} objectives; points have {pts.shape[1]}")
    if pts.shape[0] == 0:
        raise ValueError("expected_utility of an empty point set")
    return float(np.mean(np.max(w @ pts.T, axis=1)))


def sparsity(points) -> float:
    """Sparsity of the non-dominated set (PGMORL's): mean squared gap between
    neighbours along each objective, `sum_j sum_i (s_j[i] - s_j[i+1])^2 / (n - 1)`.
    0 for fewer than two points; lower means more even coverage."""
    pts = _points(points)
    front = pts[nondominated(pts)] if pts.shape[0] else pts
    n = front.shape[0]
    if n < 2:
        return 0.0
    sorted_cols = np.sort(front, axis=0)
    return float(np.sum(np.diff(sorted_cols, axis=0) ** 2) / (n - 1))


def cardinality(points) -> int:
    """Number of distinct non-dominated points."""
    pts = _points(points)
    return int(nondominated(pts).sum()) if pts.shape[0] else 0


def ranks(values) -> np.ndarray:
    """`[n]` the rank of each of `values` `[n]` from 0, ties taking their mean rank."""
    v = np.asarray(values, dtype=np.float64)
    r = np.empty(v.shape[0])
    r[np.argsort(v, kind="stable")] = np.arange(v.shape[0], dtype=np.float64)
    for value in np.unique(v):
        tied = v == value
        r[tied] = r[tied].mean()
    return r


def rank_correlation(x, y) -> float:
    """Spearman's rank correlation of `x` and `y` (`[n]` each): Pearson's correlation of
    their `ranks`. NaN where either is constant (there is no order to correlate).

    >>> rank_correlation([1.0, 0.5, 0.0], [3.2, 2.0, 2.5])
    0.5
    """
    rx, ry = ranks(x), ranks(y)
    if rx.shape != ry.shape:
        raise ValueError(f"x and y differ in length: {rx.shape[0]} and {ry.shape[0]}")
    dx, dy = rx - rx.mean(), ry - ry.mean()
    norm = float(np.sqrt(np.sum(dx * dx) * np.sum(dy * dy)))
    if norm == 0.0:
        return float("nan")
    return float(np.sum(dx * dy) / norm)


def simplex_lattice(m: int, n: int) -> np.ndarray:
    """`n` preference vectors spread uniformly on the `m`-simplex, `[n, m]`.

    For `m = 2`: `n` evenly spaced points from `[1, 0]` to `[0, 1]`. For `m > 2`: the
    smallest simplex lattice (step `1/h`) with at least `n` points, thinned to `n` by
    farthest-point sampling that keeps the corners.
    """
    if m < 1 or n < 1:
        raise ValueError(f"simplex_lattice needs m >= 1 and n >= 1, got m={m}, n={n}")
    if m == 1:
        return np.ones((n, 1))
    if n == 1:
        return np.full((1, m), 1.0 / m)
    if m == 2:
        t = np.linspace(1.0, 0.0, n)
        return np.stack([t, 1.0 - t], axis=1)
    h = 1
    while math.comb(h + m - 1, m - 1) < n:
        h += 1
    grid = (
        np.array(
            [c for c in itertools.product(range(h + 1), repeat=m) if sum(c) == h], dtype=np.float64
        )[::-1]
        / h
    )
    chosen = [int(i) for i in np.nonzero(np.isclose(grid.max(axis=1), 1.0))[0]][:n]
    while len(chosen) < n:
        dist = np.min(np.linalg.norm(grid[:, None] - grid[chosen][None], axis=-1), axis=1)
        chosen.append(int(np.argmax(dist)))
    return grid[sorted(chosen)]


def lattice_size(m: int, h: int) -> int:
    """Points of the full simplex lattice of `m` objectives with step `1/h`:
    `C(h + m - 1, m - 1)` (3, 6, 10, 15, 21, ... for `m = 3`)."""
    return math.comb(h + m - 1, m - 1)


def preference_lattice(m: int, n: int, exact: bool = True) -> np.ndarray:
    """The sweep's `n` preferences for `m` objectives, `[n, m]`.

    For `m <= 2`, `simplex_lattice(m, n)` (`n` evenly spaced points). For `m >= 3`, the
    full simplex lattice with step `1/h` (every preference whose entries are multiples of
    `1/h`), which is even only whole: `n` must be one of its sizes `lattice_size(m, h)`
    (`exact`), or else (`exact=False`) the smallest full lattice with at least `n`
    points is returned.

    Raises:
      ValueError: `exact` and `n` not a lattice size for `m >= 3` (naming the nearest).
    """
    if m <= 2 or n == 1:
        return simplex_lattice(m, n)
    h = 1
    while lattice_size(m, h) < n:
        h += 1
    if exact and lattice_size(m, h) != n:
        below = lattice_size(m, h - 1) if h > 1 else None
        nearest = f"{below} or {lattice_size(m, h)}" if below else f"{lattice_size(m, h)}"
        raise ValueError(
            f"{n} preferences do not make an even lattice on the {m}-objective simplex; "
            f"the nearest that do: {nearest} (C(h+{m - 1}, {m - 1}) for h divisions)"
        )
    return simplex_lattice(m, lattice_size(m, h))
