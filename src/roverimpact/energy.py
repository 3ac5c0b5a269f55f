r"""Kinetic-energy partition into the constrained and admissible subspaces.

For a system with generalized velocities :math:`v` (n), mass matrix :math:`M` (n x n,
symmetric positive definite) and m constraint rows :math:`A v = 0`, the velocity splits
into a part in the subspace of constrained motion (SCM) and one in the subspace of
admissible motion (SAM) (Kövecses 2008; González et al., DETC2014-35554, eqs. 1-3):

.. math::

    P_c = M^{-1} A^T (A M^{-1} A^T)^{-1} A, \quad v_c = P_c v, \quad v_a = v - v_c,
    \quad T_c = \tfrac12 v_c^T M v_c, \quad T_a = \tfrac12 v_a^T M v_a .

:math:`v_c` and :math:`v_a` are M-orthogonal, so :math:`T = T_c + T_a`. With the normal
of a coming impact added as a row of :math:`A`, :math:`T_c` just before contact is the
effective kinetic energy :math:`T_c^-`.

This module depends on numpy (and numba for the compiled kernel) only: it works on the
mass matrix of any engine.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from . import _validation
from ._kernels import masses as _masses
from ._kernels import partition as _one
from ._kernels.lanes_jit import lanes_kernel
from ._validation import InputError, as_array, broadcast_batch, fmt_index
from .exceptions import EnergyGainWarning

#: Default relative tolerance of the rank decision (see :func:`partition`).
RTOL = 1e-9

#: Batches with at least this many items use the lane-parallel kernel (8 items per SIMD
#: block); smaller ones the one-item-at-a-time kernel. Below 64 items the lanes gain less
#: than 50 us a call (1.5-2.8x, n = 5-18) while compiling them costs 6-8 s on a fresh
#: install (``benchmarks/bench_startup.py --kernels``); the built-in studies' 17-point
#: sweeps stay on the one-item kernel.
LANES_MIN_BATCH = 64

__all__ = ["ROW_SCALE_RANGE", "RTOL", "T_LIMIT", "Partition", "effective_mass", "partition",
           "projector"]


@dataclass(frozen=True)
class Partition:
    """Kinetic-energy partition of one or a batch of configurations.

    Attributes
    ----------
    T : float or (...,) array
        Total kinetic energy 1/2 v^T M v [J].
    T_c : float or (...,) array
        Kinetic energy in the subspace of constrained motion, 1/2 v_c^T M v_c [J].
    T_a : float or (...,) array
        Kinetic energy in the subspace of admissible motion, 1/2 v_a^T M v_a [J].
    v_c : (..., n) array
        Constrained part of the velocity, P_c v (same units as v).
    v_a : (..., n) array
        Admissible part of the velocity, v - v_c; satisfies A v_a = 0.
    rank : int or (...,) int array
        Numerical rank of A (number of independent constraint rows).
    """

    T: np.ndarray
    T_c: np.ndarray
    T_a: np.ndarray
    v_c: np.ndarray
    v_a: np.ndarray
    rank: np.ndarray


def prepare(M, A, v=None):
    """Validate shapes, return float arrays, the broadcast batch shape and n, m."""
    M = as_array(M, "M", min_ndim=2)
    A = as_array(A, "A", min_ndim=1)
    if M.shape[-1] != M.shape[-2]:
        raise InputError(f"M must have shape (..., n, n), got {M.shape}")
    n = M.shape[-1]
    if n == 0:
        raise InputError("M is empty (n = 0): the system has no degrees of freedom")
    if A.ndim == 1:
        A = A[None, :]
    if A.shape[-1] != n:
        raise InputError(
            f"A must have shape (..., m, n) with n = {n} columns to match M {M.shape}, "
            f"got {A.shape}"
        )
    shapes = {"M": M.shape[:-2], "A": A.shape[:-2]}
    if v is not None:
        v = as_array(v, "v", min_ndim=1)
        if v.shape[-1] != n:
            raise InputError(
                f"v must have shape (..., n) with n = {n} to match M {M.shape}, got {v.shape}"
            )
        shapes["v"] = v.shape[:-1]
    batch = broadcast_batch(**shapes)
    return M, A, v, batch, n, A.shape[-2]


#: Largest |entry| of an item's rows A outside which :func:`partition` and
#: :func:`~roverimpact.impulsive_impact` scale them (as :mod:`roverimpact.frictional` does):
#: far from where the squared whitened row norms under- or overflow float64.
ROW_SCALE_RANGE = (1e-50, 1e50)


def row_scale(A: np.ndarray) -> np.ndarray | None:
    """One power of two per item of rows ``A (..., m, n)``, about its largest |entry|, or
    None when every item's largest |entry| lies in :data:`ROW_SCALE_RANGE` (or is 0, NaN
    or inf, which the checks name). ``A / scale[..., None, None]`` then has entries of
    order 1: the same subspace and rank decision (one factor for all rows of an item keeps
    their relative sizes, which ``rtol`` judges), computed exactly (a power of two). Rows
    of entries about 1e-200 had whitened norms that underflowed to 0 (T_c = 0, rank 0),
    about 1e160 ones that overflowed to inf."""
    if A.size == 0:
        return None
    if A.ndim == 2:  # one item: two reductions, no temporary array
        lo, hi = ROW_SCALE_RANGE
        big = max(A.max(), -A.min())
        if not (0 < big < lo or hi < big < math.inf):
            return None
        return np.ldexp(1.0, np.frexp(big)[1])
    return power_of_two_scale(np.maximum(A.max(axis=(-1, -2)), -A.min(axis=(-1, -2))))


def power_of_two_scale(big: np.ndarray) -> np.ndarray | None:
    """For each largest |entry| ``big`` (any shape) of a group of rows, the power of two
    about it where it lies outside :data:`ROW_SCALE_RANGE` (and is nonzero and finite),
    1.0 elsewhere; None when no entry needs scaling. Dividing the rows by it is exact.
    :func:`row_scale` and :func:`roverimpact.frictional_impact` scale by it."""
    lo, hi = ROW_SCALE_RANGE
    with np.errstate(invalid="ignore"):
        out = (big > 0) & np.isfinite(big) & ((big < lo) | (big > hi))
    if not out.any():
        return None
    return np.where(out, np.ldexp(1.0, np.frexp(np.where(out, big, 1.0))[1]), 1.0)


def _size(shape: tuple[int, ...]) -> int:
    return math.prod(shape)


_ZERO_INDEX = np.zeros(1, dtype=np.int64)
_ZERO_INDEX.flags.writeable = False


def flat_index(shape: tuple[int, ...], batch: tuple[int, ...]) -> np.ndarray:
    """Flat index into an input of batch ``shape`` for every item of the broadcast ``batch``."""
    if shape == batch:  # no broadcasting (includes the unbatched case)
        return _ZERO_INDEX if batch == () else np.arange(_size(batch), dtype=np.int64)
    idx = np.arange(_size(shape), dtype=np.int64).reshape(shape)
    return np.ascontiguousarray(np.broadcast_to(idx, batch).reshape(-1))


def _raise_status(status, M, A, v, iM, iA, iv, batch):
    bad = int(np.flatnonzero(status)[0])
    code = int(status[bad])
    if code in (_validation.STATUS_NONFINITE_M, _validation.STATUS_ASYMMETRIC_M,
                _validation.STATUS_NOT_PD):
        raise _validation.mass_matrix_error(M, int(iM[bad]), code)
    name, arr, flat, core = (
        ("A", A, iA[bad], 2) if code == _validation.STATUS_NONFINITE_A else ("v", v, iv[bad], 1)
    )
    own = arr.shape[: arr.ndim - core]
    idx = tuple(int(i) for i in np.unravel_index(int(flat), own)) if own else ()
    raise InputError(f"{name} contains NaN or inf ({fmt_index(idx)})")


#: The largest kinetic energy 1/2 v^T M v the partition computes [J], about 9e307: half
#: the largest float64, since 2 T = |L^T v|^2 (M = L L^T) must be one.
T_LIMIT = float(np.finfo(np.float64).max) / 2


#: an energy gain above this fraction of T^- is warned about (round-off stays far below)
GAIN_RTOL = 1e-9


def warn_energy_gain(Tm: np.ndarray, Tp: np.ndarray, batch: tuple, cause: str) -> None:
    """EnergyGainWarning when an impact ends with more kinetic energy than it began with
    (``T^+ > T^-`` by more than :data:`GAIN_RTOL` of ``T^-``; one flat item each), naming
    the count and the largest gain; ``cause`` says which law does it and what to use."""
    gain = Tp - Tm
    bad = gain > GAIN_RTOL * Tm
    if not bad.any():
        return
    worst = int(np.argmax(np.where(bad, gain, -np.inf)))
    idx = tuple(int(i) for i in np.unravel_index(worst, batch)) if batch else ()
    count = f"{int(bad.sum())} of {bad.size} items, " if bad.size > 1 else ""
    warnings.warn(f"the impact adds kinetic energy ({count}{fmt_index(idx)}: T+ = "
                  f"{float(Tp[worst]):.4g} J from T- = {float(Tm[worst]):.4g} J): {cause}",
                  EnergyGainWarning, stacklevel=3)


def raise_overflow(T, M, v, iM, iv, batch):
    """One InputError for the first item whose energy ``T`` is not finite (finite M and
    v, but 1/2 v^T M v above ``T_LIMIT``): its T_c, T_a and v_c are inf or NaN."""
    bad = int(np.flatnonzero(~np.isfinite(T))[0])
    n = M.shape[-1]
    Mi = M.reshape(-1, n, n)[int(iM[bad])]
    vi = v.reshape(-1, n)[int(iv[bad])]
    where = fmt_index(tuple(int(i) for i in np.unravel_index(bad, batch))) + ", " if batch else ""
    raise InputError(
        f"the kinetic energy 1/2 v^T M v overflows float64 ({where}max |M_ij| = "
        f"{np.abs(Mi).max():.3g}, max |v_i| = {np.abs(vi).max():.3g}): it must stay below "
        f"{T_LIMIT:.2g} J, about max|M_ij| * max|v_i|^2 * n < 1e308; check the units of "
        "M and v"
    )


def scalarize(x: np.ndarray, batch: tuple[int, ...]):
    return x.reshape(-1)[0] if batch == () else x.reshape(batch)


def partition(M, A, v, *, rtol: float = RTOL, want_velocities: bool = True) -> Partition:
    r"""Split the kinetic energy into its constrained and admissible parts.

    .. math::

        P_c = M^{-1} A^T (A M^{-1} A^T)^{+} A,\quad v_c = P_c v,\quad
        T_c = \tfrac12 v_c^T M v_c,\quad T_a = T - T_c

    Parameters
    ----------
    M : (..., n, n) array_like
        Symmetric positive-definite mass matrix [kg, kg m, kg m^2 by coordinate].
    A : (..., m, n) array_like, or (n,) for a single row
        Constraint Jacobian: the rows of ``A v = 0``, the impact normal included.
        Rows may be redundant or dependent (closed loops, several ground contacts).
    v : (..., n) array_like
        Generalized velocity just before the impact.
    rtol : float, optional
        Relative tolerance of the rank decision. Rows are whitened (``L^{-1} a_i^T``,
        ``M = L L^T``) and normalised; a pivot of the rank-revealing QR below ``rtol``
        marks a row as dependent on the others, and a row whose whitened norm is below
        ``rtol`` times the largest is treated as zero.
    want_velocities : bool, optional
        Compute ``v_c`` and ``v_a`` (default). ``False`` skips them for speed; the
        fields are then ``None``.

    Returns
    -------
    Partition
        ``T``, ``T_c``, ``T_a``, ``v_c``, ``v_a``, ``rank``; batch shape is the broadcast
        of the batch shapes of ``M``, ``A`` and ``v``.

    Raises
    ------
    InputError
        For mismatched shapes, NaN or inf, a non-symmetric or non-positive-definite
        ``M`` (naming the input and the batch index), and finite inputs whose kinetic
        energy overflows float64: accepted are ``M`` and ``v`` with
        ``1/2 v^T M v`` below ``T_LIMIT`` (about 9e307 J; roughly
        ``max|M_ij| * max|v_i|**2 * n < 1e308``), so the results are always finite.

    Notes
    -----
    With ``M = L L^T`` and ``u = L^T v``, :math:`T_c = \tfrac12 |\Pi u|^2` where
    :math:`\Pi` is the orthogonal projector onto the range of :math:`W = L^{-1}A^T`.
    :math:`\Pi` is built from an orthonormal basis of :math:`W`'s columns, so dependent
    rows of :math:`A` are dropped by a rank-revealing factorisation instead of inverting a
    singular :math:`A M^{-1} A^T`. Batches of at least ``LANES_MIN_BATCH`` items run 8 at a
    time in SIMD lanes (Gram-Schmidt twice in row order); an item with nearly dependent
    rows (a kept residual below 1e-4) is recomputed with a Householder QR with column
    pivoting, which smaller batches use throughout. Both give the same result to rounding.
    Rows of any finite scale are taken: an item whose rows come out of rank 0 with nonzero
    entries far from order 1 (beyond ``ROW_SCALE_RANGE``; their squared whitened norms
    under- or overflowed) is recomputed with its rows divided by one power of two.

    Examples
    --------
    A point mass of 2 kg moving at (3, 4) m/s, constrained along x:

    >>> import numpy as np, roverimpact as ri
    >>> p = ri.partition(2 * np.eye(2), [[1.0, 0.0]], [3.0, 4.0])
    >>> round(float(p.T), 12), round(float(p.T_c), 12), round(float(p.T_a), 12), int(p.rank)
    (25.0, 9.0, 16.0, 1)
    """
    try:
        ok = 0.0 < rtol < 1.0  # NaN and inf fail it too
    except (TypeError, ValueError):  # None, a string, an array
        ok = False
    if not ok:
        rtol = _validation.check_rtol(rtol)  # says what is wrong (or a 1-item array)
    if (type(M) is _NDARRAY and type(A) is _NDARRAY and type(v) is _NDARRAY
            and M.ndim == 2 and A.ndim == 2 and v.ndim == 1
            and M.dtype is _F8 and A.dtype is _F8 and v.dtype is _F8):
        if not (M.flags.carray and A.flags.carray and v.flags.carray):
            # not C contiguous and aligned (a transpose, a column slice), or read-only
            # (carray: C, aligned and writeable, one flag read instead of two): a C copy
            # costs a microsecond, numba refusing the layout about 80, and the kernel's
            # entry point takes C arrays only
            M, A, v = (np.require(x, requirements="CA") for x in (M, A, v))
        try:  # one system: the kernel on the arrays as they are
            single = _partition_single(M, A, v, rtol, want_velocities)
        except _NOT_ONE_SYSTEM:  # an argument numba refuses all the same
            single = None
        if single is not None:
            return single
    elif (type(M) is _NDARRAY and type(A) is _NDARRAY and type(v) is _NDARRAY
            and M.dtype is _F8 and A.dtype is _F8 and v.dtype is _F8):
        # a batch below LANES_MIN_BATCH items of one batch shape (or with one M, A or v
        # for all items): the one-item kernel without the broadcasting bookkeeping
        small = _partition_small(M, A, v, float(rtol), bool(want_velocities))
        if small is not None:
            return small
    if v is None:
        raise InputError("v is required: the generalized velocity (..., n)")
    M, A, v, batch, n, m = prepare(M, A, v)
    p = _partition_batch(M, A, v, batch, n, m, float(rtol), bool(want_velocities))
    if m and np.size(p.rank) and np.min(p.rank) == 0:
        # Rank 0 with rows: zero rows, or rows far from order 1 whose squared whitened norms
        # under- or overflowed (every row then counts as zero). Those are scaled, and only
        # then: a check of every item's rows on every call costs more than the rare case.
        scale = row_scale(A)
        if scale is not None:
            p = _partition_batch(M, A / scale[..., None, None], v, batch, n, m, float(rtol),
                                 bool(want_velocities))
    return p


def _partition_batch(M, A, v, batch, n, m, rtol, want_velocities) -> Partition:
    """:func:`partition` of checked arrays of broadcast batch shape ``batch``."""
    Mf = np.ascontiguousarray(M.reshape(_size(M.shape[:-2]), n, n))
    Af = np.ascontiguousarray(A.reshape(_size(A.shape[:-2]), m, n))
    vf = np.ascontiguousarray(v.reshape(_size(v.shape[:-1]), n))
    iM = flat_index(M.shape[:-2], batch)
    iA = flat_index(A.shape[:-2], batch)
    iv = flat_index(v.shape[:-1], batch)
    nb = iM.shape[0]
    if nb < LANES_MIN_BATCH:
        return _partition_items(M, A, v, Mf, Af, vf, iM, iA, iv, batch, rtol,
                                want_velocities)
    T, Tc, Ta = np.empty((3, nb))
    rank = np.empty(nb, dtype=np.int64)
    status = np.zeros(nb, dtype=np.int64)
    vc, va = (np.empty((nb, n)), np.empty((nb, n))) if want_velocities else (_NO_OUT, _NO_OUT)
    lanes_kernel(nb)(Mf, Af, vf, iM, iA, iv, rtol, want_velocities, T, Tc, Ta, vc, va, rank,
                     status)
    _check_items(status, T, Tc, M, A, v, iM, iA, iv, batch)
    if want_velocities:
        v_c, v_a = vc.reshape(*batch, n), va.reshape(*batch, n)
    else:
        v_c = v_a = None
    return Partition(
        T=scalarize(T, batch),
        T_c=scalarize(Tc, batch),
        T_a=scalarize(Ta, batch),
        v_c=v_c,
        v_a=v_a,
        rank=scalarize(rank, batch),
    )


def _check_items(status, T, Tc, M, A, v, iM, iA, iv, batch) -> None:
    """The checks of a batch's results, for both kernels: the first item whose status is
    not ``STATUS_OK`` raises its error, then the first item whose energy overflows."""
    if np.count_nonzero(status):  # (a third of status.any()'s time)
        _raise_status(status.astype(np.int64, copy=False), M, A, v, iM, iA, iv, batch)
    total = T + Tc
    if not np.isfinite(total).all():
        raise_overflow(total, M, v, iM, iv, batch)


def _partition_items(M, A, v, Mf, Af, vf, iM, iA, iv, batch, rtol, want_velocities):
    """:func:`partition` of a batch below ``LANES_MIN_BATCH`` items: the one-item kernel
    item by item, its results returned as views of its output rows (``v_a`` as the kernel
    computed it, ``v - v_c`` item by item), not copied out column by column
    (``benchmarks/bench_single.py`` times 2 and 17 items). The same numbers, checks and
    errors as the lane path."""
    nb, n, m = iM.shape[0], Mf.shape[-1], Af.shape[-2]
    index = np.empty((3, nb), dtype=np.int64)
    index[0], index[1], index[2] = iM, iA, iv
    V = _one.OUT_V
    out = np.empty((nb, V + 2 * n if want_velocities else V))
    _one.partition_kernel.get(nb)(Mf.reshape(-1, n), Af.reshape(-1, n), vf.reshape(-1),
                                  index, m, rtol, want_velocities, out)
    _check_items(out[:, _one.OUT_STATUS], out[:, _one.OUT_T], out[:, _one.OUT_TC], M, A, v,
                 iM, iA, iv, batch)
    return _rows_partition(out, out[:, _one.OUT_RANK].astype(np.int64), n, batch,
                           want_velocities)


def _rows_partition(out, rank, n, batch, want_velocities) -> Partition:
    """The :class:`Partition` of the one-item kernel's output rows ``out`` (nb items of
    batch shape ``batch``) and their ranks: views of ``out``'s columns, not copies
    (reshaped to ``batch`` where it has more than one axis)."""
    V = _one.OUT_V
    T, Tc, Ta = out[:, _one.OUT_T], out[:, _one.OUT_TC], out[:, _one.OUT_TA]
    if want_velocities:
        v_c, v_a = out[:, V:V + n], out[:, V + n:]
    else:
        v_c = v_a = None
    if len(batch) != 1:  # one axis: the columns already have the batch's shape
        T, Tc, Ta, rank = (scalarize(x, batch) for x in (T, Tc, Ta, rank))
        if want_velocities:
            v_c, v_a = v_c.reshape(*batch, n), v_a.reshape(*batch, n)
    return _new_partition(T, Tc, Ta, v_c, v_a, rank)


def _partition_small(M, A, v, rtol, want_velocities) -> Partition | None:
    """:func:`partition` of a small batch: float64 arrays M (..., n, n), A (..., m, n) and
    v (..., n) of one batch shape of 1 to ``LANES_MIN_BATCH - 1`` items (or none, for
    one M, A or v shared by all items: no other broadcasting) and m >= 1; None for
    anything else (the general path then takes it). What :func:`_partition_batch` and
    :func:`_partition_items` do for them (the same kernel on the same numbers and item
    index, the same checks and errors), without the broadcasting bookkeeping, whose
    twenty-odd small numpy calls cost most of a call of a few items (n = 18, m = 4,
    2 items: about 47 us against 7 for the kernel; ``benchmarks/bench_single.py``): the
    item index is made once per batch size and sharing, and one comparison screens the
    results: an item that fails its checks has NaN energies, and ``T`` and ``T_c`` below
    ``T_LIMIT`` (half the largest float64) make ``T + T_c`` finite; :func:`_check_items`
    runs on any other item (and raises what the general path raises, or nothing for an
    energy of exactly ``T_LIMIT``)."""
    if M.ndim < 2 or A.ndim < 2 or v.ndim < 1:
        return None
    bM, bA, bv = M.shape[:-2], A.shape[:-2], v.shape[:-1]
    batch = bM or bA or bv
    n = M.shape[-1]
    if (not batch or (bA and bA != batch) or (bv and bv != batch) or M.shape[-2] != n
            or A.shape[-1] != n or v.shape[-1] != n or n == 0):
        return None
    nb = _size(batch)
    m = A.shape[-2]
    if not (0 < nb < LANES_MIN_BATCH and m):
        return None
    if M.flags.c_contiguous and A.flags.c_contiguous and v.flags.c_contiguous:
        Mc, Ac, vc = M, A, v
    else:  # Fortran order, transposes, slices: C copies, as _partition_batch makes
        Mc, Ac, vc = np.ascontiguousarray(M), np.ascontiguousarray(A), np.ascontiguousarray(v)
    if bM and bA and bv:
        index = _ITEMS_INDEX[nb]
        if index is None:
            index = _items_index(nb)
    else:  # one M, A or v shared by all items
        index = _SHARED_INDEX.get((nb, bool(bM), bool(bA), bool(bv)))
        if index is None:
            index = _shared_index(nb, bool(bM), bool(bA), bool(bv))
    V = _one.OUT_V
    out = np.empty((nb, V + 2 * n) if want_velocities else (nb, V))
    _one.partition_kernel.get(nb)(Mc.reshape(-1, n), Ac.reshape(-1, n), vc.reshape(-1),
                                  index, m, rtol, want_velocities, out)
    if (np.count_nonzero(out[:, _one.OUT_STATUS])
            or np.count_nonzero(out[:, _one.OUT_T:_one.OUT_TC + 1] < T_LIMIT) != 2 * nb):
        # an item failed its checks (its status; NaN energies too), or T + T_c may
        # overflow: the checks
        _check_items(out[:, _one.OUT_STATUS], out[:, _one.OUT_T], out[:, _one.OUT_TC],
                     M, A, v, index[0], index[1], index[2], batch)
    rank = out[:, _one.OUT_RANK].astype(np.int64)
    if np.count_nonzero(rank) != nb:  # zero rows, or rows far from order 1: scaled
        scale = row_scale(A)
        if scale is not None:
            return _partition_batch(M, A / scale[..., None, None], v, batch, n, m, rtol,
                                    want_velocities)
    return _rows_partition(out, rank, n, batch, want_velocities)


#: the item index ``(3, nb)`` of a batch of nb items without broadcasting (every row
#: 0 .. nb - 1), read-only, made on first use for each nb below ``LANES_MIN_BATCH``
_ITEMS_INDEX: list[np.ndarray | None] = [None] * LANES_MIN_BATCH


def _items_index(nb: int) -> np.ndarray:
    index = np.empty((3, nb), dtype=np.int64)
    index[:] = np.arange(nb, dtype=np.int64)
    index.flags.writeable = False
    _ITEMS_INDEX[nb] = index
    return index


#: the item index of a batch of nb items where some of M, A and v have no batch axes
#: (what :func:`flat_index` gives: zeros for those), by (nb, M, A, v batched)
_SHARED_INDEX: dict[tuple[int, bool, bool, bool], np.ndarray] = {}


def _shared_index(nb: int, *batched: bool) -> np.ndarray:
    index = np.zeros((3, nb), dtype=np.int64)
    for row, b in zip(index, batched, strict=True):
        if b:
            row[:] = np.arange(nb, dtype=np.int64)
    index.flags.writeable = False
    _SHARED_INDEX[(nb, *batched)] = index
    return index


#: What numba raises for arguments outside the one-system kernel's signature. Numba
#: builds that error's message from the kernel's signature, which costs tens of
#: microseconds: :func:`partition` checks the types, numbers of axes and memory layout
#: first, so batches, lists and transposes never get that far.
_NOT_ONE_SYSTEM = TypeError
_NDARRAY, _F8 = np.ndarray, np.dtype(np.float64)


def _partition_single(M, A, v, rtol, want_velocities) -> Partition | None:
    """:func:`partition` of one system given as float64 C arrays M (n, n), A (m, n),
    v (n,): the one-item kernel on the arrays as they are, without the broadcasting
    bookkeeping (the same numbers, checks and errors). Raises ``_NOT_ONE_SYSTEM`` (numba's,
    for another layout) or returns None (other shapes; rank 0 of rows far from order 1,
    which the general path scales) where the general path must take over. The kernel
    returns the energies and the rank (Python floats, made numpy scalars here as the
    batched path gives them) and writes only the velocities, when wanted.

    M, A and v must be float64 C arrays of those dimensions, aligned: the kernel is
    called through its entry point (:meth:`._kernels._jit.Kernel.unchecked`)."""
    kernel = _ONE.entry or _ONE.unchecked(1)
    if want_velocities:
        n = len(M)  # other shapes: the kernel says so
        out = np.empty((1, 2 * n))
        status, T, Tc, Ta, r = kernel(M, A, v, _ZERO_INDEX3, -1, rtol, True, out)
    else:
        status, T, Tc, Ta, r = kernel(M, A, v, _ZERO_INDEX3, -1, rtol, False, _NO_OUT)
    if status:
        if status == _one.STATUS_SHAPE:
            return None
        _raise_status(np.array([status], dtype=np.int64), M, A, v, _ZERO_INDEX, _ZERO_INDEX,
                      _ZERO_INDEX, ())
    if not math.isfinite(T + Tc):
        raise_overflow(np.array([T + Tc]), M, v, _ZERO_INDEX, _ZERO_INDEX, ())
    r = int(r)
    if not r and row_scale(A) is not None:
        return None  # rank 0 of rows far from order 1: partition scales them
    try:
        rank = _RANKS[r]
    except IndexError:
        rank = np.int64(r)
    if want_velocities:
        row = out[0]
        return _new_partition(_F64(T), _F64(Tc), _F64(Ta), row[:n], row[n:], rank)
    return _new_partition(_F64(T), _F64(Tc), _F64(Ta), None, None, rank)


#: the one-item partition kernel (:class:`._kernels._jit.Kernel`)
_ONE = _one.partition_kernel
_ZERO_INDEX3 = np.zeros((3, 1), dtype=np.int64)
_ZERO_INDEX3.flags.writeable = False
#: the velocity outputs (the one-system kernel's ``out``, the lane kernel's ``vc`` and
#: ``va``) when no velocities are wanted: the kernels do not write them then
_NO_OUT = np.empty((1, 0))
_F64 = np.float64
#: ranks as numpy integers, as the batched path gives them, made once (a new np.int64
#: per call costs a tenth of the call)
_RANKS = tuple(np.int64(r) for r in range(65))


def _new_partition(T, T_c, T_a, v_c, v_a, rank) -> Partition:
    """``Partition(T, T_c, T_a, v_c, v_a, rank)`` without the frozen dataclass's
    ``__init__``, which sets each field through ``object.__setattr__`` (0.57 against
    0.22 us a call, of about 4 us for a one-system :func:`partition`). The fields are the
    dataclass's; tests/test_energy.py checks the object equals the one ``__init__`` makes."""
    p = _object_new(Partition)
    d = p.__dict__
    d["T"] = T
    d["T_c"] = T_c
    d["T_a"] = T_a
    d["v_c"] = v_c
    d["v_a"] = v_a
    d["rank"] = rank
    return p


