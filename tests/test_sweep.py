"""`python -m wcac_jax.sweep` end to end on tiny bandit settings: outputs, chunking,
SIGKILL + resume, two devices, bad input, NaN."""

import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys

import jax
import mujoco
import numpy as np
import pytest
from sweep_args import TINY_BANDIT

from wcac_jax import pareto, sweep
from wcac_jax.sweep import cli

TINY = [*TINY_BANDIT, "--quiet"]
# slow enough (about a second per chunk) that a SIGKILL lands between chunks
SLOW = [
    "--env",
    "concave_bandit",
    "--n-prefs",
    "3",
    "--envs-per-pref",
    "64",
    "--critic-steps",
    "2",
    "--rollout-steps",
    "4",
    "--network",
    "mlp",
    "--width",
    "256",
    "--depth",
    "2",
    "--steps-per-pref",
    "60000",
    "--chunks",
    "10",
    "--eval-episodes",
    "2",
]


def _cli(args, env=None, **kwargs):
    return subprocess.run(
        [sys.executable, "-m", "wcac_jax.sweep", *args],
        capture_output=True,
        text=True,
        env={**os.environ, **(env or {})},
        **kwargs,
    )


def _load(out):
    with open(os.path.join(out, "front.json")) as f:
        front = json.load(f)
    with np.load(os.path.join(out, "curves.npz")) as data:
        curves = {k: data[k] for k in data.files}
    return front, curves


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory, jax_cache):
    out = str(tmp_path_factory.mktemp("sweep") / "run")
    proc = _cli([*TINY, "--n-prefs", "4", "--chunks", "3", "--out", out], env=jax_cache)
    assert proc.returncode == 0, proc.stderr
    return out


def test_every_traced_scalarization_is_one_compiled_program(tiny_run, jax_cache, tmp_path):
    """The sweep passes `smooth_wc`, `wc` or `linear` to its training program as a traced
    index, so a sweep in another direction of the same configuration is the same program:
    JAX's persistent compilation cache serves all it compiles (no entry is added)."""
    cache = jax_cache["JAX_COMPILATION_CACHE_DIR"]
    before = {f for f in os.listdir(cache) if f.endswith("-cache")}
    assert any(f.startswith("jit_chunk") for f in before), sorted(before)
    args = ["--n-prefs", "4", "--chunks", "3", "--scalarization", "linear"]
    proc = _cli([*TINY, *args, "--out", str(tmp_path / "linear")], jax_cache)
    assert proc.returncode == 0, proc.stderr
    assert {f for f in os.listdir(cache) if f.endswith("-cache")} == before


def test_outputs_exist_parse_and_agree(tiny_run):
    for name in ("front.json", "front.csv", "front.png", "curves.npz", "config.json"):
        assert os.path.getsize(os.path.join(tiny_run, name)) > 0, name
    assert os.listdir(os.path.join(tiny_run, "checkpoint"))
    front, curves = _load(tiny_run)
    assert len(front["prefs"]) == 4
    assert front["objective_names"] == ["one_minus_sin", "one_minus_cos"]
    assert front["versions"]["jax"] == jax.__version__
    assert front["versions"]["mujoco"] == mujoco.__version__
    np.testing.assert_allclose([r["pref"] for r in front["prefs"]], curves["prefs"])
    t = front["config"]["train"]["num_iterations"]
    assert curves["train/weights"].shape == (4, t, 2)
    for i, row in enumerate(front["prefs"]):
        np.testing.assert_allclose(row["lambda"], curves["train/weights"][i, -1], rtol=1e-6)
        assert row["g_mu"] == pytest.approx(float(curves["train/g_mu"][i, -1]), rel=1e-6)
        np.testing.assert_allclose(row["j_hat"], curves["train/j_hat"][i, -1], rtol=1e-6)
        assert len(row["return"]) == len(row["discounted_return"]) == 2
    assert front["env_steps_per_pref"] == int(curves["train/env_steps"][0, -1])
    # the metrics, recomputed from the saved returns by independent code (pymoo's HV,
    # brute-force dominance)
    assert front["hv_ref"] == [0.0, 0.0]  # the bandit's default_hv_ref
    returns = np.array([row["return"] for row in front["prefs"]])
    ref = np.array(front["hv_ref"])
    inside = np.all(returns > ref, axis=1)
    from pymoo.indicators.hv import HV

    expected_hv = HV(ref_point=-ref)(-returns[inside]) if inside.any() else 0.0
    assert front["hypervolume"] == pytest.approx(expected_hv, rel=1e-9)
    assert front["outside_hv_ref"] == np.flatnonzero(~inside).tolist()
    for i, (row, p) in enumerate(zip(front["prefs"], returns, strict=True)):
        dominated = any(np.all(q >= p) and np.any(q > p) for q in returns)
        duplicate = any(np.array_equal(returns[j], p) for j in range(i))
        assert row["nondominated"] == (not dominated and not duplicate), i
        assert row["inside_hv_ref"] == bool(inside[i])
    lines = open(os.path.join(tiny_run, "front.csv")).read().strip().splitlines()
    assert len(lines) == 5 and lines[0].startswith("pref_one_minus_sin")
    with open(os.path.join(tiny_run, "config.json")) as f:
        assert json.load(f) == front["config"]


