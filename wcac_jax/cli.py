"""The command line, `python -m wcac_jax.sweep` or `wcac-sweep`: flags to a `SweepConfig`,
then `run_sweep`.

Exit status: 0 done, 2 bad input (one line naming it; nothing written), 3 training
diverged (the last good checkpoint is kept).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import textwrap
import time

import jax

from wcac_jax import algos, distributed, envs, pareto, presets
from wcac_jax.presets import PAPER_PREFS
from wcac_jax.sweep import (
    SweepConfig,
    SweepError,
    TrainingDiverged,
    check_pref_count,
    make_env,
    run_conditioned,
    run_sweep,
)


def _parse_prefs(text: str) -> tuple[tuple[float, ...], ...]:
    try:
        return tuple(
            tuple(float(x) for x in part.split(",")) for part in text.split(";") if part.strip()
        )
    except ValueError:
        raise SweepError(
            f"--prefs {text!r} is not a ';'-separated list of ','-separated "
            "numbers, e.g. '1,0;0.5,0.5;0,1'"
        ) from None


def _parse_floats(text: str, flag: str) -> tuple[float, ...]:
    try:
        return tuple(float(x) for x in text.split(","))
    except ValueError:
        raise SweepError(f"{flag} {text!r} is not a ','-separated list of numbers") from None


# Config flags are generated from the registered updates' configuration fields
# (`wcac_jax.algos`, each field's doc its help): one flag per field, named after it but
# where `FLAG_DESTS` says otherwise; `num_iterations` has none (`--steps-per-pref` sets
# it). Each defaults to None, i.e. the preset's (or the environment's default's) value.
# Scripts that build a sweep of their own take them too (`add_config_flags`,
# `apply_config_flags`).
FLAG_DESTS = {"num_envs": "envs_per_pref"}
_NO_FLAG = ("num_iterations",)
# what a flag does beyond setting its field
_FLAG_NOTES = {
    "j_ub": "e.g. '2000,1000'; with the practical update it also sets --utopia fixed",
}
_TYPES = {"int": int, "float": float, "bool": bool}


def _config_fields() -> dict[str, dict[str, dataclasses.Field]]:
    """`{field name: {update name: its Field}}` over every registered update, in
    declaration order (the paper's fields first)."""
    out: dict[str, dict[str, dataclasses.Field]] = {}
    for name, algo in algos.ALGOS.items():
        for f in dataclasses.fields(algo.config):
            if f.name not in _NO_FLAG:
                out.setdefault(f.name, {})[name] = f
    return out


def _default_text(value) -> str:
    return "none" if value is None else str(value)


def _meaning(field_name: str, per_update: dict[str, dataclasses.Field]) -> str:
    """A flag's help: the field's doc, which updates it applies to and each one's default."""
    docs = {f.metadata["doc"] for f in per_update.values()}
    if len(docs) == 1:
        doc = docs.pop()
        if len(per_update) < len(algos.ALGOS):
            doc = f"{' and '.join(per_update)} only: {doc}"
    else:
        doc = "; ".join(f"{name}: {f.metadata['doc']}" for name, f in per_update.items())
    if field_name in _FLAG_NOTES:
        doc += f" ({_FLAG_NOTES[field_name]})"
    defaults = ", ".join(f"{name} {_default_text(f.default)}" for name, f in per_update.items())
    return f"{doc} (preset default: {defaults})"


def _config_flags() -> tuple[tuple[str, str, str], ...]:
    return tuple(
        (FLAG_DESTS.get(name, name), name, _meaning(name, per_update))
        for name, per_update in _config_fields().items()
    )


# (flag dest, config field, meaning), one per configuration field
CONFIG_FLAGS = _config_flags()
# flag dest -> argparse type (`bool`: a `--x` / `--no-x` switch; the rest strings,
# `--j-ub` parsed by `apply_config_flags`)
_FLAG_TYPES = {
    FLAG_DESTS.get(name, name): _TYPES[next(iter(per_update.values())).type]
    for name, per_update in _config_fields().items()
    if next(iter(per_update.values())).type in _TYPES
}


def _flag(dest: str) -> str:
    return "--" + dest.replace("_", "-")


def add_config_flags(parser: argparse.ArgumentParser, skip: tuple[str, ...] = ()) -> None:
    """Adds one flag per `CONFIG_FLAGS` entry but those in `skip` (default None: the
    configuration's own value)."""
    group = parser.add_argument_group(
        "training configuration (each flag changes one field of the preset's or the "
        "environment's default configuration; it must be a field of that update)"
    )
    for dest, _, meaning in CONFIG_FLAGS:
        if dest in skip:
            continue
        kind = _FLAG_TYPES.get(dest, str)
        group.add_argument(
            _flag(dest),
            dest=dest,
            default=None,
            help=meaning.replace("%", "%%"),
            # a switch `--x` / `--no-x` for a yes/no field
            **({"action": argparse.BooleanOptionalAction} if kind is bool else {"type": kind}),
        )


def apply_config_flags(args, train: algos.UpdateConfig, name: str) -> algos.UpdateConfig:
    """`train` with every `CONFIG_FLAGS` flag given in `args` applied over it.

    On the practical update `--j-ub` means a fixed utopia point, so it also sets `utopia`
    to "fixed" unless `--utopia` says otherwise; a flag the configuration would ignore
    (`--j-ub` with `--utopia estimated`, `--utopia-margin` with a fixed point) is an error.

    Args:
      args: parsed arguments carrying the flags' dests (absent ones count as not given).
      train: the configuration the flags change.
      name: what `train` is, for messages (e.g. "the practical preset").

    Raises:
      SweepError: naming a flag that does not apply to `train`, or a bad value.
    """
    fields = {f.name for f in dataclasses.fields(train)}
    changes = {}
    for dest, field_name, _ in CONFIG_FLAGS:
        value = getattr(args, dest, None)
        if value is None:
            continue
        if field_name not in fields:
            raise SweepError(
                f"{_flag(dest)} does not apply to {name}, a {algos.kind(train)} configuration"
            )
        changes[field_name] = _parse_floats(value, _flag(dest)) if dest == "j_ub" else value
    if "utopia" in fields:
        utopia = changes.get("utopia", "fixed" if "j_ub" in changes else train.utopia)
        if "j_ub" in changes and utopia != "fixed":
            raise SweepError("--j-ub sets a fixed utopia point; --utopia estimated ignores it")
        if "utopia_margin" in changes and utopia == "fixed":
            raise SweepError(
                "--utopia-margin applies to the estimated utopia point; a fixed one "
                "(--j-ub / --utopia fixed) ignores it"
            )
        if utopia != train.utopia:
            changes["utopia"] = utopia
    try:
        return train.replace(**changes)
    except ValueError as err:
        raise SweepError(str(err)) from None


def _config_changes(config) -> str:
    """`field=value` of `config` where it differs from its update's own defaults."""
    base = type(config)()
    return ", ".join(
        f"{f.name}={getattr(config, f.name):.6g}"
        if isinstance(getattr(config, f.name), float)
        else f"{f.name}={getattr(config, f.name)}"
        for f in dataclasses.fields(config)
        if f.name not in _NO_FLAG and getattr(config, f.name) != getattr(base, f.name)
    )


def _defaults_table() -> str:
    lines = ["each environment's default run (flags override it):"]
    for name in envs.names():
        d = presets.env_defaults(name)
        changes = _config_changes(d.config)
        options = ", ".join(f"--{k.replace('_', '-')} {v}" for k, v in d.env_options)
        text = (
            f"{name}: {d.preset} ({algos.kind(d.config)} update"
            + (f"; {changes}" if changes else "")
            + ")"
            + (f" with {options}" if options else "")
            + f", {d.steps_per_pref:,} env steps per preference"
            + (
                f", each preference's best of its last {d.selection[0]} policies "
                f"{d.selection[1]:,} env steps apart"
                if d.selection[0] > 1
                else ""
            )
            + f"; {d.note}"
        )
        lines.append(textwrap.fill(text, 79, initial_indent="  ", subsequent_indent="    "))
    return "\n".join(lines)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m wcac_jax.sweep",
        description=textwrap.fill(
            "Train a whole Pareto front (one policy per preference) in one compiled "
            "program and write front.json, front.csv, front.png, curves.npz, config.json "
            "and a checkpoint to --out. With no flag but --env (and --n-prefs), each "
            f"environment runs its default (below) on {presets.DEFAULT_N_PREFS} evenly "
            "spaced preferences. --preset paper applies the paper's recipe (and its nine "
            "preferences [1,0] [0.9,0.1] [0.8,0.2] [0.7,0.3] [0.5,0.5] [0.3,0.7] [0.2,0.8] "
            "[0.1,0.9] [0,1]) to any environment; --preset practical the practical update. "
            "Explicit flags override the preset's values. Installed, the same command is "
            "also `wcac-sweep`.",
            79,
        ),
        epilog=_defaults_table(),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    g = p.add_mutually_exclusive_group()
    g.add_argument(
        "--n-prefs",
        type=int,
        default=None,
        help=f"N preferences evenly spread on the simplex (default: {presets.DEFAULT_N_PREFS}, "
        "or the paper's nine with --preset paper). With 3 or more objectives, the full "
        "lattice with h divisions, so N must be one of its sizes, C(h+m-1, m-1) (3, 6, 10, "
        "15, 21, ... for 3 objectives; another N is refused naming the nearest two); the "
        "default there is the smallest such lattice with at least "
        f"{presets.DEFAULT_N_PREFS} points (10 for 3 objectives)",
    )
    g.add_argument("--prefs", default=None, help="explicit preferences, e.g. '1,0;0.5,0.5;0,1'")
    p.add_argument(
        "--preset",
        choices=presets.PRESETS,
        default=None,
        help="training configuration: paper (the paper's recipe and preferences) or "
        "practical (default: the environment's, see below)",
    )
    p.add_argument("--env", default="walker2d", help=f"environment: {', '.join(envs.names())}")
    walker = dict(presets.env_defaults("walker2d").env_options)
    p.add_argument(
        "--physics",
        default=None,
        help="walker2d model: gymnasium-v5 (Gymnasium's v5 model, the paper's) or brax "
        f"(Brax's model) (default: {walker['physics']})",
    )
    p.add_argument(
        "--engine",
        default=None,
        help="physics engine of the MuJoCo tasks (walker2d, hopper, ...): mujoco (MuJoCo's C "
        "engine, multi-threaded; several times faster on a CPU) or mjx (for accelerators) "
        f"(default: {walker['engine']})",
    )
    p.add_argument(
        "--episode-length",
        type=int,
        default=None,
        help="time limit of the MuJoCo tasks, in steps (default 500, as the paper)",
    )
    p.add_argument(
        "--steps-per-pref",
        type=int,
        default=None,
        help="environment steps per preference (default: the environment's, see below); "
        "training runs whole iterations, so a budget that is not a multiple of an "
        "iteration's env steps is rounded up, with a note of the budget that runs",
    )
    add_config_flags(p)
    p.add_argument(
        "--hv-ref",
        default=None,
        help="hypervolume reference point, e.g. '-500,-3000' (default: the environment's "
        "default_hv_ref, per objective the least return an episode can have)",
    )
    p.add_argument(
        "--eval-episodes", type=int, default=8, help="evaluation episodes per preference (8)"
    )
    add_selection_flags(p)
    p.add_argument("--seed", type=int, default=0, help="random seed (0)")
    p.add_argument("--out", default=None, help="output directory (default: a new runs/<time>)")
    p.add_argument("--resume", action="store_true", help="continue the sweep in --out")
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the results in a non-empty --out (without it or --resume, a "
        "non-empty --out is refused); the new sweep runs beside it and replaces it once "
        "finished, so an interrupted run leaves the old results as they were",
    )
    p.add_argument(
        "--chunks",
        type=int,
        default=10,
        help="checkpoints per run (and progress lines in a log; on a terminal the bar "
        "moves every few seconds); does not change results (10)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress output")
    add_conditioned_flags(p)
    g = p.add_argument_group(
        "several processes (README, 'Many machines'): run the same command in each, "
        "with its own --process-id"
    )
    g.add_argument(
        "--coordinator",
        default=None,
        metavar="HOST:PORT",
        help="process 0's address; every process joins one sweep (default: "
        "$JAX_COORDINATOR_ADDRESS; without either, one process)",
    )
    g.add_argument(
        "--num-processes",
        type=int,
        default=None,
        help="processes in the sweep (default: $SLURM_NTASKS or $OMPI_COMM_WORLD_SIZE)",
    )
    g.add_argument(
        "--process-id",
        type=int,
        default=None,
        help="this process's rank, 0..N-1 (default: $SLURM_PROCID or $OMPI_COMM_WORLD_RANK)",
    )
    g.add_argument(
        "--coordinator-timeout",
        type=float,
        default=300.0,
        metavar="SECONDS",
        help="how long the processes wait for each other at the start (300)",
    )
    return p


def add_conditioned_flags(parser) -> None:
    """`--conditioned --total-steps N --eval-prefs K` (`wcac_jax.sweep.conditioned`)."""
    g = parser.add_argument_group(
        "one preference-conditioned network for the whole front (the conditioned update)"
    )
    g.add_argument(
        "--conditioned",
        action="store_true",
        help="train ONE network on preferences drawn per episode and evaluate it at "
        "--eval-prefs evenly spread preferences (default preset: conditioned)",
    )
    g.add_argument(
        "--total-steps",
        type=int,
        default=None,
        help="with --conditioned: env steps of the whole training (default: "
        f"{CONDITIONED_TOTAL_STEPS:,})",
    )
    g.add_argument(
        "--eval-prefs",
        type=int,
        default=None,
        help=f"with --conditioned: preferences the network is evaluated at "
        f"({CONDITIONED_EVAL_PREFS}; --prefs for explicit ones)",
    )


CONDITIONED_TOTAL_STEPS = 3_000_000
CONDITIONED_EVAL_PREFS = 33


def conditioned_config(args) -> SweepConfig:
    """The `SweepConfig` of `--conditioned`: the conditioned preset (or `--preset`), the
    flags over it, `--total-steps` as its budget, `--eval-prefs` (or `--prefs`) as the
    preferences the front is evaluated at; the final network reported."""
    for flag, value in (("--steps-per-pref", args.steps_per_pref), ("--n-prefs", args.n_prefs)):
        if value is not None:
            raise SweepError(
                f"{flag} does not apply to --conditioned (--total-steps, --eval-prefs)"
            )
    if args.select_last not in (None, 1):
        raise SweepError("--select-last does not apply to --conditioned (one network)")
    inner = argparse.Namespace(**vars(args))
    inner.preset = args.preset or "conditioned"
    inner.steps_per_pref = args.total_steps or CONDITIONED_TOTAL_STEPS
    inner.n_prefs = CONDITIONED_EVAL_PREFS if args.eval_prefs is None else args.eval_prefs
    inner.select_last, inner.select_every = 1, 0
    inner.total_steps = inner.eval_prefs = None
    inner.conditioned = None  # the flags above are checked: the sweep's own steps follow
    return config_from_args(inner)


def config_from_args(args) -> SweepConfig:
    """Builds (and validates) a `SweepConfig` from parsed CLI arguments: the preset's (or
    the environment's default) configuration, with every flag given applied over it."""
    conditioned = getattr(args, "conditioned", False)
    if conditioned:
        return conditioned_config(args)
    for flag in ("total_steps", "eval_prefs"):
        if getattr(args, flag, None) is not None:
            raise SweepError(f"{_flag(flag)} needs --conditioned")
    if args.preset == "conditioned" and conditioned is not None:
        raise SweepError("--preset conditioned trains one network for all: add --conditioned")
    defaults = presets.env_defaults(args.env)
    if args.preset is not None:
        try:
            train = presets.preset(args.preset)
        except ValueError as err:
            raise SweepError(str(err)) from None
        name = f"the {args.preset} preset"
    else:
        train, name = defaults.config, f"{args.env}'s default ({defaults.preset})"
    train = apply_config_flags(args, train, name)

    env_options = dict(defaults.env_options)
    if args.physics is not None:
        env_options["physics"] = args.physics
    if args.episode_length is not None:
        env_options["episode_length"] = args.episode_length
    if args.engine is not None:
        env_options["engine"] = args.engine
    if args.prefs is not None:
        prefs = _parse_prefs(args.prefs)
    elif args.n_prefs is None and args.preset == "paper":
        prefs = PAPER_PREFS
    else:
        n = presets.DEFAULT_N_PREFS if args.n_prefs is None else args.n_prefs
        if n < 1:
            raise SweepError(f"--n-prefs must be >= 1, got {n}")
        env = make_env(SweepConfig(prefs=(), env=args.env, env_options=env_options))
        m = int(env.num_objectives)
        check_pref_count(n, train, env)  # before the preferences are made
        try:
            grid = pareto.preference_lattice(m, n, exact=args.n_prefs is not None)
        except ValueError as err:
            raise SweepError(f"--n-prefs: {err}") from None
        prefs = tuple(tuple(float(x) for x in p) for p in grid)
    steps = defaults.steps_per_pref if args.steps_per_pref is None else args.steps_per_pref
    config = SweepConfig(
        prefs=prefs,
        env=args.env,
        env_options=env_options,
        train=train,
        steps_per_pref=steps,
        seed=args.seed,
        eval_episodes=args.eval_episodes,
        hv_ref=None if args.hv_ref is None else _parse_floats(args.hv_ref, "--hv-ref"),
    )
    if args.preset is None and defaults.fallback and not args.quiet:
        print(f"note: {defaults.note}", file=sys.stderr, flush=True)
    config, note = apply_selection_flags(args, config, defaults.selection_for(args.preset))
    if note is not None and not args.quiet:
        print(f"note: {note}", file=sys.stderr, flush=True)
    note = budget_note(config)
    if note is not None and not args.quiet:
        print(f"note: {note}", file=sys.stderr, flush=True)
    return config


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
            f"--select-every {config.select_every:,} rounds up to {every:,} iterations "
            f"({every * per:,} env steps)"
        )
    return "; ".join(parts) or None


