"""The paper's update, Algorithms 1 + 2: `PaperConfig` and `make_trainer`.

Per iteration, for one preference:

1. critics restart (warm or cold, `critic.restart`);
2. `K` critic steps: all `N` environments step once under the current policy (Markov
   sampling: they continue from where they were) and every critic takes a TD step with
   projection, the critics' iterates averaged (`wcac_jax.core.critic`);
3. `L` rollout steps collect `M = N * L` transitions;
4. TD-residual advantages under the averaged critics, `Jhat` from the start states'
   values, the scalarization's weights, the score-function direction `d` of the
   smoothed weighted-Chebyshev scalarization (one backward pass, `wcac_jax.core.actor`) and
   the actor's (normalised) optimizer step;
5. the observation normaliser absorbs the iteration's observations.

So each iteration costs `N * (K + L)` environment steps
(`PaperConfig.env_steps_per_iteration`). The shared pieces (rollout, episode
bookkeeping, observation normalisation, the `Trainer`) are `wcac_jax.core.runtime`'s.
"""

from __future__ import annotations

import functools
from typing import Any

import chex
import jax
import jax.numpy as jnp
import optax

from wcac_jax.core import actor, critic, networks, runtime, scalarize
from wcac_jax.core.actor import ACTOR_OPTIMIZERS
from wcac_jax.core.config import (
    INF_AS_NONE,
    TUPLE_AS_LIST,
    Config,
    discount,
    field,
    finite,
    frozen_config,
    one_of,
    optional_point,
    positive_below_f32_max,
    positive_int,
    positive_or_inf,
)
from wcac_jax.core.networks import NETWORK_KINDS


def _scalarization_names():
    return (*scalarize.SCALARIZATIONS, "mgda")


@frozen_config
class PaperConfig(Config):
    """Hyperparameters of Algorithm 1 + 2 for one preference (the sweep vmaps over `P`).

    The defaults are the paper's setting (Algorithm 2's cold restart and projection,
    Appendix B.2's sizes and step sizes). On `projection_radius`: the paper gives no
    value (its theory asks for `B = Theta(w^(1/32) D^-6)`, constant unstated); the
    default 1.0 is the measured reach of Algorithm 2 itself: on Walker2d (paper network,
    w = 256, D = 2, beta = 1e-3, N = 16), K = 10 TD steps from `W(0)` moved a layer by a
    median 0.33-0.59 and at most 0.99 over 40 iterations (against `||W_b(0)||_F` = 362),
    so the ball holds every iterate the paper's own steps normally reach and binds only
    on a runaway step, keeping `W` in the near-initial regime the analysis needs (warm
    critics, unprojected, drifted 2.6-5.2 from `W(0)` in the same 40 iterations).
    """

    num_envs: int = field(16, "N, parallel environments per preference", positive_int)
    critic_steps: int = field(
        10, "K, TD steps (each one step of all N environments) per iteration", positive_int
    )
    rollout_steps: int = field(
        10, "L, actor rollout steps per iteration (M = N * L samples)", positive_int
    )
    num_iterations: int = field(100, "T, outer iterations", positive_int)
    gamma: float = field(0.99, "discount", discount)
    mu: float = field(0.05, "smoothing temperature of smooth_wc", positive_below_f32_max)
    j_ub: tuple[float, ...] | None = field(
        None,
        "utopia point, one entry per objective (None: the environment's default)",
        optional_point,
        TUPLE_AS_LIST,
    )
    scalarization: str = field(
        "smooth_wc",
        "the actor's direction, a registered scalarization (smooth_wc is the method) or "
        "mgda (MGDA's common-descent direction, a baseline)",
        one_of(_scalarization_names),
    )
    network: str = field(
        "paper",
        "'paper' (the paper's ReLU network, observations projected to the unit sphere "
        "after normalisation) or 'mlp' (a trainable MLP), for the actor and critics alike",
        one_of(NETWORK_KINDS),
    )
    width: int = field(256, "w, hidden width of both networks", positive_int)
    depth: int = field(2, "D, hidden layers of both networks", positive_int)
    actor_lr: float = field(3e-4, "alpha, the actor's step size", positive_below_f32_max)
    critic_lr: float = field(1e-3, "beta, the critics' TD step size", positive_below_f32_max)
    actor_optimizer: str = field(
        "normalized",
        "normalized (the paper, constant alpha), normalized_harmonic (alpha / (t + 1)), "
        "adam or sgd",
        one_of(ACTOR_OPTIMIZERS),
    )
    projection_radius: float = field(
        1.0,
        "B, radius of the critics' per-layer Frobenius balls around W(0) (inf: no projection)",
        positive_or_inf,
        INF_AS_NONE,
    )
    critic_warm_start: bool = field(
        False,
        "continue from the last iteration's critics instead of restarting every critic "
        "from W(0) (Algorithm 2); a practical departure",
    )
    log_std_init: float = field(-0.5, "initial log-std of the Gaussian policy", finite)
    learn_log_std: bool = field(True, "whether the policy's log-std is trained")
    normalize_obs: bool = field(True, "running mean/std observation normalisation (per preference)")

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


