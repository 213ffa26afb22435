"""The paper's network, the MLPs, the policy head and the projection, by hand."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from wcac_jax import networks
from wcac_jax.core.networks import NetParams


def test_paper_network_forward_by_hand():
    net = networks.paper_network(in_dim=2, out_dim=1, width=2, depth=1)
    params = NetParams(
        trainable={"w": (jnp.array([[1.0, -1.0], [2.0, 0.0]]),)},
        fixed={"a": jnp.eye(2), "c": jnp.array([[1.0], [-1.0]])},
    )
    # x0 = [0.6, 0.8]; W x0 = [-0.2, 1.2]; ReLU / sqrt(2) = [0, 1.2 / sqrt 2]; y = -1.2 / sqrt 2
    y = net.apply(params, jnp.array([0.6, 0.8]))
    np.testing.assert_allclose(y, [-1.2 / math.sqrt(2)], rtol=1e-6)
    batch = net.apply(params, jnp.array([[0.6, 0.8], [0.0, 1.0]]))
    assert batch.shape == (2, 1)


def test_paper_network_initialisation_statistics():
    width, depth = 256, 2
    params = networks.paper_network(17, 3, width, depth).init(jax.random.key(0))
    assert set(params.trainable) == {"w"} and len(params.trainable["w"]) == depth
    assert params.fixed["a"].shape == (width, 17) and params.fixed["c"].shape == (width, 3)
    for w in params.trainable["w"]:
        assert w.shape == (width, width)
        assert float(jnp.var(w)) == pytest.approx(2.0, rel=0.02)
    assert float(jnp.var(params.fixed["a"])) == pytest.approx(2.0, rel=0.1)
    assert float(jnp.var(params.fixed["c"])) == pytest.approx(1.0, rel=0.2)


def test_every_w_gets_a_gradient_and_a_and_c_stay_fixed():
    net = networks.paper_network(3, 1, 8, 2)
    params = net.init(jax.random.key(1))
    x = jnp.array([0.6, 0.0, 0.8])
    grads = jax.grad(lambda tr: net.apply(NetParams(tr, params.fixed), x)[0])(params.trainable)
    for b, g in enumerate(grads["w"]):
        assert g.shape == params.trainable["w"][b].shape
        assert float(jnp.abs(g).max()) > 0, f"W_{b + 1} gets no gradient"
    # one training iteration (critic TD steps and the actor's step) of the paper network
    # on the bandit: every W of the actor and of both critics moves, A and c do not
    from wcac_jax import envs
    from wcac_jax.algos import PaperConfig, make_trainer

    config = PaperConfig(
        num_envs=4, critic_steps=2, rollout_steps=2, num_iterations=1, width=8, depth=2
    )
    trainer = make_trainer(config, envs.make("concave_bandit"))
    pref = jnp.array([0.5, 0.5])
    before = trainer.init(jax.random.key(0), pref)
    after, _ = jax.jit(trainer.step)(before, pref)
    for name, old, new in (
        ("actor", before.actor.trainable["net"]["w"], after.actor.trainable["net"]["w"]),
        ("critic", before.critic.params.trainable["w"], after.critic.params.trainable["w"]),
    ):
        for b, (w0, w1) in enumerate(zip(old, new, strict=True)):
            assert float(jnp.abs(w1 - w0).max()) > 0, f"{name} W_{b + 1} did not move"
    for old, new in (
        (before.actor.fixed["net"], after.actor.fixed["net"]),
        (before.critic.params.fixed, after.critic.params.fixed),
    ):
        assert set(old) == {"a", "c"}
        for k in ("a", "c"):
            np.testing.assert_array_equal(new[k], old[k])


def test_mlp_network_shapes_and_selection():
    net = networks.make_network("mlp", 5, 2, 16, 3)
    params = net.init(jax.random.key(0))
    assert params.fixed == {}
    assert net.apply(params, jnp.ones((4, 5))).shape == (4, 2)
    with pytest.raises(ValueError, match="'cnn'.*paper, mlp"):
        networks.make_network("cnn", 5, 2, 16, 3)
    with pytest.raises(ValueError, match="depth"):
        networks.make_network("paper", 5, 2, 16, 0)


def test_orthogonal_init_without_lapack():
    """`networks.orthogonal`: `W^T W = scale^2 I` (or `W W^T` for wide `W`), per key."""
    for shape in [(17, 64), (64, 64), (64, 6)]:
        w = networks.orthogonal(2.0)(jax.random.key(3), shape)
        assert w.shape == shape
        gram = w.T @ w if shape[0] >= shape[1] else w @ w.T
        np.testing.assert_allclose(gram, 4.0 * np.eye(min(shape)), atol=1e-5)
    a, b = (networks.orthogonal()(jax.random.key(k), (8, 8)) for k in (0, 1))
    assert not np.allclose(a, b)


def test_tanh_mlp_forward_by_hand_and_its_initial_gains():
    net = networks.tanh_mlp(in_dim=2, out_dim=1, width=2, depth=1, out_scale=0.01)
    params = net.init(jax.random.key(0))
    assert params.fixed == {}
    dense = {
        "Dense_0": {"kernel": jnp.eye(2), "bias": jnp.array([0.0, 1.0])},
        "Dense_1": {"kernel": jnp.array([[1.0], [2.0]]), "bias": jnp.array([0.5])},
    }
    assert jax.tree.map(jnp.shape, params.trainable) == {"params": jax.tree.map(jnp.shape, dense)}
    # x = [0.5, -1]: h = tanh([0.5, 0]) = [0.46212, 0]; y = 0.46212 + 2 * 0 + 0.5
    y = net.apply(NetParams(trainable={"params": dense}, fixed={}), jnp.array([[0.5, -1.0]]))
    np.testing.assert_allclose(y, [[math.tanh(0.5) + 0.5]], rtol=1e-6)
    # initial kernels: hidden rows orthogonal with gain sqrt(2) (a wide [3, 8] matrix),
    # the output column with gain out_scale; biases 0
    init = networks.tanh_mlp(3, 1, 8, 2, out_scale=0.01).init(jax.random.key(1)).trainable
    w0, w2 = init["params"]["Dense_0"]["kernel"], init["params"]["Dense_2"]["kernel"]
    np.testing.assert_allclose(w0 @ w0.T, 2.0 * np.eye(3), atol=1e-5)
    np.testing.assert_allclose(np.linalg.norm(w2), 0.01, rtol=1e-5)
    assert all(not np.any(layer["bias"]) for layer in init["params"].values())
    with pytest.raises(ValueError, match="tanh_mlp needs depth >= 1"):
        networks.tanh_mlp(3, 1, 8, 0, out_scale=1.0)


def test_projection_inside_untouched_outside_onto_sphere():
    center = {"w1": jnp.zeros((2, 2)), "w2": jnp.ones((3,))}
    params = {"w1": jnp.array([[3.0, 0.0], [0.0, 4.0]]), "w2": jnp.ones((3,)) + 0.1}
    out = networks.project_to_ball(params, center, radius=1.0)
    # layer 1 is at distance 5: scaled onto the sphere, direction kept
    np.testing.assert_allclose(out["w1"], [[0.6, 0.0], [0.0, 0.8]], rtol=1e-6)
    # layer 2 is at distance 0.1 * sqrt(3) < 1: untouched (projection is per layer)
    np.testing.assert_array_equal(out["w2"], params["w2"])
    unbounded = networks.project_to_ball(params, center, radius=math.inf)
    np.testing.assert_array_equal(unbounded["w1"], params["w1"])


def test_unit_sphere():
    x = networks.unit_sphere(jnp.array([[3.0, 4.0], [0.0, 0.0]]))
    np.testing.assert_allclose(x, [[0.6, 0.8], [0.0, 0.0]])


def test_gaussian_policy_log_prob_and_parameters():
    net = networks.paper_network(2, 2, 4, 1)
    learned = networks.gaussian_policy(net, 2, log_std_init=-0.5, learn_log_std=True)
    params = learned.init(jax.random.key(0))
    assert set(params.trainable) == {"net", "log_std"}
    fixed = networks.gaussian_policy(net, 2, log_std_init=-0.5, learn_log_std=False)
    assert set(fixed.init(jax.random.key(0)).trainable) == {"net"}
    mean, log_std = learned.apply(params, jnp.ones((3, 2)))
    assert mean.shape == (3, 2) and log_std.shape == (2,)
    # standard normal in 2-D at the mean: -log(2 pi)
    lp = networks.gaussian_log_prob(jnp.zeros(2), jnp.zeros(2), jnp.zeros(2))
    assert float(lp) == pytest.approx(-math.log(2 * math.pi), rel=1e-6)
    # one-D N(1, 0.5^2) at 2: -0.5 * 4 - log 0.5 - 0.5 log(2 pi)
    lp = networks.gaussian_log_prob(jnp.ones(1), jnp.log(jnp.full(1, 0.5)), jnp.full(1, 2.0))
    assert float(lp) == pytest.approx(-2.0 - math.log(0.5) - 0.5 * math.log(2 * math.pi), rel=1e-6)


def test_gaussian_policy_log_std_by_preference_by_hand():
    """With `pref_size = m` the log-std is `p @ L`: each vertex's own row of `L`, linear
    between them, the same for every preference at first."""
    net = networks.paper_network(4, 2, 4, 1)
    policy = networks.gaussian_policy(net, 2, log_std_init=-1.0, pref_size=2)
    params = policy.init(jax.random.key(0))
    assert params.trainable["log_std"].shape == (2, 2)
    obs = jnp.array([[0.3, -0.2, 1.0, 0.0], [0.3, -0.2, 0.25, 0.75]])
    _, log_std = policy.apply(params, obs)
    np.testing.assert_array_equal(log_std, jnp.full((2, 2), -1.0))
    rows = jnp.array([[-1.0, -2.0], [0.0, 1.0]])
    trained = NetParams({**params.trainable, "log_std": rows}, params.fixed)
    mean, log_std = policy.apply(trained, obs)
    # p = (1, 0): L's first row; p = (1/4, 3/4): (-1/4 + 0, -2/4 + 3/4)
    np.testing.assert_allclose(log_std, [[-1.0, -2.0], [-0.25, 0.25]], rtol=1e-6)
    # one entropy per input: sum_d log_std_d + log(2 pi e) (two dimensions)
    c = math.log(2 * math.pi * math.e)
    np.testing.assert_allclose(policy.entropy((mean, log_std)), [-3.0 + c, 0.0 + c], rtol=1e-6)
    lp = policy.log_prob((mean, log_std), mean)
    np.testing.assert_allclose(lp, [3.0 - math.log(2 * math.pi), -math.log(2 * math.pi)], rtol=1e-6)


def test_categorical_policy_by_hand():
    net = networks.paper_network(2, 3, 4, 1)
    policy = networks.categorical_policy(net)
    logits = jnp.log(jnp.array([[0.2, 0.3, 0.5], [0.6, 0.2, 0.2]]))
    np.testing.assert_allclose(
        policy.log_prob(logits, jnp.array([2, 0])), jnp.log(jnp.array([0.5, 0.6])), rtol=1e-6
    )
    np.testing.assert_array_equal(policy.mode(logits), [2, 0])
    expected = -(0.2 * math.log(0.2) + 0.3 * math.log(0.3) + 0.5 * math.log(0.5))
    assert float(policy.entropy(logits)[0]) == pytest.approx(expected, rel=1e-5)
    draws = policy.sample(jax.random.key(0), jnp.broadcast_to(logits[0], (20000, 3)))
    np.testing.assert_allclose(jnp.bincount(draws, length=3) / 20000, [0.2, 0.3, 0.5], atol=0.02)
    params = policy.init(jax.random.key(1))
    assert policy.apply(params, jnp.ones((5, 2))).shape == (5, 3)


def test_gaussian_policy_interface():
    policy = networks.gaussian_policy(networks.paper_network(2, 2, 4, 1), 2, -1.0)
    dist = policy.apply(policy.init(jax.random.key(0)), jnp.ones((3, 2)))
    np.testing.assert_array_equal(policy.mode(dist), dist[0])
    np.testing.assert_array_equal(policy.to_env(jnp.array([2.0, -3.0, 0.5])), [1.0, -1.0, 0.5])
    boxed = networks.gaussian_policy(networks.paper_network(2, 2, 4, 1), 2, -1.0, True, 0.4)
    np.testing.assert_allclose(boxed.to_env(jnp.array([2.0, -3.0, 0.5])), [0.4, -0.4, 0.2])
    # one half-width per action (PGMORL's hopper: 2, 2, 4): 2 * 1, 2 * -1, 4 * 0.5
    per_action = networks.gaussian_policy(
        networks.paper_network(2, 3, 4, 1), 3, -1.0, True, (2.0, 2.0, 4.0)
    )
    np.testing.assert_allclose(per_action.to_env(jnp.array([2.0, -3.0, 0.5])), [2.0, -2.0, 2.0])
    # entropy of N(mu, e^-2 I) in 2-D: 2 * (-1 + 0.5 log(2 pi e))
    assert float(policy.entropy(dist)[0]) == pytest.approx(
        2 * (-1 + 0.5 * math.log(2 * math.pi * math.e)), rel=1e-6
    )
