"""A scalarization of one's own, registered from user code and trained with: the augmented
weighted Chebyshev `max_i r_i + rho * sum_i r_i`, `r_i = p_i (z_i - J_i)`.

    python examples/custom_scalarization.py          # the concave bandit, 5 preferences

Its objective weights (`grad_J S = -w * p`, what the actor's direction uses) come from
automatic differentiation; `--scalarization augmented_wc` would choose it on the command
line of a script that registers it.
"""

import sys

import jax.numpy as jnp

from wcac_jax import scalarize
from wcac_jax.sweep import default_sweep, run_sweep

TINY = "--tiny" in sys.argv  # the test suite's size


def augmented_wc(values, pref, j_ub, mu, rho=0.01):
    regrets = pref * (j_ub - values)  # [m]
    return jnp.max(regrets) + rho * jnp.sum(regrets)


scalarize.register("augmented_wc", augmented_wc)
config = default_sweep(
    "concave_bandit",
    n_prefs=5,
    scalarization="augmented_wc",
    eval_episodes=1,
    steps_per_pref=32 * 6 * (10 if TINY else 600),  # iterations of 32 x (2 + 4) env steps
)
front = run_sweep(config, progress=False)  # no output directory: the front is returned
for row in front["prefs"]:
    print(f"p = {row['pref']}: rewards {row['return']}, weights {row['lambda']}")
