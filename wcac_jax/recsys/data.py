"""Reads a KuaiRand directory (the real 27K files or `synth`'s) and builds the offline
transitions of the benchmark protocol (RECSYS.md §2).

- rows: `log_standard_4_08_to_4_21_27k_part1.csv`, only the `n_candidates` (150) most
  viewed videos, in log order; the first `train_fraction` of them (450,000 of the
  480,385 rows in the real file) train, the rest test;
- action: the video's index among the candidates, ordered by views (0 = most viewed);
- state (`24 + 6 C + 6 H` = 1,044 dims, z-normalised over the training rows): the user's
  24 features (`USER_CATEGORICAL` label-encoded, `onehot_feat0..17`), the `C`
  candidates' 6 features (`VIDEO_FEATURES`), and the 6 features of the last `H` = 20
  videos this user viewed (zeros when fewer). The candidate block is the same in every
  state, so z-normalisation turns it into zeros: it is kept for the protocol's size;
- reward `[7]`: `is_click, is_like, is_follow, is_comment, is_forward, is_hate,
  play_time_ms / 10000`;
- an episode is one user's consecutive rows (`done` where the next row is another
  user's), with `gamma = 0.99` left to the learner.

The 6 label-encoded user features are our reading of "the 6 string/bucket features":
`user_active_degree`, `is_video_author` and the four `*_range` buckets. Missing feature
values (NaN, and `-124`) are filled with the column's training mean, i.e. 0 after
normalisation.

Bad input (a missing file or column, a non-numeric or missing value where the protocol
needs a number) raises `DataError` naming the file and column; on the command line
(`python -m wcac_jax.recsys.data DIR`) that is one `error:` line and exit status 2.
"""

from __future__ import annotations

import glob
import os
import sys
from dataclasses import dataclass

import chex
import jax.numpy as jnp
import numpy as np
import pandas as pd
from flax import struct

from wcac_jax.recsys.cli import ArgumentParser

LOG_FILE = "log_standard_4_08_to_4_21_27k_part1.csv"
USER_FILE = "user_features_27k.csv"
VIDEO_BASIC_FILE = "video_features_basic_27k.csv"
VIDEO_STATISTIC_GLOB = "video_features_statistic_27k_part*.csv"

REWARD_COLUMNS = (
    "is_click",
    "is_like",
    "is_follow",
    "is_comment",
    "is_forward",
    "is_hate",
    "play_time_ms",
)
SIGNALS = ("click", "like", "follow", "comment", "forward", "hate", "watch_time")
LOG_COLUMNS = ("user_id", "video_id", *REWARD_COLUMNS)
USER_CATEGORICAL = (
    "user_active_degree",
    "is_video_author",
    "follow_user_num_range",
    "fans_user_num_range",
    "friend_user_num_range",
    "register_days_range",
)
USER_ONEHOT = tuple(f"onehot_feat{j}" for j in range(18))
VIDEO_BASIC_COLUMNS = ("video_id", "video_duration", "music_type", "tag")
VIDEO_STAT_COLUMNS = ("video_id", "play_user_num", "play_duration", "like_cnt")
VIDEO_FEATURES = (
    "video_duration",
    "music_type",
    "tag",
    "play_user_num",
    "play_duration",
    "like_cnt",
)
PAPER_TRAIN_FRACTION = 450_000 / 480_385


class DataError(ValueError):
    """A KuaiRand file is missing or malformed; the message names the file and column."""


@dataclass(frozen=True)
class ProtocolConfig:
    """Sizes of the protocol.

    Attributes:
      n_candidates: `C`, the most viewed videos kept (150).
      history: `H`, previously viewed videos in the state (20).
      train_fraction: share of the kept rows, in log order, used for training.
      chunksize: rows per chunk when reading the (possibly huge) log.
    """

    n_candidates: int = 150
    history: int = 20
    train_fraction: float = PAPER_TRAIN_FRACTION
    chunksize: int = 2_000_000

    @property
    def state_dim(self) -> int:
        return len(USER_CATEGORICAL) + len(USER_ONEHOT) + 6 * (self.n_candidates + self.history)


