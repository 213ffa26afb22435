"""The preference-conditioned update: `ConditionedConfig` and `make_trainer`. ONE actor
`pi(a | s, p)` and ONE vector critic `V(s, p)` (`m` outputs) for the whole front.

Every environment of the batch carries its own preference `p`, drawn at each episode
start from Dirichlet(`pref_alpha`) on the simplex (`PreferenceConditioned`) and appended
to its observation; with `pref_draw="environment"`, drawn at the environment's first
reset and kept for the whole run, so that the network trains on `N` preferences, each
with one environment's every episode. Dirichlet(1) is the uniform distribution on the
simplex: every part of the front is trained on equally often, in any number of
objectives, and, unlike a stratified grid, no preference is privileged, so the network
must interpolate between none. Per iteration, as the practical update does for one preference
(`wcac_jax.algos.practical`, whose pieces this reuses):

1. rewards are scaled per objective by the running std `sigma` of the discounted return;
   the observation (not its preference part) by running mean/std;
2. per-objective GAE advantages `A_i` from the vector critic, which takes `(s, p)`;
3. for each transition, with `p` its episode's preference and `s0` its episode's start
   (`episode_start_obs`), `Jhat(p) = sigma * V(s0, p)` (discounted, in the objectives'
   units); the utopia point `z` is estimated from every `Jhat` in play (the best each
   objective has reached, as `wcac_jax.core.utopia`, with the spread over the batch's
   preferences); the scalarization's weights `w(Jhat(p), p, z)` give the scalarized
   advantage `sum_i (w_i p_i + rho) sigma_i A_i` (`scalarized_advantage`): the practical
   update's formula for that environment's own preference;
4. epochs of minibatches on the clipped surrogate (per-minibatch normalised advantages)
   plus the critic's regression (`losses.ppo_loss`, `losses.minibatch_epochs`).

The policy's exploration noise is one learned log-std for every preference, or with
`log_std_by_pref` one per vertex of the simplex, `log_std(p) = p @ L`
(`networks.gaussian_policy`), so that the front's ends can keep different noise.

The state is the practical update's (`PracticalState`), the `Trainer` the shared one:
its `pref` argument is ignored (each environment draws its own), so a sweep trains it as
ONE row. `make_evaluate_at` runs the one network at a given preference.
"""

from __future__ import annotations

import functools

import chex
import jax
import jax.numpy as jnp
import optax
from brax.envs.base import Env, State, Wrapper

from wcac_jax.algos import practical
from wcac_jax.algos.practical import PracticalConfig, PracticalState
from wcac_jax.core import networks, runtime, scalarize, utopia
from wcac_jax.core.config import field, frozen_config, one_of, positive, positive_int
from wcac_jax.core.types import typed_key

CONDITIONINGS = ("concat", "film")
PREF_DRAWS = ("episode", "environment")


@frozen_config
class ConditionedConfig(PracticalConfig):
    """The practical update's sizes and hyperparameters for ONE preference-conditioned
    network (`num_envs` environments in all, each with its own preference), and the
    preferences' distribution."""

    num_envs: int = field(64, "N, parallel environments (each its own preference)", positive_int)
    # (a fixed small noise on the concave bandit, where a stochastic policy's front is the
    # convex hull of the deterministic one)
    learn_log_std: bool = field(True, "whether the policy's log-std is trained")
    pref_alpha: float = field(1.0, "Dirichlet concentration of the preferences drawn", positive)
    pref_draw: str = field(
        "episode",
        "p drawn per 'episode' or per 'environment' (one for the whole run)",
        one_of(PREF_DRAWS),
    )
    log_std_by_pref: bool = field(
        False,
        "log-std per simplex vertex, linear in p",
    )
    conditioning: str = field(
        "concat",
        "how the networks take p: 'concat' (appended to the observation) or "
        "'film' (appended, and also scaling and shifting every hidden layer)",
        one_of(CONDITIONINGS),
    )


def dirichlet_preference(m: int, alpha: float = 1.0):
    """`key -> [m]` a preference drawn from Dirichlet(alpha) (alpha = 1: uniform)."""
    conc = jnp.full((m,), alpha, jnp.float32)
    return lambda key: jax.random.dirichlet(key, conc).astype(jnp.float32)


