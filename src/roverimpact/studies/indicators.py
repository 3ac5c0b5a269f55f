r"""How much does T_c^- add? The same agreement statistics for simpler indicators.

T_c^- is the kinetic energy in the subspace of constrained motion just before the impact
(obstacle row and the other active rows). Three simpler indicators could rank the peak
force as well, and every agreement table reports them beside T_c^- (the *baselines*):

========================  ==========================================  ==================
column                    indicator                                    what it ignores
========================  ==========================================  ==================
``v_n``                   normal approach speed (u sin beta)          every mass
``T_n_total``             :math:`\tfrac12 m_{total} v_n^2`            how the mass is
                                                                       coupled to the
                                                                       contact
``T_c_obstacle``          T_c^- with the obstacle row only,           the other contacts
                          :math:`\tfrac12 m_{free} v_n^2`,            and joints held
                          :math:`m_{free} = 1/(a M^{-1} a^T)`          during the impact
========================  ==========================================  ==================

(With one row, :math:`T_c = (a v)^2 / (2\,a M^{-1} a^T)`, so the obstacle-row-only T_c^-
is :math:`\tfrac12 m_{free} v_n^2`.) :func:`compare_indicators` computes, for one force
column (``F_max``, ``F_max_mujoco``, ...), the agreement of every indicator with it on the
same cases, and the paired bootstrap interval of Spearman's rho of T_c^- minus that of
each baseline (:func:`roverimpact.studies.stats.spearman_difference`);
:func:`statements` turns them into sentences, each derived from those numbers: where T_c^-
ranks better than a baseline (the interval of the difference above 0), where a baseline
cannot rank at all (it is the same for every case, e.g. v_n in a study at fixed approach
speed), where both rank alike, and where the study cannot tell them apart.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .stats import Agreement, Estimate, agreement, agreements_and_gains, spearman_difference

__all__ = ["BASELINES", "INDICATORS", "IndicatorComparison", "IndicatorResult",
           "compare_indicators", "statements", "with_baselines"]

#: Indicator columns and their labels, T_c^- first.
INDICATORS = {
    "T_c_minus": "T_c^-",
    "v_n": "v_n",
    "T_n_total": "1/2 m_total v_n^2",
    "T_c_obstacle": "T_c^- (obstacle row only)",
}
#: The baselines: every indicator but T_c^-.
BASELINES = tuple(k for k in INDICATORS if k != "T_c_minus")


def with_baselines(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` with the baseline columns ``T_n_total`` and ``T_c_obstacle`` added from
    ``v_n``, ``m_total`` and ``m_eff_free`` where they are missing (tables written before
    the columns existed keep what they have)."""
    add = {}
    if "v_n" in table:
        v = np.maximum(table["v_n"].to_numpy(float), 0.0)
        if "T_n_total" not in table and "m_total" in table:
            add["T_n_total"] = 0.5 * table["m_total"].to_numpy(float) * v * v
        if "T_c_obstacle" not in table and "m_eff_free" in table:
            add["T_c_obstacle"] = 0.5 * table["m_eff_free"].to_numpy(float) * v * v
    return table.assign(**add) if add else table


@dataclass(frozen=True)
class IndicatorResult:
    """Agreement of one indicator with the force.

    Attributes
    ----------
    column, label : str
        Results column and printed name.
    agreement : Agreement
        Spearman, Kendall, Pearson, concordant pairs with bootstrap intervals.
    constant : bool
        The indicator has the same value in every case (it cannot rank them; its
        correlations are NaN).
    spearman_gain : Estimate or None
        Spearman of T_c^- minus Spearman of this indicator, with its paired bootstrap
        interval; None for T_c^- itself.
    """

    column: str
    label: str
    agreement: Agreement
    constant: bool
    spearman_gain: Estimate | None

    def as_dict(self) -> dict:
        return {"column": self.column, "label": self.label, "constant": self.constant,
                "agreement": self.agreement.as_dict(),
                "spearman_gain": (None if self.spearman_gain is None else
                                  {"value": self.spearman_gain.value,
                                   "low": self.spearman_gain.low,
                                   "high": self.spearman_gain.high})}


