"""Algorithm 1 + 2 as one pure program: `make_train(config, env)` returns `train(key, pref)`.

`make_trainer` does all Python-side setup (networks, optimizer, wrapped and vmapped env)
and returns pure functions:

- `init(key, pref) -> TrainState` — networks, `N` environments, normaliser;
- `run(state, pref, num_iterations) -> (state, metrics)` — `num_iterations` outer
  iterations as one `lax.scan`; metrics are stacked per iteration (`[T, ...]`)
  (`assemble` builds it, and `mean_action`, from one iteration's `step`, for both updates).

Iteration `t` uses the key `fold_in(state.key, t)`, so splitting a run into chunks of
`run` calls gives bit-identical results to one call. Per iteration, for one preference:

1. critics restart (warm or cold, `critic.restart`);
2. `K` critic steps: all `N` environments step once under the current policy (Markov
   sampling: they continue from where they were) and every critic takes a TD step;
3. `L` rollout steps collect `M = N * L` transitions;
4. TD-residual advantages under the averaged critics, `Jhat` from the start states'
   values, the scalarization's weights, the direction `d` (one backward pass) and the
   actor's optimizer step;
5. the observation normaliser absorbs the iteration's observations.

So each iteration costs `N * (K + L)` environment steps (`config.env_steps_per_iteration`).
Observations are normalised with running mean/std (Brax's `running_statistics`, per
preference) and, for the paper network, given a constant bias feature and projected to
the unit sphere (`networks.paper_input`: a feature that never varies is normalised to 0,
and the bias-free paper network must never see an all-zero input). Actions are
clipped to `[-1, 1]` for the environment; the score uses the unclipped sample.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, NamedTuple

import chex
import jax
import jax.numpy as jnp
import numpy as np
import optax
from brax.envs.base import State
from brax.training.acme import running_statistics, specs
from flax import struct

from wcac_jax import actor, critic, networks, scalarize
from wcac_jax.config import TrainConfig
from wcac_jax.envs.wrappers import EpisodeWrapper
from wcac_jax.types import EpisodeStats, Transition, typed_key

# scalarizations selectable by a traced index (`direction` argument of `train`)
TRACED_DIRECTIONS = ("smooth_wc", "wc", "linear")


@struct.dataclass
class TrainState:
    """Everything one preference's training carries between iterations.

    Attributes:
      actor: policy parameters.
      actor_opt_state: the actor optimizer's state.
      critic: the `m` critics (leaves `[m, ...]`).
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
    actor_opt_state: Any
    critic: critic.CriticState
    obs_stats: running_statistics.RunningStatisticsState
    env_state: State
    episodes: EpisodeStats
    key: chex.PRNGKey
    iteration: chex.Array


class Trainer(NamedTuple):
    """The pure functions of one training setup (see module docstring).

    Attributes:
      init: `(key, pref [m]) -> TrainState`.
      run: `(state, pref [m], num_iterations, direction=None) -> (state, metrics)`;
        `num_iterations` is static (bind it with `functools.partial` before `jit`);
        `direction` is an optional traced index into `TRACED_DIRECTIONS`.
      step: `(state, pref [m], direction=None) -> (state, metrics)`, one iteration.
      policy: the policy (`networks.Policy`).
      value_network: the critics' network `(init, apply)`.
      preprocess: `(obs_stats, obs [..., obs]) -> network input [..., in]` (`in` is
        `network_input_size`).
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
    (which every update's state has). `j_ub`: `[m]`."""
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


def resolve_j_ub(config: TrainConfig, env) -> tuple[float, ...]:
    """The utopia point: `config.j_ub`, or the environment's default; checks its length."""
    j_ub = config.j_ub if config.j_ub is not None else tuple(env.default_j_ub)
    if len(j_ub) != env.num_objectives:
        raise ValueError(
            f"j_ub {list(j_ub)} has {len(j_ub)} entries; the environment has "
            f"{env.num_objectives} objectives ({', '.join(env.objective_names)})"
        )
    return tuple(float(v) for v in j_ub)


def network_input_size(config: TrainConfig, obs_size: int) -> int:
    """The networks' input size: the paper network also takes a bias feature
    (`networks.paper_input`), the MLP (which has biases) the observation alone."""
    return obs_size + 1 if config.network == "paper" else obs_size


