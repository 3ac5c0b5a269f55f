r"""Force-sensor experiments: ingest recordings, detect impacts, compare with the model.

Pipeline for each trial (one CSV file), see ``docs/experiments.md``:

1. read ``time_s, <channel>_<unit>, ...`` and check it (units in the header must match the
   trials file, time strictly increasing and uniformly sampled, short NaN gaps only);
2. scale every channel by its calibration gain [N per raw unit];
3. remove each channel's offset and linear drift, fitted on the samples outside impacts
   (found from a first robust line, then iterated);
4. low-pass filter with a zero-phase Butterworth filter (``scipy.signal.sosfiltfilt``);
5. sum the channels into the normal force F(t) [N];
6. detect each impact (F above a threshold set from the noise; two bounces joined by a
   light contact are split at the minimum between them), its peak force, duration
   (between the threshold crossings around the peak) and impulse :math:`\int F\,dt`
   (over the whole event, zero crossings and the filter's ringing included); an impact
   shorter than a few periods of the cut-off is flagged ``short``.

Trials are independent: a corrupted file is reported (:class:`TrialFailure`) and the
others still run. :func:`compare_with_model` puts the measured peaks next to a model's
:math:`T_c^-` and simulated :math:`F_{max}` for the same :math:`\beta` and speed, with rank
agreement (Kendall :math:`\tau`, Spearman :math:`\rho`).

The model is any callable ``model_fn(beta_rad, speed) -> {"T_c_minus": J, "F_max": N}``.
The trials file's ``[model]`` table (``kind = "scenario"``) builds a :class:`ScenarioModel`:
a scenario TOML file (the rover, its contacts, the obstacle law and a ``[simulation]``
table) whose obstacle angle and driving speed are set per condition; :math:`T_c^-` comes
from :mod:`roverimpact.scenario` and :math:`F_{max}` from the compliant-contact simulator
:mod:`roverimpact.simulate`, both through :func:`roverimpact.studies.evaluate.evaluate_case`.
"""

from .compare import ModelComparison, ScenarioModel, compare_with_model, scenario_model
from .pipeline import ExperimentResult, process_recording, run_experiment, write_outputs
from .recording import TrialDataError, TrialFailure, read_recording
from .signal import detect_impacts, fit_gain, lowpass, normal_force
from .synthetic import SYNTHETIC_TRUTH, make_synthetic_trials
from .trials import (
    DetectionConfig,
    FilterConfig,
    ScenarioModelConfig,
    SensorsConfig,
    TrialConfig,
    TrialsFile,
    load_trials,
)

__all__ = [
    "SYNTHETIC_TRUTH",
    "DetectionConfig",
    "ExperimentResult",
    "FilterConfig",
    "ModelComparison",
    "ScenarioModel",
    "ScenarioModelConfig",
    "SensorsConfig",
    "TrialConfig",
    "TrialDataError",
    "TrialFailure",
    "TrialsFile",
    "compare_with_model",
    "detect_impacts",
    "fit_gain",
    "load_trials",
    "lowpass",
    "make_synthetic_trials",
    "normal_force",
    "process_recording",
    "read_recording",
    "run_experiment",
    "scenario_model",
    "write_outputs",
]
