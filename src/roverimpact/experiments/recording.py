"""Reading one force-sensor recording (CSV): header units, uniform time, short NaN gaps."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from .._io import no_file, utf16_problem
from ..exceptions import InputError
from .trials import SensorsConfig

__all__ = ["CLIP_SAMPLES", "TrialDataError", "TrialFailure", "read_recording", "true_runs"]

#: A channel whose maximum is held for this many consecutive samples or more (equal within
#: 1e-6 of its range), entered and left by steps larger than :data:`CLIP_STEP_QUANTA` of
#: its quantum, is clipped: the sensor or the ADC saturated, and the peak is lost.
CLIP_SAMPLES = 4

#: The steps into and out of a flat top of a clipped channel exceed this many quanta of
#: the channel (its smallest step between two distinct readings). A smooth peak read by
#: an ADC also stays on its top code for several samples (a 1000 N half-sine of 20 ms
#: through a 12-bit +-10 V ADC at 250 N/V with 0.2 codes rms of noise, sampled at 20 kHz:
#: 4 samples, ``tests/test_experiment_recording.py``), but reaches and leaves it by one
#: quantum; a saturated one arrives at the slope of the pulse. The quantum is estimated
#: from the readings, so a noise-free recording (whose steep parts skip codes) may hide it.
CLIP_STEP_QUANTA = 2.0


class TrialDataError(InputError):
    """A recording cannot be used (the message says why)."""


@dataclass(frozen=True)
class TrialFailure:
    """A trial that could not be processed."""

    trial: int
    file: str
    message: str


def true_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, length) of the runs of True in a 1-D boolean array, in order
    (``scipy.ndimage.label`` and ``find_objects``)."""
    from scipy import ndimage

    labels, _ = ndimage.label(np.asarray(mask, dtype=bool))
    return [(sl.start, sl.stop - sl.start) for (sl,) in ndimage.find_objects(labels)]


#: control characters other than tab, newline and carriage return
_UNPRINTABLE = re.compile("[\x01-\x08\x0b\x0c\x0e-\x1f]")


def _header(columns, limit: int = 200) -> str:
    """A header as a list, shortened to about ``limit`` characters for a message."""
    text = str(list(columns))
    return text if len(text) <= limit else f"{text[:limit]}... ({len(columns)} columns)"


def _parser_problem(path: Path, exc: Exception) -> str:
    """One line for a pandas tokenizer error: which line has more fields than the header,
    and the header line itself (often a metadata line without '#')."""
    m = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", str(exc))
    if not m:
        return f"not a readable CSV file ({str(exc).strip()})"
    want, line, got = map(int, m.groups())
    header_no, header = 0, ""
    with path.open(encoding="utf-8", errors="replace") as fh:
        for k, text in enumerate(fh, 1):
            if text.strip() and not text.lstrip("\ufeff").startswith("#"):
                header_no, header = k, text.strip()
                break
    return (f"line {line} has {got} fields but the header (line {header_no}: "
            f"{header[:80]!r}) has {want}: metadata lines above the header must start "
            "with '#'")


