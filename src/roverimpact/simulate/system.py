r"""Equations of motion of a Pinocchio model with compliant wheel contacts and loop closures.

.. math::

    M(q)\,\dot v + h(q, v) = \tau_s(q, v) + \sum_i J_{p,i}^T F_i + J_l^T \lambda, \qquad
    J_l \dot v = -\dot J_l v - 2\alpha J_l v - \alpha^2 \phi(q)

``h`` is Pinocchio's nonLinearEffects (Coriolis, centrifugal, gravity), ``tau_s`` the joint
springs and dampers, ``F_i`` the contact force of wheel/plane pair ``i`` applied at the
contact point with linear Jacobian ``J_p,i`` and ``(phi, J_l)`` the loop closure with
Baumgarte gain ``alpha``. Trees without loops use ABA directly.

Configurations live on the manifold: the state is a chart ``dq`` around an anchor
``q_ref``, ``q = integrate(q_ref, dq)``, with ``d(dq)/dt = (d integrate / d dq)^{-1} v``.
The integrator re-anchors when ``|dq|`` grows (see ``_run``).
"""

from __future__ import annotations

from bisect import bisect_left
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..contact.hunt_crossley import family_force, one_family
from ..exceptions import ModelError
from ..models.constraints import loop_jdot_v

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
#: Singular values of a constant loop Jacobian ``J`` below this times the largest mark
#: dependent rows: the least-squares solve of the general path drops those of
#: ``J M^-1 J^T`` below 1e-12 times the largest, about the square of this
_LOOP_RCOND = 1e-6
_EUCLIDEAN_JOINTS = {"JointModelRX", "JointModelRY", "JointModelRZ", "JointModelPX",
                     "JointModelPY", "JointModelPZ", "JointModelRevoluteUnaligned",
                     "JointModelPrismaticUnaligned", "JointModelTranslation"}


