"""The practical update (`wcac_jax.algos.practical`): its formulas, its loss and its minibatch
epochs against hand-computed values, its config, learning on the concave bandit (known
answer) with the traced directions, and the augmented scalarization on a bandit with a
weakly Pareto end (known answer)."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from brax.training.acme import running_statistics, specs

from wcac_jax import algos, envs, utopia
from wcac_jax.algos import practical
from wcac_jax.core import losses
from wcac_jax.core.runtime import TRACED_DIRECTIONS
from wcac_jax.envs import concave_bandit as cb


def test_return_normaliser_by_hand():
    # gamma = .5, one env starting at a discounted return of 2; the episode ends at t=1
    acc, seen = jax.jit(practical.accumulate_returns, static_argnums=3)(
        jnp.array([[2.0]]), jnp.ones((3, 1, 1)), jnp.array([[0.0], [1.0], [0.0]]), 0.5
    )
    np.testing.assert_allclose(seen[:, 0, 0], [2.0, 2.0, 1.0])  # .5*2+1, .5*2+1, 0*.5+1
    np.testing.assert_allclose(acc, [[1.0]])
    stats = running_statistics.update(
        running_statistics.init_state(specs.Array((1,), jnp.float32)), seen
    )
    # population std of (2, 2, 1): sqrt(2/9)
    np.testing.assert_allclose(stats.std, [math.sqrt(2.0 / 9.0)], rtol=1e-5)
    scaled = practical.scale_rewards(jnp.array([[3.0, -30.0]]), jnp.array([2.0, 1.0]), 10.0)
    np.testing.assert_allclose(scaled, [[1.5, -10.0]])


def test_observation_normaliser_by_hand():
    env = envs.make("concave_bandit")
    config = practical.PracticalConfig(
        num_envs=2, rollout_steps=4, num_minibatches=2, obs_clip=10.0
    )
    trainer = practical.make_trainer(config, env)
    stats = running_statistics.update(
        running_statistics.init_state(specs.Array((1,), jnp.float32)), jnp.array([[0.0], [2.0]])
    )  # mean 1, std 1
    out = trainer.preprocess(stats, jnp.array([[3.0], [100.0], [-1.0]]))
    np.testing.assert_allclose(out, [[2.0], [10.0], [-2.0]], rtol=1e-6)  # 99 clipped to 10


def test_at_a_corner_every_direction_is_the_same_update():
    """At p = [1, 0] smooth_wc's coefficients are (lambda_1 sigma_1, 0) and linear's
    (sigma_1, 0): the minibatch normalisation removes the positive factor, so the two
    surrogates' advantages agree up to rounding (any difference between such runs is the
    run-to-run spread, not the direction)."""
    from wcac_jax import scalarize

    adv = jnp.array([[1.0, 5.0], [3.0, -2.0], [-1.0, 0.5], [2.0, 7.0]])  # [B, m]
    sigma, pref = jnp.array([4.0, 9.0]), jnp.array([1.0, 0.0])
    j_hat, z = jnp.array([10.0, -3.0]), jnp.array([11.0, 2.0])
    weights = {
        "smooth_wc": scalarize.smooth_wc_weights(j_hat, pref, z, 1.0),
        "linear": scalarize.linear_weights(j_hat, pref),
    }
    # softmax([1 * 1, 0 * 5]) = (e / (e + 1), 1 / (e + 1)): a positive factor on A_1
    np.testing.assert_allclose(weights["smooth_wc"][0], math.e / (math.e + 1), rtol=1e-6)
    # A_1 = (1, 3, -1, 2): mean 1.25, std sqrt(2.1875)
    expected = (np.array([1.0, 3.0, -1.0, 2.0]) - 1.25) / np.sqrt(2.1875)
    for w in weights.values():
        coeff = scalarize.augmented_coefficients(w, pref, 0.0) * sigma
        np.testing.assert_allclose(losses.normalize_advantages(adv @ coeff), expected, rtol=1e-5)


def test_config_validates_and_round_trips():
    with pytest.raises(ValueError, match="num_minibatches 3 must divide"):
        practical.PracticalConfig(num_envs=4, rollout_steps=4, num_minibatches=3)
    with pytest.raises(ValueError, match="scalarization must be one of"):
        practical.PracticalConfig(scalarization="mgda")
    with pytest.raises(ValueError, match="utopia must be one of"):
        practical.PracticalConfig(utopia="guess")
    with pytest.raises(ValueError, match="clip_eps must be > 0"):
        practical.PracticalConfig(clip_eps=0.0)
    # finite in float64 but not in float32 (the program's type), or not finite at all
    bad = {
        "j_ub": (1e39, 1.0),
        "mu": 1e39,
        "learning_rate": float("inf"),
        "ent_coef": float("nan"),
        "utopia_margin": -1.0,
        "augment": -0.01,
        "log_std_init": float("inf"),
    }
    for name, value in bad.items():
        with pytest.raises(ValueError, match=f"^{name} must be"):
            practical.PracticalConfig(**{name: value})
    config = practical.PracticalConfig(j_ub=[1, 2], utopia="fixed")
    assert config.j_ub == (1.0, 2.0)
    assert config.env_steps_per_iteration == 16 * 128
    d = algos.to_dict(config)
    assert d["kind"] == "practical"
    assert algos.from_dict(d) == config
    # what older runs recorded: the kind "ppo", and no field added since (its default)
    legacy = {**d, "kind": "ppo"}
    del legacy["augment"], legacy["anneal_lr"]
    assert algos.from_dict(legacy) == config
    with pytest.raises(ValueError, match="no field 'clip'"):
        algos.from_dict({**d, "clip": 0.2})


def test_annealed_learning_rate_by_hand():
    config = practical.PracticalConfig(
        num_envs=4, rollout_steps=4, num_iterations=2, num_epochs=1, num_minibatches=2
    )
    assert practical.learning_rate(config.replace(learning_rate=1e-3)) == 1e-3  # constant
    schedule = practical.learning_rate(config.replace(learning_rate=1e-3, anneal_lr=True))
    # 2 iterations x 1 epoch x 2 minibatches = 4 updates: 1e-3 falling by 1e-3 / 4
    for count, expected in [(0, 1e-3), (1, 7.5e-4), (2, 5e-4), (3, 2.5e-4), (4, 0.0), (9, 0.0)]:
        assert float(schedule(count)) == pytest.approx(expected, rel=1e-6, abs=1e-12)  # f32


def test_annealed_run_stops_moving_after_its_last_update():
    """With `anneal_lr` and `num_iterations = 1` the step size reaches 0 after the run's 2
    updates, so a second iteration leaves the policy where the first put it."""
    env = envs.make("concave_bandit")
    config = practical.PracticalConfig(
        num_envs=4,
        rollout_steps=4,
        num_iterations=1,
        num_epochs=1,
        num_minibatches=2,
        anneal_lr=True,
        utopia="fixed",
    )
    trainer = practical.make_trainer(config, env)
    pref = jnp.array([[0.5, 0.5]])
    state = jax.vmap(trainer.init, in_axes=(None, 0))(jax.random.key(0), pref)
    step = jax.jit(jax.vmap(lambda s, p: trainer.run(s, p, 1)[0], axis_name=utopia.PREF_AXIS))
    once = step(state, pref)
    twice = step(once, pref)
    moved = jax.tree.map(lambda a, b: float(jnp.max(jnp.abs(a - b))), state.actor, once.actor)
    assert max(jax.tree.leaves(moved)) > 0
    jax.tree.map(np.testing.assert_array_equal, once.actor, twice.actor)
    jax.tree.map(np.testing.assert_array_equal, once.critic, twice.critic)


def test_small_policy_head_and_zero_initial_advantage_weights():
    env = envs.make("walker2d")
    trainer = practical.make_trainer(
        practical.PracticalConfig(num_envs=2, rollout_steps=4, num_minibatches=2), env
    )
    actor = trainer.policy.init(jax.random.key(0))
    obs = 3.0 * jax.random.normal(jax.random.key(1), (64, env.observation_size))
    stats = running_statistics.init_state(specs.Array((env.observation_size,), jnp.float32))
    mean, log_std = trainer.policy.apply(actor, trainer.preprocess(stats, obs))
    assert float(jnp.max(jnp.abs(mean))) < 0.1  # no torque saturated at initialisation
    np.testing.assert_allclose(log_std, 0.0)
    critic = trainer.value_network.init(jax.random.key(2))
    assert trainer.value_network.apply(critic, obs).shape == (64, 2)  # one value per objective


# -- learning: the concave bandit, 3 preferences x 2 traced directions, one program


ITERS = 60
CONFIG = practical.PracticalConfig(
    num_envs=16,
    rollout_steps=8,
    num_epochs=4,
    num_minibatches=2,
    learning_rate=3e-3,
    mu=0.01,
    utopia="fixed",
    j_ub=cb.DEFAULT_J_UB,
    log_std_init=math.log(0.3),
)
PREFS = np.array([[1.0, 0.0], [0.5, 0.5], [0.0, 1.0]], np.float32)
DIRECTIONS = ("smooth_wc", "linear")


@pytest.fixture(scope="module")
def bandit_runs():
    env = envs.make("concave_bandit")
    trainer = practical.make_trainer(CONFIG, env)
    n_p, n_d = len(PREFS), len(DIRECTIONS)
    keys = jnp.tile(jax.random.split(jax.random.key(0), n_p), n_d)
    prefs = jnp.tile(jnp.asarray(PREFS), (n_d, 1))
    index = jnp.repeat(jnp.asarray([TRACED_DIRECTIONS.index(d) for d in DIRECTIONS]), n_p)

    def train(key, pref, direction):
        return trainer.run(trainer.init(key, pref), pref, ITERS, direction)

    states, metrics = jax.jit(jax.vmap(train, axis_name=utopia.PREF_AXIS))(keys, prefs, index)
    action = jax.vmap(lambda s: trainer.mean_action(s, jnp.ones((1,))))(states)[:, 0]
    theta = np.asarray(cb.action_to_theta(action)).reshape(n_d, n_p)
    return {d: theta[k] for k, d in enumerate(DIRECTIONS)}, metrics


def test_practical_learns_the_bandit_ends_and_the_chebyshev_optimum(bandit_runs):
    theta, metrics = bandit_runs
    assert np.all(np.isfinite(np.asarray(metrics["train/j_hat"])))
    for direction in DIRECTIONS:
        assert theta[direction][0] < 0.1  # [1, 0]: reward (1, 0) at theta = 0
        assert theta[direction][2] > math.pi / 2 - 0.1  # [0, 1]: theta = pi / 2
    # [.5, .5]: smooth_wc lands on the interior weighted-Chebyshev optimum (pi / 4 by
    # symmetry); linear, on this concave front, heads for an end
    target = float(cb.wc_optimum(PREFS[1], cb.DEFAULT_J_UB))
    assert abs(theta["smooth_wc"][1] - target) < 0.05
    assert abs(theta["linear"][1] - math.pi / 4) > 0.3


# -- the augmented scalarization: a bandit whose [1, 0] end is a weakly Pareto flat


class _KinkedBandit(cb.ConcaveBandit):
    """`r = (min(0, 1/2 - 3t/2), t - 1/3)` with `t = (clip(a) + 1) / 2`: for `p = [1, 0]`
    every `t <= 1/3` maximises `r_1` (weakly Pareto optimal), and `t = 1/3` is the only
    Pareto optimal one. (Rewards near 0 there, so that the return normaliser's clip,
    `|r / sigma| <= 10`, stays inactive as the policy's noise shrinks.)"""

    objective_names = ("capped", "t")

    def step(self, state, action):
        t = 0.5 * (jnp.clip(action[0], -1.0, 1.0) + 1.0)
        return state.replace(
            reward=jnp.stack([jnp.minimum(0.0, 0.5 - 1.5 * t), t - 1.0 / 3.0]),
            done=jnp.ones((), jnp.float32),
            metrics={"theta": t},
        )


def test_augmented_practical_finds_the_pareto_optimal_point_of_a_weakly_pareto_end():
    """With `augment = rho`, `p = [1, 0]` ascends `(1 + rho) r_1 + rho r_2` (`lambda_1 = 1`).
    For a Gaussian `t ~ N(m, s^2)` its expectation is stationary where
    `1.5 (1 + rho) P(t > 1/3) = rho`, i.e. `m = 1/3 + s Phi^-1(rho / (1.5 (1 + rho)))`:
    the kink (the Pareto optimal point) less the noise's safety margin. Without the
    augmentation every `m` well below 1/3 is as good, and nothing holds `m` there."""
    rho = 0.2
    config = CONFIG.replace(augment=rho)
    trainer = practical.make_trainer(config, _KinkedBandit())
    seeds = 4  # four independent runs of p = [1, 0], one program
    prefs = jnp.tile(jnp.array([[1.0, 0.0]]), (seeds, 1))

    def train(key, pref):
        state, metrics = trainer.run(trainer.init(key, pref), pref, 2 * ITERS)
        t = 0.5 * (trainer.mean_action(state, jnp.ones((1,)))[0] + 1.0)
        obs = trainer.preprocess(state.obs_stats, jnp.ones((1, 1)))
        s = 0.5 * jnp.exp(jnp.ravel(trainer.policy.apply(state.actor, obs)[1])[0])  # std of t
        return t, s, metrics

    m, s, metrics = jax.jit(jax.vmap(train, axis_name=utopia.PREF_AXIS))(
        jax.random.split(jax.random.key(1), seeds), prefs
    )
    expected = 1.0 / 3.0 + s * jax.scipy.stats.norm.ppf(rho / (1.5 * (1.0 + rho)))
    np.testing.assert_allclose(m, expected, atol=0.04)
    assert abs(float(jnp.mean(m - expected))) < 0.02
    # the augmentation's value is in the scalarized metric: g + rho * sum_i (z_i - J_i)
    z, j_hat = metrics["train/utopia"][:, -1], metrics["train/j_hat"][:, -1]
    np.testing.assert_allclose(
        metrics["train/scalarized"][:, -1],
        metrics["train/g_mu"][:, -1] + rho * jnp.sum(z - j_hat, axis=-1),
        rtol=1e-5,
    )
