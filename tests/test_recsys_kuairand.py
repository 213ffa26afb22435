"""KuaiRand's three real layouts (committed fixtures in `tests/fixtures/kuairand/`): each
is found by its file names and loads; logs that interleave users in time order become
one episode per user, in time order."""

import filecmp
import os
import shutil
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from wcac_jax.recsys import data as data_lib
from wcac_jax.recsys import kuairand

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FIXTURES = os.path.join(ROOT, "tests", "fixtures", "kuairand")
SMALL = data_lib.ProtocolConfig(n_candidates=10, history=3)

# measured on the committed fixtures (C = 10): kept rows, train rows, users (= episodes)
MEASURED = {"27k": (170, 159, 8), "1k": (229, 215, 6), "pure": (198, 185, 8)}


def _fixture(version):
    return os.path.join(FIXTURES, version)


def test_committed_fixtures_are_what_the_script_writes(tmp_path):
    subprocess.run(
        [sys.executable, os.path.join(FIXTURES, "make_fixtures.py"), "--out", str(tmp_path)],
        check=True,
    )
    for version in kuairand.VERSIONS:
        names = sorted(os.listdir(tmp_path / version))
        assert names == sorted(kuairand.LAYOUTS[version].files)
        assert sorted(os.listdir(_fixture(version))) == names
        _, mismatch, errors = filecmp.cmpfiles(
            tmp_path / version, _fixture(version), names, shallow=False
        )
        assert mismatch == errors == [], (version, mismatch, errors)


@pytest.mark.parametrize("version", kuairand.VERSIONS)
def test_fixture_has_the_real_layout_interleaved_in_time(version):
    layout = kuairand.detect(_fixture(version))
    assert layout.version == version
    for name in layout.standard_logs:
        log = pd.read_csv(os.path.join(_fixture(version), name))
        assert all(pd.api.types.is_integer_dtype(log[c]) for c in log.columns), name
        assert (np.diff(log["time_ms"]) >= 0).all()
        # users interleaved: far more user changes than users
        assert (np.diff(log["user_id"]) != 0).sum() > 5 * log["user_id"].nunique()
    basic = pd.read_csv(os.path.join(_fixture(version), layout.video_basic))
    assert pd.api.types.is_integer_dtype(basic["visible_status"])
    assert pd.api.types.is_float_dtype(basic["video_duration"])


@pytest.mark.parametrize("version", kuairand.VERSIONS)
def test_each_layout_loads_one_episode_per_user_in_time_order(version):
    d = _fixture(version)
    data = data_lib.load(d, SMALL)
    rows, train, users = MEASURED[version]
    assert (data.n_rows, data.n_train, len(data.user_ids)) == (rows, train, users)
    assert data.n_episodes == users
    # the same rows as the log's kept rows, each user's consecutive and in time order
    log = pd.read_csv(os.path.join(d, kuairand.LAYOUTS[version].log))
    kept = log[log["video_id"].isin(data.video_ids)]
    assert len(kept) == rows
    user = data.user_ids[np.asarray(data.user_index)]
    video = data.video_ids[np.asarray(data.action)]
    starts = np.r_[0, np.flatnonzero(np.asarray(data.done))[:-1] + 1]
    assert len(np.unique(user[starts])) == users  # no user twice
    # users in the order of their first kept row
    first = kept.drop_duplicates("user_id")["user_id"].to_numpy()
    np.testing.assert_array_equal(user[starts], first)
    for u in first:
        mine = kept[kept["user_id"] == u]
        np.testing.assert_array_equal(video[user == u], mine["video_id"])
        np.testing.assert_allclose(
            np.asarray(data.reward)[user == u, 0], mine["is_click"].to_numpy()
        )


def test_layout_by_name_and_by_version(tmp_path):
    both = tmp_path / "both"
    shutil.copytree(_fixture("1k"), both)
    for name in os.listdir(_fixture("pure")):
        shutil.copy(os.path.join(_fixture("pure"), name), both)
    with pytest.raises(kuairand.DataError, match=r"KuaiRand-1K and KuaiRand-Pure; choose one"):
        data_lib.load(str(both), SMALL)
    assert data_lib.load(str(both), SMALL, version="pure").n_rows == MEASURED["pure"][0]
    assert data_lib.load(str(both), SMALL, version="1k").n_rows == MEASURED["1k"][0]
    # the version named, its file missing
    with pytest.raises(kuairand.DataError, match=r"log_standard_4_08_to_4_21_27k_part1\.csv: file"):
        data_lib.load(str(both), SMALL, version="27k")
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(kuairand.DataError, match="no KuaiRand file"):
        data_lib.load(str(empty), SMALL)


