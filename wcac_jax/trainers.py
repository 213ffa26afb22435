"""Which training program runs a configuration: the paper's update or the practical one.

The one place that dispatches on the configuration's class: `TrainConfig` (kind
`"paper"`, `train.make_trainer`, Algorithm 1 + 2) or `PPOConfig` (kind `"ppo"`,
`ppo.make_trainer`). Both return the same `train.Trainer`, so everything downstream
(sweeps, evaluation, checkpoints) is shared.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from wcac_jax import ppo, train
from wcac_jax.config import TrainConfig
from wcac_jax.ppo import PPOConfig

CONFIG_KINDS = {"paper": TrainConfig, "ppo": PPOConfig}
AnyConfig = TrainConfig | PPOConfig


def kind(config: AnyConfig) -> str:
    """`"paper"` or `"ppo"`: the kind of `config`."""
    for name, cls in CONFIG_KINDS.items():
        if isinstance(config, cls):
            return name
    raise TypeError(f"not a training configuration: {type(config).__name__}")


def make_trainer(config: AnyConfig, env) -> train.Trainer:
    """The pure `init`/`run`/`step` of `config`'s training program for `env`."""
    if kind(config) == "ppo":
        return ppo.make_trainer(config, env)
    return train.make_trainer(config, env)


def make_evaluate(config: AnyConfig, env, num_episodes: int) -> Callable:
    """`train.make_evaluate` for the policy of `config`'s training program."""
    return train.make_evaluate(config, env, num_episodes, make_trainer(config, env))


def to_dict(config: AnyConfig) -> dict:
    """`config.to_dict()` with its `kind` recorded."""
    return {"kind": kind(config), **config.to_dict()}


def from_dict(d: dict) -> AnyConfig:
    """The inverse of `to_dict`; a dict without `kind` is a `TrainConfig` (older runs)."""
    d = dict(d)
    name = d.pop("kind", "paper")
    if name not in CONFIG_KINDS:
        raise ValueError(f"unknown training kind {name!r}; valid: {', '.join(CONFIG_KINDS)}")
    if name == "ppo":
        return PPOConfig.from_dict(d)
    if d.get("projection_radius") is None:
        d["projection_radius"] = math.inf
    if d.get("j_ub") is not None:
        d["j_ub"] = tuple(d["j_ub"])
    return TrainConfig(**d)
