"""One process of a multi-process sweep that stops after its first chunk, as if every
process were killed there: `python tests/distributed_worker.py <sweep flags>` (the flags
of `python -m wcac_jax.sweep`, `--coordinator` and `--out` included)."""

import sys

from wcac_jax import sweep
from wcac_jax.sweep import cli, distributed

args = cli.build_parser().parse_args(sys.argv[1:])
distributed.initialize(
    distributed.from_environment(
        args.coordinator, args.num_processes, args.process_id, args.coordinator_timeout
    )
)
result = sweep.run_sweep(
    cli.config_from_args(args), args.out, chunks=args.chunks, progress=False, stop_after_chunks=1
)
assert result.get("interrupted"), result
