"""Compiled (numba) kernel of the effective mass of single rows, free and with held rows.

For a row ``a`` (a contact normal in generalized coordinates), ``M = L L^T`` and the
whitened row ``w = L^{-1} a^T``:

- free: ``a M^{-1} a^T = |w|^2``,
- with held rows ``B`` (the other contacts, which persist through the impact):
  ``a N a^T = |(I - Pi) w|^2``, ``N = M^{-1} - M^{-1} B^T (B M^{-1} B^T)^+ B M^{-1}``,
  where ``Pi`` projects onto ``range(L^{-1} B^T)``.

The second is the admissible part of a velocity: for ``v = M^{-1} a^T`` (so that
``L^T v = w``) the partition of :mod:`.partition` with the rows ``B`` gives
``T_a = 1/2 |(I - Pi) w|^2``. So one pass per item is: factor ``M`` (reused while
consecutive items share it), ``w`` by forward substitution, ``v`` by back substitution,
and :func:`~.partition.partition_factored` of ``B`` and ``v``: the same checks, the same
rank decision (pivoted QR, ``rtol``) and the same compiled code as the partition.
"""

from __future__ import annotations

import numpy as np
from numba import types

from .._validation import STATUS_NONFINITE_A, STATUS_OK
from ._jit import f8, i8, kernel, ro, rw
from .partition import FASTMATH, factor, partition_factored, readonly

#: Columns of the kernel's output row: ``a M^-1 a^T``, ``a N a^T`` (with the held rows),
#: the rank of the held rows, the status (``STATUS_OK`` or the partition's codes; a
#: non-finite held row is ``STATUS_NONFINITE_A``, a non-finite ``a`` ``STATUS_ROW``).
OUT_FREE, OUT_HELD, OUT_RANK, OUT_STATUS = range(4)

#: Status of an item whose row ``a`` holds NaN or inf.
STATUS_ROW = 100


def masses_signature():
    """``(M, a, B, index, p, rtol, out)`` of :func:`masses_kernel`."""
    return types.void(ro(f8, 2), ro(f8, 2), ro(f8, 2), ro(i8, 2), i8, f8, rw(f8, 2))


@kernel(masses_signature(), fastmath=FASTMATH, loop_vectorize=False)
def masses_kernel(M, a, B, index, p, rtol, out):  # pragma: no cover - compiled
    """For every item ``b``, with ``(iM, ia, iB) = index[:, b]``: the mass matrix
    ``M[iM n : iM n + n]``, the row ``a[ia]`` and the held rows ``B[iB p : iB p + p]``
    (the inputs stacked along their first axis); ``out[b]`` receives ``a M^-1 a^T``,
    ``a N a^T``, the rank of the held rows and the status (columns :data:`OUT_FREE` ...;
    an item that fails its checks: NaN and its status). The caller checks shapes and
    indices. Loop vectoriser off, as the one-item partition kernel (short loops)."""
    nb = index.shape[1]
    n = M.shape[1]
    buf = np.empty(n * n + 2 * p * n + 2 * p + 7 * n + 4)
    L = buf[:n * n].reshape(n, n)
    o = n * n
    W = buf[o:o + p * n].reshape(p, n)
    o += p * n
    H = buf[o:o + p * n].reshape(p, n)
    o += p * n
    hn = buf[o:o + p]
    o += p
    cn = buf[o:o + p]
    o += p
    invd = buf[o:o + n]
    o += n
    w = buf[o:o + n]
    o += n
    vv = buf[o:o + n]
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
    no_vc = np.bool_(False)
    last = -1
    last_code = STATUS_OK
    for b in range(nb):
        im = index[0, b]
        row = out[b]
        if im != last:
            last_code = factor(M[im * n:im * n + n], L, invd)
            last = im
        code = last_code
        if code == STATUS_OK:
            ab = a[index[1, b]]
            g = 0.0
            for i in range(n):  # w = L^{-1} a^T
                s = ab[i]
                Li = L[i]
                for k in range(i):
                    s -= Li[k] * w[k]
                s *= invd[i]
                w[i] = s
                g += s * s
            if not np.isfinite(g):
                code = STATUS_ROW
            else:
                for i in range(n - 1, -1, -1):  # v = L^{-T} w = M^{-1} a^T
                    s = w[i]
                    for j in range(i + 1, n):
                        s -= L[j, i] * vv[j]
                    vv[i] = s * invd[i]
                ib = index[2, b] * p
                # vv read-only, as the partition kernels pass v: one compiled version
                code = partition_factored(L, invd, B[ib:ib + p], readonly(vv), rtol, no_vc,
                                          W, H, hn, u, y, z, cn, dummy, res)
        if code != STATUS_OK:
            row[OUT_FREE] = row[OUT_HELD] = row[OUT_RANK] = np.nan
            row[OUT_STATUS] = STATUS_NONFINITE_A if code == STATUS_NONFINITE_A else code
            continue
        row[OUT_FREE] = g
        row[OUT_HELD] = 2.0 * res[2]
        row[OUT_RANK] = res[3]
        row[OUT_STATUS] = STATUS_OK
