r"""Force-sensor experiments: ingest recordings, detect impacts, compare with the model.

Pipeline for each trial (one CSV file), see ``docs/experiments.md``:

1. read ``time_s, <channel>_<unit>, ...`` and check it (units in the header must match the
   trials file, time strictly increasing and uniformly sampled, short NaN gaps only);
2. scale every channel by its calibration gain [N per raw unit];
3. remove each channel's offset and linear drift, fitted on the samples outside impacts;
4. low-pass filter with a zero-phase Butterworth filter (``scipy.signal.sosfiltfilt``);
5. sum the channels into the normal force F(t) [N];
6. detect each impact (F above a threshold set from the noise), its peak force, impulse
   :math:`\int F\,dt` and duration (between the zero crossings around the peak).

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

from __future__ import annotations

import math
import shutil
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from .._io import read_toml
from ..exceptions import ConfigError, InputError

__all__ = [
    "DetectionConfig",
    "ExperimentResult",
    "FilterConfig",
    "ModelComparison",
    "ScenarioModel",
    "ScenarioModelConfig",
    "SensorsConfig",
    "TrialConfig",
    "TrialFailure",
    "TrialsFile",
    "compare_with_model",
    "detect_impacts",
    "fit_gain",
    "load_trials",
    "lowpass",
    "make_synthetic_trials",
    "normal_force",
    "plot_overlay",
    "process_recording",
    "read_recording",
    "run_experiment",
    "write_outputs",
]


# ----------------------------------------------------------------------------------------
# Trials file
# ----------------------------------------------------------------------------------------


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class SensorsConfig(_Strict):
    """``[sensors]``: force channels, calibration gains and units.

    ``gains[i]`` converts channel i from its raw unit to newtons (N per raw unit); the CSV
    column of channel i must be named ``<channels[i]>_<units[i]>``. ``units`` may be one
    string for all channels. ``sample_rate_hz``, if given, is checked against the time
    column (1 % tolerance).
    """

    channels: list[str] = Field(min_length=1)
    gains: list[float]
    units: list[str] | str = "V"
    sample_rate_hz: float | None = Field(None, gt=0, allow_inf_nan=False)

    @model_validator(mode="after")
    def _lengths(self):
        if len(self.gains) != len(self.channels):
            raise ValueError(
                f"gains has {len(self.gains)} values for {len(self.channels)} channels"
            )
        if not all(math.isfinite(g) and g != 0 for g in self.gains):
            raise ValueError(f"gains must be finite and non-zero, got {self.gains}")
        if isinstance(self.units, list) and len(self.units) != len(self.channels):
            raise ValueError(
                f"units has {len(self.units)} entries for {len(self.channels)} channels"
            )
        if len(set(self.channels)) != len(self.channels):
            raise ValueError(f"channel names must be unique, got {self.channels}")
        return self

    @property
    def unit_list(self) -> list[str]:
        return [self.units] * len(self.channels) if isinstance(self.units, str) else self.units

    @property
    def columns(self) -> list[str]:
        """CSV column names expected for the channels."""
        return [f"{c}_{u}" for c, u in zip(self.channels, self.unit_list, strict=True)]


class FilterConfig(_Strict):
    """``[filter]``: zero-phase Butterworth low-pass (``sosfiltfilt``, so the effective
    order is twice ``order``)."""

    cutoff_hz: float = Field(300.0, gt=0, allow_inf_nan=False)
    order: int = Field(4, ge=1, le=12)


class DetectionConfig(_Strict):
    """``[detection]``: impact detection and offset removal (all optional).

    An impact is where the filtered force exceeds
    ``max(threshold_n, noise_sigmas * noise, 0.001 * max|F|)``, ``noise`` being the robust
    standard deviation (1.4826 MAD) of the first ``baseline_s`` seconds (then of all the
    samples away from impacts); the last term only matters for noise-free data. Impacts closer than
    ``min_separation_s`` are merged. NaN runs of up to ``max_nan_run`` samples are
    interpolated; longer ones make the file fail.
    """

    threshold_n: float = Field(0.0, ge=0, allow_inf_nan=False)
    noise_sigmas: float = Field(10.0, gt=0, allow_inf_nan=False)
    baseline_s: float = Field(0.05, gt=0, allow_inf_nan=False)
    min_separation_s: float = Field(0.005, ge=0, allow_inf_nan=False)
    max_nan_run: int = Field(3, ge=0)


class TrialConfig(_Strict):
    """``[[trial]]``: one recording. ``file`` is relative to the trials file; ``speed`` is
    the approach speed [m/s]; ``beta_deg`` the face angle [deg]."""

    file: str
    beta_deg: float = Field(allow_inf_nan=False)
    speed: float = Field(gt=0, allow_inf_nan=False)
    repeat: int = 1
    notes: str = ""


class ScenarioModelConfig(_Strict):
    """``[model]`` with ``kind = "scenario"``: the rover model of the comparison.

    ``scenario`` is a scenario TOML file (path relative to the trials file) with an
    optional ``[simulation]`` table; see :class:`ScenarioModel`.
    """

    kind: Literal["scenario"]
    scenario: str

    def build(self, base_dir: str | Path = ".") -> ScenarioModel:
        """The :class:`ScenarioModel` of ``base_dir / scenario``."""
        return ScenarioModel.from_file(Path(base_dir) / self.scenario)


class TrialsFile(_Strict):
    """A trials file (TOML): ``[sensors]``, ``[filter]``, ``[detection]``, ``[[trial]]``
    and an optional ``[model]`` for the model comparison. Unknown keys are rejected."""

    sensors: SensorsConfig
    filter: FilterConfig = FilterConfig()
    detection: DetectionConfig = DetectionConfig()
    trial: list[TrialConfig] = Field(min_length=1)
    model: ScenarioModelConfig | None = None
    description: str = ""


def load_trials(path: str | Path) -> tuple[TrialsFile, Path]:
    """Read and validate a trials file; returns it and the directory its paths are relative to.

    Raises
    ------
    ConfigError
        Malformed TOML or a wrong/unknown key, with the key path named.
    """
    path = Path(path)
    raw = read_toml(path)
    try:
        cfg = TrialsFile.model_validate(raw)
    except ValidationError as exc:
        msgs = "; ".join(
            f"{'.'.join(str(p) for p in e['loc']) or '(top)'}: {e['msg']}" for e in exc.errors()
        )
        raise ConfigError(f"{path}: {msgs}") from None
    return cfg, path.resolve().parent


# ----------------------------------------------------------------------------------------
# Reading and signal processing
# ----------------------------------------------------------------------------------------


class TrialDataError(InputError):
    """A recording cannot be used (the message says why)."""


@dataclass(frozen=True)
class TrialFailure:
    """A trial that could not be processed."""

    trial: int
    file: str
    message: str


def _nan_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, length) of the runs of True in a 1-D boolean array."""
    if not mask.any():
        return []
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts = np.flatnonzero(d == 1)
    ends = np.flatnonzero(d == -1)
    return list(zip(starts.tolist(), (ends - starts).tolist(), strict=True))


