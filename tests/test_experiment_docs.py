"""Numbers docs/experiments.md and the package docstring quote about the pipeline."""

from __future__ import annotations

import re
from pathlib import Path

import tomllib

from roverimpact import experiments as ex

DOCS = Path(__file__).resolve().parents[1] / "docs" / "experiments.md"


def _trials_example() -> dict:
    text = DOCS.read_text()
    block = re.search(r"\*\*Trials file\*\*.*?```toml\n(.*?)```", text, re.S).group(1)
    return tomllib.loads(block)


def test_documented_defaults_are_the_defaults():
    """The '[detection] # all optional' and [filter] tables show the defaults: baseline_s
    read 0.1 while the default is 0.05."""
    doc = _trials_example()
    for table, cls in (("detection", ex.DetectionConfig), ("filter", ex.FilterConfig)):
        assert doc[table] == cls().model_dump(), table


def test_package_docstring_says_where_the_duration_is_measured():
    """It said 'duration (between the zero crossings around the peak)'; detect_impacts
    and the docs measure it between the threshold crossings."""
    doc = " ".join(ex.__doc__.split())
    assert "duration (between the threshold crossings around the peak)" in doc
    assert "duration (between the zero crossings" not in doc
    assert "where F crosses the threshold" in " ".join(ex.detect_impacts.__doc__.split())


def test_documented_rank_statistics_are_scipys():
    """The docs say Kendall tau-b (scipy, ties) and Spearman's p exact up to
    SPEARMAN_EXACT_MAX_N conditions; checked against scipy.stats on a tied sample."""
    from itertools import permutations

    import numpy as np
    from scipy import stats as sps

    from roverimpact.studies.stats import SPEARMAN_EXACT_MAX_N, rank_correlation

    text = " ".join(DOCS.read_text().split())
    assert f"exact by permutations up to {SPEARMAN_EXACT_MAX_N} conditions" in text
    x, y = np.array([105.0, 95, 95, 70, 40]), np.array([0.081, 0.072, 0.054, 0.045, 0.018])
    rc = rank_correlation(x, y)
    kt = sps.kendalltau(x, y)
    assert (rc.kendall_tau, rc.kendall_p) == (kt.statistic, kt.pvalue)
    rho = sps.spearmanr(x, y).statistic
    # the exact two-sided p: all 5! pairings, each ranked by scipy
    rhos = [sps.spearmanr(x, y[list(p)]).statistic for p in permutations(range(5))]
    assert rc.spearman_rho == rho
    assert abs(rc.spearman_p - np.mean(np.abs(rhos) >= abs(rho) - 1e-12)) < 1e-12
