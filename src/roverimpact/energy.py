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
from dataclasses import dataclass

import numpy as np

from . import _checks
from ._checks import InputError, as_array, broadcast_batch, fmt_index
from ._kernels import lanes_kernel, partition_kernel

#: Default relative tolerance of the rank decision (see :func:`partition`).
RTOL = 1e-9

#: Batches with at least this many items use the lane-parallel kernel (8 items per SIMD
#: block); smaller ones the one-item-at-a-time kernel.
LANES_MIN_BATCH = 16

__all__ = ["RTOL", "Partition", "effective_mass", "partition", "projector"]


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


def _prepare(M, A, v=None):
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


def _size(shape: tuple[int, ...]) -> int:
    return math.prod(shape)


_ZERO_INDEX = np.zeros(1, dtype=np.int64)
_ZERO_INDEX.flags.writeable = False


def _flat_index(shape: tuple[int, ...], batch: tuple[int, ...]) -> np.ndarray:
    """Flat index into an input of batch ``shape`` for every item of the broadcast ``batch``."""
    if shape == batch:  # no broadcasting (includes the unbatched case)
        return _ZERO_INDEX if batch == () else np.arange(_size(batch), dtype=np.int64)
    idx = np.arange(_size(shape), dtype=np.int64).reshape(shape)
    return np.ascontiguousarray(np.broadcast_to(idx, batch).reshape(-1))


def _raise_status(status, M, A, v, iM, iA, iv, batch):
    bad = int(np.flatnonzero(status)[0])
    code = int(status[bad])
    if code in (_checks.STATUS_NONFINITE_M, _checks.STATUS_ASYMMETRIC_M, _checks.STATUS_NOT_PD):
        raise _checks.mass_matrix_error(M, int(iM[bad]), code)
    name, arr, flat, core = (
        ("A", A, iA[bad], 2) if code == _checks.STATUS_NONFINITE_A else ("v", v, iv[bad], 1)
    )
    own = arr.shape[: arr.ndim - core]
    idx = tuple(int(i) for i in np.unravel_index(int(flat), own)) if own else ()
    raise InputError(f"{name} contains NaN or inf ({fmt_index(idx)})")