_object_new = object.__new__


# ----------------------------------------------------------------------------------------
# Dense reference path (numpy LAPACK): projector and effective mass, and a second method
# for the tests.
# ----------------------------------------------------------------------------------------


def whitened(M, A, rtol):
    """Cholesky factor L, whitened rows W = L^{-1} A^T and an orthonormal basis of range(W).

    Returns ``L (..., n, n)``, ``W (..., n, m)``, ``U (..., n, m)`` (left singular vectors
    of W with its columns scaled to unit length; a column below ``rtol`` times the largest
    counts as zero) and ``mask (..., m)``, the singular values above ``rtol`` times the
    largest.
    """
    _validation.check_mass_matrix(M)
    _validation.check_finite(A, "A", 2)
    L = np.linalg.cholesky(M)
    W = np.linalg.solve(L, np.swapaxes(A, -1, -2))
    cn = np.linalg.norm(W, axis=-2, keepdims=True)
    cmax = cn.max(axis=-1, keepdims=True, initial=0.0)  # no rows: 0
    keep = (cn > rtol * cmax) & (cmax > 0)
    Wn = np.where(keep, W / np.where(keep, cn, 1.0), 0.0)
    U, s, _ = np.linalg.svd(Wn, full_matrices=False)
    smax = s[..., :1] if s.shape[-1] else s
    mask = (s > rtol * np.maximum(smax, 1e-300)) & (s > 0)
    return L, W, U, mask


