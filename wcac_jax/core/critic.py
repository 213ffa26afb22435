"""Algorithm 2 (the DNN critic) as pure functions over a stack of `m` value networks.

The `m` critics share one architecture; their parameters are stacked on a leading `m`
axis and every per-objective operation is a `vmap` over it. One call of `update` is one
step `k` of Algorithm 2 for all objectives at once:

  `delta_i = V(s; W_i) - r_i - gamma (1 - terminal) V(s'; W_i)`   (TD error, paper's sign)
  `W_i <- Proj_B(W_i - beta * mean_N(delta_i * grad_W V(s; W_i)))`   (semi-gradient step)
  `Wbar_i <- (k+1)/(k+2) Wbar_i + 1/(k+2) W_i`                      (iterate average)

so that after `K` steps `Wbar_i` is the arithmetic mean of the `K + 1` iterates
`W_i(0), ..., W_i(K)`. Terminal states (the walker fell) do not bootstrap; time-limit
truncation does (the caller passes `terminal = 0` there and the true next observation).

Each outer iteration starts with `restart`: the paper restarts every critic from `W(0)`
(`warm_start=False`); by default (`warm_start=True`) the critics continue from their last
iterate, which learns far faster because a policy changes little between iterations. The
projection ball stays centred on the initial `W(0)` either way.

`apply` arguments are a network's `apply` (see `networks.Network`), whose output has one
entry (`[..., 1]`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import chex
import jax
import jax.numpy as jnp
from flax import struct

from wcac_jax.core.networks import NetParams, project_to_ball

Apply = Callable[[NetParams, chex.Array], chex.Array]


@struct.dataclass
class CriticState:
    """The `m` critics of Algorithm 2. Every leaf carries a leading `[m]` axis.

    Attributes:
      params: current iterates `W_i(k)` (trainable) and the fixed `A_i`, `c_i`.
      average: iterate averages `Wbar_i` (trainable part only); the actor uses these.
      center: initial trainable parameters `W_i(0)`: the projection's centre and the
        cold-start point.
      step: `k`, the number of TD steps taken in the current outer iteration.
    """

    params: NetParams
    average: Any
    center: Any
    step: chex.Array


def init(network_init: Callable[[chex.PRNGKey], NetParams], key: chex.PRNGKey, m: int):
    """Initialises `m` critics at the same `W(0)`, as Algorithm 2's line 2 does.

    Args:
      network_init: a network's `init`.
      key: PRNG key.
      m: number of objectives.

    Returns:
      A `CriticState` whose leaves have a leading `[m]` axis.
    """
    params = jax.tree.map(lambda x: jnp.broadcast_to(x, (m, *x.shape)), network_init(key))
    return CriticState(
        params=params,
        average=params.trainable,
        center=params.trainable,
        step=jnp.zeros((), jnp.int32),
    )


def restart(state: CriticState, warm_start: bool) -> CriticState:
    """Begins an outer iteration: from the last iterate (warm) or from `W(0)` (cold).

    The iterate average restarts at the starting point, so `Wbar` averages only the
    iterates of the current policy's evaluation.
    """
    start = state.params.trainable if warm_start else state.center
    return state.replace(
        params=state.params.replace(trainable=start),
        average=start,
        step=jnp.zeros_like(state.step),
    )


def values(apply: Apply, params: NetParams, obs: chex.Array) -> chex.Array:
    """Evaluates all `m` critics.

    Args:
      apply: a network's `apply`.
      params: stacked critic parameters, leaves `[m, ...]`.
      obs: `[..., obs]` (preprocessed) observations.

    Returns:
      `[..., m]` values.
    """
    out = jax.vmap(lambda p: apply(p, obs)[..., 0])(params)  # [m, ...]
    return jnp.moveaxis(out, 0, -1)


def averaged_params(state: CriticState) -> NetParams:
    """The averaged critics `Wbar` with their fixed parameters, leaves `[m, ...]`."""
    return state.params.replace(trainable=state.average)


def td_error(
    v: chex.Array, reward: chex.Array, v_next: chex.Array, terminal: chex.Array, gamma: float
) -> chex.Array:
    """`delta = V(s) - r - gamma (1 - terminal) V(s')`, elementwise (paper's sign)."""
    return v - reward - gamma * (1.0 - terminal) * v_next


def _td_step_one(
    apply: Apply,
    params: NetParams,
    obs: chex.Array,
    reward: chex.Array,
    next_obs: chex.Array,
    terminal: chex.Array,
    gamma: float,
    learning_rate: float,
    weight: chex.Array | None = None,
):
    """One semi-gradient TD(0) step for ONE objective on a batch of `N` transitions.

    Args: obs, next_obs `[N, obs]`; reward, terminal `[N]`; weight `[N]` or `None`.
    Returns: (new trainable parameters, TD errors `[N]`).
    """
    chex.assert_rank([obs, next_obs, reward, terminal], [2, 2, 1, 1])
    v_next = jax.lax.stop_gradient(apply(params, next_obs)[:, 0])

    def value_fn(trainable):
        return apply(params.replace(trainable=trainable), obs)[:, 0]

    v, vjp = jax.vjp(value_fn, params.trainable)
    delta = td_error(v, reward, v_next, terminal, gamma)
    weighted = delta if weight is None else weight * delta
    (grad,) = vjp(weighted / delta.shape[0])  # mean_N(weight * delta * grad V(s))
    new = jax.tree.map(lambda w, g: w - learning_rate * g, params.trainable, grad)
    return new, delta


def update(
    apply: Apply,
    state: CriticState,
    obs: chex.Array,
    reward: chex.Array,
    next_obs: chex.Array,
    terminal: chex.Array,
    *,
    gamma: float,
    learning_rate: float,
    radius: float,
    weight: chex.Array | None = None,
) -> tuple[CriticState, chex.Array]:
    """Step `k` of Algorithm 2 for all `m` critics: TD step, projection, averaging
    (`W_i <- Proj_B(W_i - beta mean_N(weight delta_i grad V_i(s)))`, then the average).

    Args:
      apply: the value network's `apply`.
      state: the critics.
      obs: `[N, obs]` preprocessed observations `s_k` (one per environment).
      reward: `[N, m]` reward vectors `r_{k+1}`.
      next_obs: `[N, obs]` preprocessed next observations `s_{k+1}` (the true ones, also
        on the step that ends an episode).
      terminal: `[N]`, 1 where `s_{k+1}` is terminal (no bootstrap), else 0.
      gamma: discount.
      learning_rate: `beta`.
      radius: projection radius `B` (`inf` for none).
      weight: `[N]` per-transition weights (e.g. importance weights of an off-policy
        batch); `None`: 1 each, Algorithm 2 itself.

    Returns:
      The new state and the TD errors, `[N, m]`.
    """
    chex.assert_rank(reward, 2)
    chex.assert_shape(terminal, (reward.shape[0],))
    new, delta = jax.vmap(_td_step_one, in_axes=(None, 0, None, 1, None, None, None, None, None))(
        apply, state.params, obs, reward, next_obs, terminal, gamma, learning_rate, weight
    )
    new = jax.vmap(project_to_ball, in_axes=(0, 0, None))(new, state.center, radius)
    k = state.step.astype(jnp.float32)
    average = jax.tree.map(
        lambda a, w: a * ((k + 1.0) / (k + 2.0)) + w / (k + 2.0), state.average, new
    )
    state = state.replace(
        params=state.params.replace(trainable=new), average=average, step=state.step + 1
    )
    return state, delta.T
