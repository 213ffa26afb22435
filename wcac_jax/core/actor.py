"""Algorithm 1 (the actor) as pure functions, with the sign fixed as in docs/algorithm.md.

From `M = N * L` on-policy transitions and the averaged critics:

  `A_i = r_i + gamma (1 - terminal) V(s'; Wbar_i) - V(s; Wbar_i)`   (TD-residual advantage)
  `gradJ_i = mean_M(A_i * psi)`, `psi = grad_theta log pi(a | s)`   (policy gradient)
  `Jhat_i = mean_{s0} V(s0; Wbar_i)`                                 (start-state value)
  `d = -sum_i w_i p_i gradJ_i`                                       (estimate of grad G)

where `w` are the scalarization's objective weights (`lambda` for `smooth_wc`, see
`scalarize`). `d` is computed with ONE backward pass through
`mean_M(stop_gradient(sum_i w_i p_i A_i) * log pi(a | s))`, never `m` passes. The step
`theta <- theta - alpha_t d / ||d||` descends `G`; it is an optax transformation built by
`make_optimizer`, whose alternatives apply adam or sgd to `d` instead.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import chex
import jax
import jax.numpy as jnp
import optax

from wcac_jax.core.networks import NetParams

# `(params, obs [M, obs], action [M, ...]) -> log pi(a | s) [M]`
LogProb = Callable[[NetParams, chex.Array, chex.Array], chex.Array]

ACTOR_OPTIMIZERS = ("normalized", "normalized_harmonic", "adam", "sgd")


def td_advantages(
    v: chex.Array, reward: chex.Array, v_next: chex.Array, terminal: chex.Array, gamma: float
) -> chex.Array:
    """TD-residual advantages `A = r + gamma (1 - terminal) V(s') - V(s)`.

    Args:
      v, reward, v_next: `[..., m]`.
      terminal: `[...]`, 1 where `s'` is terminal.
      gamma: discount.

    Returns:
      `[..., m]`.
    """
    chex.assert_equal_shape([v, reward, v_next])
    return reward + gamma * (1.0 - terminal)[..., None] * v_next - v


def objective_estimates(start_values: chex.Array) -> chex.Array:
    """`Jhat_i`: the mean over start states of the critics' values. `[S, m] -> [m]`."""
    chex.assert_rank(start_values, 2)
    return jnp.mean(start_values, axis=0)


def surrogate(
    log_prob: LogProb,
    trainable: Any,
    fixed: Any,
    obs: chex.Array,
    action: chex.Array,
    coeff: chex.Array,
) -> chex.Array:
    """`mean_M(coeff * log pi(a | s))`: its gradient is `mean_M(coeff * psi)`.

    Args:
      log_prob: the policy's `log pi(a | s)` (of the unclipped action).
      trainable, fixed: the policy's parameters (differentiated w.r.t. `trainable`).
      obs: `[M, obs]`; action: `[M, act]` or `[M]`; coeff: `[M]` (treated as a constant).
    """
    chex.assert_rank([obs, coeff], [2, 1])
    lp = log_prob(NetParams(trainable, fixed), obs, action)
    return jnp.mean(jax.lax.stop_gradient(coeff) * lp)


def direction(
    log_prob: LogProb,
    params: NetParams,
    obs: chex.Array,
    action: chex.Array,
    advantages: chex.Array,
    objective_weights: chex.Array,
    pref: chex.Array,
) -> Any:
    """The descent direction `d = -sum_i w_i p_i gradJ_i`, in one backward pass.

    Args:
      log_prob: the policy's `log pi(a | s)`, `(params, obs, action) -> [M]`.
      params: the policy's parameters.
      obs: `[M, obs]` preprocessed observations.
      action: `[M, act]` (or `[M]` for discrete actions) the sampled, unclipped actions.
      advantages: `[M, m]` advantage estimates `A_i`.
      objective_weights: `[m]` scalarization weights `w` (e.g. `lambda`).
      pref: `[m]` preference vector.

    Returns:
      A pytree like `params.trainable`: `d`, an estimate of the gradient of the
      scalarized objective (which is minimised).
    """
    chex.assert_rank([advantages, objective_weights, pref], [2, 1, 1])
    coeff = advantages @ (objective_weights * pref)  # [M]
    grad = jax.grad(surrogate, argnums=1)(
        log_prob, params.trainable, params.fixed, obs, action, coeff
    )
    return jax.tree.map(jnp.negative, grad)


def objective_gradients(
    log_prob: LogProb,
    params: NetParams,
    obs: chex.Array,
    action: chex.Array,
    advantages: chex.Array,
) -> Any:
    """The `m` per-objective policy gradients `gradJ_i = mean_M(A_i psi)`.

    `m` backward passes (vmapped); `direction` needs only one. Used by multi-gradient
    methods and tests. Returns a pytree like `params.trainable` with a leading `[m]` axis.
    """
    chex.assert_rank(advantages, 2)
    return jax.vmap(
        lambda a: jax.grad(surrogate, argnums=1)(
            log_prob, params.trainable, params.fixed, obs, action, a
        )
    )(advantages.T)


