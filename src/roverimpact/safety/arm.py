r"""Exact effective mass of robot-arm links (the robot side of ISO/TS 15066's two-body model).

The exact robot-side mass for a contact at a point p of link i along a unit direction u is
the effective mass of the row :math:`a = u^T J_p(q)` (kinetic-energy partition,
:func:`roverimpact.effective_mass`):

.. math::  m_u = \frac{1}{u^T J_p M(q)^{-1} J_p^T u} .

It depends on the configuration, the link and the direction: :func:`arm_effective_masses`
shows how far the standard's single number :math:`M/2 + m_L`
(:func:`roverimpact.safety.iso_ts_15066.iso_robot_mass`) is from it.

Coupled joints (URDF ``<mimic>``, MJCF joint equalities, closed loops) are the model's
loop-closure rows :math:`B` (:mod:`roverimpact.models.joints`), held as in the scenario
path (``roverimpact energy``): the mass is that of the row with :math:`B v = 0`,

.. math::  m_u = \frac{1}{u^T J_p N J_p^T u},\qquad
    N = M^{-1} - M^{-1} B^T (B M^{-1} B^T)^{+} B M^{-1},

the same as the reduced model's (:math:`v = S z`: :math:`M_z = S^T M S`, :math:`J_z = J_p S`).

Everything model-side comes from :mod:`roverimpact.models`: the robot file through
:func:`~roverimpact.models.load_robot`, :math:`M(q)` and :math:`B` from its
:class:`~roverimpact.models.kinematics.ConstraintSet` and :math:`J_p` from
:func:`~roverimpact.models.constraints.point_jacobian`. Pinocchio is imported lazily.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from .._validation import as_array, check_rtol
from ..energy import projector, row_masses
from ..exceptions import InputError, ModelError
from .iso_ts_15066 import BodyRegion, body_region, iso_robot_mass, max_transient_speed

__all__ = ["READY_POSES", "arm_effective_masses", "load_arm", "point_effective_mass",
           "point_speed_limits"]


def load_arm(source: str | Path):
    """Load a fixed-base arm (:func:`roverimpact.models.load_robot`).

    Parameters
    ----------
    source : str or Path
        A URDF or MJCF file, or a robot of the ``example-robot-data`` package:
        ``"erd:<name>"`` (e.g. ``"erd:panda"``, ``"erd:ur5"``) or
        ``"example-robot-data:<name or path>"`` (see :mod:`roverimpact.models.robot_data`);
        only the kinematics and inertias are read.

    Returns
    -------
    MultibodyModel
        Its ``model`` is the ``pinocchio.Model``; its loop closure holds the couplings of
        ``<mimic>`` joints, which the functions of this module keep.

    Raises
    ------
    ModelError
        Missing or unreadable file, unknown robot, or package not installed.
    """
    from ..models import load_robot

    return load_robot(source)


#: A configuration away from singularities for the arms of example-robot-data (rad, m).
READY_POSES = {
    "panda": [0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4, 0.02,
              0.02],
}


def ready_pose(source: str | Path) -> list[float] | None:
    """The :data:`READY_POSES` entry of a robot of example-robot-data under any spelling
    (``"erd:panda"``, ``"example-robot-data:panda"``,
    ``"erd:panda_description/urdf/panda.urdf"``: the same file), else ``None``."""
    from ..models.robot_data import example_robot_file, is_example_robot

    if not is_example_robot(str(source)):
        return None
    path = example_robot_file(str(source)).resolve()
    for name, pose in READY_POSES.items():
        if example_robot_file(f"erd:{name}").resolve() == path:
            return list(pose)
    return None


def _arm(model, q, *, batch: bool = False):
    """(ConstraintSet of the model's coupling rows, checked q) from a ``MultibodyModel``, a
    robot file (:func:`load_arm`) or a ``pinocchio.Model`` (which carries no couplings:
    every joint is independent). ``q`` is (nq,), or (..., nq) with ``batch``."""
    import pinocchio as pin

    from ..models import MultibodyModel
    from ..models.constraints import LoopClosure
    from ..models.joints import check_configuration
    from ..models.kinematics import ConstraintSet

    if isinstance(model, (str, os.PathLike)):
        model = load_arm(model)
    elif isinstance(model, pin.Model):
        model = MultibodyModel(model, name=model.name)
    elif not isinstance(model, MultibodyModel):
        raise InputError("model must be a MultibodyModel (load_arm, load_robot), a robot "
                         "file (URDF/MJCF path, erd:<name>) or a pinocchio.Model, got "
                         f"{type(model).__name__}")
    held = [] if model.loop_closure is None else [LoopClosure(tuple(model.loop_names))]
    cs = ConstraintSet(model, held)
    nq = model.model.nq
    q = as_array(q, "q", min_ndim=1)
    if q.shape[-1:] != (nq,) or (q.ndim != 1 and not batch):
        two = _two_numbers(model)
        shape = f"({nq},)" + (f" or (..., {nq}) for a batch" if batch else "")
        raise InputError(f"q must have shape {shape} for this model{f' ({two})' if two else ''}"
                         f", got {q.shape}")
    check_configuration(model.model, q)  # NaN, a (cos, sin) pair or quaternion not unit
    check_joint_limits(model, q)
    if model.loop_closure is not None:  # a mimic joint at its leader's value, loops closed
        from ..scenario.build import check_loop_closed

        for qi in q.reshape(-1, nq):
            check_loop_closed(model, *model.loop_closure(qi))
    return cs, q


#: Pinocchio's "no limit" (the largest double, a joint added without limits); inf too.
_NO_LIMIT = 1e300

#: The singular rule of :func:`point_effective_mass` and :func:`arm_effective_masses`:
#: a point cannot move along u (``m_u = inf``) when |u^T J_p| <= SINGULAR_RTOL |J_p|.
#: Rounding of J_p is ~1e-16 |J_p|, so only a singular configuration itself (to rounding)
#: is inf; near one m_u ~ 1/|u^T J_p|^2 stays finite and exact (the planar 2-link arm at
#: q2 = 1e-7 rad from stretched: m1/sin^2 q2 + m2 = 2e14 kg, tests/test_safety.py).
SINGULAR_RTOL = 1e-10


def check_joint_limits(mbm, q, what: str = "q", hint: str | None = None) -> None:
    """Refuse ``q`` (..., nq) outside the position limits of a revolute or prismatic joint
    (the URDF's ``<limit lower upper>``; joints without limits, or with ``lower >= upper``,
    are not checked): a configuration in degrees read as radians is the usual cause.
    ``what`` names ``q`` in the message, ``hint`` (default: the one about degrees) ends
    it."""
    from ..models.joints import joint_coordinate

    model = mbm.model
    lo, hi = np.asarray(model.lowerPositionLimit), np.asarray(model.upperPositionLimit)
    flat = q.reshape(-1, model.nq)
    for name in model.names[1:]:
        jc = joint_coordinate(mbm, name)
        if jc.kind not in ("revolute", "prismatic") or jc.nq != 1:
            continue
        i = jc.idx_q
        if not (-_NO_LIMIT < lo[i] < hi[i] < _NO_LIMIT):  # none, or lower >= upper
            continue
        tol = 1e-9 * max(1.0, abs(lo[i]), abs(hi[i]))
        bad = (lo[i] - flat[:, i] > tol) | (flat[:, i] - hi[i] > tol)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            where = f" (configuration {k})" if q.ndim > 1 else ""
            unit = "rad" if jc.kind == "revolute" else "m"
            if hint is None:
                hint = ("; angles are in radians: for degrees use numpy.radians, or --deg "
                        "on the command line" if jc.kind == "revolute" else "")
            raise InputError(f"{what}{where}: joint {name!r} = {flat[k, i]:g} {unit} is outside "
                             f"its limits [{lo[i]:g}, {hi[i]:g}] {unit}{hint}")


def _two_numbers(mbm) -> str:
    """``"a continuous joint takes two numbers, cos theta and sin theta: 'a', 'b'"``, or
    ``""`` for a model without continuous joints."""
    from ..models.joints import joint_coordinate

    cont = [repr(nm) for nm in mbm.model.names[1:]
            if joint_coordinate(mbm, nm).kind == "continuous"]
    if not cont:
        return ""
    return f"a continuous joint takes two numbers, cos theta and sin theta: {', '.join(cont)}"


def arm_configuration(model, values, *, deg: bool = False) -> np.ndarray:
    """The configuration ``q`` (nq,) of a list of numbers, as ``safety arm --q`` reads it.

    Parameters
    ----------
    model : MultibodyModel
    values : sequence of float
        Either Pinocchio's ``nq`` coordinates (a continuous joint takes two, cos theta and
        sin theta), or, when the model has 1-DoF joints only and the count differs from
        ``nq``, one value per joint in the model's order [rad or m; continuous joints by
        angle], set by name as ``[configuration.joints]`` of a scenario sets them (a mimic
        joint's value must agree with its leader's).
    deg : bool, optional
        The values are one per joint, the angles of revolute and continuous joints in
        degrees (prismatic joints stay in m): ``safety arm --deg``.

    Raises
    ------
    InputError
        A count that is neither (with ``deg``: not one value per joint).
    """
    from ..models.joints import joint_coordinate
    from ..scenario.build import configuration
    from ..scenario.schema import ConfigurationSpec

    names = list(model.model.names[1:])
    values = as_array(values, "q", min_ndim=1)
    nq = model.model.nq
    kinds = [joint_coordinate(model, nm) for nm in names]
    one_dof = all(jc.one_dof for jc in kinds)
    if deg:
        if not (one_dof and values.shape == (len(names),)):
            what = (f"{len(names)} (one per joint: {', '.join(names)})" if one_dof else
                    "one value per joint, for an arm of 1-DoF joints only")
            raise InputError(f"q in degrees takes {what}, got {values.size} numbers")
        values = np.array([np.radians(x) if jc.kind in ("revolute", "continuous") else x
                           for jc, x in zip(kinds, values, strict=True)])
    elif values.shape == (nq,):
        return values
    per_joint = (len(names) != nq or deg) and one_dof
    if not (per_joint and values.shape == (len(names),)):
        alt = (f", or {len(names)} (one value per joint: {', '.join(names)}; continuous "
               "joints by angle)") if per_joint else ""
        two = _two_numbers(model)
        raise InputError(f"q must have {nq} numbers (Pinocchio's coordinates"
                         f"{f'; {two}' if two else ''}){alt}, got {values.size}")
    return configuration(model, ConfigurationSpec(
        joints={nm: float(x) for nm, x in zip(names, values, strict=True)}))


def _kinematics(cs, q):
    """``(data, M, B)``: joint Jacobians and frame placements at ``q``, M(q) (n, n) and the
    rows B (p, n) of the model's joint couplings and loops, held through the contact."""
    from ..models.constraints import mass_matrix

    cs.kinematics(q)
    return cs.data, mass_matrix(cs.mbm.model, cs.data, q), cs.rows(q)


