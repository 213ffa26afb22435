"""`wcac_jax.sweep.progress`: plain lines in a log, a tqdm bar on a terminal, and the
pace of the program's calls."""

import io
import re

import pytest

from wcac_jax.sweep import progress


class Terminal(io.StringIO):
    def isatty(self):
        return True


LINE = re.compile(r"\[sweep\] ([\d,]+)/([\d,]+) env steps, ([\d,]+) env-steps/s, ETA ([\d,]+) s")


def _lines(text):
    return [tuple(int(g.replace(",", "")) for g in LINE.fullmatch(line).groups()) for line in text]


def test_plain_lines_one_per_chunk_with_its_own_rate():
    log = io.StringIO()
    report = progress.Progress(total=12_000, done=2_000, stream=log)
    assert not report.live
    report.advance(1_000, 0.5)
    report.advance(3_000, 1.5)  # one chunk of two calls: 4,000 steps in 2 s
    assert log.getvalue() == ""  # nothing between checkpoints
    report.chunk_done()
    report.advance(6_000, 1.0)
    report.chunk_done()
    report.close()
    lines = log.getvalue().splitlines()
    assert lines[0] == "[sweep] 6,000/12,000 env steps, 2,000 env-steps/s, ETA 3 s"
    assert _lines(lines) == [(6_000, 12_000, 2_000, 3), (12_000, 12_000, 6_000, 0)]


def test_disabled_reports_nothing():
    for stream in (io.StringIO(), Terminal()):
        report = progress.Progress(total=100, enabled=False, stream=stream)
        report.advance(100, 1.0)
        report.chunk_done()
        report.close()
        assert stream.getvalue() == "" and not report.live


def test_a_terminal_gets_a_bar_of_env_steps_rate_and_time_left():
    term = Terminal()
    report = progress.Progress(total=10_000, done=2_000, stream=term)
    assert report.live
    report.advance(4_000, 1.0)
    report.chunk_done()  # no plain line under a bar
    report.close()
    text = term.getvalue()
    assert "[sweep]" not in text
    last = text.replace("\r", "\n").strip().splitlines()[-1]
    # a resumed sweep's bar starts at the steps done before (not counted in its rate)
    assert re.search(r"sweep:\s+60%\|.*\| 6\.00k/10\.0k env steps \[[\d:]+<[\d:?]+, ", last), last
    assert last.endswith(" env-steps/s]"), last


@pytest.mark.parametrize(
    "per_iteration,left,expected",
    [(None, 50, 1), (0.5, 50, 4), (0.5, 3, 3), (10.0, 50, 1), (1e-6, 7, 7)],
)
def test_pace_is_a_few_seconds_of_iterations(per_iteration, left, expected):
    pace = progress.Pace(seconds=2.0)
    if per_iteration is not None:
        pace.record(3, 3 * per_iteration)
    assert pace.iterations(left) == expected
