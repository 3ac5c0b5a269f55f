"""Studies: sweeps over scenario parameters, agreement statistics, paper reproduction.

See ``docs/studies.md``. The wiring to the model, contact and simulation layers is in
:mod:`roverimpact.studies.evaluate`.
"""

from .config import Case, Study, expand, load_study
from .evaluate import FunctionEvaluator, ScenarioEvaluator, evaluate_case
from .indicators import IndicatorComparison, compare_indicators
from .stats import Agreement, Estimate, agreement, concordant_pair_fraction, spearman_difference
from .sweep import StudyResult, load_results, not_posed, prepare_study, run_study

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
