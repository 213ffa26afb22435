"""KuaiRand's three layouts (27K, 1K, Pure): the files each one holds, which layout a
directory is, and the checked reading of the columns the protocol uses.

The layouts differ in their file names only (the columns are the same):

- `27k`: the standard log of 04-08..04-21 split in `..._27k_part1.csv` and `_part2.csv`
  (each holding most users over the same dates), the later standard log (04-22..05-08,
  also in two parts), the random-exposure log, `user_features_27k.csv`,
  `video_features_basic_27k.csv` and the statistics in `video_features_statistic_27k_
  part1..3.csv`;
- `1k`, `pure`: one file per log and one statistics file, named `..._1k.csv` and
  `..._pure.csv`.

The protocol reads the first standard log file (27K: part1, the paper's 480,385 kept
rows), the user features, the basic video features and every statistics file.

Every value the protocol uses is checked where it is read, against KuaiRand's types and
ranges; the first bad one raises `DataError` with one line naming the file, the column
and an example data row (1-based, the header not counted).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
import pandas as pd

VERSIONS = ("27k", "1k", "pure")


class DataError(ValueError):
    """A KuaiRand file is missing or malformed; the message names the file and column."""


@dataclass(frozen=True)
class Layout:
    """The file names of one KuaiRand version.

    Attributes:
      version: one of `VERSIONS`.
      standard_logs: the 04-08..04-21 standard log, as its files split it; the protocol
        reads the first.
      other_logs: the later standard log and the random-exposure log (not read).
      user: the user features; video_basic: the basic video features.
      video_statistic: the statistics files (all read).
    """

    version: str
    standard_logs: tuple[str, ...]
    other_logs: tuple[str, ...]
    user: str
    video_basic: str
    video_statistic: tuple[str, ...]

    @property
    def name(self) -> str:
        return "KuaiRand-" + {"27k": "27K", "1k": "1K", "pure": "Pure"}[self.version]

    @property
    def log(self) -> str:
        return self.standard_logs[0]

    @property
    def files(self) -> tuple[str, ...]:
        return (
            *self.standard_logs,
            *self.other_logs,
            self.user,
            self.video_basic,
            *self.video_statistic,
        )


def _layout(version: str, parts: int, stat_parts: int) -> Layout:
    def split(stem: str, n: int) -> tuple[str, ...]:
        if n == 1:
            return (f"{stem}_{version}.csv",)
        return tuple(f"{stem}_{version}_part{k}.csv" for k in range(1, n + 1))

    return Layout(
        version=version,
        standard_logs=split("log_standard_4_08_to_4_21", parts),
        other_logs=(
            *split("log_standard_4_22_to_5_08", parts),
            f"log_random_4_22_to_5_08_{version}.csv",
        ),
        user=f"user_features_{version}.csv",
        video_basic=f"video_features_basic_{version}.csv",
        video_statistic=split("video_features_statistic", stat_parts),
    )


LAYOUTS = {
    "27k": _layout("27k", parts=2, stat_parts=3),
    "1k": _layout("1k", parts=1, stat_parts=1),
    "pure": _layout("pure", parts=1, stat_parts=1),
}


def detect(directory: str, version: str | None = None) -> Layout:
    """The layout of a KuaiRand directory: `version` if given, else the one layout whose
    file names it holds.

    Raises:
      DataError: not a directory, an unknown `version`, no KuaiRand file, or the files
        of more than one layout (then `version` must say which).
    """
    if not os.path.isdir(directory):
        raise DataError(f"{directory}: not a directory")
    if version is not None:
        if version not in LAYOUTS:
            raise DataError(f"unknown KuaiRand version {version!r}; valid: {', '.join(VERSIONS)}")
        return LAYOUTS[version]
    found = [
        v
        for v, layout in LAYOUTS.items()
        if any(os.path.isfile(os.path.join(directory, f)) for f in layout.files)
    ]
    if not found:
        names = " or ".join(LAYOUTS[v].log for v in VERSIONS)
        raise DataError(f"{directory}: no KuaiRand file (expected {names}, ...)")
    if len(found) > 1:
        names = " and ".join(LAYOUTS[v].name for v in found)
        raise DataError(f"{directory}: holds files of {names}; choose one with --version")
    return LAYOUTS[found[0]]


def path(directory: str, name: str) -> str:
    """`directory/name`, which must be a file."""
    p = os.path.join(directory, name)
    if not os.path.isfile(p):
        raise DataError(f"{p}: file not found (expected KuaiRand's {name})")
    return p


def read(p: str, columns, chunksize=None):
    """`pd.read_csv` of `columns` (or an iterator of chunks), with a missing column or an
    unreadable file raised as a `DataError` naming the file."""
    try:
        header = pd.read_csv(p, nrows=0).columns
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as err:
        raise DataError(f"{p}: not a readable CSV ({err})") from None
    missing = [c for c in columns if c not in header]
    if missing:
        raise DataError(f"{p}: missing column {missing[0]!r}")
    try:
        return pd.read_csv(p, usecols=list(columns), chunksize=chunksize, low_memory=False)
    except (pd.errors.ParserError, ValueError) as err:
        raise DataError(f"{p}: not a readable CSV ({err})") from None


def chunks(p: str, columns, chunksize: int):
    """The file's `columns` in chunks of `chunksize` rows; the chunks' index is the data
    row (0-based) across the whole file."""
    try:
        yield from read(p, columns, chunksize)
    except pd.errors.ParserError as err:
        raise DataError(f"{p}: not a readable CSV ({err})") from None


def _fail(p: str, column: str, problem: str, s: pd.Series, bad, show_value=True) -> None:
    """Raises the one-line `DataError` for the first row where `bad` holds."""
    i = np.flatnonzero(np.asarray(bad))[0]
    v = s.iloc[i]
    value = f" {v.item() if isinstance(v, np.generic) else v!r}" if show_value else ""
    raise DataError(f"{p}: column {column!r}: {problem}{value} (data row {s.index[i] + 1})")


def _as_numbers(s: pd.Series, p: str, column: str) -> pd.Series:
    if pd.api.types.is_numeric_dtype(s) and not pd.api.types.is_bool_dtype(s):
        return s.astype(np.float64) if pd.api.types.is_float_dtype(s) else s
    conv = pd.to_numeric(s, errors="coerce")
    bad = conv.isna() & s.notna()
    if bad.any():
        _fail(p, column, "non-numeric value", s, bad)
    return conv


def numbers(df: pd.DataFrame, column: str, p: str, allow_missing: bool) -> pd.Series:
    """The column as numbers; a non-numeric or (unless allowed) missing value is an error."""
    s = df[column]
    conv = _as_numbers(s, p, column)
    if not allow_missing and conv.isna().any():
        _fail(p, column, "missing value", s, conv.isna(), show_value=False)
    return conv


def _finite(conv: pd.Series, s: pd.Series, p: str, column: str) -> None:
    bad = np.isinf(conv.to_numpy(np.float64, na_value=np.nan))
    if bad.any():
        _fail(p, column, "non-finite value", s, bad)


def integers(
    df: pd.DataFrame, column: str, p: str, low: int | None = None, binary: bool = False
) -> pd.Series:
    """The column as KuaiRand's int64: a missing, non-numeric, non-finite or fractional
    value, a float column (e.g. `12.0` for an ID), a value below `low` or (if `binary`)
    outside {0, 1} is an error.

    Returns:
      the column, int64, with the frame's index.
    """
    s = df[column]
    conv = numbers(df, column, p, allow_missing=False)
    _finite(conv, s, p, column)
    if not pd.api.types.is_integer_dtype(conv):
        x = conv.to_numpy(np.float64)
        frac = x != np.round(x)
        _fail(p, column, "float value where KuaiRand has int64:", s, frac if frac.any() else [True])
    if binary and not conv.isin((0, 1)).all():
        _fail(p, column, "value outside {0, 1}:", s, ~conv.isin((0, 1)))
    if low is not None and (conv < low).any():
        _fail(p, column, f"value below {low}:", s, conv < low)
    return conv.astype(np.int64)


def features(df: pd.DataFrame, column: str, p: str) -> pd.Series:
    """The column as float64 numbers, missing values as NaN; a non-numeric or infinite
    value is an error."""
    s = df[column]
    conv = numbers(df, column, p, allow_missing=True)
    _finite(conv, s, p, column)
    return conv.astype(np.float64)


def not_all_missing(x: pd.Series, p: str, column: str, what: str) -> None:
    """An error if every value of `x` (a feature over the rows the protocol uses, indexed
    by data row) is missing: the column would carry nothing."""
    if len(x) and x.isna().all():
        raise DataError(
            f"{p}: column {column!r}: every value is missing for {what} "
            f"(data row {x.index[0] + 1}, ...)"
        )
