"""The README's first command from Python: Walker2d's default front with `run_sweep`.

    python examples/walker2d_sweep.py runs/example   # 9 preferences x 1M env steps each
        (about 20 minutes on a 2-core CPU); then examples/load_and_rollout.py runs/example

`default_sweep` resolves the library's defaults (the environment's configuration,
budget, model and engine, and the choice among each preference's last policies) exactly
as `python -m wcac_jax.sweep --n-prefs 9` does; keyword arguments change any of them.
"""

import sys

from wcac_jax.sweep import default_sweep, run_sweep

TINY = "--tiny" in sys.argv  # the test suite's size: 3 preferences, 4 iterations
out = next((a for a in sys.argv[1:] if not a.startswith("--")), "runs/example")
small = dict(num_envs=4, rollout_steps=16, num_minibatches=4, width=16, depth=1)
small |= dict(steps_per_pref=256, eval_episodes=2, env_options={"episode_length": 50})
config = default_sweep("walker2d", n_prefs=3 if TINY else 9, **(small if TINY else {}))


def progress(env_steps, metrics):  # after each call of the training program
    print(f"{env_steps:,} env steps per preference, Jhat {metrics['train/j_hat'][:, -1, 0]}")


front = run_sweep(config, out, overwrite=True, progress=False, progress_fn=progress)
for row in front["prefs"]:
    speed = row["mean_x_velocity"]
    print(f"p = {row['pref']}: {speed:.2f} m/s, returns {row['return']}")
print(f"hypervolume {front['hypervolume']:.4g}; written to {out}")
