"""What the Walker2d experiments share: the named training configurations and the
per-policy summaries (forward speed, control effort) read from a sweep's `front.json`.

`paper` is the paper's setting (the paper's Appendix B.2) and nothing else. Every
departure from it is a separate, named configuration here, so that a result is never
silently tuned: the scripts record the name and the full config with the results.
"""

from __future__ import annotations

import argparse
import inspect
import json
import math
import os

import jax
import numpy as np
from script_io import fail, finish_out, make_out  # noqa: F401 (the Walker2d scripts' own)

from wcac_jax import envs, pareto, presets
from wcac_jax.algos import PaperConfig
from wcac_jax.sweep import (
    SweepConfig,
    SweepError,
    TrainingDiverged,
    check_output_dir,
    cli,
    default_hv_ref,
    run_sweep,
)
from wcac_jax.sweep.outputs import library_versions

PAPER_STEPS_PER_PREF = 1_000_000
SMOOTH_STEPS = 500  # the paper smooths its learning curves over 500 environment steps

CONFIGS = {
    # The paper: its ReLU network (fixed A and c, trainable W, 1/sqrt(w) scaling) for the
    # actor and both critics, the normalised actor step with constant alpha = 3e-4,
    # beta = 1e-3, gamma = 0.99, mu = 0.05, J_ub = (2000, 1000), width 256, depth 2, and
    # Algorithm 2 as written: every critic restarts from W(0) at each iteration and is
    # projected onto the ball of radius B = 1.0 (the paper states no B; see
    # `PaperConfig.projection_radius` for how this one was measured).
    "paper": PaperConfig(),
    # Departure: a conventional flax MLP (every layer trained, policy head initialised
    # small so initial actions are not saturated) for actor and critics, and Adam on
    # the direction d_t instead of the normalised step; warm critics without projection
    # (as it was run). Everything else as the paper.
    "mlp-adam": PaperConfig(
        network="mlp", actor_optimizer="adam", critic_warm_start=True, projection_radius=math.inf
    ),
    # Departure: the paper's setting but the critics continue from the previous
    # iteration and are never projected (what `paper` meant before the paper's own
    # Algorithm 2 became the default; the Walker2d results recorded before then).
    "paper-warm": PaperConfig(critic_warm_start=True, projection_radius=math.inf),
    # The practical preset (wcac_jax.sweep.presets): the same smoothed weighted-Chebyshev
    # direction, optimised as PPO (GAE, clipped ratio, 5 epochs x 16 minibatches, Adam,
    # observation and return normalisation, 128x128 tanh networks, a utopia point the sweep
    # estimates from all preferences). A different update, not a paper setting.
    "practical": presets.preset("practical"),
}


def add_run_args(parser: argparse.ArgumentParser, out: str) -> None:
    """The flags both Walker2d scripts take."""
    parser.add_argument("--config", default="paper", help=f"one of {', '.join(CONFIGS)}")
    parser.add_argument("--scale", type=float, default=1.0, help="fraction of 1M env steps")
    parser.add_argument("--steps-per-pref", type=int, default=None, help="overrides --scale")
    parser.add_argument("--physics", default="brax", help="brax or gymnasium-v5")
    parser.add_argument("--engine", default="mjx", help="mjx or mujoco (MuJoCo's C engine)")
    parser.add_argument("--envs-per-pref", type=int, default=None, help="N (default: config's)")
    parser.add_argument("--eval-episodes", type=int, default=8)
    parser.add_argument("--chunks", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=out)
    parser.add_argument("--plot-only", action="store_true", help="redraw a finished --out")
    parser.add_argument(
        "--resume",
        action="store_true",
        help="continue an interrupted run in --out (finished sweeps are read, not rerun)",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the results in a non-empty --out (refused without it or --resume); "
        "the run writes beside --out and replaces it when finished, so an interrupted run "
        "leaves the old results as they were",
    )


def train_config(name: str, **changes) -> PaperConfig:
    """The named configuration `name` with `changes` applied (sizes for tiny runs)."""
    if name not in CONFIGS:
        fail(f"unknown --config {name!r}; valid: {', '.join(CONFIGS)}")
    return CONFIGS[name].replace(**{k: v for k, v in changes.items() if v is not None})


