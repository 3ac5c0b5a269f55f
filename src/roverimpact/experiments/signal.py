"""Signal processing of a recording: scaling, drift removal, low-pass, impact detection."""

from __future__ import annotations

import math
from functools import lru_cache
from itertools import pairwise

import numpy as np
import pandas as pd

from ..exceptions import InputError
from .recording import true_runs
from .trials import DetectionConfig, FilterConfig

__all__ = ["RING_MARGIN", "RING_PERIODS", "SHORT_PERIODS", "detect_impacts", "fit_gain",
           "lowpass", "normal_force", "ringing"]

#: The impulse is integrated this many periods of the low-pass cut-off past the zero
#: crossings around an impact: the zero-phase filter keeps the integral, but spreads it
#: into ringing lobes on either side (-14 % and +4 % of the peak for a short pulse), which
#: the zero crossings alone leave out (+9 % impulse for a 2 ms half-sine at 300 Hz).
RING_PERIODS = 2.0

#: An impact measured shorter than this many periods of the low-pass cut-off is flagged
#: ``short``: the filter distorts its peak and duration (half-sine pulses at 300 Hz: peak
#: within 0.25 % above; +1.9 % to -1.2 % at 1.5-2.4 periods; -11 % at 1.25, -31 % at 1.1).
SHORT_PERIODS = 2.5

#: An excursion is the filter's ringing of a larger impact (not an impact of its own) when
#: its peak is below this many times the largest side lobe of the filter's impulse
#: response (:func:`ringing`; 3.7 % of the peak for order 4) times the impact's peak, and
#: it lies within the response's extent of the impact: lobes of two edges add up.
RING_MARGIN = 1.5


