"""Reads a KuaiRand directory (real files of any of KuaiRand's three layouts, or
`synth`'s) and builds the offline transitions of the benchmark protocol (docs/recsys.md,
"Protocol").

- rows: the layout's first 04-08..04-21 standard log (`kuairand.Layout.log`; on
  KuaiRand-27K `log_standard_4_08_to_4_21_27k_part1.csv`), only the `n_candidates`
  (150) most viewed videos, ordered by user and by `time_ms` within a user (the real
  logs interleave users in time order; users keep the order of their first row, equal
  times their file order, so a log already grouped that way is not reordered); the
  first `train_fraction` of them (450,000 of the 480,385 rows of the real 27K file)
  train, the rest test;
- action: the video's index among the candidates, ordered by views (0 = most viewed);
- state (`24 + 6 C + 6 H` = 1,044 dims, z-normalised over the training rows): the user's
  24 features (`USER_CATEGORICAL` label-encoded, `onehot_feat0..17`), the `C`
  candidates' 6 features (`VIDEO_FEATURES`), and the 6 features of the last `H` = 20
  videos this user viewed (zeros when fewer). The candidate block is the same in every
  state, so z-normalisation turns it into zeros: it is kept for the protocol's size;
- reward `[7]`: `is_click, is_like, is_follow, is_comment, is_forward, is_hate,
  play_time_ms / 10000`;
- an episode is one user's rows (`done` where the next row is another user's), with
  `gamma = 0.99` left to the learner.

That is the default protocol. `load(..., protocol="tscac")` (`--protocol tscac`) builds
the same arrays as the public KuaiRand-27K pipeline does instead: rows in file order
(episodes end where consecutive rows change user), `is_live_streamer` in place of
`friend_user_num_range`, the history ring that holds the current video, missing values 0,
each split normalised by its own rows (`for_test_rows`), the behaviour model fitted on the
test rows (`Protocol.behaviour_rows`); docs/recsys.md lists every difference.

The 6 label-encoded user features are our reading of "the 6 string/bucket features":
`user_active_degree`, `is_video_author` and the four `*_range` buckets. Missing feature
values (empty or NaN, and `-124`) are filled with the column's training mean, i.e. 0
after normalisation.

Bad input is rejected, never passed on (`kuairand`'s checks): a missing file or column;
in the log, a missing, non-numeric, infinite or float value (KuaiRand's log columns are
int64: a `video_id` written `12.5` or `12.0` is named as a float), a signal outside
{0, 1}, a negative id, `time_ms` or `play_time_ms`; in the features the protocol uses,
a non-numeric or infinite value, or a column with no value at all for the log's users
or the candidate videos. Each raises `DataError` with one line naming the file, the
column and an example data row; on the command line (`python -m wcac_jax.recsys.data
DIR`) that is one `error:` line and exit status 2.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import chex
import jax.numpy as jnp
import numpy as np
import pandas as pd
from flax import struct

from wcac_jax.recsys import kuairand
from wcac_jax.recsys.cli import ArgumentParser
from wcac_jax.recsys.kuairand import DataError, Layout

# KuaiRand-27K's names, for callers that know the layout
LOG_FILE = kuairand.LAYOUTS["27k"].log
USER_FILE = kuairand.LAYOUTS["27k"].user
VIDEO_BASIC_FILE = kuairand.LAYOUTS["27k"].video_basic

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
LOG_COLUMNS = ("user_id", "video_id", "time_ms", *REWARD_COLUMNS)
USER_CATEGORICAL = (
    "user_active_degree",
    "is_video_author",
    "follow_user_num_range",
    "fans_user_num_range",
    "friend_user_num_range",
    "register_days_range",
)
USER_ONEHOT = tuple(f"onehot_feat{j}" for j in range(18))
# the public KuaiRand-27K pipeline's six label-encoded user features (`--protocol tscac`)
USER_CATEGORICAL_TSCAC = (
    "user_active_degree",
    "is_live_streamer",
    "is_video_author",
    "follow_user_num_range",
    "fans_user_num_range",
    "register_days_range",
)
PROTOCOLS = ("default", "tscac")
TSCAC_STD_EPS = 1e-3  # added to every standard deviation there
TSCAC_MUSIC_TYPE_FILL = 2.0  # its value for a missing music_type
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

    def __post_init__(self):
        if self.n_candidates < 2:
            raise ValueError(f"--candidates must be >= 2, got {self.n_candidates}")
        if self.history < 0:
            raise ValueError(f"--history must be >= 0, got {self.history}")
        if not 0.0 < self.train_fraction < 1.0:
            raise ValueError(f"train_fraction must be in (0, 1), got {self.train_fraction}")

    @property
    def state_dim(self) -> int:
        return len(USER_CATEGORICAL) + len(USER_ONEHOT) + 6 * (self.n_candidates + self.history)


@struct.dataclass
class Protocol:
    """The offline data set: per-row arrays and the tables states are built from.

    Per-row arrays (`n` rows, each user's consecutive and in time order, `n_train`
    first ones for training):
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
    Ids (host numpy arrays, int64): user_ids `[U]` of `user_table`'s rows; video_ids
      `[C]` of the candidates, most viewed first.
    log_row: `[n]` int32, each row's data row (0-based) in the log file, or None.
    The test split's normalisation (`for_test_rows`), None where it is the training one
    (the default protocol): test_user_table `[U, 24]`, test_hist_mean, test_hist_std
    `[H, 6]`.
    protocol: `"default"` or `"tscac"` (`load`).
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
    # leaves, not static fields: jit compares static fields with `==` when it meets a
    # second Protocol, which arrays cannot answer (a second run in one process failed)
    user_ids: np.ndarray
    video_ids: np.ndarray
    log_row: chex.Array | None = None
    test_user_table: chex.Array | None = None
    test_hist_mean: chex.Array | None = None
    test_hist_std: chex.Array | None = None
    protocol: str = struct.field(pytree_node=False, default="default")

    @property
    def n_rows(self) -> int:
        return int(self.action.shape[0])

    @property
    def n_candidates(self) -> int:
        return int(self.video_raw.shape[0])

    @property
    def state_dim(self) -> int:
        return int(self.user_table.shape[1] + self.cand_state.shape[0] + self.hist_mean.size)

    @property
    def n_episodes(self) -> int:
        return int(np.asarray(self.done).sum())

    @property
    def behaviour_rows(self) -> tuple[int, int]:
        """`(start, stop)`: the rows the behaviour model (Behavior-Clone) is fitted on:
        the training rows, or under `protocol="tscac"` the test rows, as there."""
        if self.protocol == "tscac":
            return self.n_train, self.n_rows
        return 0, self.n_train