def apply_selection_flags(
    args, config: SweepConfig, default: tuple[int, int] = (1, 0)
) -> tuple[SweepConfig, str | None]:
    """`config` with `--select-last` and `--select-every` (`add_selection_flags`) applied
    over `default` = `(select_last, select_every)` (e.g. an environment's,
    `presets.Defaults.selection`). With neither flag given, `default` applies when the
    budget leaves room for its candidates, and otherwise the final policies are reported
    and the second value says so (`with_selection`).

    Raises:
      SweepError: a flag's bad value, or candidates the flags ask for that do not fit.
    """
    if args.select_last is None and args.select_every is None:
        return with_selection(config, default)
    changes = {
        "select_last": default[0] if args.select_last is None else args.select_last,
        "select_every": default[1] if args.select_every is None else args.select_every,
    }
    if changes["select_last"] == 1:  # one candidate, the final policy: no spacing
        if args.select_every:
            raise SweepError(
                f"--select-every {args.select_every} spaces the candidates of "
                "--select-last K > 1; with one (the final policy) it would be ignored"
            )
        changes["select_every"] = 0
    return dataclasses.replace(config, **changes), None


def with_selection(
    config: SweepConfig, selection: tuple[int, int]
) -> tuple[SweepConfig, str | None]:
    """`config` reporting each preference's best of its last policies as `selection` =
    `(select_last, select_every)` asks (an environment's default, `presets.Defaults`);
    or, when its budget leaves no room for those candidates, `config` as it is (final
    policies) and a line saying so."""
    last, every = selection
    try:
        return dataclasses.replace(config, select_last=last, select_every=every), None
    except SweepError:  # the candidates do not fit the budget
        return config, (
            f"{config.steps_per_pref:,} env steps per preference leave no room for the "
            f"default choice among each preference's last {last} policies {every:,} env "
            "steps apart; reporting the final policies (--select-last, --select-every to "
            "choose)"
        )


