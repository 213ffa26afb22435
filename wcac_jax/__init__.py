"""wcac_jax: smoothed weighted-Chebyshev deep actor-critic for multi-objective RL in JAX.

The public API: scalarizations (`smooth_wc`, `wc`, `linear` and their weights), the
training program (`TrainConfig`, `make_train`, `make_trainer`, `make_evaluate`), and
the building blocks as modules (`networks`, `critic`, `actor`, `envs`).
"""

from wcac_jax import actor, critic, envs, networks, scalarize
from wcac_jax.config import TrainConfig
from wcac_jax.scalarize import linear, smooth_wc, smooth_wc_weights, wc, wc_weights
from wcac_jax.train import TrainState, make_evaluate, make_train, make_trainer

__version__ = "0.1.0"

__all__ = [
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
    "scalarize",
    "smooth_wc",
    "smooth_wc_weights",
    "wc",
    "wc_weights",
]
