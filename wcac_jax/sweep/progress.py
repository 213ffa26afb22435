"""A sweep's progress on stderr: a tqdm bar on a terminal, plain lines in a log.

The host hears from the compiled training program only between its calls. On a terminal
the sweep sizes each call to about `UPDATE_SECONDS` of training (`Pace`), and the bar
moves after every call: env steps done, env-steps/s and the time left. Otherwise (stderr
a file or a pipe) the sweep calls the program once per chunk, as it checkpoints, and
writes one line per chunk:

    [sweep] 1,105,920/8,801,280 env steps, 11,032 env-steps/s, ETA 698 s

How the run is cut into calls changes no number (`training.make_chunk`: iterations past
a call's stop leave the state untouched).
"""

from __future__ import annotations

import sys

import numpy as np

from wcac_jax.sweep import distributed

UPDATE_SECONDS = 2.0  # the training between two moves of the bar


class Progress:
    """A sweep's progress report (only process 0 reports).

    Args:
      total: env steps of the whole sweep (every preference).
      done: env steps done before this run (a resumed sweep's).
      enabled: `False`: nothing; `None` or `True`: report.
      stream: where to (default `sys.stderr`); a terminal gets the bar.
    """

    def __init__(self, total: int, done: int = 0, enabled: bool | None = None, stream=None):
        self.stream = sys.stderr if stream is None else stream
        self.enabled = enabled is not False
        self.total, self.done = total, done
        self.bar = None
        self._steps, self._seconds = 0, 0.0  # since the last plain line
        if self.enabled and _isatty(self.stream):
            from tqdm import tqdm

            self.bar = tqdm(
                total=total,
                initial=done,
                file=self.stream,
                desc="sweep",
                unit=" env-steps",
                unit_scale=True,
                dynamic_ncols=True,
                bar_format="{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} env steps "
                "[{elapsed}<{remaining}, {rate_fmt}]",
            )

    @property
    def live(self) -> bool:
        """Whether the report moves within a chunk (the bar): worth cutting it into calls."""
        return self.bar is not None

    def advance(self, steps: int, seconds: float) -> None:
        """`steps` more env steps, trained in `seconds` (one call of the program)."""
        self.done += steps
        self._steps += steps
        self._seconds += seconds
        if self.bar is not None:
            self.bar.update(steps)

    def chunk_done(self) -> None:
        """A chunk is checkpointed: its plain line (its own env-steps/s, and the time
        left at that rate)."""
        if self.enabled and self.bar is None:
            rate = self._steps / max(self._seconds, 1e-9)
            eta = (self.total - self.done) / max(rate, 1e-9)
            print(
                f"[sweep] {self.done:,}/{self.total:,} env steps, {rate:,.0f} env-steps/s, "
                f"ETA {eta:,.0f} s",
                file=self.stream,
                flush=True,
            )
        self._steps, self._seconds = 0, 0.0

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


class Pace:
    """How many iterations each call of the training program runs: about `seconds` of
    training (at the last call's rate; one iteration before any call is timed), the
    same on every process (process 0's count)."""

    def __init__(self, seconds: float | None = None):
        self.seconds = UPDATE_SECONDS if seconds is None else seconds
        self.per_iteration = None  # seconds, measured

    def iterations(self, left: int) -> int:
        """The next call's iterations, `1..left`."""
        if self.per_iteration is None:
            n = 1
        else:
            n = int(self.seconds / max(self.per_iteration, 1e-9))
        return int(distributed.broadcast(np.asarray(max(1, min(n, left)), np.int32)))

    def record(self, iterations: int, seconds: float) -> None:
        self.per_iteration = seconds / iterations


def note(line: str, enabled: bool | None = True) -> None:
    """One line on stderr, unless `enabled` is `False`."""
    if enabled is not False:
        print(line, file=sys.stderr, flush=True)


def _isatty(stream) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):  # no such method, or a closed stream
        return False
