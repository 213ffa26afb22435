"""A front on the concave bandit with `make_train`: one training run is a pure function of a
key and a preference, and the front is that function vmapped over the preferences.

    python examples/bandit_front.py          # 11 preferences, 600 iterations: seconds
"""

import sys

import jax
import jax.numpy as jnp
import numpy as np

from wcac_jax import envs, make_evaluate, make_train, pareto, presets

TINY = "--tiny" in sys.argv  # the test suite's size

env = envs.make("concave_bandit")
config = presets.BANDIT.replace(num_iterations=20 if TINY else 600)  # its tuned settings
train = make_train(config, env)  # train(key, pref [2]) -> (state, metrics [T, ...])
prefs = jnp.asarray(pareto.simplex_lattice(2, 11), jnp.float32)
keys = jax.random.split(jax.random.key(0), prefs.shape[0])
states, metrics = jax.jit(jax.vmap(train))(keys, prefs)

# each preference's deterministic policy, evaluated on one episode (the bandit's one step)
evaluate = jax.jit(jax.vmap(make_evaluate(config, env, num_episodes=1)))
returns = np.asarray(evaluate(states, keys)["eval/return"])
for pref, ret in zip(prefs.tolist(), returns.tolist(), strict=True):
    print(f"p = [{pref[0]:.1f}, {pref[1]:.1f}]: rewards ({ret[0]:.3f}, {ret[1]:.3f})")
print(f"{pareto.cardinality(returns)} distinct non-dominated points of 11")
