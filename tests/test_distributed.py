"""A sweep over several processes (`--coordinator`, `wcac_jax.sweep.distributed`) on 127.0.0.1:
two processes with one CPU device each give the same front, bit for bit, as one process
with two host devices, also across a stop and `--resume`; flags that don't fit and an
unreachable coordinator exit with status 2, one line, nothing written."""

import os
import socket
import subprocess
import sys

import numpy as np
import pytest
from sweep_args import TINY_BANDIT

from wcac_jax.sweep import cli

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SWEEP = [*TINY_BANDIT, "--n-prefs", "4", "--chunks", "3"]
TIMEOUT = 240  # seconds per process: a hang fails the test instead of stalling the suite


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _env(devices: int) -> dict:
    env = dict(os.environ, XLA_FLAGS=f"--xla_force_host_platform_device_count={devices}")
    env["PYTHONPATH"] = os.pathsep.join([ROOT, HERE, env.get("PYTHONPATH", "")])
    return env


def _sweep_cmd(*args):
    return [sys.executable, "-m", "wcac_jax.sweep", *SWEEP, *args]


def _run_processes(make_cmd, n=2, timeout_s=60):
    """Starts `n` processes (`make_cmd(process_id)`) on one coordinator; waits for all."""
    coordinator = f"127.0.0.1:{_free_port()}"
    flags = ("--coordinator", coordinator, "--num-processes", str(n))
    procs = [
        subprocess.Popen(
            [*make_cmd(i), *flags, "--process-id", str(i), "--coordinator-timeout", str(timeout_s)],
            env=_env(1),
            cwd=ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for i in range(n)
    ]
    results = []
    try:
        for p in procs:
            out, err = p.communicate(timeout=TIMEOUT)
            results.append((p.returncode, out, err))
    finally:
        for p in procs:
            p.kill()
    return results


def _same_front(a, b):
    with open(os.path.join(a, "front.csv")) as f, open(os.path.join(b, "front.csv")) as g:
        assert f.read() == g.read()
    ca, cb = np.load(os.path.join(a, "curves.npz")), np.load(os.path.join(b, "curves.npz"))
    assert sorted(ca.files) == sorted(cb.files)
    for k in ca.files:
        np.testing.assert_array_equal(ca[k], cb[k], err_msg=k)


@pytest.fixture(scope="module")
def one_process(tmp_path_factory):
    """The reference: the same sweep in one process with two host devices."""
    out = str(tmp_path_factory.mktemp("one") / "run")
    r = subprocess.run(
        _sweep_cmd("--out", out),
        env=_env(2),
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )
    assert r.returncode == 0, r.stderr
    return out


def test_two_processes_give_the_front_of_one_process_with_two_devices(one_process, tmp_path):
    outs = [tmp_path / "run", tmp_path / "elsewhere"]  # process 1 gets its own --out
    results = _run_processes(lambda i: _sweep_cmd("--out", str(outs[i])))
    for rc, _, err in results:
        assert rc == 0, err
    assert "[process 0/2] preferences #0-#1 of 4" in results[0][2]
    assert "[process 1/2] preferences #2-#3 of 4" in results[1][2]
    _same_front(one_process, str(outs[0]))
    assert not outs[1].exists()  # only process 0 writes


def test_two_processes_resume_after_a_stop(one_process, tmp_path):
    out = str(tmp_path / "run")
    worker = os.path.join(HERE, "distributed_worker.py")
    stopped = _run_processes(lambda i: [sys.executable, worker, *SWEEP, "--out", out])
    for rc, _, err in stopped:
        assert rc == 0, err
    assert not os.path.exists(os.path.join(out, "front.json"))  # stopped mid-run
    assert os.listdir(os.path.join(out, "checkpoint"))
    resumed = _run_processes(lambda i: _sweep_cmd("--out", out, "--resume"))
    for rc, _, err in resumed:
        assert rc == 0, err
    # it continued from the checkpoint: only the last 2 of the 3 chunks ran
    progress = [line for line in resumed[0][2].splitlines() if line.startswith("[sweep] ")]
    progress = [line.split()[1] for line in progress if "env steps" in line]
    assert len(progress) == 2 and progress[-1].startswith("4,800/"), progress
    _same_front(one_process, out)


# every process builds MJX's Walker2d and resets it under jit: MJX's `put_model` used to
# place each process's model on process 0's device, which process 1 cannot read
_MJX_ENV = """
import sys, jax
from wcac_jax import envs
from wcac_jax.sweep import cli, distributed
a = cli.build_parser().parse_args(sys.argv[1:])
distributed.initialize(distributed.from_environment(
    a.coordinator, a.num_processes, a.process_id, a.coordinator_timeout))
env = envs.make("walker2d", physics="brax", engine="mjx")
leaves = jax.tree.leaves(env.engine.sys)
assert all(x.is_fully_addressable for x in leaves if isinstance(x, jax.Array))
state = jax.jit(env.reset)(jax.random.key(0))
print(float(state.obs.sum()))
"""


def test_two_processes_each_build_the_mjx_walker():
    results = _run_processes(lambda i: [sys.executable, "-c", _MJX_ENV])
    for rc, _, err in results:
        assert rc == 0, err
    assert results[0][1] == results[1][1]  # the same start from the same key


@pytest.mark.parametrize(
    "flags, message",
    [
        (
            ["--coordinator", "127.0.0.1:1", "--num-processes", "0", "--process-id", "0"],
            "--num-processes must be >= 1, got 0",
        ),
        (
            ["--coordinator", "127.0.0.1:1", "--num-processes", "2", "--process-id", "2"],
            "--process-id 2 is out of range for --num-processes 2 (valid: 0..1)",
        ),
        (
            ["--coordinator", "127.0.0.1:1", "--num-processes", "2", "--process-id", "-1"],
            "--process-id -1 is out of range",
        ),
        (
            ["--coordinator", "localhost", "--num-processes", "2", "--process-id", "0"],
            "--coordinator 'localhost' is not HOST:PORT",
        ),
        (
            ["--coordinator", "127.0.0.1:99999", "--num-processes", "2", "--process-id", "0"],
            "is not HOST:PORT",
        ),
        (
            ["--num-processes", "2", "--process-id", "1"],
            "--num-processes and --process-id need --coordinator HOST:PORT",
        ),
        (
            ["--coordinator", "127.0.0.1:1", "--process-id", "1"],
            "--coordinator given, but --num-processes is not",
        ),
        (
            [
                "--coordinator",
                "127.0.0.1:1",
                "--num-processes",
                "2",
                "--process-id",
                "1",
                "--coordinator-timeout",
                "0",
            ],
            "--coordinator-timeout must be > 0, got 0.0",
        ),
    ],
)
def test_flags_that_dont_fit_exit_2(flags, message, tmp_path, capsys, monkeypatch):
    for name in ("JAX_COORDINATOR_ADDRESS", "SLURM_NTASKS", "SLURM_PROCID"):
        monkeypatch.delenv(name, raising=False)
    out = tmp_path / "run"
    assert cli.main([*SWEEP, *flags, "--quiet", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and message in err[0], err
    assert not out.exists()


def test_missing_flags_come_from_the_launchers_environment():
    from wcac_jax.sweep.distributed import from_environment

    slurm = {"SLURM_NTASKS": "4", "SLURM_PROCID": "3"}
    c = from_environment("10.0.0.1:1234", None, None, 30.0, environ=slurm)
    assert (c.coordinator, c.num_processes, c.process_id) == ("10.0.0.1:1234", 4, 3)
    mpi = {
        "JAX_COORDINATOR_ADDRESS": "h:1",
        "OMPI_COMM_WORLD_SIZE": "2",
        "OMPI_COMM_WORLD_RANK": "0",
    }
    c = from_environment(None, None, None, 30.0, environ=mpi)
    assert (c.coordinator, c.num_processes, c.process_id) == ("h:1", 2, 0)
    assert from_environment(None, None, None, 30.0, environ=slurm) is None  # one process


@pytest.mark.parametrize(
    "process_id, message",
    [
        ("1", "process 1 could not reach the coordinator 127.0.0.1:{port} within 3 s"),
        (
            "0",
            "only 1 of 2 processes reached the coordinator 127.0.0.1:{port} within 3 s "
            "(missing process id(s) 1)",
        ),
    ],
)
def test_unreachable_coordinator_exits_2(process_id, message, tmp_path):
    port = _free_port()
    out = tmp_path / "run"
    r = subprocess.run(
        _sweep_cmd(
            "--out",
            str(out),
            "--coordinator",
            f"127.0.0.1:{port}",
            "--num-processes",
            "2",
            "--process-id",
            process_id,
            "--coordinator-timeout",
            "3",
            "--quiet",
        ),
        env=_env(1),
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), lines
    assert message.format(port=port) in lines[0]
    assert not out.exists()