def _jacobian(model, data, frame_id: int, p_frame: np.ndarray) -> np.ndarray:
    """J_p (3, nv), world axes, of the point ``p_frame`` given in frame ``frame_id``."""
    from ..models.constraints import point_jacobian

    return point_jacobian(model, data, frame_id, data.oMf[frame_id].rotation @ p_frame)


def _resolve_point(model, link: str, point):
    """(frame id, point in the frame) for a frame name and a point in that frame."""
    if not model.existFrame(link):
        names = [f.name for f in model.frames if f.type == _body_type()]
        raise ModelError(f"no frame {link!r} in model {model.name!r}; bodies: {names}")
    fid = model.getFrameId(link)
    if int(model.frames[fid].parentJoint) == 0:
        raise ModelError(f"frame {link!r} is fixed to the world: it cannot hit anything")
    p = np.zeros(3) if point is None else as_array(point, "point")
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise InputError(f"point must be 3 finite coordinates in frame {link!r}, got {p}")
    return fid, p


def _body_type():
    import pinocchio as pin

    return pin.FrameType.BODY


def _unit_directions(direction) -> tuple[np.ndarray, bool]:
    """Unit directions (k, 3) of ``direction`` (3,) or (k, 3), and whether it was one;
    one InputError for another shape, NaN, inf or a zero row."""
    u = as_array(direction, "direction", min_ndim=1)
    single = u.ndim == 1
    u = np.atleast_2d(u)
    if u.shape[-1] != 3 or u.ndim != 2:
        raise InputError(f"direction must have shape (3,) or (k, 3), got {u.shape}")
    if not np.all(np.isfinite(u)):
        raise InputError("direction must be finite and non-zero")
    big = np.max(np.abs(u), axis=1, initial=0.0)  # scaled first: |(0, 0, 1e300)| overflows
    if np.any(big == 0):
        raise InputError("direction must be finite and non-zero")
    u = u / big[:, None]
    return u / np.linalg.norm(u, axis=1)[:, None], single


