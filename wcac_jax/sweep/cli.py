"""The command line, `python -m wcac_jax.sweep` or `wcac-sweep`: a shell over the library's
defaults (`wcac_jax.sweep.default_sweep`: each flag is one of its arguments) and
`run_sweep` (or `run_conditioned`).

`--help` lists each flag once, with the value the chosen `--env` (and `--preset`) would
use; `--help-all` adds every update's fields and each environment's default in full.
`--print-config` shows the resolved configuration (what `config.json` will hold) and
exits. `--out DIR --resume` continues the sweep in `DIR` as its `config.json` recorded
it; a flag given beside it must agree with that record.

Exit status: 0 done, 2 bad input (one `error:` line naming the flag; nothing written), 3
training diverged (the last good checkpoint is kept).
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import os
import re
import sys
import textwrap
import time

from wcac_jax import algos, envs, pareto, protocols
from wcac_jax.sweep import (
    SweepConfig,
    SweepError,
    TrainingDiverged,
    default_sweep,
    distributed,
    presets,
    read_config,
    run_conditioned,
    run_sweep,
)
from wcac_jax.sweep import defaults as resolution
from wcac_jax.sweep.conditioned import training_sweep
from wcac_jax.sweep.outputs import json_bytes
from wcac_jax.sweep.protocol import budget_note as protocol_budget_note
from wcac_jax.sweep.protocol import protocol_prefs, protocol_sweep

PROG = "python -m wcac_jax.sweep"

# ---------------------------------------------------------------- flags and field names

# One flag per field of the registered updates' configurations, named after the field but
# where `FLAG_DESTS` says otherwise; `num_iterations` has none (the budget sets it).
FLAG_DESTS = {"num_envs": "envs_per_pref"}
_NO_FLAG = ("num_iterations",)
# what a flag does beyond setting its field
_FLAG_NOTES = {"j_ub": "e.g. '2000,1000'; on the practical update it also sets --utopia fixed"}
_TYPES = {"int": int, "float": float, "bool": bool}
# the sweep's own arguments (`default_sweep`'s, `SweepConfig`'s) by flag
_SWEEP_FLAGS = {
    "steps_per_pref": "--steps-per-pref",
    "n_prefs": "--n-prefs",
    "prefs": "--prefs",
    "seed": "--seed",
    "eval_episodes": "--eval-episodes",
    "hv_ref": "--hv-ref",
    "select_last": "--select-last",
    "select_every": "--select-every",
}
# the environment's options with a flag of their own, and what each is
_ENV_FLAGS = {
    "physics": "Walker2d's model: gymnasium-v5 or brax",
    "engine": "mujoco (MuJoCo's C engine, for CPUs) or mjx (for accelerators)",
    "episode_length": "time limit in steps",
}
# with --conditioned, the budget is the whole training's and the preferences are those
# the network is evaluated at
_CONDITIONED_FLAGS = {"steps_per_pref": "--total-steps", "n_prefs": "--eval-prefs"}


def _flag(dest: str) -> str:
    return "--" + dest.replace("_", "-")


def _config_fields() -> dict[str, dict[str, dataclasses.Field]]:
    """`{field name: {update name: its Field}}` over every registered update, in
    declaration order (the paper's fields first)."""
    out: dict[str, dict[str, dataclasses.Field]] = {}
    for name, algo in algos.ALGOS.items():
        for f in dataclasses.fields(algo.config):
            if f.name not in _NO_FLAG:
                out.setdefault(f.name, {})[name] = f
    return out


def _value(value) -> str:
    if value is None:
        return "none"
    if isinstance(value, tuple):
        return ",".join(f"{v:g}" for v in value)
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def _choices(f: dataclasses.Field) -> tuple[str, ...] | None:
    """The values a field takes, read from its registry now (`config.one_of`)."""
    valid = getattr(f.metadata.get("check"), "choices", None)
    return tuple(valid()) if valid is not None else None


def _meaning(field_name: str, per_update: dict[str, dataclasses.Field]) -> str:
    """A flag's full help (`--help-all`): the field's doc, which updates it applies to,
    its choices and each update's default."""
    docs = {f.metadata["doc"] for f in per_update.values()}
    if len(docs) == 1:
        doc = docs.pop()
        if len(per_update) < len(algos.ALGOS):
            doc = f"{' and '.join(per_update)} only: {doc}"
    else:
        doc = "; ".join(f"{name}: {f.metadata['doc']}" for name, f in per_update.items())
    if field_name in _FLAG_NOTES:
        doc += f" ({_FLAG_NOTES[field_name]})"
    choices = sorted({c for f in per_update.values() for c in (_choices(f) or ())})
    if choices:
        doc += f"; one of {', '.join(choices)}"
    defaults = ", ".join(f"{name} {_value(f.default)}" for name, f in per_update.items())
    return f"{doc} (preset default: {defaults})"


def _config_flags() -> tuple[tuple[str, str, str], ...]:
    return tuple(
        (FLAG_DESTS.get(name, name), name, _meaning(name, per_update))
        for name, per_update in _config_fields().items()
    )


# (flag dest, config field, meaning), one per configuration field of the updates
# registered at import (the parser reads the registry when it is built)
CONFIG_FLAGS = _config_flags()


def _field_flags() -> dict[str, str]:
    """`{field name: flag}` of every configuration field with a flag."""
    return {name: _flag(FLAG_DESTS.get(name, name)) for name in _config_fields()}


def flagged(message: str, conditioned: bool = False) -> str:
    """`message` (the library's, naming fields and arguments) naming the flags a user
    types instead: `name='value'` becomes `--name value`, a name with an underscore
    becomes its flag anywhere, and a plain name its flag where it opens the message."""
    names = {
        **_field_flags(),
        **_SWEEP_FLAGS,
        **{name: _flag(name) for name in _ENV_FLAGS},
        **(_CONDITIONED_FLAGS if conditioned else {}),
    }
    words = "|".join(sorted(map(re.escape, names), key=len, reverse=True))
    message = re.sub(rf"\b({words})='?([^'\s,;)]*)'?", lambda m: f"{names[m[1]]} {m[2]}", message)
    message = re.sub(
        rf"(?<![-\w/.'])({words})\b(?!')",
        lambda m: names[m[1]] if "_" in m[1] or m.start() == 0 else m[0],
        message,
    )
    return message


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


# ---------------------------------------------------------------- the parser


class _Parser(argparse.ArgumentParser):
    """argparse with one line per error (`error: ... (see --help)`, exit 2) instead of
    the usage, and values that start with '-' taken as values (`--hv-ref -500,-3000`)."""

    def error(self, message: str):
        self.exit(2, f"error: {message} (see --help)\n")

    def parse_known_args(self, args=None, namespace=None):
        args = list(sys.argv[1:] if args is None else args)
        return super().parse_known_args(_joined(self, args), namespace)


def _joined(parser: argparse.ArgumentParser, argv: list[str]) -> list[str]:
    """`argv` with `--flag -value` written `--flag=-value` where `--flag` takes a value
    and `-value` is no flag (argparse would read a negative list as a flag)."""
    actions = parser._option_string_actions
    out, i = [], 0
    while i < len(argv):
        token = argv[i]
        action = actions.get(token)
        takes_value = action is not None and action.nargs is None and action.const is None
        if takes_value and i + 1 < len(argv):
            value = argv[i + 1]
            if value.startswith("-") and value not in actions and value != "--":
                out.append(f"{token}={value}")
                i += 2
                continue
        out.append(token)
        i += 1
    return out


def _chosen(argv: list[str]) -> tuple[str, str | None, bool]:
    """`(env, preset, conditioned)` as `argv` asks, read before the parser is built (the
    help shows their defaults); the parser checks them afterwards."""
    pre = argparse.ArgumentParser(add_help=False, allow_abbrev=False)
    pre.add_argument("--env", default="walker2d")
    pre.add_argument("--preset", default=None)
    pre.add_argument("--conditioned", action="store_true")
    args, _ = pre.parse_known_args([a for a in argv if a not in ("-h", "--help")])
    env = args.env if args.env in envs.names() else "walker2d"
    preset = args.preset if args.preset in algos.ALGOS else None
    if args.conditioned and preset is None:
        preset = "conditioned"
    return env, preset, args.conditioned


def _base_config(env: str, preset: str | None):
    return presets.preset(preset) if preset else presets.env_defaults(env).config


def build_parser(argv=None, full: bool = False) -> argparse.ArgumentParser:
    """The command line's parser; its help shows the defaults of the `--env` and
    `--preset` in `argv` (default: Walker2d's), and with `full` (`--help-all`) every
    update's fields and each environment's default in full."""
    env, preset, _ = _chosen(list(argv or []))
    base = _base_config(env, preset)
    d = presets.env_defaults(env)
    options = {**envs.option_defaults(env), **dict(d.env_options)}
    p = _Parser(
        prog=PROG,
        usage=f"{PROG} [--env NAME] [--n-prefs N | --prefs P] [flags]",
        description=textwrap.fill(
            "Train a whole Pareto front (one policy per preference) in one compiled "
            "program; writes front.json, front.csv, front.png, curves.npz, config.json and "
            "a checkpoint to --out (docs/outputs.md); each --env has a default (below). "
            "Values in parentheses are those "
            f"of --env {env}" + (f" --preset {preset}" if preset else "") + "; --help-all "
            "shows every update's.",
            79,
        ),
        epilog=_defaults_table(full),
        formatter_class=lambda prog: argparse.RawDescriptionHelpFormatter(
            prog, max_help_position=26
        ),
        allow_abbrev=False,
    )
    p.add_argument(
        "--help-all",
        action=functools.partial(_HelpAll, argv=list(argv or [])),
        help="this help with every update's fields and defaults",
    )
    g = p.add_argument_group("what to train")
    g.add_argument(
        "--env", default="walker2d", metavar="NAME", help="a registered environment (below)"
    )
    g.add_argument(
        "--preset", default=None, metavar="NAME", help=f"{', '.join(algos.ALGOS)} ({d.preset})"
    )
    prefs = g.add_mutually_exclusive_group()
    prefs.add_argument(
        "--n-prefs",
        type=int,
        default=None,
        metavar="N",
        help=f"preferences evenly spread ({presets.DEFAULT_N_PREFS}; the paper's nine under "
        "--preset paper; 3 objectives: 6, 10, 15, ...)",
    )
    prefs.add_argument(
        "--prefs", default=None, metavar="P", help="explicit, e.g. '1,0;0.5,0.5;0,1'"
    )
    g.add_argument(
        "--steps-per-pref",
        type=int,
        default=None,
        metavar="N",
        help=f"env steps per preference, rounded up to whole iterations ({d.steps_per_pref:,})",
    )
    g.add_argument("--seed", type=int, default=0, metavar="N", help="random seed (0)")
    g.add_argument(
        "--print-config", action="store_true", help="print the resolved configuration and exit"
    )
    g = p.add_argument_group("one preference-conditioned network for the whole front")
    g.add_argument(
        "--conditioned",
        action="store_true",
        help="the same as --preset conditioned",
    )
    g.add_argument(
        "--total-steps",
        type=int,
        default=None,
        metavar="N",
        help=f"its env steps in all ({presets.CONDITIONED_TOTAL_STEPS:,})",
    )
    g.add_argument(
        "--eval-prefs",
        type=int,
        default=None,
        metavar="N",
        help=f"preferences it is evaluated at ({presets.CONDITIONED_EVAL_PREFS})",
    )
    g = p.add_argument_group("a benchmark protocol of the field (docs/protocols.md)")
    g.add_argument(
        "--protocol",
        choices=tuple(protocols.PROTOCOLS),
        default=None,
        metavar="NAME",
        help=f"{' or '.join(protocols.PROTOCOLS)}: its preset, budget and scoring",
    )
    g.add_argument(
        "--off-budget",
        action="store_true",
        help="allow another --total-steps (marked: not comparable)",
    )
    g = p.add_argument_group(f"the environment ({env}'s options)")
    for name, text in _ENV_FLAGS.items():
        shown = f" ({options[name]})" if name in options else ""
        kind = int if name == "episode_length" else str
        g.add_argument(_flag(name), type=kind, default=None, metavar="X", help=text + shown)
    add_config_flags(p, base=base, full=full, title=_training_title(env, preset, base, full))
    g = p.add_argument_group("evaluation and the reported policies")
    g.add_argument(
        "--eval-episodes",
        type=int,
        default=None,
        metavar="N",
        help="evaluation episodes per preference (8; a protocol's own with --protocol)",
    )
    g.add_argument(
        "--hv-ref",
        default=None,
        metavar="LIST",
        help="hypervolume reference point, e.g. '-500,-3000' (the environment's least returns)",
    )
    add_selection_flags(g, d.selection_for(preset))
    g = p.add_argument_group("output")
    g.add_argument("--out", default=None, metavar="DIR", help="output directory (runs/<time>)")
    g.add_argument(
        "--resume", action="store_true", help="continue the sweep in --out as it was recorded"
    )
    g.add_argument(
        "--overwrite",
        action="store_true",
        help="replace a non-empty --out once the new sweep has finished",
    )
    g.add_argument(
        "--chunks",
        type=int,
        default=10,
        metavar="N",
        help="checkpoints per run; does not change results (10)",
    )
    g.add_argument("--quiet", action="store_true", help="no progress output")
    g = p.add_argument_group("several processes (docs/distributed.md)")
    g.add_argument("--coordinator", default=None, metavar="HOST:PORT", help="process 0's address")
    g.add_argument(
        "--num-processes", type=int, default=None, metavar="N", help="processes in the sweep"
    )
    g.add_argument("--process-id", type=int, default=None, metavar="N", help="this one's rank")
    g.add_argument(
        "--coordinator-timeout",
        type=float,
        default=300.0,
        metavar="S",
        help="seconds the processes wait for each other (300)",
    )
    return p


class _HelpAll(argparse.Action):
    """`--help-all`: the help with every update's fields and defaults (for the `--env`
    and `--preset` of `argv`)."""

    def __init__(self, option_strings, dest, argv, **kwargs):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)
        self.argv = argv

    def __call__(self, parser, namespace, values, option_string=None):
        build_parser(self.argv, full=True).print_help()
        parser.exit()