@struct.dataclass
class Protocol:
    """The offline data set: per-row arrays and the tables states are built from.

    Per-row arrays (`n` rows in log order, `n_train` first ones for training):
      user_index: `[n]` row of `user_table`; action: `[n]` candidate index;
      reward: `[n, 7]` (`SIGNALS` order, raw: hate is a rate to be minimised);
      done: `[n]` 1 where the next row belongs to another user (or there is none);
      history: `[n, H]` candidate indices viewed before by the same user, most recent
        first, -1 where none.
    Tables:
      user_table: `[U, 24]` normalised user features; video_raw: `[C, 6]` raw candidate
      features; cand_state: `[6 C]` the state's (normalised) candidate block;
      hist_mean, hist_std: `[H, 6]` normalisation of the history block;
      action_features: `[C, 6]` candidate features z-normalised across candidates.
    """

    user_index: chex.Array
    action: chex.Array
    reward: chex.Array
    done: chex.Array
    history: chex.Array
    user_table: chex.Array
    video_raw: chex.Array
    cand_state: chex.Array
    hist_mean: chex.Array
    hist_std: chex.Array
    action_features: chex.Array
    n_train: int = struct.field(pytree_node=False)
    user_ids: np.ndarray = struct.field(pytree_node=False)
    video_ids: np.ndarray = struct.field(pytree_node=False)

    @property
    def n_rows(self) -> int:
        return int(self.action.shape[0])

    @property
    def n_candidates(self) -> int:
        return int(self.video_raw.shape[0])

    @property
    def state_dim(self) -> int:
        return int(self.user_table.shape[1] + self.cand_state.shape[0] + self.hist_mean.size)


def states(data: Protocol, rows: chex.Array) -> chex.Array:
    """The normalised states of some rows (pure, jittable).

    Args:
      data: the protocol's arrays.
      rows: `[B]` row indices.

    Returns:
      `[B, state_dim]` states: user block, candidate block, history block.
    """
    user = data.user_table[data.user_index[rows]]
    hist = data.history[rows]
    raw = jnp.where(hist[..., None] >= 0, data.video_raw[jnp.maximum(hist, 0)], 0.0)
    hist_block = ((raw - data.hist_mean) / data.hist_std).reshape(rows.shape[0], -1)
    cand = jnp.broadcast_to(data.cand_state, (rows.shape[0], data.cand_state.shape[0]))
    return jnp.concatenate([user, cand, hist_block], axis=-1)


def _path(directory: str, name: str) -> str:
    path = os.path.join(directory, name)
    if not os.path.isfile(path):
        raise DataError(f"{path}: file not found (expected KuaiRand's {name})")
    return path


def _read(path: str, columns, chunksize=None):
    """`pd.read_csv` of `columns` with errors turned into `DataError`s naming the file."""
    try:
        header = pd.read_csv(path, nrows=0).columns
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as err:
        raise DataError(f"{path}: not a readable CSV ({err})") from None
    missing = [c for c in columns if c not in header]
    if missing:
        raise DataError(f"{path}: missing column {missing[0]!r}")
    try:
        return pd.read_csv(path, usecols=list(columns), chunksize=chunksize, low_memory=False)
    except (pd.errors.ParserError, ValueError) as err:
        raise DataError(f"{path}: not a readable CSV ({err})") from None


def _numeric(df: pd.DataFrame, column: str, path: str, allow_missing: bool) -> pd.Series:
    """The column as numbers; a non-numeric (or, unless allowed, missing) value is an error."""
    s = df[column]
    if not pd.api.types.is_numeric_dtype(s):
        conv = pd.to_numeric(s, errors="coerce")
        bad = conv.isna() & s.notna()
        if bad.any():
            i = bad.idxmax()
            raise DataError(
                f"{path}: column {column!r}: non-numeric value {s[i]!r} (data row {i + 1})"
            )
        s = conv
    if not allow_missing and s.isna().any():
        i = s.isna().idxmax()
        raise DataError(f"{path}: column {column!r}: missing value (data row {i + 1})")
    return s


def _chunks(path, columns, chunksize):
    try:
        yield from _read(path, columns, chunksize)
    except pd.errors.ParserError as err:
        raise DataError(f"{path}: not a readable CSV ({err})") from None


