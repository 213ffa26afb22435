"""The numpy policy (`wcac_jax.evaluate.numpy_policy`) against the JAX policy's
`Trainer.mean_action` on the same parameters, statistics and observations, for every
update's network: the practical update's tanh MLP (clipped normalised observations), the
paper update's ReLU network (bias feature, unit sphere, `1 / sqrt(w)`) and its MLP, the
conditioned network (the preference appended after normalisation), and Humanoid's action
box of half-width 0.4.

Both sides compute in float32; only the order of the sums inside the matrix products
differs (XLA's against numpy's BLAS). A float32 sum of `n` products carries a rounding
error of about `sqrt(n) * 2^-24` of the sum of their magnitudes, a few 1e-7 per layer
here; over three layers, with tanh's slope at most 1, that is about 1e-6 on an action of
order 1 (measured: at most 2.4e-6, on Humanoid's 348 inputs; 0.7e-6 to 1.7e-6 on the
others). `ATOL = 1e-5` is four times the measurement and a thousand times below a
modelling difference (a missing observation clip or a dropped `1 / sqrt(w)` moves actions
by 1e-2 or more, checked below).
"""

import dataclasses
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from brax.training.acme import running_statistics, specs

from wcac_jax import algos, envs, networks
from wcac_jax.algos import ConditionedConfig, PaperConfig, PracticalConfig
from wcac_jax.evaluate import numpy_policy

ATOL = 1e-5
SMALL = dict(num_envs=4, rollout_steps=8, num_iterations=1, width=32, depth=2)


class _State(NamedTuple):
    """The fields `mean_action` reads (`runtime.assemble`)."""

    actor: networks.NetParams
    obs_stats: running_statistics.RunningStatisticsState


def _state(trainer, obs_size, key, gain):
    """Trained-looking parameters, so that some means leave `[-1, 1]` and are clipped and
    some do not: every trainable entry drawn from N(0, gain^2 / fan-in) (a layer's
    outputs then keep their inputs' scale, as a trained network's do), and statistics
    far from the identity."""
    key_init, key_params, key_mean, key_std = jax.random.split(key, 4)
    actor = trainer.policy.init(key_init)
    leaves, tree = jax.tree.flatten(actor.trainable)
    keys = jax.random.split(key_params, len(leaves))
    drawn = [
        jax.random.normal(k, x.shape, x.dtype) * gain / x.shape[0] ** 0.5
        for k, x in zip(keys, leaves, strict=True)
    ]
    actor = actor.replace(trainable=jax.tree.unflatten(tree, drawn))
    stats = running_statistics.init_state(specs.Array((obs_size,), jnp.float32))
    stats = stats.replace(
        mean=jax.random.normal(key_mean, (obs_size,)),
        std=jnp.exp(jax.random.normal(key_std, (obs_size,))),
    )
    return _State(actor, stats)


def _observations(obs_size, n=256, seed=0):
    """`[n, obs]`: a spread wide enough that some normalised entries pass `+-obs_clip`."""
    return np.random.default_rng(seed).normal(0.0, 8.0, (n, obs_size)).astype(np.float32)


# name: (environment, update, gain of the drawn weights: enough to clip some means)
CASES = {
    "practical": ("hopper-2obj", PracticalConfig(**SMALL), 2.0),
    "paper": ("hopper-2obj", PaperConfig(num_envs=4, width=32, depth=2), 4.0),
    "paper-mlp": ("hopper-2obj", PaperConfig(num_envs=4, width=32, depth=2, network="mlp"), 0.6),
    "humanoid": ("humanoid", PracticalConfig(**SMALL), 2.0),
}