def test_chunking_does_not_change_results(tiny_run, tmp_path):
    front3, curves3 = _load(tiny_run)
    config = cli.config_from_args(cli.build_parser().parse_args([*TINY, "--n-prefs", "4"]))
    front1 = sweep.run_sweep(config, str(tmp_path / "one"), chunks=1, progress=False)
    _, curves1 = _load(str(tmp_path / "one"))
    for k in curves3:
        np.testing.assert_array_equal(curves1[k], curves3[k], err_msg=k)
    for a, b in zip(front1["prefs"], front3["prefs"], strict=True):
        assert a["return"] == b["return"]


def test_load_sweep_restores_the_trained_state(tiny_run, tmp_path):
    import jax

    run = sweep.load_sweep(tiny_run)
    with open(os.path.join(tiny_run, "config.json")) as f:
        assert run.config.to_dict() == json.load(f)
    _, curves = _load(tiny_run)
    t = run.config.num_iterations
    np.testing.assert_array_equal(np.asarray(run.state.iteration), [t] * 4)
    for k, v in run.metrics.items():
        np.testing.assert_array_equal(v, curves[k], err_msg=k)
    # trained, not freshly initialised: the actor moved from the sweep's own initial
    # parameters (preference i starts from fold_in(key(seed), i))
    keys = jax.vmap(lambda i: jax.random.fold_in(jax.random.key(run.config.seed), i))(np.arange(4))
    fresh = jax.vmap(run.trainer.init)(keys, np.asarray(run.config.prefs, np.float32))
    moved = jax.tree.map(
        lambda a, b: float(np.abs(np.asarray(a) - np.asarray(b)).max()),
        run.state.actor.trainable,
        fresh.actor.trainable,
    )
    assert min(jax.tree.leaves(moved)) > 0
    # one preference's state replays on: the next iteration is finite and counted
    state0 = jax.tree.map(lambda leaf: leaf[0], run.state)
    state1, metrics = jax.jit(run.trainer.step)(state0, np.asarray(run.config.prefs[0]))
    assert int(state1.iteration) == t + 1
    assert all(np.isfinite(np.asarray(v)).all() for v in metrics.values())
    with pytest.raises(sweep.SweepError, match="no sweep in"):
        sweep.load_sweep(str(tmp_path))
    (tmp_path / "config.json").write_text("{not json")
    with pytest.raises(sweep.SweepError, match="is not readable JSON"):
        sweep.load_sweep(str(tmp_path))


@pytest.mark.slow
def test_sigkill_then_resume_equals_uninterrupted(tmp_path):
    out = str(tmp_path / "killed")
    proc = subprocess.Popen(
        [sys.executable, "-m", "wcac_jax.sweep", *SLOW, "--out", out],
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        text=True,
    )
    for line in proc.stderr:  # plain progress lines: one per saved chunk
        if line.startswith("[sweep]") and "env steps" in line:
            proc.send_signal(signal.SIGKILL)
            break
    proc.wait()
    assert proc.returncode == -signal.SIGKILL
    assert not os.path.exists(os.path.join(out, "front.json"))  # really interrupted
    assert os.listdir(os.path.join(out, "checkpoint"))  # after a saved chunk
    resumed = _cli([*SLOW, "--out", out, "--resume"])
    assert resumed.returncode == 0, resumed.stderr
    full = _cli([*SLOW, "--out", str(tmp_path / "full")])
    assert full.returncode == 0, full.stderr
    front_r, curves_r = _load(out)
    front_f, curves_f = _load(str(tmp_path / "full"))
    for k in curves_f:
        np.testing.assert_array_equal(curves_r[k], curves_f[k], err_msg=k)
    assert [r["return"] for r in front_r["prefs"]] == [r["return"] for r in front_f["prefs"]]


