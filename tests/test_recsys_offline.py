"""The offline actor-critics: formulas against hand-computed values, each method's
update on a tiny batch against its rule, and learning on a problem with a known answer."""

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from wcac_jax import critic as critic_lib
from wcac_jax import scalarize
from wcac_jax.core.actor import min_norm_weights
from wcac_jax.core.networks import NetParams
from wcac_jax.recsys import offline
from wcac_jax.recsys.data import Protocol

TINY = offline.OfflineConfig(steps=10, batch_size=8, width=8, critic_warmup=0.0)


def tiny_protocol(n=24, users=3, c=4, h=2, seed=0, reward=None, action=None):
    """A hand-made protocol: `n` rows of `users` users in runs, `c` candidates."""
    rng = np.random.default_rng(seed)
    user_index = np.sort(rng.integers(0, users, n))
    action = rng.integers(0, c, n) if action is None else action
    if reward is None:
        reward = (rng.random((n, 7)) < 0.5).astype(np.float32)
        reward[:, 6] = rng.exponential(1.0, n)
    hist = -np.ones((n, h), np.int32)
    for i in range(1, n):
        if user_index[i - 1] == user_index[i]:
            hist[i] = np.r_[action[i - 1], hist[i - 1][:-1]]
    feats = np.linspace(-1, 1, c * 6).reshape(c, 6)
    f32 = lambda x: jnp.asarray(x, jnp.float32)
    return Protocol(
        user_index=jnp.asarray(user_index, jnp.int32),
        action=jnp.asarray(action, jnp.int32),
        reward=f32(reward),
        done=f32(np.r_[user_index[1:] != user_index[:-1], True]),
        history=jnp.asarray(hist),
        user_table=f32(rng.normal(size=(users, 24))),
        video_raw=f32(feats),
        cand_state=f32(np.zeros(6 * c)),
        hist_mean=f32(np.zeros((h, 6))),
        hist_std=f32(np.ones((h, 6))),
        action_features=f32(feats),
        n_train=n - 4,
        user_ids=np.arange(users),
        video_ids=np.arange(c),
    )


def test_action_input_interpolates_hand_computed():
    feats = jnp.arange(18.0).reshape(3, 6)  # C = 3
    got = np.asarray(offline.action_input(feats, jnp.array([0.5, 2.0, 0.0])))
    np.testing.assert_allclose(got[0], [3, 4, 5, 6, 7, 8, -0.5])  # halfway between rows 0, 1
    np.testing.assert_allclose(got[1], [12, 13, 14, 15, 16, 17, 1.0])  # the last candidate
    np.testing.assert_allclose(got[2], [0, 1, 2, 3, 4, 5, -1.0])


def test_critic_loss_hand_computed():
    """Linear critics `Q_i(x) = i x`: with r = 1, gamma = 0.5, x = 1, x' = 2,
    delta_i = i - 1 - 0.5 * 2 i = -1 (not done) and i - 1 (done)."""
    net = offline.linear_network(1, 1)
    w = jnp.arange(7.0).reshape(7, 1, 1)
    params = NetParams({"w": w, "b": jnp.zeros((7, 1))}, {})
    x, x_next, r = jnp.ones((1, 1)), 2 * jnp.ones((1, 1)), jnp.ones((1, 7))
    loss, delta = offline.critic_loss(
        net.apply, params.trainable, params.fixed, params, x, r, x_next, jnp.zeros(1), 0.5
    )
    np.testing.assert_allclose(delta, -np.ones((1, 7)))
    np.testing.assert_allclose(loss, 3.5)
    loss, delta = offline.critic_loss(
        net.apply, params.trainable, params.fixed, params, x, r, x_next, jnp.ones(1), 0.5
    )
    np.testing.assert_allclose(delta[0], np.arange(7.0) - 1)
    np.testing.assert_allclose(loss, 0.5 * np.sum((np.arange(7.0) - 1) ** 2))


