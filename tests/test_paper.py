"""The whole program on the concave bandit: learning, one trace, chunking, metrics.

Each compiled program is built once per session (module fixtures)."""

import functools
import math
from typing import NamedTuple

import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from brax.envs.base import Env, State

from wcac_jax import envs
from wcac_jax.algos import PaperConfig, make_evaluate, make_train, make_trainer
from wcac_jax.core.runtime import assemble, env_steps, finished_episode_return, rollout
from wcac_jax.core.types import EpisodeStats
from wcac_jax.envs import concave_bandit as cb

# None of these preferences has its optimum at the policies' start (theta ~ pi/4, the MLP
# policy head starts near action 0): [0.35, 0.65]'s weighted-Chebyshev optimum is 1.118.
PREFS = jnp.array([[0.8, 0.2], [0.35, 0.65], [0.2, 0.8]])
# A fixed small policy noise: with a learned std the expected-return front of stochastic
# policies is the convex hull of the bandit's front, not the front itself.
BANDIT = PaperConfig(
    num_envs=32,
    critic_steps=2,
    rollout_steps=4,
    num_iterations=600,
    mu=0.002,
    network="mlp",
    width=32,
    depth=1,
    actor_lr=0.1,
    critic_lr=0.1,
    actor_optimizer="normalized_harmonic",
    log_std_init=math.log(0.05),
    learn_log_std=False,
    normalize_obs=False,
    # warm critics without projection (not the paper's cold restart): 2 TD steps from W(0)
    # per iteration could not evaluate the policy
    critic_warm_start=True,
    projection_radius=math.inf,
)


def _learned_theta(config, env, states):
    trainer = make_trainer(config, env)
    action = jax.vmap(lambda s: trainer.mean_action(s, jnp.ones((1,))))(states)
    return np.asarray(cb.action_to_theta(action[:, 0]))


@pytest.fixture(scope="module")
def env():
    return envs.make("concave_bandit")


@pytest.fixture(scope="module")
def smooth_run(env):
    train = chex.assert_max_traces(make_train(BANDIT, env), n=1)
    sweep = jax.jit(jax.vmap(train))
    keys = jax.random.split(jax.random.key(0), len(PREFS))
    out = sweep(keys, PREFS)
    # a second call with other preferences must reuse the compiled program (no retrace)
    sweep(keys, PREFS[::-1])
    return out


def test_smooth_wc_reaches_the_weighted_chebyshev_optimum(env, smooth_run):
    states, _ = smooth_run
    theta = _learned_theta(BANDIT, env, states)
    target = np.asarray(jax.vmap(cb.wc_optimum, (0, None))(PREFS, cb.DEFAULT_J_UB))
    np.testing.assert_allclose(theta, target, atol=0.05)
    assert len(set(np.round(theta, 2))) == 3
    # every target is far from where the policies started: they had to learn
    start = jax.vmap(make_trainer(BANDIT, env).init)(
        jax.random.split(jax.random.key(0), len(PREFS)), PREFS
    )
    theta0 = _learned_theta(BANDIT, env, start)
    assert np.all(np.abs(target - theta0) > 0.3), (theta0, target)


def test_linear_ends_at_the_ends_of_the_front(env):
    config = BANDIT.replace(scalarization="linear")
    states, _ = jax.jit(jax.vmap(make_train(config, env)))(
        jax.random.split(jax.random.key(0), len(PREFS)), PREFS
    )
    theta = _learned_theta(config, env, states)
    dist_to_end = np.minimum(np.abs(theta), np.abs(theta - math.pi / 2))
    assert np.all(dist_to_end < 0.05), theta


def test_metrics_shapes_and_consistency(smooth_run):
    states, metrics = smooth_run
    p, t = len(PREFS), BANDIT.num_iterations
    for name in ("train/j_hat", "train/weights", "train/episode_return", "train/td_error"):
        assert metrics[name].shape == (p, t, 2), name
    for name in ("train/g_mu", "train/scalarized", "train/iteration", "train/direction_norm"):
        assert metrics[name].shape == (p, t), name
    assert all(bool(jnp.all(jnp.isfinite(v))) for v in jax.tree.leaves(metrics))
    np.testing.assert_allclose(jnp.sum(metrics["train/weights"], -1), 1.0, rtol=1e-5)
    np.testing.assert_array_equal(metrics["train/iteration"][0], np.arange(1, t + 1))
    assert env_steps(BANDIT, metrics["train/iteration"][0, -1]) == BANDIT.total_env_steps
    assert int(states.iteration[0]) == t
    # every bandit step ends an episode: all N * (K + L) of them are counted
    np.testing.assert_array_equal(metrics["train/episodes"], BANDIT.env_steps_per_iteration)
    # Jhat tracks the learned policy's true expected reward
    final = metrics["train/j_hat"][:, -1]
    np.testing.assert_allclose(final, metrics["train/episode_return"][:, -1], atol=0.02)


