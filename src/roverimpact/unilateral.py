r"""Which contacts hold through an impact: the unilateral impact problem and its active set.

:math:`T_c^-` depends on the constraint rows held at the instant of impact. A rover's
ground contacts are unilateral: some stay closed through the impact, some lift off. This
module finds them by solving the impact as a linear complementarity problem (LCP) on the
normal impulses (Moreau, Pfeiffer & Glocker 1996, ch. 7), then computes :math:`T_c^-`
with exactly the contacts that hold plus the bilateral rows.

Problem
-------
Mass matrix :math:`M` (n x n), pre-impact velocity :math:`v^-`, unilateral rows
:math:`N` (k x n: ground contacts, the obstacle; :math:`N v < 0` approaching) and
bilateral rows :math:`B` (loop closures, locked joints, persistent contacts). With
impulses :math:`p \ge 0` on :math:`N` and free :math:`q` on :math:`B`,

.. math::

    M (v^+ - v^-) = N^T p + B^T q, \qquad B v^+ = 0,

and Newton's law in complementarity form, with :math:`\gamma^\pm = N v^\pm`,

.. math::

    0 \le p \;\perp\; \gamma^+ + E\gamma^- \ge 0 \qquad (E = \mathrm{diag}(e_i)).

With :math:`M = L L^T`, :math:`u = L^T v`, :math:`W_N = L^{-1} N^T`,
:math:`W_B = L^{-1} B^T` and :math:`\Pi_B` the orthogonal projector onto
:math:`\mathrm{range}(W_B)^\perp`, the bilateral rows are eliminated exactly:
:math:`u^+ = \Pi_B (u^- + W_N p)`, so with :math:`\tilde W = \Pi_B W_N`

.. math::

    w = G p + b, \quad G = \tilde W^T \tilde W \;(\text{PSD}), \quad
    b = \tilde W^T u^- + E \gamma^- ,

an LCP with a positive-semidefinite (possibly singular: redundant contacts) Delassus
matrix. It is solved by Lemke's algorithm with lexicographic anti-cycling, which either
finds a solution or proves that none exists (PSD matrices are copositive-plus).

Poisson's law (``law="poisson"``) splits the impact into compression (the LCP above with
:math:`E = 0`, impulse :math:`p_c`) and expansion: :math:`p_e = E p_c + x`,
:math:`0 \le x \perp \gamma^+ \ge 0`, total :math:`p = p_c + p_e`.

Active set and :math:`T_c^-`
----------------------------
A contact *holds* if its impulse is positive or its complementarity slack is zero (it
leaves with exactly the restitution velocity). :math:`T_c^-` is the partition of
:math:`v^-` with the holding unilateral rows and all bilateral rows. For ``e = 0`` (and
bilateral rows at rest) :math:`T_c^-` equals the energy lost in the impact, and for a
common Newton ``e`` the energy lost is :math:`(1 - e^2) T_c^-`; contacts at the
threshold (zero impulse and zero slack) do not change :math:`T_c^-`.

Energy: for a common ``e`` in [0, 1] and bilateral rows at rest before the impact, both
laws never add energy (Newton: :math:`\Delta T = -\tfrac12\frac{1-e}{1+e} p^T G p`).
With different ``e`` per contact Newton's law can add energy (a known defect of the law).
Note that with Newton's law a contact that was already separating (:math:`\gamma^-_i>0`)
may leave with :math:`\gamma^+_i \ge -e\gamma^-_i`; use ``e = 0`` or Poisson's law if that
matters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import _validation
from ._kernels.lemke import STATUS_INFEASIBLE, STATUS_LOCKED, STATUS_MAXITER, impact_kernel
from ._validation import as_array, broadcast_batch, check_rows, check_rtol, fmt_index
from .energy import RTOL, flat_index, raise_overflow, scalarize, warn_energy_gain
from .exceptions import InputError, SolverError

#: Default tolerance of the complementarity decisions (relative to ``sqrt(2 T^-)``).
TOL = 1e-9

#: A solution whose relative complementarity residual exceeds this raises SolverError.
MAX_RESIDUAL = 1e-7

_LAWS = ("newton", "poisson")

__all__ = ["TOL", "UnilateralImpactResult", "active_set", "unilateral_impact"]


@dataclass(frozen=True)
class UnilateralImpactResult:
    """Result of :func:`unilateral_impact` (batch shape ``...`` of the inputs).

    Attributes
    ----------
    v_plus : (..., n) ndarray
        Generalized velocity just after the impact.
    impulse : (..., k) ndarray
        Normal impulse of each unilateral row (>= 0) [N s for unit normals].
    impulse_bilateral : (..., p) ndarray
        Impulse of each bilateral row (minimum-norm split for dependent rows).
    active : (..., k) bool ndarray
        The unilateral rows that hold through the impact.
    approaching : (..., k) bool ndarray
        Rows with ``N v^- < 0`` before the impact (beyond the tolerance).
    impact : bool or (...,) bool ndarray
        Whether any unilateral row is approaching (otherwise there is no impact and the
        impulses are zero, up to the bilateral rows).
    T_minus, T_plus, energy_lost : float or (...,) ndarray
        Kinetic energy before, after, and their difference [J].
    T_c_minus : float or (...,) ndarray
        Effective kinetic energy with the active unilateral rows plus the bilateral
        rows [J].
    rank : int or (...,) ndarray
        Rank of those rows.
    residual : float or (...,) ndarray
        Complementarity residual in whitened units: ``max(-p, -w) / u`` and
        ``|p w| / (u max(u, max|p|))`` with ``u = sqrt(2 T^-)`` (around 1e-15 for a clean
        solve; the product is read relative to the impulses, whose round-off it carries).
    slack : (..., k) ndarray
        ``w``: normal velocity after the impact minus its restitution target
        (Newton: ``N v^+ + e N v^-``; Poisson: ``N v^+``).
    law : str
        ``"newton"`` or ``"poisson"``.
    """

    v_plus: np.ndarray
    impulse: np.ndarray
    impulse_bilateral: np.ndarray
    active: np.ndarray
    approaching: np.ndarray
    impact: np.ndarray
    T_minus: np.ndarray
    T_plus: np.ndarray
    energy_lost: np.ndarray
    T_c_minus: np.ndarray
    rank: np.ndarray
    residual: np.ndarray
    slack: np.ndarray
    law: str


def check_residual(resid: np.ndarray, batch: tuple) -> None:
    """SolverError naming the worst item when a relative complementarity residual (one per
    flat batch item) exceeds :data:`MAX_RESIDUAL`."""
    worst = float(resid.max()) if resid.size else 0.0
    if worst > MAX_RESIDUAL:
        bad = int(np.argmax(resid))
        idx = tuple(int(i) for i in np.unravel_index(bad, batch)) if batch else ()
        raise SolverError(
            f"the contact impulses do not satisfy complementarity ({fmt_index(idx)}, "
            f"relative residual {worst:.2g}): the problem is too ill-conditioned; check the "
            "scaling of M and of the contact rows"
        )


def _solve(M, v, unilateral, restitution, bilateral, law, obstacle, tol, rtol, want_vplus):
    if law not in _LAWS:
        raise InputError(f"law must be one of {_LAWS}, got {law!r}")
    tol = check_rtol(tol, "tol", 1e-3)
    rtol = check_rtol(rtol)
    M = as_array(M, "M", min_ndim=2)
    if M.shape[-1] != M.shape[-2] or M.shape[-1] == 0:
        raise InputError(f"M must have shape (..., n, n) with n >= 1, got {M.shape}")
    n = M.shape[-1]
    v = as_array(v, "v", min_ndim=1)
    if v.shape[-1] != n:
        raise InputError(f"v must have shape (..., n) with n = {n} to match M, got {v.shape}")
    _validation.check_finite(v, "v", 1)
    N = check_rows(unilateral, "unilateral", n)
    k = N.shape[-2]
    if k == 0:
        raise InputError("unilateral has no rows: give at least the obstacle contact row")
    B = np.zeros((0, n)) if bilateral is None else check_rows(bilateral, "bilateral", n)
    if (isinstance(restitution, (int, float)) and not isinstance(restitution, bool)
            and math.isfinite(restitution)):
        if not 0.0 <= restitution <= 1.0:
            raise InputError(f"restitution must lie in [0, 1], got {restitution:g}")
        e = np.full(k, float(restitution))
    else:
        e = as_array(restitution, "restitution")
        # (..., k): the last axis is the contact, not a batch axis
        _validation.check_coefficients(e, "restitution", low=0.0, high=1.0)
        if e.ndim == 0:
            e = np.full(k, float(e))
        if e.shape[-1] not in (1, k):
            raise InputError(
                f"restitution must be a scalar or have k = {k} values, got {e.shape}")
        e = np.broadcast_to(e, (*e.shape[:-1], k))
    batch = broadcast_batch(M=M.shape[:-2], v=v.shape[:-1], unilateral=N.shape[:-2],
                            bilateral=B.shape[:-2], restitution=e.shape[:-1])
    pb = B.shape[-2]
    iM = flat_index(M.shape[:-2], batch)
    iN = flat_index(N.shape[:-2], batch)
    iB = flat_index(B.shape[:-2], batch)
    iv = flat_index(v.shape[:-1], batch)
    iE = flat_index(e.shape[:-1], batch)
    nb = iM.shape[0]
    Mf = np.ascontiguousarray(M.reshape(-1, n, n))
    # rows scaled to a largest entry of 1 (exact: impulses scale by 1/s, normal velocities
    # by s), so that rows of tiny entries do not underflow inside the kernel
    sN = np.max(np.abs(N), axis=-1).reshape(-1, k)
    Nf = np.ascontiguousarray(N.reshape(-1, k, n) / sN[..., None])
    Bf = B.reshape(math.prod(B.shape[:-2]), pb, n)
    if pb:
        Bf = Bf / np.max(np.abs(Bf), axis=-1, keepdims=True)
    Bf = np.ascontiguousarray(Bf)
    vf = np.ascontiguousarray(v.reshape(-1, n))
    Ef = np.ascontiguousarray(e.reshape(-1, k))
    out = {
        "P": np.zeros((nb, k)), "vplus": np.empty((nb, n) if want_vplus else (0, n)),
        "slack": np.zeros((nb, k)), "Tm": np.zeros(nb), "Tp": np.zeros(nb),
        "Tc": np.zeros(nb), "rank": np.zeros(nb, dtype=np.int64),
        "active": np.zeros((nb, k), dtype=np.bool_),
        "approaching": np.zeros((nb, k), dtype=np.bool_),
        "resid": np.zeros(nb), "status": np.zeros(nb, dtype=np.int64),
    }
    impact_kernel.get(nb)(Mf, Nf, Bf, vf, Ef, iM, iN, iB, iv, iE, law == "poisson",
                          float(rtol), float(tol), bool(want_vplus), *out.values())
    out["P"] /= sN[iN]
    out["slack"] *= sN[iN]
    status = out["status"]
    if status.any():
        bad = int(np.flatnonzero(status)[0])
        idx = tuple(int(i) for i in np.unravel_index(bad, batch)) if batch else ()
        code = int(status[bad])
        where = fmt_index(idx)
        eb = Ef[iE[bad]]
        if code == STATUS_INFEASIBLE and law == "newton" and (
                not eb.any() or (pb == 0 and (eb == eb[0]).all())):
            # p minimises |W p + c|^2 over p >= 0 (W the whitened unilateral rows, projected
            # off the bilateral ones; c = (1 + e) L^T v, resp. its projection for e = 0),
            # whose minimiser always exists: the pivoting broke down, not the problem
            raise SolverError(
                f"Lemke's algorithm broke down on this contact problem ({where}), which has "
                "a solution (with Newton's law and one restitution coefficient, or e = 0, "
                "it always does): nearly opposite contact normals need impulses far larger "
                "than the approach and defeat the pivoting. Merge or remove the nearly "
                "opposite contact rows"
            )
        if code == STATUS_INFEASIBLE:
            raise SolverError(
                f"the unilateral impact problem has no solution ({where}): no set of "
                "non-negative contact impulses stops every contact from closing. Check the "
                "signs of the contact rows (N v < 0 must mean approaching) and the "
                "bilateral rows, which may force a contact to penetrate"
            )
        if code == STATUS_LOCKED:
            raise SolverError(
                f"a unilateral row lies in the span of the bilateral rows and is forced "
                f"to close ({where}): the bilateral rows leave it no freedom; remove that "
                "contact or the constraint that locks it"
            )
        if code == STATUS_MAXITER:
            raise SolverError(
                f"Lemke's algorithm did not terminate ({where}): the contact problem is "
                "degenerate; remove redundant contact rows or loosen tol"
            )
        raise _validation.mass_matrix_error(M, int(iM[bad]), code)
    if not np.isfinite(out["Tm"]).all():  # finite M and v, 1/2 v^T M v above float64
        raise_overflow(out["Tm"], M, v, iM, iv, batch)
    check_residual(out["resid"], batch)
    if obstacle is not None:
        if not (isinstance(obstacle, (int, np.integer)) and -k <= obstacle < k):
            raise InputError(f"obstacle must be a row index of unilateral (0..{k - 1}), "
                             f"got {obstacle!r}")
        sep = ~out["approaching"][:, obstacle]
        if sep.any():
            bad = int(np.flatnonzero(sep)[0])
            idx = tuple(int(i) for i in np.unravel_index(bad, batch)) if batch else ()
            raise InputError(
                f"the obstacle row {int(obstacle)} is not approaching ({fmt_index(idx)}): "
                "N v >= 0 means the bodies separate, so there is no impact to analyse"
            )
    return out, batch, N, B, M, v, n, k, pb


def unilateral_impact(M, v, unilateral, restitution=0.0, bilateral=None, *,
                      law: str = "newton", obstacle: int | None = None, tol: float = TOL,
                      rtol: float = RTOL) -> UnilateralImpactResult:
    r"""Impulsive impact with unilateral contacts: which hold, which release, and v+.

    Solves :math:`0 \le p \perp N v^+ + E N v^- \ge 0` (Newton) with
    :math:`M(v^+ - v^-) = N^T p + B^T q`, :math:`B v^+ = 0` (see the module docstring).

    Parameters
    ----------
    M : (..., n, n) array_like
        Symmetric positive-definite mass matrix.
    v : (..., n) array_like
        Generalized velocity just before the impact.
    unilateral : (..., k, n) array_like, or (n,) for one row
        Unilateral contact rows (ground contacts, the obstacle contact): the normal
        velocity of each contact, ``N v < 0`` approaching. Unit normals give impulses in
        N s. No row may be zero.
    restitution : float or (..., k) array_like
        Coefficient(s) of restitution ``e`` in [0, 1].
    bilateral : (..., p, n) array_like, optional
        Rows held with zero velocity after the impact (loop closures, locked joints,
        persistent contacts). Dependent rows are allowed.
    law : {"newton", "poisson"}
        Restitution law (kinematic Newton, or Poisson's compression/expansion impulses).
    obstacle : int, optional
        Index of the obstacle row; if given, it must be approaching in every batch item
        (else InputError: no impact).
    tol : float
        Relative tolerance of the complementarity decisions (which contact holds, which
        row approaches), relative to ``sqrt(2 T^-)`` in whitened units.
    rtol : float
        Rank tolerance for dependent rows, as in :func:`~roverimpact.partition`.

    Returns
    -------
    UnilateralImpactResult

    Raises
    ------
    InputError
        Bad shapes, NaN or inf, zero rows, ``e`` outside [0, 1], non-SPD ``M``, an
        obstacle row that is not approaching.
    SolverError
        Infeasible problem (the bilateral rows force a contact to penetrate), or a
        degenerate one that Lemke's algorithm cannot settle.

    Examples
    --------
    A 1 kg point on the floor (row ``[0, 1]``) hitting a wall (row ``[1, 0]``) at 1 m/s:
    the floor contact carries no impulse and stays closed, the wall stops the motion.

    >>> import numpy as np, roverimpact as ri
    >>> r = ri.unilateral_impact(np.eye(2), [-1.0, 0.0], [[1.0, 0.0], [0.0, 1.0]])
    >>> r.active.tolist(), np.round(r.impulse, 12).tolist(), float(r.T_c_minus)
    ([True, True], [1.0, 0.0], 0.5)
    """
    out, batch, N, B, M, v, n, k, pb = _solve(M, v, unilateral, restitution, bilateral, law,
                                              obstacle, tol, rtol, True)
    v_plus = out["vplus"].reshape(*batch, n)
    vb = np.broadcast_to(v, (*batch, n))
    Mb = np.broadcast_to(M, (*batch, n, n))
    Nb = np.broadcast_to(N, (*batch, k, n))
    imp = out["P"].reshape(*batch, k)
    if pb:
        Bb = np.broadcast_to(B, (*batch, pb, n))
        g = np.einsum("...ij,...j->...i", Mb, v_plus - vb) - np.einsum(
            "...ji,...j->...i", Nb, imp)
        Bt = np.swapaxes(Bb, -1, -2)
        imp_b = np.einsum("...ij,...j->...i", np.linalg.pinv(Bt, rcond=rtol), g)
    else:
        imp_b = np.zeros((*batch, 0))
    Tm = out["Tm"]
    Tp = out["Tp"]
    warn_energy_gain(Tm, Tp, batch, "Newton's restitution adds energy with different e "
                     "per contact and one separating before the impact, or with e > 0 and "
                     "bilateral rows moving before the impact (B v- != 0); use one e and "
                     "bilateral rows at rest, e = 0, or law='poisson'")
    approaching = out["approaching"].reshape(*batch, k)
    return UnilateralImpactResult(
        v_plus=v_plus,
        impulse=imp,
        impulse_bilateral=imp_b,
        active=out["active"].reshape(*batch, k),
        approaching=approaching,
        impact=scalarize(approaching.reshape(-1, k).any(axis=-1), batch),
        T_minus=scalarize(Tm, batch),
        T_plus=scalarize(Tp, batch),
        energy_lost=scalarize(Tm - Tp, batch),
        T_c_minus=scalarize(out["Tc"], batch),
        rank=scalarize(out["rank"], batch),
        residual=scalarize(out["resid"], batch),
        slack=out["slack"].reshape(*batch, k),
        law=law,
    )


def active_set(M, v, unilateral, bilateral=None, *, restitution=0.0, law: str = "newton",
               obstacle: int | None = None, tol: float = TOL, rtol: float = RTOL) -> np.ndarray:
    """The unilateral rows that hold through the impact (boolean mask).

    Same problem and arguments as :func:`unilateral_impact`, which also returns
    ``T_c_minus`` computed with this set; this function skips ``v+`` and the bilateral
    impulses.

    Returns
    -------
    active : (..., k) bool ndarray

    Examples
    --------
    A 1 kg point on the floor sliding into a 45 degree slope: the slope pushes it up, so
    the floor contact releases.

    >>> import numpy as np, roverimpact as ri
    >>> s = np.sqrt(0.5)
    >>> ri.active_set(np.eye(2), [1.0, 0.0], [[0.0, 1.0], [-s, s]]).tolist()
    [False, True]
    """
    out, batch, *_ = _solve(M, v, unilateral, restitution, bilateral, law, obstacle, tol,
                            rtol, False)
    active = out["active"]  # (items, k): k given, for an empty batch too
    return active.reshape(*batch, active.shape[-1])
