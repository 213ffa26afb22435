"""The practical update: `PracticalConfig` and `make_trainer`. The same smoothed
weighted-Chebyshev direction as the paper's update, optimised the way on-policy deep RL
is in practice (a PPO-style clipped surrogate, as morl-baselines' MOPPO does).

Per preference `p` and iteration, the `N` environments take `L` steps under the current
policy (`M = N * L` transitions), and then:

1. rewards are divided, per objective, by the running std of their discounted return
   (`sigma_i`, clipped to `+-reward_clip`); observations are normalised by running
   mean/std (clipped to `+-obs_clip`);
2. a vector critic (one network, `m` outputs) gives per-objective GAE advantages
   (`losses.gae`): falls do not bootstrap, time-limit truncation bootstraps from the true next
   observation (`info["final_obs"]`), and the recursion stops at every episode end;
3. `Jhat_i = sigma_i * mean_{s0} V_i(s0)` (discounted, in the objectives' own units), the
   utopia point `z` (fixed, or estimated by the whole sweep, see `wcac_jax.core.utopia`), and
   the scalarization's weights `w` (`lambda` for `smooth_wc`) give the scalarized
   advantage `sum_i w_i p_i sigma_i A_i` — the advantage of the direction
   `-sum_i w_i p_i gradJ_i` of `actor.direction`, with each `A_i` back in its
   objective's units (with `augment = rho > 0`, `w_i p_i + rho` in place of `w_i p_i`);
4. `num_epochs` passes over `num_minibatches` shuffled minibatches
   (`losses.minibatch_epochs`), one Adam step with global gradient-norm clipping per
   minibatch on `losses.ppo_loss`: the clipped-ratio surrogate on the (per-minibatch
   normalised) scalarized advantage, plus the critic's regression on its GAE targets.

`_iteration` reads one iteration top to bottom; the generic PPO pieces are
`wcac_jax.core.losses`'.

`make_trainer` returns the same `runtime.Trainer` as the paper's update (through
`runtime.assemble`, which adds the shared `run` and `mean_action`), so sweeps,
evaluation, checkpoints and chunking work unchanged. Each iteration costs `N * L`
environment steps. Iteration `t` draws its randomness from `fold_in(state.key, t)`.
"""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import chex
import jax
import jax.numpy as jnp
import optax
from brax.training.acme import running_statistics, specs

from wcac_jax.core import losses, networks, runtime, scalarize, utopia
from wcac_jax.core.config import (
    TUPLE_AS_LIST,
    Config,
    discount,
    field,
    finite,
    frozen_config,
    non_negative,
    one_of,
    optional_point,
    positive,
    positive_int,
    unit_interval,
)


