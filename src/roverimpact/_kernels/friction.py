"""Compiled (numba) kernel of the frictional impact problem (see :mod:`roverimpact.frictional`).

Per configuration, with no Python in the loop:

1. Cholesky factor ``M = L L^T`` (the checked factor of the partition kernel),
   ``u = L^T v``; whitened rows ``W = L^{-1} R^T`` of the bilateral, normal and tangent
   rows; an orthonormal basis ``Q`` of the whitened bilateral rows (CGS2, dependent rows
   dropped), projected out of the others: ``W~ = (I - Q Q^T) W``, ``u0 = (I - Q Q^T) u``;
2. the Gram matrix ``H`` of the projected normal and tangent columns; the friction
   directions ``d_j = sum_r c_jr t_r`` of a contact are combinations of its tangent rows,
   so their Gram entries follow from ``H`` (directions in the span of the bilateral rows
   do nothing and are dropped);
3. the LCP in ``z = (p, beta, lambda)`` (Anitescu & Potra 1997)::

       w_n = G_nn p + G_nd beta + b_n              >= 0  _|_  p      >= 0
       w_d = G_dn p + G_dd beta + E lambda + b_d   >= 0  _|_  beta   >= 0
       w_l = U p - E^T beta                        >= 0  _|_  lambda >= 0

   A problem without friction variables goes through exactly the frictionless path of
   :mod:`roverimpact._lcp`. Otherwise, first an active-set iteration on the contact
   modes (:func:`_mode_iteration`: separating, sticking, sliding on a vertex or an edge
   of the polygon; each mode set is a linear system in the Gram matrix), started from
   the frictionless solution, and accepted only when every condition of the LCP holds;
   if it does not settle, Lemke's algorithm with the lexicographic rule and an exact
   solve on the final basis, on the LCP column-scaled to a unit diagonal of the ``G``
   blocks, ``lambda`` scaled so that ``E`` has O(1) entries and the cone rows divided
   by ``max(mu, 1)`` (equivalent LCPs). The matrix is copositive and ``b`` lies in the
   dual of its kernel cone, so Lemke's algorithm terminates with a solution in exact
   arithmetic; floating-point pivoting can stall on the very degenerate problems of
   redundant contacts at rest (zero entries of ``b``, rank-deficient ``G``), and then
   the pivoting is repeated on ``b`` plus a small fixed perturbation (1e-9 .. 1e-5 of
   ``max|b|``, which breaks the ties), the final basis being solved exactly with the
   unperturbed ``b`` (``fallback`` flag);
4. ``mu = inf`` contacts hold their tangent rows as bilateral rows while they hold: the
   set of such locked contacts is iterated (lock every holding contact that slips,
   release every locked contact that separates or holds with a zero normal impulse, whose
   locked tangent rows could otherwise carry friction without a normal impulse), starting
   from all of them locked (the
   no-slip rows held), then, if that fails, from none, until it is consistent. If it
   never is (a contact that separates when locked and slips when released, the
   impulsive analogue of Painleve's paradox) or every locked set tried makes the
   problem infeasible, those contacts get ``mu = MU_INF`` (``fallback``);
5. ``u+ = u0 + W~_N p + W~_T tau``, the contact states, ``T_c^-`` with the held rows.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types

from .._validation import STATUS_OK
from ._jit import NJIT_OPTIONS, b1, boolean, f8, i8, kernel, ro, rw
from .lemke import (
    STATUS_INFEASIBLE,
    STATUS_LOCKED,
    STATUS_MAXITER,
    relative_residual,
    scaled_lcp,
)
from .partition import factor

#: contact states (``state`` output)
SEPARATING = 0
STICKING = 1
SLIDING = 2

#: friction coefficient of the mu = inf contacts when no consistent locked set exists
MU_INF = 1e4

_PIV = 1e-12  # smallest tableau entry accepted as a pivot (problem scaled to O(1))
_LEX = 1e-11  # relative tolerance of the lexicographic comparisons
_ACCEPT = 1e-10  # residual of the scaled LCP (max|b| = 1) accepted at once
_ATTEMPTS = 5  # unperturbed, then four perturbations of b


@njit(**NJIT_OPTIONS)
def _whiten(L, invd, row, out, col):  # pragma: no cover - compiled
    """``out[col] = L^{-1} row`` (forward substitution); returns the norm."""
    n = row.shape[0]
    o = out[col]
    nrm = 0.0
    for i in range(n):
        s = row[i]
        Li = L[i]
        for c in range(i):
            s -= Li[c] * o[c]
        s *= invd[i]
        o[i] = s
        nrm += s * s
    return np.sqrt(nrm)


@njit(**NJIT_OPTIONS)
def _orth_append_t(Q, r, x, rtol):  # pragma: no cover - compiled
    """CGS2: orthogonalise unit vector ``x`` against the rows ``Q[:r]``; append it as
    row ``r`` if independent (``_lcp._orth_append`` with the basis stored by rows)."""
    n = x.shape[0]
    for _ in range(2):
        for j in range(r):
            Qj = Q[j]
            s = 0.0
            for i in range(n):
                s += Qj[i] * x[i]
            for i in range(n):
                x[i] -= s * Qj[i]
    nrm = 0.0
    for i in range(n):
        nrm += x[i] * x[i]
    nrm = np.sqrt(nrm)
    if nrm <= rtol or r >= n:
        return r
    inv = 1.0 / nrm
    for i in range(n):
        Q[r, i] = x[i] * inv
    return r + 1


@njit(**NJIT_OPTIONS)
def _lexless(T, i, si, j, sj, K, rhs):  # pragma: no cover - compiled
    """Is row ``i`` (times ``si``) lexicographically smaller than row ``j`` (times ``sj``)?

    Compared on ``(rhs, B^{-1})`` with a tolerance relative to the entries.
    """
    x = T[i, rhs] * si
    y = T[j, rhs] * sj
    t = _LEX * max(1.0, abs(x), abs(y))
    if x < y - t:
        return True
    if x > y + t:
        return False
    for c in range(K):
        x = T[i, c] * si
        y = T[j, c] * sj
        t = _LEX * max(1.0, abs(x), abs(y))
        if x < y - t:
            return True
        if x > y + t:
            return False
    return False


@njit(**NJIT_OPTIONS)
def _pivot(T, K, ncol, r, c):  # pragma: no cover - compiled
    inv = 1.0 / T[r, c]
    for j in range(ncol):
        T[r, j] *= inv
    for i in range(K):
        if i != r:
            f = T[i, c]
            if f != 0.0:
                for j in range(ncol):
                    T[i, j] -= f * T[r, j]
            T[i, c] = 0.0
    T[r, c] = 1.0


@njit(**NJIT_OPTIONS)
def _lemke(G, q, K, z, T, basis, maxit):  # pragma: no cover - compiled
    """Lemke's algorithm on the leading ``K x K`` block: ``w = G z + q >= 0 _|_ z >= 0``.

    ``z`` receives the basic solution (negative round-off clipped); ``basis`` the final
    basis (for the exact solve). Returns a status code.
    """
    neg = False
    for i in range(K):
        z[i] = 0.0
        basis[i] = i
        if q[i] < 0.0:
            neg = True
    if not neg:
        return STATUS_OK
    z0 = 2 * K
    rhs = 2 * K + 1
    ncol = 2 * K + 2
    for i in range(K):
        for j in range(K):
            T[i, j] = 0.0
            T[i, K + j] = -G[i, j]
        T[i, i] = 1.0
        T[i, z0] = -1.0
        T[i, rhs] = q[i]
    r = np.int64(0)  # not a literal: one compile of _lexless/_pivot, not two
    for i in range(1, K):
        if _lexless(T, i, 1.0, r, 1.0, K, rhs):
            r = i
    enter = z0
    for _ in range(maxit):
        leave = basis[r]
        _pivot(T, K, ncol, r, enter)
        basis[r] = enter
        if leave == z0:
            for i in range(K):
                b = basis[i]
                if K <= b < 2 * K:
                    z[b - K] = max(T[i, rhs], 0.0)
            return STATUS_OK
        enter = leave + K if leave < K else leave - K
        r = np.int64(-1)  # (a literal -1 would compile _lexless a third time)
        for i in range(K):
            a = T[i, enter]
            if a > _PIV:
                if r < 0 or _lexless(T, i, 1.0 / a, r, 1.0 / T[r, enter], K, rhs):
                    r = i
        if r < 0:
            return STATUS_INFEASIBLE  # secondary ray
    return STATUS_MAXITER


@njit(**NJIT_OPTIONS)
def _basis_solve(G, q, K, basis, S, A, rs, out):  # pragma: no cover - compiled
    """Exact solution on Lemke's final basis: ``G_SS z_S = -q_S``, ``S`` its basic ``z``.

    Gaussian elimination with partial pivoting; ``out`` (clipped at 0). False if the
    basis is numerically singular.
    """
    ns = 0
    for i in range(K):
        out[i] = 0.0
        b = basis[i]
        if K <= b < 2 * K:
            S[ns] = b - K
            ns += 1
    for a in range(ns):
        for c in range(ns):
            A[a, c] = G[S[a], S[c]]
        rs[a] = -q[S[a]]
    for c in range(ns):
        p = c
        for a in range(c + 1, ns):
            if abs(A[a, c]) > abs(A[p, c]):
                p = a
        if abs(A[p, c]) < 1e-14:
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
            if f != 0.0:
                for j in range(c, ns):
                    A[a, j] -= f * A[c, j]
                rs[a] -= f * rs[c]
    for c in range(ns - 1, -1, -1):
        s = rs[c]
        for j in range(c + 1, ns):
            s -= A[c, j] * out[S[j]]
        out[S[c]] = s / A[c, c]
    for a in range(ns):
        out[S[a]] = max(out[S[a]], 0.0)
    return True


@njit(**NJIT_OPTIONS)
def _residual(G, q, z, K):  # pragma: no cover - compiled
    res = 0.0
    for i in range(K):
        w = q[i]
        for j in range(K):
            w += G[i, j] * z[j]
        res = max(res, -z[i], -w, abs(z[i] * w))
    return res


@njit(**NJIT_OPTIONS)
def _frictional_lcp(G, qs, K, thr, z, qx, qp, zl, zb, T, basis, S, A, rs):
    # pragma: no cover - compiled
    """Solve the scaled frictional LCP ``(G, qs)`` (leading K); ``z`` in units of ``qs``.

    Returns ``(status, fallback)``. Entries of ``qs`` in ``(-thr, 0)`` are round-off of
    zero (contacts at rest) and are set to 0.
    """
    qmax = 0.0
    qmin = 0.0
    for i in range(K):
        if -thr < qs[i] < 0.0:
            qs[i] = 0.0
        qmax = max(qmax, abs(qs[i]))
        qmin = min(qmin, qs[i])
    for i in range(K):
        z[i] = 0.0
    if qmin == 0.0:
        return STATUS_OK, False
    for i in range(K):
        qx[i] = qs[i] / qmax
    maxit = 50 + 20 * K
    best = np.inf
    used = -1
    code = STATUS_OK
    for a in range(_ATTEMPTS):
        # a fixed, deterministic perturbation: golden-ratio or geometric sequence
        for i in range(K):
            if a == 0:
                qp[i] = qx[i]
            elif a == 1 or a == 4:
                size = 1e-9 if a == 1 else 1e-7
                qp[i] = qx[i] + size * (0.5 + (i * 0.6180339887498949) % 1.0)
            else:
                size = 1e-7 if a == 2 else 1e-5
                qp[i] = qx[i] + size * 0.8**i
        st = _lemke(G, qp, K, zl, T, basis, maxit)
        if st != STATUS_OK:
            code = st
            continue
        res = _residual(G, qx, zl, K)
        if _basis_solve(G, qx, K, basis, S, A, rs, zb):
            rb = _residual(G, qx, zb, K)
            if rb < res:
                res = rb
                for i in range(K):
                    zl[i] = zb[i]
        if res < best:
            best = res
            used = a
            for i in range(K):
                z[i] = zl[i] * qmax
        if res <= _ACCEPT:
            break
    if used < 0:
        return code, False
    return STATUS_OK, used > 0


# contact modes of the active-set iteration
_M_SEP = 0  # no impulse
_M_FREE = 1  # frictionless contact that holds: normal impulse only
_M_STICK = 2  # normal impulse and a friction impulse inside the cone, no slip
_M_VERT = 3  # sliding, friction impulse mu p d_j (a vertex of the polygon)
_M_EDGE = 4  # sliding, friction impulse on the edge (d_j, d_j+1), beta_j + beta_j+1 = mu p


@njit(**NJIT_OPTIONS)
def _gauss(A, rhs, m, out, pc):  # pragma: no cover - compiled
    """Solve ``A[:m, :m] out = rhs``: rows equilibrated, partial pivoting.

    A column without a usable pivot (redundant contacts) is skipped and its unknown set
    to zero: the basic solution of a rank-deficient system, if it is consistent (else
    False). ``pc`` receives the pivot column of each row.
    """
    bmax = 0.0
    for a in range(m):
        rmax = 0.0
        for c in range(m):
            rmax = max(rmax, abs(A[a, c]))
        if rmax > 0.0:
            inv = 1.0 / rmax
            for c in range(m):
                A[a, c] *= inv
            rhs[a] *= inv
        bmax = max(bmax, abs(rhs[a]))
    r = 0
    for c in range(m):
        out[c] = 0.0
        if r == m:
            continue
        p = r
        for a in range(r + 1, m):
            if abs(A[a, c]) > abs(A[p, c]):
                p = a
        if abs(A[p, c]) < 1e-10:
            continue  # dependent column: unknown c stays zero
        if p != r:
            for j in range(c, m):
                t = A[r, j]
                A[r, j] = A[p, j]
                A[p, j] = t
            t = rhs[r]
            rhs[r] = rhs[p]
            rhs[p] = t
        inv = 1.0 / A[r, c]
        for a in range(r + 1, m):
            f = A[a, c] * inv
            if f != 0.0:
                for j in range(c, m):
                    A[a, j] -= f * A[r, j]
                rhs[a] -= f * rhs[r]
        pc[r] = c
        r += 1
    for a in range(r, m):  # dependent equations must be consistent
        if abs(rhs[a]) > 1e-9 * max(bmax, 1e-300):
            return False
    for a in range(r - 1, -1, -1):
        c = pc[a]
        s = rhs[a]
        for j in range(c + 1, m):
            s -= A[a, j] * out[j]
        out[c] = s / A[a, c]
    return True


@njit(**NJIT_OPTIONS)
def _mode_iteration(H, h0, tgt, sc, tw, fr, mue, ntan, nd, coef, cosm, k, tm, thr, mode,
                    va, xp, xt, vel, uc, ux, ec, ex, Am, HX, rhs, sol, perm, hist, maxit):
    # pragma: no cover - compiled
    """Active-set iteration on the contact modes; the number of iterations to a
    verified LCP solution, or -1.

    Every iteration solves the linear equations of the current modes (normal velocity
    at its Newton target for the holding contacts, zero slip for the sticking ones, the
    friction impulse on a vertex or an edge of the polygon for the sliding ones) and
    checks every inequality of the LCP: ``p >= 0``, normal slack ``>= 0``, friction
    inside the cone, slip speed ``lambda >= 0`` and friction in the direction(s) most
    opposed to the slip. A violated contact changes mode; ``maxit`` iterations without
    a verified solution (or a singular system) return False, and the caller solves the
    LCP by Lemke's algorithm. ``H`` (kc x kc) and ``h0`` (kc): Gram matrix and free
    velocities of the projected normal (0..k-1) and tangent (k + c*tm + q) columns;
    ``tgt`` the normal velocity targets ``-e N v-``; ``sc``, ``tw`` normal and tangent
    column scales; ``fr`` contacts with friction variables; ``mode``, ``va`` the initial
    modes (and vertex/edge index), updated. Output ``xp (k)``, ``xt (k, tm)``.
    """
    for c in range(k):
        hist[c] = False
    mold = np.empty(k, dtype=np.int64)
    vold = np.empty(k, dtype=np.int64)
    best = k + 1
    stall = 0
    single = False
    for it in range(maxit):
        # unknowns: (contact, kind, direction) ; kind 0 = p, 1 = tau_q, 2 = beta_a, 3 = beta_b
        m = np.int64(0)  # (a literal 0 would compile _gauss twice)
        for c in range(k):
            md = mode[c]
            if md == _M_SEP:
                continue
            uc[m] = c
            ux[m, 0] = 0  # p
            m += 1
            if md == _M_STICK:
                for q in range(ntan[c]):
                    uc[m] = c
                    ux[m, 0] = 1
                    ux[m, 1] = q
                    m += 1
            elif md == _M_EDGE:
                for e2 in range(2):
                    uc[m] = c
                    ux[m, 0] = 2 + e2
                    m += 1
        # equations: normal rows of holding contacts, tangent rows of sticking ones, and
        # for an edge the equal slip along both directions and beta_a + beta_b = mu p
        ne = 0
        for c in range(k):
            md = mode[c]
            if md == _M_SEP:
                continue
            ec[ne] = c
            ex[ne, 0] = 0
            ne += 1
            if md == _M_STICK:
                for q in range(ntan[c]):
                    ec[ne] = c
                    ex[ne, 0] = 1
                    ex[ne, 1] = q
                    ne += 1
            elif md == _M_EDGE:
                ec[ne] = c
                ex[ne, 0] = 2
                ne += 1
                ec[ne] = c
                ex[ne, 0] = 3
                ne += 1
        kc = H.shape[0]
        # HX[:, i]: velocity change of every column per unit of unknown i
        for i in range(m):
            c = uc[i]
            ki = ux[i, 0]
            base = k + c * tm
            for r in range(kc):
                HX[r, i] = 0.0
            if ki == 0:
                for r in range(kc):
                    HX[r, i] = H[r, c]
                if mode[c] == _M_VERT:
                    for q in range(ntan[c]):
                        w2 = mue[c] * coef[c, va[c], q]
                        for r in range(kc):
                            HX[r, i] += w2 * H[r, base + q]
            elif ki == 1:
                for r in range(kc):
                    HX[r, i] = H[r, base + ux[i, 1]]
            else:
                jd = va[c] if ki == 2 else (va[c] + 1) % nd[c]
                for q in range(ntan[c]):
                    w2 = coef[c, jd, q]
                    for r in range(kc):
                        HX[r, i] += w2 * H[r, base + q]
        for e in range(ne):
            c = ec[e]
            kind = ex[e, 0]
            base = k + c * tm
            if kind == 0:
                for i in range(m):
                    Am[e, i] = HX[c, i]
                rhs[e] = tgt[c] - h0[c]
            elif kind == 1:
                row = base + ex[e, 1]
                for i in range(m):
                    Am[e, i] = HX[row, i]
                rhs[e] = -h0[row]
            elif kind == 2:  # equal slip along both directions of the edge
                j1 = va[c]
                j2 = (va[c] + 1) % nd[c]
                s = 0.0
                for i in range(m):
                    Am[e, i] = 0.0
                for q in range(ntan[c]):
                    w2 = coef[c, j1, q] - coef[c, j2, q]
                    s += w2 * h0[base + q]
                    for i in range(m):
                        Am[e, i] += w2 * HX[base + q, i]
                rhs[e] = -s
            else:  # beta_a + beta_b - mu p = 0
                for i in range(m):
                    a2 = 0.0
                    if uc[i] == c:
                        if ux[i, 0] == 0:
                            a2 = -mue[c]
                        elif ux[i, 0] >= 2:
                            a2 = 1.0
                    Am[e, i] = a2
                rhs[e] = 0.0
        if m and not _gauss(Am, rhs, m, sol, perm):
            return -1
        for c in range(k):
            xp[c] = 0.0
            for q in range(tm):
                xt[c, q] = 0.0
        for i in range(m):
            c = uc[i]
            ki = ux[i, 0]
            if ki == 0:
                xp[c] = sol[i]
                if mode[c] == _M_VERT:
                    for q in range(ntan[c]):
                        xt[c, q] += mue[c] * coef[c, va[c], q] * sol[i]
            elif ki == 1:
                xt[c, ux[i, 1]] += sol[i]
            else:
                jd = va[c] if ki == 2 else (va[c] + 1) % nd[c]
                for q in range(ntan[c]):
                    xt[c, q] += coef[c, jd, q] * sol[i]
        # velocities of every column
        for r in range(kc):
            s = h0[r]
            for i in range(m):
                s += HX[r, i] * sol[i]
            vel[r] = s
        # check every contact, change the modes of the violated ones
        ok = True
        for c in range(k):
            mold[c] = mode[c]
            vold[c] = va[c]
        for c in range(k):
            md = mode[c]
            zp = xp[c] * sc[c]
            wn = (vel[c] - tgt[c]) / sc[c]
            # slip along each direction, phi_j = d_j . s (scaled), and its minimum
            jmin = 0
            pmin = np.inf
            if fr[c]:
                for j in range(nd[c]):
                    s = 0.0
                    for q in range(ntan[c]):
                        s += coef[c, j, q] * vel[k + c * tm + q]
                    s /= tw[c]
                    if s < pmin:
                        pmin = s
                        jmin = j
            if md == _M_SEP:
                if wn < -thr:
                    ok = False
                    if not fr[c]:
                        mode[c] = _M_FREE
                    elif hist[c] and pmin < -thr:
                        # sticking pulled it off the ground before: slide against the slip
                        mode[c] = _M_VERT
                        va[c] = jmin
                    else:
                        mode[c] = _M_STICK
                continue
            if zp < -thr:
                hist[c] = hist[c] or md == _M_STICK
                mode[c] = _M_SEP
                ok = False
                continue
            if md == _M_FREE:
                continue
            if md == _M_STICK:
                # gauge of tau on the polygon (planar: |tau|), against mu p
                if ntan[c] == 1:
                    g = abs(xt[c, 0])
                    jf = 0 if xt[c, 0] > 0.0 else 1
                else:
                    g = -np.inf
                    jf = 0
                    for j in range(nd[c]):
                        j2 = (j + 1) % nd[c]
                        s = 0.0
                        for q in range(ntan[c]):
                            s += (coef[c, j, q] + coef[c, j2, q]) * xt[c, q]
                        s /= 2.0 * cosm * cosm
                        if s > g:
                            g = s
                            jf = j
                if (g - mue[c] * xp[c]) * tw[c] > thr:
                    mode[c] = _M_VERT if ntan[c] == 1 else _M_EDGE
                    va[c] = jf
                    ok = False
                continue
            # sliding: lambda = -phi of the active direction(s)
            ja = va[c]
            s = 0.0
            for q in range(ntan[c]):
                s += coef[c, ja, q] * vel[k + c * tm + q]
            lam = -s / tw[c]
            if lam < -thr:
                mode[c] = _M_STICK
                ok = False
                continue
            if md == _M_EDGE:
                # beta of both ends
                ba = 0.0
                bb = 0.0
                for i in range(m):
                    if uc[i] == c and ux[i, 0] == 2:
                        ba = sol[i]
                    elif uc[i] == c and ux[i, 0] == 3:
                        bb = sol[i]
                jb = (ja + 1) % nd[c]
                if ba * tw[c] < -thr:
                    mode[c] = _M_VERT
                    va[c] = jb
                    ok = False
                    continue
                if bb * tw[c] < -thr:
                    mode[c] = _M_VERT
                    ok = False
                    continue
                if pmin < -lam - thr and jmin != ja and jmin != jb:
                    mode[c] = _M_VERT
                    va[c] = jmin
                    ok = False
                continue
            # vertex
            if pmin < -lam - thr and jmin != ja:
                ok = False
                if ntan[c] == 2 and jmin == (ja + 1) % nd[c]:
                    mode[c] = _M_EDGE
                elif ntan[c] == 2 and ja == (jmin + 1) % nd[c]:
                    mode[c] = _M_EDGE
                    va[c] = jmin
                else:
                    va[c] = jmin
        if ok:
            return it + 1
        # block changes; when they stop reducing the number of violated contacts for 3
        # iterations (cycling), one change at a time, the least index (Murty's rule)
        nviol = 0
        for c in range(k):
            if mode[c] != mold[c] or va[c] != vold[c]:
                nviol += 1
                if single and nviol > 1:
                    mode[c] = mold[c]
                    va[c] = vold[c]
        if nviol < best:
            best = nviol
            stall = 0
        else:
            stall += 1
            if stall >= 3:
                single = True
    return -1


@njit(**NJIT_OPTIONS)
def _held_energy(H, h, nrm, S, m, C, y):  # pragma: no cover - compiled
    """``(1/2 h_S^T H_SS^+ h_S, rank)`` by a pivoted Cholesky factor of the Gram matrix
    of the held columns ``S[:m]`` (normalised by ``nrm``).

    A pivot below 1e-13 of the normalised diagonal (a residual norm below ~3e-7) marks a
    column as dependent on the others; ``C`` (m x m) and ``y`` (m) are work arrays.
    """
    for a in range(m):
        ia = S[a]
        for c in range(m):
            C[a, c] = H[ia, S[c]] / (nrm[ia] * nrm[S[c]])
        y[a] = h[ia] / nrm[ia]
    r = 0
    for c in range(m):
        # largest remaining diagonal entry
        p = c
        for a in range(c + 1, m):
            if C[a, a] > C[p, p]:
                p = a
        if C[p, p] <= 1e-13:
            break
        if p != c:
            for j in range(m):
                t = C[c, j]
                C[c, j] = C[p, j]
                C[p, j] = t
            for j in range(m):
                t = C[j, c]
                C[j, c] = C[j, p]
                C[j, p] = t
            t = y[c]
            y[c] = y[p]
            y[p] = t
        d = np.sqrt(C[c, c])
        C[c, c] = d
        for a in range(c + 1, m):
            C[a, c] /= d
        for a in range(c + 1, m):
            f = C[a, c]
            if f != 0.0:
                for j in range(c + 1, a + 1):
                    C[a, j] -= f * C[j, c]
        for a in range(c + 1, m):  # mirror the updated lower triangle
            for j in range(c + 1, a):
                C[j, a] = C[a, j]
        r += 1
    # forward substitution on the first r (pivoted) entries
    e = 0.0
    for a in range(r):
        s = y[a]
        for j in range(a):
            s -= C[a, j] * y[j]
        y[a] = s / C[a, a]
        e += y[a] * y[a]
    return 0.5 * e, r


def _friction_signature():
    """Inputs read-only C arrays (``M, N, Tg, B, v, E, MU``, the seven flat indices,
    ``ntan, nd, coef``), ``cosm, rtol, tol, want_vplus``, then the writable outputs."""
    i1 = types.int8
    return (ro(f8, 3), ro(f8, 3), ro(f8, 4), ro(f8, 3), ro(f8, 2), ro(f8, 2), ro(f8, 2),
            *(ro(i8, 1),) * 7, ro(i8, 1), ro(i8, 1), ro(f8, 3),
            f8, f8, f8, boolean,
            rw(f8, 2), rw(f8, 3), rw(f8, 2), rw(f8, 2), rw(f8, 3),
            rw(f8, 1), rw(f8, 1), rw(f8, 1), rw(i8, 1), rw(i1, 2),
            rw(b1, 2), rw(b1, 3), rw(b1, 2), rw(b1, 2),
            rw(f8, 1), rw(i8, 1), rw(b1, 1), rw(i1, 1), rw(i8, 1))


# one explicit signature (compiled on first use): as a plain @njit it was compiled once per
# mix of read-only and writable inputs (six in the test suite; one compile is the longest of
# the package's kernels, ``benchmarks/bench_startup.py --kernels``)
@kernel(_friction_signature())
def friction_kernel(
    M, N, Tg, B, v, E, MU, iM, iN, iT, iB, iv, iE, iU, ntan, nd, coef, cosm, rtol, tol,
    want_vplus,
    P, Pt, vplus, slack, slip, Tm, Tp, Tc, rank, state, hold_n, hold_t, locked,
    approaching, resid, status, fallback, meth, iters,
):  # pragma: no cover - compiled
    """Frictional impact of every item ``b`` (see the module docstring).

    Shapes: ``M (., n, n)``, ``N (., k, n)``, ``Tg (., k, tm, n)`` (tangent rows, zero
    padded), ``B (., pb, n)``, ``v (., n)``, ``E (., k)`` restitution, ``MU (., k)``
    friction coefficients (``inf`` allowed), ``i*`` flat indices per item, ``ntan (k,)``
    tangent rows per contact, ``nd (k,)`` directions per contact, ``coef (k, md, tm)``
    their coefficients on the tangent rows, ``cosm = cos(pi / facets)``. Outputs per
    item: ``P (k)``, ``Pt (k, tm)``
    (friction impulses on the tangent rows; zero for locked contacts, whose impulses are
    bilateral), ``vplus (n)``, ``slack (k)`` (``N v+ + e N v-``), ``slip (k, tm)``
    (``T v+``), ``Tm, Tp, Tc, rank``, ``state (k)``, ``hold_n (k)``, ``hold_t (k, tm)``,
    ``locked (k)`` (mu = inf contacts holding their tangent rows), ``approaching (k)``,
    ``resid``, ``status``, ``fallback``, ``meth`` (0 frictionless solve, 1 mode
    iteration, 2 Lemke, 3 Lemke with perturbation).
    """
    nb = iM.shape[0]
    n = M.shape[1]
    k = N.shape[1]
    tm = Tg.shape[2]
    pb = B.shape[1]
    kc = k + k * tm
    dmax = 0
    for c in range(k):
        dmax += nd[c]
    kmax = k + dmax + k
    L = np.zeros((n, n))
    invd = np.empty(n)
    u = np.empty(n)
    u0 = np.empty(n)
    up = np.empty(n)
    x = np.empty(n)
    WB = np.empty((max(pb, 1), n))
    nB = np.empty(max(pb, 1))
    Q = np.empty((pb + kc, n))  # rows: orthonormal basis vectors
    W = np.empty((kc, n))  # whitened normal (0..k-1) and tangent (k + c*tm + r) columns
    Wp = np.empty((kc, n))  # the same, bilateral (and locked tangent) part projected out
    nW = np.empty(kc)
    nWp = np.empty(kc)
    H = np.empty((kc, kc))  # Gram matrix of the projected columns
    Hr = np.empty((tm, tm))  # unprojected Gram of one contact's tangent columns
    h0 = np.empty(kc)  # projected columns . u0
    gm = np.empty(k)  # N v- (row velocities)
    sc = np.empty(k)
    dep = np.zeros(k, dtype=np.bool_)
    fric = np.zeros(k, dtype=np.bool_)
    inf = np.zeros(k, dtype=np.bool_)
    mue = np.empty(k)  # friction coefficient used in the LCP
    lock = np.zeros(k, dtype=np.bool_)
    hn = np.zeros(k, dtype=np.bool_)
    flips = np.zeros(k, dtype=np.int64)
    slipn = np.empty(k)
    dsc = np.empty(max(dmax, 1))
    down = np.empty(max(dmax, 1), dtype=np.int64)
    dj = np.empty(max(dmax, 1), dtype=np.int64)
    lam = np.empty(k, dtype=np.int64)  # index of the contact's lambda variable, or -1
    sig = np.empty(k)
    G = np.zeros((kmax, kmax))
    qs = np.empty(kmax)
    z = np.empty(kmax)
    qx = np.empty(kmax)
    qp = np.empty(kmax)
    zl = np.empty(kmax)
    zb = np.empty(kmax)
    T = np.empty((kmax, 2 * kmax + 2))
    basis = np.empty(kmax, dtype=np.int64)
    S = np.empty(kmax, dtype=np.int64)
    A = np.empty((kmax, kmax))
    rs = np.empty(kmax)
    Gn = np.empty((k, k))
    # the frictionless solve's own tableau and solve matrix: C arrays of its size, where
    # slices of T and A would compile the Lemke helpers a second time (for 'A' layouts)
    Tn = np.empty((k, 2 * k + 2))
    An = np.empty((k, k))
    qn0 = np.empty(k)
    xp = np.empty(k)
    xt = np.empty((k, tm))
    tgt = np.empty(k)
    fr = np.zeros(k, dtype=np.bool_)
    tw = np.empty(k)
    vel = np.empty(kc)
    mode = np.empty(k, dtype=np.int64)
    va = np.zeros(k, dtype=np.int64)
    m3 = 3 * k
    uc = np.empty(m3, dtype=np.int64)
    ux = np.zeros((m3, 2), dtype=np.int64)
    ec = np.empty(m3, dtype=np.int64)
    ex = np.zeros((m3, 2), dtype=np.int64)
    Am = np.empty((m3, m3))
    HX = np.empty((kc, m3))
    rhs = np.empty(m3)
    sol = np.empty(m3)
    perm = np.empty(m3, dtype=np.int64)
    hist = np.zeros(k, dtype=np.bool_)
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
        Tb = Tg[iT[b]]
        Bb = B[iB[b]]
        vb = v[iv[b]]
        eb = E[iE[b]]
        mub = MU[iU[b]]
        tt = 0.0
        for i in range(n):
            s = 0.0
            for j in range(i, n):
                s += L[j, i] * vb[j]
            u[i] = s
            tt += s * s
        Tm[b] = 0.5 * tt
        tt_minus = tt
        # sqrt(2 T-) without underflow (tiny velocities)
        umax = 0.0
        for i in range(n):
            umax = max(umax, abs(u[i]))
        usc = 0.0
        if umax > 0.0:
            for i in range(n):
                usc += (u[i] / umax) ** 2
            usc = umax * np.sqrt(usc)
        usc = max(usc, 1e-300)
        thr = tol * usc
        # bilateral rows -> orthonormal basis Q[:rB0]
        bmax = 0.0
        for j in range(pb):
            nB[j] = _whiten(L, invd, Bb[j], WB, j)
            bmax = max(bmax, nB[j])
        rB0 = np.int64(0)  # (a literal 0 would compile _orth_append_t twice)
        for j in range(pb):
            if nB[j] > rtol * bmax and nB[j] > 0.0:
                for i in range(n):
                    x[i] = WB[j, i] / nB[j]
                rB0 = _orth_append_t(Q, rB0, x, rtol)
        # whitened normal and tangent columns
        for j in range(k):
            nW[j] = _whiten(L, invd, Nb[j], W, j)
            for c in range(tm):
                col = k + j * tm + c
                nW[col] = _whiten(L, invd, Tb[j, c], W, col)
            s = 0.0
            for i in range(n):
                s += W[j, i] * u[i]
            gm[j] = s
            approaching[b, j] = s / nW[j] < -thr
            traw = 0.0
            for c in range(ntan[j]):
                traw = max(traw, nW[k + j * tm + c])
            # friction: mu > 0 and tangent rows that are not all zero in this item
            fric[j] = ntan[j] > 0 and mub[j] > 0.0 and traw > 0.0
            inf[j] = fric[j] and not np.isfinite(mub[j])
            lock[j] = inf[j]
            mue[j] = mub[j]
        st = STATUS_OK
        fb = False
        res = 0.0
        D = 0
        nloop = 2 * k + 2
        outer = 0
        for j in range(k):
            flips[j] = 0
        phase = 0  # mu = inf contacts: 0 all locked at first, 1 none, 2 mu = MU_INF
        while True:
            if outer == nloop and phase == 0:
                # no consistent locked set from all locked: start from none locked
                phase = 1
                outer = 0
                for j in range(k):
                    lock[j] = False
            elif outer == nloop and phase == 1:
                # none either (the no-slip contacts alternate between holding and
                # separating): the mu -> inf limit by a large finite mu
                phase = 2
                for j in range(k):
                    if inf[j]:
                        inf[j] = False
                        lock[j] = False
                        mue[j] = MU_INF
                fb = True
            anylock = False
            for j in range(k):
                anylock = anylock or inf[j]
            # basis of the bilateral rows plus the tangent rows of the locked contacts
            r = rB0
            for j in range(k):
                if lock[j]:
                    for c in range(ntan[j]):
                        col = k + j * tm + c
                        for i in range(n):
                            x[i] = W[col, i] / nW[col]
                        r = _orth_append_t(Q, r, x, rtol)
            rB = r
            for i in range(n):
                u0[i] = u[i]
            for _ in range(2):
                for j in range(rB):
                    s = 0.0
                    for i in range(n):
                        s += Q[j, i] * u0[i]
                    for i in range(n):
                        u0[i] -= s * Q[j, i]
            for col in range(kc):
                for i in range(n):
                    Wp[col, i] = W[col, i]
                if rB:
                    for _ in range(2):
                        for c in range(rB):
                            s = 0.0
                            for i in range(n):
                                s += Q[c, i] * Wp[col, i]
                            for i in range(n):
                                Wp[col, i] -= s * Q[c, i]
                nrm = 0.0
                s = 0.0
                for i in range(n):
                    nrm += Wp[col, i] * Wp[col, i]
                    s += Wp[col, i] * u0[i]
                nWp[col] = np.sqrt(nrm)
                h0[col] = s
            for a in range(kc):
                for c in range(a, kc):
                    s = 0.0
                    for i in range(n):
                        s += Wp[a, i] * Wp[c, i]
                    H[a, c] = s
                    H[c, a] = s
            for j in range(k):
                dep[j] = nWp[j] <= rtol * nW[j]
                sc[j] = nW[j] if dep[j] else nWp[j]
            # friction directions of the finite-mu contacts (dependent ones dropped)
            D = 0
            F = 0
            easy = True  # no dependent normal row, no dropped direction: modes usable
            for c in range(k):
                lam[c] = -1
                easy = easy and not dep[c]
                if not fric[c] or inf[c] or dep[c]:
                    continue
                d0 = D
                smax = 0.0
                base = k + c * tm
                for q1 in range(ntan[c]):
                    for q2 in range(q1, ntan[c]):
                        s = 0.0
                        for i in range(n):
                            s += W[base + q1, i] * W[base + q2, i]
                        Hr[q1, q2] = s
                        Hr[q2, q1] = s
                for j in range(nd[c]):
                    raw = 0.0
                    prj = 0.0
                    for q1 in range(ntan[c]):
                        for q2 in range(ntan[c]):
                            cc = coef[c, j, q1] * coef[c, j, q2]
                            prj += cc * H[base + q1, base + q2]
                            raw += cc * Hr[q1, q2]
                    raw = np.sqrt(max(raw, 0.0))
                    prj = np.sqrt(max(prj, 0.0))
                    if prj <= rtol * raw or prj == 0.0:
                        easy = False
                        continue
                    dsc[D] = prj
                    down[D] = c
                    dj[D] = j
                    smax = max(smax, prj)
                    D += 1
                if D > d0:
                    lam[c] = F
                    sig[c] = smax
                    F += 1
            K = k + D + F
            # normal block (as the frictionless kernel) and its right-hand side
            st = STATUS_OK
            for a in range(k):
                for c in range(a, k):
                    s = 0.0
                    if not (dep[a] or dep[c]):
                        s = H[a, c] / (sc[a] * sc[c])
                    G[a, c] = s
                    G[c, a] = s
                qs[a] = (h0[a] + eb[a] * gm[a]) / sc[a]
                if dep[a]:
                    if qs[a] < -thr:
                        st = STATUS_LOCKED
                    qs[a] = max(qs[a], 0.0)
            if st != STATUS_OK:
                if anylock and outer < nloop:  # this locked set fails: mu = MU_INF
                    outer = nloop
                    st = STATUS_OK
                    continue
                break
            for j in range(k):
                xp[j] = 0.0
                for q in range(tm):
                    xt[j, q] = 0.0
            solved = False
            if F == 0 or easy:
                # the frictionless solve: the answer without friction variables, else
                # the first guess of the contact modes
                for a in range(k):
                    for c in range(k):
                        Gn[a, c] = G[a, c]
                    qn0[a] = qs[a]
                st0 = scaled_lcp(Gn, qn0, z[:k], Tn, basis[:k], S[:k], An, rs[:k], zl[:k],
                                  50 + 20 * k, thr)
                if F == 0:
                    st = st0
                    if st != STATUS_OK:
                        if anylock and outer < nloop:
                            outer = nloop
                            st = STATUS_OK
                            continue
                        break
                    res = relative_residual(Gn, qn0, z[:k], k, usc)
                    for j in range(k):
                        xp[j] = 0.0 if dep[j] else z[j] / sc[j]
                    solved = True
                    meth[b] = 0
                elif st0 == STATUS_OK:
                    for j in range(k):
                        xp[j] = z[j] / sc[j]
                        tgt[j] = -eb[j] * gm[j]
                        fr[j] = lam[j] >= 0
                        tw[j] = 0.0
                        for q in range(ntan[j]):
                            tw[j] = max(tw[j], nW[k + j * tm + q])
                    for j in range(k):
                        # guess: frictionless holding contacts stick if they do not slip,
                        # else slide against the slip
                        w = h0[j] - tgt[j]
                        for c in range(k):
                            w += H[j, c] * xp[c]
                        mode[j] = _M_SEP
                        if not (z[j] > thr or w / sc[j] <= thr):
                            continue
                        if not fr[j]:
                            mode[j] = _M_FREE
                            continue
                        pmin = np.inf
                        for jd in range(nd[j]):
                            s = 0.0
                            for q in range(ntan[j]):
                                col = k + j * tm + q
                                v1 = h0[col]
                                for c in range(k):
                                    v1 += H[col, c] * xp[c]
                                s += coef[j, jd, q] * v1
                            s /= tw[j]
                            if s < pmin:
                                pmin = s
                                va[j] = jd
                        mode[j] = _M_STICK if pmin > -thr else _M_VERT
                    nit = _mode_iteration(H, h0, tgt, sc, tw, fr, mue, ntan, nd, coef,
                                          cosm, k, tm, thr, mode, va, xp, xt, vel, uc, ux,
                                          ec, ex, Am, HX, rhs, sol, perm, hist, 10 * k + 10)
                    iters[b] = nit
                    if nit > 0:
                        # normal complementarity relative to max|b| (the friction
                        # conditions hold by construction or were checked to thr)
                        qsc = 0.0
                        for j in range(k):
                            qsc = max(qsc, abs(qs[j]))
                        qsc = max(qsc, 1e-300)
                        res = 0.0
                        for j in range(k):
                            zs = xp[j] * sc[j]
                            ws = (vel[j] - tgt[j]) / sc[j]
                            res = max(res, -zs, -ws, abs(zs * ws) / qsc)
                        solved = res <= _ACCEPT * qsc
                        res = res / usc
                        meth[b] = 1
                    if not solved:
                        for j in range(k):
                            xp[j] = 0.0
                            for q in range(tm):
                                xt[j, q] = 0.0
            if not solved:
                # Lemke's algorithm on the whole LCP
                for d in range(D):
                    c = down[d]
                    j = dj[d]
                    base = k + c * tm
                    for a in range(k):
                        s = 0.0
                        if not dep[a]:
                            for q in range(ntan[c]):
                                s += coef[c, j, q] * H[a, base + q]
                            s /= sc[a] * dsc[d]
                        G[a, k + d] = s
                        G[k + d, a] = s
                    for d2 in range(d, D):
                        c2 = down[d2]
                        j2 = dj[d2]
                        base2 = k + c2 * tm
                        s = 0.0
                        for q1 in range(ntan[c]):
                            for q2 in range(ntan[c2]):
                                s += (coef[c, j, q1] * coef[c2, j2, q2]
                                      * H[base + q1, base2 + q2])
                        s /= dsc[d] * dsc[d2]
                        G[k + d, k + d2] = s
                        G[k + d2, k + d] = s
                    for f in range(F):
                        G[k + d, k + D + f] = 0.0
                        G[k + D + f, k + d] = 0.0
                    # w_d += lambda_c (lambda scaled by sig_c); cone row / max(mu, 1)
                    li = k + D + lam[c]
                    G[k + d, li] = sig[c] / dsc[d]
                    G[li, k + d] = -sig[c] / (dsc[d] * max(mue[c], 1.0))
                    s = 0.0
                    for q in range(ntan[c]):
                        s += coef[c, j, q] * h0[base + q]
                    qs[k + d] = s / dsc[d]
                for f in range(F):
                    for a in range(k):
                        G[k + D + f, a] = 0.0
                        G[a, k + D + f] = 0.0
                    for f2 in range(F):
                        G[k + D + f, k + D + f2] = 0.0
                    qs[k + D + f] = 0.0
                for c in range(k):
                    if lam[c] >= 0:
                        G[k + D + lam[c], c] = mue[c] / max(mue[c], 1.0) * sig[c] / sc[c]
                st, fbl = _frictional_lcp(G, qs, K, thr, z, qx, qp, zl, zb, T, basis, S, A,
                                          rs)
                if st != STATUS_OK:
                    if anylock and outer < nloop:
                        outer = nloop
                        st = STATUS_OK
                        continue
                    break
                fb = fb or fbl
                meth[b] = 3 if fbl else 2
                res = relative_residual(G, qs, z, K, usc)
                for j in range(k):
                    xp[j] = 0.0 if dep[j] else z[j] / sc[j]
                for d in range(D):
                    c = down[d]
                    bd = z[k + d] / dsc[d]
                    for q in range(ntan[c]):
                        xt[c, q] += coef[c, dj[d], q] * bd
            # u+ = u0 + W~_N p + W~_T tau
            for i in range(n):
                up[i] = u0[i]
            for j in range(k):
                P[b, j] = xp[j]
                if xp[j] != 0.0:
                    for i in range(n):
                        up[i] += Wp[j, i] * xp[j]
                for q in range(tm):
                    Pt[b, j, q] = xt[j, q]
                    if xt[j, q] != 0.0:
                        col = k + j * tm + q
                        for i in range(n):
                            up[i] += Wp[col, i] * xt[j, q]
            # which contacts hold, and their slip
            for j in range(k):
                s = 0.0
                for i in range(n):
                    s += Wp[j, i] * up[i]
                s += eb[j] * gm[j]
                slack[b, j] = s
                hn[j] = xp[j] * sc[j] > thr or s / sc[j] <= thr
                sl = 0.0
                for q in range(tm):
                    col = k + j * tm + q
                    w = 0.0
                    if q < ntan[j]:
                        for i in range(n):
                            w += Wp[col, i] * up[i]
                        if nW[col] > 0.0:
                            sl += (w / nW[col]) ** 2
                    slip[b, j, q] = w
                slipn[j] = np.sqrt(sl)
            # mu = inf: lock the holding contacts that slip, release the separating ones
            # and those that hold without a normal impulse (zero slack): their locked
            # tangent rows could carry a friction impulse with none on the normal, which
            # no mu allows (|tau| <= mu p = 0), and the locked set would not be the
            # mu -> inf limit
            change = False
            cycle = False
            for j in range(k):
                if inf[j]:
                    pushes = xp[j] * sc[j] > thr
                    if (lock[j] and not (hn[j] and pushes)) or (
                            not lock[j] and hn[j] and slipn[j] > thr):
                        lock[j] = not lock[j]
                        change = True
                        flips[j] += 1
                        cycle = cycle or flips[j] > 2  # locked, released, locked again
            if not change or outer >= nloop:
                break
            outer = nloop if cycle else outer + 1
            if cycle or outer == nloop:
                for j in range(k):
                    flips[j] = 0
        status[b] = st
        fallback[b] = fb
        if st != STATUS_OK:
            continue
        resid[b] = res
        tt = 0.0
        for i in range(n):
            tt += up[i] * up[i]
        Tp[b] = 0.5 * tt
        # states and the rows held for T_c^-: T_c = 1/2 |u - u0|^2 (the bilateral and
        # locked rows, projected out) + 1/2 h_S^T H_SS^+ h_S (the other held rows)
        ns = np.int64(0)  # (a literal 0 would compile _held_energy twice)
        for j in range(k):
            locked[b, j] = lock[j]
            stick = hn[j] and fric[j] and slipn[j] <= thr
            state[b, j] = STICKING if stick else (SLIDING if hn[j] else SEPARATING)
            hold_n[b, j] = hn[j]
            if hn[j] and nWp[j] > rtol * nW[j]:
                S[ns] = j
                ns += 1
            for q in range(tm):
                col = k + j * tm + q
                ht = stick and q < ntan[j] and nW[col] > 0.0
                hold_t[b, j, q] = ht
                if ht and nWp[col] > rtol * nW[col]:
                    S[ns] = col
                    ns += 1
        tq = 0.0
        for i in range(n):
            tq += u0[i] * u0[i]
        eh, rh = _held_energy(H, h0, nWp, S, ns, A, zl)
        Tc[b] = 0.5 * max(tt_minus - tq, 0.0) + eh
        rank[b] = rB + rh
        if want_vplus:
            for i in range(n - 1, -1, -1):
                s = up[i]
                for j in range(i + 1, n):
                    s -= L[j, i] * vplus[b, j]
                vplus[b, i] = s * invd[i]