@pytest.mark.slow
def test_two_devices_match_one(tiny_run, tmp_path):
    out = str(tmp_path / "two")
    proc = _cli(
        [*TINY, "--prefs", "1,0;0.5,0.5;0,1", "--chunks", "3", "--out", out],
        env={"XLA_FLAGS": "--xla_force_host_platform_device_count=2"},
    )
    assert proc.returncode == 0, proc.stderr
    one = str(tmp_path / "one")
    proc = _cli([*TINY, "--prefs", "1,0;0.5,0.5;0,1", "--chunks", "3", "--out", one])
    assert proc.returncode == 0, proc.stderr
    front2, curves2 = _load(out)
    front1, curves1 = _load(one)
    assert len(front2["devices"]) == 2 and len(front1["devices"]) == 1
    assert len(front2["prefs"]) == 3  # the padding preference is dropped
    for k in curves1:
        if curves1[k].dtype.kind in "fiu":
            np.testing.assert_allclose(curves2[k], curves1[k], rtol=1e-5, atol=1e-6, err_msg=k)
        else:
            np.testing.assert_array_equal(curves2[k], curves1[k], err_msg=k)
    np.testing.assert_allclose(
        [r["return"] for r in front2["prefs"]],
        [r["return"] for r in front1["prefs"]],
        rtol=1e-5,
    )


def test_default_hv_ref_of_every_environment():
    from wcac_jax import envs

    for name in envs.names():
        env = envs.make(name)
        assert len(sweep.default_hv_ref(env)) == env.num_objectives, name
    assert sweep.default_hv_ref(envs.make("concave_bandit")) == (0.0, 0.0)
    # walker2d: per step -1 forward and -6 control (its least reward), times the limit
    assert sweep.default_hv_ref(envs.make("walker2d", episode_length=100)) == (-100.0, -600.0)
    # Deep Sea Treasure: no treasure, every step of the limit spent; its time objective
    # is negative, so the old (0, 0) gave every front a hypervolume of 0
    dst = envs.make("deep_sea_treasure", episode_length=100)
    ref = sweep.default_hv_ref(dst)
    assert ref == (0.0, -100.0)
    # treasure 1 one step down, treasure 124 after 19 steps: 124 * 81 + 1 * 18
    pts = [[1.0, -1.0], [124.0, -19.0]]
    assert pareto.hypervolume(pts, ref) == pytest.approx(124 * 81 + 18)
    assert not pareto.outside_reference(pts, ref).any()


