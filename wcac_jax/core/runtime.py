"""What every update shares: the `Trainer` it returns, the state fields it carries, the
policy and its observation preprocessing, the environments' steps and episode
bookkeeping, the scalarization switch, evaluation and environment-step accounting.

An update (`wcac_jax.algos`) builds its `init` and one-iteration `step` from these
pieces and hands them to `assemble`, which adds the shared `run` (a `lax.scan` of
`step`) and `mean_action`. Iteration `t` draws its randomness from
`fold_in(state.key, t)` (`iteration_key`), so splitting a run into chunks of `run` calls
gives bit-identical results to one call.

Observations are normalised with running mean/std (Brax's `running_statistics`, per
preference; optionally clipped) and, for the paper network, given a constant bias
feature and projected to the unit sphere (`networks.paper_input`: a feature that never
varies is normalised to 0, and the bias-free paper network must never see an all-zero
input). Actions are clipped to `[-1, 1]` for the environment; the score uses the
unclipped sample.
"""

from __future__ import annotations

# the episode wrapper first: it imports MJX (which Brax's modules import) without its
# optional-backend notices
from wcac_jax.core.episodes import EpisodeWrapper  # isort: skip

from collections.abc import Callable
from typing import Any, NamedTuple, Protocol

import chex
import jax
import jax.numpy as jnp
import numpy as np
import optax
from brax.envs.base import State
from brax.training.acme import running_statistics, specs
from flax import struct

from wcac_jax.core import networks, scalarize
from wcac_jax.core.types import EpisodeStats, Transition, typed_key

# scalarizations selectable by a traced index (the `direction` argument of `step`/`run`):
# every registered one, in registration order (`scalarize.register`), read when a program
# is built, so that one registered after import is selectable too
TRACED_DIRECTIONS = scalarize.NAMES


class UpdateState(Protocol):
    """The fields every update's state carries, declared once here; each update's state
    class (`update_state`) adds its own.

    Attributes:
      actor: policy parameters.
      obs_stats: running observation statistics.
      env_state: the `N` environments (leaves `[N, ...]`).
      episodes: episode bookkeeping (`[N, m]`, `[N]`).
      key: raw key data (`jax.random.key_data`) of the run's base key; iteration `t`
        uses `fold_in(key, t)`. Raw, so that states convert to numpy and checkpoint.
      iteration: `t`, outer iterations done (int32: at most `2^31 - 1`; the environment
        steps taken so far are `t * config.env_steps_per_iteration`, counted on the host
        by `env_steps`, since an int32 step counter would overflow at `2^31` steps and
        JAX has no 64-bit integers by default).
    """

    actor: networks.NetParams
    obs_stats: running_statistics.RunningStatisticsState
    env_state: State
    episodes: EpisodeStats
    key: chex.PRNGKey
    iteration: chex.Array


def update_state(order: tuple[str, ...]):
    """Makes a class declaring an update's own state fields a flax struct with
    `UpdateState`'s fields too, all in `order`.

    The order is the pytree's leaf order, which a checkpoint stores by position
    (`wcac_jax.sweep.checkpoint`): it stays what it was when runs were saved, so that they
    restore and resume.

    Raises:
      TypeError: `order` is not exactly the shared and the class's own fields.
    """

    def wrap(cls):
        own = dict(cls.__dict__.get("__annotations__", {}))
        shared = UpdateState.__annotations__
        if sorted(order) != sorted([*shared, *own]):
            raise TypeError(
                f"{cls.__name__}: order {order} must list {sorted([*shared, *own])} once each"
            )
        namespace = {k: v for k, v in cls.__dict__.items() if k not in ("__dict__", "__weakref__")}
        namespace["__annotations__"] = {name: own.get(name, shared.get(name)) for name in order}
        return struct.dataclass(type(cls.__name__, (), namespace))

    return wrap


class Trainer(NamedTuple):
    """The pure functions of one training setup.

    Attributes:
      init: `(key, pref [m]) -> state` (an `UpdateState`).
      run: `(state, pref [m], num_iterations, direction=None) -> (state, metrics)`;
        `num_iterations` is static (bind it with `functools.partial` before `jit`);
        `direction` is an optional traced index into `TRACED_DIRECTIONS`; metrics are
        stacked per iteration (`[T, ...]`).
      step: `(state, pref [m], direction=None) -> (state, metrics)`, one iteration.
      policy: the policy (`networks.Policy`).
      value_network: the critics' network `(init, apply)`.
      preprocess: `(obs_stats, obs [..., obs]) -> network input [..., in]`.
      mean_action: `(state, obs [..., obs]) -> action` the deterministic policy's action
        as the environment takes it (the clipped Gaussian mean; the most likely action).
      j_ub: `[m]` the utopia point in use.
    """

    init: Callable
    run: Callable
    step: Callable
    policy: networks.Policy
    value_network: networks.Network
    preprocess: Callable
    mean_action: Callable
    j_ub: chex.Array