def projector(M, A, *, rtol: float = RTOL) -> np.ndarray:
    r"""Projector onto the subspace of constrained motion.

    .. math::  P_c = M^{-1} A^T (A M^{-1} A^T)^{+} A

    Parameters
    ----------
    M : (..., n, n) array_like
        Symmetric positive-definite mass matrix.
    A : (..., m, n) array_like, or (n,) for one row
        Constraint Jacobian; redundant or dependent rows are allowed.
    rtol : float, optional
        Relative tolerance of the rank decision, as in :func:`partition`.

    Returns
    -------
    P_c : (..., n, n) ndarray
        Satisfies ``P_c @ P_c = P_c``, ``A (I - P_c) = 0`` and ``M P_c`` symmetric.
    """
    rtol = _validation.check_rtol(rtol)
    M, A, _, batch, n, m = prepare(M, A)
    scale = row_scale(A)  # P_c depends on the span of the rows alone
    if scale is not None:
        A = A / scale[..., None, None]
    M = np.broadcast_to(M, (*batch, n, n))
    A = np.broadcast_to(A, (*batch, m, n))
    L, _, U, mask = whitened(M, A, rtol)
    Ur = U * mask[..., None, :]
    Pi = Ur @ np.swapaxes(Ur, -1, -2)  # orthogonal projector on range(W)
    # P_c = L^{-T} Pi L^T
    LT = np.swapaxes(L, -1, -2)
    return np.linalg.solve(LT, Pi @ LT)