def _training_title(env: str, preset: str | None, base, full: bool) -> str:
    if full:
        return (
            "training configuration: each flag changes one field of the preset's or the "
            "environment's default configuration, and must be a field of that update"
        )
    source = f"--preset {preset}" if preset else f"{env}'s default"
    return f"training: {source}, the {algos.kind(base)} update (each flag sets one field)"


def add_config_flags(
    parser: argparse.ArgumentParser,
    skip: tuple[str, ...] = (),
    base=None,
    full: bool = True,
    title: str | None = None,
) -> None:
    """Adds one flag per configuration field of the registered updates but those in
    `skip` (default `None`: the configuration's own value). With `full`, each flag's help
    is every update's doc and default (`--help-all`); otherwise only `base`'s fields are
    shown, with `base`'s values, and the other updates' flags are named in one line."""
    fields = _config_fields()
    own = (
        {f.name: f for f in dataclasses.fields(base)} if base is not None else dict.fromkeys(fields)
    )
    hidden = [] if full else [n for n in fields if n not in own]
    description = None
    if hidden:
        description = textwrap.fill(
            "other updates' flags (--help-all): "
            + ", ".join(_flag(FLAG_DESTS.get(n, n)) for n in hidden),
            77,
            break_on_hyphens=False,
        )
    group = parser.add_argument_group(
        title or "training configuration (each flag changes one field)", description
    )
    for name, per_update in fields.items():
        dest = FLAG_DESTS.get(name, name)
        if dest in skip:
            continue
        f = next(iter(per_update.values()))
        kind = _TYPES.get(f.type, str)
        if full or base is None:
            text = _meaning(name, per_update)
        elif name in own:
            text = _short(own[name]) + f" ({_value(getattr(base, name))})"
        else:
            text = argparse.SUPPRESS
        group.add_argument(
            _flag(dest),
            dest=dest,
            default=None,
            help=text.replace("%", "%%") if text is not argparse.SUPPRESS else text,
            # a switch `--x` / `--no-x` for a yes/no field
            **(
                {"action": argparse.BooleanOptionalAction}
                if kind is bool
                else {"type": kind, "metavar": "X"}
            ),
        )


