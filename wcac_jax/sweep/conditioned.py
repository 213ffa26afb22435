"""A front from ONE preference-conditioned network (`wcac_jax.algos.conditioned`):
`run_conditioned` trains it as a sweep of one row and evaluates it at the sweep's
preferences; `policy_at` and `evaluate_at` read a trained one back at any preference.

The training is `run_sweep`'s (chunked, checkpointed after every chunk, resumable,
bit-identical however it is chunked), on a sweep whose one row is the simplex's centre
(the network ignores it: each environment draws its own preference) and whose
`steps_per_pref` is the whole budget. Its output directory is then a sweep's: `config.json`
(that one-row sweep), `checkpoint/`, `curves.npz` (the one network's curves); and
`front.json`, `front.csv`, `front.png` are rewritten with the network evaluated at every
preference of the asked-for sweep (`front.json["conditioned"]` says so, with the
evaluation's own env steps and seconds). `env_steps_total` is the training's alone.

With `select_last = K > 1` the network's last `K` policies (`select_every` env steps
apart) are kept, and each preference reports the one `choose_policies` picks for it on
episodes of their own, evaluated afresh on the reported episodes
(`front.json["selection"]` records the choice; the candidates' evaluation counts in the
evaluation's env steps): the network's own choice among its recent selves, as
`wcac_jax.sweep.selection` makes a sweep's.
"""

from __future__ import annotations

import dataclasses
import json
import shutil
import tempfile
import time

import jax
import jax.numpy as jnp
import numpy as np

from wcac_jax import algos, protocols
from wcac_jax.algos import conditioned
from wcac_jax.core import runtime
from wcac_jax.sweep import outputs, selection
from wcac_jax.sweep.config import SweepConfig, SweepError, default_hv_ref, make_env, validate_prefs
from wcac_jax.sweep.load import LoadedSweep, load_sweep
from wcac_jax.sweep.outputs import summarize, write_outputs
from wcac_jax.sweep.run import run_sweep


def training_sweep(config: SweepConfig) -> SweepConfig:
    """The one-row sweep that trains `config`'s network: its preferences replaced by the
    simplex's centre (with `select_last > 1` its last policies are kept as the
    candidates `choose_policies` chooses among)."""
    if not isinstance(config.train, algos.ConditionedConfig):
        raise SweepError(
            f"a conditioned front needs the conditioned update, got {algos.kind(config.train)}"
        )
    m = len(config.prefs[0])
    return dataclasses.replace(config, prefs=((1.0 / m,) * m,))


def policy_at(run: LoadedSweep, pref):
    """`obs [..., obs] -> action`: the conditioned network of `run` (a `load_sweep` of a
    conditioned front), its mean action at the preference `pref` `[m]`."""
    return conditioned.policy_at(run.trainer, jax.tree.map(lambda leaf: leaf[0], run.state), pref)


def evaluate_at(
    run: LoadedSweep, prefs, episodes: int | None = None, seed: int = 1, gamma: float | None = None
) -> dict:
    """The network of `run` evaluated at each of `prefs` `[K, m]` (`episodes` fresh ones
    each; default the sweep's): `runtime.make_evaluate`'s metrics `[K, ...]` on the host,
    with returns discounted at `gamma` (default: the training's), and `eval/j_hat`
    `[K, m]`, the critic's `sigma * V(s0, p)` at those episodes' starts."""
    prefs = jnp.asarray(np.asarray(prefs, np.float32))
    keys = jax.random.split(jax.random.key(seed), prefs.shape[0])
    program = _evaluate_program(run, episodes or run.config.eval_episodes, gamma)
    state = jax.tree.map(lambda leaf: leaf[0], run.state)
    return jax.device_get(program(state, keys, prefs))


def _evaluate_program(
    run: LoadedSweep, episodes: int, gamma: float | None, per_pref_state: bool = False
):
    """`(state, keys [K], prefs [K, m]) -> metrics [K, ...]`: one state for every
    preference, or with `per_pref_state` a state per preference (leaves `[K, ...]`)."""
    train = run.config.train_config()
    measured = train if gamma is None else train.replace(gamma=gamma)
    evaluate = conditioned.make_evaluate_at(measured, run.env, episodes, run.trainer)
    estimate = conditioned.make_estimate_at(train, run.env, episodes, run.trainer)

    def one(state, key, pref):
        return {**evaluate(state, key, pref), **estimate(state, key, pref)}

    return jax.jit(jax.vmap(one, in_axes=(0 if per_pref_state else None, 0, 0)))


