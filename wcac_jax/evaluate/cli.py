"""`python -m wcac_jax.evaluate RUN --in mo-gymnasium`: a finished run's reported policies
re-run in MO-Gymnasium's own v5 environment with numpy inference
(`wcac_jax.evaluate.reference`), written beside the project's evaluation.

The host side: arguments, refusals (one line, exit status 2, nothing written), the
progress bar, the clock and the result file.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import os
import sys
import time

from wcac_jax.sweep.outputs import json_bytes, library_versions, write_atomic

INSTALL = (
    "mo-gymnasium is not installed; install it with: pip install 'wcac_jax[mo-gymnasium]' "
    "(or pip install 'mo-gymnasium>=1.3' 'gymnasium[mujoco]>=1.0')"
)
REFERENCES = ("mo-gymnasium",)


class _UsageError(ValueError):
    pass


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        """A usage error, for `main` to print as one line (exit status 2)."""
        raise _UsageError(f"{message} (see --help)")


def parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="python -m wcac_jax.evaluate",
        description=(
            "Re-run a finished run's reported policies (each preference's policy of a sweep, "
            "or the conditioned network at the front's preferences; a --protocol run at the "
            "protocol's preferences, episodes and discount) in MO-Gymnasium's own v5 "
            "environment, with the policies' mean actions computed in numpy, and write that "
            "evaluation beside the project's: per preference the mean undiscounted and "
            "discounted returns, their standard deviations over the episodes, the episode "
            "lengths, the project's numbers, and how far apart the two are in standard errors."
        ),
    )
    p.add_argument("run", metavar="RUN", help="the run's output directory (--out of the sweep)")
    p.add_argument(
        "--in",
        dest="reference",
        required=True,
        choices=REFERENCES,
        help="the reference implementation to evaluate in",
    )
    p.add_argument(
        "--episodes",
        type=int,
        default=None,
        help="episodes per preference (default: the run's evaluation episodes)",
    )
    p.add_argument(
        "--project-episodes",
        type=int,
        default=None,
        help="re-run the project's own evaluation with this many fresh episodes per "
        "preference, instead of reading the run's (front.json's): both sides' means then "
        "carry little noise",
    )
    p.add_argument(
        "--prefs",
        default=None,
        help="preferences to evaluate, e.g. '1,0;0.5,0.5' (default: the run's; a sweep of one "
        "policy per preference has policies at its own preferences only)",
    )
    p.add_argument(
        "--seed", type=int, default=0, help="episode k resets with seed SEED + k (default 0)"
    )
    p.add_argument(
        "--out",
        default=None,
        help="the result file (default: RUN/evaluation_mo_gymnasium.json)",
    )
    p.add_argument("--overwrite", action="store_true", help="replace an existing result file")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return p


def _parse_prefs(text: str) -> list[list[float]]:
    try:
        return [[float(x) for x in part.split(",")] for part in text.split(";") if part.strip()]
    except ValueError:
        raise ValueError(
            f"--prefs {text!r} is not a ';'-separated list of ','-separated numbers"
        ) from None


def _refusal(args) -> str | None:
    """Why the command may not run (one line), before anything is loaded; or `None`."""
    for flag, value in (
        ("--episodes", args.episodes),
        ("--project-episodes", args.project_episodes),
    ):
        if value is not None and value < 1:
            return f"{flag} must be at least 1, got {value}"
    if not os.path.isdir(args.run):
        return f"no run in {args.run!r} (no such directory)"
    if os.path.exists(args.out) and not args.overwrite:
        return f"{args.out!r} exists (--overwrite replaces it)"
    if os.path.isdir(args.out):
        return f"--out {args.out!r} is a directory"
    return None


def _mo_gymnasium_installed() -> bool:
    try:
        import mo_gymnasium  # noqa: F401
    except ImportError:
        return False
    return True


def _progress(enabled: bool):
    if not enabled:
        return lambda it: it
    from tqdm import tqdm

    return lambda it: tqdm(it, desc="preferences", unit="pref", leave=False)


def main(argv=None) -> int:
    try:
        args = parser().parse_args(argv)
    except _UsageError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    args.out = args.out or os.path.join(args.run, "evaluation_mo_gymnasium.json")
    refusal = _refusal(args)
    if refusal is None and not _mo_gymnasium_installed():
        refusal = INSTALL
    if refusal is not None:
        print(f"error: {refusal}", file=sys.stderr)
        return 2
    from wcac_jax.evaluate import reference

    t0 = time.perf_counter()
    try:
        prefs = None if args.prefs is None else _parse_prefs(args.prefs)
        target = reference.load_target(args.run, prefs, args.project_episodes)
        make_env = reference.make_reference_env(target)
    except ValueError as err:  # EvaluationError, a bad --prefs
        print(f"error: {err}", file=sys.stderr)
        return 2
    show = not args.quiet and sys.stderr.isatty()
    result = reference.evaluate(target, make_env, args.episodes, args.seed, _progress(show))
    result["versions"] = {
        **library_versions(),
        **{name: _version(name) for name in ("mo-gymnasium", "gymnasium")},
    }
    result["wall_s"] = time.perf_counter() - t0
    write_atomic(args.out, json_bytes(result))
    print(_summary(result, args.out))
    return 0


def _version(name: str) -> str | None:
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return None


def _summary(result: dict, out: str) -> str:
    """One line: what ran and how far apart the two evaluations are."""
    largest = result["agreement"]["return"]["largest_difference"]
    n = len(result["prefs"])
    z = largest["z"]
    apart = "" if z is None else f" ({abs(z):.1f} standard errors)"
    return (
        f"wrote {out}: {n} preference{'s' * (n != 1)} x {result['episodes']} episodes in "
        f"{result['mo_gymnasium_id']}; largest difference of mean returns from the project's "
        f"{largest['difference']:+.4g} at {largest['pref']}{apart}"
    )