def _check_not_clipped(name: str, t, x, col: str, full_scale: float | None) -> None:
    """Raise :class:`TrialDataError` for an infinite reading, one at ``full_scale`` or a
    flat top at the maximum (:data:`CLIP_SAMPLES`) entered and left by steps of more than
    :data:`CLIP_STEP_QUANTA` quanta."""
    inf = np.isinf(x)
    if inf.any():
        i = int(np.flatnonzero(inf)[0])
        raise TrialDataError(
            f"{name}: column {col!r} is infinite at row {i + 1} (t = {t[i]:.6g} s), an "
            "overflow or saturation marker; a missing sample must be empty or NaN")
    if np.isnan(x).all():
        return
    top = float(np.nanmax(x))
    if full_scale is not None and top >= full_scale:
        i = int(np.flatnonzero(x >= full_scale)[0])
        raise TrialDataError(
            f"{name}: column {col!r} reaches the sensor's full_scale {full_scale:g} at row "
            f"{i + 1} (t = {t[i]:.6g} s): saturated, the peak is lost; re-record with a "
            "larger range")
    tol = 1e-6 * float(np.nanmax(x) - np.nanmin(x))
    values = np.unique(x[np.isfinite(x)])
    quantum = float(np.diff(values).min()) if values.size > 1 else 0.0
    step = max(CLIP_STEP_QUANTA * quantum, tol)

    def steep(i: int, n: int) -> bool:  # entered and left by more than a few quanta
        into = top - x[i - 1] if i > 0 else np.inf
        out = top - x[i + n] if i + n < len(x) else np.inf
        return bool(min(into, out) > step)  # NaN neighbours: not steep

    runs = [r for r in true_runs(x >= top - tol) if r[1] >= CLIP_SAMPLES and steep(*r)]
    if runs and tol > 0:
        i, n = runs[0]
        raise TrialDataError(
            f"{name}: column {col!r} is clipped: its maximum {top:g} is held for {n} "
            f"samples from row {i + 1} (t = {t[i]:.6g} s), a flat top: the sensor or the ADC "
            "saturated and the peak is lost; re-record with a larger range")


def _printed_uniform(t: np.ndarray) -> np.ndarray | None:
    """The uniform times ``t0 + k dt`` (least squares) that ``t`` is when it was printed
    with too few decimals (2048 Hz written to 0.1 ms: steps of 0.4 and 0.5 ms), or None
    when ``t`` is not that: every time within half a unit of its last decimal of the line
    (0.55: the fitted line is not quite the true one)."""
    for d in range(10):   # the resolution the times were printed with
        r = 10.0 ** -d
        if np.max(np.abs(t / r - np.round(t / r))) < 1e-6:
            break
    else:
        return None
    k = np.arange(len(t), dtype=float)
    b, a = np.polyfit(k, t, 1)
    line = a + b * k
    return line if b > 0 and np.max(np.abs(t - line)) <= 0.55 * r else None