def _skew(d: np.ndarray) -> np.ndarray:
    """Batched skew matrices: (..., 3) -> (..., 3, 3) with skew(d) w = d x w."""
    S = np.zeros((*d.shape[:-1], 3, 3))
    S[..., 0, 1], S[..., 0, 2] = -d[..., 2], d[..., 1]
    S[..., 1, 0], S[..., 1, 2] = d[..., 2], -d[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -d[..., 1], d[..., 0]
    return S


@dataclass
class Plane:
    """A contact plane ``n . (x - p0) = 0`` with outward unit normal ``n``.

    ``z_max`` bounds a half-plane face (obstacle of finite height): contact points above
    it do not touch. ``wheels`` (a bool per wheel, ``None`` for all) says which wheels
    can touch it: an obstacle in front of some wheels only. ``law`` is a contact law
    object, ``v_i`` the penetration velocity passed to it.
    """

    name: str
    n: np.ndarray
    p0: np.ndarray
    law: object
    v_i: float
    z_max: float = np.inf
    wheels: np.ndarray | None = None


@dataclass
class ContactState:
    """Contact quantities of every wheel/plane pair at one instant (arrays (planes, wheels))."""

    gap: np.ndarray
    delta: np.ndarray
    delta_dot: np.ndarray
    f_n: np.ndarray
    f_t: np.ndarray          # magnitude of the friction force
    F: np.ndarray            # (planes, wheels, 3) contact force on the wheel, world axes
    Jp: np.ndarray           # (planes, wheels, 3, nv) contact-point Jacobians
    tau: np.ndarray          # (nv,) generalized contact force
    n: np.ndarray | None = None   # (planes, wheels, 3) contact normals


@dataclass(frozen=True)
class ContactForces:
    """What the equations of motion need at one instant (:meth:`ContactSystem.applied_force`).

    ``gap``, ``delta`` (indentation ``max(-gap, 0)``), ``f_n``, ``f_t``: (planes, wheels)
    as in :class:`ContactState`; ``tau`` (nv,) the generalized force of the contacts and
    the joint springs, ``sum_i J_p,i^T F_i + tau_s``.
    """

    gap: np.ndarray
    f_n: np.ndarray
    f_t: np.ndarray
    tau: np.ndarray

    @property
    def delta(self) -> np.ndarray:
        return np.maximum(-self.gap, 0.0)


@dataclass
class ContactSystem:
    """A Pinocchio model, its wheels, planes, springs and loop closure, ready to integrate.

    Parameters
    ----------
    model : pinocchio.Model
        Copied; its gravity is set from ``gravity`` (3,).
    wheel_frames, radii : list of str, (nw,) array
    planes : list of Plane
    springs : list of (idx_v, value, k, c, q0)
        Joint springs: ``value(q)`` is the joint's angle or displacement (continuous
        joints included), ``tau[idx_v] = -k (value - q0) - c v[idx_v]``.
    loop_closure : callable or None
        ``q -> (phi (k,), J (k, nv))``.
    mu, v_slip : float
        Regularised Coulomb friction ``F_t = -mu f_n tanh(|v_t|/v_slip) v_t/|v_t|``.
    baumgarte : float
        Gain alpha [1/s] of the loop-closure stabilisation.
    terrain : TerrainGround or None
        The ground under the wheels (:class:`~roverimpact.simulate.terrain.TerrainGround`):
        then ``planes[0]`` is the ground (its law and ``v_i``) and its geometry per wheel
        (normal, contact point, gap) comes from the terrain under the wheel's disc, not
        from the plane. ``None``: the plane ``planes[0]`` as given (spheres).
    axes : (nw, 3) array or None
        Spin axes of the wheels in their frames (needed with ``terrain``).
    """

    model: object
    wheel_frames: list
    radii: np.ndarray
    planes: list
    gravity: np.ndarray
    springs: list = field(default_factory=list)
    loop_closure: object = None
    mu: float = 0.0
    v_slip: float = 1e-3
    baumgarte: float = 20.0
    terrain: object = None
    axes: np.ndarray | None = None

    def __post_init__(self):
        self.model = pin.Model(self.model)
        self.model.gravity.linear = np.asarray(self.gravity, dtype=float)
        self.data = self.model.createData()
        self.nq, self.nv = self.model.nq, self.model.nv
        self.fids = []
        for f in self.wheel_frames:
            if not self.model.existFrame(f):
                raise ModelError(f"wheel frame {f!r} is not a frame of model "
                                 f"{self.model.name!r}")
            self.fids.append(self.model.getFrameId(f))
        self.radii = np.asarray(self.radii, dtype=float)
        if self.terrain is not None:
            if self.axes is None or np.shape(self.axes) != (len(self.fids), 3):
                raise ModelError("a terrain under the wheels needs their spin axes "
                                 "(axes, one per wheel)")
            self.axes = np.asarray(self.axes, dtype=float)
            self.axes = self.axes / np.linalg.norm(self.axes, axis=1)[:, None]
        self._lower = np.tril_indices(self.nv, -1)
        # (closure, B, Jr) of a closure with a constant Jacobian, made at its first use
        self._rows = None
        self._centre_views = _FrameTranslations()
        self.euclidean = self.nq == self.nv and all(
            j.shortname() in _EUCLIDEAN_JOINTS for j in list(self.model.joints)[1:])
        self._set_planes()

    def _set_planes(self):
        self.N = np.array([p.n for p in self.planes]).reshape(-1, 3)
        self.offsets = np.array([p.n @ p.p0 for p in self.planes])
        self.z_max = np.array([p.z_max for p in self.planes])
        nw = len(self.radii)
        self.touch = np.array([np.ones(nw, bool) if p.wheels is None
                               else np.asarray(p.wheels, bool) for p in self.planes])
        self.bounded = bool(np.isfinite(self.z_max).any() or not self.touch.all())
        runs = []                         # [k0, k1): consecutive planes of one law object
        for k, p in enumerate(self.planes):
            if runs and self.planes[runs[-1][0]].law is p.law:
                runs[-1][1] = k + 1
            else:
                runs.append([k, k + 1])
        self._law_runs = [tuple(r) for r in runs]
        # pairs by flat index k * nw + w (row-major in (planes, wheels)): their frame and normal
        self._pair_fid = self.fids * len(self.planes)
        self._N_pairs = np.repeat(self.N, nw, axis=0)
        self._family = _Family.of(self.planes)
        self._offsets_col, self._z_max_col = self.offsets[:, None], self.z_max[:, None]
        self._radii_row = self.radii[None, :]
        self._r_nz = self.radii[None, :] * self.N[:, None, 2]   # height of c - r n over c
        # contact point = centre - r n: J_p = J_lin - skew(-r n) J_ang = J_lin + r skew(n) J_ang
        self.rSn = self.radii[None, :, None, None] * _skew(self.N)[:, None, :, :]

    # ------------------------------------------------------------------ manifold chart
    def config(self, q_ref: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """q = integrate(q_ref, dq)."""
        if self.euclidean:
            return q_ref + dq
        return pin.integrate(self.model, q_ref, dq)

    def chart_rate(self, q_ref, dq, v) -> np.ndarray:
        """d(dq)/dt for generalized velocity v at q = integrate(q_ref, dq)."""
        if self.euclidean:
            return v
        Jint = pin.dIntegrate(self.model, q_ref, dq, pin.ArgumentPosition.ARG1)
        try:
            return np.linalg.solve(Jint, v)
        except np.linalg.LinAlgError:
            # only a trial stage far off the chart (|dq| ~ 2 pi; the run re-anchors at
            # 0.5): a finite value the step's error estimate rejects, not an exception
            return np.linalg.lstsq(Jint, v, rcond=None)[0]

    # ------------------------------------------------------------------ kinematics
    def wheel_kinematics(self, q, v=None):
        """Wheel centres (nw, 3) and frame Jacobians (nw, 6, nv) in world-aligned axes."""
        model, data = self.model, self.data
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        c = self._centres()
        J = np.array([pin.getFrameJacobian(model, data, f, _LWA) for f in self.fids])
        return c, J.reshape(len(self.fids), 6, self.nv)

    def wheel_centres(self, q) -> np.ndarray:
        pin.framesForwardKinematics(self.model, self.data, q)
        return self._centres()

    def _centres(self) -> np.ndarray:
        """Wheel centres (nw, 3) from the current frame placements."""
        return self._centre_views.get(self.data, self.fids)

    def gaps(self, q) -> np.ndarray:
        """Signed gaps (planes, wheels): n . (c - p0) - r [m] (the terrain's gap on row 0
        with a terrain)."""
        if self.terrain is not None:
            pin.framesForwardKinematics(self.model, self.data, q)
            c, ax = self._centres_axes()
            return self._geometry(c, ax)[2]
        c = self.wheel_centres(q)
        return self._gaps(c)

    def gaps_of_centres(self, c) -> np.ndarray:
        """:meth:`gaps` of wheel spheres at centres ``c`` (nw, 3) given by another engine
        (planes only, no terrain)."""
        return self._gaps(np.asarray(c, dtype=float))

    def _gaps(self, c):
        g = self.N @ c.T - self._offsets_col - self._radii_row            # (np, nw)
        if not self.bounded:
            return g
        # contact points above the top of a finite face, and wheels the face is not in
        # front of, do not touch it
        z_cp = c[:, 2] - self._r_nz                                       # (np, nw)
        return np.where((z_cp <= self._z_max_col) & self.touch, g, np.inf)

    # ------------------------------------------------------------------ terrain
    def _centres_axes(self):
        """Wheel centres and world spin axes (nw, 3) from the current frame placements."""
        oMf = [self.data.oMf[f] for f in self.fids]
        c = np.array([m.translation for m in oMf]).reshape(-1, 3)
        R = np.array([m.rotation for m in oMf]).reshape(-1, 3, 3)
        return c, np.einsum("wij,wj->wi", R, self.axes)

    def _geometry(self, c, ax):
        """Normals ``N`` and contact offsets ``D = p - c`` (planes, wheels, 3) and gaps
        (planes, wheels) with a terrain: row 0 from the terrain under each wheel's disc,
        the other planes as spheres (``D = -r n``)."""
        npl, nw = len(self.planes), len(self.fids)
        N = np.broadcast_to(self.N[:, None, :], (npl, nw, 3)).copy()
        D = -self.radii[None, :, None] * N
        gap = self.N @ c.T - self.offsets[:, None] - self.radii[None, :]
        N[0], D[0], gap[0] = self.terrain.contact(c, ax, self.radii)
        if self.bounded:
            ok = (c[None, :, 2] + D[:, :, 2] <= self.z_max[:, None]) & self.touch
            ok[0] = True                               # the ground has no edge
            gap = np.where(ok, gap, np.inf)
        return N, D, gap

    def _contacts_terrain(self, q, v, v_i):
        model, data = self.model, self.data
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        c, ax = self._centres_axes()
        J = np.array([pin.getFrameJacobian(model, data, f, _LWA) for f in self.fids])
        J = J.reshape(len(self.fids), 6, self.nv)
        N, D, gap = self._geometry(c, ax)
        # contact point p = c + D: J_p = J_lin - skew(D) J_ang
        Jp = J[None, :, :3, :] - _skew(D) @ J[None, :, 3:, :]       # (np, nw, 3, nv)
        vp = Jp @ v
        vn = (vp * N).sum(axis=-1)
        return self._forces(gap, Jp, vp, vn, N, v_i)

    # ------------------------------------------------------------------ contact forces
    def contacts(self, q, v, v_i=None) -> ContactState:
        """Contact forces of all wheel/plane pairs at (q, v)."""
        if self.terrain is not None:
            return self._contacts_terrain(q, v, v_i)
        c, J = self.wheel_kinematics(q)
        gap = self._gaps(c)
        Jp = J[None, :, :3, :] + self.rSn @ J[None, :, 3:, :]        # (np, nw, 3, nv)
        vp = Jp @ v                                                  # (np, nw, 3)
        vn = (vp * self.N[:, None, :]).sum(axis=-1)
        return self._forces(gap, Jp, vp, vn, self.N[:, None, :], v_i)

    def applied_force(self, q, v, v_i=None) -> ContactForces:
        """The contact forces and the generalized force of contacts and springs at (q, v):
        :meth:`generalized_forces` (same equations), without the quantities of the pairs
        out of contact (their point Jacobians, velocities and forces are not formed). The
        simulator's right-hand side."""
        model, data = self.model, self.data
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        if self.terrain is not None:
            N_all, D, gap = self._geometry(*self._centres_axes())
        else:
            gap = self._gaps(self._centres())
        f_n = np.zeros(gap.shape)
        f_t = np.zeros(gap.shape)
        tau = self.spring_torque(q, v)
        # pairs in contact k * nw + w, by plane (np.flatnonzero: 2 us more)
        flat = (gap < 0.0).ravel().nonzero()[0]
        if flat.size == 0:
            return ContactForces(gap, f_n, f_t, tau)
        fid = self._pair_fid
        J = np.concatenate([pin.getFrameJacobian(model, data, fid[i], _LWA)
                            for i in flat.tolist()]).reshape(-1, 6, self.nv)
        if self.terrain is not None:
            N = N_all.reshape(-1, 3).take(flat, axis=0)
            Dk = D.reshape(-1, 3).take(flat, axis=0)
            Jp = J[:, :3, :] - _skew(Dk) @ J[:, 3:, :]             # (K, 3, nv)
        else:
            # (take: ~1 us less than [flat] each)
            N = self._N_pairs.take(flat, axis=0)
            Jp = J[:, :3, :] + self.rSn.reshape(-1, 3, 3).take(flat, axis=0) @ J[:, 3:, :]
        vp = Jp @ v                                              # (K, 3)
        vn = (vp * N).sum(axis=-1)
        fn, ft, F = self._pair_forces(flat, -gap.take(flat), vp, vn, N, v_i)
        f_n.put(flat, fn)
        f_t.put(flat, ft)
        # summed in the order of ContactState.tau (pairs row-major): the same bits
        tau += (Jp * F[:, :, None]).sum(axis=(0, 1))
        return ContactForces(gap, f_n, f_t, tau)

    def _pair_forces(self, flat, delta, vp, vn, N, v_i):
        """Normal force ``f_n``, friction force ``f_t`` (K,) and contact force ``F`` (K, 3)
        of K pairs in contact: flat index ``flat`` = plane * wheels + wheel (ascending),
        indentation ``delta`` > 0, contact-point velocity ``vp`` (K, 3), normal velocity
        ``vn``, normal ``N`` (K, 3). Pairs on several planes whose laws are all of the
        Hunt–Crossley family with one exponent: one evaluation of
        :func:`~roverimpact.contact.hunt_crossley.family_force` with the parameters per pair;
        else one law call for consecutive planes that share a law and ``v_i``. Laws are
        elementwise: the same values as one call per plane."""
        K = flat.size
        planes = self.planes
        nw = len(self.fids)
        v_i = [p.v_i for p in planes] if v_i is None else v_i
        fl = flat.tolist()
        fam = self._family
        if fam is not None:
            a = fl[0] // nw
            if a == fl[-1] // nw:                      # all pairs on plane a
                raw = family_force(fam.k[a], fam.n, fam.z[a], delta, -vn, v_i[a])
            else:                                      # parameters per pair
                k, z, vi = fam.per_pair(v_i, nw).take(flat, axis=1)
                raw = family_force(k, fam.n, z, delta, -vn, vi)
            fn = np.maximum(raw, 0.0)
        else:
            fn = self._law_forces(fl, delta, -vn, v_i)
        F = fn[:, None] * N
        if self.mu > 0.0:
            vt = vp - vn[:, None] * N
            s = np.sqrt((vt * vt).sum(axis=-1))
            ft = self.mu * fn * np.tanh(s / self.v_slip)
            F = F - (ft / np.maximum(s, 1e-300))[:, None] * vt
        else:
            ft = np.zeros(K)
        return fn, ft, F

    def _law_forces(self, fl, delta, rate, v_i):
        """Normal forces (K,) of the pairs of flat indices ``fl`` (ascending list): one call
        of the law for consecutive planes that share a law and ``v_i``, none for planes
        without pairs."""
        K, nw, planes = len(fl), len(self.fids), self.planes
        fn = None
        for k0, k1 in self._law_runs:
            i0 = bisect_left(fl, k0 * nw)
            if i0 == K or fl[i0] >= k1 * nw:       # no pair on these planes
                continue
            if k1 - k0 == 1 or all(x == v_i[k0] for x in v_i[k0 + 1:k1]):
                runs = ((k0, k1),)
            else:
                runs = [(k, k + 1) for k in range(k0, k1)]
            for a, b in runs:
                i0, i1 = bisect_left(fl, a * nw), bisect_left(fl, b * nw)
                if i1 == i0:
                    continue
                raw = planes[a].law.force(delta[i0:i1], rate[i0:i1], v_i[a])
                f = np.maximum(np.asarray(raw, float), 0.0)
                if i0 == 0 and i1 == K and f.shape == (K,):   # one call for all pairs
                    return f
                if fn is None:
                    fn = np.empty(K)
                fn[i0:i1] = f
        return fn

    def _forces(self, gap, Jp, vp, vn, N, v_i) -> ContactState:
        """Normal and friction forces from the gaps, point Jacobians, contact-point
        velocities ``vp`` and normal velocities ``vn`` (``N``: normals, broadcastable to
        (planes, wheels, 3))."""
        npl, nw = gap.shape
        delta = -gap if not self.bounded else np.where(np.isfinite(gap), -gap, -1.0)
        N = np.broadcast_to(N, (npl, nw, 3))
        f_n = np.zeros((npl, nw))
        f_t = np.zeros((npl, nw))
        F = np.zeros((npl, nw, 3))
        flat = (delta > 0.0).ravel().nonzero()[0]      # pairs in contact, by plane
        if flat.size:
            fn, ft, Fk = self._pair_forces(
                flat, delta.take(flat), vp.reshape(-1, 3).take(flat, axis=0), vn.take(flat),
                N.reshape(-1, 3).take(flat, axis=0), v_i)
            F.reshape(-1, 3)[flat] = Fk
            f_n.put(flat, fn)
            f_t.put(flat, ft)
        tau = (Jp * F[..., None]).sum(axis=(0, 1, 2))
        return ContactState(gap, np.maximum(delta, 0.0), -vn, f_n, f_t, F, Jp, tau, N)

    # ------------------------------------------------------------------ dynamics
    def spring_torque(self, q, v) -> np.ndarray:
        tau = np.zeros(self.nv)
        for iv, value, k, c, q0 in self.springs:
            tau[iv] -= k * (value(q) - q0) + c * v[iv]
        return tau

    def mass_matrix(self, q) -> np.ndarray:
        M = pin.crba(self.model, self.data, q)
        return np.triu(M) + np.triu(M, 1).T

    def loop(self, q):
        phi, Jl = self.loop_closure(q)
        return np.atleast_1d(np.asarray(phi, float)), np.atleast_2d(np.asarray(Jl, float))

    def acceleration(self, q, v, tau) -> np.ndarray:
        """Generalized acceleration under the applied generalized force ``tau``.

        With a loop closure, ``a = a0 + M^-1 J^T lam`` where ``a0`` is the unconstrained
        acceleration and ``J M^-1 J^T lam = gamma - J a0`` (``gamma``: the Baumgarte
        stabilised bias), solved in the least-squares sense (dependent rows: a joint both
        locked and in a loop). A closure whose ``J`` is constant (linear loops, locked
        joints) has its independent rows found once (:meth:`_constant_rows`), so that
        system is solved directly: the same acceleration to rounding."""
        if self.loop_closure is None:
            return pin.aba(self.model, self.data, q, v, tau)
        a0 = pin.aba(self.model, self.data, q, v, tau)          # unconstrained
        Minv = pin.computeMinverse(self.model, self.data, q)
        Minv[self._lower] = Minv.T[self._lower]                 # the upper triangle is set
        rows = self._rows
        if rows is not None and rows[0] is not self.loop_closure:  # another closure set
            rows = self._rows = None
        if rows is None and getattr(self.loop_closure, "constant_jacobian", False):
            rows = self._rows = (self.loop_closure, *self._constant_rows(q))
        if rows is not None:
            _, B, Jr = rows
            if not len(Jr):
                return a0
            phi = B @ self.loop(q)[0]
            a = self.baumgarte
            MinvJT = Minv @ Jr.T
            G = Jr @ MinvJT                                      # SPD: Jr of full rank
            r = -2 * a * (Jr @ v) - a * a * phi - Jr @ a0
            lam = r / G[0, 0] if len(r) == 1 else np.linalg.solve(G, r)
            return a0 + MinvJT @ lam
        phi, Jl = self.loop(q)
        Jdv = loop_jdot_v(self.loop_closure, self.model, q, v, phi.shape[0])
        a = self.baumgarte
        gamma = -Jdv - 2 * a * (Jl @ v) - a * a * phi
        MinvJT = Minv @ Jl.T
        G = Jl @ MinvJT                                          # J M^-1 J^T
        lam = np.linalg.lstsq(G, gamma - Jl @ a0, rcond=1e-12)[0]
        return a0 + MinvJT @ lam

    def _constant_rows(self, q) -> tuple[np.ndarray, np.ndarray]:
        """``(B, Jr)`` of a loop closure whose ``J`` (k, nv) is constant: ``Jr = B J``
        (r, nv) spans its rows with r independent ones (``B`` (r, k) orthonormal rows: the
        left singular vectors of ``J`` whose singular values are above ``_LOOP_RCOND``
        times the largest). The constrained acceleration of ``J`` is that of ``Jr`` with
        the residual ``B phi``: the least-squares solution of the dependent system
        restricted to the range of ``J``, where it lies."""
        J = self.loop(q)[1]
        U, S, _ = np.linalg.svd(J, full_matrices=False)
        r = int(np.count_nonzero(S > _LOOP_RCOND * S[0])) if S.size and S[0] > 0 else 0
        B = np.ascontiguousarray(U[:, :r].T)
        return B, B @ J

    def generalized_forces(self, q, v, v_i=None):
        cs = self.contacts(q, v, v_i)
        return cs, cs.tau + self.spring_torque(q, v)

    # ------------------------------------------------------------------ energy
    def kinetic_energy(self, q, v) -> float:
        return float(0.5 * v @ self.mass_matrix(q) @ v)

    def potential_energy(self, q) -> float:
        """Gravity + joint springs + elastic contact energy k delta^(n+1)/(n+1) [J]."""
        V = float(pin.computePotentialEnergy(self.model, self.data, q))
        for _iv, value, k, _c, q0 in self.springs:
            V += 0.5 * k * (value(q) - q0) ** 2
        delta = np.maximum(-self.gaps(q), 0.0)
        for k, p in enumerate(self.planes):
            dk = delta[k][np.isfinite(delta[k])]
            V += float(np.sum(p.law.k * dk ** (p.law.n + 1) / (p.law.n + 1)))
        return V


class _Family:
    """The laws of the planes when all are Hunt–Crossley family laws with the family's force
    and one exponent ``n`` (:func:`~roverimpact.contact.hunt_crossley.one_family`):
    stiffness ``k`` and damping number ``z`` per plane."""

    def __init__(self, laws):
        self.k = [float(law.k) for law in laws]
        self.z = [float(law.z) for law in laws]
        self.n = float(laws[0].n)
        self._v_i, self._table = None, None

    @classmethod
    def of(cls, planes):
        """The family of the planes' laws, or None."""
        laws = [p.law for p in planes]
        return cls(laws) if one_family(laws) else None

    def per_pair(self, v_i, nw):
        """(3, planes * nw): ``k``, ``z`` and ``v_i`` of every pair (flat index
        plane * nw + wheel), kept while ``v_i`` (per plane) is unchanged."""
        v_i = list(v_i)
        if v_i != self._v_i:
            self._v_i = [float(x) for x in v_i]
            self._table = np.repeat(np.array([self.k, self.z, self._v_i]), nw, axis=1)
        return self._table


class _FrameTranslations:
    """The translations of frames of a pinocchio ``Data`` (wheel centres) as one (n, 3) array,
    from views of ``data.oMf`` kept between calls: the frame placements are updated in place
    (their storage does not move), and one array per frame and call costs ~1 us each.

    Bound to one ``Data`` (checked on every call). A copy of the system has its own
    ``Data``: a deep copy or a pickle starts unbound. Where the binding returns copies
    rather than views of ``oMf`` (owning their data, or at another address on each access),
    the translations are read on every call."""

    def __init__(self):
        self.data, self.views = None, None

    def __deepcopy__(self, memo):
        return type(self)()

    def __reduce__(self):
        return type(self), ()

    def get(self, data, fids) -> np.ndarray:
        if self.data is not data:
            views = [data.oMf[f].translation for f in fids]
            again = [data.oMf[f].translation for f in fids]
            live = all(not a.flags.owndata and a.ctypes.data == b.ctypes.data
                       for a, b in zip(views, again, strict=True))
            self.data, self.views = data, (views if live else None)
        if self.views is None:
            return np.concatenate([data.oMf[f].translation for f in fids]).reshape(-1, 3)
        return np.array(self.views).reshape(-1, 3)