@frozen_config
class PracticalConfig(Config):
    """Sizes and hyperparameters of the practical update (the sweep vmaps over `P`)."""

    num_envs: int = field(16, "N, parallel environments per preference", positive_int)
    rollout_steps: int = field(
        128, "L, steps of every environment per iteration (M = N * L)", positive_int
    )
    num_iterations: int = field(100, "T, outer iterations", positive_int)
    num_epochs: int = field(5, "passes over the M samples per iteration", positive_int)
    num_minibatches: int = field(16, "minibatches per pass (must divide M)", positive_int)
    gamma: float = field(0.99, "discount", discount)
    gae_lambda: float = field(0.95, "GAE's lambda", unit_interval)
    clip_eps: float = field(0.2, "the ratio's clipping range epsilon", positive)
    learning_rate: float = field(3e-4, "Adam's step size (its start, with anneal_lr)", positive)
    anneal_lr: bool = field(
        False,
        "decay the step size linearly to 0 (over the run's num_iterations * num_epochs * "
        "num_minibatches updates, as CleanRL's and purejaxrl's PPO do)",
    )
    adam_eps: float = field(1e-5, "Adam's epsilon", positive)
    max_grad_norm: float = field(0.5, "global gradient-norm clip", positive)
    vf_coef: float = field(0.5, "weight of the critic's regression loss", non_negative)
    ent_coef: float = field(0.0, "weight of the entropy bonus", non_negative)
    width: int = field(128, "hidden width of the (tanh) actor and critic", positive_int)
    depth: int = field(2, "hidden layers of the (tanh) actor and critic", positive_int)
    log_std_init: float = field(
        0.0, "initial log-std of the Gaussian policy (state-independent, learned)", finite
    )
    normalize_obs: bool = field(True, "running mean/std observation normalisation")
    obs_clip: float = field(10.0, "clip normalised observations to +-obs_clip", positive)
    normalize_returns: bool = field(True, "scale each reward by its return's std")
    reward_clip: float = field(10.0, "scaled rewards are clipped to +-reward_clip", positive)
    mu: float = field(
        1.0, "smoothing temperature of smooth_wc (in the objectives' discounted units)", positive
    )
    j_ub: tuple[float, ...] | None = field(
        None,
        "the fixed utopia point, used when utopia is 'fixed' (None: the environment's)",
        optional_point,
        TUPLE_AS_LIST,
    )
    utopia: str = field(
        "estimated",
        "'fixed' (j_ub) or 'estimated' (by the sweep, wcac_jax.core.utopia)",
        one_of(utopia.UTOPIA_MODES),
    )
    utopia_margin: float = field(0.1, "estimated utopia's margin (utopia.estimate)", non_negative)
    utopia_min_spread: float = field(
        1.0, "the estimated utopia point's least spread (utopia.estimate)", positive
    )
    scalarization: str = field(
        "smooth_wc",
        "the actor's direction, a registered scalarization (smooth_wc is the method)",
        one_of(lambda: tuple(scalarize.SCALARIZATIONS)),
    )
    augment: float = field(
        0.0,
        "rho of S + rho * sum_i (z_i - J_i) (the augmented scalarization, "
        "scalarize.augmented_coefficients): a weight rho on every objective, in its own "
        "units, on top of w_i p_i; 0 is the method itself",
        non_negative,
    )

    def validate(self) -> None:
        if self.sample_count % self.num_minibatches:
            raise ValueError(
                f"num_minibatches {self.num_minibatches} must divide num_envs * "
                f"rollout_steps = {self.sample_count}"
            )

    @property
    def sample_count(self) -> int:
        """`M = N * L`, transitions per iteration."""
        return self.num_envs * self.rollout_steps

    @property
    def env_steps_per_iteration(self) -> int:
        """Environment steps of one preference per iteration: `N * L`."""
        return self.sample_count

    @property
    def total_env_steps(self) -> int:
        """Environment steps of one preference over the whole run."""
        return self.env_steps_per_iteration * self.num_iterations


@runtime.update_state(
    (
        "actor",
        "critic",
        "opt_state",
        "obs_stats",
        "return_stats",
        "discounted_return",
        "utopia",
        "env_state",
        "episodes",
        "key",
        "iteration",
    )
)
class PracticalState:
    """One preference's training state: `runtime.UpdateState`'s fields and

    Attributes:
      critic: the vector critic's parameters (`m` outputs).
      opt_state: Adam's state over `{"actor", "critic"}`.
      return_stats: running statistics of the per-objective discounted return (`[m]`;
        its std scales the rewards).
      discounted_return: `[N, m]` each environment's discounted return so far this episode.
      utopia: the sweep's utopia estimate (`wcac_jax.core.utopia`).
    """

    critic: networks.NetParams
    opt_state: optax.OptState
    return_stats: running_statistics.RunningStatisticsState
    discounted_return: chex.Array
    utopia: utopia.UtopiaState


# ----------------------------------------------------------------------------- formulas


def accumulate_returns(
    acc: chex.Array, rewards: chex.Array, done: chex.Array, gamma: float
) -> tuple[chex.Array, chex.Array]:
    """The running discounted returns whose std scales the rewards (as SB3's VecNormalize).

    Args:
      acc: `[N, m]` discounted return of each environment's episode so far.
      rewards: `[L, N, m]` the next `L` steps' rewards.
      done: `[L, N]` episode ends.
      gamma: discount.

    Returns:
      `(acc, seen)`: the carried returns after `L` steps (reset where an episode ended)
      and `[L, N, m]` the return after each step (`seen_t = gamma seen_{t-1} + r_t`,
      before the reset), which the statistics absorb.
    """
    chex.assert_rank([acc, rewards, done], [2, 3, 2])

    def body(acc, x):
        r, d = x
        seen = gamma * acc + r
        return jnp.where(d[:, None] > 0, 0.0, seen), seen

    return jax.lax.scan(body, acc, (rewards, done))


def scale_rewards(rewards: chex.Array, std: chex.Array, clip: float) -> chex.Array:
    """`clip(r_i / std_i, -clip, clip)`. rewards `[..., m]`, std `[m]`."""
    return jnp.clip(rewards / std, -clip, clip)


