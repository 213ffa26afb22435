"""Algorithm 2: TD errors, projection, iterate averaging and the TD fixed point."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from wcac_jax import critic, networks


def test_td_error_sign_and_terminal_by_hand():
    # paper's sign: delta = V(s) - r - gamma (1 - terminal) V(s')
    assert float(critic.td_error(1.0, 0.5, 2.0, 0.0, 0.9)) == pytest.approx(1.0 - 0.5 - 1.8)
    assert float(critic.td_error(1.0, 0.5, 2.0, 1.0, 0.9)) == pytest.approx(0.5)


def _setup(width=16, depth=1, m=2, in_dim=3):
    net = networks.paper_network(in_dim, 1, width, depth)
    return net, critic.init(net.init, jax.random.key(0), m)


def test_init_stacks_m_copies_of_one_initial_point():
    _, state = _setup(m=3)
    w = state.params.trainable["w"][0]
    assert w.shape == (3, 16, 16)
    np.testing.assert_array_equal(w[0], w[2])


def test_iterate_average_is_arithmetic_mean_of_iterates():
    net, state = _setup()
    keys = jax.random.split(jax.random.key(1), 6)
    iterates = [state.params.trainable]
    for key in keys:
        k1, k2, k3 = jax.random.split(key, 3)
        obs = networks.unit_sphere(jax.random.normal(k1, (8, 3)))
        next_obs = networks.unit_sphere(jax.random.normal(k2, (8, 3)))
        reward = jax.random.uniform(k3, (8, 2))
        state, delta = critic.update(
            net.apply,
            state,
            obs,
            reward,
            next_obs,
            jnp.zeros(8),
            gamma=0.9,
            learning_rate=0.05,
            radius=jnp.inf,
        )
        assert delta.shape == (8, 2)
        iterates.append(state.params.trainable)
    expected = jax.tree.map(lambda *xs: jnp.mean(jnp.stack(xs), axis=0), *iterates)
    jax.tree.map(
        lambda a, b: np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6),
        state.average,
        expected,
    )
    assert int(state.step) == 6


def test_projection_keeps_each_critic_in_its_ball():
    net, state = _setup()
    obs = networks.unit_sphere(jnp.ones((4, 3)))
    state, _ = critic.update(
        net.apply,
        state,
        obs,
        jnp.full((4, 2), 100.0),
        obs,
        jnp.ones(4),
        gamma=0.9,
        learning_rate=1.0,
        radius=0.25,
    )
    dist = jnp.sqrt(jnp.sum((state.params.trainable["w"][0] - state.center["w"][0]) ** 2, (1, 2)))
    np.testing.assert_allclose(dist, [0.25, 0.25], rtol=1e-5)


def test_restart_cold_and_warm():
    net, state = _setup()
    obs = networks.unit_sphere(jnp.ones((4, 3)))
    state, _ = critic.update(
        net.apply,
        state,
        obs,
        jnp.ones((4, 2)),
        obs,
        jnp.zeros(4),
        gamma=0.9,
        learning_rate=0.1,
        radius=jnp.inf,
    )
    warm = critic.restart(state, warm_start=True)
    cold = critic.restart(state, warm_start=False)
    np.testing.assert_array_equal(warm.params.trainable["w"][0], state.params.trainable["w"][0])
    np.testing.assert_array_equal(warm.average["w"][0], state.params.trainable["w"][0])
    np.testing.assert_array_equal(cold.params.trainable["w"][0], state.center["w"][0])
    assert int(warm.step) == 0 and int(cold.step) == 0


def test_td_fixed_point_matches_exact_values_on_a_markov_chain():
    """Three states, two objectives, gamma = 0.8: V = (I - gamma P)^-1 r within 2%."""
    gamma = 0.8
    p = np.array([[0.1, 0.6, 0.3], [0.5, 0.2, 0.3], [0.3, 0.3, 0.4]])
    r = np.array([[1.0, 0.0], [0.0, 2.0], [0.5, 0.5]])  # reward of leaving state s
    exact = np.linalg.solve(np.eye(3) - gamma * p, r)  # [3, 2]
    net = networks.paper_network(3, 1, 64, 1)
    state = critic.init(net.init, jax.random.key(0), 2)
    n_chains, steps = 64, 400
    onehot = jnp.eye(3)
    cum_p = jnp.asarray(np.cumsum(p, axis=1))

    @jax.jit
    def outer(carry, key):
        state, s = carry
        state = critic.restart(state, warm_start=True)

        def step(carry, key):
            state, s = carry
            u = jax.random.uniform(key, (n_chains, 1))
            s_next = jnp.minimum(jnp.sum(u > cum_p[s], axis=1), 2)
            state, _ = critic.update(
                net.apply,
                state,
                onehot[s],
                jnp.asarray(r)[s],
                onehot[s_next],
                jnp.zeros(n_chains),
                gamma=gamma,
                learning_rate=0.02,
                radius=jnp.inf,
            )
            return (state, s_next), None

        (state, s), _ = jax.lax.scan(step, (state, s), jax.random.split(key, steps))
        return (state, s), None

    s0 = jnp.zeros(n_chains, jnp.int32)
    (state, _), _ = jax.lax.scan(outer, (state, s0), jax.random.split(jax.random.key(1), 10))
    values = critic.values(net.apply, critic.averaged_params(state), onehot)  # [3, 2]
    np.testing.assert_allclose(values, exact, rtol=0.02)
