"""A task of one's own: a Brax-style environment with a reward vector, registered by name
and swept like the built-in ones (under the library's fallback default, as a note says).

    python examples/own_environment.py     # a point on a line: go far, or spend little
"""

import sys

import jax.numpy as jnp

from wcac_jax import envs
from wcac_jax.sweep import default_sweep, run_sweep

TINY = "--tiny" in sys.argv  # the test suite's size


class LineWalk(envs.MOEnv):
    """Move a point along [-1, 1]: reward `[x, -a^2]` per step, for 20 steps."""

    objective_names = ("distance", "effort")
    default_j_ub = (21.0, 1.0)  # above every return: x <= 1 and -a^2 <= 0 per step
    default_hv_ref = (-20.0, -20.0)  # the least returns: x >= -1 and a^2 <= 1 per step
    episode_length, observation_size, action_size, backend = 20, 1, 1, "none"

    def reset(self, rng):
        zero = jnp.zeros((), jnp.float32)
        return envs.State(None, jnp.zeros((1,)), jnp.zeros((2,)), zero, {})

    def step(self, state, action):
        x = jnp.clip(state.obs + 0.1 * action, -1.0, 1.0)
        return state.replace(obs=x, reward=jnp.stack([x[0], -jnp.sum(action**2)]))


envs.register("line_walk", LineWalk)
steps = 2_048 * (2 if TINY else 50)  # iterations of 16 environments x 128 steps
config = default_sweep("line_walk", n_prefs=5, steps_per_pref=steps, on_note=print)
for row in run_sweep(config, progress=False)["prefs"]:
    print(f"p = {row['pref']}: distance {row['return'][0]:.2f}, effort {row['return'][1]:.2f}")