@runtime.update_state(
    ("actor", "actor_opt_state", "critic", "obs_stats", "env_state", "episodes", "key", "iteration")
)
class PaperState:
    """One preference's training state: `runtime.UpdateState`'s fields and

    Attributes:
      actor_opt_state: the actor optimizer's state.
      critic: the `m` critics (leaves `[m, ...]`).
    """

    actor_opt_state: Any
    critic: critic.CriticState


def network_input_size(config: PaperConfig, obs_size: int) -> int:
    """The networks' input size: the paper network also takes a bias feature
    (`networks.paper_input`), the MLP (which has biases) the observation alone."""
    return obs_size + 1 if config.network == "paper" else obs_size


def default_networks(config: PaperConfig) -> networks.NetworkFactory:
    """The networks of `config`: `config.network` (the paper's, or an MLP) of
    `config.width` and `config.depth`, with a policy head for the actor."""

    def factory(in_size: int, out_size: int, *, role: str) -> networks.Network:
        return networks.make_network(
            config.network,
            in_size,
            out_size,
            config.width,
            config.depth,
            policy_head=role == "actor",
        )

    return factory


def make_policy(
    config: PaperConfig, env, network_factory: networks.NetworkFactory | None = None
) -> networks.Policy:
    """The actor for `env` (`runtime.make_policy`) on `network_factory`'s network
    (default: `config.network`, `default_networks`)."""
    in_size = network_input_size(config, int(env.observation_size))
    factory = network_factory or default_networks(config)
    return runtime.make_policy(
        env,
        lambda out: factory(in_size, out, role="actor"),
        config.log_std_init,
        config.learn_log_std,
    )


def _init(parts: runtime.UpdateParts, key: chex.PRNGKey, pref: chex.Array) -> PaperState:
    del pref  # the initial state does not depend on the preference
    config = parts.config
    fields, key_critic = runtime.init_fields(
        key, parts.policy, parts.venv, config.num_envs, parts.m, parts.obs_size
    )
    return PaperState(
        **fields,
        actor_opt_state=parts.optimizer.init(fields["actor"].trainable),
        critic=critic.init(parts.value_net.init, key_critic, parts.m),
    )


def _critic_phase(parts: runtime.UpdateParts, state: PaperState, key: chex.PRNGKey):
    """Algorithm 2: `K` TD steps on fresh on-policy transitions.

    Returns:
      `(env_state, episodes, critics, observations [K, N, obs], |TD error| [K, m])`.
    """
    config, prep = parts.config, functools.partial(parts.preprocess, state.obs_stats)

    def critic_step(carry, key):
        env_state, episodes, crit = carry
        env_state, episodes, tr = parts.env_step(
            state.actor, state.obs_stats, env_state, episodes, key
        )
        crit, delta = critic.update(
            parts.value_net.apply,
            crit,
            prep(tr.obs),
            tr.reward,
            prep(tr.next_obs),
            tr.terminal,
            gamma=config.gamma,
            learning_rate=config.critic_lr,
            radius=config.projection_radius,
        )
        return (env_state, episodes, crit), (tr.obs, jnp.mean(jnp.abs(delta), axis=0))

    crit = critic.restart(state.critic, config.critic_warm_start)
    (env_state, episodes, crit), (critic_obs, td_abs) = jax.lax.scan(
        critic_step,
        (state.env_state, state.episodes, crit),
        jax.random.split(key, config.critic_steps),
    )
    return env_state, episodes, crit, critic_obs, td_abs


def _actor_direction(parts: runtime.UpdateParts, state, crit, flat, start_obs, pref, direction):
    """Algorithm 1's direction from an `M`-sample batch `flat` (leaves `[M, ...]`) under
    the averaged critics: `(d, weights [m], scalarized, j_hat [m], adv [M, m], obs_in)`."""
    config, value_net = parts.config, parts.value_net
    prep = functools.partial(parts.preprocess, state.obs_stats)
    avg = critic.averaged_params(crit)
    obs_in = prep(flat.obs)
    v = critic.values(value_net.apply, avg, obs_in)
    v_next = critic.values(value_net.apply, avg, prep(flat.next_obs))
    adv = actor.td_advantages(v, flat.reward, v_next, flat.terminal, config.gamma)  # [M, m]
    j_hat = actor.objective_estimates(critic.values(value_net.apply, avg, prep(start_obs)))

    def log_prob(params, obs, action):
        return parts.policy.log_prob(parts.policy.apply(params, obs), action)

    if config.scalarization == "mgda":
        if direction is not None:
            raise ValueError("a traced direction index needs a scalarization, not mgda")
        # MGDA has no scalarization of its own; its progress is reported with `smooth_wc`
        scalarized = scalarize.smooth_wc(j_hat, pref, parts.j_ub, config.mu)
        d, weights = actor.mgda_direction(log_prob, state.actor, obs_in, flat.action, adv, pref)
    else:
        weights, scalarized = runtime.scalarization(
            config.scalarization if direction is None else direction,
            j_hat,
            pref,
            parts.j_ub,
            config.mu,
        )
        d = actor.direction(log_prob, state.actor, obs_in, flat.action, adv, weights, pref)
    return d, weights, scalarized, j_hat, adv, obs_in