def read_log(path: str, chunksize: int = 2_000_000, keep_videos=None) -> pd.DataFrame:
    """Reads a KuaiRand log's `LOG_COLUMNS` (validated integers/numbers), optionally only
    the rows whose `video_id` is in `keep_videos`. Rows stay in log order."""
    parts = []
    for chunk in _chunks(path, LOG_COLUMNS, chunksize):
        for col in LOG_COLUMNS:
            chunk[col] = _numeric(chunk, col, path, allow_missing=False)
        if keep_videos is not None:
            chunk = chunk[chunk["video_id"].isin(keep_videos)]
        parts.append(chunk)
    if not parts:
        raise DataError(f"{path}: no rows")
    return pd.concat(parts, ignore_index=True)


def _top_videos(path: str, n: int, chunksize: int) -> np.ndarray:
    counts = None
    for chunk in _chunks(path, ("video_id",), chunksize):
        c = _numeric(chunk, "video_id", path, allow_missing=False).value_counts()
        counts = c if counts is None else counts.add(c, fill_value=0)
    if counts is None or len(counts) == 0:
        raise DataError(f"{path}: no rows")
    if len(counts) < n:
        raise DataError(f"{path}: column 'video_id': only {len(counts)} videos, need {n}")
    # most viewed first; ties by video_id
    order = np.lexsort((counts.index.to_numpy(), -counts.to_numpy()))
    return counts.index.to_numpy()[order[:n]].astype(np.int64)


def _user_table(directory: str, user_ids: np.ndarray) -> np.ndarray:
    path = _path(directory, USER_FILE)
    df = _read(path, ("user_id", *USER_CATEGORICAL, *USER_ONEHOT))
    df["user_id"] = _numeric(df, "user_id", path, allow_missing=False)
    df = df.drop_duplicates("user_id").set_index("user_id")
    missing = np.setdiff1d(user_ids, df.index.to_numpy())
    if missing.size:
        raise DataError(f"{path}: column 'user_id': no row for user {missing[0]} of the log")
    df = df.loc[user_ids]
    cols = []
    for col in USER_CATEGORICAL:  # label-encoded; the missing value is a label of its own
        cols.append(pd.factorize(df[col].astype(str), sort=True)[0].astype(np.float64))
    for col in USER_ONEHOT:
        x = _numeric(df, col, path, allow_missing=True).to_numpy(np.float64, copy=True)
        x[x == -124] = np.nan
        cols.append(x)
    return np.stack(cols, axis=1)


def _video_table(directory: str, video_ids: np.ndarray) -> np.ndarray:
    path = _path(directory, VIDEO_BASIC_FILE)
    basic = pd.concat(
        [c[c["video_id"].isin(video_ids)] for c in _chunks(path, VIDEO_BASIC_COLUMNS, 2_000_000)]
    )
    basic["video_id"] = _numeric(basic, "video_id", path, allow_missing=False)
    for col in ("video_duration", "music_type"):
        basic[col] = _numeric(basic, col, path, allow_missing=True)
    first_tag = basic["tag"].astype("string").str.split(",").str[0].str.strip()
    basic["tag"] = _numeric(pd.DataFrame({"tag": first_tag}), "tag", path, allow_missing=True)
    basic = basic.drop_duplicates("video_id").set_index("video_id")

    paths = sorted(glob.glob(os.path.join(directory, VIDEO_STATISTIC_GLOB)))
    if not paths:
        raise DataError(
            f"{os.path.join(directory, VIDEO_STATISTIC_GLOB)}: file not found "
            "(expected KuaiRand's video statistics)"
        )
    stats = []
    for p in paths:
        for chunk in _chunks(p, VIDEO_STAT_COLUMNS, 2_000_000):
            chunk["video_id"] = _numeric(chunk, "video_id", p, allow_missing=False)
            chunk = chunk[chunk["video_id"].isin(video_ids)].copy()
            for col in VIDEO_STAT_COLUMNS[1:]:
                chunk[col] = _numeric(chunk, col, p, allow_missing=True)
            stats.append(chunk)
    stat = pd.concat(stats).drop_duplicates("video_id").set_index("video_id")
    table = pd.concat([basic.reindex(video_ids), stat.reindex(video_ids)], axis=1)
    x = table[list(VIDEO_FEATURES)].to_numpy(np.float64)
    return np.where(np.isnan(x), np.nanmean(x, axis=0), x)


