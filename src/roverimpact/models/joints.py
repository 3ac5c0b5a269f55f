r"""Joint coordinates by name, for every kind of 1-DoF joint, and mimic couplings.

A 1-DoF joint of a Pinocchio model is one of

* ``"revolute"`` -- ``RX``, ``RY``, ``RZ``, ``RevoluteUnaligned``: ``nq = nv = 1``, the
  angle theta [rad] is ``q[idx_q]``;
* ``"prismatic"`` -- ``PX``, ``PY``, ``PZ``, ``PrismaticUnaligned``: ``nq = nv = 1``, the
  displacement [m];
* ``"continuous"`` -- URDF ``continuous`` joints (``RUBX``, ``RUBY``, ``RUBZ``,
  ``RevoluteUnboundedUnaligned``): ``nq = 2``, ``nv = 1``,
  ``q[idx_q:idx_q+2] = (cos theta, sin theta)``, ``theta = atan2(sin, cos)`` in
  ``(-pi, pi]``;

and for all three the rate is ``v[idx_v]`` [rad/s or m/s]. The helpers below read and
write these coordinates by joint name, so callers never index ``q`` by hand.

Mimic joints. Pinocchio 4.1's URDF parser, by default (``mimic=False``, what
:func:`~roverimpact.models.load_robot` uses), **drops the coupling** of a
``<mimic joint="leader" multiplier="a" offset="b"/>``: both joints stay independent
DoFs. (With ``mimic=True`` it builds a ``JointModelMimic`` with no coordinate of its own,
which the rest of roverimpact does not support.) roverimpact keeps the independent joints
and restores the coupling as one constraint row per mimic joint (label
``"mimic:<joint>"`` among the model's loop closures), linear in the joint values:

.. math::

    \phi = \theta_m - a\,\theta_\ell - b = 0, \qquad J = e_m - a\, e_\ell

(``e`` rows of the identity in ``v``; ``J`` does not depend on ``q``). MJCF joint
equalities ``<equality><joint joint1="m" joint2="l" polycoef="c0 c1 0 0 0"/>`` are the
same coupling (``theta_m - ref_m = c0 + c1 (theta_l - ref_l)``). With the row always
active the kinetic-energy partition equals that of the reduced model; the setters below
move a joint's followers with it. Couplings are stored as ``params["mimic"] =
[[joint, leader or None, a, b], ...]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..exceptions import InputError, ModelError

__all__ = [
    "JointCoordinate",
    "JointCoupling",
    "apply_couplings",
    "attach_couplings",
    "check_configuration",
    "joint_coordinate",
    "joint_reader",
    "joint_value",
    "lock_row",
    "set_joint_rate",
    "set_joint_value",
    "spring_torque",
    "velocity_index",
]

_ONE_DOF = ("revolute", "prismatic", "continuous")

#: How far from 1 the norm of a configuration's quaternion or (cos, sin) pair may be
UNIT_TOL = 1e-6


def _unit_parts(model) -> list[tuple[str, int, int, str]]:
    """``(joint, start in q, length, what)`` of the parts of ``q`` that must have unit norm:
    quaternions of free and spherical joints, (cos, sin) of continuous and planar ones."""
    out = []
    for j in range(1, model.njoints):
        jm = model.joints[j]
        kind = _kind(jm)
        if kind in ("free", "spherical") and jm.nq > jm.nv:
            out.append((model.names[j], jm.idx_q + jm.nq - 4, 4, "quaternion"))
        elif kind in ("continuous", "planar"):
            out.append((model.names[j], jm.idx_q + jm.nq - 2, 2, "(cos, sin) pair"))
    return out


def check_configuration(model, q, what: str = "q") -> None:
    """Refuse ``q`` (..., nq) that is not a configuration of ``model``: NaN or inf
    (InputError), or a quaternion or (cos, sin) pair whose norm is not 1 to
    :data:`UNIT_TOL` (ModelError naming the joint: Pinocchio would read a quaternion of
    norm 2 as a rotation scaled by 4, and T_c^- came out 46 % higher)."""
    import pinocchio as pin

    q = np.asarray(q, dtype=float)
    # the common case, one configuration, on the path of setup.evaluate(q): a finite sum
    # (NaN and inf carry through it; an overflow of finite values goes on to the full
    # check) and unit parts of unit norm, without numpy's ufunc and reduction calls
    if q.ndim == 1 and math.isfinite(sum(q.tolist())) and pin.isNormalized(model, q, UNIT_TOL):
        return
    if not np.isfinite(q).all():
        raise InputError(f"{what} contains NaN or inf")
    for name, start, k, part in _unit_parts(model):
        norm = np.linalg.norm(q[..., start:start + k], axis=-1)
        bad = np.abs(norm - 1.0) > UNIT_TOL
        if np.any(bad):
            value = float(np.ravel(norm)[np.flatnonzero(np.ravel(bad))[0]])
            takes = ("a continuous joint takes two numbers, cos theta and sin theta; "
                     if _kind(model.joints[model.getJointId(name)]) == "continuous" else "")
            raise ModelError(
                f"{what} is not a configuration of the model: the {part} of joint {name!r} "
                f"has norm {value:.6g}, not 1 ({takes}normalise it: "
                "pinocchio.normalize(model, q))")


def _kind(jm) -> str:
    s = jm.shortname().removeprefix("JointModel")
    if jm.nq == 1 and jm.nv == 1:
        if s in ("PX", "PY", "PZ", "PrismaticUnaligned"):
            return "prismatic"
        if s in ("RX", "RY", "RZ", "RevoluteUnaligned"):
            return "revolute"
        return s.lower()  # helical ...
    if jm.nq == 2 and jm.nv == 1:
        return "continuous"
    return {"FreeFlyer": "free", "Spherical": "spherical", "SphericalZYX": "spherical",
            "Planar": "planar", "Mimic": "mimic"}.get(s, s.lower())


@dataclass(frozen=True)
class JointCoordinate:
    """Where a joint lives in ``q`` and ``v``.

    Attributes
    ----------
    name : str
    kind : str
        ``"revolute"``, ``"prismatic"``, ``"continuous"`` (1-DoF) or ``"free"``,
        ``"spherical"``, ``"planar"``, ...
    idx_q, nq, idx_v, nv : int
        Slices ``q[idx_q:idx_q+nq]``, ``v[idx_v:idx_v+nv]``.
    mimic : tuple or None
        ``(leader or None, a, b)`` if the joint follows ``theta = a theta_leader + b``.
    """

    name: str
    kind: str
    idx_q: int
    nq: int
    idx_v: int
    nv: int
    mimic: tuple | None = None

    @property
    def one_dof(self) -> bool:
        return self.kind in _ONE_DOF


def _model(mbm):
    return getattr(mbm, "model", mbm)


def _mimic(mbm) -> dict[str, tuple]:
    params = getattr(mbm, "params", None) or {}
    return {row[0]: (row[1], float(row[2]), float(row[3])) for row in params.get("mimic", ())}


def joint_coordinate(mbm, name: str, *, what: str = "joint") -> JointCoordinate:
    """The :class:`JointCoordinate` of joint ``name``.

    Parameters
    ----------
    mbm : MultibodyModel or pinocchio.Model
    name : str
    what : str
        Context for the error message (e.g. ``"configuration.joints"``).

    Raises
    ------
    ModelError
        Unknown joint, naming it and listing the model's joints.
    """
    model = _model(mbm)
    if not isinstance(name, str) or not model.existJointName(name) or name == "universe":
        known = list(model.names[1:])
        raise ModelError(f"{what}: unknown joint {name!r}; the model has joints {known}")
    jm = model.joints[model.getJointId(name)]
    return JointCoordinate(name, _kind(jm), jm.idx_q, jm.nq, jm.idx_v, jm.nv,
                           _mimic(mbm).get(name))


def _one_dof(mbm, name: str, what: str) -> JointCoordinate:
    jc = joint_coordinate(mbm, name, what=what)
    if not jc.one_dof:
        raise ModelError(f"{what}: joint {name!r} is a {jc.kind} joint (nq = {jc.nq}, nv = "
                         f"{jc.nv}); only 1-DoF joints (revolute, prismatic, continuous) "
                         "are accepted here")
    return jc


def _wrap(x):
    """Angle(s) wrapped to ``(-pi, pi]``."""
    return -(np.mod(-np.asarray(x) + np.pi, 2.0 * np.pi) - np.pi)


def _theta(jc: JointCoordinate, q: np.ndarray) -> np.ndarray:
    if jc.kind == "continuous":
        return np.arctan2(q[..., jc.idx_q + 1], q[..., jc.idx_q])
    return q[..., jc.idx_q]


def _put(jc: JointCoordinate, q: np.ndarray, theta) -> None:
    if jc.kind == "continuous":
        q[..., jc.idx_q] = np.cos(theta)
        q[..., jc.idx_q + 1] = np.sin(theta)
    else:
        q[..., jc.idx_q] = theta


def _as(x, n: int, what: str) -> np.ndarray:
    x = np.array(x, dtype=float)  # a copy
    if x.ndim == 0 or x.shape[-1] != n:
        raise ModelError(f"{what} must have shape (..., {n}), got {x.shape}")
    return x


def joint_value(mbm, q, name: str):
    """Value of 1-DoF joint ``name`` in ``q`` (..., nq): angle [rad] or displacement [m];
    a continuous joint's angle is ``atan2(sin, cos)`` in ``(-pi, pi]``.

    Returns
    -------
    float or (...) ndarray
    """
    jc = _one_dof(mbm, name, "joint value")
    out = _theta(jc, _as(q, _model(mbm).nq, "q"))
    return float(out) if np.ndim(out) == 0 else out


def joint_reader(mbm, name: str, *, what: str = "joint value"):
    """``q -> joint_value(mbm, q, name)`` for a ``q`` of shape (nq,), with the joint looked
    up and checked once (for the simulator's right-hand side, called thousands of times).

    Raises
    ------
    ModelError
        As :func:`joint_value`: unknown joint or not a 1-DoF joint.
    """
    jc = _one_dof(mbm, name, what)
    i = jc.idx_q
    if jc.kind == "continuous":
        return lambda q: float(np.arctan2(q[i + 1], q[i]))
    return lambda q: float(q[i])


def _leader_chain(mimic: dict, name: str, what: str):
    """``(root, theta_root(theta_name))`` by walking up the mimic chain."""
    seen = set()
    a_tot, b_tot = 1.0, 0.0  # theta_name = a_tot theta_root + b_tot
    cur = name
    while cur in mimic:
        if cur in seen:
            raise ModelError(f"{what}: mimic joints form a cycle through {cur!r}")
        seen.add(cur)
        leader, a, b = mimic[cur]
        if leader is None:  # fixed: theta_cur = b
            return None, a_tot * 0.0, a_tot * b + b_tot
        a_tot, b_tot = a_tot * a, a_tot * b + b_tot
        cur = leader
    return cur, a_tot, b_tot


def _followers(mimic: dict, leader: str) -> list[tuple[str, float, float]]:
    return [(f, a, b) for f, (lead, a, b) in mimic.items() if lead == leader]


def set_joint_value(mbm, q, name: str, value, *, what: str = "configuration.joints"):
    """``q`` with 1-DoF joint ``name`` set to ``value`` (rad or m), its mimic followers
    moved with it.

    Setting a mimic joint sets its leader to ``(value - b) / a`` and every joint coupled to
    it (``theta_m = a theta_leader + b``). Continuous joints get ``(cos, sin)``.

    Parameters
    ----------
    mbm : MultibodyModel or pinocchio.Model
    q : (..., nq) array_like
    name : str
    value : float or (...) array_like

    Returns
    -------
    (..., nq) ndarray
        A new array (``q`` is not modified).

    Examples
    --------
    >>> import numpy as np, pinocchio as pin
    >>> from roverimpact.models.joints import joint_value, set_joint_value
    >>> model = pin.Model()
    >>> _ = model.addJoint(0, pin.JointModelRUBY(), pin.SE3.Identity(), "wheel")
    >>> q = set_joint_value(model, pin.neutral(model), "wheel", np.pi / 2)
    >>> q.round(12).tolist(), joint_value(model, q, "wheel") == np.pi / 2
    ([0.0, 1.0], True)
    """
    q = _as(q, _model(mbm).nq, "q")
    _one_dof(mbm, name, what)
    mimic = _mimic(mbm)
    value = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(value)):
        raise ModelError(f"{what}: joint {name!r}: value must be finite, got {value}")
    root, a, b = _leader_chain(mimic, name, what)
    if root is None or a == 0.0:
        if not np.allclose(value, b, rtol=0, atol=1e-12):
            raise ModelError(f"{what}: joint {name!r} is held at {b:g} by its coupling; it "
                             f"cannot be set to {value}")
        stack = [(name, value)]
    else:
        stack = [(root, (value - b) / a)]
    while stack:
        nm, th = stack.pop()
        _put(joint_coordinate(mbm, nm), q, th)
        stack.extend((f, fa * th + fb) for f, fa, fb in _followers(mimic, nm))
    return q


def set_joint_rate(mbm, v, name: str, rate, *, what: str = "velocity.joints"):
    """``v`` with the rate of 1-DoF joint ``name`` set to ``rate`` (rad/s or m/s), its
    mimic followers at ``a * rate`` (a mimic joint sets its leader to ``rate / a``).

    Returns
    -------
    (..., nv) ndarray
        A new array.
    """
    v = _as(v, _model(mbm).nv, "v")
    _one_dof(mbm, name, what)
    mimic = _mimic(mbm)
    rate = np.asarray(rate, dtype=float)
    if not np.all(np.isfinite(rate)):
        raise ModelError(f"{what}: joint {name!r}: rate must be finite, got {rate}")
    root, a, _ = _leader_chain(mimic, name, what)
    if root is None or a == 0.0:
        if not np.allclose(rate, 0.0, rtol=0, atol=1e-12):
            raise ModelError(f"{what}: joint {name!r} is held fixed by its coupling; its "
                             "rate must be 0")
        return v
    stack = [(root, rate / a)]
    while stack:
        nm, r = stack.pop()
        v[..., joint_coordinate(mbm, nm).idx_v] = r
        stack.extend((f, fa * r) for f, fa, _fb in _followers(mimic, nm))
    return v


def velocity_index(mbm, name: str, *, what: str = "joint") -> int:
    """Index in ``v`` of 1-DoF joint ``name`` (continuous joints included)."""
    return _one_dof(mbm, name, what).idx_v


def lock_row(mbm, name: str, *, what: str = "contacts.locked") -> np.ndarray:
    """Constraint row (nv,) locking 1-DoF joint ``name``: ``e_{idx_v}``, so ``row v`` is
    its rate."""
    jc = _one_dof(mbm, name, what)
    row = np.zeros(_model(mbm).nv)
    row[jc.idx_v] = 1.0
    return row


def spring_torque(mbm, q, v, name: str, k: float, c: float = 0.0, theta0: float = 0.0,
                  *, what: str = "spring"):
    r"""Generalized force of a linear spring-damper on 1-DoF joint ``name``.

    .. math::

        \tau = -\left(k\,(\theta - \theta_0) + c\,\dot\theta\right) e_{idx_v}

    For a continuous joint ``theta - theta0`` is wrapped to ``(-pi, pi]`` (its angle is
    only known modulo 2 pi).

    Parameters
    ----------
    q : (..., nq) array_like
    v : (..., nv) array_like
    k : float
        Stiffness [N m/rad or N/m].
    c : float
        Damping [N m s/rad or N s/m].
    theta0 : float
        Rest value [rad or m].

    Returns
    -------
    (..., nv) ndarray
    """
    model = _model(mbm)
    jc = _one_dof(mbm, name, what)
    q = _as(q, model.nq, "q")
    v = _as(v, model.nv, "v")
    d = _theta(jc, q) - theta0
    if jc.kind == "continuous":
        d = _wrap(d)
    tau = np.zeros((*np.broadcast_shapes(q.shape[:-1], v.shape[:-1]), model.nv))
    tau[..., jc.idx_v] = -(k * d + c * v[..., jc.idx_v])
    return tau


# ----------------------------------------------------------------------------- couplings


@dataclass(frozen=True)
class JointCoupling:
    r"""Closure rows linear in 1-DoF joint values: ``phi_k = sum_i C[k, i] theta_i + c0[k]``.

    ``theta`` of a continuous joint is its angle; a row touching a continuous joint is
    wrapped to ``(-pi, pi]``. ``J = C`` in the columns ``idx_v`` (constant). Callable as
    ``loop_closure(q) -> (phi (k,), J (k, nv))`` like
    :class:`~roverimpact.models._build.LinearLoopClosure`.
    """

    joints: tuple[str, ...]
    coefficients: tuple[tuple[float, ...], ...]
    offsets: tuple[float, ...]
    idx_q: tuple[int, ...]
    idx_v: tuple[int, ...]
    continuous: tuple[bool, ...]
    nv: int
    #: ``J`` does not depend on ``q`` (the compiled row plan stores it once).
    constant_jacobian = True

    @classmethod
    def from_rows(cls, mbm, joints, coefficients, offsets) -> JointCoupling:
        jcs = [_one_dof(mbm, nm, "coupling") for nm in joints]
        C = tuple(tuple(float(x) for x in row) for row in coefficients)
        return cls(tuple(joints), C, tuple(float(x) for x in offsets),
                   tuple(j.idx_q for j in jcs), tuple(j.idx_v for j in jcs),
                   tuple(j.kind == "continuous" for j in jcs), int(_model(mbm).nv))

    def __call__(self, q) -> tuple[np.ndarray, np.ndarray]:
        q = np.asarray(q, dtype=float)
        cols = []
        for iq, cont in zip(self.idx_q, self.continuous, strict=True):
            cols.append(np.arctan2(q[..., iq + 1], q[..., iq]) if cont else q[..., iq])
        theta = np.stack(cols, axis=-1)
        C = np.asarray(self.coefficients, dtype=float).reshape(-1, len(self.joints))
        phi = theta @ C.T + np.asarray(self.offsets)
        wrap = (C[:, np.asarray(self.continuous)] != 0).any(axis=1)
        phi = np.where(wrap, _wrap(phi), phi)
        J = np.zeros((C.shape[0], self.nv))
        J[:, list(self.idx_v)] = C
        return phi, J


def mimic_rows(mbm) -> tuple[list[str], list[str], list[list[float]], list[float]]:
    """``(labels, joints, C, c0)`` of the couplings in ``params["mimic"]`` (a row
    ``"mimic:<joint>"`` each) and ``params["couplings"]`` (``[label, joints, coefficients,
    offset]``: MJCF tendon equalities over fixed tendons, a row ``label`` each)."""
    params = getattr(mbm, "params", None) or {}
    mimic = params.get("mimic", [])
    general = params.get("couplings", [])
    joints: list[str] = []
    for f, lead, _a, _b in mimic:
        for nm in (f, lead):
            if nm is not None and nm not in joints:
                joints.append(nm)
    for _lab, names, _coefs, _off in general:
        joints.extend(nm for nm in names if nm not in joints)
    C, c0, labels = [], [], []
    for f, lead, a, b in mimic:
        row = [0.0] * len(joints)
        row[joints.index(f)] = 1.0
        if lead is not None:
            row[joints.index(lead)] -= float(a)
        C.append(row)
        c0.append(-float(b))
        labels.append(f"mimic:{f}")
    for lab, names, coefs, off in general:
        row = [0.0] * len(joints)
        for nm, x in zip(names, coefs, strict=True):
            row[joints.index(nm)] += float(x)
        C.append(row)
        c0.append(float(off))
        labels.append(str(lab))
    return labels, joints, C, c0


def apply_couplings(mbm, q) -> np.ndarray:
    """``q`` with every mimic joint set from its leader (a new array)."""
    q = _as(q, _model(mbm).nq, "q")
    mimic = _mimic(mbm)
    roots = {_leader_chain(mimic, f, "mimic")[0] for f in mimic}
    for root in roots:
        if root is None:
            continue
        q = set_joint_value(mbm, q, root, _theta(joint_coordinate(mbm, root), q),
                            what="mimic")
    for f, (lead, _a, b) in mimic.items():
        if lead is None:
            _put(joint_coordinate(mbm, f), q, b)
    return q


def attach_couplings(mbm) -> None:
    """Add the couplings of ``mbm.params["mimic"]`` and ``mbm.params["couplings"]`` to
    ``mbm.loop_closure`` (one :class:`JointCoupling` holding the model's linear loop rows,
    if any, one row ``"mimic:<joint>"`` per mimic joint and one per general coupling) and
    make ``params["q_nominal"]`` satisfy them: mimic joints are set from their leaders,
    then, if a row still does not hold, the coupled joint values move by the least-squares
    (minimum-norm) correction onto all rows.

    Raises
    ------
    ModelError
        If a mimic or leader joint is not a 1-DoF joint, or the existing loop closure is
        not linear.
    """
    labels, joints, C, c0 = mimic_rows(mbm)
    if not labels:
        return
    from ._build import LinearLoopClosure

    rows_C, rows_c0, names = [], [], []
    lc = mbm.loop_closure
    if lc is not None:
        if not isinstance(lc, (LinearLoopClosure, JointCoupling)):
            raise ModelError(f"model {mbm.name!r}: mimic joints need a linear loop closure "
                             "to join")
        for nm in lc.joints:
            if nm not in joints:
                joints.append(nm)
        offsets = getattr(lc, "offsets", (0.0,) * len(lc.coefficients))
        for row, off in zip(lc.coefficients, offsets, strict=True):
            full = [0.0] * len(joints)
            for nm, x in zip(lc.joints, row, strict=True):
                full[joints.index(nm)] = float(x)
            rows_C.append(full)
            rows_c0.append(float(off))
        names.extend(mbm.loop_names)
    for row, b, lab in zip(C, c0, labels, strict=True):
        rows_C.append(list(row) + [0.0] * (len(joints) - len(row)))
        rows_c0.append(b)
        names.append(lab)
    mbm.loop_closure = JointCoupling.from_rows(mbm, joints, rows_C, rows_c0)
    mbm.loop_names = names
    import pinocchio as pin

    q0 = mbm.params.get("q_nominal")
    q0 = pin.neutral(mbm.model) if q0 is None else np.asarray(q0, dtype=float)
    q0 = apply_couplings(mbm, q0)
    q0 = _project_rows(mbm.loop_closure, q0)
    mbm.params["q_nominal"] = [float(x) for x in q0]


def _project_rows(lc: JointCoupling, q: np.ndarray, atol: float = 1e-12) -> np.ndarray:
    """``q`` moved onto ``phi(q) = 0`` by ``theta -= C^+ phi`` over the coupled joints that
    are not continuous (rows linear in them: one step is exact); ``q`` itself when the rows
    hold already."""
    phi, _ = lc(q)
    if not np.any(np.abs(phi) > atol):
        return q
    C = np.asarray(lc.coefficients, dtype=float).reshape(-1, len(lc.joints))
    free = [i for i, cont in enumerate(lc.continuous) if not cont]
    dtheta = -np.linalg.pinv(C[:, free]) @ phi
    q = np.array(q, dtype=float)
    for i, d in zip(free, dtheta, strict=True):
        q[lc.idx_q[i]] += d
    return q
