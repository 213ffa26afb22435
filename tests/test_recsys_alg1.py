"""The paper's Algorithm 1 offline: its pieces against hand-computed values and the
shared critic update, and learning on a problem with a known answer."""

import jax
import jax.numpy as jnp
import numpy as np
from test_recsys_offline import tiny_protocol

from wcac_jax import critic as critic_lib
from wcac_jax.core.networks import make_network
from wcac_jax.recsys import alg1, offline


def test_log_prob_hand_computed():
    """`-(a - mu)^2 / (2 sigma^2)`: mu = 1, a = 3, sigma = 2 -> -0.5."""
    assert float(alg1.log_prob(jnp.array(1.0), jnp.array(3.0), 2.0)) == -0.5


def test_episode_starts_hand_computed():
    data = tiny_protocol(n=6).replace(done=jnp.array([0.0, 1.0, 0.0, 0.0, 1.0, 1.0]), n_train=6)
    np.testing.assert_array_equal(alg1.episode_starts(data), [0, 2, 5])


def _critics():
    net = make_network("mlp", 3, 1, 8, 2)
    state = critic_lib.init(net.init, jax.random.key(0), 7)
    rng = np.random.default_rng(0)
    x, x_next = (jnp.asarray(rng.normal(size=(5, 3)), jnp.float32) for _ in range(2))
    r = jnp.asarray(rng.normal(size=(5, 7)), jnp.float32)
    done = jnp.array([0.0, 0.0, 1.0, 0.0, 1.0])
    return net, state, x, x_next, r, done


def test_critic_update_with_unit_weights_is_algorithm_2():
    """`weight = 1`: the same step, projection and average as without a weight."""
    net, state, x, x_next, r, done = _critics()
    kw = dict(gamma=0.9, radius=0.05, learning_rate=0.1)
    want, d_want = critic_lib.update(net.apply, state, x, r, x_next, done, **kw)
    got, d_got = critic_lib.update(net.apply, state, x, r, x_next, done, weight=jnp.ones(5), **kw)
    np.testing.assert_allclose(d_got, d_want, rtol=1e-6)
    for a, b in zip(jax.tree.leaves(got), jax.tree.leaves(want), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-7)


def test_critic_update_scales_each_transition_by_its_weight():
    """Without projection the step is linear in the weight: weights 2 on every row double
    it, weight 0 on a row removes that row's part (the same as dropping the row)."""
    net, state, x, x_next, r, done = _critics()
    kw = dict(gamma=0.9, learning_rate=0.1, radius=float("inf"))
    step = lambda rho, s=state, sl=slice(None): jax.tree.map(
        lambda n, o: n - o,
        critic_lib.update(net.apply, s, x[sl], r[sl], x_next[sl], done[sl], weight=rho, **kw)[
            0
        ].params.trainable,
        s.params.trainable,
    )
    one, two = step(jnp.ones(5)), step(2.0 * jnp.ones(5))
    jax.tree.map(lambda a, b: np.testing.assert_allclose(2 * a, b, rtol=1e-4, atol=1e-6), one, two)
    drop = step(jnp.array([1.0, 1.0, 1.0, 1.0, 0.0]))
    kept = step(jnp.ones(4), sl=slice(0, 4))  # mean over 4 rows, not 5
    jax.tree.map(
        lambda a, b: np.testing.assert_allclose(a, 0.8 * b, rtol=1e-4, atol=1e-6), drop, kept
    )


def test_algorithm_1_learns_to_recommend_the_clicked_video():
    """Known direction: the logged actions are uniform over 4 candidates (mean 1.5) and only
    candidate 3 is ever clicked; with all preference on clicks the Gaussian policy's mean
    moves from 1.5 towards 3, past 2. It settles near 2.3, short of 3, because the
    behaviour model here (`N(1.5, 1)`) is not the uniform logging policy: the ratios then
    do not make the baseline's term vanish (measured: 2.29)."""
    n = 400
    rng = np.random.default_rng(0)
    action = rng.integers(0, 4, n)
    reward = np.zeros((n, 7), np.float32)
    reward[:, 0] = action == 3
    reward[:, 1:] = 0.5  # the other signals ignore the action
    data = tiny_protocol(n=n, users=20, action=action, reward=reward).replace(n_train=n - 20)
    cfg = offline.OfflineConfig(
        steps=1200, batch_size=32, width=16, gamma=0.5, critic_warmup=0.2, bc_weight=0.0
    )
    acfg = alg1.Alg1Config(sigma=1.0, alpha=0.1, beta=0.05, critic_steps=2)
    obj = offline.objectives(data, cfg.gamma, cfg.ub_margin)
    train, act = alg1.make_train(cfg, acfg, data)
    behaviour = jnp.full((n,), 1.5)
    state, metrics = jax.jit(train)(jax.random.key(0), jnp.eye(7)[0], data, obj, behaviour)
    a = act(state.actor, offline.net_input(data, jnp.arange(n)))
    assert np.isfinite(np.asarray(metrics["train/critic_loss"])).all()
    assert float(jnp.mean(a)) > 2.0, float(jnp.mean(a))
