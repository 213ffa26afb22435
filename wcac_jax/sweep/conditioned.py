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

from wcac_jax import algos, outputs, runtime
from wcac_jax.algos import conditioned
from wcac_jax.outputs import summarize, write_outputs
from wcac_jax.sweep.config import SweepConfig, SweepError, default_hv_ref, make_env, validate_prefs
from wcac_jax.sweep.load import LoadedSweep, load_sweep
from wcac_jax.sweep.run import run_sweep


def training_sweep(config: SweepConfig) -> SweepConfig:
    """The one-row sweep that trains `config`'s network: its preferences replaced by the
    simplex's centre, its own final policy reported."""
    if not isinstance(config.train, algos.ConditionedConfig):
        raise SweepError(
            f"a conditioned front needs the conditioned update, got {algos.kind(config.train)}"
        )
    m = len(config.prefs[0])
    return dataclasses.replace(config, prefs=((1.0 / m,) * m,), select_last=1, select_every=0)


def policy_at(run: LoadedSweep, pref):
    """`obs [..., obs] -> action`: the conditioned network of `run` (a `load_sweep` of a
    conditioned front), its mean action at the preference `pref` `[m]`."""
    return conditioned.policy_at(run.trainer, jax.tree.map(lambda leaf: leaf[0], run.state), pref)


def evaluate_at(run: LoadedSweep, prefs, episodes: int | None = None, seed: int = 1) -> dict:
    """The network of `run` evaluated at each of `prefs` `[K, m]` (`episodes` fresh ones
    each; default the sweep's): `runtime.make_evaluate`'s metrics `[K, ...]` on the host,
    and `eval/j_hat` `[K, m]`, the critic's `sigma * V(s0, p)` at those episodes' starts."""
    prefs = jnp.asarray(np.asarray(prefs, np.float32))
    keys = jax.random.split(jax.random.key(seed), prefs.shape[0])
    program = _evaluate_program(run, episodes or run.config.eval_episodes)
    state = jax.tree.map(lambda leaf: leaf[0], run.state)
    return jax.device_get(program(state, keys, prefs))


def _evaluate_program(run: LoadedSweep, episodes: int):
    train = run.config.train_config()
    evaluate = conditioned.make_evaluate_at(train, run.env, episodes, run.trainer)
    estimate = conditioned.make_estimate_at(train, run.env, episodes, run.trainer)

    def one(state, key, pref):
        return {**evaluate(state, key, pref), **estimate(state, key, pref)}

    return jax.jit(jax.vmap(one, in_axes=(None, 0, 0)))


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
    evaluation = evaluate_at(run, prefs, config.eval_episodes, seed=config.seed + (1 << 30))
    eval_s = time.perf_counter() - t0
    front = _front(config, run, prefs, evaluation, trained, eval_s)
    if write:
        write_outputs(out, front, run.metrics, np.asarray(run.config.prefs))
    return front


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
            "eval_prefs": n,
            "eval_env_steps": eval_steps,
            "eval_s": eval_s,
        },
        config={**config.to_dict(), "train": algos.to_dict(train)},
    )
    return json.loads(json.dumps(front))
