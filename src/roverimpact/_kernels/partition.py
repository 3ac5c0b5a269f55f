"""Compiled (numba) kernel of the kinetic-energy partition.

One pass per configuration, no Python in the loop:

1. Cholesky factor ``M = L L^T`` (checks symmetry and definiteness; reused while
   consecutive items share the same ``M``),
2. ``u = L^T v`` so that ``T = 1/2 |u|^2``,
3. ``W = L^{-1} A^T`` (forward substitution), columns normalised to unit length
   (the subspace, hence ``T_c``, does not depend on the scale of the rows of ``A``,
   except that a column below ``rtol`` times the largest counts as zero),
4. Householder QR of ``W`` with column pivoting (rank revealing, as LAPACK ``xGEQP3``);
   the rank ``r`` is the number of pivots above ``rtol``,
5. ``y = Q^T u``: ``T_c = 1/2 sum_{k<r} y_k^2``, ``T_a = 1/2 sum_{k>=r} y_k^2``,
6. optionally ``v_c = L^{-T} Q [y_0..y_{r-1}, 0, ...]``.

The orthogonal projector onto ``range(W) = range(L^{-1} A^T)`` is the whitened form of
``P_c = M^{-1} A^T (A M^{-1} A^T)^+ A``; no inverse of a singular matrix is ever formed.

:func:`partition_kernel` processes one item at a time (one system, or the batches below
``roverimpact.energy.LANES_MIN_BATCH`` items). :func:`.lanes_jit.lanes_kernel`
returns the lane-parallel kernel (generated module :mod:`.lanes`), which processes 8 items
at once in SIMD lanes and hands nearly dependent rows back to :func:`partition_factored`.
:func:`prefetch` is a cache hint used by that kernel.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.core.imputils import impl_ret_borrowed
from numba.extending import intrinsic

from .._validation import (
    STATUS_ASYMMETRIC_M,
    STATUS_NONFINITE_A,
    STATUS_NONFINITE_M,
    STATUS_NONFINITE_V,
    STATUS_NOT_PD,
    STATUS_OK,
    SYM_RTOL,
)
from ._jit import NJIT_OPTIONS, PYTHON_EQUIVALENTS, boolean, f8, i8, kernel, ro, rw, shared

_EPS = np.finfo(np.float64).eps
# Reassociation lets LLVM vectorise the lane kernel's sums (SLP); no 'nnan'/'ninf': the
# kernels rely on NaN comparisons to detect bad input.
FASTMATH = {"reassoc", "contract", "arcp"}


@shared(fastmath=FASTMATH)
def factor(Mi, L, invd):  # pragma: no cover - compiled
    """Check ``Mi`` (finite, symmetric, positive definite) and factor it, ``Mi = L L^T``.

    ``invd`` receives ``1 / diag(L)`` (on the way it holds the pivots not yet reached; after
    a failure its entries are partial, and callers read neither it nor ``L``). Symmetry:
    ``|M_ij - M_ji| <= SYM_RTOL * max|M_kk|`` (a NaN or inf off the diagonal fails this
    test too; the caller classifies it). The
    symmetry test runs inside the factorisation, on each ``M_ij`` as it is read (one pass
    over M, not two: up to 0.1 us of a one-item partition of 4.3-4.5 us, n = 18, in
    ad-hoc timings taken in turns); a matrix that is
    both asymmetric and not positive definite is reported asymmetric, as a separate first
    pass would.
    """
    n = Mi.shape[0]
    maxdiag = 0.0
    for i in range(n):
        d = Mi[i, i]
        if not np.isfinite(d):
            return STATUS_NONFINITE_M
        if abs(d) > maxdiag:
            maxdiag = abs(d)
    tol = SYM_RTOL * maxdiag
    thresh = n * _EPS * maxdiag
    ok = True
    # invd[i] holds M_ii - sum_{k<j} L_ik^2 until column i is reached: each L_ij is
    # subtracted as it is made, so the pivot is not one chain of j dependent multiply-adds
    # at column j (the same subtractions in the same order)
    for i in range(n):
        invd[i] = Mi[i, i]
    for j in range(n):
        Lj = L[j]
        Mj = Mi[j]
        s = invd[j]
        if not s > thresh:  # the columns not yet read decide between the two codes
            for c in range(j, n):
                Mc = Mi[c]
                for i in range(c + 1, n):
                    ok &= abs(Mi[i, c] - Mc[i]) <= tol
            return STATUS_NOT_PD if ok else STATUS_ASYMMETRIC_M
        d = np.sqrt(s)
        Lj[j] = d
        inv = 1.0 / d
        invd[j] = inv
        # the rows below, four at a time: four independent sums instead of one chain of
        # dependent multiply-adds (each waits for the last); the same operations per entry
        i = j + 1
        while i + 3 < n:
            L0, L1, L2, L3 = L[i], L[i + 1], L[i + 2], L[i + 3]
            t0, t1, t2, t3 = Mi[i, j], Mi[i + 1, j], Mi[i + 2, j], Mi[i + 3, j]
            ok &= abs(t0 - Mj[i]) <= tol
            ok &= abs(t1 - Mj[i + 1]) <= tol
            ok &= abs(t2 - Mj[i + 2]) <= tol
            ok &= abs(t3 - Mj[i + 3]) <= tol
            for k in range(j):
                e = Lj[k]
                t0 -= L0[k] * e
                t1 -= L1[k] * e
                t2 -= L2[k] * e
                t3 -= L3[k] * e
            t0 *= inv
            t1 *= inv
            t2 *= inv
            t3 *= inv
            L0[j] = t0
            L1[j] = t1
            L2[j] = t2
            L3[j] = t3
            invd[i] -= t0 * t0
            invd[i + 1] -= t1 * t1
            invd[i + 2] -= t2 * t2
            invd[i + 3] -= t3 * t3
            i += 4
        for i in range(i, n):  # noqa: B020 (the rows the blocks left)
            Li = L[i]
            t = Mi[i, j]
            ok &= abs(t - Mj[i]) <= tol
            for k in range(j):
                t -= Li[k] * Lj[k]
            t *= inv
            Li[j] = t
            invd[i] -= t * t
    return STATUS_OK if ok else STATUS_ASYMMETRIC_M


@shared(fastmath=FASTMATH)
def partition_factored(
    L, invd, Ab, vb, rtol, want_vc, W, H, hn, u, y, z, cn, vc_row, res
):  # pragma: no cover - compiled
    """Steps 2-6 for one item whose ``M = L L^T`` is factored; returns a status code.

    ``res`` receives ``T, T_c, T_a, rank``; ``vc_row`` receives ``v_c`` if ``want_vc``.
    ``W, H`` (m, n), ``hn, cn`` (m,), ``u, y, z`` (n,) are scratch.
    """
    n = L.shape[0]
    m = Ab.shape[0]
    kmax = min(n, m)
    for i in range(n):
        if not np.isfinite(vb[i]):
            return STATUS_NONFINITE_V
    for j in range(m):
        for i in range(n):
            if not np.isfinite(Ab[j, i]):
                return STATUS_NONFINITE_A
    # u = L^T v, T = 1/2 |u|^2
    for i in range(n):
        u[i] = 0.0
    for j in range(n):
        Lj = L[j]
        vj = vb[j]
        for i in range(j + 1):
            u[i] += Lj[i] * vj
    tt = 0.0
    for i in range(n):
        y[i] = u[i]
        tt += u[i] * u[i]
    res[0] = 0.5 * tt
    # W = L^{-1} A^T, one forward substitution per row of A, four rows at a time (four
    # independent sums, as in factor)
    cmax = 0.0
    j = 0
    while j + 3 < m:
        W0, W1, W2, W3 = W[j], W[j + 1], W[j + 2], W[j + 3]
        n0 = n1 = n2 = n3 = 0.0
        for i in range(n):
            Li = L[i]
            s0, s1, s2, s3 = Ab[j, i], Ab[j + 1, i], Ab[j + 2, i], Ab[j + 3, i]
            for k in range(i):
                e = Li[k]
                s0 -= e * W0[k]
                s1 -= e * W1[k]
                s2 -= e * W2[k]
                s3 -= e * W3[k]
            d = invd[i]
            s0 *= d
            s1 *= d
            s2 *= d
            s3 *= d
            W0[i] = s0
            W1[i] = s1
            W2[i] = s2
            W3[i] = s3
            n0 += s0 * s0
            n1 += s1 * s1
            n2 += s2 * s2
            n3 += s3 * s3
        cn[j], cn[j + 1], cn[j + 2], cn[j + 3] = (np.sqrt(n0), np.sqrt(n1), np.sqrt(n2),
                                                  np.sqrt(n3))
        j += 4
    for j in range(j, m):  # noqa: B020 (the rows the blocks left)
        # a row alone: a column of L at a time (each W_ji gets the same subtractions in
        # the same order, none waiting for the one before)
        Wj = W[j]
        for i in range(n):
            Wj[i] = Ab[j, i]
        nrm = 0.0
        for k in range(n):
            s = Wj[k] * invd[k]
            Wj[k] = s
            nrm += s * s
            for i in range(k + 1, n):
                Wj[i] -= L[i, k] * s
        cn[j] = np.sqrt(nrm)
    for j in range(m):
        if cn[j] > cmax:
            cmax = cn[j]
    for j in range(m):
        if cmax == 0.0 or cn[j] <= rtol * cmax:
            for i in range(n):
                W[j, i] = 0.0
        else:
            inv = 1.0 / cn[j]
            for i in range(n):
                W[j, i] *= inv
    # Householder QR with column pivoting
    r = 0
    for k in range(kmax):
        # squared norms of the rows left (into cn), two at a time: independent sums
        j = k
        while j + 1 < m:
            s0 = s1 = 0.0
            for i in range(k, n):
                a0 = W[j, i]
                a1 = W[j + 1, i]
                s0 += a0 * a0
                s1 += a1 * a1
            cn[j] = s0
            cn[j + 1] = s1
            j += 2
        if j < m:
            s0 = 0.0
            for i in range(k, n):
                s0 += W[j, i] * W[j, i]
            cn[j] = s0
        best = -1.0
        p = k
        for j in range(k, m):
            if cn[j] > best:
                best = cn[j]
                p = j
        norm = np.sqrt(best)
        if norm <= rtol:
            break
        if p != k:
            for i in range(n):
                t = W[k, i]
                W[k, i] = W[p, i]
                W[p, i] = t
        x0 = W[k, k]
        alpha = -norm if x0 >= 0.0 else norm
        h2 = 0.0
        for i in range(k, n):
            H[k, i] = W[k, i]
        H[k, k] = x0 - alpha
        for i in range(k, n):
            h2 += H[k, i] * H[k, i]
        hn[k] = h2
        if h2 > 0.0:
            # the reflection of the rows below and of y: their dot products with H[k]
            # first, two at a time (independent sums), then the updates
            j = k + 1
            while j + 1 < m:
                s0 = s1 = 0.0
                for i in range(k, n):
                    h = H[k, i]
                    s0 += h * W[j, i]
                    s1 += h * W[j + 1, i]
                cn[j] = s0
                cn[j + 1] = s1
                j += 2
            sy = 0.0
            if j < m:
                s0 = 0.0
                for i in range(k, n):
                    h = H[k, i]
                    s0 += h * W[j, i]
                    sy += h * y[i]
                cn[j] = s0
            else:
                for i in range(k, n):
                    sy += H[k, i] * y[i]
            for j in range(k + 1, m):
                f = 2.0 * cn[j] / h2
                for i in range(k, n):
                    W[j, i] -= f * H[k, i]
            f = 2.0 * sy / h2
            for i in range(k, n):
                y[i] -= f * H[k, i]
        r += 1
    tc = 0.0
    for k in range(r):
        tc += y[k] * y[k]
    ta = 0.0
    for k in range(r, n):
        ta += y[k] * y[k]
    res[1] = 0.5 * tc
    res[2] = 0.5 * ta
    res[3] = r
    if want_vc:
        for i in range(n):
            z[i] = y[i] if i < r else 0.0
        for k in range(r - 1, -1, -1):
            h2 = hn[k]
            if h2 > 0.0:
                s = 0.0
                for i in range(k, n):
                    s += H[k, i] * z[i]
                f = 2.0 * s / h2
                for i in range(k, n):
                    z[i] -= f * H[k, i]
        # back substitution L^T v_c = z
        for i in range(n - 1, -1, -1):
            s = z[i]
            for j in range(i + 1, n):
                s -= L[j, i] * vc_row[j]
            vc_row[i] = s * invd[i]
    return STATUS_OK


#: Columns of the partition kernel's output row: ``T, T_c, T_a, rank, status``, then
#: ``v_c`` and ``v_a`` (n each) if velocities are wanted.
OUT_T, OUT_TC, OUT_TA, OUT_RANK, OUT_STATUS, OUT_V = range(6)


@njit(**NJIT_OPTIONS)
def _failed(row, code):  # pragma: no cover - compiled
    """An output row of an item that fails its checks: the status, NaN energies, rank 0."""
    row[OUT_T] = row[OUT_TC] = row[OUT_TA] = np.nan
    row[OUT_RANK] = 0.0
    row[OUT_STATUS] = code


#: Status of a one-system call (``m = -1``) whose shapes do not match.
STATUS_SHAPE = -1


def items_signature():
    """``(M, A, v, index, m, rtol, want_vc, out) -> (status, T, T_c, T_a, rank)`` of
    :func:`partition_kernel`."""
    return types.UniTuple(f8, 5)(ro(f8, 2), ro(f8, 2), ro(f8, 1), ro(i8, 2), i8, f8, boolean,
                                 rw(f8, 2))


@kernel(items_signature(), fastmath=FASTMATH, loop_vectorize=False)
def partition_kernel(M, A, v, index, m, rtol, want_vc, out):  # pragma: no cover - compiled
    """Partition every item ``b``, one at a time: the mass matrix ``M[iM n : iM n + n]``,
    rows ``A[iA m : iA m + m]`` and velocity ``v[iv n : iv n + n]``, ``(iM, iA, iv) =
    index[:, b]`` (the inputs stacked along their first axis). ``out[b]`` receives
    ``T, T_c, T_a, rank, status`` and, if ``want_vc``, ``v_c`` and ``v_a`` (columns
    :data:`OUT_V` onwards; an item that fails its checks: NaN energies, rank 0, and
    velocities left as they were). The caller checks the shapes and indices. Returns zeros.

    With ``m = -1``, one system (M (n, n), A (m, n), v (n,), ``index`` zero) passed as it
    is: the kernel checks its shapes and returns ``(status, T, T_c, T_a, rank)``
    (``status`` :data:`STATUS_SHAPE` if the shapes do not match); ``out`` (1, 2 n)
    receives ``v_c`` and ``v_a`` if ``want_vc``, and is not touched otherwise (a caller may
    pass one array of shape (1, 0) every time).

    Few arguments and results returned, not written, on purpose: numba unboxes every
    array argument of every call, and reading an output row back costs a Python call per
    number, together a large share of a one-system call of a few microseconds
    (``benchmarks/bench_single.py``). A :class:`~._jit.Kernel`: compiled for one
    signature on first use (``.get()``), with LLVM's loop vectoriser off: its loops run
    over one item's n and m (a few to a few tens), too short for vector code to pay for
    its set-up, and it made this kernel slower: n = 18, m = 4, 6.0-6.1 us a call against
    4.4-4.6 with T_c alone, 7.2-7.4 against 4.9-5.1 with the velocities; no size from
    n = 5 to 60 faster with it (``benchmarks/bench_single.py --vectoriser``)."""
    nb = index.shape[1]
    n = M.shape[1]
    one = m < 0
    if one:  # one system as it is (index zero): the shapes must match exactly
        m = A.shape[0]
        if (n == 0 or M.shape[0] != n or A.shape[1] != n or v.shape[0] != n or nb != 1
                or (want_vc and (out.shape[0] != 1 or out.shape[1] != 2 * n))):
            return float(STATUS_SHAPE), 0.0, 0.0, 0.0, 0.0
    # one scratch buffer: every allocation costs about as much as a short loop
    buf = np.empty(n * n + 2 * m * n + 2 * m + 5 * n + 4)
    L = buf[:n * n].reshape(n, n)  # only the lower triangle is written and read
    o = n * n
    W = buf[o:o + m * n].reshape(m, n)  # W[j] is column j of L^{-1} A^T (row-major)
    o += m * n
    H = buf[o:o + m * n].reshape(m, n)  # Householder vectors: H[k, k:] holds v_k
    o += m * n
    hn = buf[o:o + m]  # their squared norms
    o += m
    cn = buf[o:o + m]
    o += m
    invd = buf[o:o + n]
    o += n
    u = buf[o:o + n]
    o += n
    y = buf[o:o + n]
    o += n
    z = buf[o:o + n]
    o += n
    dummy = buf[o:o + n]
    o += n
    res = buf[o:o + 4]
    if one:
        vc_row = out[0, :n] if want_vc else dummy
        code = factor(M, L, invd)
        if code == STATUS_OK:
            code = partition_factored(L, invd, A, v, rtol, want_vc, W, H, hn, u, y, z, cn,
                                      vc_row, res)
        if code != STATUS_OK:
            return float(code), np.nan, np.nan, np.nan, 0.0
        if want_vc:
            for i in range(n):
                out[0, n + i] = v[i] - vc_row[i]
        return 0.0, res[0], res[1], res[2], res[3]
    last = -1
    last_code = STATUS_OK
    for b in range(nb):
        im = index[0, b]
        row = out[b]
        if im != last:
            last_code = factor(M[im * n:im * n + n], L, invd)
            last = im
        if last_code != STATUS_OK:
            _failed(row, last_code)
            continue
        ia = index[1, b] * m
        iv = index[2, b] * n
        vb = v[iv:iv + n]
        vc_row = row[OUT_V:OUT_V + n] if want_vc else dummy
        code = partition_factored(L, invd, A[ia:ia + m], vb, rtol, want_vc, W, H, hn, u, y,
                                  z, cn, vc_row, res)
        if code != STATUS_OK:
            _failed(row, code)
        else:
            row[OUT_STATUS] = code
            row[OUT_T] = res[0]
            row[OUT_TC] = res[1]
            row[OUT_TA] = res[2]
            row[OUT_RANK] = res[3]
            if want_vc:
                for i in range(n):
                    row[OUT_V + n + i] = vb[i] - vc_row[i]
    return 0.0, 0.0, 0.0, 0.0, 0.0


@intrinsic
def readonly(typingctx, arr):
    """``arr`` typed read-only: the same array (no copy), for a writable array passed to a
    :func:`~._jit.shared` function whose other callers pass read-only ones (the kernels'
    inputs). numba compiles a function once per set of argument types, and a writable and
    a read-only array are different types: without this, ``factor`` and
    ``partition_factored`` were compiled a second time for ``T_c_at``'s kernel."""
    if not isinstance(arr, types.Array) or not arr.mutable:
        return None

    def codegen(context, builder, signature, args):  # pragma: no cover - compiled
        return impl_ret_borrowed(context, builder, signature.return_type, args[0])

    return arr.copy(readonly=True)(arr), codegen


