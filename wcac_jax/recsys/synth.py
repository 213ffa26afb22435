"""A synthetic KuaiRand-27K: KuaiRand's files, columns, types and value ranges, written
from a latent user-video response model that is kept, so every policy's TRUE expected
signals can be computed (`ResponseModel.expected`).

The model. Each user has a latent taste `z_u` (`[k]`) and each video a latent `y_v`
(`[k]`, centred on its first tag's centroid) and five traits: quality `q`, log-duration
`d = log(duration / 30 s)`, controversy `c`, author appeal `f` and shareability `s`.
With the affinity `a = z_u . y_v / sqrt(k)` the per-impression probabilities are

  click            sigmoid(b_click + 1.0 a + 0.4 q + 0.3 z_u[0])
  like | click     sigmoid(b_like + 1.2 a + 0.8 q - 0.8 d + 0.3 z_u[1])
  follow | click   sigmoid(b_follow + 0.8 a + 1.0 f + 0.2 q)
  comment | click  sigmoid(b_comment + 0.6 a + 0.9 c + 0.3 z_u[2])
  forward | click  sigmoid(b_forward + 0.6 a + 0.9 s - 0.5 d)
  hate             sigmoid(b_hate - 0.9 a + 0.8 c - 0.5 q)          (no click needed)
  play_time        click * duration * sigmoid(b_watch + 0.9 a + 0.5 q - 0.4 d + 0.6 eps)

so the signals share the affinity (correlated) and partly conflict: watch time grows
with duration while likes and forwards fall with it, and controversy raises comments
together with dislikes. The user features (`onehot_feat*`, activity) are noisy
quantisations of `z_u`, so the signals are learnable from the features.

The logged ("standard") policy shows video `v` to user `u` with probability
`∝ pop_v exp(0.8 a + 0.4 q)`; the random-exposure log shows uniform videos. The biases
`b_*` are calibrated (bisection) so that the standard logs' expected rates equal
KuaiRand-Pure's published rates, and each binary signal's positives are then drawn as a
sample of exactly `round(rate * rows)` rows with odds proportional to the model's
(Gumbel top-k on the log-odds, an approximation of conditional Bernoulli sampling), so
the realised rates match the published ones to rounding.

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

from wcac_jax.outputs import unwritable_dir
from wcac_jax.recsys.cli import ArgumentParser
from wcac_jax.recsys.kuairand import LAYOUTS

# KuaiRand-Pure standard logs (RECSYS.md §1); watch time: the protocol's test mean.
PURE_RATES = {
    "is_click": 0.460,
    "is_like": 0.0185,
    "is_comment": 0.00255,
    "is_follow": 0.00107,
    "is_forward": 0.00096,
    "is_hate": 0.00049,
}
MEAN_PLAY_TIME_MS = 12_850.0
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
# onehot_feat0..17 cardinalities, close to KuaiRand's
ONEHOT_SIZES = (2, 7, 50, 1471, 15, 34, 3, 118, 454, 7, 5, 5, 3, 2, 2, 2, 2, 2)
# (weight on affinity, on traits...) of each binary signal's logit; see module docstring
_W_CLICK = dict(a=1.0, q=0.4, z0=0.3)
_W_LIKE = dict(a=1.2, q=0.8, d=-0.8, z1=0.3)
_W_FOLLOW = dict(a=0.8, f=1.0, q=0.2)
_W_COMMENT = dict(a=0.6, c=0.9, z2=0.3)
_W_FORWARD = dict(a=0.6, s=0.9, d=-0.5)
_W_HATE = dict(a=-0.9, c=0.8, q=-0.5)
_W_WATCH = dict(a=0.9, q=0.5, d=-0.4)
_WATCH_NOISE = 0.6
_BINARY = (
    ("is_click", _W_CLICK),
    ("is_like", _W_LIKE),
    ("is_follow", _W_FOLLOW),
    ("is_comment", _W_COMMENT),
    ("is_forward", _W_FORWARD),
    ("is_hate", _W_HATE),
)
_GATED = ("is_like", "is_follow", "is_comment", "is_forward")  # need a click


@dataclass(frozen=True)
class SynthConfig:
    """Sizes of a synthetic data set.

    Attributes:
      users: number of users.
      videos: number of videos (the protocol keeps the 150 most viewed).
      rows: rows of `log_standard_..._part1.csv` (the file the protocol reads); part2
        holds `rows // 4` more rows of the same users, the random log `rows // 10`.
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
    """The generator's response model: latent users and videos and calibrated biases.

    Attributes:
      user_ids: `[U]`; z: `[U, k]` user tastes.
      video_ids: `[V]`; y: `[V, k]` video latents; traits: `[V, 6]` columns
        `(q, d, c, f, s, duration_ms)`.
      bias: `[7]` biases of click, like, follow, comment, forward, hate, watch.
    """

    user_ids: np.ndarray
    z: np.ndarray
    video_ids: np.ndarray
    y: np.ndarray
    traits: np.ndarray
    bias: np.ndarray

    def _terms(self, ui, vi):
        q, d, c, f, s, dur = (self.traits[vi, j] for j in range(6))
        z = self.z[ui]
        a = np.sum(z * self.y[vi], axis=-1) / np.sqrt(self.z.shape[1])
        return dict(a=a, q=q, d=d, c=c, f=f, s=s, z0=z[..., 0], z1=z[..., 1], z2=z[..., 2]), dur

    def logits(self, ui, vi):
        """Per-impression logits without biases: `{signal: [...]}` and durations `[...]`."""
        terms, dur = self._terms(ui, vi)
        out = {name: sum(w * terms[k] for k, w in ws.items()) for name, ws in _BINARY}
        out["watch"] = sum(w * terms[k] for k, w in _W_WATCH.items())
        return out, dur

    def expected(self, user_ids, video_ids) -> np.ndarray:
        """TRUE expected signals of showing `video_ids` to `user_ids` (broadcast).

        Returns:
          `[..., 7]`: P(click), P(like), P(follow), P(comment), P(forward), P(hate),
          E[play_time_ms] / 10000 (the protocol's reward vector, in its order).
        """
        ui = np.searchsorted(self.user_ids, user_ids)
        vi = np.searchsorted(self.video_ids, video_ids)
        ui, vi = np.broadcast_arrays(ui, vi)
        lg, dur = self.logits(ui, vi)
        b = self.bias
        click = _sigmoid(b[0] + lg["is_click"])
        out = [click]
        for j, name in enumerate(("is_like", "is_follow", "is_comment", "is_forward"), 1):
            out.append(click * _sigmoid(b[j] + lg[name]))
        out.append(_sigmoid(b[5] + lg["is_hate"]))
        out.append(click * dur * _expected_sigmoid(b[6] + lg["watch"], _WATCH_NOISE) / 1e4)
        return np.stack(out, axis=-1)

    def save(self, path: str) -> None:
        np.savez(path, **{k: getattr(self, k) for k in self.__dataclass_fields__})

    @classmethod
    def load(cls, path: str) -> ResponseModel:
        with np.load(path) as f:
            return cls(**{k: f[k] for k in cls.__dataclass_fields__})


