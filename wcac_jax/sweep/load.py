"""A finished or interrupted sweep read back from its output directory: `load_sweep`."""

from __future__ import annotations

from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from wcac_jax.algos import ConditionedConfig, conditioned, make_evaluate, make_trainer
from wcac_jax.core.runtime import Trainer, UpdateState, with_env_steps
from wcac_jax.core.utopia import PREF_AXIS
from wcac_jax.sweep import checkpoint, selection
from wcac_jax.sweep.config import SweepConfig, SweepError, make_env, read_config


class LoadedSweep(NamedTuple):
    """A sweep restored from its output directory (see `load_sweep`).

    Attributes:
      config: the sweep's configuration (from `config.json`).
      env: its environment (`make_env(config)`), the one `trainer` was built for.
      trainer: the pure `init`/`step`/`run`/`mean_action` of its training setup.
      state: the last checkpointed `UpdateState`, every leaf with the preference axis
        first (`[P, ...]`); `state.iteration[i]` iterations are done.
      metrics: per-iteration metrics `[P, T, ...]` (zeros past `state.iteration`), with
        `train/env_steps` (int64) counted on the host from `train/iteration`.
      chosen: with `config.select_last > 1` and the sweep finished, each preference's
        reported policy (`wcac_jax.sweep.selection`, leaves `[P, ...]`), the one `front.json`
        evaluated; else `None` (the reported policy is `state`'s).
      candidates: with `config.select_last > 1` and the sweep finished, every candidate
        policy the choice was made among (leaves `[K, P, ...]`, at
        `config.candidate_iterations`); else `None`.
    """

    config: SweepConfig
    env: Any
    trainer: Trainer
    state: UpdateState
    metrics: dict
    chosen: UpdateState | None = None
    candidates: UpdateState | None = None

    @property
    def reported(self) -> UpdateState:
        """Each preference's reported policy, the one `front.json` evaluated (leaves
        `[P, ...]`): `chosen` where the sweep chose among its last policies, else
        `state`."""
        return self.state if self.chosen is None else self.chosen

    def policy(self, i: int):
        """`obs [..., obs] -> action`: preference `i`'s reported policy, its mean action
        as the environment takes it."""
        state = jax.tree.map(lambda leaf: leaf[i], self.reported)
        return lambda obs: self.trainer.mean_action(state, obs)

    def policy_at(self, pref):
        """`obs [..., obs] -> action`, the mean action at the preference `pref` `[m]` of a
        conditioned sweep's one network (`wcac_jax.sweep.conditioned`).

        Raises:
          SweepError: the sweep trained one policy per preference (index `state`).
        """
        if not isinstance(self.config.train, ConditionedConfig):
            raise SweepError("policy_at needs a conditioned sweep (one network for all)")
        return conditioned.policy_at(self.trainer, jax.tree.map(lambda x: x[0], self.state), pref)


def load_sweep(out: str, network_factory=None) -> LoadedSweep:
    """Restores the last checkpoint of the sweep in `out`, finished or interrupted (a
    sweep trained with a `network_factory` of its own needs the same one here).

    The trained policies and critics, to evaluate, render or inspect; or, after a
    `TrainingDiverged`, the last good state, to replay iteration by iteration:

        run = load_sweep("runs/x")
        state_i = jax.tree.map(lambda leaf: leaf[i], run.state)  # preference i
        state_i, metrics_i = jax.jit(run.trainer.step)(state_i, run.config.prefs[i])

    Raises:
      SweepError: `out` holds no sweep configuration or no checkpoint.
    """
    config = read_config(out, context="")
    manager = checkpoint.manager(out)
    if manager.latest_step() is None:
        raise SweepError(f"no checkpoint in {out!r}")
    env = make_env(config)
    trainer = make_trainer(config.train_config(), env, network_factory)
    n_prefs, n_iters = len(config.prefs), config.num_iterations
    # the checkpoint's state and candidates hold the rows the sweep ran: the preferences
    # padded to its device count by repeating the last (`wcac_jax.sweep.run._lay_out`)
    rows = n_prefs + (-n_prefs % (config.device_count or 1))
    prefs = jnp.asarray(np.asarray(config.prefs, np.float32))
    prefs = jnp.concatenate([prefs, jnp.repeat(prefs[-1:], rows - n_prefs, axis=0)])
    keys = jax.vmap(lambda i: jax.random.fold_in(jax.random.key(config.seed), i))(
        jnp.minimum(jnp.arange(rows), n_prefs - 1)
    )
    # shapes only: nothing is initialised or traced through the environment twice
    state = jax.eval_shape(jax.vmap(trainer.init), keys, prefs)
    shapes = jax.eval_shape(jax.vmap(trainer.step, axis_name=PREF_AXIS), state, prefs)[1]
    template = {
        "state": jax.tree.map(lambda s: np.zeros(s.shape, s.dtype), state),
        "metrics": {
            k: np.zeros((n_prefs, n_iters, *s.shape[1:]), s.dtype) for k, s in shapes.items()
        },
    }
    pool = None
    if config.select_last > 1:
        evaluate = make_evaluate(config.train_config(), env, config.eval_episodes, trainer)
        found = jax.eval_shape(jax.vmap(evaluate), state, keys)
        pool = selection.Pool(config.candidate_iterations, template["state"], found)
        template["selection"] = pool.tree
    restored = checkpoint.restore(manager, template)
    state = jax.tree.map(lambda x: jnp.asarray(x[:n_prefs]), restored["state"])
    metrics = with_env_steps(config.train_config(), restored["metrics"])
    chosen = candidates = None
    if pool is not None and int(restored["state"].iteration[0]) >= n_iters:
        pool.tree = restored["selection"]
        # as the sweep chose: over every row, by the run's own criterion
        picked = pool.choose(np.asarray(prefs), selection.criterion(config.train))[3]
        chosen = jax.tree.map(lambda x: jnp.asarray(x[:n_prefs]), picked)
        candidates = pool.treedef.unflatten([x[:, :n_prefs] for x in pool.tree["states"]])
    return LoadedSweep(config, env, trainer, state, metrics, chosen, candidates)