def _short(f: dataclasses.Field) -> str:
    """A field's doc up to its first `;` (or a `:` outside an aside), without a closing
    aside that defines no value, and its choices where the doc does not name them all."""
    short = f.metadata["doc"].split("; ")[0]
    head = short.split(": ")[0]
    if head != short and head.count("(") == head.count(")"):
        short = head
    if short.endswith(")") and " (" in short:
        shorter, aside = short[: short.rindex(" (")], short[short.rindex(" (") :]
        if len(shorter) >= 12 and ":" not in aside and shorter.count("(") == shorter.count(")"):
            short = shorter
    choices = _choices(f) or ()
    if choices and not all(c in short for c in choices):
        short += f": {', '.join(choices)}"
    return short


def _defaults_table(full: bool) -> str:
    """Each environment's default run: environments with the same default on one line
    (`full`: one line each, with its note)."""
    lines = ["each --env's default, its configuration and env steps per preference:"]
    grouped: dict[str, list[str]] = {}
    for name in envs.names():
        d = presets.env_defaults(name)
        last, every = d.selection
        kind = algos.kind(d.config)
        source = d.preset if d.preset == kind else f"{d.preset} ({kind})"
        text = f"{source}, {d.steps_per_pref:,}"
        text += f", the best of its last {last} policies" if last > 1 else ""
        if not full:
            grouped.setdefault(text, []).append(name)
            continue
        changes = _config_changes(d.config)
        options = ", ".join(f"--{k.replace('_', '-')} {v}" for k, v in d.env_options)
        text += f" {every:,} env steps apart" if last > 1 else ""
        text += (f"; {changes}" if changes else "") + (f"; {options}" if options else "")
        text = f"{name + ':':<19}{text}; {d.note}"
        lines.append(textwrap.fill(text, 79, initial_indent="  ", subsequent_indent="    "))
    for text, names in grouped.items():
        line = f"{', '.join(names)}: {text}"
        lines.append(textwrap.fill(line, 79, initial_indent="  ", subsequent_indent="    "))
    return "\n".join(lines)