def point_effective_mass(model, q, link: str, direction, *, point=None, payload: float = 0.0,
                         payload_frame: str | None = None, payload_point=None,
                         rtol: float = SINGULAR_RTOL):
    r"""Exact effective mass of a point of a link along one or many unit directions.

    .. math::  m_u = \frac{1}{u^T J_p(q) N(q) J_p(q)^T u}

    (:math:`N = M^{-1}` for independent joints; with the model's coupling rows :math:`B`
    held, see the module docstring) computed with :func:`roverimpact.energy.row_masses`
    (``m_eff`` with ``held=B``, as :func:`roverimpact.effective_mass`) on the rows
    :math:`a = u^T J_p`. A ``payload`` :math:`m_L` is a point mass at the payload point
    :math:`L` (its Jacobian :math:`J_L`): :math:`M \to M + m_L J_L^T J_L`.

    Parameters
    ----------
    model : MultibodyModel, str, Path or pinocchio.Model
        Fixed-base arm (:func:`load_arm` or :func:`roverimpact.models.load_robot`), or a
        robot file or ``"erd:<name>"`` that :func:`load_arm` loads. A bare
        ``pinocchio.Model`` carries no couplings: a ``<mimic>`` joint would move on its
        own.
    q : (nq,) or (..., nq) array_like
        Configuration [rad, m], or a batch of them: Pinocchio evaluates ``M`` and ``J_p``
        per configuration, the masses of the whole batch are one call of
        :func:`~roverimpact.energy.row_masses`. A value outside the limits of a revolute
        or prismatic joint (the URDF's ``<limit>``) is refused: angles given in degrees
        are the usual cause.
    link : str
        Name of a Pinocchio frame (a link/body or any frame fixed to one).
    direction : (3,) or (k, 3) array_like
        Contact direction(s) in world axes; normalised here. The same directions at every
        configuration of a batch.
    point : (3,) array_like, optional
        Contact point in the frame's coordinates [m]; default the frame origin.
    payload : float, optional
        Payload mass :math:`m_L` [kg] (tool and workpiece, the :math:`m_L` of the
        standard's :math:`M/2 + m_L`), added to the model as a point mass; default 0.
    payload_frame : str, optional
        Frame the payload is fixed to; default ``link``.
    payload_point : (3,) array_like, optional
        Payload's centre of mass in ``payload_frame`` coordinates [m]; default ``point``
        when ``payload_frame`` is not given, else that frame's origin.
    rtol : float, optional
        A row with :math:`|u^T J_p| \le` ``rtol`` :math:`|J_p|` (Frobenius norm) means the
        point cannot move along ``u``; its effective mass is ``inf``. The default
        :data:`SINGULAR_RTOL` is the rule of :func:`arm_effective_masses`' ``m_max``.

    Returns
    -------
    m_u : float, (k,), (...) or (..., k) ndarray
        [kg]; ``inf`` where the point cannot move along the direction (a singular
        configuration along ``u``). The batch axes of ``q`` come first, then ``k`` for a
        (k, 3) ``direction``.
    """
    rtol = check_rtol(rtol)
    cs, q = _arm(model, q, batch=True)
    model = cs.mbm.model
    u, single = _unit_directions(direction)
    fid, p = _resolve_point(model, link, point)
    payload = _check_payload(payload)
    if payload_frame is None:
        fid_L, p_L = fid, (p if payload_point is None else
                           _resolve_point(model, link, payload_point)[1])
    else:
        fid_L, p_L = _resolve_point(model, payload_frame, payload_point)
    batch = q.shape[:-1]
    Ms, As, Bs, Jps = [], [], [], []
    for qi in q.reshape(-1, model.nq):
        data, M, B = _kinematics(cs, qi)
        if payload:
            J_L = _jacobian(model, data, fid_L, p_L)
            M = M + payload * (J_L.T @ J_L)
        Jp = _jacobian(model, data, fid, p)
        Ms.append(M)
        As.append(u @ Jp)  # (k, nv)
        Bs.append(B)
        Jps.append(Jp)
    out = _masses_along(np.array(Ms), np.array(As), np.array(Bs), np.array(Jps), rtol)
    out = out.reshape((*batch, len(u)))
    if single:
        out = out[..., 0]
    return float(out) if out.ndim == 0 else out


