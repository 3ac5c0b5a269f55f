"""Agreement statistics: checked against brute-force pair counts and textbook identities."""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from roverimpact.studies.stats import agreement, concordant_pair_fraction


def _brute_pairs(x, y):
    """Count concordant / discordant / tied pairs with a double loop (the definition)."""
    C = D = T = 0
    for i, j in itertools.combinations(range(len(x)), 2):
        s = (x[i] - x[j]) * (y[i] - y[j])
        if s > 0:
            C += 1
        elif s < 0:
            D += 1
        else:
            T += 1
    return C, D, T


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 6), st.integers(0, 6)), min_size=2, max_size=40))
def test_concordant_fraction_matches_brute_force_with_ties(pairs):
    x = np.array([p[0] for p in pairs], float)
    y = np.array([p[1] for p in pairs], float)
    C, D, T = _brute_pairs(x, y)
    frac, c, d, t = concordant_pair_fraction(x, y)
    assert (c, d, t) == (C, D, T)
    if C + D:
        assert frac == pytest.approx(C / (C + D))
    else:
        assert np.isnan(frac)


def test_fraction_equals_kendall_tau_a_identity_without_ties(rng):
    """Without ties, tau = (C - D) / (C + D) so the fraction is (1 + tau) / 2."""
    x = rng.standard_normal(50)
    y = x + 0.8 * rng.standard_normal(50)
    C, D, _ = _brute_pairs(x, y)
    tau_a = (C - D) / (C + D)
    a = agreement(x, y, n_boot=0)
    assert a.concordant_fraction.value == pytest.approx((1 + tau_a) / 2)
    assert a.kendall.value == pytest.approx(tau_a)


def test_monotone_map_has_perfect_rank_agreement_but_not_linear(rng):
    """y = exp(3x) is increasing: Spearman = Kendall = fraction = 1, Pearson < 1."""
    x = np.sort(rng.uniform(0, 2, 30))
    a = agreement(x, np.exp(3 * x), n_boot=100, seed=1)
    assert a.spearman.value == pytest.approx(1.0)
    assert a.kendall.value == pytest.approx(1.0)
    assert a.concordant_fraction.value == 1.0
    assert a.pearson.value < 0.95
    assert a.spearman.low == pytest.approx(1.0)  # every resample is monotone too


def test_reversed_order_and_spearman_closed_form():
    """rho = 1 - 6 sum d^2 / (n (n^2 - 1)) for distinct ranks; a reversal gives -1."""
    x = np.array([1.0, 2, 3, 4, 5])
    y = np.array([2.0, 1, 4, 3, 5])  # d = (1, -1, 1, -1, 0): sum d^2 = 4
    a = agreement(x, y, n_boot=0)
    assert a.spearman.value == pytest.approx(1 - 6 * 4 / (5 * 24))
    b = agreement(x, -x, n_boot=0)
    assert b.spearman.value == pytest.approx(-1.0)
    assert b.concordant_fraction.value == 0.0


def test_bootstrap_is_seeded_and_brackets_the_estimate(rng):
    x = rng.standard_normal(40)
    y = x + rng.standard_normal(40)
    a1 = agreement(x, y, n_boot=200, seed=7)
    a2 = agreement(x, y, n_boot=200, seed=7)
    a3 = agreement(x, y, n_boot=200, seed=8)
    assert a1 == a2
    assert a1.spearman != a3.spearman
    for e in (a1.spearman, a1.kendall, a1.pearson, a1.concordant_fraction):
        assert e.low <= e.value <= e.high


def test_nan_pairs_dropped_and_degenerate_inputs():
    a = agreement([1, 2, np.nan, 4], [1, 3, 2, 5], n_boot=0)
    assert a.n == 3
    c = agreement([1, 1, 1, 1], [1, 2, 3, 4], n_boot=100)
    assert np.isnan(c.spearman.value)
    with pytest.raises(ValueError, match="same length"):
        agreement([1, 2], [1, 2, 3])