@dataclass(frozen=True)
class IndicatorComparison:
    """The indicators against one force column, on the same cases.

    Attributes
    ----------
    force : str
        The force column (``F_max``, ``F_max_mujoco``).
    n : int
        Cases used (finite force and T_c^-, not excluded).
    results : tuple of IndicatorResult
        T_c^- first, then the baselines present in the table.
    statements : tuple of str
        Sentences derived from the statistics (:func:`statements`).
    """

    force: str
    n: int
    results: tuple[IndicatorResult, ...]
    statements: tuple[str, ...]

    def result(self, column: str) -> IndicatorResult | None:
        return next((r for r in self.results if r.column == column), None)

    def as_dict(self) -> dict:
        return {"force": self.force, "n": self.n,
                "indicators": {r.column: r.as_dict() for r in self.results},
                "statements": list(self.statements)}


def compare_indicators(table: pd.DataFrame, force: str = "F_max", *, exclude=None,
                       n_boot: int = 1000, seed: int = 0, confidence: float = 0.95,
                       force_label: str | None = None) -> IndicatorComparison | None:
    """Agreement of T_c^- and of each baseline with ``force`` on the same cases.

    Parameters
    ----------
    table : pandas.DataFrame
        Study results: ``T_c_minus``, the force column, and the baseline columns (or
        their inputs ``v_n``, ``m_total``, ``m_eff_free``: :func:`with_baselines`).
    force : str
        Column of the reference peak force [N].
    exclude : (len(table),) bool array, optional
        Cases left out (e.g. whole-window cases).
    n_boot, seed, confidence
        Bootstrap settings (as :func:`roverimpact.studies.stats.agreement`).
    force_label : str, optional
        Name of the force in the statements (default: the column).

    Returns
    -------
    IndicatorComparison or None
        None if fewer than 3 cases have a finite force and T_c^-.
    """
    table = with_baselines(table)
    if force not in table or "T_c_minus" not in table:
        return None
    y = table[force].to_numpy(float)
    T = table["T_c_minus"].to_numpy(float)
    keep = np.isfinite(y) & np.isfinite(T)
    if exclude is not None:
        keep &= ~np.asarray(exclude, dtype=bool)
    if keep.sum() < 3:
        return None
    y, T = y[keep], T[keep]
    cols, labels, xs, constants = [], [], [], []
    for col, label in INDICATORS.items():  # T_c_minus first
        if col not in table:
            continue
        x = table[col].to_numpy(float)[keep]
        fin = x[np.isfinite(x)]
        # the same value up to round-off (v_n = u sin beta computed per configuration):
        # constant, and ranked as such (ties), not by the round-off
        constant = fin.size >= 1 and bool(np.ptp(fin) <= _SAME * np.max(np.abs(fin)))
        if constant:
            x = np.where(np.isfinite(x), fin[0], x)
        cols.append(col)
        labels.append(label)
        xs.append(x)
        constants.append(constant)
    # T_c^-'s and each baseline's agreement, and the paired Spearman gain of T_c^- over
    # each baseline: on shared resamples (agreement and spearman_difference bit for bit),
    # unless T_c^- is constant (its agreement then ranks the constant, its gains T)
    opts = {"n_boot": n_boot, "seed": seed, "confidence": confidence}
    if not constants[0]:
        ags, gains = agreements_and_gains(xs, y, **opts)
    else:
        ags = [agreement(x, y, **opts) for x in xs]
        gains = [spearman_difference(T, x, y, **opts) for x in xs[1:]]
    results = [IndicatorResult(col, label, a, constant, gain) for col, label, a, constant, gain
               in zip(cols, labels, ags, constants, [None, *gains], strict=True)]
    comp = IndicatorComparison(force, int(keep.sum()), tuple(results), ())
    return IndicatorComparison(force, comp.n, comp.results,
                               tuple(statements(comp, force_label or force)))


#: Relative spread below which an indicator counts as the same in every case.
_SAME = 1e-9


def _f(x: float) -> str:
    return "n/a" if not math.isfinite(x) else f"{x:.3f}"


def _g(x: float) -> str:
    return "n/a" if not math.isfinite(x) else f"{x:+.3f}"