class PreferenceConditioned(Wrapper):
    """`env` with a preference appended to its observation (`[obs + m]`), drawn by
    `sample_pref(key) -> [m]` at every reset and kept for the episode (`info["pref"]`);
    with `keep`, drawn at the environment's first reset and kept for every later episode
    too (`next_episode`, which the time limit's auto-reset calls)."""

    def __init__(self, env: Env, sample_pref, keep: bool = False):
        super().__init__(env)
        self.sample_pref = sample_pref
        self.keep = bool(keep)
        self.m = int(env.num_objectives)

    def next_episode(self, finished: State, fresh: State) -> State:
        """The state a new episode starts from, given the finished one's last state and
        `fresh`, a reset's (`EpisodeWrapper` calls it at every auto-reset): `fresh` with
        the finished episode's preference where `keep`, else `fresh` (its own draw)."""
        if not self.keep:
            return fresh
        return _carrying(fresh, fresh.obs[: -self.m], finished.info["pref"])

    def reset(self, rng: jax.Array) -> State:
        key_pref, key_env = jax.random.split(typed_key(rng))
        state = self.env.reset(key_env)
        return _carrying(state, state.obs, self.sample_pref(key_pref))

    def step(self, state: State, action: jax.Array) -> State:
        # the episode's preference, read from the observation: a time limit's auto-reset
        # (`EpisodeWrapper`) replaces the observation with the new episode's, whose
        # preference is drawn afresh, but carries the finished episode's `info` on
        pref = state.obs[-self.m :]
        nstate = self.env.step(state.replace(obs=state.obs[: -self.m]), action)
        return _carrying(nstate, nstate.obs, pref)

    @property
    def observation_size(self) -> int:
        return int(self.env.observation_size) + self.m


def _carrying(state: State, raw_obs: chex.Array, pref: chex.Array) -> State:
    """`state` whose observation is `raw_obs` `[obs]` with `pref` `[m]` appended, and
    whose `info["pref"]` is `pref`."""
    return state.replace(obs=jnp.concatenate([raw_obs, pref]), info={**state.info, "pref": pref})


def episode_start_obs(first_obs: chex.Array, obs: chex.Array, done: chex.Array) -> chex.Array:
    """The start observation of each transition's episode, for ONE environment.

    Args:
      first_obs: `[obs]` the start of the episode in progress before the rollout.
      obs: `[L, obs]` the observations the transitions start from.
      done: `[L]` 1 where the episode ended at that transition (the next transition then
        starts a new episode from its own `obs`).

    Returns:
      `[L, obs]`.
    """

    def body(start, x):
        o, d_prev = x
        start = jnp.where(d_prev > 0, o, start)
        return start, start

    done_prev = jnp.concatenate([jnp.zeros((1,), done.dtype), done[:-1]])
    _, starts = jax.lax.scan(body, first_obs, (obs, done_prev))
    return starts


def scalarized_advantage(
    adv: chex.Array,
    j_hat: chex.Array,
    pref: chex.Array,
    z: chex.Array,
    sigma: chex.Array,
    mu: float,
    direction,
    augment: float = 0.0,
) -> tuple[chex.Array, chex.Array]:
    """The practical update's scalarized advantage of ONE transition with preference `p`:
    `(sum_i c_i A_i, weights [m])` with `c = (w(Jhat, p, z) p + rho) sigma`.

    Args:
      adv: `[m]` per-objective advantages (in scaled units).
      j_hat, pref, z, sigma: `[m]` the objectives' estimates at `p`, the preference, the
        utopia point, the reward scales.
      mu: the smoothing temperature; augment: `rho`.
      direction: the scalarization (`runtime.scalarization`'s: a name or an index).
    """
    weights, _ = runtime.scalarization(direction, j_hat, pref, z, mu)
    coeff = scalarize.augmented_coefficients(weights, pref, augment) * sigma
    return adv @ coeff, weights


def estimate_utopia(config: ConditionedConfig, state: utopia.UtopiaState, j_hat: chex.Array):
    """`(state, z [m])` from the batch's `Jhat` `[..., m]`: `wcac_jax.core.utopia`'s rule with
    the preferences in play (every transition's) in place of the sweep's."""
    flat = j_hat.reshape((-1, j_hat.shape[-1]))
    best = jnp.maximum(state.best, jnp.max(flat, axis=0))
    z = utopia.point(
        best,
        jnp.min(flat, axis=0),
        margin=config.utopia_margin,
        min_spread=config.utopia_min_spread,
    )
    return utopia.UtopiaState(best=best), z


