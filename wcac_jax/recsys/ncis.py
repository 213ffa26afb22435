"""Off-policy evaluation of the protocol (docs/recsys.md, "Protocol"): NCIS, and the ground
truth.

NCIS (normalised capped importance sampling): target `pi` and behaviour `pi_b` are both
Gaussians `N(action(s), sigma^2)` over the candidate index (`sigma = 25`); per logged
test transition `w = clip(pi(a | s) / pi_b(a | s), 0, cap)` (`cap = 10`) and per signal
the estimate is `sum w r / sum w`. The behaviour policy is Behavior-Clone, so
Behavior-Clone scored against itself (`w = 1`) returns the logged test means.

The ground truth (synthetic data only): the policy's expected signals when its Gaussian
action is rounded to the nearest candidate and clipped to `[0, C-1]`, under the
generator's response model (`synth.ResponseModel.expected`), averaged over the test rows;
and the oracle, the Gaussian policy of the same width whose mean maximises that true
value of a given objective row by row.
"""

from __future__ import annotations

import chex
import jax.numpy as jnp
from jax.scipy.special import ndtr

SIGMA = 25.0
CAP = 10.0


def importance_weights(
    target: chex.Array,
    behaviour: chex.Array,
    logged: chex.Array,
    sigma: float = SIGMA,
    cap: float = CAP,
) -> chex.Array:
    """`w = clip(N(a; target, sigma^2) / N(a; behaviour, sigma^2), 0, cap)`.

    Args:
      target, behaviour: `[n]` the two policies' actions `action(s)` (continuous indices).
      logged: `[n]` the logged actions `a`.

    Returns:
      `[n]` capped weights (the Gaussians' constants cancel; the ratio is taken in logs).
    """
    chex.assert_equal_shape([target, behaviour, logged])
    log_ratio = (jnp.square(logged - behaviour) - jnp.square(logged - target)) / (2 * sigma**2)
    return jnp.clip(jnp.exp(jnp.minimum(log_ratio, jnp.log(cap) + 1.0)), 0.0, cap)


def ncis(
    target: chex.Array,
    behaviour: chex.Array,
    logged: chex.Array,
    reward: chex.Array,
    sigma: float = SIGMA,
    cap: float = CAP,
) -> chex.Array:
    """NCIS per signal: `sum_n w_n r_n / sum_n w_n`.

    Args:
      target, behaviour, logged: `[n]` as `importance_weights`.
      reward: `[n, m]` logged reward vectors.

    Returns:
      `[m]` estimates.
    """
    chex.assert_rank(reward, 2)
    w = importance_weights(target, behaviour, logged, sigma, cap)
    return w @ reward / jnp.sum(w)


def index_probabilities(action: chex.Array, n_candidates: int, sigma: float = SIGMA):
    """`P(round(clip(A, 0, C-1)) = j)` for `A ~ N(action, sigma^2)`: `[n] -> [n, C]`.

    The mass below 0.5 goes to index 0 and above `C - 1.5` to index `C-1`.
    """
    edges = jnp.arange(1, n_candidates) - 0.5  # [C-1] boundaries between indices
    cdf = ndtr((edges[None, :] - action[:, None]) / sigma)  # [n, C-1]
    upper = jnp.concatenate([cdf, jnp.ones_like(cdf[:, :1])], axis=1)
    lower = jnp.concatenate([jnp.zeros_like(cdf[:, :1]), cdf], axis=1)
    return upper - lower


def true_value(action: chex.Array, expected: chex.Array, sigma: float = SIGMA) -> chex.Array:
    """The policy's true expected signals over the test rows.

    Args:
      action: `[n]` the policy's `action(s)` on the test rows.
      expected: `[n, C, m]` the response model's expected signals of each candidate for
        each row's user.

    Returns:
      `[m]` `mean_n sum_j P_nj E[r | user_n, video_j]`.
    """
    return jnp.mean(true_rows(action, expected, sigma), axis=0)


def true_rows(action: chex.Array, expected: chex.Array, sigma: float = SIGMA) -> chex.Array:
    """`true_value` row by row: `[n, m]`, `sum_j P_nj E[r | user_n, video_j]`."""
    chex.assert_rank(expected, 3)
    p = index_probabilities(action, expected.shape[1], sigma)
    return jnp.einsum("nc,ncm->nm", p, expected)


def effective_sample_size(weights: chex.Array) -> chex.Array:
    """Kish's effective sample size of importance weights, `(sum w)^2 / sum w^2`: `[n] -> []`.

    `n` when every weight is equal, 1 when one weight carries everything.
    """
    return jnp.square(jnp.sum(weights)) / jnp.sum(jnp.square(weights))


def oracle_actions(expected: chex.Array, coeff: chex.Array, sigma: float = SIGMA) -> chex.Array:
    """The best Gaussian policy's mean for each row under the true response model.

    Among the means `g = 0, 1, ..., C-1`, the one whose smoothed policy (`N(g, sigma^2)`,
    rounded and clipped to a candidate, as `true_value` scores it) maximises the row's
    preference-weighted true value `sum_j P(j | g) E[r | row, video_j] . coeff`.

    Args:
      expected: `[n, C, m]` true expected signals of each candidate for each row.
      coeff: `[m]` the objective's weight of each signal (preference times scale).

    Returns:
      `[n]` the best means (float).
    """
    c = expected.shape[1]
    probs = index_probabilities(jnp.arange(c, dtype=jnp.float32), c, sigma)  # [G=C, C]
    value = (expected @ coeff) @ probs.T  # [n, G]
    return jnp.argmax(value, axis=-1).astype(jnp.float32)