def test_combination_weights_hand_computed():
    j = jnp.zeros(7)
    p = jnp.full(7, 1 / 7)
    j_ub = jnp.arange(1.0, 8.0)
    prev = jnp.full(7, 1 / 7)
    gram = jnp.diag(jnp.array([1.0, 4.0, 1.0, 1.0, 1.0, 1.0, 2.0]))
    w = lambda method, **kw: np.asarray(
        offline.combine_weights(offline.SPECS[method], j, p, j_ub, 0.1, gram, prev, 0.9)
    )
    soft = np.exp(np.arange(1.0, 8.0) / 7 / 0.1)
    np.testing.assert_allclose(w("wcac"), soft / soft.sum(), rtol=1e-5)
    np.testing.assert_allclose(w("mocha"), np.eye(7)[6])
    # orthogonal gradients: the min-norm point weighs each by 1 / ||g_i||^2, with squared
    # norm 1 / sum(1 / ||g_i||^2); `actor.min_norm_weights` runs 100 Frank-Wolfe steps,
    # which reach the weights to ~3e-3 and the squared norm to ~1e-4 (relative)
    inv = 1 / np.array([1.0, 4.0, 1.0, 1.0, 1.0, 1.0, 2.0])
    np.testing.assert_allclose(w("pdpg"), inv / inv.sum(), atol=5e-3)
    np.testing.assert_allclose(w("pdpg") @ gram @ w("pdpg"), 1 / inv.sum(), rtol=1e-3)
    np.testing.assert_allclose(w("moac"), 0.9 / 7 + 0.1 * w("pdpg"), atol=1e-6)


def test_objectives_hand_computed():
    """Rows: user 0 (2 rows), user 1 (1 row) + 1 test row; gamma = 0.5."""
    reward = np.zeros((4, 7), np.float32)
    reward[:, 0] = [1.0, 0.0, 1.0, 0.0]  # click: training mean 2/3
    reward[:, 5] = [0.0, 1.0, 0.0, 0.0]  # hate: training mean 1/3, negated
    reward[:, 1:5] = 1.0
    reward[:, 6] = 1.0
    data = tiny_protocol(n=4, users=2, reward=reward).replace(
        user_index=jnp.array([0, 0, 1, 1]), done=jnp.array([0.0, 1.0, 0.0, 1.0])
    )
    data = data.replace(n_train=3)
    obj = offline.objectives(data, gamma=0.5, ub_margin=0.2)
    scale = np.asarray(obj.scale)
    np.testing.assert_allclose(scale[[0, 5, 1]], [0.5 / (2 / 3), -0.5 / (1 / 3), 0.5], rtol=1e-6)
    # click returns-to-go: row0 = s + 0.5 * 0 = s, row1 = 0, row2 = s  (s = 0.75)
    s = 0.75
    j_click = (s + 0 + s) / 3
    # hate: row0 = 0 + 0.5 * (-1.5), row1 = -1.5, row2 = 0
    j_hate = (-0.75 - 1.5 + 0) / 3
    np.testing.assert_allclose(obj.j_ub[0], j_click * 1.2, rtol=1e-6)
    np.testing.assert_allclose(obj.j_ub[5], j_hate * 0.8, rtol=1e-6)


def test_objectives_keep_raw_rewards_under_tscac():
    """The same rows under `protocol="tscac"`: scale 1 (hate -1), returns of raw rewards."""
    reward = np.zeros((4, 7), np.float32)
    reward[:, 0] = [1.0, 0.0, 1.0, 0.0]
    reward[:, 5] = [0.0, 1.0, 0.0, 0.0]
    data = tiny_protocol(n=4, users=2, reward=reward).replace(
        user_index=jnp.array([0, 0, 1, 1]), done=jnp.array([0.0, 1.0, 0.0, 1.0])
    )
    data = data.replace(n_train=3, protocol="tscac")
    obj = offline.objectives(data, gamma=0.5, ub_margin=0.2)
    np.testing.assert_allclose(obj.scale, [1, 1, 1, 1, 1, -1, 1])
    # click returns-to-go: 1, 0, 1; hate: -0.5, -1, 0
    np.testing.assert_allclose(obj.j_ub[0], 2 / 3 * 1.2, rtol=1e-6)
    np.testing.assert_allclose(obj.j_ub[5], -0.5 * 0.8, rtol=1e-6)


