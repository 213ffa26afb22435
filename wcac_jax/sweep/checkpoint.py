"""A sweep's checkpoint: host pytrees (its state and metrics) saved and restored with
orbax, in `<out>/checkpoint/`, keeping the latest step only.

Leaves are stored by position, and empty ones not at all: orbax cannot save zero-size
arrays (such as MJX's actuator activations of a model without activation dynamics), so a
restore takes them from its template. Only process 0 saves (host arrays, no barrier).
"""

from __future__ import annotations

import os

import jax
import numpy as np


def manager(out: str):
    """The orbax `CheckpointManager` of the sweep in `out` (creates `out/checkpoint/`)."""
    import orbax.checkpoint as ocp

    extra = {}
    if jax.process_count() > 1:  # process 0 alone saves
        extra["multiprocessing_options"] = ocp.options.MultiprocessingOptions(
            primary_host=0, active_processes={0}
        )
    path = os.path.abspath(os.path.join(out, "checkpoint"))
    os.makedirs(path, exist_ok=True)  # orbax can't create it when only process 0 saves
    options = ocp.CheckpointManagerOptions(
        max_to_keep=1, create=False, enable_async_checkpointing=False, **extra
    )
    return ocp.CheckpointManager(path, options=options)


def save(mgr, step: int, tree) -> None:
    """Saves the host pytree `tree` as `step`, and waits until it is written."""
    import orbax.checkpoint as ocp

    mgr.save(step, args=ocp.args.StandardSave(_by_position(tree)))
    mgr.wait_until_finished()


def restore(mgr, template):
    """The latest step's pytree, shaped like `template` (numpy leaves); the template's
    empty leaves as they are."""
    import orbax.checkpoint as ocp

    saved = mgr.restore(mgr.latest_step(), args=ocp.args.StandardRestore(_by_position(template)))
    leaves, treedef = jax.tree.flatten(template)
    return jax.tree.map(
        np.asarray, treedef.unflatten([saved.get(str(i), x) for i, x in enumerate(leaves)])
    )


def _by_position(tree) -> dict:
    # numpy leaves (a pytree such as Brax's UInt64 turns numpy back into jax arrays when
    # rebuilt, and orbax refuses a host-local jax array once several processes run)
    leaves = jax.tree.leaves(tree)
    return {str(i): np.asarray(x) for i, x in enumerate(leaves) if np.size(x) > 0}