def test_vectorized_bootstrap_matches_scipy_per_resample(rng):
    """The batched resample statistics equal scipy's, resample by resample (ties included)."""
    from scipy import stats as sps

    from roverimpact.studies.stats import _boot_stats

    x = np.round(rng.standard_normal(12), 1)
    y = np.round(x + rng.standard_normal(12), 1)
    idx = np.random.default_rng(5).integers(0, 12, (30, 12))  # the resamples it draws
    got = _boot_stats(x, y, np.random.default_rng(5), 30)
    for b in range(30):
        xb, yb = x[idx[b]], y[idx[b]]
        if np.ptp(xb) == 0 or np.ptp(yb) == 0:
            continue
        assert got[b, 0] == pytest.approx(sps.spearmanr(xb, yb).statistic)
        assert got[b, 1] == pytest.approx(sps.kendalltau(xb, yb).statistic)
        assert got[b, 2] == pytest.approx(sps.pearsonr(xb, yb).statistic)
        C, D, _ = _brute_pairs(xb, yb)
        assert got[b, 3] == pytest.approx(C / (C + D))


@pytest.mark.parametrize("ties", ["none", "rounded", "few values", "constant half"])
def test_bootstrap_of_many_cases_matches_scipy_in_bounded_memory(rng, monkeypatch, ties):
    """Above 400 cases (the compiled kernel: each resample's statistics from how often it
    draws each case, Kendall's tau-b by a Fenwick tree), each resample's statistics equal
    scipy's on the resample itself and the concordant fraction its definition's, ties of
    every kind included; the resamples are drawn a block at a time (here 3 blocks) and are
    the draws of ``integers(0, n, (n_boot, n))`` at once. And memory stays bounded: the
    whole (n_boot, n) arrays of a report of 1e5 cases with F_max took 6.5 GB and more than
    10 minutes. Here 100 x 10 000 resamples stay under 20 MB with a block of 1e5 elements
    (all at once: 64 MB)."""
    import tracemalloc

    from scipy import stats as sps

    from roverimpact.studies import stats

    n = 450
    x = rng.standard_normal(n)
    y = x + rng.standard_normal(n)
    if ties == "rounded":
        x, y = np.round(x, 1), np.round(y, 1)
    elif ties == "few values":
        x = rng.integers(0, 4, n).astype(float)
    elif ties == "constant half":
        x[: n // 2] = 0.5
        y = np.round(3 * y)
    monkeypatch.setattr(stats, "BOOT_BLOCK", 3 * n, raising=False)
    idx = np.random.default_rng(9).integers(0, n, (8, n))
    got = stats._boot_stats(x, y, np.random.default_rng(9), 8)
    for b in range(8):
        xb, yb = x[idx[b]], y[idx[b]]
        assert got[b, 0] == pytest.approx(sps.spearmanr(xb, yb).statistic, abs=1e-12)
        assert got[b, 1] == pytest.approx(sps.kendalltau(xb, yb).statistic, abs=1e-12)
        assert got[b, 2] == pytest.approx(sps.pearsonr(xb, yb).statistic, abs=1e-12)
        s = np.sign(np.subtract.outer(xb, xb)) * np.sign(np.subtract.outer(yb, yb))
        assert got[b, 3] == pytest.approx(np.sum(s > 0) / np.sum(s != 0), abs=1e-12)
    d = stats.spearman_difference(x, -y, y, n_boot=100, seed=4)
    diffs = [sps.spearmanr(x[i], y[i]).statistic - sps.spearmanr(-y[i], y[i]).statistic
             for i in np.random.default_rng(4).integers(0, n, (100, n))]
    assert (d.low, d.high) == pytest.approx(
        (np.quantile(diffs, 0.025), np.quantile(diffs, 0.975)), abs=1e-12)
    monkeypatch.setattr(stats, "BOOT_BLOCK", 100_000, raising=False)
    n = 10_000
    x = rng.standard_normal(n)
    y = x + rng.standard_normal(n)
    tracemalloc.start()
    a = stats.agreement(x, y, n_boot=100, seed=0)
    d = stats.spearman_difference(x, -x, y, n_boot=100, seed=0)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 20e6, f"peak {peak / 1e6:.0f} MB"
    assert a.spearman.low < sps.spearmanr(x, y).statistic < a.spearman.high
    assert d.value == pytest.approx(2 * sps.spearmanr(x, y).statistic, abs=1e-12)


@pytest.mark.parametrize("n", [60, 450])  # numpy's resamples, the compiled kernel's
def test_agreements_and_gains_equal_agreement_and_spearman_difference(rng, n):
    """The report's shared resampling gives what agreement and spearman_difference give
    one by one, to the bit: every statistic and interval of each column, and the paired
    Spearman gain of the first column over each other one; a column with NaN (other
    cases) goes through spearman_difference itself, a constant one gives NaN gains."""
    from roverimpact.studies.stats import (
        agreement,
        agreements_and_gains,
        spearman_difference,
    )

    y = rng.standard_normal(n)
    first = np.round(y + 0.5 * rng.standard_normal(n), 2)
    other = np.round(y + rng.standard_normal(n), 1)
    holes = other.copy()
    holes[::7] = np.nan
    columns = [first, other, -first, holes, np.full(n, 3.0)]
    ags, gains = agreements_and_gains(columns, y, n_boot=150, seed=3, confidence=0.9)

    def flat(a):
        return np.array([a.n, *(getattr(a, f).value for f in ("spearman", "kendall", "pearson",
                                                               "concordant_fraction")),
                         *(getattr(a, f).low for f in ("spearman", "kendall", "pearson",
                                                       "concordant_fraction")),
                         *(getattr(a, f).high for f in ("spearman", "kendall", "pearson",
                                                        "concordant_fraction"))])

    for x, a in zip(columns, ags, strict=True):
        np.testing.assert_array_equal(flat(a), flat(agreement(x, y, n_boot=150, seed=3,
                                                              confidence=0.9)))
    for x, g in zip(columns[1:], gains, strict=True):
        ref = spearman_difference(first, x, y, n_boot=150, seed=3, confidence=0.9)
        np.testing.assert_array_equal([g.value, g.low, g.high],
                                      [ref.value, ref.low, ref.high])
    assert np.isfinite([gains[0].low, gains[2].low]).all() and np.isnan(gains[3].value)


@pytest.mark.parametrize("constant", [False, True])
def test_report_takes_t_c_agreement_from_its_indicator_comparison(rng, constant):
    """The report's agreement of T_c^- with F_max is the indicator comparison's own (the
    same cases, resamples and seed), equal to the bit to a second agreement call, which
    it no longer makes; a constant T_c^- (ranked as a constant there) and fewer than 3
    forces keep their own paths."""
    from roverimpact.report.html import _tc_agreement
    from roverimpact.studies.indicators import compare_indicators
    from roverimpact.studies.stats import agreement

    n = 500
    v_n = rng.uniform(0.05, 0.5, n)
    T = np.full(n, 0.7) if constant else 0.5 * rng.uniform(5, 20, n) * v_n**2
    F = 3e3 * np.abs(T + 0.01 * rng.standard_normal(n)) ** 0.6
    F[::11] = np.nan  # failed runs
    table = pd.DataFrame({"T_c_minus": T, "F_max": F, "v_n": v_n, "m_total": 25.0,
                          "m_eff_free": rng.uniform(5, 20, n)})
    ww = np.zeros(n, bool)
    ww[::13] = True  # whole-window cases, left out
    comp = compare_indicators(table, "F_max", exclude=ww, n_boot=120, seed=5)
    got = _tc_agreement(table[~ww], "F_max", comp, 120, 5)
    ref = agreement(table[~ww]["T_c_minus"], table[~ww]["F_max"], n_boot=120, seed=5)
    assert (got is comp.result("T_c_minus").agreement) is not constant
    for f in ("spearman", "kendall", "pearson", "concordant_fraction"):
        e, r = getattr(got, f), getattr(ref, f)
        np.testing.assert_array_equal([e.value, e.low, e.high], [r.value, r.low, r.high])
    assert got.n == ref.n
    few = table.assign(F_max=np.where(np.arange(n) < 2, 1.0, np.nan))
    assert _tc_agreement(few, "F_max", None, 120, 5) is None