def _masses_along(M, A, B, Jp, rtol: float = SINGULAR_RTOL) -> np.ndarray:
    """m_u (b, k) [kg] of the rows A (b, k, nv) = u^T J_p, held rows B (b, p, nv): the one
    place of the singular rule, ``inf`` where :math:`|u^T J_p| \\le` ``rtol``
    :math:`|J_p|` (Frobenius norm of J_p (b, 3, nv)), else
    :func:`~roverimpact.energy.row_masses`."""
    scale = np.maximum(np.linalg.norm(Jp, axis=(-2, -1)), 1e-300)
    moving = np.linalg.norm(A, axis=-1) > rtol * scale[:, None]
    out = np.full(moving.shape, np.inf)
    if moving.any():
        bi, ki = np.nonzero(moving)
        out[bi, ki] = row_masses(M[bi], A[bi, ki], B[bi] if B.shape[1] else None)[0]
    return out


def _check_payload(payload) -> float:
    """A payload mass [kg]: one finite number >= 0, or one InputError."""
    x = as_array(payload, "payload")
    if x.ndim != 0 or not (np.isfinite(x) and x >= 0):
        raise InputError(f"payload must be one finite number >= 0 kg, got {payload!r}")
    return float(x)


def _link_points(model, which: str):
    """(label, joint id, frame id, point in that frame) for every moving body of the tree.

    The frame is the body's (first ``BODY`` frame on the joint), else any frame on the
    joint; the point is the body's centre of mass (``"com"``) or the joint origin.
    """
    out = []
    for jid in range(1, model.njoints):
        on_joint = [i for i, f in enumerate(model.frames) if f.parentJoint == jid]
        body = [i for i in on_joint if model.frames[i].type == _body_type()]
        if not on_joint:
            raise ModelError(f"joint {model.names[jid]!r} has no frame: add one "
                             "(model.addJointFrame) to place its points")
        fid = (body or on_joint)[0]
        label = model.frames[fid].name if body else model.names[jid]
        p_joint = np.array(model.inertias[jid].lever) if which == "com" else np.zeros(3)
        out.append((label, jid, fid, np.asarray(model.frames[fid].placement.actInv(p_joint))))
    return out


