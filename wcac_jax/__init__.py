"""wcac_jax: smoothed weighted-Chebyshev deep actor-critic for multi-objective RL in JAX.

The public API: scalarizations (`smooth_wc`, `wc`, `linear` and their weights, by name in
`scalarize.SCALARIZATIONS`), the two updates by name (`algos`: the paper's,
`PaperConfig`, and the practical one, `PracticalConfig`), one way to build and run
either (`make_train`, `make_trainer`, `make_evaluate`), what both share (`runtime`),
named presets and per-environment defaults (`presets`), and the building blocks as
modules (`networks`, `critic`, `actor`, `utopia`, `envs`).
"""

# envs first: it imports MJX (which Brax's modules import) without its optional-backend
# notices
from wcac_jax import envs  # isort: skip

from wcac_jax import actor, algos, critic, networks, presets, runtime, scalarize, utopia
from wcac_jax.algos import PaperConfig, PracticalConfig, make_evaluate, make_train, make_trainer
from wcac_jax.runtime import Trainer, UpdateState
from wcac_jax.scalarize import linear, smooth_wc, smooth_wc_weights, wc, wc_weights

__version__ = "0.1.0"

__all__ = [
    "PaperConfig",
    "PracticalConfig",
    "Trainer",
    "UpdateState",
    "actor",
    "algos",
    "critic",
    "envs",
    "linear",
    "make_evaluate",
    "make_train",
    "make_trainer",
    "networks",
    "presets",
    "runtime",
    "scalarize",
    "smooth_wc",
    "smooth_wc_weights",
    "utopia",
    "wc",
    "wc_weights",
]
