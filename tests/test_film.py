"""FiLM conditioning (`networks.film_tanh_mlp`, `ConditionedConfig(conditioning="film")`):
the forward pass by hand, its start as the plain MLP, and the conditioned update with it."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from wcac_jax import algos, envs, networks
from wcac_jax.algos import ConditionedConfig


def _by_hand(params, x, cond_dim):
    """tanh(h (1 + gamma) + beta) per hidden layer, gamma/beta from the last entries."""
    p = params.trainable["params"]
    c = x[..., -cond_dim:]
    h = x
    for dense, film in (("Dense_0", "Dense_1"), ("Dense_2", "Dense_3")):
        pre = h @ p[dense]["kernel"] + p[dense]["bias"]
        mod = c @ p[film]["kernel"] + p[film]["bias"]
        gamma, beta = np.split(np.asarray(mod), 2, axis=-1)
        h = np.tanh(np.asarray(pre) * (1.0 + gamma) + beta)
    return h @ p["Dense_4"]["kernel"] + p["Dense_4"]["bias"]


def test_film_forward_by_hand():
    net = networks.film_tanh_mlp(5, 3, 8, 2, 1.0, cond_dim=2)
    params = net.init(jax.random.key(0))
    x = np.asarray(jax.random.normal(jax.random.key(1), (4, 5)))
    # at initialisation the modulation is zero: the plain tanh MLP of the same layers
    for film in ("Dense_1", "Dense_3"):
        assert not np.any(params.trainable["params"][film]["kernel"])
    np.testing.assert_allclose(net.apply(params, x), _by_hand(params, x, 2), rtol=1e-5, atol=1e-6)
    # a non-zero modulation enters as the formula says
    bumped = jax.tree.map(lambda a: a + 0.3, params)
    out = net.apply(bumped, x)
    np.testing.assert_allclose(out, _by_hand(bumped, x, 2), rtol=1e-5, atol=1e-6)
    assert not np.allclose(out, net.apply(params, x))
    with pytest.raises(ValueError, match="cond_dim"):
        networks.film_tanh_mlp(5, 3, 8, 2, 1.0, cond_dim=6)


def test_conditioned_update_trains_with_film():
    env = envs.make("concave_bandit")
    config = ConditionedConfig(
        num_envs=8,
        rollout_steps=4,
        num_minibatches=2,
        num_iterations=3,
        width=8,
        depth=1,
        conditioning="film",
    )
    train = algos.make_train(config, env)
    state, metrics = jax.jit(jax.vmap(train))(
        jax.random.split(jax.random.key(0), 1), jnp.array([[0.5, 0.5]])
    )
    assert np.all(np.isfinite(metrics["train/value_loss"]))
    film = state.actor.trainable["net"]["params"]["Dense_1"]["kernel"]
    assert np.any(np.asarray(film) != 0.0)  # the modulation learned
    with pytest.raises(ValueError, match="conditioning"):
        ConditionedConfig(conditioning="hyper")