def _iteration(parts: runtime.UpdateParts, state: PracticalState, pref, direction=None):
    """One iteration (see the module docstring): `(state, metrics)`."""
    del pref  # every environment carries its own
    config, m = parts.config, parts.m
    raw_size = parts.obs_size - m
    key_rollout, key_epochs = runtime.iteration_keys(state)
    start_before = state.env_state.info["first_obs"]  # [N, obs + m]
    (env_state, episodes), batch = runtime.rollout(
        parts.env_step,
        state.actor,
        state.obs_stats,
        state.env_state,
        state.episodes,
        key_rollout,
        config.rollout_steps,
    )  # batch leaves [L, N, ...]
    estimates = practical._advantages(parts, state, batch, env_state)
    discounted_return, return_stats, sigma, obs_in, adv, target, _ = estimates
    starts = jax.vmap(episode_start_obs, in_axes=(0, 1, 1), out_axes=1)(
        start_before, batch.obs, batch.done
    )  # [L, N, obs + m]
    j_hat = sigma * parts.value_net.apply(state.critic, parts.preprocess(state.obs_stats, starts))
    prefs = batch.obs[..., raw_size:]  # [L, N, m]
    if config.utopia == "estimated":
        utopia_state, z = estimate_utopia(config, state.utopia, j_hat)
    else:
        utopia_state, z = state.utopia, parts.j_ub
    index = (
        runtime.TRACED_DIRECTIONS.index(config.scalarization) if direction is None else direction
    )
    per_sample = functools.partial(
        scalarized_advantage,
        z=z,
        sigma=sigma,
        mu=config.mu,
        direction=index,
        augment=config.augment,
    )
    scalar_adv, weights = jax.vmap(jax.vmap(per_sample))(adv, j_hat, prefs)  # [L, N], [L, N, m]
    optimised = practical._optimise(parts, state, batch, obs_in, scalar_adv, target, key_epochs)
    obs_seen = batch.obs[..., :raw_size].reshape((config.sample_count, raw_size))
    metrics = {
        "train/j_hat": jnp.mean(j_hat, axis=(0, 1)),
        "train/weights": jnp.mean(weights, axis=(0, 1)),
        "train/scalarized": jnp.mean(scalar_adv),
        "train/g_mu": jnp.mean(
            jax.vmap(scalarize.smooth_wc, in_axes=(0, 0, None, None))(
                j_hat.reshape((-1, m)), prefs.reshape((-1, m)), z, config.mu
            )
        ),
        "train/utopia": z,
    }
    renewed = state.replace(
        return_stats=return_stats,
        discounted_return=discounted_return,
        utopia=utopia_state,
        env_state=env_state,
        episodes=episodes,
        obs_stats=runtime.update_obs_stats(config.normalize_obs, state.obs_stats, obs_seen),
    )
    return practical.finish_iteration(parts, state, renewed, estimates, optimised, metrics)


def make_preprocess(config: PracticalConfig, raw_size: int):
    """`(obs_stats, obs [..., raw + m]) -> network input`: the raw observation normalised
    (`runtime.make_preprocess`), the preference as it is (already on the simplex)."""
    normalize = runtime.make_preprocess(config.normalize_obs, obs_clip=config.obs_clip)

    def preprocess(obs_stats, obs):
        raw, pref = obs[..., :raw_size], obs[..., raw_size:]
        return jnp.concatenate([normalize(obs_stats, raw), pref], axis=-1)

    return preprocess


def conditioned_networks(config: ConditionedConfig, m: int) -> networks.NetworkFactory:
    """The conditioned update's networks on `[obs + m]` inputs, as `config.conditioning`
    says: the practical update's tanh MLPs on the concatenation, or
    `networks.film_tanh_mlp` conditioned on the inputs' last `m` entries (the
    preference); the actor's last layer at scale 0.01, the critic's at 1."""
    if config.conditioning != "film":
        return practical.default_networks(config)

    def factory(in_size: int, out_size: int, *, role: str) -> networks.Network:
        scale = 0.01 if role == "actor" else 1.0
        return networks.film_tanh_mlp(in_size, out_size, config.width, config.depth, scale, m)

    return factory