def for_test_rows(data: Protocol) -> Protocol:
    """The protocol with the test split's normalisation of the user and history blocks,
    for computing states of test rows (the same `data` unless `protocol="tscac"`,
    which normalises each split by its own rows)."""
    if data.test_user_table is None:
        return data
    return data.replace(
        user_table=data.test_user_table,
        hist_mean=data.test_hist_mean,
        hist_std=data.test_hist_std,
    )


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


def read_log(path: str, chunksize: int = 2_000_000, keep_videos=None) -> pd.DataFrame:
    """Reads a KuaiRand log's `LOG_COLUMNS` (checked numbers), optionally only the rows
    whose `video_id` is in `keep_videos`. Rows stay in file order; the index is the row's
    data row in the file (0-based)."""
    parts = []
    for chunk in kuairand.chunks(path, LOG_COLUMNS, chunksize):
        for col in LOG_COLUMNS:
            binary = col.startswith("is_")
            low = None if binary else 0
            chunk[col] = kuairand.integers(chunk, col, path, low=low, binary=binary)
        if keep_videos is not None:
            chunk = chunk[chunk["video_id"].isin(keep_videos)]
        parts.append(chunk)
    if not parts:
        raise DataError(f"{path}: no rows")
    return pd.concat(parts)


def by_user_in_time(user_id: np.ndarray, time_ms: np.ndarray) -> np.ndarray:
    """The row order that makes each user's rows consecutive and in time order.

    Users keep the order of their first row; rows with equal times keep their file
    order, so a log already grouped by user and in time order within each user is left
    as it is. (KuaiRand's logs interleave users in time order.)

    Args:
      user_id: `[n]`; time_ms: `[n]`.

    Returns:
      `[n]` row indices.
    """
    first_seen = pd.factorize(user_id)[0]
    return np.lexsort((np.arange(user_id.shape[0]), time_ms, first_seen))


