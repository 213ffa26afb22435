"""A utopia point the sweep estimates itself, from all its preferences at once.

Weighted Chebyshev measures each objective's regret against a utopia point `z` that no
policy should reach. A fixed `z` (the paper's `J_ub`) must be guessed in advance, and a
guess far above the achievable returns makes `lambda` one-hot for the whole run. A sweep
trains every preference together, so it can estimate `z` from what all of them reach:

  `best_i <- max(best_i, max_p Jhat_i(p))`   (the best `Jhat_i` any preference reached so far)
  `spread_i = best_i - min_p Jhat_i(p)`      (how far apart the preferences are now)
  `z_i = best_i + margin * max(spread_i, min_spread)`

`max_p` and `min_p` are collectives over the vmapped preference axis (`jax.lax.pmax` /
`pmin` on the axis named `PREF_AXIS`) when the caller runs under
`jax.vmap(..., axis_name=PREF_AXIS)` (as `sweep.run_sweep` does); without that axis (a
plain `jax.vmap`, or one preference alone) each preference estimates its own point from
its own `Jhat`, as a sweep of that one preference would; where the preferences
are also split over devices (`jax.shard_map` on a mesh axis named `DEVICE_AXIS`, as the
sweep does), the collectives span that axis too, i.e. every preference of the sweep. Max
and min ignore duplicates, so the padding the sweep adds (copies of the last preference) changes
nothing. `best` is carried in the training state, so the estimate is pure, deterministic,
and the same whether a run is split into chunks or not. Imports nothing but jax.
"""

from __future__ import annotations

import chex
import jax
import jax.numpy as jnp
from flax import struct

# the name of the vmapped preference axis the estimate is shared over
PREF_AXIS = "prefs"
# the name of the mesh axis the sweep splits the preferences over (`jax.shard_map`)
DEVICE_AXIS = "devices"
UTOPIA_MODES = ("fixed", "estimated")


@struct.dataclass
class UtopiaState:
    """The running part of the estimate.

    Attributes:
      best: `[m]` the best `Jhat_i` any preference has reached so far (`-inf` at first).
    """

    best: chex.Array


def init(m: int) -> UtopiaState:
    """No estimate yet: `best = -inf` for each of the `m` objectives."""
    return UtopiaState(best=jnp.full((m,), -jnp.inf, jnp.float32))


def estimate(
    state: UtopiaState,
    j_hat: chex.Array,
    *,
    margin: float,
    min_spread: float,
    axis_name: str = PREF_AXIS,
) -> tuple[UtopiaState, chex.Array]:
    """Updates the estimate with this iteration's `Jhat` of every preference.

    Args:
      state: the estimate so far (the same on every preference).
      j_hat: `[m]` this preference's objective estimates.
      margin: how far above the best value `z` lies, relative to the spread.
      min_spread: a floor on the spread, so that `z` stays above `best` when all
        preferences agree (e.g. a sweep of one preference).
      axis_name: the vmapped preference axis (unbound: this preference alone).

    Returns:
      `(state, z)`: the new state and the utopia point `z` (`[m]`), identical on every
      preference.
    """
    chex.assert_rank(j_hat, 1)
    if _is_bound(axis_name):
        axes = (DEVICE_AXIS, axis_name) if _is_bound(DEVICE_AXIS) else axis_name
        hi = jax.lax.pmax(j_hat, axes)
        lo = jax.lax.pmin(j_hat, axes)
    else:  # no named preference axis (a plain `jax.vmap`, or none): this preference alone
        hi = lo = j_hat
    best = jnp.maximum(state.best, hi)
    return UtopiaState(best=best), point(best, lo, margin=margin, min_spread=min_spread)


def point(best: chex.Array, lo: chex.Array, *, margin: float, min_spread: float) -> chex.Array:
    """`z = best + margin * max(best - lo, min_spread)` (`[m]`): the utopia point above the
    best values `best`, given the least ones `lo` (the rule `estimate` applies; also
    `wcac_jax.sweep.selection`'s)."""
    return best + margin * jnp.maximum(best - lo, min_spread)


def _is_bound(name: str) -> bool:
    """Whether the axis `name` is bound where this is traced (the device axis exists only
    under the sweep's `shard_map`)."""
    try:
        jax.lax.axis_size(name)
    except NameError:
        return False
    return True