def _solve_lower(L, X):
    """``L^{-1} X`` for ``L (..., n, n)`` and ``X (..., n, m)``; one solve for all of ``X``
    when ``L`` has no batch axes (a shared mass matrix)."""
    if L.ndim == 2:
        n = L.shape[0]
        Xn = np.moveaxis(X, -2, 0)
        Y = np.linalg.solve(L, Xn.reshape(n, -1)).reshape(Xn.shape)
        return np.moveaxis(Y, 0, -2)
    return np.linalg.solve(L, X)


def _scaled_held(B):
    """Held rows ``B (..., p, n)`` divided by :func:`row_scale`'s power of two per item when
    they are far from order 1: the mobility they leave depends on their span alone, and
    rows of entries about 1e-200 or 1e200 were ignored (their whitened norms under- or
    overflowed: m_eff_free for m_eff) by the kernel and the SVD, not by :func:`partition`."""
    scale = row_scale(B)
    return B if scale is None else B / scale[..., None, None]


def _held_complement(L, W, held, rtol):
    """Whitened rows ``W (..., n, m)`` minus their part in range(L^{-1} B^T), B = ``held``."""
    B = as_array(held, "held", min_ndim=1)
    if B.ndim == 1:
        B = B[None, :]
    n = W.shape[-2]
    if B.shape[-1] != n:
        raise InputError(f"held must have shape (..., p, n) with n = {n}, got {B.shape}")
    _validation.check_finite(B, "held", 2)
    broadcast_batch(**{"M and A": W.shape[:-2], "held": B.shape[:-2]})
    if B.shape[-2] == 0:
        return W
    B = _scaled_held(B)
    # one basis per distinct B: an unbatched B (e.g. the other rows of a sweep over the
    # obstacle normal) with a shared M is factorised once for the whole batch
    WB = _solve_lower(L, np.swapaxes(B, -1, -2))
    cn = np.linalg.norm(WB, axis=-2, keepdims=True)
    cmax = cn.max(axis=-1, keepdims=True)
    WB = np.where(cn > rtol * cmax, WB / np.where(cn > 0, cn, 1.0), 0.0)
    U, sv, _ = np.linalg.svd(WB, full_matrices=False)
    keep = sv > 1e-9 * np.maximum(sv[..., :1], 1e-300)
    U = U * keep[..., None, :]
    return W - U @ (np.swapaxes(U, -1, -2) @ W)


