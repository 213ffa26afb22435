"""Time limit and auto-reset for ONE environment with vector rewards.

Brax's `EpisodeWrapper` keeps a scalar `sum_reward`, which breaks with a reward vector, so
this is the same idea written for `[m]` rewards and an unbatched state (the caller vmaps
over `N` environments and over preferences):

- `info["steps"]` counts steps; reaching `episode_length` sets `done` with
  `info["truncation"] = 1` (unless the environment also terminated on that step);
- `info["terminal"]` is the environment's own `done` (a fall): these states do not
  bootstrap, truncated ones do;
- `info["final_obs"]` is the true next observation, kept also when the episode ends and
  `obs` is replaced by the reset observation, so TD targets can bootstrap truncation;
- a finished episode restarts from the environment's initial state drawn at `reset` (as
  Brax's `AutoResetWrapper` does: each environment copy keeps its own start state).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from brax.envs.base import Env, State, Wrapper


class EpisodeWrapper(Wrapper):
    """Time limit + auto-reset for one unbatched environment with `[m]` rewards."""

    def __init__(self, env: Env, episode_length: int):
        super().__init__(env)
        if episode_length < 1:
            raise ValueError(f"episode_length must be >= 1, got {episode_length!r}")
        self.episode_length = int(episode_length)

    def reset(self, rng: jax.Array) -> State:
        state = self.env.reset(rng)
        zero = jnp.zeros((), jnp.float32)
        info = {
            **state.info,
            "steps": jnp.zeros((), jnp.int32),
            "truncation": zero,
            "terminal": zero,
            "final_obs": state.obs,
            "first_pipeline_state": state.pipeline_state,
            "first_obs": state.obs,
        }
        return state.replace(info=info, done=zero)

    def step(self, state: State, action: jax.Array) -> State:
        nstate = self.env.step(state.replace(done=jnp.zeros_like(state.done)), action)
        terminal = nstate.done.astype(jnp.float32)
        steps = state.info["steps"] + 1
        time_up = (steps >= self.episode_length).astype(jnp.float32)
        done = jnp.maximum(terminal, time_up)
        first_ps = state.info["first_pipeline_state"]
        pipeline_state = jax.tree.map(
            lambda a, b: jnp.where(done > 0, a, b), first_ps, nstate.pipeline_state
        )
        obs = jnp.where(done > 0, state.info["first_obs"], nstate.obs)
        info = {
            **nstate.info,
            "steps": jnp.where(done > 0, 0, steps).astype(jnp.int32),
            "truncation": time_up * (1.0 - terminal),
            "terminal": terminal,
            "final_obs": nstate.obs,
            "first_pipeline_state": first_ps,
            "first_obs": state.info["first_obs"],
        }
        return nstate.replace(pipeline_state=pipeline_state, obs=obs, done=done, info=info)
