"""The table's bootstrap and its reading as a share of the Behavior-Clone -> oracle gap,
against hand-computed values on tiny cases."""

import numpy as np
import pytest

from wcac_jax.recsys import stats


def test_draw_counts_every_row_once_per_draw_and_seeds_in_range():
    d = stats.draw(np.random.default_rng(0), n_rows=7, n_seeds=3, n_boot=50)
    assert d.counts.shape == (50, 7) and d.seeds.shape == (50, 3)
    np.testing.assert_array_equal(d.counts.sum(axis=1), 7)
    assert d.seeds.min() >= 0 and d.seeds.max() <= 2


def test_ncis_replicates_hand_computed():
    """Two rows, weights (1, 3), rewards (1, 0); one seed. All rows once: 1 / 4; row 0
    twice: 2 / 2 = 1; row 1 twice: 0."""
    w = np.array([[1.0, 3.0]])
    wr = (w * np.array([1.0, 0.0]))[..., None]
    d = stats.Draws(np.array([[1.0, 1.0], [2.0, 0.0], [0.0, 2.0]]), np.zeros((3, 1), int))
    np.testing.assert_allclose(stats.ncis_replicates([w], [wr], [d])[:, 0], [0.25, 1.0, 0.0])


def test_seed_draws_and_data_sets_are_averaged():
    """Two seeds with means 1 and 3 on one data set: drawing (0, 0) gives 1, (0, 1) gives 2;
    a second data set with the value 10 everywhere averages in with weight 1/2. A method
    with one seed (the oracle) takes it whatever the draw."""
    v1 = np.array([[[1.0], [1.0]], [[3.0], [3.0]]])  # [S=2, n=2, 1]
    v2 = np.full((2, 2, 1), 10.0)
    d = stats.Draws(np.ones((2, 2)), np.array([[0, 0], [0, 1]]))
    got = stats.mean_replicates([v1, v2], [d, d])[:, 0]
    np.testing.assert_allclose(got, [(1 + 10) / 2, (2 + 10) / 2])
    one = np.array([[[5.0], [7.0]]])  # [S=1, n=2, 1]
    np.testing.assert_allclose(stats.mean_replicates([one], [d])[:, 0], [6.0, 6.0])
    np.testing.assert_allclose(stats.point([v1.mean(axis=1), v2.mean(axis=1)]), [(2 + 10) / 2])


def test_interval_relative_gap_and_verdict_hand_computed():
    np.testing.assert_allclose(stats.ci95(np.arange(101.0)), [2.5, 97.5])
    np.testing.assert_allclose(
        stats.relative(np.array([1.5, 1.0]), np.array([1.0, -2.0])), [50.0, 150.0]
    )
    assert np.isnan(stats.relative(np.array([1.0]), np.array([0.0]))[0])
    assert stats.gap_share(1.5, 1.0, 3.0) == pytest.approx(0.25)
    assert stats.verdict((0.1, 2.0)) == "better"
    assert stats.verdict((-2.0, -0.1)) == "worse"
    assert stats.verdict((-0.1, 0.1)) == "n.s."