def row_masses(M, a, held=None, *, rtol: float = RTOL):
    r"""Effective masses of single rows with and without held rows, in one pass.

    ``(m_eff, m_eff_free)``: :func:`effective_mass` ``(M, a, held=held,
    single_row=True)`` and ``(M, a, single_row=True)`` (``m_eff`` is ``m_eff_free``
    without ``held``), from one factorisation of each mass matrix: with
    :math:`w = L^{-1} a^T` (:math:`M = L L^T`), :math:`a M^{-1} a^T = |w|^2`, and
    :math:`a N a^T` is twice the admissible energy :math:`T_a` that :func:`partition`
    gives the velocity :math:`M^{-1} a^T` with the rows ``held`` (the same checks and rank
    decision). Batches of ``LANES_MIN_BATCH`` items or more run in the compiled kernel
    :mod:`roverimpact._kernels.masses` (the factor reused while consecutive items share
    ``M``); smaller ones compute ``w`` and :math:`M^{-1} a^T` with numpy's LAPACK and
    call :func:`partition`. Both agree to rounding (``tests/test_energy.py``).

    Parameters
    ----------
    M : (..., n, n) array_like
        Symmetric positive-definite mass matrices.
    a : (..., n) array_like
        One row per batch item.
    held : (..., p, n) or (n,) array_like, optional
        Rows held persistent through the impact (redundant rows allowed).
    rtol : float, optional
        Relative tolerance of the rank decision of the held rows, as in :func:`partition`.

    Returns
    -------
    m_eff, m_eff_free : float or (...) ndarray
        [kg] for unit directions of a point velocity; ``inf`` where the held rows block
        ``a`` (:math:`a N a^T \le 10^{-12}\, a M^{-1} a^T`).

    Raises
    ------
    InputError
        For bad shapes, NaN or inf, a ``M`` that is not symmetric positive definite
        (naming the input and the batch index) and a row ``a`` that is zero.
    """
    rtol = _validation.check_rtol(rtol)
    M, a, _, _, n, _ = prepare(M, as_array(a, "a", min_ndim=1)[..., None, :])
    a = a[..., 0, :]
    _validation.check_finite(a, "A", 1)
    if held is None:
        B = np.zeros((0, n))
    else:
        B = as_array(held, "held", min_ndim=1)
        if B.ndim == 1:
            B = B[None, :]
        if B.shape[-1] != n:
            raise InputError(f"held must have shape (..., p, n) with n = {n}, got {B.shape}")
        _validation.check_finite(B, "held", 2)
        B = _scaled_held(B)
    batch = broadcast_batch(M=M.shape[:-2], A=a.shape[:-1], held=B.shape[:-2])
    grams = None
    if _size(batch) < LANES_MIN_BATCH:
        grams = _row_grams_small(M, a, B, batch, n, rtol)
    if grams is None:
        grams = _row_grams_kernel(M, a, B, batch, n, rtol)
    g_free, g = grams
    with np.errstate(divide="ignore", over="ignore"):
        m_eff_free = 1.0 / g_free
    if not np.all(np.isfinite(m_eff_free) & (g_free > 0.0)):
        bad = np.flatnonzero(~(np.isfinite(m_eff_free) & (g_free > 0.0)))[0]
        idx = tuple(int(i) for i in np.unravel_index(bad, batch)) if batch else ()
        row = np.broadcast_to(a, (*batch, n)).reshape(-1, n)[bad]
        if not row.any():
            raise InputError(f"A is a zero row ({fmt_index(idx)}): no direction to measure")
        # a nonzero row whose a M^-1 a^T underflows: m_eff is beyond float64
        raise InputError(f"m_eff = 1 / (a M^-1 a^T) of row A overflows float64 "
                         f"({fmt_index(idx)}, max |a_i| = {np.abs(row).max():.3g}): check "
                         "the units of M and A")
    if B.shape[-2] == 0:  # nothing held: the same number, not its rounding through T_a
        m_eff = m_eff_free
    else:
        blocked = g <= 1e-12 * g_free
        with np.errstate(divide="ignore"):
            m_eff = np.where(blocked, np.inf, 1.0 / np.where(blocked, 1.0, g))
    return scalarize(m_eff, batch), scalarize(m_eff_free, batch)