def read_recording(path: str | Path, sensors: SensorsConfig, *, max_nan_run: int = 3):
    """Read one CSV recording and check it.

    Returns
    -------
    t : (N,) ndarray
        Time [s], strictly increasing, uniformly sampled.
    raw : (N, n_channels) ndarray
        Raw channel values in their unit (short NaN gaps interpolated).
    fs : float
        Sampling rate [Hz].
    n_filled : int
        Number of samples that were NaN and got interpolated.

    Raises
    ------
    TrialDataError
        Missing file, empty file, missing columns, a unit in the header that differs from
        the trials file, non-numeric values, non-monotone or irregular time, long NaN runs.
    """
    path = Path(path)
    if not path.is_file():
        raise TrialDataError(f"{path.name}: no such file")
    try:
        df = pd.read_csv(path, comment="#", skipinitialspace=True)
    except pd.errors.EmptyDataError:
        raise TrialDataError(f"{path.name}: empty file (no header, no data)") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise TrialDataError(f"{path.name}: not a readable CSV file ({exc})") from None
    df.columns = [str(c).strip() for c in df.columns]
    if "time_s" not in df.columns:
        raise TrialDataError(
            f"{path.name}: no 'time_s' column (header is {list(df.columns)}); the first "
            "column must be the time in seconds"
        )
    cols = []
    for ch, unit, col in zip(sensors.channels, sensors.unit_list, sensors.columns,
                             strict=True):
        if col in df.columns:
            cols.append(col)
            continue
        other = [c for c in df.columns if c.startswith(f"{ch}_")]
        if other:
            raise TrialDataError(
                f"{path.name}: column {other[0]!r} has unit {other[0][len(ch) + 1:]!r} but the "
                f"trials file gives unit {unit!r} for channel {ch!r} (expected column {col!r})"
            )
        raise TrialDataError(
            f"{path.name}: missing column {col!r} for channel {ch!r} (header is "
            f"{list(df.columns)})"
        )
    if len(df) == 0:
        raise TrialDataError(f"{path.name}: header but no data rows")
    try:
        numeric = df[["time_s", *cols]].apply(pd.to_numeric, errors="raise")
        data = np.array(numeric, dtype=float)
    except (ValueError, TypeError) as exc:
        raise TrialDataError(f"{path.name}: non-numeric value ({exc})") from None
    t, raw = data[:, 0], data[:, 1:]
    if len(t) < 16:
        raise TrialDataError(f"{path.name}: only {len(t)} samples; need at least 16")
    if not np.all(np.isfinite(t)):
        i = int(np.flatnonzero(~np.isfinite(t))[0])
        raise TrialDataError(f"{path.name}: time_s is NaN or inf at row {i + 1}")
    dt = np.diff(t)
    if np.any(dt <= 0):
        i = int(np.flatnonzero(dt <= 0)[0])
        raise TrialDataError(
            f"{path.name}: time is not strictly increasing at row {i + 2} "
            f"(t = {t[i]:.6g} s then {t[i + 1]:.6g} s)"
        )
    dt_med = float(np.median(dt))
    if np.max(np.abs(dt - dt_med)) > 0.05 * dt_med:
        i = int(np.argmax(np.abs(dt - dt_med)))
        raise TrialDataError(
            f"{path.name}: irregular sampling at row {i + 2} (step {dt[i]:.3g} s, median "
            f"{dt_med:.3g} s); resample the recording to a uniform rate"
        )
    fs = 1.0 / dt_med
    if sensors.sample_rate_hz is not None and abs(fs - sensors.sample_rate_hz) > (
        0.01 * sensors.sample_rate_hz
    ):
        raise TrialDataError(
            f"{path.name}: time column gives {fs:.6g} Hz but the trials file says "
            f"sample_rate_hz = {sensors.sample_rate_hz:g}"
        )
    n_filled = 0
    for j, col in enumerate(cols):
        bad = ~np.isfinite(raw[:, j])
        if not bad.any():
            continue
        runs = _nan_runs(bad)
        start, length = max(runs, key=lambda r: r[1])
        if length > max_nan_run or bad.all():
            raise TrialDataError(
                f"{path.name}: column {col!r} has a run of {length} NaN/missing samples from "
                f"t = {t[start]:.6g} s (at most {max_nan_run} are interpolated)"
            )
        good = ~bad
        raw[bad, j] = np.interp(t[bad], t[good], raw[good, j])
        n_filled += int(bad.sum())
    return t, raw, fs, n_filled


