"""wcac_jax: smoothed weighted-Chebyshev deep actor-critic for multi-objective RL in JAX.

The public API: scalarizations (`smooth_wc`, `wc`, `linear` and their weights, by name in
`scalarize.SCALARIZATIONS`), the updates by name (`algos`: the paper's, `PaperConfig`, the
practical one, `PracticalConfig`, and the preference-conditioned one), one way to build
and run each (`make_train`, `make_trainer`, `make_evaluate`), what they share (`runtime`),
named presets and per-environment defaults (`presets`), a whole sweep with the library's
defaults (`default_sweep`, `run_sweep`, `load_sweep`), the front's metrics (`pareto`) and
figures (`plot`), and the building blocks as modules (`networks`, `critic`, `actor`,
`utopia`, `envs`).

The package's rooms (docs/architecture.md): `core` (the method's pure pieces), `algos`
(the updates), `envs` (the tasks), `sweep` (the host side: command line, presets, runs,
files), `evaluate` and `recsys`; `pareto` and `protocols` (numpy only) stay at the top.
Every name here loads on first use (PEP 562) from its room, so that `import
wcac_jax.pareto` loads neither JAX nor a physics engine.
"""

import importlib

__version__ = "0.1.0"

# name -> the module that defines it
_NAMES = {
    "PaperConfig": "wcac_jax.algos",
    "PracticalConfig": "wcac_jax.algos",
    "ConditionedConfig": "wcac_jax.algos",
    "make_evaluate": "wcac_jax.algos",
    "make_train": "wcac_jax.algos",
    "make_trainer": "wcac_jax.algos",
    "Trainer": "wcac_jax.core.runtime",
    "UpdateState": "wcac_jax.core.runtime",
    "linear": "wcac_jax.core.scalarize",
    "smooth_wc": "wcac_jax.core.scalarize",
    "smooth_wc_weights": "wcac_jax.core.scalarize",
    "wc": "wcac_jax.core.scalarize",
    "wc_weights": "wcac_jax.core.scalarize",
    "SweepConfig": "wcac_jax.sweep",
    "default_sweep": "wcac_jax.sweep",
    "load_sweep": "wcac_jax.sweep",
    "run_sweep": "wcac_jax.sweep",
}
# module name -> where it lives
_MODULES = {
    "actor": "wcac_jax.core.actor",
    "algos": "wcac_jax.algos",
    "critic": "wcac_jax.core.critic",
    "envs": "wcac_jax.envs",
    "networks": "wcac_jax.core.networks",
    "pareto": "wcac_jax.pareto",
    "plot": "wcac_jax.sweep.plot",
    "presets": "wcac_jax.sweep.presets",
    "runtime": "wcac_jax.core.runtime",
    "scalarize": "wcac_jax.core.scalarize",
    "sweep": "wcac_jax.sweep",
    "utopia": "wcac_jax.core.utopia",
}


def __getattr__(name: str):
    if name in _MODULES:
        return importlib.import_module(_MODULES[name])
    if name in _NAMES:
        return getattr(importlib.import_module(_NAMES[name]), name)
    raise AttributeError(f"module 'wcac_jax' has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *_NAMES, *_MODULES})


__all__ = sorted({*_NAMES, *_MODULES})
