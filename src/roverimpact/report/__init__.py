"""Reports of studies: figures (plots.py) and a self-contained HTML report (html.py).

Names are loaded on first use (PEP 562), as the package's: a command that draws one figure
(``roverimpact simulate``'s force history, :mod:`.simulation`) does not import the
study report and its statistics (scipy.stats) with it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import attach as _attach

#: public name -> module that defines it (relative to this package)
_EXPORTS = {"build_report": ".html", "plot_study": ".plots"}

__all__ = ["build_report", "plot_study"]


__getattr__, __dir__ = _attach(__name__, _EXPORTS)

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs
    from .html import build_report
    from .plots import plot_study
