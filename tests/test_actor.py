"""Algorithm 1: advantages, the one-pass direction, and a step that decreases G_mu."""

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

from wcac_jax import actor, scalarize
from wcac_jax.envs import concave_bandit
from wcac_jax.networks import NetParams, gaussian_log_prob

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


def test_mgda_direction_descends_every_objective():
    params = NetParams({"mean": jnp.array(0.1), "scale": jnp.array(0.3)}, {})

    def policy(params, obs, action):  # two parameters, so the gradients can conflict
        mean = params.trainable["mean"] + params.trainable["scale"] * obs[..., :1]
        return gaussian_log_prob(mean, jnp.log(jnp.array([SIGMA])), action)

    obs = jax.random.normal(jax.random.key(0), (512, 1))
    action = jax.random.normal(jax.random.key(1), (512, 1))
    adv = jnp.stack([action[:, 0], -action[:, 0] * obs[:, 0]], axis=1)
    pref = jnp.array([0.5, 0.5])
    d, lam = actor.mgda_direction(policy, params, obs, action, adv, pref)
    np.testing.assert_allclose(jnp.sum(lam), 1.0, rtol=1e-6)
    grads = actor.objective_gradients(policy, params, obs, action, adv)
    flat_d = jnp.stack([d["mean"], d["scale"]])
    flat_g = jnp.stack([grads["mean"], grads["scale"]], axis=1) * pref[:, None]  # [m, 2]
    # -d is the min-norm point v of the hull: v . (p_i g_i) >= ||v||^2 for every i
    assert jnp.all(flat_g @ (-flat_d) >= jnp.sum(flat_d**2) * (1 - 1e-3))
