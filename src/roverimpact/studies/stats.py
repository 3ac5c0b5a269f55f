r"""Agreement between the indicator T_c^- and the simulated peak force F_max.

The papers claim that T_c^- *orders* impact configurations like the peak force does, so
the main statistics are rank statistics:

- Spearman's :math:`\rho` (Pearson correlation of the ranks) and Kendall's
  :math:`\tau_b`;
- the concordant pair fraction :math:`C / (C + D)`: of all pairs of cases that neither
  quantity ties, the share that T_c^- orders like F_max (``(1 + tau_a) / 2`` without ties);
- Pearson's r (linear agreement) for completeness.

Each comes with a seeded percentile bootstrap confidence interval (cases resampled with
replacement, pairs kept together). Above :data:`SIGN_MATRIX_MAX_N` cases a compiled
kernel (:mod:`roverimpact._kernels.bootstrap`) computes each resample's statistics from
how often it draws each case, without sorting the resample.

:func:`rank_correlation` gives Kendall's and Spearman's coefficients with p-values instead
(no bootstrap), for a few conditions such as the experiment comparison: scipy's Kendall p
(exact for small samples without ties), and for Spearman the exact permutation p up to
:data:`SPEARMAN_EXACT_MAX_N` pairs (scipy's t approximation gives p = 0 for a perfect
ranking of 3 or 4 pairs, where the exact p is 1/3 or 1/12), scipy's above.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from itertools import permutations

import numpy as np
from scipy import stats as sps

from ..exceptions import InputError

__all__ = [
    "RATIO_TOLERANCE",
    "SPEARMAN_EXACT_MAX_N",
    "Agreement",
    "Estimate",
    "ForceRatios",
    "RankCorrelation",
    "agreement",
    "agreements_and_gains",
    "concordant_pair_fraction",
    "force_ratios",
    "rank_correlation",
    "spearman_difference",
]


@dataclass(frozen=True)
class Estimate:
    """A statistic with its bootstrap confidence interval ``[low, high]``."""

    value: float
    low: float
    high: float

    def __str__(self) -> str:
        return f"{self.value:.3f} [{self.low:.3f}, {self.high:.3f}]"


@dataclass(frozen=True)
class Agreement:
    """Agreement statistics of two paired samples (x = indicator, y = reference).

    Attributes
    ----------
    n : int
        Number of pairs used (pairs with NaN dropped).
    spearman, kendall, pearson : Estimate
        Correlations with bootstrap confidence intervals.
    concordant_fraction : Estimate
        Share of untied pairs ordered alike.
    n_concordant, n_discordant, n_tied : int
        Pair counts of the full sample (``n_tied``: pairs tied in x or y).
    confidence : float
        Level of the intervals. ``n_boot``, ``seed``: bootstrap settings.
    """

    n: int
    spearman: Estimate
    kendall: Estimate
    pearson: Estimate
    concordant_fraction: Estimate
    n_concordant: int
    n_discordant: int
    n_tied: int
    confidence: float
    n_boot: int
    seed: int

    def as_dict(self) -> dict:
        return asdict(self)


def _tie_pairs(*cols: np.ndarray) -> int:
    """Number of pairs equal in all of ``cols`` (sum of t(t-1)/2 over groups)."""
    _, counts = np.unique(np.stack(cols, axis=-1), axis=0, return_counts=True)
    counts = counts.astype(np.int64)
    return int(np.sum(counts * (counts - 1) // 2))


def _clean(x, y) -> tuple[np.ndarray, np.ndarray]:
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if x.shape != y.shape:
        raise InputError(f"x and y must have the same length, got {x.size} and {y.size}")
    ok = np.isfinite(x) & np.isfinite(y)
    return x[ok], y[ok]


def concordant_pair_fraction(x, y) -> tuple[float, int, int, int]:
    """Share of pairs that ``x`` orders like ``y``, among pairs tied in neither.

    A pair (i, j) is concordant if ``(x_i - x_j)(y_i - y_j) > 0`` and discordant if
    ``< 0``. Computed in O(n log n) from Kendall's tau-b and the tie counts:
    ``C - D = tau_b sqrt((n0 - n1)(n0 - n2))``, ``C + D = n0 - n1 - n2 + n3``.

    Returns
    -------
    fraction, n_concordant, n_discordant, n_tied
        ``fraction`` is NaN when no pair is untied.
    """
    x, y = _clean(x, y)
    n = x.size
    n0 = n * (n - 1) // 2
    if n < 2:
        return float("nan"), 0, 0, n0
    n1, n2, n3 = _tie_pairs(x), _tie_pairs(y), _tie_pairs(x, y)
    untied = n0 - n1 - n2 + n3
    if untied == 0:
        return float("nan"), 0, 0, n0
    tau_b = sps.kendalltau(x, y, variant="b").statistic
    diff = tau_b * np.sqrt(float(n0 - n1) * float(n0 - n2))
    C = round((untied + diff) / 2)
    D = untied - C
    return C / untied, C, D, n0 - untied


@dataclass(frozen=True)
class RankCorrelation:
    """Kendall's tau-b and Spearman's rho of two paired samples, with two-sided p-values
    (``scipy.stats.kendalltau``; Spearman's exact by permutation up to
    :data:`SPEARMAN_EXACT_MAX_N` pairs, else ``scipy.stats.spearmanr``) and the number of
    pairs used."""

    kendall_tau: float
    kendall_p: float
    spearman_rho: float
    spearman_p: float
    n: int


#: Up to this many pairs, the Spearman p-value is exact: the share of all n! orderings of
#: y whose rank correlation with x is at least as large in absolute value (two-sided;
#: 40320 orderings at 8).
SPEARMAN_EXACT_MAX_N = 8


def _spearman_exact_p(x: np.ndarray, y: np.ndarray) -> float:
    """Two-sided exact permutation p-value of Spearman's rho (ties: average ranks)."""
    a = sps.rankdata(x)
    b = sps.rankdata(y)
    a, b = a - a.mean(), b - b.mean()
    perms = np.array(list(permutations(range(len(a)))))
    num = b[perms] @ a  # rho of each ordering times |a| |b|: compare the numerators
    obs = float(b @ a)
    return float(np.mean(np.abs(num) >= abs(obs) * (1 - 1e-12) - 1e-12))


