"""Multi-process sweep throughput on one machine: the same sweep run as one process with
`D` host devices and as `D` processes with one device each (`--coordinator` on
127.0.0.1), one after the other; env-steps/s and wall time from each run's `front.json`,
CPU use from the children's resource usage, and whether the two fronts are identical.

    python experiments/bench_processes.py --out experiments/results/bench_processes_cpu.json
    python experiments/bench_processes.py --sweep "--env walker2d --engine mjx --physics brax"

On one 2-core machine no speed-up is expected (both layouts share the same two cores);
this measures what the multi-process runtime costs.
"""

import argparse
import json
import os
import platform
import resource
import shlex
import socket
import subprocess
import sys
import tempfile
import time

from script_io import refuse_existing

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_SWEEPS = (
    "--env walker2d --n-prefs 2 --steps-per-pref 100000",
    "--env walker2d --engine mjx --physics brax --n-prefs 2 --steps-per-pref 50000",
)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _env(devices: int) -> dict:
    return dict(os.environ, XLA_FLAGS=f"--xla_force_host_platform_device_count={devices}")


def _cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _run(cmds: list[list[str]], devices: int, timeout_s: float) -> dict:
    """Runs the processes of one layout at once; returns wall and CPU seconds."""
    cpu0, t0 = _cpu_s(), time.perf_counter()
    procs = [subprocess.Popen(c, env=_env(devices), cwd=ROOT, text=True) for c in cmds]
    try:
        codes = [p.wait(timeout=timeout_s) for p in procs]
    finally:
        for p in procs:
            p.kill()
    wall = time.perf_counter() - t0
    if any(codes):
        raise SystemExit(f"error: a sweep process exited with {codes}: {cmds}")
    return {
        "process_wall_s": wall,
        "cpu_busy_cores": (_cpu_s() - cpu0) / wall,
        "load_average_1min_after": os.getloadavg()[0],  # > cores: other work shared the CPU
    }


def measure(sweep: str, devices: int, workdir: str, timeout_s: float) -> dict:
    base = [sys.executable, "-m", "wcac_jax.sweep", *shlex.split(sweep), "--quiet"]
    one_out, many_out = os.path.join(workdir, "one"), os.path.join(workdir, "many")
    rows = {}
    one = _run([[*base, "--out", one_out]], devices, timeout_s)
    coordinator = f"127.0.0.1:{_free_port()}"
    many = _run(
        [
            [*base, "--out", many_out, "--coordinator", coordinator]
            + ["--num-processes", str(devices), "--process-id", str(i)]
            for i in range(devices)
        ],
        1,
        timeout_s,
    )
    for name, out, run in (
        (f"1 process x {devices} devices", one_out, one),
        (f"{devices} processes x 1 device", many_out, many),
    ):
        with open(os.path.join(out, "front.json")) as f:
            front = json.load(f)
        rows[name] = {
            "env_steps_per_s": front["env_steps_per_s"],
            "compile_s": front["compile_s"],
            "wall_s": front["wall_s"],
            **run,
        }
    with open(os.path.join(one_out, "front.csv")) as f:
        with open(os.path.join(many_out, "front.csv")) as g:
            identical = f.read() == g.read()
    return {"sweep": sweep, "devices": devices, "runs": rows, "fronts_identical": identical}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sweep", action="append", help="sweep flags (repeatable); default: two")
    ap.add_argument("--devices", type=int, default=2, help="devices = processes (default 2)")
    ap.add_argument("--timeout", type=float, default=1800.0, help="seconds per layout")
    ap.add_argument("--out", default=None, help="JSON file to write (default: print only)")
    ap.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    args = ap.parse_args(argv)
    if args.out:
        refuse_existing(args.out, args.overwrite)
    if args.devices < 1:
        ap.error(f"--devices must be >= 1, got {args.devices}")
    results = []
    for sweep in args.sweep or DEFAULT_SWEEPS:
        with tempfile.TemporaryDirectory() as workdir:
            r = measure(sweep, args.devices, workdir, args.timeout)
        results.append(r)
        for name, row in r["runs"].items():
            print(
                f"{sweep} | {name}: {row['env_steps_per_s']:,.0f} env-steps/s, "
                f"wall {row['process_wall_s']:.1f} s, {row['cpu_busy_cores']:.2f} cores busy",
                flush=True,
            )
        print(f"  fronts identical: {r['fronts_identical']}", flush=True)
    record = {
        "machine": {"cpu_count": os.cpu_count(), "processor": platform.machine()},
        "results": results,
    }
    if args.out:
        from wcac_jax.sweep.outputs import json_bytes, write_atomic

        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        write_atomic(args.out, json_bytes(record))
    return 0


if __name__ == "__main__":
    sys.exit(main())