def lowpass(x, fs: float, cutoff_hz: float, order: int = 4, axis: int = 0) -> np.ndarray:
    """Zero-phase Butterworth low-pass: ``sosfiltfilt(butter(order, cutoff, fs=fs))``.

    Forward-backward filtering doubles the order and cancels the phase: no time shift of
    the peak. The gain at ``cutoff_hz`` is 1/2 (-6 dB).

    Raises
    ------
    InputError
        Cut-off at or above the Nyquist frequency, or a signal too short to filter.
    """
    from scipy.signal import butter, sosfiltfilt

    if not 0 < cutoff_hz < 0.5 * fs:
        raise InputError(
            f"filter cutoff_hz = {cutoff_hz:g} must be between 0 and the Nyquist frequency "
            f"{0.5 * fs:g} Hz"
        )
    sos = butter(order, cutoff_hz, btype="low", fs=fs, output="sos")
    x = np.asarray(x, dtype=float)
    padlen = 3 * (2 * len(sos) + 1)
    if x.shape[axis] <= padlen:
        raise InputError(f"signal of {x.shape[axis]} samples is too short to filter "
                         f"(needs more than {padlen})")
    return sosfiltfilt(sos, x, axis=axis)


def _robust_sigma(x: np.ndarray) -> float:
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


def _regions(mask: np.ndarray, gap: int) -> list[tuple[int, int]]:
    """[start, end) index ranges of True runs, merging runs separated by <= gap samples."""
    runs = [(s, s + n) for s, n in _nan_runs(mask)]
    merged: list[tuple[int, int]] = []
    for s, e in runs:
        if merged and s - merged[-1][1] <= gap:
            merged[-1] = (merged[-1][0], e)
        else:
            merged.append((s, e))
    return merged


def normal_force(t, raw, gains, fs: float, filt: FilterConfig = FilterConfig(),
                 det: DetectionConfig = DetectionConfig()):
    """Calibrated, offset- and drift-free, filtered normal force from the raw channels.

    Each channel is multiplied by its gain, then a straight line (offset + drift) fitted
    to the samples away from impacts is subtracted, the result is low-pass filtered and
    the channels are summed.

    Returns
    -------
    F : (N,) ndarray
        Normal force [N].
    threshold : float
        Detection threshold used [N].
    offsets : (n_channels,) ndarray
        Fitted channel offsets at t[0] [N].
    """
    t = np.asarray(t, float)
    forces = np.asarray(raw, float) * np.asarray(gains, float)[None, :]
    nb = max(round(det.baseline_s * fs), 8)
    if nb >= len(t) // 2:
        raise InputError(f"recording of {t[-1] - t[0]:.3g} s is too short for a baseline of "
                         f"{det.baseline_s:g} s")
    # pass 1: constant offset from the baseline window, find the impact regions
    f0 = lowpass(forces - np.median(forces[:nb], axis=0), fs, filt.cutoff_hz, filt.order)
    s0 = f0.sum(axis=1)
    sigma = _robust_sigma(s0[:nb])
    threshold = max(det.threshold_n, det.noise_sigmas * sigma, 1e-3 * np.max(np.abs(s0)))
    active = np.abs(s0) > threshold
    quiet = np.ones(len(t), bool)
    for s, e in _regions(active, 0):
        guard = max(e - s, int(0.01 * fs))
        quiet[max(s - guard, 0): e + guard] = False
    if quiet.sum() < nb:
        raise InputError("too few samples away from impacts to fit the sensor offset")
    # pass 2: offset + linear drift per channel, least squares on the quiet samples
    X = np.stack([np.ones(quiet.sum()), t[quiet] - t[0]], axis=1)
    coef, *_ = np.linalg.lstsq(X, forces[quiet], rcond=None)
    base = coef[0][None, :] + (t - t[0])[:, None] * coef[1][None, :]
    F = lowpass(forces - base, fs, filt.cutoff_hz, filt.order).sum(axis=1)
    sigma = _robust_sigma(F[quiet])
    threshold = max(det.threshold_n, det.noise_sigmas * sigma, 1e-3 * np.max(np.abs(F)))
    return F, threshold, coef[0]


def _crossing(t, F, i, j, level: float = 0.0) -> float:
    """Time where F crosses ``level`` between samples i and j (linear interpolation)."""
    if F[i] == F[j]:
        return float(t[i])
    return float(t[i] + (t[j] - t[i]) * (F[i] - level) / (F[i] - F[j]))