def _config_changes(config) -> str:
    """`field=value` of `config` where it differs from its update's own defaults."""
    base = type(config)()
    return ", ".join(
        f"{f.name}={_value(getattr(config, f.name))}"
        for f in dataclasses.fields(config)
        if f.name not in _NO_FLAG and getattr(config, f.name) != getattr(base, f.name)
    )


def add_selection_flags(parser, default: tuple[int, int] | None = None) -> None:
    """`--select-last K --select-every STEPS` (`wcac_jax.sweep.selection`), on `parser`; the
    help names `default` = `(select_last, select_every)` when given."""
    shown = ""
    if default is not None:
        shown = f" ({default[0]}" + (
            f", {default[1]:,} env steps apart)" if default[0] > 1 else ")"
        )
    parser.add_argument(
        "--select-last",
        type=int,
        default=None,
        metavar="K",
        help="each preference's best of its last K policies" + shown,
    )
    parser.add_argument(
        "--select-every",
        type=int,
        default=None,
        metavar="N",
        help="env steps between those K policies, rounded up to whole iterations",
    )


# ---------------------------------------------------------------- flags to a sweep


def apply_config_flags(args, train, name: str):
    """`train` with every configuration flag given in `args` applied over it
    (`default_sweep`'s rule: on the practical update `--j-ub` also fixes the utopia
    point); `name` says what `train` is, for messages.

    Raises:
      SweepError: naming a flag that does not apply to `train`, or a bad value.
    """
    try:
        return resolution.with_changes(train, _train_changes(args), name)
    except SweepError as err:
        raise SweepError(flagged(str(err))) from None


