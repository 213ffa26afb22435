"""A one-step bandit with a non-convex (concave) Pareto front whose answer is known exactly.

The action `a in [-1, 1]` (clipped) is mapped to an angle `theta = (a + 1) pi / 4` in
`[0, pi/2]` and earns the reward vector `(1 - sin theta, 1 - cos theta)`. Every step ends
the episode (the observation is the constant `[1.0]`), so `J(policy) = E[r]`.

The front of deterministic policies, `{(1 - sin t, 1 - cos t)}`, curves towards the
origin: linear scalarization can only reach its two ends, while weighted Chebyshev with
preference `p` and utopia `z` reaches the point where `p_1 (z_1 - 1 + sin theta) =
p_2 (z_2 - 1 + cos theta)` (`wc_optimum`).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
from brax.envs.base import State

from wcac_jax.envs.base import MOEnv

OBJECTIVE_NAMES = ("one_minus_sin", "one_minus_cos")
DEFAULT_J_UB = (1.1, 1.1)


def action_to_theta(action):
    """`theta = (clip(a, -1, 1) + 1) pi / 4`: `[...]` actions to `[...]` angles."""
    return (jnp.clip(action, -1.0, 1.0) + 1.0) * (jnp.pi / 4.0)


def theta_to_action(theta):
    """Inverse of `action_to_theta` on `[0, pi/2]`."""
    return theta * (4.0 / jnp.pi) - 1.0


def reward(theta):
    """`[...]` angles to `[..., 2]` reward vectors `(1 - sin theta, 1 - cos theta)`."""
    return jnp.stack([1.0 - jnp.sin(theta), 1.0 - jnp.cos(theta)], axis=-1)


def exact_front(n: int = 201) -> np.ndarray:
    """`[n, 2]` points of the exact Pareto front, from `theta = 0` to `pi/2`."""
    return np.asarray(reward(jnp.linspace(0.0, jnp.pi / 2, n)))


def exact_front_hypervolume() -> float:
    """The hypervolume of the exact front with reference point `(0, 0)`: `1 - pi/4`.

    The front `(x, y) = (1 - sin t, 1 - cos t)`, `t in [0, pi/2]`, is the quarter of the
    unit circle centred on `(1, 1)` nearest the origin: `(1 - x)^2 + (1 - y)^2 = 1`, running
    from `(1, 0)` to `(0, 1)` with `y` decreasing in `x`. The region it dominates above
    `(0, 0)` is therefore the area under it, `y = 1 - sqrt(1 - (1 - x)^2)` on `[0, 1]`:
    the unit square less the quarter disc of radius 1 around `(1, 1)`, so
    `int_0^1 y dx = 1 - int_0^1 sqrt(1 - s^2) ds = 1 - pi/4` (about 0.2146).

    A front sampled at `n` evenly spaced angles dominates a staircase under this area,
    short of it by about `pi / (8 (n - 1))` (0.09% of it at `n = 2001`).
    """
    return 1.0 - math.pi / 4.0


def wc_optimum(pref, j_ub=DEFAULT_J_UB):
    """The angle minimising `max_i p_i (z_i - r_i(theta))` over `[0, pi/2]`.

    Solves `p_1 (z_1 - 1 + sin t) = p_2 (z_2 - 1 + cos t)` by bisection (the left side
    minus the right is increasing in `t`); clamps to an end when there is no root.

    Args:
      pref: `[2]` preference. j_ub: `[2]` utopia point.

    Returns:
      A scalar angle.
    """
    pref = jnp.asarray(pref, jnp.float32)
    j_ub = jnp.asarray(j_ub, jnp.float32)

    def f(t):
        return pref[0] * (j_ub[0] - 1.0 + jnp.sin(t)) - pref[1] * (j_ub[1] - 1.0 + jnp.cos(t))

    def body(_, bounds):
        lo, hi = bounds
        mid = 0.5 * (lo + hi)
        go_right = f(mid) < 0
        return jnp.where(go_right, mid, lo), jnp.where(go_right, hi, mid)

    lo, hi = jax.lax.fori_loop(0, 60, body, (jnp.float32(0.0), jnp.float32(jnp.pi / 2)))
    return 0.5 * (lo + hi)


class ConcaveBandit(MOEnv):
    """The concave bandit as a Brax-style `Env` (`reset`, `step`, vector `State.reward`)."""

    objective_names = OBJECTIVE_NAMES
    default_j_ub = DEFAULT_J_UB
    # hypervolume reference: the least return of each objective (both lie in [0, 1])
    default_hv_ref = (0.0, 0.0)
    episode_length = 1

    def reset(self, rng: jax.Array) -> State:
        del rng
        zero = jnp.zeros((), jnp.float32)
        return State(
            pipeline_state=None,
            obs=jnp.ones((1,), jnp.float32),
            reward=jnp.zeros((2,), jnp.float32),
            done=zero,
            metrics={"theta": zero},
        )

    def step(self, state: State, action: jax.Array) -> State:
        theta = action_to_theta(action[0])
        return state.replace(
            reward=reward(theta),
            done=jnp.ones((), jnp.float32),
            metrics={"theta": theta},
        )

    @property
    def observation_size(self) -> int:
        return 1

    @property
    def action_size(self) -> int:
        return 1

    @property
    def backend(self) -> str:
        return "none"