def assemble(init, step, policy, value_net, preprocess, j_ub: chex.Array) -> Trainer:
    """The `Trainer` of an update given its `init` and one-iteration `step`
    `(state, pref [m], direction=None) -> (state, metrics)`: `run` scans `step`, and
    `mean_action` is the policy's mode, reading only `state.actor` and `state.obs_stats`
    (`UpdateState`). `j_ub`: `[m]`."""
    m = j_ub.shape[0]

    def run(state, pref: chex.Array, num_iterations: int, direction=None):
        chex.assert_shape(pref, (m,))
        return jax.lax.scan(
            lambda s, _: step(s, pref, direction), state, None, length=num_iterations
        )

    def mean_action(state, obs: chex.Array) -> chex.Array:
        dist = policy.apply(state.actor, preprocess(state.obs_stats, obs))
        return policy.to_env(policy.mode(dist))

    return Trainer(init, run, step, policy, value_net, preprocess, mean_action, j_ub)


def resolve_j_ub(config, env) -> tuple[float, ...]:
    """The utopia point: `config.j_ub`, or the environment's default; checks its length."""
    j_ub = config.j_ub if config.j_ub is not None else tuple(env.default_j_ub)
    if len(j_ub) != env.num_objectives:
        raise ValueError(
            f"j_ub {list(j_ub)} has {len(j_ub)} entries; the environment has "
            f"{env.num_objectives} objectives ({', '.join(env.objective_names)})"
        )
    return tuple(float(v) for v in j_ub)


# ----------------------------------------------------------------------------- the policy


def make_policy(
    env,
    make_net: Callable[[int], networks.Network],
    log_std_init: float,
    learn_log_std: bool,
    pref_size: int = 0,
) -> networks.Policy:
    """The actor for `env`'s action space: a Gaussian for continuous actions in
    `[-1, 1]^act` scaled to the environment's box (`env.action_bound`: a half-width, or
    one per action dimension; default 1), a softmax over `env.num_actions` for discrete
    ones.

    Args:
      make_net: `out -> network` with `out` outputs (the update's choice of network).
      log_std_init, learn_log_std: the Gaussian's initial log-std and whether it learns.
      pref_size: `m > 0`: the Gaussian's log-std a function of the preference, the
        inputs' last `m` entries (`networks.gaussian_policy`).
    """
    num_actions = getattr(env, "num_actions", None)
    out = int(num_actions) if num_actions else int(env.action_size)
    net = make_net(out)
    if num_actions:
        return networks.categorical_policy(net)
    bound = getattr(env, "action_bound", 1.0)
    return networks.gaussian_policy(net, out, log_std_init, learn_log_std, bound, pref_size)


def make_preprocess(
    normalize_obs: bool, obs_clip: float | None = None, bias_feature: bool = False
) -> Callable:
    """`(obs_stats, obs [..., obs]) -> network input`: running mean/std normalisation
    (with `normalize_obs`; clipped to `+-obs_clip` unless `None`), then, with
    `bias_feature`, the paper network's input (`networks.paper_input`)."""

    def preprocess(obs_stats, obs):
        x = obs
        if normalize_obs:
            x = running_statistics.normalize(x, obs_stats, max_abs_value=obs_clip)
        if bias_feature:
            x = networks.paper_input(x)
        return x

    return preprocess


def update_obs_stats(normalize_obs: bool, obs_stats, obs: chex.Array):
    """The statistics after absorbing `obs` `[B, obs]` (unchanged without normalisation)."""
    return running_statistics.update(obs_stats, obs) if normalize_obs else obs_stats


# ----------------------------------------------------------------------------- environments


class VecEnv(NamedTuple):
    """`N` copies of an environment under `EpisodeWrapper`, vmapped.

    Attributes:
      reset: `keys [N] -> State` (leaves `[N, ...]`).
      step: `(State, action [N, ...]) -> State`.
    """

    reset: Callable
    step: Callable


