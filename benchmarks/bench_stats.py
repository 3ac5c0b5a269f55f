"""Speed of the bootstrap statistics of a study with simulated peak forces.

    python benchmarks/bench_stats.py                  # 1e4 and 1e5 cases, 1000 resamples
    python benchmarks/bench_stats.py --sizes 2000 --n-boot 200
    python benchmarks/bench_stats.py --report 1e5     # `roverimpact report` of such a study

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

``--report N``: the whole ``roverimpact report`` of a study with F_max and N cases, in a
child process (wall time and peak resident memory). The study is a real 4-case simulated
sweep of the 2-D rover whose results table is then replaced by N rows of the columns above
(the other columns copied from its rows): the report's statistics, figure and tables run
on N cases without simulating them. To time another version of the package, put its
``src`` first on ``PYTHONPATH``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

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


STUDY = """name = "bench_stats"
simulate = true
x = "obstacle.beta_deg"

[base]
model = { name = "rover2d", params = { suspension = "rocker", h = 0.35 } }
velocity = { u = 0.5 }
contacts = { ground = "normal" }
obstacle = { wheel = "front", beta_deg = 60.0 }
contact_law = { name = "hunt-crossley", k = 1.0e7, e = 0.8 }
simulation = { mu = 0.0, gravity = "earth" }

[grid]
"obstacle.beta_deg" = { start = 20.0, stop = 90.0, num = 4 }
"""


def report(n: int) -> None:
    """``roverimpact report`` of a study of ``n`` cases with F_max (see the docstring)."""
    cli = [sys.executable, "-m", "roverimpact"]
    with tempfile.TemporaryDirectory() as tmp:
        toml, out = Path(tmp) / "study.toml", Path(tmp) / "study"
        toml.write_text(STUDY)
        subprocess.run([*cli, "sweep", str(toml), "-o", str(out)], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        rows = pd.read_parquet(out / "results.parquet")
        rng = np.random.default_rng(0)
        big = rows.iloc[rng.integers(0, len(rows), n)].reset_index(drop=True)
        syn = table(n, rng)
        big["case"] = np.arange(n)
        big["case_id"] = [f"{i:07d}-bench" for i in range(n)]
        big["obstacle.beta_deg"] = np.degrees(np.arcsin(syn["v_n"] / 0.2))
        for col in ("v_n", "m_total", "m_eff_free", "T_c_minus", "F_max"):
            big[col] = syn[col]
        big["m_eff"] = 2 * syn["T_c_minus"] / syn["v_n"] ** 2
        big["F_pred"] = syn["F_max"]
        big["contact_whole_window"] = big["not_an_impact"] = False
        big.to_parquet(out / "results.parquet", index=False)
        manifest = json.loads((out / "manifest.json").read_text())
        manifest["n_cases"] = manifest["n_computed"] = n
        (out / "manifest.json").write_text(json.dumps(manifest, indent=1))
        # the command in a process of its own, which says its own peak memory at the end
        code = ("import resource, sys\nfrom roverimpact.cli import main\n"
                f"rc = main(['report', {str(out)!r}])\n"
                "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr)\n"
                "sys.exit(rc)")
        t0 = time.perf_counter()
        run = subprocess.run([sys.executable, "-c", code], check=True, text=True,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        wall = time.perf_counter() - t0
        peak = int(run.stderr.split()[-1]) / 1024  # kB -> MB
    import roverimpact

    print(f"roverimpact report of {n:,} cases with F_max ({roverimpact.__file__}): "
          f"{wall:.1f} s, peak resident memory {peak:.0f} MB")


def main() -> None:
    print(reference())  # how fast this machine is right now (machine.py)
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=float, nargs="+", default=[1e4, 1e5])
    ap.add_argument("--n-boot", type=int, default=1000)
    ap.add_argument("--baseline", type=int, default=20,
                    help="resamples the scipy baseline is timed on (scaled to --n-boot)")
    ap.add_argument("--report", type=float, metavar="N",
                    help="time `roverimpact report` of a study of N cases with F_max instead")
    a = ap.parse_args()
    if a.report:
        report(int(a.report))
        return
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