def arm_effective_masses(model, q, *, payload: float = 0.0, points: str = "com",
                         region: str | BodyRegion = "hands_fingers"):
    r"""Compare the standard's :math:`m_R = M/2 + m_L` with the exact effective mass per link.

    For every moving body i (the body of joint i, with the fixed links merged into it by
    Pinocchio) at the point ``points`` (``"com"``: its centre of mass; ``"origin"``: the
    joint origin), the exact effective mass over all unit directions u ranges between

    .. math::  m_{min} = 1/\lambda_{max}(G),\quad m_{max} = 1/\lambda_{min}(G),\quad
        G = J_p N J_p^T \;(3\times3)

    (:math:`N` as in :func:`point_effective_mass`: :math:`M^{-1}` with the model's coupling
    rows held). ``m_max`` is :func:`point_effective_mass` along the eigenvector of
    :math:`\lambda_{min}(G)`, by its rule: ``inf`` where :math:`|u^T J_p| \le`
    :data:`SINGULAR_RTOL` :math:`|J_p|` (the point cannot move along u; a singular
    configuration), else finite and computed from the row :math:`u^T J_p` (not
    :math:`1/\lambda_{min}`, which loses digits as G is formed near a singularity). The table also
    gives the ISO speed limit for ``region`` with the standard's crude mass and with the
    exact lightest / heaviest direction.

    Parameters
    ----------
    model : MultibodyModel, str, Path or pinocchio.Model
        Fixed-base arm, as in :func:`point_effective_mass`; ``M`` of the standard is the
        summed mass of its moving bodies.
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
        ``v_exact_best`` (for m_min) [m/s]; the speeds are NaN for a region where the
        standard permits no transient contact (skull/forehead, face).
    """
    import pandas as pd

    if points not in ("com", "origin"):
        raise InputError(f"points must be 'com' or 'origin', got {points!r}")
    cs, q = _arm(model, q)
    model = cs.mbm.model
    reg = body_region(region)
    M_total = float(sum(model.inertias[j].mass for j in range(1, model.njoints)))
    m_iso = float(iso_robot_mass(M_total, payload))
    data, M, B = _kinematics(cs, q)
    # N = M^-1 - M^-1 B^T (B M^-1 B^T)^+ B M^-1 = (I - P_c) M^-1, P_c of the held rows B
    N = np.linalg.inv(M)
    if len(B):
        N = N - projector(M, B) @ N
    rows = []
    for body, jid, fid, p in _link_points(model, points):
        Jp = _jacobian(model, data, fid, p)
        G = Jp @ N @ Jp.T
        lam, V = np.linalg.eigh(0.5 * (G + G.T))
        lmax = lam[-1]
        if lmax <= 0:
            m_min = m_max = np.inf
        else:
            m_min = 1.0 / lmax
            # the row of the weakest direction, by point_effective_mass's rule and method
            # (1 / lam[0] of G formed near a singularity keeps ~|u^T J_p|^2 / eps digits)
            m_max = float(_masses_along(M[None], (V[:, 0] @ Jp)[None, None], B[None],
                                        Jp[None])[0, 0])
        rows.append({
            "link": body,
            "joint": model.names[jid],
            "m_R_iso": m_iso,
            "m_min": m_min,
            "m_max": m_max,
            "ratio_min": m_min / m_iso,
        })
    df = pd.DataFrame(rows)
    if reg.F_transient is None:  # no transient contact permitted (head): no speed
        df["v_iso"] = df["v_exact_worst"] = df["v_exact_best"] = np.nan
    else:
        df["v_iso"] = max_transient_speed(reg, m_iso)
        df["v_exact_worst"] = max_transient_speed(reg, df["m_max"].to_numpy())
        df["v_exact_best"] = max_transient_speed(reg, df["m_min"].to_numpy())
    df.attrs.update({"M_total": M_total, "payload": float(payload), "region": reg.name,
                     "q": q.tolist(), "points": points})
    return df


