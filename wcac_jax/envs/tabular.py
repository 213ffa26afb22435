"""A small tabular multi-objective MDP whose objectives and optimum are computed exactly.

`S` states, `A` discrete actions, `m` objectives; rewards `R[s, a, i]` uniform in
`[0, 1]`, transition kernel `P[s, a, :]` drawn from a Dirichlet, all from `seed`. Episodes
start in state 0; the observation is the state's one-hot vector (unit norm, as the
paper's network assumes). There is no terminal state: episodes are cut at
`episode_length` steps by the time limit, which bootstraps, so the critics estimate the
infinite-horizon discounted values.

For a policy table `pi [S, A]`, the discounted values solve the linear Bellman system
`V = r_pi + gamma P_pi V` (`exact_values`), `J(pi) = V(s0)` (`exact_objectives`), and
`optimal_scalarized` finds `min_theta G_mu(J(softmax(theta)) | p)` over tabular softmax
policies by exact gradient descent (`jax.grad` through the linear solve).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import optax
from brax.envs.base import State

from wcac_jax.core import scalarize
from wcac_jax.envs.base import MOEnv


class TabularMOMDP(MOEnv):
    """The tabular MOMDP as a Brax-style `Env` with discrete actions (`num_actions`).

    Args:
      num_states: `S`.
      num_actions: `A`.
      num_objectives: `m`.
      gamma: the discount the exact values use (train with the same `gamma`).
      episode_length: time limit in steps.
      seed: draws the rewards and the kernel.
    """

    def __init__(
        self,
        num_states: int = 4,
        num_actions: int = 3,
        num_objectives: int = 2,
        gamma: float = 0.9,
        episode_length: int = 100,
        seed: int = 0,
    ):
        for name, value in (
            ("num_states", num_states),
            ("num_actions", num_actions),
            ("num_objectives", num_objectives),
            ("episode_length", episode_length),
        ):
            if not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if not 0.0 <= gamma < 1.0:
            raise ValueError(f"gamma must be in [0, 1), got {gamma!r}")
        rng = np.random.default_rng(seed)
        # `num_objectives` is the number of `objective_names` (set below)
        self.num_states, self.num_actions = num_states, num_actions
        self.gamma, self.episode_length = float(gamma), int(episode_length)
        self.rewards = jnp.asarray(
            rng.uniform(0, 1, (num_states, num_actions, num_objectives)), jnp.float32
        )
        self.kernel = jnp.asarray(
            rng.dirichlet(np.ones(num_states), (num_states, num_actions)), jnp.float32
        )
        self.objective_names = tuple(f"objective_{i}" for i in range(num_objectives))
        # J <= 1 / (1 - gamma); a little above it is a valid utopia point
        self.default_j_ub = (1.0 / (1.0 - gamma) + 0.5,) * num_objectives
        self.default_hv_ref = (0.0,) * num_objectives  # rewards >= 0: the least return

    def reset(self, rng: jax.Array) -> State:
        zero = jnp.zeros((), jnp.float32)
        if not jnp.issubdtype(rng.dtype, jax.dtypes.prng_key):
            rng = jax.random.wrap_key_data(rng)
        return State(
            pipeline_state={"s": jnp.zeros((), jnp.int32)},
            obs=jax.nn.one_hot(0, self.num_states, dtype=jnp.float32),
            reward=jnp.zeros((self.num_objectives,), jnp.float32),
            done=zero,
            # transitions draw from this key (Brax's `step` takes none); auto-resets keep it
            info={"rng": jax.random.key_data(rng)},
        )

    def step(self, state: State, action: jax.Array) -> State:
        s = state.pipeline_state["s"]
        a = jnp.asarray(action, jnp.int32).reshape(())
        rng, sub = jax.random.split(jax.random.wrap_key_data(state.info["rng"]))
        s_next = jax.random.categorical(sub, jnp.log(self.kernel[s, a] + 1e-12))
        return state.replace(
            pipeline_state={"s": s_next.astype(jnp.int32)},
            obs=jax.nn.one_hot(s_next, self.num_states, dtype=jnp.float32),
            reward=self.rewards[s, a],
            done=jnp.zeros((), jnp.float32),
            info={**state.info, "rng": jax.random.key_data(rng)},
        )

    @property
    def observation_size(self) -> int:
        return self.num_states

    @property
    def action_size(self) -> int:
        return self.num_actions

    @property
    def backend(self) -> str:
        return "none"

    # ------------------------------------------------------------------ exact answers

    def exact_values(self, pi: jax.Array) -> jax.Array:
        """`V [S, m]` of the policy table `pi [S, A]` (rows on the simplex)."""
        p_pi = jnp.einsum("sa,sat->st", pi, self.kernel)
        r_pi = jnp.einsum("sa,sam->sm", pi, self.rewards)
        return jnp.linalg.solve(jnp.eye(self.num_states) - self.gamma * p_pi, r_pi)

    def exact_objectives(self, pi: jax.Array) -> jax.Array:
        """`J [m]`: the discounted return from the start state 0."""
        return self.exact_values(pi)[0]

    def optimal_scalarized(self, pref, j_ub, mu, steps: int = 20000, lr: float = 0.1):
        """`(theta*, G_mu(theta*))`: the best tabular softmax policy for `smooth_wc`,
        found by Adam on the exact objective (`theta [S, A]` logits)."""
        pref, j_ub = jnp.asarray(pref, jnp.float32), jnp.asarray(j_ub, jnp.float32)

        def g(theta):
            j = self.exact_objectives(jax.nn.softmax(theta, axis=-1))
            return scalarize.smooth_wc(j, pref, j_ub, mu)

        opt = optax.adam(lr)
        theta = jnp.zeros((self.num_states, self.num_actions))

        def body(carry, _):
            theta, opt_state = carry
            updates, opt_state = opt.update(jax.grad(g)(theta), opt_state)
            return (optax.apply_updates(theta, updates), opt_state), None

        (theta, _), _ = jax.lax.scan(body, (theta, opt.init(theta)), None, length=steps)
        return theta, g(theta)
