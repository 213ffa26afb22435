"""experiments/README.md indexes experiments/results/: one row per entry, no row for an
entry that is not there, and no path into the results that does not exist."""

import os
import re

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, "experiments", "results")
INDEX = os.path.join(ROOT, "experiments", "README.md")

# a table row whose first cell is one name in backticks: | `name` | ... |
ROW = re.compile(r"^\| `([^`|]+)` \|", re.MULTILINE)
# a path into the results anywhere in the index (commands' --out included)
PATH = re.compile(r"experiments/results/([A-Za-z0-9_.\-]+)")


def _entries() -> set[str]:
    return {name for name in os.listdir(RESULTS) if not name.startswith(".")}


def _index() -> str:
    with open(INDEX, encoding="utf-8") as f:
        return f.read()


def test_every_entry_has_exactly_one_row():
    rows = ROW.findall(_index())
    assert sorted(set(rows)) == sorted(rows), "an entry has more than one row"
    missing = _entries() - set(rows)
    assert not missing, f"entries of experiments/results/ without a row: {sorted(missing)}"


def test_every_row_names_an_entry_that_exists():
    stale = set(ROW.findall(_index())) - _entries()
    assert not stale, f"rows for entries not in experiments/results/: {sorted(stale)}"


def test_every_path_into_the_results_exists():
    """The index's commands and text name results by path: each path's first component
    (the entry; what follows may be a placeholder such as `seedS`) must exist."""
    named = set(PATH.findall(_index()))
    assert named, "the index names no path into experiments/results/"
    stale = named - _entries()
    assert not stale, f"paths into experiments/results/ that do not exist: {sorted(stale)}"


def test_the_parsers_see_what_a_reader_sees():
    # guards the patterns above: a row, a path, and what must not count as either
    text = (
        "| `a_seed` | `python x.py --out experiments/results/b/seedS` | c | current |\n"
        "| entry | command | backs | status |\n"
        "`experiments/results/` alone names no entry\n"
    )
    assert ROW.findall(text) == ["a_seed"]
    assert PATH.findall(text) == ["b"]
