r"""Coulomb friction at impact: which contacts hold, stick or slide, and :math:`T_c^-`.

The frictionless unilateral problem (:mod:`roverimpact.activeset`) decides which contacts
hold through the impact but lets every contact slide freely; holding the no-slip rows of
every closed contact as bilateral rows instead jams the system. This module solves the
impact with Coulomb friction at every candidate contact, so that each contact separates,
sticks or slides as the impulses decide, and :math:`T_c^-` follows from the contacts that
hold *and the way they hold*.

Problem
-------
Mass matrix :math:`M` (n x n), pre-impact velocity :math:`v^-`, per contact :math:`i` a
normal row :math:`n_i` (``N v < 0`` approaching) and :math:`t_i \in \{0, 1, 2\}` tangent
rows :math:`T_i` (the slip velocity of the contact point along orthonormal tangent
directions: 1 row for planar models, 2 in 3-D), bilateral rows :math:`B` (loop closures,
locked joints). The friction cone :math:`\|\tau_i\| \le \mu_i p_i` is replaced by a
polyhedral cone spanned by directions :math:`d_{ij}` in the tangent plane (Stewart &
Trinkle 1996; Anitescu & Potra 1997): :math:`\pm T_i` for :math:`t_i = 1`, and for
:math:`t_i = 2` the ``facets`` unit vectors :math:`d_{ij} = \cos\theta_j T_{i1} +
\sin\theta_j T_{i2}`, :math:`\theta_j = 2\pi j/m` (an inscribed regular m-gon). With
normal impulses :math:`p \ge 0`, direction impulses :math:`\beta \ge 0`, a slip-speed
variable :math:`\lambda \ge 0` per contact and free bilateral impulses :math:`q`,

.. math::

    M (v^+ - v^-) = N^T p + D^T \beta + B^T q, \qquad B v^+ = 0,

    0 \le p_i \perp n_i v^+ + e_i\, n_i v^- \ge 0,

    0 \le \beta_{ij} \perp d_{ij} v^+ + \lambda_i \ge 0,

    0 \le \lambda_i \perp \mu_i p_i - \textstyle\sum_j \beta_{ij} \ge 0 .

The last two lines are Coulomb's law on the polygon: a contact with slip
(:math:`\lambda_i > 0`) has its impulse on the cone boundary, in the direction(s) most
opposed to the slip (maximal dissipation); a contact without slip has any impulse in the
cone. Newton's restitution acts on the normal only (the tangential velocity of a
sticking contact is zero after the impact). Coulomb's law acts on the slip after the
impact, not along the impact as in Routh's incremental analysis (Stronge 2000, ch. 4):
the two agree unless a contact's slip reverses during the impact
(``test_slip_reversal_algebraic_law_not_routh``). The bilateral rows are eliminated
exactly as in the frictionless problem (whitening with :math:`M = L L^T`, projection onto the
orthogonal complement of the whitened bilateral rows); the remaining LCP in
:math:`(p, \beta, \lambda)` has the matrix

.. math::

    \begin{pmatrix} G_{nn} & G_{nd} & 0 \\ G_{dn} & G_{dd} & E \\ U & -E^T & 0
    \end{pmatrix},

with :math:`G = \tilde W^T \tilde W` PSD, :math:`E` the contact-to-direction incidence
and :math:`U = \mathrm{diag}(\mu)`: copositive, and Lemke's algorithm solves it whenever
it has a solution (Anitescu & Potra 1997). The compiled kernel
(:mod:`roverimpact._friction_kernel`) first iterates on the contact modes (each mode
set is a linear system; a solution is accepted only when every condition above holds)
and otherwise solves the LCP by Lemke's algorithm (lexicographic rule, exact solve on
the final basis; a fixed tiny perturbation of the right-hand side breaks the ties of
very degenerate problems). ``mu = 0`` (or no tangent rows) gives exactly the
frictionless problem. ``mu = inf`` means no slip while the contact holds: the tangent
rows of such a contact are held as bilateral rows exactly when its normal holds with a
positive impulse (a contact holding at zero impulse carries no friction, as for any finite
mu; the set of these locked contacts is iterated to a consistent one, starting from all
locked;
if there is none, those contacts are solved with :math:`\mu` = :data:`MU_INF` = 1e4
and ``fallback`` is set). A finite mu above :data:`MU_MAX` = 1e4 is refused (the
bound ``mu p`` amplifies the round-off of ``p``): ``inf`` means no slip. Several
solutions can exist (friction makes the problem non-monotone); one of them is returned.

Contact states and :math:`T_c^-`
--------------------------------
A contact *holds* if its normal impulse is positive or its complementarity slack is zero
(as in the frictionless problem). A holding contact with friction *sticks* if its slip
velocity after the impact is zero, else it *slides*; a holding frictionless contact
(``mu = 0`` or no tangent rows) is reported as sliding. :math:`T_c^-` is the partition
of :math:`v^-` with

* a sticking contact: its normal row and its tangent rows (its contact point is stopped
  in every direction, exactly as the bilateral no-slip rows would stop it),
* a sliding contact: its normal row only (its tangential velocity is not constrained:
  the friction impulse is bounded by :math:`\mu p`, not determined by a kinematic row),
* a separating contact: nothing,

plus all bilateral rows. With :math:`e = 0` and no sliding contact, :math:`T_c^-` equals
the energy lost in the impact, as in the frictionless problem (tested). With sliding
contacts it is an approximation: the friction impulse of a sliding contact is neither
zero (what the partition with the normal row alone assumes) nor a constraint impulse,
and :math:`T_c^-` counts none of its effect.

Energy: with :math:`e = 0` the impact never adds energy,
:math:`T^- - T^+ = \tfrac12 \Delta v^T M \Delta v + \sum_i \mu_i \lambda_i p_i`. With
:math:`e > 0` Newton's law with friction can add energy when a contact's slip stops or
reverses (Kane's paradox; Stronge 2000, ch. 5): a rod end that slides in and sticks with
``e = 1`` keeps its whole normal rebound while its slip is stopped, and the impact gains
energy (``test_energy_gain_when_slip_stops_without_reversing``: +0.1125 J of 0.68 J,
the slip stopping in compression and never reversing); :func:`frictional_impact` then
warns (:class:`~roverimpact.exceptions.EnergyGainWarning`). It does not when every contact
is at rest or approaching before the impact with zero slip (a rolling rover), for any
:math:`e_i` in [0, 1] (tested, both).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from . import _validation
from ._kernels.friction import MU_INF, friction_kernel
from ._kernels.lemke import STATUS_INFEASIBLE, STATUS_LOCKED, STATUS_MAXITER
from ._validation import as_array, broadcast_batch, check_rows, fmt_index
from .energy import (
    RTOL,
    flat_index,
    power_of_two_scale,
    raise_overflow,
    scalarize,
    warn_energy_gain,
)
from .exceptions import InputError, SolverError
from .unilateral import TOL, check_residual

#: default number of friction directions (facets of the polyhedral cone) of a contact
#: with two tangent rows
FACETS = 8

#: largest finite friction coefficient accepted (the MU_INF of the kernel); above it only
#: ``inf`` (no slip). The friction bound ``mu p`` multiplies the round-off of the normal
#: impulse ``p`` by ``mu``: solutions with ``|tau| > mu p`` came back at ``mu = 1e6`` (six
#: contacts at rest, round-off normal velocities of 1e-15, friction on contacts with
#: ``p = 0``) and regularly from 1e8 on (a contact with ``p = -6e-12`` N s carrying 5.8 N s
#: of friction at ``mu = 1e12``, the impact adding 14 J to 3.5 J with ``e = 0``). Up to
#: 3e5 none did, on 1200 drawn problems.
MU_MAX = MU_INF

#: contact state names, indexed by the kernel's codes
STATES = ("separating", "sticking", "sliding")

FRICTION_MODELS = ("coulomb", "frictionless", "no-slip")

__all__ = [
    "FACETS",
    "FRICTION_MODELS",
    "MU_INF",
    "MU_MAX",
    "FrictionalImpactResult",
    "frictional_active_set",
    "frictional_impact",
]

_STATE_NAMES = np.array(STATES)


@dataclass(frozen=True)
class FrictionalImpactResult:
    """Result of :func:`frictional_impact` (batch shape ``...`` of the inputs).

    Attributes
    ----------
    v_plus : (..., n) ndarray
        Generalized velocity just after the impact.
    impulse : (..., k) ndarray
        Normal impulse of each contact (>= 0) [N s for unit rows].
    impulse_tangent : (..., k, t) ndarray
        Friction impulse of each contact on its tangent rows (the generalized impulse is
        ``T_i^T tau_i``); zero for rows a contact does not have.
    impulse_bilateral : (..., p) ndarray
        Impulse of each bilateral row (minimum-norm split for dependent rows).
    state : (..., k) str ndarray
        ``"separating"``, ``"sticking"`` or ``"sliding"``.
    hold_normal : (..., k) bool ndarray
        Normal rows held for T_c^- (the contacts that hold).
    hold_tangent : (..., k, t) bool ndarray
        Tangent rows held for T_c^- (those of the sticking contacts).
    approaching : (..., k) bool ndarray
        Contacts with ``N v^- < 0`` before the impact (beyond the tolerance).
    impact : bool or (...,) ndarray
        Whether any contact is approaching.
    slack : (..., k) ndarray
        ``N v^+ + e N v^-``: normal velocity after the impact minus its target.
    slip : (..., k, t) ndarray
        ``T v^+``: slip velocity of each contact along its tangent rows after the impact.
    T_minus, T_plus, energy_lost : float or (...,) ndarray
        Kinetic energy before, after, and their difference [J].
    T_c_minus : float or (...,) ndarray
        Effective kinetic energy with the held rows plus the bilateral rows [J].
    rank : int or (...,) ndarray
        Rank of those rows.
    residual : float or (...,) ndarray
        Complementarity residual of the LCP, relative as in
        :attr:`~roverimpact.unilateral.UnilateralImpactResult.residual`.
    locked : (..., k) bool ndarray
        ``mu = inf`` contacts whose tangent rows were held as bilateral rows.
    fallback : bool or (...,) ndarray
        Items whose LCP needed the perturbed pivoting (degenerate problems).
    """

    v_plus: np.ndarray
    impulse: np.ndarray
    impulse_tangent: np.ndarray
    impulse_bilateral: np.ndarray
    state: np.ndarray
    hold_normal: np.ndarray
    hold_tangent: np.ndarray
    approaching: np.ndarray
    impact: np.ndarray
    slack: np.ndarray
    slip: np.ndarray
    T_minus: np.ndarray
    T_plus: np.ndarray
    energy_lost: np.ndarray
    T_c_minus: np.ndarray
    rank: np.ndarray
    residual: np.ndarray
    locked: np.ndarray
    fallback: np.ndarray


def _per_contact(x, name, k, *, low, high=None, allow_inf=False):
    """Scalar or (..., k) coefficient array, checked."""
    if (isinstance(x, (int, float)) and not isinstance(x, bool) and x >= low
            and (x <= high if high is not None else True) and (allow_inf or math.isfinite(x))):
        return np.full(k, float(x))
    a = as_array(x, name)
    if a.ndim and a.shape[-1] not in (1, k):
        raise InputError(f"{name} must be a scalar or have k = {k} values (one per "
                         f"contact), got shape {a.shape}")
    # checked as given: the last axis is the contact, the others are batch axes
    _validation.check_coefficients(a, name, low=low, high=high, allow_inf=allow_inf,
                                   item="contact")
    return np.full(k, float(a)) if a.ndim == 0 else np.broadcast_to(a, (*a.shape[:-1], k))


def _tangent_rows(tangent, k, n):
    """Tangent rows as a zero-padded ``(..., k, tm, n)`` array and ``ntan (k,)``.

    ``tangent`` is an array ``(..., k, t, n)`` (every contact has ``t`` rows), or a list
    or tuple of ``k`` entries, each ``None`` (no friction), ``(t_i, n)`` or
    ``(..., t_i, n)``.
    """
    if tangent is None:
        return np.zeros((k, 1, n)), np.zeros(k, dtype=np.int64)
    if isinstance(tangent, (list, tuple)):
        if len(tangent) != k:
            raise InputError(f"tangent as a list must have one entry per contact (k = {k}),"
                             f" got {len(tangent)}")
        parts = []
        for i, t in enumerate(tangent):
            if t is None:
                parts.append(np.zeros((0, n)))
                continue
            a = as_array(t, f"tangent[{i}]", min_ndim=1)
            if a.ndim == 1:
                a = a[None, :]
            if a.shape[-1] != n:
                raise InputError(f"tangent[{i}] must have shape (..., t, n) with n = {n} "
                                 f"columns to match M, got {a.shape}")
            parts.append(a)
        ntan = np.array([a.shape[-2] for a in parts], dtype=np.int64)
        tm = max(int(ntan.max()), 1)
        batch = broadcast_batch(**{f"tangent[{i}]": a.shape[:-2] for i, a in
                                   enumerate(parts)})
        Tg = np.zeros((*batch, k, tm, n))
        for i, a in enumerate(parts):
            if a.shape[-2]:
                Tg[..., i, : a.shape[-2], :] = a
    else:
        Tg = as_array(tangent, "tangent", min_ndim=3)
        if Tg.shape[-3] != k or Tg.shape[-1] != n:
            raise InputError(f"tangent must have shape (..., k, t, n) with k = {k} contacts"
                             f" and n = {n} columns, got {Tg.shape}")
        ntan = np.full(k, Tg.shape[-2], dtype=np.int64)
        if Tg.shape[-2] == 0:
            Tg = np.zeros((*Tg.shape[:-2], 1, n))
    if (ntan > 2).any():
        i = int(np.argmax(ntan > 2))
        raise InputError(f"contact {i} has {int(ntan[i])} tangent rows: give 1 (planar) or"
                         " 2 (3-D) rows per contact, or none")
    _validation.check_finite(Tg, "tangent", 3)
    # a contact's tangent rows are all zero (no friction in that item) or all nonzero
    zero = np.max(np.abs(Tg), axis=-1) == 0.0  # (..., k, tm)
    used = np.arange(Tg.shape[-2])[None, :] < ntan[:, None]  # (k, tm)
    nz = (~zero & used).sum(axis=-1)
    partial = (nz > 0) & (nz < ntan)
    if partial.any():
        where = np.argwhere(partial)[0]
        idx = tuple(int(i) for i in where[:-1])
        raise InputError(f"tangent rows of contact {int(where[-1])} are partly zero "
                         f"({fmt_index(idx)}): give a contact all its tangent rows, or "
                         "all-zero rows for a frictionless contact")
    return Tg, ntan


@functools.lru_cache(maxsize=64)
def _directions(ntan: tuple[int, ...], facets: int):
    """Directions per contact and their coefficients on the tangent rows."""
    k = len(ntan)
    nd = np.array([0 if t == 0 else (2 if t == 1 else facets) for t in ntan], np.int64)
    tm = max(max(ntan), 1)
    coef = np.zeros((k, max(int(nd.max()), 1), tm))
    th = 2 * np.pi * np.arange(facets) / facets
    for i, t in enumerate(ntan):
        if t == 1:
            coef[i, :2, 0] = [1.0, -1.0]
        elif t == 2:
            coef[i, :facets, 0] = np.cos(th)
            coef[i, :facets, 1] = np.sin(th)
    for a in (nd, coef):
        a.flags.writeable = False
    return nd, coef


def _solve(M, v, normal, tangent, mu, restitution, bilateral, facets, tol, rtol,
           want_vplus, ntan=None):
    tol = _validation.check_rtol(tol, "tol", 1e-3)
    rtol = _validation.check_rtol(rtol)
    if isinstance(facets, bool) or not isinstance(facets, (int, np.integer)) or facets < 3:
        raise InputError(f"facets must be an integer >= 3 (friction directions of a 3-D "
                         f"contact), got {facets!r}")
    M = as_array(M, "M", min_ndim=2)
    if M.shape[-1] != M.shape[-2] or M.shape[-1] == 0:
        raise InputError(f"M must have shape (..., n, n) with n >= 1, got {M.shape}")
    n = M.shape[-1]
    v = as_array(v, "v", min_ndim=1)
    if v.shape[-1] != n:
        raise InputError(f"v must have shape (..., n) with n = {n} to match M, got {v.shape}")
    _validation.check_finite(v, "v", 1)
    N = check_rows(normal, "normal", n)
    k = N.shape[-2]
    if k == 0:
        raise InputError("normal has no rows: give at least the obstacle contact row")
    if ntan is None:
        Tg, ntan = _tangent_rows(tangent, k, n)
    else:  # internal call: padded rows already checked
        Tg = tangent
    B = np.zeros((0, n)) if bilateral is None else check_rows(bilateral, "bilateral", n)
    e = _per_contact(restitution, "restitution", k, low=0.0, high=1.0)
    mu = _per_contact(mu, "mu", k, low=0.0, allow_inf=True)
    big = np.isfinite(mu) & (mu > MU_MAX)
    if big.any():
        first = tuple(int(i) for i in np.argwhere(big)[0])
        where = f"contact {first[-1]}" + (f", {fmt_index(first[:-1])}" if len(first) > 1
                                           else "")
        raise InputError(f"mu must be at most {MU_MAX:g} or inf (no slip), got "
                         f"{float(mu[first]):g} ({where}): above {MU_MAX:g} the friction "
                         "bound mu p multiplies the round-off of the normal impulse p by mu "
                         "beyond what float64 resolves; give mu = inf for a contact that "
                         "cannot slip")
    batch = broadcast_batch(M=M.shape[:-2], v=v.shape[:-1], normal=N.shape[:-2],
                            tangent=Tg.shape[:-3], bilateral=B.shape[:-2],
                            restitution=e.shape[:-1], mu=mu.shape[:-1])
    nd, coef = _directions(tuple(int(t) for t in ntan), int(facets))
    pb = B.shape[-2]
    tm = Tg.shape[-2]
    idx = [flat_index(s, batch) for s in (M.shape[:-2], N.shape[:-2], Tg.shape[:-3],
                                           B.shape[:-2], v.shape[:-1], e.shape[:-1],
                                           mu.shape[:-1])]
    nb = idx[0].shape[0]
    flat = [np.ascontiguousarray(a.reshape(math.prod(a.shape[: a.ndim - c]),
                                           *a.shape[a.ndim - c:]))
            for a, c in ((M, 2), (N, 2), (Tg, 3), (B, 2), (v, 1), (e, 1), (mu, 1))]
    # rows of tiny or huge entries (1e-155 gave NaN, 1e160 no impact: G = N M^-1 N^T under-
    # or overflowed in the kernel) are scaled as in unilateral_impact: in each item, each
    # contact's normal and tangent rows divided by one power of two about the largest
    # |entry| of its normal row, each bilateral row by its own. Exact: impulses scale by
    # 1/s and velocities along the rows by s (B v+ = 0 does not depend on B's scale). Only
    # the rows out of range, and by their own item's size: the other rows go to the kernel
    # as given, so that an item gives the same bits alone as in a batch (the scale of a
    # batch mixes with M's and B's in rounding). (One factor per contact over the whole
    # batch left an item of 1e-200 rows beside one of order 1 unscaled: ZeroDivisionError.)
    s = power_of_two_scale(np.max(np.abs(flat[1]), axis=2))  # (items of N, k)
    if s is None:
        s = np.ones(k)
    else:
        if flat[1].shape[0] != 1 or flat[2].shape[0] != 1:
            # one factor per item and contact for the normal and tangent rows together:
            # both taken to the full batch
            flat[1], flat[2] = flat[1][idx[1]], flat[2][idx[2]]
            s = s[idx[1]]
            idx[1] = idx[2] = np.arange(nb, dtype=np.int64)
        if s.shape[0] == 1:
            s = s[0]  # (k,): the rows are unbatched
        flat[1] = flat[1] / s[..., None]
        flat[2] = flat[2] / s[..., None, None]
    if pb:
        sB = power_of_two_scale(np.max(np.abs(flat[3]), axis=-1, keepdims=True))
        if sB is not None:
            flat[3] = flat[3] / sB
    out = {
        "P": np.zeros((nb, k)), "Pt": np.zeros((nb, k, tm)),
        "vplus": np.empty((nb, n) if want_vplus else (0, n)),
        "slack": np.zeros((nb, k)), "slip": np.zeros((nb, k, tm)),
        "Tm": np.zeros(nb), "Tp": np.zeros(nb), "Tc": np.zeros(nb),
        "rank": np.zeros(nb, dtype=np.int64), "state": np.zeros((nb, k), dtype=np.int8),
        "hold_n": np.zeros((nb, k), dtype=np.bool_),
        "hold_t": np.zeros((nb, k, tm), dtype=np.bool_),
        "locked": np.zeros((nb, k), dtype=np.bool_),
        "approaching": np.zeros((nb, k), dtype=np.bool_),
        "resid": np.zeros(nb), "status": np.zeros(nb, dtype=np.int64),
        "fallback": np.zeros(nb, dtype=np.bool_),
        "meth": np.full(nb, -1, dtype=np.int8),
        "iters": np.zeros(nb, dtype=np.int64),
    }
    friction_kernel.get(nb)(*flat, *idx, ntan, nd, coef, math.cos(math.pi / int(facets)),
                            float(rtol), float(tol), bool(want_vplus), *out.values())
    out["P"] /= s
    out["Pt"] /= s[..., None]
    out["slack"] *= s
    out["slip"] *= s[..., None]
    _raise_status(out, M, idx[0], batch, restitution=bool((e > 0).any()))
    if not np.isfinite(out["Tm"]).all():  # finite M and v, 1/2 v^T M v above float64
        raise_overflow(out["Tm"], M, v, idx[0], idx[4], batch)
    return out, batch, dict(M=M, v=v, N=N, Tg=Tg, B=B, n=n, k=k, tm=tm, pb=pb)


def _raise_status(out, M, iM, batch, *, restitution=False):
    status = out["status"]
    if status.any():
        bad = int(np.flatnonzero(status)[0])
        idx = tuple(int(i) for i in np.unravel_index(bad, batch)) if batch else ()
        code = int(status[bad])
        where = fmt_index(idx)
        if code == STATUS_INFEASIBLE:
            raise SolverError(
                f"the frictional impact problem has no solution ({where}): no contact "
                "impulses stop every contact from closing. Either a sign is wrong (N v < 0 "
                "must mean approaching; the bilateral rows may force a contact to "
                "penetrate), or, with restitution e > 0 at several contacts with friction, "
                "Newton's restitution law has no solution for this state (a known property "
                "of Newton's law with Coulomb friction): try e = 0, or mu = 0 at the "
                "contacts that slide"
            )
        if code == STATUS_LOCKED:
            raise SolverError(
                f"a normal row lies in the span of the bilateral rows and is forced to "
                f"close ({where}): remove that contact or the constraint that locks it"
            )
        if code == STATUS_MAXITER:
            raise SolverError(
                f"Lemke's algorithm did not terminate ({where}): the frictional contact "
                "problem is degenerate; remove redundant contact rows or use fewer facets"
            )
        raise _validation.mass_matrix_error(M, int(iM[bad]), code)
    try:
        check_residual(out["resid"], batch)
    except SolverError as err:
        if not restitution:
            raise
        # no solution, seen as a residual: e.g. two identical contacts and a third with
        # e = 0.5 at mu = 1e4, where a search of every contact mode finds none
        raise SolverError(f"{err}; or, with restitution e > 0 at contacts with friction, "
                          "the problem may have no solution (a known property of Newton's "
                          "restitution law with Coulomb friction): try e = 0, or mu = 0 at "
                          "the contacts that slide") from None


def frictional_impact(M, v, normal, tangent, mu, restitution=0.0, bilateral=None, *,
                      facets: int = FACETS, tol: float = TOL,
                      rtol: float = RTOL) -> FrictionalImpactResult:
    r"""Impulsive impact with unilateral contacts and Coulomb friction.

    Solves the impact LCP of the module docstring: normal impulses
    :math:`0 \le p \perp N v^+ + E N v^- \ge 0`, friction impulses in a polyhedral cone
    :math:`\|\tau_i\| \le \mu_i p_i` with maximal dissipation, and
    :math:`M(v^+ - v^-) = N^T p + \sum_i T_i^T \tau_i + B^T q`, :math:`B v^+ = 0`.

    Parameters
    ----------
    M : (..., n, n) array_like
        Symmetric positive-definite mass matrix.
    v : (..., n) array_like
        Generalized velocity just before the impact.
    normal : (..., k, n) array_like, or (n,) for one contact
        Normal row of each contact (``N v < 0`` approaching). No row may be zero.
    tangent : (..., k, t, n) array_like, or a list/tuple of k entries, or None
        Tangent rows of each contact: the slip velocity of the contact point along
        orthonormal tangent directions, scaled like the normal row (``t = 1`` planar,
        ``t = 2`` in 3-D). The list form gives each contact its own rows, ``(t_i, n)``
        or ``(..., t_i, n)``, or ``None`` (frictionless contact). All-zero tangent rows
        make a contact frictionless in that batch item. ``None``: no friction anywhere.
        The rows are taken as given, not checked against the normal: in generalized
        coordinates a true tangent row can be parallel to the normal row (a contact point
        that moves along one line), so a row that is not the slip velocity is not caught.
    mu : float or (..., k) array_like
        Friction coefficient of each contact, in ``[0, MU_MAX]`` (1e4) or ``inf`` = no
        slip while the contact holds (its tangent rows are then held as bilateral rows).
        A finite mu above 1e4 is refused: the bound ``mu p`` multiplies the round-off of
        ``p`` by mu, and from 1e6 on the solver returned friction impulses outside the
        cone.
    restitution : float or (..., k) array_like
        Newton's coefficient of restitution on the normal, in [0, 1].
    bilateral : (..., p, n) array_like, optional
        Rows held with zero velocity after the impact (loop closures, locked joints).
    facets : int
        Friction directions of a contact with two tangent rows (an inscribed regular
        polygon; 8 by default). Planar contacts use ``±t``. Between two directions the
        polygon reaches ``cos(pi/facets) mu p`` only: a 3-D contact acts as if ``mu`` were
        up to ``1 - cos(pi/facets)`` smaller (7.6 % for 8), which matters near the stick
        threshold (docs/active-set.md).
    tol, rtol : float
        Tolerance of the complementarity decisions (relative to ``sqrt(2 T^-)`` in
        whitened units) and rank tolerance, as in :func:`~roverimpact.unilateral_impact`.

    Returns
    -------
    FrictionalImpactResult

    Raises
    ------
    InputError
        Bad shapes, NaN or inf (``mu = inf`` is allowed), zero normal rows, partly zero
        tangent rows, ``mu`` negative or finite above 1e4, ``e`` outside [0, 1], non-SPD
        ``M``.
    SolverError
        No solution (the bilateral rows force a contact to penetrate, or dependent
        contacts with contradictory restitution), or a degenerate problem Lemke's
        algorithm cannot settle.

    Warns
    -----
    EnergyGainWarning
        ``T^+ > T^-`` (by more than 1e-9 of ``T^-``): Newton's restitution with friction
        (``e > 0``, a slip that stops or reverses: Kane's paradox).

    Examples
    --------
    A 1 kg point hits the floor at 1 m/s with 0.6 m/s of slip. Sticking would need a
    friction impulse of 0.6 N s against a normal impulse of 1 N s: with ``mu = 0.5`` the
    point slides and keeps 0.1 m/s, with ``mu = 0.8`` it sticks.

    >>> import numpy as np, roverimpact.frictional as fr
    >>> for mu in (0.5, 0.8):
    ...     r = fr.frictional_impact(np.eye(2), [0.6, -1.0], [[0.0, 1.0]], [[[1.0, 0.0]]], mu)
    ...     print(r.state.tolist(), np.round(r.v_plus, 12).tolist(),
    ...           np.round(r.impulse_tangent, 12).tolist())
    ['sliding'] [0.1, 0.0] [[-0.5]]
    ['sticking'] [0.0, 0.0] [[-0.6]]
    """
    out, batch, d = _solve(M, v, normal, tangent, mu, restitution, bilateral, facets, tol,
                           rtol, True)
    n, k, tm, pb = d["n"], d["k"], d["tm"], d["pb"]
    v_plus = out["vplus"].reshape(*batch, n)
    imp = out["P"].reshape(*batch, k)
    imp_t = out["Pt"].reshape(*batch, k, tm)
    locked = out["locked"].reshape(*batch, k)
    if pb or locked.any():
        # impulses of the bilateral rows and of the tangent rows of the locked (mu = inf)
        # contacts: minimum-norm split of the momentum they must supply
        vb = np.broadcast_to(d["v"], (*batch, n))
        Mb = np.broadcast_to(d["M"], (*batch, n, n))
        Nb = np.broadcast_to(d["N"], (*batch, k, n))
        Tb = np.broadcast_to(d["Tg"], (*batch, k, tm, n))
        Bb = np.broadcast_to(d["B"], (*batch, pb, n))
        g = (np.einsum("...ij,...j->...i", Mb, v_plus - vb)
             - np.einsum("...ji,...j->...i", Nb, imp)
             - np.einsum("...kti,...kt->...i", Tb, imp_t))
        R = np.concatenate([Bb, (Tb * locked[..., None, None]).reshape(*batch, k * tm, n)],
                           axis=-2)
        c = np.einsum("...ij,...j->...i", np.linalg.pinv(np.swapaxes(R, -1, -2),
                                                         rcond=rtol), g)
        imp_b = c[..., :pb]
        imp_t = imp_t + c[..., pb:].reshape(*batch, k, tm)
    else:
        imp_b = np.zeros((*batch, 0))
    approaching = out["approaching"].reshape(*batch, k)
    Tm, Tp = out["Tm"], out["Tp"]
    warn_energy_gain(Tm, Tp, batch, "Newton's restitution with e > 0 adds energy when a "
                     "contact's slip stops or reverses (Kane's paradox; docs/active-set.md), "
                     "with different e per contact, or with bilateral rows moving before the "
                     "impact: the result is Newton's law, not a physical impact; use e = 0")
    return FrictionalImpactResult(
        v_plus=v_plus,
        impulse=imp,
        impulse_tangent=imp_t,
        impulse_bilateral=imp_b,
        state=_STATE_NAMES[out["state"]].reshape(*batch, k),
        hold_normal=out["hold_n"].reshape(*batch, k),
        hold_tangent=out["hold_t"].reshape(*batch, k, tm),
        approaching=approaching,
        impact=scalarize(approaching.reshape(-1, k).any(axis=-1), batch),
        slack=out["slack"].reshape(*batch, k),
        slip=out["slip"].reshape(*batch, k, tm),
        T_minus=scalarize(Tm, batch),
        T_plus=scalarize(Tp, batch),
        energy_lost=scalarize(Tm - Tp, batch),
        T_c_minus=scalarize(out["Tc"], batch),
        rank=scalarize(out["rank"], batch),
        residual=scalarize(out["resid"], batch),
        locked=locked,
        fallback=scalarize(out["fallback"], batch),
    )


def frictional_active_set(M, v, normal, tangent, mu, bilateral=None, *, ntan=None,
                          restitution=0.0, facets: int = FACETS, tol: float = TOL):
    """Which rows hold through a frictional impact (for T_c^-): ``(hold_normal, hold_tangent)``.

    Same arguments as :func:`frictional_impact` (``tangent`` as an array
    ``(..., k, t, n)``; ``ntan`` (k,) the number of tangent rows each contact has, the
    others being zero). A sticking contact holds its normal and tangent rows, a sliding one
    its normal row, a separating one nothing.

    Returns
    -------
    hold_normal : (..., k) bool ndarray
    hold_tangent : (..., k, t) bool ndarray
    """
    out, batch, _ = _solve(M, v, normal, tangent, mu, restitution, bilateral, facets, tol,
                           RTOL, False, ntan=ntan)
    k = np.shape(normal)[-2]
    tm = np.shape(tangent)[-2]
    return out["hold_n"].reshape(*batch, k), out["hold_t"].reshape(*batch, k, tm)
