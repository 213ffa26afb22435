"""A finished sweep read back (`load_sweep`) and each preference's reported policy rolled
out for one episode, written as a pure function and compiled once.

    python examples/load_and_rollout.py runs/example   # a run of examples/walker2d_sweep.py
"""

import sys

import jax
import jax.numpy as jnp

from wcac_jax.sweep import load_sweep

out = next((a for a in sys.argv[1:] if not a.startswith("--")), "runs/example")
run = load_sweep(out)  # its config, environment, trainer, states [P, ...] and metrics
env = run.env


@jax.jit
def episode(state, key):
    """The undiscounted return `[m]` and length of one episode of `state`'s policy."""

    def step(carry, _):
        env_state, alive, total, length = carry
        env_state = env.step(env_state, run.trainer.mean_action(state, env_state.obs))
        total, length = total + alive * env_state.reward, length + alive
        return (env_state, alive * (1.0 - env_state.done), total, length), None

    one, zero = jnp.float32(1.0), jnp.float32(0.0)
    start = (env.reset(key), one, jnp.zeros(env.num_objectives), zero)
    (_, _, total, length), _ = jax.lax.scan(step, start, None, length=env.episode_length)
    return total, length


for i, pref in enumerate(run.config.prefs):
    state = jax.tree.map(lambda leaf, i=i: leaf[i], run.reported)  # what front.json reports
    total, length = episode(state, jax.random.key(i))
    print(f"p = {list(pref)}: return {total.tolist()} over {int(length)} steps")