def _top_videos(path: str, n: int, chunksize: int, protocol: str = "default") -> np.ndarray:
    counts = None
    for chunk in kuairand.chunks(path, ("video_id",), chunksize):
        c = kuairand.integers(chunk, "video_id", path, low=0).value_counts()
        counts = c if counts is None else counts.add(c, fill_value=0)
    if counts is None or len(counts) == 0:
        raise DataError(f"{path}: no rows")
    if len(counts) < n:
        raise DataError(f"{path}: column 'video_id': only {len(counts)} videos, need {n}")
    if protocol == "tscac":
        # as there: numpy's default argsort of the counts in video_id order, reversed
        counts = counts.sort_index()
        order = np.argsort(counts.to_numpy())[::-1]
    else:  # most viewed first; ties by video_id
        order = np.lexsort((counts.index.to_numpy(), -counts.to_numpy()))
    return counts.index.to_numpy()[order[:n]].astype(np.int64)


def _user_frame(directory: str, layout: Layout, user_ids: np.ndarray, categorical):
    """The user features' rows of the log's users, in `user_ids` order (the index is the
    data row), and the file's path."""
    path = kuairand.path(directory, layout.user)
    df = kuairand.read(path, ("user_id", *categorical, *USER_ONEHOT))
    df["user_id"] = kuairand.integers(df, "user_id", path, low=0)
    df = df.drop_duplicates("user_id")
    pos = pd.Index(df["user_id"]).get_indexer(user_ids)
    if (pos < 0).any():
        missing = user_ids[np.argmax(pos < 0)]
        raise DataError(f"{path}: column 'user_id': no row for user {missing} of the log")
    df = df.iloc[pos]
    for col in categorical:
        kuairand.not_all_missing(df[col], path, col, "the log's users")
    return df, path


def _onehot(df: pd.DataFrame, path: str, minus_124_missing: bool) -> list[np.ndarray]:
    cols = []
    for col in USER_ONEHOT:
        x = kuairand.features(df, col, path)
        if minus_124_missing:
            x[x == -124] = np.nan
        kuairand.not_all_missing(x, path, col, "the log's users")
        cols.append(x.to_numpy(np.float64, copy=True))
    return cols


def _user_table(directory: str, layout: Layout, user_ids: np.ndarray) -> np.ndarray:
    df, path = _user_frame(directory, layout, user_ids, USER_CATEGORICAL)
    # label-encoded in sorted order; the missing value is a label of its own
    cols = [
        pd.factorize(df[col].astype(str), sort=True)[0].astype(np.float64)
        for col in USER_CATEGORICAL
    ]
    return np.stack(cols + _onehot(df, path, minus_124_missing=True), axis=1)


