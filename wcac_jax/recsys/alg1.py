"""The paper's Algorithm 1 (actor) and Algorithm 2 (critics), offline, on the protocol's
logged transitions: the "wcac (Algorithm 1)" row.

As docs/algorithm.md states the method, with the logged data in place of rollouts:

- actor: a stochastic Gaussian policy over the continuous candidate index,
  `pi_theta(a | s) = N(a; mu_theta(s), sigma^2)`, `mu_theta(s) = (C-1) sigmoid(net(s))`,
  `sigma` the evaluation's (`ncis.SIGMA`), so the trained policy is the evaluated one;
- critics (Algorithm 2): `m` value networks `V_i(s)`, semi-gradient TD(0) with step `beta`,
  each layer projected onto the ball of radius `B` around its initialisation, and the
  iterates averaged (`Wbar_i`); the critics continue across outer iterations (warm start)
  and the average restarts at each (`critic.restart(warm_start=True)`). The transitions
  were logged by another policy, so each TD error is weighted by the capped per-decision
  importance ratio `rho = clip(pi_theta(a | s) / pi_b(a | s), 0, cap)`, `pi_b` the
  behaviour model's Gaussian (the same ratio NCIS uses): the critics evaluate `pi_theta`;
- actor step (Algorithm 1): `K` critic steps per outer iteration, then, with the averaged
  critics, `A_i = r_i + gamma (1 - done) Vbar_i(s') - Vbar_i(s)`,
  `Jhat_i = mean over episode-start states of Vbar_i(s_0)`,
  `lambda = softmax(p (J_ub - Jhat) / mu)`, the score-function direction
  `d = -mean_B(rho sum_i lambda_i p_i A_i grad log pi_theta(a | s))` (`actor.direction`,
  one backward pass) plus the behaviour-cloning term every method shares, and the
  normalised step `theta <- theta - alpha d / ||d||`.

Rewards are scaled as for the other methods (`offline.objectives`), and the first
`critic_warmup` of the steps train the critics only.
"""

from __future__ import annotations

from dataclasses import dataclass

import chex
import jax
import jax.numpy as jnp
import numpy as np
import optax
from flax import struct

from wcac_jax.core import actor as actor_lib
from wcac_jax.core import critic as critic_lib
from wcac_jax.core import scalarize
from wcac_jax.core.networks import NetParams, make_network
from wcac_jax.recsys import ncis as ncis_lib
from wcac_jax.recsys import offline
from wcac_jax.recsys.data import Protocol

M = offline.M


@dataclass(frozen=True)
class Alg1Config:
    """Algorithm 1's own step sizes (sizes, `gamma`, `mu`, `bc_weight` and the budget come
    from the shared `offline.OfflineConfig`).

    Attributes:
      alpha: the actor's normalised step length.
      beta: the critics' TD step size (plain SGD, as Algorithm 2).
      radius: projection radius `B` of each critic layer around its initialisation.
      critic_steps: `K`, critic steps per outer iteration (one actor step each).
      sigma: the Gaussian policy's standard deviation over the index.
      cap: the importance ratio's cap.
    """

    alpha: float = 0.02
    beta: float = 0.05
    radius: float = 10.0
    critic_steps: int = 4
    sigma: float = ncis_lib.SIGMA
    cap: float = ncis_lib.CAP

    def __post_init__(self):
        if self.alpha <= 0 or self.beta <= 0 or self.radius <= 0 or self.sigma <= 0:
            raise ValueError(f"alpha, beta, radius, sigma must be > 0: {self}")
        if self.critic_steps < 1:
            raise ValueError(f"critic_steps must be >= 1, got {self.critic_steps}")


@struct.dataclass
class Alg1State:
    actor: NetParams
    actor_opt: optax.OptState
    critic: critic_lib.CriticState  # leaves [m, ...]
    step: chex.Array


def log_prob(mu: chex.Array, action: chex.Array, sigma: float) -> chex.Array:
    """`log N(action; mu, sigma^2)` without its constant: `-(action - mu)^2 / (2 sigma^2)`."""
    return -jnp.square(action - mu) / (2.0 * sigma**2)


def episode_starts(data: Protocol) -> np.ndarray:
    """Training rows that begin an episode (the first row, and each row after a `done`)."""
    done = np.asarray(data.done[: data.n_train])
    return np.flatnonzero(np.r_[True, done[:-1] > 0])


