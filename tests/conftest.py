"""Shared test setup: float32 CPU, and compiled programs shared per session via fixtures."""

import os

os.environ.setdefault("JAX_PLATFORMS", "cpu")