class UpdateParts(NamedTuple):
    """What an update's `make_trainer` builds once and its iteration's pieces take.

    Attributes:
      config: the update's configuration.
      m: objectives; obs_size: the observation's size.
      j_ub: `[m]` the fixed utopia point (`resolve_j_ub`).
      policy, value_net: the networks; optimizer: the update's optax transformation.
      preprocess: `(obs_stats, obs) -> network input` (`make_preprocess`).
      env_step: `policy_step` with the policy bound; venv: the vectorized environment.
    """

    config: Any
    m: int
    obs_size: int
    j_ub: chex.Array
    policy: networks.Policy
    value_net: networks.Network
    optimizer: optax.GradientTransformation
    preprocess: Callable
    env_step: Callable
    venv: VecEnv


def vectorize(env) -> VecEnv:
    """`env` with its time limit (`EpisodeWrapper`), reset and step vmapped over `N`."""
    wrapped = EpisodeWrapper(env, env.episode_length)
    return VecEnv(jax.vmap(wrapped.reset), jax.vmap(wrapped.step))


def init_episodes(n_envs: int, m: int) -> EpisodeStats:
    """Episode bookkeeping of `N` environments before their first step (`[N, m]`, `[N]`)."""
    return EpisodeStats(
        running_return=jnp.zeros((n_envs, m), jnp.float32),
        last_return=jnp.zeros((n_envs, m), jnp.float32),
        finished=jnp.zeros((n_envs,), jnp.int32),
    )


def init_fields(
    key: chex.PRNGKey, policy: networks.Policy, venv: VecEnv, n_envs: int, m: int, obs_size: int
) -> tuple[dict, chex.PRNGKey]:
    """The `UpdateState` fields of a fresh run, and the key left for the update's critic.

    `key` is split into the actor's, the critic's, the environments' and the run's base
    key, in that order.

    Returns:
      `(fields, critic_key)`, `fields` the keyword arguments of `UpdateState`.
    """
    key_actor, key_critic, key_env, key_run = jax.random.split(typed_key(key), 4)
    fields = {
        "actor": policy.init(key_actor),
        "obs_stats": running_statistics.init_state(specs.Array((obs_size,), jnp.float32)),
        "env_state": venv.reset(jax.random.split(key_env, n_envs)),
        "episodes": init_episodes(n_envs, m),
        "key": jax.random.key_data(key_run),
        "iteration": jnp.zeros((), jnp.int32),
    }
    return fields, key_critic


def iteration_keys(state: UpdateState, num: int = 2) -> chex.PRNGKey:
    """`num` keys of iteration `state.iteration`: `split(fold_in(state.key, t), num)`."""
    base = jax.random.wrap_key_data(state.key)
    return jax.random.split(jax.random.fold_in(base, state.iteration), num)


def policy_step(policy, preprocess, v_step, actor_params, obs_stats, env_state, episodes, key):
    """All `N` environments take one step of the policy.

    Args:
      policy: the `networks.Policy`.
      preprocess: `(obs_stats, obs [N, obs]) -> network input`.
      v_step: the wrapped environment's step, vmapped over `N` (`VecEnv.step`).
      actor_params, obs_stats: the policy's parameters and observation statistics.
      env_state: the `N` environments (leaves `[N, ...]`); `episodes`: their bookkeeping.
      key: this step's key (one sample per environment).

    Returns:
      `(env_state, episodes, transition)`, the transition's leaves `[N, ...]`.
    """
    dist = policy.apply(actor_params, preprocess(obs_stats, env_state.obs))
    action = policy.sample(key, dist)
    next_state = v_step(env_state, policy.to_env(action))
    done = next_state.done
    transition = Transition(
        obs=env_state.obs,
        action=action,
        reward=next_state.reward,
        next_obs=next_state.info["final_obs"],
        terminal=next_state.info["terminal"],
        done=done,
    )
    running = episodes.running_return + next_state.reward
    ended = done[:, None] > 0
    episodes = EpisodeStats(
        running_return=jnp.where(ended, 0.0, running),
        last_return=jnp.where(ended, running, episodes.last_return),
        finished=episodes.finished + (done > 0).astype(jnp.int32),
    )
    return next_state, episodes, transition


def rollout(env_step, actor_params, obs_stats, env_state, episodes, key, length: int):
    """`length` steps of `env_step` (`policy_step` with its policy bound) under fixed
    parameters.

    Returns:
      `((env_state, episodes), transitions)`, the transitions' leaves `[length, N, ...]`.
    """

    def step(carry, key):
        env_state, episodes = carry
        env_state, episodes, tr = env_step(actor_params, obs_stats, env_state, episodes, key)
        return (env_state, episodes), tr

    return jax.lax.scan(step, (env_state, episodes), jax.random.split(key, length))


