"""The field's benchmark protocols as data, and the scores they define (numpy only).

A protocol fixes everything a published multi-objective MuJoCo number depends on besides
the learner: the tasks, the episode length, how a policy's objective vector is measured
(deterministic policy, how many episodes, the discount), which points count, the
hypervolume's reference point, the utility grid, how many preferences a
preference-conditioned policy is evaluated at, and the env-step budget of training.
`python -m wcac_jax.sweep --env TASK --protocol NAME` trains at the protocol's budget and
scores the front as the protocol does; `experiments/field.py` sets those scores beside
the published ones on the same definition only.

Two protocols:

- `cmorl`: C-MORL's (ICLR 2025), on MO-Gymnasium's MuJoCo tasks themselves (here their v5
  versions, as the re-runs that D3PO's table reports): 500-step episodes; deterministic
  policy; returns discounted with gamma = 0.99 from the first step; HV of the evaluated
  policies' objective vectors against the reference point -100 on every objective (points
  that do not dominate it add nothing); EU the mean, over a weight grid (step 0.01 for 2
  objectives, 0.1 for 3), of the best `w . J`; 5 evaluation episodes on Hopper-2d, 10 on
  the others; 1.5M env steps of training in all for 2 objectives, 2M for 3.
- `pgmorl`: PGMORL's (ICML 2020) and COLA's (NeurIPS 2025), on their own tasks (the
  `*-pgmorl` and `*-cola` environments, which reset without noise): 500-step episodes;
  deterministic policy; undiscounted returns; points with a negative objective dropped; HV
  against the origin; the conditioned policy evaluated at COLA's preferences (201 for 2
  objectives, 217 for 3), 3 episodes each; 3M env steps of training.

Weight and preference grids are built as the published code builds them (`weight_grid`):
`np.arange(0, 1 + step, step)` per objective, the product kept where its float sum is
exactly 1. For 3 objectives that drops lattice points whose rounded coordinates do not
sum to 1 exactly: C-MORL's EU grid at step 0.1 has 62 of the lattice's 66 weights,
COLA's preferences at step 0.05 217 of 231.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from wcac_jax import pareto


@dataclass(frozen=True)
class Task:
    """One task of a protocol.

    Attributes:
      env: the registered environment (`wcac_jax.envs`).
      published: the task's name in the protocol's papers (e.g. "Hopper-2d").
      reference: the environment's id in the code the protocol was defined on.
      num_objectives: `m`.
      eval_episodes: evaluation episodes per policy (or per preference).
      episode_length: the time limit, in steps.
    """

    env: str
    published: str
    reference: str
    num_objectives: int
    eval_episodes: int
    episode_length: int = 500


@dataclass(frozen=True)
class Protocol:
    """A benchmark protocol (see the module docstring).

    Attributes:
      name: the `--protocol` name.
      title: one line naming it and its sources.
      tasks: its tasks.
      gamma: the discount of the measured returns (1.0: undiscounted).
      ref_value: the hypervolume's reference point, the same on every objective.
      drop_negative: points with a negative objective are dropped before scoring.
      budget_by_m: `{m: env steps of training in all}`.
      eu_step_by_m: `{m: the utility grid's step}` (`weight_grid`).
      pref_step_by_m: `{m: the step of the grid a conditioned policy is evaluated at}`.
    """

    name: str
    title: str
    tasks: tuple[Task, ...]
    gamma: float
    ref_value: float
    drop_negative: bool
    budget_by_m: dict
    eu_step_by_m: dict
    pref_step_by_m: dict

    def task(self, env: str) -> Task:
        """The protocol's task on the environment `env`.

        Raises:
          ValueError: `env` is not one of the protocol's tasks (listing them).
        """
        for task in self.tasks:
            if task.env == env:
                return task
        valid = ", ".join(t.env for t in self.tasks)
        raise ValueError(f"--env {env!r} is not a task of the {self.name} protocol; valid: {valid}")

    def budget(self, m: int) -> int:
        """Env steps of training in all, for `m` objectives."""
        return self.budget_by_m[m]

    def ref_point(self, m: int) -> np.ndarray:
        """`[m]` the hypervolume's reference point."""
        return np.full((m,), self.ref_value, np.float64)

    def eu_weights(self, m: int) -> np.ndarray:
        """`[K, m]` the utility grid."""
        return weight_grid(m, self.eu_step_by_m[m])

    def eval_prefs(self, m: int) -> np.ndarray:
        """`[K, m]` the preferences a conditioned policy is evaluated at."""
        return weight_grid(m, self.pref_step_by_m[m])

    def score(self, returns) -> dict:
        """The protocol's scores of a front.

        Args:
          returns: `[P, m]` each evaluated policy's objective vector, measured as the
            protocol says (discount `gamma`, its episodes' mean).

        Returns:
          `{"hv", "eu", "nondominated", "kept"}`: the hypervolume against
          `ref_point(m)` and the expected utility over `eu_weights(m)`, both of the
          points kept (all of them, or with `drop_negative` those with no negative
          objective; `hv = eu = 0` when none is kept), the number of distinct
          non-dominated points among them that dominate the reference point, and how
          many were kept.
        """
        points = np.asarray(returns, np.float64)
        if points.ndim != 2:
            raise ValueError(f"returns must be [P, m], got shape {points.shape}")
        m = points.shape[1]
        if self.drop_negative:
            points = points[np.all(points >= 0.0, axis=1)]
        if len(points) == 0:
            return {"hv": 0.0, "eu": 0.0, "nondominated": 0, "kept": 0}
        ref = self.ref_point(m)
        inside = points[~pareto.outside_reference(points, ref)]
        return {
            "hv": pareto.hypervolume(points, ref),
            "eu": pareto.expected_utility(points, self.eu_weights(m)),
            "nondominated": pareto.cardinality(inside) if len(inside) else 0,
            "kept": int(len(points)),
        }


