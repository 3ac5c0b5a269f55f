r"""Write a built-in rover (a Pinocchio tree of 1-DoF revolute and prismatic joints;
continuous joints are refused) as a MuJoCo MJCF file.

:func:`export_mjcf` is the MJCF sibling of :func:`~roverimpact.models.robot.export_urdf`:
the same bodies, inertias and joints, plus what MuJoCo needs to simulate the rover:

* **Bodies**: one ``<body>`` per Pinocchio joint, at the joint placement, carrying the
  joint's inertia (``<inertial>`` with the full tensor; ``inertiafromgeom="false"`` so
  geoms add no mass). The joint sits at the body origin, as in the builders.
* **Massless links**: MuJoCo rejects moving bodies without mass ("mass and inertia of
  moving bodies must be larger than mjMINVAL"), which is why its URDF import fails on the
  planar rover's base (``base_x``, ``base_z`` links of zero mass). A massless body with a
  single child is merged into the child: MuJoCo applies the joints of one body in order,
  each about its axis/anchor in the body frame as moved by the previous ones, so a chain
  :math:`P_1 X_1(q_1) P_2 X_2(q_2) \cdots P_k X_k(q_k)` (placements :math:`P_i`, joint
  motions :math:`X_i`) is one body at :math:`B = P_1\cdots P_k` with joints
  :math:`X_i' = G_i^{-1} X_i G_i`, :math:`G_i = P_{i+1}\cdots P_k`: axis
  :math:`R_{G_i}^T a_i` through the anchor :math:`G_i^{-1}(0)`. The planar base becomes
  slide x, slide z, hinge y in the chassis body.
* **Free-flyer root**: a ``<freejoint>``. MuJoCo's free-joint velocity is (linear
  velocity of the body origin in *world* axes, angular velocity in body axes), Pinocchio's
  is (linear, angular) both in body axes: :func:`mujoco_velocity` converts.
* **Wheels**: a ``sphere`` geom of the wheel radius at the wheel frame. The own simulator
  (:mod:`roverimpact.simulate`) treats every wheel as a sphere touching planes at
  ``centre - r n``; a MuJoCo ``cylinder`` lying on a plane gives up to four rim contacts
  (each with the full contact stiffness) instead of one, so the sphere is the geometry
  that reproduces the own simulator's single contact point and normal.
* **Loop closures** (:class:`~roverimpact.models._build.LinearLoopClosure`, e.g. the
  rocker-bogie differential ``q_rocker_left + q_rocker_right = 0``): one ``<fixed>``
  tendon per row with the row's coefficients, and an ``<equality><tendon>`` holding its
  length at 0 (``polycoef = 0``), i.e. :math:`\sum_i C_{ki} q_i = 0` exactly as
  ``mbm.loop_closure``.
* **Rotor inertia** (``model.armature``, an MJCF model's joint ``armature``): the joint's
  ``armature`` (one value per joint, as MuJoCo has it).
* **Joint springs/dampers** (``springs``: ``{joint: JointSpring or dict(k, c, q0)}``, as
  :class:`~roverimpact.simulate.SimulationConfig.springs`): ``stiffness``, ``damping``,
  ``springref`` of the MJCF joint, :math:`\tau = -k(q - q_0) - c\dot q`.

Joint coordinates: hinge/slide ``qpos`` equal Pinocchio's ``q`` (``ref = 0``); the
free joint's quaternion is (w, x, y, z) in MuJoCo and (x, y, z, w) in Pinocchio
(:func:`mujoco_qpos`). ``tests/test_engine_mujoco.py`` checks ``mj_fullM`` of the exported
file against Pinocchio's ``M(q)`` at random configurations.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from .._io import check_writable
from ..exceptions import ModelError
from ._build import LinearLoopClosure
from .base import MultibodyModel
from .robot import fmt_floats, joint_armature, link_name

__all__ = ["MjcfLayout", "export_mjcf", "mjcf_element", "mujoco_qpos", "mujoco_velocity",
           "pinocchio_state"]

#: MJCF geom name of a wheel.
WHEEL_GEOM = "wheel_geom_{}"


@dataclass
class MjcfLayout:
    """How the exported MJCF maps onto the Pinocchio model.

    Attributes
    ----------
    joints : list of (name, kind)
        Pinocchio joints (``model.names[1:]``) with their MJCF kind (``"free"``,
        ``"slide"``, ``"hinge"``); MJCF joints have the same names.
    wheel_geoms : dict
        Wheel name -> MJCF geom name.
    wheel_bodies : dict
        Wheel name -> MJCF body name the wheel geom is attached to.
    loop_tendons : list of str
        Fixed-tendon names of the loop-closure rows (one equality each).
    free_joint : str or None
        Name of the free-flyer root joint, if any.
    """

    joints: list = field(default_factory=list)
    wheel_geoms: dict = field(default_factory=dict)
    wheel_bodies: dict = field(default_factory=dict)
    loop_tendons: list = field(default_factory=list)
    free_joint: str | None = None


def _joint_kind(model, j: int) -> tuple[str, np.ndarray | None]:
    """(MJCF joint type, axis in the joint frame) of Pinocchio joint ``j``: its kind
    (:func:`~roverimpact.models.joints.joint_coordinate`) and axis
    (:func:`~roverimpact.models.declare.joint_axis`), as :func:`.robot.export_urdf` reads
    them."""
    from .declare import joint_axis
    from .joints import joint_coordinate

    if model.joints[j].shortname() == "JointModelFreeFlyer":
        return "free", None
    kind = joint_coordinate(model, model.names[j]).kind
    axis = joint_axis(model, j)
    if kind in ("revolute", "prismatic") and axis is not None:
        return ("hinge" if kind == "revolute" else "slide"), axis / np.linalg.norm(axis)
    raise ModelError(f"export_mjcf: joint {model.names[j]!r} of type "
                     f"{model.joints[j].shortname()} is not supported (only prismatic/"
                     "revolute 1-DoF joints and a free-flyer root)")


def _massless(model, j: int) -> bool:
    I = model.inertias[j]
    return I.mass == 0.0 and not np.any(I.inertia)


def _reference_q(mbm: MultibodyModel) -> np.ndarray:
    q0 = getattr(mbm, "q0", None)
    if q0 is None:
        q0 = (mbm.params or {}).get("q_nominal")
    return pin.neutral(mbm.model) if q0 is None else np.asarray(q0, dtype=float)


def _spring_values(sp) -> tuple[float, float, float | None]:
    if isinstance(sp, dict):
        return float(sp.get("k", 0.0)), float(sp.get("c", 0.0)), sp.get("q0")
    return float(sp.k), float(sp.c), sp.q0


def mjcf_element(mbm: MultibodyModel, *, springs: dict | None = None,
                 loop_solref=None, loop_solimp=None) -> tuple[ET.Element, MjcfLayout]:
    """The ``<mujoco>`` element of :func:`export_mjcf` and the joint/wheel layout.

    The caller may add ``<option>``, world geoms and ``<contact>`` pairs before compiling
    (the MuJoCo engine of :mod:`roverimpact.simulate.engines` does).

    Raises
    ------
    ModelError
        No wheels, an unsupported joint, a massless body that cannot be merged, a body
        with mass but no rotational inertia, a wheel on a merged massless link, a spring on
        an unknown or multi-DoF joint, or a loop closure that is not linear.
    """
    model = mbm.model
    if not mbm.wheels:
        raise ModelError(f"export_mjcf: model {mbm.name!r} has no wheels (nothing would "
                         "touch the ground or the obstacle)")
    springs = dict(springs or {})
    q_ref = _reference_q(mbm)
    for name in springs:
        if not model.existJointName(name):
            raise ModelError(f"export_mjcf: spring on unknown joint {name!r}; joints: "
                             f"{list(model.names[1:])}")
        if model.joints[model.getJointId(name)].nv != 1:
            raise ModelError(f"export_mjcf: spring on joint {name!r}: only 1-DoF joints "
                             "take springs")

    root = ET.Element("mujoco", model=mbm.name)
    ET.SubElement(root, "compiler", angle="radian", inertiafromgeom="false",
                  autolimits="true", balanceinertia="false")
    world = ET.SubElement(root, "worldbody")
    layout = MjcfLayout()
    children: dict[int, list[int]] = {j: [] for j in range(model.njoints)}
    for j in range(1, model.njoints):
        children[model.parents[j]].append(j)
    wheel_frames = {}
    for w in mbm.wheels:
        if not model.existFrame(w.frame):
            raise ModelError(f"export_mjcf: wheel {w.name!r} names unknown frame {w.frame!r}")
        f = model.frames[model.getFrameId(w.frame)]
        wheel_frames.setdefault(int(f.parentJoint), []).append((w, f.placement))
    merged: set[int] = set()

    def armature(j) -> dict:
        """``{"armature": ...}`` of joint ``j`` (rotor inertia, on M's diagonal), if any."""
        arm = joint_armature(model, j)
        if not np.any(arm != 0.0):
            return {}
        if np.any(arm != arm[0]):
            raise ModelError(f"export_mjcf: the armature of joint {model.names[j]!r} differs "
                             f"between its DoFs ({arm.tolist()}); MuJoCo has one per joint")
        return {"armature": fmt_floats(arm[0])}

    def add_joint(body_el, j, kind, axis, anchor):
        name = model.names[j]
        layout.joints.append((name, kind))
        if kind == "free":
            layout.free_joint = name
            arm = armature(j)
            if arm:
                ET.SubElement(body_el, "joint", name=name, type="free", **arm)
            else:
                ET.SubElement(body_el, "freejoint", name=name)
            return
        attrs = {"name": name, "type": kind, "axis": fmt_floats(axis), "pos": fmt_floats(anchor)}
        attrs.update(armature(j))
        if name in springs:
            k, c, q0 = _spring_values(springs[name])
            jm = model.joints[j]
            attrs.update(stiffness=fmt_floats(k), damping=fmt_floats(c),
                         springref=fmt_floats(q_ref[jm.idx_q] if q0 is None else q0))
        ET.SubElement(body_el, "joint", **attrs)

    def build(parent_el, j):
        # collect the chain of massless single-child joints ending at a body with mass
        chain = [j]
        while _massless(model, chain[-1]):
            kids = children[chain[-1]]
            if len(kids) != 1:
                raise ModelError(
                    f"export_mjcf: body of joint {model.names[chain[-1]]!r} has no mass and "
                    f"{len(kids)} child joints: MuJoCo needs mass on every moving body and "
                    "only a massless link with exactly one child can be merged into it")
            if chain[-1] in wheel_frames:
                raise ModelError(f"export_mjcf: a wheel is attached to the massless link of "
                                 f"joint {model.names[chain[-1]]!r}, which is merged away")
            chain.append(kids[0])
        jb = chain[-1]
        merged.update(chain[:-1])
        placements = [model.jointPlacements[i] for i in chain]
        B = pin.SE3.Identity()
        for P in placements:
            B = B * P
        body = ET.SubElement(parent_el, "body", name=link_name(model, jb),
                             pos=fmt_floats(B.translation),
                             quat=fmt_floats(pin.Quaternion(B.rotation).coeffs()[[3, 0, 1, 2]]))
        I = model.inertias[jb]
        Ic = I.inertia
        if I.mass <= 0.0 or np.linalg.eigvalsh(Ic).min() <= 0.0:
            raise ModelError(
                f"export_mjcf: body of joint {model.names[jb]!r} has mass {I.mass:g} kg and "
                f"inertia eigenvalues {np.linalg.eigvalsh(Ic)}: MuJoCo needs positive mass "
                "and rotational inertia on every moving body")
        ET.SubElement(body, "inertial", pos=fmt_floats(I.lever), mass=fmt_floats(I.mass),
                      fullinertia=fmt_floats([Ic[0, 0], Ic[1, 1], Ic[2, 2], Ic[0, 1], Ic[0, 2],
                                        Ic[1, 2]]))
        for i, ji in enumerate(chain):
            kind, axis = _joint_kind(model, ji)
            if kind == "free" and (len(chain) > 1 or model.parents[ji] != 0):
                raise ModelError("export_mjcf: a free-flyer joint must be the root joint and "
                                 "carry a body with mass")
            G = pin.SE3.Identity()
            for P in placements[i + 1:]:
                G = G * P
            if kind == "free":
                add_joint(body, ji, kind, None, None)
            else:
                Ginv = G.inverse()
                add_joint(body, ji, kind, G.rotation.T @ axis, Ginv.translation)
        for w, plc in wheel_frames.get(jb, []):
            name = WHEEL_GEOM.format(w.name)
            layout.wheel_geoms[w.name] = name
            layout.wheel_bodies[w.name] = body.get("name")
            ET.SubElement(body, "geom", name=name, type="sphere", size=fmt_floats(w.radius),
                          pos=fmt_floats(plc.translation), rgba="0.2 0.2 0.2 1")
        for c in children[jb]:
            build(body, c)

    for j in children[0]:
        build(world, j)
    if wheel_frames.get(0):
        raise ModelError("export_mjcf: a wheel is attached to the world (universe) frame")

    if mbm.loop_closure is not None:
        lc = mbm.loop_closure
        if not isinstance(lc, LinearLoopClosure):
            raise ModelError("export_mjcf: only linear loop closures (LinearLoopClosure) can be "
                             "written as MJCF equality constraints")
        names = list(mbm.loop_names) or [str(i) for i in range(len(lc.coefficients))]
        tendon = ET.SubElement(root, "tendon")
        equality = ET.SubElement(root, "equality")
        for name, row in zip(names, lc.coefficients, strict=True):
            tname = f"loop_{name}"
            fixed = ET.SubElement(tendon, "fixed", name=tname)
            for jn, coef in zip(lc.joints, row, strict=True):
                if coef != 0.0:
                    ET.SubElement(fixed, "joint", joint=jn, coef=fmt_floats(coef))
            attrs = {"name": tname, "tendon1": tname, "polycoef": "0 0 0 0 0"}
            if loop_solref is not None:
                attrs["solref"] = fmt_floats(loop_solref)
            if loop_solimp is not None:
                attrs["solimp"] = fmt_floats(loop_solimp)
            ET.SubElement(equality, "tendon", **attrs)
            layout.loop_tendons.append(tname)
    return root, layout


def export_mjcf(mbm: MultibodyModel, path: str | Path, *, springs: dict | None = None) -> Path:
    """Write a built-in rover as a MuJoCo MJCF file (see the module docstring).

    Parameters
    ----------
    mbm : MultibodyModel
        A tree of prismatic/revolute joints with an optional free-flyer root, wheels, and
        an optional linear loop closure (``rover2d``, ``rocker_bogie``).
    path : str or Path
        Output ``.xml`` file.
    springs : dict, optional
        ``{joint: JointSpring or {"k", "c", "q0"}}``: joint springs/dampers written as the
        MJCF joint's ``stiffness``, ``damping``, ``springref`` (q0 defaults to the model's
        reference configuration, as in the own simulator).

    Returns
    -------
    Path
        The written file; ``mujoco.MjModel.from_xml_path(path)`` loads it.

    Raises
    ------
    ModelError
        See :func:`mjcf_element`.
    ConfigError
        If ``path`` cannot be written (a missing folder, a folder, no permission).

    Examples
    --------
    >>> import tempfile, mujoco
    >>> from roverimpact.models import rover2d
    >>> from roverimpact.models.export_mjcf import export_mjcf
    >>> with tempfile.TemporaryDirectory() as d:
    ...     m = mujoco.MjModel.from_xml_path(str(export_mjcf(rover2d(), d + "/r.xml")))
    >>> m.nv, m.nbody   # world + chassis + 2 wheels: the base_x/base_z links are merged
    (5, 4)
    """
    path = check_writable(path, folder=False, option=None)
    root, _ = mjcf_element(mbm, springs=springs)
    ET.indent(root)
    path.write_text(ET.tostring(root, encoding="unicode") + "\n")
    return path


# ---------------------------------------------------------------------- state conversion
def _free_rotation(q_free) -> np.ndarray:
    return pin.Quaternion(np.asarray(q_free[3:7], float)).normalized().toRotationMatrix()


def mujoco_qpos(model, layout: MjcfLayout, mj_model, q) -> np.ndarray:
    """MuJoCo ``qpos`` of the Pinocchio configuration ``q`` (nq,)."""
    q = np.asarray(q, dtype=float)
    qpos = np.zeros(mj_model.nq)
    import mujoco

    for name, kind in layout.joints:
        jm = model.joints[model.getJointId(name)]
        adr = mj_model.jnt_qposadr[mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_JOINT, name)]
        if kind == "free":
            qf = q[jm.idx_q: jm.idx_q + 7]
            qpos[adr: adr + 3] = qf[:3]
            qpos[adr + 3: adr + 7] = qf[[6, 3, 4, 5]]
        else:
            qpos[adr] = q[jm.idx_q]
    return qpos