def test_27k_needs_every_statistics_part(tmp_path):
    d = tmp_path / "d"
    shutil.copytree(_fixture("27k"), d)
    os.remove(d / "video_features_statistic_27k_part3.csv")
    with pytest.raises(kuairand.DataError, match=r"video_features_statistic_27k_part3\.csv: file"):
        data_lib.load(str(d), SMALL)


def test_interleaved_log_hand_computed(tmp_path):
    """Three users interleaved in time order (and one of them out of time order in the
    file): one episode per user, users in the order of their first row."""
    d = tmp_path / "d"
    shutil.copytree(_fixture("pure"), d)
    layout = kuairand.LAYOUTS["pure"]
    log = pd.read_csv(d / layout.log)
    u = log["user_id"].drop_duplicates().to_numpy()[:3]  # A, B, C
    v = pd.read_csv(d / layout.video_basic)["video_id"].to_numpy()[:3]
    a, b, c = u
    #          time  user video  click
    rows = [
        (100, b, v[0], 1),
        (200, a, v[1], 0),
        (300, b, v[1], 1),
        (400, c, v[2], 0),
        (500, a, v[0], 1),
        (700, b, v[2], 0),
        (650, b, v[0], 1),  # before the row above in time
        (800, c, v[0], 1),
        (900, a, v[2], 1),
    ]
    base = log.iloc[0].to_dict()
    new = pd.DataFrame(
        [base | dict(time_ms=t, user_id=w, video_id=x, is_click=k) for t, w, x, k in rows]
    )
    new.astype(log.dtypes.to_dict()).to_csv(d / layout.log, index=False)
    data = data_lib.load(str(d), data_lib.ProtocolConfig(n_candidates=3, history=2))
    # views: v0 x4, v1 x2, v2 x3 -> candidates (v0, v2, v1), actions 0, 2, 1
    np.testing.assert_array_equal(data.video_ids, [v[0], v[2], v[1]])
    user = data.user_ids[np.asarray(data.user_index)]
    # B: t=100 v0, 300 v1, 650 v0, 700 v2; A: 200 v1, 500 v0, 900 v2; C: 400 v2, 800 v0
    np.testing.assert_array_equal(user, [b, b, b, b, a, a, a, c, c])
    np.testing.assert_array_equal(np.asarray(data.action), [0, 2, 0, 1, 2, 0, 1, 1, 0])
    np.testing.assert_array_equal(np.asarray(data.reward)[:, 0], [1, 1, 1, 0, 0, 1, 1, 0, 1])
    np.testing.assert_array_equal(np.asarray(data.done), [0, 0, 0, 1, 0, 0, 1, 0, 1])
    assert data.n_episodes == 3 and data.n_rows / data.n_episodes == 3.0
    np.testing.assert_array_equal(
        np.asarray(data.history),
        [[-1, -1], [0, -1], [2, 0], [0, 2], [-1, -1], [2, -1], [0, 2], [-1, -1], [1, -1]],
    )
    # train/test: round(9 * 450,000 / 480,385) = 8 rows train
    assert data.n_train == 8


@pytest.mark.parametrize("version", kuairand.VERSIONS)
def test_cli_reports_rows_users_episodes(version, capsys):
    assert data_lib.main([_fixture(version), "--candidates", "10", "--history", "3"]) == 0
    rows, train, users = MEASURED[version]
    out = capsys.readouterr().out.splitlines()[0]
    assert out == (
        f"{kuairand.LAYOUTS[version].name} {kuairand.LAYOUTS[version].log}: {rows} rows "
        f"({train} train), {users} users, {users} episodes of mean length "
        f"{rows / users:.2f}, 10 candidates, state {24 + 6 * 13} dims"
    )
    assert data_lib.main([_fixture(version), "--version", version, "--candidates", "10"]) == 0


def _corrupt(tmp_path, version, name, edit):
    """A copy of a fixture with `edit(df)` applied to the file `name`."""
    d = tmp_path / version
    shutil.copytree(_fixture(version), d)
    df = pd.read_csv(d / name)
    edit(df)
    df.to_csv(d / name, index=False)
    return str(d)


def _cli_error(d, capsys):
    code = data_lib.main([d, "--candidates", "10", "--history", "3"])
    err = capsys.readouterr().err.splitlines()
    assert code == 2 and len(err) == 1, (code, err)
    return err[0]


def _set(column, row, value):
    def edit(df):
        if not isinstance(value, int | np.integer):
            df[column] = df[column].astype(object if isinstance(value, str) else float)
        df.loc[row, column] = value

    return edit


PURE = kuairand.LAYOUTS["pure"]