def _user_table_tscac(
    directory: str, layout: Layout, user_ids: np.ndarray, user_index: np.ndarray
) -> np.ndarray:
    """`[U, 24]` as the public pipeline builds it: `USER_CATEGORICAL_TSCAC` each coded
    by the rank of its value's frequency over the log's rows (the most frequent 0), the
    onehot features as they are (-124 included); missing values NaN."""
    df, path = _user_frame(directory, layout, user_ids, USER_CATEGORICAL_TSCAC)
    cols = []
    for col in USER_CATEGORICAL_TSCAC:
        per_row = df[col].iloc[user_index].reset_index(drop=True)
        counts = per_row.value_counts()
        code = dict(zip(counts.index, range(len(counts)), strict=True))
        cols.append(df[col].map(code).to_numpy(np.float64))
    return np.stack(cols + _onehot(df, path, minus_124_missing=False), axis=1)


def _candidate_rows(frames, path: str, video_ids: np.ndarray) -> pd.DataFrame:
    """The rows of the candidate videos (first row per video), indexed by data row."""
    rows = pd.concat(frames).drop_duplicates("video_id")
    if not len(rows):
        raise DataError(
            f"{path}: column 'video_id': no row for any of the {len(video_ids)} candidate "
            f"videos (e.g. video {video_ids[0]})"
        )
    return rows


def _video_table(directory: str, layout: Layout, video_ids: np.ndarray) -> np.ndarray:
    path = kuairand.path(directory, layout.video_basic)
    what = "the candidate videos"
    frames = []
    for chunk in kuairand.chunks(path, VIDEO_BASIC_COLUMNS, 2_000_000):
        chunk["video_id"] = kuairand.integers(chunk, "video_id", path, low=0)
        frames.append(chunk[chunk["video_id"].isin(video_ids)])
    basic = _candidate_rows(frames, path, video_ids)
    for col in ("video_duration", "music_type"):
        basic[col] = kuairand.features(basic, col, path)
    first_tag = basic["tag"].astype("string").str.split(",").str[0].str.strip()
    basic["tag"] = kuairand.features(pd.DataFrame({"tag": first_tag}), "tag", path)
    for col in VIDEO_BASIC_COLUMNS[1:]:
        kuairand.not_all_missing(basic[col], path, col, what)
    basic = basic.set_index("video_id")

    paths = [kuairand.path(directory, name) for name in layout.video_statistic]
    stats = []
    for part, p in enumerate(paths):
        for chunk in kuairand.chunks(p, VIDEO_STAT_COLUMNS, 2_000_000):
            chunk["video_id"] = kuairand.integers(chunk, "video_id", p, low=0)
            chunk = chunk[chunk["video_id"].isin(video_ids)].copy()
            for col in VIDEO_STAT_COLUMNS[1:]:
                chunk[col] = kuairand.features(chunk, col, p)
            chunk["part"] = part
            stats.append(chunk)
    stat = _candidate_rows(stats, " and ".join(paths), video_ids)
    for col in VIDEO_STAT_COLUMNS[1:]:
        kuairand.not_all_missing(stat[col], paths[stat["part"].iloc[0]], col, what)
    stat = stat.set_index("video_id")
    table = pd.concat([basic.reindex(video_ids), stat.reindex(video_ids)], axis=1)
    return table[list(VIDEO_FEATURES)].to_numpy(np.float64)  # NaN where missing


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


def _ring_histories(user_index: np.ndarray, action: np.ndarray, h: int) -> np.ndarray:
    """`[n, H]` the public pipeline's history block: a ring of `H` slots per run of one
    user's consecutive rows, the row's own video written first (slot `pos mod H`, `pos`
    the row's place in the run), so each slot holds the latest video of its residue and
    the current one is among them; -1 where none yet."""
    n = user_index.shape[0]
    i = np.arange(n)
    start = np.r_[True, user_index[1:] != user_index[:-1]]
    run_start = np.maximum.accumulate(np.where(start, i, 0))
    pos = (i - run_start)[:, None]
    k = pos - (pos - np.arange(h)[None, :]) % max(h, 1)
    return np.where(k >= 0, action[run_start[:, None] + np.maximum(k, 0)], -1).astype(np.int32)


