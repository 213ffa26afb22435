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


def test_set_replicates_resample_data_sets_then_seeds_by_hand():
    """Two data sets with per-seed values (1, 3) and (10, 30): drawing set 1 twice, with
    seeds (0, 1) and (1, 1), gives the mean of (10 + 30) / 2 and 30; set 0 with seeds
    (0, 0) then set 1 with (1, 0) the mean of 1 and (30 + 10) / 2. A one-seed method (the
    oracle) takes its value whatever seed is drawn."""
    per_seed = [np.array([[1.0], [3.0]]), np.array([[10.0], [30.0]])]
    d = stats.SetDraws(
        sets=np.array([[1, 1], [0, 1]]), seeds=np.array([[[0, 1], [1, 1]], [[0, 0], [1, 0]]])
    )
    np.testing.assert_allclose(stats.set_replicates(per_seed, d)[:, 0], [25.0, 10.5])
    one = [np.array([[5.0]]), np.array([[7.0]])]
    np.testing.assert_allclose(stats.set_replicates(one, d)[:, 0], [7.0, 6.0])
    drawn = stats.draw_sets(np.random.default_rng(0), n_sets=3, n_seeds=5, n_boot=40)
    assert drawn.sets.shape == (40, 3) and drawn.seeds.shape == (40, 3, 5)
    assert drawn.sets.max() <= 2 and drawn.seeds.max() <= 4 and drawn.seeds.min() >= 0
