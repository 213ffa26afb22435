"""The environment registry: names to constructors, each with its objectives and utopia point.

`make(name, **overrides)` builds an environment; every environment is a `MOEnv` (`base`), a
Brax-style `Env` (`reset(key) -> State`, `step(state, action) -> State`, single unbatched
copy) whose `State.reward` is a vector with one entry per objective, and which declares
`objective_names`, `num_objectives`, `default_j_ub`, `default_hv_ref` (the hypervolume
reference point: per objective the least return an episode can have), `episode_length`
and a rendering hook (`base` says what each means). MuJoCo tasks build on
`mujoco_base.MujocoEnv`. The method wraps an environment with `EpisodeWrapper` (its time
limit and auto-reset, `wcac_jax.core.episodes`, re-exported here) and vmaps it. Tasks
import nothing of the updates or the host side: of the method's modules only the episode
wrapper, and `scalarize` for the tabular task's exact optimum.
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable

# the episode wrapper first: it imports MJX (which Brax's modules import) without its
# optional-backend notices
from wcac_jax.core.episodes import EpisodeWrapper  # isort: skip

from brax.envs.base import State

from wcac_jax.envs.base import MOEnv

# name -> "module:attribute" (or a constructor, `register`); a task's module, and the model
# it loads, is imported when the task is first made.
_REGISTRY: dict[str, str | Callable] = {
    "concave_bandit": "wcac_jax.envs.concave_bandit:ConcaveBandit",
    "walker2d": "wcac_jax.envs.walker2d:Walker2d",
    "tabular_momdp": "wcac_jax.envs.tabular:TabularMOMDP",
    "deep_sea_treasure": "wcac_jax.envs.deep_sea_treasure:DeepSeaTreasure",
    "hopper": "wcac_jax.envs.hopper:Hopper",
    "hopper-2obj": "wcac_jax.envs.hopper:HopperTwoObjectives",
    "halfcheetah": "wcac_jax.envs.halfcheetah:HalfCheetah",
    "swimmer": "wcac_jax.envs.swimmer:Swimmer",
    "ant": "wcac_jax.envs.ant:Ant",
    "ant-2obj": "wcac_jax.envs.ant:AntTwoObjectives",
    "humanoid": "wcac_jax.envs.humanoid:Humanoid",
    "walker2d-pgmorl": "wcac_jax.envs.pgmorl_walker2d:Walker2dPGMORL",
    "halfcheetah-pgmorl": "wcac_jax.envs.pgmorl_halfcheetah:HalfCheetahPGMORL",
    "halfcheetah-cola": "wcac_jax.envs.pgmorl_halfcheetah:HalfCheetahCOLA",
    "hopper-pgmorl": "wcac_jax.envs.pgmorl_hopper:HopperPGMORL",
    "hopper3-pgmorl": "wcac_jax.envs.pgmorl_hopper:Hopper3PGMORL",
    "ant-pgmorl": "wcac_jax.envs.pgmorl_ant:AntPGMORL",
    "ant3-cola": "wcac_jax.envs.pgmorl_ant:Ant3COLA",
    "swimmer-pgmorl": "wcac_jax.envs.pgmorl_swimmer:SwimmerPGMORL",
    "humanoid-pgmorl": "wcac_jax.envs.pgmorl_humanoid:HumanoidPGMORL",
}


# options whose default has changed, with the value a run that recorded none of them ran
# with (a sweep's `config.json` written before the change): Walker2d's constructor built
# Brax's model on MJX until it took the command line's defaults
EARLIER_DEFAULTS: dict[str, dict] = {"walker2d": {"physics": "brax", "engine": "mjx"}}


def register(name: str, target: str | Callable) -> None:
    """Registers a constructor taking keyword options as `name`: `"module:attribute"`
    (imported when first used), or the constructor itself (e.g. a user's own class)."""
    _REGISTRY[name] = target


def names() -> tuple[str, ...]:
    """The registered environment names, sorted."""
    return tuple(sorted(_REGISTRY))


def _constructor(name: str) -> Callable:
    if name not in _REGISTRY:
        raise ValueError(f"unknown environment {name!r}; valid: {', '.join(names())}")
    target = _REGISTRY[name]
    if callable(target):
        return target
    module, attr = target.split(":")
    return getattr(importlib.import_module(module), attr)


def option_defaults(name: str) -> dict:
    """`name`'s options and their default values (e.g. `{"engine": "mujoco", ...}`), without
    building it.

    Raises:
      ValueError: for an unknown name (listing the valid ones).
    """
    params = inspect.signature(_constructor(name)).parameters
    return {
        p.name: p.default
        for p in params.values()
        if p.name != "self" and p.default is not inspect.Parameter.empty
    }


def make(name: str, **overrides):
    """Builds the environment `name` with keyword `overrides` of its options.

    Raises:
      ValueError: for an unknown name (listing the valid ones) or an unknown option
        (listing the environment's options).
    """
    ctor = _constructor(name)
    params = inspect.signature(ctor).parameters
    valid = [p for p in params if p != "self"]
    unknown = sorted(set(overrides) - set(valid))
    if unknown:
        raise ValueError(
            f"unknown option(s) {', '.join(map(repr, unknown))} for environment {name!r}; "
            f"valid: {', '.join(valid) if valid else '(none)'}"
        )
    return ctor(**overrides)


__all__ = [
    "EARLIER_DEFAULTS",
    "EpisodeWrapper",
    "MOEnv",
    "State",
    "make",
    "names",
    "option_defaults",
    "register",
]
