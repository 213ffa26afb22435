"""One sweep over several processes: `jax.distributed`, with clear errors, and the few
host-side moves a multi-process sweep needs.

`initialize(Cluster(...))` starts JAX's multi-process runtime; afterwards `jax.devices()`
lists every process's devices and `run_sweep` shards the preference axis over all of them.
JAX's own start-up aborts the whole process (SIGABRT, a C++ stack trace) when the
coordinator can't be reached; so the processes first meet over a plain TCP socket on the
coordinator's port, with a timeout, and every failure becomes a `DistributedError` (one
line; the CLI exits with status 2 before writing anything).

The host-side moves (`to_host`, `to_global`, `broadcast`) are the identity's equivalents
on one process, so `run_sweep` has one code path: only process 0 reads and writes
`--out` (results and checkpoints); the others receive a restored checkpoint through a
collective, so no shared file system is needed.
"""

from __future__ import annotations

import os
import socket
import struct
import time
from dataclasses import dataclass

import jax
import numpy as np

_HELLO = b"wcac"  # what a process sends at the rendezvous, with its id and the count
_READY = b"go"


class DistributedError(ValueError):
    """Flags that don't fit together, or processes that could not meet."""


@dataclass(frozen=True)
class Cluster:
    """How this process joins a multi-process sweep.

    Attributes:
      coordinator: `HOST:PORT` of process 0 (it listens there; the others connect).
      num_processes: how many processes run the sweep (each runs the same command).
      process_id: this process's rank, in `[0, num_processes)`.
      timeout_s: how long to wait for every process to arrive.
    """

    coordinator: str
    num_processes: int
    process_id: int
    timeout_s: float = 300.0

    def __post_init__(self):
        host_port(self.coordinator)
        for name in ("num_processes", "process_id"):
            value = getattr(self, name)
            if not isinstance(value, int | np.integer) or isinstance(value, bool):
                raise DistributedError(f"{name} must be an integer, got {value!r}")
        if self.num_processes < 1:
            raise DistributedError(f"--num-processes must be >= 1, got {self.num_processes}")
        if not 0 <= self.process_id < self.num_processes:
            raise DistributedError(
                f"--process-id {self.process_id} is out of range for --num-processes "
                f"{self.num_processes} (valid: 0..{self.num_processes - 1})"
            )
        if not self.timeout_s > 0:
            raise DistributedError(f"--coordinator-timeout must be > 0, got {self.timeout_s}")


def host_port(coordinator: str) -> tuple[str, int]:
    """Splits `HOST:PORT`; raises `DistributedError` naming the bad value."""
    host, sep, port = str(coordinator).rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise DistributedError(
            f"--coordinator {coordinator!r} is not HOST:PORT (e.g. 10.0.0.1:12355, port 1-65535)"
        )
    return host.strip("[]"), int(port)


def from_environment(
    coordinator: str | None,
    num_processes: int | None,
    process_id: int | None,
    timeout_s: float,
    environ=os.environ,
) -> Cluster | None:
    """The `Cluster` of the flags, each missing one read from the environment a launcher
    sets: `JAX_COORDINATOR_ADDRESS` (JAX's own), SLURM's `SLURM_NTASKS`/`SLURM_PROCID`, or
    Open MPI's `OMPI_COMM_WORLD_SIZE`/`OMPI_COMM_WORLD_RANK`. `None` (one process) when no
    coordinator is given either way."""
    coordinator = coordinator or environ.get("JAX_COORDINATOR_ADDRESS")
    if coordinator is None:
        flags = (("--num-processes", num_processes), ("--process-id", process_id))
        given = [flag for flag, value in flags if value is not None]
        if given:
            raise DistributedError(f"{' and '.join(given)} need --coordinator HOST:PORT")
        return None

    def pick(value, flag, names):
        if value is not None:
            return value
        for name in names:
            if name in environ:
                try:
                    return int(environ[name])
                except ValueError:
                    raise DistributedError(f"${name}={environ[name]!r} is not an integer") from None
        raise DistributedError(
            f"--coordinator given, but {flag} is not (nor ${' or $'.join(names)})"
        )

    n = pick(num_processes, "--num-processes", ("SLURM_NTASKS", "OMPI_COMM_WORLD_SIZE"))
    i = pick(process_id, "--process-id", ("SLURM_PROCID", "OMPI_COMM_WORLD_RANK"))
    return Cluster(coordinator, n, i, timeout_s)


def rendezvous(cluster: Cluster) -> None:
    """Waits (at most `cluster.timeout_s`) until every process has reached process 0 at the
    coordinator's address, so that JAX's start-up, which cannot fail gracefully, finds
    everyone there. Raises `DistributedError` on a timeout or a mismatch."""
    host, port = host_port(cluster.coordinator)
    deadline = time.monotonic() + cluster.timeout_s
    hello = _HELLO + struct.pack("!ii", cluster.num_processes, cluster.process_id)
    if cluster.process_id == 0:
        _serve(host, port, cluster, deadline, len(hello))
    else:
        _join(host, port, cluster, deadline, hello)