def _expected_sigmoid(mean, scale, order: int = 20):
    """`E[sigmoid(mean + scale * eps)]`, `eps ~ N(0, 1)`, by Gauss-Hermite quadrature."""
    x, w = np.polynomial.hermite_e.hermegauss(order)
    w = w / w.sum()
    return np.tensordot(_sigmoid(np.asarray(mean)[..., None] + scale * x), w, axes=1)


def _bisect_bias(logit, target_sum, lo=-30.0, hi=30.0, iters=60):
    """The bias `b` with `sum(sigmoid(b + logit)) = target_sum` (monotone in `b`)."""
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        if _sigmoid(mid + logit).sum() < target_sum:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def _exact_count_sample(rng, logit, k):
    """Exactly `k` positives, drawn with odds `exp(logit)` (Gumbel top-k on log-odds)."""
    out = np.zeros(logit.shape, np.int64)
    if k > 0:
        keys = logit + rng.gumbel(size=logit.shape)
        out[np.argpartition(-keys, k - 1)[:k]] = 1
    return out


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
        col = np.floor(ranks * size).astype(np.float64)
        if j in (4, 9):  # KuaiRand has missing values in a few of these columns
            col[rng.random(cfg.users) < 0.01] = np.nan
        df[f"onehot_feat{j}"] = col
    return df, z, activity


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
    tags = [f"{a},{b}" if rng.random() < 0.6 else f"{a}" for a, b in zip(tag1, tag2, strict=True)]
    dur_col = duration.astype(np.float64)
    dur_col[rng.random(cfg.videos) < 0.005] = np.nan
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
            "visible_status": rng.choice(["public", "friend_visible"], cfg.videos, p=[0.97, 0.03]),
            "video_duration": dur_col,
            "server_width": rng.choice([720, 1080, 540], cfg.videos),
            "server_height": rng.choice([1280, 1920, 960], cfg.videos),
            "music_id": rng.integers(0, 5000, cfg.videos),
            "music_type": rng.choice([4.0, 8.0, 9.0, 11.0], cfg.videos),
            "tag": tags,
        }
    )
    basic["upload_dt"] = basic["upload_dt"].dt.strftime("%Y-%m-%d")
    pop = rng.lognormal(0.0, 1.0, cfg.videos)
    return basic, y, traits, pop


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


