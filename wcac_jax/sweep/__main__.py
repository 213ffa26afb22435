"""`python -m wcac_jax.sweep`: the command line, `wcac_jax.sweep.cli.main` (one host device per
core unless `XLA_FLAGS` says otherwise, `cli.use_every_core`)."""

import sys

from wcac_jax.sweep.cli import main

if __name__ == "__main__":
    sys.exit(main(every_core=True))