@lru_cache
def ringing(order: int) -> tuple[float, float]:
    """Side lobes of the zero-phase Butterworth low-pass (``sosfiltfilt`` of ``butter(order)``).

    Its impulse response h (computed with scipy at 200 samples per period of the cut-off)
    has a main lobe and, on either side, ringing lobes of alternating sign.

    Returns
    -------
    lobe : float
        The largest positive side lobe of h over its peak (0.0373 for order 4, 0.0019 for
        order 2, 0 for order 1).
    extent : float
        How far past the zero crossing of the main lobe |h| still reaches 1e-3 of its
        peak, in periods of the cut-off (2.0 for order 4): farther, the ringing of an
        impact is under the detection threshold's floor of 0.1 % of the peak.
    """
    from scipy.signal import butter, find_peaks, sosfiltfilt

    per = 200  # samples per period of the cut-off
    n = 80 * per
    x = np.zeros(n)
    x[n // 2] = 1.0
    h = sosfiltfilt(butter(order, 1.0 / per, fs=1.0, output="sos"), x)
    k = int(np.argmax(h))
    side = h[k:]
    z = int(np.argmax(side <= 0)) if (side <= 0).any() else len(side)
    side = side[z:] / h[k]
    pk, _ = find_peaks(side)
    lobe = float(side[pk].max()) if len(pk) else 0.0
    above = np.flatnonzero(np.abs(side) >= 1e-3)
    extent = float(above[-1] + 1) / per if above.size else 0.0
    return lobe, extent


def _merge_ringing(F: np.ndarray, pieces: list[tuple[int, int]], reach: int,
                   fraction: float) -> list[tuple[int, int]]:
    """Pieces with the filter's ringing lobes merged into the impact that rings: a piece
    whose peak is at most ``fraction`` times a larger one's and that starts (ends) within
    ``reach`` samples of its end (start), taken outwards from the largest impacts."""
    if fraction <= 0 or len(pieces) < 2:
        return pieces
    peak = [float(F[s:e].max()) for s, e in pieces]
    owner = list(range(len(pieces)))
    for i in sorted(range(len(pieces)), key=lambda j: -peak[j]):
        if owner[i] != i:
            continue
        s, e = pieces[i]
        for step in (-1, 1):
            j = i + step
            while 0 <= j < len(pieces) and owner[j] == j and peak[j] <= fraction * peak[i]:
                gap = s - pieces[j][1] if step < 0 else pieces[j][0] - e
                if gap > reach:
                    break
                owner[j] = i
                j += step
    merged: dict[int, tuple[int, int]] = {}
    for j, (s, e) in enumerate(pieces):
        a, b = merged.get(owner[j], (s, e))
        merged[owner[j]] = (min(a, s), max(b, e))
    return sorted(merged.values())


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
    """Noise sigma from the median absolute deviation: 1.4826 MAD (normal noise)."""
    from scipy.stats import median_abs_deviation

    return float(1.4826 * median_abs_deviation(x))


def _threshold(det: DetectionConfig, F: np.ndarray, noise: np.ndarray) -> float:
    """Detection threshold [N]: ``max(threshold_n, noise_sigmas * sigma(noise), 1e-3 max|F|)``."""
    return max(det.threshold_n, det.noise_sigmas * _robust_sigma(noise),
               1e-3 * np.max(np.abs(F)))


def _regions(mask: np.ndarray, gap: int) -> list[tuple[int, int]]:
    """[start, end) index ranges of True runs, merging runs separated by <= gap samples."""
    runs = [(s, s + n) for s, n in true_runs(mask)]
    merged: list[tuple[int, int]] = []
    for s, e in runs:
        if merged and s - merged[-1][1] <= gap:
            merged[-1] = (merged[-1][0], e)
        else:
            merged.append((s, e))
    return merged


def _robust_line(t: np.ndarray, x: np.ndarray, max_points: int = 800) -> np.ndarray:
    """(2, n_channels) offset at t[0] and slope of a straight line through each column of
    ``x``, by Siegel's repeated medians (``scipy.stats.siegelslopes``) on at most
    ``max_points`` evenly spread samples: impacts (a minority of the samples, however
    large) do not pull it, and neither does a drift."""
    from scipy.stats import siegelslopes

    idx = np.unique(np.linspace(0, len(t) - 1, min(max_points, len(t))).astype(int))
    tt = t[idx] - t[0]
    coef = np.empty((2, x.shape[1]))
    for j in range(x.shape[1]):
        r = siegelslopes(x[idx, j], tt)
        coef[:, j] = r.intercept, r.slope
    return coef


def normal_force(t, raw, gains, fs: float, filt: FilterConfig = FilterConfig(),
                 det: DetectionConfig = DetectionConfig()):
    """Calibrated, offset- and drift-free, filtered normal force from the raw channels.

    Each channel is multiplied by its gain, then a straight line (offset + drift) fitted
    to the samples away from impacts is subtracted, the result is low-pass filtered and
    the channels are summed. The samples away from impacts are found iteratively: a first
    robust line (repeated medians, which neither the impacts nor the drift pull), the
    samples above the threshold (and a guard band around them) left out, a least-squares
    line on the rest, again until the set of samples no longer changes (at most 5 times).

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
    tr = (t - t[0])[:, None]

    def quiet_samples(coef, quiet):
        """Samples away from impacts (and a guard band) of the force left by ``coef``,
        and the median of that force over the quiet start."""
        s0 = lowpass(forces - coef[0] - tr * coef[1], fs, filt.cutoff_hz, filt.order).sum(axis=1)
        noise = s0[:nb] if quiet is None else s0[quiet]
        thr = _threshold(det, s0, noise)
        new = np.ones(len(t), bool)
        for s, e in _regions(np.abs(s0) > thr, 0):
            guard = max(min(e - s, nb), int(0.01 * fs))  # at most the baseline's length
            new[max(s - guard, 0): e + guard] = False
        return new, float(np.median(s0[:nb])) < -thr

    # the first line: robust through all samples. When a load held after the impact (a
    # wheel resting on the obstacle) fills most of the recording, that line goes through
    # the load, and the unloaded start reads below it (a load reads positive): then the
    # first line is the offset of the quiet start (baseline_s), no drift
    coef = _robust_line(t, forces)
    new, start_below = quiet_samples(coef, None)
    if start_below:
        coef = np.stack([np.median(forces[:nb], axis=0), np.zeros(forces.shape[1])])
        new, _ = quiet_samples(coef, None)
    quiet = None
    for _ in range(5):
        if new.sum() < nb:
            raise InputError(
                f"too few samples away from impacts to fit the sensor offset ({new.sum()} "
                f"quiet samples, need {nb}: baseline_s = {det.baseline_s:g} s); the "
                "recording should start with the sensors unloaded")
        if quiet is not None and np.array_equal(new, quiet):
            break
        quiet = new
        # offset + linear drift per channel, least squares on the quiet samples
        X = np.stack([np.ones(quiet.sum()), t[quiet] - t[0]], axis=1)
        coef, *_ = np.linalg.lstsq(X, forces[quiet], rcond=None)
        new, _ = quiet_samples(coef, quiet)
    F = lowpass(forces - coef[0] - tr * coef[1], fs, filt.cutoff_hz, filt.order).sum(axis=1)
    return F, _threshold(det, F, F[quiet]), coef[0]


def _crossing(t, F, i, j, level: float = 0.0) -> float:
    """Time where F crosses ``level`` between samples i and j (linear interpolation)."""
    if F[i] == F[j]:
        return float(t[i])
    return float(t[i] + (t[j] - t[i]) * (F[i] - level) / (F[i] - F[j]))


def _split_points(F: np.ndarray, s: int, e: int, threshold: float, split_fraction: float,
                  min_rise: int) -> list[int]:
    """Indices in (s, e) where an excursion above the threshold holds two distinct impacts.

    A peak of F[s:e] is distinct when both its bases (the lowest force between it and the
    next higher peak on each side, or the excursion's edge) are below ``split_fraction``
    times its height and at least ``min_rise`` samples away from it; the highest peak
    always is. The excursion is split at the minimum F_min between consecutive distinct
    peaks, which is then below ``split_fraction`` times the smaller of the two
    (scale-free: a light contact of a few newtons between two bounces of hundreds splits,
    a noise wiggle on a peak does not), unless ``F_min < -threshold``: a sensor under load
    does not read negative, so such a dip is the filter's undershoot. The distance rule
    keeps the filter's ringing (a lobe about 1/(2 cutoff) from the undershoot before it)
    with the impact that caused it.
    """
    from scipy.signal import find_peaks, peak_prominences

    a, b = max(s - 1, 0), min(e + 1, len(F))
    seg = F[a:b]
    peaks, _ = find_peaks(seg)
    if len(peaks) < 2:
        return []
    _, lb, rb = peak_prominences(seg, peaks)
    h = split_fraction * seg[peaks]
    keep = ((seg[lb] < h) & (seg[rb] < h) & (peaks - lb >= min_rise) & (rb - peaks >= min_rise)
            | (peaks == peaks[np.argmax(seg[peaks])]))
    kept = peaks[keep]
    cuts = [a + p + int(np.argmin(seg[p:q + 1])) for p, q in pairwise(kept)]
    return [m for m in cuts if F[m] >= -threshold]


def _pieces(F: np.ndarray, threshold: float, gap: int, split_fraction: float
            ) -> list[tuple[int, int]]:
    """[start, end) index ranges of the impacts: the excursions above the threshold
    (closer than ``gap`` samples merged) split at deep minima (:func:`_split_points`,
    with ``min_rise = gap``). Consecutive pieces with ``end == start`` meet at a split."""
    pieces: list[tuple[int, int]] = []
    for s, e in _regions(F > threshold, gap):
        bounds = [s, *_split_points(F, s, e, threshold, split_fraction, max(gap, 1)), e]
        pieces += list(pairwise(bounds))
    return pieces


def detect_impacts(t, F, threshold: float, *, min_separation_s: float = 0.005,
                   split_fraction: float = 0.5, cutoff_hz: float | None = None,
                   order: int = 4) -> pd.DataFrame:
    """Impacts in a force trace: peak, impulse and duration of each excursion above threshold.

    Each region where ``F > threshold`` (regions closer than ``min_separation_s`` merged,
    e.g. filter ringing next to a large peak, or a light contact that noise takes under
    the threshold) gives one impact, except that a region holding distinct peaks is split
    at the deep minimum between them (below ``split_fraction`` times the smaller peak,
    above ``-threshold``, and at least ``min_separation_s`` from either peak, see
    :func:`_split_points`): two bounces joined by a light contact are two impacts. With
    ``cutoff_hz`` (and the filter's ``order``), an excursion that is the filter's ringing
    of a larger impact (peak below :data:`RING_MARGIN` times the filter's side lobe
    :func:`ringing` of the impact's peak, within the ringing's extent + 1 periods of the
    cut-off from the impact) belongs to that impact: a zero-phase low-pass rings on both
    sides of a pulse (order 4: lobes of 3.7 % of the peak up to 2 periods away), which at
    a low cut-off lies beyond ``min_separation_s``. Each impact is measured on the lobe
    that holds its peak:

    - ``F_peak`` = max F [N] at ``t_peak`` [s],
    - ``t_start``, ``t_end``, ``duration``: where F crosses the threshold (interpolated)
      and the time between [s] (the low tails under the threshold are left out: with a
      threshold of a few noise sigmas they are short, and the zero crossings themselves
      wander with the noise); on the side of a split, where F crosses the threshold above
      the minimum at the split (``F_min + threshold``),
    - ``impulse`` = :math:`\\int F\\,dt` [N s] (trapezoidal) over the region widened to the
      zero crossings of F on either side, so that the tails are counted, but never past
      the cut with a neighbouring impact (the lowest force between them), and on the side
      of a split up to it: the impulses of a record never add up to more than its
      integral, and those of a split region add up to the region's. With ``cutoff_hz``
      (the low-pass filter's), the window is widened by :data:`RING_PERIODS` periods
      past the zero crossings (still not past a cut): the whole event, ringing lobes
      included, whose integral is the unfiltered impulse,
    - ``short`` (with ``cutoff_hz``): the duration is under :data:`SHORT_PERIODS`
      periods of the cut-off, so the filter has distorted the peak (attenuated, for a
      pulse much shorter) and the duration; a higher ``cutoff_hz`` measures it better.

    Returns
    -------
    pandas.DataFrame
        Columns ``impact, t_start, t_peak, t_end, F_peak, impulse, duration, short``
        (empty if none).
    """
    t = np.asarray(t, float)
    F = np.asarray(F, float)
    dt = float(np.median(np.diff(t)))
    gap = round(min_separation_s / dt)
    pieces = _pieces(F, threshold, gap, split_fraction)
    if cutoff_hz is not None:
        lobe, extent = ringing(order)
        pieces = _merge_ringing(F, pieces, math.ceil((extent + 1.0) / (cutoff_hz * dt)),
                                RING_MARGIN * lobe)
    n = len(F)
    # the cut between two neighbours: the split, or the lowest force of the gap between
    cuts = [e if e == s2 else e + int(np.argmin(F[e:s2]))
            for (_, e), (s2, _) in pairwise(pieces)]
    rows = []
    for i, (s, e) in enumerate(pieces):
        # a split with a neighbour: the shared sample bounds both, the level is raised
        split_lo = i > 0 and pieces[i - 1][1] == s
        split_hi = i + 1 < len(pieces) and pieces[i + 1][0] == e
        lo = cuts[i - 1] if i > 0 else 0
        hi = cuts[i] if i + 1 < len(pieces) else n - 1
        lev_lo = F[s] + threshold if split_lo else threshold
        lev_hi = F[e] + threshold if split_hi else threshold
        k = s + int(np.argmax(F[s:e]))
        # main lobe: walk from the peak to the threshold crossings, then to the zero crossings
        s1 = k
        while s1 > lo and F[s1 - 1] > lev_lo:
            s1 -= 1
        e1 = k
        while e1 < hi and F[e1 + 1] > lev_hi:
            e1 += 1
        # impulse: to the zero crossings, or to the split (the contact between two
        # bounces belongs to them: the impulses of a split add up to its integral)
        a, b = s1, e1
        while a > lo and F[a - 1] > 0:
            a -= 1
        while b < hi and F[b + 1] > 0:
            b += 1
        a = lo if split_lo else a
        b = hi if split_hi else b
        if cutoff_hz is not None:  # the whole event: ringing lobes on either side
            w = math.ceil(RING_PERIODS / (cutoff_hz * dt))
            a = lo if split_lo else max(a - w, lo)
            b = hi if split_hi else min(b + w, hi)
        tt, ff = t[a:b + 1], F[a:b + 1]
        if cutoff_hz is None and (a > lo or i == 0):  # at a zero crossing, not at the cut
            z0 = _crossing(t, F, a - 1, a) if a > 0 else float(t[0])
            tt, ff = np.concatenate([[z0], tt]), np.concatenate([[0.0], ff])
        if cutoff_hz is None and (b < hi or i + 1 == len(pieces)):
            z1 = _crossing(t, F, b, b + 1) if b < n - 1 else float(t[-1])
            tt, ff = np.concatenate([tt, [z1]]), np.concatenate([ff, [0.0]])
        t0 = _crossing(t, F, s1 - 1, s1, lev_lo) if s1 > lo else float(t[s1])
        t1 = _crossing(t, F, e1, e1 + 1, lev_hi) if e1 < hi else float(t[e1])
        rows.append({
            "t_start": t0, "t_peak": float(t[k]), "t_end": t1, "F_peak": float(F[k]),
            "impulse": float(np.trapezoid(ff, tt)), "duration": t1 - t0,
            "short": cutoff_hz is not None and (t1 - t0) * cutoff_hz < SHORT_PERIODS,
        })
    df = pd.DataFrame(rows, columns=["t_start", "t_peak", "t_end", "F_peak", "impulse",
                                     "duration", "short"])
    df.insert(0, "impact", np.arange(len(df)))
    return df


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
