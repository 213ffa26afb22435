"""Uncertainty of the recommendation table: a paired, stratified bootstrap over test rows
and training seeds, and the reading of a row as a share of the Behavior-Clone -> oracle gap.

Every method is scored on the same test rows of each data set (one data set per data
seed), with several training seeds. A bootstrap replicate draws, within each data set,
the test rows with replacement (one draw shared by every method and seed: the comparison
with Behavior-Clone is paired) and the training seeds with replacement (one draw shared
by every method); a method's replicate is the mean over data sets and drawn seeds of its
estimate on the drawn rows. The data sets themselves are not resampled there, so those
intervals are conditional on them. `draw_sets` and `set_replicates` resample the data
sets as well (a two-level bootstrap: data sets, then training seeds within each drawn
set), from each seed's estimate on all of its set's test rows; with few data sets that
interval spans about the range of the per-set values. Host side, numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Draws:
    """One data set's bootstrap draws: `counts [B, n]` how often each test row is drawn,
    `seeds [B, S]` the drawn training seeds."""

    counts: np.ndarray
    seeds: np.ndarray


def draw(rng: np.random.Generator, n_rows: int, n_seeds: int, n_boot: int) -> Draws:
    """`n_boot` replicates over `n_rows` test rows and `n_seeds` training seeds."""
    rows = rng.integers(0, n_rows, (n_boot, n_rows))
    counts = np.zeros((n_boot, n_rows), np.float64)
    np.add.at(counts, (np.arange(n_boot)[:, None], rows), 1.0)
    return Draws(counts=counts, seeds=rng.integers(0, n_seeds, (n_boot, n_seeds)))


def _pick(per_seed: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """`per_seed [B, S, k]`, `seeds [B, S']` -> the mean over the drawn seeds `[B, k]`.
    A method with fewer seeds than drawn (the oracle has one) takes them modulo its count."""
    s = per_seed.shape[1]
    picked = np.take_along_axis(per_seed, (seeds % s)[:, :, None], axis=1)
    return picked.mean(axis=1)


def ncis_replicates(weights: list, weighted: list, draws: list) -> np.ndarray:
    """NCIS `sum w r / sum w` per replicate, averaged over seeds and data sets.

    Args:
      weights: per data set `[S, n]` importance weights; weighted: per data set
        `[S, n, k]` the products `w r`; draws: per data set `Draws`.

    Returns:
      `[B, k]`.
    """
    out = []
    for w, wr, d in zip(weights, weighted, draws, strict=True):
        num = np.einsum("bn,snk->bsk", d.counts, wr)
        den = np.einsum("bn,sn->bs", d.counts, w)
        out.append(_pick(num / den[:, :, None], d.seeds))
    return np.mean(out, axis=0)


def mean_replicates(values: list, draws: list) -> np.ndarray:
    """A per-row mean (the true value) per replicate: `values` per data set `[S, n, k]`
    -> `[B, k]`."""
    out = []
    for v, d in zip(values, draws, strict=True):
        per_seed = np.einsum("bn,snk->bsk", d.counts, v) / d.counts.sum(axis=1)[:, None, None]
        out.append(_pick(per_seed, d.seeds))
    return np.mean(out, axis=0)


@dataclass(frozen=True)
class SetDraws:
    """Two-level bootstrap draws: `sets [B, D]` the drawn data sets, `seeds [B, D, S]` the
    training seeds drawn within each drawn set."""

    sets: np.ndarray
    seeds: np.ndarray


def draw_sets(rng: np.random.Generator, n_sets: int, n_seeds: int, n_boot: int) -> SetDraws:
    """`n_boot` replicates over `n_sets` data sets and, within each, `n_seeds` seeds."""
    sets = rng.integers(0, n_sets, (n_boot, n_sets))
    return SetDraws(sets=sets, seeds=rng.integers(0, n_seeds, (n_boot, n_sets, n_seeds)))


def set_replicates(per_seed: list, draws: SetDraws) -> np.ndarray:
    """A method's two-level replicates: the mean over the drawn data sets of the mean
    over their drawn seeds.

    Args:
      per_seed: per data set `[S, k]`, each training seed's estimate on all of that
        set's test rows (the oracle's `S` is 1: it takes its one value whatever the draw).
      draws: from `draw_sets`, shared by every method (paired).

    Returns:
      `[B, k]`.
    """
    stacked = np.stack(per_seed)  # [D, S, k]
    s = stacked.shape[1]
    picked = stacked[draws.sets[:, :, None], draws.seeds % s]  # [B, D, S', k]
    return picked.mean(axis=(1, 2))


def point(per_data: list) -> np.ndarray:
    """The estimate on the data as drawn: `per_data` per data set `[S, k]` -> `[k]`."""
    return np.mean([x.mean(axis=0) for x in per_data], axis=0)


def ci95(replicates: np.ndarray) -> np.ndarray:
    """Percentile interval `[2.5%, 97.5%]` of `[B, ...]` replicates: `[..., 2]`."""
    return np.moveaxis(np.percentile(replicates, [2.5, 97.5], axis=0), 0, -1)


def relative(x: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """`100 (x - ref) / |ref|` (nan where `ref` is 0)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(ref == 0, np.nan, 100.0 * (x - ref) / np.abs(ref))


def gap_share(x: np.ndarray, bc: np.ndarray, oracle: np.ndarray) -> np.ndarray:
    """`(x - bc) / (oracle - bc)`: 0 at Behavior-Clone, 1 at the oracle."""
    return (x - bc) / (oracle - bc)


def verdict(interval) -> str:
    """`"better"`/`"worse"` when the interval of a difference excludes 0, else `"n.s."`."""
    lo, hi = interval
    if lo > 0:
        return "better"
    if hi < 0:
        return "worse"
    return "n.s."
