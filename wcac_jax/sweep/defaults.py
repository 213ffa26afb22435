"""The library's defaults, resolved in one place: `default_sweep` turns an environment's
name, a preset, a preference count and any overrides into the `SweepConfig` that runs.

Resolution, in order: the training configuration is the named preset's (`--preset`) or
the environment's own default (`presets.env_defaults`), with the given fields changed
(on the practical update a fixed `j_ub` also fixes the utopia point); the environment's
options are its default's, with the given ones over them; the preferences are the given
ones, or the paper's nine under the paper's preset, or `n_prefs` evenly spread (the
smallest full lattice with at least that many for three objectives and more); the
budget is the environment's (the whole training's for the conditioned update), rounded
up to whole iterations; each preference reports the default's choice among its last
policies when the budget leaves room for them. The command line (`wcac_jax.sweep.cli`) is a
shell over this function, so `run_sweep(default_sweep("walker2d", n_prefs=9))` trains
exactly what `python -m wcac_jax.sweep --n-prefs 9` trains.

What the resolution decides that a user may not expect (the budget rounded up, a
default choice that does not fit) is said in one line to `on_note` (the command line
prints it; `None`: not said).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

from wcac_jax import algos, envs, pareto
from wcac_jax.core import runtime
from wcac_jax.sweep import presets
from wcac_jax.sweep.config import SweepConfig, SweepError, make_env, validate_prefs
from wcac_jax.sweep.run import check_pref_count


def default_sweep(
    env: str = "walker2d",
    preset: str | None = None,
    n_prefs: int | None = None,
    *,
    prefs=None,
    steps_per_pref: int | None = None,
    env_options: dict | None = None,
    seed: int = 0,
    eval_episodes: int = 8,
    hv_ref=None,
    select_last: int | None = None,
    select_every: int | None = None,
    on_note: Callable[[str], None] | None = None,
    **train,
) -> SweepConfig:
    """The sweep the library runs on `env` by default, with the given changes.

    Args:
      env: a registered environment (`envs.names()`).
      preset: a named training configuration (`presets.PRESETS`: `paper`,
        `practical`, `conditioned`); `None`: the environment's default. `conditioned`
        trains one network for the whole front (`run_conditioned`): then
        `steps_per_pref` is the whole training's budget and the preferences are those
        the network is evaluated at.
      n_prefs: that many preferences evenly spread on the simplex (`None`: the paper's
        nine under `preset="paper"`, else `presets.DEFAULT_N_PREFS`, or
        `presets.CONDITIONED_EVAL_PREFS` for the conditioned update).
      prefs: explicit preferences `[P, m]` (in place of `n_prefs`).
      steps_per_pref: env steps per preference (`None`: the environment's default).
      env_options: the environment's options over its default's (e.g. `engine`).
      seed, eval_episodes, hv_ref: as `SweepConfig`'s.
      select_last, select_every: each preference's choice among its last policies
        (`None`: the default's, when the budget leaves room for it).
      on_note: receives each line the resolution has to say.
      **train: fields of the training configuration to change (e.g. `mu=0.5`).

    Raises:
      SweepError: naming the argument (or field) and the bad value.
    """
    if env not in envs.names():
        raise SweepError(f"unknown environment {env!r}; valid: {', '.join(envs.names())}")
    if n_prefs is not None and prefs is not None:
        raise SweepError("give n_prefs or prefs, not both")
    defaults = presets.env_defaults(env)
    if preset is None:
        base, name = defaults.config, f"{env}'s default ({defaults.preset})"
    else:
        try:
            base = presets.preset(preset)
        except ValueError as err:
            raise SweepError(str(err)) from None
        name = f"the {preset} preset"
    config = with_changes(base, train, name)
    conditioned = isinstance(config, algos.ConditionedConfig)
    options = {**dict(defaults.env_options), **(env_options or {})}
    probe = make_env(SweepConfig(prefs=(), env=env, env_options=options))
    try:  # a utopia point of the wrong length, before anything is built on it
        runtime.resolve_j_ub(config, probe)
    except ValueError as err:
        raise SweepError(str(err)) from None
    if prefs is not None:
        validate_prefs(prefs, int(probe.num_objectives))
        grid = tuple(tuple(float(x) for x in p) for p in prefs)
    elif n_prefs is None and preset == "paper":
        grid = presets.PAPER_PREFS
    else:
        grid = _lattice(n_prefs, conditioned, config, probe)
    if hv_ref is not None and len(hv_ref) != int(probe.num_objectives):
        raise SweepError(
            f"hv_ref {list(hv_ref)} has {len(hv_ref)} entries, expected {probe.num_objectives}"
        )
    if steps_per_pref is None:
        steps_per_pref = presets.CONDITIONED_TOTAL_STEPS if conditioned else defaults.steps_per_pref
    sweep = SweepConfig(
        prefs=grid,
        env=env,
        env_options=options,
        train=config,
        steps_per_pref=steps_per_pref,
        seed=seed,
        eval_episodes=eval_episodes,
        hv_ref=hv_ref,
    )
    if preset is None and defaults.fallback:
        _say(on_note, defaults.note)
    if conditioned:
        if select_last not in (None, 1) or select_every:
            raise SweepError("select_last does not apply to the conditioned update (one network)")
    else:
        sweep = with_selection(
            sweep, select_last, select_every, defaults.selection_for(preset), on_note
        )
    _say(on_note, budget_note(sweep))
    return sweep


def with_changes(config, changes: dict, name: str):
    """`config` with the fields `changes` changed; on an update with a utopia mode
    (the practical one), a fixed `j_ub` means a fixed utopia point, so it also sets
    `utopia` to `"fixed"` unless `changes` says otherwise, and a change the
    configuration would ignore (`j_ub` with an estimated utopia point, `utopia_margin`
    with a fixed one) is refused.

    Args:
      name: what `config` is, for messages (e.g. "the practical preset").

    Raises:
      SweepError: naming a field `config` does not have, or a bad value.
    """
    fields = {f.name for f in dataclasses.fields(config)}
    unknown = [k for k in changes if k not in fields]
    if unknown:
        raise SweepError(
            f"{unknown[0]} does not apply to {name}, a {algos.kind(config)} configuration"
        )
    changes = dict(changes)
    if "utopia" in fields:
        utopia = changes.get("utopia", "fixed" if "j_ub" in changes else config.utopia)
        if "j_ub" in changes and utopia != "fixed":
            raise SweepError("j_ub sets a fixed utopia point; utopia='estimated' ignores it")
        if "utopia_margin" in changes and utopia == "fixed":
            raise SweepError(
                "utopia_margin applies to the estimated utopia point; a fixed one "
                "(j_ub / utopia='fixed') ignores it"
            )
        if utopia != config.utopia:
            changes["utopia"] = utopia
    try:
        return config.replace(**changes)
    except (ValueError, TypeError) as err:
        raise SweepError(str(err)) from None


def with_selection(
    config: SweepConfig,
    select_last: int | None,
    select_every: int | None,
    default: tuple[int, int] = (1, 0),
    on_note: Callable[[str], None] | None = None,
) -> SweepConfig:
    """`config` reporting each preference's best of its last `select_last` policies,
    `select_every` env steps apart, either `None` meaning `default`'s value. With
    neither given, `default` applies when the budget leaves room for its candidates;
    otherwise the final policies are reported, and `on_note` is told so.

    Raises:
      SweepError: a bad value, or candidates asked for that do not fit the budget.
    """
    if select_last is None and select_every is None:
        last, every = default
        try:
            return dataclasses.replace(config, select_last=last, select_every=every)
        except SweepError:  # the candidates do not fit the budget
            _say(
                on_note,
                f"{config.steps_per_pref:,} env steps per preference leave no room for the "
                f"default choice among each preference's last {last} policies {every:,} env "
                "steps apart; reporting the final policies (select_last, select_every to "
                "choose)",
            )
            return config
    last = default[0] if select_last is None else select_last
    every = default[1] if select_every is None else select_every
    if last == 1:  # one candidate, the final policy: no spacing
        if select_every:
            raise SweepError(
                f"select_every {select_every} spaces the candidates of select_last K > 1; "
                "with one (the final policy) it would be ignored"
            )
        every = 0
    return dataclasses.replace(config, select_last=last, select_every=every)


def budget_note(config: SweepConfig) -> str | None:
    """A line stating the env steps that run when `steps_per_pref` (or, with a choice,
    `select_every`) is not a whole number of iterations and is rounded up; else `None`."""
    per = config.train.env_steps_per_iteration
    runs = config.num_iterations * per
    parts = []
    if runs != config.steps_per_pref:
        parts.append(
            f"{config.steps_per_pref:,} env steps per preference round up to "
            f"{config.num_iterations:,} iterations of {per:,}: training runs {runs:,}"
        )
    if config.select_last > 1 and config.select_every % per:
        every = -(-config.select_every // per)
        parts.append(
            f"select_every {config.select_every:,} rounds up to {every:,} iterations "
            f"({every * per:,} env steps)"
        )
    return "; ".join(parts) or None


def _lattice(n: int | None, conditioned: bool, config, env) -> tuple[tuple[float, ...], ...]:
    """`n` preferences evenly spread for `env`'s objectives (`pareto.preference_lattice`:
    for three objectives and more a full lattice, exactly `n` points when `n` is given)."""
    exact = n is not None or conditioned
    if n is None:
        n = presets.CONDITIONED_EVAL_PREFS if conditioned else presets.DEFAULT_N_PREFS
    if n < 1:
        raise SweepError(f"n_prefs must be >= 1, got {n}")
    if not conditioned:  # the training states alone must fit, before they are made
        check_pref_count(n, config, env, "n_prefs")
    try:
        grid = pareto.preference_lattice(int(env.num_objectives), n, exact=exact)
    except ValueError as err:
        raise SweepError(f"n_prefs: {err}") from None
    return tuple(tuple(float(x) for x in p) for p in grid)


def _say(on_note, line: str | None) -> None:
    if on_note is not None and line:
        on_note(line)
