r"""Robot arms near people: ISO/TS 15066 transient-contact speed limits and exact effective mass.

ISO/TS 15066:2016 (Annex A, power and force limiting) models a free (transient) collision
between a robot and a human body region as two masses joined by a linear spring:

.. math::

    \mu = \Big(\frac{1}{m_H} + \frac{1}{m_R}\Big)^{-1}, \qquad
    E = \frac{F^2}{2K} = \tfrac12 \mu v_{rel}^2 \quad\Rightarrow\quad
    v_{rel,max} = \frac{F_{max}}{\sqrt{\mu K}} ,

with :math:`m_H` the effective mass and :math:`K` the effective spring constant of the
body region (Table A.3), :math:`F_{max}` the permissible transient contact force (Table A.2:
twice the quasi-static force) and the robot's *reduced* mass taken crudely as

.. math::  m_R = \frac{M}{2} + m_L

(:math:`M` total mass of the moving parts of the robot, :math:`m_L` the payload).

The exact robot-side mass for a contact at a point p of link i along a unit direction u is
the effective mass of the row :math:`a = u^T J_p(q)` (kinetic-energy partition,
:func:`roverimpact.effective_mass`):

.. math::  m_u = \frac{1}{u^T J_p M(q)^{-1} J_p^T u} .

It depends on the configuration, the link and the direction: :func:`arm_effective_masses`
shows how far the standard's single number :math:`M/2 + m_L` is from it.

Pinocchio is imported lazily (only the arm functions need it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ._checks import as_array
from .energy import effective_mass
from .exceptions import InputError, ModelError

__all__ = [
    "BODY_AREAS",
    "BODY_REGIONS",
    "ISO_TS_15066_SOURCE",
    "READY_POSES",
    "BodyArea",
    "BodyRegion",
    "arm_effective_masses",
    "body_region",
    "iso_robot_mass",
    "load_arm",
    "max_transient_speed",
    "point_effective_mass",
    "reduced_mass",
    "transfer_energy",
]

#: Where the numbers of :data:`BODY_REGIONS` and :data:`BODY_AREAS` come from.
ISO_TS_15066_SOURCE = (
    "ISO/TS 15066:2016, Robots and robotic devices - Collaborative robots, Annex A: "
    "Table A.2 (biomechanical limits: maximum permissible quasi-static force per body region "
    "and pressure per body area; transient limits = 2 x quasi-static, footnote c), "
    "Table A.3 (effective spring constant K and effective mass m_H per body region), "
    "eqs. (A.1)-(A.6) (two-body model, mu, m_R = M/2 + m_L, E = F^2/(2K), "
    "v_rel,max = F_max / sqrt(mu K))."
)


@dataclass(frozen=True)
class BodyRegion:
    """One body region of the ISO/TS 15066 body model.

    Attributes
    ----------
    name : str
        Key used by the API and the CLI (``"hands_fingers"``, ...).
    label : str
        Name as printed in the standard.
    m_H : float
        Effective mass of the body region [kg] (Table A.3).
    K : float
        Effective spring constant [N/m] (Table A.3 gives N/mm).
    F_qs : float
        Maximum permissible quasi-static contact force [N] (Table A.2).
    transient_factor : float or None
        Multiplier from quasi-static to transient force (Table A.2: 2). ``None`` where the
        standard gives no transient value (skull/forehead, face): transient contact with
        the head is to be avoided, so no speed is computed.
    """

    name: str
    label: str
    m_H: float
    K: float
    F_qs: float
    transient_factor: float | None = 2.0

    @property
    def F_transient(self) -> float | None:
        """Maximum permissible transient contact force [N], or ``None``."""
        return None if self.transient_factor is None else self.transient_factor * self.F_qs


@dataclass(frozen=True)
class BodyArea:
    """One of the 29 specific body areas with a pressure limit (Table A.2).

    Attributes
    ----------
    number : int
        Area number in the standard's body map (1..29).
    label : str
        Name of the area in the standard.
    region : str
        Key of the :class:`BodyRegion` it belongs to.
    p_qs : float
        Maximum permissible quasi-static pressure [Pa] (Table A.2 gives N/cm^2).
    """

    number: int
    label: str
    region: str
    p_qs: float

    @property
    def p_transient(self) -> float:
        """Maximum permissible transient pressure [Pa] (2 x quasi-static)."""
        return 2.0 * self.p_qs


_NPMM = 1e3  # N/mm -> N/m
_NPCM2 = 1e4  # N/cm^2 -> Pa

#: ISO/TS 15066:2016 body regions: (Table A.3) m_H [kg], K [N/m]; (Table A.2) F_qs [N].
BODY_REGIONS: dict[str, BodyRegion] = {
    r.name: r
    for r in (
        BodyRegion("skull_forehead", "Skull and forehead", 4.4, 150 * _NPMM, 130.0, None),
        BodyRegion("face", "Face", 4.4, 75 * _NPMM, 65.0, None),
        BodyRegion("neck", "Neck", 1.2, 50 * _NPMM, 150.0),
        BodyRegion("back_shoulders", "Back and shoulders", 40.0, 35 * _NPMM, 210.0),
        BodyRegion("chest", "Chest", 40.0, 25 * _NPMM, 140.0),
        BodyRegion("abdomen", "Abdomen", 40.0, 10 * _NPMM, 110.0),
        BodyRegion("pelvis", "Pelvis", 40.0, 25 * _NPMM, 180.0),
        BodyRegion("upper_arms_elbows", "Upper arms and elbow joints", 3.0, 30 * _NPMM, 150.0),
        BodyRegion("lower_arms_wrists", "Lower arms and wrist joints", 2.0, 40 * _NPMM, 160.0),
        BodyRegion("hands_fingers", "Hands and fingers", 0.6, 75 * _NPMM, 140.0),
        BodyRegion("thighs_knees", "Thighs and knees", 75.0, 50 * _NPMM, 220.0),
        BodyRegion("lower_legs", "Lower legs", 75.0, 60 * _NPMM, 130.0),
    )
}

#: ISO/TS 15066:2016 Table A.2 specific body areas and their quasi-static pressure limits.
BODY_AREAS: tuple[BodyArea, ...] = tuple(
    BodyArea(i + 1, label, region, p * _NPCM2)
    for i, (label, region, p) in enumerate(
        (
            ("Middle of forehead", "skull_forehead", 130),
            ("Temple", "skull_forehead", 110),
            ("Masticatory muscle", "face", 110),
            ("Neck muscle", "neck", 140),
            ("Seventh neck muscle", "neck", 210),
            ("Shoulder joint", "back_shoulders", 160),
            ("Fifth lumbar vertebra", "back_shoulders", 210),
            ("Sternum", "chest", 120),
            ("Pectoral muscle", "chest", 170),
            ("Abdominal muscle", "abdomen", 140),
            ("Pelvic bone", "pelvis", 210),
            ("Deltoid muscle", "upper_arms_elbows", 190),
            ("Humerus", "upper_arms_elbows", 220),
            ("Radial bone", "lower_arms_wrists", 190),
            ("Forearm muscle", "lower_arms_wrists", 180),
            ("Arm nerve", "lower_arms_wrists", 180),
            ("Forefinger pad D", "hands_fingers", 300),
            ("Forefinger pad ND", "hands_fingers", 270),
            ("Forefinger end joint D", "hands_fingers", 280),
            ("Forefinger end joint ND", "hands_fingers", 220),
            ("Thenar eminence", "hands_fingers", 200),
            ("Palm D", "hands_fingers", 260),
            ("Palm ND", "hands_fingers", 260),
            ("Back of the hand D", "hands_fingers", 200),
            ("Back of the hand ND", "hands_fingers", 190),
            ("Thigh muscle", "thighs_knees", 250),
            ("Kneecap", "thighs_knees", 220),
            ("Middle of shin", "lower_legs", 220),
            ("Calf muscle", "lower_legs", 210),
        )
    )
)


def body_region(name: str | BodyRegion) -> BodyRegion:
    """Look up a body region by key (``"hands_fingers"``) or return it unchanged."""
    if isinstance(name, BodyRegion):
        return name
    key = str(name).strip().lower().replace("-", "_").replace(" ", "_")
    if key not in BODY_REGIONS:
        raise InputError(
            f"unknown body region {name!r}; known: {', '.join(BODY_REGIONS)}"
        )
    return BODY_REGIONS[key]


def _positive(x, name: str, *, allow_zero: bool = False, allow_inf: bool = False) -> np.ndarray:
    arr = as_array(x, name)
    bad = np.isnan(arr) | (arr < 0 if allow_zero else arr <= 0)
    if not allow_inf:
        bad |= ~np.isfinite(arr)
    if np.any(bad):
        what = "non-negative" if allow_zero else "positive"
        raise InputError(f"{name} must be {what} and finite, got {arr[bad].ravel()[0]!r}")
    return arr


def iso_robot_mass(M_total, payload=0.0):
    r"""The standard's reduced robot mass :math:`m_R = M/2 + m_L` [kg].

    Parameters
    ----------
    M_total : float or array_like
        Total mass of the moving parts of the robot [kg].
    payload : float or array_like, optional
        Payload (tool and part) mass :math:`m_L` [kg].
    """
    M_total = _positive(M_total, "M_total")
    payload = _positive(payload, "payload", allow_zero=True)
    out = 0.5 * M_total + payload
    return out[()] if out.ndim == 0 else out


def reduced_mass(m_H, m_R):
    r"""Two-body reduced mass :math:`\mu = (1/m_H + 1/m_R)^{-1}` [kg].

    ``m_R = inf`` (a robot point that cannot move along the contact direction) gives
    :math:`\mu = m_H`. Broadcasts over arrays.
    """
    m_H = _positive(m_H, "m_H")
    m_R = _positive(m_R, "m_R", allow_inf=True)
    out = 1.0 / (1.0 / m_H + 1.0 / m_R)
    return out[()] if out.ndim == 0 else out


def transfer_energy(region: str | BodyRegion, *, force=None) -> float:
    r"""Energy the body region can absorb, :math:`E = F^2 / (2K)` [J].

    ``force`` defaults to the region's transient force limit.
    """
    r = body_region(region)
    F = r.F_transient if force is None else float(force)
    if F is None:
        raise InputError(
            f"ISO/TS 15066 gives no transient force for {r.label!r} (contact with the head is "
            "to be avoided); pass force= explicitly"
        )
    F = float(_positive(F, "force"))
    return F * F / (2.0 * r.K)


def max_transient_speed(region: str | BodyRegion, m_R, *, force=None, pressure=None,
                        contact_area=None):
    r"""Largest permissible relative speed for transient contact (ISO/TS 15066 A.3).

    .. math::  v_{rel,max} = \frac{F_{max}}{\sqrt{\mu K}},\quad
        \mu = (1/m_H + 1/m_R)^{-1},\quad F_{max} = \min(F_T,\; p_T A)

    Parameters
    ----------
    region : str or BodyRegion
        Body region (key of :data:`BODY_REGIONS`).
    m_R : float or array_like
        Robot-side mass [kg]: the standard's :func:`iso_robot_mass` or an exact effective
        mass (:func:`point_effective_mass`); ``inf`` allowed.
    force : float, optional
        Force limit [N]; default the region's transient limit (2 x quasi-static).
    pressure, contact_area : float, optional
        Pressure limit [Pa] and contact area [m^2]: if both are given, the force is capped
        at ``pressure * contact_area`` (eq. A.6 of the standard).

    Returns
    -------
    v_max : float or ndarray
        [m/s], broadcast over ``m_R``.
    """
    r = body_region(region)
    F = r.F_transient if force is None else force
    if F is None:
        raise InputError(
            f"ISO/TS 15066 gives no transient force limit for {r.label!r} (transient contact "
            "with the head is to be avoided); pass force= to compute a speed anyway"
        )
    F = _positive(F, "force")
    if (pressure is None) != (contact_area is None):
        raise InputError("pressure and contact_area must be given together")
    if pressure is not None:
        F = np.minimum(F, _positive(pressure, "pressure") * _positive(contact_area,
                                                                      "contact_area"))
    mu = reduced_mass(r.m_H, m_R)
    out = F / np.sqrt(mu * r.K)
    return out[()] if np.ndim(out) == 0 else out


# ----------------------------------------------------------------------------------------
# Arms (Pinocchio)
# ----------------------------------------------------------------------------------------


def load_arm(source: str | Path):
    """Load a fixed-base arm as a ``pinocchio.Model``.

    Parameters
    ----------
    source : str or Path
        A URDF file, or ``"erd:<name>"`` for a robot of the ``example-robot-data`` package
        (e.g. ``"erd:panda"``, ``"erd:ur5"``); only the kinematics and inertias are read.

    Raises
    ------
    ModelError
        Unreadable URDF, unknown robot, or package not installed.
    """
    import pinocchio as pin

    s = str(source)
    if s.startswith("erd:"):
        from .models.robot_data import example_robot_urdf

        path = example_robot_urdf(s[4:])
    else:
        path = Path(s)
    if not path.is_file():
        raise ModelError(f"{path}: no such URDF file (or use erd:<name>)")
    try:
        return pin.buildModelFromUrdf(str(path))
    except (ValueError, RuntimeError) as exc:
        raise ModelError(f"{path}: not a readable URDF ({exc})") from None


#: A configuration away from singularities for the arms of example-robot-data (rad, m).
READY_POSES = {
    "panda": [0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4, 0.02,
              0.02],
}


def _mass_matrix(model, data, q):
    import pinocchio as pin

    M = np.array(pin.crba(model, data, q)).reshape(model.nv, model.nv)
    return np.triu(M) + np.triu(M, 1).T


def _check_q(model, q):
    q = as_array(q, "q", min_ndim=1)
    if q.shape != (model.nq,):
        raise InputError(f"q must have shape ({model.nq},) for this model, got {q.shape}")
    if not np.all(np.isfinite(q)):
        raise InputError("q contains NaN or inf")
    return q


def _point_jacobian(model, data, joint_id: int, p_joint: np.ndarray) -> np.ndarray:
    """Translational Jacobian J_p (3, nv), world axes, of a point fixed in joint ``joint_id``.

    Needs ``computeJointJacobians`` and ``updateFramePlacements`` done on ``data``.
    ``v_p = v_o + w x r = J_lin v - [r]_x J_ang v`` with ``r = R p_joint``.
    """
    import pinocchio as pin

    J = np.asarray(
        pin.getJointJacobian(model, data, joint_id, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
    ).reshape(6, model.nv)
    r = data.oMi[joint_id].rotation @ p_joint
    rx = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    return J[:3] - rx @ J[3:]


def _resolve_point(model, link: str, point):
    """(joint id, point in the joint frame) for a frame name and a point in that frame."""
    if not model.existFrame(link):
        names = [f.name for f in model.frames if f.type == _body_type()]
        raise ModelError(f"no frame {link!r} in model {model.name!r}; bodies: {names}")
    fid = model.getFrameId(link)
    frame = model.frames[fid]
    jid = int(frame.parentJoint)
    if jid == 0:
        raise ModelError(f"frame {link!r} is fixed to the world: it cannot hit anything")
    p = np.zeros(3) if point is None else as_array(point, "point")
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise InputError(f"point must be 3 finite coordinates in frame {link!r}, got {p}")
    return jid, np.asarray(frame.placement.act(p))


def _body_type():
    import pinocchio as pin

    return pin.FrameType.BODY


def point_effective_mass(model, q, link: str, direction, *, point=None, rtol: float = 1e-10):
    r"""Exact effective mass of a point of a link along one or many unit directions.

    .. math::  m_u = \frac{1}{u^T J_p(q) M(q)^{-1} J_p(q)^T u}

    computed with :func:`roverimpact.effective_mass` on the row :math:`a = u^T J_p`.

    Parameters
    ----------
    model : pinocchio.Model
        Fixed-base arm.
    q : (nq,) array_like
        Configuration.
    link : str
        Name of a Pinocchio frame (a link/body or any frame fixed to one).
    direction : (3,) or (k, 3) array_like
        Contact direction(s) in world axes; normalised here.
    point : (3,) array_like, optional
        Contact point in the frame's coordinates [m]; default the frame origin.
    rtol : float, optional
        A row with :math:`|u^T J_p| \le` ``rtol`` :math:`|J_p|` means the point cannot move
        along ``u``; its effective mass is ``inf``.

    Returns
    -------
    m_u : float or (k,) ndarray
        [kg]; ``inf`` where the point cannot move along the direction.
    """
    import pinocchio as pin

    q = _check_q(model, q)
    u = as_array(direction, "direction", min_ndim=1)
    single = u.ndim == 1
    u = np.atleast_2d(u)
    if u.shape[-1] != 3 or u.ndim != 2:
        raise InputError(f"direction must have shape (3,) or (k, 3), got {u.shape}")
    nrm = np.linalg.norm(u, axis=1)
    if not np.all(np.isfinite(nrm)) or np.any(nrm == 0):
        raise InputError("direction must be finite and non-zero")
    u = u / nrm[:, None]
    jid, p = _resolve_point(model, link, point)
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    M = _mass_matrix(model, data, q)
    Jp = _point_jacobian(model, data, jid, p)
    A = u @ Jp  # (k, nv)
    moving = np.linalg.norm(A, axis=1) > rtol * max(np.linalg.norm(Jp), 1e-300)
    out = np.full(len(u), np.inf)
    if moving.any():
        out[moving] = effective_mass(M, A[moving][:, None, :])[..., 0, 0]
    return float(out[0]) if single else out


def _link_points(model, which: str):
    """(label, joint id, point in joint frame) for every moving body of the tree."""
    out = []
    for jid in range(1, model.njoints):
        body = next(
            (f.name for f in model.frames if f.parentJoint == jid and f.type == _body_type()),
            model.names[jid],
        )
        p = np.array(model.inertias[jid].lever) if which == "com" else np.zeros(3)
        out.append((body, jid, p))
    return out


def arm_effective_masses(model, q, *, payload: float = 0.0, points: str = "com",
                         region: str | BodyRegion = "hands_fingers"):
    r"""Compare the standard's :math:`m_R = M/2 + m_L` with the exact effective mass per link.

    For every moving body i (the body of joint i, with the fixed links merged into it by
    Pinocchio) at the point ``points`` (``"com"``: its centre of mass; ``"origin"``: the
    joint origin), the exact effective mass over all unit directions u ranges between

    .. math::  m_{min} = 1/\lambda_{max}(G),\quad m_{max} = 1/\lambda_{min}(G),\quad
        G = J_p M^{-1} J_p^T \;(3\times3),

    (``inf`` where the point cannot move along some direction). The table also gives the
    ISO speed limit for ``region`` with the standard's crude mass and with the exact
    lightest / heaviest direction.

    Parameters
    ----------
    model : pinocchio.Model
        Fixed-base arm; ``M`` of the standard is the summed mass of its moving bodies.
    q : (nq,) array_like
        Configuration.
    payload : float, optional
        Payload :math:`m_L` [kg] of the standard's formula. It is not added to the exact
        model: add it to the URDF (or the model's last inertia) for a like-for-like check.
    points : {"com", "origin"}
        Which point of each body.
    region : str or BodyRegion
        Body region for the speed columns.

    Returns
    -------
    pandas.DataFrame
        One row per moving body: ``link``, ``joint``, ``m_R_iso`` [kg], ``m_min``, ``m_max``
        [kg], ``ratio_min`` (m_min / m_R_iso), ``v_iso``, ``v_exact_worst`` (for m_max),
        ``v_exact_best`` (for m_min) [m/s].
    """
    import pandas as pd
    import pinocchio as pin

    if points not in ("com", "origin"):
        raise InputError(f"points must be 'com' or 'origin', got {points!r}")
    q = _check_q(model, q)
    reg = body_region(region)
    M_total = float(sum(model.inertias[j].mass for j in range(1, model.njoints)))
    m_iso = float(iso_robot_mass(M_total, payload))
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    M = _mass_matrix(model, data, q)
    Minv = np.linalg.inv(M)
    rows = []
    for body, jid, p in _link_points(model, points):
        Jp = _point_jacobian(model, data, jid, p)
        G = Jp @ Minv @ Jp.T
        lam = np.linalg.eigvalsh(0.5 * (G + G.T))
        lmax = lam[-1]
        if lmax <= 0:
            m_min = m_max = np.inf
        else:
            m_min = 1.0 / lmax
            m_max = np.inf if lam[0] <= 1e-10 * lmax else 1.0 / lam[0]
        rows.append({
            "link": body,
            "joint": model.names[jid],
            "m_R_iso": m_iso,
            "m_min": m_min,
            "m_max": m_max,
            "ratio_min": m_min / m_iso,
        })
    df = pd.DataFrame(rows)
    if reg.F_transient is not None:
        df["v_iso"] = max_transient_speed(reg, m_iso)
        df["v_exact_worst"] = max_transient_speed(reg, df["m_max"].to_numpy())
        df["v_exact_best"] = max_transient_speed(reg, df["m_min"].to_numpy())
    df.attrs.update({"M_total": M_total, "payload": float(payload), "region": reg.name,
                     "q": q.tolist(), "points": points})
    return df