def make_train(cfg: offline.OfflineConfig, acfg: Alg1Config, data: Protocol):
    """Algorithm 1 on the logged data as one pure function.

    Returns:
      `(train, act)`: `train(key, pref [m], data, objectives, behaviour [n_rows]) ->
      (Alg1State, metrics [steps // K, ...])`, a `lax.scan` over `cfg.steps // K` outer
      iterations of `K` critic steps and one actor step (`cfg.steps` critic steps in all,
      the budget of the other methods); `behaviour` is the behaviour model's action on
      every row. `act(actor_params, x [B, in]) -> [B]` the policy's mean index.
    """
    in_dim, c = offline.input_dim(data), data.n_candidates
    actor_net = make_network("mlp", in_dim, 1, cfg.width, 2, policy_head=True)
    critic_net = make_network("mlp", in_dim, 1, cfg.width, 2)
    actor_opt = actor_lib.make_optimizer("normalized", acfg.alpha)
    warmup = int(cfg.critic_warmup * cfg.steps)
    starts = jnp.asarray(episode_starts(data), jnp.int32)

    def act(params, x):
        return offline.policy_action(actor_net.apply, params, x, c)

    def init(key):
        key_actor, key_critic = jax.random.split(key)
        actor = actor_net.init(key_actor)
        return Alg1State(
            actor=actor,
            actor_opt=actor_opt.init(actor.trainable),
            critic=critic_lib.init(critic_net.init, key_critic, M),
            step=jnp.zeros((), jnp.int32),
        )

    def actor_step(state: Alg1State, batch, rho, x0, pref, obj):
        vbar = critic_lib.averaged_params(state.critic)
        v = critic_lib.values(critic_net.apply, vbar, batch["x"])
        v_next = critic_lib.values(critic_net.apply, vbar, batch["x_next"])
        adv = actor_lib.td_advantages(v, batch["reward"], v_next, batch["done"], cfg.gamma)
        j_hat = actor_lib.objective_estimates(critic_lib.values(critic_net.apply, vbar, x0))
        lam = scalarize.smooth_wc_weights(j_hat, pref, obj.j_ub, cfg.mu)

        def lp(params, x, a):
            return log_prob(act(params, x), a, acfg.sigma)

        d = actor_lib.direction(
            lp, state.actor, batch["x"], batch["action"], rho[:, None] * adv, lam, pref
        )
        if cfg.bc_weight > 0.0:
            a_pi, mu_vjp = jax.vjp(
                lambda t: act(NetParams(t, state.actor.fixed), batch["x"]), state.actor.trainable
            )
            (bc,) = mu_vjp(offline.bc_cotangent(a_pi, batch["action"], c))
            d = jax.tree.map(lambda g, b: g + cfg.bc_weight * b, d, bc)
        upd, opt_state = actor_opt.update(d, state.actor_opt, state.actor.trainable)
        actor = state.actor.replace(trainable=optax.apply_updates(state.actor.trainable, upd))
        return actor, opt_state, j_hat, lam

    def critic_step(state: Alg1State, key, data_: Protocol, obj, behaviour):
        batch = offline.sample_batch(key, data_, cfg.batch_size, obj)
        mu = act(state.actor, batch["x"])
        rho = ncis_lib.importance_weights(
            mu, behaviour[batch["rows"]], batch["action"], acfg.sigma, acfg.cap
        )
        critic, delta = critic_lib.update(
            critic_net.apply,
            state.critic,
            batch["x"],
            batch["reward"],
            batch["x_next"],
            batch["done"],
            gamma=cfg.gamma,
            learning_rate=acfg.beta,
            radius=acfg.radius,
            weight=rho,
        )
        loss = 0.5 * jnp.sum(jnp.mean(jnp.square(delta), axis=0))
        return state.replace(critic=critic, step=state.step + 1), (loss, batch, rho)

    def iteration(state: Alg1State, key, pref, data_: Protocol, obj, behaviour):
        """`K` critic steps, then (after the warm-up) one actor step on the last batch."""
        key_critic, key_start = jax.random.split(key)
        state, (losses, batches, rhos) = jax.lax.scan(
            lambda st, k: critic_step(st, k, data_, obj, behaviour),
            state,
            jax.random.split(key_critic, acfg.critic_steps),
        )
        batch = jax.tree.map(lambda x: x[-1], batches)
        rows0 = starts[jax.random.randint(key_start, (cfg.batch_size,), 0, starts.shape[0])]
        x0 = offline.net_input(data_, rows0)
        actor, opt_state, j_hat, lam = actor_step(state, batch, rhos[-1], x0, pref, obj)
        now = state.step > warmup
        keep = lambda old, new: jax.tree.map(lambda o, n: jnp.where(now, n, o), old, new)
        state = state.replace(
            actor=keep(state.actor, actor),
            actor_opt=keep(state.actor_opt, opt_state),
            critic=critic_lib.restart(state.critic, warm_start=True),
        )
        metrics = {
            "train/critic_loss": jnp.mean(losses),
            "train/j_hat": j_hat,
            "train/weights": lam,
            "train/mean_action": jnp.mean(act(state.actor, batch["x"])),
            "train/rho": jnp.mean(rhos),
        }
        return state, metrics

    def train(key, pref, data_: Protocol, obj: offline.Objectives, behaviour):
        chex.assert_shape(pref, (M,))
        key_init, key_steps = jax.random.split(key)
        n_iter = cfg.steps // acfg.critic_steps
        return jax.lax.scan(
            lambda st, k: iteration(st, k, pref, data_, obj, behaviour),
            init(key_init),
            jax.random.split(key_steps, n_iter),
        )

    return train, act