def _train_changes(args) -> dict:
    changes = {}
    for dest, field_name, _ in _config_flags():
        value = getattr(args, dest, None)
        if value is not None:
            changes[field_name] = _parse_floats(value, _flag(dest)) if dest == "j_ub" else value
    return changes


def _sweep_arguments(args) -> dict:
    """`default_sweep`'s arguments from the parsed flags (the conditioned update's
    `--total-steps` and `--eval-prefs` as its budget and preference count)."""
    conditioned = bool(getattr(args, "conditioned", False)) or args.preset == "conditioned"
    if getattr(args, "conditioned", False) and args.preset not in (None, "conditioned"):
        raise SweepError(
            f"--conditioned trains the conditioned update; --preset {args.preset} is another"
        )
    if conditioned:
        for flag, value in (
            ("--steps-per-pref", args.steps_per_pref),
            ("--n-prefs", args.n_prefs),
        ):
            if value is not None:
                raise SweepError(
                    f"{flag} does not apply to --conditioned (--total-steps, --eval-prefs)"
                )
        if args.select_last not in (None, 1) or args.select_every:
            raise SweepError("--select-last does not apply to --conditioned (one network)")
    else:
        for flag in ("total_steps", "eval_prefs"):
            if getattr(args, flag, None) is not None:
                raise SweepError(f"{_flag(flag)} needs --conditioned")
    options = {
        name: getattr(args, name) for name in _ENV_FLAGS if getattr(args, name, None) is not None
    }
    return {
        "env": args.env,
        "preset": "conditioned" if conditioned and args.preset is None else args.preset,
        "n_prefs": getattr(args, "eval_prefs", None) if conditioned else args.n_prefs,
        "prefs": None if args.prefs is None else _parse_prefs(args.prefs),
        "steps_per_pref": getattr(args, "total_steps", None)
        if conditioned
        else args.steps_per_pref,
        "env_options": options,
        "seed": args.seed,
        **({} if args.eval_episodes is None else {"eval_episodes": args.eval_episodes}),
        "hv_ref": None if args.hv_ref is None else _parse_floats(args.hv_ref, "--hv-ref"),
        "select_last": None if conditioned else args.select_last,
        "select_every": None if conditioned else args.select_every,
        **_train_changes(args),
    }