def detect_impacts(t, F, threshold: float, *, min_separation_s: float = 0.005) -> pd.DataFrame:
    """Impacts in a force trace: peak, impulse and duration of each excursion above threshold.

    Each region where ``F > threshold`` (regions closer than ``min_separation_s`` merged,
    e.g. filter ringing next to a large peak) gives one impact, measured on the lobe that
    holds its peak:

    - ``F_peak`` = max F [N] at ``t_peak`` [s],
    - ``t_start``, ``t_end``, ``duration``: where F crosses the threshold (interpolated)
      and the time between [s] (the low tails under the threshold are left out: with a
      threshold of a few noise sigmas they are short, and the zero crossings themselves
      wander with the noise),
    - ``impulse`` = :math:`\\int F\\,dt` [N s] (trapezoidal) over the region widened to the
      zero crossings of F on either side, so that the tails are counted.

    Returns
    -------
    pandas.DataFrame
        Columns ``impact, t_start, t_peak, t_end, F_peak, impulse, duration`` (empty if none).
    """
    t = np.asarray(t, float)
    F = np.asarray(F, float)
    dt = float(np.median(np.diff(t)))
    gap = round(min_separation_s / dt)
    rows = []
    for s, e in _regions(F > threshold, gap):
        k = s + int(np.argmax(F[s:e]))
        # main lobe: walk from the peak to the threshold crossings, then to the zero crossings
        s1 = k
        while s1 > 0 and F[s1 - 1] > threshold:
            s1 -= 1
        e1 = k
        while e1 < len(F) - 1 and F[e1 + 1] > threshold:
            e1 += 1
        a, b = s1, e1
        while a > 0 and F[a - 1] > 0:
            a -= 1
        while b < len(F) - 1 and F[b + 1] > 0:
            b += 1
        z0 = _crossing(t, F, a - 1, a) if a > 0 else float(t[0])
        z1 = _crossing(t, F, b, b + 1) if b < len(F) - 1 else float(t[-1])
        tt = np.concatenate([[z0], t[a:b + 1], [z1]])
        ff = np.concatenate([[0.0], F[a:b + 1], [0.0]])
        t0 = _crossing(t, F, s1 - 1, s1, threshold) if s1 > 0 else float(t[0])
        t1 = _crossing(t, F, e1, e1 + 1, threshold) if e1 < len(F) - 1 else float(t[-1])
        rows.append({
            "t_start": t0, "t_peak": float(t[k]), "t_end": t1, "F_peak": float(F[k]),
            "impulse": float(np.trapezoid(ff, tt)), "duration": t1 - t0,
        })
    df = pd.DataFrame(rows, columns=["t_start", "t_peak", "t_end", "F_peak", "impulse",
                                     "duration"])
    df.insert(0, "impact", np.arange(len(df)))
    return df


def process_recording(path, cfg: TrialsFile):
    """Read, calibrate, filter and detect impacts in one recording.

    Returns
    -------
    impacts : pandas.DataFrame
        As :func:`detect_impacts`, plus ``threshold``, ``fs`` and ``n_filled``.
    trace : (t, F)
        The processed normal force.

    Raises
    ------
    TrialDataError
        Unusable file, or no impact above the threshold.
    """
    t, raw, fs, n_filled = read_recording(path, cfg.sensors,
                                          max_nan_run=cfg.detection.max_nan_run)
    name = Path(path).name
    try:
        F, thr, _ = normal_force(t, raw, cfg.sensors.gains, fs, cfg.filter, cfg.detection)
    except InputError as exc:
        raise TrialDataError(f"{name}: {exc}") from None
    imp = detect_impacts(t, F, thr, min_separation_s=cfg.detection.min_separation_s)
    if imp.empty:
        raise TrialDataError(
            f"{name}: no impact found (force never exceeds the threshold {thr:.3g} N; "
            f"peak {np.max(F):.3g} N)"
        )
    imp["threshold"] = thr
    imp["fs"] = fs
    imp["n_filled"] = n_filled
    return imp, (t, F)


@dataclass
class ExperimentResult:
    """Everything :func:`run_experiment` found.

    Attributes
    ----------
    impacts : pandas.DataFrame
        One row per detected impact of every successful trial (trial metadata included).
    trials : pandas.DataFrame
        One row per successful trial: its main (largest) impact.
    failures : list of TrialFailure
        Trials that could not be processed, with the reason.
    config : TrialsFile
    base_dir : Path
        Directory the trial files are relative to.
    traces : dict
        ``trial index -> (t, F)`` processed force traces.
    """

    impacts: pd.DataFrame
    trials: pd.DataFrame
    failures: list[TrialFailure]
    config: TrialsFile
    base_dir: Path
    traces: dict = field(default_factory=dict, repr=False)

    @property
    def failures_table(self) -> pd.DataFrame:
        return pd.DataFrame([f.__dict__ for f in self.failures],
                            columns=["trial", "file", "message"])


def run_experiment(trials: str | Path | TrialsFile, base_dir: str | Path | None = None
                   ) -> ExperimentResult:
    """Process every trial of a trials file; failures are collected, not raised.

    Parameters
    ----------
    trials : path or TrialsFile
        The trials file (or an already loaded one, then ``base_dir`` is needed).
    base_dir : path, optional
        Directory the ``file`` entries are relative to (default: the trials file's).

    Raises
    ------
    ConfigError
        Only for a malformed trials file; a bad recording is a :class:`TrialFailure`.
    """
    if isinstance(trials, TrialsFile):
        cfg, base = trials, Path(base_dir or ".")
    else:
        cfg, base = load_trials(trials)
        if base_dir is not None:
            base = Path(base_dir)
    rows, mains, failures, traces = [], [], [], {}
    for i, tr in enumerate(cfg.trial):
        try:
            imp, trace = process_recording(base / tr.file, cfg)
        except InputError as exc:
            failures.append(TrialFailure(i, tr.file, str(exc)))
            continue
        meta = {"trial": i, "file": tr.file, "beta_deg": tr.beta_deg, "speed": tr.speed,
                "repeat": tr.repeat, "notes": tr.notes}
        for k, v in reversed(list(meta.items())):
            imp.insert(0, k, v)
        rows.append(imp)
        mains.append(imp.loc[imp["F_peak"].idxmax()].to_dict() | {"n_impacts": len(imp)})
        traces[i] = trace
    impacts = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame()
    trials_df = pd.DataFrame(mains)
    return ExperimentResult(impacts, trials_df, failures, cfg, base, traces)


