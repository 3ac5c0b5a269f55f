r"""Compiled contact-space impact (:mod:`roverimpact.contact.reduced`) for laws of one form.

:func:`rk4_peaks` and :func:`stiff_peaks` integrate, for every item of a batch,
:math:`\ddot\delta = -(b + G f)` with every row's force

.. math::

    f_i = \max\bigl(0,\; k_i \delta_i^{n_i} (1 + a_i \dot\delta_i) + c_i \dot\delta_i
    - f_{0,i}\bigr) \quad (\delta_i > 0), \qquad f_i = 0 \quad (\delta_i \le 0),

which is Hertz (a = c = f_0 = 0), the Hunt-Crossley family (a = z / v_i), Kelvin-Voigt
(n = 1, a = 0, c its damping) and a spring-damper with a rest offset (f_0 = k times the
offset: MuJoCo's contacts as :mod:`roverimpact.simulate.newtons` models them) exactly. Each
row's law is ``(k, n, a, c, f_0)``.

:func:`rk4_peaks`: classical fixed-step Runge-Kutta of order 4 with a step from the
stiffest row's time scale (the caller's ``dt``). :func:`stiff_peaks`, for items where the
Hunt-Crossley damping at a small approach speed would make that step tiny: the L-stable
Rosenbrock pair of MATLAB's ode23s with step control. Two kernels, each compiled on first
use (the second takes about 3 s to compile; the studies never use it).

The peak of the impact row is located by a parabola through the largest sampled force and
its neighbours, separation (the impact row's gap reopening) by linear interpolation.
tests/test_newtons.py checks both integrators against closed forms (1-DoF laws, preloaded
springs, the matrix exponential of two linear rows) and LSODA on random systems,
tests/test_traverse_refine.py against :func:`roverimpact.contact.reduced.reduced_impact`'s
LSODA (rtol 1e-8) on rover impacts.

Only numpy and numba here.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._jit import NJIT_OPTIONS, Kernel, f8, i8, ro, rw, types


@njit(**NJIT_OPTIONS)
def _forces(d, dd, k, n, a, c, f0, out):
    """Each row's force; a row at zero penetration and closing is in contact (the limit
    from inside: c dd for a damper, so that the first step of an impact sees it)."""
    for i in range(d.shape[0]):
        if d[i] > 0.0 or (d[i] == 0.0 and dd[i] > 0.0):
            if n[i] == 1.5:
                p = d[i] * np.sqrt(d[i])
            elif n[i] == 1.0:
                p = d[i]
            else:
                p = d[i] ** n[i]
            f = k[i] * p * (1.0 + a[i] * dd[i]) + c[i] * dd[i] - f0[i]
            out[i] = f if f > 0.0 else 0.0
        else:
            out[i] = 0.0


@njit(**NJIT_OPTIONS)
def _deriv(G, b, k, n, a, c, f0, d, dd, f, acc):
    _forces(d, dd, k, n, a, c, f0, f)
    m = d.shape[0]
    for i in range(m):
        s = b[i]
        for j in range(m):
            s += G[i, j] * f[j]
        acc[i] = -s


@njit(**NJIT_OPTIONS)
def _reduced_peak(G, b, k, n, a, c, f0, delta0, rate0, o, t_max, dt, out):
    """One item: out = (peak, t_peak, duration, ended)."""
    m = b.shape[0]
    d = delta0.copy()
    dd = rate0.copy()
    f = np.zeros(m)
    k1d, k1v = np.empty(m), np.empty(m)
    k2d, k2v = np.empty(m), np.empty(m)
    k3d, k3v = np.empty(m), np.empty(m)
    k4d, k4v = np.empty(m), np.empty(m)
    tmpd, tmpv = np.empty(m), np.empty(m)
    n_steps = int(np.ceil(t_max / dt))
    h = t_max / n_steps
    f_prev2 = 0.0
    f_prev = 0.0
    best = 0.0
    t_best = 0.0
    ended = False
    duration = t_max
    t = 0.0
    for step in range(n_steps):
        # RK4
        for i in range(m):
            k1d[i] = dd[i]
        _deriv(G, b, k, n, a, c, f0, d, dd, f, k1v)
        for i in range(m):
            tmpd[i] = d[i] + 0.5 * h * k1d[i]
            tmpv[i] = dd[i] + 0.5 * h * k1v[i]
            k2d[i] = tmpv[i]
        _deriv(G, b, k, n, a, c, f0, tmpd, tmpv, f, k2v)
        for i in range(m):
            tmpd[i] = d[i] + 0.5 * h * k2d[i]
            tmpv[i] = dd[i] + 0.5 * h * k2v[i]
            k3d[i] = tmpv[i]
        _deriv(G, b, k, n, a, c, f0, tmpd, tmpv, f, k3v)
        for i in range(m):
            tmpd[i] = d[i] + h * k3d[i]
            tmpv[i] = dd[i] + h * k3v[i]
            k4d[i] = tmpv[i]
        _deriv(G, b, k, n, a, c, f0, tmpd, tmpv, f, k4v)
        d_old = d[o]
        for i in range(m):
            d[i] += h / 6.0 * (k1d[i] + 2.0 * k2d[i] + 2.0 * k3d[i] + k4d[i])
            dd[i] += h / 6.0 * (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + k4v[i])
        t = (step + 1) * h
        _forces(d, dd, k, n, a, c, f0, f)
        fo = f[o]
        if fo > best:
            best = fo
            t_best = t
        elif step >= 1 and f_prev == best and f_prev > 0.0:
            # parabola through (t - 2h, f_prev2), (t - h, f_prev), (t, fo)
            den = f_prev2 - 2.0 * f_prev + fo
            if den < 0.0:
                x = 0.5 * (f_prev2 - fo) / den
                if -1.0 < x < 1.0:
                    pk = f_prev - 0.25 * (f_prev2 - fo) * x
                    if pk > best:
                        best = pk
                        t_best = t - h + x * h
        f_prev2 = f_prev
        f_prev = fo
        if d_old > 0.0 and d[o] <= 0.0:
            ended = True
            duration = t - h + h * d_old / (d_old - d[o])
            break
    out[0] = best
    out[1] = t_best
    out[2] = duration
    out[3] = 1.0 if ended else 0.0


@njit(**NJIT_OPTIONS)
def _rhs(G, b, k, n, a, c, f0, y, m, f, out):
    """out = (dd, -(b + G f(d, dd))) for y = (d, dd)."""
    _forces(y[:m], y[m:], k, n, a, c, f0, f)
    for i in range(m):
        out[i] = y[m + i]
        s = b[i]
        for j in range(m):
            s += G[i, j] * f[j]
        out[m + i] = -s


@njit(**NJIT_OPTIONS)
def _lu(W, piv):
    """In-place LU with partial pivoting of the square W."""
    N = W.shape[0]
    for j in range(N):
        p = j
        big = abs(W[j, j])
        for i in range(j + 1, N):
            if abs(W[i, j]) > big:
                big = abs(W[i, j])
                p = i
        piv[j] = p
        if p != j:
            for q in range(N):
                t = W[j, q]
                W[j, q] = W[p, q]
                W[p, q] = t
        d = W[j, j]
        if d == 0.0:
            continue
        for i in range(j + 1, N):
            W[i, j] /= d
            f = W[i, j]
            if f != 0.0:
                for q in range(j + 1, N):
                    W[i, q] -= f * W[j, q]


@njit(**NJIT_OPTIONS)
def _solve(W, piv, x):
    """x <- W^-1 x with the factors of :func:`_lu`."""
    N = W.shape[0]
    for j in range(N):
        p = piv[j]
        if p != j:
            t = x[j]
            x[j] = x[p]
            x[p] = t
    for i in range(N):
        s = x[i]
        for q in range(i):
            s -= W[i, q] * x[q]
        x[i] = s
    for i in range(N - 1, -1, -1):
        s = x[i]
        for q in range(i + 1, N):
            s -= W[i, q] * x[q]
        x[i] = s / W[i, i] if W[i, i] != 0.0 else 0.0


@njit(**NJIT_OPTIONS)
def _reduced_peak_stiff(G, b, k, n, a, c, f0, delta0, rate0, o, t_max, h0, d_scale, tol,
                        out):
    """One item by the L-stable Rosenbrock pair of Shampine and Reichelt (MATLAB's ode23s,
    order 2 with an order-3 error estimate; the step keeps the estimate under ``tol`` times
    ``d_scale`` [m] on the gaps and ``tol`` times the largest initial rate on the rates),
    from the step ``h0``: for rows whose damping makes the explicit step tiny
    (Hunt-Crossley at a small approach speed). out as :func:`_reduced_peak`."""
    m = b.shape[0]
    N = 2 * m
    dcoef = 1.0 / (2.0 + np.sqrt(2.0))
    e32 = 6.0 + np.sqrt(2.0)
    y = np.empty(N)
    y[:m] = delta0
    y[m:] = rate0
    scale = np.empty(N)
    vmax = 0.0
    for i in range(m):
        vmax = max(vmax, abs(rate0[i]))
    for i in range(m):
        scale[i] = max(d_scale, 1e-15)
        scale[m + i] = max(vmax, 1e-15)
    f = np.zeros(m)
    F0, F1, F2 = np.empty(N), np.empty(N), np.empty(N)
    k1, k2, k3 = np.empty(N), np.empty(N), np.empty(N)
    yt = np.empty(N)
    ynew = np.empty(N)
    W = np.empty((N, N))
    piv = np.zeros(N, np.int64)
    _rhs(G, b, k, n, a, c, f0, y, m, f, F0)
    t = 0.0
    h = h0
    h_max = t_max / 50.0
    best = 0.0
    t_best = 0.0
    # the last three accepted (t, f_o)
    ta, tb, fa, fb = -1.0, -1.0, 0.0, 0.0
    ended = False
    duration = t_max
    while t < t_max:
        if t + h > t_max:
            h = t_max - t
        # W = I - h d J, J = [[0, I], [-G D1, -G D2]]
        for i in range(N):
            for j in range(N):
                W[i, j] = 0.0
            W[i, i] = 1.0
        for i in range(m):
            W[i, m + i] = -h * dcoef
        for j in range(m):
            dj = y[j]
            if f[j] > 0.0:                  # in contact (d > 0, or d = 0 closing)
                kj, nj, aj = k[j], n[j], a[j]
                if dj > 0.0:
                    p = dj ** nj
                    D1 = kj * nj * dj ** (nj - 1.0) * (1.0 + aj * y[m + j])
                else:
                    p = 0.0
                    D1 = kj * (1.0 + aj * y[m + j]) if nj == 1.0 else 0.0
                D2 = kj * p * aj + c[j]
            else:
                D1 = 0.0
                D2 = 0.0
            for i in range(m):
                W[m + i, j] = h * dcoef * G[i, j] * D1
                W[m + i, m + j] += h * dcoef * G[i, j] * D2
        _lu(W, piv)
        for i in range(N):
            k1[i] = F0[i]
        _solve(W, piv, k1)
        for i in range(N):
            yt[i] = y[i] + 0.5 * h * k1[i]
        _rhs(G, b, k, n, a, c, f0, yt, m, f, F1)
        for i in range(N):
            k2[i] = F1[i] - k1[i]
        _solve(W, piv, k2)
        for i in range(N):
            k2[i] += k1[i]
            ynew[i] = y[i] + h * k2[i]
        _rhs(G, b, k, n, a, c, f0, ynew, m, f, F2)
        for i in range(N):
            k3[i] = F2[i] - e32 * (k2[i] - F1[i]) - 2.0 * (k1[i] - F0[i])
        _solve(W, piv, k3)
        err = 0.0
        for i in range(N):
            e = h / 6.0 * abs(k1[i] - 2.0 * k2[i] + k3[i]) / scale[i]
            if e > err:
                err = e
        err /= tol
        if err > 1.0 and h > 1e-14 * t_max:
            h *= max(0.2, 0.8 * err ** (-1.0 / 3.0))
            _rhs(G, b, k, n, a, c, f0, y, m, f, F0)
            continue
        d_old = y[o]
        t += h
        for i in range(N):
            y[i] = ynew[i]
            F0[i] = F2[i]
        _forces(y[:m], y[m:], k, n, a, c, f0, f)
        fo = f[o]
        if fo > best:
            best = fo
            t_best = t
        elif fb == best and fb > 0.0 and ta >= 0.0:
            # parabola through (ta, fa), (tb, fb), (t, fo)
            d1 = (fb - fa) / (tb - ta)
            d2 = (fo - fb) / (t - tb)
            a2 = (d2 - d1) / (t - ta)
            if a2 < 0.0:
                a1 = d1 - a2 * (ta + tb)
                ts = -a1 / (2.0 * a2)
                if ta < ts < t:
                    pk = fa + d1 * (ts - ta) + a2 * (ts - ta) * (ts - tb)
                    if pk > best:
                        best = pk
                        t_best = ts
        ta, fa = tb, fb
        tb, fb = t, fo
        if d_old > 0.0 and y[o] <= 0.0:
            ended = True
            duration = t - h + h * d_old / (d_old - y[o])
            break
        h = min(h * min(5.0, 0.8 * max(err, 1e-12) ** (-1.0 / 3.0)), h_max)
    out[0] = best
    out[1] = t_best
    out[2] = duration
    out[3] = 1.0 if ended else 0.0


def _rk4_peaks(G, b, k, n, a, c, f0, delta0, rate0, o, t_max, dt, out):
    """Every item of the batch (leading axis B): out[i] = (peak, t_peak, duration,
    ended) of the impact row ``o`` by fixed-step Runge-Kutta of step ``dt[i]``; the rows'
    laws ``(k, n, a, c, f0)`` as arrays (B, m) each (read-only: the compiler then knows
    they do not alias the state, which halves the time)."""
    for i in range(G.shape[0]):
        _reduced_peak(G[i], b[i], k[i], n[i], a[i], c[i], f0[i], delta0[i], rate0[i], o,
                      t_max, dt[i], out[i])


def _stiff_peaks(G, b, k, n, a, c, f0, delta0, rate0, o, t_max, dt, d_scale, tol, out):
    """As :func:`_rk4_peaks` by the Rosenbrock pair from the step ``dt[i]`` (gap scale
    ``d_scale[i]`` [m], tolerance ``tol``)."""
    for i in range(G.shape[0]):
        _reduced_peak_stiff(G[i], b[i], k[i], n[i], a[i], c[i], f0[i], delta0[i], rate0[i],
                            o, t_max, dt[i], d_scale[i], tol, out[i])


_LAW = (ro(f8, 2),) * 5
#: Items of the integrators' Python code while numba's cache lacks them
#: (:meth:`~._jit.Kernel.get`): none. An item runs hundreds to thousands of steps (tens of
#: milliseconds or more in Python, where one item can outlast the rest of the compile).
PYTHON_BUDGET = 0
rk4_peaks = Kernel(
    _rk4_peaks,
    types.void(ro(f8, 3), ro(f8, 2), *_LAW, ro(f8, 2), ro(f8, 2), i8, f8, ro(f8, 1),
               rw(f8, 2)),
    home=f"{__name__}:rk4_peaks", python_budget=PYTHON_BUDGET,
)
stiff_peaks = Kernel(
    _stiff_peaks,
    types.void(ro(f8, 3), ro(f8, 2), *_LAW, ro(f8, 2), ro(f8, 2), i8, f8, ro(f8, 1),
               ro(f8, 1), f8, rw(f8, 2)),
    home=f"{__name__}:stiff_peaks", python_budget=PYTHON_BUDGET,
)

__all__ = ["rk4_peaks", "stiff_peaks"]
