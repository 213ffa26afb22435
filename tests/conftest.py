"""Shared test setup: float32 CPU, and compiled programs shared per session via fixtures."""

import os

os.environ.setdefault("JAX_PLATFORMS", "cpu")
# `python -m wcac_jax.sweep` gives XLA one host device per core unless XLA_FLAGS is set:
# tests that run it in a subprocess compare it with in-process (one-device) runs, so they
# get one device unless they ask for more
os.environ.setdefault("XLA_FLAGS", "--xla_force_host_platform_device_count=1")
