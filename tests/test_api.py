"""The Python API as a user meets it: `make_train` under a plain `jax.vmap`, a
scalarization registered from the user's own code, the contract a new update must meet,
and the hooks (`network_factory`, `progress_fn`)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from wcac_jax import (
    PracticalConfig,
    algos,
    envs,
    make_train,
    networks,
    runtime,
    scalarize,
    utopia,
)
from wcac_jax.algos import contract, practical
from wcac_jax.core.config import Config, field, frozen_config
from wcac_jax.sweep import SweepConfig, SweepError, load_sweep, run_sweep

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


@frozen_config
class _HalfWritten(Config):
    """A configuration that forgot its temperature and its step count."""

    num_iterations: int = field(10, "T")
    gamma: float = field(0.99, "discount")
    j_ub: tuple | None = field(None, "utopia point")
    scalarization: str = field("smooth_wc", "direction")


def test_an_update_without_the_contracts_fields_is_refused_at_registration():
    with pytest.raises(contract.ContractError) as err:
        algos.register("half_written", _HalfWritten, lambda config, env: None)
    assert "lacks mu, env_steps_per_iteration (a property)" in str(err.value)
    assert "half_written" not in algos.ALGOS
    with pytest.raises(contract.ContractError, match="must be a config.Config subclass"):
        algos.register("half_written", dict, lambda config, env: None)


@frozen_config
class _NoGMu(PracticalConfig):
    """The practical update under another name, whose step forgets `train/g_mu`."""


def _no_g_mu_trainer(config, env):
    trainer = practical.make_trainer(config, env)

    def step(state, pref, direction=None):
        state, metrics = trainer.step(state, pref, direction)
        return state, {k: v for k, v in metrics.items() if k != "train/g_mu"}

    return runtime.assemble(
        trainer.init, step, trainer.policy, trainer.value_network, trainer.preprocess, trainer.j_ub
    )


@pytest.fixture
def no_g_mu():
    algos.register("no_g_mu", _NoGMu, _no_g_mu_trainer)
    yield _NoGMu
    del algos.ALGOS["no_g_mu"]


def test_an_update_whose_metrics_miss_a_key_is_refused_before_compiling(
    no_g_mu, tmp_path, monkeypatch
):
    def compile_(*args, **kwargs):
        raise AssertionError("compiled")

    monkeypatch.setattr(jax.stages.Lowered, "compile", compile_)
    config = SweepConfig(
        prefs=((1.0, 0.0), (0.0, 1.0)),
        env="concave_bandit",
        train=no_g_mu(**{f: getattr(TINY, f) for f in ("num_envs", "rollout_steps")}).replace(
            num_minibatches=2, num_epochs=1, width=8, depth=1
        ),
        steps_per_pref=16,
    )
    out = tmp_path / "run"
    with pytest.raises(SweepError, match="update 'no_g_mu': .* train/g_mu is missing"):
        run_sweep(config, str(out), progress=False)
    assert not out.exists()
    with pytest.raises(contract.ContractError, match="not a runtime.Trainer"):
        algos.register("no_g_mu", _NoGMu, lambda config, env: (config, env))
        algos.make_trainer(config.train, envs.make("concave_bandit"))


def _narrow(calls):
    """A network factory that records what it is asked for and builds tanh MLPs of
    width 3 (the practical update's own are `TINY.width` = 8)."""

    def factory(in_size, out_size, *, role):
        calls.append((in_size, out_size, role))
        return networks.tanh_mlp(in_size, out_size, 3, 1, 0.01 if role == "actor" else 1.0)

    return factory


def test_make_train_builds_its_networks_with_a_network_factory(bandit):
    calls = []
    state, _ = jax.jit(jax.vmap(make_train(TINY, bandit, network_factory=_narrow(calls))))(
        _keys(2), PREFS
    )
    # the bandit: 1 observation, 1 action (the Gaussian's mean), 2 objectives
    assert calls == [(1, 1, "actor"), (1, 2, "critic")]
    kernels = [x.shape for x in jax.tree.leaves(state.actor.trainable) if x.ndim == 3]
    assert kernels == [(2, 1, 3), (2, 3, 1)]  # [P, in, out]: input -> 3 -> mean


def test_run_sweep_calls_progress_fn_and_load_sweep_takes_the_same_factory(bandit, tmp_path):
    """Three iterations of 16 env steps (4 environments x 4 steps) in three chunks: the
    hook sees each chunk's iteration, the env steps so far, and the sweep's networks
    are the factory's, restored with it."""
    config = SweepConfig(
        prefs=((1.0, 0.0), (0.0, 1.0)), env="concave_bandit", train=TINY, steps_per_pref=48
    )
    seen = []
    out = str(tmp_path / "run")
    run_sweep(
        config,
        out,
        chunks=3,
        progress=False,
        progress_fn=lambda steps, metrics: seen.append(
            (steps, metrics["train/iteration"].tolist(), metrics["train/env_steps"].tolist())
        ),
        network_factory=_narrow([]),
    )
    assert seen == [
        (16, [[1], [1]], [[16], [16]]),
        (32, [[2], [2]], [[32], [32]]),
        (48, [[3], [3]], [[48], [48]]),
    ]
    run = load_sweep(out, network_factory=_narrow([]))
    kernels = [x.shape for x in jax.tree.leaves(run.state.actor.trainable) if x.ndim == 3]
    assert kernels == [(2, 1, 3), (2, 3, 1)]
