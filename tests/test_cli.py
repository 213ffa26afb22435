"""The command line as a newcomer meets it: one-line errors that name the flag typed,
negative values, a help that fits two screens, the resolved configuration shown,
`--resume` that reads the run's own record, and the library's defaults behind all of it
(`default_sweep`)."""

import json
import os
import re
import shutil
import subprocess
import sys

import jax
import pytest
from sweep_args import TINY_BANDIT

from wcac_jax import envs, scalarize, sweep
from wcac_jax.sweep import SweepConfig, cli, default_sweep

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TINY = [*TINY_BANDIT, "--quiet"]
# the README's first command's committed run (recorded under the update's older name)
FIRST = os.path.join(ROOT, "experiments", "results", "cli_default_front_select5", "seed0")


def _main(argv, capsys):
    """`(status, stdout, stderr)` of `cli.main(argv)`."""
    status = cli.main(argv)
    out, err = capsys.readouterr()
    return status, out, err


def _one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    return lines[0]


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--n-prefs", "x"], "argument --n-prefs: invalid int value: 'x' (see --help)"),
        (["--bogus"], "unrecognized arguments: --bogus (see --help)"),
        (["--n-prefs", "3", "--prefs", "1,0"], "not allowed with argument"),
        (["--chunks"], "argument --chunks: expected one argument (see --help)"),
    ],
)
def test_every_argparse_error_is_one_line_and_exits_2(argv, message, capsys):
    status, out, err = _main(argv, capsys)
    assert status == 2 and out == ""
    assert message in _one_error_line(err)


@pytest.mark.parametrize("more", [["--n-prefs", "3"], []], ids=["n-prefs", "no preference flag"])
def test_a_utopia_point_of_the_wrong_length_is_one_line(more, capsys, tmp_path):
    status, _, err = _main(["--j-ub", "2", *more, "--out", str(tmp_path / "x")], capsys)
    assert status == 2 and not (tmp_path / "x").exists()
    assert "--j-ub [2.0] has 1 entries; the environment has 2 objectives" in _one_error_line(err)


def test_negative_values_are_values(capsys):
    status, out, err = _main(
        ["--hv-ref", "-500,-3000", "--j-ub", "-5,3", "--print-config", "--quiet"], capsys
    )
    assert status == 0, err
    printed = json.loads(out)
    assert printed["hv_ref"] == [-500.0, -3000.0]
    assert printed["train"]["j_ub"] == [-5.0, 3.0] and printed["train"]["utopia"] == "fixed"
    # a negative preference is read as one, and refused for what it is
    status, _, err = _main(["--prefs", "-1,2", "--print-config"], capsys)
    assert status == 2
    assert "preference #0 [-1.0, 2.0] has a negative entry" in _one_error_line(err)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--steps-per-pref", "0"], "--steps-per-pref must be a positive integer, got 0"),
        (["--envs-per-pref", "0"], "--envs-per-pref must be a positive integer, got 0"),
        (["--num-minibatches", "7"], "--num-minibatches 7 must divide --envs-per-pref *"),
        (["--select-last", "3", "--select-every", "0"], "--select-last 3 needs --select-every"),
        (["--conditioned", "--total-steps", "0"], "--total-steps must be a positive integer"),
        (["--conditioned", "--eval-prefs", "0"], "--eval-prefs must be >= 1, got 0"),
        (["--j-ub", "3,4", "--utopia", "estimated"], "--j-ub sets a fixed utopia point"),
    ],
)
def test_errors_name_the_flag_typed(argv, message, capsys):
    status, _, err = _main([*argv, "--print-config"], capsys)
    assert status == 2
    assert message in _one_error_line(err)


def _help(monkeypatch, *argv, full: bool = False) -> str:
    """The help of `argv` on an 80-column terminal."""
    monkeypatch.setenv("COLUMNS", "80")
    return cli.build_parser(list(argv), full=full).format_help()


