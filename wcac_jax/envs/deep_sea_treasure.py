"""Deep Sea Treasure with the concave map of Vamplew et al. (MO-Gymnasium's
`deep-sea-treasure-concave-v0`), with its exact objectives and Pareto front.

An 11 x 11 grid; the submarine starts at the top-left cell (row 0, column 0) and moves
up, down, left or right (actions 0-3; a move into rock or off the grid stays put). Column
`c < 10` is open down to row `TREASURE_ROWS[c]`, where treasure `TREASURE_VALUES[c]`
lies (rock below); column 10 is open sea. Each step earns `(treasure, -1)`: the treasure's
value on the step that reaches it (which ends the episode), else 0, and a time penalty of
-1. The observation is the one-hot cell index (121). The time limit (`episode_length`,
100 as MO-Gymnasium's) truncates and bootstraps.

Exact answers, for the discount `gamma`:

- `path_returns(gamma)`: `[10, 2]` the discounted returns of the shortest path to each
  treasure (`n` steps: `(gamma^(n-1) T, -sum_{t<n} gamma^t)`);
- `exact_objectives(pi, gamma)`: the expected discounted returns of a stochastic policy
  table `pi [121, 4]` (a linear solve; treasure cells absorb);
- `exact_front(gamma)`: the vertices of the front of stochastic policies. Returns of
  stationary policies are linear in their occupancy measure, so the achievable set is
  the convex hull of the deterministic policies' returns, and its front is the upper-right
  boundary of the hull of `path_returns`: linear scalarization can only reach its
  vertices, weighted Chebyshev any point on its edges.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from brax.envs.base import State

from wcac_jax.envs.base import MOEnv

SIZE = 11
TREASURE_ROWS = (1, 2, 3, 4, 4, 4, 7, 7, 9, 10)
TREASURE_VALUES = (1.0, 2.0, 3.0, 5.0, 8.0, 16.0, 24.0, 50.0, 74.0, 124.0)
MOVES = ((-1, 0), (1, 0), (0, -1), (0, 1))  # up, down, left, right


def _grid() -> tuple[np.ndarray, np.ndarray]:
    """`open [11, 11]` (bool) and `treasure [11, 11]` (value, 0 where none)."""
    open_ = np.ones((SIZE, SIZE), dtype=bool)
    treasure = np.zeros((SIZE, SIZE), dtype=np.float32)
    for c, (row, value) in enumerate(zip(TREASURE_ROWS, TREASURE_VALUES, strict=True)):
        open_[row + 1 :, c] = False
        treasure[row, c] = value
    return open_, treasure


def _next_cell_table() -> np.ndarray:
    """`[121, 4]` the cell index each action leads to."""
    open_, _ = _grid()
    table = np.zeros((SIZE * SIZE, 4), dtype=np.int32)
    for r in range(SIZE):
        for c in range(SIZE):
            for a, (dr, dc) in enumerate(MOVES):
                nr, nc = r + dr, c + dc
                ok = 0 <= nr < SIZE and 0 <= nc < SIZE and open_[nr, nc]
                table[r * SIZE + c, a] = nr * SIZE + nc if ok else r * SIZE + c
    return table


class DeepSeaTreasure(MOEnv):
    """Deep Sea Treasure (concave map) as a Brax-style `Env` with discrete actions."""

    objective_names = ("treasure", "time")
    num_actions = 4
    default_j_ub = (125.0, 0.0)  # treasure <= 124; every episode takes at least one step

    def __init__(self, episode_length: int = 100):
        if not isinstance(episode_length, int) or episode_length < 1:
            raise ValueError(f"episode_length must be a positive integer, got {episode_length!r}")
        self.episode_length = episode_length
        # hypervolume reference: the least return of each objective, no treasure (0) and
        # every step of the time limit spent (-episode_length; discounted returns are
        # above it too), so every policy that reaches a treasure lies inside the box
        self.default_hv_ref = (0.0, -float(episode_length))
        _, treasure = _grid()
        self._next = jnp.asarray(_next_cell_table())
        self._treasure = jnp.asarray(treasure.reshape(-1))

    def reset(self, rng: jax.Array) -> State:
        del rng
        zero = jnp.zeros((), jnp.float32)
        return State(
            pipeline_state={"cell": jnp.zeros((), jnp.int32)},
            obs=jax.nn.one_hot(0, SIZE * SIZE, dtype=jnp.float32),
            reward=jnp.zeros((2,), jnp.float32),
            done=zero,
        )

    def step(self, state: State, action: jax.Array) -> State:
        cell = self._next[state.pipeline_state["cell"], jnp.asarray(action, jnp.int32)]
        value = self._treasure[cell]
        return state.replace(
            pipeline_state={"cell": cell},
            obs=jax.nn.one_hot(cell, SIZE * SIZE, dtype=jnp.float32),
            reward=jnp.stack([value, jnp.float32(-1.0)]),
            done=(value > 0).astype(jnp.float32),
        )

    @property
    def observation_size(self) -> int:
        return SIZE * SIZE

    @property
    def action_size(self) -> int:
        return 4

    @property
    def backend(self) -> str:
        return "none"

    def exact_objectives(self, pi: jax.Array, gamma: float) -> jax.Array:
        """`[2]` expected discounted returns from the start of the policy table `pi [121, 4]`.

        Solves `V = sum_a pi(a|s) (r(s, a) + gamma [s' not terminal] V(s'))`; reaching a
        treasure ends the episode (the time limit is ignored, as the critics' bootstrapping
        does).
        """
        n = SIZE * SIZE
        nxt = self._next  # [n, 4]
        terminal_next = (self._treasure[nxt] > 0).astype(jnp.float32)  # [n, 4]
        reward = jnp.stack([self._treasure[nxt], -jnp.ones_like(terminal_next)], axis=-1)
        r_pi = jnp.einsum("sa,sam->sm", pi, reward)
        p_pi = jnp.zeros((n, n)).at[jnp.arange(n)[:, None], nxt].add(pi * (1 - terminal_next))
        values = jnp.linalg.solve(jnp.eye(n) - gamma * p_pi, r_pi)
        return values[0]


def path_returns(gamma: float) -> np.ndarray:
    """`[10, 2]` discounted returns of the shortest path to each treasure."""
    steps = np.array([row + c for c, row in enumerate(TREASURE_ROWS)], dtype=np.float64)
    treasure = np.asarray(TREASURE_VALUES) * gamma ** (steps - 1)
    time = -np.array([np.sum(gamma ** np.arange(n)) for n in steps])
    return np.stack([treasure, time], axis=1)


def exact_front(gamma: float) -> np.ndarray:
    """`[k, 2]` vertices of the stochastic-policy front (upper-right convex hull
    boundary of `path_returns`), ordered by increasing treasure."""
    pts = path_returns(gamma)
    pts = pts[np.argsort(pts[:, 0])]
    hull: list[np.ndarray] = []
    for p in pts[::-1]:  # from the richest treasure towards the quickest
        while len(hull) >= 2:
            a, b = hull[-2], hull[-1]
            # keep only right turns (the boundary is concave seen from above-right)
            if (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]) <= 0:
                hull.pop()
            else:
                break
        hull.append(p)
    return np.asarray(hull[::-1])


def distance_to_front(points: np.ndarray, front: np.ndarray) -> np.ndarray:
    """Distance of each point `[n, 2]` to the piecewise-linear front `[k, 2]`."""
    out = np.full(len(points), np.inf)
    segments = [(front[i], front[i + 1]) for i in range(len(front) - 1)] or [(front[0], front[0])]
    for a, b in segments:
        ab = b - a
        t = np.clip(((points - a) @ ab) / max(float(ab @ ab), 1e-12), 0.0, 1.0)
        out = np.minimum(out, np.linalg.norm(points - (a + t[:, None] * ab), axis=1))
    return out