def default_networks(config: PracticalConfig) -> networks.NetworkFactory:
    """The practical update's networks: tanh MLPs of `config.width` and `config.depth`,
    orthogonally initialised, the actor's last layer at scale 0.01, the critic's at 1."""

    def factory(in_size: int, out_size: int, *, role: str) -> networks.Network:
        scale = 0.01 if role == "actor" else 1.0
        return networks.tanh_mlp(in_size, out_size, config.width, config.depth, scale)

    return factory


def make_policy(
    config: PracticalConfig, env, network_factory: networks.NetworkFactory | None = None
) -> networks.Policy:
    """A Gaussian with state-independent learned log-std (continuous actions in
    `[-1, 1]^act`), or a softmax over `env.num_actions` (discrete ones), on
    `network_factory`'s actor (default: a tanh MLP, `default_networks`)."""
    obs_size = int(env.observation_size)
    factory = network_factory or default_networks(config)
    return runtime.make_policy(
        env,
        lambda out: factory(obs_size, out, role="actor"),
        config.log_std_init,
        learn_log_std=True,
    )


# ----------------------------------------------------------------------------- the program


def learning_rate(config: PracticalConfig) -> float | optax.Schedule:
    """Adam's step size: `config.learning_rate`, or with `anneal_lr` a schedule of the
    update count `k` falling linearly from it to 0 at the run's last update (`k = T *
    epochs * minibatches`; later counts stay at 0)."""
    if not config.anneal_lr:
        return config.learning_rate
    n_updates = config.num_iterations * config.num_epochs * config.num_minibatches
    return optax.linear_schedule(config.learning_rate, 0.0, n_updates)


def _init(parts: runtime.UpdateParts, key: chex.PRNGKey, pref: chex.Array) -> PracticalState:
    del pref  # the initial state does not depend on the preference
    n_envs, m = parts.config.num_envs, parts.m
    fields, key_critic = runtime.init_fields(
        key, parts.policy, parts.venv, n_envs, m, parts.obs_size
    )
    critic_params = parts.value_net.init(key_critic)
    return PracticalState(
        **fields,
        critic=critic_params,
        opt_state=parts.optimizer.init(
            {"actor": fields["actor"].trainable, "critic": critic_params.trainable}
        ),
        return_stats=running_statistics.init_state(specs.Array((m,), jnp.float32)),
        discounted_return=jnp.zeros((n_envs, m), jnp.float32),
        utopia=utopia.init(m),
    )


class Estimates(NamedTuple):
    """What a rollout's rewards and the critic give (`_advantages`).

    Attributes:
      discounted_return: `[N, m]` each environment's discounted return carried on.
      return_stats: the return normaliser after the rollout.
      sigma: `[m]` the reward scales (the discounted return's std).
      obs_in: `[L, N, obs]` the rollout's preprocessed observations.
      adv: `[L, N, m]` per-objective GAE advantages (in scaled units).
      target: `[L, N, m]` the critic's regression targets.
      j_hat: `[m]` `sigma * mean_{s0} V(s0)`, the objectives' estimates.
    """

    discounted_return: chex.Array
    return_stats: running_statistics.RunningStatisticsState
    sigma: chex.Array
    obs_in: chex.Array
    adv: chex.Array
    target: chex.Array
    j_hat: chex.Array


class Optimised(NamedTuple):
    """What an iteration's minibatch epochs give (`_optimise`).

    Attributes:
      params: `{"actor", "critic"}` the new trainable parameters.
      opt_state: the optimiser's new state.
      info: `losses.ppo_loss`'s diagnostics, leaves `[epochs, minibatches]`.
      dist: the behaviour policy's distributions at the rollout's observations.
    """

    params: dict
    opt_state: optax.OptState
    info: dict
    dist: Any


