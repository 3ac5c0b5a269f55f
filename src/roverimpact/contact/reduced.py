r"""Peak force of an impact on a system with several compliant, preloaded contacts.

The closed forms of :func:`~roverimpact.contact.predict` treat the impact as a mass
:math:`m_{eff}` hitting the contact law at :math:`v_n` with nothing else acting: the other
contacts rigid (held) or absent, no gravity. On a rover the wheels stand on a compliant
ground that carries the weight, so the obstacle contact (i) works in series with the ground
springs, (ii) takes over part of the weight while it lasts and (iii) may unload a wheel's
ground contact, which then lets go. This module models all three without integrating the
multibody system: at the frozen pre-impact configuration the normal gaps of the contacts
obey, exactly for a system whose contact forces act through the rows :math:`A`
(:math:`M\dot v = \tau + A^T f`, bilateral rows held rigidly),

.. math::

    \ddot\delta = -(b + G f), \qquad G = A N A^T, \quad b = A N \tau,
    \quad N = M^{-1} - M^{-1}C^T (C M^{-1} C^T)^{-1} C M^{-1},

with :math:`\delta` the penetrations (:math:`\dot\delta = -A v`), :math:`f_i =
\max(0, f_i(\delta_i, \dot\delta_i))` each contact's law, :math:`\tau` the applied
generalized forces (gravity, Coriolis and centrifugal terms, joint springs) and :math:`C`
the bilateral rows (loop closures, locked joints). Only the configuration is frozen (the
impact moves the rover by millimetres) and the rows' drift terms :math:`\dot A v` are left
out. It is a contact-space ODE of 2 m states (m contacts), integrated in
:func:`reduced_impact`: a few hundred steps of a small system (14 states on a six-wheel
rover).

Limit: with the obstacle row alone and no applied force it is the 1-DoF impact of
:func:`~roverimpact.contact.impact_1dof` with :math:`m_{eff} = 1/G_{oo}`, whose peak
the closed forms give (tests/test_newtons.py checks it, a preloaded spring-damper against
its analytic solution and two coupled rows against the matrix exponential).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from .._validation import check_finite, check_psd
from ..exceptions import InputError, SolverError
from .base import ContactLaw, check_law

__all__ = ["ReducedImpact", "held_inverse", "law_form", "reduced_impact", "reduced_impact_batch",
           "static_indentation", "static_loads", "static_loads_batch"]


@dataclass(frozen=True)
class ReducedImpact:
    """Result of :func:`reduced_impact`.

    Attributes
    ----------
    peak_force : float
        Largest force of the impact contact [N] (within ``t_max``).
    time_of_peak : float
        [s] after first touch.
    duration : float
        Contact duration [s]; ``t_max`` if the contact had not ended (``ended`` False).
    ended : bool
        The impact contact separated within ``t_max``.
    loads : (m,) ndarray
        Static forces of the other contacts before the impact [N] (0 for the impact row).
    """

    peak_force: float
    time_of_peak: float
    duration: float
    ended: bool
    loads: np.ndarray


def static_loads(G, b, *, rtol: float = 1e-10) -> np.ndarray:
    r"""Static forces :math:`\lambda \ge 0` of unilateral contacts with
    :math:`b + G\lambda = 0` on the loaded ones (no acceleration of their gaps) and
    :math:`b + G\lambda \ge 0` on the others (they would open): the complementarity
    solution, by dropping the most negative force until none is negative.

    Parameters
    ----------
    G : (m, m) array_like
        Inverse effective mass matrix of the rows (symmetric positive semi-definite).
    b : (m,) array_like
        Gap acceleration (separating positive) under the applied forces alone.
    """
    G = np.asarray(G, float)
    b = np.asarray(b, float)
    m = b.shape[0]
    act = list(range(m))
    lam = np.zeros(m)
    scale = rtol * max(float(np.max(np.abs(G @ np.abs(b)))) if m else 0.0, 1e-300)
    while act:
        lam = np.zeros(m)
        lam[act] = np.linalg.lstsq(G[np.ix_(act, act)], -b[act], rcond=None)[0]
        neg = [i for i in act if lam[i] < -scale]
        if not neg:
            break
        act.remove(min(neg, key=lambda i: lam[i]))
    return np.maximum(lam, 0.0)


def static_indentation(law, f0, v_i: float = 1.0) -> np.ndarray:
    """Indentations [m] with ``law.force(delta, 0, v_i) = f0`` for each static force ``f0``
    [N] (0 where f0 <= 0; bisection on a spring that stiffens with delta)."""
    f0 = np.atleast_1d(np.asarray(f0, float))
    out = np.zeros_like(f0)
    for i, f in enumerate(f0):
        if f <= 0.0:
            continue
        n = getattr(law, "n", 1.0)
        guess = (f / law.k) ** (1.0 / n)
        lo, hi = 0.0, 2.0 * guess
        while float(law.force(hi, 0.0, v_i)) < f:
            hi *= 2.0
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if float(law.force(mid, 0.0, v_i)) < f else (lo, mid)
        out[i] = 0.5 * (lo + hi)
    return out


def held_inverse(M, C=None) -> np.ndarray:
    r""":math:`N = M^{-1} - M^{-1}C^T (C M^{-1} C^T)^{+} C M^{-1}`: the inverse mass of the
    system with the bilateral rows ``C`` (loop closures, locked joints) held rigidly
    (module docstring); :math:`M^{-1}` without rows (``C`` None or empty)."""
    Minv = np.linalg.inv(np.asarray(M, float))
    if C is None or np.size(C) == 0:
        return Minv
    C = np.atleast_2d(np.asarray(C, float))
    return Minv - Minv @ C.T @ np.linalg.pinv(C @ Minv @ C.T) @ C @ Minv


def law_form(law, v_i: float) -> tuple[float, float, float, float, float] | None:
    r"""``(k, n, a, c, f0)`` with ``law.force(delta, delta_dot, v_i)`` =
    :math:`k\delta^n(1 + a\dot\delta) + c\dot\delta - f_0` for :math:`\delta > 0` (the
    form of the compiled integrators, :mod:`roverimpact._kernels.reduced`): Hertz, the
    Hunt-Crossley family, Kelvin-Voigt, and any object with a ``reduced_form(v_i)`` method
    returning it; None for any other law."""
    from .hertz import Hertz
    from .hunt_crossley import HuntCrossleyFamily

    if isinstance(law, HuntCrossleyFamily):
        return float(law.k), float(law.n), float(law.z) / float(v_i), 0.0, 0.0
    if isinstance(law, Hertz):
        return float(law.k), float(law.n), 0.0, 0.0, 0.0
    if callable(getattr(law, "reduced_form", None)):
        return tuple(float(x) for x in law.reduced_form(v_i))
    sd = law.spring_damper() if isinstance(law, ContactLaw) else None
    if sd is not None:
        return float(sd[0]), 1.0, 0.0, float(sd[1]), 0.0
    return None


def static_loads_batch(G, b) -> np.ndarray:
    """:func:`static_loads` of every item of a batch (G (B, s, s), b (B, s)): one batched
    solve where every contact is loaded, the active-set loop of :func:`static_loads` for
    the others."""
    G = np.asarray(G, float)
    b = np.asarray(b, float)
    B, m = b.shape
    lam = np.zeros((B, m))
    if m == 0 or B == 0:
        return lam
    try:
        with np.errstate(all="ignore"):
            lam = np.linalg.solve(G, -b[..., None])[..., 0]
        tol = 1e-10 * np.max(np.abs(np.einsum("bij,bj->bi", G, np.abs(b))), axis=1)
        redo = np.flatnonzero(np.any(lam < -tol[:, None], axis=1)
                              | ~np.all(np.isfinite(lam), axis=1))
    except np.linalg.LinAlgError:
        redo = np.arange(B)
    for i in redo:
        lam[i] = static_loads(G[i], b[i])
    return np.maximum(lam, 0.0)


#: tolerance of the Rosenbrock pair, relative to the state's scale
STIFF_TOL = 1e-6
#: explicit steps per window above which an item is integrated by the Rosenbrock pair
STIFF_STEPS = 2000


def _steps(G, b, L, loads, v, o, t_max):
    """Step of the compiled integrator per item: 0.2 / the largest rate of the rows
    linearised at twice the largest force expected (0.5 / the largest damping rate there),
    at most 1/200 of the window and 1/20 of the impact row's closed-form time scale
    ``delta_H / v_n``; where the damping rate alone would need
    more than :data:`STIFF_STEPS` steps, the item is stiff. Returns (dt, explicit, stiff,
    d_scale): the Runge-Kutta step, the step without the damping bound (the Rosenbrock
    pair's first), the stiff flags, and the larger of the closed-form indentation and the
    static ones [m] (the Rosenbrock pair's scale)."""
    B = G.shape[0]
    k, n, a, c, f0 = (L[..., i] for i in range(5))
    g = np.maximum(np.diagonal(G, axis1=1, axis2=2), 0.0)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        fin = g[:, o] > 0
        m_o = np.where(fin, 1.0 / np.where(fin, g[:, o], 1.0), 0.0)
        d_H = np.where(fin, (0.5 * (n[:, o] + 1.0) * m_o * v * v / k[:, o])
                       ** (1.0 / (n[:, o] + 1.0)), 1e-3)
        F = 2.0 * np.maximum.reduce([np.max(loads, axis=1), k[:, o] * d_H ** n[:, o],
                                     np.abs(b[:, o]) * m_o,
                                     np.sum(np.abs(np.einsum("bij,bj->bi", G, loads)), 1) * m_o])
        k_lin = n * k ** (1.0 / n) * F[:, None] ** ((n - 1.0) / n)
        omega = np.max(np.sqrt(g * k_lin), axis=1)
        damp = np.max(g * (F[:, None] * np.abs(a) + c), axis=1)
        explicit = np.minimum.reduce([np.full(B, t_max / 200.0),
                                      np.where(omega > 0, 0.2 / omega, np.inf),
                                      0.05 * d_H / v])
        dt = np.minimum(explicit, np.where(damp > 0, 0.5 / damp, np.inf))
        stiff = t_max / dt > STIFF_STEPS
        d0 = np.where(loads > 0.0, (np.maximum(loads + f0, 0.0) / k) ** (1.0 / n), 0.0)
        d_scale = np.maximum(d_H, np.max(d0, axis=1))
    return (np.ascontiguousarray(dt), np.ascontiguousarray(explicit),
            np.ascontiguousarray(stiff), np.ascontiguousarray(d_scale))


#: Most steps :func:`reduced_impact_batch` lets the Runge-Kutta integrator take to cover
#: ``t_max`` (the compiled kernel counts its steps in an int64; past it the count wraps).
MAX_STEPS = 2.0 ** 53


def _impact_row(impact, m: int) -> int:
    """The row ``impact`` indexes among ``m`` (a negative index counts from the end, as in
    Python), or one InputError naming it and the valid range: an index outside
    ``[-m, m - 1]`` was wrapped modulo ``m`` (another row taken for the impact row)."""
    if isinstance(impact, (bool, np.bool_)) or not isinstance(impact, (int, np.integer)):
        raise InputError(f"impact must be an integer row index, got {impact!r}")
    if not -m <= impact < m:
        rng = f"in [{-m}, {m - 1}]" if m else "none: there are no rows"
        raise InputError(f"impact must index one of the {m} rows, an integer {rng}, got "
                         f"{impact}")
    return int(impact) % m


def _broadcast(x, name: str, shape: tuple[int, ...]) -> np.ndarray:
    """``x`` as a C float array of ``shape``, or one InputError naming it (numpy's
    "operands could not be broadcast together" named neither the input nor the shape)."""
    x = np.asarray(x, float)
    try:
        return np.ascontiguousarray(np.broadcast_to(x, shape))
    except ValueError:
        raise InputError(f"{name} must broadcast to {shape} (batch, rows"
                         f"{', law' if len(shape) == 3 else ''}) to match G, got "
                         f"{x.shape}") from None


def _check_t_max(t_max) -> None:
    if not (isinstance(t_max, (int, float, np.integer, np.floating))
            and math.isfinite(t_max) and t_max > 0):
        raise InputError(f"t_max must be a finite time > 0 [s], got {t_max!r}")


#: What G is, for the messages of :func:`~roverimpact._validation.check_psd`
_G_IS = "the rows' inverse mass A M^-1 A^T"


def _check_batch(G, b, L, rate0, t_max) -> None:
    """:func:`reduced_impact_batch`'s inputs: finite arrays, each item's ``G`` symmetric
    positive semi-definite, a finite ``t_max`` > 0, each law's ``k >= 0`` and ``n > 0``.
    Else the integrators' step count is NaN or infinite, which the compiled kernels and
    their Python code (a fresh install's small work) do not even report alike (a wrong
    result, ``ZeroDivisionError``, ``ValueError``), or (a G with a negative eigenvalue:
    a row whose gap accelerates into the contact that pushes it) the Runge-Kutta returns
    an infinite force and the Rosenbrock pair never ends."""
    _check_t_max(t_max)
    for name, x, core in (("G", G, 2), ("b", b, 1), ("L", L, 2), ("rate0", rate0, 1)):
        check_finite(x, name, core)
    check_psd(G, "G", _G_IS)
    if np.any(L[..., 0] < 0.0) or np.any(~(L[..., 1] > 0.0)):
        raise InputError("each row's law (k, n, a, c, f0) needs a stiffness k >= 0 and an "
                         "exponent n > 0")


def reduced_impact_batch(G, b, L, rate0, *, t_max: float, impact: int = -1,
                         preload: bool = True, integrator: str = "auto") -> ReducedImpact:
    r""":func:`reduced_impact` of every item of a batch by the compiled integrators
    (:mod:`roverimpact._kernels.reduced`): rows of the form of :func:`law_form`.

    Parameters
    ----------
    G : (B, m, m) array_like
        Symmetric positive semi-definite (to 1e-8 of its largest diagonal, the rounding of
        :math:`A N A^T`).
    b, rate0 : (B, m) array_like
    L : (B, m, 5) array_like
        Each row's law ``(k, n, a, c, f0)``:
        :math:`f = k\delta^n(1 + a\dot\delta) + c\dot\delta - f_0` (:func:`law_form`).
    t_max, impact, preload
        As :func:`reduced_impact` (``impact`` the same row of every item, an integer in
        ``[-m, m - 1]``).
    integrator : "auto", "rk4" or "rosenbrock"
        The fixed-step Runge-Kutta for every item, the Rosenbrock pair for every item, or
        per item (``"auto"``): the Rosenbrock pair where the damping would take the
        Runge-Kutta more than :data:`STIFF_STEPS` steps. Each is a kernel of its own,
        compiled on first use (the Rosenbrock pair about 3 s).

    Returns
    -------
    ReducedImpact
        With arrays (B,) (``loads`` (B, m)).

    Raises
    ------
    InputError
        NaN or inf in the arrays, a ``G`` not (B, m, m) or not symmetric positive
        semi-definite, ``impact`` not a row index, ``t_max`` not a finite time > 0, a law
        with ``k < 0`` or ``n <= 0``, no approach speed on the impact row, or a step that
        would need more than :data:`MAX_STEPS` Runge-Kutta steps to cover ``t_max`` (a
        Rosenbrock item: a first step of zero).
    """
    from .._kernels.reduced import rk4_peaks, stiff_peaks

    G = np.ascontiguousarray(G, dtype=float)
    if G.ndim != 3 or G.shape[1] != G.shape[2]:
        raise InputError(f"G must have shape (B, m, m), got {G.shape}")
    b, rate0 = (_broadcast(x, name, G.shape[:2]) for x, name in ((b, "b"), (rate0, "rate0")))
    L = _broadcast(L, "L", (*G.shape[:2], 5))
    B, m = b.shape
    o = _impact_row(impact, m)
    _check_batch(G, b, L, rate0, t_max)
    if np.any(~(rate0[:, o] > 0.0)):
        raise InputError("the impact row needs an approach speed > 0 in every item")
    others = [i for i in range(m) if i != o]
    loads = np.zeros((B, m))
    if preload and others:
        loads[:, others] = static_loads_batch(G[:, others][:, :, others], b[:, others])
    k, n, f0 = L[..., 0], L[..., 1], L[..., 4]
    with np.errstate(divide="ignore"):
        delta0 = np.where(loads > 0.0, (np.maximum(loads + f0, 0.0) / k) ** (1.0 / n), 0.0)
    if integrator not in ("auto", "rk4", "rosenbrock"):
        raise InputError(f"integrator must be 'auto', 'rk4' or 'rosenbrock', got "
                         f"{integrator!r}")
    dt, explicit, stiff, d_scale = _steps(G, b, L, loads, rate0[:, o], o, t_max)
    if integrator != "auto":
        stiff = np.full(B, integrator == "rosenbrock")
    dt = np.where(stiff, explicit, dt)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        steps = t_max / dt
    # the Runge-Kutta's fixed steps, the Rosenbrock pair's first one (which then adapts)
    bad = np.where(stiff, ~np.isfinite(steps), ~(steps <= MAX_STEPS))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"the integrator's step {dt[i]:.3g} s cannot cover t_max = "
                         f"{t_max:.3g} s in at most {MAX_STEPS:.3g} steps (item {i}): check "
                         f"the laws' stiffness and damping and the units of G and rate0")
    out = np.empty((B, 4))
    for kernel, sel in ((rk4_peaks, ~stiff), (stiff_peaks, stiff)):
        idx = np.flatnonzero(sel)
        if idx.size == 0:
            continue
        part = np.empty((idx.size, 4))
        law = tuple(np.ascontiguousarray(L[idx, :, j]) for j in range(5))
        args = (G[idx], b[idx], *law, delta0[idx], rate0[idx], int(o), float(t_max),
                dt[idx])
        if kernel is stiff_peaks:
            args += (d_scale[idx], STIFF_TOL)
        kernel.get(idx.size)(*args, part)
        out[idx] = part
    return ReducedImpact(peak_force=out[:, 0], time_of_peak=out[:, 1], duration=out[:, 2],
                         ended=out[:, 3] > 0.5, loads=loads)


def reduced_impact(G, b, laws, v_i, rate0, *, t_max: float, impact: int = -1,
                   preload: bool = True, rtol: float = 1e-8,
                   method: str = "lsoda") -> ReducedImpact:
    r"""Integrate the contact-space impact (module docstring) until the impact contact
    separates or ``t_max`` has elapsed.

    Parameters
    ----------
    G : (m, m) array_like
        :math:`A N A^T` of every compliant contact row, the impact row included [1/kg].
    b : (m,) array_like
        :math:`A N \tau` [m/s^2] (gap acceleration under the applied forces, separating
        positive).
    laws : sequence of m contact laws
        Each row's law (:func:`~roverimpact.contact.get_law`, or any object with
        ``force(delta, delta_dot, v_i)`` [N] and a stiffness ``k``).
    v_i : sequence of m floats
        The ``v_i`` argument of each law [m/s] (the impact row: its approach speed).
    rate0 : (m,) array_like
        Penetration rates at first touch [m/s] (:math:`-A v`); the impact row's is its
        approach speed :math:`v_n > 0`.
    t_max : float
        Window [s].
    impact : int
        Index of the impact row, in ``[-m, m - 1]`` (a negative one counts from the end).
    preload : bool
        Start the other rows at their static load (:func:`static_loads`); False: all
        gaps start at 0 (the other contacts just touching).
    method : "lsoda", "auto", "rk4" or "rosenbrock"
        scipy's LSODA (``rtol``; the reference), or a compiled integrator of
        :mod:`roverimpact._kernels.reduced` (:func:`reduced_impact_batch`'s
        ``integrator``: 20-100 times faster; laws of :func:`law_form`, LSODA for any
        other).

    Returns
    -------
    ReducedImpact
    """
    G = np.atleast_2d(np.asarray(G, float))
    b = np.atleast_1d(np.asarray(b, float))
    m = b.shape[0]
    if G.shape != (m, m):
        raise InputError(f"G must be ({m}, {m}) to match b, got {G.shape}")
    _check_t_max(t_max)  # (the compiled methods check it again, with the laws)
    check_finite(G, "G", 2)
    check_finite(b, "b", 1)
    check_psd(G, "G", _G_IS)
    laws = [law if not isinstance(law, ContactLaw) and callable(getattr(law, "force", None))
            else check_law(law) for law in laws]
    v_i = np.broadcast_to(np.asarray(v_i, float), (m,)).copy()
    d_rate = np.asarray(rate0, float).reshape(m).copy()
    o = _impact_row(impact, m)
    if not (d_rate[o] > 0.0):
        raise InputError(f"the impact row needs an approach speed > 0, got {d_rate[o]}")
    if method not in ("lsoda", "auto", "rk4", "rosenbrock"):
        raise InputError(f"method must be 'lsoda', 'auto', 'rk4' or 'rosenbrock', got "
                         f"{method!r}")
    others = [i for i in range(m) if i != o]
    if method != "lsoda":
        forms = [law_form(law, vi) for law, vi in zip(laws, v_i, strict=True)]
        if all(f is not None for f in forms):
            r = reduced_impact_batch(G[None], b[None], np.array(forms, float)[None],
                                     d_rate[None], t_max=t_max, impact=o, preload=preload,
                                     integrator=method)
            return ReducedImpact(peak_force=float(r.peak_force[0]),
                                 time_of_peak=float(r.time_of_peak[0]),
                                 duration=float(r.duration[0]), ended=bool(r.ended[0]),
                                 loads=r.loads[0])
    loads = np.zeros(m)
    delta0 = np.zeros(m)
    if preload and others:
        sub = np.ix_(others, others)
        loads[others] = static_loads(G[sub], b[others])
        for i in others:
            delta0[i] = static_indentation(laws[i], loads[i:i + 1], v_i[i])[0]

    groups: dict[int, list[int]] = {}
    for i, law in enumerate(laws):                # rows sharing a law: one call
        groups.setdefault(id(law), []).append(i)
    groups_ = [(laws[idx[0]], np.array(idx), v_i[idx]) for idx in groups.values()]

    def forces(d, dd):
        f = np.zeros(m)
        for law, idx, vi in groups_:
            di = d[idx]
            raw = np.asarray(law.force(np.maximum(di, 0.0), dd[idx], vi), float)
            f[idx] = np.where(di > 0.0, np.maximum(raw, 0.0), 0.0)
        return f

    def rhs(_t, y):
        d, dd = y[:m], y[m:]
        return np.concatenate([dd, -(b + G @ forces(d, dd))])

    def ev_sep(_t, y):
        return y[o]

    ev_sep.terminal = True
    ev_sep.direction = -1
    # step bound: the impact row's own time scale at the closed-form peak (k, m_eff)
    m_o = 1.0 / G[o, o] if G[o, o] > 0 else np.inf
    law_o = laws[o]
    n_o = float(getattr(law_o, "n", 1.0))
    d_H = (0.5 * (n_o + 1.0) * m_o * d_rate[o] ** 2 / law_o.k) ** (1.0 / (n_o + 1.0)) \
        if np.isfinite(m_o) else 1e-3
    step = min(t_max / 50.0, 0.1 * d_H / d_rate[o])
    y0 = np.concatenate([delta0, d_rate])
    sol = solve_ivp(rhs, (0.0, t_max), y0, method="LSODA", events=ev_sep, rtol=rtol,
                    atol=1e-12 * max(d_H, 1e-9), max_step=step, dense_output=True)
    if sol.status < 0:
        raise SolverError(f"reduced impact: integrator failed ({sol.message})")
    F = np.array([forces(sol.y[:m, j], sol.y[m:, j])[o] for j in range(sol.t.size)])
    j = int(np.argmax(F))
    # refine the peak between the neighbouring steps
    ta, tb = sol.t[max(j - 1, 0)], sol.t[min(j + 1, sol.t.size - 1)]
    tt = np.linspace(ta, tb, 41)
    yy = sol.sol(tt)
    Ff = np.array([forces(yy[:m, i], yy[m:, i])[o] for i in range(tt.size)])
    i = int(np.argmax(Ff))
    peak, t_peak = (float(Ff[i]), float(tt[i])) if Ff[i] > F[j] else (float(F[j]),
                                                                      float(sol.t[j]))
    ended = sol.status == 1
    return ReducedImpact(peak_force=peak, time_of_peak=t_peak,
                         duration=float(sol.t[-1]), ended=bool(ended), loads=loads)