def _iteration(parts: runtime.UpdateParts, state: PaperState, pref: chex.Array, direction=None):
    """One outer iteration (see the module docstring): `(state, metrics)`."""
    config, obs_size = parts.config, parts.obs_size
    key_critic, key_rollout = runtime.iteration_keys(state)
    finished_before = jnp.sum(state.episodes.finished)

    env_state, episodes, crit, critic_obs, td_abs = _critic_phase(parts, state, key_critic)
    # Algorithm 1: an M = N * L sample Markov batch under the same policy.
    (env_state, episodes), batch = runtime.rollout(
        parts.env_step,
        state.actor,
        state.obs_stats,
        env_state,
        episodes,
        key_rollout,
        config.rollout_steps,
    )
    flat = jax.tree.map(lambda x: x.reshape((-1, *x.shape[2:])), batch)  # [M, ...]
    d, weights, scalarized, j_hat, adv, obs_in = _actor_direction(
        parts, state, crit, flat, env_state.info["first_obs"], pref, direction
    )
    updates, opt_state = parts.optimizer.update(d, state.actor_opt_state, state.actor.trainable)
    new_actor = state.actor.replace(trainable=optax.apply_updates(state.actor.trainable, updates))

    obs_seen = jnp.concatenate(
        [critic_obs.reshape((-1, obs_size)), batch.obs.reshape((-1, obs_size))]
    )
    policy = parts.policy
    metrics = {
        "train/j_hat": j_hat,
        "train/weights": weights,
        "train/scalarized": scalarized,
        "train/g_mu": scalarize.smooth_wc(j_hat, pref, parts.j_ub, config.mu),
        "train/episode_return": runtime.finished_episode_return(episodes),
        "train/episodes": jnp.sum(episodes.finished) - finished_before,
        "train/iteration": state.iteration + 1,
        "train/td_error": jnp.mean(td_abs, axis=0),
        "train/advantage": jnp.mean(adv, axis=0),
        "train/direction_norm": optax.tree.norm(d),
        "train/policy_entropy": jnp.mean(policy.entropy(policy.apply(state.actor, obs_in))),
    }
    new_state = state.replace(
        actor=new_actor,
        actor_opt_state=opt_state,
        critic=crit,
        obs_stats=runtime.update_obs_stats(config.normalize_obs, state.obs_stats, obs_seen),
        env_state=env_state,
        episodes=episodes,
        iteration=state.iteration + 1,
    )
    return new_state, metrics


def make_trainer(
    config: PaperConfig, env, network_factory: networks.NetworkFactory | None = None
) -> runtime.Trainer:
    """Builds the pure `init`/`run`/`step` of Algorithm 1 + 2 for `env`.

    Args:
      config: static sizes and hyperparameters.
      env: a single unbatched Brax-style environment with vector rewards exposing
        `num_objectives`, `default_j_ub` and `episode_length` (see `wcac_jax.envs`).
      network_factory: builds the actor and each critic (`networks.NetworkFactory`;
        default `default_networks(config)`).
    """
    obs_size = int(env.observation_size)
    j_ub = jnp.asarray(runtime.resolve_j_ub(config, env), jnp.float32)
    venv = runtime.vectorize(env)
    factory = network_factory or default_networks(config)
    policy = make_policy(config, env, factory)
    value_net = factory(network_input_size(config, obs_size), 1, role="critic")
    preprocess = runtime.make_preprocess(
        config.normalize_obs, bias_feature=config.network == "paper"
    )
    parts = runtime.UpdateParts(
        config=config,
        m=int(env.num_objectives),
        obs_size=obs_size,
        j_ub=j_ub,
        policy=policy,
        value_net=value_net,
        optimizer=actor.make_optimizer(config.actor_optimizer, config.actor_lr),
        preprocess=preprocess,
        env_step=functools.partial(runtime.policy_step, policy, preprocess, venv.step),
        venv=venv,
    )
    init = functools.partial(_init, parts)
    step = functools.partial(_iteration, parts)
    return runtime.assemble(init, step, policy, value_net, preprocess, j_ub)
