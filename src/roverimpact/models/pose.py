r"""Pose on terrain: place a rover so that its chosen wheels touch the ground, loops closed.

The caller places the rover horizontally (base x, y and yaw in ``q_guess``); the solver
finds the rest of the pose: the base's height, roll and pitch (a floating base; height
and pitch for the planar base of :func:`~roverimpact.models.rover2d`) and the passive
suspension joints (the model's ``lockable_joints`` less ``fixed``), so that

.. math::

    g_w(q) = p_{w,z}(q) - h(p_{w,x}, p_{w,y}) = 0 \quad (w \in \text{wheels}), \qquad
    \phi(q) = 0,

with :math:`p_w` the rim point of lowest clearance of wheel :math:`w`
(:func:`~roverimpact.models.terrain.wheel_ground_contact`), :math:`h` the terrain height
and :math:`\phi` the loop-closure residual (the rocker-bogie differential). Wheel spin
joints are never unknowns: a wheel's rotation about its own axis does not move its rim.

Jacobian (analytic)
-------------------
The rim point minimises the vertical clearance :math:`g(\varphi)` over the rim angle, so
(envelope theorem) the rim point may be differentiated as if it were fixed to the wheel:
its velocity differs from that of the material point of the wheel at :math:`p_w` by a
vector tangent to the rim, and :math:`\partial g / \partial \varphi = 0` says exactly that
:math:`(\hat z - \nabla h)` is orthogonal to that tangent. Hence, on the tangent space,

.. math::

    \frac{\partial g_w}{\partial q} = (-h_x, -h_y, 1)\, J_p(p_w)
        = \frac{n_w^T J_p(p_w)}{n_{w,z}},

with :math:`J_p` the point Jacobian of the wheel frame at :math:`p_w`
(:func:`~roverimpact.models.constraints.point_jacobian`, Pinocchio's
``LOCAL_WORLD_ALIGNED`` frame Jacobian) and :math:`n_w` the terrain's outward normal. The
signed gap reported (that of ``wheel_ground_contact``, the distance to the tangent plane)
is :math:`n_{w,z} g_w`, so it vanishes with :math:`g_w` and its derivative there is
:math:`n_w^T J_p`. The loop rows are the model's own :math:`J` of
``loop_closure(q) -> (phi, J)``.

Coordinates and steps
---------------------
The unknowns ``x`` are the base's height ``base_z`` [m], ``base_roll`` and ``base_pitch``
[rad] (Pinocchio's roll-pitch-yaw, :math:`R = R_z(\psi) R_y(\theta) R_x(\varphi)`, with
the guess's yaw :math:`\psi` and base x, y held exactly) and the suspension joints, whose
steps are applied with ``pin.integrate``. The base is updated in this chart rather than
by ``pin.integrate`` of a twist, whose SE(3) exponential would move x, y and yaw at second
order. The tangent map :math:`T = \partial v / \partial x` (columns :math:`R^T \hat z` for
the height, ``pin.rpy.computeRpyJacobian(rpy, LOCAL)`` for roll and pitch, unit columns
for the joints) turns the residual's tangent-space Jacobian into :math:`\partial r /
\partial x = J_r T`.

Gauss-Newton with backtracking, steps from the pseudo-inverse (SVD):

.. math::

    \Delta x = -J^+ r + (I - J^+ J)(x_{guess} - x),

the minimum-norm correction of the residual plus, when the problem is underdetermined
(a planar rover with a rocker: 3 unknowns, 2 wheels), a step back towards the guess in
the null space of :math:`J`. At convergence :math:`r = 0` and :math:`x - x_{guess}` is
orthogonal to that null space: of the poses where the chosen wheels touch, the solver
returns the one nearest to the guess (locally, in the metric of metres and radians).
Overdetermined problems (a rigid four-wheel chassis) converge when they are consistent
(a plane); when they are not, the least-squares pose leaves gaps, and
:class:`PoseError` names the wheels and their gaps instead of returning it.

Examples
--------
>>> import numpy as np
>>> from roverimpact.models import rover2d
>>> from roverimpact.models.terrain import PlaneTerrain
>>> rv = rover2d(suspension="rocker")
>>> slope = np.deg2rad(10.0)                     # ground rising forward by 10 degrees
>>> ground = PlaneTerrain((0, 0, 0), (-np.sin(slope), 0, np.cos(slope)))
>>> pose = pose_on_terrain(rv, ground)
>>> pose.solved
('base_z', 'base_pitch', 'rocker')
>>> bool(np.abs(pose.gap).max() < 1e-9)
True
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..exceptions import InputError, ModelError, SolverError
from .base import MultibodyModel
from .declare import base_info
from .terrain import HeightField, Terrain, WheelContact, wheel_ground_contact, wheel_terrains

__all__ = ["PoseError", "PoseProblem", "TerrainPose", "place", "pose_on_terrain", "wheel_contacts"]

_BASE_FREE = ("base_z", "base_roll", "base_pitch")
_BASE_PLANAR = ("base_z", "base_pitch")
_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
#: largest step of one iteration in any coordinate [m or rad]
_MAX_STEP = 0.25
#: a guess whose chosen wheels are on average farther than this above or below the terrain
#: [m] is first moved vertically onto it (four capped steps; a DEM's absolute elevations)
_FAR = 4 * _MAX_STEP
#: statuses solved again from other starts (``restarts`` of :func:`pose_on_terrain`)
_RESTARTED = ("stalled", "max_iter", "infeasible")
_RESTART_SEED = 0


def _restart_steps(prob, n: int) -> np.ndarray:
    """``n`` offsets (n, nx) of the unknowns for restarts: the same for every pose (a
    pose's result does not depend on the batch it is solved in), drawn from a fixed seed
    in units of the rover (height in wheel radii)."""
    rng = np.random.default_rng(_RESTART_SEED)
    radius = float(np.max(prob.radii))
    D = np.empty((n, prob.nx))
    for c, name in enumerate(prob.names):
        if name == "base_z":
            D[:, c] = radius * rng.uniform(-0.5, 1.5, n)
        elif name in ("base_roll", "base_pitch"):
            D[:, c] = rng.uniform(-0.2, 0.2, n)
        else:
            D[:, c] = rng.uniform(-0.4, 0.4, n)
    return D


@dataclass(frozen=True)
class TerrainPose:
    """A rover posed on a terrain (:func:`pose_on_terrain`), for one guess or a batch.

    Shapes have the batch shape ``(...)`` of ``q_guess`` in front (none for one guess).

    Attributes
    ----------
    q : (..., nq) ndarray
        Configuration: the guess with the solved coordinates replaced.
    wheels : tuple of str
        Every wheel of the model, in the model's order (the wheel axis of the arrays).
    chosen : tuple of str
        The wheels solved to touch the terrain.
    gap : (..., n_wheels) ndarray
        Signed gap of each wheel [m] (``wheel_ground_contact``: distance of the rim point
        from the terrain's tangent plane; < 0 = penetration). Within ``tol`` of 0 for the
        chosen wheels, >= -tol for the others.
    point : (..., n_wheels, 3) ndarray
        Rim point of lowest clearance of each wheel [m] (world).
    normal : (..., n_wheels, 3) ndarray
        Outward unit terrain normal below each rim point.
    loop_residual : (..., k) ndarray
        Loop-closure residual ``phi(q)`` (k = 0 for a tree).
    iterations : int or (...) ndarray
        Gauss-Newton steps taken.
    solved : tuple of str
        The coordinates solved for: ``base_z``, ``base_roll``, ``base_pitch`` (as the base
        allows) and suspension joint names, in the order of the unknowns.
    rank : int or (...) ndarray
        Rank of the Jacobian of the residual at the solution; ``len(solved) - rank``
        coordinates were left free (kept nearest to the guess).
    status : str or (...) ndarray of str
        ``"ok"``; ``"infeasible"`` (the chosen wheels cannot all touch: least squares
        reached with gaps left); ``"stalled"`` (no step reduces the gaps);
        ``"penetration"`` (a wheel not chosen is below the terrain); ``"max_iter"``.
        Only with ``check=False`` can a result hold anything but ``"ok"``.
    """

    q: np.ndarray
    wheels: tuple[str, ...]
    chosen: tuple[str, ...]
    gap: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    loop_residual: np.ndarray
    iterations: int | np.ndarray
    solved: tuple[str, ...]
    rank: int | np.ndarray
    status: str | np.ndarray

    @property
    def ok(self):
        """True where the pose was found (``status == "ok"``)."""
        return np.asarray(self.status) == "ok"

    @property
    def free(self):
        """Number of solved coordinates the equations left free (underdetermined)."""
        return len(self.solved) - np.asarray(self.rank)


class PoseError(SolverError):
    """The chosen wheels cannot all touch the terrain, or a wheel penetrates it.

    ``result`` holds the closest pose found (a :class:`TerrainPose`, ``status`` per pose).
    """

    def __init__(self, message: str, result: TerrainPose | None = None):
        super().__init__(message)
        self.result = result


def _base(mbm) -> tuple[str, tuple[str, ...]]:
    """``("free" | "planar" | "fixed", base joint names)``, as declared or detected
    (:func:`roverimpact.models.declare.base_info`; a planar base's joints are the x
    slide, the z slide and the pitch hinge, whatever their names)."""
    info = base_info(mbm)
    return {"floating": "free"}.get(info.kind, info.kind), info.joints


def _default_q(mbm) -> np.ndarray:
    q = np.array(mbm.params.get("q_nominal", pin.neutral(mbm.model)), dtype=float)
    return q if q.shape == (mbm.model.nq,) else pin.neutral(mbm.model)


def _check_q(mbm, q, name: str = "q_guess") -> np.ndarray:
    try:
        q = np.array(q, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be numbers ({exc})") from None
    nq = mbm.model.nq
    if q.ndim == 0 or q.shape[-1] != nq:
        raise InputError(f"{name} must have shape (..., {nq}) for model {mbm.name!r}, got "
                         f"{q.shape}")
    if not np.isfinite(q).all():
        raise InputError(f"{name} contains NaN or inf")
    return q


def place(mbm: MultibodyModel, x: float = 0.0, y: float = 0.0, yaw: float = 0.0,
          q=None) -> np.ndarray:
    """A guess for :func:`pose_on_terrain`: the rover's nominal pose moved to (x, y, yaw).

    Parameters
    ----------
    mbm : MultibodyModel
    x, y : float
        Base position [m] (world).
    yaw : float
        Heading of the base about world z [rad] (a floating base only).
    q : (nq,) array_like, optional
        Configuration to move (default ``params["q_nominal"]`` or Pinocchio's neutral).

    Returns
    -------
    (nq,) ndarray
        ``q`` with the base's x, y and yaw set (roll, pitch and height unchanged).

    Examples
    --------
    >>> from roverimpact.models import rocker_bogie
    >>> q = place(rocker_bogie(), 2.0, 1.0, yaw=0.5)
    >>> q[:2].tolist()
    [2.0, 1.0]
    """
    q = _default_q(mbm) if q is None else _check_q(mbm, q, "q").reshape(-1).copy()
    kind, base_joints = _base(mbm)
    if kind == "free":
        R = pin.Quaternion(q[3:7]).normalized().toRotationMatrix()
        roll, pitch, _ = pin.rpy.matrixToRpy(R)
        q[0], q[1] = x, y
        q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(roll, pitch, yaw)).coeffs()
    elif kind == "planar":
        if y != 0.0 or yaw != 0.0:
            raise InputError("place: the planar rover moves in the x-z plane; y and yaw must "
                             "be 0")
        q[mbm.model.joints[mbm.model.getJointId(base_joints[0])].idx_q] = x
    elif (x, y, yaw) != (0.0, 0.0, 0.0):
        raise InputError(f"place: model {mbm.name!r} has a fixed base; it cannot be moved")
    return q


class PoseProblem:
    r"""The equations of :func:`pose_on_terrain`: residual, Jacobian and coordinate steps.

    Parameters
    ----------
    mbm : MultibodyModel
    terrain : Terrain or dict {wheel name: Terrain}
    wheels : sequence of str, optional
        Wheels that must touch (default: every wheel).
    fixed : sequence of str
        Coordinates not to solve: ``base_z``, ``base_roll``, ``base_pitch`` or suspension
        joint names (of ``lockable_joints``).

    Attributes
    ----------
    names : tuple of str
        The unknowns ``x`` (see :attr:`TerrainPose.solved`).
    chosen : (n_wheels,) bool ndarray
        Which wheels are equations.
    """

    def __init__(self, mbm: MultibodyModel, terrain: Terrain, *, wheels=None, fixed=()):
        if not isinstance(mbm, MultibodyModel):
            raise InputError(f"pose_on_terrain needs a MultibodyModel, got {type(mbm).__name__}")
        if not mbm.wheels:
            raise ModelError(f"model {mbm.name!r} has no wheels: there is nothing to place on "
                             "the terrain")
        self._groups = wheel_terrains(terrain, [w.name for w in mbm.wheels], who="pose_on_terrain")
        model = mbm.model
        self.mbm, self.terrain, self.model = mbm, terrain, model
        self.data = model.createData()
        names = [w.name for w in mbm.wheels]
        if wheels is None:
            wheels = names
        elif isinstance(wheels, str):
            wheels = [wheels]
        wheels = list(wheels)
        unknown = [w for w in wheels if w not in names]
        if unknown or not wheels:
            raise InputError(f"wheels: unknown or empty wheel list {unknown}; wheels of "
                             f"{mbm.name!r}: {names}")
        self.wheel_names = tuple(names)
        self.chosen = np.array([n in wheels for n in names])
        self._ic = np.flatnonzero(self.chosen)
        self.fids = [model.getFrameId(w.frame) for w in mbm.wheels]
        self.axes = np.array([w.axis for w in mbm.wheels], dtype=float)
        self.radii = np.array([w.radius for w in mbm.wheels], dtype=float)

        self.kind, self._base_joints = _base(mbm)
        base = {"free": _BASE_FREE, "planar": _BASE_PLANAR, "fixed": ()}[self.kind]
        fixed = [fixed] if isinstance(fixed, str) else list(fixed)
        allowed = list(base) + list(mbm.lockable_joints)
        bad = [f for f in fixed if f not in allowed]
        if bad:
            raise InputError(f"fixed: unknown coordinate(s) {bad}; the solvable coordinates of "
                             f"{mbm.name!r} are {allowed}")
        self.base = tuple(b for b in base if b not in fixed)
        self._jv, labels = [], []
        for name in mbm.lockable_joints:
            if name in fixed:
                continue
            if not model.existJointName(name):
                raise ModelError(f"lockable joint {name!r} of {mbm.name!r} is not a joint")
            j = model.joints[model.getJointId(name)]
            self._jv.extend(j.idx_v + k for k in range(j.nv))
            labels.extend([name] if j.nv == 1 else [f"{name}[{k}]" for k in range(j.nv)])
        self.names = self.base + tuple(labels)
        if not self.names:
            raise InputError(f"nothing to solve: model {mbm.name!r} has no free base "
                             "coordinate and no suspension joint left (check fixed=)")
        self.nx = len(self.names)
        self._nb = len(self.base)
        if self.kind == "planar":
            jz, jp = (model.joints[model.getJointId(n)] for n in self._base_joints[1:])
            self._iq = {"base_z": jz.idx_q, "base_pitch": jp.idx_q}
            self._iv = {"base_z": jz.idx_v, "base_pitch": jp.idx_v}
        self._loop = mbm.loop_closure
        self.n_loop = 0 if self._loop is None else int(
            np.asarray(self._loop(_default_q(mbm))[0]).size)

    # ------------------------------------------------------------------ coordinates
    def _base_values(self, q) -> dict:
        if self.kind == "free":
            R = pin.Quaternion(q[3:7]).normalized().toRotationMatrix()
            roll, pitch, yaw = pin.rpy.matrixToRpy(R)
            return {"base_z": q[2], "base_roll": roll, "base_pitch": pitch, "yaw": yaw}
        if self.kind == "planar":
            return {k: q[i] for k, i in self._iq.items()}
        return {}

    def _set_base(self, q, vals: dict) -> np.ndarray:
        if self.kind == "free":
            q[2] = vals["base_z"]
            R = pin.rpy.rpyToMatrix(vals["base_roll"], vals["base_pitch"], vals["yaw"])
            q[3:7] = pin.Quaternion(R).coeffs()
        elif self.kind == "planar":
            for k, i in self._iq.items():
                q[i] = vals[k]
        return q

    def normalize(self, q) -> np.ndarray:
        """``q`` with the base rebuilt from its chart (a unit quaternion)."""
        q = np.array(q, dtype=float)
        return self._set_base(q, self._base_values(q))

    def step(self, q, dx) -> np.ndarray:
        """The configuration ``q`` (nq,) moved by ``dx`` (nx,) in the unknowns: joints by
        ``pin.integrate``, the base in its chart (x, y and yaw of ``q`` held exactly)."""
        vals = self._base_values(q)
        for k, name in enumerate(self.base):
            vals[name] = vals[name] + dx[k]
        if self._jv:
            dv = np.zeros(self.model.nv)
            dv[self._jv] = dx[self._nb:]
            q = pin.integrate(self.model, q, dv)
        else:
            q = np.array(q, dtype=float)
        return self._set_base(q, vals)

    def difference(self, q0, q1) -> np.ndarray:
        """``x(q1) - x(q0)`` (nx,) in the unknowns (joints by ``pin.difference``)."""
        b0, b1 = self._base_values(q0), self._base_values(q1)
        dx = np.empty(self.nx)
        for k, name in enumerate(self.base):
            dx[k] = b1[name] - b0[name]
        if self._jv:
            dx[self._nb:] = pin.difference(self.model, q0, q1)[self._jv]
        return dx

    def tangent(self, q) -> np.ndarray:
        r"""``T = dv/dx`` (nv, nx): the tangent-space velocity of a unit rate of each unknown."""
        T = np.zeros((self.model.nv, self.nx))
        if self.kind == "free":
            R = pin.Quaternion(q[3:7]).normalized().toRotationMatrix()
            Jr = pin.rpy.computeRpyJacobian(pin.rpy.matrixToRpy(R), pin.ReferenceFrame.LOCAL)
            for k, name in enumerate(self.base):
                if name == "base_z":
                    T[0:3, k] = R[2]                      # R^T e_z, in the base's axes
                else:
                    T[3:6, k] = Jr[:, 0 if name == "base_roll" else 1]
        elif self.kind == "planar":
            for k, name in enumerate(self.base):
                T[self._iv[name], k] = 1.0
        T[self._jv, np.arange(self._nb, self.nx)] = 1.0
        return T

    # ------------------------------------------------------------------ equations
    def evaluate(self, q, *, jacobian: bool = True, wrt: str = "x"):
        r"""Residual, its Jacobian in the unknowns, and every wheel's contact.

        Parameters
        ----------
        q : (..., nq) array_like
            Configurations (one Pinocchio pass each, one ``wheel_ground_contact`` call
            for all wheels of all of them).
        jacobian : bool
            Also return the Jacobian.
        wrt : {"x", "v"}
            Jacobian with respect to the unknowns ``x`` (m, nx), or on the whole tangent
            space ``v`` (m, nv), before the tangent map ``T``.

        Returns
        -------
        r : (..., m) ndarray
            ``[g_w of the chosen wheels, phi]``: vertical gaps
            :math:`g_w = p_z - h(p_x, p_y)` [m] and the loop residual.
        J : (..., m, nx) or (..., m, nv) ndarray, or None
            :math:`[n_w^T J_p(p_w) / n_{w,z};\ J_{loop}]\, T`, with
            :math:`n^T J_p = n^T J_{lin} + (r \times n)^T J_{ang}` from the
            ``LOCAL_WORLD_ALIGNED`` frame Jacobian of the wheel
            (as :func:`~roverimpact.models.constraints.point_jacobian`),
            :math:`r = p_w - c_w`.
        contact : WheelContact
            ``wheel_ground_contact`` of every wheel, batch shape ``(..., n_wheels)``.
        """
        if wrt not in ("x", "v"):
            raise InputError(f"wrt must be 'x' or 'v', got {wrt!r}")
        model, data = self.model, self.data
        q = np.asarray(q, dtype=float)
        batch = q.shape[:-1]
        Q = q.reshape(-1, model.nq)
        k, nw, nv, ic = Q.shape[0], len(self.fids), model.nv, self._ic
        C = np.empty((k, nw, 3))
        Ax = np.empty((k, nw, 3))
        phi = np.empty((k, self.n_loop))
        if jacobian:
            Jf = np.empty((k, ic.size, 6, nv))
            Jl = np.empty((k, self.n_loop, nv))
            T = np.empty((k, nv, self.nx))
        for i in range(k):
            if jacobian:
                pin.computeJointJacobians(model, data, Q[i])
            else:
                pin.forwardKinematics(model, data, Q[i])
            pin.updateFramePlacements(model, data)
            for w, f in enumerate(self.fids):
                M = data.oMf[f]
                C[i, w] = M.translation
                Ax[i, w] = M.rotation @ self.axes[w]
            if self._loop is not None:
                ph, jl = self._loop(Q[i])
                phi[i] = ph
                if jacobian:
                    Jl[i] = np.asarray(jl, dtype=float).reshape(self.n_loop, nv)
            if jacobian:
                for c, w in enumerate(ic):
                    Jf[i, c] = np.asarray(pin.getFrameJacobian(
                        model, data, self.fids[w], _LWA)).reshape(6, nv)
                if wrt == "x":
                    T[i] = self.tangent(Q[i])
        try:
            wc = _contacts(self._groups, C, Ax, self.radii)
        except InputError as exc:
            raise InputError(f"pose_on_terrain: {exc}") from None
        g = wc.point[:, ic, 2] - wc.ground[:, ic, 2]
        r = np.concatenate([g, phi], axis=1)
        J = None
        if jacobian:
            m = wc.normal[:, ic] / wc.normal[:, ic, 2:3]          # (-h_x, -h_y, 1)
            lever = np.cross(wc.point[:, ic] - C[:, ic], m)        # r x m
            rows = (np.einsum("kcj,kcjv->kcv", m, Jf[:, :, :3])
                    + np.einsum("kcj,kcjv->kcv", lever, Jf[:, :, 3:]))
            J = np.concatenate([rows, Jl], axis=1)
            if wrt == "x":
                J = J @ T
            J = J.reshape(*batch, *J.shape[1:])
        wc = WheelContact(point=wc.point.reshape(*batch, nw, 3),
                          ground=wc.ground.reshape(*batch, nw, 3),
                          normal=wc.normal.reshape(*batch, nw, 3),
                          gap=wc.gap.reshape(*batch, nw), phi=wc.phi.reshape(*batch, nw))
        return r.reshape(*batch, r.shape[1]), J, wc


def _contact(terrain, C, Ax, radii) -> WheelContact:
    """:func:`wheel_ground_contact`; a height field's only error is a rim off the grid."""
    try:
        return wheel_ground_contact(terrain, C, Ax, radii)
    except InputError as exc:
        if isinstance(terrain, HeightField):
            raise InputError(f"a wheel leaves the terrain ({exc})") from None
        raise


def _contacts(groups, C, Ax, radii) -> WheelContact:
    """:func:`wheel_ground_contact` of every wheel (``C``, ``Ax``: (k, n_wheels, 3)), each
    on its own terrain: one call per distinct terrain."""
    if len(groups) == 1:
        return _contact(groups[0][0], C, Ax, radii)
    k, nw = C.shape[:2]
    out = {f: np.empty((k, nw, 3)) for f in ("point", "ground", "normal")}
    out |= {f: np.empty((k, nw)) for f in ("gap", "phi")}
    for t, ix in groups:
        wc = _contact(t, C[:, ix], Ax[:, ix], radii[ix])
        for f in out:
            out[f][:, ix] = getattr(wc, f)
    return WheelContact(**out)


def wheel_contacts(mbm: MultibodyModel, terrain, q) -> WheelContact:
    """Every wheel's :func:`~roverimpact.models.terrain.wheel_ground_contact` at ``q``.

    Parameters
    ----------
    mbm : MultibodyModel
    terrain : Terrain or dict
        One terrain, or ``{wheel name: terrain}`` for every wheel.
    q : (nq,) array_like

    Returns
    -------
    WheelContact
        Batch shape ``(n_wheels,)``, in ``mbm.wheels`` order.
    """
    q = _check_q(mbm, q, "q").reshape(-1)
    model = mbm.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    fids = [model.getFrameId(w.frame) for w in mbm.wheels]
    C = np.array([[data.oMf[f].translation for f in fids]])
    Ax = np.array([[data.oMf[f].rotation @ np.asarray(w.axis, float)
                    for f, w in zip(fids, mbm.wheels, strict=True)]])
    radii = np.array([w.radius for w in mbm.wheels], float)
    groups = wheel_terrains(terrain, [w.name for w in mbm.wheels], who="pose_on_terrain")
    wc = _contacts(groups, C, Ax, radii)
    return WheelContact(point=wc.point[0], ground=wc.ground[0], normal=wc.normal[0],
                        gap=wc.gap[0], phi=wc.phi[0])


def _fmt_gaps(names, gaps) -> str:
    return ", ".join(f"{n} {1e3 * g:+.3g} mm" for n, g in zip(names, gaps, strict=True))


def pose_on_terrain(mbm: MultibodyModel, terrain: Terrain, q_guess=None, *, wheels=None,
                    fixed=(), tol: float = 1e-9, max_iter: int = 50, restarts: int = 8,
                    check: bool = True) -> TerrainPose:
    r"""Place a rover on a terrain: base height, roll, pitch and suspension, loops closed.

    Solves :math:`g_w(q) = 0` for the chosen wheels and :math:`\phi(q) = 0` by
    Gauss-Newton with the analytic Jacobian (module docstring); of the solutions it
    returns the one nearest to the guess. A batch of guesses is solved together (one
    terrain query per iteration for all of them).

    Parameters
    ----------
    mbm : MultibodyModel
        A model with wheels: :func:`~roverimpact.models.rover2d`,
        :func:`~roverimpact.models.rocker_bogie`, or a URDF/MJCF file that declares them.
    terrain : Terrain or dict
        :class:`~roverimpact.models.terrain.PlaneTerrain`, ``HeightField``,
        ``FunctionTerrain`` (z up, metres), or ``{wheel name: terrain}`` for every wheel
        (a plane of its own under each wheel, say).
    q_guess : (..., nq) array_like, optional
        Start and the coordinates that are kept: the base's x, y and yaw (the caller
        places the rover; see :func:`place`), wheel spins, fixed joints. Default: the
        model's ``params["q_nominal"]`` (or Pinocchio's neutral configuration). A guess
        whose chosen wheels are on average more than 1 m above or below the terrain (the
        nominal pose over a DEM in absolute elevations) is first moved vertically by that
        mean gap, if ``base_z`` is solved for.
    wheels : sequence of str, optional
        The wheels that must touch (default: every wheel).
    fixed : sequence of str
        Coordinates kept at the guess: ``"base_z"``, ``"base_roll"``, ``"base_pitch"``,
        or suspension joints (of ``mbm.lockable_joints``). A rover with every suspension
        joint fixed is rigid.
    tol : float
        Convergence: every chosen wheel's gap [m] and the loop residual below ``tol``, and
        in an underdetermined problem the step back towards the guess below ``tol``.
    max_iter : int
        Gauss-Newton steps allowed per pose.
    restarts : int
        A pose that fails (stalled, out of steps, or gaps left) is solved again from this
        many other starts: the guess moved by fixed, seeded offsets of the unknowns
        (height -0.5 to 1.5 wheel radii, roll and pitch up to 0.2 rad, suspension joints
        up to 0.4 rad); of the poses found the one nearest to the guess is kept. Gauss-
        Newton stalls where a wheel's lowest rim point jumps between two places (a wheel
        against a rock); on a rocky field (k = 0.2) 13 of 1000 random placements failed
        without restarts and none with 8. ``0``: no restarts.
    check : bool
        Raise :class:`PoseError` if a pose fails (default); with ``False`` the result's
        ``status`` says which did.

    Returns
    -------
    TerrainPose

    Raises
    ------
    ModelError
        The model has no wheels.
    InputError
        Unknown wheel or coordinate names, a bad ``q_guess``, a wheel outside a height
        field.
    PoseError (a SolverError)
        The chosen wheels cannot all touch the terrain (a rigid chassis on uneven ground:
        the gaps of the closest, least-squares pose are named per wheel); a wheel that
        was not chosen penetrates the terrain; no convergence in ``max_iter`` steps.
        ``err.result`` is the closest pose.
    """
    prob = PoseProblem(mbm, terrain, wheels=wheels, fixed=fixed)
    if not (np.isfinite(tol) and tol > 0):
        raise InputError(f"tol must be a positive number, got {tol!r}")
    if isinstance(restarts, bool) or not isinstance(restarts, (int, np.integer)) \
            or restarts < 0:
        raise InputError(f"restarts must be a whole number >= 0, got {restarts!r}")
    q_guess = _default_q(mbm) if q_guess is None else _check_q(mbm, q_guess)
    batch = q_guess.shape[:-1]
    Qg = np.array([prob.normalize(q) for q in q_guess.reshape(-1, prob.model.nq)])
    k = Qg.shape[0]
    Q, r, gap, point, normal, status, steps, rank = _gauss_newton(prob, Qg, Qg.copy(), tol,
                                                                  max_iter, lift=True)
    again = np.flatnonzero(np.isin(status, _RESTARTED))
    if restarts and again.size:
        # local minima of |r| where a wheel's lowest rim point jumps between two places
        # (a wheel against a rock): the same guesses from a few fixed, seeded starts
        D = _restart_steps(prob, int(restarts))
        starts = np.array([prob.step(Qg[i], d) for i in again for d in D])
        R = _gauss_newton(prob, np.repeat(Qg[again], len(D), axis=0), starts, tol, max_iter)
        Q2, r2, gap2, point2, normal2, status2, steps2, rank2 = R
        pen2 = ((~prob.chosen[None, :]) & (gap2 < -tol)).any(axis=1)
        for j, i in enumerate(again):
            sl = slice(j * len(D), (j + 1) * len(D))
            good = np.flatnonzero((status2[sl] == "ok") & ~pen2[sl]) + sl.start
            steps[i] += int(steps2[sl].sum())
            if good.size:  # of the poses found, the nearest to the guess
                b = good[np.argmin([np.linalg.norm(prob.difference(Qg[i], Q2[g]))
                                    for g in good])]
                Q[i], r[i], gap[i], point[i], normal[i] = Q2[b], r2[b], gap2[b], point2[b], \
                    normal2[b]
                status[i], rank[i] = "ok", rank2[b]
    nc = prob._ic.size
    pen = (~prob.chosen[None, :]) & (gap < -tol)
    status[(status == "ok") & pen.any(axis=1)] = "penetration"

    def shaped(a):
        return a.reshape(*batch, *a.shape[1:])

    chosen = tuple(prob.wheel_names[w] for w in prob._ic)
    one = lambda a: a.reshape(batch) if batch else a.reshape(()).item()  # noqa: E731
    result = TerrainPose(
        q=shaped(Q), wheels=prob.wheel_names, chosen=chosen, gap=shaped(gap),
        point=shaped(point), normal=shaped(normal), loop_residual=shaped(r[:, nc:]),
        iterations=one(steps), solved=prob.names, rank=one(rank),
        status=one(status.astype(str)))
    bad = np.flatnonzero(status != "ok")
    if check and bad.size:
        raise PoseError(_failure_message(prob, chosen, bad, status, gap, pen, r[:, nc:],
                                         max_iter, k, tol), result)
    return result


def _gauss_newton(prob: PoseProblem, Qg: np.ndarray, Q: np.ndarray, tol: float,
                  max_iter: int, lift: bool = False):
    """Gauss-Newton with backtracking from the starts ``Q`` (k, nq) towards the guesses
    ``Qg`` (the null-space pull); returns ``Q, r, gap, point, normal, status, steps,
    rank`` (status without ``"penetration"``).

    ``lift``: a start whose chosen wheels are on average more than ``_FAR`` above or
    below the terrain is first moved vertically by that mean gap, and its guess with it
    (``Qg`` is changed in place): the steps are capped at ``_MAX_STEP``, and the nominal
    pose over a terrain in absolute elevations (a DEM at 1500 m) ran out of steps."""
    k, nx = Qg.shape[0], prob.nx
    r, J, wc = prob.evaluate(Q)
    gap, point, normal = wc.gap.copy(), wc.point.copy(), wc.normal.copy()
    if lift and "base_z" in prob.names:
        mean = r[:, :prob._ic.size].mean(axis=1)
        far = np.flatnonzero(np.abs(mean) > _FAR)
        if far.size:
            dz = np.zeros(nx)
            iz = prob.names.index("base_z")
            for i in far:
                dz[iz] = -mean[i]
                Q[i] = Qg[i] = prob.step(Q[i], dz)
            r[far], J[far], wcf = prob.evaluate(Q[far])
            gap[far], point[far], normal[far] = wcf.gap, wcf.point, wcf.normal
    normr = np.linalg.norm(r, axis=1)
    status = np.full(k, "run", dtype=object)
    steps = np.zeros(k, dtype=int)
    rank = np.zeros(k, dtype=int)
    lam, pred = np.ones(k), np.zeros(k)
    dx = np.zeros((k, nx))
    fresh = np.ones(k, dtype=bool)           # needs a new Gauss-Newton direction
    for _ in range(16 * (int(max_iter) + 1)):
        idx = np.flatnonzero((status == "run") & fresh)
        if idx.size:
            U, s, Vt = np.linalg.svd(J[idx], full_matrices=False)
            for j, i in enumerate(idx):
                rk = int(np.sum(s[j] > 1e-10 * max(s[j, 0], 1e-300))) if s.shape[1] else 0
                rank[i] = rk
                Vr = Vt[j, :rk]
                # minimum-norm Gauss-Newton step, and back to the guess in the null space
                dx_r = -Vr.T @ ((U[j, :, :rk].T @ r[i]) / s[j, :rk])
                back = prob.difference(Q[i], Qg[i])
                dx_n = back - Vr.T @ (Vr @ back)
                feasible = np.max(np.abs(r[i]), initial=0.0) <= tol
                if feasible and np.max(np.abs(dx_n), initial=0.0) <= tol:
                    status[i] = "ok"
                    continue
                full = normr[i] - np.linalg.norm(r[i] + J[i] @ dx_r)
                if not feasible and full <= 1e-6 * normr[i]:
                    status[i] = "infeasible"   # least squares reached with gaps left
                    continue
                if steps[i] >= max_iter:
                    status[i] = "max_iter"
                    continue
                d = dx_r + dx_n
                scale = min(1.0, _MAX_STEP / max(np.max(np.abs(d)), 1e-300))
                dx[i] = scale * d
                pred[i] = normr[i] - np.linalg.norm(r[i] + scale * (J[i] @ dx_r))
                lam[i] = 1.0
            fresh[idx] = False
        run = np.flatnonzero(status == "run")
        if run.size == 0:
            break
        Qt = np.array([prob.step(Q[i], lam[i] * dx[i]) for i in run])
        rt, Jt, wct = prob.evaluate(Qt)
        nt = np.linalg.norm(rt, axis=1)
        acc = (nt <= normr[run] - 1e-4 * lam[run] * pred[run]) | (nt <= tol)
        a = run[acc]
        Q[a], r[a], J[a], normr[a] = Qt[acc], rt[acc], Jt[acc], nt[acc]
        gap[a], point[a], normal[a] = wct.gap[acc], wct.point[acc], wct.normal[acc]
        steps[a] += 1
        fresh[a] = True
        rej = run[~acc]
        lam[rej] *= 0.5
        low = rej[lam[rej] < 1e-4]
        status[low] = np.where(np.max(np.abs(r[low]), axis=1, initial=0.0) <= tol, "ok",
                               "stalled")
    status[status == "run"] = "max_iter"
    return Q, r, gap, point, normal, status, steps, rank


def _failure_message(prob, chosen, bad, status, gap, pen, phi, max_iter, k, prob_tol) -> str:
    i = int(bad[0])
    where = f"pose {i} of {k} ({bad.size} failed; check=False returns them all): " \
        if k > 1 else ""
    gaps_c = gap[i, prob._ic]
    worst = chosen[int(np.argmax(np.abs(gaps_c)))]
    worst_loop = np.max(np.abs(phi[i]), initial=0.0)
    loop = f"; loop residual {worst_loop:.2g}" if worst_loop > prob_tol else ""
    name = prob.mbm.name
    if status[i] in ("infeasible", "stalled"):
        how = ("the closest pose leaves gaps" if status[i] == "infeasible"
               else "the solver stalled at gaps")
        return (f"{where}the wheels {list(chosen)} of {name!r} cannot all touch the terrain "
                f"by moving {list(prob.names)}: {how} {_fmt_gaps(chosen, gaps_c)} (largest: "
                f"{worst}){loop}. Choose the wheels that should touch with wheels=[...], free "
                "suspension joints (fixed=), or use a model with a suspension")
    if status[i] == "penetration":
        names = [n for n, p in zip(prob.wheel_names, pen[i], strict=True) if p]
        return (f"{where}with {list(chosen)} on the terrain, wheel(s) {names} of {name!r} "
                f"penetrate it (gaps {_fmt_gaps(names, gap[i, pen[i]])}): add them to "
                "wheels=[...] or place the rover elsewhere")
    return (f"{where}pose_on_terrain did not converge in {max_iter} steps (gaps "
            f"{_fmt_gaps(chosen, gaps_c)}{loop}): give a closer q_guess or raise max_iter")
