"""A trained policy's deterministic action in numpy: `NumpyPolicy` and `mean_action`.

The same function as the project's `Trainer.mean_action` (`wcac_jax.core.runtime`), computed
outside JAX from a checkpoint's parameters: the observation normalised by the running
statistics (`(obs - mean) / std`, clipped to `+-obs_clip` where the update clips), the
paper network's bias feature and unit-sphere projection where it has them, a conditioned
network's preference appended after normalisation, the network's dense layers
(`networks.Layer`, in float32 as JAX computes them), and the Gaussian's mean clipped to
`[-1, 1]` and scaled to the environment's action box. Only Gaussian policies (continuous
actions), the MuJoCo tasks' kind.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wcac_jax import algos
from wcac_jax.algos import ConditionedConfig, PaperConfig

ACTIVATIONS = {
    "linear": lambda x: x,
    "relu": lambda x: np.maximum(x, np.float32(0.0)),
    "tanh": np.tanh,
}


@dataclass(frozen=True)
class NumpyPolicy:
    """A deterministic policy as numpy arrays (float32).

    Attributes:
      layers: `((kernel [in, out], bias [out], activation, scale), ...)` first to last
        (`networks.Layer`).
      obs_mean, obs_std: `[obs]` the running statistics; `None`: no normalisation.
      obs_clip: normalised observations are clipped to `+-obs_clip`; `None`: not clipped.
      bias_feature: the paper network's input (`networks.paper_input`): a constant 1
        appended, then projected onto the unit sphere.
      pref: `[m]` a conditioned network's preference, appended after normalisation;
        `None` for a network of one preference.
      action_bound: the half-width of the environment's action box.
    """

    layers: tuple
    obs_mean: np.ndarray | None
    obs_std: np.ndarray | None
    obs_clip: float | None
    bias_feature: bool
    pref: np.ndarray | None
    action_bound: float


def mean_action(policy: NumpyPolicy, obs) -> np.ndarray:
    """The deterministic action as the environment takes it. `obs [..., obs] -> [..., act]`
    (float32)."""
    x = np.asarray(obs, np.float32)
    if policy.obs_mean is not None:
        x = (x - policy.obs_mean) / policy.obs_std
        if policy.obs_clip is not None:
            x = np.clip(x, np.float32(-policy.obs_clip), np.float32(policy.obs_clip))
    if policy.bias_feature:
        x = np.concatenate([x, np.ones_like(x[..., :1])], axis=-1)
        norm = np.sqrt(np.sum(np.square(x), axis=-1, keepdims=True))
        x = x / np.maximum(norm, np.float32(1e-8))
    if policy.pref is not None:
        pref = np.broadcast_to(policy.pref, (*x.shape[:-1], policy.pref.shape[-1]))
        x = np.concatenate([x, pref], axis=-1)
    for kernel, bias, activation, scale in policy.layers:
        x = ACTIVATIONS[activation](x @ kernel + bias)
        if scale != 1.0:
            x = x * np.float32(scale)
    action = np.clip(x, np.float32(-1.0), np.float32(1.0))
    return action if policy.action_bound == 1.0 else np.float32(policy.action_bound) * action


def from_state(config, trainer, env, state, pref=None) -> NumpyPolicy:
    """The numpy policy of one trained state.

    Args:
      config: the update's configuration (`SweepConfig.train_config()`).
      trainer: the `runtime.Trainer` it was trained with (its `policy.layers` reads the
        parameters).
      env: the environment it was trained on (its `action_bound`, default 1).
      state: ONE preference's `UpdateState` (no preference axis).
      pref: `[m]` the preference of a conditioned network; `None` otherwise.

    Raises:
      ValueError: a policy without dense layers (not a Gaussian of this package's
        networks), a conditioned network without `pref`, or a `pref` for one that is not.
    """
    if getattr(env, "num_actions", None) or trainer.policy.layers is None:
        raise ValueError("only a Gaussian policy over continuous actions runs in numpy")
    conditioned = isinstance(config, ConditionedConfig)
    if conditioned != (pref is not None):
        raise ValueError("a preference is given exactly for a conditioned network")
    layers = tuple(
        (
            np.asarray(layer.kernel, np.float32),
            np.asarray(layer.bias, np.float32),
            layer.activation,
            float(layer.scale),
        )
        for layer in trainer.policy.layers(state.actor)
    )
    normalize = bool(config.normalize_obs)
    paper = isinstance(config, PaperConfig)
    if not paper and algos.kind(config) not in ("practical", "conditioned"):
        raise ValueError(f"no numpy policy for the {algos.kind(config)!r} update")
    return NumpyPolicy(
        layers=layers,
        obs_mean=np.asarray(state.obs_stats.mean, np.float32) if normalize else None,
        obs_std=np.asarray(state.obs_stats.std, np.float32) if normalize else None,
        # the paper's update normalises without clipping (`runtime.make_preprocess`)
        obs_clip=None if paper else float(config.obs_clip),
        bias_feature=paper and config.network == "paper",
        pref=None if pref is None else np.asarray(pref, np.float32),
        action_bound=float(getattr(env, "action_bound", 1.0)),
    )
