"""Pins every formula of the scalarizations with hand-computed values."""

import math

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from wcac_jax import scalarize

VALUES = jnp.array([1.0, 2.0])
PREF = jnp.array([0.3, 0.7])
J_UB = jnp.array([3.0, 3.0])
# regrets p * (J_ub - J) = [0.6, 0.7]


def test_hand_computed_values():
    assert scalarize.linear(VALUES, PREF) == pytest.approx(-1.7)
    assert scalarize.wc(VALUES, PREF, J_UB) == pytest.approx(0.7)
    # 0.1 * log(e^6 + e^7) = 0.7 + 0.1 * log(1 + e^-1)
    assert scalarize.smooth_wc(VALUES, PREF, J_UB, 0.1) == pytest.approx(
        0.7 + 0.1 * math.log1p(math.exp(-1.0)), rel=1e-6
    )
    lam = scalarize.smooth_wc_weights(VALUES, PREF, J_UB, 0.1)
    e = 1.0 / (1.0 + math.exp(1.0))
    np.testing.assert_allclose(lam, [e, 1.0 - e], rtol=1e-6)
    np.testing.assert_array_equal(scalarize.wc_weights(VALUES, PREF, J_UB), [0.0, 1.0])
    np.testing.assert_array_equal(scalarize.linear_weights(VALUES, PREF), [1.0, 1.0])


@pytest.mark.parametrize("m", [2, 3, 5])
def test_smoothing_bounds_on_random_inputs(m):
    key_v, key_p, key_mu = jax.random.split(jax.random.key(m), 3)
    values = jax.random.normal(key_v, (200, m)) * 10
    pref = jax.random.dirichlet(key_p, jnp.ones(m), (200,))
    mu = jax.random.uniform(key_mu, (200,), minval=1e-3, maxval=5.0)
    j_ub = jnp.full((m,), 40.0)
    g = jax.vmap(scalarize.wc, (0, 0, None))(values, pref, j_ub)
    big_g = jax.vmap(scalarize.smooth_wc, (0, 0, None, 0))(values, pref, j_ub, mu)
    slack = 1e-5 * (1 + jnp.abs(g))
    assert jnp.all(g <= big_g + slack)
    assert jnp.all(big_g <= g + mu * math.log(m) + slack)
    lam = jax.vmap(scalarize.smooth_wc_weights, (0, 0, None, 0))(values, pref, j_ub, mu)
    np.testing.assert_allclose(jnp.sum(lam, axis=-1), 1.0, rtol=1e-6)
    assert jnp.all(lam >= 0)


def test_smooth_wc_tends_to_wc_as_mu_vanishes():
    g = scalarize.wc(VALUES, PREF, J_UB)
    gaps = [float(scalarize.smooth_wc(VALUES, PREF, J_UB, mu) - g) for mu in (1.0, 0.1, 0.01, 1e-4)]
    assert all(a > b for a, b in zip(gaps, gaps[1:], strict=False))
    assert gaps[-1] == pytest.approx(0.0, abs=1e-6)


def test_no_overflow_with_huge_arguments():
    values = jnp.array([0.0, -1e6])
    pref = jnp.array([0.5, 0.5])
    j_ub = jnp.array([1.0, 1.0])
    mu = 0.5  # arguments p_i (J_ub_i - J_i) / mu up to 1e6
    out = scalarize.smooth_wc(values, pref, j_ub, mu)
    assert jnp.isfinite(out)
    assert out == pytest.approx(0.5 * (1e6 + 1.0), rel=1e-6)
    lam = scalarize.smooth_wc_weights(values, pref, j_ub, mu)
    np.testing.assert_allclose(lam, [0.0, 1.0], atol=1e-6)
    grad = jax.grad(scalarize.smooth_wc)(values, pref, j_ub, mu)
    assert jnp.all(jnp.isfinite(grad))
    tiny_mu = scalarize.smooth_wc(jnp.array([1.0, 2.0]), PREF, J_UB, 1e-7)
    assert jnp.isfinite(tiny_mu)


def test_grad_of_g_mu_is_minus_weighted_objective_gradients():
    def objectives(theta):  # J: R^3 -> R^2
        return jnp.array([jnp.sin(theta[0]) + theta[1] ** 2, theta[0] * theta[2] - theta[1]])

    theta = jnp.array([0.3, -0.7, 1.2])
    pref, j_ub, mu = jnp.array([0.4, 0.6]), jnp.array([3.0, 2.0]), 0.3
    grad = jax.grad(lambda th: scalarize.smooth_wc(objectives(th), pref, j_ub, mu))(theta)
    lam = scalarize.smooth_wc_weights(objectives(theta), pref, j_ub, mu)
    jac = jax.jacobian(objectives)(theta)  # [m, k]
    expected = -jnp.sum((lam * pref)[:, None] * jac, axis=0)
    np.testing.assert_allclose(grad, expected, rtol=1e-5)


