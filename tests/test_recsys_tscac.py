"""The two protocols' data construction: `protocol="tscac"` (the public KuaiRand-27K
pipeline's rows, candidates, user features, history ring, missing values and per-split
normalisation) against hand-computed cases and the committed fixtures, and the default
protocol left as it was."""

import os
import shutil

import numpy as np
import pandas as pd
import pytest

from wcac_jax.recsys import data as data_lib
from wcac_jax.recsys import kuairand

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FIXTURES = os.path.join(ROOT, "tests", "fixtures", "kuairand")
SMALL = data_lib.ProtocolConfig(n_candidates=10, history=3)
PURE = kuairand.LAYOUTS["pure"]


def _pure(tmp_path, rows=None, edit_basic=None):
    """A copy of the Pure fixture, its log replaced by `rows` (time, user index, video
    index) if given, its basic video features edited by `edit_basic(df)`."""
    d = tmp_path / "pure"
    shutil.copytree(os.path.join(FIXTURES, "pure"), d)
    if rows is not None:
        log = pd.read_csv(d / PURE.log)
        u = log["user_id"].drop_duplicates().to_numpy()
        v = pd.read_csv(d / PURE.video_basic)["video_id"].to_numpy()
        base = log.iloc[0].to_dict()
        new = pd.DataFrame(
            [base | dict(time_ms=t, user_id=u[a], video_id=v[b]) for t, a, b in rows]
        )
        new.astype(log.dtypes.to_dict()).to_csv(d / PURE.log, index=False)
    if edit_basic is not None:
        basic = pd.read_csv(d / PURE.video_basic)
        edit_basic(basic)
        basic.to_csv(d / PURE.video_basic, index=False)
    return str(d)


def test_ring_history_hand_computed():
    """Two slots; user runs A A A B A: each row's own video is written first, at slot
    `place in run mod 2`, so it is in its own state."""
    user = np.array([0, 0, 0, 1, 0])
    action = np.array([5, 6, 7, 8, 9])
    got = data_lib._ring_histories(user, action, 2)
    np.testing.assert_array_equal(got, [[5, -1], [5, 6], [7, 6], [8, -1], [9, -1]])
    assert data_lib._ring_histories(user, action, 0).shape == (5, 0)
    # 20 slots: the 22nd row of a run holds rows 21 and 22 in slots 0 and 1
    long = data_lib._ring_histories(np.zeros(22, int), np.arange(22), 20)
    assert list(long[21, :3]) == [20, 21, 2]


def test_candidate_ties_as_each_protocol_breaks_them(tmp_path):
    """Views v0 x2, v1 x2, v2 x2, v3 x1: the default ranks ties by video id, the public
    pipeline by numpy's argsort of the counts in id order, reversed (the larger id
    first for a small table)."""
    rows = [(t, t % 3, b) for t, b in enumerate([0, 1, 2, 3, 0, 1, 2])]
    d = _pure(tmp_path, rows)
    v = pd.read_csv(os.path.join(d, PURE.video_basic))["video_id"].to_numpy()
    ids = np.sort(v[:4])  # the fixture's ids are sorted: v0 < v1 < v2 < v3
    cfg = data_lib.ProtocolConfig(n_candidates=3, history=2, train_fraction=0.5)
    np.testing.assert_array_equal(data_lib.load(d, cfg).video_ids, ids[:3])
    np.testing.assert_array_equal(data_lib.load(d, cfg, protocol="tscac").video_ids, ids[2::-1])


def test_tscac_keeps_the_file_order_and_ends_episodes_where_the_user_changes(tmp_path):
    rows = [(100, 1, 0), (200, 0, 1), (300, 0, 0), (250, 1, 2), (500, 2, 0), (600, 2, 1)]
    d = _pure(tmp_path, rows)
    cfg = data_lib.ProtocolConfig(n_candidates=3, history=2, train_fraction=0.5)
    data = data_lib.load(d, cfg, protocol="tscac")
    log = pd.read_csv(os.path.join(d, PURE.log))
    np.testing.assert_array_equal(data.user_ids[np.asarray(data.user_index)], log["user_id"])
    np.testing.assert_array_equal(data.video_ids[np.asarray(data.action)], log["video_id"])
    np.testing.assert_array_equal(np.asarray(data.done), [1, 0, 1, 1, 0, 1])
    np.testing.assert_array_equal(np.asarray(data.log_row), np.arange(6))
    # views v0 x3, v1 x2, v2 x1 -> actions 0, 1, 0, 2, 0, 1; the ring holds the current one
    np.testing.assert_array_equal(
        np.asarray(data.history), [[0, -1], [1, -1], [1, 0], [2, -1], [0, -1], [0, 1]]
    )
    assert data.protocol == "tscac" and data.behaviour_rows == (data.n_train, data.n_rows)
    default = data_lib.load(d, cfg)
    assert default.protocol == "default" and default.behaviour_rows == (0, default.n_train)
    assert data_lib.for_test_rows(default) is default