def rank_correlation(x, y) -> RankCorrelation:
    """Kendall tau-b and Spearman rho of ``x`` and ``y`` with their p-values.

    Pairs with NaN or inf are dropped (``n`` counts the rest). All four figures are NaN
    with fewer than 3 pairs or a constant sample. The Spearman p-value is exact
    (permutations) up to :data:`SPEARMAN_EXACT_MAX_N` pairs, scipy's t approximation
    above.

    Examples
    --------
    >>> rc = rank_correlation([1, 2, 3, 4], [10, 20, 40, 30])
    >>> round(rc.kendall_tau, 4), round(rc.spearman_rho, 4), rc.n
    (0.6667, 0.8, 4)
    """
    x, y = _clean(x, y)
    nan = float("nan")
    if x.size < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return RankCorrelation(nan, nan, nan, nan, int(x.size))
    kt = sps.kendalltau(x, y, variant="b")
    sr = sps.spearmanr(x, y)
    p = _spearman_exact_p(x, y) if x.size <= SPEARMAN_EXACT_MAX_N else float(sr.pvalue)
    return RankCorrelation(float(kt.statistic), float(kt.pvalue), float(sr.statistic),
                           p, int(x.size))


def _corrs(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float, float]:
    rc = rank_correlation(x, y)
    if math.isnan(rc.kendall_tau):
        return (float("nan"),) * 4
    rho, tau = rc.spearman_rho, rc.kendall_tau
    r = float(sps.pearsonr(x, y).statistic)
    frac = concordant_pair_fraction(x, y)[0]
    return rho, tau, r, frac


def _rowwise_pearson(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    a = a - a.mean(axis=1, keepdims=True)
    b = b - b.mean(axis=1, keepdims=True)
    den = np.sqrt(np.sum(a * a, axis=1) * np.sum(b * b, axis=1))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, np.sum(a * b, axis=1) / np.where(den > 0, den, 1.0), np.nan)


#: Elements (resamples x cases) of one block of bootstrap resamples: the resampled and
#: ranked arrays of a block stay near 100 MB whatever n_boot and n (the whole
#: (n_boot, n) arrays at once took 6.5 GB for a report of 1e5 cases).
BOOT_BLOCK = 4_000_000


#: Most cases whose bootstrap statistics come from sign matrices in numpy; above, the
#: compiled kernel (:func:`_boot_kernel`).
SIGN_MATRIX_MAX_N = 400


