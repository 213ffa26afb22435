"""Pareto metrics against hand computations, brute force and pymoo."""

import numpy as np
import pytest

from wcac_jax import pareto


def test_hypervolume_2d_staircase_by_hand():
    # staircase (1,3), (2,2), (3,1) over ref (0,0): 3*1 + 2*1 + 1*1 = 6
    assert pareto.hypervolume([[1, 3], [2, 2], [3, 1]], [0, 0]) == pytest.approx(6.0)
    # a dominated point and a point not dominating ref change nothing
    pts = [[1, 3], [2, 2], [3, 1], [1, 1], [5, -1]]
    assert pareto.hypervolume(pts, [0, 0]) == pytest.approx(6.0)
    # shifted reference: (1+1)*(3+1) for one point
    assert pareto.hypervolume([[1, 3]], [-1, -1]) == pytest.approx(8.0)
    assert pareto.hypervolume(np.zeros((0, 2)), [0, 0]) == 0.0


def test_hypervolume_3d_by_inclusion_exclusion():
    # two boxes [0,2]x[0,1]x[0,1] (vol 2) and [0,1]x[0,2]x[0,1] (vol 2) overlap in the
    # unit cube (vol 1): 2 + 2 - 1 = 3
    assert pareto.hypervolume([[2, 1, 1], [1, 2, 1]], [0, 0, 0]) == pytest.approx(3.0)
    # three boxes (2,1,1), (1,2,1), (1,1,2): 3 * 2 - 3 * 1 + 1 = 4
    assert pareto.hypervolume([[2, 1, 1], [1, 2, 1], [1, 1, 2]], [0, 0, 0]) == pytest.approx(4.0)
    # (3,2,1) and (1,2,3): 6 + 6 - |(1,2,1)| = 12 - 2 = 10
    assert pareto.hypervolume([[3, 2, 1], [1, 2, 3]], [0, 0, 0]) == pytest.approx(10.0)


@pytest.mark.parametrize("m", [2, 3, 4])
def test_hypervolume_agrees_with_pymoo(m):
    hv_mod = pytest.importorskip("pymoo.indicators.hv")
    rng = np.random.default_rng(m)
    for _ in range(50):
        n = int(rng.integers(1, 12))
        pts = rng.uniform(0, 1, (n, m))
        if rng.uniform() < 0.3:  # ties
            pts = np.round(pts, 1)
        ref = np.full(m, -0.1)
        expected = hv_mod.HV(ref_point=-ref)(-pts)  # pymoo minimises
        assert pareto.hypervolume(pts, ref) == pytest.approx(expected, rel=1e-9, abs=1e-12)


def test_nondominated_against_brute_force_with_ties():
    rng = np.random.default_rng(0)
    for _ in range(50):
        pts = rng.integers(0, 4, (int(rng.integers(1, 15)), int(rng.integers(2, 4))))
        mask = pareto.nondominated(pts)
        for i, p in enumerate(pts):
            dominated = any(np.all(q >= p) and np.any(q > p) for q in pts)
            first = not any(np.array_equal(pts[j], p) for j in range(i))
            assert mask[i] == (not dominated and first)


def test_nondominated_2d_by_hand():
    # (3,1) and (1,3) trade off; (2,2) too; (2,1) is dominated by (2,2) (same x) and by
    # (3,1) (same y); (1,3) repeated: kept once, its first row; (0,5) beats every y
    pts = [[1, 3], [2, 1], [3, 1], [2, 2], [1, 3], [0, 5], [-np.inf, 5], [np.inf, -np.inf]]
    np.testing.assert_array_equal(
        pareto.nondominated(pts), [True, False, True, True, False, True, False, True]
    )
    assert pareto.nondominated(np.zeros((0, 2))).shape == (0,)


def test_nondominated_2d_sort_matches_pairwise_comparison():
    """The sort of two objectives against every pair compared: many points, ties in x,
    in y and whole rows, infinities."""
    rng = np.random.default_rng(1)
    for _ in range(40):
        n = int(rng.integers(1, 300))
        pts = rng.integers(-5, 6, (n, 2)).astype(np.float64)
        pts[rng.uniform(size=(n, 2)) < 0.02] = np.inf
        pts[rng.uniform(size=(n, 2)) < 0.02] = -np.inf
        if rng.uniform() < 0.5:  # sparser ties
            pts += rng.normal(size=(n, 2)) * (rng.uniform(size=(n, 1)) < 0.5)
        ge = np.all(pts[None, :] >= pts[:, None], axis=-1)  # [i, j]: j >= i everywhere
        gt = np.any(pts[None, :] > pts[:, None], axis=-1)
        same = np.all(pts[None, :] == pts[:, None], axis=-1)
        expected = ~np.any(ge & gt, axis=1) & ~np.any(np.tril(same, -1), axis=1)
        np.testing.assert_array_equal(pareto.nondominated(pts), expected)


def test_outside_reference_by_hand():
    pts = [[1, 3], [2, -1], [0, 5], [-3, -3]]
    # (2, -1) is below ref in y, (0, 5) on its boundary in x: neither adds volume
    np.testing.assert_array_equal(pareto.outside_reference(pts, [0, 0]), [False, True, True, True])
    assert pareto.hypervolume(pts, [0, 0]) == pytest.approx(3.0)
    # a lower reference takes every point in: (2+4)*(3+4) + ... by the staircase
    assert not pareto.outside_reference(pts, [-4, -4]).any()
    # sorted by x: (2,-1): 6*3=18; (1,3): 5*4=20; (0,5): 4*2=8; (-3,-3) dominated
    assert pareto.hypervolume(pts, [-4, -4]) == pytest.approx(46.0)
    with pytest.raises(ValueError, match="objectives"):
        pareto.outside_reference(pts, [0, 0, 0])