def _adam_first_step(grad, lr):
    """Adam's first update is `-lr * g / (|g| + eps)` elementwise."""
    return jax.tree.map(lambda g: -lr * g / (jnp.abs(g) + 1e-8), grad)


def _reference_step(method, cfg, act, critic_apply, state, new, batch, pref, obj):
    """The update recomputed from the rule's definitions: (critic step, w, actor step)."""
    feats = batch["action_features"]
    x_sa = jnp.concatenate([batch["x"], offline.action_input(feats, batch["action"])], -1)
    a_next = act(state.actor_target, batch["x_next"])
    x_next = jnp.concatenate([batch["x_next"], offline.action_input(feats, a_next)], -1)

    def td_loss(t):
        return offline.critic_loss(
            critic_apply, t, state.critic.fixed, state.critic_target, x_sa,
            batch["reward"], x_next, batch["done"], TINY.gamma,
        )[0]  # fmt: skip

    critic_step = _adam_first_step(jax.grad(td_loss)(state.critic.trainable), cfg.critic_lr)

    def j_of(trainable):  # J_i = mean_B Q_i(s, mu(s)) under the updated critics
        a = act(NetParams(trainable, state.actor.fixed), batch["x"])
        x = jnp.concatenate([batch["x"], offline.action_input(feats, a)], -1)
        return jnp.mean(critic_lib.values(critic_apply, new.critic, x), axis=0)

    theta = state.actor.trainable
    j_hat = j_of(theta)
    grads = jax.jacrev(j_of)(theta)  # leaves [m, ...]
    scaled = [(g * pref.reshape((-1,) + (1,) * (g.ndim - 1))) for g in jax.tree.leaves(grads)]
    flat = jnp.concatenate([g.reshape(7, -1) for g in scaled], axis=1)
    if method == "wcac":
        w = scalarize.smooth_wc_weights(j_hat, pref, obj.j_ub, TINY.mu)
    elif method == "mocha":
        w = scalarize.wc_weights(j_hat, pref, obj.j_ub)
    else:
        w = min_norm_weights(flat @ flat.T)
        if method == "moac":
            w = TINY.momentum * state.weights + (1 - TINY.momentum) * w
    d = jax.tree.map(lambda g: -jnp.tensordot(w * pref, g, axes=1), grads)
    if cfg.bc_weight:

        def bc_loss(t):
            a = act(NetParams(t, state.actor.fixed), batch["x"])
            return jnp.mean(jnp.square((a - batch["action"]) / 3.0))

        d = jax.tree.map(lambda a, b: a + cfg.bc_weight * b, d, jax.grad(bc_loss)(theta))
    # each network class's actor at its own step size (the defaults differ tenfold)
    dnn, linear = cfg.actor_lr, cfg.linear_actor_lr
    lr = {"wcac": dnn, "pdpg": dnn, "moac": linear, "mocha": linear}[method]
    assert cfg.actor_lr != cfg.linear_actor_lr
    return critic_step, w, _adam_first_step(d, lr), flat