def _times(rng, user_of_row, start_day, days):
    """Dates, hourmin and time_ms increasing within each user (rows sorted by user)."""
    n = user_of_row.shape[0]
    base = pd.Timestamp(start_day).value // 1_000_000
    t = base + rng.integers(0, days * 86_400_000, n)
    order = np.lexsort((t, user_of_row))
    t = t[order]
    stamp = pd.to_datetime(t, unit="ms")
    date = stamp.strftime("%Y%m%d").astype(np.int64)
    hourmin = (stamp.hour * 100 + (stamp.minute // 30) * 30).to_numpy().astype(np.int64)
    return date, hourmin, t


def _rows_per_user(rng, activity, rows):
    counts = rng.multinomial(rows - activity.shape[0], activity / activity.sum()) + 1
    return np.repeat(np.arange(activity.shape[0]), counts)


def generate(cfg: SynthConfig):
    """Builds the data set in memory.

    Returns:
      `(frames, model)`: `frames` maps each KuaiRand file name to its DataFrame, and
      `model` is the `ResponseModel` the logs were drawn from.
    """
    rng = np.random.default_rng(cfg.seed)
    users, z, activity = _users(rng, cfg)
    basic, y, traits, pop = _videos(rng, cfg)
    model = ResponseModel(
        user_ids=users["user_id"].to_numpy(),
        z=z,
        video_ids=basic["video_id"].to_numpy(),
        y=y,
        traits=traits,
        bias=np.zeros(7),
    )
    # the standard logs (both parts), then the random-exposure log
    n1, n2, n_rand = cfg.rows, cfg.rows // 4, max(cfg.rows // 10, 1)
    ui_std = np.concatenate([_rows_per_user(rng, activity, n1), _rows_per_user(rng, activity, n2)])
    aff = z @ y.T / np.sqrt(LATENT)
    pref = 0.8 * aff + 0.4 * traits[:, 0][None, :] + np.log(pop)[None, :]
    vi_std = _choose_videos(rng, pref, ui_std)
    ui_rand = np.sort(rng.integers(0, cfg.users, n_rand))
    vi_rand = rng.integers(0, cfg.videos, n_rand)

    lg_std, dur_std = model.logits(ui_std, vi_std)
    n_std = ui_std.shape[0]
    bias = np.zeros(7)
    bias[0] = _bisect_bias(lg_std["is_click"], PURE_RATES["is_click"] * n_std)
    p_click = _sigmoid(bias[0] + lg_std["is_click"])
    clicked = _exact_count_sample(
        rng, bias[0] + lg_std["is_click"], round(PURE_RATES["is_click"] * n_std)
    )
    std_signals = {"is_click": clicked}
    for j, (name, _) in enumerate(_BINARY[1:], 1):
        k = round(PURE_RATES[name] * n_std)
        if name in _GATED:
            # calibrated on P(click) rather than the drawn clicks: the model is exact
            bias[j] = _bisect_bias_weighted(lg_std[name], p_click, k)
            sel = np.flatnonzero(clicked)
            out = np.zeros(n_std, np.int64)
            out[sel] = _exact_count_sample(rng, bias[j] + lg_std[name][sel], k)
        else:
            bias[j] = _bisect_bias(lg_std[name], k)
            out = _exact_count_sample(rng, bias[j] + lg_std[name], k)
        std_signals[name] = out
    watch_mean = dur_std * p_click
    bias[6] = _bisect_watch(lg_std["watch"], watch_mean, MEAN_PLAY_TIME_MS * n_std)
    model = ResponseModel(**{**model.__dict__, "bias": bias})

    def draw(ui, vi, signals=None):
        lg, dur = model.logits(ui, vi)
        n = ui.shape[0]
        if signals is None:  # random log: plain Bernoulli draws from the same model
            signals = {}
            click = (rng.random(n) < _sigmoid(bias[0] + lg["is_click"])).astype(np.int64)
            signals["is_click"] = click
            for j, (name, _) in enumerate(_BINARY[1:], 1):
                p = _sigmoid(bias[j] + lg[name]) * (click if name in _GATED else 1)
                signals[name] = (rng.random(n) < p).astype(np.int64)
        frac = _sigmoid(bias[6] + lg["watch"] + _WATCH_NOISE * rng.normal(size=n))
        play = np.round(signals["is_click"] * dur * frac).astype(np.int64)
        long_view = ((play >= np.minimum(dur, 18_000)) & (signals["is_click"] == 1)).astype(
            np.int64
        )
        profile = signals["is_follow"] | (rng.random(n) < 0.01 * signals["is_click"])
        comment_stay = np.where(signals["is_comment"] == 1, rng.integers(1_000, 60_000, n), 0)
        return pd.DataFrame(
            {
                "user_id": model.user_ids[ui],
                "video_id": model.video_ids[vi],
                **{k: None for k in ("date", "hourmin", "time_ms")},
                **{
                    k: signals[k]
                    for k in (
                        "is_click",
                        "is_like",
                        "is_follow",
                        "is_comment",
                        "is_forward",
                        "is_hate",
                    )
                },
                "long_view": long_view,
                "play_time_ms": play,
                "duration_ms": dur.astype(np.int64),
                "profile_stay_time": np.where(profile == 1, rng.integers(1, 120, n), 0),
                "comment_stay_time": comment_stay,
                "is_profile_enter": profile.astype(np.int64),
                "is_rand": 0,
                "tab": rng.choice(15, n, p=_TAB_P),
            }
        )

    std = draw(ui_std, vi_std, std_signals)
    date, hourmin, t = _times(rng, ui_std[:n1], "2022-04-08", 14)
    # rows are grouped by user already (`_rows_per_user`); times increase within a user
    part1 = std.iloc[:n1].reset_index(drop=True)
    part1["date"], part1["hourmin"], part1["time_ms"] = date, hourmin, t
    part2 = std.iloc[n1:].reset_index(drop=True)
    part2["date"], part2["hourmin"], part2["time_ms"] = _times(rng, ui_std[n1:], "2022-04-08", 14)
    rand = draw(ui_rand, vi_rand)
    rand["date"], rand["hourmin"], rand["time_ms"] = _times(rng, ui_rand, "2022-04-22", 17)
    rand["is_rand"] = 1

    frames = {
        FILES["standard"][0]: part1[list(LOG_COLUMNS)],
        FILES["standard"][1]: part2[list(LOG_COLUMNS)],
        FILES["random"]: rand[list(LOG_COLUMNS)],
        FILES["user"]: users,
        FILES["video_basic"]: basic,
    }
    stats = _statistics(rng, pd.concat([part1, part2]), basic["video_id"].to_numpy())
    thirds = np.array_split(np.arange(len(stats)), 3)
    for name, idx in zip(FILES["video_statistic"], thirds, strict=True):
        frames[name] = stats.iloc[idx].reset_index(drop=True)
    return frames, model


def _bisect_bias_weighted(logit, weight, target_sum, lo=-30.0, hi=30.0, iters=60):
    """The bias `b` with `sum(weight * sigmoid(b + logit)) = target_sum`."""
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        if (weight * _sigmoid(mid + logit)).sum() < target_sum:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def _bisect_watch(logit, scale, target_sum, lo=-30.0, hi=30.0, iters=60):
    """The bias `b` with `sum(scale * E[sigmoid(b + logit + noise)]) = target_sum`."""
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        if (scale * _expected_sigmoid(mid + logit, _WATCH_NOISE)).sum() < target_sum:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


_TAB_P = np.array([0.02, 0.55, 0.25, 0.05, 0.04] + [0.01] * 9 + [0.0])
_TAB_P = _TAB_P / _TAB_P.sum()

# The platform-wide statistics cover far more users than the log; scale the log's sums.
_STAT_SCALE = 37


def _statistics(rng, log: pd.DataFrame, video_ids: np.ndarray) -> pd.DataFrame:
    """Per-video aggregate statistics (KuaiRand's columns), from the standard logs."""
    g = log.groupby("video_id")
    agg = pd.DataFrame(index=pd.Index(video_ids, name="video_id"))
    agg["show_cnt"] = g.size()
    agg["show_user_num"] = g["user_id"].nunique()
    agg["play_cnt"] = g["is_click"].sum()
    agg["play_user_num"] = log[log["is_click"] == 1].groupby("video_id")["user_id"].nunique()
    agg["play_duration"] = g["play_time_ms"].sum()
    agg["complete_play_cnt"] = (
        (log["play_time_ms"] >= log["duration_ms"]).groupby(log["video_id"]).sum()
    )
    agg["valid_play_cnt"] = (log["play_time_ms"] >= 7_000).groupby(log["video_id"]).sum()
    agg["long_time_play_cnt"] = g["long_view"].sum()
    agg["short_time_play_cnt"] = (
        ((log["play_time_ms"] > 0) & (log["play_time_ms"] < 3_000)).groupby(log["video_id"]).sum()
    )
    for col, name in (
        ("is_like", "like"),
        ("is_comment", "comment"),
        ("is_follow", "follow"),
        ("is_forward", "share"),
        ("is_hate", "reduce_similar"),
    ):
        agg[f"{name}_cnt"] = g[col].sum()
        agg[f"{name}_user_num"] = log[log[col] == 1].groupby("video_id")["user_id"].nunique()
    agg = agg.fillna(0) * _STAT_SCALE
    agg = agg.round().astype(np.int64)
    agg["play_progress"] = (
        (g["play_time_ms"].sum() / g["duration_ms"].sum()).reindex(video_ids).fillna(0).round(4)
    )
    agg["report_cnt"] = rng.poisson(0.2 * agg["reduce_similar_cnt"] + 0.1)
    agg["collect_cnt"] = rng.poisson(0.3 * agg["like_cnt"] + 0.1)
    agg["counts"] = agg["show_cnt"]
    agg = agg.reset_index()
    front = [
        "video_id",
        "counts",
        "show_cnt",
        "show_user_num",
        "play_cnt",
        "play_user_num",
        "play_duration",
        "complete_play_cnt",
        "valid_play_cnt",
        "long_time_play_cnt",
        "short_time_play_cnt",
        "play_progress",
        "like_cnt",
        "like_user_num",
        "comment_cnt",
        "comment_user_num",
        "follow_cnt",
        "follow_user_num",
        "share_cnt",
        "share_user_num",
        "report_cnt",
        "reduce_similar_cnt",
        "reduce_similar_user_num",
        "collect_cnt",
    ]
    return agg[front]


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
