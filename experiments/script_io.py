"""What every experiment script does at its edges, written once: a one-line exit for bad
input, the output directory a run writes to (refused when it holds results, continued on
`--resume`, replaced on `--overwrite` only once the new run has finished), and a result
file refused unless `--overwrite` replaces it.

Imported by the scripts beside it (their own directory is on the path when they run).
"""

from __future__ import annotations

import os
import sys


def fail(message, status: int = 2):
    """One `error:` line on stderr, then exit with `status` (2: bad input, 3: NaN)."""
    print(f"error: {message}", file=sys.stderr)
    raise SystemExit(status)


def refuse_existing(path: str, overwrite: bool, flag: str = "--out ") -> None:
    """Exit 2 with one line if the result file `path` exists and `overwrite` is not given:
    checked before any measurement, so an earlier result is never lost by accident."""
    if os.path.lexists(path) and not overwrite:
        fail(f"{flag}{path!r} exists (--overwrite replaces it)")


def make_out(
    out: str, resume: bool = False, overwrite: bool = False, resume_adds: bool = False
) -> str:
    """Creates the directory a run writes to and returns it: `out`, refusing a non-empty
    one unless `resume`; with `overwrite`, a fresh directory beside `out` that
    `finish_out` renames over it. With `resume_adds` (a run that adds parts to `out`)
    `resume` may start an empty `out`; otherwise it needs a run to continue. Refuses
    (exit 2, one line) before any training."""
    from wcac_jax.sweep.outputs import fresh_staging_dir  # (the library loads when it is needed)

    does = "adds to it" if resume_adds else "continues an interrupted run"
    if resume and overwrite:
        fail(f"--out {out!r}: --resume {does} and --overwrite replaces it: give one")
    if resume and not resume_adds:
        if not (os.path.isdir(out) and os.listdir(out)):
            fail(f"--resume: nothing to resume in --out {out!r}")
        return out
    if os.path.exists(out) and not os.path.isdir(out):
        fail(f"--out {out!r} exists and is not a directory")
    if overwrite:
        work, problem = fresh_staging_dir(out)
        if problem:
            fail(f"--overwrite: --out {out!r} can't be replaced ({problem})")
        return work
    if os.path.isdir(out) and os.listdir(out) and not resume:
        fail(f"--out {out!r} is not empty (--resume {does}, --overwrite replaces it)")
    os.makedirs(out, exist_ok=True)
    return out


def finish_out(work: str, out: str) -> None:
    """Puts the finished results in place: `work` (`make_out`'s) renamed over `out`."""
    from wcac_jax.sweep.outputs import replace_dir

    if os.path.abspath(work) != os.path.abspath(out):
        replace_dir(work, out)
