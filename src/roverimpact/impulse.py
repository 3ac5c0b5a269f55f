r"""Impulsive (rigid-body) impact maps.

During an impact of negligible duration, positions do not change and finite forces do
no work; the velocity jumps by :math:`\Delta v = M^{-1} J^T p` where :math:`p` are the
impulses along the constraint rows :math:`J` (Newton-Euler, e.g. Pfeiffer & Glocker,
*Multibody Dynamics with Unilateral Contacts*, 1996, ch. 7).

The contact rows :math:`A` follow Newton's law of restitution,
:math:`A v^+ = -e\, A v^-` (componentwise, ``A v^- < 0`` when approaching). Persistent
rows :math:`B` (wheels that stay on the ground, loop closures, locked joints) keep zero
velocity after the impact, :math:`B v^+ = 0`.

With :math:`J = [A; B]`, :math:`G = J M^{-1} J^T` and
:math:`d = -(I + E) J v^-` (``E = diag(e, 0)``), the impulses solve :math:`G p = d`.
Dependent rows make :math:`G` singular; the minimum-norm solution
:math:`p = G^{+} d` is used, obtained from the SVD of the whitened rows
:math:`W = L^{-1} J^T` (``M = L L^T``), never from an inverse of :math:`G`.

For contact rows that share one restitution coefficient and persistent rows already at
rest, :math:`v^+ = v^- - (1 + e) P_c v^-` and the kinetic energy lost is
:math:`(1 - e^2)\, T_c^-`. With a different ``e`` per row on rows that are coupled
through :math:`M` (:math:`G` not diagonal), Newton's law applied to all of them at once
can add energy, a known defect of the law (as :mod:`roverimpact.unilateral` notes;
``tests/test_impulse.py`` has a case that gains 0.48 J of 0.52).

Every row of ``A`` is a contact that holds through the impact: a row already separating
(:math:`A_i v^- > 0`) is pulled back to :math:`-e\, A_i v^-` like any other. Which contacts
hold is :func:`roverimpact.unilateral_impact`'s decision (it reduces to this map for the
contacts it finds holding).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _validation
from ._validation import InputError, as_array, broadcast_batch, fmt_index
from .energy import (
    RTOL,
    partition,
    prepare,
    row_scale,
    scalarize,
    warn_energy_gain,
    whitened,
)

__all__ = ["ImpactResult", "impulsive_impact"]


@dataclass(frozen=True)
class ImpactResult:
    """Result of an impulsive impact.

    Attributes
    ----------
    v_plus : (..., n) ndarray
        Generalized velocity just after the impact.
    impulse : (..., m) ndarray
        Impulse along each contact row of ``A`` [N s for unit normals].
    impulse_persistent : (..., p) ndarray
        Impulse along each persistent row.
    generalized_impulse : (..., n) ndarray
        ``J^T p = M (v_plus - v)``, the generalized impulse.
    T_minus, T_plus : float or (...,) ndarray
        Kinetic energy before and after [J].
    energy_lost : float or (...,) ndarray
        ``T_minus - T_plus`` [J]: ``(1 - e^2) T_c_minus`` (never negative) when every
        contact row has the same ``e`` and the persistent rows are at rest before the
        impact; with different ``e`` on coupled rows it can be negative (module notes).
    T_c_minus : float or (...,) ndarray
        Effective kinetic energy: ``T_c`` of ``v`` with all rows ``[A; B]`` [J].
    rank : int or (...,) ndarray
        Rank of ``[A; B]``.
    """

    v_plus: np.ndarray
    impulse: np.ndarray
    impulse_persistent: np.ndarray
    generalized_impulse: np.ndarray
    T_minus: np.ndarray
    T_plus: np.ndarray
    energy_lost: np.ndarray
    T_c_minus: np.ndarray
    rank: np.ndarray


def _restitution(e, name="restitution"):
    e = as_array(e, name)
    # (..., m): the last axis is the row, not a batch axis
    _validation.check_coefficients(e, name, low=0.0, high=1.0)
    return e


def impulsive_impact(M, A, v, restitution=0.0, persistent=None, *, rtol: float = RTOL):
    r"""Rigid-body impact map with Newton restitution and persistent constraints.

    Parameters
    ----------
    M : (..., n, n) array_like
        Symmetric positive-definite mass matrix.
    A : (..., m, n) array_like, or (n,) for a single contact
        Contact rows, none all zeros; row i times ``v`` is the normal velocity of contact
        i, negative when approaching. Every row holds through the impact (module notes).
    v : (..., n) array_like
        Generalized velocity just before the impact.
    restitution : float or (..., m) array_like
        Newton's coefficient of restitution ``e`` in [0, 1], one for all rows or one per
        row: ``A v^+ = -e A v^-``.
    persistent : (..., p, n) array_like, optional
        Rows that keep zero velocity through the impact: ``B v^+ = 0``.
    rtol : float, optional
        Rank tolerance for dependent rows, as in :func:`~roverimpact.partition`.

    Returns
    -------
    ImpactResult

    Raises
    ------
    InputError
        For bad arrays, a row all zeros, ``e`` outside [0, 1], or dependent rows whose
        restitution targets contradict each other (no impulse can meet them all).

    Examples
    --------
    Two 1 kg masses on a line, the first at 2 m/s, the second at rest, e = 1: they
    exchange velocities.

    >>> import numpy as np, roverimpact as ri
    >>> r = ri.impulsive_impact(np.eye(2), [[-1.0, 1.0]], [2.0, 0.0], restitution=1.0)
    >>> np.round(r.v_plus, 12).tolist(), round(float(r.energy_lost), 12)
    ([0.0, 2.0], 0.0)
    """
    if v is None:
        raise InputError("v is required: the generalized velocity (..., n) before impact")
    M, A, v, batch, n, m = prepare(M, A, v)
    A = _validation.check_rows(A, "A", n)
    if persistent is not None:
        B = _validation.check_rows(persistent, "persistent", n)
        batch = broadcast_batch(M=M.shape[:-2], A=A.shape[:-2], v=v.shape[:-1],
                                persistent=B.shape[:-2])
    else:
        B = np.zeros((0, n))
    p = B.shape[-2]
    e = _restitution(restitution)
    if e.ndim > 0 and e.shape[-1] not in (1, m):
        raise InputError(f"restitution must be a scalar or have m = {m} values, got {e.shape}")
    e_rows = np.broadcast_to(e if e.ndim else e[None], (*e.shape[:-1], m) if e.ndim else (m,))
    batch = broadcast_batch(M=M.shape[:-2], A=A.shape[:-2], v=v.shape[:-1],
                            **({"persistent": B.shape[:-2]} if persistent is not None else {}),
                            restitution=e_rows.shape[:-1])
    _validation.check_finite(v, "v", 1)
    _validation.check_finite(B, "persistent", 2)

    Mb = np.broadcast_to(M, (*batch, n, n))
    J = np.concatenate(
        [np.broadcast_to(A, (*batch, m, n)), np.broadcast_to(B, (*batch, p, n))], axis=-2
    )
    # rows far from order 1 (entries of 1e-200 gave v+ = v, T_c_minus = 0; of 1e160 NaN)
    # divided by one power of two per item: exact, and the impulses scale back by it
    rows_scale = row_scale(J)
    if rows_scale is not None:
        J = J / rows_scale[..., None, None]
    vb = np.broadcast_to(v, (*batch, n))
    E = np.concatenate([np.broadcast_to(e_rows, (*batch, m)), np.zeros((*batch, p))], axis=-1)

    # first: refuses inputs whose kinetic energy overflows, before any arithmetic on them
    part = partition(Mb, J, vb, rtol=rtol, want_velocities=False)
    L, W, _, _ = whitened(Mb, J, rtol)
    Jv = np.einsum("...ij,...j->...i", J, vb)
    d = -(1.0 + E) * Jv
    d[..., m:] = -Jv[..., m:]  # persistent rows: B v+ = 0
    # The rank decision is partition's, on the same normalised rows, so that the impulses
    # agree with T_c_minus and rank: rows scaled to unit whitened norm (a row below rtol
    # times the largest counts as zero), the r = rank largest singular values kept. With
    # G = D G_n D (D = the row norms), G p = d is G_n (D p) = D^-1 d: p = D^-1 G_n^+ D^-1 d.
    # (An SVD of the rows as given dropped a small row, or one at a small angle to
    # another, that partition kept: energy_lost 1 J where T_c_minus was 7 J.)
    cn = np.linalg.norm(W, axis=-2)
    cmax = cn.max(axis=-1, keepdims=True, initial=0.0)
    zero = ~((cn > rtol * cmax) & (cmax > 0))
    c = np.where(cn > 0, cn, 1.0)  # a row counted as zero keeps its norm: D^-1 d checks it
    Wn = np.where(zero[..., None, :], 0.0, W / c[..., None, :])
    dn = d / c
    U, s, Vt = np.linalg.svd(Wn, full_matrices=False)
    rank = np.asarray(part.rank)[..., None]
    keep = (np.arange(s.shape[-1]) < rank) & (s > 0)
    Vtd = np.einsum("...ij,...j->...i", Vt, dn)
    # consistency: the achievable part of D^-1 d is V_r V_r^T D^-1 d
    resid = dn - np.einsum("...ji,...j->...i", Vt, np.where(keep, Vtd, 0.0))
    scale = np.maximum(np.linalg.norm(dn, axis=-1), 1e-300)
    bad = np.linalg.norm(resid, axis=-1) > 1e-8 * scale
    if np.any(bad):
        first = np.argwhere(np.atleast_1d(bad))[0]
        idx = tuple(int(i) for i in first) if batch else ()
        item = tuple(first) if batch else ()
        small = np.flatnonzero(zero[item] & (np.abs(dn[item]) > 1e-8 * scale[item]))
        if small.size:
            i = int(small[0])
            row = f"row {i} of A" if i < m else f"persistent row {i - m}"
            raise InputError(
                f"{row} is below rtol = {rtol:g} times the largest row in whitened norm "
                f"({fmt_index(idx)}) and counts as zero, as in partition, so it cannot "
                "take its restitution target: give the rows comparable scales, or a "
                "smaller rtol")
        raise InputError(
            f"the constraint rows are dependent and their restitution targets contradict "
            f"each other ({fmt_index(idx)}): give dependent rows the same restitution, "
            "or remove the redundant rows"
        )
    inv_s = np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0)
    # p_n = V S^-2 V^T D^-1 d, p = D^-1 p_n ; delta u = W p = W_n p_n = U S^-1 V^T D^-1 d
    coef = Vtd * inv_s
    imp = np.einsum("...ji,...j->...i", Vt, coef * inv_s) / c
    du = np.einsum("...ij,...j->...i", U, coef)
    LT = np.swapaxes(L, -1, -2)
    dv = np.linalg.solve(LT, du[..., None])[..., 0]
    v_plus = vb + dv
    u_minus = np.einsum("...ji,...j->...i", L, vb)  # L^T v
    u_plus = u_minus + du
    T_minus = 0.5 * np.sum(u_minus**2, axis=-1)
    T_plus = 0.5 * np.sum(u_plus**2, axis=-1)
    lost = 0.5 * np.sum(-du * (2 * u_minus + du), axis=-1)
    warn_energy_gain(np.ravel(T_minus), np.ravel(T_minus - lost), batch,
                     "Newton's restitution adds energy with different e per row when a row "
                     "is separating before the impact, or with e > 0 and persistent rows "
                     "moving before it; use one e and persistent rows at rest, or e = 0")
    gen = np.einsum("...ji,...j->...i", J, imp)
    if rows_scale is not None:
        imp = imp / rows_scale[..., None]
    return ImpactResult(
        v_plus=v_plus,
        impulse=imp[..., :m],
        impulse_persistent=imp[..., m:],
        generalized_impulse=gen,
        T_minus=scalarize(np.asarray(T_minus), batch),
        T_plus=scalarize(np.asarray(T_plus), batch),
        energy_lost=scalarize(np.asarray(lost), batch),
        T_c_minus=part.T_c,
        rank=part.rank,
    )
