"""The sweep's own utopia estimate (`wcac_jax.core.utopia`) under vmap, by hand."""

import os
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np

from wcac_jax import utopia

J_HAT = jnp.array([[1.0, 5.0], [3.0, 2.0], [2.0, 4.0]])  # three preferences, two objectives


def _estimate(state, j_hat):
    return jax.vmap(
        lambda s, j: utopia.estimate(s, j, margin=0.5, min_spread=2.5),
        axis_name=utopia.PREF_AXIS,
    )(state, j_hat)


def _init(p):
    return jax.vmap(lambda _: utopia.init(2))(jnp.arange(p))


def test_shared_estimate_by_hand():
    state, z = jax.jit(_estimate)(_init(3), J_HAT)
    # best = max_p = (3, 5); spread = best - min_p = (2, 3), floored at 2.5: (2.5, 3)
    # z = best + 0.5 * spread = (4.25, 6.5), the same for every preference
    np.testing.assert_allclose(z, [[4.25, 6.5]] * 3)
    np.testing.assert_allclose(state.best, [[3.0, 5.0]] * 3)
    # a worse iteration keeps the best so far and widens the spread: min_p = (0, 0)
    state, z = jax.jit(_estimate)(state, jnp.zeros((3, 2)))
    np.testing.assert_allclose(z, [[4.5, 7.5]] * 3)  # (3 + .5 * 3, 5 + .5 * 5)


def test_padding_with_duplicates_changes_nothing():
    padded = jnp.concatenate([J_HAT, J_HAT[-1:], J_HAT[-1:]])
    _, z = jax.jit(_estimate)(_init(5), padded)
    np.testing.assert_allclose(z, [[4.25, 6.5]] * 5)


def test_chunk_invariant_one_scan_equals_two_calls():
    steps = jnp.stack([J_HAT, jnp.zeros((3, 2)), J_HAT + 1.0])  # [T, P, m]

    def run(state, js):
        return jax.lax.scan(
            lambda s, j: jax.vmap(
                lambda si, ji: utopia.estimate(si, ji, margin=0.5, min_spread=2.5),
                axis_name=utopia.PREF_AXIS,
            )(s, j),
            state,
            js,
        )

    whole_state, whole_z = jax.jit(run)(_init(3), steps)
    part_state, z1 = jax.jit(run)(_init(3), steps[:1])
    part_state, z2 = jax.jit(run)(part_state, steps[1:])
    np.testing.assert_array_equal(whole_z, jnp.concatenate([z1, z2]))
    np.testing.assert_array_equal(whole_state.best, part_state.best)
    np.testing.assert_allclose(whole_state.best[0], [4.0, 6.0])


# the sweep splits the preferences over devices (`jax.shard_map` on `DEVICE_AXIS`); the
# estimate must still see every preference. Two host devices need a fresh JAX: a subprocess.
_TWO_DEVICES = """
import jax, jax.numpy as jnp
from jax.sharding import PartitionSpec as P
from wcac_jax import utopia
assert jax.device_count() == 2
mesh = jax.make_mesh((2,), (utopia.DEVICE_AXIS,), axis_types=(jax.sharding.AxisType.Auto,))
j_hat = jnp.array([[1.0, 5.0], [3.0, 2.0], [2.0, 4.0], [2.0, 4.0]])  # 4 = 3 + 1 padding
state = jax.vmap(lambda _: utopia.init(2))(jnp.arange(4))
f = jax.vmap(lambda s, j: utopia.estimate(s, j, margin=0.5, min_spread=2.5),
             axis_name=utopia.PREF_AXIS)
spec = P(utopia.DEVICE_AXIS)
state, z = jax.jit(jax.shard_map(f, mesh=mesh, in_specs=spec, out_specs=spec,
                                  check_vma=False))(state, j_hat)
print(z.tolist(), state.best.tolist())
"""


def test_shared_across_devices_by_hand():
    env = dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=2")
    run = subprocess.run(
        [sys.executable, "-c", _TWO_DEVICES], env=env, capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0, run.stderr
    # as test_shared_estimate_by_hand: preferences 0-1 on one device, 2-3 on the other
    assert run.stdout.strip() == f"{[[4.25, 6.5]] * 4} {[[3.0, 5.0]] * 4}", run.stdout
