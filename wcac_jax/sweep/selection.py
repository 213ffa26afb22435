"""Each preference's reported policy chosen among its last few, by the run's own criterion.

A sweep reports, per preference, the policy it ends with. On-policy training oscillates,
and a Walker2d policy that ends a run falling in one evaluation episode in eight has often
had a sibling a few iterations earlier that stood. With `select_last = K > 1` the sweep
keeps the policies at the `K` iterations

    T - (K - 1 - j) * every,   j = 0 .. K-1      (the last is the final policy)

evaluates each on the same `eval_episodes` start states per preference (keys distinct
from the final evaluation's), and reports for preference `p` the candidate with the least
score of its evaluated undiscounted returns `J` (`[m]`) under the run's own
scalarization (`criterion`): for `smooth_wc` (the method), `wc` and `mgda` the
weighted-Chebyshev regret

    scalarize.wc(J, p, z) = max_i p_i (z_i - J_i)

(the limit of `smooth_wc` as `mu -> 0`), for `linear` its own score
`scalarize.linear(J, p) = -sum_i p_i J_i`, for any other registered scalarization its
`value(J, p, z, mu)`. `z` is one utopia point for the whole sweep, estimated from every
candidate of every preference by `wcac_jax.core.utopia`'s rule (`utopia.point`): `z_i = max
J_i + margin * max(spread_i, min_spread)` with `spread_i = max J_i - min J_i` over all
candidates and preferences, the margin and spread floor the run's own
(`PracticalConfig.utopia_margin`, `utopia_min_spread`; a configuration without them, the
paper's, uses `MARGIN` and `MIN_SPREAD`). Ties go to the later candidate. The front is
then evaluated afresh (`front.json`), on episodes the choice was not made on. Training
is untouched: the choice changes only which of a preference's own policies is reported,
at `K * eval_episodes` evaluation episodes per preference (the sweep records their env
steps).

The candidate iterations are fixed by the configuration (not by the chunking), so a sweep
chooses the same policies however it is split into chunks or resumed.

`utopia_point` and `choose` are pure jnp functions (jit/vmap/grad); `Pool`
holds the candidates on the host between chunks.
"""

from __future__ import annotations

from typing import NamedTuple

import chex
import jax
import jax.numpy as jnp
import numpy as np

from wcac_jax.core import scalarize, utopia

# `utopia_point`'s margin and spread floor where the run's configuration has none (the
# paper's): the practical preset's defaults (`PracticalConfig.utopia_margin`,
# `utopia_min_spread`)
MARGIN = 0.1
MIN_SPREAD = 1.0
# scalarizations whose choice is scored by the hard weighted Chebyshev: `smooth_wc` is its
# smoothing, and MGDA has no scalarization of its own (its progress is reported with
# `smooth_wc`)
_BY_WC = ("smooth_wc", "wc", "mgda")


class Criterion(NamedTuple):
    """What a sweep's choice scores its candidates by (`criterion`).

    Attributes:
      score: a registered scalarization (`wcac_jax.core.scalarize`), evaluated at each
        candidate's returns and minimised.
      margin: the utopia point's margin over the best return (`utopia_point`).
      min_spread: the utopia point's least spread.
      mu: the scalarization's temperature, for a score that takes one.
    """

    score: str = "wc"
    margin: float = MARGIN
    min_spread: float = MIN_SPREAD
    mu: float = 1.0


def criterion(train) -> Criterion:
    """The choice's `Criterion` of a run whose per-preference training configuration is
    `train` (a `PaperConfig` or `PracticalConfig`): its scalarization (`smooth_wc`,
    `mgda`: the hard weighted Chebyshev), its utopia margin and spread floor."""
    name = train.scalarization
    return Criterion(
        score="wc" if name in _BY_WC else name,
        margin=float(getattr(train, "utopia_margin", MARGIN)),
        min_spread=float(getattr(train, "utopia_min_spread", MIN_SPREAD)),
        mu=float(train.mu),
    )


def rule(score: str) -> str:
    """`front.json`'s words for the choice by `score`."""
    if score == "wc":
        return "least max_i p_i (z_i - J_i) over the candidates' evaluated returns J"
    if score == "linear":
        return "least -sum_i p_i J_i over the candidates' evaluated returns J"
    return f"least {score}(J | p, z, mu) over the candidates' evaluated returns J"


def candidate_iterations(num_iterations: int, last: int, every: int) -> tuple[int, ...]:
    """The iterations (1-based counts of iterations done) whose policies are candidates.

    Args:
      num_iterations: `T`, the sweep's iterations per preference.
      last: `K >= 1` candidates (1: the final policy only, no choice).
      every: iterations between candidates (`>= 1` when `K > 1`).

    Raises:
      ValueError: `K < 1`, `every < 1` with `K > 1`, or a candidate before iteration 1.
    """
    if last < 1:
        raise ValueError(f"select_last must be >= 1, got {last}")
    if last > 1 and every < 1:
        raise ValueError(f"select_every must be >= 1 iteration with select_last {last}")
    first = num_iterations - (last - 1) * every
    if first < 1:
        raise ValueError(
            f"select_last {last} candidates {every} iterations apart need more than "
            f"{(last - 1) * every} iterations; the sweep has {num_iterations}"
        )
    return tuple(first + j * every for j in range(last))


def utopia_point(
    returns: chex.Array, margin: float = MARGIN, min_spread: float = MIN_SPREAD
) -> chex.Array:
    """`[m]`: `max J_i + margin * max(max J_i - min J_i, min_spread)` over every leading
    axis of `returns` `[..., m]` (all candidates of all preferences)."""
    flat = returns.reshape((-1, returns.shape[-1]))
    hi, lo = jnp.max(flat, axis=0), jnp.min(flat, axis=0)
    return utopia.point(hi, lo, margin=margin, min_spread=min_spread)