def config_from_args(args) -> SweepConfig:
    """The `SweepConfig` the parsed flags ask for (`default_sweep`), its notes printed
    unless `--quiet`.

    Raises:
      SweepError: naming the flag and the bad value.
    """
    if getattr(args, "protocol", None) is not None:
        return protocol_config(args)
    if getattr(args, "off_budget", False):
        raise SweepError("--off-budget needs --protocol")
    conditioned = bool(getattr(args, "conditioned", False)) or args.preset == "conditioned"
    quiet = getattr(args, "quiet", False)

    def note(line: str) -> None:
        if not quiet:
            print(f"note: {flagged(line, conditioned)}", file=sys.stderr, flush=True)

    try:
        return default_sweep(**_sweep_arguments(args), on_note=note)
    except SweepError as err:
        raise SweepError(flagged(str(err), conditioned)) from None


_PROTOCOL_FIXES = (
    "prefs",
    "n_prefs",
    "eval_prefs",
    "steps_per_pref",
    "select_last",
    "select_every",
    "eval_episodes",
    "preset",
    "conditioned",
    "episode_length",
)


def protocol_config(args) -> SweepConfig:
    """The `SweepConfig` of `--protocol`: `protocol_sweep` of `--env`, the training flags
    over the protocol's preset, `--total-steps` only with `--off-budget`.

    Raises:
      SweepError: a flag the protocol fixes, or `--total-steps` without `--off-budget`.
    """
    for dest in _PROTOCOL_FIXES:
        if getattr(args, dest, None) not in (None, False):
            raise SweepError(f"{_flag(dest)} does not apply to --protocol (the protocol fixes it)")
    if args.total_steps is not None and not args.off_budget:
        raise SweepError(
            f"--total-steps with --protocol {args.protocol} trains off the protocol's budget: "
            "add --off-budget to do so on purpose"
        )
    train = presets.protocol_preset(args.protocol, args.env).config
    train = apply_config_flags(args, train, f"the {args.protocol} protocol's preset for {args.env}")
    options = {name: getattr(args, name) for name in ("physics", "engine")}
    options = {k: v for k, v in options.items() if v is not None}
    config = protocol_sweep(args.env, args.protocol, args.seed, train, args.total_steps, options)
    if not getattr(args, "quiet", False):
        print(f"note: {protocol_budget_note(config)}", file=sys.stderr, flush=True)
    return config


def apply_selection_flags(
    args, config: SweepConfig, default: tuple[int, int] = (1, 0)
) -> tuple[SweepConfig, str | None]:
    """`config` with `--select-last` and `--select-every` applied over `default`
    (`default_sweep`'s rule), and the note a default that does not fit gives (else
    `None`).

    Raises:
      SweepError: a flag's bad value, or candidates the flags ask for that do not fit.
    """
    notes = []
    try:
        config = resolution.with_selection(
            config, args.select_last, args.select_every, default, notes.append
        )
    except SweepError as err:
        raise SweepError(flagged(str(err))) from None
    return config, (flagged(notes[0]) if notes else None)


def budget_note(config: SweepConfig) -> str | None:
    """`default_sweep`'s line on a budget rounded up to whole iterations, with flags."""
    note = resolution.budget_note(config)
    return None if note is None else flagged(note)


# ---------------------------------------------------------------- --resume


def _given(parser: argparse.ArgumentParser, argv: list[str]) -> dict[str, str]:
    """`{dest: the flag as typed}` of every flag in `argv`."""
    given = {}
    for token in _joined(parser, argv):
        option = token.split("=", 1)[0]
        action = parser._option_string_actions.get(option)
        if action is not None and token.startswith("--"):
            given[action.dest] = option
    return given


# flags that say nothing about what is trained
_RUN_FLAGS = {
    "out",
    "resume",
    "overwrite",
    "chunks",
    "quiet",
    "print_config",
    "coordinator",
    "num_processes",
    "process_id",
    "coordinator_timeout",
}