def weight_grid(m: int, step: float) -> np.ndarray:
    """`[K, m]` the published code's weight grid: every combination of
    `np.arange(0, 1 + step, step)` over the `m` objectives whose float sum is exactly 1,
    sorted (as `np.unique` sorts rows)."""
    axis = np.arange(0.0, 1.0 + step, step)
    grid = np.array(list(itertools.product(axis, repeat=m)))
    return np.unique(grid[grid.sum(axis=1) == 1.0], axis=0)


CMORL = Protocol(
    name="cmorl",
    title="C-MORL's protocol (ICLR 2025) on MO-Gymnasium's v5 MuJoCo tasks, as D3PO reports it",
    tasks=(
        Task("hopper-2obj", "Hopper-2d", "mo-hopper-2obj-v5", 2, eval_episodes=5),
        Task("hopper", "Hopper-3d", "mo-hopper-v5", 3, eval_episodes=10),
        Task("ant-2obj", "Ant-2d", "mo-ant-2obj-v5", 2, eval_episodes=10),
        Task("ant", "Ant-3d", "mo-ant-v5", 3, eval_episodes=10),
        # C-MORL's code cuts every episode at 500 steps; D3PO's re-run of it on v5 let
        # the humanoid run 1,000. At gamma 0.99 steps 500-999 weigh 0.99^500 = 0.7% of
        # the first step each at most: 500 here, as C-MORL's own code.
        Task("humanoid", "Humanoid-2d", "mo-humanoid-v5", 2, eval_episodes=10),
        Task("walker2d", "Walker-2d", "mo-walker2d-v5", 2, eval_episodes=10),
        Task("halfcheetah", "HalfCheetah-2d", "mo-halfcheetah-v5", 2, eval_episodes=10),
        Task("swimmer", "Swimmer-2d", "mo-swimmer-v5", 2, eval_episodes=10),
    ),
    gamma=0.99,
    ref_value=-100.0,
    drop_negative=False,
    budget_by_m={2: 1_500_000, 3: 2_000_000},
    eu_step_by_m={2: 0.01, 3: 0.1},
    pref_step_by_m={2: 0.01, 3: 0.1},
)

PGMORL = Protocol(
    name="pgmorl",
    title="PGMORL's protocol (ICML 2020) on its own tasks, at COLA's budget and "
    "preferences (NeurIPS 2025)",
    tasks=(
        Task("walker2d-pgmorl", "Walker-2d", "MO-Walker2d-v2", 2, eval_episodes=3),
        Task("halfcheetah-pgmorl", "HalfCheetah-2d (PGMORL)", "MO-HalfCheetah-v2", 2, 3),
        Task("hopper-pgmorl", "Hopper-2d", "MO-Hopper-v2", 2, eval_episodes=3),
        Task("hopper3-pgmorl", "Hopper-3d", "MO-Hopper-v3", 3, eval_episodes=3),
        Task("ant-pgmorl", "Ant-2d", "MO-Ant-v2", 2, eval_episodes=3),
        Task("swimmer-pgmorl", "Swimmer-2d", "MO-Swimmer-v2", 2, eval_episodes=3),
        Task("humanoid-pgmorl", "Humanoid-2d", "MO-Humanoid-v2", 2, 3, episode_length=1000),
        Task("halfcheetah-cola", "HalfCheetah-2d", "MO-New-HalfCheetah-v2", 2, 3),
        Task("ant3-cola", "Ant-3d", "MO-Ant-v3", 3, eval_episodes=3),
    ),
    gamma=1.0,
    ref_value=0.0,
    drop_negative=True,
    budget_by_m={2: 3_000_000, 3: 3_000_000},
    # COLA's utility grid is its evaluation grid for 3 objectives; for 2 it is a list of
    # 18 preferences, so the uniform grid of the evaluation stands in (UT is not compared)
    eu_step_by_m={2: 0.005, 3: 0.05},
    pref_step_by_m={2: 0.005, 3: 0.05},
)