def _zscore_stats(x: np.ndarray, axis=0):
    mean = np.nanmean(x, axis=axis)
    mean = np.where(np.isnan(mean), 0.0, mean)
    x = np.where(np.isnan(x), mean, x)
    std = x.std(axis=axis)
    return mean, np.where(std > 1e-12, std, 1.0)


def _histories(user_index: np.ndarray, action: np.ndarray, h: int) -> np.ndarray:
    n = user_index.shape[0]
    i = np.arange(n)
    start = np.r_[True, user_index[1:] != user_index[:-1]]
    run_start = np.maximum.accumulate(np.where(start, i, 0))
    pos = i - run_start
    j = np.arange(h)
    src = i[:, None] - 1 - j[None, :]
    return np.where(j[None, :] < pos[:, None], action[np.maximum(src, 0)], -1).astype(np.int32)


def load(directory: str, config: ProtocolConfig = ProtocolConfig()) -> Protocol:
    """Reads a KuaiRand directory and builds the protocol's offline transitions.

    Raises:
      DataError: a file or column is missing, or a value is malformed.
    """
    if not os.path.isdir(directory):
        raise DataError(f"{directory}: not a directory")
    log_path = _path(directory, LOG_FILE)
    candidates = _top_videos(log_path, config.n_candidates, config.chunksize)
    log = read_log(log_path, config.chunksize, keep_videos=candidates)
    n = len(log)
    n_train = int(round(n * config.train_fraction))
    if not 0 < n_train < n:
        raise DataError(f"{log_path}: {n} kept rows cannot be split {config.train_fraction:.4f}")

    user_ids, user_index = np.unique(log["user_id"].to_numpy(np.int64), return_inverse=True)
    action = pd.Index(candidates).get_indexer(log["video_id"].to_numpy(np.int64))
    reward = log[list(REWARD_COLUMNS)].to_numpy(np.float64)
    reward[:, -1] /= 10_000.0
    done = np.r_[user_index[1:] != user_index[:-1], True].astype(np.float32)
    history = _histories(user_index, action, config.history)

    user_raw = _user_table(directory, user_ids)
    u_mean, u_std = _zscore_stats(user_raw[user_index[:n_train]])
    user_raw = np.where(np.isnan(user_raw), u_mean, user_raw)
    video_raw = _video_table(directory, candidates)
    cand_mean, cand_std = _zscore_stats(video_raw)
    hist_train = history[:n_train]
    hist_raw = np.where(hist_train[..., None] >= 0, video_raw[np.maximum(hist_train, 0)], 0.0)
    h_mean, h_std = _zscore_stats(hist_raw)
    # the candidate block is one constant vector: its training z-score is 0 everywhere
    cand_flat = video_raw.reshape(-1)
    cand_state = np.zeros_like(cand_flat)
    f32 = lambda x: jnp.asarray(x, jnp.float32)
    return Protocol(
        user_index=jnp.asarray(user_index, jnp.int32),
        action=jnp.asarray(action, jnp.int32),
        reward=f32(reward),
        done=f32(done),
        history=jnp.asarray(history),
        user_table=f32((user_raw - u_mean) / u_std),
        video_raw=f32(video_raw),
        cand_state=f32(cand_state),
        hist_mean=f32(h_mean),
        hist_std=f32(h_std),
        action_features=f32((video_raw - cand_mean) / cand_std),
        n_train=n_train,
        user_ids=user_ids,
        video_ids=candidates,
    )


def main(argv=None) -> int:
    parser = ArgumentParser(
        prog="python -m wcac_jax.recsys.data",
        description="Check a KuaiRand directory and summarise the protocol's transitions.",
    )
    parser.add_argument("directory")
    args = parser.parse_args(argv)
    try:
        data = load(args.directory)
    except DataError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    test = np.asarray(data.reward[data.n_train :]).mean(axis=0)
    print(
        f"{data.n_rows} rows ({data.n_train} train), {len(data.user_ids)} users, "
        f"{data.n_candidates} candidates, state {data.state_dim} dims"
    )
    print("test means: " + ", ".join(f"{s} {v:.5g}" for s, v in zip(SIGNALS, test, strict=True)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