def _row_grams_kernel(M, a, B, batch, n, rtol):
    """``a M^-1 a^T`` and ``a N a^T`` (flat over ``batch``) by the compiled kernel
    :func:`roverimpact._kernels.masses.masses_kernel`; M's checks raise here (``a`` and
    ``B`` are checked finite)."""
    p = B.shape[-2]
    index = np.empty((3, _size(batch)), dtype=np.int64)
    iM = index[0] = flat_index(M.shape[:-2], batch)
    index[1] = flat_index(a.shape[:-1], batch)
    index[2] = flat_index(B.shape[:-2], batch)
    out = np.empty((index.shape[1], 4))
    _masses.masses_kernel.get(index.shape[1])(
        np.ascontiguousarray(M.reshape(-1, n)), np.ascontiguousarray(a.reshape(-1, n)),
        np.ascontiguousarray(B.reshape(-1, n)), index, p, float(rtol), out)
    status = out[:, _masses.OUT_STATUS]
    if np.count_nonzero(status):
        bad = int(np.flatnonzero(status)[0])
        code = int(status[bad])
        if code in (_validation.STATUS_NONFINITE_M, _validation.STATUS_ASYMMETRIC_M,
                    _validation.STATUS_NOT_PD):
            raise _validation.mass_matrix_error(M, int(iM[bad]), code)
        # a and B are finite: a M^-1 a^T or M^-1 a^T overflowed
        where = fmt_index(tuple(int(i) for i in np.unravel_index(bad, batch)) if batch else ())
        raise InputError(f"a M^-1 a^T of row A overflows float64 ({where}): check the units "
                         "of M and A")
    return out[:, _masses.OUT_FREE], out[:, _masses.OUT_HELD]


