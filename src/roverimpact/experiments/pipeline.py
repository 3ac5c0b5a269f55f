"""Every trial of a trials file: recordings -> impacts -> per-trial table; writing the outputs."""

from __future__ import annotations

import shutil
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np
import pandas as pd

from ..exceptions import InputError
from .compare import ModelComparison
from .recording import TrialDataError, TrialFailure, read_recording
from .signal import SHORT_PERIODS, detect_impacts, normal_force
from .trials import TrialsFile, load_trials

__all__ = ["INPUT_COPIES", "ExperimentResult", "process_recording", "run_experiment",
           "write_outputs"]

#: The names of the copies of the inputs in the output folder: fixed, so that a trials
#: file and a scenario of the same name do not overwrite each other (their own names are
#: in summary.json, ``inputs``)
INPUT_COPIES = {"trials": "inputs_trials.toml", "scenario": "inputs_scenario.toml"}


#: The force reads negative (the sensor's sign is wrong) when its lowest value is more than
#: this many times its highest: a zero-phase low-pass undershoots a pulse by at most 14 %
#: of its peak (a rigid mount's ringing by less than the peak).
NEGATIVE_RATIO = 2.0


def _check_sign(name: str, t, raw, F, thr: float, sensors) -> None:
    """Raise :class:`TrialDataError` when the normal force is mostly a pull: a sensor that
    reads negative under compression, whose impacts would otherwise be measured on the
    filter's ringing (a few newtons, a negative impulse) with no error."""
    lo, hi = float(np.min(F)), float(np.max(F))
    if not (-lo > NEGATIVE_RATIO * max(hi, 0.0) and -lo > thr):
        return
    k = int(np.argmin(F))
    x = np.asarray(raw, float) * np.asarray(sensors.gains, float)[None, :]
    x = x - np.median(x, axis=0)
    cols = [c for c, j in zip(sensors.columns, range(x.shape[1]), strict=True)
            if -x[:, j].min() > NEGATIVE_RATIO * max(x[:, j].max(), 0.0)]
    which = f" (column(s) {', '.join(cols)})" if cols else ""
    raise TrialDataError(
        f"{name}: the normal force reads negative{which}: its lowest {lo:.4g} N at "
        f"t = {t[k]:.6g} s is more than {NEGATIVE_RATIO:g} times its highest {hi:.4g} N; "
        "a compressive load must read positive (gains are newtons per raw unit, > 0): "
        "negate the column of a sensor that reads negative under compression")