def test_expected_utility_by_hand():
    pts = [[1.0, 0.0], [0.0, 1.0], [0.6, 0.6]]
    weights = [[1.0, 0.0], [0.5, 0.5], [0.0, 1.0]]
    # best per weight: 1.0, 0.6, 1.0 -> mean 2.6 / 3
    assert pareto.expected_utility(pts, weights) == pytest.approx(2.6 / 3)


def test_sparsity_and_cardinality():
    pts = [[0, 3], [1, 2], [3, 0], [0, 0], [1, 2]]
    assert pareto.cardinality(pts) == 3
    # front sorted per objective: x: 0,1,3 -> 1 + 4; y: 0,2,3 -> 4 + 1; (5 + 5) / 2
    assert pareto.sparsity(pts) == pytest.approx(5.0)
    assert pareto.sparsity([[1, 1]]) == 0.0


def test_rank_correlation_by_hand():
    assert pareto.rank_correlation([1, 2, 3], [30, 20, 10]) == -1.0
    # ranks (0, 1, 2, 3) and (0, 2, 1, 3): deviations (-1.5, -0.5, 0.5, 1.5) and
    # (-1.5, 0.5, -0.5, 1.5), products sum to 4, squares to 5 each: 4 / 5
    assert pareto.rank_correlation([1, 2, 3, 4], [1, 3, 2, 4]) == pytest.approx(0.8)
    # ties take their mean rank: (0, 1.5, 1.5) against (0, 1, 2): 1.5 / sqrt(1.5 * 2)
    assert pareto.rank_correlation([1, 2, 2], [1, 2, 3]) == pytest.approx(np.sqrt(3) / 2)
    np.testing.assert_array_equal(pareto.ranks([0.5, 0.1, 0.5, 0.2]), [2.5, 0.0, 2.5, 1.0])
    # a constant sequence has no order to correlate
    assert np.isnan(pareto.rank_correlation([1, 1], [1, 2]))
    with pytest.raises(ValueError, match="differ in length"):
        pareto.rank_correlation([1, 2], [1, 2, 3])


def test_simplex_lattice():
    np.testing.assert_allclose(pareto.simplex_lattice(2, 3), [[1, 0], [0.5, 0.5], [0, 1]])
    for m, n in [(3, 6), (3, 10), (4, 7), (3, 1)]:
        grid = pareto.simplex_lattice(m, n)
        assert grid.shape == (n, m)
        np.testing.assert_allclose(grid.sum(axis=1), 1.0)
        assert np.all(grid >= 0)
        assert len({tuple(r) for r in np.round(grid, 9)}) == n
    corners = pareto.simplex_lattice(3, 6)
    assert {tuple(r) for r in corners} >= {(1, 0, 0), (0, 1, 0), (0, 0, 1)}


def test_preference_lattice():
    # two objectives: the evenly spaced points of today, unchanged
    for n in (1, 2, 5, 9):
        np.testing.assert_array_equal(pareto.preference_lattice(2, n), pareto.simplex_lattice(2, n))
    # three: the full lattice, every entry a multiple of 1/h, each point once
    for h, size in [(1, 3), (2, 6), (3, 10), (4, 15)]:
        assert pareto.lattice_size(3, h) == size
        grid = pareto.preference_lattice(3, size)
        assert grid.shape == (size, 3)
        np.testing.assert_allclose(grid.sum(axis=1), 1.0)
        np.testing.assert_allclose(grid * h, np.round(grid * h), atol=1e-12)
        assert len({tuple(r) for r in np.round(grid * h).astype(int)}) == size
    with pytest.raises(ValueError, match=r"9 preferences .* nearest that do: 6 or 10"):
        pareto.preference_lattice(3, 9)
    with pytest.raises(ValueError, match=r"nearest that do: 3 "):
        pareto.preference_lattice(3, 2)
    assert len(pareto.preference_lattice(3, 9, exact=False)) == 10  # the default's rule
    assert pareto.preference_lattice(3, 1).shape == (1, 3)


def test_hypervolume_3d_agrees_with_pymoo_on_front_sized_returns():
    """Returns of the size of 500-step fronts, a reference below them (as the table's
    morl-baselines convention), up to 60 points."""
    hv_mod = pytest.importorskip("pymoo.indicators.hv")
    rng = np.random.default_rng(7)
    for n in (5, 21, 60):
        pts = rng.uniform(-50, 2000, (n, 3))
        ref = np.full(3, -100.0)
        expected = hv_mod.HV(ref_point=-ref)(-pts)
        assert pareto.hypervolume(pts, ref) == pytest.approx(expected, rel=1e-9)


def test_errors():
    with pytest.raises(ValueError, match="NaN"):
        pareto.hypervolume([[1.0, np.nan]], [0, 0])
    with pytest.raises(ValueError, match="objectives"):
        pareto.hypervolume([[1.0, 2.0]], [0, 0, 0])
    with pytest.raises(ValueError, match="2-D"):
        pareto.nondominated([1.0, 2.0])
    with pytest.raises(ValueError, match="objectives"):
        pareto.expected_utility([[1.0, 2.0]], [[1.0, 0.0, 0.0]])
