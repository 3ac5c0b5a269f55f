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

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..exceptions import ModelError

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
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


@dataclass
class ContactSystem:
    """A Pinocchio model, its wheels, planes, springs and loop closure, ready to integrate.

    Parameters
    ----------
    model : pinocchio.Model
        Copied; its gravity is set from ``gravity`` (3,).
    wheel_frames, radii : list of str, (nw,) array
    planes : list of Plane
    springs : list of (idx_q, idx_v, k, c, q0)
    loop_closure : callable or None
        ``q -> (phi (k,), J (k, nv))``.
    mu, v_slip : float
        Regularised Coulomb friction ``F_t = -mu f_n tanh(|v_t|/v_slip) v_t/|v_t|``.
    baumgarte : float
        Gain alpha [1/s] of the loop-closure stabilisation.
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
        return np.linalg.solve(Jint, v)

    # ------------------------------------------------------------------ kinematics
    def wheel_kinematics(self, q, v=None):
        """Wheel centres (nw, 3) and frame Jacobians (nw, 6, nv) in world-aligned axes."""
        model, data = self.model, self.data
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        c = np.array([data.oMf[f].translation for f in self.fids]).reshape(-1, 3)
        J = np.array([pin.getFrameJacobian(model, data, f, _LWA) for f in self.fids])
        return c, J.reshape(len(self.fids), 6, self.nv)

    def wheel_centres(self, q) -> np.ndarray:
        pin.framesForwardKinematics(self.model, self.data, q)
        return np.array([self.data.oMf[f].translation for f in self.fids]).reshape(-1, 3)

    def gaps(self, q) -> np.ndarray:
        """Signed gaps (planes, wheels): n . (c - p0) - r [m]."""
        c = self.wheel_centres(q)
        return self._gaps(c)

    def _gaps(self, c):
        g = self.N @ c.T - self.offsets[:, None] - self.radii[None, :]   # (np, nw)
        if not self.bounded:
            return g
        # contact points above the top of a finite face, and wheels the face is not in
        # front of, do not touch it
        z_cp = c[None, :, 2] - self.radii[None, :] * self.N[:, None, 2]
        return np.where((z_cp <= self.z_max[:, None]) & self.touch, g, np.inf)

    # ------------------------------------------------------------------ contact forces
    def contacts(self, q, v, v_i=None) -> ContactState:
        """Contact forces of all wheel/plane pairs at (q, v)."""
        c, J = self.wheel_kinematics(q)
        npl, nw = len(self.planes), len(self.fids)
        gap = self._gaps(c)
        Jp = J[None, :, :3, :] + self.rSn @ J[None, :, 3:, :]        # (np, nw, 3, nv)
        vp = Jp @ v                                                  # (np, nw, 3)
        vn = (vp * self.N[:, None, :]).sum(axis=-1)
        delta = -gap if not self.bounded else np.where(np.isfinite(gap), -gap, -1.0)
        delta_dot = -vn
        f_n = np.zeros((npl, nw))
        on_any = delta > 0.0
        if on_any.any():
            v_i = [p.v_i for p in self.planes] if v_i is None else v_i
            for k, p in enumerate(self.planes):
                on = on_any[k]
                if on.any():
                    raw = np.asarray(p.law.force(delta[k][on], delta_dot[k][on], v_i[k]),
                                     float)
                    f_n[k, on] = np.maximum(raw, 0.0)
        F = f_n[..., None] * self.N[:, None, :]
        f_t = np.zeros_like(f_n)
        if self.mu > 0.0 and on_any.any():
            vt = vp - vn[..., None] * self.N[:, None, :]
            s = np.sqrt((vt * vt).sum(axis=-1))
            f_t = self.mu * f_n * np.tanh(s / self.v_slip)
            F = F - (f_t / np.maximum(s, 1e-300))[..., None] * vt
        tau = (Jp * F[..., None]).sum(axis=(0, 1, 2))
        return ContactState(gap, np.maximum(delta, 0.0), delta_dot, f_n, f_t, F, Jp, tau)

    # ------------------------------------------------------------------ dynamics
    def spring_torque(self, q, v) -> np.ndarray:
        tau = np.zeros(self.nv)
        for iq, iv, k, c, q0 in self.springs:
            tau[iv] -= k * (q[iq] - q0) + c * v[iv]
        return tau

    def mass_matrix(self, q) -> np.ndarray:
        M = pin.crba(self.model, self.data, q)
        return np.triu(M) + np.triu(M, 1).T

    def loop(self, q):
        phi, Jl = self.loop_closure(q)
        return np.atleast_1d(np.asarray(phi, float)), np.atleast_2d(np.asarray(Jl, float))

    def acceleration(self, q, v, tau) -> np.ndarray:
        """Generalized acceleration under the applied generalized force ``tau``."""
        if self.loop_closure is None:
            return pin.aba(self.model, self.data, q, v, tau)
        a0 = pin.aba(self.model, self.data, q, v, tau)          # unconstrained
        Minv = pin.computeMinverse(self.model, self.data, q)
        Minv = np.triu(Minv) + np.triu(Minv, 1).T
        phi, Jl = self.loop(q)
        eps = 1e-6 / max(1.0, float(np.max(np.abs(v))))
        Jp_ = self.loop(pin.integrate(self.model, q, eps * v))[1]
        Jm_ = self.loop(pin.integrate(self.model, q, -eps * v))[1]
        Jdv = (Jp_ - Jm_) @ v / (2 * eps)
        a = self.baumgarte
        gamma = -Jdv - 2 * a * (Jl @ v) - a * a * phi
        MinvJT = Minv @ Jl.T
        G = Jl @ MinvJT                                          # J M^-1 J^T
        lam = np.linalg.lstsq(G, gamma - Jl @ a0, rcond=1e-12)[0]
        return a0 + MinvJT @ lam

    def generalized_forces(self, q, v, v_i=None):
        cs = self.contacts(q, v, v_i)
        return cs, cs.tau + self.spring_torque(q, v)

    # ------------------------------------------------------------------ energy
    def kinetic_energy(self, q, v) -> float:
        return float(0.5 * v @ self.mass_matrix(q) @ v)

    def potential_energy(self, q) -> float:
        """Gravity + joint springs + elastic contact energy k delta^(n+1)/(n+1) [J]."""
        V = float(pin.computePotentialEnergy(self.model, self.data, q))
        for iq, _iv, k, _c, q0 in self.springs:
            V += 0.5 * k * (q[iq] - q0) ** 2
        delta = np.maximum(-self.gaps(q), 0.0)
        for k, p in enumerate(self.planes):
            dk = delta[k][np.isfinite(delta[k])]
            V += float(np.sum(p.law.k * dk ** (p.law.n + 1) / (p.law.n + 1)))
        return V