PROTOCOLS: dict[str, Protocol] = {p.name: p for p in (CMORL, PGMORL)}


def get(name: str) -> Protocol:
    """The protocol `name`.

    Raises:
      ValueError: an unknown name (listing the valid ones).
    """
    if name not in PROTOCOLS:
        raise ValueError(f"unknown protocol {name!r}; valid: {', '.join(PROTOCOLS)}")
    return PROTOCOLS[name]


def front_scores(front: dict) -> dict:
    """The protocol's scores of a finished conditioned front (`front.json`'s content, whose
    `config.protocol` names the protocol), and how the run met the protocol.

    Returns:
      `Protocol.score`'s values, and `protocol`, `task` (its published name), `returns`
      (the `front.json` field scored: `discounted_return` at the protocol's gamma, or
      the undiscounted `return`), `budget`, `env_steps_trained`, `eval_prefs`,
      `eval_env_steps` (the choice's among the last policies included), `final_network`
      (with such a choice, the final network's `hv` and `eu` on the choice's own
      episodes; else `None`), and `deviations`: one line per way the run departs from
      the protocol (another budget, other evaluation episodes, preferences or episode
      length); empty when it meets it.
    """
    config = front["config"]
    protocol = get(config["protocol"])
    task = protocol.task(config["env"])
    key = "return" if protocol.gamma == 1.0 else "discounted_return"
    returns = np.array([row[key] for row in front["prefs"]], np.float64)
    m = returns.shape[1]
    budget = protocol.budget(m)
    trained = int(front["env_steps_total"])
    per_iteration = trained // int(config["train"]["num_iterations"])
    deviations = []
    if not budget - per_iteration < trained <= budget:
        deviations.append(
            f"trained {trained:,} env steps; the protocol's budget is {budget:,} "
            f"(whole iterations of {per_iteration:,}: at most the budget, less than one "
            "iteration short of it)"
        )
    if int(config["eval_episodes"]) != task.eval_episodes:
        deviations.append(
            f"{config['eval_episodes']} evaluation episodes per preference; the protocol's "
            f"are {task.eval_episodes}"
        )
    prefs = np.array([row["pref"] for row in front["prefs"]], np.float64)
    expected = protocol.eval_prefs(m)
    if prefs.shape != expected.shape or not np.allclose(prefs, expected, atol=1e-6):
        deviations.append(
            f"evaluated at {len(prefs)} preferences; the protocol's grid has {len(expected)}"
        )
    length = config["env_options"].get("episode_length", task.episode_length)
    if length != task.episode_length:
        deviations.append(f"episode length {length}; the protocol's is {task.episode_length}")
    gamma = front.get("eval_gamma")
    if protocol.gamma < 1.0 and gamma != protocol.gamma:
        deviations.append(
            f"returns discounted at {gamma}; the protocol's gamma is {protocol.gamma}"
        )
    final = None
    if "selection" in front:  # the network's final policy alone, on the choice's episodes
        candidates = np.asarray(front["selection"]["candidate_return"], np.float64)
        final = {k: protocol.score(candidates[-1])[k] for k in ("hv", "eu")}
    return {
        "protocol": protocol.name,
        "task": task.published,
        "returns": key,
        "gamma": protocol.gamma,
        "ref_point": protocol.ref_point(m).tolist(),
        **protocol.score(returns),
        "budget": budget,
        "env_steps_trained": trained,
        "eval_prefs": int(len(prefs)),
        "eval_env_steps": int(front.get("conditioned", {}).get("eval_env_steps", 0)),
        "final_network": final,
        "deviations": deviations,
    }
