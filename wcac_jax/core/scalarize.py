"""Scalarizations of a vector of objective values, each a *minimisation* objective.

Rewards are maximised, so every scalarization here is a regret to be minimised
(docs/algorithm.md): the hard weighted Chebyshev `g`, its log-sum-exp smoothing `G_mu`, and the
linear baseline. Each function takes ONE sample (vectors of shape `[m]`) and returns a
scalar or an `[m]` vector; callers `vmap` over preferences or batches. All of them are
jittable, vmappable and differentiable, and import nothing but jax and chex.

The *objective weights* `w(J | p)` of a scalarization `S` are defined by
`grad_J S(J | p) = -w * p` (elementwise), so an actor can build the descent direction
`-sum_i w_i p_i grad J_i` from per-objective policy gradients without differentiating `S`:

- `smooth_wc`: `w = softmax(p * (J_ub - J) / mu)` (the paper's `lambda`),
- `wc`: `w = onehot(argmax_i p_i (J_ub_i - J_i))` (a subgradient),
- `linear`: `w = 1`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple, Protocol

import chex
import jax
import jax.numpy as jnp


def _regrets(values: chex.Array, pref: chex.Array, j_ub: chex.Array) -> chex.Array:
    chex.assert_rank([values, pref, j_ub], 1)
    chex.assert_equal_shape([values, pref, j_ub])
    return pref * (j_ub - values)


def linear(values: chex.Array, pref: chex.Array) -> chex.Array:
    """Linear scalarization `L(J | p) = -sum_i p_i J_i` (to be minimised).

    Args:
      values: `[m]` objective values `J` (higher is better).
      pref: `[m]` preference vector on the simplex.

    Returns:
      A scalar.
    """
    chex.assert_rank([values, pref], 1)
    chex.assert_equal_shape([values, pref])
    return -jnp.dot(pref, values)


def wc(values: chex.Array, pref: chex.Array, j_ub: chex.Array) -> chex.Array:
    """Hard weighted Chebyshev `g(J | p) = max_i p_i (J_ub_i - J_i)`.

    Args:
      values: `[m]` objective values `J`.
      pref: `[m]` preference vector.
      j_ub: `[m]` utopia point, `J_ub_i > J_i` for every policy.

    Returns:
      A scalar.
    """
    return jnp.max(_regrets(values, pref, j_ub))


def smooth_wc(
    values: chex.Array, pref: chex.Array, j_ub: chex.Array, mu: chex.Numeric
) -> chex.Array:
    """Smoothed weighted Chebyshev `G_mu(J | p) = mu * logsumexp_i(p_i (J_ub_i - J_i) / mu)`.

    Uses a max-shifted logsumexp, so arguments `p_i (J_ub_i - J_i) / mu` of 1e6 and more
    neither overflow nor produce NaN. `g <= G_mu <= g + mu log m`, and `G_mu -> g` as
    `mu -> 0`.

    Args:
      values: `[m]` objective values `J`.
      pref: `[m]` preference vector.
      j_ub: `[m]` utopia point.
      mu: smoothing temperature, `mu > 0`.

    Returns:
      A scalar.
    """
    return mu * jax.nn.logsumexp(_regrets(values, pref, j_ub) / mu)


def smooth_wc_weights(
    values: chex.Array, pref: chex.Array, j_ub: chex.Array, mu: chex.Numeric
) -> chex.Array:
    """The objective weights `lambda = softmax(p * (J_ub - J) / mu)` of `smooth_wc`.

    They sum to one and satisfy `grad_J G_mu = -lambda * p`, hence
    `grad_theta G_mu = -sum_i lambda_i p_i grad_theta J_i`.

    Args:
      values: `[m]` objective values `J`.
      pref: `[m]` preference vector.
      j_ub: `[m]` utopia point.
      mu: smoothing temperature, `mu > 0`.

    Returns:
      `[m]` weights on the simplex.
    """
    return jax.nn.softmax(_regrets(values, pref, j_ub) / mu)


def wc_weights(values: chex.Array, pref: chex.Array, j_ub: chex.Array) -> chex.Array:
    """Subgradient weights of `wc`: one-hot on the objective with the largest regret.

    Ties go to the lowest index (a valid subgradient).

    Args:
      values: `[m]`; pref: `[m]`; j_ub: `[m]`.

    Returns:
      `[m]` one-hot weights.
    """
    regrets = _regrets(values, pref, j_ub)
    return jax.nn.one_hot(jnp.argmax(regrets), regrets.shape[0], dtype=regrets.dtype)


def linear_weights(values: chex.Array, pref: chex.Array) -> chex.Array:
    """Objective weights of `linear`: all ones, since `grad_J L = -p`.

    Args:
      values: `[m]`; pref: `[m]`.

    Returns:
      `[m]` ones.
    """
    chex.assert_equal_shape([values, pref])
    return jnp.ones_like(values)


def augmented_coefficients(weights: chex.Array, pref: chex.Array, rho: chex.Numeric) -> chex.Array:
    """Descent coefficients `c = w * p + rho` of a scalarization augmented by
    `rho * sum_i (J_ub_i - J_i)`.

    The augmented weighted Chebyshev `S(J | p) + rho * sum_i (J_ub_i - J_i)` (Steuer and
    Choo, 1983) keeps a small weight `rho` on every objective, also where `p_i = 0`, so
    its minimisers are Pareto optimal rather than only weakly so (e.g. the `p = [1, 0]`
    end of a front no longer ignores the second objective). Since
    `grad_J S = -w * p`, the augmented scalarization has `grad_J = -(w * p + rho)`, and an
    actor descends it along `-sum_i c_i grad J_i`. `rho = 0` is `S` itself.

    Args:
      weights: `[m]` the scalarization's objective weights `w(J | p)`.
      pref: `[m]` preference vector.
      rho: the augmentation's weight, `rho >= 0`.

    Returns:
      `[m]` coefficients.
    """
    chex.assert_equal_shape([weights, pref])
    return weights * pref + rho


def augmentation(values: chex.Array, j_ub: chex.Array, rho: chex.Numeric) -> chex.Array:
    """The augmentation term `rho * sum_i (J_ub_i - J_i)` (a scalar; see
    `augmented_coefficients`).

    Args:
      values: `[m]` objective values `J`; j_ub: `[m]` utopia point; rho: its weight.
    """
    chex.assert_equal_shape([values, j_ub])
    return rho * jnp.sum(j_ub - values)


class _ValueFn(Protocol):
    def __call__(self, values, pref, j_ub, mu) -> chex.Array: ...


class Scalarization(NamedTuple):
    """A scalarization as a pair of per-sample functions with one signature.

    Attributes:
      value: `(values [m], pref [m], j_ub [m], mu) -> scalar`, to be minimised.
      weights: `(values [m], pref [m], j_ub [m], mu) -> [m]`, with
        `grad_J value = -weights * pref`.
    """

    value: _ValueFn
    weights: _ValueFn


def weights_by_autodiff(value: _ValueFn) -> _ValueFn:
    """The objective weights of `value` from its gradient: `w_i = -dS/dJ_i / p_i` where
    `p_i > 0`, and 0 where `p_i = 0`.

    Exact for a scalarization that sees `J` only through the regrets `p_i (J_ub_i - J_i)`
    (as every one here does): its gradient vanishes where `p_i = 0`, so `w * p` there is
    0 whatever `w_i` is. A scalarization that also weighs objectives with `p_i = 0` needs
    weights of its own.
    """

    def weights(values, pref, j_ub, mu):
        grad = jax.grad(value)(values, pref, j_ub, mu)
        active = pref > 0
        return jnp.where(active, -grad / jnp.where(active, pref, 1.0), 0.0)

    return weights


def register(name: str, value: _ValueFn, weights: _ValueFn | None = None) -> None:
    """Adds a scalarization under `name` (`weights` default: `weights_by_autodiff`), at
    import or later, from a user's own code. Registered names are valid `scalarization`
    values of every update and indices of the traced direction (`NAMES`), in
    registration order."""
    SCALARIZATIONS[name] = Scalarization(value, weights or weights_by_autodiff(value))


class _Names(Sequence):
    """The registered names in registration order, read from `SCALARIZATIONS` whenever
    asked: a name registered after import is in it."""

    def __getitem__(self, index):
        return tuple(SCALARIZATIONS)[index]

    def __len__(self) -> int:
        return len(SCALARIZATIONS)

    def __repr__(self) -> str:
        return repr(tuple(SCALARIZATIONS))


# name -> scalarization; the order is that of the traced direction index
SCALARIZATIONS: dict[str, Scalarization] = {}
# every registered name, in registration order: a traced direction is an index into it
NAMES = _Names()
register("smooth_wc", smooth_wc, smooth_wc_weights)
register("wc", lambda v, p, z, mu: wc(v, p, z), lambda v, p, z, mu: wc_weights(v, p, z))
register("linear", lambda v, p, z, mu: linear(v, p), lambda v, p, z, mu: linear_weights(v, p))


def get(name: str) -> Scalarization:
    """Looks up a registered scalarization by name (`smooth_wc`, `wc`, `linear`, ...).

    Raises:
      ValueError: naming the bad value and the valid ones.
    """
    try:
        return SCALARIZATIONS[name]
    except KeyError:
        raise ValueError(
            f"unknown scalarization {name!r}; valid: {', '.join(sorted(SCALARIZATIONS))}"
        ) from None
