"""The updates, by name: `paper` (Algorithms 1 + 2, `algos.paper`), `practical` (the same
smoothed weighted-Chebyshev direction with a clipped surrogate, `algos.practical`) and
`conditioned` (one preference-conditioned network for the whole front,
`algos.conditioned`).

`ALGOS` maps each name to its configuration class and `make_trainer`; everything else
dispatches on a configuration's class through it (`kind`), and every update returns
the same `runtime.Trainer`, so sweeps, evaluation and checkpoints are shared. A new
update is a module with a `Config` subclass and a `make_trainer` that meet the contract
(`algos.contract`: the fields and metrics the rest of the library reads), and one
`register` line here (or in the user's own code).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

# the method's shared pieces first: they import MJX (which Brax's modules import) without
# its optional-backend notices
from wcac_jax.core import networks, runtime  # isort: skip

from wcac_jax.algos import conditioned, contract, paper, practical
from wcac_jax.algos.conditioned import ConditionedConfig
from wcac_jax.algos.contract import UpdateConfig
from wcac_jax.algos.paper import PaperConfig
from wcac_jax.algos.practical import PracticalConfig


class Algo(NamedTuple):
    """One update: its configuration class and `make_trainer(config, env) -> Trainer`;
    `make_evaluate(config, env, num_episodes, trainer)`, where its policy needs more than
    `runtime.make_evaluate` gives it (default: that)."""

    config: type
    make_trainer: Callable
    make_evaluate: Callable | None = None


ALGOS: dict[str, Algo] = {}


def register(
    name: str, config: type, make_trainer: Callable, make_evaluate: Callable | None = None
) -> None:
    """Registers an update under `name` (a `--preset` and a configuration `kind`), after
    checking its configuration class against the contract (`contract.check_config_class`;
    its metrics are checked by a sweep before it compiles).

    Raises:
      contract.ContractError: naming what the configuration lacks.
    """
    contract.check_config_class(name, config)
    ALGOS[name] = Algo(config, make_trainer, make_evaluate)


register("paper", PaperConfig, paper.make_trainer)
register("practical", PracticalConfig, practical.make_trainer)
register(
    "conditioned", ConditionedConfig, conditioned.make_trainer, conditioned.make_evaluate_centre
)
# kinds that older runs recorded, by their name now
LEGACY_KINDS = {"ppo": "practical"}


def kind(config) -> str:
    """The registered name of `config`'s update (`"paper"`, `"practical"`,
    `"conditioned"`): its own class's, not a base class's."""
    for name, algo in ALGOS.items():
        if type(config) is algo.config:
            return name
    for name, algo in ALGOS.items():
        if isinstance(config, algo.config):
            return name
    raise TypeError(f"not a training configuration: {type(config).__name__}")


def config_class(name: str) -> type:
    """The configuration class of the update `name` (legacy names accepted).

    Raises:
      ValueError: naming the bad value and the valid ones.
    """
    name = LEGACY_KINDS.get(name, name)
    if name not in ALGOS:
        raise ValueError(f"unknown training kind {name!r}; valid: {', '.join(ALGOS)}")
    return ALGOS[name].config


def make_trainer(
    config, env, network_factory: networks.NetworkFactory | None = None
) -> runtime.Trainer:
    """The pure `init`/`run`/`step` of `config`'s update for `env`; `network_factory`
    (`networks.NetworkFactory`) builds its actor and critics in place of the update's
    own networks (`None`: the update's, as its configuration says).

    Raises:
      contract.ContractError: the update's `make_trainer` returned no `runtime.Trainer`.
    """
    name = kind(config)
    extra = {} if network_factory is None else {"network_factory": network_factory}
    trainer = ALGOS[name].make_trainer(config, env, **extra)
    if not isinstance(trainer, runtime.Trainer):
        raise contract.ContractError(
            f"update {name!r}: make_trainer returned a {type(trainer).__name__}, not a "
            "runtime.Trainer (build it with runtime.assemble)"
        )
    return trainer


def make_evaluate(
    config, env, num_episodes: int, trainer: runtime.Trainer | None = None
) -> Callable:
    """`evaluate(state, key) -> metrics` of the mean policy of `config`'s update
    (`runtime.make_evaluate`; `trainer` default: `make_trainer(config, env)`)."""
    evaluate = ALGOS[kind(config)].make_evaluate or runtime.make_evaluate
    return evaluate(config, env, num_episodes, trainer or make_trainer(config, env))


def make_train(config, env, network_factory: networks.NetworkFactory | None = None) -> Callable:
    """Returns `train(key, pref, direction=None) -> (state, metrics)`: the whole run of
    `config.num_iterations` iterations, one `lax.scan` (`network_factory`: as
    `make_trainer`'s).

    `key` (a PRNG key) and `pref` (`[m]`) are traced, so a sweep is
    `jax.jit(jax.vmap(train))(keys [P], prefs [P, m])`; `metrics` leaves are `[T, ...]`
    (`[P, T, ...]` under the vmap). With the practical update's estimated utopia point
    (`wcac_jax.core.utopia`), a plain `jax.vmap` lets each preference estimate its own, as a
    sweep of that preference alone would; `jax.vmap(train, axis_name=utopia.PREF_AXIS)`
    shares one across the batch, as `run_sweep` does.

    The optional `direction` is a traced integer index into `runtime.TRACED_DIRECTIONS`
    (`0`: smooth_wc, `1`: wc, `2`: linear, then any scalarization registered after them)
    that overrides `config.scalarization`, so scalarizations can be compared inside one
    compiled program (`jax.vmap(train)(keys, prefs, directions)`).
    """
    trainer = make_trainer(config, env, network_factory)

    def train(key, pref, direction=None):
        return trainer.run(trainer.init(key, pref), pref, config.num_iterations, direction)

    return train


def to_dict(config) -> dict:
    """`config.to_dict()` with its `kind` recorded first."""
    return {"kind": kind(config), **config.to_dict()}


def from_dict(d: dict):
    """The inverse of `to_dict`. Also reads what older runs recorded: no `kind` (the
    paper's update), the kind `"ppo"` (now `"practical"`), and fields missing because
    they were added later (their defaults, which is what those runs ran with)."""
    d = dict(d)
    return config_class(d.pop("kind", "paper")).from_dict(d)


__all__ = [
    "ALGOS",
    "Algo",
    "ConditionedConfig",
    "PaperConfig",
    "PracticalConfig",
    "UpdateConfig",
    "config_class",
    "from_dict",
    "kind",
    "make_evaluate",
    "make_train",
    "make_trainer",
    "register",
    "to_dict",
]
