"""Impact detection on force traces with known answers (half-sine pulses: peak A, impulse
2 A T / pi, duration T), through the low-pass filter of the pipeline."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from roverimpact import experiments as ex

FS = 5000.0


def _half_sine(t, t0, T, A):
    """A half-sine pulse of height A [N] and length T [s] from t0; its impulse is 2 A T / pi."""
    x = (t - t0) / T
    return np.where((x > 0) & (x < 1), A * np.sin(np.pi * np.clip(x, 0, 1)), 0.0)


def _run_one_trial(tmp_path, t, f):
    """``run_experiment`` of one recording (time ``t`` [s], channel ``ch1`` in N)."""
    pd.DataFrame({"time_s": t, "ch1_N": f}).to_csv(tmp_path / "a.csv", index=False)
    (tmp_path / "trials.toml").write_text(
        '[sensors]\nchannels = ["ch1"]\nunits = "N"\ngains = [1.0]\n\n'
        '[[trial]]\nfile = "a.csv"\nbeta_deg = 30.0\nspeed = 0.3\n')
    return ex.run_experiment(tmp_path / "trials.toml")


def _filtered(f, cutoff_hz=300.0):
    return ex.lowpass(f, FS, cutoff_hz)


def test_bounces_joined_by_light_contact_are_two_impacts():
    """800 N then 500 N (30 ms each, 100 ms apart) with a 3 N light contact between them,
    above the threshold: two impacts, each with its own peak and impulse; the light
    contact's 0.21 N s goes to one of them, so the impulses add up to the integral."""
    t = np.arange(int(FS)) / FS
    f = _half_sine(t, 0.40, 0.03, 800.0) + _half_sine(t, 0.50, 0.03, 500.0)
    f[(t > 0.43) & (t < 0.50)] += 3.0
    f += np.random.default_rng(22).normal(0, 0.5, len(t))
    F = _filtered(f)
    imp = ex.detect_impacts(t, F, 1.67)
    assert len(imp) == 2
    np.testing.assert_allclose(imp["F_peak"], [800.0, 500.0], rtol=0.01)
    ref = 2 * np.array([800.0, 500.0]) * 0.03 / np.pi  # 15.28, 9.55
    np.testing.assert_allclose(imp["impulse"], ref, atol=0.21 + 0.05)
    np.testing.assert_allclose(imp["impulse"].sum(), ref.sum() + 3.0 * 0.07, atol=0.05)
    np.testing.assert_allclose(imp["duration"], 0.03, atol=0.002)


def test_noise_and_ringing_do_not_split():
    """A single pulse with noise on it, and the ringing of a short pulse: one impact each."""
    t = np.arange(int(0.5 * FS)) / FS
    rng = np.random.default_rng(3)
    for T, A in [(0.03, 800.0), (0.002, 1000.0), (0.0005, 1000.0)]:
        F = _filtered(_half_sine(t, 0.2, T, A) + rng.normal(0, 0.5, len(t)))
        assert len(ex.detect_impacts(t, F, 1.7)) == 1, T
    # a plateau held by a light contact with noise: still one impact
    f = _half_sine(t, 0.2, 0.03, 300.0)
    f[(t > 0.215) & (t < 0.3)] = np.maximum(f[(t > 0.215) & (t < 0.3)], 20.0)
    F = _filtered(f + rng.normal(0, 2.0, len(t)))
    assert len(ex.detect_impacts(t, F, 7.0)) == 1


def test_impacts_sharing_a_lobe_do_not_share_its_impulse():
    """1000 N and 400 N (20 ms each, 80 ms apart) with a 40 N resting load between them,
    under the threshold of 80 N: two impacts, whose impulses (half-sines 12.73 and
    5.09 N s, plus a share of the 3.2 N s of the resting load) add up to the integral
    of the lobe (21.0 N s), not twice it."""
    t = np.arange(int(FS)) / FS
    f = _half_sine(t, 0.40, 0.02, 1000.0) + _half_sine(t, 0.48, 0.02, 400.0)
    f[(t > 0.41) & (t < 0.49)] += 40.0
    F = _filtered(f + np.random.default_rng(2).normal(0, 0.5, len(t)))
    imp = ex.detect_impacts(t, F, 80.0)
    assert len(imp) == 2
    ref = 2 * np.array([1000.0, 400.0]) * 0.02 / np.pi
    assert np.all(imp["impulse"] > ref - 0.05)
    assert np.all(imp["impulse"] < ref + 40.0 * 0.08 + 0.05)
    lobe = (t > 0.39) & (t < 0.51)
    np.testing.assert_allclose(imp["impulse"].sum(), np.trapezoid(f[lobe], t[lobe]), rtol=0.01)