def _advantages(parts: runtime.UpdateParts, state: PracticalState, batch, env_state) -> Estimates:
    """Scaled rewards, GAE and the objective estimates of a rollout `batch` (leaves
    `[L, N, ...]`)."""
    config, m = parts.config, parts.m
    prep = functools.partial(parts.preprocess, state.obs_stats)
    discounted_return, seen = accumulate_returns(
        state.discounted_return, batch.reward, batch.done, config.gamma
    )
    return_stats = state.return_stats
    if config.normalize_returns:
        return_stats = running_statistics.update(return_stats, seen)
        sigma = return_stats.std
    else:
        sigma = jnp.ones((m,), jnp.float32)
    reward = scale_rewards(batch.reward, sigma, config.reward_clip)

    def values(obs_in):
        return parts.value_net.apply(state.critic, obs_in)  # [..., m]

    obs_in = prep(batch.obs)  # [L, N, obs]
    v = values(obs_in)
    v_next = values(prep(batch.next_obs))
    adv = jax.vmap(losses.gae, in_axes=(1, 1, 1, 1, 1, None, None), out_axes=1)(
        v, v_next, reward, batch.terminal, batch.done, config.gamma, config.gae_lambda
    )  # [L, N, m]
    j_hat = sigma * jnp.mean(values(prep(env_state.info["first_obs"])), axis=0)
    return Estimates(discounted_return, return_stats, sigma, obs_in, adv, adv + v, j_hat)


def _scalarize(parts: runtime.UpdateParts, state: PracticalState, j_hat, pref, direction):
    """The utopia point and the scalarization at `j_hat`:
    `(utopia_state, z [m], weights [m], scalarized)`."""
    config = parts.config
    if config.utopia == "estimated":
        utopia_state, z = utopia.estimate(
            state.utopia, j_hat, margin=config.utopia_margin, min_spread=config.utopia_min_spread
        )
    else:
        utopia_state, z = state.utopia, parts.j_ub
    # an index, static or traced: one `lax.switch` whichever is asked for
    index = (
        runtime.TRACED_DIRECTIONS.index(config.scalarization) if direction is None else direction
    )
    weights, scalarized = runtime.scalarization(index, j_hat, pref, z, config.mu)
    scalarized = scalarized + scalarize.augmentation(j_hat, z, config.augment)
    return utopia_state, z, weights, scalarized


def _optimise(
    parts: runtime.UpdateParts, state: PracticalState, batch, obs_in, scalar_adv, target, key
) -> Optimised:
    """`num_epochs` passes of minibatch steps on the iteration's `M` samples, from the
    behaviour policy's distributions at `obs_in` `[L, N, obs]`; `scalar_adv` `[L, N]`,
    `target` `[L, N, m]`."""
    config, policy, n = parts.config, parts.policy, parts.config.sample_count
    dist = policy.apply(state.actor, obs_in)
    flat = {
        "obs": obs_in.reshape((n, parts.obs_size)),
        "action": batch.action.reshape((n, *batch.action.shape[2:])),
        "log_prob": policy.log_prob(dist, batch.action).reshape(n),
        "advantage": scalar_adv.reshape(n),
        "target": target.reshape((n, parts.m)),
    }
    params = {"actor": state.actor.trainable, "critic": state.critic.trainable}
    loss = functools.partial(
        losses.ppo_loss,
        policy=policy,
        value_net=parts.value_net,
        clip_eps=config.clip_eps,
        vf_coef=config.vf_coef,
        ent_coef=config.ent_coef,
    )
    (params, opt_state), info = losses.minibatch_epochs(
        loss,
        parts.optimizer,
        params,
        state.opt_state,
        flat,
        key,
        config.num_epochs,
        config.num_minibatches,
        fixed={"actor_fixed": state.actor, "critic_fixed": state.critic},
    )
    return Optimised(params, opt_state, info, dist)


def _iteration(parts: runtime.UpdateParts, state: PracticalState, pref: chex.Array, direction=None):
    """One iteration (see the module docstring): `(state, metrics)`."""
    config = parts.config
    key_rollout, key_epochs = runtime.iteration_keys(state)

    # ------------------------------------------------ rollout: L steps of N environments
    (env_state, episodes), batch = runtime.rollout(
        parts.env_step,
        state.actor,
        state.obs_stats,
        state.env_state,
        state.episodes,
        key_rollout,
        config.rollout_steps,
    )  # batch leaves [L, N, ...]

    # ------------------------------------------------ per-objective advantages and Jhat
    estimates = _advantages(parts, state, batch, env_state)

    # ------------------------------------------------ the scalarized advantage
    utopia_state, z, weights, scalarized = _scalarize(
        parts, state, estimates.j_hat, pref, direction
    )
    # each A_i back in its objective's units
    coeff = scalarize.augmented_coefficients(weights, pref, config.augment) * estimates.sigma

    # ------------------------------------------------ epochs of minibatch steps
    optimised = _optimise(
        parts, state, batch, estimates.obs_in, estimates.adv @ coeff, estimates.target, key_epochs
    )

    # ------------------------------------------------ the next state and the metrics
    renewed = state.replace(
        env_state=env_state,
        episodes=episodes,
        return_stats=estimates.return_stats,
        discounted_return=estimates.discounted_return,
        utopia=utopia_state,
        obs_stats=runtime.update_obs_stats(
            config.normalize_obs,
            state.obs_stats,
            batch.obs.reshape((config.sample_count, parts.obs_size)),
        ),
    )
    metrics = {
        "train/j_hat": estimates.j_hat,
        "train/weights": weights,
        "train/scalarized": scalarized,
        "train/g_mu": scalarize.smooth_wc(estimates.j_hat, pref, z, config.mu),
        "train/utopia": z,
    }
    return finish_iteration(parts, state, renewed, estimates, optimised, metrics)