def load(
    directory: str,
    config: ProtocolConfig = ProtocolConfig(),
    version: str | None = None,
    protocol: str = "default",
) -> Protocol:
    """Reads a KuaiRand directory and builds the protocol's offline transitions.

    Args:
      directory: the KuaiRand files of one layout (`kuairand.LAYOUTS`).
      config: the protocol's sizes.
      version: `"27k"`, `"1k"` or `"pure"`; by default the layout whose file names the
        directory holds.
      protocol: `"default"`, this module's protocol, or `"tscac"`, the public
        KuaiRand-27K pipeline's construction detail for detail (`_tscac_tables`,
        `_ring_histories`; docs/recsys.md lists the differences).

    Raises:
      DataError: a file or column is missing, or a value is malformed.
      ValueError: an unknown `protocol`.
    """
    if protocol not in PROTOCOLS:
        raise ValueError(f"unknown protocol {protocol!r}; valid: {', '.join(PROTOCOLS)}")
    layout = kuairand.detect(directory, version)
    log_path = kuairand.path(directory, layout.log)
    candidates = _top_videos(log_path, config.n_candidates, config.chunksize, protocol)
    log = read_log(log_path, config.chunksize, keep_videos=candidates)
    n = len(log)
    n_train = int(round(n * config.train_fraction))
    if not 0 < n_train < n:
        raise DataError(f"{log_path}: {n} kept rows cannot be split {config.train_fraction:.4f}")
    if protocol == "default":  # tscac keeps the file's order
        user, time_ms = log["user_id"].to_numpy(np.int64), log["time_ms"].to_numpy(np.int64)
        log = log.iloc[by_user_in_time(user, time_ms)]

    user_ids, user_index = np.unique(log["user_id"].to_numpy(np.int64), return_inverse=True)
    action = pd.Index(candidates).get_indexer(log["video_id"].to_numpy(np.int64))
    reward = log[list(REWARD_COLUMNS)].to_numpy(np.float64)
    reward[:, -1] /= 10_000.0
    done = np.r_[user_index[1:] != user_index[:-1], True].astype(np.float32)
    histories = _histories if protocol == "default" else _ring_histories
    history = histories(user_index, action, config.history)
    video_raw = _video_table(directory, layout, candidates)  # NaN where missing
    if protocol == "default":
        user_raw = _user_table(directory, layout, user_ids)
        tables = _default_tables(user_raw, user_index, video_raw, history, n_train)
    else:
        user_raw = _user_table_tscac(directory, layout, user_ids, user_index)
        tables = _tscac_tables(user_raw, user_index, video_raw, history, n_train)
    return Protocol(
        user_index=jnp.asarray(user_index, jnp.int32),
        action=jnp.asarray(action, jnp.int32),
        reward=_f32(reward),
        done=_f32(done),
        history=jnp.asarray(history),
        n_train=n_train,
        user_ids=user_ids,
        video_ids=candidates,
        log_row=jnp.asarray(log.index.to_numpy(), jnp.int32),
        protocol=protocol,
        **tables,
    )


def _f32(x):
    return jnp.asarray(x, jnp.float32)


def _default_tables(user_raw, user_index, video_raw, history, n_train) -> dict:
    """This module's normalisation: missing values the training mean (candidates: the
    candidates' mean), every block z-scored by the training rows."""
    u_mean, u_std = _zscore_stats(user_raw[user_index[:n_train]])
    user_raw = np.where(np.isnan(user_raw), u_mean, user_raw)
    video_raw = np.where(np.isnan(video_raw), np.nanmean(video_raw, axis=0), video_raw)
    cand_mean, cand_std = _zscore_stats(video_raw)
    hist_train = history[:n_train]
    hist_raw = np.where(hist_train[..., None] >= 0, video_raw[np.maximum(hist_train, 0)], 0.0)
    h_mean, h_std = _zscore_stats(hist_raw)
    # the candidate block is one constant vector: its training z-score is 0 everywhere
    cand_state = np.zeros_like(video_raw.reshape(-1))
    return dict(
        user_table=_f32((user_raw - u_mean) / u_std),
        video_raw=_f32(video_raw),
        cand_state=_f32(cand_state),
        hist_mean=_f32(h_mean),
        hist_std=_f32(h_std),
        action_features=_f32((video_raw - cand_mean) / cand_std),
    )


