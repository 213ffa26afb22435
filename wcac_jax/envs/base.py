"""What a multi-objective task declares: `MOEnv`, a Brax `Env` with a reward vector.

Training, the sweep and the outputs read only these from an environment (one unbatched
copy; the caller vmaps):

- `reset(key) -> State`, `step(state, action) -> State` (Brax's API) with `State.reward`
  a float32 vector `[num_objectives]` and `State.done` 1 on a terminal step (a fall; the
  time limit is `EpisodeWrapper`'s, not the environment's);
- `objective_names` (one per objective) and `num_objectives` (their count);
- `default_j_ub`: the utopia point the weighted-Chebyshev scalarization measures from
  unless a run sets its own (`[num_objectives]`, above every return a policy reaches);
- `default_hv_ref`: the hypervolume reference point, per objective the least return an
  episode can have, or for an objective with no such bound a stated floor far below any
  return seen (`sweep.default_hv_ref` reads it);
- `episode_length`: the time limit in steps that training and evaluation wrap it with;
- `observation_size`, `action_size` (Brax's), and `num_actions` for discrete actions;
- `render_scene()`: what `render` draws the environment's positions with, or `None` for
  a task with no picture.

Declarations that depend on options (the time limit, the number of objectives) are set
per instance in the constructor; fixed ones are class attributes. `check` verifies that an
environment's declarations agree with each other.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from brax.envs.base import Env


@dataclass(frozen=True)
class Scene:
    """How to draw an environment: its MuJoCo model (`mujoco.MjModel`) at given `qpos`,
    seen by a camera tracking `track_body` from `distance` (m), `elevation` and
    `azimuth` (degrees; azimuth 90 with elevation near 0 is a side view)."""

    model: Any
    track_body: str
    distance: float
    elevation: float
    azimuth: float


class MOEnv(Env):
    """A Brax `Env` whose reward is a vector, one entry per objective; see the module
    docstring for what a task declares."""

    objective_names: tuple[str, ...]
    default_j_ub: tuple[float, ...]
    default_hv_ref: tuple[float, ...]
    episode_length: int

    @property
    def num_objectives(self) -> int:
        return len(self.objective_names)

    def render_scene(self) -> Scene | None:
        """The model and camera `render.render` draws with; `None`: no picture."""
        return None


def positive_int(name: str, value) -> int:
    """`value` if it is an integer `>= 1` (not a bool), else a `ValueError` naming it."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    return value


def check(env: MOEnv) -> None:
    """Raises `ValueError` unless `env`'s declarations agree: as many objective names,
    utopia entries and hypervolume-reference entries as objectives, each reference entry
    below the utopia's, and a positive integer time limit."""
    m = int(env.num_objectives)
    for name in ("objective_names", "default_j_ub", "default_hv_ref"):
        if len(getattr(env, name)) != m:
            raise ValueError(
                f"{type(env).__name__}.{name} has {len(getattr(env, name))} "
                f"entries for {m} objectives"
            )
    if any(r >= u for r, u in zip(env.default_hv_ref, env.default_j_ub, strict=True)):
        raise ValueError(
            f"{type(env).__name__}: default_hv_ref {env.default_hv_ref} is not below "
            f"default_j_ub {env.default_j_ub}"
        )
    positive_int("episode_length", env.episode_length)
