"""A whole Pareto front in one compiled program: `run_sweep` (`python -m wcac_jax.sweep`,
or `wcac-sweep`, is its command line, `wcac_jax.cli`).

All preferences (and their `N` environments each) train in ONE compiled program,
`jit(vmap(chunk))` over the preference axis, with keys and preferences as traced
arguments. This package is the one impure edge of `wcac_jax`: it owns the host loop
over chunks, the orbax checkpoints after every chunk, the progress report, the clocks
and every file written.

Chunking does not change the numbers: iteration `t` of preference `i` draws its
randomness from `fold_in(fold_in(key(seed), i), t)`, and every chunk is the same
compiled program of `ceil(T / chunks)` iterations whose iterations past a call's stop
leave the state untouched (so a chunk may also run as several calls, as the progress bar
asks). `--resume` restores the last checkpoint and continues bit for bit.

Devices: the preference axis is split over every device (a 1-D mesh whose axis is
`utopia.DEVICE_AXIS`), and each device runs the vmapped program on its own preferences
(`jax.shard_map`); a preference count that does not divide evenly is padded by repeating
the last preference, and the padding is dropped from the results. Several processes
(`wcac_jax.distributed`; `--coordinator` on the command line): the mesh spans every
process's devices, each process runs its shards, and only process 0 reads and writes
`out`.

Modules: `defaults` (`default_sweep`: the library's defaults resolved into a
`SweepConfig`), `config` (`SweepConfig` and the checks of a sweep's input), `training` (the
compiled programs, and the only imports of the training modules), `run` (`run_sweep`'s
steps), `progress` (the bar and the log lines), `load` (`load_sweep`); the files a sweep
writes are `wcac_jax.outputs` and `wcac_jax.checkpoint`, the choice among its last
policies `wcac_jax.selection`.
"""

from wcac_jax.outputs import staging_dir
from wcac_jax.presets import PAPER_PREFS
from wcac_jax.sweep.conditioned import run_conditioned
from wcac_jax.sweep.config import (
    MAX_ITERATIONS,
    PAPER_STEPS_PER_PREF,
    SweepConfig,
    SweepError,
    check_output_dir,
    default_hv_ref,
    make_env,
    read_config,
    validate_prefs,
)
from wcac_jax.sweep.defaults import default_sweep
from wcac_jax.sweep.load import LoadedSweep, load_sweep
from wcac_jax.sweep.run import TrainingDiverged, check_pref_count, run_sweep
from wcac_jax.sweep.training import make_chunk

__all__ = [
    "MAX_ITERATIONS",
    "PAPER_PREFS",
    "PAPER_STEPS_PER_PREF",
    "LoadedSweep",
    "SweepConfig",
    "SweepError",
    "TrainingDiverged",
    "check_output_dir",
    "check_pref_count",
    "default_hv_ref",
    "default_sweep",
    "load_sweep",
    "make_chunk",
    "make_env",
    "read_config",
    "run_conditioned",
    "run_sweep",
    "staging_dir",
    "validate_prefs",
]
