"""Speed of the bootstrap statistics of a study with simulated peak forces.

    python benchmarks/bench_stats.py                  # 1e4 and 1e5 cases, 1000 resamples
    python benchmarks/bench_stats.py --sizes 2000 --n-boot 200

For each size n (cases with T_c^- and F_max), in one process:

- ``agreement(x, y, n_boot)``: Spearman, Kendall tau-b, Pearson and the concordant
  fraction with their percentile bootstrap intervals (above 400 cases the compiled
  kernel, ``roverimpact._kernels.bootstrap``), against what a user would write: per
  resample ``scipy.stats.spearmanr``, ``kendalltau`` and ``pearsonr`` of ``x[i], y[i]``
  (timed on ``--baseline`` resamples and scaled to ``n_boot``);
- ``spearman_difference(x1, x2, y, n_boot)``, the paired bootstrap of the gain of T_c^-
  over a baseline;
- ``compare_indicators`` of a synthetic results table: what a study's report computes
  with F_max (T_c^- and three baselines, each with its intervals, and three paired
  differences).

The data are seeded: T_c^- of random (v_n, m_eff), F_max a noisy power of T_c^-.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd
from machine import reference
from scipy import stats as sps

from roverimpact.studies.indicators import compare_indicators
from roverimpact.studies.stats import agreement, spearman_difference


def table(n: int, rng: np.random.Generator) -> pd.DataFrame:
    """A study's columns: approach speed, masses, T_c^- and a peak force."""
    v_n = 0.2 * np.sin(rng.uniform(0.05, np.pi / 2, n))
    m_eff_free = rng.uniform(5.0, 20.0, n)
    m_eff = m_eff_free * rng.uniform(0.5, 1.0, n)
    T = 0.5 * m_eff * v_n**2
    return pd.DataFrame({"v_n": v_n, "m_total": np.full(n, 25.0), "m_eff_free": m_eff_free,
                         "T_c_minus": T,
                         "F_max": 3e3 * T**0.6 * np.exp(0.1 * rng.standard_normal(n))})


def by_scipy(x, y, idx) -> np.ndarray:
    """Per resample, what a user would write with scipy."""
    out = np.empty((len(idx), 3))
    for b, i in enumerate(idx):
        out[b] = (sps.spearmanr(x[i], y[i]).statistic, sps.kendalltau(x[i], y[i]).statistic,
                  sps.pearsonr(x[i], y[i]).statistic)
    return out


def main() -> None:
    print(reference())  # how fast this machine is right now (machine.py)
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=float, nargs="+", default=[1e4, 1e5])
    ap.add_argument("--n-boot", type=int, default=1000)
    ap.add_argument("--baseline", type=int, default=20,
                    help="resamples the scipy baseline is timed on (scaled to --n-boot)")
    a = ap.parse_args()
    rng = np.random.default_rng(0)
    agreement(rng.standard_normal(500), rng.standard_normal(500), n_boot=100)  # compiled
    for n in (int(s) for s in a.sizes):
        df = table(n, rng)
        x, y = df["T_c_minus"].to_numpy(), df["F_max"].to_numpy()
        t0 = time.perf_counter()
        ag = agreement(x, y, n_boot=a.n_boot)
        t_ag = time.perf_counter() - t0
        idx = np.random.default_rng(0).integers(0, n, (a.baseline, n))
        t0 = time.perf_counter()
        ref = by_scipy(x, y, idx)
        t_ref = (time.perf_counter() - t0) * a.n_boot / a.baseline
        t0 = time.perf_counter()
        spearman_difference(x, df["v_n"].to_numpy(), y, n_boot=a.n_boot)
        t_diff = time.perf_counter() - t0
        t0 = time.perf_counter()
        comp = compare_indicators(df, n_boot=a.n_boot)
        t_comp = time.perf_counter() - t0
        assert comp is not None and np.all(np.isfinite(ref))
        print(f"{n:>9,} cases, {a.n_boot} resamples:")
        print(f"  agreement            {t_ag:7.2f} s  (Spearman {ag.spearman.value:.3f} "
              f"[{ag.spearman.low:.3f}, {ag.spearman.high:.3f}], Kendall "
              f"{ag.kendall.value:.3f} [{ag.kendall.low:.3f}, {ag.kendall.high:.3f}])")
        print(f"  scipy per resample   {t_ref:7.2f} s  (timed on {a.baseline} resamples; "
              f"{t_ref / t_ag:.1f}x the time of agreement)")
        print(f"  spearman_difference  {t_diff:7.2f} s")
        print(f"  compare_indicators   {t_comp:7.2f} s  (a report's statistics with F_max: "
              f"{len(comp.results)} indicators and {len(comp.results) - 1} differences)")


if __name__ == "__main__":
    main()
