"""What an update must provide for the rest of the library to train, sweep, evaluate,
checkpoint and summarise it: the contract `algos.register` checks when an update is
registered, and a sweep before it compiles.

An update is a configuration class and a `make_trainer(config, env) -> runtime.Trainer`
(which may also take `network_factory=`, `networks.NetworkFactory`, to let a user choose
its networks):

- the configuration is a frozen `config.Config` (declared with `@frozen_config`) with
  the fields `CONFIG_FIELDS` (`num_iterations`, set by the sweep from its budget;
  `scalarization` and `mu`, its direction; `gamma`, the evaluation's discount; `j_ub`,
  its utopia point or `None` for the environment's) and the property
  `env_steps_per_iteration` (one preference's env steps per iteration, which turns a
  budget into iterations);
- its trainer's `step(state, pref, direction=None) -> (state, metrics)` reports at least
  `METRICS` per iteration, each with the shape given there (`[m]`: one entry per
  objective), which `front.json` (`outputs.summarize`) and the env-step count read.
"""

from __future__ import annotations

import dataclasses
from typing import Protocol, runtime_checkable

from wcac_jax.core.config import Config

CONFIG_FIELDS = ("num_iterations", "scalarization", "mu", "gamma", "j_ub")
# metric -> its shape per iteration ("m": one entry per objective, "": a scalar)
METRICS = {
    "train/j_hat": "m",
    "train/weights": "m",
    "train/scalarized": "",
    "train/g_mu": "",
    "train/episode_return": "m",
    "train/iteration": "",
}


@runtime_checkable
class UpdateConfig(Protocol):
    """The configuration of any registered update (see the module docstring)."""

    num_iterations: int
    scalarization: str
    mu: float
    gamma: float
    j_ub: tuple[float, ...] | None

    @property
    def env_steps_per_iteration(self) -> int: ...

    def replace(self, **changes) -> UpdateConfig: ...

    def to_dict(self) -> dict: ...


class ContractError(TypeError):
    """An update that does not meet the contract; the message names what is missing."""


def check_config_class(name: str, cls: type) -> None:
    """Checks that `cls` can be the configuration of the update `name`.

    Raises:
      ContractError: naming each missing piece.
    """
    if not (isinstance(cls, type) and issubclass(cls, Config) and dataclasses.is_dataclass(cls)):
        raise ContractError(
            f"update {name!r}: its configuration {cls!r} must be a config.Config subclass "
            "declared with @frozen_config"
        )
    fields = {f.name for f in dataclasses.fields(cls)}
    missing = [f for f in CONFIG_FIELDS if f not in fields]
    if not isinstance(getattr(cls, "env_steps_per_iteration", None), property):
        missing.append("env_steps_per_iteration (a property)")
    if missing:
        raise ContractError(
            f"update {name!r}: {cls.__name__} lacks {', '.join(missing)} (every update's "
            f"configuration has {', '.join(CONFIG_FIELDS)} and env_steps_per_iteration; "
            "see wcac_jax.algos.contract)"
        )


def check_metrics(name: str, shapes: dict, m: int) -> None:
    """Checks one iteration's metrics of the update `name`: `shapes` maps each metric
    the step reports to its shape (without batch or time axes), `m` is the objectives.

    Raises:
      ContractError: naming each missing metric or wrong shape.
    """
    problems = []
    for key, kind in METRICS.items():
        want = (m,) if kind == "m" else ()
        if key not in shapes:
            problems.append(f"{key} is missing")
        elif tuple(shapes[key]) != want:
            problems.append(f"{key} has shape {tuple(shapes[key])}, not {want}")
    if problems:
        raise ContractError(
            f"update {name!r}: its step's metrics do not meet the contract: "
            f"{'; '.join(problems)} (every update reports {', '.join(METRICS)}; see "
            "wcac_jax.algos.contract)"
        )