def resume_config(args, given: dict[str, str]) -> SweepConfig:
    """The sweep `--out` holds, as its `config.json` recorded it: resuming needs no other
    flag, and a flag given beside `--resume` must agree with the record.

    Raises:
      SweepError: naming (at most three of) the flags given that differ from it.
    """
    saved = read_config(args.out, "--resume")
    conditioned = isinstance(saved.train, algos.ConditionedConfig)
    env = envs.make(saved.env, **saved.env_options)
    m = int(env.num_objectives)
    differ = []

    def compare(flag: str, asked, recorded) -> None:
        if asked != recorded:
            differ.append(f"{flag} {_value(asked)} (it has {_value(recorded)})")

    for dest, flag in given.items():
        if dest in _RUN_FLAGS or dest in ("n_prefs", "prefs", "eval_prefs") and conditioned:
            continue
        if dest == "env":
            compare(flag, args.env, saved.env)
        elif dest in _ENV_FLAGS:
            option = saved.env_options.get(dest, envs.option_defaults(saved.env).get(dest))
            compare(flag, getattr(args, dest), option)
        elif dest == "n_prefs":
            grid = pareto.preference_lattice(m, args.n_prefs) if args.n_prefs > 0 else []
            same = [list(p) for p in saved.prefs] == [[float(x) for x in p] for p in grid]
            if not same:
                differ.append(f"{flag} {args.n_prefs} (it has {len(saved.prefs)} preferences)")
        elif dest == "prefs":
            if _parse_prefs(args.prefs) != saved.prefs:
                differ.append(f"{flag} {args.prefs!r} (it has other preferences)")
        elif dest in ("steps_per_pref", "total_steps"):
            compare(flag, getattr(args, dest), saved.steps_per_pref)
        elif dest in ("seed", "eval_episodes", "select_last", "select_every", "protocol"):
            compare(flag, getattr(args, dest), getattr(saved, dest))
        elif dest == "hv_ref":
            compare(flag, _parse_floats(args.hv_ref, flag), saved.hv_ref)
        elif dest in ("preset", "conditioned"):
            kind = "conditioned" if dest == "conditioned" else args.preset
            if kind != algos.kind(saved.train):
                differ.append(
                    f"{flag}{'' if dest == 'conditioned' else ' ' + kind} "
                    f"(it ran the {algos.kind(saved.train)} update)"
                )
    changes = _train_changes(args)
    if changes:
        asked = apply_config_flags(args, saved.train, f"the sweep in {args.out!r}")
        for name in changes:
            compare(
                _flag(FLAG_DESTS.get(name, name)), getattr(asked, name), getattr(saved.train, name)
            )
    if differ:
        more = f" and {len(differ) - 3} more" if len(differ) > 3 else ""
        raise SweepError(
            f"--resume: the sweep in {args.out!r} ran with other values than "
            f"{'; '.join(differ[:3])}{more}; --resume alone continues it"
        )
    if not conditioned:
        return saved
    if saved.protocol is not None:  # config.json records the training; the protocol its grid
        return dataclasses.replace(saved, prefs=protocol_prefs(saved.protocol, saved.env))
    if args.prefs is not None:
        prefs = _parse_prefs(args.prefs)
    else:  # the preferences the network is evaluated at: asked for, or the default's
        n = presets.CONDITIONED_EVAL_PREFS if args.eval_prefs is None else args.eval_prefs
        try:
            prefs = tuple(tuple(float(x) for x in p) for p in pareto.preference_lattice(m, n))
        except ValueError as err:
            raise SweepError(f"--eval-prefs: {err}") from None
    return dataclasses.replace(saved, prefs=prefs)


# ---------------------------------------------------------------- main


def use_every_core(engine: str | None = None) -> str:
    """Keeps every core busy; returns a line saying how. Unless the user set `XLA_FLAGS`,
    splits the host CPU into one XLA device per core (the preference axis is sharded over
    devices, so every core trains) — except with `engine="mujoco"`, whose C engine
    already steps on one thread per core: its host callback takes the whole batch on one
    device, and XLA warns at length about gathering a sharded batch for it. Only before JAX
    initialises its backend (the device count is fixed then)."""
    import jax
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


