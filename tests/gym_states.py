"""States of MO-Gymnasium's mo-walker2d-v5 to compare our Walker2d against (shared by the
MJX and the MuJoCo-engine conformance tests)."""

import numpy as np
import pytest


def gymnasium_states(n_states, seed=0, float32_actions=False):
    """States (float64 qpos, qvel) and actions from random-action rollouts of
    mo-walker2d-v5, continuing a few steps past each fall so states beyond the healthy
    limits appear. `float32_actions`: actions representable in float32 (for an exact
    float64 comparison). Returns `(env, states, actions)`."""
    mo_gym = pytest.importorskip("mo_gymnasium")
    genv = mo_gym.make("mo-walker2d-v5")
    rng = np.random.default_rng(seed)
    genv.reset(seed=seed)
    states, actions, past_fall = [], [], 0
    while len(states) < n_states:
        action = rng.uniform(-1.0, 1.0, 6)
        if float32_actions:
            action = action.astype(np.float32).astype(np.float64)
        data = genv.unwrapped.data
        states.append((data.qpos.copy(), data.qvel.copy()))
        actions.append(action)
        _, _, terminated, _, _ = genv.step(action)
        past_fall += bool(terminated) or past_fall > 0
        if past_fall > 5:
            genv.reset(seed=int(rng.integers(1 << 30)))
            past_fall = 0
    return genv, states, actions