def _row_grams_small(M, a, B, batch, n, rtol):
    """What :func:`_row_grams_kernel` gives, for a batch below ``LANES_MIN_BATCH`` items,
    without that kernel (whose compile a fresh install's one-scenario commands would
    pay; ``benchmarks/bench_startup.py --kernels``): ``w = L^{-1} a^T`` and ``v = L^{-T} w``
    by numpy's LAPACK, ``a N a^T = 2 T_a`` of :func:`partition` ``(M, B, v)`` (the kernel's
    steps, the same rank decision; tested to agree to rounding), which also checks ``M``
    (without held rows too: ``B`` then has none). None where numpy's Cholesky fails or
    a number overflows (the kernel then names the problem)."""
    try:
        L = np.linalg.cholesky(np.broadcast_to(M, (*batch, n, n)))
    except np.linalg.LinAlgError:
        return None
    with np.errstate(over="ignore", invalid="ignore"):
        w = np.linalg.solve(L, np.broadcast_to(a, (*batch, n))[..., None])
        g_free = np.sum(w[..., 0] * w[..., 0], axis=-1).reshape(-1)
        v = np.linalg.solve(np.swapaxes(L, -1, -2), w)[..., 0]
    if not (np.isfinite(g_free).all() and np.isfinite(v).all()):
        return None
    p = partition(M, B, v, rtol=rtol, want_velocities=False)
    return g_free, 2.0 * np.reshape(p.T_a, -1)


