"""Reports of studies: figures (plots.py) and a self-contained HTML report (html.py)."""

from .html import build_report
from .plots import plot_study

__all__ = ["build_report", "plot_study"]
