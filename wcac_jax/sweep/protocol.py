"""A benchmark protocol's run (`wcac_jax.protocols`): `protocol_sweep` builds the
`SweepConfig` of one task under one protocol — the protocol's preset for the task
(`presets.protocol_preset`), trained as ONE preference-conditioned network on the
protocol's budget in whole iterations (rounded down, so never above it), evaluated at
the protocol's preferences with its episodes, episode length and discount — and
`run_conditioned` trains and scores it (`front.json["protocol"]`).
"""

from __future__ import annotations

from wcac_jax import algos, envs, protocols
from wcac_jax.sweep import presets
from wcac_jax.sweep.config import SweepConfig, SweepError


def protocol_sweep(
    env: str,
    protocol: str,
    seed: int = 0,
    train: algos.ConditionedConfig | None = None,
    total_steps: int | None = None,
    env_options: dict | None = None,
    selection: tuple[int, int] | None = None,
) -> SweepConfig:
    """The `SweepConfig` of `env` under `protocol` (see the module docstring).

    Args:
      env: a task of the protocol.
      protocol: a name of `protocols.PROTOCOLS`.
      seed: the run's seed.
      train: the conditioned configuration (default: the protocol's preset for `env`).
      total_steps: env steps of training (default: the protocol's budget); another
        budget is recorded as a deviation in `front.json["protocol"]`.
      env_options: the environment's options over the protocol's (its episode length and
        MuJoCo's C engine, where the environment has those options, and the
        environment's default model).
      selection: `(select_last, select_every)`, the choice among the network's last
        policies (default: the preset's).

    Raises:
      SweepError: an unknown protocol, a task not in it, or a budget below one iteration.
    """
    try:
        spec = protocols.get(protocol)
        task = spec.task(env)
    except ValueError as err:
        raise SweepError(str(err)) from None
    preset = presets.protocol_preset(protocol, env)
    train = preset.config if train is None else train
    select_last, select_every = preset.selection if selection is None else selection
    if not isinstance(train, algos.ConditionedConfig):
        raise SweepError(f"a protocol's run trains the conditioned update, got {algos.kind(train)}")
    budget = spec.budget(task.num_objectives) if total_steps is None else total_steps
    per = train.env_steps_per_iteration
    if budget < per:
        raise SweepError(f"--total-steps {budget:,} is less than one iteration ({per:,} env steps)")
    try:
        accepted = envs.option_defaults(env)
    except ValueError as err:
        raise SweepError(str(err)) from None
    protocol_options = {"engine": "mujoco", "episode_length": task.episode_length}
    options = {
        **dict(presets.env_defaults(env).env_options),
        **{k: v for k, v in protocol_options.items() if k in accepted},
        **(env_options or {}),
    }
    return SweepConfig(
        prefs=protocol_prefs(protocol, env),
        env=env,
        env_options=options,
        train=train,
        steps_per_pref=(budget // per) * per,  # whole iterations, at most the budget
        seed=seed,
        eval_episodes=task.eval_episodes,
        select_last=select_last,
        select_every=select_every,
        protocol=protocol,
    )


def protocol_prefs(protocol: str, env: str) -> tuple[tuple[float, ...], ...]:
    """The preferences `protocol` evaluates `env`'s front at (its grid), rounded to 6
    decimals as `config.json` records them."""
    spec = protocols.get(protocol)
    m = spec.task(env).num_objectives
    return tuple(tuple(round(float(x), 6) for x in p) for p in spec.eval_prefs(m))


def budget_note(config: SweepConfig) -> str:
    """One line: the env steps the run trains against its protocol's budget."""
    spec = protocols.get(config.protocol)
    budget = spec.budget(spec.task(config.env).num_objectives)
    per = config.train.env_steps_per_iteration
    trained = config.num_iterations * per
    if trained > budget:
        return (
            f"trains {trained:,} env steps, ABOVE the {spec.name} protocol's budget of "
            f"{budget:,}: the front is not comparable with the protocol's published numbers"
        )
    if budget - trained >= per:
        return (
            f"trains {trained:,} env steps, below the {spec.name} protocol's budget of "
            f"{budget:,}: scored, but not set beside the protocol's published numbers"
        )
    return (
        f"trains {config.num_iterations:,} iterations of {per:,} env steps = {trained:,}, "
        f"the {spec.name} protocol's budget of {budget:,} rounded down to whole iterations"
    )


__all__ = ["budget_note", "protocol_sweep"]