def _tscac_tables(user_raw, user_index, video_raw, history, n_train) -> dict:
    """The public pipeline's normalisation: a missing music_type 2, every other missing
    value 0 (in raw units), then each split's states z-scored by that split's own rows,
    `TSCAC_STD_EPS` added to every standard deviation. The candidate block is constant,
    so 0 after that too; the critics' candidate features are z-scored across candidates
    as in the default protocol."""
    video_raw = video_raw.copy()
    music = VIDEO_FEATURES.index("music_type")
    video_raw[:, music] = np.where(
        np.isnan(video_raw[:, music]), TSCAC_MUSIC_TYPE_FILL, video_raw[:, music]
    )
    video_raw = np.nan_to_num(video_raw)
    user_raw = np.nan_to_num(user_raw)

    def split(rows):
        u = user_raw[user_index[rows]]
        h = history[rows]
        h = np.where(h[..., None] >= 0, video_raw[np.maximum(h, 0)], 0.0)
        table = (user_raw - u.mean(0)) / (u.std(0) + TSCAC_STD_EPS)
        return _f32(table), _f32(h.mean(0)), _f32(h.std(0) + TSCAC_STD_EPS)

    train_user, train_mean, train_std = split(slice(0, n_train))
    test_user, test_mean, test_std = split(slice(n_train, None))
    cand_mean, cand_std = _zscore_stats(video_raw)
    return dict(
        user_table=train_user,
        video_raw=_f32(video_raw),
        cand_state=_f32(np.zeros(video_raw.size)),
        hist_mean=train_mean,
        hist_std=train_std,
        action_features=_f32((video_raw - cand_mean) / cand_std),
        test_user_table=test_user,
        test_hist_mean=test_mean,
        test_hist_std=test_std,
    )


def main(argv=None) -> int:
    parser = ArgumentParser(
        prog="python -m wcac_jax.recsys.data",
        description="Check a KuaiRand directory and summarise the protocol's transitions.",
    )
    parser.add_argument("directory")
    parser.add_argument(
        "--version",
        choices=kuairand.VERSIONS,
        default=None,
        help="the KuaiRand layout (default: found from the file names)",
    )
    parser.add_argument(
        "--candidates",
        type=int,
        default=ProtocolConfig.n_candidates,
        help="C, the most viewed videos kept",
    )
    parser.add_argument(
        "--history",
        type=int,
        default=ProtocolConfig.history,
        help="H, previously viewed videos in the state",
    )
    parser.add_argument(
        "--protocol",
        choices=PROTOCOLS,
        default="default",
        help="the state and row construction (default: this project's; tscac: the public "
        "KuaiRand-27K pipeline's)",
    )
    args = parser.parse_args(argv)
    try:
        config = ProtocolConfig(n_candidates=args.candidates, history=args.history)
    except ValueError as err:
        parser.error(str(err))
    try:
        data = load(args.directory, config, args.version, args.protocol)
    except DataError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    test = np.asarray(data.reward[data.n_train :]).mean(axis=0)
    layout = kuairand.detect(args.directory, args.version)
    print(
        f"{layout.name} {layout.log}: {data.n_rows} rows ({data.n_train} train), "
        f"{len(data.user_ids)} users, {data.n_episodes} episodes of mean length "
        f"{data.n_rows / data.n_episodes:.2f}, {data.n_candidates} candidates, "
        f"state {data.state_dim} dims"
    )
    print("test means: " + ", ".join(f"{s} {v:.5g}" for s, v in zip(SIGNALS, test, strict=True)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
