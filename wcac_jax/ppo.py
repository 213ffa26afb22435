"""The practical actor update: the same smoothed weighted-Chebyshev direction, optimised
the way on-policy deep RL is in practice (PPO, as morl-baselines' MOPPO does).

Per preference `p` and iteration, the `N` environments take `L` steps under the current
policy (`M = N * L` transitions), and then:

1. rewards are divided, per objective, by the running std of their discounted return
   (`sigma_i`, clipped to `+-reward_clip`); observations are normalised by running
   mean/std (clipped to `+-obs_clip`);
2. a vector critic (one network, `m` outputs) gives per-objective GAE advantages
   (`gae`): falls do not bootstrap, time-limit truncation bootstraps from the true next
   observation (`info["final_obs"]`), and the recursion stops at every episode end;
3. `Jhat_i = sigma_i * mean_{s0} V_i(s0)` (discounted, in the objectives' own units), the
   utopia point `z` (fixed, or estimated by the whole sweep, see `wcac_jax.utopia`), and
   the scalarization's weights `w` (`lambda` for `smooth_wc`) give the scalarized
   advantage `sum_i w_i p_i sigma_i A_i` — the advantage of the direction
   `-sum_i w_i p_i gradJ_i` of `actor.direction`, with each `A_i` back in its
   objective's units (with `augment = rho > 0`, `w_i p_i + rho` in place of `w_i p_i`);
4. `num_epochs` passes over `num_minibatches` shuffled minibatches
   (`minibatch_epochs`), one Adam step with global gradient-norm clipping per
   minibatch on `ppo_loss`: the clipped-ratio surrogate on the (per-minibatch
   normalised) scalarized advantage (`clipped_surrogate`), plus the critic's regression
   on its GAE targets.

`make_trainer` returns the same `train.Trainer` as the paper's update (through
`train.assemble`, which adds the shared `run` and `mean_action`), so sweeps,
evaluation, checkpoints and chunking work unchanged. Each iteration costs `N * L`
environment steps. Iteration `t` draws its randomness from `fold_in(state.key, t)`.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import chex
import jax
import jax.numpy as jnp
import optax
from brax.envs.base import State
from brax.training.acme import running_statistics, specs
from flax import struct

from wcac_jax import networks, scalarize, utopia
from wcac_jax.config import finite_f32
from wcac_jax.envs.wrappers import EpisodeWrapper
from wcac_jax.train import (
    TRACED_DIRECTIONS,
    Trainer,
    assemble,
    finished_episode_return,
    init_episodes,
    policy_step,
    resolve_j_ub,
    rollout,
)
from wcac_jax.types import EpisodeStats, typed_key


@dataclass(frozen=True)
class PPOConfig:
    """Sizes and hyperparameters of the practical update (the sweep vmaps over `P`).

    Attributes:
      num_envs: `N`, parallel environments per preference.
      rollout_steps: `L`, steps of every environment per iteration (`M = N * L`).
      num_iterations: `T`, outer iterations.
      num_epochs: passes over the `M` samples per iteration.
      num_minibatches: minibatches per pass (must divide `M`).
      gamma: discount.
      gae_lambda: GAE's `lambda`.
      clip_eps: the ratio's clipping range `epsilon`.
      learning_rate: Adam's step size (its start, with `anneal_lr`).
      anneal_lr: decay the step size linearly to 0 over the run's `num_iterations *
        num_epochs * num_minibatches` updates (as CleanRL's and purejaxrl's PPO do).
      adam_eps: Adam's `epsilon`.
      max_grad_norm: global gradient-norm clip.
      vf_coef: weight of the critic's regression loss.
      ent_coef: weight of the entropy bonus.
      width, depth: hidden layers of the (tanh) actor and critic networks.
      log_std_init: initial log-std of the Gaussian policy (state-independent, learned).
      normalize_obs: running mean/std observation normalisation.
      obs_clip: normalised observations are clipped to `+-obs_clip`.
      normalize_returns: per-objective reward scaling by the discounted return's std.
      reward_clip: scaled rewards are clipped to `+-reward_clip`.
      mu: smoothing temperature of `smooth_wc` (in the objectives' discounted units).
      j_ub: the fixed utopia point (`None`: the environment's); used when
        `utopia == "fixed"`.
      utopia: `"fixed"` (`j_ub`) or `"estimated"` (by the sweep, `wcac_jax.utopia`).
      utopia_margin, utopia_min_spread: see `utopia.estimate`.
      scalarization: `"smooth_wc"` (the method), `"wc"` or `"linear"`.
      augment: `rho` of the augmented scalarization `S + rho * sum_i (z_i - J_i)`
        (`scalarize.augmented_coefficients`): a weight `rho` on every objective, in its
        own units, on top of `w_i p_i`. `0` (the default) is the method as SPEC §4 has it.
    """

    num_envs: int = 16
    rollout_steps: int = 128
    num_iterations: int = 100
    num_epochs: int = 5
    num_minibatches: int = 16
    gamma: float = 0.99
    gae_lambda: float = 0.95
    clip_eps: float = 0.2
    learning_rate: float = 3e-4
    anneal_lr: bool = False
    adam_eps: float = 1e-5
    max_grad_norm: float = 0.5
    vf_coef: float = 0.5
    ent_coef: float = 0.0
    width: int = 128
    depth: int = 2
    log_std_init: float = 0.0
    normalize_obs: bool = True
    obs_clip: float = 10.0
    normalize_returns: bool = True
    reward_clip: float = 10.0
    mu: float = 1.0
    j_ub: tuple[float, ...] | None = None
    utopia: str = "estimated"
    utopia_margin: float = 0.1
    utopia_min_spread: float = 1.0
    scalarization: str = "smooth_wc"
    augment: float = 0.0

    def __post_init__(self):
        for name in (
            "num_envs",
            "rollout_steps",
            "num_iterations",
            "num_epochs",
            "num_minibatches",
            "width",
            "depth",
        ):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if self.sample_count % self.num_minibatches:
            raise ValueError(
                f"num_minibatches {self.num_minibatches} must divide num_envs * "
                f"rollout_steps = {self.sample_count}"
            )
        for name in ("gamma", "gae_lambda"):
            if not 0.0 <= getattr(self, name) <= 1.0 or (name == "gamma" and self.gamma == 1.0):
                raise ValueError(f"{name} must be in [0, 1), got {getattr(self, name)!r}")
        for name in (
            "clip_eps",
            "learning_rate",
            "adam_eps",
            "max_grad_norm",
            "obs_clip",
            "reward_clip",
            "mu",
            "utopia_min_spread",
        ):
            value = getattr(self, name)
            if not value > 0:  # also rejects NaN
                raise ValueError(f"{name} must be > 0, got {value!r}")
            if not finite_f32(value):
                raise ValueError(f"{name} must be finite in float32, got {value!r}")
        for name in ("vf_coef", "ent_coef", "utopia_margin", "augment"):
            value = getattr(self, name)
            if not (value >= 0 and finite_f32(value)):
                raise ValueError(f"{name} must be >= 0 and finite, got {value!r}")
        if not finite_f32(self.log_std_init):
            raise ValueError(f"log_std_init must be finite in float32, got {self.log_std_init!r}")
        if self.j_ub is not None:
            j_ub = tuple(float(v) for v in self.j_ub)
            if not all(finite_f32(v) for v in j_ub):
                raise ValueError(f"j_ub must be finite in float32, got {self.j_ub!r}")
            object.__setattr__(self, "j_ub", j_ub)
        choices = {"scalarization": TRACED_DIRECTIONS, "utopia": utopia.UTOPIA_MODES}
        for name, valid in choices.items():
            if getattr(self, name) not in valid:
                raise ValueError(
                    f"{name} must be one of {', '.join(valid)}; got {getattr(self, name)!r}"
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

    def replace(self, **changes) -> PPOConfig:
        """A copy with `changes` applied (and validated)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        """A JSON-friendly dict of every field."""
        out = dataclasses.asdict(self)
        out["j_ub"] = None if self.j_ub is None else list(self.j_ub)
        return out

    @classmethod
    def from_dict(cls, d: dict) -> PPOConfig:
        """The inverse of `to_dict`."""
        d = dict(d)
        if d.get("j_ub") is not None:
            d["j_ub"] = tuple(d["j_ub"])
        return cls(**d)


@struct.dataclass
class PPOState:
    """Everything one preference's training carries between iterations.

    Attributes:
      actor: policy parameters.
      critic: the vector critic's parameters (`m` outputs).
      opt_state: Adam's state over `{"actor", "critic"}`.
      obs_stats: running observation statistics.
      return_stats: running statistics of the per-objective discounted return (`[m]`;
        its std scales the rewards).
      discounted_return: `[N, m]` each environment's discounted return so far this episode.
      utopia: the sweep's utopia estimate (`wcac_jax.utopia`).
      env_state: the `N` environments (leaves `[N, ...]`).
      episodes: episode bookkeeping (`[N, m]`, `[N]`).
      key: raw key data of the run's base key; iteration `t` uses `fold_in(key, t)`.
      iteration: `t`, iterations done (environment steps are counted on the host from
        it, as int64: `train.env_steps`).
    """

    actor: networks.NetParams
    critic: networks.NetParams
    opt_state: optax.OptState
    obs_stats: running_statistics.RunningStatisticsState
    return_stats: running_statistics.RunningStatisticsState
    discounted_return: chex.Array
    utopia: utopia.UtopiaState
    env_state: State
    episodes: EpisodeStats
    key: chex.PRNGKey
    iteration: chex.Array


# ----------------------------------------------------------------------------- formulas


def gae(
    values: chex.Array,
    next_values: chex.Array,
    rewards: chex.Array,
    terminal: chex.Array,
    done: chex.Array,
    gamma: float,
    lam: float,
) -> chex.Array:
    """Per-objective generalised advantage estimates along ONE environment's trajectory.

    Time is the leading axis: transition `t` goes from `s_t` to `s'_t` (the true next
    state, also when the episode ended and the environment reset), so
    `delta_t = r_t + gamma (1 - terminal_t) V(s'_t) - V(s_t)` and
    `A_t = delta_t + gamma lam (1 - done_t) A_{t+1}`, with `A_L = 0`: a fall
    (`terminal`) does not bootstrap; a time-limit truncation (`done`, not `terminal`)
    bootstraps from `V(s'_t)`; neither carries advantages across the episode boundary;
    the last transition bootstraps from `V(s'_{L-1})`.

    Args:
      values: `[L, m]` `V(s_t)`.
      next_values: `[L, m]` `V(s'_t)`.
      rewards: `[L, m]`.
      terminal: `[L]`, 1 where `s'_t` is terminal.
      done: `[L]`, 1 where the episode ended at `t` (terminal or truncated).
      gamma: discount.
      lam: GAE's `lambda`.

    Returns:
      `[L, m]` advantages (the critic's targets are `advantages + values`).
    """
    chex.assert_rank([values, terminal, done], [2, 1, 1])
    chex.assert_equal_shape([values, next_values, rewards])
    deltas = rewards + gamma * (1.0 - terminal)[:, None] * next_values - values
    carry_on = gamma * lam * (1.0 - done)[:, None]

    def body(next_adv, x):
        delta, c = x
        adv = delta + c * next_adv
        return adv, adv

    _, adv = jax.lax.scan(body, jnp.zeros_like(deltas[0]), (deltas, carry_on), reverse=True)
    return adv


def clipped_surrogate(log_ratio: chex.Array, advantages: chex.Array, clip_eps: float):
    """PPO's clipped objective `mean(min(rho A, clip(rho, 1 - eps, 1 + eps) A))` (maximised).

    Args:
      log_ratio: `[B]` `log pi_new(a|s) - log pi_old(a|s)`.
      advantages: `[B]`.
      clip_eps: `eps`.

    Returns:
      A scalar.
    """
    chex.assert_equal_shape([log_ratio, advantages])
    ratio = jnp.exp(log_ratio)
    clipped = jnp.clip(ratio, 1.0 - clip_eps, 1.0 + clip_eps)
    return jnp.mean(jnp.minimum(ratio * advantages, clipped * advantages))


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


def normalize_advantages(adv: chex.Array) -> chex.Array:
    """`(A - mean) / (std + 1e-8)` over a minibatch `[B]`."""
    return (adv - jnp.mean(adv)) / (jnp.std(adv) + 1e-8)


def ppo_loss(
    config: PPOConfig,
    policy: networks.Policy,
    value_net: networks.Network,
    params: dict,
    batch: dict,
) -> tuple[chex.Array, dict]:
    """One minibatch's loss (minimised) and diagnostics: `-surrogate + vf_coef * value_loss
    - ent_coef * entropy`, the surrogate on the minibatch-normalised advantage.

    Args:
      config: `clip_eps`, `vf_coef`, `ent_coef`.
      policy, value_net: the networks.
      params: `{"actor", "critic"}` trainable parameters (what is differentiated).
      batch: `obs` `[B, obs]` (already normalised), `action` `[B, ...]`, `log_prob` `[B]`
        (the behaviour policy's), `advantage` `[B]` (scalarized), `target` `[B, m]`, and
        `actor_fixed` / `critic_fixed`, the `NetParams` whose `trainable` part `params`
        replaces.

    Returns:
      `(loss, {"value_loss", "approx_kl", "clip_fraction"})`, all scalars.
    """
    dist = policy.apply(batch["actor_fixed"].replace(trainable=params["actor"]), batch["obs"])
    log_ratio = policy.log_prob(dist, batch["action"]) - batch["log_prob"]
    surrogate = clipped_surrogate(
        log_ratio, normalize_advantages(batch["advantage"]), config.clip_eps
    )
    v = value_net.apply(batch["critic_fixed"].replace(trainable=params["critic"]), batch["obs"])
    value_loss = 0.5 * jnp.mean(jnp.square(v - batch["target"]))
    entropy = jnp.mean(policy.entropy(dist))
    loss = -surrogate + config.vf_coef * value_loss - config.ent_coef * entropy
    ratio = jnp.exp(log_ratio)
    return loss, {
        "value_loss": value_loss,
        "approx_kl": jnp.mean((ratio - 1.0) - log_ratio),
        "clip_fraction": jnp.mean((jnp.abs(ratio - 1.0) > config.clip_eps).astype(jnp.float32)),
    }


def minibatch_epochs(
    loss_fn,
    optimizer: optax.GradientTransformation,
    params,
    opt_state: optax.OptState,
    data: dict,
    key: chex.PRNGKey,
    num_epochs: int,
    num_minibatches: int,
    fixed: dict | None = None,
):
    """`num_epochs` passes over `data`, each a fresh permutation cut into
    `num_minibatches` minibatches, one `optimizer` step on `loss_fn` per minibatch.

    Args:
      loss_fn: `(params, minibatch) -> (loss, info)`.
      optimizer: an optax transformation.
      params, opt_state: where to start.
      data: leaves `[M, ...]`, `M` divisible by `num_minibatches`.
      key: the permutations' key (split into one per epoch).
      num_epochs, num_minibatches: static sizes.
      fixed: entries added unsliced to every minibatch.

    Returns:
      `((params, opt_state), info)`, `info`'s leaves `[num_epochs, num_minibatches, ...]`.
    """
    fixed = fixed or {}
    n = jax.tree.leaves(data)[0].shape[0]
    mb_size = n // num_minibatches

    def minibatch_step(carry, mb):
        params, opt_state = carry
        grads, info = jax.grad(loss_fn, has_aux=True)(params, {**mb, **fixed})
        updates, opt_state = optimizer.update(grads, opt_state, params)
        return (optax.apply_updates(params, updates), opt_state), info

    def epoch(carry, key):
        perm = jax.random.permutation(key, n)
        mbs = jax.tree.map(
            lambda x: x[perm].reshape((num_minibatches, mb_size, *x.shape[1:])), data
        )
        return jax.lax.scan(minibatch_step, carry, mbs)

    return jax.lax.scan(epoch, (params, opt_state), jax.random.split(key, num_epochs))


def make_policy(config: PPOConfig, env) -> networks.Policy:
    """A Gaussian with state-independent learned log-std (continuous actions in
    `[-1, 1]^act`), or a softmax over `env.num_actions` (discrete ones)."""
    num_actions = getattr(env, "num_actions", None)
    out = int(num_actions) if num_actions else int(env.action_size)
    net = networks.tanh_mlp(int(env.observation_size), out, config.width, config.depth, 0.01)
    if num_actions:
        return networks.categorical_policy(net)
    return networks.gaussian_policy(net, out, config.log_std_init, learn_log_std=True)


# ----------------------------------------------------------------------------- the program


def learning_rate(config: PPOConfig) -> float | optax.Schedule:
    """Adam's step size: `config.learning_rate`, or with `anneal_lr` a schedule of the
    update count `k` falling linearly from it to 0 at the run's last update (`k = T *
    epochs * minibatches`; later counts stay at 0)."""
    if not config.anneal_lr:
        return config.learning_rate
    n_updates = config.num_iterations * config.num_epochs * config.num_minibatches
    return optax.linear_schedule(config.learning_rate, 0.0, n_updates)


def make_trainer(config: PPOConfig, env) -> Trainer:
    """Builds the pure `init`/`run`/`step` of the practical update for `env`.

    With `config.utopia == "estimated"`, `step` and `run` must be called under
    `jax.vmap(..., axis_name=utopia.PREF_AXIS)` (the sweep does; one preference alone is
    a vmap over one).

    Args:
      config: static sizes and hyperparameters.
      env: a single unbatched Brax-style environment with vector rewards (see
        `wcac_jax.envs`).
    """
    m = int(env.num_objectives)
    obs_size = int(env.observation_size)
    j_ub = jnp.asarray(resolve_j_ub(config, env), jnp.float32)
    n_envs, gamma = config.num_envs, config.gamma
    n_samples = config.sample_count

    wrapped = EpisodeWrapper(env, env.episode_length)
    v_reset = jax.vmap(wrapped.reset)
    v_step = jax.vmap(wrapped.step)

    policy = make_policy(config, env)
    value_net = networks.tanh_mlp(obs_size, m, config.width, config.depth, 1.0)
    optimizer = optax.chain(
        optax.clip_by_global_norm(config.max_grad_norm),
        optax.adam(learning_rate(config), eps=config.adam_eps),
    )
    scals = [scalarize.get(name) for name in TRACED_DIRECTIONS]
    static_index = TRACED_DIRECTIONS.index(config.scalarization)
    loss_fn = functools.partial(ppo_loss, config, policy, value_net)

    def preprocess(obs_stats, obs):
        if not config.normalize_obs:
            return obs
        return running_statistics.normalize(obs, obs_stats, max_abs_value=config.obs_clip)

    def values(critic_params, obs_in):
        return value_net.apply(critic_params, obs_in)  # [..., m]

    def init(key: chex.PRNGKey, pref: chex.Array) -> PPOState:
        del pref  # the initial state does not depend on the preference
        key_actor, key_critic, key_env, key_run = jax.random.split(typed_key(key), 4)
        actor_params = policy.init(key_actor)
        critic_params = value_net.init(key_critic)
        return PPOState(
            actor=actor_params,
            critic=critic_params,
            opt_state=optimizer.init(
                {"actor": actor_params.trainable, "critic": critic_params.trainable}
            ),
            obs_stats=running_statistics.init_state(specs.Array((obs_size,), jnp.float32)),
            return_stats=running_statistics.init_state(specs.Array((m,), jnp.float32)),
            discounted_return=jnp.zeros((n_envs, m), jnp.float32),
            utopia=utopia.init(m),
            env_state=v_reset(jax.random.split(key_env, n_envs)),
            episodes=init_episodes(n_envs, m),
            key=jax.random.key_data(key_run),
            iteration=jnp.zeros((), jnp.int32),
        )

    env_step = functools.partial(policy_step, policy, preprocess, v_step)

    def scalarization(direction, j_hat, pref, z):
        """(weights [m], scalarized value) of the scalarization `direction` (an index)."""
        branches = [
            lambda j, p, u, s=s: (s.weights(j, p, u, config.mu), s.value(j, p, u, config.mu))
            for s in scals
        ]
        return jax.lax.switch(direction, branches, j_hat, pref, z)

    def iteration(state: PPOState, pref: chex.Array, direction: chex.Array | None = None):
        key_rollout, key_epochs = jax.random.split(
            jax.random.fold_in(jax.random.wrap_key_data(state.key), state.iteration)
        )
        obs_stats = state.obs_stats
        prep = functools.partial(preprocess, obs_stats)
        finished_before = jnp.sum(state.episodes.finished)

        (env_state, episodes), batch = rollout(
            env_step,
            state.actor,
            obs_stats,
            state.env_state,
            state.episodes,
            key_rollout,
            config.rollout_steps,
        )  # batch leaves [L, N, ...]

        discounted_return, seen = accumulate_returns(
            state.discounted_return, batch.reward, batch.done, gamma
        )
        return_stats = state.return_stats
        if config.normalize_returns:
            return_stats = running_statistics.update(return_stats, seen)
            sigma = return_stats.std
        else:
            sigma = jnp.ones((m,), jnp.float32)
        reward = scale_rewards(batch.reward, sigma, config.reward_clip)

        obs_in = prep(batch.obs)  # [L, N, obs]
        v = values(state.critic, obs_in)
        v_next = values(state.critic, prep(batch.next_obs))
        adv = jax.vmap(gae, in_axes=(1, 1, 1, 1, 1, None, None), out_axes=1)(
            v, v_next, reward, batch.terminal, batch.done, gamma, config.gae_lambda
        )  # [L, N, m]
        target = adv + v

        j_hat = sigma * jnp.mean(values(state.critic, prep(env_state.info["first_obs"])), axis=0)
        if config.utopia == "estimated":
            utopia_state, z = utopia.estimate(
                state.utopia,
                j_hat,
                margin=config.utopia_margin,
                min_spread=config.utopia_min_spread,
            )
        else:
            utopia_state, z = state.utopia, j_ub
        index = static_index if direction is None else direction
        weights, scalarized = scalarization(index, j_hat, pref, z)
        scalarized = scalarized + scalarize.augmentation(j_hat, z, config.augment)
        # each A_i back in its objective's units
        coeff = scalarize.augmented_coefficients(weights, pref, config.augment) * sigma
        scalar_adv = adv @ coeff  # [L, N]

        dist = policy.apply(state.actor, obs_in)
        flat = {
            "obs": obs_in.reshape((n_samples, obs_size)),
            "action": batch.action.reshape((n_samples, *batch.action.shape[2:])),
            "log_prob": policy.log_prob(dist, batch.action).reshape(n_samples),
            "advantage": scalar_adv.reshape(n_samples),
            "target": target.reshape((n_samples, m)),
        }
        params = {"actor": state.actor.trainable, "critic": state.critic.trainable}
        (params, opt_state), info = minibatch_epochs(
            loss_fn,
            optimizer,
            params,
            state.opt_state,
            flat,
            key_epochs,
            config.num_epochs,
            config.num_minibatches,
            fixed={"actor_fixed": state.actor, "critic_fixed": state.critic},
        )

        new_obs_stats = obs_stats
        if config.normalize_obs:
            new_obs_stats = running_statistics.update(
                obs_stats, batch.obs.reshape((n_samples, obs_size))
            )
        newly_finished = jnp.sum(episodes.finished) - finished_before
        metrics = {
            "train/j_hat": j_hat,
            "train/weights": weights,
            "train/scalarized": scalarized,
            "train/g_mu": scalarize.smooth_wc(j_hat, pref, z, config.mu),
            "train/utopia": z,
            "train/episode_return": finished_episode_return(episodes),
            "train/episodes": newly_finished,
            "train/iteration": state.iteration + 1,
            "train/advantage": jnp.mean(adv, axis=(0, 1)),
            "train/return_std": sigma,
            "train/policy_entropy": jnp.mean(policy.entropy(dist)),
            "train/value_loss": jnp.mean(info["value_loss"]),
            "train/approx_kl": jnp.mean(info["approx_kl"]),
            "train/clip_fraction": jnp.mean(info["clip_fraction"]),
        }
        new_state = state.replace(
            actor=state.actor.replace(trainable=params["actor"]),
            critic=state.critic.replace(trainable=params["critic"]),
            opt_state=opt_state,
            obs_stats=new_obs_stats,
            return_stats=return_stats,
            discounted_return=discounted_return,
            utopia=utopia_state,
            env_state=env_state,
            episodes=episodes,
            iteration=state.iteration + 1,
        )
        return new_state, metrics

    return assemble(init, iteration, policy, value_net, preprocess, j_ub)