def read_recording(path: str | Path, sensors: SensorsConfig, *, max_nan_run: int = 3,
                   with_filled: bool = False):
    """Read one CSV recording and check it.

    Returns
    -------
    t : (N,) ndarray
        Time [s], strictly increasing, uniformly sampled (times printed with too few
        decimals for the rate, e.g. 2048 Hz to 0.1 ms, are replaced by the uniform times
        they round).
    raw : (N, n_channels) ndarray
        Raw channel values in their unit (short NaN gaps interpolated).
    fs : float
        Sampling rate [Hz]: samples over the span, (N - 1) / (t[-1] - t[0]).
    n_filled : int
        Number of samples that were NaN and got interpolated.
    filled : (N,) bool ndarray
        Only with ``with_filled=True`` (a fifth item): the samples of which some channel
        was NaN and got interpolated (an interpolated peak reads low).

    Raises
    ------
    TrialDataError
        Missing file, empty file, missing columns, a unit in the header that differs from
        the trials file, non-numeric values, non-monotone or irregular time, long NaN runs,
        an infinite value, a clipped channel (see :func:`_check_not_clipped`).
    """
    path = Path(path)
    if not path.is_file():
        raise TrialDataError(f"{path.name}: {no_file(path)}")
    with path.open("rb") as fh:
        head = fh.read(4096)
    problem = utf16_problem(head)
    if problem:
        raise TrialDataError(f"{path.name}: {problem}")
    if b"\x00" in head or _UNPRINTABLE.search(head.decode("utf-8", "replace")):
        raise TrialDataError(f"{path.name}: not a text CSV file (binary data)")
    try:
        df = pd.read_csv(path, comment="#", skipinitialspace=True)
    except pd.errors.EmptyDataError:
        raise TrialDataError(f"{path.name}: empty file (no header, no data)") from None
    except pd.errors.ParserError as exc:
        raise TrialDataError(f"{path.name}: {_parser_problem(path, exc)}") from None
    except UnicodeDecodeError as exc:
        raise TrialDataError(f"{path.name}: not a readable CSV file ({exc})") from None
    df.columns = [str(c).strip() for c in df.columns]
    df = df.dropna(how="all")   # rows of bare commas (',,' : a spreadsheet's empty rows)
    if "time_s" not in df.columns:
        names = ("time", *(f"{ch.lower()}_" for ch in sensors.channels))
        for sep, said in ((";", "semicolons"), ("\t", "tabs")):
            # a header of such columns: one of them the time or a channel (not a line of
            # text with a ';' in it, e.g. a trials file given as a recording)
            parts = [p.strip().lower() for c in df.columns for p in str(c).split(sep)]
            if any(sep in c for c in df.columns) and any(p.startswith(names) for p in parts):
                raise TrialDataError(
                    f"{path.name}: the columns are separated by {said} (header "
                    f"{_header(df.columns)}), not commas: save it as comma-separated CSV "
                    "with '.' as the decimal point (a spreadsheet with a decimal comma "
                    "writes ';' and '0,5')")
        timeish = [c for c in df.columns if c.lower().startswith(("time", "t_", "t "))]
        hint = (f"; {timeish[0]!r} looks like the time: give it in seconds in a column "
                "named 'time_s'") if timeish else ""
        raise TrialDataError(
            f"{path.name}: no 'time_s' column (header is {_header(df.columns)}): the time in "
            f"seconds must be a column named 'time_s'{hint}"
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
            f"{_header(df.columns)})"
        )
    if len(df) == 0:
        raise TrialDataError(f"{path.name}: header but no data rows")
    numeric = df[["time_s", *cols]].apply(pd.to_numeric, errors="coerce")
    text = df[["time_s", *cols]].astype(str).apply(lambda c: c.str.strip().str.lower())
    # a cell that is not a number: coerced to NaN, but not empty, not 'nan'
    bad = numeric.isna() & df[["time_s", *cols]].notna() & ~text.isin(["nan", "", "na"])
    if bad.to_numpy().any():
        i, j = (int(k) for k in np.argwhere(bad.to_numpy())[0])
        col = bad.columns[j]
        cell = str(df[col].iloc[i]).strip()
        hint = (": a units row under the header? Put the units in the column names "
                "(time_s, ch1_V) or start the row with '#'") if i == 0 else ""
        raise TrialDataError(f"{path.name}: column {col!r}, data row {i + 1}: "
                             f"{cell[:40]!r} is not a number{hint}")
    data = np.array(numeric, dtype=float)
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
        uniform = _printed_uniform(t)
        if uniform is None:
            i = int(np.argmax(np.abs(dt - dt_med)))
            raise TrialDataError(
                f"{path.name}: irregular sampling at row {i + 2} (step {dt[i]:.3g} s, median "
                f"{dt_med:.3g} s); resample the recording to a uniform rate"
            )
        t = uniform
    fs = (len(t) - 1) / float(t[-1] - t[0])   # the mean step: unbiased by the print's rounding
    if sensors.sample_rate_hz is not None and abs(fs - sensors.sample_rate_hz) > (
        0.01 * sensors.sample_rate_hz
    ):
        raise TrialDataError(
            f"{path.name}: time column gives {fs:.6g} Hz but the trials file says "
            f"sample_rate_hz = {sensors.sample_rate_hz:g}"
        )
    for j, col in enumerate(cols):
        _check_not_clipped(path.name, t, raw[:, j], col, sensors.full_scale_list[j])
    n_filled = 0
    filled = np.zeros(len(t), bool)
    for j, col in enumerate(cols):
        bad = ~np.isfinite(raw[:, j])
        if not bad.any():
            continue
        filled |= bad
        runs = true_runs(bad)
        start, length = max(runs, key=lambda r: r[1])
        if length > max_nan_run or bad.all():
            raise TrialDataError(
                f"{path.name}: column {col!r} has a run of {length} NaN/missing samples from "
                f"t = {t[start]:.6g} s (at most {max_nan_run} are interpolated)"
            )
        good = ~bad
        raw[bad, j] = np.interp(t[bad], t[good], raw[good, j])
        n_filled += int(bad.sum())
    if with_filled:
        return t, raw, fs, n_filled, filled
    return t, raw, fs, n_filled
