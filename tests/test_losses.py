"""The generic on-policy pieces (`wcac_jax.core.losses`) against hand-computed values: GAE at
falls and time limits, the clipped surrogate and its gradient, the minibatch loss, and
epochs that visit every sample once each."""

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
import optax

from wcac_jax import networks
from wcac_jax.core import losses


def test_gae_terminal_and_truncation_by_hand():
    # gamma = lam = 0.5. Transition 1 falls (terminal: no bootstrap, the recursion
    # stops); transition 2 hits the time limit (bootstraps from its true next state's
    # value 6, not from the next transition's start value 4; the recursion stops).
    v = jnp.array([1.0, 2.0, 3.0, 4.0])
    v_next = jnp.array([2.0, 5.0, 6.0, 7.0])
    r = jnp.ones(4)
    terminal = jnp.array([0.0, 1.0, 0.0, 0.0])
    done = jnp.array([0.0, 1.0, 1.0, 0.0])
    # deltas: 1 + .5*2 - 1 = 1; 1 - 2 = -1; 1 + .5*6 - 3 = 1; 1 + .5*7 - 4 = .5
    # A3 = .5; A2 = 1; A1 = -1; A0 = 1 + .25 * (-1) = .75
    expected = np.array([0.75, -1.0, 1.0, 0.5])
    # two objectives: the second is the first times 2 (GAE is linear in r and V)
    adv = jax.jit(losses.gae, static_argnums=(5, 6))(
        jnp.stack([v, 2 * v], -1),
        jnp.stack([v_next, 2 * v_next], -1),
        jnp.stack([r, 2 * r], -1),
        terminal,
        done,
        0.5,
        0.5,
    )
    np.testing.assert_allclose(adv, np.stack([expected, 2 * expected], -1), rtol=1e-6)


def test_clipped_surrogate_and_its_gradient_by_hand():
    log_ratio = jnp.log(jnp.array([1.5, 0.5, 1.1, 0.7]))
    adv = jnp.array([1.0, 1.0, -2.0, -1.0])
    # min(rho A, clip(rho, .8, 1.2) A): 1.2 (clipped), 0.5, -2.2, -0.8 (clipped)
    value, grad = jax.jit(jax.value_and_grad(losses.clipped_surrogate), static_argnums=2)(
        log_ratio, adv, 0.2
    )
    np.testing.assert_allclose(value, (1.2 + 0.5 - 2.2 - 0.8) / 4, rtol=1e-6)
    # d/d log rho of rho A is rho A where the unclipped term is the minimum, else 0
    np.testing.assert_allclose(grad, [0.0, 0.5 / 4, -2.2 / 4, 0.0], rtol=1e-6, atol=1e-7)


def test_advantage_normalisation_by_hand():
    out = losses.normalize_advantages(jnp.array([1.0, 3.0]))
    np.testing.assert_allclose(out, [-1.0, 1.0], rtol=1e-6)


def _constant_net(name: str):
    """A `networks.Network` whose output is its one parameter `name`, at every input."""
    return networks.Network(
        init=lambda key: networks.NetParams({name: jnp.zeros(1)}, {}),
        apply=lambda params, x: jnp.broadcast_to(params.trainable[name], (*x.shape[:-1], 1)),
    )


def test_ppo_loss_by_hand():
    # a unit Gaussian whose mean is one parameter w (same at every state), a critic that
    # is one constant c; the batch was collected at w = 0 and the loss is taken at
    # w = 0.5, c = 2
    policy = networks.gaussian_policy(_constant_net("w"), 1, 0.0, learn_log_std=False)
    value_net = _constant_net("c")
    actor_fixed, critic_fixed = policy.init(None), value_net.init(None)
    actions = jnp.array([[0.0], [1.0]])
    old_dist = policy.apply(actor_fixed, jnp.zeros((2, 3)))
    batch = {
        "obs": jnp.zeros((2, 3)),
        "action": actions,
        "log_prob": policy.log_prob(old_dist, actions),
        "advantage": jnp.array([1.0, 3.0]),  # normalised: -1, 1
        "target": jnp.array([[1.0], [4.0]]),
        "actor_fixed": actor_fixed,
        "critic_fixed": critic_fixed,
    }
    params = {"actor": {"net": {"w": jnp.array([0.5])}}, "critic": {"c": jnp.array([2.0])}}
    loss_fn = functools.partial(
        losses.ppo_loss,
        policy=policy,
        value_net=value_net,
        clip_eps=0.2,
        vf_coef=0.5,
        ent_coef=0.01,
    )
    (loss, info), grads = jax.value_and_grad(loss_fn, has_aux=True)(params, batch)
    # log ratio = -(a - .5)^2/2 + a^2/2: -0.125 at a = 0, 0.375 at a = 1
    r0, r1 = math.exp(-0.125), math.exp(0.375)  # 0.8825 (inside the clip), 1.4550
    surrogate = (-r0 + 1.2) / 2  # min(r0 * -1, clip(r0) * -1), min(r1 * 1, 1.2 * 1)
    value_loss = 0.5 * ((2 - 1) ** 2 + (2 - 4) ** 2) / 2  # 1.25
    entropy = 0.5 * math.log(2 * math.pi * math.e)
    np.testing.assert_allclose(loss, -surrogate + 0.5 * value_loss - 0.01 * entropy, rtol=1e-6)
    np.testing.assert_allclose(info["value_loss"], value_loss, rtol=1e-6)
    kl = ((r0 - 1 + 0.125) + (r1 - 1 - 0.375)) / 2
    np.testing.assert_allclose(info["approx_kl"], kl, rtol=1e-5)
    np.testing.assert_allclose(info["clip_fraction"], 0.5)  # only |r1 - 1| > 0.2
    # d loss / dc = 0.5 * mean(c - target) = 0.5 * (1 - 2) / 2; d loss / dw comes from
    # the unclipped a = 0 term only: -(1/2) * d(r0 * -1)/dw = (1/2) r0 * (a - w) = -r0 / 4
    np.testing.assert_allclose(grads["critic"]["c"], [-0.25], rtol=1e-6)
    np.testing.assert_allclose(grads["actor"]["net"]["w"], [-r0 / 4], rtol=1e-5)


def test_minibatch_epochs_visit_every_sample_once_per_epoch():
    # loss = scale * p * sum(x_mb) with SGD at step 1: each minibatch moves p by
    # -scale * sum(x_mb), so after E epochs p = p0 - E * scale * sum(x) whatever the order
    def loss_fn(p, mb):
        return mb["scale"] * p * jnp.sum(mb["x"]), mb["x"]

    data = {"x": jnp.arange(6.0)}
    (p, _), seen = jax.jit(losses.minibatch_epochs, static_argnums=(0, 1, 6, 7))(
        loss_fn,
        optax.sgd(1.0),
        jnp.float32(1.0),
        optax.sgd(1.0).init(jnp.float32(1.0)),
        data,
        jax.random.key(0),
        2,
        3,
        {"scale": jnp.float32(2.0)},
    )
    np.testing.assert_allclose(p, 1.0 - 2 * 2.0 * 15.0)
    assert seen.shape == (2, 3, 2)  # [epochs, minibatches, minibatch size]
    for epoch in seen:
        np.testing.assert_array_equal(np.sort(np.ravel(epoch)), np.arange(6.0))
    assert not np.array_equal(seen[0], seen[1])  # each epoch its own permutation
