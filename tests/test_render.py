"""`render.make_rollout` on a hand-computed environment; `render.render`'s input check.

(The frames themselves need an OpenGL platform chosen before `mujoco` is imported, so
they are drawn in a subprocess: `test_experiments.py::test_walker2d_front_tiny` films
its tiny front with `experiments/walker2d_film.py`.)
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from brax.envs.base import State

from wcac_jax import envs
from wcac_jax.evaluate import render


class _Data(NamedTuple):
    qpos: jax.Array


class _Line:
    """`qpos [2]` moves by the action each step; it falls (done) once `qpos[0] >= 3`."""

    def reset(self, key):
        del key
        q = jnp.zeros(2)
        return State(_Data(q), q, jnp.zeros(2), jnp.zeros(()), {})

    def step(self, state, action):
        q = state.pipeline_state.qpos + action
        return state.replace(pipeline_state=_Data(q), obs=q, done=(q[0] >= 3).astype(float))


class _Constant(NamedTuple):
    """A 'trainer' whose deterministic policy takes the state's constant action."""

    @staticmethod
    def mean_action(state, obs):
        del obs
        return state["action"]


def test_rollout_holds_the_fallen_pose_and_counts_the_steps():
    rollout = jax.jit(jax.vmap(render.make_rollout(_Constant(), _Line(), steps=5)))
    state = {"action": jnp.array([[1.0, 0.5], [0.5, 1.0]])}  # two 'preferences'
    qpos, length, fell = rollout(state, jax.random.split(jax.random.key(0), 2))
    assert qpos.shape == (2, 6, 2) and length.shape == fell.shape == (2,)
    # the first falls on step 3 (qpos[0] reaches 3) and is held there
    np.testing.assert_allclose(
        qpos[0], [[0, 0], [1, 0.5], [2, 1], [3, 1.5], [3, 1.5], [3, 1.5]], rtol=0
    )
    # the second reaches 2.5 after 5 steps and never falls
    np.testing.assert_allclose(qpos[1], [[0.5 * t, 1.0 * t] for t in range(6)], rtol=0)
    np.testing.assert_array_equal(length, [3, 5])
    np.testing.assert_array_equal(fell, [True, False])
    # falling on the last step: all steps counted, and it fell
    qpos, length, fell = jax.jit(render.make_rollout(_Constant(), _Line(), steps=3))(
        {"action": jnp.array([1.0, 0.0])}, jax.random.key(1)
    )
    assert int(length) == 3 and bool(fell)
    np.testing.assert_allclose(qpos[:, 0], [0, 1, 2, 3], rtol=0)


def _walker():
    return envs.make("walker2d", physics="gymnasium-v5", engine="mujoco")


def test_render_checks_the_positions_shape():
    with pytest.raises(ValueError, match=r"qpos must be \[T, 9\], got shape \(4, 7\)"):
        render.render(_walker(), np.zeros((4, 7)))


def test_render_asks_the_environment_for_its_scene():
    """The model and camera come from the environment's hook: the hopper's model has 6
    positions, the walker's 9; an environment without a hook has nothing to draw."""
    scene = _walker().render_scene()
    assert scene.model.nq == 9 and scene.track_body == "torso"
    with pytest.raises(ValueError, match=r"qpos must be \[T, 6\], got shape \(2, 9\)"):
        render.render(envs.make("hopper"), np.zeros((2, 9)))
    with pytest.raises(ValueError, match="ConcaveBandit has nothing to render"):
        render.render(envs.make("concave_bandit"), np.zeros((2, 1)))
    with pytest.raises(ValueError, match="_Line has nothing to render"):
        render.render(_Line(), np.zeros((2, 2)))


def test_render_says_when_there_is_no_opengl_context(monkeypatch):
    """Whatever MuJoCo raises when it can't make a context (it depends on the platform)
    becomes one RuntimeError naming `MUJOCO_GL`."""
    import mujoco

    def no_context(*args):
        raise AttributeError("module 'gl_context' has no attribute 'GLContext'")

    monkeypatch.setattr(mujoco, "Renderer", no_context)
    monkeypatch.setenv("MUJOCO_GL", "disable")
    with pytest.raises(RuntimeError, match=r"no OpenGL context \(MUJOCO_GL='disable'.*GLContext"):
        render.render(_walker(), np.zeros((2, 9)))