def test_chunking_does_not_change_the_numbers(env):
    config = BANDIT.replace(num_iterations=10)
    trainer = make_trainer(config, env)
    pref = PREFS[1]
    state0 = trainer.init(jax.random.key(3), pref)
    whole, m_whole = jax.jit(functools.partial(trainer.run, num_iterations=10))(state0, pref)
    run4 = jax.jit(functools.partial(trainer.run, num_iterations=4))
    run6 = jax.jit(functools.partial(trainer.run, num_iterations=6))
    part, m1 = run4(state0, pref)
    part, m2 = run6(part, pref)
    jax.tree.map(np.testing.assert_array_equal, whole, part)
    joined = jax.tree.map(lambda a, b: jnp.concatenate([a, b]), m1, m2)
    jax.tree.map(np.testing.assert_array_equal, m_whole, joined)


def test_evaluate_reports_the_mean_policy_return(env, smooth_run):
    states, _ = smooth_run
    evaluate = jax.jit(jax.vmap(make_evaluate(BANDIT, env, num_episodes=4)))
    out = evaluate(states, jax.random.split(jax.random.key(5), len(PREFS)))
    theta = _learned_theta(BANDIT, env, states)
    np.testing.assert_allclose(out["eval/return"], cb.reward(jnp.asarray(theta)), rtol=1e-5)
    np.testing.assert_allclose(out["eval/discounted_return"], out["eval/return"])
    np.testing.assert_allclose(out["eval/length"], 1.0)


def test_wrong_j_ub_length_is_rejected(env):
    with pytest.raises(ValueError, match=r"j_ub \[1.0, 2.0, 3.0\] has 3 entries"):
        make_train(BANDIT.replace(j_ub=(1.0, 2.0, 3.0)), env)


@pytest.mark.parametrize(
    "field,value",
    [
        ("num_envs", 0),
        ("mu", 0.0),
        ("mu", float("nan")),
        ("gamma", 1.0),
        ("scalarization", "max"),
        ("network", "cnn"),
        ("actor_optimizer", "lbfgs"),
    ],
)
def test_config_rejects_bad_values(field, value):
    with pytest.raises(ValueError, match=field):
        PaperConfig(**{field: value})


def test_mgda_reaches_the_ends_at_the_corners_and_stays_inside(env):
    """At a corner MGDA follows the one remaining objective to its end of the front; in
    between, every policy of the bandit is Pareto-stationary (the two objectives' gradients
    point in opposite directions along theta), so MGDA has no direction to follow: its
    sampled min-norm point is noise, which the normalised step turns into a random walk
    of steps alpha_t (0.09 rad in 300 iterations here), not a drift to an end."""
    config = BANDIT.replace(scalarization="mgda", num_iterations=300)
    prefs = jnp.array([[1.0, 0.0], [0.5, 0.5], [0.0, 1.0]])
    keys = jax.random.split(jax.random.key(0), len(prefs))
    states, metrics = jax.jit(jax.vmap(make_train(config, env)))(keys, prefs)
    np.testing.assert_allclose(jnp.sum(metrics["train/weights"], -1), 1.0, rtol=1e-4)
    theta = _learned_theta(config, env, states)
    theta0 = _learned_theta(config, env, jax.vmap(make_trainer(config, env).init)(keys, prefs))
    np.testing.assert_allclose(theta[[0, 2]], [0.0, math.pi / 2], atol=0.05)
    assert abs(theta[1] - theta0[1]) < 0.25, (theta0, theta)


def test_env_steps_count_past_two_to_the_31(env):
    """Environment steps are counted on the host from the iteration (int32 in the
    program): 30M iterations of 192 steps are 5.8e9 steps, past 2^32."""
    trainer = make_trainer(BANDIT, env)
    state = trainer.init(jax.random.key(0), PREFS[0])
    state = state.replace(iteration=jnp.asarray(30_000_000, jnp.int32))
    state, metrics = jax.jit(trainer.step)(state, PREFS[0])
    expected = 30_000_001 * BANDIT.env_steps_per_iteration
    assert expected > 2**32
    assert env_steps(BANDIT, state.iteration) == expected
    assert env_steps(BANDIT, metrics["train/iteration"]) == expected
    assert env_steps(BANDIT, np.array([1, 2])).tolist() == [192, 384]


PAPER_BANDIT = BANDIT.replace(network="paper", width=16, normalize_obs=True, num_iterations=300)