def test_short_impacts_keep_their_impulse_and_are_flagged():
    """Half-sines of 1000 N through the 300 Hz low-pass at 20 kHz: the impulse over the
    whole event is the pulse's 2 A T / pi (the filter keeps the integral; the zero
    crossings alone gave +9 % at T = 2 ms); an impact shorter than SHORT_PERIODS periods
    of the cut-off is flagged, and the peak errors quoted for SHORT_PERIODS hold."""
    fs, fc = 20000.0, 300.0
    t = np.arange(int(0.5 * fs)) / fs
    peak_err = {}
    for T in [0.02, 0.01, 0.008, 0.005, 0.004, 0.003, 0.002, 0.001]:
        F = ex.lowpass(_half_sine(t, 0.25, T, 1000.0), fs, fc)
        imp = ex.detect_impacts(t, F, 1.0, cutoff_hz=fc)
        assert len(imp) == 1
        r = imp.iloc[0]
        np.testing.assert_allclose(r.impulse, 2 * 1000.0 * T / np.pi, rtol=2e-3)
        periods = r.duration * fc
        assert r.short == (periods < ex.signal.SHORT_PERIODS)
        peak_err[T] = (periods, r.F_peak / 1000.0 - 1)
    # the figures of SHORT_PERIODS' docstring and docs/experiments.md
    assert all(abs(e) < 0.0025 for p, e in peak_err.values() if p >= ex.signal.SHORT_PERIODS)
    assert peak_err[0.002][1] < -0.30 and peak_err[0.001][1] < -0.6
    assert abs(peak_err[0.003][0] - 1.25) < 0.01 and -0.12 < peak_err[0.003][1] < -0.10
    assert abs(peak_err[0.002][0] / fc - 0.0037) < 1e-4
    docs = (Path(__file__).resolve().parents[1] / "docs" / "experiments.md").read_text()
    assert f"{ex.signal.SHORT_PERIODS:g} periods of the cut-off (`SHORT_PERIODS`" in docs
    assert f"by {ex.signal.RING_PERIODS:g} periods of the\n   cut-off (`RING_PERIODS`)" in docs
    assert peak_err[0.02][0] > ex.signal.SHORT_PERIODS > peak_err[0.005][0]


def test_short_impact_warned_in_the_outputs(tmp_path):
    """A 2 ms impact in a recording: the trial runs, and its warning names the trial,
    the duration and the remedy (a higher cutoff_hz)."""
    fs = 20000.0
    t = np.arange(int(0.5 * fs)) / fs
    f = _half_sine(t, 0.25, 0.002, 1000.0) + np.random.default_rng(16).normal(0, 0.5, len(t))
    res = _run_one_trial(tmp_path, t, f)
    assert bool(res.trials["short"].iloc[0])
    (w,) = res.warnings
    assert "trial 0 (a.csv)" in w and "cutoff_hz" in w and "300 Hz" in w
    files = ex.write_outputs(res, tmp_path / "out")
    assert json.loads(files["summary"].read_text())["warnings"] == [w]


def test_short_impact_at_a_low_sample_rate_asks_for_a_higher_rate(tmp_path):
    """A 1000 N, 2 ms half-sine sampled at 1 kHz (samples of 707 N; filtered peak 632 N): no
    cut-off below the Nyquist frequency (500 Hz) measures it, since 2.5 periods of 500 Hz
    are 5 ms. The warning used to advise "raise [filter] cutoff_hz (below 500 Hz)", which
    cannot help; it now asks for a higher sample rate."""
    fs = 1000.0
    t = np.arange(int(fs)) / fs
    f = _half_sine(t, 0.5005, 0.002, 1000.0) + np.random.default_rng(2).normal(0, 0.5, len(t))
    res = _run_one_trial(tmp_path, t, f)
    (w,) = res.warnings
    assert "record at a higher sample rate" in w and "raise [filter]" not in w
    assert "Nyquist frequency 500 Hz" in w


def test_ringing_of_a_low_cutoff_is_not_an_impact():
    """At a 50-100 Hz cut-off the zero-phase filter's ringing lobes (3.7 % of the peak for
    order 4, up to 2 periods away: beyond ``min_separation_s``) stayed above a low-noise
    threshold and were listed as impacts of their own, with negative impulses (a 10 ms,
    2000 N half-sine at 50 Hz gave 5 impacts, the main one's impulse +4.8 %). One impact,
    its impulse the closed form 2 A T / pi; a second hit 60 ms later still counts."""
    lobe, extent = ex.signal.ringing(4)
    np.testing.assert_allclose([lobe, extent], [0.0373, 2.03], atol=0.01)
    t = np.arange(int(FS)) / FS
    rng = np.random.default_rng(5)
    for T, fc in [(0.01, 50.0), (0.025, 50.0), (0.05, 100.0)]:
        F = _filtered(_half_sine(t, 0.4, T, 2000.0) + rng.normal(0, 0.5, len(t)), fc)
        imp = ex.detect_impacts(t, F, 2.0, cutoff_hz=fc)
        assert len(imp) == 1, (T, fc, imp)
        np.testing.assert_allclose(imp["impulse"], 2 * 2000.0 * T / np.pi, rtol=0.002)
    f = _half_sine(t, 0.4, 0.02, 2000.0) + _half_sine(t, 0.46, 0.02, 300.0)
    F = _filtered(f + rng.normal(0, 0.5, len(t)), 100.0)
    imp = ex.detect_impacts(t, F, 2.0, cutoff_hz=100.0)
    np.testing.assert_allclose(imp["F_peak"], [2000.0, 300.0], rtol=0.01)
    np.testing.assert_allclose(imp["impulse"].sum(), 2 * 2300.0 * 0.02 / np.pi, rtol=0.002)
    docs = (Path(__file__).resolve().parents[1] / "docs" / "experiments.md").read_text()
    assert f"under {ex.signal.RING_MARGIN:g} times that fraction" in docs
    assert "lobes up to 3.7 %\n   of the peak, up to 2 periods" in docs