def add_selection_flags(parser) -> None:
    """`--select-last K --select-every STEPS` (`wcac_jax.selection`), on `parser`."""
    parser.add_argument(
        "--select-last",
        type=int,
        default=None,
        help="report each preference's best of its last K policies, by weighted Chebyshev "
        "on their own evaluation episodes (1: the final policy; default: the "
        "environment's, below, when the budget leaves room for them, else 1)",
    )
    parser.add_argument(
        "--select-every",
        type=int,
        default=None,
        help="env steps between those K policies, rounded up to whole iterations (needed "
        "with --select-last > 1, an error with one policy; default: the environment's)",
    )


def use_every_core(engine: str | None = None) -> str:
    """Keeps every core busy; returns a line saying how. Unless the user set `XLA_FLAGS`,
    splits the host CPU into one XLA device per core (the preference axis is sharded over
    devices, so every core trains) — except with `engine="mujoco"`, whose C engine
    already steps on one thread per core: its host callback takes the whole batch on one
    device, and XLA warns at length about gathering a sharded batch for it. Only before JAX
    initialises its backend (the device count is fixed then)."""
    from jax._src import xla_bridge

    cores = os.cpu_count() or 1
    if xla_bridge.backends_are_initialized():
        return f"[devices] JAX already initialised: {jax.device_count()} device(s)"
    if "XLA_FLAGS" in os.environ:
        return f"[devices] XLA_FLAGS={os.environ['XLA_FLAGS']!r} (yours): devices as it says"
    if engine == "mujoco":
        return f"[devices] engine mujoco: MuJoCo steps on {cores} threads, one per core"
    os.environ["XLA_FLAGS"] = f"--xla_force_host_platform_device_count={cores}"
    return (
        f"[devices] {cores} host devices, one per core (XLA_FLAGS={os.environ['XLA_FLAGS']}; "
        "set XLA_FLAGS to choose otherwise)"
    )