@pytest.mark.parametrize("version", kuairand.VERSIONS)
def test_tscac_on_each_real_layout(version):
    """On an interleaved log the public pipeline's episodes are a row or two long; the
    log rows are the kept rows in file order (`log_row`)."""
    d = os.path.join(FIXTURES, version)
    data = data_lib.load(d, SMALL, protocol="tscac")
    log = pd.read_csv(os.path.join(d, kuairand.LAYOUTS[version].log))
    kept = log[log["video_id"].isin(data.video_ids)]
    np.testing.assert_array_equal(np.asarray(data.log_row), kept.index)
    np.testing.assert_array_equal(data.user_ids[np.asarray(data.user_index)], kept["user_id"])
    changes = np.r_[kept["user_id"].to_numpy()[1:] != kept["user_id"].to_numpy()[:-1], True]
    np.testing.assert_array_equal(np.asarray(data.done), changes)
    assert data.n_rows / data.n_episodes < 2.0 < data_lib.load(d, SMALL).n_rows / len(data.user_ids)
    assert data.state_dim == SMALL.state_dim


def test_tscac_user_block_hand_computed():
    """User features: `is_live_streamer` in place of `friend_user_num_range`, each coded
    by the rank of its frequency over the log's rows; each split z-scored by its own
    rows with 1e-3 added to the standard deviation."""
    d = os.path.join(FIXTURES, "27k")
    data = data_lib.load(d, SMALL, protocol="tscac")
    users = pd.read_csv(os.path.join(d, "user_features_27k.csv")).set_index("user_id")
    per_row = users.loc[data.user_ids[np.asarray(data.user_index)]]
    raw = []
    for col in data_lib.USER_CATEGORICAL_TSCAC:
        counts = per_row[col].reset_index(drop=True).value_counts()
        raw.append(per_row[col].map({v: i for i, v in enumerate(counts.index)}).to_numpy())
    raw = np.stack(raw + [per_row[c].to_numpy() for c in data_lib.USER_ONEHOT], 1).astype(float)
    # the most frequent value is 0
    top = per_row["user_active_degree"].value_counts().index[0]
    assert (raw[per_row["user_active_degree"].to_numpy() == top, 0] == 0).all()
    n = data.n_train
    s = data_lib.states(data, np.arange(n))
    want = (raw[:n] - raw[:n].mean(0)) / (raw[:n].std(0) + 1e-3)
    np.testing.assert_allclose(np.asarray(s)[:, :24], want, atol=1e-5)
    test = data_lib.for_test_rows(data)
    s = data_lib.states(test, np.arange(n, data.n_rows))
    want = (raw[n:] - raw[n:].mean(0)) / (raw[n:].std(0) + 1e-3)
    np.testing.assert_allclose(np.asarray(s)[:, :24], want, atol=1e-5)
    # the history block: each split by its own rows too, so its test mean is about 0
    hist = np.asarray(s)[:, 24 + 60 :]
    np.testing.assert_allclose(hist.mean(0), 0.0, atol=1e-4)
    assert not np.allclose(np.asarray(data.hist_mean), np.asarray(test.hist_mean))


def test_tscac_missing_video_values(tmp_path):
    """A missing music_type is 2 and any other missing value 0 (raw units); the default
    protocol fills both with the candidates' mean."""

    log = pd.read_csv(os.path.join(FIXTURES, "pure", PURE.log))
    first = log["video_id"].value_counts().index[0]  # a candidate under both protocols

    def blank(df):
        df["music_type"] = df["music_type"].astype(float)
        keep = df["video_id"] == first  # one value left, so the column is usable
        df.loc[~keep, ["music_type", "video_duration"]] = np.nan
        df.loc[keep, ["music_type", "video_duration"]] = [4.0, 9_000.0]

    d = _pure(tmp_path, edit_basic=blank)
    tscac = data_lib.load(d, SMALL, protocol="tscac")
    default = data_lib.load(d, SMALL)
    dur, music = (data_lib.VIDEO_FEATURES.index(c) for c in ("video_duration", "music_type"))
    for data, fill in ((tscac, (0.0, 2.0)), (default, (9_000.0, 4.0))):
        raw = np.asarray(data.video_raw)
        others = data.video_ids != first
        assert others.sum() == len(others) - 1
        np.testing.assert_array_equal(raw[others, dur], fill[0])
        np.testing.assert_array_equal(raw[others, music], fill[1])


def test_unknown_protocol_and_cli(capsys):
    d = os.path.join(FIXTURES, "1k")
    with pytest.raises(ValueError, match="unknown protocol 'paper'"):
        data_lib.load(d, SMALL, protocol="paper")
    assert data_lib.main([d, "--candidates", "10", "--protocol", "tscac"]) == 0
    out = capsys.readouterr().out.splitlines()[0]
    data = data_lib.load(d, data_lib.ProtocolConfig(n_candidates=10), protocol="tscac")
    assert f"{data.n_episodes} episodes of mean length {data.n_rows / data.n_episodes:.2f}" in out
    with pytest.raises(SystemExit):
        data_lib.main([d, "--protocol", "paper"])
    assert capsys.readouterr().err.startswith("error:")