def effective_mass(M, A, *, held=None, single_row: bool | None = None, rtol: float = RTOL):
    r"""Effective mass of the constrained directions, :math:`(A M^{-1} A^T)^{-1}`.

    For one row :math:`a` (a unit contact normal mapped to generalized coordinates) this
    is the scalar :math:`m_{eff} = 1 / (a M^{-1} a^T)`: the mass a point would need to
    have to carry the same kinetic energy along that direction. If the rows of ``A`` are
    dependent, the Moore-Penrose pseudo-inverse is returned (it maps constraint-space
    velocity changes to the minimum-norm impulses).

    With ``held`` rows :math:`B` (other contacts, loop closures, locked joints that
    persist through the impact), the mobility is the one left by :math:`B v = 0`:

    .. math::  m_{eff} = (A N A^T)^{-1}, \qquad
               N = M^{-1} - M^{-1} B^T (B M^{-1} B^T)^{+} B M^{-1},

    and a single row that :math:`B` already blocks (:math:`a N a^T \le 10^{-12}\,
    a M^{-1} a^T`) has :math:`m_{eff} = \infty`.

    Single rows (a 1-D ``A``, or ``single_row``) are computed by :func:`row_masses` (the
    held rows' rank decided as in :func:`partition`); several rows by numpy's Cholesky
    and SVD.

    Parameters
    ----------
    M : (..., n, n) array_like
        Symmetric positive-definite mass matrix.
    A : (..., m, n) array_like, or (n,) for one row
        Constraint rows. A 1-D ``A`` returns a scalar (per batch item).
    held : (..., p, n) array_like, optional
        Rows held persistent through the impact; redundant rows allowed. A ``held``
        without batch axes (several rows) is factorised once for the whole batch.
    single_row : bool, optional
        Read ``A`` as a batch of single rows ``(..., n)`` (one scalar per batch item);
        default: only a 1-D ``A`` is a single row.
    rtol : float, optional
        Relative tolerance of the rank decision, as in :func:`partition`.

    Returns
    -------
    m_eff : (..., m, m) ndarray, or (...) for a 1-D ``A``
        In kg if the rows are unit directions of a point velocity [m/s].

    Raises
    ------
    InputError
        For bad ``M``, ``A`` or ``held`` and for a single row that is zero (no direction).

    Examples
    --------
    A 3 kg point mass along a unit direction, then with its vertical motion held:

    >>> import numpy as np, roverimpact as ri
    >>> round(float(ri.effective_mass(3 * np.eye(3), [0.0, 0.6, 0.8])), 12)
    3.0
    >>> round(float(ri.effective_mass(3 * np.eye(3), [0.0, 0.6, 0.8], held=[0, 0, 1])), 12)
    8.333333333333
    """
    rtol = _validation.check_rtol(rtol)
    A = as_array(A, "A", min_ndim=1)
    single = A.ndim == 1 if single_row is None else bool(single_row)
    if single:
        m_eff, m_eff_free = row_masses(M, A, held, rtol=rtol)
        return m_eff_free if held is None else m_eff
    M, A, _, batch, n, m = prepare(M, A)
    _validation.check_mass_matrix(M)        # on M's own batch shape: a shared M once
    _validation.check_finite(A, "A", 2)
    L = np.linalg.cholesky(M)
    W = np.broadcast_to(_solve_lower(L, np.swapaxes(A, -1, -2)), (*batch, n, m))
    if held is not None:
        W = _held_complement(L, W, held, rtol)
    _, s, Vt = np.linalg.svd(W, full_matrices=False)
    smax = s[..., :1]
    keep = s > rtol * np.maximum(smax, 1e-300)
    inv_s2 = np.where(keep, 1.0 / np.where(keep, s, 1.0) ** 2, 0.0)
    V = np.swapaxes(Vt, -1, -2)
    return (V * inv_s2[..., None, :]) @ Vt