@pytest.mark.parametrize("case", list(CASES))
def test_numpy_policy_equals_the_jax_policy(case):
    name, config, gain = CASES[case]
    env = envs.make(name)
    trainer = algos.make_trainer(config, env)
    state = _state(trainer, int(env.observation_size), jax.random.key(1), gain)
    obs = _observations(int(env.observation_size))
    theirs = np.asarray(jax.jit(trainer.mean_action)(state, obs))
    ours = numpy_policy.mean_action(numpy_policy.from_state(config, trainer, env, state), obs)
    assert ours.dtype == np.float32 and ours.shape == theirs.shape == (256, env.action_size)
    bound = getattr(env, "action_bound", 1.0)
    assert np.mean(np.abs(theirs) == bound) > 0.05  # some means are clipped
    assert np.mean(np.abs(theirs) < 0.9 * bound) > 0.05  # and some are not
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=ATOL)


def test_conditioned_numpy_policy_equals_the_jax_policy_at_each_preference():
    env = envs.make("hopper-2obj")
    config = ConditionedConfig(**SMALL)
    trainer = algos.make_trainer(config, env)
    raw = int(env.observation_size)
    state = _state(trainer, raw, jax.random.key(2), 2.0)
    obs = _observations(raw)
    actions = []
    for pref in ([1.0, 0.0], [0.3, 0.7]):
        theirs = np.asarray(algos.conditioned.policy_at(trainer, state, pref)(obs))
        policy = numpy_policy.from_state(config, trainer, env, state, pref=pref)
        ours = numpy_policy.mean_action(policy, obs)
        np.testing.assert_allclose(ours, theirs, rtol=0, atol=ATOL)
        actions.append(ours)
    assert np.abs(actions[0] - actions[1]).max() > 1e-2  # the preference matters


def test_a_modelling_difference_is_far_above_the_tolerance():
    """What `ATOL` must catch: the same policy without the observation clip, or without
    the paper network's `1 / sqrt(w)`, moves actions by far more than 1e-5."""
    env = envs.make("hopper-2obj")
    obs = _observations(int(env.observation_size))
    for _, config, gain in (CASES["practical"], CASES["paper"]):
        trainer = algos.make_trainer(config, env)
        state = _state(trainer, int(env.observation_size), jax.random.key(1), gain)
        policy = numpy_policy.from_state(config, trainer, env, state)
        right = numpy_policy.mean_action(policy, obs)
        if isinstance(config, PaperConfig):
            layers = tuple((k, b, a, 1.0) for k, b, a, _ in policy.layers)
            wrong = dataclasses.replace(policy, layers=layers)
        else:
            wrong = dataclasses.replace(policy, obs_clip=None)
        assert np.abs(numpy_policy.mean_action(wrong, obs) - right).max() > 1e-2


def test_the_network_layers_compute_apply():
    """`Network.layers` lists exactly what `apply` computes, for every network kind."""
    x = jax.random.normal(jax.random.key(0), (16, 5))
    built = {
        "paper": networks.paper_network(5, 3, 8, 2),
        "mlp": networks.mlp_network(5, 3, 8, 2),
        "tanh": networks.tanh_mlp(5, 3, 8, 2, 1.0),
    }
    acts = {"linear": lambda v: v, "relu": jax.nn.relu, "tanh": jnp.tanh}
    for kind, net in built.items():
        params = net.init(jax.random.key(1))
        h = x
        for layer in net.layers(params):
            h = layer.scale * acts[layer.activation](h @ layer.kernel + layer.bias)
        np.testing.assert_allclose(h, net.apply(params, x), rtol=1e-5, atol=1e-6, err_msg=kind)


def test_from_state_refuses_what_it_cannot_compute():
    env = envs.make("hopper-2obj")
    config = ConditionedConfig(**SMALL)
    trainer = algos.make_trainer(config, env)
    state = _state(trainer, int(env.observation_size), jax.random.key(2), 2.0)
    with pytest.raises(ValueError, match="preference"):
        numpy_policy.from_state(config, trainer, env, state)  # a conditioned one needs it
    bandit = envs.make("deep_sea_treasure")
    discrete = algos.make_trainer(PracticalConfig(**SMALL), bandit)
    with pytest.raises(ValueError, match="Gaussian"):
        numpy_policy.from_state(PracticalConfig(**SMALL), discrete, bandit, state)
