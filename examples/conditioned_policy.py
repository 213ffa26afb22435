"""ONE preference-conditioned network for the whole front (`preset="conditioned"`), then
its policy at a preference it was never evaluated at.

    python examples/conditioned_policy.py runs/conditioned   # the concave bandit: minutes

Every environment draws its own preference per episode, so the one network learns the
whole front; `load_sweep(out).policy_at(p)` is its policy at any `p`.
"""

import sys

import jax.numpy as jnp

from wcac_jax.sweep import default_sweep, load_sweep, run_conditioned

TINY = "--tiny" in sys.argv  # the test suite's size
out = next((a for a in sys.argv[1:] if not a.startswith("--")), "runs/conditioned")
small = dict(num_envs=8, rollout_steps=4, num_minibatches=2, width=16, depth=1)
config = default_sweep(
    "concave_bandit",
    preset="conditioned",
    n_prefs=5,
    eval_episodes=1,
    steps_per_pref=320 if TINY else 2_000_000,
    **(small if TINY else {}),
)
front = run_conditioned(config, out, overwrite=True, progress=False)
print("evaluated at", [row["pref"] for row in front["prefs"]])

policy = load_sweep(out).policy_at([0.3, 0.7])  # obs [..., 1] -> action [..., 1]
action = policy(jnp.ones((1,)))
theta = (action[0] + 1.0) * jnp.pi / 4  # the bandit's arm: an angle in [0, pi/2]
print(
    f"at p = [0.3, 0.7] the network pulls the arm at {float(theta):.3f} rad, rewards "
    f"({1 - float(jnp.sin(theta)):.3f}, {1 - float(jnp.cos(theta)):.3f})"
)
