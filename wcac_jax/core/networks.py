"""Function approximators as `(init, apply)` pairs: the paper's ReLU network, flax MLPs
(ReLU, and the practical preset's orthogonally initialised tanh MLP), the Gaussian and
categorical policy heads, and the per-layer Frobenius-ball projection of Algorithm 2.

Every network's parameters are a `NetParams(trainable, fixed)` pytree: only `trainable`
is ever differentiated, updated, projected or averaged; `fixed` holds what the paper keeps
at its initial value (`A` and `c`). `apply(params, x)` accepts any leading batch axes:
`x` is `[..., in_dim]` and the result `[..., out_dim]`. Every network here is a chain of
dense layers, and `layers(params)` lists them (`Layer`), so that the same function can be
computed outside JAX (`wcac_jax.evaluate.numpy_policy`) without reading the pytree's
layout.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple, Protocol

import chex
import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

NETWORK_KINDS = ("paper", "mlp")


@struct.dataclass
class NetParams:
    """Parameters of one network.

    Attributes:
      trainable: pytree of the trained parameters (the paper's `W = (W_1..W_D)`).
      fixed: pytree of parameters kept at their initial values (the paper's `A`, `c`).
    """

    trainable: Any
    fixed: Any


class Layer(NamedTuple):
    """One dense layer of a network: `y = scale * activation(x @ kernel + bias)`.

    Attributes:
      kernel: `[in, out]`.
      bias: `[out]`.
      activation: `"linear"`, `"relu"` or `"tanh"`.
      scale: a constant factor on the activation's output (the paper network's
        `1 / sqrt(w)`; 1 elsewhere).
    """

    kernel: chex.Array
    bias: chex.Array
    activation: str
    scale: float = 1.0


class Network(NamedTuple):
    """A network as two pure functions, and its parameters as dense layers.

    Attributes:
      init: `key -> NetParams`.
      apply: `(NetParams, x [..., in_dim]) -> y [..., out_dim]`.
      layers: `NetParams -> (Layer, ...)`, the layers `apply` computes, first to last:
        `apply(params, x)` is `x` passed through each in turn.
    """

    init: Callable[[chex.PRNGKey], NetParams]
    apply: Callable[[NetParams, chex.Array], chex.Array]
    layers: Callable[[NetParams], tuple[Layer, ...]] | None = None


class NetworkFactory(Protocol):
    """Builds an update's networks (the `network_factory` of `algos.make_train`, as
    Brax's `network_factory`): `factory(in_size, out_size, role=...) -> Network`.

    `role` is `"actor"` (the policy's head: `out_size` its mean's or its logits' size) or
    `"critic"` (the values: `out_size` 1 for each of the paper's `m` critics, `m` for a
    vector critic); `in_size` is the preprocessed observation's size.
    """

    def __call__(self, in_size: int, out_size: int, *, role: str) -> Network: ...


def paper_network(in_dim: int, out_dim: int, width: int, depth: int) -> Network:
    """The paper's ReLU network (Section 3.2).

    `x0 = A x`, `x_b = ReLU(W_b x_{b-1}) / sqrt(w)` for `b = 1..D`, `y = c^T x_D`, with
    entries of `A` (`[w, d]`) and every `W_b` (`[w, w]`) drawn i.i.d. `N(0, 2)` and of `c`
    (`[w, out_dim]`, one column per output) drawn `N(0, 1)`. Only `W` is trainable
    (`trainable = {"w": (W_1, .., W_D)}`, one leaf per layer, so the projection acts per
    layer); `fixed = {"a": A, "c": c}`. The paper assumes `||x||_2 = 1`; see
    `unit_sphere`. With unit inputs the output's scale at initialisation is about
    `sqrt(2 w)`.

    Args:
      in_dim: `d`, the input size.
      out_dim: number of outputs (1 for a value, the action size for a policy mean).
      width: `w`.
      depth: `D >= 1`, the number of trained layers.
    """
    if depth < 1 or width < 1:
        raise ValueError(f"paper_network needs depth >= 1 and width >= 1, got {depth=}, {width=}")
    inv_sqrt_w = 1.0 / math.sqrt(width)

    def init(key: chex.PRNGKey) -> NetParams:
        key_a, key_w, key_c = jax.random.split(key, 3)
        a = math.sqrt(2.0) * jax.random.normal(key_a, (width, in_dim))
        ws = tuple(
            math.sqrt(2.0) * jax.random.normal(k, (width, width))
            for k in jax.random.split(key_w, depth)
        )
        c = jax.random.normal(key_c, (width, out_dim))
        return NetParams(trainable={"w": ws}, fixed={"a": a, "c": c})

    def apply(params: NetParams, x: chex.Array) -> chex.Array:
        h = x @ params.fixed["a"].T
        for w in params.trainable["w"]:
            h = jax.nn.relu(h @ w.T) * inv_sqrt_w
        return h @ params.fixed["c"]

    def layers(params: NetParams) -> tuple[Layer, ...]:
        a, c = params.fixed["a"], params.fixed["c"]
        return (
            Layer(a.T, jnp.zeros((width,), a.dtype), "linear"),
            *(
                Layer(w.T, jnp.zeros((width,), w.dtype), "relu", inv_sqrt_w)
                for w in params.trainable["w"]
            ),
            Layer(c, jnp.zeros((out_dim,), c.dtype), "linear"),
        )

    return Network(init, apply, layers)


_ACTIVATIONS = {"relu": nn.relu, "tanh": jnp.tanh}


class _MLP(nn.Module):
    hidden: tuple[int, ...]
    out_dim: int
    activation: str  # a name of `_ACTIVATIONS`
    hidden_init: Callable
    out_init: Callable

    @nn.compact
    def __call__(self, x):
        for size in self.hidden:
            x = _ACTIVATIONS[self.activation](nn.Dense(size, kernel_init=self.hidden_init)(x))
        return nn.Dense(self.out_dim, kernel_init=self.out_init)(x)


def _trainable_network(module: _MLP, in_dim: int) -> Network:
    """A flax MLP as a `Network` whose parameters are all trainable (`fixed` empty)."""

    def init(key: chex.PRNGKey) -> NetParams:
        return NetParams(trainable=module.init(key, jnp.zeros((in_dim,))), fixed={})

    def apply(params: NetParams, x: chex.Array) -> chex.Array:
        return module.apply(params.trainable, x)

    def layers(params: NetParams) -> tuple[Layer, ...]:
        # flax names the module's `nn.Dense` layers `Dense_0`, `Dense_1`, ... in call order
        dense = [params.trainable["params"][f"Dense_{i}"] for i in range(len(module.hidden) + 1)]
        activations = [module.activation] * len(module.hidden) + ["linear"]
        return tuple(
            Layer(d["kernel"], d["bias"], act) for d, act in zip(dense, activations, strict=True)
        )

    return Network(init, apply, layers)


def _check_size(name: str, width: int, depth: int) -> None:
    if depth < 1 or width < 1:
        raise ValueError(f"{name} needs depth >= 1 and width >= 1, got {depth=}, {width=}")


def mlp_network(
    in_dim: int, out_dim: int, width: int, depth: int, out_scale: float = 1.0
) -> Network:
    """A conventional fully trainable ReLU MLP (flax), `depth` hidden layers of `width`.

    Every parameter (kernels and biases, LeCun-normal init) is trainable; `fixed` is empty.
    The output layer's initial weights are scaled by `out_scale` (policies use 0.01, as is
    common practice, so that every initial mean action lies well inside the bounds).
    """
    _check_size("mlp_network", width, depth)
    out_init = nn.initializers.variance_scaling(out_scale**2, "fan_in", "truncated_normal")
    module = _MLP((width,) * depth, out_dim, "relu", nn.initializers.lecun_normal(), out_init)
    return _trainable_network(module, in_dim)


def orthogonal(scale: float = 1.0):
    """An orthogonal initializer (as `flax.linen.initializers.orthogonal`) without LAPACK.

    A Gaussian matrix's columns are orthonormalised by Gram-Schmidt, twice per column
    (CGS2, orthogonal to float32 precision), in plain `jnp`; the result is Haar-distributed
    like QR with positive `diag(R)`. Why not flax's: its QR is a LAPACK custom call that,
    batched under the sweep's `vmap` (jaxlib 0.10's `ParallelBatchMap`), deadlocks
    XLA's CPU thread pool now and then when two such calls run at once (measured: the
    practical trainer's `init` for 9 preferences hung in about 1 of 4 runs, every
    thread waiting in `QrFactorizationKernel`).
    """

    def init(key: chex.PRNGKey, shape, dtype=jnp.float32) -> chex.Array:
        rows, cols = shape[0], math.prod(shape[1:])
        n, k = max(rows, cols), min(rows, cols)
        a = jax.random.normal(key, (n, k), jnp.float32)

        def column(q, j):
            v = jax.lax.dynamic_index_in_dim(a, j, axis=1, keepdims=False)
            for _ in range(2):  # unfilled columns of q are 0 and project nothing
                v = v - q @ (q.T @ v)
            return jax.lax.dynamic_update_index_in_dim(q, v / jnp.linalg.norm(v), j, 1), None

        q, _ = jax.lax.scan(column, jnp.zeros_like(a), jnp.arange(k))
        q = q if rows >= cols else q.T
        return (scale * q).reshape(shape).astype(dtype)

    return init


def tanh_mlp(in_dim: int, out_dim: int, width: int, depth: int, out_scale: float) -> Network:
    """A fully trainable tanh MLP as deep on-policy RL uses it (the practical preset's):
    orthogonal init (`orthogonal`), gain `sqrt(2)` on hidden layers and `out_scale` on the
    output (0.01 for a policy, so that every initial mean action is near 0; 1 for a critic)."""
    _check_size("tanh_mlp", width, depth)
    module = _MLP(
        (width,) * depth, out_dim, "tanh", orthogonal(math.sqrt(2)), orthogonal(out_scale)
    )
    return _trainable_network(module, in_dim)


class _FiLMMLP(nn.Module):
    """`_MLP` whose every hidden layer's pre-activation `h` is modulated by the input's
    last `cond_dim` entries `c`: `tanh(h * (1 + gamma(c)) + beta(c))`, `gamma` and `beta`
    linear in `c` and zero at initialisation (so it starts as the plain MLP)."""

    hidden: tuple[int, ...]
    out_dim: int
    cond_dim: int
    hidden_init: Callable
    out_init: Callable

    @nn.compact
    def __call__(self, x):
        cond = x[..., -self.cond_dim :]
        for size in self.hidden:
            h = nn.Dense(size, kernel_init=self.hidden_init)(x)
            film = nn.Dense(2 * size, kernel_init=nn.initializers.zeros)(cond)
            gamma, beta = jnp.split(film, 2, axis=-1)
            x = jnp.tanh(h * (1.0 + gamma) + beta)
        return nn.Dense(self.out_dim, kernel_init=self.out_init)(x)


def film_tanh_mlp(
    in_dim: int, out_dim: int, width: int, depth: int, out_scale: float, cond_dim: int
) -> Network:
    """`tanh_mlp` conditioned by FiLM on the input's last `cond_dim` entries (e.g. a
    preference appended to the observation): the whole input enters the first layer, as
    in `tanh_mlp`, and the conditioning part also scales and shifts every hidden layer
    (`_FiLMMLP`; the modulation starts at zero, so at initialisation this is `tanh_mlp`
    with the same hidden and output initialisers)."""
    _check_size("film_tanh_mlp", width, depth)
    if not 0 < cond_dim <= in_dim:
        raise ValueError(f"film_tanh_mlp needs 0 < cond_dim <= in_dim, got {cond_dim=}, {in_dim=}")
    module = _FiLMMLP(
        (width,) * depth, out_dim, cond_dim, orthogonal(math.sqrt(2)), orthogonal(out_scale)
    )
    return _trainable_network(module, in_dim)


def make_network(
    kind: str, in_dim: int, out_dim: int, width: int, depth: int, policy_head: bool = False
) -> Network:
    """Builds a network by kind: `"paper"` (`paper_network`, exactly as the paper
    initialises it, also for a policy) or `"mlp"` (`mlp_network`; with `policy_head`, the
    output layer starts 100x smaller so that initial mean actions are near 0)."""
    if kind == "paper":
        return paper_network(in_dim, out_dim, width, depth)
    if kind == "mlp":
        return mlp_network(in_dim, out_dim, width, depth, out_scale=0.01 if policy_head else 1.0)
    raise ValueError(f"unknown network kind {kind!r}; valid: {', '.join(NETWORK_KINDS)}")


def unit_sphere(x: chex.Array, eps: float = 1e-8) -> chex.Array:
    """Projects each `[..., d]` row onto the unit sphere (the paper's `||x||_2 = 1`)."""
    return x / jnp.maximum(jnp.linalg.norm(x, axis=-1, keepdims=True), eps)


def paper_input(x: chex.Array) -> chex.Array:
    """The paper network's input: `[x, 1]` projected onto the unit sphere. `[..., d] ->
    [..., d + 1]`.

    The constant `1` is a bias feature, so that the input is never all zero by
    construction. The running normaliser maps a feature that never varies to exactly 0
    (its std is clamped to a tiny value and `x - mean = 0`), and the paper network has no
    bias, so an all-zero input gives an output of exactly 0 whatever `W` is: on
    `concave_bandit`, whose observation is the constant `[1.]`, every policy would then
    stay at its initial action. A bias feature is what a bias-free network needs anyway
    (without it, `y` is positively homogeneous in `x`, `y(0) = 0`); it keeps the paper's
    `||x||_2 = 1` and its initialisation unchanged (one more column of `A`). The
    alternative, not standardising near-constant features, would still give 0 for a
    feature that is constant at 0 (an unvisited one-hot cell, say).
    """
    return unit_sphere(jnp.concatenate([x, jnp.ones_like(x[..., :1])], axis=-1))


def project_to_ball(params: Any, center: Any, radius: float) -> Any:
    """Per-layer Frobenius-ball projection `Proj_B` of Algorithm 2.

    Each leaf `W_b` is scaled back onto `||W_b - W_b(0)||_F <= radius` around its
    counterpart in `center`; a leaf already inside the ball is returned unchanged.
    `radius = inf` disables the projection.

    Args:
      params: pytree of trainable parameters.
      center: pytree of the same structure (the initial parameters `W(0)`).
      radius: `B > 0`.
    """

    def project(w, w0):
        delta = w - w0
        norm = jnp.sqrt(jnp.sum(jnp.square(delta)))
        scale = jnp.minimum(1.0, radius / jnp.maximum(norm, 1e-30))
        return w0 + delta * scale

    return jax.tree.map(project, params, center)


class Policy(NamedTuple):
    """A stochastic policy as pure functions around a network.

    Attributes:
      init: `key -> NetParams`.
      apply: `(NetParams, obs [..., obs]) -> dist`, the distribution's parameters.
      sample: `(key, dist) -> action` (Gaussian: unclipped `[..., act]`; categorical:
        integer `[...]`).
      log_prob: `(dist, action) -> [...]`.
      mode: `dist -> action`, the deterministic policy (Gaussian mean; most likely action).
      entropy: `dist -> [...]`.
      to_env: `action -> action` as the environment takes it (Gaussian: clipped to
        `[-1, 1]`; the score always uses the unclipped sample).
      layers: `NetParams -> (Layer, ...)`, the network's layers inside the policy's
        parameters (`Network.layers`: a Gaussian's mean, a softmax's logits).
    """

    init: Callable[[chex.PRNGKey], NetParams]
    apply: Callable[[NetParams, chex.Array], Any]
    sample: Callable[[chex.PRNGKey, Any], chex.Array]
    log_prob: Callable[[Any, chex.Array], chex.Array]
    mode: Callable[[Any], chex.Array]
    entropy: Callable[[Any], chex.Array]
    to_env: Callable[[chex.Array], chex.Array]
    layers: Callable[[NetParams], tuple[Layer, ...]] | None = None


def gaussian_policy(
    network: Network,
    action_size: int,
    log_std_init: float,
    learn_log_std: bool = True,
    action_bound: float | tuple[float, ...] = 1.0,
    pref_size: int = 0,
) -> Policy:
    """A diagonal Gaussian with the network's `action_size` outputs as mean and a
    state-independent log-std; `dist = (mean [..., act], log_std [act])`.

    With `pref_size = m > 0` the inputs' last `m` entries are a preference `p` on the
    simplex and the log-std depends on it alone: `log_std(p) = p @ L`, with `L` `[m, act]`
    one log-std per vertex (all `log_std_init` at first, so every preference starts with
    the same noise), and `dist = (mean [..., act], log_std [..., act])`.

    The policy acts in `[-1, 1]^act`; `to_env` clips there and scales by `action_bound`,
    the half-width of the environment's own action box (humanoid's is 0.4; a tuple gives
    one per action dimension, e.g. PGMORL's hopper's `(2, 2, 4)`), so the environment
    receives actions in its own space.

    The trainable parameters of the policy, all of which the actor's normalised step
    covers, are the network's trainable parameters and, if `learn_log_std`, the log-std.
    """

    def init(key: chex.PRNGKey) -> NetParams:
        net = network.init(key)
        shape = (pref_size, action_size) if pref_size else (action_size,)
        log_std = jnp.full(shape, log_std_init, dtype=jnp.float32)
        if learn_log_std:
            return NetParams({"net": net.trainable, "log_std": log_std}, {"net": net.fixed})
        return NetParams({"net": net.trainable}, {"net": net.fixed, "log_std": log_std})

    def net_params(params: NetParams) -> NetParams:
        return NetParams(params.trainable["net"], params.fixed["net"])

    def apply(params: NetParams, obs: chex.Array) -> tuple[chex.Array, chex.Array]:
        log_std = params.trainable["log_std"] if learn_log_std else params.fixed["log_std"]
        if pref_size:
            log_std = obs[..., -pref_size:] @ log_std
        return network.apply(net_params(params), obs), log_std

    def entropy(dist):
        mean, log_std = dist
        per_dim = log_std + 0.5 * math.log(2 * math.pi * math.e)
        return jnp.broadcast_to(jnp.sum(per_dim, axis=-1), mean.shape[:-1])

    return Policy(
        init=init,
        apply=apply,
        sample=lambda key, dist: gaussian_sample(key, *dist),
        log_prob=lambda dist, action: gaussian_log_prob(*dist, action),
        mode=lambda dist: dist[0],
        entropy=entropy,
        to_env=_to_box(action_bound),
        layers=lambda params: network.layers(net_params(params)),
    )


def _to_box(bound: float | tuple[float, ...]) -> Callable[[chex.Array], chex.Array]:
    """`action [..., act] -> bound * clip(action, -1, 1)`, `bound` a scalar or `[act]` (no
    multiplication when every entry is 1)."""
    bound = np.asarray(bound, np.float32)
    if np.all(bound == 1.0):
        return lambda action: jnp.clip(action, -1.0, 1.0)
    return lambda action: bound * jnp.clip(action, -1.0, 1.0)


def categorical_policy(network: Network) -> Policy:
    """A softmax policy over the network's outputs (one logit per action); `dist = logits`.

    All of the network's trainable parameters are the policy's.
    """

    def entropy(logits):
        logp = jax.nn.log_softmax(logits)
        return -jnp.sum(jnp.exp(logp) * logp, axis=-1)

    return Policy(
        init=network.init,
        apply=network.apply,
        sample=lambda key, logits: jax.random.categorical(key, logits),
        log_prob=lambda logits, action: jnp.take_along_axis(
            jax.nn.log_softmax(logits), action[..., None].astype(jnp.int32), axis=-1
        )[..., 0],
        mode=lambda logits: jnp.argmax(logits, axis=-1),
        entropy=entropy,
        to_env=lambda action: action,
        layers=network.layers,
    )


def gaussian_log_prob(mean: chex.Array, log_std: chex.Array, action: chex.Array) -> chex.Array:
    """Log-density of a diagonal Gaussian. `mean`, `action`: `[..., act]`; returns `[...]`."""
    z = (action - mean) * jnp.exp(-log_std)
    return jnp.sum(-0.5 * jnp.square(z) - log_std - 0.5 * math.log(2 * math.pi), axis=-1)


def gaussian_sample(key: chex.PRNGKey, mean: chex.Array, log_std: chex.Array) -> chex.Array:
    """Draws `mean + exp(log_std) * eps`, `eps ~ N(0, I)`, of the shape of `mean`."""
    return mean + jnp.exp(log_std) * jax.random.normal(key, mean.shape, mean.dtype)