def test_help_fits_two_screens_with_each_flag_once(monkeypatch):
    """`--help` on an 80-column terminal: at most 120 lines for every environment, each
    flag listed once with the chosen environment's value; the other updates' fields
    behind `--help-all`; no pointer at a README section."""
    for name in envs.names():
        for preset in (None, "paper", "conditioned"):
            text = _help(monkeypatch, "--env", name, *(["--preset", preset] if preset else []))
            assert len(text.splitlines()) <= 120, (name, preset)
            flags = re.findall(r"^  (--[a-z-]+)", text, flags=re.M)
            assert len(flags) == len(set(flags)), (name, preset)
            assert "README" not in text
    walker = _help(monkeypatch)
    assert "--mu X                  smoothing temperature of smooth_wc (1)" in walker
    assert "--physics X" in walker and "(gymnasium-v5)" in walker and "(mujoco)" in walker
    assert "--critic-steps" in walker and "--critic-steps X" not in walker  # named only
    bandit = _help(monkeypatch, "--env", "concave_bandit")
    assert "--mu X                  smoothing temperature of smooth_wc (0.002)" in bandit
    every = " ".join(_help(monkeypatch, full=True).split())
    assert "discount (preset default: paper 0.99, practical 0.99, conditioned 0.99)" in every
    # the command itself, as typed
    done = subprocess.run(
        [sys.executable, "-m", "wcac_jax.sweep", "--help"],
        capture_output=True,
        text=True,
        env={**os.environ, "COLUMNS": "80"},
    )
    assert done.returncode == 0 and len(done.stdout.splitlines()) <= 120


@pytest.fixture
def halfway():
    """A scalarization registered after import, as a user would, and removed after."""
    scalarize.register("halfway", lambda v, p, z, mu: 0.5 * scalarize.wc(v, p, z))
    yield "halfway"
    del scalarize.SCALARIZATIONS["halfway"]


