"""The registry, the episode wrapper, and the concave bandit's exact answers."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from brax.envs.base import Env, State

from wcac_jax import envs, pareto, scalarize
from wcac_jax.core.episodes import EpisodeWrapper
from wcac_jax.envs import concave_bandit as cb


def test_registry_errors_name_the_valid_choices():
    with pytest.raises(ValueError, match="'nope'.*concave_bandit"):
        envs.make("nope")
    with pytest.raises(ValueError, match="'colour'.*concave_bandit"):
        envs.make("concave_bandit", colour="red")
    assert "concave_bandit" in envs.names()


@pytest.mark.parametrize("name", envs.names())
def test_every_environment_declares_what_training_reads(name):
    """Each registered environment is a `base.MOEnv` whose declarations agree."""
    from wcac_jax.envs import base

    env = envs.make(name, **({"engine": "mujoco"} if name == "walker2d" else {}))
    assert isinstance(env, base.MOEnv)
    base.check(env)
    assert env.observation_size >= 1 and env.action_size >= 1


def test_option_defaults_without_building():
    assert envs.option_defaults("hopper")["engine"] == "mujoco"
    assert envs.option_defaults("walker2d")["engine"] == "mujoco"  # the command line's
    assert envs.option_defaults("walker2d")["episode_length"] == 500
    assert envs.option_defaults("concave_bandit") == {}
    with pytest.raises(ValueError, match="'nope'.*concave_bandit"):
        envs.option_defaults("nope")


def test_check_names_what_disagrees():
    from wcac_jax.envs import base

    env = envs.make("concave_bandit")
    env.default_j_ub = (1.1,)
    with pytest.raises(ValueError, match="default_j_ub has 1 entries for 2 objectives"):
        base.check(env)
    env.default_j_ub, env.default_hv_ref = (1.1, 1.1), (0.0, 2.0)
    with pytest.raises(ValueError, match=r"default_hv_ref \(0.0, 2.0\) is not below"):
        base.check(env)


def test_concave_bandit_rewards_by_hand():
    env = envs.make("concave_bandit")
    assert env.num_objectives == 2 and len(env.objective_names) == 2
    state = jax.jit(env.reset)(jax.random.key(0))
    nxt = jax.jit(env.step)(state, jnp.array([0.0]))  # theta = pi/4
    np.testing.assert_allclose(nxt.reward, [1 - math.sqrt(0.5)] * 2, rtol=1e-6)
    assert float(nxt.done) == 1.0
    ends = jax.vmap(env.step, (None, 0))(state, jnp.array([[-1.0], [1.0], [5.0]]))
    np.testing.assert_allclose(ends.reward, [[1, 0], [0, 1], [0, 1]], atol=1e-6)


def test_wc_optimum_solves_the_balance_equation():
    for pref in ([0.5, 0.5], [0.8, 0.2], [0.1, 0.9], [0.3, 0.7]):
        t = float(cb.wc_optimum(jnp.array(pref), cb.DEFAULT_J_UB))
        z1, z2 = cb.DEFAULT_J_UB
        assert pref[0] * (z1 - 1 + math.sin(t)) == pytest.approx(pref[1] * (z2 - 1 + math.cos(t)))
    assert float(cb.wc_optimum(jnp.array([0.5, 0.5]))) == pytest.approx(math.pi / 4, abs=1e-6)
    assert float(cb.wc_optimum(jnp.array([1.0, 0.0]))) == pytest.approx(0.0, abs=1e-6)
    assert float(cb.wc_optimum(jnp.array([0.0, 1.0]))) == pytest.approx(math.pi / 2, abs=1e-6)
    front = cb.exact_front(11)
    assert front.shape == (11, 2) and np.all(np.diff(front[:, 0]) < 0)


def test_concave_bandit_exact_front_hypervolume():
    """`1 - pi/4` (by hand: the unit square less the quarter disc of radius 1 around
    `(1, 1)`), which the staircases of ever finer sampled fronts approach from below, short
    of it by the staircase's `pi / (8 (n - 1))`."""
    exact = cb.exact_front_hypervolume()
    assert exact == pytest.approx(0.21460183660255172, abs=1e-15)
    shortfalls = []
    for n in (2001, 20001):
        sampled = pareto.hypervolume(cb.exact_front(n), (0.0, 0.0))
        shortfalls.append(exact - sampled)
        assert 0.0 < exact - sampled == pytest.approx(math.pi / (8 * (n - 1)), rel=1e-3)
    assert shortfalls[1] < 2e-5 and shortfalls[1] < shortfalls[0] / 9


