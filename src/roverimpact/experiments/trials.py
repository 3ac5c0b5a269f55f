"""The trials file: sensors, filter, detection, trials and the model of the comparison."""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Literal

from pydantic import Field, field_validator, model_validator

from .._io import read_toml
from .._schema import StrictModel, validate

__all__ = [
    "FORCE_UNITS",
    "DetectionConfig",
    "FilterConfig",
    "ScenarioModelConfig",
    "SensorsConfig",
    "TrialConfig",
    "TrialsFile",
    "load_trials",
]


#: Force units a channel may read, in newtons: the gain of such a channel (N per unit) must
#: be within a factor 2 of this (a kN channel with gain 1 would read 1000 times low).
FORCE_UNITS = {"N": 1.0, "mN": 1e-3, "kN": 1e3, "daN": 10.0, "lbf": 4.4482216152605,
               "kgf": 9.80665}


class SensorsConfig(StrictModel):
    """``[sensors]``: force channels, calibration gains and units.

    ``gains[i]`` (> 0) converts channel i from its raw unit to newtons (N per raw unit),
    so that a compressive load reads positive; the CSV
    column of channel i must be named ``<channels[i]>_<units[i]>``. ``units`` may be one
    string for all channels. ``sample_rate_hz``, if given, is checked against the time
    column (1 % tolerance). ``full_scale``, if given (one value or one per channel, in the
    raw unit), is the reading at which a channel saturates: a recording reaching it fails,
    as does one whose maximum is held for :data:`~roverimpact.experiments.recording.CLIP_SAMPLES`
    or more consecutive samples (a flat top: clipped by the sensor or the ADC).
    """

    channels: list[str] = Field(min_length=1)
    gains: list[float]
    units: list[str] | str = "V"
    sample_rate_hz: float | None = Field(None, gt=0, allow_inf_nan=False)
    full_scale: list[float] | float | None = None

    @model_validator(mode="after")
    def _lengths(self):
        if len(self.gains) != len(self.channels):
            raise ValueError(
                f"gains has {len(self.gains)} values for {len(self.channels)} channels"
            )
        bad = [f"{g:g}" for g in self.gains if not (math.isfinite(g) and g > 0)]
        if bad:
            raise ValueError(
                f"gains must be finite and > 0 (newtons per raw unit: a compressive load "
                f"reads positive), got {', '.join(bad)}")
        if isinstance(self.units, list) and len(self.units) != len(self.channels):
            raise ValueError(
                f"units has {len(self.units)} entries for {len(self.channels)} channels"
            )
        fsl = self.full_scale
        if isinstance(fsl, list) and len(fsl) != len(self.channels):
            raise ValueError(
                f"full_scale has {len(fsl)} values for {len(self.channels)} channels")
        if fsl is not None and not all(map(math.isfinite, fsl if isinstance(fsl, list)
                                           else [fsl])):
            raise ValueError("full_scale must be finite")
        for ch, unit, g in zip(self.channels, self.unit_list, self.gains, strict=True):
            to_n = FORCE_UNITS.get(unit)
            if to_n is not None and not 0.5 * to_n <= g <= 2.0 * to_n:
                raise ValueError(
                    f"channel {ch!r} reads {unit}, a force: its gain {g:g} is in N per {unit} "
                    f"and 1 {unit} = {to_n:g} N, so it should be about {to_n:g} (a "
                    f"calibration correction within a factor 2); the units are not "
                    "converted otherwise")
        if len(set(self.channels)) != len(self.channels):
            raise ValueError(f"channel names must be unique, got {self.channels}")
        return self

    @property
    def unit_list(self) -> list[str]:
        return [self.units] * len(self.channels) if isinstance(self.units, str) else self.units

    @property
    def full_scale_list(self) -> list[float | None]:
        """Saturation reading of each channel [raw unit] (None: not given)."""
        fsl = self.full_scale
        return list(fsl) if isinstance(fsl, list) else [fsl] * len(self.channels)

    @property
    def columns(self) -> list[str]:
        """CSV column names expected for the channels."""
        return [f"{c}_{u}" for c, u in zip(self.channels, self.unit_list, strict=True)]