def statements(comp: IndicatorComparison, force_label: str = "F_max") -> list[str]:
    """Where T_c^- earns its keep in ``comp`` and where not: one sentence per baseline
    and a summary, every claim read off the statistics.

    T_c^- *ranks* the force if its own Spearman interval lies above 0 (without bootstrap:
    if rho > 0). Only then can it earn its keep: a baseline is *beaten* if it is
    constant (it cannot rank the cases) or if the paired bootstrap interval of
    Spearman(T_c^-) - Spearman(baseline) lies above 0; *ahead* if it lies below 0;
    *equal* if both coefficients are the same; otherwise the study does not tell them
    apart (interval across 0, or no interval without bootstrap). Where the study does not
    show that T_c^- ranks the force (random or reversed order, or too few cases), the
    statements say so and no baseline
    counts as beaten (a constant baseline once did, whatever T_c^-'s rho: "earns its
    keep" at rho = -1).
    """
    tc = comp.result("T_c_minus")
    if tc is None or not math.isfinite(tc.agreement.spearman.value):
        return []
    rho = tc.agreement.spearman.value
    low, high = tc.agreement.spearman.low, tc.agreement.spearman.high
    pct = round(100 * tc.agreement.confidence)
    ranks = low > 0.0 if math.isfinite(low) else rho > 0.0
    out, beaten, not_beaten, ahead = [], [], [], []
    if not ranks:
        ci = (f"{pct}% CI [{_f(low)}, {_f(high)}]" if math.isfinite(low)
              else "no bootstrap interval")
        out.append(f"This study does not show that T_c^- ranks {force_label}: Spearman "
                   f"{_f(rho)} ({ci}" + (", not above 0" if math.isfinite(low) else "")
                   + ").")
    for r in comp.results:
        if r.spearman_gain is None:
            continue
        g = r.spearman_gain
        rb = r.agreement.spearman.value
        if r.constant and not ranks:
            not_beaten.append(r.label)
            out.append(f"{r.label} is the same for every case here, so it cannot rank them; "
                       f"nor does T_c^- (Spearman {_f(rho)}).")
        elif r.constant:
            beaten.append(r.label)
            out.append(f"{r.label} is the same for every case here, so it cannot rank them; "
                       f"T_c^- ranks {force_label} with Spearman {_f(rho)}.")
        elif not math.isfinite(g.value):
            not_beaten.append(r.label)
            out.append(f"{r.label}: Spearman {_f(rb)}, no comparison with T_c^- "
                       f"({_f(rho)}).")
        elif g.value == 0.0:
            not_beaten.append(r.label)
            out.append(f"{r.label} ranks {force_label} exactly as T_c^- does (Spearman "
                       f"{_f(rho)} both): T_c^- adds nothing over it here.")
        elif math.isfinite(g.low) and g.low > 0.0:
            (beaten if ranks else not_beaten).append(r.label)
            out.append(f"T_c^- ranks {force_label} better than {r.label}: Spearman "
                       f"{_f(rho)} vs {_f(rb)}, difference {_g(g.value)} ({pct}% CI "
                       f"[{_g(g.low)}, {_g(g.high)}]).")
        elif math.isfinite(g.high) and g.high < 0.0:
            ahead.append(r.label)
            out.append(f"{r.label} ranks {force_label} better than T_c^-: Spearman "
                       f"{_f(rb)} vs {_f(rho)}, difference {_g(-g.value)} ({pct}% CI "
                       f"[{_g(-g.high)}, {_g(-g.low)}]).")
        else:
            not_beaten.append(r.label)
            ci = (f"{pct}% CI [{_g(g.low)}, {_g(g.high)}] includes 0"
                  if math.isfinite(g.low) else "no bootstrap interval")
            out.append(f"T_c^- vs {r.label}: Spearman {_f(rho)} vs {_f(rb)}, difference "
                       f"{_g(g.value)} ({ci}): this study (n = {comp.n}) does not tell "
                       "them apart.")
    summary = [] if ranks else [f"this study does not show that T_c^- ranks {force_label}, "
                                "so it earns its keep against no baseline"]
    if beaten:
        summary.append(f"T_c^- earns its keep against {', '.join(beaten)}")
    if not_beaten and ranks:
        summary.append(("not against " if beaten else "T_c^- does not earn its keep against ")
                       + ", ".join(not_beaten) + " (same ranking, or not told apart)")
    if ahead:
        summary.append(f"{', '.join(ahead)} {'ranks' if len(ahead) == 1 else 'rank'} "
                       "better than T_c^-")
    if summary:
        out.append("In short: " + "; ".join(summary) + ".")
    return out
