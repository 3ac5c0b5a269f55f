r"""Vectorised assembly of a :class:`~roverimpact.models.kinematics.ConstraintSet`'s rows.

The per-constraint path (``GroundContact.rows`` etc.) is the readable reference; this
module computes the same ``A`` in one compiled pass from the world-frame joint Jacobian
``data.J`` (the twist of each joint's motion subspace at the world origin), which the
world-convention CRBA fills as ``pin.computeJointJacobians`` does. For a point ``p`` of
a body with supporting joints ``S``:

.. math::

    v_p = \big(J_{lin} - [p]_\times J_{ang}\big)\big|_{S}\, v, \qquad
    a = d^T v_p = \big(d^T J_{lin} + (p \times d)^T J_{ang}\big)\big|_{S}

(columns outside ``S`` are zero; ``pin.getFrameJacobian`` applies the same mask). The
contact point of a wheel facing a surface of normal ``n`` is the rim point
``c - r\,\hat d``, ``\hat d`` the unit part of ``n`` orthogonal to the world wheel axis
``a = R\,a_{local}``; the no-slip directions are ``t = a \times n / |a \times n|`` and
``n \times t``. Rows that do not depend on ``q`` (locked joints, linear loop closures) are
stored once.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from numba import njit

from .._kernels._jit import NJIT_OPTIONS, b1, f8, i8, kernel, ro, rw
from .._kernels.partition import factor, partition_factored, readonly
from ._build import LinearLoopClosure
from .constraints import RIM_AXIS_TOL, GroundContact, LockedJoint, LoopClosure, PointContact

# row kinds
_NORMAL, _LONG, _LAT, _CONST = 0, 1, 2, 3
# contact kinds
_WHEEL, _POINT = 0, 1


@njit(**NJIT_OPTIONS)
def _assemble(Jt, X, f_row, c_frame, c_kind, c_vec, c_normal, c_radius, r_contact, r_kind,
              r_const, support, rows, A):  # pragma: no cover - compiled
    """Fill ``A`` (k, nv): its row ``i`` is the plan's row ``rows[i]`` (k of them).

    ``Jt`` (nv, 6): the world joint Jacobian ``data.J`` (6, nv) transposed, as Pinocchio
    stores it (column-major: read in place, :data:`_WORLD`).

    ``X`` (., 12): frame placements as Pinocchio stores an SE3, the rotation column-major
    (``R[i, j] = X[g, i + 3 j]``) then the translation (``X[g, 9:12]``); used frame ``f``
    is row ``g = f_row[f]``. ``support`` (F, nv) masks the columns of frame ``f``.
    """
    nc = c_frame.shape[0]
    nv = Jt.shape[0]
    PT = np.empty((nc, 6))  # contact point, then no-slip direction a x n / |a x n| (wheels)
    P, T = PT[:, :3], PT[:, 3:]
    for c in range(nc):
        g = f_row[c_frame[c]]
        n0, n1, n2 = c_normal[c, 0], c_normal[c, 1], c_normal[c, 2]
        if c_kind[c] == _WHEEL:
            x0, x1, x2 = c_vec[c, 0], c_vec[c, 1], c_vec[c, 2]
            a0 = X[g, 0] * x0 + X[g, 3] * x1 + X[g, 6] * x2
            a1 = X[g, 1] * x0 + X[g, 4] * x1 + X[g, 7] * x2
            a2 = X[g, 2] * x0 + X[g, 5] * x1 + X[g, 8] * x2
            na = n0 * a0 + n1 * a1 + n2 * a2
            d0, d1, d2 = n0 - na * a0, n1 - na * a1, n2 - na * a2
            nd = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            if nd < RIM_AXIS_TOL:
                d0, d1, d2 = n0, n1, n2
            else:
                d0, d1, d2 = d0 / nd, d1 / nd, d2 / nd
            r = c_radius[c]
            P[c, 0] = X[g, 9] - r * d0
            P[c, 1] = X[g, 10] - r * d1
            P[c, 2] = X[g, 11] - r * d2
            t0, t1, t2 = a1 * n2 - a2 * n1, a2 * n0 - a0 * n2, a0 * n1 - a1 * n0
            nt = np.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
            if nt > 0.0:
                t0, t1, t2 = t0 / nt, t1 / nt, t2 / nt
            T[c, 0], T[c, 1], T[c, 2] = t0, t1, t2
        else:
            x0, x1, x2 = c_vec[c, 0], c_vec[c, 1], c_vec[c, 2]
            for i in range(3):
                P[c, i] = X[g, 9 + i] + X[g, i] * x0 + X[g, 3 + i] * x1 + X[g, 6 + i] * x2
            T[c, 0], T[c, 1], T[c, 2] = 0.0, 0.0, 0.0
    for i in range(A.shape[0]):
        row = rows[i]
        kind = r_kind[row]
        if kind == _CONST:
            for j in range(nv):
                A[i, j] = r_const[row, j]
            continue
        c = r_contact[row]
        n0, n1, n2 = c_normal[c, 0], c_normal[c, 1], c_normal[c, 2]
        if kind == _NORMAL:
            d0, d1, d2 = n0, n1, n2
        elif kind == _LONG:
            d0, d1, d2 = T[c, 0], T[c, 1], T[c, 2]
        else:  # n x t
            t0, t1, t2 = T[c, 0], T[c, 1], T[c, 2]
            d0, d1, d2 = n1 * t2 - n2 * t1, n2 * t0 - n0 * t2, n0 * t1 - n1 * t0
        p0, p1, p2 = P[c, 0], P[c, 1], P[c, 2]
        # p x d
        e0, e1, e2 = p1 * d2 - p2 * d1, p2 * d0 - p0 * d2, p0 * d1 - p1 * d0
        f = c_frame[c]
        for j in range(nv):
            if support[f, j]:
                A[i, j] = (d0 * Jt[j, 0] + d1 * Jt[j, 1] + d2 * Jt[j, 2]
                           + e0 * Jt[j, 3] + e1 * Jt[j, 4] + e2 * Jt[j, 5])
            else:
                A[i, j] = 0.0


@njit(**NJIT_OPTIONS)
def _symmetrize(M):  # pragma: no cover - compiled
    """Copy the upper triangle of ``M`` (what ``pin.crba`` fills) to the lower one."""
    n = M.shape[0]
    for i in range(1, n):
        for j in range(i):
            M[i, j] = M[j, i]


def _evaluate_signature(nd: int):
    """``(Jt, X, f_row, c_frame, c_kind, c_vec, c_normal, c_radius, r_contact, r_kind,
    r_const, support, M, A)``: ``Jt, X, r_const, M, A`` with ``nd`` dimensions (2: one
    configuration, 3: stacked; stacked, ``c_normal`` and ``c_radius`` have one more),
    inputs read-only C arrays, ``M`` and ``A`` written."""
    return (ro(f8, nd), ro(f8, nd), ro(i8, 1), ro(i8, 1), ro(i8, 1), ro(f8, 2),
            ro(f8, nd), ro(f8, nd - 1), ro(i8, 1), ro(i8, 1), ro(f8, nd), ro(b1, 2),
            rw(f8, nd), rw(f8, nd))


# one explicit signature each (compiled on first use): the placements X may be a read-only
# view of Pinocchio's storage or a writable buffer, which would otherwise compile twice
@kernel(_evaluate_signature(2))
def _evaluate_one(Jt, X, f_row, c_frame, c_kind, c_vec, c_normal, c_radius, r_contact,
                  r_kind, r_const, support, M, A):  # pragma: no cover - compiled
    _symmetrize(M)
    _assemble(Jt, X, f_row, c_frame, c_kind, c_vec, c_normal, c_radius, r_contact, r_kind,
              r_const, support, readonly(np.arange(A.shape[0])), A)  # read-only: one compile


def _partition_at_signature():
    """``(Jt, X, M, ints, floats, support, rows, v, rtol, res) -> status``: one
    configuration's ``Jt``, ``X`` and ``M`` as for :func:`_evaluate_one` (``M`` the upper
    triangle ``pin.crba`` filled, mirrored in place), the plan's other arrays packed in
    two (:func:`_unpack`), then the rows ``rows`` of ``A``, ``v`` and ``rtol`` of the
    partition; ``res`` (4,) receives ``T, T_c, T_a, rank``."""
    return i8(ro(f8, 2), ro(f8, 2), rw(f8, 2), ro(i8, 1), ro(f8, 1), ro(b1, 2), ro(i8, 1),
              ro(f8, 1), f8, rw(f8, 1))


@njit(**NJIT_OPTIONS)
def _unpack(ints, floats, nv):  # pragma: no cover - compiled
    """``(f_row, c_frame, c_kind, c_vec, c_normal, c_radius, r_contact, r_kind, r_const)``
    as views of the two buffers :class:`RowPlan` packs them in (:func:`_pack`): ``ints``
    is ``nc, m``, then ``c_frame, c_kind`` (nc each), ``r_contact, r_kind`` (m each) and
    ``f_row`` (the rest); ``floats`` is ``c_vec, c_normal`` (nc, 3), ``c_radius`` (nc)
    and ``r_const`` (m, nv), each C-ordered."""
    nc, m = ints[0], ints[1]
    o = 2 + 2 * nc + 2 * m
    return (ints[o:], ints[2:2 + nc], ints[2 + nc:2 + 2 * nc],
            floats[:3 * nc].reshape((nc, 3)), floats[3 * nc:6 * nc].reshape((nc, 3)),
            floats[6 * nc:7 * nc], ints[2 + 2 * nc:2 + 2 * nc + m],
            ints[2 + 2 * nc + m:o], floats[7 * nc:7 * nc + m * nv].reshape((m, nv)))


# The plan's constant arrays come packed in two: numba's dispatcher checks the type of each
# argument of every call and converts it, a good part of a call of a few microseconds
@kernel(_partition_at_signature())
def _partition_at(Jt, X, M, ints, floats, support, rows, v, rtol, res
                  ):  # pragma: no cover - compiled
    """M and the chosen rows of A at one configuration, and their kinetic-energy partition
    (``T``, ``T_c``, ``T_a``, rank; no velocities), in one call: the one-item partition of
    :mod:`roverimpact._kernels.partition` (the same checks; a nonzero status is its code)."""
    nv = M.shape[0]
    f_row, c_frame, c_kind, c_vec, c_normal, c_radius, r_contact, r_kind, r_const = _unpack(
        ints, floats, nv)
    _symmetrize(M)
    m = rows.shape[0]
    A = np.empty((m, nv))  # only the chosen rows
    _assemble(Jt, X, f_row, c_frame, c_kind, c_vec, c_normal, c_radius, r_contact, r_kind,
              r_const, support, rows, A)
    L = np.zeros((nv, nv))
    invd = np.empty(nv)
    code = factor(readonly(M), L, invd)  # read-only, as the partition kernels pass them:
    if code != 0:  # one compiled version of factor and partition_factored, not two
        return code
    W = np.empty((m, nv))
    H = np.empty((m, nv))
    scratch = np.empty((4, nv))
    cn = np.empty((2, m))
    no_vc = np.bool_(False)  # not a literal: one compile of partition_factored, not two
    return partition_factored(L, invd, readonly(A), v, rtol, no_vc, W, H, cn[0], scratch[0],
                              scratch[1], scratch[2], cn[1], scratch[3], res)


@kernel(_evaluate_signature(3))
def _evaluate_many(Jt, X, f_row, c_frame, c_kind, c_vec, c_normal, c_radius, r_contact,
                   r_kind, r_const, support, M, A):  # pragma: no cover - compiled
    """Items ``i`` of ``Jt`` (k, nv, 6), ``X`` (k, ., 12), ``M`` (k, nv, nv), ``A`` (k, m, nv);
    ``r_const`` (1 or k, m, nv), ``c_normal`` (1 or k, nc, 3), ``c_radius`` (1 or k, nc)."""
    kc, kn, kr = r_const.shape[0], c_normal.shape[0], c_radius.shape[0]
    every = readonly(np.arange(A.shape[1]))  # every row (read-only, as _partition_at's)
    for i in range(Jt.shape[0]):
        _symmetrize(M[i])
        _assemble(Jt[i], X[i], f_row, c_frame, c_kind, c_vec, c_normal[min(i, kn - 1)],
                  c_radius[min(i, kr - 1)], r_contact, r_kind, r_const[min(i, kc - 1)],
                  support, every, A[i])


class RowPlan:
    """Structure of a constraint set's rows, built once; :meth:`rows` after kinematics."""

    def __init__(self, cs):

        model = cs.mbm.model
        nv = model.nv
        frames: list[int] = []  # distinct frame ids, in first-use order
        contacts = []  # (frame slot, kind, vec, normal, radius)
        rows = []  # (contact, kind, const row)
        self.loop_rows: list[int] = []  # rows of a nonlinear loop closure (per call)
        self._loop_constant = True
        #: contact index of each constraint (-1: not a contact), and the wheel of each
        #: contact (None: a point)
        self.constraint_contact: list[int] = []
        self.contact_wheel: list[str | None] = []
        for c, fid in zip(cs.constraints, cs._fids, strict=True):
            if fid is not None and fid not in frames:
                frames.append(fid)
            wheel = getattr(c, "wheel", None)
            is_contact = isinstance(c, (GroundContact, PointContact))
            self.constraint_contact.append(len(contacts) if is_contact else -1)
            if is_contact:
                self.contact_wheel.append(None if wheel is None else wheel.name)
            if isinstance(c, GroundContact):
                ci = len(contacts)
                contacts.append((frames.index(fid), _WHEEL, c.wheel.axis, c.normal,
                                 c.wheel.radius))
                rows.append((ci, _NORMAL, None))
                if c.noslip:
                    rows.append((ci, _LONG, None))
                    if not c.planar:
                        rows.append((ci, _LAT, None))
            elif isinstance(c, PointContact):
                ci = len(contacts)
                if c.wheel is not None:
                    contacts.append((frames.index(fid), _WHEEL, c.wheel.axis, c.normal,
                                     c.wheel.radius))
                else:
                    contacts.append((frames.index(fid), _POINT, c.point, c.normal, 0.0))
                rows.append((ci, _NORMAL, None))
            elif isinstance(c, LockedJoint):
                j = model.joints[model.getJointId(c.joint)]
                for k in range(j.nv):
                    r = np.zeros(nv)
                    r[j.idx_v + k] = 1.0
                    rows.append((-1, _CONST, r))
            elif isinstance(c, LoopClosure):
                loop = cs.mbm.loop_closure
                # a linear closure (constant J) is stored once; others are recomputed

                Jl = loop(np.asarray(pin.neutral(model)))[1]
                self._loop_constant &= (isinstance(loop, LinearLoopClosure)
                                        or getattr(loop, "constant_jacobian", False))
                for k in range(Jl.shape[0]):
                    self.loop_rows.append(len(rows))
                    rows.append((-1, _CONST, np.array(Jl[k], dtype=float)))
        self.frame_ids = frames
        nf, nc, m = len(frames), len(contacts), len(rows)
        self.c_frame = np.array([c[0] for c in contacts], dtype=np.int64).reshape(nc)
        self.c_kind = np.array([c[1] for c in contacts], dtype=np.int64).reshape(nc)
        self.c_vec = np.array([c[2] for c in contacts], dtype=float).reshape(nc, 3)
        self.c_normal = np.array([c[3] for c in contacts], dtype=float).reshape(nc, 3)
        self.c_radius = np.array([c[4] for c in contacts], dtype=float).reshape(nc)
        self.r_contact = np.array([max(r[0], 0) for r in rows], dtype=np.int64).reshape(m)
        self.r_kind = np.array([r[1] for r in rows], dtype=np.int64).reshape(m)
        self.r_const = np.zeros((m, nv))
        for i, r in enumerate(rows):
            if r[2] is not None:
                self.r_const[i] = r[2]
        self.support = np.zeros((max(nf, 1), nv), dtype=np.bool_)
        for k, fid in enumerate(frames):
            jid = model.frames[fid].parentJoint
            for s in model.supports[jid]:
                if s == 0:
                    continue
                jm = model.joints[s]
                self.support[k, jm.idx_v:jm.idx_v + jm.nv] = True
        self.m, self.nv = m, nv
        self._cs = cs
        # the model and data every pass uses (the placement view below reads this data):
        # the data of the thread that makes the plan (ConstraintSet.data)
        self._model, self._data = model, cs.data
        # frame placements: a read-only view of Pinocchio's own storage when its layout is
        # the expected one (checked here), else a buffer refilled frame by frame per call
        self._oMf = _placement_view(cs.data, model.nframes) if frames else None
        # the world joint Jacobian, transposed (nv, 6): a view of Pinocchio's data.J (its
        # column-major storage), which the world-convention CRBA fills (:data:`_WORLD`)
        self._Jt = _jacobian_view(cs.data, nv)
        if self._oMf is not None:
            self.f_row = np.array(frames, dtype=np.int64)
        else:
            self.f_row = np.arange(max(nf, 1), dtype=np.int64)
        self._X = np.zeros((max(nf, 1), 12))
        # the arrays above become views of two buffers (for _partition_at, which takes
        # them packed); r_const's loop rows are written through its view
        self._ints, (_, self.c_frame, self.c_kind, self.r_contact, self.r_kind, self.f_row) = (
            _pack((np.array([nc, m]), self.c_frame, self.c_kind, self.r_contact, self.r_kind,
                   self.f_row), np.int64))
        self._floats, (self.c_vec, self.c_normal, self.c_radius, self.r_const) = _pack(
            (self.c_vec, self.c_normal, self.c_radius, self.r_const), np.float64)
        self._args = (self.f_row, self.c_frame, self.c_kind, self.c_vec, self.c_normal,
                      self.c_radius, self.r_contact, self.r_kind)
        # _pass's short path: nv > 1 (Pinocchio's arrays are 2-D), the placements
        # read in place, no loop rows to recompute; and partition_at's compiled kernel,
        # once loaded
        self._plain = nv > 1 and self._oMf is not None and self._loop_constant
        self._run = None

    @property
    def loops_constant(self) -> bool:
        """Whether the loop-closure rows are the same at every configuration."""
        return self._loop_constant

    def _placements(self, X=None) -> np.ndarray:
        """Placements ``(., 12)`` of the frames (after ``updateFramePlacements``)."""
        if self._oMf is not None:
            if X is None:
                return self._oMf
            X[...] = self._oMf
            return X
        X = self._X if X is None else X
        oMf = self._data.oMf
        for k, fid in enumerate(self.frame_ids):
            H = oMf[fid].homogeneous
            X[k, :9] = H[:3, :3].T.reshape(9)
            X[k, 9:] = H[:3, 3]
        return X

    def _pass(self, q) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One Pinocchio pass at ``q`` (nq,): ``M`` (its upper triangle, from CRBA), the
        world joint Jacobian transposed ``Jt`` (nv, 6) and the frame placements ``X``; the
        rows of a nonlinear loop closure updated in :attr:`r_const`."""
        model, data = self._model, self._data
        M = pin.crba(model, data, q, _WORLD)
        Jt = self._Jt if self._Jt is not None else _jacobian_copy(data, self.nv)
        pin.updateFramePlacements(model, data)
        if self._plain:  # the usual plan (the hot path of T_c_at): nothing more to do
            return M, Jt, self._oMf
        if self.nv == 1:  # (pinocchio may hand a (1, 1) matrix back as a 1-D array)
            M = np.reshape(M, (1, 1)).copy()
        X = self._oMf if self._oMf is not None else self._placements()
        if not self._loop_constant:
            Jl = self._cs.mbm.loop_closure(q)[1]
            for k, i in enumerate(self.loop_rows):
                self.r_const[i] = Jl[k]
        return M, Jt, X

    def evaluate(self, q) -> tuple[np.ndarray, np.ndarray]:
        """``(M (nv, nv), A (m, nv))`` at ``q`` (nq,) from one Pinocchio pass.

        CRBA (upper triangle of ``M``), joint Jacobians ``data.J`` and frame placements,
        then one compiled call that mirrors ``M`` and fills every row of ``A``.
        """
        M, Jt, X = self._pass(q)
        A = np.empty((self.m, self.nv))
        _evaluate_one.get(1)(Jt, X, *self._args, self.r_const, self.support, M, A)
        return M, A

    def partition_at(self, q, rows: np.ndarray, v: np.ndarray, rtol: float,
                     res: np.ndarray) -> int:
        """The partition (``T, T_c, T_a``, rank into ``res`` (4,)) of the rows ``rows`` of
        ``A`` at one configuration ``q`` (nq,) with velocity ``v``: one Pinocchio pass and
        one compiled call (:func:`_partition_at`). Returns the partition's status code
        (nonzero: the caller makes the error message, from :meth:`evaluate`)."""
        run = self._run
        if run is None:
            run = _partition_at.get(1)
            if _partition_at.compiled:  # then get(1) returns it from now on
                self._run = run
        M, Jt, X = self._pass(q)
        return run(Jt, X, M, self._ints, self._floats, self.support, rows, v, rtol, res)

    def evaluate_many(self, Q, chunk: int = 64, *, before=None, c_normal=None,
                      c_radius=None) -> tuple[np.ndarray, np.ndarray]:
        """``(M (k, nv, nv), A (k, m, nv))`` for configurations ``Q`` (k, nq).

        One Pinocchio pass per configuration, its Jacobian and placements copied into
        small stacked buffers; one compiled call per ``chunk`` items (the buffers stay in
        cache).

        Items may be other models of the same structure (a family,
        :class:`~roverimpact.models.family.ModelFamily`): ``before(i)`` is called before
        item ``i``'s Pinocchio pass (to write its numbers into the model), and
        ``c_normal`` (k, nc, 3) and ``c_radius`` (k, nc) give each item's contact normals
        and wheel radii (default: this plan's, :attr:`c_normal`, :attr:`c_radius`).
        """
        model, data = self._model, self._data
        cn = self.c_normal[None] if c_normal is None else np.ascontiguousarray(c_normal)
        cr = self.c_radius[None] if c_radius is None else np.ascontiguousarray(c_radius)
        for x, name in ((cn, "c_normal"), (cr, "c_radius")):
            if x.shape[0] not in (1, Q.shape[0]):
                raise ValueError(f"{name}: one item or {Q.shape[0]}, got {x.shape}")
        args = (*self._args[:4], cn, cr, *self._args[6:])
        k, nv, m = Q.shape[0], self.nv, self.m
        Ms = np.empty((k, nv, nv))
        A = np.empty((k, m, nv))
        c = max(1, min(chunk, k))
        Js = np.empty((c, nv, 6))
        Xs = np.empty((c, *self._placements().shape))
        if self._loop_constant:
            rc = self.r_const[None]
        else:
            rc = np.broadcast_to(self.r_const, (k, m, nv)).copy()
            for i in range(k):
                rc[i, self.loop_rows] = self._cs.mbm.loop_closure(Q[i])[1]
        crba, place, world, Jt = pin.crba, pin.updateFramePlacements, _WORLD, self._Jt
        # (pinocchio may hand a (1, 1) matrix back as a 1-D array: write through 1-D views)
        Mo = Ms.reshape(k, 1) if nv == 1 else Ms
        view = self._oMf
        for s in range(0, k, c):
            e = min(s + c, k)
            for i in range(s, e):
                q = Q[i]
                if before is not None:
                    before(i)
                Mo[i] = crba(model, data, q, world)
                Js[i - s] = Jt if Jt is not None else _jacobian_copy(data, nv)
                place(model, data)
                if view is not None:
                    Xs[i - s] = view
                else:
                    self._placements(Xs[i - s])
            _evaluate_many.get(e - s)(Js[:e - s], Xs[:e - s], *args[:4],
                                 cn if cn.shape[0] == 1 else cn[s:e],
                                 cr if cr.shape[0] == 1 else cr[s:e], *args[6:],
                                 rc if rc.shape[0] == 1 else rc[s:e], self.support, Ms[s:e],
                                 A[s:e])
        return Ms, A


#: CRBA in Pinocchio's world convention: ``M``'s upper triangle as the local convention
#: makes it (to rounding, 1e-14 of its largest entry), and on the way the world joint
#: Jacobian ``data.J`` and ``data.oMi`` that ``pin.computeJointJacobians`` makes (the
#: same forward step, equal to the bit: ``tests/test_models_assemble.py``): one pass over
#: the tree for both.
_WORLD = pin.Convention.WORLD


def _jacobian_view(data, nv: int) -> np.ndarray | None:
    """``data.J`` (6, nv) transposed, (nv, 6) C-ordered: a view of Pinocchio's column-major
    storage, which every pass rewrites in place; None if ``data.J`` is not handed out as
    such a view (then :func:`_jacobian_copy` per pass). Like :func:`_placement_view`, it
    refers to ``data``'s memory: the owner keeps ``data`` alive and never resizes it."""
    J = data.J
    Jt = J.reshape(1, 6) if nv == 1 else J.T
    if (Jt.shape == (nv, 6) and Jt.flags.c_contiguous and Jt.dtype == np.float64
            and np.shares_memory(Jt, data.J)):
        return Jt
    return None  # pragma: no cover - Pinocchio as installed hands out views


def _jacobian_copy(data, nv: int) -> np.ndarray:
    """``data.J`` transposed as a new (nv, 6) C-ordered array."""
    return np.ascontiguousarray(np.reshape(data.J, (6, nv)).T)


def _pack(arrays, dtype) -> tuple[np.ndarray, list[np.ndarray]]:
    """One 1-D buffer holding ``arrays`` one after the other (C order), and a view of it
    shaped as each of them."""
    buf = np.concatenate([np.asarray(a, dtype=dtype).ravel() for a in arrays])
    views, o = [], 0
    for a in arrays:
        views.append(buf[o:o + a.size].reshape(a.shape))
        o += a.size
    return buf, views


def _placement_view(data, nframes: int):
    """``data.oMf`` as one read-only ``(nframes, 12)`` array, or None.

    Pinocchio keeps the frame placements in one contiguous ``std::vector<SE3>``; each SE3 is
    its rotation (3 x 3, column-major) followed by its translation, and ``.rotation`` /
    ``.translation`` are views of that storage. When every frame is laid out that way (the
    addresses are checked, not assumed), a strided view over the vector reads all
    placements without a Python call per frame. The view refers to ``data``'s memory: the
    owner keeps ``data`` alive and never resizes it.
    """
    try:
        oMf = data.oMf
        R0 = oMf[0].rotation
        if R0.dtype != np.float64 or R0.strides != (8, 24):
            return None
        base = R0.__array_interface__["data"][0]
        for i in range(nframes):
            se = oMf[i]
            R, p = se.rotation, se.translation
            if (R.strides != (8, 24) or p.strides != (8,)
                    or R.__array_interface__["data"][0] != base + 96 * i
                    or p.__array_interface__["data"][0] != base + 96 * i + 72):
                return None
        X = np.lib.stride_tricks.as_strided(R0, shape=(nframes, 12), strides=(96, 8),
                                            writeable=False)
        for i in {0, nframes - 1}:  # the addresses matched: the values are the same memory
            se = oMf[i]
            if not (np.array_equal(X[i, :9], se.rotation.T.reshape(9))
                    and np.array_equal(X[i, 9:], se.translation)):
                return None  # pragma: no cover - the addresses matched
        return X
    except Exception:  # pragma: no cover - a binding without these attributes
        return None