def fit_gain(raw, force):
    """Calibration gain from a reference load: least squares ``force = gain * (raw - raw_0)``.

    Parameters
    ----------
    raw : (N,) array_like
        Sensor readings [raw unit] under known loads (e.g. static weights).
    force : (N,) array_like
        The known loads [N].

    Returns
    -------
    gain : float
        [N per raw unit].
    raw_0 : float
        Reading at zero load [raw unit].
    rms : float
        RMS residual [N].
    """
    raw = np.asarray(raw, float)
    force = np.asarray(force, float)
    if raw.shape != force.shape or raw.ndim != 1 or len(raw) < 2:
        raise InputError("raw and force must be 1-D arrays of the same length (>= 2)")
    if np.ptp(force) == 0:
        raise InputError("the reference loads must not all be equal")
    X = np.stack([raw, np.ones_like(raw)], axis=1)
    (g, c), *_ = np.linalg.lstsq(X, force, rcond=None)
    rms = float(np.sqrt(np.mean((X @ [g, c] - force) ** 2)))
    return float(g), float(-c / g), rms


# ----------------------------------------------------------------------------------------
# Model comparison
# ----------------------------------------------------------------------------------------


#: Keys of the scenario's ``[simulation]`` table that each condition sets.
_PER_CONDITION = ("speed", "beta_deg")


@dataclass(frozen=True)
class ScenarioModel:
    r"""The rover model of the comparison: a scenario evaluated at each (beta, speed).

    For a condition the scenario gets ``obstacle.beta_deg`` = :math:`\beta` and
    ``velocity.u`` = speed (the driving speed, m/s); then

    - :math:`T_c^-` [J] is the effective kinetic energy of the scenario
      (:func:`roverimpact.energy_of`, with the scenario's constraint choice),
    - :math:`F_{max}` [N] is the peak of the summed obstacle normal force of the
      compliant-contact simulation (:func:`roverimpact.simulate_impact`) configured from
      the scenario as for ``roverimpact simulate`` (obstacle law from ``[contact_law]``,
      the rest from ``[simulation]``).

    Both come from :func:`roverimpact.studies.evaluate.evaluate_case`, the studies' single
    entry point into the scenario and simulate layers.

    Attributes
    ----------
    scenario : dict
        The scenario as read from TOML (with its optional ``simulation`` table).
    source : str
        Where it came from (for messages).
    """

    scenario: dict
    source: str = "scenario"

    @classmethod
    def from_file(cls, path: str | Path) -> ScenarioModel:
        """Read a scenario TOML file; a relative ``model.file`` is taken from its folder.

        Raises
        ------
        ConfigError
            Missing or malformed file, invalid scenario, or a ``[simulation]`` table that
            sets ``speed`` or ``beta_deg`` (each condition sets them).
        """
        path = Path(path)
        if not path.is_file():
            raise ConfigError(f"{path}: no such scenario file (model.scenario of the trials "
                              "file, relative to the trials file)")
        return cls.from_dict(read_toml(path), source=str(path), base_dir=path.parent)

    @classmethod
    def from_dict(cls, raw: dict, *, source: str = "scenario",
                  base_dir: str | Path | None = None) -> ScenarioModel:
        """Validate a scenario dict (schema and simulation settings; the model is built
        on the first call)."""
        from .evaluate import ScenarioEvaluator

        raw = dict(raw)
        sim = raw.get("simulation") or {}
        clash = sorted(set(_PER_CONDITION) & set(sim)) if isinstance(sim, dict) else []
        if clash:
            raise ConfigError(f"{source}: [simulation] must not set {clash}: the speed and "
                              "beta of every trial are used")
        model = raw.get("model")
        if isinstance(model, dict) and isinstance(model.get("file"), str) and base_dir:
            f = model["file"]
            if "://" not in f and not Path(f).is_absolute():
                raw["model"] = model | {"file": str(Path(base_dir) / f)}
        out = cls(raw, source)
        try:
            ScenarioEvaluator().validate(out.case(math.radians(45.0), 0.5))
        except ConfigError as exc:
            raise ConfigError(f"{source}: {exc}") from None
        return out

    def case(self, beta: float, speed: float) -> dict:
        """The scenario dict of one condition (``beta`` [rad], ``speed`` [m/s])."""
        from .config import apply_overrides

        return apply_overrides(self.scenario, {
            "obstacle.beta_deg": round(math.degrees(beta), 9), "obstacle.normal": None,
            "velocity.u": float(speed)})

    def __call__(self, beta: float, speed: float) -> dict:
        """``{"T_c_minus": J, "F_max": N, "m_eff": kg, "v_n": m/s, "contact_duration": s,
        "sim_error": str}`` for ``beta`` [rad] and ``speed`` [m/s]; F_max is NaN and
        ``sim_error`` says why if the simulation failed."""
        from .evaluate import evaluate_case

        out = evaluate_case(self.case(beta, speed), simulate=True)
        keys = ("T_c_minus", "F_max", "m_eff", "v_n", "contact_duration", "sim_error")
        return {k: out[k] for k in keys}


