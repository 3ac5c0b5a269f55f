"""Cases whose contact lasted the whole simulated window: found, flagged, excluded from the
agreement statistics, and the exclusion said.

The simulator's side (``contact_whole_window`` = not ``separated``, ``contact_duration`` =
``t_after``) is checked on the quick reproduction in tests/test_study_reproduce.py.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from roverimpact.report.html import analyse_folder
from roverimpact.studies.stats import agreement
from roverimpact.studies.store import whole_window_cases


def test_from_the_column():
    t = pd.DataFrame({"contact_whole_window": [True, False, None]})
    assert whole_window_cases(t).tolist() == [True, False, False]


def test_older_tables_from_the_duration_cap():
    t = pd.DataFrame({"contact_duration": [0.2, 0.019, np.nan, 0.05],
                      "simulation.t_after": [0.2, 0.2, 0.2, 0.05]})
    assert whole_window_cases(t).tolist() == [True, False, False, True]


def test_no_simulation_no_whole_window_case():
    assert not whole_window_cases(pd.DataFrame({"T_c_minus": [1.0, 2.0]})).any()


def test_report_excludes_them_and_says_how_many(tmp_path):
    beta = np.array([10.0, 20.0, 30.0, 50.0, 70.0, 90.0])
    T = np.array([0.03, 0.1, 0.34, 1.10, 2.15, 1.93])
    F = np.array([900.0, 400.0, 634.0, 1234.0, 1766.0, 1773.0])  # 10 deg: a static load
    ww = [True, False, False, False, False, False]
    pd.DataFrame({"case": range(6), "obstacle.beta_deg": beta, "T_c_minus": T, "F_max": F,
                  "contact_duration": [0.2, 0.03, 0.02, 0.02, 0.02, 0.02],
                  "contact_whole_window": ww}).to_parquet(tmp_path / "results.parquet")
    (tmp_path / "manifest.json").write_text(json.dumps(
        {"name": "s", "parameters": ["obstacle.beta_deg"], "x": "obstacle.beta_deg",
         "simulate": True}))
    s = analyse_folder(tmp_path, n_boot=100, seed=1)
    ref = agreement(T[1:], F[1:], n_boot=100, seed=1)  # the statistics of the other five
    assert s.agreement.n == 5 and s.n_whole_window == 1
    assert s.agreement.spearman.value == pytest.approx(ref.spearman.value)
    assert s.n_text == "n = 5 (1 whole-window case excluded)"
    stats = json.loads((tmp_path / "stats.json").read_text())
    assert stats["n"] == 5 and stats["n_whole_window"] == 1
    assert stats["whole_window"] == "excluded"
    with_it = agreement(T, F, n_boot=0)
    assert with_it.spearman.value < s.agreement.spearman.value  # it did change the answer