@intrinsic
def prefetch(typingctx, arr, offset):
    """Hint the CPU to fetch element ``offset`` of C-contiguous ``arr`` (flat index) into
    cache (``llvm.prefetch``, read, high locality); no effect on results."""
    if not isinstance(arr, types.Array) or not isinstance(offset, types.Integer):
        return None

    def codegen(context, builder, signature, args):  # pragma: no cover - compiled
        ary = context.make_array(signature.args[0])(context, builder, args[0])
        off = context.cast(builder, args[1], signature.args[1], types.intp)
        ptr = builder.bitcast(builder.gep(ary.data, [off]), ir.IntType(8).as_pointer())
        i32 = ir.IntType(32)
        name = "llvm.prefetch.p0" if str(ptr.type) == "ptr" else "llvm.prefetch.p0i8"
        fnty = ir.FunctionType(ir.VoidType(), [ptr.type, i32, i32, i32])
        fn = cgutils.get_or_insert_function(builder.module, fnty, name)
        builder.call(fn, [ptr, i32(0), i32(1), i32(1)])
        return context.get_dummy_value()

    return types.void(arr, offset), codegen


def _same_array(arr):
    return arr


def _no_prefetch(arr, offset):
    return None


# what the kernels' Python code runs in their place (roverimpact._kernels._jit.python_version)
PYTHON_EQUIVALENTS[readonly] = _same_array
PYTHON_EQUIVALENTS[prefetch] = _no_prefetch


# ----------------------------------------------------------------------------------------
# Lane-parallel kernel (generated module _kernels_lanes.py), compiled on first use with
# LLVM's SLP vectoriser switched on: numba leaves it off by default, and without it the
# per-lane statements stay scalar.
# ----------------------------------------------------------------------------------------
