r"""Numerical 1-DOF impact: m_eff x'' = -max(f(delta, delta_dot, v_n), 0) until separation.

The reference the closed forms are checked against. The ODE is integrated in the Hertz
scales of :func:`.hertz.hertz_scales` (xi = delta/delta_H, tau = t v/delta_H), in which it reads
:math:`\xi'' = -\tfrac{n+1}{2} f/F_H`, with DOP853 at rtol 1e-12. Events: maximum
indentation (delta_dot = 0), separation at delta = 0 and, for laws that can pull
(Kelvin–Voigt), at f = 0 while unloading; after f = 0 the mass moves freely, so the exit
speed is the speed at that instant. The peak force is the largest force on the evenly
spaced samples and the integrator's own steps, refined between the neighbours of the
largest (a strongly damped peak comes long before the first even sample).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._validation import check_rtol
from ..exceptions import InputError, SolverError
from .base import ContactLaw, check_law, positive_array

__all__ = ["ImpactHistory", "impact_1dof"]


@dataclass(frozen=True)
class ImpactHistory:
    """Result of :func:`impact_1dof` (one impact).

    Attributes
    ----------
    peak_force : float
        Maximum contact force [N].
    time_of_peak : float
        Time of the peak force after first touch [s].
    max_indentation : float
        Maximum indentation [m].
    time_of_max_indentation : float
        [s].
    duration : float
        Contact duration [s] (first touch to separation).
    exit_speed : float
        Normal separation speed [m/s] (> 0).
    restitution_achieved : float
        e* = exit_speed / v_n.
    energy_dissipated : float
        1/2 m (v_n^2 - v_out^2) [J].
    t, delta, delta_dot, force : (n_samples,) arrays
        Force history [s], [m], [m/s], [N] (force clamped at 0).
    law : str
    """

    peak_force: float
    time_of_peak: float
    max_indentation: float
    time_of_max_indentation: float
    duration: float
    exit_speed: float
    restitution_achieved: float
    energy_dissipated: float
    t: np.ndarray
    delta: np.ndarray
    delta_dot: np.ndarray
    force: np.ndarray
    law: str


def impact_1dof(
    law: ContactLaw,
    m_eff: float,
    v_n: float,
    *,
    rtol: float = 1e-12,
    n_samples: int = 801,
    max_duration: float = 1e4,
) -> ImpactHistory:
    """Integrate the impact of a mass ``m_eff`` [kg] arriving at ``v_n`` [m/s] on ``law``.

    Parameters
    ----------
    law : ContactLaw
    m_eff : float
        Effective mass [kg], > 0.
    v_n : float
        Normal approach speed [m/s], > 0.
    rtol : float
        Relative tolerance of the integrator (absolute tolerance rtol * 1e-2 in the scaled
        variables).
    n_samples : int
        Number of points of the returned force history.
    max_duration : float
        Give up (SolverError) if no separation within this many Hertz times delta_H/v_n.
    """
    from scipy import integrate, optimize
    check_law(law)
    if np.ndim(m_eff) or np.ndim(v_n):
        raise InputError("impact_1dof integrates one impact: pass scalars m_eff and v_n "
                         f"(got shapes {np.shape(m_eff)} and {np.shape(v_n)})")
    m = float(positive_array(m_eff, "m_eff [kg]"))
    v = float(positive_array(v_n, "v_n [m/s]"))
    rtol = check_rtol(rtol)
    try:
        ok = (not isinstance(max_duration, (bool, str)) and np.ndim(max_duration) == 0
              and math.isfinite(float(max_duration)) and float(max_duration) > 0)
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise InputError(f"max_duration must be a finite number > 0 (Hertz times), got "
                         f"{max_duration!r}")
    max_duration = float(max_duration)
    n, k = law.n, law.k
    with np.errstate(all="ignore"):
        d_H = ((n + 1.0) * m * v * v / (2.0 * k)) ** (1.0 / (n + 1.0))
        F_H = k * d_H**n
        t_H = d_H / v
    if not all(math.isfinite(x) and x > 0 for x in (d_H, F_H, t_H)):
        raise InputError(f"m_eff = {m:g} kg, v_n = {v:g} m/s on {law.name} (k = {k:g}): the "
                         f"impact's scales are out of floating-point range (indentation "
                         f"{d_H:g} m, force {F_H:g} N, time {t_H:g} s)")
    gain = (n + 1.0) / 2.0

    def raw(y):
        return law.force(d_H * y[0], v * y[1], v) / F_H

    def rhs(_tau, y):
        f = raw(y) if y[0] > 0 else 0.0
        return np.array([y[1], -gain * max(float(f), 0.0)])

    def ev_sep(_tau, y):
        return y[0]

    ev_sep.terminal, ev_sep.direction = True, -1

    def ev_max(_tau, y):
        return y[1]

    ev_max.terminal, ev_max.direction = False, -1
    events = [ev_sep, ev_max]
    if law.can_pull:

        def ev_pull(_tau, y):
            return float(raw(y)) if y[0] > 0 else 1.0

        ev_pull.terminal, ev_pull.direction = True, -1
        events.append(ev_pull)

    sol = integrate.solve_ivp(
        rhs, (0.0, max_duration), np.array([0.0, 1.0]), method="DOP853", rtol=rtol,
        atol=rtol * 1e-2, events=events, dense_output=True,
    )
    ends = [te for te in (sol.t_events[0], sol.t_events[2] if law.can_pull else [])
            if len(te)]
    if sol.status != 1 or not ends:
        raise SolverError(
            f"{law.name}: no separation within {max_duration:g} Hertz times "
            f"({max_duration * t_H:.3g} s): the contact is too damped to end, or ends "
            "later (a strongly damped exit creeps: gonthier at e = 1e-8 lasts 8e4 Hertz "
            "times); pass a larger max_duration"
        )
    tau_end = float(min(te[0] for te in ends))
    y_end = sol.sol(tau_end)
    tau_max = float(sol.t_events[1][0]) if len(sol.t_events[1]) else float("nan")
    xi_max = float(sol.sol(tau_max)[0]) if np.isfinite(tau_max) else float(np.max(sol.y[0]))

    def clamped(tau):
        y = sol.sol(tau)
        return np.maximum(np.where(y[0] > 0, raw(y), 0.0), 0.0)

    taus = np.linspace(0.0, tau_end, max(int(n_samples), 3))
    fs = clamped(taus)
    # The peak is searched on the evenly spaced samples and the integrator's own steps:
    # with strong damping (gonthier e <= 1e-5) it falls before the first sample, in the
    # early short steps, and the samples alone gave a peak of 0 N.
    grid = np.union1d(taus, sol.t[sol.t <= tau_end])
    fg = clamped(grid)
    i = int(np.argmax(fg))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    res = optimize.minimize_scalar(lambda s: -float(clamped(s)), bounds=(lo, hi),
                                   method="bounded", options={"xatol": 1e-12 * (hi - lo)})
    if -res.fun > fg[i]:
        tau_peak, f_peak = float(res.x), float(-res.fun)
    else:
        tau_peak, f_peak = float(grid[i]), float(fg[i])
    ys = sol.sol(taus)
    v_out = -float(y_end[1]) * v
    return ImpactHistory(
        peak_force=f_peak * F_H,
        time_of_peak=tau_peak * t_H,
        max_indentation=xi_max * d_H,
        time_of_max_indentation=tau_max * t_H,
        duration=tau_end * t_H,
        exit_speed=v_out,
        restitution_achieved=v_out / v,
        energy_dissipated=0.5 * m * (v * v - v_out * v_out),
        t=taus * t_H,
        delta=np.maximum(ys[0], 0.0) * d_H,
        delta_dot=ys[1] * v,
        force=fs * F_H,
        law=law.name,
    )