def make_trainer(
    config: ConditionedConfig, env, network_factory: networks.NetworkFactory | None = None
) -> runtime.Trainer:
    """Builds the pure `init`/`run`/`step` of the conditioned update for `env` (see the
    module docstring); `pref` arguments are ignored. `network_factory` builds the actor
    and the vector critic, each taking `(s, p)` (default: the practical update's)."""
    m, raw_size = int(env.num_objectives), int(env.observation_size)
    cenv = PreferenceConditioned(
        env,
        dirichlet_preference(m, config.pref_alpha),
        keep=config.pref_draw == "environment",
    )
    obs_size = raw_size + m
    j_ub = jnp.asarray(runtime.resolve_j_ub(config, env), jnp.float32)
    venv = runtime.vectorize(cenv)
    factory = network_factory or conditioned_networks(config, m)
    policy = runtime.make_policy(
        cenv,
        lambda out: factory(obs_size, out, role="actor"),
        config.log_std_init,
        config.learn_log_std,
        m if config.log_std_by_pref else 0,
    )
    value_net = factory(obs_size, m, role="critic")
    preprocess = make_preprocess(config, raw_size)
    parts = runtime.UpdateParts(
        config=config,
        m=m,
        obs_size=obs_size,
        j_ub=j_ub,
        policy=policy,
        value_net=value_net,
        optimizer=optax.chain(
            optax.clip_by_global_norm(config.max_grad_norm),
            optax.adam(practical.learning_rate(config), eps=config.adam_eps),
        ),
        preprocess=preprocess,
        env_step=functools.partial(runtime.policy_step, policy, preprocess, venv.step),
        venv=venv,
    )
    # the observation statistics cover the raw observation only
    init = functools.partial(practical._init, parts._replace(obs_size=raw_size))
    step = functools.partial(_iteration, parts)
    return runtime.assemble(init, step, policy, value_net, preprocess, j_ub)


def make_evaluate_at(config: PracticalConfig, env, num_episodes: int, trainer: runtime.Trainer):
    """`evaluate_at(state, key, pref [m]) -> metrics`: the one network's mean policy
    evaluated at `pref` (traced), `runtime.make_evaluate`'s metrics."""

    def evaluate_at(state, key, pref):
        fixed = PreferenceConditioned(env, lambda _key: pref)
        return runtime.make_evaluate(config, fixed, num_episodes, trainer)(state, key)

    return evaluate_at


def make_estimate_at(config: PracticalConfig, env, num_episodes: int, trainer: runtime.Trainer):
    """`estimate_at(state, key, pref [m]) -> {"eval/j_hat": [m]}`: the critic's
    `sigma * mean V(s0, p)` over the start states of `make_evaluate_at`'s episodes (the
    same key), in the objectives' discounted units."""
    m = int(env.num_objectives)

    def estimate_at(state: PracticalState, key, pref):
        fixed = PreferenceConditioned(env, lambda _key: pref)
        keys = jax.random.split(typed_key(key), num_episodes)
        starts = runtime.vectorize(fixed).reset(keys).obs  # `runtime.make_evaluate`'s
        inputs = trainer.preprocess(state.obs_stats, starts)
        values = trainer.value_network.apply(state.critic, inputs)
        sigma = state.return_stats.std if config.normalize_returns else jnp.ones((m,))
        return {"eval/j_hat": sigma * jnp.mean(values, axis=0)}

    return estimate_at


def policy_at(trainer: runtime.Trainer, state: PracticalState, pref):
    """`obs [..., obs] -> action`: the network's mean action (as the environment takes
    it) at the preference `pref` `[m]`, for raw observations."""
    pref = jnp.asarray(pref, jnp.float32)

    def act(obs):
        obs = jnp.asarray(obs, jnp.float32)
        tiled = jnp.broadcast_to(pref, (*obs.shape[:-1], pref.shape[-1]))
        return trainer.mean_action(state, jnp.concatenate([obs, tiled], axis=-1))

    return act


def make_evaluate_centre(config: PracticalConfig, env, num_episodes: int, trainer):
    """`evaluate(state, key) -> metrics` at the simplex's centre (`make_evaluate_at`): the
    shared evaluation's signature, for a sweep's one row (`wcac_jax.sweep.conditioned`
    evaluates the network at every preference)."""
    m = int(env.num_objectives)
    evaluate_at = make_evaluate_at(config, env, num_episodes, trainer)
    return lambda state, key: evaluate_at(state, key, jnp.full((m,), 1.0 / m, jnp.float32))
