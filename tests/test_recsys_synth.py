"""The synthetic KuaiRand-27K: files, columns, value ranges, the published signal rates,
the response model's consistency with the drawn logs, and the CLI's bad input."""

import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from wcac_jax.recsys import synth
from wcac_jax.recsys.data import LOG_COLUMNS
from wcac_jax.recsys.kuairand import LAYOUTS

# big enough that every published rate is a whole number of positives within 10 %
CFG = synth.SynthConfig(users=200, videos=220, rows=24_000, seed=3)


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("synth"))
    model = synth.write(CFG, out)
    return out, model


def _standard(out):
    return pd.concat([pd.read_csv(os.path.join(out, f)) for f in synth.FILES["standard"]])


def test_writes_every_kuairand_file_with_its_columns(generated):
    out, _ = generated
    names = [
        *synth.FILES["standard"],
        synth.FILES["random"],
        synth.FILES["user"],
        synth.FILES["video_basic"],
        *synth.FILES["video_statistic"],
    ]
    for name in names:
        assert os.path.isfile(os.path.join(out, name)), name
    for name in (*synth.FILES["standard"], synth.FILES["random"]):
        assert tuple(pd.read_csv(os.path.join(out, name), nrows=1).columns) == synth.LOG_COLUMNS
    users = pd.read_csv(os.path.join(out, synth.FILES["user"]))
    assert list(users.columns[:13]) == [
        "user_id",
        "user_active_degree",
        "is_lowactive_period",
        "is_live_streamer",
        "is_video_author",
        "follow_user_num",
        "follow_user_num_range",
        "fans_user_num",
        "fans_user_num_range",
        "friend_user_num",
        "friend_user_num_range",
        "register_days",
        "register_days_range",
    ]
    assert [f"onehot_feat{j}" for j in range(18)] == list(users.columns[13:])
    assert pd.api.types.is_string_dtype(users["user_active_degree"])
    assert set(users["is_live_streamer"]) <= {0, 1, -124}
    basic = pd.read_csv(os.path.join(out, synth.FILES["video_basic"]))
    assert {"video_id", "author_id", "video_type", "video_duration", "music_type", "tag"} <= set(
        basic.columns
    )
    assert set(basic["video_type"]) <= {"NORMAL", "AD"}
    assert basic["tag"].astype(str).str.fullmatch(r"\d+(,\d+)*").all()
    stats = pd.concat([pd.read_csv(os.path.join(out, f)) for f in synth.FILES["video_statistic"]])
    assert len(stats) == CFG.videos
    assert {"play_user_num", "play_duration", "like_cnt", "show_cnt"} <= set(stats.columns)


def test_log_values_have_kuairand_types_and_ranges(generated):
    out, _ = generated
    log = pd.read_csv(os.path.join(out, synth.FILES["standard"][0]))
    assert len(log) == CFG.rows
    assert set(LOG_COLUMNS) <= set(log.columns)
    for col in synth.LOG_COLUMNS:
        assert pd.api.types.is_integer_dtype(log[col]), col
    for col in (
        "is_click",
        "is_like",
        "is_follow",
        "is_comment",
        "is_forward",
        "is_hate",
        "long_view",
        "is_profile_enter",
    ):
        assert set(log[col]) <= {0, 1}, col
    assert log["date"].between(20220408, 20220421).all()
    assert log["tab"].between(0, 14).all() and (log["is_rand"] == 0).all()
    assert (log["play_time_ms"] >= 0).all() and (log["play_time_ms"] <= log["duration_ms"]).all()
    # grouped by user, time increasing within a user: episodes are consecutive rows
    assert (np.diff(log["user_id"]) >= 0).all()
    same = np.diff(log["user_id"]) == 0
    assert (np.diff(log["time_ms"])[same] >= 0).all()
    rand = pd.read_csv(os.path.join(out, synth.FILES["random"]))
    assert (rand["is_rand"] == 1).all() and rand["date"].between(20220422, 20220508).all()


def test_standard_log_rates_within_10_percent_of_kuairand_pure(generated):
    out, _ = generated
    log = _standard(out)
    for col, rate in synth.PURE_RATES.items():
        assert abs(log[col].mean() / rate - 1.0) <= 0.10, (col, log[col].mean(), rate)


def test_response_model_matches_the_drawn_logs(generated):
    """The truth the generator exposes is the model the logs were drawn from."""
    out, model = generated
    log = _standard(out)
    expected = model.expected(log["user_id"].to_numpy(), log["video_id"].to_numpy()).mean(0)
    drawn = [log[c].mean() for c in ("is_click", "is_like", "is_follow")]
    np.testing.assert_allclose(expected[:3], drawn, rtol=0.05)
    np.testing.assert_allclose(expected[6], log["play_time_ms"].mean() / 1e4, rtol=0.05)
    # the random log is drawn independently (plain Bernoulli) from the same model
    rand = pd.read_csv(os.path.join(out, synth.FILES["random"]))
    r_exp = model.expected(rand["user_id"].to_numpy(), rand["video_id"].to_numpy()).mean(0)
    assert abs(r_exp[0] - rand["is_click"].mean()) < 4 * np.sqrt(r_exp[0] / len(rand))
    loaded = synth.ResponseModel.load(os.path.join(out, synth.MODEL_FILE))
    np.testing.assert_array_equal(loaded.expected([0, 1], [5, 7]), model.expected([0, 1], [5, 7]))