@pytest.mark.parametrize("bc_weight", [1.0, 0.0])
@pytest.mark.parametrize("method", offline.METHODS)
def test_one_update_follows_the_methods_rule(method, bc_weight):
    """One step on a tiny batch: the critics take Adam's first step on the TD loss, and
    the actor Adam's first step on `d = -sum_i w_i p_i grad J_i` (+ the behaviour-cloning
    term, the same for every method, or none) with the method's weights `w`, recomputed
    here from their definitions (the per-signal gradients by reverse mode through critic
    and actor, where the update goes forward through the critic)."""
    data = tiny_protocol()
    spec = offline.SPECS[method]
    cfg = dataclasses.replace(TINY, bc_weight=bc_weight)
    obj = offline.objectives(data, TINY.gamma, TINY.ub_margin)
    init, update, act = offline.make_update(spec, cfg, offline.input_dim(data), 4)
    state = init(jax.random.key(0))
    batch = offline.sample_batch(jax.random.key(1), data, 8, obj)
    pref = jnp.array([0.3, 0.1, 0.1, 0.1, 0.1, 0.1, 0.2])
    new, metrics = jax.jit(update)(state, batch, pref, obj)
    _, critic_net = offline.make_networks(spec, TINY, offline.input_dim(data))
    reference = jax.jit(functools.partial(_reference_step, method, cfg, act, critic_net.apply))
    critic_step, w, actor_step, flat = reference(state, new, batch, pref, obj)

    got = jax.tree.map(lambda a, b: a - b, new.critic.trainable, state.critic.trainable)
    jax.tree.map(lambda g, w: np.testing.assert_allclose(g, w, atol=2e-6), got, critic_step)
    weights = np.asarray(metrics["train/weights"])
    if spec.combine in ("min_norm", "min_norm_momentum"):
        # the min-norm point is unique, its weights need not be: here four signals'
        # gradients coincide, and which of them takes the weight is a rounding's choice
        np.testing.assert_allclose(weights.sum(), 1.0, atol=1e-6)
        assert (weights >= -1e-7).all()
        np.testing.assert_allclose(weights @ flat, w @ flat, rtol=1e-4, atol=1e-9)
    else:
        np.testing.assert_allclose(weights, w, atol=1e-5)
    got = jax.tree.map(lambda a, b: a - b, new.actor.trainable, state.actor.trainable)
    jax.tree.map(lambda g, w: np.testing.assert_allclose(g, w, atol=2e-6), got, actor_step)
    assert all(np.isfinite(np.asarray(v)).all() for v in jax.tree.leaves(metrics))


def test_warmup_steps_leave_the_actor_alone():
    data = tiny_protocol()
    cfg = offline.OfflineConfig(steps=10, batch_size=8, width=8, critic_warmup=0.5)
    obj = offline.objectives(data, cfg.gamma, cfg.ub_margin)
    init, update, _ = offline.make_update(offline.SPECS["wcac"], cfg, offline.input_dim(data), 4)
    state = init(jax.random.key(0))
    batch = offline.sample_batch(jax.random.key(1), data, 8, obj)
    new, _ = jax.jit(update)(state, batch, jnp.full(7, 1 / 7), obj)
    jax.tree.map(np.testing.assert_array_equal, new.actor.trainable, state.actor.trainable)
    assert int(new.step) == 1


def test_wcac_learns_to_recommend_the_clicked_video():
    """Known answer: the logged actions are uniform over 4 candidates and only candidate 3
    is ever clicked; with all preference on clicks the actor moves to index 3."""
    n = 400
    rng = np.random.default_rng(0)
    action = rng.integers(0, 4, n)
    reward = np.zeros((n, 7), np.float32)
    reward[:, 0] = action == 3
    reward[:, 1:] = 0.5  # the other signals ignore the action
    data = tiny_protocol(n=n, users=20, action=action, reward=reward)
    data = data.replace(n_train=n - 20)
    cfg = offline.OfflineConfig(
        steps=600, batch_size=32, width=16, gamma=0.5, critic_warmup=0.2, bc_weight=0.0
    )
    obj = offline.objectives(data, cfg.gamma, cfg.ub_margin)
    train, act = offline.make_train("wcac", cfg, data)
    pref = jnp.array([1.0, 0, 0, 0, 0, 0, 0])
    state, _ = jax.jit(train)(jax.random.key(0), pref, data, obj)
    a = act(state.actor, offline.net_input(data, jnp.arange(n)))
    assert float(jnp.mean(a)) > 2.7, float(jnp.mean(a))


def test_behavior_clone_learns_a_deterministic_logging_policy():
    """Known answer: each user is always shown the same candidate; BC recovers it."""
    n = 300
    users = np.sort(np.random.default_rng(1).integers(0, 6, n))
    action = users % 4
    data = tiny_protocol(n=n, users=6, action=action).replace(
        user_index=jnp.asarray(users, jnp.int32)
    )
    cfg = offline.OfflineConfig(steps=150, batch_size=32, width=16)
    train, act = offline.make_train_bc(cfg, data)
    params, losses = jax.jit(train)(jax.random.key(0), data)
    pred = np.asarray(act(params, offline.net_input(data, jnp.arange(n))))
    assert (pred == action).mean() > 0.95 and losses[-1] < losses[0]


