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