def test_signals_are_correlated_and_partly_in_conflict(generated):
    """Over (user, video) pairs, the true like and watch-time rates co-move through the
    affinity but pull apart on duration; comments and dislikes share controversy."""
    _, model = generated
    e = model.expected(model.user_ids[:, None], model.video_ids[None, :]).reshape(-1, 7)
    corr = np.corrcoef(e.T)
    assert corr[0, 1] > 0.1 and corr[0, 6] > 0.1  # click with like and with watch time
    dur = np.broadcast_to(model.traits[:, 5], (len(model.user_ids), len(model.video_ids)))
    like_per_ms = np.corrcoef(np.log(dur.reshape(-1)), np.log(e[:, 1]))[0, 1]
    watch_per_ms = np.corrcoef(np.log(dur.reshape(-1)), np.log(e[:, 6]))[0, 1]
    assert like_per_ms < 0 < watch_per_ms
    # controversy (trait 2) raises comments and dislikes together
    controversy = np.broadcast_to(model.traits[:, 2], dur.shape).reshape(-1)
    assert np.corrcoef(controversy, np.log(e[:, 3]))[0, 1] > 0.2
    assert np.corrcoef(controversy, np.log(e[:, 5]))[0, 1] > 0.2


def test_same_seed_same_data():
    cfg = synth.SynthConfig(users=20, videos=30, rows=500, seed=7)
    a, _ = synth.generate(cfg)
    b, _ = synth.generate(cfg)
    for name in a:
        pd.testing.assert_frame_equal(a[name], b[name])


@pytest.mark.parametrize(
    "args, word",
    [
        (["--users", "1"], "--users"),
        (["--rows", "-5"], "--rows"),
        (["--seed", "-1"], "--seed"),
        (["--videos", "0"], "--videos"),
        (["--users", "abc"], "--users"),
    ],
)
def test_cli_bad_input_one_line_exit_2_nothing_written(tmp_path, capsys, args, word):
    out = tmp_path / "out"
    try:
        code = synth.main(["--out", str(out), *args])
    except SystemExit as exit_:  # argparse's own errors (a non-integer) exit directly
        code = exit_.code
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and word in err[0]
    assert not out.exists()


def test_cli_writes_a_small_set(tmp_path):
    out = tmp_path / "new" / "d"  # missing parents are made, as the sweep's --out
    assert synth.main(["--out", str(out), "--users", "10", "--videos", "20", "--rows", "200"]) == 0
    assert len(pd.read_csv(out / synth.FILES["standard"][0])) == 200


def test_cli_refuses_an_out_it_cannot_make(tmp_path, capsys):
    a_file = tmp_path / "a_file"
    a_file.write_text("")
    for out in (a_file, a_file / "d"):
        assert synth.main(["--out", str(out), "--users", "10"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"{str(a_file)!r} is not a directory" in err[0]
    assert a_file.read_text() == ""


def _tree(d):
    return {p.relative_to(d): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


def test_writes_kuairand_27k_names():
    names = [*synth.FILES["standard"], synth.FILES["random"], synth.FILES["user"]]
    names += [synth.FILES["video_basic"], *synth.FILES["video_statistic"]]
    assert set(names) <= set(LAYOUTS["27k"].files)


def test_cli_refuses_to_write_over_kuairand_files(tmp_path, capsys):
    out = tmp_path / "d"
    args = ["--out", str(out), "--users", "10", "--videos", "20", "--rows", "200"]
    assert synth.main(args) == 0
    before = _tree(out)
    capsys.readouterr()
    assert synth.main([*args, "--seed", "1"]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"error: --out {str(out)!r} already holds KuaiRand's "
        "log_standard_4_08_to_4_21_27k_part1.csv; pass --overwrite to replace it"
    ]
    assert _tree(out) == before
    # a real log of another layout is protected too, and nothing is added beside it
    pure = tmp_path / "pure"
    pure.mkdir()
    (pure / "log_standard_4_08_to_4_21_pure.csv").write_text("user_id\n1\n")
    assert synth.main(["--out", str(pure), "--users", "10"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "log_standard_4_08_to_4_21_pure.csv; pass --overwrite" in err[0]
    assert _tree(pure) == {Path("log_standard_4_08_to_4_21_pure.csv"): b"user_id\n1\n"}
    # --overwrite replaces them
    assert synth.main([*args, "--seed", "1", "--overwrite"]) == 0
    after = _tree(out)
    assert set(after) == set(before)
    assert after[Path(synth.FILES["standard"][0])] != before[Path(synth.FILES["standard"][0])]