# every registered scalarization, so a new one is checked here without a line of its own
@pytest.mark.parametrize("name", list(scalarize.SCALARIZATIONS))
def test_weights_are_minus_gradient_over_pref(name):
    scal = scalarize.get(name)
    values = jnp.array([0.5, 1.5, -0.5])
    pref = jnp.array([0.2, 0.5, 0.3])
    j_ub = jnp.array([2.0, 2.0, 2.0])
    grad = jax.grad(scal.value)(values, pref, j_ub, 0.2)
    np.testing.assert_allclose(grad, -scal.weights(values, pref, j_ub, 0.2) * pref, rtol=1e-5)


def test_weights_by_autodiff_match_the_hand_written_ones():
    values, j_ub = jnp.array([0.5, 1.5, -0.5]), jnp.array([2.0, 2.0, 2.0])
    derived = scalarize.weights_by_autodiff(scalarize.smooth_wc)
    pref = jnp.array([0.2, 0.5, 0.3])
    np.testing.assert_allclose(
        derived(values, pref, j_ub, 0.2),
        scalarize.smooth_wc_weights(values, pref, j_ub, 0.2),
        rtol=1e-5,
    )
    # a zero preference gives a zero weight (its objective drops out of w * p), not NaN
    pref = jnp.array([1.0, 0.0, 0.0])
    corner = derived(values, pref, j_ub, 0.2)
    lam = scalarize.smooth_wc_weights(values, pref, j_ub, 0.2)  # softmax([7.5, 0, 0])
    np.testing.assert_allclose(corner, [lam[0], 0.0, 0.0], rtol=1e-6)
    assert 0.99 < float(lam[0]) < 1.0 and float(lam[1]) > 0.0


def test_augmented_coefficients_by_hand_and_as_a_gradient():
    # w * p + rho: [0.3 * 0.5, 0.7 * 0.5] + 0.1, and a zero preference keeps rho
    np.testing.assert_allclose(
        scalarize.augmented_coefficients(jnp.array([0.5, 0.5]), PREF, 0.1), [0.25, 0.45]
    )
    np.testing.assert_allclose(
        scalarize.augmented_coefficients(jnp.array([1.0, 0.0]), jnp.array([1.0, 0.0]), 0.01),
        [1.01, 0.01],
    )
    # rho * sum(J_ub - J) = 0.1 * (2 + 1)
    assert scalarize.augmentation(VALUES, J_UB, 0.1) == pytest.approx(0.3)
    # grad_J of the augmented smooth_wc is -(lambda * p + rho), also where p_i = 0
    pref, mu, rho = jnp.array([1.0, 0.0]), 0.2, 0.05

    def augmented(values):
        return scalarize.smooth_wc(values, pref, J_UB, mu) + scalarize.augmentation(
            values, J_UB, rho
        )

    lam = scalarize.smooth_wc_weights(VALUES, pref, J_UB, mu)
    np.testing.assert_allclose(
        jax.grad(augmented)(VALUES),
        -scalarize.augmented_coefficients(lam, pref, rho),
        rtol=1e-6,
    )


def test_jit_vmap_and_simplex_corners():
    prefs = jnp.array([[1.0, 0.0], [0.0, 1.0], [0.5, 0.5]])
    out = jax.jit(jax.vmap(scalarize.smooth_wc, (None, 0, None, None)))(VALUES, prefs, J_UB, 0.05)
    chex.assert_shape(out, (3,))
    assert jnp.all(jnp.isfinite(out))
    # p = [1, 0]: only the first objective's regret (2.0) matters, up to mu log 2.
    assert float(out[0]) == pytest.approx(2.0, abs=0.05 * math.log(2) + 1e-6)
    lam = scalarize.smooth_wc_weights(VALUES, prefs[1], J_UB, 0.05)
    np.testing.assert_allclose(lam, [0.0, 1.0], atol=1e-6)


def test_unknown_scalarization_names_valid_ones():
    with pytest.raises(ValueError, match="'nope'.*linear, smooth_wc, wc"):
        scalarize.get("nope")


def test_shape_mismatch_is_rejected():
    with pytest.raises(AssertionError):
        scalarize.wc(jnp.ones(2), jnp.ones(3), jnp.ones(2))
