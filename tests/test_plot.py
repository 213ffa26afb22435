"""Plots and the notebook, from a tiny saved sweep (they never train)."""

import os
import warnings

import matplotlib

matplotlib.use("Agg")

import nbformat  # noqa: E402
import pytest  # noqa: E402
from nbclient import NotebookClient  # noqa: E402
from sweep_args import TINY_BANDIT  # noqa: E402

from wcac_jax import plot, sweep  # noqa: E402
from wcac_jax.sweep import cli

TINY = [*TINY_BANDIT, "--n-prefs", "5"]
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("plots")
    out = {}
    for scal in ("smooth_wc", "linear"):
        config = cli.config_from_args(
            cli.build_parser().parse_args([*TINY, "--scalarization", scal])
        )
        out[scal] = str(base / scal)
        sweep.run_sweep(config, out[scal], chunks=1, progress=False)
    return out


def _save_without_warnings(fig, path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fig.savefig(path)
    plot.plt.close(fig)
    assert os.path.getsize(path) > 1000


def test_front_plot_single_and_overlaid(runs, tmp_path):
    _save_without_warnings(plot.plot_front(runs["smooth_wc"], rays=True), tmp_path / "one.png")
    fig = plot.plot_front([runs["smooth_wc"], runs["linear"]], labels=["smooth_wc", "linear"])
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert any(t.startswith("smooth_wc") for t in labels)
    assert any(t.startswith("linear") for t in labels)
    _save_without_warnings(fig, tmp_path / "two.png")


def test_curves_and_weights(runs, tmp_path):
    fig = plot.plot_curves(runs["smooth_wc"], smooth=3)
    assert len(fig.axes) == 2 and len(fig.axes[0].lines) == 5
    _save_without_warnings(fig, tmp_path / "curves.png")
    _save_without_warnings(plot.plot_weights(runs["smooth_wc"]), tmp_path / "weights.png")


def test_notebook_executes_headlessly(runs):
    path = os.path.join(ROOT, "notebooks", "pareto_front.ipynb")
    nb = nbformat.read(path, as_version=4)
    params = [c for c in nb.cells if "parameters" in c.metadata.get("tags", [])]
    assert len(params) == 1
    params[0].source = f"RUN = {runs['smooth_wc']!r}"
    NotebookClient(
        nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": ROOT}}
    ).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.output_type == "error"]
    assert any("image/png" in o.get("data", {}) for o in outputs)


def test_three_objective_front_as_pairwise_projections(tmp_path):
    """A 3-objective front.json (made up here, no training) is drawn as its three
    projections coloured by preference, and a simplex of the preferences."""
    import numpy as np

    from wcac_jax import pareto

    prefs = pareto.preference_lattice(3, 10)
    returns = 100 * prefs + np.random.default_rng(0).normal(0, 5, prefs.shape)
    front = {
        "env": "hopper",
        "objective_names": ["forward_velocity", "height", "control"],
        "hypervolume": 1.0,
        "prefs": [
            {"pref": p.tolist(), "return": r.tolist()} for p, r in zip(prefs, returns, strict=True)
        ],
    }
    fig = plot.plot_front(front)
    assert len(fig.axes) == 4
    assert fig.axes[0].get_xlabel().startswith("forward_velocity")
    assert fig.axes[2].get_ylabel().startswith("control")
    filled = fig.axes[0].collections[1]  # the non-dominated points, coloured by preference
    n = int(pareto.nondominated(returns).sum())
    assert len(filled.get_offsets()) == n and n >= 3
    np.testing.assert_allclose(filled.get_facecolors()[:, :3], prefs[pareto.nondominated(returns)])
    _save_without_warnings(fig, tmp_path / "three.png")
    with pytest.raises(ValueError, match="3 objectives"):
        plot.plot_front_3d({"prefs": [{"pref": [1.0, 0.0], "return": [1.0, 2.0]}]})
