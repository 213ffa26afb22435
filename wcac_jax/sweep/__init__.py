"""A whole Pareto front in one compiled program: `run_sweep` (`python -m wcac_jax.sweep`,
or `wcac-sweep`, is its command line, `wcac_jax.sweep.cli`).

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
(`wcac_jax.sweep.distributed`; `--coordinator` on the command line): the mesh spans every
process's devices, each process runs its shards, and only process 0 reads and writes
`out`.

Modules: `cli` (the command line), `presets` (named configurations and each
environment's default), `defaults` (`default_sweep`: the library's defaults resolved into
a `SweepConfig`), `config` (`SweepConfig` and the checks of a sweep's input), `protocol`
and `conditioned` (a sweep under a benchmark protocol; the preference-conditioned run),
`training` (the compiled programs), `run` (`run_sweep`'s steps), `selection` (the choice
among a preference's last policies), `progress` (the bar and the log lines),
`distributed` (several processes), `outputs` and `checkpoint` (the files a sweep writes),
`load` (`load_sweep`) and `plot` (figures from saved results).

Every name loads on first use (PEP 562), so that the host's file helpers
(`wcac_jax.sweep.outputs`) load without the training modules.
"""

import importlib

# name -> the module that defines it
_NAMES = {
    "MAX_ITERATIONS": "config",
    "PAPER_STEPS_PER_PREF": "config",
    "SweepConfig": "config",
    "SweepError": "config",
    "check_output_dir": "config",
    "default_hv_ref": "config",
    "make_env": "config",
    "read_config": "config",
    "validate_prefs": "config",
    "PAPER_PREFS": "presets",
    "run_conditioned": "conditioned",
    "default_sweep": "defaults",
    "LoadedSweep": "load",
    "load_sweep": "load",
    "TrainingDiverged": "run",
    "check_pref_count": "run",
    "run_sweep": "run",
    "make_chunk": "training",
    "staging_dir": "outputs",
}
_MODULES = (
    "checkpoint",
    "cli",
    "conditioned",
    "config",
    "defaults",
    "distributed",
    "load",
    "outputs",
    "plot",
    "presets",
    "progress",
    "protocol",
    "run",
    "selection",
    "training",
)


def __getattr__(name: str):
    if name in _MODULES:
        return importlib.import_module(f"{__name__}.{name}")
    if name in _NAMES:
        return getattr(importlib.import_module(f"{__name__}.{_NAMES[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *_NAMES, *_MODULES})


__all__ = sorted(_NAMES)
