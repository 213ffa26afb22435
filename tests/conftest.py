"""Shared test setup: float32 CPU, and compiled programs shared per session via fixtures."""

import os

import pytest

os.environ.setdefault("JAX_PLATFORMS", "cpu")
# `python -m wcac_jax.sweep` gives XLA one host device per core unless XLA_FLAGS is set:
# tests that run it in a subprocess compare it with in-process (one-device) runs, so they
# get one device unless they ask for more
os.environ.setdefault("XLA_FLAGS", "--xla_force_host_platform_device_count=1")


@pytest.fixture(scope="module")
def jax_cache(tmp_path_factory):
    """The environment of a subprocess that keeps every compiled program in a JAX
    persistent compilation cache, one directory per test module
    (`JAX_COMPILATION_CACHE_DIR`)."""
    return {
        "JAX_COMPILATION_CACHE_DIR": str(tmp_path_factory.mktemp("jax-cache")),
        "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS": "0",
        "JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES": "-1",
    }
