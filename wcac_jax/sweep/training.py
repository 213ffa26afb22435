"""The compiled programs of a sweep: `make_chunk`, the unit of its host loop, and
`build_programs`, its init/chunk/evaluate programs laid out over the devices.

The updates themselves come from `wcac_jax.algos` (by configuration) and what they share
from `wcac_jax.core.runtime`.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax
import jax.extend
import jax.numpy as jnp
from jax.sharding import PartitionSpec as P

from wcac_jax.algos import UpdateConfig, make_evaluate, make_trainer
from wcac_jax.core.runtime import Trainer
from wcac_jax.core.utopia import DEVICE_AXIS, PREF_AXIS


def make_chunk(trainer: Trainer, chunk_len: int):
    """`chunk(state, stop, pref[, direction]) -> (state, metrics [chunk_len, ...])`:
    `chunk_len` iterations of `trainer.step` (given the optional traced index `direction`
    into `TRACED_DIRECTIONS`), to be called under `jax.vmap(..., axis_name=PREF_AXIS)`.

    Iterations at or past `stop` (a traced int32, the same for every preference: the
    sweep's last iteration, or the next one whose policy `wcac_jax.sweep.selection` keeps) leave
    the state as it is and give zero metrics, and cost nothing: every preference is at
    the same iteration, so the predicate is reduced over the preference axis to ONE
    scalar and `cond` runs one branch. (A per-preference predicate would be batched, and
    `vmap` turns a batched `cond` into a `select` that runs both branches: the padding
    was trained in full and thrown away.)
    """

    def chunk(state, stop, pref, *direction):
        def body(state, _):
            active = jax.lax.pmin(state.iteration - stop, PREF_AXIS) < 0
            # the step traced once (slow for MJX): `cond` replays its jaxpr, and a skipped
            # iteration gives zeros of the shapes that trace found
            jaxpr, shapes = jax.make_jaxpr(
                lambda s, p: trainer.step(s, p, *direction), return_shape=True
            )(state, pref)
            replay = jax.extend.core.jaxpr_as_fun(jaxpr)
            tree = jax.tree.structure(shapes)
            return jax.lax.cond(
                active,
                lambda s, p: tree.unflatten(replay(*jax.tree.leaves((s, p)))),
                lambda s, p: (s, jax.tree.map(lambda x: jnp.zeros(x.shape, x.dtype), shapes[1])),
                state,
                pref,
            )

        return jax.lax.scan(body, state, None, length=chunk_len)

    return chunk


class Programs(NamedTuple):
    """A sweep's jitted programs; every argument and result carries the preference axis
    first (`[P', ...]`, `P'` the preferences with their padding), sharded over the mesh.

    Attributes:
      init: `(keys [P', 2] uint32, prefs [P', m]) -> state`.
      chunk: `(state, stop [P'] int32, prefs [P', m][, direction [P'] int32]) ->
        (state, metrics [P', chunk_len, ...])`, the state donated (`make_chunk`).
      evaluate: `(state, keys [P', 2] uint32) -> {"eval/return" [P', m], ...}`.
    """

    init: Any
    chunk: Any
    evaluate: Any


def build_programs(
    train: UpdateConfig,
    env,
    mesh: jax.sharding.Mesh,
    chunk_len: int,
    eval_episodes: int,
    network_factory=None,
) -> Programs:
    """The `Programs` of `train` on `env`, each device running the vmapped program on its
    own preferences.

    Every leaf of the state and metrics carries the preference axis first; each device
    runs the vmapped program on its own preferences (`shard_map`), so host callbacks
    (MuJoCo's C engine) step each device's environments where they are, in every
    process. The preference axis is named so that a trainer may share values across it
    (the practical update's estimated utopia point, `wcac_jax.core.utopia`, which spans the
    device axis too). `network_factory`: the update's networks (`make_trainer`).
    """
    trainer = make_trainer(train, env, network_factory)
    chunk = make_chunk(trainer, chunk_len)

    # (`check_vma=False`: values computed from constants, e.g. an episode's first flags,
    # are the same on every device, and the scan's carry types must not tell them apart)
    def per_device(f):
        spec = P(DEVICE_AXIS)
        return jax.shard_map(f, mesh=mesh, in_specs=spec, out_specs=spec, check_vma=False)

    init = jax.jit(per_device(jax.vmap(lambda k, p: trainer.init(jax.random.wrap_key_data(k), p))))
    chunk_fn = jax.jit(per_device(jax.vmap(chunk, axis_name=PREF_AXIS)), donate_argnums=0)
    evaluate_one = make_evaluate(train, env, eval_episodes, trainer)
    evaluate = jax.jit(
        per_device(jax.vmap(lambda s, k: evaluate_one(s, jax.random.wrap_key_data(k))))
    )
    return Programs(init, chunk_fn, evaluate)


def state_bytes(train: UpdateConfig, env) -> int:
    """Bytes of one preference's training state (`trainer.init`'s, shapes only: nothing
    is initialised)."""
    trainer = make_trainer(train, env)
    m = int(env.num_objectives)
    shapes = jax.eval_shape(
        trainer.init, jax.random.key(0), jax.ShapeDtypeStruct((m,), jnp.float32)
    )
    return sum(x.size * x.dtype.itemsize for x in jax.tree.leaves(shapes))