def test_paper_network_learns_the_bandit_despite_its_constant_observation(env):
    """The bandit's observation is the constant `[1.]`, which the running normaliser maps
    to exactly 0; the paper network (no bias) must still get a non-zero input, so that
    its policy can move. From one initial policy (a key whose initial mean action is
    inside (-1, 1): the paper network's initial output has scale sqrt(2 w) ~ 5.7, so most
    keys start saturated at an end, where the clipped action's reward is flat), three
    preferences end at their three weighted-Chebyshev optima."""
    trainer = make_trainer(PAPER_BANDIT, env)
    prefs = jnp.array([[1.0, 0.0], [0.35, 0.65], [0.0, 1.0]])
    keys = jnp.stack([jax.random.split(jax.random.key(0), 40)[11]] * len(prefs))
    states, _ = jax.jit(jax.vmap(make_train(PAPER_BANDIT, env)))(keys, prefs)
    x = jax.vmap(trainer.preprocess, (0, None))(states.obs_stats, jnp.ones((1,)))
    assert np.all(np.linalg.norm(x, axis=-1) > 0.99), x  # never all zero
    theta = _learned_theta(PAPER_BANDIT, env, states)
    # the initial policy, on the input it sees once the normaliser has seen the constant
    start = jax.vmap(trainer.init)(keys, prefs).replace(obs_stats=states.obs_stats)
    theta0 = _learned_theta(PAPER_BANDIT, env, start)
    target = np.asarray(jax.vmap(cb.wc_optimum, (0, None))(prefs, cb.DEFAULT_J_UB))
    np.testing.assert_allclose(theta, target, atol=0.05)
    assert np.all(np.abs(target - theta0[0]) > 0.3), (theta0, target)


class _Cycle(Env):
    """`x` cycles 0 -> 1 -> 2 -> 0 whatever the action; obs one-hot(x); leaving `x` earns
    `[1 + x, 1]`. With `fall`, the step 2 -> 0 is a fall (terminal). Resets start at
    `start`, or uniformly at random (`start=None`)."""

    num_objectives = 2
    objective_names = ("x", "one")
    default_j_ub = (10.0, 10.0)
    observation_size = 3
    action_size = 1
    backend = "none"

    def __init__(self, fall: bool, episode_length: int, start: int | None = None):
        self.fall, self.episode_length, self.start = fall, episode_length, start

    def reset(self, rng):
        x = jax.random.randint(rng, (), 0, 3) if self.start is None else jnp.asarray(self.start)
        z = jnp.zeros(())
        obs = jax.nn.one_hot(x, 3)
        return State(pipeline_state={"x": x}, obs=obs, reward=jnp.zeros(2), done=z)

    def step(self, state, action):
        x = state.pipeline_state["x"]
        nx = (x + 1) % 3
        done = jnp.where(self.fall & (nx == 0), 1.0, 0.0)
        reward = jnp.stack([1.0 + x, 1.0]).astype(jnp.float32)
        return state.replace(
            pipeline_state={"x": nx}, obs=jax.nn.one_hot(nx, 3), reward=reward, done=done
        )


CYCLE = PaperConfig(
    num_envs=16,
    critic_steps=10,
    rollout_steps=2,
    num_iterations=150,
    gamma=0.5,
    network="mlp",
    width=32,
    depth=1,
    critic_lr=0.1,
    normalize_obs=False,
    critic_warm_start=True,  # the values are learned across iterations
    projection_radius=math.inf,
)


@pytest.mark.parametrize("fall", [False, True])
def test_td_targets_bootstrap_truncations_and_not_falls(fall):
    """Episodes of 2 steps from uniform start states. Without falls the chain never ends,
    so the right values are the continuing chain's `V = (I - gamma P)^-1 r` (the time
    limit bootstraps from the TRUE next state `final_obs`, not the reset one); with the
    fall 2 -> 0 terminal, `V(2) = r(2)` and no value flows back through the fall. Any
    mix-up of `terminal`, `done` and `final_obs` in the training loop moves a value by
    more than 0.25."""
    env = _Cycle(fall, episode_length=2)
    trainer = make_trainer(CYCLE, env)
    pref = jnp.array([0.5, 0.5])
    state = trainer.init(jax.random.key(0), pref)
    state, _ = jax.jit(functools.partial(trainer.run, num_iterations=CYCLE.num_iterations))(
        state, pref
    )
    from wcac_jax import critic

    avg = critic.averaged_params(state.critic)
    learned = critic.values(trainer.value_network.apply, avg, jnp.eye(3))  # [3, m]
    r = np.array([[1.0, 1.0], [2.0, 1.0], [3.0, 1.0]])
    p = np.roll(np.eye(3), 1, axis=1)  # x -> x + 1
    if fall:
        p[2] = 0.0  # the fall 2 -> 0 does not bootstrap
    exact = np.linalg.solve(np.eye(3) - CYCLE.gamma * p, r)
    # by hand: without falls V(., one) = 1 / (1 - 0.5) = 2, V(0, x) = 2.75 / 0.875;
    # with them V(2) = (3, 1), V(1) = (3.5, 1.5), V(0) = (2.75, 1.75)
    if fall:
        np.testing.assert_allclose(exact, [[2.75, 1.75], [3.5, 1.5], [3.0, 1.0]])
    else:
        np.testing.assert_allclose(exact[:, 1], 2.0)
        np.testing.assert_allclose(exact[0, 0], 2.75 / 0.875)
    np.testing.assert_allclose(learned, exact, atol=0.1)