def main(argv=None, *, every_core: bool | None = None) -> int:
    """The command line; returns the exit status (the console script `wcac-sweep` and
    `python -m wcac_jax.sweep` exit with it).

    Args:
      argv: the arguments (`None`: the process's own, `sys.argv[1:]`).
      every_core: one host device per core unless `XLA_FLAGS` is set, said on the first
        line (`use_every_core`); `None`: when `argv` is `None`, i.e. when this process
        is the command (a call from Python with its own arguments keeps JAX's devices).
    """
    if every_core is None:
        every_core = argv is None
    args = build_parser().parse_args(argv)
    try:
        cluster = distributed.from_environment(
            args.coordinator, args.num_processes, args.process_id, args.coordinator_timeout
        )
    except distributed.DistributedError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    if every_core:
        engine = args.engine or dict(presets.env_defaults(args.env).env_options).get("engine")
        if engine is None and args.env in envs.names():  # an unknown --env is reported below
            engine = envs.option_defaults(args.env).get("engine")
        note = use_every_core(engine)
        if not args.quiet:
            print(note, file=sys.stderr, flush=True)
    try:
        if cluster is not None:  # before anything touches JAX's devices
            distributed.initialize(cluster)
        config = config_from_args(args)
        out = args.out or os.path.join("runs", time.strftime("%Y%m%d-%H%M%S"))
        if args.resume and args.out is None:
            raise SweepError("--resume needs --out DIR")
        front = (run_conditioned if args.conditioned else run_sweep)(
            config,
            out,
            resume=args.resume,
            overwrite=args.overwrite,
            chunks=args.chunks,
            progress=False if args.quiet else None,
        )
    except (SweepError, distributed.DistributedError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except TrainingDiverged as err:
        print(f"error: {err}", file=sys.stderr)
        return 3
    if front.get("finished"):  # `--resume` of a finished sweep: nothing done, nothing written
        if not args.quiet:
            print(f"{out} is finished (its front.json is written): --resume has nothing to do")
        return 0
    if not distributed.is_writer():
        if not args.quiet:
            print(f"[process {jax.process_index()}] done; process 0 wrote {out}", file=sys.stderr)
        return 0
    if not args.quiet:
        print(
            f"wrote {out}: {len(front['prefs'])} preferences, hypervolume "
            f"{front['hypervolume']:.6g}, {front['env_steps_per_s']:,.0f} env-steps/s, "
            f"{front['wall_s']:.0f} s"
        )
        if "selection" in front:
            chosen = front["selection"]["chosen_iteration"]
            print(
                f"chosen policies (iteration per preference, of {config.num_iterations}): {chosen}"
            )
    outside = front["outside_hv_ref"]
    if outside:
        print(
            f"warning: {len(outside)} of {len(front['prefs'])} policies lie outside the "
            f"hypervolume reference box {front['hv_ref']} and add nothing to it: "
            + ", ".join(f"#{i} {front['prefs'][i]['pref']}" for i in outside),
            file=sys.stderr,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main(every_core=True))