def config_with_flags(name: str, args, **changes):
    """The named configuration `name` with `changes` and then the sweep CLI's config flags
    in `args` (`wcac_jax.sweep.cli.apply_config_flags`) applied, or a one-line exit naming the
    bad flag or value."""
    try:
        return cli.apply_config_flags(args, train_config(name, **changes), f"--config {name}")
    except SweepError as err:
        fail(err)


def steps_per_pref(scale: float, steps: int | None) -> int:
    """Environment steps per preference: `steps`, or `scale` times the paper's 1M."""
    if steps is not None:
        if steps < 1:
            fail(f"--steps-per-pref must be >= 1, got {steps}")
        return steps
    if not scale > 0:
        fail(f"--scale must be > 0, got {scale}")
    return max(1, round(scale * PAPER_STEPS_PER_PREF))


def smoothing_window(steps_per_iteration: int) -> int:
    """Iterations in a moving-average window of about `SMOOTH_STEPS` environment steps."""
    return max(1, round(SMOOTH_STEPS / steps_per_iteration))


def sweep(config: SweepConfig, out: str, chunks: int, resume: bool = False) -> dict:
    """`run_sweep`, with bad input (status 2) and NaN (status 3) as one-line exits.

    With `resume`, a sweep that already finished in `out` (its `front.json` is there) is
    read back instead of rerun, one that was interrupted continues from its checkpoint
    (bit for bit), and one never started starts.
    """
    front_path = os.path.join(out, "front.json")
    started = os.path.isfile(os.path.join(out, "config.json"))
    try:
        if resume and os.path.isfile(front_path):
            check_output_dir(out, config, resume=True)  # the same sweep, or an error
            with open(front_path) as f:
                return rescore_front(json.load(f))  # a front written before today's metrics
        return run_sweep(config, out, chunks=chunks, resume=resume and started)
    except SweepError as err:
        fail(err, 2)
    except TrainingDiverged as err:
        fail(err, 3)


def sweep_config(**fields) -> SweepConfig:
    """`SweepConfig(**fields)`, or a one-line exit (status 2) naming the bad value."""
    try:
        return SweepConfig(**fields)
    except SweepError as err:
        fail(err)


def falls_per_episode(mean_length: float, episode_length: int, episodes: int) -> float | None:
    """The fraction of `episodes` evaluated episodes that ended by a fall, when their mean
    length determines it, else `None`.

    An episode ends by a fall (length `1..episode_length`) or at the time limit (length
    `episode_length`), so `s` survivors need `s * episode_length + (episodes - s) <=
    episodes * mean_length`: when that rules out even one survivor, every episode fell.
    Otherwise (some episode may have reached the limit, or fallen on its last step) the
    mean length cannot tell, and the answer is `None`.
    """
    total = round(episodes * mean_length)  # the sum of the integer lengths
    if episode_length > 1 and total - episodes < episode_length - 1:
        return 1.0
    return None