class _Counter(Env):
    """obs = position; +1 per step; falls (terminal) when it reaches 3 if `fall`."""

    num_objectives = 2

    def __init__(self, fall):
        self.fall = fall

    def reset(self, rng):
        z = jnp.zeros(())
        return State(pipeline_state={"x": z}, obs=jnp.zeros(1), reward=jnp.zeros(2), done=z)

    def step(self, state, action):
        x = state.pipeline_state["x"] + 1
        done = jnp.where(self.fall & (x >= 3), 1.0, 0.0)
        return state.replace(
            pipeline_state={"x": x}, obs=x[None], reward=jnp.stack([x, -x]), done=done
        )

    observation_size = 1
    action_size = 1
    backend = "none"


@pytest.mark.parametrize("fall", [False, True])
def test_episode_wrapper_time_limit_terminal_and_auto_reset(fall):
    env = EpisodeWrapper(_Counter(fall), episode_length=3 if not fall else 10)
    state = env.reset(jax.random.key(0))
    step = jax.jit(env.step)
    for _ in range(3):
        state = step(state, jnp.zeros(1))
    assert float(state.done) == 1.0
    assert float(state.info["truncation"]) == (0.0 if fall else 1.0)
    assert float(state.info["terminal"]) == (1.0 if fall else 0.0)
    assert float(state.info["final_obs"][0]) == 3.0  # true next observation kept
    assert float(state.obs[0]) == 0.0  # auto-reset
    np.testing.assert_allclose(state.reward, [3.0, -3.0])
    state = step(state, jnp.zeros(1))
    assert float(state.done) == 0.0 and float(state.obs[0]) == 1.0
    with pytest.raises(ValueError, match="episode_length"):
        EpisodeWrapper(_Counter(fall), 0)


class _RandomStart(Env):
    """Starts at a uniform random position in [0, 1); +1 per step; never falls."""

    num_objectives = 1
    observation_size = 1
    action_size = 1
    backend = "none"

    def reset(self, rng):
        x = jax.random.uniform(rng, ())
        z = jnp.zeros(())
        return State(pipeline_state={"x": x}, obs=x[None], reward=jnp.zeros(1), done=z)

    def step(self, state, action):
        x = state.pipeline_state["x"] + 1
        return state.replace(pipeline_state={"x": x}, obs=x[None], reward=jnp.ones(1))


def _start_observations(key, num_steps, episode_length=3):
    """Runs `num_steps` steps of 3-step episodes; returns every step's `obs` and `first_obs`
    and the final state."""
    env = EpisodeWrapper(_RandomStart(), episode_length)

    def body(state, _):
        state = env.step(state, jnp.zeros(1))
        return state, (state.obs[0], state.info["first_obs"][0])

    return jax.lax.scan(body, env.reset(key), None, length=num_steps)


def test_episode_wrapper_draws_a_fresh_start_state_for_every_episode():
    state, (obs, first) = jax.jit(_start_observations, static_argnums=1)(jax.random.key(0), 12)
    starts = np.asarray(obs[2::3])  # the reset observation after each 3-step episode
    assert np.all((starts >= 0) & (starts < 1))
    assert len(set(starts.round(6))) == len(starts)  # four episodes, four start states
    np.testing.assert_array_equal(np.asarray(first[2::3]), starts)  # first_obs follows
    np.testing.assert_allclose(np.asarray(obs[3:12:3]), starts[:3] + 1, rtol=1e-6)
    # deterministic given the key; another key, other start states
    _, (again, _) = jax.jit(_start_observations, static_argnums=1)(jax.random.key(0), 12)
    np.testing.assert_array_equal(obs, again)
    _, (other, _) = jax.jit(_start_observations, static_argnums=1)(jax.random.key(1), 12)
    assert not np.allclose(obs, other)


def test_episode_wrapper_resets_do_not_depend_on_chunking():
    """The reset keys live in the state: 5 + 7 steps give the same states as 12."""
    env = EpisodeWrapper(_RandomStart(), 3)
    step = jax.jit(env.step)
    whole = env.reset(jax.random.key(2))
    for _ in range(12):
        whole = step(whole, jnp.zeros(1))
    part, _ = jax.jit(_start_observations, static_argnums=1)(jax.random.key(2), 5)
    for _ in range(7):
        part = step(part, jnp.zeros(1))
    jax.tree.map(np.testing.assert_array_equal, whole, part)


