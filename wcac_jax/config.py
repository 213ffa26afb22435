"""Static configuration of a training run: sizes and hyperparameters, frozen and validated.

Everything here is static (closed over by the compiled program); what is swept — the
preference vector and the PRNG key — is a traced argument of `train`, never config.
Derived sizes are properties. Invalid values raise `ValueError` naming the field, the
bad value and what is allowed.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from wcac_jax.actor import ACTOR_OPTIMIZERS
from wcac_jax.networks import NETWORK_KINDS
from wcac_jax.scalarize import SCALARIZATIONS

# The programs compute in float32: a value finite in float64 but not in float32 (e.g.
# 1e39) would only show up later as a NaN "divergence".
F32_MAX = 3.4028234663852886e38  # numpy.finfo(numpy.float32).max


def finite_f32(value) -> bool:
    """Whether `value` is a number that is finite in float32 (False for inf and NaN)."""
    try:
        return abs(float(value)) <= F32_MAX
    except (TypeError, ValueError):
        return False


@dataclass(frozen=True)
class TrainConfig:
    """Hyperparameters of Algorithm 1 + 2 for one preference (the sweep vmaps over `P`).

    The defaults are the paper's setting (Algorithm 2's cold restart and projection,
    Appendix B.2's sizes and step sizes).

    Attributes:
      num_envs: `N`, parallel environments per preference.
      critic_steps: `K`, TD steps (each one environment step of all `N` envs) per iteration.
      rollout_steps: `L`, actor rollout steps per iteration (`M = N * L` samples).
      num_iterations: `T`, outer iterations.
      gamma: discount.
      mu: smoothing temperature of `smooth_wc`.
      j_ub: utopia point, one entry per objective; `None` takes the environment's default.
      scalarization: the actor's direction: `"smooth_wc"` (the method), `"wc"`,
        `"linear"`, or `"mgda"` (MGDA's common-descent direction, a baseline; see
        `actor.mgda_direction`).
      network: `"paper"` (the paper's ReLU network; observations are then projected to
        the unit sphere after normalisation) or `"mlp"` (a trainable flax MLP), for the
        actor and the critics alike.
      width, depth: `w`, `D` of both networks.
      actor_lr: `alpha`.
      critic_lr: `beta`.
      actor_optimizer: `"normalized"` (paper, constant `alpha`), `"normalized_harmonic"`
        (`alpha / (t + 1)`), `"adam"` or `"sgd"`.
      projection_radius: `B` of the critics' per-layer Frobenius balls around `W(0)`
        (`inf`: no projection). The paper gives no value (its theory asks for
        `B = Theta(w^(1/32) D^-6)`, constant unstated); the default 1.0 is the measured
        reach of Algorithm 2 itself: on Walker2d (paper network, w = 256, D = 2,
        beta = 1e-3, N = 16), K = 10 TD steps from `W(0)` moved a layer by a median
        0.33-0.59 and at most 0.99 over 40 iterations (against `||W_b(0)||_F` = 362), so
        the ball holds every iterate the paper's own steps normally reach and binds only
        on a runaway step, keeping `W` in the near-initial regime the analysis needs
        (warm critics, unprojected, drifted 2.6-5.2 from `W(0)` in the same 40 iterations).
      critic_warm_start: `False` (default, the paper's Algorithm 2): every critic
        restarts from `W(0)` at each iteration; `True` continues from the last
        iteration's critics (learns values across iterations; a practical departure).
      log_std_init: initial log-std of the Gaussian policy.
      learn_log_std: whether the log-std is trained.
      normalize_obs: running mean/std observation normalisation (per preference).
    """

    num_envs: int = 16
    critic_steps: int = 10
    rollout_steps: int = 10
    num_iterations: int = 100
    gamma: float = 0.99
    mu: float = 0.05
    j_ub: tuple[float, ...] | None = None
    scalarization: str = "smooth_wc"
    network: str = "paper"
    width: int = 256
    depth: int = 2
    actor_lr: float = 3e-4
    critic_lr: float = 1e-3
    actor_optimizer: str = "normalized"
    projection_radius: float = 1.0
    critic_warm_start: bool = False
    log_std_init: float = -0.5
    learn_log_std: bool = True
    normalize_obs: bool = True

    def __post_init__(self):
        for name in (
            "num_envs",
            "critic_steps",
            "rollout_steps",
            "num_iterations",
            "width",
            "depth",
        ):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if not 0.0 <= self.gamma < 1.0:
            raise ValueError(f"gamma must be in [0, 1), got {self.gamma!r}")
        for name in ("mu", "actor_lr", "critic_lr", "projection_radius"):
            value = getattr(self, name)
            if not value > 0:  # also rejects NaN
                raise ValueError(f"{name} must be > 0, got {value!r}")
            if name != "projection_radius" and not finite_f32(value):
                raise ValueError(
                    f"{name} must be finite in float32 (< {F32_MAX:.4g}), got {value!r}"
                )
        if not finite_f32(self.log_std_init):
            raise ValueError(f"log_std_init must be finite, got {self.log_std_init!r}")
        if self.j_ub is not None:
            j_ub = tuple(float(v) for v in self.j_ub)
            if not all(finite_f32(v) for v in j_ub):
                raise ValueError(
                    f"j_ub must be finite in float32 (|x| < {F32_MAX:.4g}), got {list(self.j_ub)!r}"
                )
            object.__setattr__(self, "j_ub", j_ub)
        choices = {
            "scalarization": (*SCALARIZATIONS, "mgda"),
            "network": NETWORK_KINDS,
            "actor_optimizer": ACTOR_OPTIMIZERS,
        }
        for name, valid in choices.items():
            if getattr(self, name) not in valid:
                raise ValueError(
                    f"{name} must be one of {', '.join(valid)}; got {getattr(self, name)!r}"
                )

    @property
    def env_steps_per_iteration(self) -> int:
        """Environment steps of one preference per outer iteration: `N * (K + L)`."""
        return self.num_envs * (self.critic_steps + self.rollout_steps)

    @property
    def total_env_steps(self) -> int:
        """Environment steps of one preference over the whole run."""
        return self.env_steps_per_iteration * self.num_iterations

    @property
    def actor_batch(self) -> int:
        """`M = N * L`, samples per actor step."""
        return self.num_envs * self.rollout_steps

    def replace(self, **changes) -> TrainConfig:
        """A copy with `changes` applied (and validated)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        """A JSON-friendly dict of every field."""
        out = dataclasses.asdict(self)
        out["projection_radius"] = (
            None if math.isinf(self.projection_radius) else self.projection_radius
        )
        out["j_ub"] = None if self.j_ub is None else list(self.j_ub)
        return out