def finished_episode_return(episodes: EpisodeStats) -> chex.Array:
    """`[m]` the mean last return over the environments that have finished an episode
    (0 while none has)."""
    has_finished = (episodes.finished > 0).astype(jnp.float32)[:, None]
    return jnp.sum(episodes.last_return * has_finished, axis=0) / jnp.maximum(
        jnp.sum(has_finished), 1.0
    )


# ----------------------------------------------------------------------------- scalarization


def scalarization(direction, j_hat: chex.Array, pref: chex.Array, j_ub: chex.Array, mu):
    """`(weights [m], scalarized value)` of the scalarization `direction` at `j_hat`.

    Args:
      direction: a registered name (`scalarize.SCALARIZATIONS`, chosen when the
        program is built), or an index into `TRACED_DIRECTIONS` (static or traced: one
        `lax.switch` over every registered scalarization).
      j_hat, pref, j_ub: `[m]` objective estimates, preference, utopia point.
      mu: the smoothing temperature.
    """
    if isinstance(direction, str):
        scal = scalarize.get(direction)
        return scal.weights(j_hat, pref, j_ub, mu), scal.value(j_hat, pref, j_ub, mu)
    branches = [
        lambda j, p, z, s=s: (s.weights(j, p, z, mu), s.value(j, p, z, mu))
        for s in map(scalarize.get, TRACED_DIRECTIONS)
    ]
    return jax.lax.switch(direction, branches, j_hat, pref, j_ub)


# ----------------------------------------------------------------------------- accounting


def env_steps(config, iterations) -> np.ndarray:
    """Environment steps of one preference after `iterations` outer iterations, as int64
    on the host: `iterations * config.env_steps_per_iteration`.

    Args:
      iterations: `state.iteration` or the `train/iteration` metric, any shape.

    Returns:
      int64 array of the shape of `iterations` (exact far beyond `2^31` steps).
    """
    return np.asarray(iterations, np.int64) * np.int64(config.env_steps_per_iteration)


def with_env_steps(config, metrics: dict) -> dict:
    """`metrics` (host arrays) with `train/env_steps` added from `train/iteration`."""
    return {**metrics, "train/env_steps": env_steps(config, metrics["train/iteration"])}


# ----------------------------------------------------------------------------- evaluation


def make_evaluate(config, env, num_episodes: int, trainer: Trainer) -> Callable:
    """Returns `evaluate(state, key) -> metrics` for the deterministic (mean) policy of
    `trainer` (`trainer.mean_action`).

    Runs `num_episodes` fresh episodes in parallel for up to `env.episode_length` steps
    and returns, for each objective, the mean undiscounted return
    (`eval/return`, `[m]`) and the mean discounted return (discount `config.gamma`) from
    the start state (`eval/discounted_return`, `[m]`), plus `eval/length` (mean episode
    length) and, for an environment that reports its forward speed (`x_velocity` in
    `State.metrics`, the engine's own), `eval/x_velocity`: its mean over every step of
    the episodes (m/s).
    """
    venv = vectorize(env)
    m = int(env.num_objectives)
    gamma = config.gamma

    def evaluate(state: UpdateState, key: chex.PRNGKey):
        env_state = venv.reset(jax.random.split(typed_key(key), num_episodes))
        has_x = "x_velocity" in env_state.metrics

        def step(carry, _):
            (env_state, alive, ret, disc_ret, discount, length), x_sum = carry
            action = trainer.mean_action(state, env_state.obs)
            env_state = venv.step(env_state, action)
            r = env_state.reward * alive[:, None]
            ret, disc_ret = ret + r, disc_ret + discount[:, None] * r
            if has_x:
                x_sum = x_sum + env_state.metrics["x_velocity"] * alive
            length = length + alive
            alive = alive * (1.0 - env_state.done)
            return ((env_state, alive, ret, disc_ret, discount * gamma, length), x_sum), None

        zeros = jnp.zeros((num_episodes, m), jnp.float32)
        ones = jnp.ones((num_episodes,), jnp.float32)
        carry = (env_state, ones, zeros, zeros, ones, jnp.zeros_like(ones))
        ((_, _, ret, disc_ret, _, length), x_sum), _ = jax.lax.scan(
            step, (carry, jnp.zeros_like(ones)), None, length=int(env.episode_length)
        )
        out = {
            "eval/return": jnp.mean(ret, axis=0),
            "eval/discounted_return": jnp.mean(disc_ret, axis=0),
            "eval/length": jnp.mean(length),
        }
        if has_x:
            out["eval/x_velocity"] = jnp.sum(x_sum) / jnp.maximum(jnp.sum(length), 1.0)
        return out

    return evaluate
