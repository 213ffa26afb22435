"""The Python API as a user meets it: `make_train` under a plain `jax.vmap`, a
scalarization registered from the user's own code, the contract a new update must meet,
and the hooks (`network_factory`, `progress_fn`)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from wcac_jax import PracticalConfig, envs, make_train, scalarize, utopia

# a practical update small enough to compile in seconds on the bandit
TINY = PracticalConfig(
    num_envs=4, rollout_steps=4, num_minibatches=2, num_epochs=1, width=8, depth=1
).replace(num_iterations=3)
PREFS = jnp.array([[1.0, 0.0], [0.0, 1.0]])


@pytest.fixture(scope="module")
def bandit():
    return envs.make("concave_bandit")


def _keys(n):
    return jax.random.split(jax.random.key(0), n)


def test_make_train_runs_under_a_plain_vmap(bandit):
    """Without a named preference axis each preference estimates its own utopia point,
    by `utopia.estimate`'s rule on its own `Jhat`: `best_t = max_{s <= t} Jhat_s` and
    `z_t = best_t + margin * max(best_t - Jhat_t, min_spread)`; named, one point is
    shared by the batch."""
    train = make_train(TINY, bandit)
    _, metrics = jax.jit(jax.vmap(train))(_keys(2), PREFS)
    j_hat = np.asarray(metrics["train/j_hat"])  # [P, T, m]
    best = np.maximum.accumulate(j_hat, axis=1)
    spread = np.maximum(best - j_hat, TINY.utopia_min_spread)
    np.testing.assert_allclose(
        metrics["train/utopia"], best + TINY.utopia_margin * spread, rtol=1e-6
    )
    assert not np.array_equal(metrics["train/utopia"][0], metrics["train/utopia"][1])
    _, shared = jax.jit(jax.vmap(train, axis_name=utopia.PREF_AXIS))(_keys(2), PREFS)
    np.testing.assert_array_equal(shared["train/utopia"][0], shared["train/utopia"][1])


@pytest.fixture
def squared_regret():
    """A scalarization registered from a test, as a user would, and removed after."""
    scalarize.register("squared_regret", lambda v, p, z, mu: jnp.sum(p * jnp.square(z - v)))
    yield "squared_regret"
    del scalarize.SCALARIZATIONS["squared_regret"]


def test_a_scalarization_registered_after_import_trains(bandit, squared_regret):
    """`S = sum_i p_i (z_i - J_i)^2` has `grad_J S = -2 p (z - J)`, so its weights (by
    automatic differentiation) are `2 (z - J)`: the practical update reports them at its
    own `Jhat` and utopia point every iteration."""
    assert squared_regret in scalarize.NAMES and scalarize.NAMES[-1] == squared_regret
    train = make_train(TINY.replace(scalarization=squared_regret), bandit)
    _, metrics = jax.jit(jax.vmap(train))(_keys(2), jnp.array([[0.5, 0.5], [0.2, 0.8]]))
    expected = 2.0 * (metrics["train/utopia"] - metrics["train/j_hat"])
    np.testing.assert_allclose(metrics["train/weights"], expected, rtol=1e-5)
    # and by its traced index, as a sweep selects it
    index = jnp.full((2,), scalarize.NAMES.index(squared_regret))
    _, by_index = jax.jit(jax.vmap(make_train(TINY, bandit)))(
        _keys(2), jnp.array([[0.5, 0.5], [0.2, 0.8]]), index
    )
    np.testing.assert_array_equal(by_index["train/weights"], metrics["train/weights"])