def make_policy(config: TrainConfig, env) -> networks.Policy:
    """The actor for `env`'s action space: a Gaussian for continuous actions in
    `[-1, 1]^act`, a softmax over `env.num_actions` for discrete ones."""
    num_actions = getattr(env, "num_actions", None)
    out = int(num_actions) if num_actions else int(env.action_size)
    net = networks.make_network(
        config.network,
        network_input_size(config, int(env.observation_size)),
        out,
        config.width,
        config.depth,
        policy_head=True,
    )
    if num_actions:
        return networks.categorical_policy(net)
    return networks.gaussian_policy(net, out, config.log_std_init, config.learn_log_std)


def init_episodes(n_envs: int, m: int) -> EpisodeStats:
    """Episode bookkeeping of `N` environments before their first step (`[N, m]`, `[N]`)."""
    return EpisodeStats(
        running_return=jnp.zeros((n_envs, m), jnp.float32),
        last_return=jnp.zeros((n_envs, m), jnp.float32),
        finished=jnp.zeros((n_envs,), jnp.int32),
    )


def policy_step(policy, preprocess, v_step, actor_params, obs_stats, env_state, episodes, key):
    """All `N` environments take one step of the policy; shared by the paper's update and
    the practical one (`ppo`).

    Args:
      policy: the `networks.Policy`.
      preprocess: `(obs_stats, obs [N, obs]) -> network input`.
      v_step: the wrapped environment's step, vmapped over `N`.
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
    parameters; shared by both updates.

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


def make_trainer(config: TrainConfig, env) -> Trainer:
    """Builds the pure `init` and `run` of Algorithm 1 + 2 for `env` (see module doc).

    Args:
      config: static sizes and hyperparameters.
      env: a single unbatched Brax-style environment with vector rewards exposing
        `num_objectives`, `default_j_ub` and `episode_length` (see `wcac_jax.envs`).
    """
    m = int(env.num_objectives)
    obs_size = int(env.observation_size)
    j_ub = jnp.asarray(resolve_j_ub(config, env), jnp.float32)
    use_mgda = config.scalarization == "mgda"
    # MGDA has no scalarization of its own; its progress is reported with `smooth_wc`
    scal = scalarize.get("smooth_wc" if use_mgda else config.scalarization)
    n_envs, gamma = config.num_envs, config.gamma

    wrapped = EpisodeWrapper(env, env.episode_length)
    v_reset = jax.vmap(wrapped.reset)
    v_step = jax.vmap(wrapped.step)

    policy = make_policy(config, env)
    value_net = networks.make_network(
        config.network, network_input_size(config, obs_size), 1, config.width, config.depth
    )
    optimizer = actor.make_optimizer(config.actor_optimizer, config.actor_lr)

    def log_prob(params, obs, action):
        return policy.log_prob(policy.apply(params, obs), action)

    def preprocess(obs_stats, obs):
        x = obs
        if config.normalize_obs:
            x = running_statistics.normalize(x, obs_stats)
        if config.network == "paper":
            x = networks.paper_input(x)
        return x

    def init(key: chex.PRNGKey, pref: chex.Array) -> TrainState:
        del pref  # the initial state does not depend on the preference
        key = typed_key(key)
        key_actor, key_critic, key_env, key_run = jax.random.split(key, 4)
        actor_params = policy.init(key_actor)
        env_state = v_reset(jax.random.split(key_env, n_envs))
        return TrainState(
            actor=actor_params,
            actor_opt_state=optimizer.init(actor_params.trainable),
            critic=critic.init(value_net.init, key_critic, m),
            obs_stats=running_statistics.init_state(specs.Array((obs_size,), jnp.float32)),
            env_state=env_state,
            episodes=init_episodes(n_envs, m),
            key=jax.random.key_data(key_run),
            iteration=jnp.zeros((), jnp.int32),
        )

    env_step = functools.partial(policy_step, policy, preprocess, v_step)

    traced_scals = [scalarize.get(name) for name in TRACED_DIRECTIONS]

    def scalarization(direction, j_hat, pref):
        """(weights [m], scalarized value) of the static config, or of a traced index."""
        if direction is None:
            return scal.weights(j_hat, pref, j_ub, config.mu), scal.value(
                j_hat, pref, j_ub, config.mu
            )
        branches = [
            lambda j, p, s=s: (s.weights(j, p, j_ub, config.mu), s.value(j, p, j_ub, config.mu))
            for s in traced_scals
        ]
        return jax.lax.switch(direction, branches, j_hat, pref)

    def iteration(state: TrainState, pref: chex.Array, direction: chex.Array | None = None):
        key_critic, key_rollout = jax.random.split(
            jax.random.fold_in(jax.random.wrap_key_data(state.key), state.iteration)
        )
        obs_stats = state.obs_stats
        prep = functools.partial(preprocess, obs_stats)
        finished_before = jnp.sum(state.episodes.finished)

        # Algorithm 2: K TD steps on fresh on-policy transitions.
        def critic_step(carry, key):
            env_state, episodes, crit = carry
            env_state, episodes, tr = env_step(state.actor, obs_stats, env_state, episodes, key)
            crit, delta = critic.update(
                value_net.apply,
                crit,
                prep(tr.obs),
                tr.reward,
                prep(tr.next_obs),
                tr.terminal,
                gamma=gamma,
                learning_rate=config.critic_lr,
                radius=config.projection_radius,
            )
            return (env_state, episodes, crit), (tr.obs, jnp.mean(jnp.abs(delta), axis=0))

        crit = critic.restart(state.critic, config.critic_warm_start)
        (env_state, episodes, crit), (critic_obs, td_abs) = jax.lax.scan(
            critic_step,
            (state.env_state, state.episodes, crit),
            jax.random.split(key_critic, config.critic_steps),
        )

        # Algorithm 1: an M = N * L sample Markov batch under the same policy.
        (env_state, episodes), batch = rollout(
            env_step, state.actor, obs_stats, env_state, episodes, key_rollout, config.rollout_steps
        )
        flat = jax.tree.map(lambda x: x.reshape((-1, *x.shape[2:])), batch)  # [M, ...]
        avg = critic.averaged_params(crit)
        obs_in = prep(flat.obs)
        v = critic.values(value_net.apply, avg, obs_in)
        v_next = critic.values(value_net.apply, avg, prep(flat.next_obs))
        adv = actor.td_advantages(v, flat.reward, v_next, flat.terminal, gamma)  # [M, m]
        start_obs = prep(env_state.info["first_obs"])
        j_hat = actor.objective_estimates(critic.values(value_net.apply, avg, start_obs))
        if use_mgda:
            if direction is not None:
                raise ValueError("a traced direction index needs a scalarization, not mgda")
            scalarized = scal.value(j_hat, pref, j_ub, config.mu)
            d, weights = actor.mgda_direction(log_prob, state.actor, obs_in, flat.action, adv, pref)
        else:
            weights, scalarized = scalarization(direction, j_hat, pref)
            d = actor.direction(log_prob, state.actor, obs_in, flat.action, adv, weights, pref)
        updates, opt_state = optimizer.update(d, state.actor_opt_state, state.actor.trainable)
        new_actor = state.actor.replace(
            trainable=optax.apply_updates(state.actor.trainable, updates)
        )

        obs_seen = jnp.concatenate(
            [critic_obs.reshape((-1, obs_size)), batch.obs.reshape((-1, obs_size))]
        )
        new_stats = (
            running_statistics.update(obs_stats, obs_seen) if config.normalize_obs else obs_stats
        )
        newly_finished = jnp.sum(episodes.finished) - finished_before
        entropy = jnp.mean(policy.entropy(policy.apply(state.actor, obs_in)))
        metrics = {
            "train/j_hat": j_hat,
            "train/weights": weights,
            "train/scalarized": scalarized,
            "train/g_mu": scalarize.smooth_wc(j_hat, pref, j_ub, config.mu),
            "train/episode_return": finished_episode_return(episodes),
            "train/episodes": newly_finished,
            "train/iteration": state.iteration + 1,
            "train/td_error": jnp.mean(td_abs, axis=0),
            "train/advantage": jnp.mean(adv, axis=0),
            "train/direction_norm": optax.tree.norm(d),
            "train/policy_entropy": entropy,
        }
        new_state = state.replace(
            actor=new_actor,
            actor_opt_state=opt_state,
            critic=crit,
            obs_stats=new_stats,
            env_state=env_state,
            episodes=episodes,
            iteration=state.iteration + 1,
        )
        return new_state, metrics

    return assemble(init, iteration, policy, value_net, preprocess, j_ub)


def env_steps(config: TrainConfig, iterations) -> np.ndarray:
    """Environment steps of one preference after `iterations` outer iterations, as int64
    on the host: `iterations * config.env_steps_per_iteration`.

    Args:
      iterations: `state.iteration` or the `train/iteration` metric, any shape.

    Returns:
      int64 array of the shape of `iterations` (exact far beyond `2^31` steps).
    """
    return np.asarray(iterations, np.int64) * np.int64(config.env_steps_per_iteration)


def with_env_steps(config: TrainConfig, metrics: dict) -> dict:
    """`metrics` (host arrays) with `train/env_steps` added from `train/iteration`."""
    return {**metrics, "train/env_steps": env_steps(config, metrics["train/iteration"])}


def make_train(config: TrainConfig, env) -> Callable:
    """Returns `train(key, pref) -> (TrainState, metrics)`: the whole run, one `lax.scan`.

    `key` (a PRNG key) and `pref` (`[m]`) are traced, so a sweep is
    `jax.jit(jax.vmap(train))(keys [P], prefs [P, m])`; `metrics` leaves are `[T, ...]`
    (`[P, T, ...]` under the vmap). The optional `direction` is a traced integer index
    into `TRACED_DIRECTIONS` (`0`: smooth_wc, `1`: wc, `2`: linear) that overrides
    `config.scalarization`, so scalarizations can be compared inside one compiled program
    (`jax.vmap(train)(keys, prefs, directions)`). See `make_trainer` for the pieces.
    """
    trainer = make_trainer(config, env)

    def train(key: chex.PRNGKey, pref: chex.Array, direction: chex.Array | None = None):
        return trainer.run(trainer.init(key, pref), pref, config.num_iterations, direction)

    return train


def make_evaluate(
    config: TrainConfig, env, num_episodes: int, trainer: Trainer | None = None
) -> Callable:
    """Returns `evaluate(state, key) -> metrics` for the deterministic (mean) policy.

    `trainer` is the training setup whose `mean_action` is evaluated (default:
    `make_trainer(config, env)`; pass another update's, e.g. `ppo.make_trainer`'s).

    Runs `num_episodes` fresh episodes in parallel for up to `env.episode_length` steps
    and returns, for each objective, the mean undiscounted return
    (`eval/return`, `[m]`) and the mean discounted return from the start state
    (`eval/discounted_return`, `[m]`), plus `eval/length` (mean episode length).
    """
    trainer = trainer or make_trainer(config, env)
    wrapped = EpisodeWrapper(env, env.episode_length)
    m = int(env.num_objectives)

    def evaluate(state: TrainState, key: chex.PRNGKey):
        env_state = jax.vmap(wrapped.reset)(jax.random.split(typed_key(key), num_episodes))

        def step(carry, _):
            env_state, alive, ret, disc_ret, discount, length = carry
            action = trainer.mean_action(state, env_state.obs)
            env_state = jax.vmap(wrapped.step)(env_state, action)
            r = env_state.reward * alive[:, None]
            ret, disc_ret = ret + r, disc_ret + discount[:, None] * r
            length = length + alive
            alive = alive * (1.0 - env_state.done)
            return (env_state, alive, ret, disc_ret, discount * gamma, length), None

        gamma = config.gamma
        zeros = jnp.zeros((num_episodes, m), jnp.float32)
        ones = jnp.ones((num_episodes,), jnp.float32)
        carry = (env_state, ones, zeros, zeros, ones, jnp.zeros_like(ones))
        (_, _, ret, disc_ret, _, length), _ = jax.lax.scan(
            step, carry, None, length=int(env.episode_length)
        )
        return {
            "eval/return": jnp.mean(ret, axis=0),
            "eval/discounted_return": jnp.mean(disc_ret, axis=0),
            "eval/length": jnp.mean(length),
        }

    return evaluate