def finish_iteration(
    parts: runtime.UpdateParts,
    before: PracticalState,
    renewed: PracticalState,
    estimates: Estimates,
    optimised: Optimised,
    metrics: dict,
):
    """The end of an iteration the practical and the conditioned update share: the
    optimised networks and the iteration count written into `renewed` (the state whose
    environments, episodes, normalisers and utopia estimate the update has renewed),
    and `metrics` (the update's own) completed by the episodes', advantages' and epochs'
    statistics.

    Returns:
      `(state, metrics)`.
    """
    episodes, info = renewed.episodes, optimised.info
    metrics = {
        **metrics,
        "train/episode_return": runtime.finished_episode_return(episodes),
        "train/episodes": jnp.sum(episodes.finished) - jnp.sum(before.episodes.finished),
        "train/iteration": before.iteration + 1,
        "train/advantage": jnp.mean(estimates.adv, axis=(0, 1)),
        "train/return_std": estimates.sigma,
        "train/policy_entropy": jnp.mean(parts.policy.entropy(optimised.dist)),
        "train/value_loss": jnp.mean(info["value_loss"]),
        "train/approx_kl": jnp.mean(info["approx_kl"]),
        "train/clip_fraction": jnp.mean(info["clip_fraction"]),
    }
    new_state = renewed.replace(
        actor=before.actor.replace(trainable=optimised.params["actor"]),
        critic=before.critic.replace(trainable=optimised.params["critic"]),
        opt_state=optimised.opt_state,
        iteration=before.iteration + 1,
    )
    return new_state, metrics


def make_trainer(
    config: PracticalConfig, env, network_factory: networks.NetworkFactory | None = None
) -> runtime.Trainer:
    """Builds the pure `init`/`run`/`step` of the practical update for `env`.

    With `config.utopia == "estimated"`, `step` and `run` called under
    `jax.vmap(..., axis_name=utopia.PREF_AXIS)` share the utopia point across the
    preferences (the sweep does); anywhere else each preference estimates its own.

    Args:
      config: static sizes and hyperparameters.
      env: a single unbatched Brax-style environment with vector rewards (see
        `wcac_jax.envs`).
      network_factory: builds the actor and the vector critic
        (`networks.NetworkFactory`; default `default_networks(config)`).
    """
    m, obs_size = int(env.num_objectives), int(env.observation_size)
    j_ub = jnp.asarray(runtime.resolve_j_ub(config, env), jnp.float32)
    venv = runtime.vectorize(env)
    factory = network_factory or default_networks(config)
    policy = make_policy(config, env, factory)
    value_net = factory(obs_size, m, role="critic")
    preprocess = runtime.make_preprocess(config.normalize_obs, obs_clip=config.obs_clip)
    parts = runtime.UpdateParts(
        config=config,
        m=m,
        obs_size=obs_size,
        j_ub=j_ub,
        policy=policy,
        value_net=value_net,
        optimizer=optax.chain(
            optax.clip_by_global_norm(config.max_grad_norm),
            optax.adam(learning_rate(config), eps=config.adam_eps),
        ),
        preprocess=preprocess,
        env_step=functools.partial(runtime.policy_step, policy, preprocess, venv.step),
        venv=venv,
    )
    init = functools.partial(_init, parts)
    step = functools.partial(_iteration, parts)
    return runtime.assemble(init, step, policy, value_net, preprocess, j_ub)