def test_the_help_lists_scalarizations_from_the_registry(halfway, capsys):
    with pytest.raises(SystemExit):
        cli.main(["--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    assert "smooth_wc, wc, linear, halfway" in help_text
    status, out, _ = _main(["--scalarization", "halfway", "--print-config", "--quiet"], capsys)
    assert status == 0 and json.loads(out)["train"]["scalarization"] == "halfway"


def _committed(path: str) -> dict:
    """A committed `config.json` as the library reads it now (older names normalised)."""
    with open(path) as f:
        return SweepConfig.from_dict(json.load(f)).to_dict()


def test_print_config_shows_what_the_first_command_records(capsys):
    """`--n-prefs 9 --print-config` prints the configuration the README's first command
    recorded (`config.json`), and `default_sweep` resolves the same."""
    status, out, err = _main(["--n-prefs", "9", "--print-config"], capsys)
    assert status == 0
    printed = json.loads(out)
    assert printed == _committed(os.path.join(FIRST, "config.json"))
    assert err.splitlines() == [
        "note: 1,000,000 env steps per preference round up to 489 iterations of 2,048: "
        "training runs 1,001,472"
    ]
    config = default_sweep("walker2d", n_prefs=9)
    assert {**config.to_dict(), "device_count": jax.device_count()} == printed
    assert default_sweep("walker2d") == config


def test_run_sweep_of_default_sweep_records_what_the_first_command_records(tmp_path, monkeypatch):
    """`run_sweep(default_sweep("walker2d"))` and `--n-prefs 9` write the same
    `config.json`, the committed run's; each stops right after writing it (nothing is
    compiled or trained here)."""
    monkeypatch.setattr(jax.stages.Lowered, "compile", lambda self: None)
    monkeypatch.setattr(sweep.run, "_train", lambda *args: False)  # as if interrupted
    by_python = tmp_path / "python"
    assert sweep.run_sweep(default_sweep("walker2d"), str(by_python), progress=False) == {
        "interrupted": True,
        "iterations_done": 0,
    }
    by_cli = tmp_path / "cli"
    assert cli.main(["--n-prefs", "9", "--quiet", "--out", str(by_cli)]) == 0
    written = (by_python / "config.json").read_bytes()
    assert written == (by_cli / "config.json").read_bytes()
    assert json.loads(written) == _committed(os.path.join(FIRST, "config.json"))


def test_envs_make_defaults_to_the_command_lines_model_and_engine():
    walker = envs.make("walker2d")
    assert (walker.physics, walker.backend) == ("gymnasium-v5", "mujoco")
    # a run that recorded neither option ran with the defaults of its day
    old = {"prefs": [[1.0, 0.0]], "env": "walker2d", "env_options": {"physics": "brax"}}
    old |= {"train": {"kind": "paper"}, "steps_per_pref": 10, "seed": 0}
    old |= {"eval_episodes": 1, "hv_ref": None}
    assert SweepConfig.from_dict(old).env_options == {"physics": "brax", "engine": "mjx"}
    # a configuration built now records them whole
    assert SweepConfig(prefs=((1.0, 0.0),)).env_options == {
        "physics": "gymnasium-v5",
        "engine": "mujoco",
    }


LINEAR = ["--prefs", "1,0;0.5,0.5;0,1", "--scalarization", "linear"]


@pytest.fixture(scope="module")
def stopped_linear(tmp_path_factory):
    """A tiny linear sweep stopped after one of its three chunks, and the same sweep run
    through."""
    base = tmp_path_factory.mktemp("resume")
    config = cli.config_from_args(cli.build_parser().parse_args([*TINY, *LINEAR]))
    whole = sweep.run_sweep(config, str(base / "whole"), chunks=3, progress=False)
    stopped = str(base / "stopped")
    sweep.run_sweep(config, stopped, chunks=3, progress=False, stop_after_chunks=1)
    return stopped, whole


def test_resume_alone_continues_a_run_made_with_other_flags(stopped_linear, capsys):
    """The README's `--out runs/lin --resume`: no other flag, and the run continues as it
    was recorded (bit for bit as if never stopped); a flag given beside it that differs
    from the record is refused, naming it."""
    stopped, whole = stopped_linear
    kept = os.path.join(os.path.dirname(stopped), "kept")
    shutil.copytree(stopped, kept)
    status, _, err = _main(["--out", kept, "--resume", "--seed", "1", "--mu", "0.5"], capsys)
    assert status == 2
    line = _one_error_line(err)
    assert "--seed 1 (it has 0)" in line and "--mu 0.5 (it has 0.05)" in line
    assert len(line) < 300
    # the same value as the record is no difference
    status, _, err = _main(
        ["--out", stopped, "--resume", "--scalarization", "linear", "--chunks", "3", "--quiet"],
        capsys,
    )
    assert status == 0, err
    with open(os.path.join(stopped, "front.json")) as f:
        resumed = json.load(f)
    assert [r["return"] for r in resumed["prefs"]] == [r["return"] for r in whole["prefs"]]
    assert resumed["config"]["train"]["scalarization"] == "linear"


def test_the_readme_overwrite_line_replaces_a_run_with_the_same_sweep(capsys):
    """Each README line that writes `--out runs/lin` asks for the same sweep, so
    `--overwrite` replaces the run with itself, not with the default."""
    readme = open(os.path.join(ROOT, "README.md")).read()
    lines = [
        line.split("#")[0].split()
        for line in readme.splitlines()
        if line.startswith("python -m wcac_jax.sweep") and "--out runs/lin" in line
    ]
    assert len(lines) >= 3 and any("--overwrite" in line for line in lines)
    configs = []
    for line in lines:
        if "--resume" in line:
            continue
        argv = [a.strip("\"'") for a in line[3:] if a not in ("--overwrite",)]
        status, out, _ = _main([*argv, "--print-config", "--quiet"], capsys)
        assert status == 0
        configs.append(json.loads(out))
    assert all(c == configs[0] for c in configs)


def test_points_on_the_reference_box_are_not_called_outside(monkeypatch, capsys):
    """The bandit's exact front ends on its reference box (0 in one objective): such
    points add no volume but are not outside; a point below the box is, and its
    preference is written rounded."""
    front = {
        "prefs": [
            {"pref": [1.0, 0.0], "return": [1.0, 0.0]},
            {"pref": [0.9, 0.09999999999999998], "return": [0.8, 0.5]},
            {"pref": [0.1, 0.9], "return": [-0.2, 0.9]},
            {"pref": [0.0, 1.0], "return": [0.0, 1.0]},
        ],
        "hv_ref": [0.0, 0.0],
        "outside_hv_ref": [0, 2, 3],
        "hypervolume": 0.5,
        "env_steps_per_s": 1.0,
        "wall_s": 1.0,
    }
    monkeypatch.setattr(cli, "run_sweep", lambda *args, **kwargs: front)
    status, _, err = _main([*TINY, "--n-prefs", "4"], capsys)
    assert status == 0
    assert err.splitlines() == [
        "warning: 1 of 4 policies lie outside the hypervolume reference box [0, 0] and add "
        "nothing to it: #2 [0.1, 0.9]"
    ]
