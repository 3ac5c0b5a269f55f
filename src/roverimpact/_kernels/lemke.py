"""Compiled (numba) kernel of the unilateral impact problem (see :mod:`roverimpact.unilateral`).

Per configuration, with no Python in the loop:

1. Cholesky factor ``M = L L^T`` (with the same checks as the partition kernel),
   ``u = L^T v``;
2. whitened rows ``W_N = L^{-1} N^T`` (unilateral) and ``W_B = L^{-1} B^T`` (bilateral);
3. an orthonormal basis ``Q`` of ``range(W_B)`` by classical Gram-Schmidt with
   re-orthogonalisation (CGS2) of the normalised columns, dependent columns dropped;
4. the bilateral rows are eliminated exactly: ``W~ = (I - Q Q^T) W_N``,
   ``u0 = (I - Q Q^T) u``; the Delassus matrix of the unilateral rows is
   ``G = W~^T W~`` (PSD, singular for redundant contacts);
5. the LCP ``w = G p + b >= 0, p >= 0, p.w = 0`` is solved by Lemke's algorithm with the
   lexicographic anti-cycling rule on the column-scaled problem, then polished by one
   exact solve of ``G_SS p_S = -b_S`` on the complementary basis ``S``;
6. ``u+ = u0 + W~ p``, ``v+ = L^{-T} u+``, and ``T_c^-`` with the active unilateral rows
   plus the bilateral rows from the same Gram-Schmidt basis.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._validation import STATUS_OK
from ._jit import NJIT_OPTIONS, b1, boolean, f8, i8, kernel, ro, rw
from .partition import factor  # the same checked Cholesky as the partition kernel

#: kernel status codes beyond the mass-matrix codes of ``_validation`` (1..5)
STATUS_INFEASIBLE = 10  # Lemke ended on a secondary ray: no impulse can stop penetration
STATUS_MAXITER = 11  # Lemke did not terminate (cycling despite the lexicographic rule)
STATUS_LOCKED = 12  # a unilateral row lies in the span of the bilateral rows and must close

_PIV = 1e-12  # smallest tableau entry accepted as a pivot (problem scaled to O(1))



@njit(**NJIT_OPTIONS)
def _lexless(T, i, si, j, sj, k, rhs, tol):  # pragma: no cover - compiled
    """Is row ``i`` (times ``si``) lexicographically smaller than row ``j`` (times ``sj``)?

    Compared on ``(rhs, B^{-1})``: the right-hand side first, then the columns of the
    initial identity (they hold the inverse of the current basis).
    """
    x = T[i, rhs] * si
    y = T[j, rhs] * sj
    if x < y - tol:
        return True
    if x > y + tol:
        return False
    for c in range(k):
        x = T[i, c] * si
        y = T[j, c] * sj
        if x < y - tol:
            return True
        if x > y + tol:
            return False
    return False


@njit(**NJIT_OPTIONS)
def _pivot(T, r, c):  # pragma: no cover - compiled
    ncol = T.shape[1]
    k = T.shape[0]
    a = T[r, c]
    for j in range(ncol):
        T[r, j] /= a
    for i in range(k):
        if i != r:
            f = T[i, c]
            if f != 0.0:
                for j in range(ncol):
                    T[i, j] -= f * T[r, j]
            T[i, c] = 0.0
    T[r, c] = 1.0


@njit(**NJIT_OPTIONS)
def lcp_residual(G, q, z, k):  # pragma: no cover - compiled
    res = 0.0
    for i in range(k):
        w = q[i]
        for j in range(k):
            w += G[i, j] * z[j]
        res = max(res, -z[i], -w, abs(z[i] * w))
    return res


@njit(**NJIT_OPTIONS)
def _impulse_scaled_residual(G, q, z, k):  # pragma: no cover - compiled
    """:func:`lcp_residual` of ``q`` scaled to O(1), with ``w`` relative to
    ``s = max(1, max|z|)`` and ``z_i w_i`` to ``s^2`` (round-off of ``w`` grows with ``z``)."""
    s = 1.0
    for i in range(k):
        s = max(s, abs(z[i]))
    res = 0.0
    for i in range(k):
        w = q[i]
        for j in range(k):
            w += G[i, j] * z[j]
        res = max(res, -z[i], -w / s, abs(z[i] * w) / (s * s))
    return res


@njit(**NJIT_OPTIONS)
def relative_residual(G, q, z, k, usc):  # pragma: no cover - compiled
    """Residual of ``w = G z + q`` relative to the velocity scale ``usc`` (``sqrt(2T^-)``).

    Signs ``-z``, ``-w`` relative to ``usc``; the complementarity product ``|z_i w_i|``
    relative to ``usc * max(usc, max|z|)``: round-off of ``w`` grows with the impulses, so
    a large (valid) impulse, e.g. of nearly dependent rows, is not read as a failure.
    """
    zmax = usc
    for i in range(k):
        zmax = max(zmax, abs(z[i]))
    res = 0.0
    for i in range(k):
        w = q[i]
        for j in range(k):
            w += G[i, j] * z[j]
        res = max(res, -z[i] / usc, -w / usc, abs(z[i] * w) / zmax / usc)
    return res


@njit(**NJIT_OPTIONS)
def lemke(G, q, z, T, basis, S, A, rhs_s, zp, maxit):  # pragma: no cover - compiled
    """Solve ``w = G z + q >= 0, z >= 0, z.w = 0`` for a PSD ``G`` (k x k, k >= 1).

    ``q`` must be scaled to ``max|q| = 1`` and ``G`` to a unit diagonal (or zero rows) by
    the caller. Work arrays: ``T (k, 2k+2)``, ``basis (k,) int``, ``S (k,) int``,
    ``A (k, k)``, ``rhs_s (k,)``, ``zp (k,)``. Returns a status code.
    """
    k = q.shape[0]
    for i in range(k):
        z[i] = 0.0
    neg = False
    for i in range(k):
        if q[i] < 0.0:
            neg = True
    if not neg:
        return STATUS_OK
    z0 = 2 * k
    rhs = 2 * k + 1
    for i in range(k):
        for j in range(2 * k + 2):
            T[i, j] = 0.0
        T[i, i] = 1.0
        for j in range(k):
            T[i, k + j] = -G[i, j]
        T[i, z0] = -1.0
        T[i, rhs] = q[i]
        basis[i] = i
    tol = 1e-13
    # first pivot: the artificial variable enters, the lexicographically smallest row leaves
    r = np.int64(0)  # not a literal: one compile of _lexless/_pivot, not two
    for i in range(1, k):
        if _lexless(T, i, 1.0, r, 1.0, k, rhs, tol):
            r = i
    enter = z0
    done = False
    for _ in range(maxit):
        leave = basis[r]
        _pivot(T, r, enter)
        basis[r] = enter
        if leave == z0:
            done = True
            break
        enter = leave + k if leave < k else leave - k
        r = np.int64(-1)
        for i in range(k):
            a = T[i, enter]
            if a > _PIV:
                if r < 0 or _lexless(T, i, 1.0 / a, r, 1.0 / T[r, enter], k, rhs, tol):
                    r = i
        if r < 0:
            return 10  # secondary ray: infeasible (G is PSD, hence copositive-plus)
    if not done:
        return 11
    ns = np.int64(0)
    for i in range(k):
        b = basis[i]
        if k <= b < 2 * k:
            z[b - k] = max(T[i, rhs], 0.0)
            S[ns] = b - k
            ns += 1
    # polish: exact solve of G_SS z_S = -q_S (Gaussian elimination, partial pivoting)
    if ns == 0:
        return STATUS_OK
    for a in range(ns):
        for c in range(ns):
            A[a, c] = G[S[a], S[c]]
        rhs_s[a] = -q[S[a]]
    ok = True
    for c in range(ns):
        p = c
        for a in range(c + 1, ns):
            if abs(A[a, c]) > abs(A[p, c]):
                p = a
        if abs(A[p, c]) < 1e-14:
            ok = False
            break
        if p != c:
            for j in range(ns):
                t = A[c, j]
                A[c, j] = A[p, j]
                A[p, j] = t
            t = rhs_s[c]
            rhs_s[c] = rhs_s[p]
            rhs_s[p] = t
        for a in range(c + 1, ns):
            f = A[a, c] / A[c, c]
            for j in range(c, ns):
                A[a, j] -= f * A[c, j]
            rhs_s[a] -= f * rhs_s[c]
    if ok:
        for i in range(k):
            zp[i] = 0.0
        for c in range(ns - 1, -1, -1):
            s = rhs_s[c]
            for j in range(c + 1, ns):
                s -= A[c, j] * zp[S[j]]
            zp[S[c]] = max(s / A[c, c], 0.0)
        if lcp_residual(G, q, zp, k) <= lcp_residual(G, q, z, k):
            for i in range(k):
                z[i] = zp[i]
    return STATUS_OK


@njit(**NJIT_OPTIONS)
def _solve_sub(G, q, S, ns, A, rs, out):  # pragma: no cover - compiled
    """Solve ``G_SS x = -q_S`` (partial pivoting); False if singular."""
    for a in range(ns):
        for c in range(ns):
            A[a, c] = G[S[a], S[c]]
        rs[a] = -q[S[a]]
    for c in range(ns):
        p = c
        for a in range(c + 1, ns):
            if abs(A[a, c]) > abs(A[p, c]):
                p = a
        if abs(A[p, c]) < 1e-13:
            return False
        if p != c:
            for j in range(ns):
                t = A[c, j]
                A[c, j] = A[p, j]
                A[p, j] = t
            t = rs[c]
            rs[c] = rs[p]
            rs[p] = t
        for a in range(c + 1, ns):
            f = A[a, c] / A[c, c]
            for j in range(c, ns):
                A[a, j] -= f * A[c, j]
            rs[a] -= f * rs[c]
    for c in range(ns - 1, -1, -1):
        t = rs[c]
        for j in range(c + 1, ns):
            t -= A[c, j] * out[j]
        out[c] = t / A[c, c]
    return True


@njit(**NJIT_OPTIONS)
def nnls_lcp(G, q, z, S, A, rs, sol, maxit):  # pragma: no cover - compiled
    """Lawson-Hanson active-set method for ``min 1/2 z^T G z + q^T z, z >= 0`` (PSD ``G``).

    The convex QP whose optimality conditions are the LCP ``w = G z + q >= 0 ⊥ z >= 0``;
    used when Lemke's pivoting stalls on a degenerate (jammed, rank-deficient) problem.
    ``q`` scaled to O(1), ``G`` to a unit diagonal. Returns a status code.
    """
    k = q.shape[0]
    inP = np.zeros(k, dtype=np.bool_)
    bad = np.zeros(k, dtype=np.bool_)
    for i in range(k):
        z[i] = 0.0
    for _ in range(maxit):
        best = 1e-12
        j = -1
        for i in range(k):
            if not inP[i] and not bad[i]:
                g = q[i]
                for c in range(k):
                    g += G[i, c] * z[c]
                if -g > best:
                    best = -g
                    j = i
        if j < 0:
            return STATUS_OK
        inP[j] = True
        for _inner in range(maxit):
            ns = np.int64(0)  # (a literal 0 would compile _solve_sub twice)
            for i in range(k):
                if inP[i]:
                    S[ns] = i
                    ns += 1
            if not _solve_sub(G, q, S, ns, A, rs, sol):
                inP[j] = False
                bad[j] = True  # dependent on the passive columns
                break
            allpos = True
            for a in range(ns):
                if sol[a] <= 0.0:
                    allpos = False
            if allpos:
                for a in range(ns):
                    z[S[a]] = sol[a]
                break
            alpha = 1.0
            for a in range(ns):
                if sol[a] <= 0.0:
                    zi = z[S[a]]
                    t = zi / (zi - sol[a])
                    if t < alpha:
                        alpha = t
            for a in range(ns):
                i = S[a]
                z[i] += alpha * (sol[a] - z[i])
                if z[i] <= 1e-15:
                    z[i] = 0.0
                    inP[i] = False
        for i in range(k):
            bad[i] = bad[i] and not inP[i]
    return 11


@njit(**NJIT_OPTIONS)
def _orth_append(Q, r, x, rtol):  # pragma: no cover - compiled
    """CGS2: orthogonalise unit vector ``x`` against ``Q[:, :r]``; append it if independent."""
    n = x.shape[0]
    for _ in range(2):
        for j in range(r):
            s = 0.0
            for i in range(n):
                s += Q[i, j] * x[i]
            for i in range(n):
                x[i] -= s * Q[i, j]
    nrm = 0.0
    for i in range(n):
        nrm += x[i] * x[i]
    nrm = np.sqrt(nrm)
    if nrm <= rtol or r >= n:
        return r
    for i in range(n):
        Q[i, r] = x[i] / nrm
    return r + 1


@njit(**NJIT_OPTIONS)
def scaled_lcp(G, qs, z, T, basis, S, A, rs, zp, maxit, thr):  # pragma: no cover - compiled
    """Lemke on ``q`` scaled to unit max norm; ``z`` returned in the units of ``qs``.

    Entries of ``qs`` in ``(-thr, 0)`` are round-off of zero (contacts at rest) and are set
    to 0, so that a problem needing no impulse is not scaled up from noise.
    """
    k = qs.shape[0]
    qmax = 0.0
    qmin = 0.0
    for i in range(k):
        if -thr < qs[i] < 0.0:
            qs[i] = 0.0
        qmax = max(qmax, abs(qs[i]))
        qmin = min(qmin, qs[i])
    if qmin == 0.0:
        for i in range(k):
            z[i] = 0.0
        return STATUS_OK
    qn = qs / qmax
    st = lemke(G, qn, z, T, basis, S, A, rs, zp, maxit)
    if st != STATUS_OK or lcp_residual(G, qn, z, k) > 1e-11:
        # degenerate problem: the convex QP by an active-set method; keep it if it solves
        # (to round-off of w = G z + q, which grows with the impulses: nearly opposite
        # contacts need impulses 1000 times the approach, tests/test_activeset.py)
        st2 = nnls_lcp(G, qn, zp, S, A, rs, T[:, 0], maxit)
        if st2 == STATUS_OK and _impulse_scaled_residual(G, qn, zp, k) <= 1e-11:
            for i in range(k):
                z[i] = zp[i]
            st = STATUS_OK
    for i in range(k):
        z[i] *= qmax
    return st


def _impact_signature():
    """Inputs read-only C arrays (M, N, B, v, E, then the five flat indices), flags and
    tolerances, then the writable outputs."""
    return (ro(f8, 3), ro(f8, 3), ro(f8, 3), ro(f8, 2), ro(f8, 2),
            ro(i8, 1), ro(i8, 1), ro(i8, 1), ro(i8, 1), ro(i8, 1),
            boolean, f8, f8, boolean,
            rw(f8, 2), rw(f8, 2), rw(f8, 2), rw(f8, 1), rw(f8, 1), rw(f8, 1), rw(i8, 1),
            rw(b1, 2), rw(b1, 2), rw(f8, 1), rw(i8, 1))


@kernel(_impact_signature())
def impact_kernel(
    M, N, B, v, E, iM, iN, iB, iv, iE, poisson, rtol, tol, want_vplus,
    P, vplus, slack, Tm, Tp, Tc, rank, active, approaching, resid, status,
):  # pragma: no cover - compiled
    """Unilateral impact of every item ``b`` (see the module docstring).

    A :class:`~._jit.Kernel`: compiled for one signature on first use (``.get()``).

    Outputs: ``P (nb, k)`` impulses, ``vplus (nb, n)``, ``slack (nb, k)`` (normal velocity
    after the impact minus its restitution target), ``Tm``, ``Tp``, ``Tc``, ``rank``,
    ``active``/``approaching`` ``(nb, k)`` booleans, ``resid`` (relative complementarity
    residual), ``status``.
    """
    nb = iM.shape[0]
    n = M.shape[1]
    k = N.shape[1]
    pb = B.shape[1]
    L = np.zeros((n, n))
    invd = np.empty(n)  # 1 / diag(L), filled by factor
    u = np.empty(n)
    u0 = np.empty(n)
    up = np.empty(n)
    x = np.empty(n)
    WN = np.empty((n, k))
    Wt = np.empty((n, k))
    Q = np.empty((n, pb + k))
    WB = np.empty((pb, n))  # whitened bilateral rows
    nB = np.empty(pb)
    nN = np.empty(k)
    sc = np.empty(k)
    dep = np.zeros(k, dtype=np.bool_)
    gm = np.empty(k)
    g0 = np.empty(k)
    G = np.empty((k, k))
    qs = np.empty(k)
    z = np.empty(k)
    zc = np.empty(k)
    wmid = np.empty(k)
    T = np.empty((k, 2 * k + 2))
    basis = np.empty(k, dtype=np.int64)
    S = np.empty(k, dtype=np.int64)
    A = np.empty((k, k))
    rs = np.empty(k)
    zp = np.empty(k)
    maxit = 50 + 20 * k
    last = -1
    last_code = STATUS_OK
    for b in range(nb):
        im = iM[b]
        if im != last:
            last_code = factor(M[im], L, invd)
            last = im
        if last_code != STATUS_OK:
            status[b] = last_code
            continue
        Nb = N[iN[b]]
        Bb = B[iB[b]]
        vb = v[iv[b]]
        eb = E[iE[b]]
        tt = 0.0
        for i in range(n):
            s = 0.0
            for j in range(i, n):
                s += L[j, i] * vb[j]
            u[i] = s
            tt += s * s
        Tm[b] = 0.5 * tt
        usc = max(np.sqrt(tt), 1e-300)
        # whitened bilateral rows -> orthonormal basis Q[:, :r]
        r = np.int64(0)  # (a literal 0 would compile _orth_append twice)
        bmax = 0.0
        for j in range(pb):  # forward substitution, each row once
            Wj = WB[j]
            nrm = 0.0
            for i in range(n):
                s = Bb[j, i]
                for c in range(i):
                    s -= L[i, c] * Wj[c]
                s *= invd[i]
                Wj[i] = s
                nrm += s * s
            nrm = np.sqrt(nrm)
            nB[j] = nrm
            if nrm > bmax:
                bmax = nrm
        for j in range(pb):
            nrm = nB[j]
            if nrm > rtol * bmax and nrm > 0.0:
                for i in range(n):
                    x[i] = WB[j, i] / nrm
                r = _orth_append(Q, r, x, rtol)
        rB = r
        # u0 = (I - Q Q^T) u
        for i in range(n):
            u0[i] = u[i]
        for _ in range(2):
            for j in range(rB):
                s = 0.0
                for i in range(n):
                    s += Q[i, j] * u0[i]
                for i in range(n):
                    u0[i] -= s * Q[i, j]
        # whitened unilateral rows, their bilateral-free part W~ and the column scales
        for j in range(k):
            nrm = 0.0
            for i in range(n):
                s = Nb[j, i]
                for c in range(i):
                    s -= L[i, c] * WN[c, j]
                s *= invd[i]
                WN[i, j] = s
                Wt[i, j] = s
                nrm += s * s
            nN[j] = np.sqrt(nrm)
            for _ in range(2):
                for c in range(rB):
                    s = 0.0
                    for i in range(n):
                        s += Q[i, c] * Wt[i, j]
                    for i in range(n):
                        Wt[i, j] -= s * Q[i, c]
            nrm = 0.0
            g = 0.0
            h = 0.0
            for i in range(n):
                nrm += Wt[i, j] * Wt[i, j]
                g += WN[i, j] * u[i]
                h += Wt[i, j] * u0[i]
            nrm = np.sqrt(nrm)
            gm[j] = g
            g0[j] = h
            dep[j] = nrm <= rtol * nN[j]
            sc[j] = nN[j] if dep[j] else nrm
            approaching[b, j] = g / nN[j] < -tol * usc
        for a in range(k):
            for c in range(a, k):
                s = 0.0
                if not (dep[a] or dep[c]):
                    for i in range(n):
                        s += Wt[i, a] * Wt[i, c]
                    s /= sc[a] * sc[c]
                G[a, c] = s
                G[c, a] = s
        st = STATUS_OK
        if poisson:
            for j in range(k):
                qs[j] = g0[j] / sc[j]
        else:
            for j in range(k):
                qs[j] = (g0[j] + eb[j] * gm[j]) / sc[j]
        for j in range(k):
            if dep[j]:
                if qs[j] < -tol * usc:
                    st = STATUS_LOCKED
                qs[j] = max(qs[j], 0.0)
        if st == STATUS_OK:
            st = scaled_lcp(G, qs, z, T, basis, S, A, rs, zp, maxit, tol * usc)
        res = 0.0
        if st == STATUS_OK:
            res = relative_residual(G, qs, z, k, usc)
        if st == STATUS_OK and poisson:
            # expansion phase: p_e = e p_c + x, x >= 0 complementary to the final velocity
            for j in range(k):
                zc[j] = z[j]
            for a in range(k):
                s = qs[a]
                for c in range(k):
                    s += G[a, c] * zc[c]
                # closed contacts end compression at exactly zero normal velocity: keep
                # their round-off out of the expansion problem (it would make a jammed,
                # rank-deficient problem look infeasible)
                wmid[a] = s if s > tol * usc else 0.0
            for a in range(k):
                s = wmid[a]
                for c in range(k):
                    s += G[a, c] * eb[c] * zc[c]
                qs[a] = s
            st = scaled_lcp(G, qs, z, T, basis, S, A, rs, zp, maxit, tol * usc)
            if st == STATUS_OK:
                res = max(res, relative_residual(G, qs, z, k, usc))
                for j in range(k):
                    z[j] += (1.0 + eb[j]) * zc[j]
        status[b] = st
        if st != STATUS_OK:
            continue
        resid[b] = res
        # u+ = u0 + W~ p ; impulses p_j = z_j / sc_j
        for i in range(n):
            up[i] = u0[i]
        for j in range(k):
            pj = 0.0 if dep[j] else z[j] / sc[j]
            P[b, j] = pj
            if pj != 0.0:
                for i in range(n):
                    up[i] += Wt[i, j] * pj
        tt = 0.0
        for i in range(n):
            tt += up[i] * up[i]
        Tp[b] = 0.5 * tt
        for j in range(k):
            s = 0.0
            for i in range(n):
                s += Wt[i, j] * up[i]
            if not poisson:
                s += eb[j] * gm[j]
            slack[b, j] = s
            zs = 0.0 if dep[j] else z[j]
            active[b, j] = zs > tol * usc or s / sc[j] <= tol * usc
        # T_c^- with the active unilateral rows and the bilateral rows
        r = rB
        for j in range(k):
            if active[b, j] and not dep[j]:
                inv = 1.0 / sc[j]
                for i in range(n):
                    x[i] = Wt[i, j] * inv
                r = _orth_append(Q, r, x, rtol)
        tc = 0.0
        for j in range(r):
            s = 0.0
            for i in range(n):
                s += Q[i, j] * u[i]
            tc += s * s
        Tc[b] = 0.5 * tc
        rank[b] = r
        if want_vplus:
            for i in range(n - 1, -1, -1):
                s = up[i]
                for j in range(i + 1, n):
                    s -= L[j, i] * vplus[b, j]
                vplus[b, i] = s / L[i, i]