def measured_returns(config: SweepConfig) -> str:
    """The evaluation's returns a front is judged on: the discounted ones under a protocol
    that discounts, else the undiscounted ones (`eval/...`)."""
    if config.protocol is not None and protocols.get(config.protocol).gamma < 1.0:
        return "eval/discounted_return"
    return "eval/return"


def choose_policies(config: SweepConfig, run: LoadedSweep, prefs, gamma: float) -> tuple:
    """Each preference's policy chosen among the network's last `config.select_last`
    policies (`run.candidates`), as `wcac_jax.sweep.selection` chooses a sweep's: every
    candidate evaluated at every preference on `config.eval_episodes` episodes of their
    own (keys distinct from the reported evaluation's), and the candidate of least
    weighted-Chebyshev regret (the run's criterion, `selection.criterion`) on the returns
    the front is judged on (`measured_returns`) chosen per preference.

    Returns:
      `(states, record)`: the chosen states (leaves `[P, ...]`) and what `front.json`
      records of the choice (`selection`).
    """
    prefs = jnp.asarray(np.asarray(prefs, np.float32))
    program = _evaluate_program(run, config.eval_episodes, gamma)
    keys = jax.random.split(jax.random.key(config.seed + (1 << 29)), prefs.shape[0])
    found = [
        jax.device_get(program(jax.tree.map(lambda x, k=k: x[k, 0], run.candidates), keys, prefs))
        for k in range(len(config.candidate_iterations))
    ]
    key = measured_returns(config)
    returns = np.stack([f[key] for f in found])  # [K, P, m]
    length = np.stack([f["eval/length"] for f in found])  # [K, P]
    by = selection.criterion(config.train)
    index, z, regrets = selection.choose(
        jnp.asarray(returns), prefs, by.margin, by.min_spread, by.score, by.mu
    )
    index = np.asarray(index)
    states = jax.tree.map(lambda x: jnp.asarray(np.asarray(x)[index, 0]), run.candidates)
    iterations = config.candidate_iterations
    record = {
        "rule": selection.rule(by.score),
        "returns": key.removeprefix("eval/"),
        "candidate_iterations": list(iterations),
        "utopia": np.asarray(z).tolist(),
        "chosen_iteration": [iterations[int(k)] for k in index],
        "candidate_return": returns.tolist(),
        "candidate_length": length.tolist(),
        "regret": np.asarray(regrets).tolist(),
        "env_steps": int(np.rint(config.eval_episodes * length.sum())),
    }
    return states, record


def run_conditioned(
    config: SweepConfig,
    out: str | None = None,
    *,
    resume: bool = False,
    overwrite: bool = False,
    chunks: int = 4,
    progress: bool | None = None,
) -> dict:
    """Trains `config`'s conditioned network (`training_sweep`, `config.steps_per_pref`
    env steps in all) and evaluates it at every one of `config.prefs`; returns the
    front (`front.json`'s content). `out`, `resume` and `overwrite` as `run_sweep`'s
    (`out=None`: a temporary directory, removed after; with `overwrite` the whole run,
    training and evaluation, is written beside `out` and replaces it once finished).

    Raises:
      SweepError: bad input; TrainingDiverged: as `run_sweep`.
    """
    if out is None:
        with tempfile.TemporaryDirectory() as tmp:
            return _run(config, tmp, resume, chunks, progress, write=False)
    if not overwrite:
        return _run(config, out, resume, chunks, progress, write=True)
    if resume:
        raise SweepError(
            "--resume continues the sweep in --out and --overwrite replaces it: give one"
        )
    refusal = outputs.out_refusal(out, overwrite=True)
    if refusal is not None:
        raise SweepError(refusal)
    work = outputs.staging_dir(out)
    shutil.rmtree(work, ignore_errors=True)  # an earlier, interrupted try's
    front = _run(config, work, False, chunks, progress, write=True)
    if not front.get("interrupted"):
        outputs.replace_dir(work, out)
    return front


