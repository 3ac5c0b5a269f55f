"""Reports of studies: figures (plots.py) and a self-contained HTML report (html.py).

Names are loaded on first use (PEP 562), as the package's: a command that draws one figure
(``roverimpact simulate``'s force history, :mod:`.simulation`) does not import the
study report and its statistics (scipy.stats) with it.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

#: public name -> module that defines it (relative to this package)
_EXPORTS = {"build_report": ".html", "plot_study": ".plots"}

__all__ = ["build_report", "plot_study"]


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(_EXPORTS[name], __name__), name)
        globals()[name] = value  # later lookups skip this function
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *_EXPORTS})


if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs
    from .html import build_report
    from .plots import plot_study
