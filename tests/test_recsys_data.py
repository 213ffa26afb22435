"""The KuaiRand loader and protocol, on generated files and on broken ones."""

import os
import shutil

import jax.numpy as jnp
import numpy as np
import pandas as pd
import pytest

from wcac_jax.recsys import data as data_lib
from wcac_jax.recsys import synth

SMALL = data_lib.ProtocolConfig(n_candidates=10, history=3)


@pytest.fixture(scope="module")
def kuairand_dir(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("kuairand"))
    synth.write(synth.SynthConfig(users=40, videos=200, rows=4000, seed=1), out)
    return out


@pytest.fixture(scope="module")
def small(kuairand_dir):
    return data_lib.load(kuairand_dir, SMALL)


def _log(d):
    return pd.read_csv(os.path.join(d, data_lib.LOG_FILE))


def test_keeps_the_most_viewed_videos_by_user_in_time(kuairand_dir, small):
    log = _log(kuairand_dir)
    counts = log["video_id"].value_counts()
    top = sorted(counts.index, key=lambda v: (-counts[v], v))[:10]
    np.testing.assert_array_equal(small.video_ids, top)
    kept = log[log["video_id"].isin(top)].reset_index(drop=True)
    # the log interleaves users in time: each user's rows made consecutive, in time order
    kept = kept.iloc[data_lib.by_user_in_time(kept["user_id"], kept["time_ms"])]
    assert small.n_rows == len(kept)
    np.testing.assert_array_equal(small.video_ids[np.asarray(small.action)], kept["video_id"])
    np.testing.assert_array_equal(small.user_ids[np.asarray(small.user_index)], kept["user_id"])
    expected = kept[list(data_lib.REWARD_COLUMNS)].to_numpy(np.float64)
    expected[:, -1] /= 1e4
    np.testing.assert_allclose(np.asarray(small.reward), expected, rtol=1e-6)
    assert small.n_train == round(len(kept) * data_lib.PAPER_TRAIN_FRACTION)
    # an episode is one user's consecutive rows
    users = kept["user_id"].to_numpy()
    np.testing.assert_array_equal(np.asarray(small.done), np.r_[users[1:] != users[:-1], True])


def test_history_is_the_users_previous_videos_most_recent_first(small):
    action, user, hist = (np.asarray(x) for x in (small.action, small.user_index, small.history))
    for i in range(small.n_rows):
        # the same user's consecutive rows before row i (the log is grouped by user)
        start = i
        while start > 0 and user[start - 1] == user[i]:
            start -= 1
        prev = list(action[start:i][::-1][:3])
        want = prev + [-1] * (3 - len(prev))
        assert list(hist[i]) == want, i


def test_states_have_the_protocol_layout(kuairand_dir, small):
    assert small.state_dim == 24 + 6 * 10 + 6 * 3
    full = data_lib.load(kuairand_dir)
    assert full.state_dim == data_lib.ProtocolConfig().state_dim == 1044
    rows = jnp.arange(small.n_train)
    s = np.asarray(data_lib.states(small, rows))
    assert s.shape == (small.n_train, small.state_dim) and np.isfinite(s).all()
    # z-normalised over the training rows; the constant candidate block is all zeros
    np.testing.assert_allclose(s[:, :24].mean(0), 0.0, atol=1e-4)
    assert np.all(s[:, 24 : 24 + 60] == 0.0)
    np.testing.assert_allclose(s[:, 84:].mean(0), 0.0, atol=1e-4)
    # the user block is the user's label-encoded / onehot features, normalised
    users = pd.read_csv(os.path.join(kuairand_dir, data_lib.USER_FILE)).set_index("user_id")
    raw = users.loc[small.user_ids[np.asarray(small.user_index[: small.n_train])], "onehot_feat7"]
    z = (raw - raw.mean()) / raw.std(ddof=0)
    np.testing.assert_allclose(s[:, 6 + 7], z.to_numpy(), atol=1e-4)


def _broken_copy(src, dst, edit):
    shutil.copytree(src, dst)
    edit(dst)
    return dst


def test_missing_file_names_the_file(kuairand_dir, tmp_path):
    d = _broken_copy(kuairand_dir, tmp_path / "d", lambda d: os.remove(d / data_lib.USER_FILE))
    with pytest.raises(data_lib.DataError, match="user_features_27k.csv: file not found"):
        data_lib.load(str(d), SMALL)
    d2 = _broken_copy(
        kuairand_dir,
        tmp_path / "d2",
        lambda d: [os.remove(d / f) for f in synth.FILES["video_statistic"]],
    )
    with pytest.raises(data_lib.DataError, match="video_features_statistic_27k_part"):
        data_lib.load(str(d2), SMALL)


def test_missing_column_names_file_and_column(kuairand_dir, tmp_path):
    def drop(d):
        p = d / data_lib.LOG_FILE
        pd.read_csv(p).drop(columns=["is_like"]).to_csv(p, index=False)

    d = _broken_copy(kuairand_dir, tmp_path / "d", drop)
    with pytest.raises(data_lib.DataError, match=r"27k_part1\.csv: missing column 'is_like'"):
        data_lib.load(str(d), SMALL)


def test_non_numeric_value_names_file_column_and_value(kuairand_dir, tmp_path):
    def corrupt(d):
        p = d / data_lib.LOG_FILE
        df = pd.read_csv(p)
        df["play_time_ms"] = df["play_time_ms"].astype(object)
        df.loc[7, "play_time_ms"] = "12s"
        df.to_csv(p, index=False)

    d = _broken_copy(kuairand_dir, tmp_path / "d", corrupt)
    with pytest.raises(
        data_lib.DataError, match=r"part1\.csv: column 'play_time_ms': non-numeric value '12s'"
    ):
        data_lib.load(str(d), SMALL)

    def corrupt_user(d):
        p = d / data_lib.USER_FILE
        df = pd.read_csv(p)
        df["onehot_feat3"] = df["onehot_feat3"].astype(object)
        df.loc[0, "onehot_feat3"] = "x"
        df.to_csv(p, index=False)

    d2 = _broken_copy(kuairand_dir, tmp_path / "d2", corrupt_user)
    with pytest.raises(data_lib.DataError, match=r"user_features_27k\.csv: column 'onehot_feat3'"):
        data_lib.load(str(d2), SMALL)


def test_missing_signal_value_is_an_error(kuairand_dir, tmp_path):
    def blank(d):
        p = d / data_lib.LOG_FILE
        df = pd.read_csv(p)
        df["is_click"] = df["is_click"].astype(float)
        df.loc[3, "is_click"] = np.nan
        df.to_csv(p, index=False)

    d = _broken_copy(kuairand_dir, tmp_path / "d", blank)
    with pytest.raises(data_lib.DataError, match=r"column 'is_click': missing value"):
        data_lib.load(str(d), SMALL)


def test_cli_exit_2_one_line(kuairand_dir, tmp_path, capsys):
    assert data_lib.main([str(tmp_path / "nowhere")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and "nowhere" in err[0]
    assert data_lib.main([kuairand_dir]) == 0
    assert "1044 dims" in capsys.readouterr().out