BAD = [
    (["--prefs", "1,0,0;0,1"], "has 3 entries"),
    (["--prefs", "1.5,-0.5"], "negative"),
    (["--prefs", "nan,1"], "not finite"),
    (["--prefs", "0.5,0.4"], "sums to 0.9"),
    (["--prefs", "a,b"], "'a,b'"),
    (["--n-prefs", "0"], "--n-prefs must be >= 1, got 0"),
    (["--mu", "0"], "mu must be > 0, got 0.0"),
    (["--mu", "-1"], "mu must be > 0, got -1.0"),
    (["--j-ub", "1,2,3"], r"--j-ub \[1.0, 2.0, 3.0\] has 3 entries"),
    (["--env", "atari"], "'atari'; valid: ant, .*concave_bandit, .*humanoid, .*walker2d"),
    (["--physics", "bullet"], "'physics'"),
    (["--scalarization", "max"], "'max'"),
    (["--steps-per-pref", "0"], "--steps-per-pref must be a positive integer, got 0"),
    (["--eval-episodes", "0"], "--eval-episodes must be a positive integer, got 0"),
    (["--hv-ref", "nan,nan"], r"--hv-ref must be finite, got \[nan, nan\]"),
    (["--hv-ref", "1,2,3"], r"--hv-ref \[1.0, 2.0, 3.0\] has 3 entries"),
    (["--seed", "1180591620717411303424"], "seed .*got 1180591620717411303424"),
    # more iterations than the int32 counter holds
    (["--steps-per-pref", "10000000000000"], "--steps-per-pref 10000000000000 needs"),
    # fewer iterations than that, but more metrics than the machine's memory
    (["--steps-per-pref", "100000000000"], "--steps-per-pref 100000000000 needs .* GiB"),
    (["--mu", "inf"], "mu must be finite in float32 .*got inf"),
    (["--actor-lr", "inf"], "--actor-lr must be finite in float32 .*got inf"),
    (["--critic-lr", "nan"], "--critic-lr must be > 0, got nan"),
    (["--j-ub", "1e39,1"], r"--j-ub must be finite in float32 .*got \[1e\+39, 1.0\]"),
    (["--select-last", "0"], "--select-last must be a positive integer, got 0"),
    (["--select-last", "3"], "--select-last 3 needs --select-every >= 1 .*got 0"),
    (["--select-last", "2", "--select-every", "-1"], "--select-every must be a non-negative .*-1"),
    # 1200 env steps are 25 iterations of 48: 2 candidates 30 iterations apart don't fit
    (["--select-last", "2", "--select-every", "1440"], "need more than 30 .* the sweep has 25"),
    # one candidate (the bandit's default, the final policy): a spacing would be ignored
    (["--select-every", "20480"], "--select-every 20480 spaces .* it would be ignored"),
    (["--select-last", "1", "--select-every", "96"], "--select-every 96 spaces"),
    # checked before the preferences are made (a numpy MemoryError before)
    (["--n-prefs", "1000000000"], r"--n-prefs 1,000,000,000 needs at least .* GiB .* has"),
    (["--resume", "--overwrite"], "--resume continues the sweep in --out and --overwrite"),
]