@pytest.mark.parametrize(
    "column, row, value, problem",
    [
        ("play_time_ms", 7, np.inf, "non-finite value inf"),
        ("play_time_ms", 7, -np.inf, "non-finite value -inf"),
        ("play_time_ms", 7, np.nan, "missing value"),
        ("play_time_ms", 7, -5, "value below 0: -5"),
        ("time_ms", 11, -1, "value below 0: -1"),
        ("is_like", 3, 2, "value outside {0, 1}: 2"),
        ("is_hate", 3, -1, "value outside {0, 1}: -1"),
        ("is_click", 5, 0.5, "float value where KuaiRand has int64: 0.5"),
        ("video_id", 9, 12.5, "float value where KuaiRand has int64: 12.5"),
        ("user_id", 9, "u9", "non-numeric value 'u9'"),
    ],
)
def test_bad_log_value_one_line_naming_file_column_row(
    tmp_path, capsys, column, row, value, problem
):
    d = _corrupt(tmp_path, "pure", PURE.log, _set(column, row, value))
    want = f"error: {os.path.join(d, PURE.log)}: column {column!r}: {problem} (data row {row + 1})"
    assert _cli_error(d, capsys) == want


def test_float_ids_are_named_as_floats_not_as_an_empty_split(tmp_path, capsys):
    """A log rewritten with float IDs (`12.0`): the message says so."""

    def as_float(df):
        df["video_id"] = df["video_id"].astype(float)

    d = _corrupt(tmp_path, "pure", PURE.log, as_float)
    first = pd.read_csv(_fixture("pure") + "/" + PURE.log)["video_id"][0]
    assert _cli_error(d, capsys) == (
        f"error: {os.path.join(d, PURE.log)}: column 'video_id': float value where "
        f"KuaiRand has int64: {float(first)!r} (data row 1)"
    )


def _candidates():
    return data_lib.load(_fixture("pure"), SMALL).video_ids


def _row_of_candidate(name):
    df = pd.read_csv(os.path.join(_fixture("pure"), name))
    return int(np.flatnonzero(df["video_id"].isin(_candidates()))[0])


@pytest.mark.parametrize(
    "name, column, value, problem",
    [
        (PURE.user, "onehot_feat5", np.inf, "non-finite value inf"),
        (PURE.user, "onehot_feat5", "x", "non-numeric value 'x'"),
        (PURE.user, "user_id", 3.5, "float value where KuaiRand has int64: 3.5"),
        (PURE.video_basic, "video_duration", np.inf, "non-finite value inf"),
        (PURE.video_basic, "video_id", -3, "value below 0: -3"),
        (PURE.video_statistic[0], "play_duration", -np.inf, "non-finite value -inf"),
    ],
)
def test_bad_feature_value_one_line(tmp_path, capsys, name, column, value, problem):
    row = 2 if name == PURE.user else _row_of_candidate(name)
    d = _corrupt(tmp_path, "pure", name, _set(column, row, value))
    want = f"error: {os.path.join(d, name)}: column {column!r}: {problem} (data row {row + 1})"
    assert _cli_error(d, capsys) == want


@pytest.mark.parametrize(
    "name, column, what",
    [
        (PURE.user, "onehot_feat2", "the log's users"),
        (PURE.user, "fans_user_num_range", "the log's users"),
        (PURE.video_basic, "music_type", "the candidate videos"),
        (PURE.video_statistic[0], "like_cnt", "the candidate videos"),
    ],
)
def test_all_missing_feature_column_one_line(tmp_path, capsys, name, column, what):
    def blank(df):
        df[column] = np.nan

    d = _corrupt(tmp_path, "pure", name, blank)
    row = 1 if name == PURE.user else _row_of_candidate(name) + 1
    # the example row is the first row the protocol uses: the first of the log's users
    if name == PURE.user:
        users = pd.read_csv(os.path.join(d, name))["user_id"]
        first = data_lib.load(_fixture("pure"), SMALL).user_ids[0]
        row = int(np.flatnonzero(users == first)[0]) + 1
    want = (
        f"error: {os.path.join(d, name)}: column {column!r}: every value is missing for "
        f"{what} (data row {row}, ...)"
    )
    assert _cli_error(d, capsys) == want


def test_cli_exit_status_2(tmp_path):
    d = _corrupt(tmp_path, "pure", PURE.log, _set("is_like", 0, 7))
    proc = subprocess.run(
        [sys.executable, "-m", "wcac_jax.recsys.data", d, "--candidates", "10"],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": ROOT},
    )
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.splitlines() == [
        f"error: {os.path.join(d, PURE.log)}: column 'is_like': value outside {{0, 1}}: 7 "
        "(data row 1)"
    ]