def test_tabular_momdp_exact_values_match_monte_carlo():
    env = envs.make("tabular_momdp", episode_length=200)
    assert env.num_actions == 3 and env.observation_size == 4
    pi = jnp.array([[0.2, 0.3, 0.5], [1.0, 0.0, 0.0], [0.1, 0.1, 0.8], [0.5, 0.5, 0.0]])
    exact = env.exact_objectives(pi)
    # Bellman equation holds for the exact values
    v = env.exact_values(pi)
    r_pi = jnp.einsum("sa,sam->sm", pi, env.rewards)
    p_pi = jnp.einsum("sa,sat->st", pi, env.kernel)
    np.testing.assert_allclose(v, r_pi + env.gamma * p_pi @ v, rtol=1e-5)
    wrapped = EpisodeWrapper(env, env.episode_length)

    @jax.jit
    def discounted_return(key):
        key_reset, key_run = jax.random.split(key)
        state = wrapped.reset(key_reset)

        def body(carry, k):
            state, ret, disc = carry
            s = state.pipeline_state["s"]
            action = jax.random.categorical(k, jnp.log(pi[s]))
            state = wrapped.step(state, action)
            return (state, ret + disc * state.reward, disc * env.gamma), None

        init = (state, jnp.zeros(2), jnp.ones(()))
        (_, ret, _), _ = jax.lax.scan(body, init, jax.random.split(key_run, 150))
        return ret

    returns = jax.vmap(discounted_return)(jax.random.split(jax.random.key(0), 4000))
    np.testing.assert_allclose(jnp.mean(returns, axis=0), exact, rtol=0.02)


def test_tabular_momdp_optimum_beats_every_deterministic_policy():
    import itertools

    env = envs.make("tabular_momdp", num_states=3, num_actions=2)
    pref, j_ub, mu = jnp.array([0.5, 0.5]), jnp.asarray(env.default_j_ub), 0.1
    _, g_star = env.optimal_scalarized(pref, j_ub, mu)
    for actions in itertools.product(range(2), repeat=3):
        pi = jax.nn.one_hot(jnp.array(actions), 2)
        g = scalarize.smooth_wc(env.exact_objectives(pi), pref, j_ub, mu)
        assert float(g_star) <= float(g) + 1e-4


def test_deep_sea_treasure_dynamics_and_exact_answers():
    from wcac_jax.envs import deep_sea_treasure as dst

    env = envs.make("deep_sea_treasure")
    state = env.reset(jax.random.key(0))
    step = jax.jit(env.step)
    up = step(state, jnp.array(0))  # off the grid: stays at the start
    assert int(up.pipeline_state["cell"]) == 0 and float(up.done) == 0.0
    np.testing.assert_allclose(up.reward, [0.0, -1.0])
    down = step(state, jnp.array(1))  # treasure 1 right below the start
    np.testing.assert_allclose(down.reward, [1.0, -1.0])
    assert float(down.done) == 1.0
    # the shortest paths take 1, 3, 5, 7, 8, 9, 13, 14, 17, 19 steps (MO-Gymnasium's front)
    undiscounted = dst.path_returns(1.0 - 1e-12)
    np.testing.assert_allclose(-undiscounted[:, 1], [1, 3, 5, 7, 8, 9, 13, 14, 17, 19], rtol=1e-6)
    # concave map: the stochastic-policy front is the segment from treasure 1 to 124
    front = dst.exact_front(0.99)
    np.testing.assert_allclose(front, dst.path_returns(0.99)[[0, -1]])
    assert np.all(dst.distance_to_front(dst.path_returns(0.99)[1:-1], front) > 1.0)


def test_deep_sea_treasure_exact_objectives_match_monte_carlo():
    env = envs.make("deep_sea_treasure")
    gamma = 0.95
    logits = jax.random.normal(jax.random.key(1), (121, 4)) + jnp.array([0.0, 1.0, 0.0, 1.0])
    pi = jax.nn.softmax(logits, axis=-1)
    exact = env.exact_objectives(pi, gamma)
    wrapped = EpisodeWrapper(env, 400)

    @jax.jit
    def discounted_return(key):
        state = wrapped.reset(key)

        def body(carry, k):
            state, ret, disc, alive = carry
            action = jax.random.categorical(k, jnp.log(pi[state.pipeline_state["cell"]]))
            state = wrapped.step(state, action)
            ret = ret + alive * disc * state.reward
            return (state, ret, disc * gamma, alive * (1 - state.info["terminal"])), None

        init = (state, jnp.zeros(2), jnp.ones(()), jnp.ones(()))
        (_, ret, _, _), _ = jax.lax.scan(body, init, jax.random.split(key, 400))
        return ret

    returns = jax.vmap(discounted_return)(jax.random.split(jax.random.key(2), 4000))
    np.testing.assert_allclose(jnp.mean(returns, axis=0), exact, rtol=0.03, atol=0.05)