def process_recording(path, cfg: TrialsFile):
    """Read, calibrate, filter and detect impacts in one recording.

    Returns
    -------
    impacts : pandas.DataFrame
        As :func:`detect_impacts`, plus ``threshold``, ``fs``, ``n_filled`` (samples of
        the recording interpolated over NaN) and ``n_filled_peak`` (those in the impact's
        top half, where the force is at least half its peak: its peak may read low).
    trace : (t, F)
        The processed normal force.

    Raises
    ------
    TrialDataError
        Unusable file, a force that reads negative (lowest below -:data:`NEGATIVE_RATIO`
        times the highest: the sensor's sign), or no impact above the threshold.
    """
    t, raw, fs, n_filled, filled = read_recording(path, cfg.sensors,
                                                  max_nan_run=cfg.detection.max_nan_run,
                                                  with_filled=True)
    name = Path(path).name
    fc = cfg.filter.cutoff_hz
    if fc >= 0.5 * fs:
        ms = (" Is time_s in milliseconds? It must be in seconds (the rate would be "
              f"{1e3 * fs:.6g} Hz)." if fc < 0.5e3 * fs else "")
        raise TrialDataError(
            f"{name}: the time column gives a sample rate of {fs:.6g} Hz ({len(t)} samples "
            f"over {t[-1] - t[0]:.6g} s), whose Nyquist frequency {0.5 * fs:.6g} Hz is not "
            f"above [filter] cutoff_hz = {fc:g}.{ms}")
    try:
        F, thr, _ = normal_force(t, raw, cfg.sensors.gains, fs, cfg.filter, cfg.detection)
    except InputError as exc:
        raise TrialDataError(f"{name}: {exc}") from None
    _check_sign(name, t, raw, F, thr, cfg.sensors)
    imp = detect_impacts(t, F, thr, min_separation_s=cfg.detection.min_separation_s,
                         split_fraction=cfg.detection.split_fraction,
                         cutoff_hz=cfg.filter.cutoff_hz, order=cfg.filter.order)
    if imp.empty:
        raise TrialDataError(
            f"{name}: no impact found (force never exceeds the threshold {thr:.3g} N; "
            f"peak {np.max(F):.3g} N)"
        )
    imp["threshold"] = thr
    imp["fs"] = fs
    imp["n_filled"] = n_filled
    # interpolated samples in an impact's top half (F >= F_peak / 2): a NaN run on a short
    # pulse's peak, filled by a straight line, reads the peak low (1-3 %) with no error
    imp["n_filled_peak"] = [
        int(np.sum(filled & (t >= r.t_start) & (t <= r.t_end) & (F >= 0.5 * r.F_peak)))
        for r in imp.itertuples()]
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

    def require_trials(self) -> None:
        """Raise :class:`~roverimpact.exceptions.InputError` if no trial could be
        processed: one line with the first failure and the number of the others."""
        if not self.trials.empty:
            return
        n = len(self.failures)
        if not n:
            raise InputError("no trial could be processed: the trials file lists none")
        first = self.failures[0]
        more = f" (and {n - 1} more trial(s) failed)" if n > 1 else ""
        raise InputError(f"no trial could be processed: trial {first.trial}: "
                         f"{first.message}{more}")

    @property
    def warnings(self) -> list[str]:
        """One line per impact flagged ``short``: shorter than
        :data:`~roverimpact.experiments.signal.SHORT_PERIODS` periods of the low-pass
        cut-off, so its peak is distorted (attenuated) by the filter; one per impact with
        interpolated samples in its top half (``n_filled_peak``: a NaN gap on the peak,
        filled by a straight line, reads it low)."""
        if self.impacts.empty:
            return []
        out = []
        if "n_filled_peak" in self.impacts:
            for r in self.impacts[self.impacts["n_filled_peak"] > 0].itertuples():
                out.append(
                    f"trial {r.trial} ({r.file}), impact {r.impact}: {r.n_filled_peak} "
                    f"sample(s) near its peak (force above half the peak {r.F_peak:.4g} N) "
                    "were NaN and are linearly interpolated: the peak may read low (a "
                    "straight line cuts the top of a pulse); check the recording there")
        if "short" not in self.impacts:
            return out
        fc = self.config.filter.cutoff_hz
        for r in self.impacts[self.impacts["short"]].itertuples():
            need = SHORT_PERIODS / r.duration  # the cut-off that would measure it [Hz]
            if need < 0.5 * r.fs:
                remedy = (f"raise [filter] cutoff_hz (to {need:.3g} Hz or more, below "
                          f"{0.5 * r.fs:g} Hz, the Nyquist frequency) to measure it")
            else:  # no cut-off below the Nyquist frequency can: the samples are too few
                remedy = (f"no cut-off below the Nyquist frequency {0.5 * r.fs:g} Hz "
                          f"measures it (it spans {r.duration * r.fs:.3g} samples): record "
                          f"at a higher sample rate, above {2 * need:.4g} Hz (the filter lengthens "
                          "the measured duration: the pulse may be shorter still)")
            out.append(
                f"trial {r.trial} ({r.file}), impact {r.impact}: duration "
                f"{1e3 * r.duration:.3g} ms is under {SHORT_PERIODS:g} periods of the "
                f"{fc:g} Hz low-pass ({1e3 * SHORT_PERIODS / fc:.3g} ms): its peak "
                f"{r.F_peak:.4g} N is attenuated by the filter; {remedy}")
        return out

    @property
    def failures_table(self) -> pd.DataFrame:
        """One row per failure: ``trial``, ``file``, ``message``."""
        return pd.DataFrame(self.failures, columns=[f.name for f in fields(TrialFailure)])


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


def _finite(obj):
    """NaN and infinity -> None, recursively (strict JSON)."""
    import math

    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    return None if isinstance(obj, float) and not math.isfinite(obj) else obj


def write_outputs(result: ExperimentResult, outdir, *, comparison: ModelComparison | None = None,
                  trials_path: str | Path | None = None) -> dict[str, Path]:
    """Write ``impacts.csv``, ``trials.csv``, ``failures.csv``, ``comparison.csv``,
    ``summary.json`` and copies of the trials file and of the model's scenario
    (``inputs_trials.toml``, ``inputs_scenario.toml``: the inputs next to the outputs) into
    ``outdir``; the figure is :func:`roverimpact.report.experiment.plot_overlay`."""
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
               "detection": result.config.detection.model_dump(),
               "warnings": result.warnings}
    if comparison is not None:
        files["comparison"] = out / "comparison.csv"
        comparison.table.to_csv(files["comparison"], index=False)
        summary["rank_agreement"] = _finite(comparison.stats)
        ind = getattr(comparison, "indicators", None)
        summary["baselines"] = _finite(ind.as_dict()) if ind is not None else None
        summary["model"] = (result.config.model.model_dump() if result.config.model else None)
    if trials_path is not None:
        summary["inputs"] = {INPUT_COPIES["trials"]: str(trials_path)}
        if result.config.model is not None:
            summary["inputs"][INPUT_COPIES["scenario"]] = str(
                result.base_dir / result.config.model.scenario)
    files["summary"] = out / "summary.json"
    files["summary"].write_text(json.dumps(summary, indent=2, default=str))
    if trials_path is not None:
        files["inputs"] = out / INPUT_COPIES["trials"]
        shutil.copyfile(trials_path, files["inputs"])
        if result.config.model is not None:
            scn = result.base_dir / result.config.model.scenario
            if scn.is_file():
                files["inputs_model"] = out / INPUT_COPIES["scenario"]
                shutil.copyfile(scn, files["inputs_model"])
    return files