def choose(
    returns: chex.Array,
    prefs: chex.Array,
    margin: float = MARGIN,
    min_spread: float = MIN_SPREAD,
    score: str = "wc",
    mu: float = 1.0,
) -> tuple[chex.Array, chex.Array, chex.Array]:
    """Each preference's candidate of least regret.

    Args:
      returns: `[K, P, m]` evaluated returns of candidate `k` of preference `p`.
      prefs: `[P, m]` preferences.
      margin, min_spread: the utopia point's (`utopia_point`).
      score: the registered scalarization the candidates are scored by (`Criterion`).
      mu: its temperature, for a score that takes one.

    Returns:
      `(index [P], z [m], regrets [K, P])`: the chosen candidate per preference (the
      latest among ties), the utopia point, and every candidate's regret.
    """
    chex.assert_rank(returns, 3)
    z = utopia_point(returns, margin, min_spread)
    # e.g. `scalarize.wc`: max_i p_i (z_i - J_i), per candidate and preference
    value = scalarize.get(score).value
    regrets = jax.vmap(jax.vmap(value, in_axes=(0, 0, None, None)), in_axes=(0, None, None, None))(
        returns, prefs, z, mu
    )
    k = returns.shape[0]
    index = k - 1 - jnp.argmin(regrets[::-1], axis=0)  # argmin's first = the latest
    return index, z, regrets


def take(stacked, index):
    """The pytree `stacked` (leaves `[K, P, ...]`) at candidate `index[p]` for each `p`:
    leaves `[P, ...]`."""
    index = np.asarray(index)
    rows = np.arange(index.shape[0])
    return jax.tree.map(lambda x: np.asarray(x)[index, rows], stacked)


class Pool:
    """The candidates of a sweep, on the host: every candidate's state and evaluation,
    stacked on a leading candidate axis (`[K, P, ...]`, `P` the preference rows the
    sweep runs, padding included).

    Attributes:
      iterations: the candidate iterations (`candidate_iterations`).
      tree: `{"states", "eval/return", "eval/discounted_return", "eval/length"}`, the
        checkpointed part (`states`: the state's leaves, a list: some state pytrees,
        such as Brax's `UInt64`, turn numpy leaves back into jax arrays when rebuilt);
        slot `k` is filled once `iterations[k]` is done.
    """

    def __init__(self, iterations: tuple[int, ...], state_template, eval_template):
        self.iterations = tuple(iterations)
        k = len(self.iterations)

        def stack(x):  # `x`: an array or a `jax.ShapeDtypeStruct`
            return np.zeros((k, *x.shape), x.dtype)

        leaves, self.treedef = jax.tree.flatten(state_template)
        self.tree = {"states": [stack(x) for x in leaves]}
        self.tree.update({name: stack(v) for name, v in eval_template.items()})

    def next_stop(self, done: int, num_iterations: int) -> int:
        """The first candidate iteration after `done`, else `num_iterations`."""
        return next((t for t in self.iterations if t > done), num_iterations)

    def add(self, iteration: int, state, evaluation) -> None:
        """Stores the host `state` and `evaluation` of candidate `iteration`."""
        k = self.iterations.index(iteration)

        for slot, x in zip(self.tree["states"], jax.tree.leaves(state), strict=True):
            slot[k] = np.asarray(x)
        for name, v in evaluation.items():
            self.tree[name][k] = np.asarray(v)

    def choose(
        self, prefs: np.ndarray, by: Criterion | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        """`(index [P], z [m], regrets [K, P], state)`: `choose` by `by` on the stored
        returns, and the chosen state (leaves `[P, ...]`) of every row of `prefs` `[P, m]`
        (the rows the pool holds, padding included)."""
        by = by or Criterion()
        index, z, regrets = choose(
            jnp.asarray(self.tree["eval/return"]),
            jnp.asarray(prefs),
            margin=by.margin,
            min_spread=by.min_spread,
            score=by.score,
            mu=by.mu,
        )
        index = np.asarray(index)
        state = self.treedef.unflatten(take(self.tree["states"], index))
        return index, np.asarray(z), np.asarray(regrets), state

    def summary(
        self,
        index: np.ndarray,
        z: np.ndarray,
        regrets: np.ndarray,
        n: int,
        episodes: int,
        final: dict,
        by: Criterion | None = None,
    ) -> dict:
        """What `front.json` records of the choice (`selection`), for the first `n` rows;
        `episodes` evaluation episodes per candidate; `final`: the final policies'
        evaluation on the reported episodes (`eval/return`, `eval/length`), the front the
        sweep reports without the choice; `by`: the criterion the choice used."""
        by = by or Criterion()
        length = np.asarray(self.tree["eval/length"])[:, :n]
        return {
            "rule": rule(by.score),
            "score": by.score,
            "candidate_iterations": list(self.iterations),
            "utopia": z.tolist(),
            "margin": by.margin,
            "min_spread": by.min_spread,
            "chosen_iteration": [self.iterations[int(k)] for k in index[:n]],
            "candidate_return": np.asarray(self.tree["eval/return"])[:, :n].tolist(),
            "candidate_length": length.tolist(),
            "regret": regrets[:, :n].tolist(),
            # the env steps the candidates' evaluation took, per preference (the episodes
            # run to a fall or the time limit)
            "env_steps_per_pref": np.rint(episodes * length.sum(axis=0)).astype(int).tolist(),
            # the final policies on the reported evaluation's episodes: the same training
            # without the choice, paired with `front.json`'s rows
            "final_return": np.asarray(final["eval/return"])[:n].tolist(),
            "final_length": np.asarray(final["eval/length"])[:n].tolist(),
        }