@dataclass
class ModelComparison:
    """Measured peaks next to the model, with rank agreement.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per condition (beta, speed): ``n``, ``F_peak_mean``, ``F_peak_std``,
        ``T_c_minus``, ``F_max`` (model), ``F_ratio`` = measured / model and any other
        scalar the model returns (e.g. ``m_eff``, ``v_n``, ``sim_error``).
    stats : dict
        ``kendall_tau_Tc``, ``kendall_p_Tc``, ``spearman_rho_Tc``, ``spearman_p_Tc`` (measured
        peak vs model T_c^-) and the same with suffix ``_Fmax`` (vs model F_max).
    """

    table: pd.DataFrame
    stats: dict


def compare_with_model(trials_df: pd.DataFrame, model_fn: Callable[[float, float], dict]
                       ) -> ModelComparison:
    """Compare measured peak forces with a model's T_c^- and F_max, condition by condition.

    Parameters
    ----------
    trials_df : pandas.DataFrame
        Needs columns ``beta_deg``, ``speed`` and ``F_peak`` (e.g.
        :attr:`ExperimentResult.trials`). Repeats are averaged per (beta, speed).
    model_fn : callable
        ``model_fn(beta_rad, speed) -> {"T_c_minus": ..., "F_max": ...}`` (SI units), e.g.
        a :class:`ScenarioModel` (the rover scenario and simulator). Other keys of the
        dict become columns of the table.

    Returns
    -------
    ModelComparison
        Kendall tau and Spearman rho (``scipy.stats``) over the conditions where the
        model value is finite (``n_conditions_Tc``, ``n_conditions_Fmax`` count them);
        NaN with fewer than 3 such conditions or a constant column.
    """
    from scipy.stats import kendalltau, spearmanr

    need = {"beta_deg", "speed", "F_peak"}
    if trials_df is None or trials_df.empty or not need <= set(trials_df.columns):
        raise InputError(f"trials_df must be non-empty with columns {sorted(need)}")
    g = trials_df.groupby(["beta_deg", "speed"], sort=True)["F_peak"]
    table = pd.DataFrame({"n": g.size(), "F_peak_mean": g.mean(),
                          "F_peak_std": g.std(ddof=1)}).reset_index()
    out = []
    for beta_deg, speed in zip(table["beta_deg"], table["speed"], strict=True):
        res = model_fn(math.radians(beta_deg), float(speed))
        try:
            out.append({"T_c_minus": float(res["T_c_minus"]), "F_max": float(res["F_max"])}
                       | {k: v for k, v in res.items() if k not in ("T_c_minus", "F_max")})
        except (KeyError, TypeError):
            raise InputError("model_fn must return a dict with keys 'T_c_minus' and 'F_max'"
                             ) from None
    model_cols = pd.DataFrame(out)
    table["T_c_minus"] = model_cols["T_c_minus"].to_numpy()
    table["F_max"] = model_cols["F_max"].to_numpy()
    table["F_ratio"] = table["F_peak_mean"] / table["F_max"]
    for col in model_cols.columns.drop(["T_c_minus", "F_max"]):
        table[col] = model_cols[col].to_numpy()
    stats: dict = {}
    for key, col in (("Tc", "T_c_minus"), ("Fmax", "F_max")):
        ok = table[np.isfinite(table[col].to_numpy(float))]
        stats[f"n_conditions_{key}"] = len(ok)
        constant = ok["F_peak_mean"].nunique() < 2 or ok[col].nunique() < 2
        if len(ok) >= 3 and not constant:
            kt = kendalltau(ok["F_peak_mean"], ok[col])
            sr = spearmanr(ok["F_peak_mean"], ok[col])
            stats |= {f"kendall_tau_{key}": float(kt.statistic),
                      f"kendall_p_{key}": float(kt.pvalue),
                      f"spearman_rho_{key}": float(sr.statistic),
                      f"spearman_p_{key}": float(sr.pvalue)}
        else:
            stats |= {f"{s}_{key}": math.nan for s in
                      ("kendall_tau", "kendall_p", "spearman_rho", "spearman_p")}
    stats = {"n_conditions": len(table)} | stats
    return ModelComparison(table, stats)


# ----------------------------------------------------------------------------------------
# Outputs
# ----------------------------------------------------------------------------------------


