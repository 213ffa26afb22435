"""A synthetic KuaiRand-27K: KuaiRand's files, columns, types and value ranges, written
from a latent user-video response model that is kept, so every policy's TRUE expected
signals can be computed (`ResponseModel.expected`).

The model. Each user has a latent taste `z_u` (`[k]`) and each video a latent `y_v`
(`[k]`, centred on its first tag's centroid) and five traits: quality `q`, log-duration
`d = log(duration / 30 s)`, controversy `c`, author appeal `f` and shareability `s`.
With the affinity `a = z_u . y_v / sqrt(k)` the per-impression probabilities are

  click            sigmoid(b_click + 1.0 a + 0.4 q + 0.3 z_u[0] - 0.06 n - 0.5 m)
  like | click     sigmoid(b_like + 1.2 a + 0.8 q - 0.8 d + 0.3 z_u[1] - 0.4 m)
  follow | click   sigmoid(b_follow + 0.8 a + 1.0 f + 0.2 q)
  comment | click  sigmoid(b_comment + 0.6 a + 0.9 c + 0.3 z_u[2])
  forward | click  sigmoid(b_forward + 0.6 a + 0.9 s - 0.5 d)
  hate             sigmoid(b_hate - 0.9 a + 0.8 c - 0.5 q + 0.5 m)   (no click needed)
  play_time        click * 1.5 duration * sigmoid(b_watch + 0.9 a + 0.5 q - 0.4 d
                                                    - 0.04 n - 0.4 m + 0.6 eps)

so the signals share the affinity (correlated) and partly conflict: watch time grows
with duration while likes and forwards fall with it, and controversy raises comments
together with dislikes. Responses depend on the session so far: `n` is the number of
videos the user saw earlier in the same session (at most `CONTEXT`; fatigue), and
`m = sum_j 0.7^j [tag of the j-th previous video = this video's tag]` (j = 0 the most
recent; satiation). A policy that keeps showing the one best-fitting tag lowers its own
later rewards, so a discounted objective differs from a one-step one. The user features
(`onehot_feat*`, activity) are noisy quantisations of `z_u`, so the signals are
learnable from the features.

The logs. Each user's views come in sessions (on average `MEAN_SESSION` views, a few
seconds to a minute apart; sessions at least `SESSION_GAP_MS` apart) spread over the
log's dates; each file holds its rows in time order, users interleaved, as KuaiRand's
logs do. `date` and `hourmin` are Beijing time (UTC+8), `hourmin` the whole hour times
100. The logged ("standard") policy shows video `v` to user `u` with probability
`∝ pop_v exp(0.8 a + 0.4 q)`, whatever the session; the random-exposure log shows uniform
videos. A few rows log `duration_ms` 0, a few videos lack `tag` or `video_duration`.

Calibration. The biases `b_*` are set (bisection) so that the EXPECTED rates over the
rows the protocol keeps (`log_standard_..._part1.csv`'s rows of its `CANDIDATES` most
viewed videos) equal `TARGET_RATES` and `TARGET_PLAY_TIME_MS`: the test means of the
public KuaiRand-27K pipeline this benchmark follows (on that subset, not the whole of
KuaiRand). Every signal is then an independent draw from the model, so the realised
rates differ from the targets by sampling noise only (binomial: about
`sqrt(p (1 - p) / rows)`).

The statistics files hold, per video, the average over the (day, tab) pairs it was shown
in of that pair's counts (`counts` is the number of pairs), scaled up to a platform with
more users than the log, as KuaiRand's per-day averages are.

Command line: `python -m wcac_jax.recsys.synth --out DIR [--users U --videos V --rows R
--seed S | --paper-scale] [--overwrite]`. Bad input prints one `error:` line, exits 2,
writes nothing; so does a `DIR` that already holds a KuaiRand-named file (a log or
features of any layout), unless `--overwrite`.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass

import numpy as np
import pandas as pd

from wcac_jax.recsys.cli import ArgumentParser
from wcac_jax.recsys.kuairand import LAYOUTS
from wcac_jax.sweep.outputs import unwritable_dir

# The protocol subset's test means in the public KuaiRand-27K pipeline (its reference
# means of the logged policy): click, like, follow, comment, forward, hate; watch time.
TARGET_RATES = {
    "is_click": 0.533783,
    "is_like": 0.0123087,
    "is_follow": 4.60754e-4,
    "is_comment": 3.22528e-3,
    "is_forward": 1.11897e-3,
    "is_hate": 2.30377e-4,
}
TARGET_PLAY_TIME_MS = 12_854.7
CANDIDATES = 150  # the protocol's kept videos, on which the rates are calibrated
SIGNALS = ("click", "like", "follow", "comment", "forward", "hate", "watch_time")

LOG_COLUMNS = (
    "user_id",
    "video_id",
    "date",
    "hourmin",
    "time_ms",
    "is_click",
    "is_like",
    "is_follow",
    "is_comment",
    "is_forward",
    "is_hate",
    "long_view",
    "play_time_ms",
    "duration_ms",
    "profile_stay_time",
    "comment_stay_time",
    "is_profile_enter",
    "is_rand",
    "tab",
)
# KuaiRand's statistics columns after `video_id` and `counts` (all float64 averages)
STAT_COLUMNS = (
    "show_cnt",
    "show_user_num",
    "play_cnt",
    "play_user_num",
    "play_duration",
    "complete_play_cnt",
    "complete_play_user_num",
    "valid_play_cnt",
    "valid_play_user_num",
    "long_time_play_cnt",
    "long_time_play_user_num",
    "short_time_play_cnt",
    "short_time_play_user_num",
    "play_progress",
    "comment_stay_duration",
    "like_cnt",
    "like_user_num",
    "click_like_cnt",
    "double_click_cnt",
    "cancel_like_cnt",
    "cancel_like_user_num",
    "comment_cnt",
    "comment_user_num",
    "direct_comment_cnt",
    "reply_comment_cnt",
    "delete_comment_cnt",
    "delete_comment_user_num",
    "comment_like_cnt",
    "comment_like_user_num",
    "follow_cnt",
    "follow_user_num",
    "cancel_follow_cnt",
    "cancel_follow_user_num",
    "share_cnt",
    "share_user_num",
    "download_cnt",
    "download_user_num",
    "report_cnt",
    "report_user_num",
    "reduce_similar_cnt",
    "reduce_similar_user_num",
    "collect_cnt",
    "collect_user_num",
    "cancel_collect_cnt",
    "cancel_collect_user_num",
    "direct_comment_user_num",
    "reply_comment_user_num",
    "share_all_cnt",
    "share_all_user_num",
    "outsite_share_all_cnt",
)
FILES = {
    "standard": (
        "log_standard_4_08_to_4_21_27k_part1.csv",
        "log_standard_4_08_to_4_21_27k_part2.csv",
    ),
    "random": "log_random_4_22_to_5_08_27k.csv",
    "user": "user_features_27k.csv",
    "video_basic": "video_features_basic_27k.csv",
    "video_statistic": (
        "video_features_statistic_27k_part1.csv",
        "video_features_statistic_27k_part2.csv",
        "video_features_statistic_27k_part3.csv",
    ),
}
MODEL_FILE = "synthetic_response_model.npz"

LATENT = 4
N_TAGS = 30
# onehot_feat0..17 cardinalities, KuaiRand's
ONEHOT_SIZES = (2, 7, 50, 1471, 15, 34, 3, 118, 454, 7, 5, 5, 2, 2, 2, 2, 2, 2)
# (weight on affinity, on traits...) of each binary signal's logit; see module docstring
_W_CLICK = dict(a=1.0, q=0.4, z0=0.3, n=-0.06, m=-0.5)
_W_LIKE = dict(a=1.2, q=0.8, d=-0.8, z1=0.3, m=-0.4)
_W_FOLLOW = dict(a=0.8, f=1.0, q=0.2)
_W_COMMENT = dict(a=0.6, c=0.9, z2=0.3)
_W_FORWARD = dict(a=0.6, s=0.9, d=-0.5)
_W_HATE = dict(a=-0.9, c=0.8, q=-0.5, m=0.5)
_W_WATCH = dict(a=0.9, q=0.5, d=-0.4, n=-0.04, m=-0.4)
_WATCH_NOISE = 0.6
_WATCH_MAX = 1.5  # play time up to 1.5 durations: replays, as in KuaiRand's logs
_BINARY = (
    ("is_click", _W_CLICK),
    ("is_like", _W_LIKE),
    ("is_follow", _W_FOLLOW),
    ("is_comment", _W_COMMENT),
    ("is_forward", _W_FORWARD),
    ("is_hate", _W_HATE),
)
_GATED = ("is_like", "is_follow", "is_comment", "is_forward")  # need a click

# The session: how many earlier views matter, how fast satiation decays, sizes and gaps.
CONTEXT = 10
SATIATION_DECAY = 0.7
MEAN_SESSION = 12
SESSION_GAP_MS = 30 * 60_000
_VIEW_GAP_MS = (2_000, 20_000)  # a view's gap to the next in a session: min + exp(mean)
BEIJING_MS = 8 * 3_600_000
_ZERO_DURATION_ROWS = 0.005  # rows logging duration_ms 0
_MISSING_TAG, _MISSING_DURATION = 0.01, 0.005  # videos without tag / video_duration
# The platform-wide statistics cover far more users than the log; scale the log's counts.
_STAT_SCALE = 37


@dataclass(frozen=True)
class SynthConfig:
    """Sizes of a synthetic data set.

    Attributes:
      users: number of users.
      videos: number of videos (the protocol keeps the 150 most viewed).
      rows: rows of `log_standard_..._part1.csv` (the file the protocol reads); part2
        holds `rows // 4` more rows of the same users (other sessions), the random log
        `rows // 10`.
      seed: PRNG seed; the data set is a pure function of the config.
    """

    users: int = 1000
    videos: int = 300
    rows: int = 100_000
    seed: int = 0

    def __post_init__(self):
        if self.users < 2:
            raise ValueError(f"--users must be >= 2, got {self.users}")
        if self.videos < 2:
            raise ValueError(f"--videos must be >= 2, got {self.videos}")
        if self.rows < self.users:
            raise ValueError(f"--rows must be >= --users ({self.users}), got {self.rows}")
        if self.seed < 0:
            raise ValueError(f"--seed must be >= 0, got {self.seed}")


# The protocol's size: part1 holds exactly the 480,385 rows of the 150 kept videos.
PAPER_SCALE = SynthConfig(users=27_285, videos=150, rows=480_385)


def _sigmoid(x):
    return 1.0 / (1.0 + np.exp(-x))


@dataclass(frozen=True)
class ResponseModel:
    """The generator's response model: latent users and videos, calibrated biases, and
    each row's session context in the protocol's log.

    Attributes:
      user_ids: `[U]`; z: `[U, k]` user tastes.
      video_ids: `[V]`; y: `[V, k]` video latents; traits: `[V, 6]` columns
        `(q, d, c, f, s, duration_ms)`; tag: `[V]` first tag (satiation's similarity).
      bias: `[7]` biases of click, like, follow, comment, forward, hate, watch.
      log_context: `[R, CONTEXT]` for each data row (0-based, file order) of
        `log_standard_..._part1.csv`, the video ids seen earlier in the same session,
        most recent first, -1 where none.
    """

    user_ids: np.ndarray
    z: np.ndarray
    video_ids: np.ndarray
    y: np.ndarray
    traits: np.ndarray
    tag: np.ndarray
    bias: np.ndarray
    log_context: np.ndarray

    def _terms(self, ui, vi, ci):
        q, d, c, f, s, dur = (self.traits[vi, j] for j in range(6))
        z = self.z[ui]
        a = np.sum(z * self.y[vi], axis=-1) / np.sqrt(self.z.shape[1])
        seen = ci >= 0
        n = seen.sum(axis=-1).astype(np.float64)
        same = seen & (self.tag[np.maximum(ci, 0)] == self.tag[vi][..., None])
        m = same @ SATIATION_DECAY ** np.arange(ci.shape[-1])
        terms = dict(a=a, q=q, d=d, c=c, f=f, s=s, n=n, m=m)
        terms.update(z0=z[..., 0], z1=z[..., 1], z2=z[..., 2])
        return terms, dur

    def logits(self, ui, vi, ci):
        """Per-impression logits without biases: `{signal: [...]}` and durations `[...]`.

        Args:
          ui, vi: `[...]` user and video indices (rows of `z`, `y`); ci: `[..., K]`
            indices of the videos seen earlier in the session, most recent first, -1
            where none.
        """
        terms, dur = self._terms(ui, vi, ci)
        out = {name: sum(w * terms[k] for k, w in ws.items()) for name, ws in _BINARY}
        out["watch"] = sum(w * terms[k] for k, w in _W_WATCH.items())
        return out, dur

    def expected(self, user_ids, video_ids, context=None) -> np.ndarray:
        """TRUE expected signals of showing `video_ids` to `user_ids` (broadcast).

        Args:
          user_ids, video_ids: ids, broadcast together to `[...]`.
          context: `[..., K]` ids of the videos the user saw earlier in the session, most
            recent first, -1 where none (a logged row's: `logged_context`); by default
            none, the first view of a session.

        Returns:
          `[..., 7]`: P(click), P(like), P(follow), P(comment), P(forward), P(hate),
          E[play_time_ms] / 10000 (the protocol's reward vector, in its order).
        """
        ui = np.searchsorted(self.user_ids, user_ids)
        vi = np.searchsorted(self.video_ids, video_ids)
        ui, vi = np.broadcast_arrays(ui, vi)
        if context is None:
            ci = np.full((*ui.shape, 1), -1)
        else:
            context = np.asarray(context)
            ci = np.where(context >= 0, np.searchsorted(self.video_ids, context), -1)
            shape = np.broadcast_shapes(ui.shape, ci.shape[:-1])
            ui, vi = np.broadcast_to(ui, shape), np.broadcast_to(vi, shape)
            ci = np.broadcast_to(ci, (*shape, ci.shape[-1]))
        lg, dur = self.logits(ui, vi, ci)
        b = self.bias
        click = _sigmoid(b[0] + lg["is_click"])
        out = [click]
        for j, name in enumerate(("is_like", "is_follow", "is_comment", "is_forward"), 1):
            out.append(click * _sigmoid(b[j] + lg[name]))
        out.append(_sigmoid(b[5] + lg["is_hate"]))
        watch = _WATCH_MAX * dur * _expected_sigmoid(b[6] + lg["watch"], _WATCH_NOISE)
        out.append(click * watch / 1e4)
        return np.stack(out, axis=-1)

    def logged_context(self, log_rows) -> np.ndarray:
        """`[..., CONTEXT]` session contexts (video ids, -1 none) of data rows of the
        protocol's log file (`Protocol.log_row`)."""
        return self.log_context[np.asarray(log_rows)]

    def save(self, path: str) -> None:
        np.savez_compressed(path, **{k: getattr(self, k) for k in self.__dataclass_fields__})

    @classmethod
    def load(cls, path: str) -> ResponseModel:
        with np.load(path) as f:
            return cls(**{k: f[k] for k in cls.__dataclass_fields__})


def _expected_sigmoid(mean, scale, order: int = 20):
    """`E[sigmoid(mean + scale * eps)]`, `eps ~ N(0, 1)`, by Gauss-Hermite quadrature."""
    x, w = np.polynomial.hermite_e.hermegauss(order)
    w = w / w.sum()
    return np.tensordot(_sigmoid(np.asarray(mean)[..., None] + scale * x), w, axes=1)


def _bisect(total, target_sum, lo=-30.0, hi=30.0, iters=60):
    """The `b` with `total(b) = target_sum`, for `total` increasing in `b`."""
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        if total(mid) < target_sum:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def _buckets(values, edges, labels):
    return pd.cut(values, [-np.inf, *edges, np.inf], labels=labels, right=True).astype(str)


def _users(rng, cfg: SynthConfig):
    user_ids = np.arange(cfg.users)
    z = rng.normal(size=(cfg.users, LATENT))
    activity = rng.lognormal(0.0, 0.8, cfg.users)
    deg = np.array(
        ["UNKNOWN", "2_14_day_new", "low_active", "middle_active", "high_active", "full_active"]
    )[np.digitize(np.log(activity), [-1.8, -1.2, -0.6, 0.0, 0.6])]
    follow = np.floor(rng.lognormal(3.0, 1.5, cfg.users)).astype(np.int64)
    fans = np.floor(rng.lognormal(1.5, 2.0, cfg.users)).astype(np.int64)
    friend = np.floor(rng.lognormal(1.0, 1.5, cfg.users)).astype(np.int64)
    register = rng.integers(15, 3000, cfg.users)
    live = rng.choice([0, 1, -124], cfg.users, p=[0.85, 0.05, 0.10])
    df = pd.DataFrame(
        {
            "user_id": user_ids,
            "user_active_degree": deg,
            "is_lowactive_period": (activity < 0.4).astype(np.int64),
            "is_live_streamer": live,
            "is_video_author": (rng.random(cfg.users) < 0.3).astype(np.int64),
            "follow_user_num": follow,
            "follow_user_num_range": _buckets(
                follow,
                [0, 10, 50, 100, 150, 250, 500],
                [
                    "0",
                    "(0,10]",
                    "(10,50]",
                    "(50,100]",
                    "(100,150]",
                    "(150,250]",
                    "(250,500]",
                    "500+",
                ],
            ),
            "fans_user_num": fans,
            "fans_user_num_range": _buckets(
                fans,
                [0, 9, 99, 999, 4999, 9999],
                ["0", "[1,10)", "[10,100)", "[100,1k)", "[1k,5k)", "[5k,1w)", "[1w,10w)"],
            ),
            "friend_user_num": friend,
            "friend_user_num_range": _buckets(
                friend,
                [0, 4, 29, 59, 119, 249],
                ["0", "[1,5)", "[5,30)", "[30,60)", "[60,120)", "[120,250)", "250+"],
            ),
            "register_days": register,
            "register_days_range": _buckets(
                register,
                [30, 60, 90, 180, 365, 730],
                ["15-30", "31-60", "61-90", "91-180", "181-365", "366-730", "730+"],
            ),
        }
    )
    for j, size in enumerate(ONEHOT_SIZES):
        # a noisy, monotone quantisation of one latent coordinate: learnable from features
        x = z[:, j % LATENT] + 0.3 * rng.normal(size=cfg.users)
        ranks = np.argsort(np.argsort(x)) / cfg.users
        df[f"onehot_feat{j}"] = np.floor(ranks * size).astype(np.int64)
    return df, z, activity


def _some(rng, n, share):
    """`max(1, round(share n))` distinct indices below `n`: at least one at every size."""
    return rng.choice(n, max(1, round(share * n)), replace=False)


def _videos(rng, cfg: SynthConfig):
    video_ids = np.arange(cfg.videos)
    centroids = rng.normal(size=(N_TAGS, LATENT))
    tag1 = rng.integers(0, N_TAGS, cfg.videos)
    y = centroids[tag1] + 0.7 * rng.normal(size=(cfg.videos, LATENT))
    duration = np.clip(rng.lognormal(np.log(30_000.0), 0.7, cfg.videos), 3_000, 600_000)
    duration = np.round(duration).astype(np.int64)
    d = np.log(duration / 30_000.0)
    q, c, f, s = (rng.normal(size=cfg.videos) for _ in range(4))
    traits = np.stack([q, d, c, f, s, duration.astype(np.float64)], axis=1)
    tag2 = rng.integers(0, 300, cfg.videos)
    tags = np.array(
        [f"{a},{b}" if rng.random() < 0.6 else f"{a}" for a, b in zip(tag1, tag2, strict=True)],
        dtype=object,
    )
    tags[_some(rng, cfg.videos, _MISSING_TAG)] = np.nan
    dur_col = duration.astype(np.float64)
    dur_col[_some(rng, cfg.videos, _MISSING_DURATION)] = np.nan
    basic = pd.DataFrame(
        {
            "video_id": video_ids,
            "author_id": rng.integers(0, max(2, cfg.videos // 2), cfg.videos),
            "video_type": np.where(rng.random(cfg.videos) < 0.02, "AD", "NORMAL"),
            "upload_dt": pd.Timestamp("2022-04-20")
            - pd.to_timedelta(rng.integers(0, 400, cfg.videos), unit="D"),
            "upload_type": rng.choice(
                ["ShortImport", "Web", "PictureSet", "LongImport"], cfg.videos
            ),
            "visible_status": rng.choice([1, 0], cfg.videos, p=[0.97, 0.03]),
            "video_duration": dur_col,
            "server_width": rng.choice([720, 1080, 540], cfg.videos),
            "server_height": rng.choice([1280, 1920, 960], cfg.videos),
            "music_id": rng.integers(0, 5000, cfg.videos),
            "music_type": rng.choice([4, 8, 9, 11], cfg.videos),
            "tag": tags,
        }
    )
    basic["upload_dt"] = basic["upload_dt"].dt.strftime("%Y-%m-%d")
    pop = rng.lognormal(0.0, 1.0, cfg.videos)
    return basic, y, traits, tag1, pop


def _choose_videos(rng, pref_logits, user_of_row, block: int = 50_000):
    """One video per row: categorical over videos with the row's user's logits."""
    probs = np.exp(pref_logits - pref_logits.max(axis=1, keepdims=True))
    cdf = np.cumsum(probs / probs.sum(axis=1, keepdims=True), axis=1)
    out = np.empty(user_of_row.shape[0], np.int64)
    for start in range(0, out.shape[0], block):
        rows = user_of_row[start : start + block]
        u = rng.random(rows.shape[0])[:, None]
        out[start : start + block] = np.minimum((u > cdf[rows]).sum(axis=1), cdf.shape[1] - 1)
    return out


def _rows_per_user(rng, activity, rows):
    """`[U]` rows of each user (each at least one), in proportion to activity."""
    return rng.multinomial(rows - activity.shape[0], activity / activity.sum()) + 1


def _sessions(rng, counts):
    """Rows grouped by user, each user's rows cut into sessions.

    Returns:
      `(user, first)`: `[N]` the row's user and whether it opens a session.
    """
    user = np.repeat(np.arange(counts.shape[0]), counts)
    first = np.r_[True, user[1:] != user[:-1]] | (rng.random(user.shape[0]) < 1 / MEAN_SESSION)
    return user, first


def _timeline(rng, user, first, start_day: str, days: int):
    """Times of rows whose sessions are consecutive (`_sessions`' output, or several
    concatenated): each user's sessions in a random order over the window, at least
    `SESSION_GAP_MS` apart, the views of a session a few seconds apart.

    Returns:
      `[N]` int64 `time_ms` (UTC), the window starting at `start_day` 00:00 Beijing time.
    """
    session = np.cumsum(first) - 1
    gap = _VIEW_GAP_MS[0] + rng.exponential(_VIEW_GAP_MS[1], user.shape[0])
    csum = np.cumsum(gap) - gap
    offset = csum - csum[np.flatnonzero(first)][session]  # from the session's start
    s_user = user[first]
    s_len = np.bincount(session, weights=gap) + SESSION_GAP_MS
    window = days * 86_400_000.0
    total = np.bincount(s_user, weights=s_len, minlength=user.max() + 1)
    # a user whose sessions cannot fit the window is squeezed (none at the usual sizes)
    squeeze = np.minimum(1.0, 0.95 * window / np.maximum(total, 1.0))
    order = np.lexsort((rng.random(s_user.shape[0]), s_user))  # random order per user
    o_user = s_user[order]
    o_len = s_len[order] * squeeze[o_user]
    before = np.cumsum(o_len) - o_len
    user_start = np.r_[True, o_user[1:] != o_user[:-1]]
    before -= before[np.flatnonzero(user_start)][np.cumsum(user_start) - 1]
    # sorted uniform offsets in the free time keep the sessions apart and in the window
    free = np.maximum(window - total * squeeze, 0.0)[o_user]
    u = rng.random(o_user.shape[0])
    s_start = np.empty_like(before)
    s_start[order] = before + u[np.lexsort((u, o_user))] * free
    t0 = pd.Timestamp(start_day).value // 1_000_000 - BEIJING_MS
    return np.round(t0 + s_start[session] + offset * squeeze[user]).astype(np.int64)


def _contexts(first, video):
    """`[N, CONTEXT]`: the videos of the session's earlier rows, most recent first, -1
    where none (rows of a session consecutive)."""
    idx = np.arange(first.shape[0])
    start = np.maximum.accumulate(np.where(first, idx, 0))
    src = idx[:, None] - np.arange(1, CONTEXT + 1)[None, :]
    return np.where(src >= start[:, None], video[np.maximum(src, 0)], -1)


def _calibrate(model: ResponseModel, ui, vi, ci) -> np.ndarray:
    """`[7]` biases whose expected rates over the rows `(ui, vi, ci)` are the targets."""
    lg, dur = model.logits(ui, vi, ci)
    n = ui.shape[0]
    bias = np.zeros(7)
    click = lg["is_click"]
    bias[0] = _bisect(lambda b: _sigmoid(b + click).sum(), TARGET_RATES["is_click"] * n)
    p_click = _sigmoid(bias[0] + click)
    for j, (name, _) in enumerate(_BINARY[1:], 1):
        # gated signals: calibrated on P(click), so the model's rates are exact
        w = p_click if name in _GATED else 1.0
        x = lg[name]
        bias[j] = _bisect(lambda b, w=w, x=x: (w * _sigmoid(b + x)).sum(), TARGET_RATES[name] * n)
    scale, x = _WATCH_MAX * p_click * dur, lg["watch"]
    bias[6] = _bisect(
        lambda b: (scale * _expected_sigmoid(b + x, _WATCH_NOISE)).sum(), TARGET_PLAY_TIME_MS * n
    )
    return bias


_TAB_P = np.array([0.02, 0.55, 0.25, 0.05, 0.04] + [0.01] * 9 + [0.0])
_TAB_P = _TAB_P / _TAB_P.sum()


def _draw(rng, model: ResponseModel, ui, vi, ci, times) -> pd.DataFrame:
    """Log rows drawn from the model (every signal an independent draw), in time order."""
    lg, dur = model.logits(ui, vi, ci)
    b, n = model.bias, ui.shape[0]
    click = (rng.random(n) < _sigmoid(b[0] + lg["is_click"])).astype(np.int64)
    sig = {"is_click": click}
    for j, (name, _) in enumerate(_BINARY[1:], 1):
        p = _sigmoid(b[j] + lg[name]) * (click if name in _GATED else 1)
        sig[name] = (rng.random(n) < p).astype(np.int64)
    frac = _sigmoid(b[6] + lg["watch"] + _WATCH_NOISE * rng.normal(size=n))
    play = np.round(click * _WATCH_MAX * dur * frac).astype(np.int64)
    long_view = ((play >= np.minimum(dur, 18_000)) & (click == 1)).astype(np.int64)
    profile = sig["is_follow"] | (rng.random(n) < 0.01 * click)
    local = pd.to_datetime(times + BEIJING_MS, unit="ms")
    df = pd.DataFrame(
        {
            "user_id": model.user_ids[ui],
            "video_id": model.video_ids[vi],
            "date": local.strftime("%Y%m%d").astype(np.int64),
            "hourmin": (local.hour * 100).to_numpy().astype(np.int64),
            "time_ms": times,
            **sig,
            "long_view": long_view,
            "play_time_ms": play,
            # a few rows log no duration, as KuaiRand's do
            "duration_ms": np.where(rng.random(n) < _ZERO_DURATION_ROWS, 0, dur.astype(np.int64)),
            "profile_stay_time": np.where(profile == 1, rng.integers(1, 120, n), 0),
            "comment_stay_time": np.where(sig["is_comment"] == 1, rng.integers(1_000, 6e4, n), 0),
            "is_profile_enter": profile.astype(np.int64),
            "is_rand": 0,
            "tab": rng.choice(15, n, p=_TAB_P),
        }
    )[list(LOG_COLUMNS)]
    return df.iloc[np.lexsort((np.arange(n), times))].reset_index(drop=True)


def _session_rows(rng, activity, rows):
    """Users and session starts of `rows` rows (`[N]` each), grouped by user."""
    users = activity.shape[0]
    if rows >= users:
        counts = rng.multinomial(rows - users, activity / activity.sum()) + 1
    else:
        counts = rng.multinomial(rows, activity / activity.sum())
    return _sessions(rng, counts)


def generate(cfg: SynthConfig):
    """Builds the data set in memory.

    Returns:
      `(frames, model)`: `frames` maps each KuaiRand file name to its DataFrame, and
      `model` is the `ResponseModel` the logs were drawn from.
    """
    rng = np.random.default_rng(cfg.seed)
    users, z, activity = _users(rng, cfg)
    basic, y, traits, tag, pop = _videos(rng, cfg)
    n1, n2, n_rand = cfg.rows, cfg.rows // 4, max(cfg.rows // 10, 1)
    # the standard logs' two parts: other sessions of the same users over the same days
    u1, f1 = _session_rows(rng, activity, n1)
    u2, f2 = _session_rows(rng, activity, n2)
    u_std, f_std = np.r_[u1, u2], np.r_[f1, f2]
    t_std = _timeline(rng, u_std, f_std, "2022-04-08", 14)
    aff = z @ y.T / np.sqrt(LATENT)
    v_std = _choose_videos(rng, 0.8 * aff + 0.4 * traits[:, 0][None, :] + np.log(pop), u_std)
    c_std = _contexts(f_std, v_std)
    u_r, f_r = _session_rows(rng, activity, n_rand)
    t_r = _timeline(rng, u_r, f_r, "2022-04-22", 17)
    v_r = rng.integers(0, cfg.videos, u_r.shape[0])
    c_r = _contexts(f_r, v_r)

    model = ResponseModel(
        user_ids=users["user_id"].to_numpy(),
        z=z,
        video_ids=basic["video_id"].to_numpy(),
        y=y,
        traits=traits,
        tag=tag,
        bias=np.zeros(7),
        log_context=np.zeros((0, CONTEXT), np.int64),
    )
    # calibrated on the rows the protocol keeps: part1's rows of its most viewed videos
    views = np.bincount(v_std[:n1], minlength=cfg.videos)
    top = np.lexsort((np.arange(cfg.videos), -views))[:CANDIDATES]
    kept = np.isin(v_std[:n1], top)
    bias = _calibrate(model, u1[kept], v_std[:n1][kept], c_std[:n1][kept])
    order1 = np.lexsort((np.arange(n1), t_std[:n1]))  # part1's file order
    ctx = c_std[:n1][order1]
    context = np.where(ctx >= 0, model.video_ids[np.maximum(ctx, 0)], -1)
    model = ResponseModel(**{**model.__dict__, "bias": bias, "log_context": context})

    part1 = _draw(rng, model, u1, v_std[:n1], c_std[:n1], t_std[:n1])
    part2 = _draw(rng, model, u2, v_std[n1:], c_std[n1:], t_std[n1:])
    rand = _draw(rng, model, u_r, v_r, c_r, t_r)
    rand["is_rand"] = 1
    frames = {
        FILES["standard"][0]: part1,
        FILES["standard"][1]: part2,
        FILES["random"]: rand,
        FILES["user"]: users,
        FILES["video_basic"]: basic,
    }
    stats = _statistics(rng, pd.concat([part1, part2]), model.video_ids)
    thirds = np.array_split(np.arange(len(stats)), 3)
    for name, idx in zip(FILES["video_statistic"], thirds, strict=True):
        frames[name] = stats.iloc[idx].reset_index(drop=True)
    return frames, model


def _thin(rng, counts, p):
    return rng.binomial(counts, p)


def _events(rng, log: pd.DataFrame) -> dict:
    """Per-row counts of the events KuaiRand's statistics aggregate, by column stem."""
    click, play = log["is_click"].to_numpy(), log["play_time_ms"].to_numpy()
    dur = log["duration_ms"].to_numpy()
    like, comment = log["is_like"].to_numpy(), log["is_comment"].to_numpy()
    direct = _thin(rng, comment, 0.8)
    share = log["is_forward"].to_numpy()
    share_all = share + _thin(rng, click, 0.001)
    collect = _thin(rng, like, 0.3)
    return {
        "show": np.ones_like(click),
        "play": click,
        "complete_play": ((dur > 0) & (play >= dur)).astype(np.int64),
        "valid_play": click,
        "long_time_play": log["long_view"].to_numpy(),
        "short_time_play": ((play > 0) & (play < np.minimum(3_000, dur))).astype(np.int64),
        "like": like,
        "click_like": _thin(rng, like, 0.1),
        "double_click": _thin(rng, like, 0.9),
        "cancel_like": _thin(rng, like, 0.05),
        "comment": comment,
        "direct_comment": direct,
        "reply_comment": comment - direct,
        "delete_comment": _thin(rng, comment, 0.05),
        "comment_like": _thin(rng, comment, 0.3),
        "follow": log["is_follow"].to_numpy(),
        "cancel_follow": _thin(rng, log["is_follow"].to_numpy(), 0.1),
        "share": share,
        "download": _thin(rng, click, 0.002),
        "report": _thin(rng, log["is_hate"].to_numpy(), 0.2),
        "reduce_similar": log["is_hate"].to_numpy(),
        "collect": collect,
        "cancel_collect": _thin(rng, collect, 0.1),
        "share_all": share_all,
        "outsite_share_all": _thin(rng, share_all, 0.3),
    }


def _statistics(rng, log: pd.DataFrame, video_ids: np.ndarray) -> pd.DataFrame:
    """Per-video statistics as KuaiRand's: each column the average, over the (day, tab)
    pairs the video was shown in, of that pair's count (`counts`: the pairs), scaled to
    the platform; `play_progress` the average of the pairs' play / duration."""
    events = _events(rng, log)
    keys = ["video_id", "date", "tab", "user_id"]
    ev = pd.DataFrame({k: log[k].to_numpy() for k in keys})
    ev["play_duration"] = log["play_time_ms"].to_numpy()
    ev["duration"] = log["duration_ms"].to_numpy()
    ev["comment_stay_duration"] = log["comment_stay_time"].to_numpy()
    for stem, x in events.items():
        ev[stem] = x
    per_user = ev.groupby(keys).sum()
    users = (per_user[list(events)] > 0).add_suffix("_user_num")
    per_user = pd.concat([per_user, users], axis=1)
    per_pair = per_user.groupby(level=["video_id", "date", "tab"]).sum()
    progress = per_pair["play_duration"] / per_pair["duration"].where(per_pair["duration"] > 0)
    for stem in events:
        per_pair[stem + "_cnt"] = per_pair[stem]
    per_pair = per_pair * _STAT_SCALE
    per_pair["play_progress"] = progress.fillna(0.0)
    by_video = per_pair.groupby(level="video_id")
    out = pd.DataFrame(index=pd.Index(video_ids, name="video_id"))
    out["counts"] = by_video.size().reindex(video_ids).fillna(0).astype(np.int64)
    means = by_video.mean().reindex(video_ids).fillna(0.0)
    for col in STAT_COLUMNS:
        out[col] = means[col].round(3).astype(np.float64)
    return out.reset_index()


def write(cfg: SynthConfig, out: str) -> ResponseModel:
    """Generates the data set and writes it to `out` (created if needed).

    Every file is written to a temporary name and renamed, so an interrupted run never
    leaves a half-written CSV under a KuaiRand name. Also writes `MODEL_FILE`.
    """
    frames, model = generate(cfg)
    os.makedirs(out, exist_ok=True)
    for name, df in frames.items():
        tmp = os.path.join(out, name + ".tmp")
        df.to_csv(tmp, index=False)
        os.replace(tmp, os.path.join(out, name))
    tmp = os.path.join(out, "model.tmp.npz")
    model.save(tmp)
    os.replace(tmp, os.path.join(out, MODEL_FILE))
    return model


def kuairand_files(directory: str) -> list[str]:
    """The KuaiRand-named files (of any layout) in `directory`, logs first."""
    if not os.path.isdir(directory):
        return []
    names = [n for layout in LAYOUTS.values() for n in layout.files]
    names.sort(key=lambda n: not n.startswith("log_"))
    return [n for n in names if os.path.lexists(os.path.join(directory, n))]


def main(argv=None) -> int:
    parser = ArgumentParser(
        prog="python -m wcac_jax.recsys.synth", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--users", type=int, default=SynthConfig.users)
    parser.add_argument("--videos", type=int, default=SynthConfig.videos)
    parser.add_argument("--rows", type=int, default=SynthConfig.rows, help="rows of part1")
    parser.add_argument("--seed", type=int, default=SynthConfig.seed)
    parser.add_argument(
        "--overwrite", action="store_true", help="replace KuaiRand files already in --out"
    )
    parser.add_argument(
        "--paper-scale",
        action="store_true",
        help=f"{PAPER_SCALE.users} users, {PAPER_SCALE.videos} videos, {PAPER_SCALE.rows} rows",
    )
    args = parser.parse_args(argv)
    try:
        if args.paper_scale:
            cfg = SynthConfig(PAPER_SCALE.users, PAPER_SCALE.videos, PAPER_SCALE.rows, args.seed)
        else:
            cfg = SynthConfig(args.users, args.videos, args.rows, args.seed)
        problem = unwritable_dir(args.out)
        if problem:
            raise ValueError(f"--out {args.out!r} can't be written: {problem}")
        held = kuairand_files(args.out)
        if held and not args.overwrite:
            raise ValueError(
                f"--out {args.out!r} already holds KuaiRand's {held[0]}; "
                "pass --overwrite to replace it"
            )
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    write(cfg, args.out)
    print(f"wrote a synthetic KuaiRand-27K ({cfg}) to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