@pytest.mark.parametrize(
    "fall,episode_length,ret,disc,length",
    [
        # falls on its 3rd step (2 -> 0): r = (1, 1), (2, 1), (3, 1), then nothing counts
        (True, 10, [6.0, 3.0], [1 + 0.5 * 2 + 0.25 * 3, 1 + 0.5 + 0.25], 3.0),
        # truncated after 2 steps: r = (1, 1), (2, 1)
        (False, 2, [3.0, 2.0], [1 + 0.5 * 2, 1 + 0.5], 2.0),
    ],
)
def test_evaluate_discounts_and_stops_at_the_end_of_a_multi_step_episode(
    fall, episode_length, ret, disc, length
):
    env = _Cycle(fall, episode_length, start=0)
    evaluate = jax.jit(make_evaluate(CYCLE, env, num_episodes=3))
    state = make_trainer(CYCLE, env).init(jax.random.key(0), jnp.array([0.5, 0.5]))
    out = evaluate(state, jax.random.key(1))
    np.testing.assert_allclose(out["eval/return"], ret, rtol=1e-6)
    np.testing.assert_allclose(out["eval/discounted_return"], disc, rtol=1e-6)
    np.testing.assert_allclose(out["eval/length"], length)


def test_finished_episode_return_by_hand():
    last = jnp.array([[1.0, -2.0], [9.0, 9.0], [3.0, 4.0]])
    # environment 1 has finished no episode yet: its last_return is not counted
    episodes = EpisodeStats(jnp.zeros((3, 2)), last, jnp.array([2, 0, 1]))
    np.testing.assert_allclose(finished_episode_return(episodes), [2.0, 1.0])
    none = EpisodeStats(jnp.zeros((3, 2)), last, jnp.zeros(3, jnp.int32))
    np.testing.assert_allclose(finished_episode_return(none), [0.0, 0.0])


def test_rollout_steps_in_order_with_one_key_per_step():
    # a stand-in `env_step` that counts and records the key it was given
    def env_step(actor, obs_stats, env_state, episodes, key):
        return env_state + actor, episodes + 1, jax.random.key_data(key)

    key = jax.random.key(7)
    (state, episodes), keys = rollout(env_step, 2.0, None, 10.0, 0, key, 3)
    assert (float(state), int(episodes)) == (16.0, 3)
    np.testing.assert_array_equal(keys, jax.random.key_data(jax.random.split(key, 3)))


def test_assemble_runs_the_step_and_takes_the_policy_mode():
    # a stand-in step that counts iterations and records the preference and direction
    def step(state, pref, direction=None):
        return state + 1, {"pref0": pref[0], "direction": direction}

    class Policy:  # the mode of a "distribution" that is the network's output itself
        apply = staticmethod(lambda actor, x: actor * x)
        mode = staticmethod(lambda dist: dist)
        to_env = staticmethod(lambda a: jnp.clip(a, -1.0, 1.0))

    class State(NamedTuple):
        actor: float
        obs_stats: float

    preprocess = lambda stats, obs: obs - stats  # noqa: E731
    trainer = assemble(None, step, Policy, None, preprocess, jnp.zeros(2))
    state, metrics = trainer.run(0, jnp.array([0.25, 0.75]), 3, jnp.int32(2))
    assert int(state) == 3
    np.testing.assert_array_equal(metrics["pref0"], [0.25] * 3)
    np.testing.assert_array_equal(metrics["direction"], [2] * 3)
    with pytest.raises(AssertionError):  # a preference of the wrong length
        trainer.run(0, jnp.array([0.2, 0.3, 0.5]), 3)
    # 0.5 * ([1, 3, -4] - 1) = [0, 1, -2.5], clipped to [-1, 1]
    action = trainer.mean_action(State(0.5, 1.0), jnp.array([1.0, 3.0, -4.0]))
    np.testing.assert_allclose(action, [0.0, 1.0, -1.0])
    assert trainer.step is step