def _serve(host, port, cluster, deadline, hello_len):
    server = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET)
    server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        server.bind(("", port))
    except OSError as err:
        server.close()
        raise DistributedError(
            f"process 0 can't listen on port {port} of --coordinator {cluster.coordinator}: "
            f"{err.strerror}"
        ) from None
    server.listen(cluster.num_processes)
    peers: dict[int, socket.socket] = {}
    try:
        while len(peers) < cluster.num_processes - 1:
            server.settimeout(max(deadline - time.monotonic(), 1e-3))
            try:
                conn, _ = server.accept()
            except TimeoutError:
                missing = sorted(set(range(1, cluster.num_processes)) - set(peers))
                raise DistributedError(
                    f"only {len(peers) + 1} of {cluster.num_processes} processes reached the "
                    f"coordinator {cluster.coordinator} within {cluster.timeout_s:g} s "
                    f"(missing process id(s) {', '.join(map(str, missing))})"
                ) from None
            conn.settimeout(max(deadline - time.monotonic(), 1.0))
            data = _recv_exact(conn, hello_len)
            if data is None or not data.startswith(_HELLO):
                conn.close()  # not one of ours (a port scan, a stray client): ignore it
                continue
            n, i = struct.unpack("!ii", data[len(_HELLO) :])
            if n != cluster.num_processes or i in peers or not 0 < i < n:
                conn.close()
                raise DistributedError(
                    f"a process joined as id {i} of {n}, but process 0 expects ids "
                    f"1..{cluster.num_processes - 1} of {cluster.num_processes}, each once"
                )
            peers[i] = conn
        for conn in peers.values():
            conn.sendall(_READY)
        for conn in peers.values():  # the peer closes first: no TIME_WAIT on our port
            conn.settimeout(5.0)
            try:
                conn.recv(1)
            except OSError:
                pass
    finally:
        for conn in peers.values():
            conn.close()
        server.close()


def _join(host, port, cluster, deadline, hello):
    last = "no answer"
    while time.monotonic() < deadline:
        try:
            conn = socket.create_connection(
                (host, port), timeout=max(min(deadline - time.monotonic(), 5.0), 1e-3)
            )
        except OSError as err:
            last = err.strerror or str(err)
            time.sleep(min(0.2, max(deadline - time.monotonic(), 0)))
            continue
        try:
            conn.sendall(hello)
            conn.settimeout(max(deadline - time.monotonic(), 1e-3))
            if _recv_exact(conn, len(_READY)) == _READY:
                return
            last = "process 0 closed the connection"
        except OSError as err:
            last = err.strerror or str(err)
        finally:
            conn.close()
        time.sleep(0.2)
    raise DistributedError(
        f"process {cluster.process_id} could not reach the coordinator {cluster.coordinator} "
        f"within {cluster.timeout_s:g} s ({last}; is process 0 running with the same "
        "--coordinator?)"
    )


def _recv_exact(conn, n):
    data = b""
    while len(data) < n:
        try:
            chunk = conn.recv(n - len(data))
        except OSError:
            return None
        if not chunk:
            return None
        data += chunk
    return data


def initialize(cluster: Cluster) -> None:
    """Meets the other processes (`rendezvous`), then starts `jax.distributed`. Call it
    before anything touches JAX's devices."""
    if cluster.num_processes > 1:
        rendezvous(cluster)
    jax.distributed.initialize(
        cluster.coordinator,
        cluster.num_processes,
        cluster.process_id,
        initialization_timeout=max(int(cluster.timeout_s), 1),
        # a process that dies is noticed by the others within this, which then stop too
        heartbeat_timeout_seconds=max(min(int(cluster.timeout_s), 100), 10),
        shutdown_timeout_seconds=max(int(cluster.timeout_s), 1),
    )


def is_writer() -> bool:
    """Whether this process writes results (process 0)."""
    return jax.process_index() == 0


def to_host(tree):
    """Every leaf as a numpy array holding the whole global value, on every process (a
    collective: every process must call it)."""
    if jax.process_count() == 1:
        return jax.device_get(tree)
    from jax.experimental import multihost_utils

    return jax.tree.map(np.asarray, multihost_utils.process_allgather(tree, tiled=True))


def to_global(tree, sharding):
    """Host arrays (the same on every process) as global arrays laid out by `sharding`."""

    def put(x):
        x = np.asarray(x)
        return jax.make_array_from_callback(x.shape, sharding, lambda index: x[index])

    return jax.tree.map(put, tree)


def broadcast(tree):
    """Process 0's `tree` (numpy leaves) on every process (a collective); the identity on
    one process."""
    if jax.process_count() == 1:
        return tree
    from jax.experimental import multihost_utils

    return jax.tree.map(np.asarray, multihost_utils.broadcast_one_to_all(tree))


def all_ok(ok: bool) -> bool:
    """Whether process 0's `ok` is true, on every process (a collective)."""
    return bool(broadcast(np.asarray(ok, np.int32)))


def local_rows(sharding, n_rows: int) -> list[int]:
    """The rows of a `[n_rows, ...]` array with `sharding` that this process holds."""
    rows = set()
    for index in sharding.addressable_devices_indices_map((n_rows,)).values():
        rows.update(range(n_rows)[index[0]])
    return sorted(rows)
