"""`examples/` and the README's Python snippets run, at tiny sizes: each script as a user
runs it (a process of its own, with `--tiny`), the README's code as written (the
Walker2d sweep made tiny through `default_sweep`)."""

import ast
import functools
import os
import re
import subprocess
import sys

from wcac_jax import sweep

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXAMPLES = os.path.join(ROOT, "examples")
SCRIPTS = sorted(f for f in os.listdir(EXAMPLES) if f.endswith(".py"))
# what an example may import: the library's public modules, and what any user has
PUBLIC = {"wcac_jax", "wcac_jax.sweep", "wcac_jax.envs"}
OTHERS = {"sys", "jax", "jax.numpy", "numpy"}


def test_five_or_six_short_scripts_over_the_public_api():
    assert 5 <= len(SCRIPTS) <= 6
    for name in SCRIPTS:
        source = open(os.path.join(EXAMPLES, name)).read()
        assert 20 <= len(source.splitlines()) <= 40, name
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.ImportFrom):
                assert node.module in PUBLIC | OTHERS, (name, node.module)
            elif isinstance(node, ast.Import):
                assert {a.name for a in node.names} <= OTHERS, name


def _run(jax_cache, name, *args):
    """`python examples/NAME --tiny ARGS`: its output, after checking it succeeded."""
    done = subprocess.run(
        [sys.executable, os.path.join(EXAMPLES, name), "--tiny", *args],
        capture_output=True,
        text=True,
        env={**os.environ, **jax_cache},
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_the_bandit_front(jax_cache):
    out = _run(jax_cache, "bandit_front.py")
    assert len(re.findall(r"^p = \[.*\]: rewards \(", out, flags=re.M)) == 11
    assert re.search(r"^\d+ distinct non-dominated points of 11$", out, flags=re.M)


def test_the_first_command_from_python_then_a_rollout_of_its_policies(jax_cache, tmp_path):
    out = str(tmp_path / "run")
    swept = _run(jax_cache, "walker2d_sweep.py", out)
    assert "256 env steps per preference" in swept  # the progress hook's last call
    assert len(re.findall(r"^p = \[.*\]: -?\d+\.\d+ m/s", swept, flags=re.M)) == 3
    rolled = _run(jax_cache, "load_and_rollout.py", out)
    lengths = [int(n) for n in re.findall(r"over (\d+) steps", rolled)]
    assert len(lengths) == 3 and all(1 <= n <= 50 for n in lengths)


def test_a_scalarization_of_ones_own(jax_cache):
    out = _run(jax_cache, "custom_scalarization.py")
    assert len(re.findall(r"^p = \[.*\]: rewards \[.*\], weights \[", out, flags=re.M)) == 5


def test_the_conditioned_network_at_a_chosen_preference(jax_cache, tmp_path):
    out = _run(jax_cache, "conditioned_policy.py", str(tmp_path / "run"))
    assert "evaluated at [[1.0, 0.0], [0.75, 0.25]" in out
    assert re.search(r"at p = \[0.3, 0.7\] the network pulls the arm at \d\.\d+ rad", out)


def test_a_task_of_ones_own(jax_cache):
    out = _run(jax_cache, "own_environment.py")
    assert out.startswith("no tuned defaults for this environment")
    assert len(re.findall(r"^p = \[.*\]: distance -?\d", out, flags=re.M)) == 5


# the Walker2d sweep of the README's snippet, at the examples' tiny size
TINY_WALKER = dict(num_envs=4, rollout_steps=16, num_minibatches=4, width=16, depth=1)
TINY_WALKER |= dict(steps_per_pref=128, eval_episodes=1, env_options={"episode_length": 20})


def test_the_readme_python_snippets_run(tmp_path, monkeypatch):
    """The README's Python blocks, in order and as written, in one namespace; the
    sweep's `default_sweep` resolves its defaults and then the tiny sizes over them."""
    readme = open(os.path.join(ROOT, "README.md")).read()
    blocks = re.findall(r"```python\n(.*?)```", readme, flags=re.S)
    assert len(blocks) == 2
    monkeypatch.chdir(tmp_path)
    tiny = functools.partial(sweep.default_sweep, **TINY_WALKER)
    monkeypatch.setattr(sweep, "default_sweep", tiny)
    namespace = {}
    for block in blocks:
        exec(compile(block, "README.md", "exec"), namespace)
    assert namespace["metrics"]["train/j_hat"].shape == (3, 600, 2)
    assert len(namespace["front"]["prefs"]) == 9
    assert namespace["action"].shape == (6,)
