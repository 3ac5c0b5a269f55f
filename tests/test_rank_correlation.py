"""studies.stats.rank_correlation: Kendall tau-b and Spearman rho with p-values, by hand."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy import stats as sps

from roverimpact.studies.stats import SPEARMAN_EXACT_MAX_N, rank_correlation


def test_four_points_by_hand():
    """x = 1..4, y = 10, 20, 40, 30: one discordant pair of six, ranks of y 1, 2, 4, 3.

    tau = (C - D) / 6 = (5 - 1) / 6 = 2/3; rho = 1 - 6 sum d^2 / (n (n^2 - 1)) = 1 - 12/60
    = 0.8. Exact two-sided Kendall p: the inversion counts of the 24 permutations of 4 are
    1, 3, 5, 6, 5, 3, 1 for 0..6 inversions; one inversion or its mirror five or more:
    p = (1 + 3 + 3 + 1) / 24 = 1/3. Spearman's exact p: rho >= 0.8 means sum d^2 <= 2,
    i.e. the identity or one of the 3 adjacent swaps, and as many mirrored orderings have
    rho <= -0.8: p = 8 / 24 = 1/3 (scipy's t approximation gave 0.2).
    """
    rc = rank_correlation([1, 2, 3, 4], [10, 20, 40, 30])
    assert rc.n == 4
    assert rc.kendall_tau == pytest.approx(2 / 3, rel=1e-12)
    assert rc.spearman_rho == pytest.approx(0.8, rel=1e-12)
    assert rc.kendall_p == pytest.approx(1 / 3, rel=1e-12)
    assert rc.spearman_p == pytest.approx(1 / 3, rel=1e-12)


def test_ties_and_dropped_pairs():
    """With ties, tau-b = (C - D) / sqrt((n0 - n1)(n0 - n2)); pairs with NaN/inf dropped.

    x = 1, 1, 2, 3; y = 1, 2, 2, 3 (n0 = 6, n1 = 1 tie in x, n2 = 1 tie in y; pair (0, 1)
    tied in x, pair (1, 2) tied in y, the other 4 concordant): tau_b = 4 / sqrt(5 * 5) = 0.8.
    """
    rc = rank_correlation([1, 1, 2, 3, np.nan, 7], [1, 2, 2, 3, 5, np.inf])
    assert rc.n == 4
    assert rc.kendall_tau == pytest.approx(0.8, rel=1e-12)
    # rho is Pearson's r of the mid-ranks 1.5, 1.5, 3, 4 and 1, 2.5, 2.5, 4
    assert rc.spearman_rho == pytest.approx(
        sps.pearsonr([1.5, 1.5, 3, 4], [1, 2.5, 2.5, 4]).statistic, rel=1e-12)


@pytest.mark.parametrize("x, y", [([1, 2], [2, 1]), ([1, 2, 3], [5, 5, 5]),
                                  ([np.nan, 1, 2, 3], [1, 2, 3, np.nan])])
def test_too_few_or_constant_is_nan(x, y):
    rc = rank_correlation(x, y)
    assert all(math.isnan(v) for v in (rc.kendall_tau, rc.kendall_p, rc.spearman_rho,
                                       rc.spearman_p))


def _enumerated_spearman_p(x, y):
    """Two-sided permutation p by brute force: Spearman's rho (Pearson's r of scipy's
    average ranks) of every ordering of y, all orderings at once; the first, y as it is,
    is scipy's rho (one spearmanr call per ordering took 10 s for n = 7)."""
    rx, ry = sps.rankdata(x) - (len(x) + 1) / 2, sps.rankdata(y) - (len(y) + 1) / 2
    R = ry[np.array(list(itertools.permutations(range(len(y)))))]
    rhos = R @ rx / np.sqrt((rx @ rx) * (ry @ ry))
    rho = sps.spearmanr(x, y).statistic
    assert rhos[0] == pytest.approx(rho, abs=1e-13)
    return np.mean(np.abs(rhos) >= abs(rho) - 1e-12)


@pytest.mark.parametrize("n", [3, 4, 5])
def test_spearman_p_of_a_perfect_ranking_is_exact(n):
    """A perfect ranking of n pairs: 2 of the n! orderings have |rho| = 1, p = 2 / n!
    (1/3, 1/12, 1/60); scipy's t approximation gave 0 for n = 3, 4."""
    rc = rank_correlation(np.arange(n), np.arange(n) ** 2)
    assert rc.spearman_p == pytest.approx(2 / math.factorial(n), rel=1e-12)
    assert rc.kendall_p == pytest.approx(sps.kendalltau(np.arange(n), np.arange(n)).pvalue)


def test_spearman_p_matches_the_enumeration():
    """Random samples of 3..7 pairs, with and without ties: the exact p equals the brute
    force enumeration; Kendall's p stays scipy's; above SPEARMAN_EXACT_MAX_N pairs the
    p is scipy's."""
    rng = np.random.default_rng(18)
    for n in range(3, 8):
        for ties in (False, True):
            x = rng.integers(0, 3 if ties else 1000, n).astype(float)
            y = x + rng.normal(0, 1.0 if ties else 300.0, n)
            if np.ptp(x) == 0:
                continue
            rc = rank_correlation(x, y)
            assert rc.spearman_p == pytest.approx(_enumerated_spearman_p(x, y), abs=1e-12)
            assert rc.kendall_p == pytest.approx(sps.kendalltau(x, y).pvalue, rel=1e-12)
    x = np.arange(12.0)
    y = x + rng.normal(0, 3.0, 12)
    assert rank_correlation(x, y).spearman_p == pytest.approx(sps.spearmanr(x, y).pvalue)
    assert SPEARMAN_EXACT_MAX_N < 12