def _run(config, out, resume, chunks, progress, write) -> dict:
    env = make_env(config)
    prefs = validate_prefs(config.prefs, int(env.num_objectives))
    training = training_sweep(config)
    trained = run_sweep(training, out, resume=resume, chunks=chunks, progress=progress)
    if trained.get("interrupted"):
        return trained
    if trained.get("finished") and "conditioned" in trained:
        return trained
    run = load_sweep(out)
    t0 = time.perf_counter()
    gamma = eval_gamma(config)
    seed = config.seed + (1 << 30)
    choice = None
    if config.select_last > 1:
        states, choice = choose_policies(config, run, prefs, gamma)
        program = _evaluate_program(run, config.eval_episodes, gamma, per_pref_state=True)
        keys = jax.random.split(jax.random.key(seed), prefs.shape[0])
        evaluation = jax.device_get(program(states, keys, jnp.asarray(prefs, jnp.float32)))
    else:
        evaluation = evaluate_at(run, prefs, config.eval_episodes, seed=seed, gamma=gamma)
    eval_s = time.perf_counter() - t0
    front = _front(config, run, prefs, evaluation, trained, eval_s)
    front["eval_gamma"] = gamma
    if choice is not None:
        front["selection"] = choice
        front["conditioned"]["eval_env_steps"] += choice["env_steps"]
    if config.protocol is not None:
        front["protocol"] = protocols.front_scores(front)
    if write:
        write_outputs(out, front, run.metrics, np.asarray(run.config.prefs))
    return front


def eval_gamma(config: SweepConfig) -> float:
    """The discount of the evaluation's `discounted_return`: the protocol's, when it
    discounts, else the training's."""
    if config.protocol is not None and protocols.get(config.protocol).gamma < 1.0:
        return protocols.get(config.protocol).gamma
    return config.train.gamma


def _front(config, run, prefs, evaluation, trained, eval_s) -> dict:
    """`front.json`'s content: `outputs.summarize` of the evaluation, each row's `j_hat`,
    `lambda`, `g_mu` at its own preference, and the training's steps and clocks."""
    train = run.config.train_config()
    hv_ref = config.hv_ref if config.hv_ref is not None else default_hv_ref(run.env)
    n = prefs.shape[0]
    tiled = {k: np.broadcast_to(v, (n, *v.shape[1:])) for k, v in run.metrics.items()}
    timing = {k: trained.get(k, 0.0) for k in ("compile_s", "train_s", "wall_s")}
    timing["env_steps_timed"] = trained.get("env_steps_per_s", 0.0) * timing["train_s"]
    timing["parts"] = trained.get("parts", 1)
    timing["timed_from_iteration"] = trained.get("timed_from_iteration", 0)
    j_ub = runtime.resolve_j_ub(train, run.env)
    front = summarize(config, run.env, prefs, j_ub, hv_ref, tiled, evaluation, timing)
    z = jnp.asarray(front["j_ub"], jnp.float32)
    for row, j_hat in zip(front["prefs"], evaluation["eval/j_hat"], strict=True):
        pref = jnp.asarray(row["pref"], jnp.float32)
        weights, value = runtime.scalarization(train.scalarization, j_hat, pref, z, train.mu)
        row["j_hat"] = np.asarray(j_hat).tolist()
        row["lambda"] = np.asarray(weights).tolist()
        row["g_mu"] = row["scalarized"] = float(value)
        row.pop("train_episode_return")
    steps = int(run.metrics["train/env_steps"][0, -1])
    # each preference's mean length over its episodes, times the episodes: its steps (a
    # sum truncated before the product would drop up to `eval_episodes - 1` of them)
    lengths = np.asarray(evaluation["eval/length"], np.float64)
    eval_steps = int(round(float(np.sum(lengths)) * config.eval_episodes))
    front.update(
        env_steps_per_pref=None,
        env_steps_total=steps,
        wall_s=timing["wall_s"] + eval_s,
        conditioned={
            "networks": 1,
            # how the training drew its preferences: "drawn per episode" (at its start,
            # kept to its end) or "drawn per environment" (one for the whole run)
            "preferences": f"drawn per {train.pref_draw}",
            "eval_prefs": n,
            "eval_env_steps": eval_steps,
            "eval_s": eval_s,
        },
        config={**config.to_dict(), "train": algos.to_dict(train)},
    )
    return json.loads(json.dumps(front))