class FilterConfig(StrictModel):
    """``[filter]``: zero-phase Butterworth low-pass (``sosfiltfilt``, so the effective
    order is twice ``order``)."""

    cutoff_hz: float = Field(300.0, gt=0, allow_inf_nan=False)
    order: int = Field(4, ge=1, le=12)


class DetectionConfig(StrictModel):
    """``[detection]``: impact detection and offset removal (all optional).

    An impact is where the filtered force exceeds
    ``max(threshold_n, noise_sigmas * noise, 0.001 * max|F|)``, ``noise`` being the robust
    standard deviation (1.4826 MAD) of the first ``baseline_s`` seconds (then of all the
    samples away from impacts); the last term only matters for noise-free data. Impacts closer than
    ``min_separation_s`` are merged; an excursion holding distinct peaks is split at the
    minimum between them when it is below ``split_fraction`` times the smaller peak (two
    bounces joined by a light contact). NaN runs of up to ``max_nan_run`` samples are
    interpolated; longer ones make the file fail.
    """

    threshold_n: float = Field(0.0, ge=0, allow_inf_nan=False)
    noise_sigmas: float = Field(10.0, gt=0, allow_inf_nan=False)
    baseline_s: float = Field(0.05, gt=0, allow_inf_nan=False)
    min_separation_s: float = Field(0.005, ge=0, allow_inf_nan=False)
    split_fraction: float = Field(0.5, gt=0, lt=1, allow_inf_nan=False)
    max_nan_run: int = Field(3, ge=0)


class TrialConfig(StrictModel):
    """``[[trial]]``: one recording. ``file`` is relative to the trials file; ``speed`` is
    the approach speed [m/s]; ``beta_deg`` the face angle [deg], in [0, 90] as the
    scenario's ``obstacle.beta_deg`` (0: horizontal, 90: vertical wall)."""

    file: str
    beta_deg: float = Field(allow_inf_nan=False)
    speed: float = Field(gt=0, allow_inf_nan=False)
    repeat: int = 1
    notes: str = ""

    @field_validator("beta_deg")
    @classmethod
    def _beta_range(cls, v: float) -> float:
        if not 0.0 <= v <= 90.0:
            raise ValueError(f"the face angle must be in [0, 90] degrees (0: horizontal, "
                             f"90: vertical wall), got {v:g}")
        return v


class ScenarioModelConfig(StrictModel):
    """``[model]`` with ``kind = "scenario"``: the rover model of the comparison.

    ``scenario`` is a scenario TOML file (path relative to the trials file) with an
    optional ``[simulation]`` table; see :class:`ScenarioModel`. ``simulate = false``
    compares the measured peaks with T_c^- (and the simpler indicators) alone: no
    compliant-contact simulation, no F_max.
    """

    kind: Literal["scenario"]
    scenario: str
    simulate: bool = True


class TrialsFile(StrictModel):
    """A trials file (TOML): ``[sensors]``, ``[filter]``, ``[detection]``, ``[[trial]]``
    and an optional ``[model]`` for the model comparison. Unknown keys are rejected."""

    sensors: SensorsConfig
    filter: FilterConfig = FilterConfig()
    detection: DetectionConfig = DetectionConfig()
    trial: list[TrialConfig] = Field(min_length=1)
    model: ScenarioModelConfig | None = None
    description: str = ""

    @model_validator(mode="after")
    def _one_recording_per_trial(self):
        seen: dict[str, int] = {}
        for i, tr in enumerate(self.trial):
            key = os.path.normpath(tr.file)
            if key in seen:
                raise ValueError(
                    f"trial {i} lists the file {tr.file!r} of trial {seen[key]}: one "
                    "recording per trial (a copied [[trial]] block whose file was not "
                    "changed would count one recording under two conditions)")
            seen[key] = i
        return self


def load_trials(path: str | Path) -> tuple[TrialsFile, Path]:
    """Read and validate a trials file; returns it and the directory its paths are relative to.

    Raises
    ------
    ConfigError
        Malformed TOML or a wrong/unknown key, with the key path named.
    """
    path = Path(path)
    raw = read_toml(path)
    cfg = validate(TrialsFile, raw, str(path))
    return cfg, path.resolve().parent
