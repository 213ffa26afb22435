"""A finished run's reported policies evaluated in MO-Gymnasium's own v5 environments.

`load_target` reads what a run reports: an ordinary sweep's policy per preference (its
final one, or the one it chose among its last, `LoadedSweep.chosen`), or a conditioned
network at the front's preferences (for a run made with `--protocol`, the protocol's
preferences, episodes and discount), each as a `numpy_policy.NumpyPolicy`, beside the
project's own evaluation of them (`front.json`). `evaluate` runs each policy's
deterministic action in `mo_gymnasium.make(<the task's id>, max_episode_steps=<the run's
episode length>)`, episode `k` of every preference from `env.reset(seed=seed + k)`, and
`agreement` compares the two evaluations.

The two evaluations draw their reset noise from different generators (MO-Gymnasium's
numpy one, the project's JAX keys), so they agree statistically, not step for step: the
difference of two means of `K` and `K'` episodes of the same policy has the standard error
`s * sqrt(1/K + 1/K')`, with `s` the episodes' standard deviation (measured here; the
project's `front.json` keeps means only). That one step from the same state gives the same
observation and reward vector is the conformance tests' business. Where returns have a
rare mode (a policy that falls early in almost every episode and runs to the time limit
in one of a hundred), `K` episodes may miss it and `s` understates the noise: re-run such
a preference with many episodes on both sides (`load_target`'s `project_episodes`).

MO-Gymnasium is optional: it is imported by `evaluate`'s caller (`make_reference_env`),
never when this module is imported.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import jax
import numpy as np

from wcac_jax import algos, envs, protocols
from wcac_jax.algos import ConditionedConfig
from wcac_jax.evaluate import numpy_policy
from wcac_jax.sweep.conditioned import evaluate_at
from wcac_jax.sweep.config import SweepConfig, SweepError
from wcac_jax.sweep.load import load_sweep

# the v5 tasks and their MO-Gymnasium ids (C-MORL's protocol lists every one of them)
MO_GYMNASIUM_IDS: dict[str, str] = {task.env: task.reference for task in protocols.CMORL.tasks}
# a run's environment options that MO-Gymnasium's environment takes as they are
PASSED_OPTIONS = ("reset_noise_scale",)
RESULT_NAME = "evaluation_mo_gymnasium.json"
# the project's evaluation re-run with more episodes draws them from this key, not the
# run's own evaluation's (`seed + 2^30`)
REEVALUATION_SEED = 12345


class EvaluationError(ValueError):
    """Bad input to an evaluation; the command prints it as one line and exits 2."""


@dataclass(frozen=True)
class Target:
    """What a finished run reports, ready to run outside the project.

    Attributes:
      run: the run's directory.
      env: the task's registered name; gym_id: its MO-Gymnasium id.
      objective_names: the task's objectives.
      gym_kwargs: `mo_gymnasium.make`'s keyword arguments (`max_episode_steps`, and
        the run's reset noise where it set its own).
      notes: how the project's environment differed from MO-Gymnasium's in this run
        (MJX's float32 engine, solver overrides), one line each; empty for none.
      policies: `"final"` (each preference's final policy), `"chosen"` (each one's
        choice among its last policies) or `"conditioned"` (one network).
      prefs: `[P, m]`.
      policy_at: `P` numpy policies, one per preference.
      project: per preference the project's `{"return", "discounted_return",
        "episode_length"}`.
      project_episodes: the episodes of the project's means.
      project_source: where the project's numbers come from (`front.json`, or
        re-evaluated).
      gamma: the discount of both evaluations' `discounted_return`.
      protocol: the run's protocol name, or `None`.
      config: the run's configuration (`front.json["config"]`) and `env_steps_total`.
    """

    run: str
    env: str
    objective_names: tuple[str, ...]
    gym_id: str
    gym_kwargs: dict
    notes: tuple[str, ...]
    policies: str
    prefs: np.ndarray
    policy_at: tuple[numpy_policy.NumpyPolicy, ...]
    project: tuple[dict, ...]
    project_episodes: int
    project_source: str
    gamma: float
    protocol: str | None
    config: dict


def _read_front(run: str) -> dict:
    if not os.path.isfile(os.path.join(run, "config.json")):
        raise EvaluationError(f"no run in {run!r} (no config.json)")
    path = os.path.join(run, "front.json")
    if not os.path.isfile(path):
        raise EvaluationError(f"the run in {run!r} has not finished (no front.json)")
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise EvaluationError(f"{path!r} is not a readable front ({err!r})") from None


def _environment(config: SweepConfig) -> tuple[str, dict, tuple[str, ...]]:
    """`(gym_id, gym_kwargs, notes)` of the run's task, or why it has none."""
    if config.env not in MO_GYMNASIUM_IDS:
        raise EvaluationError(
            f"the run's task {config.env!r} is not one of MO-Gymnasium's v5 MuJoCo tasks "
            f"({', '.join(MO_GYMNASIUM_IDS)})"
        )
    options = {**envs.option_defaults(config.env), **config.env_options}
    if options.get("physics", "gymnasium-v5") != "gymnasium-v5":
        raise EvaluationError(
            f"the run's {config.env} model is {options['physics']!r}, not Gymnasium's v5 "
            "(--physics gymnasium-v5)"
        )
    kwargs = {"max_episode_steps": int(options["episode_length"])}
    kwargs.update({k: options[k] for k in PASSED_OPTIONS if k in config.env_options})
    notes = []
    if options.get("engine") == "mjx":
        notes.append("the project's evaluation ran MJX (float32, its solver capped)")
    for name in ("solver_iterations", "ls_iterations"):
        if options.get(name) is not None:
            notes.append(f"the project's evaluation ran {name}={options[name]}")
    return MO_GYMNASIUM_IDS[config.env], kwargs, tuple(notes)


def _row_index(front: dict) -> dict:
    return {tuple(np.round(row["pref"], 6)): row for row in front["prefs"]}


def _project(row: dict) -> dict:
    return {k: row[k] for k in ("return", "discounted_return", "episode_length")}


def load_target(run: str, prefs: Iterable | None = None, project_episodes: int | None = None):
    """The policies a finished run reports, at `prefs` `[P, m]` (default: the run's own;
    for an ordinary sweep a subset of them, for a conditioned network any), beside the
    project's evaluation of them: `front.json`'s (for a conditioned network at a
    preference its front did not evaluate, its evaluation there with the run's episodes
    and seed), or with `project_episodes` the project's evaluation re-run with that many
    fresh episodes per preference (seed `REEVALUATION_SEED`).

    Raises:
      EvaluationError: no run, an unfinished one, a task with no MO-Gymnasium v5
        environment, or preferences the run has no policy or evaluation for.
    """
    front = _read_front(run)
    try:
        config = SweepConfig.from_dict(front["config"])
    except (KeyError, TypeError, ValueError) as err:
        raise EvaluationError(f"{run!r}'s front.json holds no readable config ({err!r})") from None
    gym_id, gym_kwargs, notes = _environment(config)
    conditioned = isinstance(config.train, ConditionedConfig)
    if conditioned and "conditioned" not in front:
        raise EvaluationError(f"the run in {run!r} has not finished (its front is not evaluated)")
    try:
        loaded = load_sweep(run)
    except SweepError as err:
        raise EvaluationError(str(err)) from None
    rows = _row_index(front)
    m = len(config.prefs[0])
    asked = np.asarray(config.prefs if prefs is None else list(prefs), np.float64)
    if asked.ndim != 2 or asked.shape[1] != m or np.any(np.abs(asked.sum(axis=1) - 1) > 1e-6):
        raise EvaluationError(f"--prefs must be preferences of {m} entries summing to 1")
    train = loaded.config.train_config()
    project, missing = [], []
    for i, pref in enumerate(asked):
        row = rows.get(tuple(np.round(pref, 6)))
        if row is None:
            missing.append(i)
        project.append(None if row is None else _project(row))
    gamma = float(front.get("eval_gamma", config.train.gamma))
    if conditioned:
        states = None
        policies = tuple(
            numpy_policy.from_state(train, loaded.trainer, loaded.env, _row(loaded.state, 0), p)
            for p in asked
        )
    else:
        if missing:
            bad = [asked[i].tolist() for i in missing]
            raise EvaluationError(f"the run has no policy at the preference(s) {bad}")
        reported = loaded.chosen if loaded.chosen is not None else loaded.state
        index = [
            {tuple(np.round(p, 6)): i for i, p in enumerate(config.prefs)}[tuple(np.round(p, 6))]
            for p in asked
        ]
        states = jax.tree.map(lambda leaf: leaf[np.asarray(index)], reported)
        policies = tuple(
            numpy_policy.from_state(train, loaded.trainer, loaded.env, _row(states, i))
            for i in range(len(asked))
        )
    episodes, source = config.eval_episodes, "front.json"
    if project_episodes is not None:  # every preference, on fresh episodes
        episodes, source = project_episodes, f"re-evaluated, seed {REEVALUATION_SEED}"
        project = _evaluate_project(loaded, asked, states, episodes, REEVALUATION_SEED, gamma)
    elif missing:  # the conditioned network where its front was not evaluated
        found = _evaluate_project(
            loaded, asked[missing], None, episodes, config.seed + (1 << 30), gamma
        )
        project = list(project)
        for j, i in enumerate(missing):
            project[i] = found[j]
        source = "front.json; the others evaluated with the run's episodes and seed"
    return Target(
        run=run,
        env=config.env,
        objective_names=tuple(loaded.env.objective_names),
        gym_id=gym_id,
        gym_kwargs=gym_kwargs,
        notes=notes,
        policies="conditioned" if conditioned else "chosen" if loaded.chosen else "final",
        prefs=asked,
        policy_at=policies,
        project=tuple(project),
        project_episodes=episodes,
        project_source=source,
        gamma=gamma,
        protocol=config.protocol,
        config={**front["config"], "env_steps_total": front.get("env_steps_total")},
    )


def _row(states, i: int):
    """Preference `i`'s state of a sweep's (leaves `[P, ...]`)."""
    return jax.tree.map(lambda leaf: leaf[i], states)


def _evaluate_project(loaded, prefs, states, episodes: int, seed: int, gamma: float) -> list:
    """The project's own evaluation (`runtime.make_evaluate`) of `episodes` episodes per
    preference, at `prefs` `[P, m]`: of the conditioned network (`states` `None`), or of
    an ordinary sweep's `states` (leaves `[P, ...]`, one per preference).

    Returns:
      per preference `{"return", "discounted_return", "episode_length"}`.
    """
    if states is None:
        found = evaluate_at(loaded, prefs, episodes, seed=seed, gamma=gamma)
    else:
        train = loaded.config.train_config()
        evaluate = algos.make_evaluate(train, loaded.env, episodes, loaded.trainer)
        keys = jax.random.split(jax.random.key(seed), len(prefs))
        found = jax.device_get(jax.jit(jax.vmap(evaluate))(states, keys))
    return [
        {
            "return": np.asarray(found["eval/return"][i]).tolist(),
            "discounted_return": np.asarray(found["eval/discounted_return"][i]).tolist(),
            "episode_length": float(found["eval/length"][i]),
        }
        for i in range(len(prefs))
    ]


def run_episodes(running: list, policy, seed: int, gamma: float) -> dict:
    """One episode of `policy`'s deterministic action in each environment of `running`,
    episode `k` from `reset(seed=seed + k)`, all stepped together (one policy call per
    step for every episode still running).

    Args:
      running: `K` MO-Gymnasium environments.
      policy: a `numpy_policy.NumpyPolicy`.

    Returns:
      `{"return": [K, m], "discounted_return": [K, m], "length": [K]}` (float64).
    """
    episodes = len(running)
    obs = np.stack([env.reset(seed=seed + k)[0] for k, env in enumerate(running)])
    m = int(running[0].unwrapped.reward_dim)
    ret = np.zeros((episodes, m))
    disc = np.zeros((episodes, m))
    length = np.zeros((episodes,))
    alive = np.ones((episodes,), bool)
    discount = 1.0
    while alive.any():
        live = np.flatnonzero(alive)
        actions = numpy_policy.mean_action(policy, obs[live])
        for k, action in zip(live, actions, strict=True):
            obs[k], reward, terminated, truncated, _ = running[k].step(action)
            ret[k] += reward
            disc[k] += discount * np.asarray(reward, np.float64)
            length[k] += 1
            alive[k] = not (terminated or truncated)
        discount *= gamma
    return {"return": ret, "discounted_return": disc, "length": length}


def _std(x: np.ndarray) -> np.ndarray:
    """The episodes' sample standard deviation (`ddof=1`; NaN for one episode)."""
    if x.shape[0] < 2:
        return np.full(x.shape[1:], np.nan)
    return np.std(x, axis=0, ddof=1)


def summarize_episodes(found: dict) -> dict:
    """Per preference: the means over the episodes, their standard deviations and the
    standard errors of the means (`std / sqrt(K)`)."""
    k = found["length"].shape[0]
    out = {}
    for key, name in (("return", "return"), ("discounted_return", "discounted_return")):
        std = _std(found[key])
        out[name] = np.mean(found[key], axis=0).tolist()
        out[f"{name}_std"] = _finite(std)
        out[f"{name}_se"] = _finite(std / np.sqrt(k))
    out["episode_length"] = float(np.mean(found["length"]))
    out["episode_length_std"] = _finite(_std(found["length"][:, None]))[0]
    out["episode_lengths"] = found["length"].astype(int).tolist()
    return out


def _finite(x) -> list:
    """`x` as a list with NaN as `None` (strict JSON)."""
    return [float(v) if np.isfinite(v) else None for v in np.asarray(x, np.float64).ravel()]


def agreement(rows: list[dict], episodes: int, project_episodes: int) -> dict:
    """How the two evaluations' means differ, per kind of return (undiscounted,
    discounted) over every preference and objective.

    Each difference `d = ours - project` is set against its standard error
    `se = s * sqrt(1/K + 1/K')` (`s` our episodes' standard deviation, `K` our episodes,
    `K'` the project's) as `z = d / se`.

    Returns:
      per kind: `largest_difference` (the largest `|d|`, with its preference, objective,
      `se`, `z` and the standard error of our episode mean `s / sqrt(K)`), `max_abs_z`,
      `beyond_2se` and `beyond_3se` (how many `|z|` pass 2 and 3, against the
      `n * 4.6%` and `n * 0.27%` expected of normal noise), `n` (differences with an
      `se`) and `no_noise` (differences whose episodes did not vary, `se = 0`).
    """
    factor = np.sqrt(1.0 / episodes + 1.0 / project_episodes)
    out = {}
    for kind in ("return", "discounted_return"):
        d, se, se_mean, where = [], [], [], []
        for i, row in enumerate(rows):
            std = np.array([np.nan if v is None else v for v in row[f"{kind}_std"]])
            for j, (ours, theirs) in enumerate(zip(row[kind], row["project"][kind], strict=True)):
                d.append(ours - theirs)
                se.append(std[j] * factor)
                se_mean.append(std[j] / np.sqrt(episodes))
                where.append((i, j))
        d, se, se_mean = np.array(d), np.array(se), np.array(se_mean)
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(se > 0, d / se, np.nan)
        at = int(np.argmax(np.abs(d)))
        i, j = where[at]
        valid = np.isfinite(z)
        out[kind] = {
            "largest_difference": {
                "pref": rows[i]["pref"],
                "objective": j,
                "difference": float(d[at]),
                "se": _finite([se[at]])[0],
                "z": _finite([z[at]])[0],
                "se_of_mean": _finite([se_mean[at]])[0],
            },
            "max_abs_z": float(np.max(np.abs(z[valid]))) if valid.any() else None,
            "beyond_2se": int(np.sum(np.abs(z[valid]) > 2)),
            "beyond_3se": int(np.sum(np.abs(z[valid]) > 3)),
            "n": int(valid.sum()),
            "no_noise": int(np.sum(se == 0)),
        }
    return out


def protocol_scores(protocol: str, rows: list[dict], target: Target, episodes: int) -> dict:
    """The protocol's scores (`protocols.Protocol.score`) of both evaluations' points,
    and how this evaluation departs from the protocol (other preferences or episodes)."""
    spec = protocols.get(protocol)
    task = spec.task(target.env)
    key = "return" if spec.gamma == 1.0 else "discounted_return"
    deviations = []
    grid = spec.eval_prefs(task.num_objectives)
    if target.prefs.shape != grid.shape or not np.allclose(target.prefs, grid, atol=1e-6):
        deviations.append(f"{len(target.prefs)} preferences; the protocol's grid has {len(grid)}")
    if episodes != task.eval_episodes:
        deviations.append(f"{episodes} episodes; the protocol's are {task.eval_episodes}")
    if spec.gamma < 1.0 and target.gamma != spec.gamma:
        deviations.append(f"discounted at {target.gamma}; the protocol's gamma is {spec.gamma}")
    return {
        "protocol": protocol,
        "returns": key,
        "mo_gymnasium": spec.score([row[key] for row in rows]),
        "project": spec.score([row["project"][key] for row in rows]),
        "deviations": deviations,
    }


def evaluate(
    target: Target,
    make_env: Callable,
    episodes: int | None = None,
    seed: int = 0,
    progress: Callable[[Iterable], Iterable] = lambda it: it,
) -> dict:
    """Every preference's policy evaluated in MO-Gymnasium (`run_episodes`), beside the
    project's evaluation (the result file's content, without versions or clocks).

    Args:
      target: `load_target`'s.
      make_env: `() -> ` a new environment of `target.gym_id` with `target.gym_kwargs`.
      episodes: episodes per preference (default: the project's, `target.project_episodes`).
      seed: episode `k` of every preference resets with `seed + k`.
      progress: wraps the preferences' iteration (e.g. `tqdm`).
    """
    episodes = target.project_episodes if episodes is None else episodes
    running = [make_env() for _ in range(episodes)]  # reset anew for every preference
    rows = []
    for pref, policy, project in progress(
        list(zip(target.prefs, target.policy_at, target.project, strict=True))
    ):
        found = run_episodes(running, policy, seed, target.gamma)
        rows.append({"pref": pref.tolist(), **summarize_episodes(found), "project": project})
    for env in running:
        env.close()
    out = {
        "run": target.run,
        "env": target.env,
        "objective_names": list(target.objective_names),
        "mo_gymnasium_id": target.gym_id,
        "mo_gymnasium_kwargs": dict(target.gym_kwargs),
        "notes": list(target.notes),
        "policies": target.policies,
        "inference": "numpy, float32 (wcac_jax.evaluate.numpy_policy)",
        "episodes": episodes,
        "project_episodes": target.project_episodes,
        "project_source": target.project_source,
        "seed": seed,
        "seeds": f"episode k of every preference resets with seed {seed} + k",
        "gamma": target.gamma,
        "agreement": agreement(rows, episodes, target.project_episodes),
        "prefs": rows,
        "run_config": target.config,
    }
    if target.protocol is not None:
        out["protocol"] = protocol_scores(target.protocol, rows, target, episodes)
    return out


def make_reference_env(target: Target) -> Callable:
    """`() -> ` a new `mo_gymnasium` environment of `target` (imports MO-Gymnasium).

    Raises:
      ImportError: MO-Gymnasium is not installed.
      EvaluationError: its environment's observation or action space is not the run's.
    """
    import mo_gymnasium

    def make():
        return _without_mass_warning(lambda: mo_gymnasium.make(target.gym_id, **target.gym_kwargs))

    probe = make()
    obs_size = int(np.prod(probe.observation_space.shape))
    policy = target.policy_at[0]
    act = probe.action_space
    probe.close()
    # the network's first layer takes the observation (and a conditioned one's preference)
    expected = policy.layers[0][0].shape[0] - (0 if policy.pref is None else len(policy.pref))
    expected -= int(policy.bias_feature)
    if obs_size != expected:
        raise EvaluationError(
            f"{target.gym_id}'s observations have {obs_size} entries; the run's policy takes "
            f"{expected}"
        )
    if not np.allclose(act.high, policy.action_bound) or not np.allclose(
        act.low, -policy.action_bound
    ):
        raise EvaluationError(
            f"{target.gym_id}'s actions lie in [{act.low.min()}, {act.high.max()}]; the run's "
            f"policy acts in +-{policy.action_bound}"
        )
    return make


def _without_mass_warning(make: Callable):
    """`make()`, with the line MuJoCo's C library prints each time it loads Gymnasium's
    HalfCheetah model (its `settotalmass` attribute is deprecated; the project's own
    loader, `mujoco_base.load_model`, sets the same mass as MuJoCo's replacement does)
    dropped from the process's output; whatever else the call prints is passed on."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    with tempfile.TemporaryFile() as captured:
        os.dup2(captured.fileno(), 1)
        os.dup2(captured.fileno(), 2)
        try:
            return make()
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            captured.seek(0)
            for line in captured.read().decode(errors="replace").splitlines():
                if line.strip() and "'settotalmass' is deprecated" not in line:
                    print(line, file=sys.stderr)


__all__ = [
    "MO_GYMNASIUM_IDS",
    "RESULT_NAME",
    "EvaluationError",
    "Target",
    "agreement",
    "evaluate",
    "load_target",
    "make_reference_env",
    "protocol_scores",
    "run_episodes",
]
