"""The experiment scripts at their quickest: they run and write every field."""

import json
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _run(script, *args):
    proc = subprocess.run(
        [sys.executable, os.path.join(ROOT, "experiments", script), *args],
        capture_output=True,
        text=True,
        timeout=900,
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
    assert result["sweep_over_raw"] > 0 and result["sweep_over_sequential"] > 0
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
            "max_distance_to_front",
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
            "hypervolume_ratio",
            "largest_gap_along_front",
            "points",
        ):
            assert key in summary, key
        assert len(summary["points"]) == 3
    assert (tmp_path / "exploration.png").stat().st_size > 1000


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
    assert (tmp_path / "convergence.png").stat().st_size > 1000