def mujoco_velocity(model, layout: MjcfLayout, mj_model, q, v) -> np.ndarray:
    """MuJoCo ``qvel`` of the Pinocchio velocity ``v`` (nv,) at ``q``.

    Free joint: :math:`\\dot p_{world} = R\\,v_{lin}` (Pinocchio's linear velocity is in body
    axes), angular velocity unchanged (body axes in both).
    """
    q, v = np.asarray(q, dtype=float), np.asarray(v, dtype=float)
    qvel = np.zeros(mj_model.nv)
    import mujoco

    for name, kind in layout.joints:
        jm = model.joints[model.getJointId(name)]
        adr = mj_model.jnt_dofadr[mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_JOINT, name)]
        if kind == "free":
            R = _free_rotation(q[jm.idx_q: jm.idx_q + 7])
            qvel[adr: adr + 3] = R @ v[jm.idx_v: jm.idx_v + 3]
            qvel[adr + 3: adr + 6] = v[jm.idx_v + 3: jm.idx_v + 6]
        else:
            qvel[adr] = v[jm.idx_v]
    return qvel


def pinocchio_state(model, layout: MjcfLayout, mj_model, qpos, qvel):
    """Pinocchio ``(q, v)`` of MuJoCo ``(qpos, qvel)``; leading batch axes allowed.

    Returns
    -------
    q : (..., nq) ndarray, v : (..., nv) ndarray
    """
    import mujoco

    qpos, qvel = np.asarray(qpos, dtype=float), np.asarray(qvel, dtype=float)
    q = np.zeros((*qpos.shape[:-1], model.nq))
    v = np.zeros((*qvel.shape[:-1], model.nv))
    for name, kind in layout.joints:
        jm = model.joints[model.getJointId(name)]
        jid = mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_JOINT, name)
        qa, va = mj_model.jnt_qposadr[jid], mj_model.jnt_dofadr[jid]
        if kind == "free":
            quat = qpos[..., qa + 3: qa + 7]                   # w, x, y, z
            quat = quat / np.linalg.norm(quat, axis=-1, keepdims=True)
            q[..., jm.idx_q: jm.idx_q + 3] = qpos[..., qa: qa + 3]
            q[..., jm.idx_q + 3: jm.idx_q + 7] = quat[..., [1, 2, 3, 0]]
            w, x, y, z = (quat[..., i] for i in range(4))
            R = np.stack([
                np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
                np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
                np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
            ], -2)
            v_world = qvel[..., va: va + 3]
            v[..., jm.idx_v: jm.idx_v + 3] = np.einsum("...ji,...j->...i", R, v_world)
            v[..., jm.idx_v + 3: jm.idx_v + 6] = qvel[..., va + 3: va + 6]
        else:
            q[..., jm.idx_q] = qpos[..., qa]
            v[..., jm.idx_v] = qvel[..., va]
    return q, v