def _boot_stats(x: np.ndarray, y: np.ndarray, rng: np.random.Generator,
                n_boot: int) -> np.ndarray:
    """(n_boot, 4) Spearman, Kendall tau-b, Pearson, concordant fraction of ``n_boot``
    resamples of the pairs (``rng.integers(0, n, (n_boot, n))``, drawn in blocks of
    :data:`BOOT_BLOCK` elements: the same draws as at once).

    Up to :data:`SIGN_MATRIX_MAX_N` cases, in numpy: ranks by ``scipy.stats.rankdata`` and
    the pair statistics from the sign matrices ``sign(x_i - x_j) sign(y_i - y_j)``; above,
    :func:`_boot_kernel`.
    """
    n = x.size
    if n > SIGN_MATRIX_MAX_N:
        return _boot_kernel(x, y, rng, n_boot)
    idx = rng.integers(0, n, (n_boot, n))
    out = np.full((n_boot, 4), np.nan)
    step = max(1, BOOT_BLOCK // n)
    for s0 in range(0, n_boot, step):
        X, Y = x[idx[s0:s0 + step]], y[idx[s0:s0 + step]]
        out[s0:s0 + step, 2] = _rowwise_pearson(X, Y)
        out[s0:s0 + step, 0] = _rowwise_pearson(sps.rankdata(X, axis=1),
                                                sps.rankdata(Y, axis=1))
    block = max(1, int(4e6 // (n * n)))
    for s0 in range(0, n_boot, block):
        xs, ys = x[idx[s0:s0 + block]], y[idx[s0:s0 + block]]
        sx = np.sign(xs[:, :, None] - xs[:, None, :])
        sy = np.sign(ys[:, :, None] - ys[:, None, :])
        prod = sx * sy
        C = np.sum(prod > 0, axis=(1, 2)) / 2.0
        D = np.sum(prod < 0, axis=(1, 2)) / 2.0
        nx = np.sum(sx != 0, axis=(1, 2)) / 2.0
        ny = np.sum(sy != 0, axis=(1, 2)) / 2.0
        with np.errstate(invalid="ignore", divide="ignore"):
            out[s0:s0 + block, 1] = np.where(nx * ny > 0, (C - D) / np.sqrt(nx * ny), np.nan)
            out[s0:s0 + block, 3] = np.where(C + D > 0, C / (C + D), np.nan)
    return out


def _groups(v: np.ndarray) -> np.ndarray:
    """Group of each value: 0, 1, ... in increasing value, equal values one group."""
    return np.unique(v, return_inverse=True)[1].ravel().astype(np.int64)


def _boot_kernel(x: np.ndarray, y: np.ndarray, rng: np.random.Generator, n_boot: int, *,
                 kendall: bool = True) -> np.ndarray:
    """:func:`_boot_stats` by the compiled kernel
    (:func:`roverimpact._kernels.bootstrap.agreement_kernel`): each resample's statistics
    from the counts of its cases, O(n) for the ranks, Pearson's and Spearman's
    coefficients and O(n log n) for Kendall's tau-b (with ``kendall`` False, its columns
    are NaN). The same statistics as the numpy path to rounding: Kendall's and the
    concordant fraction from the same integer pair counts."""
    from .._kernels.bootstrap import agreement_kernel

    n = x.size
    gx, gy = _groups(x), _groups(y)
    gxy = _groups(gx * (int(gy.max()) + 1) + gy)
    order = np.argsort(gx, kind="stable")  # the kernel takes the cases in increasing x
    at = np.empty(n, np.int64)
    at[order] = np.arange(n)
    x, y, gx, gy, gxy = (np.ascontiguousarray(a[order]) for a in (x, y, gx, gy, gxy))
    out = np.empty((n_boot, 4))
    step = max(1, BOOT_BLOCK // n)
    for s0 in range(0, n_boot, step):
        k = min(step, n_boot - s0)
        agreement_kernel.get(k * n)(x, y, gx, gy, gxy, at, rng.integers(0, n, (k, n)),
                                    kendall, out[s0:s0 + k])
    return out


#: Fewest bootstrap resamples of an interval: fewer give tail percentiles of a handful of
#: resamples (one resample gave an "interval" of one number); ``n_boot = 0``: no interval.
MIN_BOOT = 100


def check_n_boot(n_boot) -> None:
    if isinstance(n_boot, bool) or not isinstance(n_boot, (int, np.integer)) or not (
            n_boot == 0 or n_boot >= MIN_BOOT):
        raise InputError(f"n_boot must be 0 (no intervals) or a whole number of at least "
                         f"{MIN_BOOT} resamples, got {n_boot!r}")


def agreement(x, y, *, n_boot: int = 1000, confidence: float = 0.95, seed: int = 0) -> Agreement:
    """Rank and linear agreement of ``x`` (e.g. T_c^-) with ``y`` (e.g. F_max).

    Parameters
    ----------
    x, y : (n,) array_like
        Paired samples; pairs with NaN or inf are dropped.
    n_boot : int
        Bootstrap resamples (0: no intervals, they are NaN).
    confidence : float
        Level of the percentile intervals, in (0, 1).
    seed : int
        Seed of the bootstrap (numpy ``default_rng``): same inputs, same intervals.

    Returns
    -------
    Agreement
    """
    return _agreement(x, y, n_boot=n_boot, confidence=confidence, seed=seed)[0]


def _agreement(x, y, *, n_boot: int, confidence: float, seed: int
               ) -> tuple[Agreement, np.ndarray | None]:
    """:func:`agreement` and the statistics of its resamples (:func:`_boot_stats`, None
    without resamples)."""
    if not 0.0 < confidence < 1.0:
        raise InputError(f"confidence must be in (0, 1), got {confidence}")
    check_n_boot(n_boot)
    x, y = _clean(x, y)
    n = x.size
    point = _corrs(x, y)
    _frac, C, D, T = concordant_pair_fraction(x, y)
    lows = highs = (float("nan"),) * 4
    boot = None
    if n_boot and n >= 3:
        boot = _boot_stats(x, y, np.random.default_rng(seed), n_boot)
        a = (1.0 - confidence) / 2.0
        finite = np.isfinite(boot)
        lows = tuple(float(np.quantile(boot[finite[:, i], i], a)) if finite[:, i].any()
                     else float("nan") for i in range(4))
        highs = tuple(float(np.quantile(boot[finite[:, i], i], 1 - a)) if finite[:, i].any()
                      else float("nan") for i in range(4))
    est = [Estimate(point[i], lows[i], highs[i]) for i in range(4)]
    return Agreement(
        n=n, spearman=est[0], kendall=est[1], pearson=est[2], concordant_fraction=est[3],
        n_concordant=C, n_discordant=D, n_tied=T, confidence=confidence, n_boot=n_boot,
        seed=seed,
    ), boot


def agreements_and_gains(columns, y, *, n_boot: int = 1000, confidence: float = 0.95,
                         seed: int = 0) -> tuple[list[Agreement], list[Estimate]]:
    """:func:`agreement` of each of ``columns`` with ``y``, and
    :func:`spearman_difference` of the first column and each other one: the same numbers,
    bit for bit, with each resample drawn and ranked once where the cases agree.

    A difference's paired resamples are those of the two agreements (the same seed, the
    same cases) wherever both columns are finite on every case ``y`` is; otherwise it is
    :func:`spearman_difference` itself. A report with F_max compares T_c^- and three
    baselines: four agreements, and three differences that no longer resample.

    Returns
    -------
    agreements : list of Agreement
        One per column.
    gains : list of Estimate
        One per column after the first.
    """
    cols = [np.asarray(x, dtype=float).ravel() for x in columns]
    c = np.asarray(y, dtype=float).ravel()
    runs = [_agreement(x, c, n_boot=n_boot, confidence=confidence, seed=seed) for x in cols]
    gains = []
    first = cols[0]
    rho_first = None  # the first column's Spearman rho, once (as spearman_difference's)
    for x, (_, boot) in zip(cols[1:], runs[1:], strict=True):
        if x.shape != first.shape or first.shape != c.shape or not (
                np.isfinite(first).all() and np.isfinite(x).all() and np.isfinite(c).all()):
            gains.append(spearman_difference(first, x, c, n_boot=n_boot,
                                             confidence=confidence, seed=seed))
            continue
        if rho_first is None:
            rho_first = rank_correlation(first, c).spearman_rho
        value = rho_first - rank_correlation(x, c).spearman_rho
        low = high = float("nan")
        if boot is not None and math.isfinite(value):
            low, high = _diff_interval(runs[0][1][:, 0] - boot[:, 0], n_boot, confidence)
        gains.append(Estimate(float(value), low, high))
    return [a for a, _ in runs], gains


def _diff_interval(diff: np.ndarray, n_boot: int, confidence: float) -> tuple[float, float]:
    """Percentile interval of the resampled differences ``diff``; NaN where fewer than half
    the resamples define both coefficients."""
    diff = diff[np.isfinite(diff)]
    if diff.size < n_boot / 2:
        return float("nan"), float("nan")
    q = (1.0 - confidence) / 2.0
    return float(np.quantile(diff, q)), float(np.quantile(diff, 1.0 - q))


def spearman_difference(x1, x2, y, *, n_boot: int = 1000, confidence: float = 0.95,
                        seed: int = 0) -> Estimate:
    r"""Spearman's :math:`\rho(x_1, y) - \rho(x_2, y)` of two indicators of the same cases,
    with a paired percentile bootstrap interval.

    Each resample draws cases (triples :math:`(x_{1i}, x_{2i}, y_i)` kept together) and
    recomputes both coefficients on it, so the interval is that of the *difference* (the
    two coefficients share their cases and are correlated; their separate intervals would
    overstate the uncertainty of the difference). Triples with NaN or inf are dropped.
    NaN where a coefficient is undefined (fewer than 3 cases or a constant column); the
    interval is NaN without resamples or where fewer than half the resamples define both.

    >>> d = spearman_difference([1, 2, 3, 4, 5], [1, 2, 4, 3, 5], [1, 2, 3, 4, 5], n_boot=0)
    >>> round(d.value, 3)
    0.1
    """
    if not 0.0 < confidence < 1.0:
        raise InputError(f"confidence must be in (0, 1), got {confidence}")
    check_n_boot(n_boot)
    a = np.asarray(x1, dtype=float).ravel()
    b = np.asarray(x2, dtype=float).ravel()
    c = np.asarray(y, dtype=float).ravel()
    if not a.shape == b.shape == c.shape:
        raise InputError(f"x1, x2 and y must have the same length, got {a.size}, {b.size} "
                         f"and {c.size}")
    ok = np.isfinite(a) & np.isfinite(b) & np.isfinite(c)
    a, b, c = a[ok], b[ok], c[ok]
    nan = float("nan")
    r1, r2 = rank_correlation(a, c).spearman_rho, rank_correlation(b, c).spearman_rho
    value = r1 - r2
    low = high = nan
    if n_boot and math.isfinite(value):
        rng = np.random.default_rng(seed)
        if a.size > SIGN_MATRIX_MAX_N:  # the same draws for both coefficients
            diff = (_boot_kernel(a, c, rng, n_boot, kendall=False)[:, 0]
                    - _boot_kernel(b, c, np.random.default_rng(seed), n_boot,
                                   kendall=False)[:, 0])
        else:
            idx = rng.integers(0, a.size, (n_boot, a.size))
            diff = np.empty(n_boot)
            step = max(1, BOOT_BLOCK // a.size)  # bounded memory, as _boot_stats
            for s0 in range(0, n_boot, step):
                i = idx[s0:s0 + step]
                ry = sps.rankdata(c[i], axis=1)
                diff[s0:s0 + step] = (_rowwise_pearson(sps.rankdata(a[i], axis=1), ry)
                                      - _rowwise_pearson(sps.rankdata(b[i], axis=1), ry))
        low, high = _diff_interval(diff, n_boot, confidence)
    return Estimate(float(value), low, high)


#: Tolerance of the predicted peak force: |F_pred / F_max - 1| <= RATIO_TOLERANCE is a hit.
RATIO_TOLERANCE = 0.05


@dataclass(frozen=True)
class ForceRatios:
    """Predicted over simulated peak force on the true impacts of a study.

    Attributes
    ----------
    prediction, force : str
        The columns compared (``F_pred_refined`` vs ``F_max_mujoco``, ...).
    n : int
        True impacts with both values finite.
    n_excluded : int
        Cases left out: not an impact (the contact lasted the whole window, or no
        approach) or a failed run.
    median, min, max : float
        Of ``prediction / force`` over the ``n`` cases (NaN if n = 0).
    n_within : int
        Cases with :math:`|ratio - 1| \\le` ``tolerance``.
    tolerance : float
    """

    prediction: str
    force: str
    n: int
    n_excluded: int
    median: float
    min: float
    max: float
    n_within: int
    tolerance: float = RATIO_TOLERANCE

    def as_dict(self) -> dict:
        return asdict(self)


def force_ratios(pred, force, exclude=None, *, prediction: str = "F_pred",
                 force_name: str = "F_max", tolerance: float = RATIO_TOLERANCE
                 ) -> ForceRatios:
    """Statistics of ``pred / force`` over the cases not in ``exclude`` (a boolean mask:
    the not-an-impact cases) where both are finite and ``force > 0``."""
    p = np.asarray(pred, float)
    f = np.asarray(force, float)
    if p.shape != f.shape:
        raise InputError(f"pred and force must have the same shape, got {p.shape}, {f.shape}")
    keep = np.isfinite(p) & np.isfinite(f) & (f > 0)
    if exclude is not None:
        keep &= ~np.asarray(exclude, bool)
    r = p[keep] / f[keep]
    nan = float("nan")
    return ForceRatios(
        prediction=prediction, force=force_name, n=int(r.size),
        n_excluded=int(p.size - r.size),
        median=float(np.median(r)) if r.size else nan,
        min=float(r.min()) if r.size else nan, max=float(r.max()) if r.size else nan,
        n_within=int(np.sum(np.abs(r - 1.0) <= tolerance + 1e-12)), tolerance=tolerance)