def _engine(args) -> str | None:
    """The engine the run will use, read without starting JAX (a resumed run's from its
    `config.json`)."""
    if args.resume and args.out:
        try:
            with open(os.path.join(args.out, "config.json")) as f:
                options = json.load(f).get("env_options", {})
            if "engine" in options:
                return options["engine"]
        except (OSError, ValueError, AttributeError):
            pass  # reported when the config is read
    engine = args.engine or dict(presets.env_defaults(args.env).env_options).get("engine")
    if engine is None and args.env in envs.names():  # an unknown --env is reported below
        engine = envs.option_defaults(args.env).get("engine")
    return engine


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
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(argv)
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_:
        if exit_.code:  # an error, said in one line
            return int(exit_.code)
        raise  # --help
    try:
        cluster = distributed.from_environment(
            args.coordinator, args.num_processes, args.process_id, args.coordinator_timeout
        )
    except distributed.DistributedError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    if every_core:
        note = use_every_core(_engine(args))
        if not args.quiet and not args.print_config:
            print(note, file=sys.stderr, flush=True)
    try:
        if cluster is not None:  # before anything touches JAX's devices
            distributed.initialize(cluster)
        if args.resume:
            if args.out is None:
                raise SweepError("--resume needs --out DIR")
            if args.overwrite:
                raise SweepError(
                    "--resume continues the sweep in --out and --overwrite replaces it: give one"
                )
            config = resume_config(args, _given(parser, argv))
        else:
            config = config_from_args(args)
        conditioned = isinstance(config.train, algos.ConditionedConfig)
        if args.print_config:
            return _print_config(config, conditioned)
        out = args.out or os.path.join("runs", time.strftime("%Y%m%d-%H%M%S"))
        front = (run_conditioned if conditioned else run_sweep)(
            config,
            out,
            resume=args.resume,
            overwrite=args.overwrite,
            chunks=args.chunks,
            progress=False if args.quiet else None,
        )
    except (SweepError, distributed.DistributedError) as err:
        print(f"error: {flagged(str(err))}", file=sys.stderr)
        return 2
    except TrainingDiverged as err:
        print(f"error: {err}", file=sys.stderr)
        return 3
    return _report(front, out, config, args.quiet)


def _print_config(config: SweepConfig, conditioned: bool) -> int:
    """Prints what the run's `config.json` will hold (`device_count` filled in as the run
    fills it; a conditioned run's is its training's, one row)."""
    import jax

    if config.device_count is None:
        config = dataclasses.replace(config, device_count=jax.device_count())
    if conditioned:
        print(
            f"note: the one network is then evaluated at {len(config.prefs)} preferences",
            file=sys.stderr,
        )
        config = training_sweep(config)
    sys.stdout.write(json_bytes(config.to_dict()).decode())
    return 0


def _report(front: dict, out: str, config: SweepConfig, quiet: bool) -> int:
    """The lines a finished run prints; 0."""
    import jax

    if front.get("interrupted"):
        if not quiet:
            print(f"{out} stopped after iteration {front['iterations_done']}: --resume continues")
        return 0
    if front.get("finished"):  # `--resume` of a finished sweep: nothing done, nothing written
        if not quiet:
            print(f"{out} is finished (its front.json is written): --resume has nothing to do")
        return 0
    if not distributed.is_writer():
        if not quiet:
            print(f"[process {jax.process_index()}] done; process 0 wrote {out}", file=sys.stderr)
        return 0
    if not quiet:
        print(
            f"wrote {out}: {len(front['prefs'])} preferences, hypervolume "
            f"{front['hypervolume']:.6g}, {front['env_steps_per_s']:,.0f} env-steps/s, "
            f"{front['wall_s']:.0f} s"
        )
        if "protocol" in front:
            score = front["protocol"]
            print(
                f"{score['protocol']} protocol ({score['task']}): HV {score['hv']:.4g}, "
                f"EU {score['eu']:.4g}, {score['nondominated']} non-dominated of "
                f"{score['eval_prefs']} preferences, {score['env_steps_trained']:,} env steps"
                + "".join(f"; NOT the protocol's: {d}" for d in score["deviations"])
            )
        if "selection" in front:
            chosen = front["selection"]["chosen_iteration"]
            print(
                f"chosen policies (iteration per preference, of {config.num_iterations}): {chosen}"
            )
    # a point on the box's boundary (an exact front's end, e.g.) adds no volume but is
    # not outside it
    ref = front["hv_ref"]
    outside = [
        i
        for i in front["outside_hv_ref"]
        if any(r < b for r, b in zip(front["prefs"][i]["return"], ref, strict=True))
    ]
    if outside:
        print(
            f"warning: {len(outside)} of {len(front['prefs'])} policies lie outside the "
            f"hypervolume reference box {_rounded(ref)} and add nothing to it: "
            + ", ".join(f"#{i} {_rounded(front['prefs'][i]['pref'])}" for i in outside),
            file=sys.stderr,
        )
    return 0


def _rounded(values) -> str:
    """`[0.1, 0.9]`: a vector written to 6 significant digits."""
    return "[" + ", ".join(f"{v:.6g}" for v in values) + "]"


if __name__ == "__main__":
    sys.exit(main(every_core=True))
