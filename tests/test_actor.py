"""Algorithm 1: advantages, the one-pass direction, and a step that decreases G_mu."""

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

from wcac_jax import actor, scalarize
from wcac_jax.core.networks import NetParams, gaussian_log_prob
from wcac_jax.envs import concave_bandit

SIGMA = 0.2


def test_td_advantages_by_hand():
    v = jnp.array([[1.0, 2.0], [0.5, 0.0]])
    reward = jnp.array([[0.5, 1.0], [1.0, 1.0]])
    v_next = jnp.array([[2.0, 3.0], [4.0, 4.0]])
    terminal = jnp.array([0.0, 1.0])
    adv = actor.td_advantages(v, reward, v_next, terminal, 0.9)
    # row 0: r + 0.9 V' - V; row 1 is terminal: r - V
    np.testing.assert_allclose(adv, [[0.5 + 1.8 - 1.0, 1.0 + 2.7 - 2.0], [0.5, 1.0]], rtol=1e-6)


def test_objective_estimates_mean_over_start_states():
    np.testing.assert_allclose(
        actor.objective_estimates(jnp.array([[1.0, 2.0], [3.0, 6.0]])), [2, 4]
    )


def _mean_policy(params, obs, action):
    """log pi(a|s) of a Gaussian whose mean is one trainable scalar (whatever the obs)."""
    mean = jnp.broadcast_to(params.trainable["mean"], (*obs.shape[:-1], 1))
    return gaussian_log_prob(mean, params.fixed["log_std"], action)


def _exact_j(mean):
    """Exact J(mean) = E[r(clip(a))], a ~ N(mean, SIGMA^2), by Gauss-Hermite quadrature."""
    nodes, weights = np.polynomial.hermite_e.hermegauss(80)
    a = mean + SIGMA * jnp.asarray(nodes)
    r = concave_bandit.reward(concave_bandit.action_to_theta(a))  # [q, 2]
    return jnp.asarray(weights / weights.sum()) @ r


def _sample_batch(mean, key, m_samples=8192):
    action = mean + SIGMA * jax.random.normal(key, (m_samples, 1))
    reward = concave_bandit.reward(concave_bandit.action_to_theta(action[:, 0]))
    return jnp.ones((m_samples, 1)), action, reward


def test_direction_is_one_pass_sum_of_per_objective_gradients():
    params = NetParams({"mean": jnp.array(0.1)}, {"log_std": jnp.log(jnp.array([SIGMA]))})
    obs, action, reward = _sample_batch(0.1, jax.random.key(0), 256)
    adv = reward - _exact_j(0.1)
    w, pref = jnp.array([0.3, 0.7]), jnp.array([0.6, 0.4])
    d = actor.direction(_mean_policy, params, obs, action, adv, w, pref)
    grads = actor.objective_gradients(_mean_policy, params, obs, action, adv)
    assert grads["mean"].shape == (2,)
    np.testing.assert_allclose(d["mean"], -jnp.sum(w * pref * grads["mean"]), rtol=1e-5)


@pytest.mark.parametrize(
    "pref,mean0", [([0.5, 0.5], -0.5), ([0.5, 0.5], 0.5), ([0.8, 0.2], 0.2), ([0.2, 0.8], -0.3)]
)
def test_one_normalised_step_decreases_g_mu(pref, mean0):
    pref, j_ub, mu = jnp.array(pref), jnp.array(concave_bandit.DEFAULT_J_UB), 0.05
    params = NetParams({"mean": jnp.array(mean0)}, {"log_std": jnp.log(jnp.array([SIGMA]))})
    obs, action, reward = _sample_batch(mean0, jax.random.key(1))
    j = _exact_j(mean0)
    adv = reward - j  # exact one-step advantages
    lam = scalarize.smooth_wc_weights(j, pref, j_ub, mu)
    d = actor.direction(_mean_policy, params, obs, action, adv, lam, pref)

    g = lambda mean: scalarize.smooth_wc(_exact_j(mean), pref, j_ub, mu)
    exact_grad = jax.grad(g)(jnp.array(mean0))
    assert float(jnp.sign(d["mean"])) == float(jnp.sign(exact_grad))
    assert float(d["mean"]) == pytest.approx(float(exact_grad), rel=0.15)

    opt = actor.make_optimizer("normalized", 0.05)
    updates, _ = opt.update(d, opt.init(params.trainable), params.trainable)
    new_mean = optax.apply_updates(params.trainable, updates)["mean"]
    assert float(jnp.abs(new_mean - mean0)) == pytest.approx(0.05, rel=1e-4)  # ||step|| = alpha
    assert float(g(new_mean)) < float(g(jnp.array(mean0)))


def test_optimizers():
    params = {"a": jnp.array([3.0, 4.0])}
    d = {"a": jnp.array([3.0, 4.0])}  # ||d|| = 5
    for kind, expected in [("normalized", [2.94, 3.92]), ("sgd", [2.7, 3.6])]:
        opt = actor.make_optimizer(kind, 0.1)
        upd, _ = opt.update(d, opt.init(params), params)
        np.testing.assert_allclose(optax.apply_updates(params, upd)["a"], expected, rtol=1e-5)
    opt = actor.make_optimizer("normalized_harmonic", 0.1)
    state = opt.init(params)
    steps = []
    for _ in range(3):
        upd, state = opt.update(d, state, params)
        steps.append(float(optax.tree.norm(upd)))
    np.testing.assert_allclose(steps, [0.1, 0.05, 0.1 / 3], rtol=1e-4)  # alpha / (t + 1)
    with pytest.raises(ValueError, match="'lbfgs'"):
        actor.make_optimizer("lbfgs", 0.1)