@pytest.mark.parametrize("protocol, fitted", [("default", 1), ("tscac", 2)])
def test_behavior_clone_fits_the_protocols_behaviour_rows(protocol, fitted):
    """Training rows always log candidate 1, test rows candidate 2: Behavior-Clone
    recovers the one its protocol fits on (`Protocol.behaviour_rows`)."""
    n = 200
    action = np.where(np.arange(n) < n // 2, 1, 2)
    data = tiny_protocol(n=n, action=action).replace(n_train=n // 2, protocol=protocol)
    cfg = offline.OfflineConfig(steps=100, batch_size=32, width=16)
    train, act = offline.make_train_bc(cfg, data)
    params, _ = jax.jit(train)(jax.random.key(0), data)
    pred = np.asarray(act(params, offline.net_input(data, jnp.arange(n))))
    assert (pred == fitted).all()


def test_check_finite_names_the_first_non_finite_step():
    offline.check_finite("m", "loss", np.array([1.0, 2.0, 3.0]))  # finite: no error
    with pytest.raises(offline.TrainingError, match=r"^m: loss is nan at step 3 of 4$"):
        offline.check_finite("m", "loss", np.array([1.0, 2.0, np.nan, np.inf]))
    # [P, steps]: the first step where any preference fails, and that preference
    losses = np.ones((3, 5))
    losses[2, 1] = np.inf
    losses[0, 3] = np.nan
    with pytest.raises(
        offline.TrainingError, match=r"^m: critic loss is inf at step 2 of 5 \(preference 3 of 3\)$"
    ):
        offline.check_finite("m", "critic loss", losses)


def test_a_diverging_critic_gives_a_non_finite_loss_that_is_caught():
    """A step size far too large: the critic loss overflows within the run, and the check
    names the first step where it did."""
    data = tiny_protocol()
    obj = offline.objectives(data, 0.9, 0.2)
    cfg = dataclasses.replace(TINY, critic_lr=1e30)
    train, _ = offline.make_train("wcac", cfg, data)
    _, metrics = jax.jit(train)(jax.random.key(0), jnp.full((7,), 1 / 7), data, obj)
    loss = np.asarray(metrics["train/critic_loss"])
    first = int(np.argmax(~np.isfinite(loss)))
    assert not np.isfinite(loss[first]) and np.isfinite(loss[:first]).all()
    with pytest.raises(offline.TrainingError, match=f"at step {first + 1} of {cfg.steps}$"):
        offline.check_finite("wcac", "critic loss", loss)


def test_bilinear_critic_hand_computed():
    """`Q = [x, phi] w + b + phi^T V x` with x = (1, 2), phi = (3,):
    w = (1, 1, 1), b = 0.5, V = (2, -1): 1 + 2 + 3 + 0.5 + 3 * (2 - 2) = 6.5; its action
    gradient `w_phi + V x = 1 + 0` depends on the state through V."""
    net = offline.bilinear_network(2, 1)
    params = NetParams(
        {"w": jnp.ones((3, 1)), "b": jnp.array([0.5]), "v": jnp.array([[2.0, -1.0]])}, {}
    )
    np.testing.assert_allclose(net.apply(params, jnp.array([[1.0, 2.0, 3.0]])), [[6.5]])
    grad = jax.grad(lambda phi, x: net.apply(params, jnp.r_[x, phi][None])[0, 0])
    np.testing.assert_allclose(grad(jnp.array([3.0]), jnp.array([1.0, 2.0])), [1.0])
    np.testing.assert_allclose(grad(jnp.array([3.0]), jnp.array([2.0, 0.0])), [5.0])


def test_bc_cotangent_hand_computed():
    """`d/da mean(((a - l) / (C-1))^2)` with C = 3, a = (2, 0), l = (0, 0): (2*2/4/2, 0)."""
    got = offline.bc_cotangent(jnp.array([2.0, 0.0]), jnp.array([0.0, 0.0]), 3)
    np.testing.assert_allclose(got, [0.5, 0.0])
