"""Studies: sweeps over scenario parameters, agreement statistics, paper reproduction.

See ``docs/studies.md``. The wiring to the model, contact and simulation layers is in
:mod:`roverimpact.studies.evaluate`. Names are loaded on first use (PEP 562), as the
package's: code that needs the statistics or the results store (``roverimpact report``)
does not import the evaluator, the scenario layer and MuJoCo with them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import attach as _attach

#: public name -> module that defines it (relative to this package)
_EXPORTS = {
    "Case": ".config", "Study": ".config", "expand": ".config", "load_study": ".config",
    "FunctionEvaluator": ".evaluate", "ScenarioEvaluator": ".evaluate",
    "evaluate_case": ".evaluate",
    "IndicatorComparison": ".indicators", "compare_indicators": ".indicators",
    "Agreement": ".stats", "Estimate": ".stats", "agreement": ".stats",
    "concordant_pair_fraction": ".stats", "spearman_difference": ".stats",
    "StudyResult": ".sweep", "load_results": ".sweep", "not_posed": ".sweep",
    "prepare_study": ".sweep", "run_study": ".sweep",
}

__all__ = [
    "Agreement",
    "Case",
    "Estimate",
    "FunctionEvaluator",
    "IndicatorComparison",
    "ScenarioEvaluator",
    "Study",
    "StudyResult",
    "agreement",
    "compare_indicators",
    "concordant_pair_fraction",
    "evaluate_case",
    "expand",
    "load_results",
    "load_study",
    "not_posed",
    "prepare_study",
    "run_study",
    "spearman_difference",
]


__getattr__, __dir__ = _attach(__name__, _EXPORTS)

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs
    from .config import Case, Study, expand, load_study
    from .evaluate import FunctionEvaluator, ScenarioEvaluator, evaluate_case
    from .indicators import IndicatorComparison, compare_indicators
    from .stats import (
        Agreement,
        Estimate,
        agreement,
        concordant_pair_fraction,
        spearman_difference,
    )
    from .sweep import StudyResult, load_results, not_posed, prepare_study, run_study
