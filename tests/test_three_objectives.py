"""Three objectives on the command line: `--n-prefs` gives the full, even lattice, refuses
a count that makes none (naming the nearest), and the default is the smallest lattice with
at least the default count; two objectives keep their evenly spaced points. No training
(`python -m wcac_jax.sweep --env hopper --n-prefs 3 --steps-per-pref 20000` runs in about
two minutes on the 2-core CPU; it is checked by hand, not here)."""

import numpy as np
import pytest

from wcac_jax import pareto, presets
from wcac_jax.sweep import cli


def _config(*args):
    return cli.config_from_args(cli.build_parser().parse_args(list(args)))


def test_n_prefs_on_three_objectives():
    corners = _config("--env", "hopper", "--n-prefs", "3")
    np.testing.assert_array_equal(corners.prefs, np.eye(3))
    six = np.array(_config("--env", "ant", "--n-prefs", "6").prefs)
    assert six.shape == (6, 3)
    np.testing.assert_allclose(six * 2, np.round(six * 2))  # steps of 1/2
    default = _config("--env", "hopper").prefs
    assert presets.DEFAULT_N_PREFS == 9 and len(default) == 10
    with pytest.raises(cli.SweepError, match=r"--n-prefs: 9 preferences .* 6 or 10"):
        _config("--env", "hopper", "--n-prefs", "9")


def test_two_objectives_unchanged():
    for n in (2, 5, 9):
        prefs = np.array(_config("--env", "hopper-2obj", "--n-prefs", str(n)).prefs)
        np.testing.assert_array_equal(prefs, pareto.simplex_lattice(2, n))