def make_optimizer(kind: str, learning_rate: float) -> optax.GradientTransformation:
    """The actor's step on `d` as an optax transformation.

    - `"normalized"`: the paper's step `theta - alpha d / ||d||` with constant `alpha`
      (its experiments); the norm is global over all trainable parameters.
    - `"normalized_harmonic"`: the same with `alpha_t = alpha / (t + 1)` (its theory).
    - `"adam"`, `"sgd"`: optax's optimisers applied to `d` (practical alternatives).

    Args:
      kind: one of `ACTOR_OPTIMIZERS`.
      learning_rate: `alpha`.
    """
    if kind == "normalized":
        return optax.chain(
            optax.normalize_by_update_norm(), optax.scale_by_learning_rate(learning_rate)
        )
    if kind == "normalized_harmonic":
        return optax.chain(
            optax.normalize_by_update_norm(),
            optax.scale_by_learning_rate(lambda t: learning_rate / (t + 1.0)),
        )
    if kind == "adam":
        return optax.adam(learning_rate)
    if kind == "sgd":
        return optax.sgd(learning_rate)
    raise ValueError(f"unknown actor optimizer {kind!r}; valid: {', '.join(ACTOR_OPTIMIZERS)}")


def min_norm_weights(
    gram: chex.Array, mask: chex.Array | None = None, num_steps: int = 100
) -> chex.Array:
    """The convex weights of the min-norm point of a set of vectors, from their Gram matrix.

    Solves `min_{lambda in simplex} lambda^T G lambda` (`G_ij = g_i . g_j`) by Frank-Wolfe
    with exact line search (MGDA-UB, Sener & Koltun 2018): the result's combination
    `v = sum_i lambda_i g_i` satisfies `v . g_i >= ||v||^2` for every `i` at the optimum.
    With `mask`, only the vectors with `mask_i` true take part (the others get weight 0).

    Args:
      gram: `[m, m]` Gram matrix.
      mask: optional `[m]` booleans, at least one true: the vectors in the hull.
      num_steps: Frank-Wolfe iterations (exact for `m = 2` after one step).

    Returns:
      `[m]` weights on the simplex, 0 where `mask` is false.
    """
    chex.assert_rank(gram, 2)
    m = gram.shape[0]
    mask = jnp.ones((m,), bool) if mask is None else mask
    chex.assert_shape(mask, (m,))

    def step(_, lam):
        g_lam = gram @ lam
        t = jnp.argmin(jnp.where(mask, g_lam, jnp.inf))
        vv, vt, tt = lam @ g_lam, g_lam[t], gram[t, t]
        denom = vv - 2.0 * vt + tt
        gamma = jnp.where(denom > 1e-20, jnp.clip((vv - vt) / jnp.maximum(denom, 1e-20), 0, 1), 0)
        return (1.0 - gamma) * lam + gamma * jax.nn.one_hot(t, m, dtype=lam.dtype)

    lam0 = mask.astype(gram.dtype) / jnp.sum(mask)
    return jax.lax.fori_loop(0, num_steps, step, lam0)


def mgda_direction(
    log_prob: LogProb,
    params: NetParams,
    obs: chex.Array,
    action: chex.Array,
    advantages: chex.Array,
    pref: chex.Array,
) -> tuple[Any, chex.Array]:
    """MGDA's common-descent direction (the MOAC-style baseline of the paper's Remark 2).

    The min-norm point `v = sum_i lambda_i gradJ_i / p_i` of the convex hull of the
    policy gradients of the objectives with `p_i > 0`, each divided by its preference
    (`m` backward passes); `d = -v` is a descent direction for every one of those
    objectives at once (`-d . gradJ_i >= 0`), converging to a policy that is Pareto
    *stationary* among them.

    The preference enters as `1 / p_i`, so the min-norm point leans towards the
    preferred objectives: with two orthogonal gradients of equal norm, `v` is proportional
    to `p_1 gradJ_1 + p_2 gradJ_2`, the linear scalarization's direction. Multiplying by
    `p_i` instead would give `gradJ_1 / p_1 + gradJ_2 / p_2` there, favouring the objective
    the preference cares less about, and would put `0` in the hull as soon as some
    `p_i = 0` (then `d = 0`: the corners of the simplex would never move). An objective
    with `p_i = 0` is dropped: the hull holds only the other objectives' gradients, so at
    a corner `e_i` the direction is `-gradJ_i`. With equal preferences this is plain MGDA.

    Args: as `direction`, without the scalarization weights.

    Returns:
      `(d, lambda)`: the direction (like `params.trainable`) and the `[m]` MGDA weights
      on the scaled gradients `gradJ_i / p_i` (0 where `p_i = 0`).
    """
    grads = objective_gradients(log_prob, params, obs, action, advantages)
    active = pref > 0
    inv_pref = jnp.where(active, 1.0 / jnp.where(active, pref, 1.0), 0.0)
    scaled = jax.tree.map(lambda g: g * inv_pref.reshape((-1,) + (1,) * (g.ndim - 1)), grads)
    flat = jnp.concatenate(
        [g.reshape(g.shape[0], -1) for g in jax.tree.leaves(scaled)], axis=1
    )  # [m, n_params]
    lam = min_norm_weights(flat @ flat.T, active)
    d = jax.tree.map(lambda g: -jnp.tensordot(lam, g, axes=1), scaled)
    return d, lam
