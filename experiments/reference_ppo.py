"""The yardstick: one single-objective PPO run of the `[1, 0]` end, off the shelf.

`sbx-rl` 0.28 (a JAX PPO with Stable-Baselines3's interface), 16 Gymnasium `Walker2d-v5`
in MuJoCo's C engine (`DummyVecEnv`), 500-step episodes, no control cost (this project's
`[1, 0]` objective), `VecNormalize` (observations and rewards), 64 x 64 networks,
rollouts of 128 steps, minibatches of 256, 10 epochs, Adam 3e-4, clip 0.2, GAE 0.95,
`log_std_init = 0`; 1,000,000 env steps; then its deterministic policy over 8 episodes.
Prints and writes (`--out`, JSON) the training wall time, env-steps/s, and the mean
speed and episode length, so the front's wall time can be set against nine such runs
measured on the same machine in the same hour (speed varies from hour to hour).

`sbx-rl` is not a dependency of wcac_jax (it pulls in PyTorch through Stable-Baselines3);
run this in a separate environment:

    python -m venv /tmp/sbx && /tmp/sbx/bin/pip install "sbx-rl==0.28.0" "gymnasium[mujoco]"
    /tmp/sbx/bin/python experiments/reference_ppo.py --seed 0 --out runs/reference_ppo_seed0.json

The committed runs are `experiments/results/reference_ppo_repeat<R>_seed<S>.json`, one
repeat per machine and hour (experiments/README.md).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import sys
import tempfile
import time


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=1_000_000, help="env steps")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--eval-episodes", type=int, default=8)
    parser.add_argument("--out", default=None, help="JSON file (default: print only)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    args = parser.parse_args(argv)
    if args.out and os.path.lexists(args.out) and not args.overwrite:
        print(f"error: --out {args.out!r} exists (--overwrite replaces it)", file=sys.stderr)
        return 2
    if args.steps <= 0 or args.eval_episodes <= 0:
        parser.error(
            f"--steps and --eval-episodes must be > 0, got {args.steps}, {args.eval_episodes}"
        )
    try:
        import gymnasium as gym
        import numpy as np
        import sbx  # noqa: F401  (make_ppo's; imported here for the one-line error)
    except ImportError as e:
        print(
            f"error: {e}; this script needs sbx-rl and gymnasium[mujoco] (see its docstring)",
            file=sys.stderr,
        )
        return 2

    def make():
        return gym.make("Walker2d-v5", max_episode_steps=500, ctrl_cost_weight=0.0)

    model, venv = make_ppo(make, args.seed)
    cpu0 = resource.getrusage(resource.RUSAGE_SELF)
    t0 = time.perf_counter()
    model.learn(total_timesteps=args.steps)
    train_s = time.perf_counter() - t0
    cpu1 = resource.getrusage(resource.RUSAGE_SELF)
    cpu_s = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)

    env = make()
    speeds, lengths = [], []
    for episode in range(args.eval_episodes):
        obs, _ = env.reset(seed=10_000 + episode)
        x0, n, done = env.unwrapped.data.qpos[0], 0, False
        while not done:
            norm = venv.normalize_obs(obs[None])
            action, _ = model.predict(norm, deterministic=True)
            obs, _, terminated, truncated, _ = env.step(action[0])
            n += 1
            done = terminated or truncated
        speeds.append((env.unwrapped.data.qpos[0] - x0) / (n * env.unwrapped.dt))
        lengths.append(n)

    result = {
        "machine": f"{platform.machine()}, {os.cpu_count()} CPUs",
        "when": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime()),
        "env_steps": args.steps,
        "seed": args.seed,
        "train_s": train_s,
        "env_steps_per_s": args.steps / train_s,
        "cores_busy": cpu_s / train_s,
        "eval_mean_speed_m_per_s": float(np.mean(speeds)),
        "eval_mean_length": float(np.mean(lengths)),
        "eval_episodes": args.eval_episodes,
    }
    print(json.dumps(result, indent=1))
    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        write_atomic(args.out, (json.dumps(result, indent=1)).encode())
    return 0


def make_ppo(make_env, seed: int):
    """`(model, venv)`: the yardstick's PPO (the settings of this module's docstring) on
    16 copies of `make_env` under `VecNormalize`; needs sbx-rl and Stable-Baselines3."""
    from sbx import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    venv = VecNormalize(DummyVecEnv([make_env] * 16), gamma=0.99)
    model = PPO(
        "MlpPolicy",
        venv,
        n_steps=128,
        batch_size=256,
        n_epochs=10,
        learning_rate=3e-4,
        clip_range=0.2,
        gae_lambda=0.95,
        gamma=0.99,
        policy_kwargs={"net_arch": [64, 64], "log_std_init": 0.0},
        seed=seed,
        verbose=0,
    )
    return model, venv


def write_atomic(path: str, data: bytes) -> None:
    """`data` written to a temporary file beside `path`, then renamed over it (as
    `wcac_jax.sweep.outputs.write_atomic`, which this script's own environment lacks)."""
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(path)), prefix=".tmp-")
    umask = os.umask(0)
    os.umask(umask)
    os.fchmod(fd, 0o666 & ~umask)  # as an ordinary open() would create it
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


if __name__ == "__main__":
    sys.exit(main())