def policy_summary(row: dict, episode_length: int, episodes: int) -> dict:
    """Forward speed and control effort of one evaluated policy (a `front.json` row).

    The walker's reward per step is `[x_velocity, -sum(a^2)] + healthy` with `healthy = 1`
    on every step but a falling one (0), so over `episodes` episodes of mean length `L`
    with a fraction `f` of them ending by a fall, the mean healthy steps per episode are
    `H = L - f`, and per evaluated step the mean forward speed is `(R_0 - H) / L` m/s and
    the mean control energy `sum(a^2)` is `(H - R_1) / L` (at most 6). `f` comes from the
    episode lengths (`falls_per_episode`); when they leave it open, both are `None` and
    `*_range` gives their bounds over the possible `f` (which the control return bounds
    too: the energy is never negative, so `f <= L - R_1`).

    Args:
      row: a `front.json` preference row (`pref`, `return` [2], `episode_length`).
      episode_length: the evaluation's time limit.
      episodes: evaluated episodes behind the row's means.
    """
    length = float(row["episode_length"])
    forward, control = (float(v) for v in row["return"])
    out = {
        "pref": row["pref"],
        "forward_return": forward,
        "control_return": control,
        "episode_length": length,
    }
    fell = falls_per_episode(length, episode_length, episodes)
    out["falls_per_episode"] = fell
    if fell is not None:
        out["mean_speed_m_per_s"] = (forward - (length - fell)) / length
        out["mean_control_per_step"] = (length - fell - control) / length
    else:
        # survivors s <= (n L - n) / (T - 1), so f >= 1 - s_max / n; and the control
        # energy is >= 0, so the healthy steps L - f are at least R_1: f <= L - R_1
        s_max = (episodes * length - episodes) // max(episode_length - 1, 1)
        lo = max(0.0, 1.0 - s_max / episodes)
        hi = min(1.0, max(lo, length - control))
        out["mean_speed_m_per_s"] = out["mean_control_per_step"] = None
        out["mean_speed_m_per_s_range"] = [(forward - length + f) / length for f in (lo, hi)]
        out["mean_control_per_step_range"] = [(length - f - control) / length for f in (hi, lo)]
    return out


# The hypervolume's sensitivity to its reference point, shown beside the default
# (`Walker2d.default_hv_ref`, (-T, -6T) on undiscounted T-step returns): morl-baselines'
# (-100, -100), which it applies to discounted returns, and (-100, -300).
HV_REFS_SHOWN = ((-100.0, -100.0), (-100.0, -300.0))


def evaluation_setup(front: dict) -> tuple[int, int]:
    """`(episode_length, episodes)` of a Walker2d sweep's evaluation, from its config."""
    from wcac_jax.envs.walker2d import Walker2d

    options = front["config"]["env_options"]
    default = inspect.signature(Walker2d).parameters["episode_length"].default
    return int(options.get("episode_length", default)), int(front["config"]["eval_episodes"])


def hv_refs(front: dict) -> list[tuple[float, ...]]:
    """The environment's default reference point of `front`, then `HV_REFS_SHOWN`."""
    env = envs.make(front["config"]["env"], **front["config"]["env_options"])
    refs = [tuple(float(v) for v in default_hv_ref(env))]
    return refs + [r for r in HV_REFS_SHOWN if r not in refs]


def rescore_front(front: dict) -> dict:
    """`front` with its hypervolume fields recomputed under the environment's default
    reference point (as `run_sweep` writes them today), from its saved returns."""
    front = dict(front)
    ref = hv_refs(front)[0] if front["config"].get("hv_ref") is None else front["config"]["hv_ref"]
    returns = np.array([row["return"] for row in front["prefs"]])
    disc = np.array([row["discounted_return"] for row in front["prefs"]])
    outside = pareto.outside_reference(returns, ref)
    front["prefs"] = [
        {**row, "inside_hv_ref": not bool(out)}
        for row, out in zip(front["prefs"], outside, strict=True)
    ]
    front["hypervolume"] = pareto.hypervolume(returns, ref)
    front["hypervolume_discounted"] = pareto.hypervolume(disc, ref)
    front["hv_ref"] = list(ref)
    front["outside_hv_ref"] = np.flatnonzero(outside).tolist()
    return front


def hypervolume_table(points, refs) -> list[dict]:
    """Per reference point: the hypervolume of `points` `[n, 2]` and the indices of the
    points outside its box (they count for nothing)."""
    return [
        {
            "hv_ref": list(ref),
            "hypervolume": pareto.hypervolume(points, ref),
            "outside": np.flatnonzero(pareto.outside_reference(points, ref)).tolist(),
        }
        for ref in refs
    ]


def machine() -> dict:
    """Where the results were computed."""
    import os
    import platform

    return {
        "platform": jax.default_backend(),
        "devices": [str(d) for d in jax.devices()],
        "device_kind": jax.devices()[0].device_kind,
        "cpu_count": os.cpu_count(),
        "processor": platform.processor() or platform.machine(),
        "versions": library_versions(),
    }