def _scalarize(x: np.ndarray, batch: tuple[int, ...]):
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
        ``M`` (naming the input and the batch index).

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

    Examples
    --------
    A point mass of 2 kg moving at (3, 4) m/s, constrained along x:

    >>> import numpy as np, roverimpact as ri
    >>> p = ri.partition(2 * np.eye(2), [[1.0, 0.0]], [3.0, 4.0])
    >>> round(float(p.T), 12), round(float(p.T_c), 12), round(float(p.T_a), 12), int(p.rank)
    (25.0, 9.0, 16.0, 1)
    """
    if not (math.isfinite(rtol) and 0.0 < rtol < 1.0):
        raise InputError(f"rtol must be in (0, 1), got {rtol}")
    M, A, v, batch, n, m = _prepare(M, A, v)
    Mf = np.ascontiguousarray(M.reshape(_size(M.shape[:-2]), n, n))
    Af = np.ascontiguousarray(A.reshape(_size(A.shape[:-2]), m, n))
    vf = np.ascontiguousarray(v.reshape(_size(v.shape[:-1]), n))
    iM = _flat_index(M.shape[:-2], batch)
    iA = _flat_index(A.shape[:-2], batch)
    iv = _flat_index(v.shape[:-1], batch)
    nb = iM.shape[0]
    T, Tc, Ta = np.empty((3, nb))
    rank = np.empty(nb, dtype=np.int64)
    status = np.zeros(nb, dtype=np.int64)
    vc = np.empty((nb, n)) if want_velocities else np.empty((0, n))
    kernel = lanes_kernel() if nb >= LANES_MIN_BATCH else partition_kernel
    kernel(Mf, Af, vf, iM, iA, iv, float(rtol), bool(want_velocities), T, Tc, Ta, vc, rank,
           status)
    if (status[0] if nb == 1 else status.any()):
        _raise_status(status, M, A, v, iM, iA, iv, batch)
    if want_velocities:
        v_c = vc.reshape(*batch, n)
        v_a = (v if v.shape == v_c.shape else np.broadcast_to(v, v_c.shape)) - v_c
    else:
        v_c = v_a = None
    return Partition(
        T=_scalarize(T, batch),
        T_c=_scalarize(Tc, batch),
        T_a=_scalarize(Ta, batch),
        v_c=v_c,
        v_a=v_a,
        rank=_scalarize(rank, batch),
    )


# ----------------------------------------------------------------------------------------
# Dense reference path (numpy LAPACK): projector and effective mass, and a second method
# for the tests.
# ----------------------------------------------------------------------------------------


def _whitened(M, A, rtol):
    """Cholesky factor L, whitened rows W = L^{-1} A^T and an orthonormal basis of range(W).

    Returns ``L (..., n, n)``, ``U (..., n, m)`` (left singular vectors of W), ``s``
    (singular values of W with dependent directions set to 0) and the rank.
    """
    _checks.check_mass_matrix(M)
    _checks.check_finite(A, "A", 2)
    L = np.linalg.cholesky(M)
    W = np.linalg.solve(L, np.swapaxes(A, -1, -2))
    cn = np.linalg.norm(W, axis=-2, keepdims=True)
    cmax = cn.max(axis=-1, keepdims=True)
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
    M, A, _, batch, n, m = _prepare(M, A)
    M = np.broadcast_to(M, (*batch, n, n))
    A = np.broadcast_to(A, (*batch, m, n))
    L, _, U, mask = _whitened(M, A, rtol)
    Ur = U * mask[..., None, :]
    Pi = Ur @ np.swapaxes(Ur, -1, -2)  # orthogonal projector on range(W)
    # P_c = L^{-T} Pi L^T
    LT = np.swapaxes(L, -1, -2)
    return np.linalg.solve(LT, Pi @ LT)


def effective_mass(M, A, *, rtol: float = RTOL):
    r"""Effective mass of the constrained directions, :math:`(A M^{-1} A^T)^{-1}`.

    For one row :math:`a` (a unit contact normal mapped to generalized coordinates) this
    is the scalar :math:`m_{eff} = 1 / (a M^{-1} a^T)`: the mass a point would need to
    have to carry the same kinetic energy along that direction. If the rows of ``A`` are
    dependent, the Moore-Penrose pseudo-inverse is returned (it maps constraint-space
    velocity changes to the minimum-norm impulses).

    Parameters
    ----------
    M : (..., n, n) array_like
        Symmetric positive-definite mass matrix.
    A : (..., m, n) array_like, or (n,) for one row
        Constraint rows. A 1-D ``A`` returns a scalar (per batch item).
    rtol : float, optional
        Relative tolerance of the rank decision, as in :func:`partition`.

    Returns
    -------
    m_eff : (..., m, m) ndarray, or (...) for a 1-D ``A``
        In kg if the rows are unit directions of a point velocity [m/s].

    Raises
    ------
    InputError
        For bad ``M`` or ``A`` and for a single row that is zero (no direction).

    Examples
    --------
    A 3 kg point mass along a unit direction:

    >>> import numpy as np, roverimpact as ri
    >>> round(float(ri.effective_mass(3 * np.eye(3), [0.0, 0.6, 0.8])), 12)
    3.0
    """
    single = np.ndim(A) == 1
    M, A, _, batch, n, m = _prepare(M, A)
    M = np.broadcast_to(M, (*batch, n, n))
    A = np.broadcast_to(A, (*batch, m, n))
    _, W, _, _ = _whitened(M, A, rtol)
    if single:
        g = np.sum(W * W, axis=(-1, -2))
        if np.any(g == 0.0):
            idx = tuple(int(i) for i in np.argwhere(np.atleast_1d(g == 0.0))[0]) if batch else ()
            raise InputError(f"A is a zero row ({fmt_index(idx)}): no direction to measure")
        return 1.0 / g
    _, s, Vt = np.linalg.svd(W, full_matrices=False)
    smax = s[..., :1]
    keep = s > rtol * np.maximum(smax, 1e-300)
    inv_s2 = np.where(keep, 1.0 / np.where(keep, s, 1.0) ** 2, 0.0)
    V = np.swapaxes(Vt, -1, -2)
    return (V * inv_s2[..., None, :]) @ Vt
