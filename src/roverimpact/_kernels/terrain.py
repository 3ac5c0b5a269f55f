r"""Compiled wheel-ground contact on a height field (the simulator's hot path).

:func:`hf_wheel_contact` is :func:`roverimpact.models.terrain.wheel_ground_contact` for a
:class:`~roverimpact.models.terrain.HeightField`, one wheel at a time in a compiled loop:
the same bicubic Catmull-Rom evaluation on the padded grid (``HeightField._zp``), the same
scan of ``n_scan + 1`` rim angles over the lower half rim, the two lowest local minima of
the scan refined by the same safeguarded Newton on :math:`g'(\phi) = 0` (bisection inside
the scan bracket when a step leaves it or :math:`g'' \le 0`), keeping the rim angle of the
lowest clearance evaluated. The numpy version does the same arithmetic on arrays (a few
summation orders differ: results agree to rounding, ``tests/test_simulate_terrain.py``);
this one avoids its per-call overhead (a dozen array evaluations of a 4 x 4 stencil for a
handful of wheels), which dominates the simulator's right-hand side on a height field.

Only numpy and numba here. A query outside the grid is not an error in the kernel: the
wheel's ``ok`` flag is False and the caller asks the numpy version for its message.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._jit import NJIT_OPTIONS

_EPS_OUT = 1e-9   # the grid's tolerance at its border, in cells (as HeightField._eval)


@njit(**NJIT_OPTIONS)
def _cr(t, w, dw, ddw):
    """Catmull-Rom weights of the samples j-1 .. j+2 (and derivatives) at fraction t."""
    t2 = t * t
    t3 = t2 * t
    w[0] = 0.5 * (-t3 + 2 * t2 - t)
    w[1] = 0.5 * (3 * t3 - 5 * t2 + 2)
    w[2] = 0.5 * (-3 * t3 + 4 * t2 + t)
    w[3] = 0.5 * (t3 - t2)
    dw[0] = 0.5 * (-3 * t2 + 4 * t - 1)
    dw[1] = 0.5 * (9 * t2 - 10 * t)
    dw[2] = 0.5 * (-9 * t2 + 8 * t + 1)
    dw[3] = 0.5 * (3 * t2 - 2 * t)
    ddw[0] = 0.5 * (-6 * t + 4)
    ddw[1] = 0.5 * (18 * t - 10)
    ddw[2] = 0.5 * (-18 * t + 8)
    ddw[3] = 0.5 * (6 * t - 2)


@njit(**NJIT_OPTIONS)
def _eval(zp, stride, nx, ny, x0, y0, dx, dy, x, y, out):
    """Height and derivatives at (x, y) into ``out`` = (h, hx, hy, hxx, hxy, hyy);
    False if the point is outside the grid."""
    u = (x - x0) / dx
    v = (y - y0) / dy
    if not (u >= -_EPS_OUT and u <= nx - 1 + _EPS_OUT and v >= -_EPS_OUT
            and v <= ny - 1 + _EPS_OUT):
        return False
    j = min(max(math.floor(u), 0), nx - 2)
    i = min(max(math.floor(v), 0), ny - 2)
    wx = np.empty(4)
    dwx = np.empty(4)
    ddwx = np.empty(4)
    wy = np.empty(4)
    dwy = np.empty(4)
    ddwy = np.empty(4)
    _cr(u - j, wx, dwx, ddwx)
    _cr(v - i, wy, dwy, ddwy)
    h = hx = hy = hxx = hxy = hyy = 0.0
    for a in range(4):
        base = (i + a) * stride + j
        px = pdx = pddx = 0.0
        for b in range(4):
            z = zp[base + b]
            px += z * wx[b]
            pdx += z * dwx[b]
            pddx += z * ddwx[b]
        h += px * wy[a]
        hx += pdx * wy[a]
        hy += px * dwy[a]
        hxx += pddx * wy[a]
        hxy += pdx * dwy[a]
        hyy += px * ddwy[a]
    out[0] = h
    out[1] = hx / dx
    out[2] = hy / dy
    out[3] = hxx / (dx * dx)
    out[4] = hxy / (dx * dy)
    out[5] = hyy / (dy * dy)
    return True


@njit(**NJIT_OPTIONS)
def _refine(zp, stride, nx, ny, x0, y0, dx, dy, c0, c1, c2, e0, e1, e2, f0, f1, f2, rr,
            phis, k, g_start, n_scan, max_iter, out):
    """Safeguarded Newton on g'(phi) from scan index ``k`` in its neighbours' bracket:
    ``(phi_best, g_best, ok)``."""
    lo = phis[max(k - 1, 0)]
    hi = phis[min(k + 1, n_scan)]
    ph = phis[k]
    g_best, phi_best = g_start, ph
    for _ in range(max_iter):
        cp, sp = math.cos(ph), math.sin(ph)
        px = c0 + rr * (-cp * e0 + sp * f0)
        py = c1 + rr * (-cp * e1 + sp * f1)
        pz = c2 + rr * (-cp * e2 + sp * f2)
        d0 = rr * (sp * e0 + cp * f0)
        d1 = rr * (sp * e1 + cp * f1)
        d2 = rr * (sp * e2 + cp * f2)
        if not _eval(zp, stride, nx, ny, x0, y0, dx, dy, px, py, out):
            return phi_best, g_best, False
        hv, hx, hy, hxx, hxy, hyy = out[0], out[1], out[2], out[3], out[4], out[5]
        gv = pz - hv
        if gv < g_best:
            g_best, phi_best = gv, ph
        dd0, dd1, dd2 = c0 - px, c1 - py, c2 - pz
        g1 = d2 - hx * d0 - hy * d1
        g2 = (dd2 - hx * dd0 - hy * dd1
              - (hxx * d0 * d0 + 2 * hxy * d0 * d1 + hyy * d1 * d1))
        if g1 > 0:
            hi = ph
        else:
            lo = ph
        new = ph - g1 / g2 if g2 != 0.0 else np.nan
        if not (g2 > 0) or not (new > lo) or not (new < hi):
            new = 0.5 * (lo + hi)
        done = abs(new - ph) < 1e-13
        ph = new
        if done:
            break
    return phi_best, g_best, True


@njit(**NJIT_OPTIONS)
def hf_wheel_contact(zp, stride, nx, ny, x0, y0, dx, dy, C, A, r, n_scan, max_iter,
                     point, normal, gap, phi_out, ok):
    """Rim point of lowest clearance of each disc wheel above a height field.

    Parameters
    ----------
    zp : (ny + 2) * (nx + 2) float array
        The padded grid, row-major (``HeightField._zp``); ``stride = nx + 2``.
    nx, ny, x0, y0, dx, dy
        Grid size, origin and spacing [m].
    C, A : (n, 3) float arrays
        Wheel centres [m] and unit spin axes (not vertical).
    r : (n,) float array
        Radii [m].
    n_scan, max_iter : int
    point, normal : (n, 3) float arrays (out)
    gap, phi_out : (n,) float arrays (out)
    ok : (n,) bool array (out)
        False where a query left the grid (outputs of that wheel undefined).
    """
    n = C.shape[0]
    out = np.empty(6)
    phis = np.empty(n_scan + 1)
    step = math.pi / n_scan
    for k in range(n_scan + 1):            # as np.linspace(-pi/2, pi/2, n_scan + 1)
        phis[k] = k * step + (-0.5 * math.pi)
    phis[n_scan] = 0.5 * math.pi
    for w in range(n):
        ok[w] = True
        c0, c1, c2 = C[w, 0], C[w, 1], C[w, 2]
        a0, a1, a2 = A[w, 0], A[w, 1], A[w, 2]
        rr = r[w]
        ne = math.sqrt(max(1.0 - a2 * a2, 0.0))
        e0, e1, e2 = -a2 * a0 / ne, -a2 * a1 / ne, (1.0 - a2 * a2) / ne
        f0 = a1 * e2 - a2 * e1
        f1 = a2 * e0 - a0 * e2
        f2 = a0 * e1 - a1 * e0
        gs = np.empty(n_scan + 1)
        for k in range(n_scan + 1):
            cp, sp = math.cos(phis[k]), math.sin(phis[k])
            px = c0 + rr * (-cp * e0 + sp * f0)
            py = c1 + rr * (-cp * e1 + sp * f1)
            pz = c2 + rr * (-cp * e2 + sp * f2)
            if not _eval(zp, stride, nx, ny, x0, y0, dx, dy, px, py, out):
                ok[w] = False
                break
            gs[k] = pz - out[0]
        if not ok[w]:
            continue
        # the two lowest local minima of the scan, refined; the lower result kept
        # not literals: a literal -1 passed on as k2 compiled _refine a second time
        k1, k2, g1v, g2v = np.int64(-1), np.int64(-1), np.inf, np.inf
        for k in range(n_scan + 1):
            left = gs[k - 1] if k > 0 else np.inf
            right = gs[k + 1] if k < n_scan else np.inf
            if gs[k] <= left and gs[k] <= right:
                if gs[k] < g1v:
                    k2, g2v = k1, g1v
                    k1, g1v = k, gs[k]
                elif gs[k] < g2v:
                    k2, g2v = k, gs[k]
        if k1 < 0:                        # no finite local minimum: the lowest sample
            k1 = int(np.argmin(gs))
            g1v = gs[k1]
        phi_best, g_best, okw = _refine(zp, stride, nx, ny, x0, y0, dx, dy, c0, c1, c2,
                                        e0, e1, e2, f0, f1, f2, rr, phis, k1, g1v, n_scan,
                                        max_iter, out)
        if okw and k2 >= 0 and np.isfinite(g2v):
            ph2, gb2, okw = _refine(zp, stride, nx, ny, x0, y0, dx, dy, c0, c1, c2,
                                    e0, e1, e2, f0, f1, f2, rr, phis, k2, g2v, n_scan,
                                    max_iter, out)
            if gb2 < g_best:
                phi_best, g_best = ph2, gb2
        ok[w] = okw
        if not ok[w]:
            continue
        cp, sp = math.cos(phi_best), math.sin(phi_best)
        px = c0 + rr * (-cp * e0 + sp * f0)
        py = c1 + rr * (-cp * e1 + sp * f1)
        pz = c2 + rr * (-cp * e2 + sp * f2)
        if not _eval(zp, stride, nx, ny, x0, y0, dx, dy, px, py, out):
            ok[w] = False
            continue
        hx, hy = out[1], out[2]
        s = math.sqrt(1.0 + hx * hx + hy * hy)
        normal[w, 0], normal[w, 1], normal[w, 2] = -hx / s, -hy / s, 1.0 / s
        point[w, 0], point[w, 1], point[w, 2] = px, py, pz
        gap[w] = (pz - out[0]) / s
        phi_out[w] = phi_best
