"""Offline multi-objective actor-critics on the protocol's logged transitions, and
Behavior-Clone; each `train(key, pref, data, objectives)` is one pure function, a
`lax.scan` over steps, that the caller vmaps over preferences (or seeds) in one compiled
program. The paper's Algorithm 1 is `wcac_jax.recsys.alg1`; these four are DDPG-style.

All four actor-critics share everything but their network class and their rule for
combining the `m = 7` per-signal objectives (`METHODS`):

- actor `mu_theta(s) in [0, C-1]`: the continuous candidate index, `(C-1) sigmoid(net(s))`
  (the benchmark's actors output a continuous index; evaluation wraps it in a Gaussian);
- critics: one Q-network per signal, `Q_i(s, a)`, parameters stacked on an `[m]` axis
  (`wcac_jax.core.critic.values` evaluates them), trained by TD on logged transitions,
  `delta_i = Q_i(s, a) - r_i - gamma (1 - done) Q'_i(s', mu'(s'))` (`critic.td_error`)
  with Polyak target networks `Q'`, `mu'` and Adam. The critic sees the action as the
  6 candidate features linearly interpolated at the continuous index plus the index
  itself (7 numbers), so that `Q` is differentiable in `a` and shares what it learns
  across similar videos;
- per-signal objectives `J_i = mean_batch Q_i(s, mu_theta(s))` and deterministic policy
  gradients `grad J_i = mean_B dQ_i/da dmu/dtheta` (one forward-mode pass through the
  critics for every `dQ_i/da`, then the actor alone); rewards are divided by their
  training means and multiplied by `1 - gamma` (values of order 1 for every signal), and
  dislike is negated, so every objective is maximised and one preference vector weighs
  comparable numbers;
- the same behaviour-cloning term for every method, `bc_weight * mean(((mu(s) - a) /
  (C-1))^2)` pulling the actor towards the logged actions (`OfflineConfig.bc_weight`;
  0 turns it off for all);
- the actor's step: Adam (`wcac_jax.core.actor.make_optimizer("adam")`) on a direction `d`,
  at `actor_lr` for DNN actors and `linear_actor_lr` for linear ones (each class at the
  step size under which its mean action levels off within the budget); the first
  `critic_warmup` of the steps train the critics only.

The combination rules:

- `wcac` (DNN, DDPG-style): smoothed weighted Chebyshev,
  `d = -sum_i lambda_i p_i grad J_i` with `lambda = softmax(p (J_ub - J) / mu)`
  (`scalarize.smooth_wc_weights`), in one backward pass;
- `pdpg` (DNN): PDPG's idea (Chen et al., WWW 2021; its exact rule is not public):
  min-norm (MGDA) weights over the preference-scaled per-signal gradients
  (`actor.min_norm_weights`);
- `moac` (linear actor): MOAC's idea (exact rule not reproduced): the same min-norm
  weights, smoothed by momentum across steps, `lambda_t = momentum lambda_{t-1} +
  (1 - momentum) lambda_minnorm`;
- `mocha` (linear actor): MOCHA's idea (exact rule not reproduced): hard weighted
  Chebyshev with the given weight vector, `d = -sum_i w_i p_i grad J_i` with `w` one-hot
  on the largest `p_i (J_ub_i - J_i)` (`scalarize.wc_weights`).

`J_ub` is the logged behaviour's mean discounted value per objective plus
`ub_margin * |value|` (computed by `objectives`). DNN networks are 3-layer ReLU
perceptrons (two hidden layers of `width`, `networks.mlp_network`). The linear methods are
policy-linear: a single affine actor layer, and critics linear in the state for each
action plus a state-action interaction (`bilinear_network`), the critic under which a
deterministic policy gradient depends on the state (with a critic affine in `(s, a)` the
gradient `dQ/da` is the same in every state). The candidate block of the state is
identically zero after normalisation (`data.states`), so the networks take the user and
history blocks only: their weights on the zero block would never move and contribute
nothing, so this is the same function, about seven times cheaper.
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
from wcac_jax.core.networks import NetParams, Network, make_network
from wcac_jax.recsys.data import Protocol, for_test_rows

M = 7
HATE = 5
METHODS = ("wcac", "pdpg", "moac", "mocha")
COMBINE_RULES = ("smooth_wc", "min_norm", "min_norm_momentum", "wc")


@dataclass(frozen=True)
class MethodSpec:
    """What distinguishes a method: its network class and its combination rule."""

    network: str  # "dnn" | "linear"
    combine: str  # one of COMBINE_RULES


SPECS = {
    "wcac": MethodSpec("dnn", "smooth_wc"),
    "pdpg": MethodSpec("dnn", "min_norm"),
    "moac": MethodSpec("linear", "min_norm_momentum"),
    "mocha": MethodSpec("linear", "wc"),
}


@dataclass(frozen=True)
class OfflineConfig:
    """Static sizes and hyperparameters shared by every method.

    Attributes:
      steps: update steps (critic and, after `critic_warmup * steps`, actor).
      batch_size: transitions per step, drawn uniformly from the training rows.
      width: hidden width of DNN networks.
      gamma: discount (the protocol's 0.99).
      critic_lr, actor_lr: Adam step sizes (`actor_lr`: the DNN actors').
      linear_actor_lr: the linear actors' Adam step size. Adam moves each parameter by
        about its step size per step, and a single affine layer's output moves with its
        bias (its inputs are normalised to mean 0): at the DNN actors' 1e-3 a linear
        actor's mean action is still falling after 2,000 steps of batch 256 on the
        synthetic KuaiRand sets and levels off only after about 5,000, where the DNN
        actors level off within 200 steps of their first; at 1e-2 it levels off within
        about 1,000, at the same place.
      tau: Polyak rate of the target networks.
      mu: smoothing temperature of `smooth_wc`.
      ub_margin: `J_ub = J_behaviour + ub_margin * |J_behaviour|`.
      momentum: MOAC's momentum on its weights.
      critic_warmup: share of the steps that train the critics only.
      bc_weight: weight of the behaviour-cloning term `mean(((mu(s) - a) / (C-1))^2)`
        added to every actor's loss (the same for every method; 0 turns it off for all).
    """

    steps: int = 2000
    batch_size: int = 128
    width: int = 128
    gamma: float = 0.99
    critic_lr: float = 1e-3
    actor_lr: float = 1e-3
    linear_actor_lr: float = 1e-2
    tau: float = 0.005
    mu: float = 0.01
    ub_margin: float = 0.2
    momentum: float = 0.9
    critic_warmup: float = 0.25
    bc_weight: float = 1.0

    def __post_init__(self):
        if self.steps < 1 or self.batch_size < 1 or self.width < 1:
            raise ValueError(f"steps, batch_size, width must be >= 1: {self}")
        if not 0.0 <= self.gamma < 1.0:
            raise ValueError(f"gamma must be in [0, 1), got {self.gamma}")
        if self.mu <= 0:
            raise ValueError(f"mu must be > 0, got {self.mu}")


class TrainingError(RuntimeError):
    """Training produced a non-finite value; the message names where it first appeared."""


def check_finite(name: str, what: str, values) -> None:
    """Raises `TrainingError` at the first non-finite entry of a training record.

    Args:
      name: the method, for the message.
      what: the quantity, e.g. `"critic loss"`.
      values: `[steps]` or `[P, steps]` (one row per preference); host side.
    """
    x = np.asarray(values, np.float64)
    x = x.reshape((1,) * (2 - x.ndim) + x.shape)
    bad = ~np.isfinite(x)
    if not bad.any():
        return
    step = int(np.argmax(bad.any(axis=0)))  # the first step where any preference failed
    pref = int(np.argmax(bad[:, step]))
    where = f" (preference {pref + 1} of {x.shape[0]})" if x.shape[0] > 1 else ""
    raise TrainingError(
        f"{name}: {what} is {x[pref, step]} at step {step + 1} of {x.shape[1]}{where}"
    )


@struct.dataclass
class Objectives:
    """How rewards become maximised, comparable objectives.

    Attributes:
      scale: `[m]` multiplies the raw reward (`(1 - gamma) / mean`, negated for hate;
        under `protocol="tscac"` the raw rewards: `1`, negated for hate).
      j_ub: `[m]` utopia point in the scaled units.
    """

    scale: chex.Array
    j_ub: chex.Array


def objectives(data: Protocol, gamma: float, ub_margin: float) -> Objectives:
    """Reward scales and the utopia point from the training rows (host side, numpy).

    `J_ub_i = J_b,i + ub_margin |J_b,i|` where `J_b,i` is the mean over training rows of
    the logged discounted return-to-go of the scaled reward `i`. Under `protocol="tscac"`
    the rewards stay raw (only hate is negated), as that pipeline trains on them.
    """
    reward = np.asarray(data.reward[: data.n_train], np.float64)
    done = np.asarray(data.done[: data.n_train], np.float64)
    sign = np.ones(M)
    sign[HATE] = -1.0
    if data.protocol == "tscac":
        scale = sign
    else:
        scale = sign * (1.0 - gamma) / np.maximum(reward.mean(axis=0), 1e-12)
    scaled = reward * scale
    ret = np.zeros_like(scaled)
    acc = np.zeros(M)
    for t in range(scaled.shape[0] - 1, -1, -1):
        acc = scaled[t] + gamma * (1.0 - done[t]) * acc
        ret[t] = acc
    j_b = ret.mean(axis=0)
    return Objectives(
        scale=jnp.asarray(scale, jnp.float32),
        j_ub=jnp.asarray(j_b + ub_margin * np.abs(j_b), jnp.float32),
    )


def linear_network(in_dim: int, out_dim: int) -> Network:
    """A single affine layer `y = x W + b`, zero-initialised; all of it trainable."""

    def init(key: chex.PRNGKey) -> NetParams:
        del key
        return NetParams({"w": jnp.zeros((in_dim, out_dim)), "b": jnp.zeros((out_dim,))}, {})

    def apply(params: NetParams, x: chex.Array) -> chex.Array:
        return x @ params.trainable["w"] + params.trainable["b"]

    return Network(init, apply)


def bilinear_network(in_dim: int, action_dim: int) -> Network:
    """A critic linear in the state for each action and in the action for each state:
    `Q(x, phi) = [x, phi] w + b + phi^T V x` on inputs `[x, phi]` (`phi` the last
    `action_dim` entries), zero-initialised.

    A critic affine in `[x, phi]` has `dQ/dphi = w_phi` in every state, so its
    deterministic policy gradient pushes every state's action the same way; the `phi^T V x`
    term makes the gradient depend on the state, which a linear policy can then follow.
    """

    def init(key: chex.PRNGKey) -> NetParams:
        del key
        return NetParams(
            {
                "w": jnp.zeros((in_dim + action_dim, 1)),
                "b": jnp.zeros((1,)),
                "v": jnp.zeros((action_dim, in_dim)),
            },
            {},
        )

    def apply(params: NetParams, x: chex.Array) -> chex.Array:
        p = params.trainable
        s, phi = x[..., :in_dim], x[..., in_dim:]
        inter = jnp.sum((phi @ p["v"]) * s, axis=-1, keepdims=True)
        return x @ p["w"] + p["b"] + inter

    return Network(init, apply)


def net_input(data: Protocol, rows: chex.Array) -> chex.Array:
    """The networks' input: the state without its all-zero candidate block, `[B, 24 + 6H]`."""
    user = data.user_table[data.user_index[rows]]
    hist = data.history[rows]
    raw = jnp.where(hist[..., None] >= 0, data.video_raw[jnp.maximum(hist, 0)], 0.0)
    hist_block = ((raw - data.hist_mean) / data.hist_std).reshape(rows.shape[0], -1)
    return jnp.concatenate([user, hist_block], axis=-1)


def input_dim(data: Protocol) -> int:
    return int(data.user_table.shape[1] + data.hist_mean.size)


def action_input(action_features: chex.Array, action: chex.Array) -> chex.Array:
    """The critic's view of a continuous index: interpolated candidate features + index.

    Args:
      action_features: `[C, 6]` normalised candidate features.
      action: `[B]` continuous indices in `[0, C-1]`.

    Returns:
      `[B, 7]`: `(1 - f) F[i] + f F[i+1]` with `i = floor(a)`, `f = a - i`, and
      `2 a / (C-1) - 1`.
    """
    c = action_features.shape[0]
    a = jnp.clip(action, 0.0, c - 1.0)
    i = jnp.clip(jnp.floor(a), 0, c - 2).astype(jnp.int32)
    f = (a - i)[:, None]
    feats = (1.0 - f) * action_features[i] + f * action_features[i + 1]
    return jnp.concatenate([feats, (2.0 * a / (c - 1.0) - 1.0)[:, None]], axis=-1)


@struct.dataclass
class OfflineState:
    """Everything one preference's training carries across steps."""

    actor: NetParams
    actor_target: NetParams
    actor_opt: optax.OptState
    critic: NetParams  # leaves [m, ...]
    critic_target: NetParams
    critic_opt: optax.OptState
    weights: chex.Array  # [m] the last combination weights (MOAC: its momentum state)
    step: chex.Array


def make_networks(spec: MethodSpec, cfg: OfflineConfig, in_dim: int):
    """`(actor, critic)` Networks: actor `[.., in] -> [.., 1]`, critic `[.., in + 7] -> [.., 1]`."""
    if spec.network == "dnn":
        return (
            make_network("mlp", in_dim, 1, cfg.width, 2, policy_head=True),
            make_network("mlp", in_dim + 7, 1, cfg.width, 2),
        )
    if spec.network == "linear":
        return linear_network(in_dim, 1), bilinear_network(in_dim, 7)
    raise ValueError(f"unknown network class {spec.network!r}; valid: dnn, linear")


def policy_action(apply, params: NetParams, x: chex.Array, n_candidates: int) -> chex.Array:
    """`mu(s) = (C-1) sigmoid(net(s))`: `[B, in] -> [B]` continuous indices."""
    return (n_candidates - 1.0) * jax.nn.sigmoid(apply(params, x)[..., 0])


def critic_loss(
    critic_apply,
    trainable,
    fixed,
    target: NetParams,
    x: chex.Array,
    reward: chex.Array,
    x_next: chex.Array,
    done: chex.Array,
    gamma: float,
):
    """`sum_i mean_B delta_i^2 / 2` over the `m` critics, with the target's `Q'(s', a')`.

    Args:
      x: `[B, in + 7]` critic inputs `(s, a)`; x_next: `[B, in + 7]` `(s', mu'(s'))`;
      reward: `[B, m]` scaled rewards; done: `[B]`.

    Returns:
      `(loss, delta [B, m])`.
    """
    q = critic_lib.values(critic_apply, NetParams(trainable, fixed), x)
    q_next = jax.lax.stop_gradient(critic_lib.values(critic_apply, target, x_next))
    delta = critic_lib.td_error(q, reward, q_next, done[:, None], gamma)
    return 0.5 * jnp.sum(jnp.mean(jnp.square(delta), axis=0)), delta


def combine_weights(
    spec: MethodSpec,
    j_hat: chex.Array,
    pref: chex.Array,
    j_ub: chex.Array,
    mu: float,
    gram: chex.Array | None,
    previous: chex.Array,
    momentum: float,
) -> chex.Array:
    """The `[m]` weights `w` of `d = -sum_i w_i p_i grad J_i` for a method.

    Args:
      j_hat: `[m]` current objective estimates; pref: `[m]`; j_ub: `[m]`.
      gram: `[m, m]` Gram matrix of the preference-scaled gradients (min-norm rules).
      previous: `[m]` the previous step's weights (momentum rule).
    """
    if spec.combine == "smooth_wc":
        return scalarize.smooth_wc_weights(j_hat, pref, j_ub, mu)
    if spec.combine == "wc":
        return scalarize.wc_weights(j_hat, pref, j_ub)
    lam = actor_lib.min_norm_weights(gram)
    if spec.combine == "min_norm":
        return lam
    if spec.combine == "min_norm_momentum":
        return momentum * previous + (1.0 - momentum) * lam
    raise ValueError(f"unknown combination rule {spec.combine!r}; valid: {COMBINE_RULES}")


def bc_cotangent(a: chex.Array, logged: chex.Array, n_candidates: int) -> chex.Array:
    """`d/da` of the behaviour-cloning loss `mean_B(((a - logged) / (C-1))^2)`: `[B]`."""
    return 2.0 * (a - logged) / (jnp.square(n_candidates - 1.0) * a.shape[0])


def _flat(tree) -> chex.Array:
    """`[m, ...]`-leading pytree -> `[m, n_params]`."""
    return jnp.concatenate([g.reshape(g.shape[0], -1) for g in jax.tree.leaves(tree)], axis=1)


def make_update(spec: MethodSpec, cfg: OfflineConfig, in_dim: int, n_candidates: int):
    """Returns `(init, update)`: `init(key) -> OfflineState` and
    `update(state, batch, pref, objectives) -> (state, metrics)` (pure, one step).

    `batch` is a dict: `x [B, in]`, `x_next [B, in]`, `action [B]` (logged index),
    `reward [B, m]` (scaled), `done [B]`, `action_features [C, 6]`.
    """
    actor_net, critic_net = make_networks(spec, cfg, in_dim)
    lr = cfg.linear_actor_lr if spec.network == "linear" else cfg.actor_lr
    actor_opt = actor_lib.make_optimizer("adam", lr)
    critic_opt = optax.adam(cfg.critic_lr)
    warmup = int(cfg.critic_warmup * cfg.steps)

    def init(key: chex.PRNGKey) -> OfflineState:
        key_actor, key_critic = jax.random.split(key)
        actor = actor_net.init(key_actor)
        critic = critic_lib.init(critic_net.init, key_critic, M).params
        return OfflineState(
            actor=actor,
            actor_target=actor,
            actor_opt=actor_opt.init(actor.trainable),
            critic=critic,
            critic_target=critic,
            critic_opt=critic_opt.init(critic.trainable),
            weights=jnp.full((M,), 1.0 / M),
            step=jnp.zeros((), jnp.int32),
        )

    def act(params, x):
        return policy_action(actor_net.apply, params, x, n_candidates)

    def update(state: OfflineState, batch, pref, obj: Objectives):
        feats = batch["action_features"]

        def q_of(critic, a):  # [B] actions -> [B, m] Q_i(s, a)
            x_pi = jnp.concatenate([batch["x"], action_input(feats, a)], axis=-1)
            return critic_lib.values(critic_net.apply, critic, x_pi)

        x_sa = jnp.concatenate([batch["x"], action_input(feats, batch["action"])], axis=-1)
        a_next = act(state.actor_target, batch["x_next"])
        x_next = jnp.concatenate([batch["x_next"], action_input(feats, a_next)], axis=-1)
        (closs, delta), cgrad = jax.value_and_grad(critic_loss, argnums=1, has_aux=True)(
            critic_net.apply,
            state.critic.trainable,
            state.critic.fixed,
            state.critic_target,
            x_sa,
            batch["reward"],
            x_next,
            batch["done"],
            cfg.gamma,
        )
        cupd, critic_opt_state = critic_opt.update(cgrad, state.critic_opt)
        critic = state.critic.replace(trainable=optax.apply_updates(state.critic.trainable, cupd))

        # DPG through the updated critics: grad J_i = mean_B dQ_i/da (s, mu(s)) dmu(s)/dtheta.
        # One forward-mode pass gives every dQ_i/da (the action is a scalar), then the
        # actor alone is differentiated: m actor passes instead of m critic passes.
        a_pi, mu_vjp = jax.vjp(
            lambda t: act(NetParams(t, state.actor.fixed), batch["x"]), state.actor.trainable
        )
        q_pi, dq_da = jax.jvp(
            lambda a: q_of(critic, a), (a_pi,), (jnp.ones_like(a_pi),)
        )  # [B, m] each
        j_hat = jnp.mean(q_pi, axis=0)
        b = a_pi.shape[0]
        if spec.combine in ("smooth_wc", "wc"):
            w = combine_weights(spec, j_hat, pref, obj.j_ub, cfg.mu, None, state.weights, 0.0)
            (grad,) = mu_vjp(-(dq_da @ (w * pref)) / b)
        else:  # the m per-signal gradients, preference-scaled
            scaled = jax.vmap(lambda c: mu_vjp(c)[0])((dq_da * pref).T / b)  # leaves [m, ...]
            flat = _flat(scaled)
            w = combine_weights(
                spec, j_hat, pref, obj.j_ub, cfg.mu, flat @ flat.T, state.weights, cfg.momentum
            )
            grad = jax.tree.map(lambda g: -jnp.tensordot(w, g, axes=1), scaled)
        if cfg.bc_weight > 0.0:
            (bc_grad,) = mu_vjp(bc_cotangent(a_pi, batch["action"], n_candidates))
            grad = jax.tree.map(lambda g, c: g + cfg.bc_weight * c, grad, bc_grad)
        aupd, actor_opt_state = actor_opt.update(grad, state.actor_opt, state.actor.trainable)
        train_actor = state.step >= warmup
        new_actor = jax.tree.map(
            lambda old, new: jnp.where(train_actor, new, old),
            (state.actor.trainable, state.actor_opt),
            (optax.apply_updates(state.actor.trainable, aupd), actor_opt_state),
        )
        actor = state.actor.replace(trainable=new_actor[0])
        state = state.replace(
            actor=actor,
            actor_opt=new_actor[1],
            actor_target=state.actor_target.replace(
                trainable=optax.incremental_update(
                    actor.trainable, state.actor_target.trainable, cfg.tau
                )
            ),
            critic=critic,
            critic_opt=critic_opt_state,
            critic_target=state.critic_target.replace(
                trainable=optax.incremental_update(
                    critic.trainable, state.critic_target.trainable, cfg.tau
                )
            ),
            weights=jnp.where(train_actor, w, state.weights),
            step=state.step + 1,
        )
        metrics = {
            "train/critic_loss": closs,
            "train/td_abs": jnp.mean(jnp.abs(delta), axis=0),
            "train/j_hat": j_hat,
            "train/weights": w,
            "train/mean_action": jnp.mean(act(actor, batch["x"])),
        }
        return state, metrics

    return init, update, act


def sample_batch(key: chex.PRNGKey, data: Protocol, batch_size: int, obj: Objectives):
    """A uniform batch of training transitions, as `make_update`'s `batch` dict."""
    rows = jax.random.randint(key, (batch_size,), 0, data.n_train)
    nxt = jnp.minimum(rows + 1, data.n_rows - 1)
    return {
        "x": net_input(data, rows),
        "x_next": net_input(data, nxt),
        "action": data.action[rows].astype(jnp.float32),
        "reward": data.reward[rows] * obj.scale,
        "done": data.done[rows],
        "action_features": data.action_features,
        "rows": rows,
    }


def make_train(method: str, cfg: OfflineConfig, data: Protocol):
    """The whole offline training of one method as one pure function.

    Returns:
      `(train, act)`: `train(key, pref [m], data, objectives) -> (OfflineState,
      metrics [steps, ...])`, a `lax.scan`; vmap it over `(key, pref)` for a sweep.
      `act(actor_params, x [B, in]) -> [B]` the trained policy's index.
    """
    if method not in SPECS:
        raise ValueError(f"unknown method {method!r}; valid: {', '.join(METHODS)}")
    init, update, act = make_update(SPECS[method], cfg, input_dim(data), data.n_candidates)

    def train(key, pref, data: Protocol, obj: Objectives):
        chex.assert_shape(pref, (M,))
        key_init, key_steps = jax.random.split(key)

        def step(state, key):
            return update(state, sample_batch(key, data, cfg.batch_size, obj), pref, obj)

        return jax.lax.scan(step, init(key_init), jax.random.split(key_steps, cfg.steps))

    return train, act


def make_train_bc(cfg: OfflineConfig, data: Protocol):
    """Behavior-Clone: a 3-layer ReLU softmax classifier of the logged candidate index,
    trained by cross-entropy with Adam on the rows `data.behaviour_rows` (the training
    rows; the test rows, with their split's normalisation, under `protocol="tscac"`).

    Returns:
      `(train, act)`: `train(key, data) -> (params, losses [steps])`;
      `act(params, x [B, in]) -> [B]` its most likely index (as float).
    """
    net = make_network("mlp", input_dim(data), data.n_candidates, cfg.width, 2)
    opt = optax.adam(cfg.critic_lr)

    def loss_fn(trainable, fixed, x, action):
        logits = net.apply(NetParams(trainable, fixed), x)
        return jnp.mean(optax.softmax_cross_entropy_with_integer_labels(logits, action))

    def train(key, data: Protocol):
        key_init, key_steps = jax.random.split(key)
        params = net.init(key_init)
        start, stop = data.behaviour_rows
        # states of test rows use the test split's normalisation (tscac's own per split)
        src = for_test_rows(data) if start >= data.n_train else data

        def step(carry, key):
            trainable, opt_state = carry
            rows = jax.random.randint(key, (cfg.batch_size,), start, stop)
            loss, grad = jax.value_and_grad(loss_fn)(
                trainable, params.fixed, net_input(src, rows), data.action[rows]
            )
            upd, opt_state = opt.update(grad, opt_state)
            return (optax.apply_updates(trainable, upd), opt_state), loss

        carry = (params.trainable, opt.init(params.trainable))
        (trainable, _), losses = jax.lax.scan(step, carry, jax.random.split(key_steps, cfg.steps))
        return params.replace(trainable=trainable), losses

    def act(params, x):
        return jnp.argmax(net.apply(params, x), axis=-1).astype(jnp.float32)

    return train, act
