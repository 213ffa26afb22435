"""wcac_jax: smoothed weighted-Chebyshev deep actor-critic for multi-objective RL in JAX.

The public API: scalarizations (`smooth_wc`, `wc`, `linear` and their weights), the
paper's training program (`TrainConfig`, `make_train`, `make_trainer`, `make_evaluate`),
the practical one (`PPOConfig`, `ppo.make_trainer`), named presets and per-environment
defaults (`presets`), and the building blocks as modules (`networks`, `critic`, `actor`,
`utopia`, `envs`).
"""

from wcac_jax import actor, critic, envs, networks, ppo, presets, scalarize, utopia
from wcac_jax.config import TrainConfig
from wcac_jax.ppo import PPOConfig
from wcac_jax.scalarize import linear, smooth_wc, smooth_wc_weights, wc, wc_weights
from wcac_jax.train import TrainState, make_evaluate, make_train, make_trainer

__version__ = "0.1.0"

__all__ = [
    "PPOConfig",
    "TrainConfig",
    "TrainState",
    "actor",
    "critic",
    "envs",
    "linear",
    "make_evaluate",
    "make_train",
    "make_trainer",
    "networks",
    "ppo",
    "presets",
    "scalarize",
    "smooth_wc",
    "smooth_wc_weights",
    "utopia",
    "wc",
    "wc_weights",
]
