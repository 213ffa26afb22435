"""The generic pieces of on-policy actor-critic training (as Brax keeps PPO's
`losses.py`): generalised advantage estimates, PPO's clipped surrogate, the minibatch
loss with its diagnostics, and epochs of shuffled minibatch steps.

Nothing here knows about preferences or scalarizations: the practical and the
conditioned updates (`wcac_jax.algos`) give these functions a scalarized advantage and
per-objective value targets. Each is a pure function; `gae` takes ONE environment's
trajectory (the caller vmaps over environments), `ppo_loss` takes its hyperparameters
as keywords (bind them once with `functools.partial`) and returns `(loss, metrics)`.
"""

from __future__ import annotations

import chex
import jax
import jax.numpy as jnp
import optax

from wcac_jax.core import networks


def gae(
    values: chex.Array,
    next_values: chex.Array,
    rewards: chex.Array,
    terminal: chex.Array,
    done: chex.Array,
    gamma: float,
    lam: float,
) -> chex.Array:
    """Per-objective generalised advantage estimates along ONE environment's trajectory.

    Time is the leading axis: transition `t` goes from `s_t` to `s'_t` (the true next
    state, also when the episode ended and the environment reset), so
    `delta_t = r_t + gamma (1 - terminal_t) V(s'_t) - V(s_t)` and
    `A_t = delta_t + gamma lam (1 - done_t) A_{t+1}`, with `A_L = 0`: a fall
    (`terminal`) does not bootstrap; a time-limit truncation (`done`, not `terminal`)
    bootstraps from `V(s'_t)`; neither carries advantages across the episode boundary;
    the last transition bootstraps from `V(s'_{L-1})`.

    Args:
      values: `[L, m]` `V(s_t)`.
      next_values: `[L, m]` `V(s'_t)`.
      rewards: `[L, m]`.
      terminal: `[L]`, 1 where `s'_t` is terminal.
      done: `[L]`, 1 where the episode ended at `t` (terminal or truncated).
      gamma: discount.
      lam: GAE's `lambda`.

    Returns:
      `[L, m]` advantages (the critic's targets are `advantages + values`).
    """
    chex.assert_rank([values, terminal, done], [2, 1, 1])
    chex.assert_equal_shape([values, next_values, rewards])
    deltas = rewards + gamma * (1.0 - terminal)[:, None] * next_values - values
    carry_on = gamma * lam * (1.0 - done)[:, None]

    def body(next_adv, x):
        delta, c = x
        adv = delta + c * next_adv
        return adv, adv

    _, adv = jax.lax.scan(body, jnp.zeros_like(deltas[0]), (deltas, carry_on), reverse=True)
    return adv


def clipped_surrogate(log_ratio: chex.Array, advantages: chex.Array, clip_eps: float):
    """PPO's clipped objective `mean(min(rho A, clip(rho, 1 - eps, 1 + eps) A))` (maximised).

    Args:
      log_ratio: `[B]` `log pi_new(a|s) - log pi_old(a|s)`.
      advantages: `[B]`.
      clip_eps: `eps`.

    Returns:
      A scalar.
    """
    chex.assert_equal_shape([log_ratio, advantages])
    ratio = jnp.exp(log_ratio)
    clipped = jnp.clip(ratio, 1.0 - clip_eps, 1.0 + clip_eps)
    return jnp.mean(jnp.minimum(ratio * advantages, clipped * advantages))


def normalize_advantages(adv: chex.Array) -> chex.Array:
    """`(A - mean) / (std + 1e-8)` over a minibatch `[B]`."""
    return (adv - jnp.mean(adv)) / (jnp.std(adv) + 1e-8)


def ppo_loss(
    params: dict,
    batch: dict,
    *,
    policy: networks.Policy,
    value_net: networks.Network,
    clip_eps: float,
    vf_coef: float,
    ent_coef: float,
) -> tuple[chex.Array, dict]:
    """One minibatch's loss (minimised) and diagnostics: `-surrogate + vf_coef * value_loss
    - ent_coef * entropy`, the surrogate on the minibatch-normalised advantage.

    Args:
      params: `{"actor", "critic"}` trainable parameters (what is differentiated).
      batch: `obs` `[B, obs]` (already preprocessed), `action` `[B, ...]`, `log_prob`
        `[B]` (the behaviour policy's), `advantage` `[B]` (scalarized), `target`
        `[B, m]`, and `actor_fixed` / `critic_fixed`, the `NetParams` whose `trainable`
        part `params` replaces.
      policy, value_net: the networks.
      clip_eps: the ratio's clipping range; vf_coef, ent_coef: the critic's and the
        entropy's weights.

    Returns:
      `(loss, {"value_loss", "approx_kl", "clip_fraction"})`, all scalars.
    """
    dist = policy.apply(batch["actor_fixed"].replace(trainable=params["actor"]), batch["obs"])
    log_ratio = policy.log_prob(dist, batch["action"]) - batch["log_prob"]
    surrogate = clipped_surrogate(log_ratio, normalize_advantages(batch["advantage"]), clip_eps)
    v = value_net.apply(batch["critic_fixed"].replace(trainable=params["critic"]), batch["obs"])
    value_loss = 0.5 * jnp.mean(jnp.square(v - batch["target"]))
    entropy = jnp.mean(policy.entropy(dist))
    loss = -surrogate + vf_coef * value_loss - ent_coef * entropy
    ratio = jnp.exp(log_ratio)
    return loss, {
        "value_loss": value_loss,
        "approx_kl": jnp.mean((ratio - 1.0) - log_ratio),
        "clip_fraction": jnp.mean((jnp.abs(ratio - 1.0) > clip_eps).astype(jnp.float32)),
    }


def minibatch_epochs(
    loss_fn,
    optimizer: optax.GradientTransformation,
    params,
    opt_state: optax.OptState,
    data: dict,
    key: chex.PRNGKey,
    num_epochs: int,
    num_minibatches: int,
    fixed: dict | None = None,
):
    """`num_epochs` passes over `data`, each a fresh permutation cut into
    `num_minibatches` minibatches, one `optimizer` step on `loss_fn` per minibatch.

    Args:
      loss_fn: `(params, minibatch) -> (loss, info)`.
      optimizer: an optax transformation.
      params, opt_state: where to start.
      data: leaves `[M, ...]`, `M` divisible by `num_minibatches`.
      key: the permutations' key (split into one per epoch).
      num_epochs, num_minibatches: static sizes.
      fixed: entries added unsliced to every minibatch.

    Returns:
      `((params, opt_state), info)`, `info`'s leaves `[num_epochs, num_minibatches, ...]`.
    """
    fixed = fixed or {}
    n = jax.tree.leaves(data)[0].shape[0]
    mb_size = n // num_minibatches

    def minibatch_step(carry, mb):
        params, opt_state = carry
        grads, info = jax.grad(loss_fn, has_aux=True)(params, {**mb, **fixed})
        updates, opt_state = optimizer.update(grads, opt_state, params)
        return (optax.apply_updates(params, updates), opt_state), info

    def epoch(carry, key):
        perm = jax.random.permutation(key, n)
        mbs = jax.tree.map(
            lambda x: x[perm].reshape((num_minibatches, mb_size, *x.shape[1:])), data
        )
        return jax.lax.scan(minibatch_step, carry, mbs)

    return jax.lax.scan(epoch, (params, opt_state), jax.random.split(key, num_epochs))