def plot_overlay(trials_df: pd.DataFrame, comparison: ModelComparison | None, path):
    """Peak force vs beta (measured points, model F_max) with T_c^- on a second, scaled axis.

    The right axis is scaled so that the largest T_c^- sits at the height of the largest
    measured mean peak: equal shapes overlay.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.2))
    speeds = sorted(trials_df["speed"].unique())
    markers = "osD^v<>"
    for i, sp in enumerate(speeds):
        d = trials_df[trials_df["speed"] == sp]
        ax.plot(d["beta_deg"], d["F_peak"], markers[i % len(markers)], color=f"C{i}",
                alpha=0.7, label=f"measured, {sp:g} m/s")
    if comparison is not None:
        tab = comparison.table
        ax2 = ax.twinx()
        for i, sp in enumerate(speeds):
            d = tab[tab["speed"] == sp]
            ax.plot(d["beta_deg"], d["F_max"], "-", color=f"C{i}", label=f"model F_max, {sp:g} m/s")
            ax2.plot(d["beta_deg"], d["T_c_minus"], "--", color=f"C{i}", alpha=0.8,
                     label=f"model $T_c^-$, {sp:g} m/s")
        fmax = float(tab["F_peak_mean"].max())
        tmax = float(tab["T_c_minus"].max())
        top = ax.get_ylim()[1]
        ax.set_ylim(0, top)
        ax2.set_ylim(0, top * tmax / fmax if fmax > 0 else 1)
        ax2.set_ylabel("effective kinetic energy $T_c^-$ [J] (dashed)")
        s = comparison.stats
        ax.set_title(f"Kendall $\\tau$ = {s['kendall_tau_Tc']:.2f}, Spearman $\\rho$ = "
                     f"{s['spearman_rho_Tc']:.2f} (peak vs $T_c^-$)", fontsize=10)
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = ax2.get_legend_handles_labels()
        ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="best")
    else:
        ax.set_ylim(bottom=0)
        ax.legend(fontsize=8)
    ax.set_xlabel(r"face angle $\beta$ [deg]")
    ax.set_ylabel("peak normal force [N]")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return Path(path)


def write_outputs(result: ExperimentResult, outdir, *, comparison: ModelComparison | None = None,
                  trials_path: str | Path | None = None, plot: bool = True) -> dict[str, Path]:
    """Write ``impacts.csv``, ``trials.csv``, ``failures.csv``, ``comparison.csv``,
    ``summary.json``, ``overlay.png`` and a copy of the trials file (the inputs next to the
    outputs) into ``outdir``."""
    import json

    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    files = {}
    files["impacts"] = out / "impacts.csv"
    result.impacts.to_csv(files["impacts"], index=False)
    files["trials"] = out / "trials.csv"
    result.trials.to_csv(files["trials"], index=False)
    files["failures"] = out / "failures.csv"
    result.failures_table.to_csv(files["failures"], index=False)
    summary = {"n_trials": len(result.config.trial), "n_ok": len(result.trials),
               "n_failed": len(result.failures),
               "filter": result.config.filter.model_dump(),
               "detection": result.config.detection.model_dump()}
    if comparison is not None:
        files["comparison"] = out / "comparison.csv"
        comparison.table.to_csv(files["comparison"], index=False)
        summary["rank_agreement"] = comparison.stats
        summary["model"] = (result.config.model.model_dump() if result.config.model else None)
    files["summary"] = out / "summary.json"
    files["summary"].write_text(json.dumps(summary, indent=2, default=str))
    if trials_path is not None:
        dst = out / ("inputs_" + Path(trials_path).name)
        shutil.copyfile(trials_path, dst)
        files["inputs"] = dst
        if result.config.model is not None:
            scn = result.base_dir / result.config.model.scenario
            if scn.is_file():
                files["inputs_model"] = out / ("inputs_" + scn.name)
                shutil.copyfile(scn, files["inputs_model"])
    if plot and not result.trials.empty:
        files["plot"] = plot_overlay(result.trials, comparison, out / "overlay.png")
    return files


# ----------------------------------------------------------------------------------------
# Synthetic data set
# ----------------------------------------------------------------------------------------

#: The "true" system of the shipped synthetic data set: the built-in 2-D rover (rigid
#: suspension) whose front wheel hits an obstacle face, Hunt-Crossley contact, simulated by
#: :func:`roverimpact.simulate_impact`. ``obstacle.beta_deg`` and ``velocity.u`` are set per
#: trial.
SYNTHETIC_TRUTH = {
    "description": "built-in 2-D rover, front wheel hits an obstacle face",
    "model": {"name": "rover2d"},
    "velocity": {"u": 0.5},
    "contacts": {"ground": "normal"},
    "obstacle": {"wheel": "front", "beta_deg": 45.0},
    "contact_law": {"name": "hunt-crossley", "k": 1.0e7, "e": 0.8, "n": 1.5},
    "simulation": {"mu": 0.3, "t_after": 0.05},
}


def _simulated_force(case: dict, max_step: float):
    """Obstacle normal force history of one simulated impact: ``(t, F, result)``.

    ``F`` [N] is the sum of the ``obstacle_*_fn`` columns of the simulator's history;
    ``t`` [s] is 0 at first contact. ``max_step`` [s] bounds the integrator step, so that
    the history resolves the pulse finely enough to be resampled."""
    from ..simulate import simulate_impact
    from .evaluate import _parse, simulation_config

    sc, sim = _parse(case)
    sim["integrator"] = dict(sim.get("integrator") or {}) | {"max_step": max_step}
    res = simulate_impact(sc.build().model, simulation_config(sc, sim))
    h = res.history
    cols = [c for c in h.columns if c.startswith("obstacle_") and c.endswith("_fn")]
    return h["t"].to_numpy(), h[cols].to_numpy().sum(axis=1), res


def make_synthetic_trials(outdir, *, betas_deg=tuple(range(30, 91, 10)), speeds=(0.3, 0.5),
                          repeats: int = 1, seed: int = 20150802, fs: float = 5000.0,
                          record_s: float = 0.5, gains=(250.0, 240.0), noise_v: float = 0.002,
                          model_stiffness_factor: float = 0.8, truth: dict | None = None
                          ) -> pd.DataFrame:
    """Write a realistic synthetic experiment: CSV recordings, ``trials.toml``, ``rover.toml``
    and ``truth.csv``.

    The true force of each trial is the summed obstacle normal force of the rover simulator
    (:func:`roverimpact.simulate_impact`) for the scenario ``truth`` (default
    :data:`SYNTHETIC_TRUTH`) at that trial's beta and speed, resampled at ``fs``. It is split
    between two load cells (random share 35-65 %), converted to volts with the known
    ``gains`` [N/V], and corrupted like a real recording: per-channel offset (0.1 V order)
    and linear drift (up to 0.02 V/s), white noise ``noise_v`` [V] and 16-bit quantisation of
    a +-10 V range. The trials file's ``[model]`` points to ``rover.toml``, the same scenario
    with the obstacle stiffness multiplied by ``model_stiffness_factor``: the comparison
    model is, as in reality, not exact.

    Returns
    -------
    pandas.DataFrame
        The truth table (also written to ``truth.csv``): per trial ``file, beta_deg,
        speed, repeat, F_peak, impulse, duration`` (of the simulated force: refined peak,
        integral, first contact to separation), ``T_c_minus`` (simulator's, at first
        contact), ``t_impact`` and ``share_ch1``.
    """
    import tomli_w

    from .config import apply_overrides

    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    tr = dict(SYNTHETIC_TRUTH if truth is None else truth)
    rng = np.random.default_rng(seed)
    gains = np.asarray(gains, float)
    lsb = 20.0 / 2**16
    n = round(record_s * fs)
    t = np.arange(n) / fs
    base_offset = np.array([0.12, -0.08])
    rows, trials = [], []
    k = 0
    for speed in speeds:
        for beta in betas_deg:
            th, Fh, res = _simulated_force(
                apply_overrides(tr, {"obstacle.beta_deg": float(beta),
                                     "velocity.u": float(speed)}), 0.1 / fs)
            if not res.separated:
                raise InputError(f"beta = {beta:g} deg, speed = {speed:g} m/s: the wheel "
                                 "does not leave the obstacle in the simulated time")
            for rep in range(1, repeats + 1):
                t0 = 0.15 + rng.uniform(0.0, 0.05)
                F = np.interp(t - t0, th, Fh, left=0.0, right=0.0)
                share = rng.uniform(0.35, 0.65)
                parts = np.stack([share * F, (1 - share) * F], axis=1)
                offset = base_offset + rng.normal(0, 0.02, 2)
                drift = rng.uniform(-0.02, 0.02, 2)
                volts = (parts / gains + offset + t[:, None] * drift
                         + rng.normal(0, noise_v, (n, 2)))
                volts = np.round(volts / lsb) * lsb
                name = f"trial_{k:02d}_beta{beta:02.0f}_v{speed:g}_r{rep}.csv"
                header = (f"synthetic recording (roverimpact.studies.experiment), seed {seed}\n"
                          f"beta_deg = {beta:g}, speed = {speed:g} m/s, repeat {rep}\n"
                          "time_s,ch1_V,ch2_V")
                np.savetxt(out / name, np.column_stack([t, volts]), delimiter=",",
                           fmt=["%.6f", "%.6f", "%.6f"], header=header, comments="# ")
                # the last header line must be the column names, not a comment
                text = (out / name).read_text()
                text = text.replace("# time_s,ch1_V,ch2_V", "time_s,ch1_V,ch2_V")
                (out / name).write_text(text)
                rows.append({"file": name, "beta_deg": float(beta), "speed": float(speed),
                             "repeat": rep, "F_peak": float(res.F_max_total),
                             "impulse": float(sum(res.impulse.values())),
                             "duration": float(res.contact_duration),
                             "T_c_minus": float(res.T_c_minus), "t_impact": t0,
                             "share_ch1": share})
                trials.append({"file": name, "beta_deg": float(beta), "speed": float(speed),
                               "repeat": rep, "notes": "synthetic"})
                k += 1
    law = dict(tr["contact_law"])
    law["k"] = float(law["k"]) * model_stiffness_factor
    model_scn = {key: v for key, v in tr.items() if key != "obstacle"} | {
        "description": f"Model of the synthetic experiment: {tr.get('description', '')}, "
                       f"obstacle stiffness x {model_stiffness_factor:g} of the data's",
        "contact_law": law,
        "obstacle": {key: v for key, v in tr["obstacle"].items() if key != "normal"},
    }
    (out / "rover.toml").write_text(
        "# Scenario of the model comparison (examples/experiment/trials.toml [model]); the\n"
        "# trials set obstacle.beta_deg and velocity.u. Written by make_synthetic_trials.\n"
        + tomli_w.dumps(model_scn))
    doc = {
        "description": "Synthetic impact experiment: rover simulator force, known "
                       "calibration, offset drift and noise; generated by "
                       "roverimpact.studies.experiment.make_synthetic_trials",
        "sensors": {"channels": ["ch1", "ch2"], "units": "V", "gains": gains.tolist(),
                    "sample_rate_hz": fs},
        "filter": {"cutoff_hz": 300.0, "order": 4},
        "detection": {"noise_sigmas": 10.0, "baseline_s": 0.1},
        "trial": trials,
        "model": {"kind": "scenario", "scenario": "rover.toml"},
    }
    (out / "trials.toml").write_text(tomli_w.dumps(doc))
    truth_df = pd.DataFrame(rows)
    truth_df.to_csv(out / "truth.csv", index=False)
    return truth_df
