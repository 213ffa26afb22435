"""`python -m wcac_jax.evaluate RUN --in mo-gymnasium` (`wcac_jax.evaluate.cli`)."""

import sys

from wcac_jax.evaluate.cli import main

sys.exit(main())
