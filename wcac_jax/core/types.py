"""Small pytree types shared by the training modules, and the PRNG key type they take."""

from __future__ import annotations

import chex
import jax
import jax.numpy as jnp
from flax import struct


def typed_key(key: chex.PRNGKey) -> chex.PRNGKey:
    """Accepts a typed key (`jax.random.key`) or raw uint32 key data (`PRNGKey`)."""
    if jnp.issubdtype(key.dtype, jax.dtypes.prng_key):
        return key
    return jax.random.wrap_key_data(key)


@struct.dataclass
class Transition:
    """A batch of transitions; every field has the same leading axes (e.g. `[N]`, `[L, N]`).

    Attributes:
      obs: `[..., obs]` raw observation `s`.
      action: `[..., act]` the sampled, unclipped action `a` (its score is used).
      reward: `[..., m]` reward vector `r`.
      next_obs: `[..., obs]` the true raw next observation `s'` (before any auto-reset).
      terminal: `[...]` 1 where `s'` is terminal (no bootstrap), else 0.
      done: `[...]` 1 where the episode ended (terminal or time limit), else 0.
    """

    obs: chex.Array
    action: chex.Array
    reward: chex.Array
    next_obs: chex.Array
    terminal: chex.Array
    done: chex.Array


@struct.dataclass
class EpisodeStats:
    """Per-environment episode bookkeeping, `[N, m]` / `[N]`.

    Attributes:
      running_return: undiscounted return of the episode in progress.
      last_return: undiscounted return of the most recently finished episode.
      finished: number of episodes finished so far.
    """

    running_return: chex.Array
    last_return: chex.Array
    finished: chex.Array