@pytest.mark.parametrize(
    "vectors,expected",
    [
        ([[1.0, 0.0], [0.0, 1.0]], [0.5, 0.5]),
        ([[1.0, 0.0], [1.0, 1.0]], [1.0, 0.0]),  # the segment's closest point is g1
        ([[2.0, 0.0], [0.0, 1.0]], [0.2, 0.8]),  # min ||(2(1-g), g)||^2 at g = 0.8
        ([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]], [1 / 3, 1 / 3, 1 / 3]),
    ],
)
def test_min_norm_weights_by_hand(vectors, expected):
    g = jnp.array(vectors)
    lam = actor.min_norm_weights(g @ g.T)
    np.testing.assert_allclose(lam, expected, atol=1e-4)


def _linear_log_prob(params, obs, action):
    """`log pi = obs . w`: the gradient of `mean_M(A_i log pi)` is `mean_M(A_i obs)`."""
    del action
    return obs @ params.trainable["w"]


# two samples whose hand-computed per-objective gradients are
# gradJ_1 = mean([2 * (1, 0), 0 * (0, 1)]) = (1, 0), gradJ_2 = mean([1 * (1, 0), 3 * (0, 1)])
# = (0.5, 1.5)
_OBS = jnp.array([[1.0, 0.0], [0.0, 1.0]])
_ADV = jnp.array([[2.0, 1.0], [0.0, 3.0]])


@pytest.mark.parametrize(
    "pref,expected_d,expected_lam",
    [
        # corners: the objective with p_i = 0 is dropped, d = -gradJ_i
        ([1.0, 0.0], [-1.0, 0.0], [1.0, 0.0]),
        ([0.0, 1.0], [-0.5, -1.5], [0.0, 1.0]),
        # hull of gradJ_i / p_i = (2, 0), (1, 3): min over t of (2 - t)^2 + (3t)^2, t = 0.2
        ([0.5, 0.5], [-1.8, -0.6], [0.8, 0.2]),
        # hull of (1.25, 0), (2.5, 7.5): the closest point is the first vertex
        ([0.8, 0.2], [-1.25, 0.0], [1.0, 0.0]),
    ],
)
def test_mgda_direction_by_hand(pref, expected_d, expected_lam):
    params = NetParams({"w": jnp.zeros(2)}, {})
    d, lam = actor.mgda_direction(
        _linear_log_prob, params, _OBS, jnp.zeros((2, 1)), _ADV, jnp.array(pref)
    )
    np.testing.assert_allclose(d["w"], expected_d, atol=1e-5)
    np.testing.assert_allclose(lam, expected_lam, atol=1e-5)


def test_mgda_moves_at_a_corner_even_when_the_objectives_conflict():
    """Opposite gradients: 0 is in the hull, so MGDA stops inside the simplex, but at the
    corner p = [1, 0] the second objective is dropped and the first one is followed."""
    params = NetParams({"w": jnp.zeros(2)}, {})
    adv = jnp.array([[2.0, -2.0], [0.0, 0.0]])  # gradJ_1 = (1, 0) = -gradJ_2
    d, _ = actor.mgda_direction(
        _linear_log_prob, params, _OBS, jnp.zeros((2, 1)), adv, jnp.array([0.5, 0.5])
    )
    np.testing.assert_allclose(d["w"], [0.0, 0.0], atol=1e-6)
    d, _ = actor.mgda_direction(
        _linear_log_prob, params, _OBS, jnp.zeros((2, 1)), adv, jnp.array([1.0, 0.0])
    )
    np.testing.assert_allclose(d["w"], [-1.0, 0.0], atol=1e-6)


@pytest.mark.parametrize("pref", [[0.2, 0.3, 0.5], [0.6, 0.0, 0.4], [0.0, 0.0, 1.0]])
def test_mgda_matches_the_min_norm_point_of_the_exact_gradients(pref):
    """Three objectives, five parameters: the exact gradients `mean_M(A_i obs)` and their
    min-norm point over the hull of `gradJ_i / p_i` (`p_i > 0`) solved by SLSQP."""
    from scipy.optimize import minimize

    obs = jax.random.normal(jax.random.key(0), (64, 5))
    adv = jax.random.normal(jax.random.key(1), (64, 3)) + jnp.array([0.5, -0.2, 0.1])
    pref = np.asarray(pref)
    exact = np.asarray(adv).T @ np.asarray(obs) / 64  # [m, 5]
    keep = pref > 0
    vertices = exact[keep] / pref[keep, None]
    res = minimize(
        lambda lam: np.sum((lam @ vertices) ** 2),
        np.full(keep.sum(), 1.0 / keep.sum()),
        bounds=[(0, 1)] * keep.sum(),
        constraints={"type": "eq", "fun": lambda lam: np.sum(lam) - 1},
        method="SLSQP",
        options={"ftol": 1e-14},
    )
    expected_lam = np.zeros(3)
    expected_lam[keep] = res.x
    params = NetParams({"w": jnp.zeros(5)}, {})
    d, lam = actor.mgda_direction(
        _linear_log_prob, params, obs, jnp.zeros((64, 1)), adv, jnp.asarray(pref, jnp.float32)
    )
    np.testing.assert_allclose(lam, expected_lam, atol=2e-3)
    np.testing.assert_allclose(d["w"], -(res.x @ vertices), atol=2e-3)
