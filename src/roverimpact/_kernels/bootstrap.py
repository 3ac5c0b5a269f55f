r"""Compiled (numba) kernel of the bootstrap of rank and linear agreement.

A resample of ``n`` cases drawn with replacement from ``n`` is a count :math:`c_j \ge 0`
per case (:math:`\sum_j c_j = n`). Its statistics follow from the counts without sorting
the resample:

- **ranks.** Cases of equal ``x`` form groups (``gx``, numbered in increasing ``x``). The
  average rank of every copy of a case of group ``g`` in the resample is
  :math:`S_g + (C_g + 1)/2`, with :math:`C_g` the copies in group ``g`` and :math:`S_g`
  those in the groups before it: the ranks ``scipy.stats.rankdata`` gives the resample
  (copies of one case are ties). Spearman's rho is Pearson's r of the ranks of ``x`` and
  ``y``, each case weighted by its count (their mean is :math:`(n + 1)/2` exactly).
- **Pearson's r** of ``x`` and ``y``, each case weighted by its count.
- **Kendall's tau-b.** :math:`S = \sum_{\text{pairs}} \operatorname{sign}(x_i - x_j)
  \operatorname{sign}(y_i - y_j)` over the pairs of the resample: cases are taken in
  increasing ``x``, one group at a time, and a Fenwick tree over the groups of ``y``
  holds the counts of the cases of smaller ``x`` (:math:`O(n \log n)`, integers). With
  :math:`n_0 = n(n-1)/2` and :math:`n_1, n_2, n_{12}` the pairs tied in ``x``, in ``y``
  and in both, :math:`\tau_b = S / \sqrt{n_0 - n_1} / \sqrt{n_0 - n_2}` (as
  ``scipy.stats.kendalltau``); the concordant fraction of the untied pairs
  :math:`u = n_0 - n_1 - n_2 + n_{12}` is :math:`(u + S) / (2u)`.

Only numpy and numba here; ``roverimpact.studies.stats`` prepares the groups and draws
the resamples.
"""

from __future__ import annotations

import math

import numpy as np
from numba import types

from ._jit import b1, f8, i8, kernel, ro, rw

#: Columns of the kernel's output: Spearman's rho, Kendall's tau-b, Pearson's r and the
#: concordant fraction of the untied pairs of each resample (NaN where undefined).
OUT_SPEARMAN, OUT_KENDALL, OUT_PEARSON, OUT_CONCORDANT = range(4)


def agreement_signature():
    """``(x, y, gx, gy, gxy, at, idx, kendall, out)`` of :func:`agreement_kernel`."""
    return types.void(ro(f8, 1), ro(f8, 1), ro(i8, 1), ro(i8, 1), ro(i8, 1), ro(i8, 1),
                      ro(i8, 2), b1, rw(f8, 2))


@kernel(agreement_signature(), fastmath=False)
def agreement_kernel(x, y, gx, gy, gxy, at, idx, kendall, out):  # pragma: no cover
    """For every resample ``b`` (the case indices ``idx[b]``, ``n`` of them), ``out[b]``
    receives Spearman's rho, Kendall's tau-b, Pearson's r and the concordant fraction
    (columns :data:`OUT_SPEARMAN` ...; with ``kendall`` False the second and the last are
    NaN).

    The cases are given in increasing ``x``: case ``i`` of ``idx`` is at position
    ``at[i]`` of ``x``, ``y``, ``gx``, ``gy`` and ``gxy``. ``gx``, ``gy``: group of each
    case by its value (0, 1, ... in increasing value, equal values one group); ``gxy``:
    group by the pair of values. The caller checks shapes and indices."""
    nb, n = idx.shape
    ngx = 0
    ngy = 0
    ngxy = 0
    for j in range(n):
        ngx = max(ngx, gx[j] + 1)
        ngy = max(ngy, gy[j] + 1)
        ngxy = max(ngxy, gxy[j] + 1)
    c = np.zeros(n, np.int32)
    cx = np.zeros(ngx, np.int64)
    cy = np.zeros(ngy, np.int64)
    cxy = np.zeros(ngxy, np.int64)
    rx = np.empty(ngx)
    ry = np.empty(ngy)
    tree = np.zeros(ngy + 1, np.int32)  # Fenwick tree over the groups of y, 1-based
    iny = np.zeros(ngy, np.int32)  # copies of each group of y in the tree
    mid = 0.5 * (n + 1)  # the mean rank
    n0 = n * (n - 1) // 2
    nan = math.nan
    for b in range(nb):
        c[:] = 0
        for k in range(n):
            c[at[idx[b, k]]] += 1
        cx[:] = 0
        cy[:] = 0
        cxy[:] = 0
        sx = 0.0
        sy = 0.0
        for j in range(n):
            w = c[j]
            if w:
                cx[gx[j]] += w
                cy[gy[j]] += w
                cxy[gxy[j]] += w
                sx += w * x[j]
                sy += w * y[j]
        s = 0
        for g in range(ngx):
            rx[g] = s + 0.5 * (cx[g] + 1)
            s += cx[g]
        s = 0
        for g in range(ngy):
            ry[g] = s + 0.5 * (cy[g] + 1)
            s += cy[g]
        mx = sx / n
        my = sy / n
        rab = raa = rbb = 0.0
        pab = paa = pbb = 0.0
        for j in range(n):
            w = c[j]
            if w:
                a = rx[gx[j]] - mid
                e = ry[gy[j]] - mid
                rab += w * (a * e)
                raa += w * (a * a)
                rbb += w * (e * e)
                a = x[j] - mx
                e = y[j] - my
                pab += w * (a * e)
                paa += w * (a * a)
                pbb += w * (e * e)
        den = math.sqrt(raa * rbb)
        out[b, 0] = rab / den if den > 0.0 else nan
        den = math.sqrt(paa * pbb)
        out[b, 2] = pab / den if den > 0.0 else nan
        if not kendall:
            out[b, 1] = nan
            out[b, 3] = nan
            continue
        tree[:] = 0
        iny[:] = 0
        below = 0  # copies of the cases of smaller x
        S = 0
        p = 0
        while p < n:
            g = gx[p]
            q = p
            while q < n and gx[q] == g:
                q += 1
            for j in range(p, q):  # against the cases of smaller x
                w = c[j]
                if w:
                    less = 0  # copies of smaller y
                    i = gy[j]
                    while i > 0:
                        less += tree[i]
                        i -= i & -i
                    S += w * (less - (below - less - iny[gy[j]]))
            for j in range(p, q):  # then this group joins them
                w = c[j]
                if w:
                    i = gy[j] + 1
                    while i <= ngy:
                        tree[i] += w
                        i += i & -i
                    iny[gy[j]] += w
                    below += w
            p = q
        n1 = 0
        for g in range(ngx):
            n1 += cx[g] * (cx[g] - 1) // 2
        n2 = 0
        for g in range(ngy):
            n2 += cy[g] * (cy[g] - 1) // 2
        n12 = 0
        for g in range(ngxy):
            n12 += cxy[g] * (cxy[g] - 1) // 2
        if n0 - n1 > 0 and n0 - n2 > 0:  # clipped to [-1, 1] as scipy's
            out[b, 1] = min(1.0, max(-1.0, S / math.sqrt(n0 - n1) / math.sqrt(n0 - n2)))
        else:
            out[b, 1] = nan
        untied = n0 - n1 - n2 + n12
        out[b, 3] = ((untied + S) // 2) / untied if untied > 0 else nan
