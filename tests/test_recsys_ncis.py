"""NCIS and the ground-truth value, against hand-computed numbers."""

import math

import jax.numpy as jnp
import numpy as np
import pytest

from wcac_jax.recsys import ncis


def test_weights_and_estimate_hand_computed():
    target = jnp.array([0.0, 10.0, 100.0])
    behaviour = jnp.array([0.0, 0.0, 0.0])
    logged = jnp.array([0.0, 10.0, 100.0])
    # w = exp(((a - b)^2 - (a - t)^2) / (2 * 25^2)), capped at 10
    w = np.asarray(ncis.importance_weights(target, behaviour, logged))
    np.testing.assert_allclose(w, [1.0, math.exp(100 / 1250), 10.0], rtol=1e-6)
    reward = jnp.array([[1.0, 0.0], [0.0, 2.0], [1.0, 1.0]])
    w1 = math.exp(0.08)
    want = [(1.0 + 10.0) / (1 + w1 + 10), (2 * w1 + 10.0) / (1 + w1 + 10)]
    np.testing.assert_allclose(ncis.ncis(target, behaviour, logged, reward), want, rtol=1e-6)


def test_weights_are_clipped_below_the_cap_and_never_negative():
    rng = np.random.default_rng(0)
    t, b, a = (jnp.asarray(rng.uniform(0, 149, 500)) for _ in range(3))
    w = np.asarray(ncis.importance_weights(t, b, a))
    assert (w >= 0).all() and (w <= 10).all() and np.isfinite(w).all()


def test_behaviour_scored_against_itself_is_the_logged_mean():
    rng = np.random.default_rng(1)
    behaviour = jnp.asarray(rng.uniform(0, 149, 1000), jnp.float32)
    logged = jnp.asarray(rng.integers(0, 150, 1000), jnp.float32)
    reward = jnp.asarray(
        rng.random((1000, 7)) < [0.5, 0.02, 1e-3, 3e-3, 1e-3, 2e-4, 0.9], jnp.float32
    )
    reward = reward.at[:, 6].multiply(jnp.asarray(rng.exponential(1.3, 1000), jnp.float32))
    est = np.asarray(ncis.ncis(behaviour, behaviour, logged, reward))
    np.testing.assert_allclose(est, np.asarray(reward).mean(0), atol=1e-6)


def test_index_probabilities_hand_computed():
    # A ~ N(0, 1), rounded and clipped to {0, 1, 2}
    p = np.asarray(ncis.index_probabilities(jnp.array([0.0]), 3, sigma=1.0))[0]
    phi = lambda x: 0.5 * (1 + math.erf(x / math.sqrt(2)))
    np.testing.assert_allclose(p, [phi(0.5), phi(1.5) - phi(0.5), 1 - phi(1.5)], rtol=1e-5)
    many = np.asarray(ncis.index_probabilities(jnp.linspace(-20.0, 170.0, 11), 150))
    np.testing.assert_allclose(many.sum(1), 1.0, rtol=1e-5)


def test_true_value_hand_computed():
    phi = lambda x: 0.5 * (1 + math.erf(x / math.sqrt(2)))
    p0, p1, p2 = phi(0.5), phi(1.5) - phi(0.5), 1 - phi(1.5)
    expected = jnp.array(
        [
            [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]],  # row 0's user
            [[0.0, 0.0], [0.0, 0.0], [1.0, 2.0]],  # row 1's user
        ]
    )
    action = jnp.array([0.0, 2.0])  # row 1: N(2, 1): P(2) = phi(0.5)
    got = np.asarray(ncis.true_value(action, expected, sigma=1.0))
    row0 = [p0, p1]
    row1 = [phi(0.5), 2 * phi(0.5)]
    np.testing.assert_allclose(got, np.mean([row0, row1], axis=0), rtol=1e-5)
    del p2


def test_effective_sample_size_hand_computed():
    ess = lambda w: float(ncis.effective_sample_size(jnp.asarray(w, jnp.float32)))
    assert ess([1.0, 1.0, 1.0, 1.0]) == pytest.approx(4.0)
    assert ess([2.0, 0.0, 0.0]) == pytest.approx(1.0)
    assert ess([1.0, 2.0]) == pytest.approx(9.0 / 5.0)


def test_oracle_actions_hand_computed():
    """C = 5, sigma = 1, one signal with values (0, 1, 0, 0.8, 0.8): the best single video
    is 1, but smoothed by the Gaussian the best mean is 4 (true value 0.006 + 0.8 (0.2417 +
    0.6915) = 0.7526, against 0.4363 at 1 and 0.6137 at 3). With sigma = 0.01 the best mean
    is the best video."""
    v = jnp.array([0.0, 1.0, 0.0, 0.8, 0.8])[None, :, None]
    assert float(ncis.oracle_actions(v, jnp.ones(1), sigma=1.0)[0]) == 4.0
    assert float(ncis.oracle_actions(v, jnp.ones(1), sigma=0.01)[0]) == 1.0
    got = ncis.true_value(jnp.array([4.0, 1.0, 3.0]), jnp.repeat(v, 3, 0), sigma=1.0)
    np.testing.assert_allclose(got, [(0.7526 + 0.4363 + 0.6137) / 3], atol=2e-4)
    # two signals, coefficients (1, -2): row 0 prefers video 0 (1 - 0), video 1 (0.5 - 2)
    e = jnp.array([[[1.0, 0.0], [0.5, 1.0]], [[0.0, 1.0], [1.0, 0.0]]])
    np.testing.assert_array_equal(ncis.oracle_actions(e, jnp.array([1.0, -2.0]), 0.01), [0, 1])


def test_behavior_clone_against_an_independent_behaviour_model_hand_computed():
    """Behavior-Clone's NCIS when the behaviour model is another policy: sigma = 1, BC
    acts (0, 0, 2), the behaviour model (0, 1, 2), logged actions (0, 1, 1), rewards
    (1, 0, 1). Weights: row 0 is 1 (same actions); row 1 exp(((1-1)^2 - (1-0)^2) / 2) =
    exp(-1/2); row 2 exp(((1-2)^2 - (1-2)^2) / 2) = 1. NCIS = (1 + 1) / (2 + exp(-1/2)),
    not the logged mean 2/3."""
    bc = jnp.array([0.0, 0.0, 2.0])
    beh = jnp.array([0.0, 1.0, 2.0])
    logged = jnp.array([0.0, 1.0, 1.0])
    r = jnp.array([[1.0], [0.0], [1.0]])
    w = ncis.importance_weights(bc, beh, logged, sigma=1.0)
    np.testing.assert_allclose(w, [1.0, np.exp(-0.5), 1.0], rtol=1e-6)
    got = ncis.ncis(bc, beh, logged, r, sigma=1.0)
    np.testing.assert_allclose(got, [2.0 / (2.0 + np.exp(-0.5))], rtol=1e-6)
    assert float(ncis.effective_sample_size(w)) < 3.0