def _assert_rejected(argv, message, out, capsys):
    """`argv` exits 2 with one `error:` line matching `message`, and `out` is not made."""
    rc = cli.main([*argv, "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2
    assert len(err.strip().splitlines()) == 1 and err.startswith("error: ")
    assert __import__("re").search(message, err), err
    assert not out.exists()


@pytest.mark.parametrize("args,message", BAD, ids=[" ".join(a) for a, _ in BAD])
def test_bad_input_exits_2_and_writes_nothing(args, message, tmp_path, capsys):
    _assert_rejected([*TINY, *args], message, tmp_path / "out", capsys)


PRACTICAL = ["--env", "concave_bandit", "--preset", "practical", "--quiet"]
BAD_PRACTICAL = [
    (["--utopia", "fixed", "--j-ub", "1e39,1"], r"--j-ub must be finite in float32"),
    (["--mu", "1e39"], "mu must be finite in float32, got 1e[+]39"),
    (["--utopia", "guess"], "'guess'"),
]


@pytest.mark.parametrize("args,message", BAD_PRACTICAL, ids=[" ".join(a) for a, _ in BAD_PRACTICAL])
def test_bad_practical_input_exits_2_and_writes_nothing(args, message, tmp_path, capsys):
    _assert_rejected([*PRACTICAL, *args], message, tmp_path / "out", capsys)


def _tree(path):
    """Every file under `path` with its size and modification time."""
    out = {}
    for root, _, files in os.walk(path):
        for name in files:
            st = os.stat(os.path.join(root, name))
            out[os.path.relpath(os.path.join(root, name), path)] = (st.st_size, st.st_mtime_ns)
    return out


def test_resume_into_a_read_only_directory_exits_2(tiny_run, capsys, monkeypatch):
    # running as root, chmod cannot make a directory unwritable: os.access reports it
    real_access = os.access
    monkeypatch.setattr(
        os,
        "access",
        lambda path, mode: False if os.path.abspath(path) == tiny_run else real_access(path, mode),
    )
    before = _tree(tiny_run)
    rc = cli.main([*TINY, "--n-prefs", "4", "--chunks", "3", "--out", tiny_run, "--resume"])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1, err
    assert f"{tiny_run!r} is not writable" in err
    assert _tree(tiny_run) == before


def test_resume_of_a_finished_sweep_says_so_and_changes_nothing(tiny_run, capsys):
    before = _tree(tiny_run)
    content = {name: open(os.path.join(tiny_run, name), "rb").read() for name in before}
    rc = cli.main([*TINY_BANDIT, "--n-prefs", "4", "--chunks", "3", "--out", tiny_run, "--resume"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    assert (out + err).splitlines() == [
        f"{tiny_run} is finished (its front.json is written): --resume has nothing to do"
    ]
    assert _tree(tiny_run) == before
    assert all(open(os.path.join(tiny_run, n), "rb").read() == b for n, b in content.items())
    # the same sweep only: another configuration is still an error
    rc = cli.main([*TINY, "--n-prefs", "4", "--seed", "1", "--out", tiny_run, "--resume"])
    assert rc == 2 and "seed" in capsys.readouterr().err
    assert _tree(tiny_run) == before


@pytest.mark.parametrize("text", ["{not json", "[1, 2]"])
def test_resume_with_a_corrupt_config_exits_2(tmp_path, capsys, text):
    out = tmp_path / "run"
    out.mkdir()
    (out / "config.json").write_text(text)
    before = _tree(out)
    rc = cli.main([*TINY, "--n-prefs", "2", "--out", str(out), "--resume"])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1, err
    assert "config.json" in err and ("not readable JSON" in err or "no sweep config" in err)
    assert _tree(out) == before


def _contents(path):
    """Every file under `path` with its bytes."""
    return {name: open(os.path.join(path, name), "rb").read() for name in _tree(path)}


def test_a_non_empty_out_is_refused_without_resume_or_overwrite(tiny_run, tmp_path, capsys):
    before = _contents(tiny_run)
    rc = cli.main([*TINY, "--n-prefs", "4", "--seed", "1", "--out", tiny_run])
    err = capsys.readouterr().err
    assert rc == 2 and err.splitlines() == [
        f"error: --out {tiny_run!r} is not empty (--resume continues its sweep, --overwrite "
        "replaces it)"
    ]
    assert _contents(tiny_run) == before
    other = tmp_path / "other"  # any file makes a directory not empty
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    rc = cli.main([*TINY, "--n-prefs", "2", "--out", str(other)])
    assert rc == 2 and "is not empty" in capsys.readouterr().err
    assert _contents(other) == {"notes.txt": b"mine"}


def test_overwrite_replaces_the_results_only_once_finished(tiny_run, tmp_path, capsys):
    out = str(tmp_path / "run")
    shutil.copytree(tiny_run, out)
    with open(os.path.join(out, "notes.txt"), "w") as f:
        f.write("old")
    before = _contents(out)
    args = [*TINY, "--n-prefs", "4", "--chunks", "3", "--seed", "1"]
    config = cli.config_from_args(cli.build_parser().parse_args(args))
    # interrupted: the old results stay as they were; the partial run is beside them
    stopped = sweep.run_sweep(
        config, out, overwrite=True, chunks=3, progress=False, stop_after_chunks=1
    )
    assert stopped["interrupted"]
    assert _contents(out) == before
    staging = sweep.staging_dir(out)
    assert os.path.dirname(staging) == str(tmp_path) and os.listdir(staging)
    # finished: the new sweep in place of the old, and nothing of the old left
    rc = cli.main([*args, "--out", out, "--overwrite"])
    assert rc == 0, capsys.readouterr().err
    assert sorted(os.listdir(tmp_path)) == ["run"]
    assert "notes.txt" not in os.listdir(out)
    front, _ = _load(out)
    assert front["config"]["seed"] == 1
    fresh = sweep.run_sweep(config, str(tmp_path / "fresh"), chunks=3, progress=False)
    assert [r["return"] for r in front["prefs"]] == [r["return"] for r in fresh["prefs"]]


def test_front_json_is_written_last(tiny_run, tmp_path, monkeypatch):
    """`front.json` marks a sweep finished (`--resume` then has nothing to do), so a
    write interrupted before it leaves none, and `--resume` writes them all."""
    from wcac_jax import plot
    from wcac_jax.sweep import outputs

    front, curves = _load(tiny_run)
    out = tmp_path / "out"
    out.mkdir()

    def broken(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(plot, "plot_front", broken)
    with pytest.raises(KeyboardInterrupt):
        metrics = {k: v for k, v in curves.items() if k.startswith("train/")}
        outputs.write_outputs(str(out), front, metrics, curves["prefs"])
    assert sorted(os.listdir(out)) == ["curves.npz", "front.csv"]  # no temporaries either


def test_a_budget_that_rounds_says_what_runs(capsys):
    """1 env step per preference is one iteration of N (K + L) = 8 (4 + 2) = 48: a note
    states the budget that runs; a budget of whole iterations gets none."""
    for steps, note in [
        ("1", "1 env steps per preference round up to 1 iterations of 48: training runs 48"),
        (
            "1000",
            "1,000 env steps per preference round up to 21 iterations of 48: training runs 1,008",
        ),
    ]:
        args = [*TINY_BANDIT, "--n-prefs", "2", "--steps-per-pref", steps]
        config = cli.config_from_args(cli.build_parser().parse_args(args))
        assert config.num_iterations * 48 == int(note.rsplit(" ", 1)[1].replace(",", ""))
        assert capsys.readouterr().err.splitlines() == [f"note: {note}"]
    args = [*TINY_BANDIT, "--n-prefs", "2", "--select-last", "3", "--select-every", "160"]
    cli.config_from_args(cli.build_parser().parse_args(args))  # 1200 = 25 iterations
    assert capsys.readouterr().err.splitlines() == [
        "note: --select-every 160 rounds up to 4 iterations (192 env steps)"
    ]
    cli.config_from_args(cli.build_parser().parse_args([*TINY, "--steps-per-pref", "1"]))
    assert capsys.readouterr().err == ""  # --quiet


def test_unwritable_out_exits_2(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    rc = cli.main([*TINY, "--n-prefs", "2", "--out", str(blocker / "sub")])
    assert rc == 2 and "can't be written" in capsys.readouterr().err
    assert not (blocker / "sub").exists()


def test_resume_with_a_different_config_names_the_keys(tiny_run, capsys):
    before = sorted(os.listdir(tiny_run))
    rc = cli.main([*TINY, "--n-prefs", "4", "--mu", "0.5", "--out", tiny_run, "--resume"])
    err = capsys.readouterr().err
    assert rc == 2 and "--mu 0.5 (it has 0.05)" in err
    assert sorted(os.listdir(tiny_run)) == before


def test_nan_stops_the_sweep_naming_preference_and_iteration(tmp_path, capsys):
    out = tmp_path / "nan"
    # a huge actor step (the default critics are projected onto B = 1.0, so a huge critic
    # step no longer diverges)
    rc = cli.main([*TINY, "--n-prefs", "2", "--actor-lr", "1e38", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 3
    assert "NaN" in err and "preference #" in err and "iteration" in err, err
    assert not (out / "front.json").exists()


def test_chunk_padding_runs_no_iterations():
    """The last chunk's padding (iterations past `n_iters`) is skipped, not trained in
    full and thrown away: a step that reports each call to the host sees only the real
    iterations, and padded ones leave the state as it is with zero metrics."""
    from typing import NamedTuple

    import jax
    import jax.numpy as jnp

    from wcac_jax.core.runtime import Trainer
    from wcac_jax.core.utopia import PREF_AXIS

    class State(NamedTuple):
        iteration: jax.Array
        total: jax.Array

    calls = []

    def step(state, pref):
        jax.debug.callback(lambda it: calls.append(int(it)), state.iteration)
        new = State(state.iteration + 1, state.total + pref[0])
        return new, {"seen": state.iteration + 1}

    trainer = Trainer(None, None, step, None, None, None, None, None)
    n_iters, chunk_len = 5, 3  # the second chunk runs 2 iterations and pads 1
    chunk = jax.jit(jax.vmap(sweep.make_chunk(trainer, chunk_len), axis_name=PREF_AXIS))
    state = State(jnp.zeros(2, jnp.int32), jnp.zeros(2))
    prefs = jnp.array([[1.0, 0.0], [0.5, 0.5]])
    stop = jnp.full(2, n_iters, jnp.int32)
    state, first = chunk(state, stop, prefs)
    state, second = chunk(state, stop, prefs)
    jax.effects_barrier()
    np.testing.assert_array_equal(state.iteration, [5, 5])
    np.testing.assert_allclose(state.total, [5.0, 2.5])
    np.testing.assert_array_equal(first["seen"], [[1, 2, 3]] * 2)
    np.testing.assert_array_equal(second["seen"], [[4, 5, 0]] * 2)
    # 2 preferences x 5 real iterations; the padded 6th never ran (a per-preference
    # predicate gave 12 calls, iteration 5 included)
    assert sorted(calls) == sorted(list(range(5)) * 2), calls


PLAIN_LINE = re.compile(r"\[sweep\] ([\d,]+)/([\d,]+) env steps, [\d,]+ env-steps/s, ETA [\d,]+ s")


def test_a_log_gets_one_progress_line_per_chunk(tmp_path, capsys):
    """With stderr a file (not a terminal), the sweep reports in plain lines: that it
    compiles, then after each checkpointed chunk the env steps done of all, the chunk's
    env-steps/s and the time left."""
    out = tmp_path / "run"
    argv = [*TINY_BANDIT, "--n-prefs", "4", "--chunks", "3", "--out", str(out)]
    assert cli.main(argv) == 0
    err = capsys.readouterr().err.splitlines()
    assert err[0] == "[sweep] compiling the training program for 4 preferences"
    done = [PLAIN_LINE.fullmatch(text) for text in err[1:]]
    assert all(done) and len(done) == 3, err
    # 25 iterations of 48 env steps per preference, 4 preferences, in chunks of
    # ceil(25 / 3) = 9 iterations
    assert [m.group(1) for m in done] == ["1,728", "3,456", "4,800"]
    assert {m.group(2) for m in done} == {"4,800"}
    assert (out / "front.json").exists()


def test_a_terminal_bar_cuts_chunks_into_calls_and_changes_no_number(
    tiny_run, tmp_path, monkeypatch
):
    """On a terminal the sweep calls its program for a few seconds of training at a time
    (`progress.Pace`), so that the bar moves within a chunk; here one iteration per call.
    Every number is the same as the run with one call per chunk."""
    from wcac_jax.sweep import progress

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    calls = []
    record = progress.Pace.record
    monkeypatch.setattr(progress, "UPDATE_SECONDS", 0.0)
    monkeypatch.setattr(
        progress.Pace, "record", lambda self, n, s: calls.append(n) or record(self, n, s)
    )
    monkeypatch.setattr(sys, "stderr", Terminal())
    config = cli.config_from_args(cli.build_parser().parse_args([*TINY, "--n-prefs", "4"]))
    front = sweep.run_sweep(config, str(tmp_path / "paced"), chunks=3, progress=True)
    bar = sys.stderr.getvalue()
    monkeypatch.undo()
    assert calls == [1] * config.num_iterations
    assert "env steps [" in bar and "env-steps/s]" in bar  # the bar, no plain line
    assert not any(PLAIN_LINE.search(line) for line in bar.replace("\r", "\n").splitlines())
    front3, curves3 = _load(tiny_run)
    _, curves = _load(str(tmp_path / "paced"))
    for k in curves3:
        np.testing.assert_array_equal(curves[k], curves3[k], err_msg=k)
    assert [r["return"] for r in front["prefs"]] == [r["return"] for r in front3["prefs"]]


def test_console_script_is_the_command_line(tmp_path):
    """`wcac-sweep` (pyproject's `[project.scripts]`) resolves to `cli.main`, which a
    console script calls with no argument: it reads the process's own arguments, splits
    the CPU as `python -m wcac_jax.sweep` does (its first line), and its return value is
    the exit status."""
    import tomllib
    from importlib.metadata import EntryPoint

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    with open(os.path.join(root, "pyproject.toml"), "rb") as f:
        value = tomllib.load(f)["project"]["scripts"]["wcac-sweep"]
    assert EntryPoint("wcac-sweep", value, "console_scripts").load() is cli.main
    script = (
        "import sys; from importlib.metadata import EntryPoint; "
        f"sys.exit(EntryPoint('wcac-sweep', {value!r}, 'console_scripts').load()())"
    )
    out = tmp_path / "out"
    proc = subprocess.run(
        [sys.executable, "-c", script, *TINY_BANDIT, "--n-prefs", "0", "--out", str(out)],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert lines[0].startswith("[devices] "), lines
    assert lines[-1] == "error: --n-prefs must be >= 1, got 0"
    assert not out.exists()


def test_the_sweep_package_does_not_import_the_command_line():
    """`wcac_jax.sweep.cli` imports `wcac_jax.sweep`, never the reverse: `python -m
    wcac_jax.sweep` runs `sweep/__main__.py` once, and the package is not executed twice."""
    code = "import sys, wcac_jax.sweep; assert 'wcac_jax.sweep.cli' not in sys.modules, sys.modules"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    proc = _cli(["--help"])
    assert proc.returncode == 0 and proc.stdout.startswith("usage: "), proc.stderr
