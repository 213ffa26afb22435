"""The experiment scripts at their quickest: they run and write every field."""

import argparse
import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "experiments"))

import pareto_exploration  # noqa: E402
import reference_ppo  # noqa: E402
import walker2d_ablation  # noqa: E402
import walker2d_common  # noqa: E402
import walker2d_front  # noqa: E402

from wcac_jax import plot  # noqa: E402
from wcac_jax.sweep import cli  # noqa: E402

TINY_WALKER = [
    *("--steps-per-pref", "160", "--envs-per-pref", "4", "--eval-episodes", "1"),
    *("--chunks", "2"),
]
# The front's committed results ran on the paper's model in MuJoCo's C engine, which
# compiles in seconds; the ablation test keeps the scripts' default (Brax's model on MJX,
# the accelerator path), the one end-to-end MJX training run of the suite.
C_ENGINE = ("--physics", "gymnasium-v5", "--engine", "mujoco")


def _run(script, *args, env=None):
    proc = subprocess.run(
        [sys.executable, os.path.join(ROOT, "experiments", script), *args],
        capture_output=True,
        text=True,
        timeout=900,
        env=None if env is None else {**os.environ, **env},
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc


def test_bench_throughput_quick_writes_every_field(tmp_path):
    out = tmp_path / "bench.json"
    proc = _run("bench_throughput.py", "--quick", "--env", "concave_bandit", "--out", str(out))
    result = json.loads(out.read_text())
    for key in (
        "machine",
        "device",
        "P",
        "N",
        "K",
        "L",
        "width",
        "depth",
        "sweep_over_raw",
        "sweep_over_sequential",
        "peak_host_memory_gib",
        "peak_device_memory_gib",
    ):
        assert key in result, key
    for part in ("raw", "sweep", "sequential"):
        assert result[part]["env_steps_per_s"] > 0 and result[part]["compile_s"] > 0
    # --quick: P = 3 preferences x N = 4 environments x 3 iterations of K + L = 4 + 4
    # steps, 288 env steps in each part; each rate is those over the part's timed seconds
    assert (result["P"], result["N"], result["K"], result["L"]) == (3, 4, 4, 4)
    for part in ("raw", "sweep", "sequential"):
        rate = 3 * 4 * 3 * (4 + 4) / result[part]["run_s"]
        assert result[part]["env_steps_per_s"] == pytest.approx(rate, rel=1e-9), part
    # an env step's physics is the raw stepping's, the networks' the sweep's rest
    ms = result["ms_per_env_step"]
    assert ms["physics"] == pytest.approx(1e3 * result["raw"]["run_s"] / 288, rel=1e-9)
    assert ms["networks"] == pytest.approx(
        1e3 * (result["sweep"]["run_s"] - result["raw"]["run_s"]) / 288, rel=1e-9
    )
    assert "(b)/(a)" in proc.stdout


@pytest.mark.slow
def test_bench_env_quick_writes_every_field(tmp_path):
    out = tmp_path / "env.json"
    _run(
        "bench_env.py",
        "--batches",
        "2",
        "--steps",
        "5",
        "--physics",
        "brax",
        "--no-drift",
        "--out",
        str(out),
    )
    result = json.loads(out.read_text())
    (row,) = result["stepping"]
    assert row["physics"] == "brax" and row["batch"] == 2 and row["env_steps_per_s"] > 0


@pytest.mark.parametrize(
    "script", ["bench_env", "bench_throughput", "bench_processes", "reference_ppo"]
)
def test_benchmarks_refuse_an_existing_out(tmp_path, capsys, script):
    """An earlier result file stays byte for byte without --overwrite: exit 2 and one line
    naming it, before anything is measured."""
    import importlib

    out = tmp_path / "result.json"
    out.write_text('{"mine": 1}')
    main = importlib.import_module(script).main
    try:
        status = main(["--out", str(out)])
    except SystemExit as exc:
        status = exc.code
    assert status == 2
    assert capsys.readouterr().err.splitlines() == [
        f"error: --out {str(out)!r} exists (--overwrite replaces it)"
    ]
    assert out.read_text() == '{"mine": 1}'
    assert [p.name for p in tmp_path.iterdir()] == ["result.json"]


def test_reference_ppo_rejects_bad_input_and_names_its_missing_packages(capsys):
    with pytest.raises(SystemExit) as exc:
        reference_ppo.main(["--steps", "0"])
    assert exc.value.code == 2 and "--steps" in capsys.readouterr().err
    try:
        import sbx  # noqa: F401
    except ImportError:
        assert reference_ppo.main(["--steps", "16"]) == 2
        assert "sbx-rl" in capsys.readouterr().err
    else:
        pytest.skip("sbx-rl is installed here: the missing-package message is not reachable")


def test_pareto_exploration_quick_writes_its_schema(tmp_path):
    _run("pareto_exploration.py", "--quick", "--out", str(tmp_path))
    result = json.loads((tmp_path / "exploration.json").read_text())
    assert len(result["prefs"]) == 3
    assert set(result["problems"]) == {"concave_bandit", "deep_sea_treasure"}
    bandit, dst = result["problems"]["concave_bandit"], result["problems"]["deep_sea_treasure"]
    assert (
        set(bandit["directions"]) == set(dst["directions"]) == {"smooth_wc", "wc", "linear", "mgda"}
    )
    for summary in bandit["directions"].values():
        for key in (
            "distinct_points",
            "max_theta_error",
            "max_distance_to_wc_optimum",
            "hypervolume_ratio",
            "largest_theta_gap",
            "theta",
            "points",
        ):
            assert key in summary, key
        assert len(summary["theta"]) == 3
    for summary in dst["directions"].values():
        for key in (
            "distinct_points",
            "points_near_front",
            "max_distance_to_front",
            "max_distance_to_wc_optimum",
            "hypervolume_ratio",
            "largest_gap_along_front",
            "points",
        ):
            assert key in summary, key
        assert len(summary["points"]) == 3
    assert (tmp_path / "exploration.png").stat().st_size > 1000
    # values, recomputed from the saved points by independent code (pymoo's HV, the
    # bandit's reward (1 - sin, 1 - cos) of the saved angles)
    from pymoo.indicators.hv import HV

    # the front's, in closed form: the unit square less the quarter disc around (1, 1)
    assert bandit["exact_front_hypervolume"] == pytest.approx(1 - np.pi / 4, rel=1e-12)
    for summary in bandit["directions"].values():
        theta, points = np.array(summary["theta"]), np.array(summary["points"])
        # (the reward is float32)
        expected = np.stack([1 - np.sin(theta), 1 - np.cos(theta)], 1)
        np.testing.assert_allclose(points, expected, rtol=0, atol=1e-6)
        np.testing.assert_allclose(
            summary["theta_error"], np.abs(theta - np.array(bandit["wc_optimum_theta"])), atol=1e-12
        )
        inside = points[np.all(points > 0, axis=1)]
        hv = HV(ref_point=np.zeros(2))(-inside) if len(inside) else 0.0
        ratio = hv / bandit["exact_front_hypervolume"]
        assert summary["hypervolume_ratio"] == pytest.approx(ratio, rel=1e-9)
    for summary in dst["directions"].values():
        points = np.array(summary["points"])
        ref = np.array(dst["hv_ref"])
        inside = points[np.all(points > ref, axis=1)]
        hv = HV(ref_point=-ref)(-inside) if len(inside) else 0.0
        assert summary["hypervolume"] == pytest.approx(hv, rel=1e-9)
    _assert_out_kept("pareto_exploration.py", tmp_path)


def _assert_out_kept(script, out):
    """`script` refuses the non-empty `out` (a file added to the results makes no
    difference) without `--overwrite`: exit 2, one line, every file as it was."""
    (out / "notes.txt").write_text("mine")
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    proc = subprocess.run(
        [sys.executable, os.path.join(ROOT, "experiments", script), "--quick"]
        + ["--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 2
    assert proc.stderr.splitlines() == [
        f"error: --out {str(out)!r} is not empty (--overwrite replaces it)"
    ]
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


@pytest.mark.parametrize(
    "pref,expected",
    [
        ([1.0, 0.0], [10.0, -10.0]),  # only the first objective counts: its best end
        ([0.0, 1.0], [0.0, 0.0]),
        ([0.5, 0.5], [5.0, -5.0]),  # max(10 - 10 s, 10 s) is least at s = 0.5
        ([0.2, 0.8], [2.0, -2.0]),  # 0.2 (10 - 10 s) = 0.8 (10 s) at s = 0.2
    ],
)
def test_exploration_weighted_chebyshev_optimum_on_a_segment(pref, expected):
    front = np.array([[0.0, 0.0], [10.0, -10.0]])
    got = pareto_exploration.dst_wc_optimum(np.array(pref), front, (10.0, 0.0))
    np.testing.assert_allclose(got, expected, atol=1e-3)


def test_exploration_bandit_summary_measures_the_distance_to_each_target():
    """Points are on the front by construction; what can be wrong is WHERE on it."""
    target = np.array([0.2, 0.7, 1.2])
    theta = target + np.array([0.0, 0.1, -0.3])
    points = np.stack([1 - np.sin(theta), 1 - np.cos(theta)], axis=1)
    out = pareto_exploration.summarise(theta, points, target, 1.0, np.zeros(2), 0.02)
    np.testing.assert_allclose(out["theta_error"], [0.0, 0.1, 0.3], atol=1e-6)
    assert out["max_theta_error"] == pytest.approx(0.3, abs=1e-6)
    t, th = target[2], theta[2]
    chord = np.hypot(np.sin(t) - np.sin(th), np.cos(t) - np.cos(th))  # 2 sin(0.15)
    assert out["max_distance_to_wc_optimum"] == pytest.approx(chord, rel=1e-5)
    assert chord == pytest.approx(2 * np.sin(0.15), rel=1e-9)


def _best_deterministic_g(pref, mu: float) -> float:
    """The least smoothed weighted-Chebyshev value `mu log sum exp(p (J_ub - J) / mu)` over
    every deterministic policy of the default tabular MOMDP, each policy's `J` by a linear
    solve in numpy from the problem's kernel and rewards."""
    import itertools

    from wcac_jax import envs

    env = envs.make("tabular_momdp")
    kernel, rewards = np.asarray(env.kernel, np.float64), np.asarray(env.rewards, np.float64)
    s, a = env.num_states, env.num_actions
    j_ub, p = np.asarray(env.default_j_ub), np.asarray(pref)
    best = np.inf
    for choice in itertools.product(range(a), repeat=s):
        pi = np.eye(a)[list(choice)]
        values = np.linalg.solve(
            np.eye(s) - env.gamma * np.einsum("sa,sat->st", pi, kernel),
            np.einsum("sa,sam->sm", pi, rewards),
        )
        x = p * (j_ub - values[0]) / mu
        best = min(best, mu * (x.max() + np.log(np.sum(np.exp(x - x.max())))))
    return float(best)


def test_convergence_rate_quick_writes_its_schema(tmp_path):
    _run("convergence_rate.py", "--quick", "--out", str(tmp_path))
    result = json.loads((tmp_path / "convergence.json").read_text())
    assert result["env"]["name"] == "tabular_momdp"
    for res in result["results"]:
        assert res["t"] == [0, 2, 4]
        for p in res["prefs"]:
            for key in (
                "pref",
                "g_star",
                "initial_gap",
                "final_gap",
                "final_over_initial",
                "slope",
                "gap",
            ):
                assert key in p, key
            assert p["initial_gap"] > 0  # the initial policy is not optimal
            # the optimum against every deterministic policy, solved here: the best
            # softmax policy is at least as good as each (up to its Adam's precision),
            # and no policy the training reaches beats it
            best = _best_deterministic_g(p["pref"], res["config"]["mu"])
            assert p["g_star"] <= best + 1e-4
            assert min(p["gap"]) >= -1e-4
            assert len(p["gap"]) == len(res["t"])
    assert (tmp_path / "convergence.png").stat().st_size > 1000
    _assert_out_kept("convergence_rate.py", tmp_path)
    # --overwrite: the new results replace the old, nothing beside them
    _run("convergence_rate.py", "--quick", "--out", str(tmp_path), "--overwrite")
    assert sorted(os.listdir(tmp_path)) == ["convergence.json", "convergence.png"]
    assert not [n for n in os.listdir(tmp_path.parent) if n.startswith(f".{tmp_path.name}.")]
    assert json.loads((tmp_path / "convergence.json").read_text()) == result


def test_walker2d_policy_summary_by_hand():
    # 8 episodes that all fall on their 10th step, each step x_velocity 0.5 and every
    # torque saturated (sum a^2 = 6); healthy reward 1 on the first 9 steps, 0 on the fall:
    # forward return 10 * 0.5 + 9 = 14, control return -60 + 9 = -51
    row = {"pref": [0.9, 0.1], "return": [14.0, -51.0], "episode_length": 10.0}
    s = walker2d_common.policy_summary(row, episode_length=500, episodes=8)
    assert s["falls_per_episode"] == 1.0
    assert s["mean_speed_m_per_s"] == pytest.approx(0.5)
    assert s["mean_control_per_step"] == pytest.approx(6.0)  # (L - 1 - R) / L, not 6.1
    assert s["forward_return"] == 14.0 and s["pref"] == [0.9, 0.1]
    # lengths 5 and 15 (mean 10) over 2 episodes: both fell, 2 unpaid healthy rewards
    # in 20 steps; control 6 per step: return (-120 + 18) / 2 = -51 per episode
    s = walker2d_common.policy_summary(
        {"pref": [1, 0], "return": [14.0, -51.0], "episode_length": 10.0}, 500, 2
    )
    assert s["mean_control_per_step"] == pytest.approx(6.0)
    # one 500-step episode, speed 0.2 and control 0.2 per step: 100 + 500, -100 + 500 if
    # it never fell, 100 + 499, -100 + 499 if it fell on its last step; the mean length
    # cannot tell, so only the bounds are given
    s = walker2d_common.policy_summary(
        {"pref": [0.5, 0.5], "return": [600.0, 400.0], "episode_length": 500.0}, 500, 1
    )
    assert s["falls_per_episode"] is None and s["mean_control_per_step"] is None
    np.testing.assert_allclose(s["mean_control_per_step_range"], [0.198, 0.2])
    np.testing.assert_allclose(s["mean_speed_m_per_s_range"], [0.2, 0.202])
    # a policy that stands with almost no torque: 8 full episodes, control return 499.6 >
    # 499, so no episode can have fallen on its last step beyond f = 500 - 499.6 = 0.4
    # (else the energy would be negative): f in [0, 0.4], not [0, 1]
    s = walker2d_common.policy_summary(
        {"pref": [0, 1], "return": [499.0, 499.6], "episode_length": 500.0}, 500, 8
    )
    np.testing.assert_allclose(s["mean_control_per_step_range"], [0.0, 0.4 / 500], atol=1e-12)
    np.testing.assert_allclose(s["mean_speed_m_per_s_range"], [-1 / 500, -0.6 / 500])


def test_falls_per_episode_from_lengths():
    # 8 episodes of limit 500: a 500-step survivor and seven 1-step falls take 507 steps,
    # so 8 * 63 = 504 cannot hold a survivor, 8 * 63.375 = 507 can
    assert walker2d_common.falls_per_episode(62.0, 500, 8) == 1.0
    assert walker2d_common.falls_per_episode(63.0, 500, 8) == 1.0
    assert walker2d_common.falls_per_episode(63.375, 500, 8) is None
    assert walker2d_common.falls_per_episode(500.0, 500, 1) is None


def _walker2d_fronts(results: str) -> list[str]:
    """The directories under `results` that `walker2d_front.py` wrote (a `summary.json`):
    `walker2d_front*`, or one level below it (an experiment's seeds, `.../seedS`)."""
    found = []
    for name in os.listdir(results):
        if not name.startswith("walker2d_front"):
            continue
        if os.path.isfile(os.path.join(results, name, "summary.json")):
            found.append(name)
        else:
            found += [
                f"{name}/{sub}"
                for sub in os.listdir(os.path.join(results, name))
                if os.path.isfile(os.path.join(results, name, sub, "summary.json"))
            ]
    return sorted(found)


# every committed Walker2d front
WALKER2D_FRONTS = _walker2d_fronts(os.path.join(ROOT, "experiments", "results"))


def test_the_readme_fronts_are_among_those_checked():
    for name in ("walker2d_front_paper_warm_brax_1M", "walker2d_front_practical_v5_e5x16/seed0"):
        assert name in WALKER2D_FRONTS


@pytest.mark.parametrize("name", WALKER2D_FRONTS)
def test_committed_walker2d_results_are_what_their_returns_give(tmp_path, name):
    """`--resummarize` rewrites a committed summary from the committed returns: what it
    writes is what the audit's own recomputation gives (`tests/audit.py`), with every
    policy in the default reference box and every control per step within its physical
    maximum of 6 (exact where every episode fell, else both ends of its range)."""
    import audit
    from pymoo.indicators.hv import HV

    committed = os.path.join(ROOT, "experiments", "results", name)
    copy = tmp_path / "experiments" / "results" / name
    shutil.copytree(committed, copy)
    walker2d_front.resummarize(str(copy))
    # the rewritten summary against the audit's own recomputation from the returns
    rel = f"experiments/results/{name}/summary.json"
    assert audit.check_walker2d_front_summary(audit.Repo(str(tmp_path)), rel) == []
    after = json.loads((copy / "summary.json").read_text())
    for direction, res in after["directions"].items():
        points = np.array([[p["forward_return"], p["control_return"]] for p in res["policies"]])
        assert res["hv_ref"] == [-500.0, -3000.0] and res["outside_hv_ref"] == []
        for table in res["hypervolume_by_ref"]:
            ref = np.array(table["hv_ref"])
            inside = np.all(points > ref, axis=1)
            assert table["outside"] == np.flatnonzero(~inside).tolist()
            assert table["hypervolume"] == pytest.approx(HV(ref_point=-ref)(-points[inside]))
        for pol in res["policies"]:
            if pol["falls_per_episode"] is None:  # some episode may have lasted
                assert pol["episode_length"] > 1, (name, direction, pol)
                for control in pol["mean_control_per_step_range"]:
                    assert 0 <= control <= 6.0, (name, direction, pol)
            else:
                assert pol["falls_per_episode"] == 1.0  # every episode fell: exact
                assert 0 <= pol["mean_control_per_step"] <= 6.0, (name, direction, pol)


def test_named_configs_keep_the_paper_setting_apart():
    paper = walker2d_common.CONFIGS["paper"]
    assert (paper.network, paper.actor_optimizer, paper.width, paper.depth) == (
        "paper",
        "normalized",
        256,
        2,
    )
    assert (paper.actor_lr, paper.critic_lr, paper.gamma, paper.mu) == (3e-4, 1e-3, 0.99, 0.05)
    # Algorithm 2: cold restart from W(0) and a finite projection; paper-warm is the rest
    assert (paper.critic_warm_start, paper.projection_radius) == (False, 1.0)
    warm = walker2d_common.CONFIGS["paper-warm"]
    assert warm == paper.replace(critic_warm_start=True, projection_radius=float("inf"))
    assert walker2d_common.steps_per_pref(0.2, None) == 200_000
    assert walker2d_common.steps_per_pref(1.0, 123) == 123
    assert walker2d_common.train_config("paper", width=None, depth=1).depth == 1
    # the sweep CLI's config flags change a named config (fields recorded in the summary)
    parser = argparse.ArgumentParser()
    cli.add_config_flags(parser, skip=("envs_per_pref", "scalarization"))
    args = parser.parse_args(["--j-ub", "400,100", "--learning-rate", "1e-4"])
    fixed = walker2d_common.config_with_flags("practical", args, num_envs=8)
    practical = walker2d_common.CONFIGS["practical"]
    assert fixed == practical.replace(
        utopia="fixed", j_ub=(400.0, 100.0), learning_rate=1e-4, num_envs=8
    )
    assert walker2d_front.config_changes(practical, fixed) == {
        "num_envs": 8,
        "learning_rate": 1e-4,
        "j_ub": [400.0, 100.0],
        "utopia": "fixed",
    }
    args = parser.parse_args(["--j-ub", "3,4", "--depth", "1"])
    assert walker2d_common.config_with_flags("paper", args) == paper.replace(
        j_ub=(3.0, 4.0), depth=1
    )


@pytest.mark.parametrize(
    ("script", "args", "named"),
    [
        (walker2d_front, ["--config", "nope"], "'nope'; valid: paper, mlp-adam"),
        (walker2d_front, ["--scale", "0"], "--scale must be > 0, got 0.0"),
        (walker2d_ablation, ["--seeds", "0"], "--seeds must be >= 1, got 0"),
        (walker2d_ablation, ["--steps-per-pref", "-5"], "got -5"),
        (walker2d_front, ["--resume"], "--resume: nothing to resume"),
        (walker2d_front, ["--resume", "--overwrite"], "--overwrite replaces it: give one"),
        (walker2d_front, ["--select-every", "2048"], "--select-every 2048 spaces"),
        (walker2d_front, ["--j-ub", "400,x"], "--j-ub '400,x'"),
        (walker2d_front, ["--config", "practical", "--j-ub", "1e39,1"], "finite"),
        (walker2d_front, ["--utopia-margin", "0.02"], "does not apply to --config paper"),
        (
            walker2d_front,
            ["--config", "practical", "--j-ub", "1,2", "--utopia-margin", "1"],
            "ignores it",
        ),
        (walker2d_front, ["--config", "practical", "--utopia-margin", "-1"], "got -1.0"),
        (walker2d_front, ["--select-last", "0"], "--select-last must be a positive integer"),
        # the practical default's 5 candidates 20,480 env steps apart, asked for by a flag
        (
            walker2d_front,
            ["--config", "practical", "--select-last", "5", "--scale", "0.05"],
            "need more than 40",
        ),
    ],
)
def test_walker2d_scripts_reject_bad_input(tmp_path, capsys, script, args, named):
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exc:
        script.main([*args, "--out", str(out)])
    _assert_refused(exc.value.code, capsys.readouterr().err, named, out)


@pytest.mark.parametrize("script", [walker2d_front, walker2d_ablation])
def test_walker2d_scripts_refuse_a_non_empty_out(tmp_path, capsys, script):
    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(SystemExit) as exc:
        script.main(["--out", str(tmp_path)])
    assert exc.value.code == 2
    assert capsys.readouterr().err.splitlines() == [
        f"error: --out {str(tmp_path)!r} is not empty (--resume continues an interrupted "
        "run, --overwrite replaces it)"
    ]
    assert [p.name for p in tmp_path.iterdir()] == ["notes.txt"]
    assert (tmp_path / "notes.txt").read_text() == "mine"


def _assert_refused(status, stderr, named, out, expected_status=2):
    """A refusal as the scripts make one: `expected_status`, a last stderr line `error:
    ...` naming `named`, and nothing written at `out`."""
    assert status == expected_status, stderr[-3000:]
    assert stderr.strip().splitlines()[-1].startswith("error:")
    assert named in stderr
    assert not out.exists()


@pytest.mark.parametrize(
    ("args", "out", "named"),
    [
        (["--run", "nowhere"], "out", "no sweep in 'nowhere'"),
        (["--run", "nowhere", "--every", "0"], "out", "--every must be >= 1, got 0"),
        (["--run", "nowhere"], "a_file/out", "a_file' is not a directory"),
    ],
)
def test_walker2d_film_rejects_bad_input(tmp_path, args, out, named):
    """In its own process, as it is run: the script picks MuJoCo's OpenGL platform when
    it is imported, which the test process must not inherit."""
    (tmp_path / "a_file").write_text("")
    out = tmp_path / out
    proc = subprocess.run(
        [sys.executable, os.path.join(ROOT, "experiments", "walker2d_film.py"), *args]
        + ["--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    _assert_refused(proc.returncode, proc.stderr, named, out)


def test_walker2d_film_refuses_existing_films(tmp_path):
    """Films already in --out stay byte for byte without --overwrite: refused before the
    run is even read (no sweep in `nowhere`), exit 2, one line naming the file."""
    (tmp_path / "film.json").write_text("mine")
    (tmp_path / "notes.txt").write_text("other")
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    proc = subprocess.run(
        [sys.executable, os.path.join(ROOT, "experiments", "walker2d_film.py")]
        + ["--run", "nowhere", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 2
    path = str(tmp_path / "film.json")
    assert proc.stderr.splitlines() == [f"error: {path!r} exists (--overwrite replaces it)"]
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_ablation_grid_is_the_papers():
    sizes = walker2d_ablation.grid([1, 2, 4], [64, 128, 256], 256, 2)
    assert sizes == [(1, 256), (2, 256), (4, 256), (2, 64), (2, 128)]
    assert plot.moving_average([1, 2, 3, 4], 2).tolist() == [1.5, 2.5, 3.5]


@pytest.mark.slow
def test_walker2d_front_tiny(tmp_path):
    import scipy.stats
    from pymoo.indicators.hv import HV

    _run(
        "walker2d_front.py",
        *TINY_WALKER,
        *C_ENGINE,
        *("--width", "16", "--depth", "1", "--out", str(tmp_path)),
    )
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["config_name"] == "paper" and summary["steps_per_pref"] == 160
    assert (summary["physics"], summary["engine"]) == ("gymnasium-v5", "mujoco")
    assert set(summary["directions"]) == {"smooth_wc", "linear"}
    for direction, res in summary["directions"].items():
        front = json.loads((tmp_path / direction / "front.json").read_text())
        assert front["config"]["train"]["scalarization"] == direction
        assert len(res["policies"]) == len(front["prefs"]) == 9
        for pol, row in zip(res["policies"], front["prefs"], strict=True):
            assert pol["pref"] == row["pref"] and pol["forward_return"] == row["return"][0]
            if pol["falls_per_episode"] is not None:
                assert 0 <= pol["mean_control_per_step"] <= 6.0
        # the metrics, recomputed from the saved returns by independent code
        points = np.array([row["return"] for row in front["prefs"]])
        ref = np.array(res["hv_ref"])
        inside = np.all(points > ref, axis=1)
        assert res["outside_hv_ref"] == np.flatnonzero(~inside).tolist()
        expected = HV(ref_point=-ref)(-points[inside]) if inside.any() else 0.0
        assert res["hypervolume"] == pytest.approx(expected, rel=1e-9)
        rho = scipy.stats.spearmanr([row["pref"][0] for row in front["prefs"]], points[:, 0])
        np.testing.assert_allclose(res["pref0_forward_rank_correlation"], rho.statistic)
    for name in ("front.png", "curves.png"):
        assert (tmp_path / name).stat().st_size > 1000
        (tmp_path / name).unlink()
    _film_of(tmp_path / "smooth_wc", tmp_path / "film")
    _run("walker2d_front.py", "--plot-only", "--out", str(tmp_path))  # redraws, no training
    for name in ("front.png", "curves.png"):
        assert (tmp_path / name).stat().st_size > 1000

    # --resume reads the finished smooth_wc sweep back and reruns the missing linear one
    # (the interrupted-sweep case, a bit-identical continuation, is test_sweep's)
    shutil.rmtree(tmp_path / "linear")
    proc = _run(
        "walker2d_front.py",
        *TINY_WALKER,
        *C_ENGINE,
        *("--width", "16", "--depth", "1", "--out", str(tmp_path), "--resume"),
    )
    assert "linear: 9 preferences" in proc.stdout
    again = json.loads((tmp_path / "summary.json").read_text())
    for direction in ("smooth_wc", "linear"):
        assert (
            again["directions"][direction]["policies"]
            == summary["directions"][direction]["policies"]
        )


def _film_of(run, out):
    """`walker2d_film.py` on a finished tiny front (MuJoCo's renderer, in a subprocess so
    that it picks EGL before importing mujoco): every preference filmed, files whole."""
    from PIL import Image

    steps, every = 20, 5
    proc = _run(
        "walker2d_film.py",
        *("--run", str(run), "--out", str(out), "--steps", str(steps)),
        *("--every", str(every), "--columns", "3", "--size", "48"),
    )
    front = json.loads((run / "front.json").read_text())
    film = json.loads((out / "film.json").read_text())
    assert (film["physics"], film["engine"], film["steps"]) == ("gymnasium-v5", "mujoco", steps)
    assert [p["pref"] for p in film["policies"]] == [row["pref"] for row in front["prefs"]]
    for p in film["policies"]:
        assert 1 <= p["length"] <= steps and (p["fell"] or p["length"] == steps)
        assert p["speed_m_per_s"] == pytest.approx(p["distance_m"] / (p["length"] * film["dt"]))
    assert len([line for line in proc.stdout.splitlines() if line.startswith("p = ")]) == 9
    with Image.open(out / "film.gif") as gif:
        assert gif.n_frames == steps // every + 1  # steps 0, 5, ..., 20
    assert (out / "film.png").stat().st_size > 1000
    assert sorted(os.listdir(out)) == ["film.gif", "film.json", "film.png"]  # no temporaries
    # without an OpenGL platform: a one-line error, and no --out left behind
    nowhere = out.parent / "film_without_gl"
    proc = subprocess.run(
        [sys.executable, os.path.join(ROOT, "experiments", "walker2d_film.py")]
        + ["--run", str(run), "--out", str(nowhere), "--steps", "2", "--size", "8"],
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "MUJOCO_GL": "disable"},
    )
    named = "error: MuJoCo's renderer found no OpenGL context (MUJOCO_GL='disable'"
    _assert_refused(proc.returncode, proc.stderr, named, nowhere, expected_status=1)


@pytest.mark.slow
def test_walker2d_ablation_tiny(tmp_path):
    _run(
        "walker2d_ablation.py",
        *TINY_WALKER,
        *("--seeds", "9", "--depths", "1", "--widths", "16", "--fixed-width", "16"),
        *("--fixed-depth", "1", "--out", str(tmp_path)),
    )
    result = json.loads((tmp_path / "ablation.json").read_text())
    assert result["seeds"] == 9 and result["pref"] == [0.9, 0.1]
    assert (result["physics"], result["engine"]) == ("brax", "mjx")  # the MJX run
    (size,) = result["sizes"]
    assert (size["depth"], size["width"]) == (1, 16)
    front = json.loads((tmp_path / "D1_w16" / "front.json").read_text())
    assert size["eval_forward_return"] == [row["return"][0] for row in front["prefs"]]
    assert size["eval_forward_mean"] == pytest.approx(np.mean(size["eval_forward_return"]))
    assert len(size["train_forward_final"]) == 9
    assert len(set(size["eval_forward_return"])) > 1  # the seeds differ
    assert len(size["curve_steps"]) == len(size["curve_forward_mean"]) > 0
    assert (tmp_path / "ablation.png").stat().st_size > 1000
    (tmp_path / "ablation.png").unlink()
    _run("walker2d_ablation.py", "--plot-only", "--out", str(tmp_path))  # redraws only
    assert (tmp_path / "ablation.png").stat().st_size > 1000


@pytest.mark.slow
def test_walker2d_film_of_a_padded_two_device_run_with_a_choice(tmp_path):
    """3 preferences on 2 host devices (4 rows, the last repeated) with a choice among
    each one's last 3 policies: the film shows the 3 chosen policies."""
    run = tmp_path / "run"
    proc = subprocess.run(
        [sys.executable, "-m", "wcac_jax.sweep", "--env", "walker2d", *C_ENGINE]
        + ["--preset", "paper", "--n-prefs", "3", "--envs-per-pref", "4", "--width", "16"]
        + ["--depth", "1", "--critic-steps", "2", "--rollout-steps", "4"]
        + ["--steps-per-pref", "168", "--select-last", "3", "--select-every", "24"]
        + ["--eval-episodes", "1", "--quiet", "--out", str(run)],
        capture_output=True,
        text=True,
        timeout=900,
        env={**os.environ, "XLA_FLAGS": "--xla_force_host_platform_device_count=2"},
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    front = json.loads((run / "front.json").read_text())
    assert len(front["devices"]) == 2 and front["chosen_iteration"]
    out = tmp_path / "film"
    proc = _run(
        "walker2d_film.py",
        *("--run", str(run), "--out", str(out), "--steps", "8", "--every", "4"),
        *("--columns", "2", "--size", "32"),
    )
    film = json.loads((out / "film.json").read_text())
    assert [p["pref"] for p in film["policies"]] == [row["pref"] for row in front["prefs"]]
    assert len([line for line in proc.stdout.splitlines() if line.startswith("p = ")]) == 3


def test_kuairand_headroom_refuses_a_non_empty_out(tmp_path, capsys):
    """Refused before any data is read (there is none): exit 2, one line, bytes kept."""
    import kuairand_headroom

    out = tmp_path / "headroom"
    out.mkdir()
    (out / "headroom.json").write_text('{"old": 1}\n')
    assert kuairand_headroom.main(["--data", str(tmp_path / "none"), "--out", str(out)]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"error: --out {str(out)!r} is not empty (--overwrite replaces it)"
    ]
    assert [p.name for p in out.iterdir()] == ["headroom.json"]
    assert (out / "headroom.json").read_text() == '{"old": 1}\n'


def test_kuairand_headroom_overwrite_replaces_out_whole(tmp_path, monkeypatch):
    import kuairand_headroom

    out = tmp_path / "headroom"
    out.mkdir()
    (out / "notes.txt").write_text("old")
    per = {"sigma": {"5.0": {"bc": 1.0, "oracle": 3.0, "gap": 2.0}}, "logged": 0.5}
    monkeypatch.setattr(kuairand_headroom, "headroom", lambda *a: per)
    argv = ["--data", str(tmp_path / "seed0"), "--out", str(out), "--overwrite"]
    assert kuairand_headroom.main(argv) == 0
    assert [p.name for p in out.iterdir()] == ["headroom.json"]
    assert json.loads((out / "headroom.json").read_text())["sigma"]["5.0"]["gap"] == 2.0
    assert os.listdir(tmp_path) == ["headroom"]  # no temporary directory left