def point_speed_limits(model, q, link: str, direction, *, point=None, payload: float = 0.0,
                       payload_frame: str | None = None, payload_point=None,
                       region: str | BodyRegion = "chest"):
    r"""The exact effective mass of one point of an arm along each direction, with its
    ISO/TS 15066 transient-contact speed limit beside the standard's own (``roverimpact
    safety point``).

    Parameters
    ----------
    model, q, link, direction, point, payload, payload_frame, payload_point
        As in :func:`point_effective_mass` (``q`` one configuration; ``direction`` (k, 3)
        or (3,), world axes, normalised here).
    region : str or BodyRegion
        Body region of the speed limits.

    Returns
    -------
    pandas.DataFrame
        One row per direction: ``ux``, ``uy``, ``uz`` (unit), ``m_u`` [kg] (exact, with the
        payload as a point mass; ``inf`` where the point cannot move along u), ``v_max``
        [m/s] (for ``m_u``), ``m_R_iso`` = M/2 + m_L [kg] and ``v_iso`` [m/s] (the
        standard's); the speeds are NaN for a region where the standard permits no
        transient contact. ``attrs``: ``M_total`` (moving mass [kg]), ``q``, ``region``.
    """
    import pandas as pd

    cs, q = _arm(model, q)
    reg = body_region(region)
    U = _unit_directions(direction)[0]
    m_u = np.atleast_1d(point_effective_mass(cs.mbm, q, link, direction, point=point,
                                             payload=payload, payload_frame=payload_frame,
                                             payload_point=payload_point))
    mdl = cs.mbm.model
    M_total = float(sum(mdl.inertias[j].mass for j in range(1, mdl.njoints)))
    m_iso = float(iso_robot_mass(M_total, payload))
    ok = reg.F_transient is not None
    df = pd.DataFrame({"ux": U[:, 0], "uy": U[:, 1], "uz": U[:, 2], "m_u": m_u,
                       "v_max": max_transient_speed(reg, m_u) if ok else np.nan,
                       "m_R_iso": m_iso,
                       "v_iso": float(max_transient_speed(reg, m_iso)) if ok else np.nan})
    df.attrs.update(M_total=M_total, q=q, region=reg.name)
    return df
