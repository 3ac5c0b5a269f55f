r"""MJCF robots as MuJoCo means them: the Pinocchio model is built from MuJoCo's compiled model.

Pinocchio's own MJCF parser (``pin.buildModelFromMJCF``) does not follow MuJoCo's
compiler: it drops the mass of geoms that do not collide (``contype = conaffinity = 0``,
the usual way to give a chassis its mass) and merges the joints of one body into a single
``JointModelComposite``. Here MuJoCo compiles the file (``mujoco.MjSpec.from_file(...)
.compile()``: defaults and classes, ``inertiafromgeom``, ``<inertial>``, every geom's
mass, ``fusestatic`` ...) and :func:`pinocchio_from_mujoco` copies the result:

* each body's mass, principal inertia and inertial frame (``body_mass``,
  ``body_inertia``, ``body_ipos``, ``body_iquat``) and its placement in the parent
  (``body_pos``, ``body_quat``);
* each joint as one Pinocchio joint with the MuJoCo name: ``hinge`` -> revolute (``RX``,
  ``RY``, ``RZ`` or ``RevoluteUnaligned``), ``slide`` -> prismatic, ``ball`` ->
  spherical, ``free`` -> free-flyer, anchored at ``jnt_pos`` with axis ``jnt_axis``;
  several joints in one body become a chain (massless intermediate bodies, the body's
  inertia on the last joint), in MuJoCo's order;
* bodies without joints are welded to their parent; ``dof_armature`` goes to
  ``model.armature``, a hinge's or slide's ``range`` (``jnt_range`` of a limited joint,
  radians) to ``model.lowerPositionLimit`` / ``upperPositionLimit``;
* frames: a BODY frame per body, a JOINT frame per joint, an OP_FRAME per site and per
  named geom. A joint, site or geom whose name is already a frame name gets the suffix
  ``_joint``, ``_site`` or ``_geom`` (Pinocchio needs unique frame names).
* equalities: joint and fixed-tendon equalities as linear couplings, ``connect`` and
  ``weld`` as point loops (:func:`attach_connect_loops`); nonlinear ones and those open
  at ``qpos0`` are ignored, with a warning.

Coordinates. For hinge and slide joints the Pinocchio coordinate equals MuJoCo's
``qpos`` (the joint's ``ref`` is built into the placements), so ``q = qpos`` and
``v = qvel`` joint by joint. Ball and free joints differ in layout only:

========  ===========================================  ================================
joint     MuJoCo ``qpos`` / ``qvel``                   Pinocchio ``q`` / ``v``
========  ===========================================  ================================
ball      ``qw qx qy qz`` / body-frame angular rate     ``qx qy qz qw`` / the same
free      ``x y z qw qx qy qz`` / world linear          ``x y z qx qy qz qw`` / body-frame
          velocity of the body origin, body-frame       linear velocity ``R^T v_world``,
          angular rate                                  angular rate
========  ===========================================  ================================

:func:`mujoco_state_to_pinocchio` and :func:`pinocchio_state_to_mujoco` convert in both
directions (URDF continuous joints, ``q = (cos, sin)``, included). The reference
configuration (``params["q_nominal"]``) is MuJoCo's ``qpos0``.

The model is checked at load: Pinocchio's ``M(q)`` (CRBA) must equal MuJoCo's
``mj_fullM`` at a generic configuration (:mod:`roverimpact.models.mujoco_check`).

``mujoco`` is imported inside the functions only: ``import roverimpact`` does not need it.
"""

from __future__ import annotations

import contextlib
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..exceptions import ModelError
from .base import MultibodyModel

__all__ = [
    "attach_connect_loops",
    "compile_mjcf",
    "load_mjcf",
    "mujoco_joint_map",
    "mujoco_state_to_pinocchio",
    "pinocchio_from_mujoco",
    "pinocchio_state_to_mujoco",
    "velocity_map",
]

#: MuJoCo joint types (``mjtJoint``) by value.
_MJ_JOINT = {0: "free", 1: "ball", 2: "slide", 3: "hinge"}
#: MuJoCo geom types (``mjtGeom``) by value.
_MJ_GEOM = {0: "plane", 1: "hfield", 2: "sphere", 3: "capsule", 4: "ellipsoid",
            5: "cylinder", 6: "box", 7: "mesh", 8: "sdf"}
_AXES = np.eye(3)


def _import_mujoco():
    try:
        import mujoco
    except ImportError as exc:  # pragma: no cover - mujoco is a base dependency
        raise ModelError(f"MJCF files need MuJoCo's compiler: pip install mujoco ({exc})") from None
    return mujoco


@contextlib.contextmanager
def mujoco_warnings(mujoco):
    """Collect MuJoCo's warnings in a list instead of its default ``MUJOCO_LOG.TXT`` in the
    current directory (the handler is process-wide: restored on exit)."""
    caught: list[str] = []
    prev = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda msg: caught.append(" ".join(str(msg).split())))
    try:
        yield caught
    finally:
        mujoco.set_mju_user_warning(prev)


def _se3(pos, quat_wxyz) -> pin.SE3:
    w, x, y, z = (float(c) for c in quat_wxyz)
    R = pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()
    return pin.SE3(R, np.asarray(pos, dtype=float).copy())


def _translation(p) -> pin.SE3:
    return pin.SE3(np.eye(3), np.asarray(p, dtype=float).copy())


def _axis_rotation(axis, angle: float) -> pin.SE3:
    return pin.SE3(pin.AngleAxis(float(angle), np.asarray(axis, dtype=float)).toRotationMatrix(),
                   np.zeros(3))


def _aligned(axis) -> int | None:
    """Index of the coordinate axis ``axis`` equals (+x, +y, +z), else ``None``."""
    for i in range(3):
        if np.allclose(axis, _AXES[i], rtol=0.0, atol=1e-12):
            return i
    return None


def _joint_model(kind: str, axis):
    if kind == "hinge":
        i = _aligned(axis)
        return (pin.JointModelRX(), pin.JointModelRY(), pin.JointModelRZ())[i] if i is not None \
            else pin.JointModelRevoluteUnaligned(np.asarray(axis, dtype=float))
    if kind == "slide":
        i = _aligned(axis)
        return (pin.JointModelPX(), pin.JointModelPY(), pin.JointModelPZ())[i] if i is not None \
            else pin.JointModelPrismaticUnaligned(np.asarray(axis, dtype=float))
    if kind == "ball":
        return pin.JointModelSpherical()
    return pin.JointModelFreeFlyer()


def _names(mujoco, m, obj, count: int) -> list[str]:
    out = []
    for i in range(count):
        nm = mujoco.mj_id2name(m, obj, i)
        out.append(nm or "")
    return out


def _unique(name: str, taken: set[str], suffix: str) -> str:
    if name not in taken:
        return name
    cand = f"{name}{suffix}"
    k = 2
    while cand in taken:
        cand = f"{name}{suffix}{k}"
        k += 1
    return cand


def pinocchio_from_mujoco(m, *, name: str | None = None) -> tuple[pin.Model, dict]:
    """Pinocchio model of a compiled MuJoCo model, body by body and joint by joint.

    Parameters
    ----------
    m : mujoco.MjModel
        Compiled model (its inertias are MuJoCo's: ``body_mass``, ``body_inertia``, ...).
    name : str, optional
        Model name (default: MuJoCo's model name).

    Returns
    -------
    model : pinocchio.Model
        One Pinocchio joint per MuJoCo joint (same name), frames per body, joint, site and
        named geom.
    info : dict
        JSON-ready description: ``"mujoco"`` (joint map for the state conversions, see
        :func:`mujoco_joint_map`), ``"q_nominal"`` (``qpos0`` as Pinocchio ``q``),
        ``"geoms"`` (one dict per geom: ``name``, ``body``, ``frame`` (``None`` if
        unnamed), ``type`` (``"cylinder"``, ...), ``size`` (MuJoCo's half-sizes: a
        cylinder is ``[radius, half-length, 0]`` along the geom's z axis), ``pos`` and
        ``quat`` (w x y z) in the body frame, ``contype``, ``conaffinity``), ``"sites"``
        (name -> frame name) and ``"bodies"`` (MuJoCo body name -> Pinocchio joint).

    Raises
    ------
    ModelError
        If a joint type is unknown to this converter.
    """
    import mujoco

    obj = mujoco.mjtObj
    body_names = _names(mujoco, m, obj.mjOBJ_BODY, m.nbody)
    joint_names = _names(mujoco, m, obj.mjOBJ_JOINT, m.njnt)
    geom_names = _names(mujoco, m, obj.mjOBJ_GEOM, m.ngeom)
    site_names = _names(mujoco, m, obj.mjOBJ_SITE, m.nsite)
    for b in range(1, m.nbody):
        if not body_names[b]:
            body_names[b] = f"body{b}"
    # joint names: MuJoCo's, unnamed ones after their body; unique among joints
    used: set[str] = {"universe"}
    for k in range(m.njnt):
        nm = joint_names[k] or f"{body_names[m.jnt_bodyid[k]]}_joint{k}"
        joint_names[k] = _unique(nm, used, "_")
        used.add(joint_names[k])
    if name is None:
        raw = bytes(m.names)
        name = raw[: raw.index(b"\0")].decode() if b"\0" in raw else ""
    model = pin.Model()
    model.name = name or "mjcf"
    frames_taken = {"universe"} | {body_names[b] for b in range(1, m.nbody)}
    body_joint = [0] * m.nbody          # Pinocchio joint carrying each body
    body_in_joint = [pin.SE3.Identity()] * m.nbody  # body frame in that joint's frame
    body_frame = [0] * m.nbody
    armature = []
    jmap = []
    for b in range(1, m.nbody):
        p = int(m.body_parentid[b])
        jid = body_joint[p]
        X = body_in_joint[p] * _se3(m.body_pos[b], m.body_quat[b])
        prev = body_frame[p]
        for k in range(int(m.body_jntadr[b]), int(m.body_jntadr[b] + m.body_jntnum[b])):
            kind = _MJ_JOINT.get(int(m.jnt_type[k]))
            if kind is None:  # pragma: no cover - MuJoCo has four joint types
                raise ModelError(f"joint {joint_names[k]!r}: unknown MuJoCo joint type "
                                 f"{int(m.jnt_type[k])}")
            qa, da = int(m.jnt_qposadr[k]), int(m.jnt_dofadr[k])
            axis, anchor = np.array(m.jnt_axis[k], dtype=float), np.array(m.jnt_pos[k], float)
            if kind == "free":
                # MuJoCo: the free body's pose is qpos itself (top-level bodies only)
                placement, after = pin.SE3.Identity(), pin.SE3.Identity()
            elif kind == "hinge":
                placement = X * _translation(anchor)
                after = _axis_rotation(axis, -m.qpos0[qa]) * _translation(-anchor)
            elif kind == "slide":
                placement = X * _translation(anchor)
                after = _translation(-axis * m.qpos0[qa]) * _translation(-anchor)
            else:  # ball: qpos0 is the identity rotation
                placement = X * _translation(anchor)
                after = _translation(-anchor)
            jid = model.addJoint(jid, _joint_model(kind, axis), placement, joint_names[k])
            jm = model.joints[jid]
            if kind in ("hinge", "slide") and bool(m.jnt_limited[k]):  # range: qpos limits
                model.lowerPositionLimit[jm.idx_q] = float(m.jnt_range[k][0])
                model.upperPositionLimit[jm.idx_q] = float(m.jnt_range[k][1])
            armature.append((jm.idx_v, np.asarray(m.dof_armature[da:da + jm.nv], dtype=float)))
            fname = _unique(joint_names[k], frames_taken, "_joint")
            frames_taken.add(fname)
            prev = model.addFrame(pin.Frame(fname, jid, prev, pin.SE3.Identity(),
                                            pin.FrameType.JOINT))
            jmap.append([joint_names[k], kind, qa, da])
            X = after
        body_joint[b] = jid
        body_in_joint[b] = X
        mass = float(m.body_mass[b])
        if mass > 0.0 or np.any(m.body_inertia[b] > 0.0):
            Y = pin.Inertia(mass, np.zeros(3), np.diag(np.asarray(m.body_inertia[b], float)))
            model.appendBodyToJoint(jid, Y, X * _se3(m.body_ipos[b], m.body_iquat[b]))
        body_frame[b] = model.addFrame(pin.Frame(body_names[b], jid, prev, X,
                                                 pin.FrameType.BODY))
    for idx_v, arm in armature:
        model.armature[idx_v:idx_v + arm.size] = arm
    # sites and geoms: operational frames at their pose
    sites = {}
    for s in range(m.nsite):
        if not site_names[s]:
            continue
        b = int(m.site_bodyid[s])
        fname = _unique(site_names[s], frames_taken, "_site")
        frames_taken.add(fname)
        model.addFrame(pin.Frame(fname, body_joint[b], body_frame[b],
                                 body_in_joint[b] * _se3(m.site_pos[s], m.site_quat[s]),
                                 pin.FrameType.OP_FRAME))
        sites[site_names[s]] = fname
    geoms = []
    for g in range(m.ngeom):
        b = int(m.geom_bodyid[g])
        fname = None
        if geom_names[g]:
            fname = _unique(geom_names[g], frames_taken, "_geom")
            frames_taken.add(fname)
            model.addFrame(pin.Frame(fname, body_joint[b], body_frame[b],
                                     body_in_joint[b] * _se3(m.geom_pos[g], m.geom_quat[g]),
                                     pin.FrameType.OP_FRAME))
        geoms.append({
            "name": geom_names[g] or None,
            "body": body_names[b] if b > 0 else "world",
            "frame": fname,
            "type": _MJ_GEOM.get(int(m.geom_type[g]), str(int(m.geom_type[g]))),
            "size": [float(x) for x in m.geom_size[g]],
            "pos": [float(x) for x in m.geom_pos[g]],
            "quat": [float(x) for x in m.geom_quat[g]],
            "contype": int(m.geom_contype[g]),
            "conaffinity": int(m.geom_conaffinity[g]),
        })
    mimic, couplings, ignored = _joint_equalities(mujoco, m, joint_names)
    connect, left_out = _connect_loops(mujoco, m, body_names, sites)
    ignored += left_out
    info = {
        "mujoco": {"nq": int(m.nq), "nv": int(m.nv), "joints": jmap,
                   "qpos0": [float(x) for x in m.qpos0]},
        "geoms": geoms,
        "sites": sites,
        "bodies": {body_names[b]: model.names[body_joint[b]] for b in range(1, m.nbody)},
    }
    if mimic:
        info["mimic"] = mimic
    if couplings:
        info["couplings"] = couplings
    if connect:
        info["connect"] = connect
    if ignored:
        info["mujoco_equalities_ignored"] = [nm for nm, _why in ignored]
        info["mujoco_equalities_ignored_why"] = [f"{nm!r} ({why})" for nm, why in ignored]
    q0, _ = state_to_pinocchio(model, info["mujoco"], np.asarray(m.qpos0, dtype=float), None)
    info["q_nominal"] = [float(x) for x in q0]
    return model, info


def _connect_loops(mujoco, m, body_names, sites) -> tuple[list[list], list]:
    """MuJoCo's active ``connect`` and ``weld`` equalities as point loops ``[name, frame_a,
    point_a, frame_b, point_b]`` (:class:`~roverimpact.models.declare.FrameLoop`, ``kind
    = "point"``), and ``(name, reason)`` of those left out.

    * connect between bodies: ``body1``'s ``anchor`` (``eq_data[0:3]``, body1 frame) and
      the same point in ``body2``'s frame at ``qpos0`` (``eq_data[3:6]``, as MuJoCo's
      compiler computes it; ``universe`` for the world); between sites: their origins.
    * weld between bodies (``torquescale > 0``): body2's pose in body1's frame is
      ``relpose`` (``eq_data[3:10]``); three points of body2 (its origin, and 1 m along its
      x and y axes) held at their places in body1 fix the relative pose (rank 6 of 9 rows).

    An equality that MuJoCo's compiler leaves open at ``qpos0`` (more than
    :data:`~roverimpact.models.declare.LOOP_GAP_TOL`: an explicit ``relpose`` or two sites
    apart), a weld between sites or with ``torquescale = 0`` is left out (the caller warns).
    """
    from .declare import LOOP_GAP_TOL

    out, ignored = [], []
    site_obj = int(mujoco.mjtObj.mjOBJ_SITE)
    connect, weld = int(mujoco.mjtEq.mjEQ_CONNECT), int(mujoco.mjtEq.mjEQ_WELD)
    d = mujoco.MjData(m)
    d.qpos[:] = m.qpos0
    mujoco.mj_kinematics(m, d)

    def world(kind: str, i: int, p) -> np.ndarray:
        pos, mat = (d.site_xpos[i], d.site_xmat[i]) if kind == "site" else (d.xpos[i],
                                                                           d.xmat[i])
        return pos + mat.reshape(3, 3) @ np.asarray(p, dtype=float)

    for e in range(m.neq):
        kind = int(m.eq_type[e])
        if not m.eq_active0[e] or kind not in (connect, weld):
            continue
        nm = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, e) or f"equality{e}"
        o1, o2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        data = np.asarray(m.eq_data[e], dtype=float)
        on_sites = int(m.eq_objtype[e]) == site_obj
        if kind == weld and (on_sites or not data[10] > 0.0):
            ignored.append((nm, "weld between sites" if on_sites else "weld, torquescale 0"))
            continue
        if on_sites:
            s1 = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SITE, o1)
            s2 = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SITE, o2)
            if s1 not in sites or s2 not in sites:
                ignored.append((nm, "connect between unnamed sites"))
                continue
            rows = [(nm, ("site", o1, sites[s1], np.zeros(3)),
                     ("site", o2, sites[s2], np.zeros(3)))]
        else:
            f1 = body_names[o1] if o1 > 0 else "universe"
            f2 = body_names[o2] if o2 > 0 else "universe"
            if kind == connect:
                rows = [(nm, ("body", o1, f1, data[:3]), ("body", o2, f2, data[3:6]))]
            else:  # body2's points at relpose in body1: R p + t
                R = np.zeros(9)
                mujoco.mju_quat2Mat(R, data[6:10] / np.linalg.norm(data[6:10]))
                R = R.reshape(3, 3)
                rows = [(f"{nm}:{tag}", ("body", o1, f1, R @ p + data[3:6]),
                         ("body", o2, f2, p))
                        for tag, p in (("o", np.zeros(3)), ("x", np.eye(3)[0]),
                                       ("y", np.eye(3)[1]))]
        gap = max(float(np.linalg.norm(world(a[0], a[1], a[3]) - world(b[0], b[1], b[3])))
                  for _n, a, b in rows)
        if gap > LOOP_GAP_TOL:
            ignored.append((nm, f"{'weld' if kind == weld else 'connect'} open by "
                                f"{gap:.3g} m at qpos0"))
            continue
        out += [[n, a[2], [float(x) for x in a[3]], b[2], [float(x) for x in b[3]]]
                for n, a, b in rows]
    return out, ignored


def _fixed_tendon(mujoco, m, t: int, joint_names) -> list[tuple[str, float]] | None:
    """``[(joint, coef), ...]`` of fixed tendon ``t`` (its length is ``sum coef qpos``), or
    ``None`` if it is spatial or runs over a joint that is not a hinge or a slide."""
    terms = []
    for w in range(int(m.tendon_adr[t]), int(m.tendon_adr[t] + m.tendon_num[t])):
        if int(m.wrap_type[w]) != int(mujoco.mjtWrap.mjWRAP_JOINT):
            return None
        j = int(m.wrap_objid[w])
        if _MJ_JOINT.get(int(m.jnt_type[j])) not in ("hinge", "slide"):
            return None
        terms.append((joint_names[j], float(m.wrap_prm[w])))
    return terms


def _joint_equalities(mujoco, m, joint_names):
    r"""MuJoCo's linear equalities as constraint rows; the others, by name, as ignored.

    Returns ``(mimic, couplings, ignored)``:

    * ``mimic``: joint equalities as couplings ``[joint, leader or None, a, b]``
      (``theta_1 = a theta_2 + b``). MuJoCo: ``theta_1 - ref_1 = c0 + c1 (theta_2 -
      ref_2)`` (refs: ``qpos0``), so ``a = c1``, ``b = ref_1 + c0 - c1 ref_2``; without
      ``joint2``, ``theta_1 = ref_1 + c0`` (MuJoCo then uses ``c0`` only).
    * ``couplings``: tendon equalities over fixed tendons as rows ``[label, joints,
      coefficients, offset]``, ``phi = sum_i C_i theta_i + offset = 0``, label
      ``"tendon:<equality>"``. A fixed tendon's length is ``L = sum_i coef_i qpos_i``, and
      MuJoCo holds ``L_1 - L_1^0 = c0 + c1 (L_2 - L_2^0)`` (``L^0``: the length at
      ``qpos0``, ``tendon_length0``); without ``tendon2``, ``L_1 - L_1^0 = c0``. So ``C =
      coef_1 - c1 coef_2`` and ``offset = -(L_1^0 + c0) + c1 L_2^0``: ``phi`` is MuJoCo's
      residual ``efc_pos`` and ``C`` its row of ``efc_J``.
    * ``ignored``: ``(name, reason)`` of the others: a
      nonzero quadratic or higher ``polycoef`` term between two joints or tendons
      (nonlinear), spatial tendons.
    """
    mimic, couplings, ignored = [], [], []
    kinds = {int(mujoco.mjtEq.mjEQ_CONNECT): "connect", int(mujoco.mjtEq.mjEQ_WELD): "weld"}
    for e in range(m.neq):
        nm = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, e) or f"equality{e}"
        if not m.eq_active0[e]:
            continue
        poly = np.asarray(m.eq_data[e, :5], dtype=float)
        kind = int(m.eq_type[e])
        o1, o2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        c0, c1 = float(poly[0]), float(poly[1])
        if kind in (int(mujoco.mjtEq.mjEQ_CONNECT), int(mujoco.mjtEq.mjEQ_WELD)):
            continue  # point loops (_connect_loops)
        if kind not in (int(mujoco.mjtEq.mjEQ_JOINT), int(mujoco.mjtEq.mjEQ_TENDON)):
            ignored.append((nm, kinds.get(kind, f"type {kind}")))
            continue
        what = "joint" if kind == int(mujoco.mjtEq.mjEQ_JOINT) else "tendon"
        if o2 >= 0 and np.any(poly[2:] != 0.0):
            ignored.append((nm, f"{what} equality, nonlinear polycoef {poly.tolist()}"))
            continue
        if what == "joint":
            ref1 = float(m.qpos0[m.jnt_qposadr[o1]])
            if o2 < 0:
                mimic.append([joint_names[o1], None, 0.0, ref1 + c0])
            else:
                ref2 = float(m.qpos0[m.jnt_qposadr[o2]])
                mimic.append([joint_names[o1], joint_names[o2], c1, ref1 + c0 - c1 * ref2])
            continue
        row: dict[str, float] = {}
        offset = -(float(m.tendon_length0[o1]) + c0)
        spatial = None
        for t, scale in ((o1, 1.0), (o2, -c1)):
            if t < 0:
                continue
            terms = _fixed_tendon(mujoco, m, t, joint_names)
            if terms is None:
                spatial = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_TENDON, t) or f"tendon{t}"
                break
            for jn, coef in terms:
                row[jn] = row.get(jn, 0.0) + scale * coef
        if spatial is not None:
            ignored.append((nm, f"tendon equality over the spatial tendon {spatial!r}"))
            continue
        if o2 >= 0:
            offset += c1 * float(m.tendon_length0[o2])
        row = {jn: x for jn, x in row.items() if x != 0.0}
        if not row:
            ignored.append((nm, "tendon equality with no joint left in it"))
            continue
        couplings.append([f"tendon:{nm}", list(row), list(row.values()), offset])
    return mimic, couplings, ignored


# ----------------------------------------------------------------------------- states


def mujoco_joint_map(mbm: MultibodyModel) -> dict:
    """The MuJoCo <-> Pinocchio joint map of a model loaded from MJCF (or a URDF checked
    against MuJoCo): ``{"nq", "nv", "joints": [[name, type, qposadr, dofadr], ...],
    "qpos0"}``.

    Raises
    ------
    ModelError
        If the model has no such map (built-in rovers; URDF loaded without MuJoCo).
    """
    mp = (mbm.params or {}).get("mujoco")
    if not mp:
        raise ModelError(f"model {mbm.name!r} has no MuJoCo joint map: load it from an MJCF "
                         "file, or from a URDF with the MuJoCo check (mujoco installed)")
    return mp


def _quat_rotate(quat_wxyz: np.ndarray, x: np.ndarray, inverse: bool) -> np.ndarray:
    """Rotate 3-vectors ``x`` (..., 3) by unit quaternions (..., 4) (w x y z), or by their
    inverse: ``x' = x + 2 w (u x x) + 2 u x (u x x)`` (``u`` negated for the inverse)."""
    w = quat_wxyz[..., :1]
    u = -quat_wxyz[..., 1:] if inverse else quat_wxyz[..., 1:]
    t = 2.0 * np.cross(u, x)
    return x + w * t + np.cross(u, t)


def _unit_quat(qq: np.ndarray, what: str) -> np.ndarray:
    n = np.linalg.norm(qq, axis=-1, keepdims=True)
    if not np.all(n > 1e-12):
        raise ModelError(f"{what}: quaternion of zero length")
    return qq / n


def state_to_pinocchio(model, mp, qpos, qvel):
    batch = qpos.shape[:-1]
    q = np.broadcast_to(pin.neutral(model), (*batch, model.nq)).copy()
    v = None if qvel is None else np.zeros((*batch, model.nv))
    for name, kind, qa, da in mp["joints"]:
        j = model.joints[model.getJointId(name)]
        iq, iv = j.idx_q, j.idx_v
        if kind in ("hinge", "slide"):
            if j.nq == 1:
                q[..., iq] = qpos[..., qa]
            else:  # URDF continuous joint: (cos, sin)
                q[..., iq] = np.cos(qpos[..., qa])
                q[..., iq + 1] = np.sin(qpos[..., qa])
            if v is not None:
                v[..., iv] = qvel[..., da]
        elif kind == "ball":
            quat = _unit_quat(qpos[..., qa:qa + 4], f"ball joint {name!r}")
            q[..., iq:iq + 3] = quat[..., 1:]
            q[..., iq + 3] = quat[..., 0]
            if v is not None:
                v[..., iv:iv + 3] = qvel[..., da:da + 3]
        else:  # free
            quat = _unit_quat(qpos[..., qa + 3:qa + 7], f"free joint {name!r}")
            q[..., iq:iq + 3] = qpos[..., qa:qa + 3]
            q[..., iq + 3:iq + 6] = quat[..., 1:]
            q[..., iq + 6] = quat[..., 0]
            if v is not None:
                v[..., iv:iv + 3] = _quat_rotate(quat, qvel[..., da:da + 3], inverse=True)
                v[..., iv + 3:iv + 6] = qvel[..., da + 3:da + 6]
    return q, v


def _to_mujoco(model, mp, q, v):
    batch = q.shape[:-1]
    qpos = np.broadcast_to(np.asarray(mp["qpos0"], dtype=float), (*batch, mp["nq"])).copy()
    qvel = None if v is None else np.zeros((*batch, mp["nv"]))
    for name, kind, qa, da in mp["joints"]:
        j = model.joints[model.getJointId(name)]
        iq, iv = j.idx_q, j.idx_v
        if kind in ("hinge", "slide"):
            qpos[..., qa] = q[..., iq] if j.nq == 1 else np.arctan2(q[..., iq + 1], q[..., iq])
            if qvel is not None:
                qvel[..., da] = v[..., iv]
        elif kind == "ball":
            qpos[..., qa] = q[..., iq + 3]
            qpos[..., qa + 1:qa + 4] = q[..., iq:iq + 3]
            if qvel is not None:
                qvel[..., da:da + 3] = v[..., iv:iv + 3]
        else:  # free
            qpos[..., qa:qa + 3] = q[..., iq:iq + 3]
            qpos[..., qa + 3] = q[..., iq + 6]
            qpos[..., qa + 4:qa + 7] = q[..., iq + 3:iq + 6]
            if qvel is not None:
                quat = _unit_quat(qpos[..., qa + 3:qa + 7], f"free joint {name!r}")
                qvel[..., da:da + 3] = _quat_rotate(quat, v[..., iv:iv + 3], inverse=False)
                qvel[..., da + 3:da + 6] = v[..., iv + 3:iv + 6]
    return qpos, qvel


def _as_state(x, n: int, what: str) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.ndim == 0 or x.shape[-1] != n or not np.all(np.isfinite(x)):
        raise ModelError(f"{what} must be finite with shape (..., {n}), got shape {x.shape}")
    return x


def mujoco_state_to_pinocchio(mbm: MultibodyModel, qpos, qvel=None):
    """MuJoCo ``(qpos, qvel)`` -> Pinocchio ``(q, v)``, joint by joint.

    Hinge/slide: ``q = qpos``, ``v = qvel`` (continuous URDF joints: ``q = (cos, sin)``).
    Ball: quaternion ``w x y z`` -> ``x y z w`` (normalized), ``v = qvel``. Free:
    ``q = (x, y, z, qx, qy, qz, qw)``, ``v = (R^T v_world, omega_body)`` with ``R`` the
    body rotation. Pinocchio joints absent from MuJoCo's model keep their neutral value.

    Parameters
    ----------
    mbm : MultibodyModel
        Loaded from MJCF, or from URDF with the MuJoCo check (see :func:`mujoco_joint_map`).
    qpos : (..., mujoco nq) array_like
    qvel : (..., mujoco nv) array_like, optional

    Returns
    -------
    q : (..., nq) ndarray
    v : (..., nv) ndarray or None
        ``None`` when ``qvel`` is not given.

    Examples
    --------
    >>> import numpy as np
    >>> from roverimpact.models.mjcf import _demo_free_body, mujoco_state_to_pinocchio
    >>> mbm = _demo_free_body()
    >>> q, v = mujoco_state_to_pinocchio(mbm, [0, 0, 1, 0, 0, 0, 1], [1, 0, 0, 0, 0, 0])
    >>> q.round(12).tolist(), v.round(12).tolist()   # 180 deg about z: world x = body -x
    ([0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0], [-1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    """
    mp = mujoco_joint_map(mbm)
    qpos = _as_state(qpos, mp["nq"], "qpos")
    if qvel is not None:
        qvel = _as_state(qvel, mp["nv"], "qvel")
        if qvel.shape[:-1] != qpos.shape[:-1]:
            raise ModelError(f"qpos and qvel batch shapes differ: {qpos.shape} vs {qvel.shape}")
    return state_to_pinocchio(mbm.model, mp, qpos, qvel)


def pinocchio_state_to_mujoco(mbm: MultibodyModel, q, v=None):
    """Pinocchio ``(q, v)`` -> MuJoCo ``(qpos, qvel)``; the inverse of
    :func:`mujoco_state_to_pinocchio` (MuJoCo coordinates of joints Pinocchio does not
    have keep ``qpos0`` and zero rate).

    Parameters
    ----------
    mbm : MultibodyModel
    q : (..., nq) array_like
    v : (..., nv) array_like, optional

    Returns
    -------
    qpos : (..., mujoco nq) ndarray
    qvel : (..., mujoco nv) ndarray or None
    """
    mp = mujoco_joint_map(mbm)
    model = mbm.model
    q = _as_state(q, model.nq, "q")
    if v is not None:
        v = _as_state(v, model.nv, "v")
        if v.shape[:-1] != q.shape[:-1]:
            raise ModelError(f"q and v batch shapes differ: {q.shape} vs {v.shape}")
    return _to_mujoco(model, mp, q, v)


def velocity_map(mbm_or_model, mp: dict, q) -> np.ndarray:
    """``T`` (nv, mujoco nv) with ``v = T qvel`` at configuration ``q`` (nq,).

    Identity blocks joint by joint, except the linear block of a free joint, ``R^T``.
    Used to compare mass matrices: ``M_mujoco = T^T M T``.
    """
    model = getattr(mbm_or_model, "model", mbm_or_model)
    T = np.zeros((model.nv, mp["nv"]))
    for name, kind, _qa, da in mp["joints"]:
        j = model.joints[model.getJointId(name)]
        iv = j.idx_v
        if kind == "free":
            xyzw = np.asarray(q[j.idx_q + 3:j.idx_q + 7], dtype=float)
            R = pin.Quaternion(xyzw).normalized().toRotationMatrix()
            T[iv:iv + 3, da:da + 3] = R.T
            T[iv + 3:iv + 6, da + 3:da + 6] = np.eye(3)
        else:
            T[iv:iv + j.nv, da:da + j.nv] = np.eye(j.nv)
    return T


# ----------------------------------------------------------------------------- loading


def _strip_roverimpact(path: Path) -> str | None:
    """The file's text without ``<roverimpact_*>`` elements (MuJoCo refuses unknown
    elements), or ``None`` if it has none."""
    root = ET.parse(path).getroot()
    found = False
    for parent in list(root.iter()):
        for child in list(parent):
            if isinstance(child.tag, str) and child.tag.startswith("roverimpact_"):
                parent.remove(child)
                found = True
    return ET.tostring(root, encoding="unicode") if found else None


def _include_files(text: str, base: Path, found: dict | None = None) -> dict[str, bytes]:
    """``{file: contents}`` of the ``<include file=...>`` elements of ``text`` and of the
    files they include, read relative to ``base`` (the model file's directory, as MuJoCo
    resolves them), for ``MjSpec.from_string``. A missing file is left to MuJoCo's own
    message."""
    found = {} if found is None else found
    for el in ET.fromstring(text).iter("include"):
        name = el.get("file")
        if not name or name in found:
            continue
        f = base / name
        if not f.is_file():
            continue
        data = f.read_bytes()
        found[name] = data
        try:
            _include_files(data.decode(), base, found)
        except (ET.ParseError, UnicodeDecodeError):
            pass  # MuJoCo says what is wrong with it
    return found


def compile_mjcf(path: str | Path, *, floating_base: bool | None = None):
    """Compile an MJCF file with MuJoCo (``MjSpec.from_file(...).compile()``).

    ``floating_base=True`` adds a free joint ``"root_joint"`` to the single top-level body
    when it has no joint (MuJoCo's way to make a body float); ``False`` removes the free
    joints of the top-level bodies, which stay fixed where the file places them; ``None``
    takes the file as it is.

    Raises
    ------
    ModelError
        If MuJoCo cannot parse or compile the file, or ``floating_base`` cannot be applied.
    """
    mujoco = _import_mujoco()
    path = Path(path)
    with mujoco_warnings(mujoco) as caught:
        m = _compile(mujoco, path, floating_base)
    for msg in dict.fromkeys(caught):
        warnings.warn(f"{path}: MuJoCo: {msg}", UserWarning, stacklevel=2)
    return m


def _compile(mujoco, path: Path, floating_base):
    try:
        text = _strip_roverimpact(path)
        if text is None and path.suffix.lower() == ".xml":
            spec = mujoco.MjSpec.from_file(str(path))
        else:  # without roverimpact's elements, or a ".mjcf" file (MuJoCo's file reader
            # picks its decoder by the suffix): from the text, its includes handed over
            if text is None:
                text = path.read_text()
            spec = mujoco.MjSpec.from_string(text, include=_include_files(text, path.parent)
                                             or None)
            spec.modelfiledir = str(path.parent) + "/"
        if floating_base:
            tops = [b for b in spec.worldbody.bodies]
            if len(tops) != 1:
                raise ModelError(f"{path}: floating_base needs a single top-level body, the "
                                 f"file has {len(tops)}; add <freejoint/> to a body instead")
            top = tops[0]
            if not any(True for _ in top.joints):
                top.add_freejoint(name="root_joint")
            elif not any(j.type == mujoco.mjtJoint.mjJNT_FREE for j in top.joints):
                raise ModelError(f"{path}: floating_base: body {top.name!r} already has "
                                 "joints; MuJoCo allows a free joint only alone in its body")
        elif floating_base is not None:  # False: weld the free bodies where the file puts them
            for body in spec.worldbody.bodies:
                for j in [j for j in body.joints if j.type == mujoco.mjtJoint.mjJNT_FREE]:
                    spec.delete(j)
        try:
            return spec.compile()
        except Exception as exc:
            return _compile_without_textures(spec, path, exc)
    except ModelError:
        raise
    except ET.ParseError as exc:
        raise ModelError(f"{path}: malformed XML ({exc})") from None
    except Exception as exc:  # MuJoCo raises ValueError with its compiler message
        msg = " ".join(str(exc).split()) or type(exc).__name__
        raise ModelError(f"{path}: MuJoCo cannot compile it ({msg})") from None


def _static(body) -> bool:
    """Whether a spec body and all its ancestors have no joint (it cannot move)."""
    while body is not None and body.name != "world":
        if any(True for _ in body.joints):
            return False
        body = body.parent
    return True


def _compile_without_textures(spec, path: Path, exc: Exception):
    """Compile ``spec`` again without the files that change no number roverimpact
    computes, when the first compile failed and the file names some: textures (a model
    copied without its ``textures/`` folder: MuJoCo stops at "Error opening file
    'textures/grid.png'") and height fields read from a file whose geoms are all on
    static bodies (terrain; roverimpact's comes from ``[terrain]``). A warning names them.
    Re-raises ``exc`` if that does not help (a missing mesh does change the inertias)."""
    import mujoco

    hf = mujoco.mjtGeom.mjGEOM_HFIELD
    terrain = [h for h in spec.hfields if h.file and all(
        _static(g.parent) for g in spec.geoms if g.type == hf and g.hfieldname == h.name)]
    files = [t.file for t in spec.textures if t.file] + [h.file for h in terrain]
    if not files:
        raise exc
    for t in list(spec.textures):
        spec.delete(t)
    for mat in spec.materials:
        mat.textures = [""] * len(mat.textures)
    names = {h.name for h in terrain}
    for g in [g for g in spec.geoms if g.type == hf and g.hfieldname in names]:
        spec.delete(g)
    for h in terrain:
        spec.delete(h)
    try:
        m = spec.compile()
    except Exception:
        raise exc from None
    msg = " ".join(str(exc).split())
    warnings.warn(f"{path}: MuJoCo could not load it with its texture and terrain files "
                  f"{files} ({msg}); loaded without textures"
                  + (f" and without the static height fields {sorted(names)}" if names else "")
                  + ", which change no mass, inertia or number roverimpact computes",
                  UserWarning, stacklevel=4)
    return m


def load_mjcf(path: str | Path, *, floating_base: bool | None = None):
    """Load an MJCF file as MuJoCo compiles it (see the module docstring).

    Parameters
    ----------
    path : str or Path
        ``.xml`` / ``.mjcf`` file.
    floating_base : bool, optional
        ``True``: add a free joint ``"root_joint"`` to the (single) top-level body if it
        has no joint. ``False``: remove the free joints of the top-level bodies (fixed
        where the file places them). Default: as in the file.

    Returns
    -------
    MultibodyModel
        ``params``: ``"source"``, ``"q_nominal"`` (MuJoCo's ``qpos0``), ``"mujoco"``
        (joint map), ``"geoms"``, ``"sites"``, ``"bodies"``, ``"total_mass"`` [kg].
    mujoco.MjModel
        The compiled model, for the load-time check of
        :func:`roverimpact.models.mujoco_check.check_mass_matrix` (which
        :func:`roverimpact.load_robot` runs).

    Raises
    ------
    ModelError
        MuJoCo cannot compile the file, or the model has no degree of freedom.
    """
    path = Path(path)
    m = compile_mjcf(path, floating_base=floating_base)
    if m.nv == 0:
        raise ModelError(f"{path}: the model has no degree of freedom")
    model, info = pinocchio_from_mujoco(m, name=None)
    if model.name == "MuJoCo Model":
        model.name = path.stem
    mbm = MultibodyModel(model=model, name=model.name, params={"source": str(path)} | info)
    mbm.params["total_mass"] = float(sum(Y.mass for Y in model.inertias))
    if info.get("mujoco_equalities_ignored"):
        warnings.warn(f"{path}: MuJoCo equality constraints "
                      f"{', '.join(info['mujoco_equalities_ignored_why'])} are neither "
                      "linear couplings of joints (joint equalities, or tendon equalities over "
                      "fixed tendons, with polycoef c0 c1 0 0 0) nor connects or welds of "
                      "bodies closed at qpos0; roverimpact ignores them (model them as loop "
                      "closures or contacts)", UserWarning, stacklevel=2)
    if info.get("mimic") or info.get("couplings"):
        from .joints import attach_couplings

        attach_couplings(mbm)
    attach_connect_loops(mbm)
    return mbm, m


def attach_connect_loops(mbm: MultibodyModel) -> None:
    """Close the loops of ``mbm.params["connect"]`` (MuJoCo ``connect`` and ``weld``
    equalities, see :func:`pinocchio_from_mujoco`) as point loops (rows
    ``loop:<equality>:x|y|z``; a weld's three points ``loop:<equality>:o|x|y:x|y|z``) at
    the nominal configuration, where MuJoCo's compiler closed them."""
    if not mbm.params.get("connect"):
        return
    from ..exceptions import ConfigError
    from .declare import FrameLoop, attach_frame_loops

    try:
        attach_frame_loops(mbm, [FrameLoop(nm, "point", fa, tuple(pa), fb, tuple(pb))
                                 for nm, fa, pa, fb, pb in mbm.params["connect"]],
                           mbm.params["q_nominal"])
    except ConfigError as exc:  # q_nominal moved onto joint couplings opened them
        names = sorted({nm.split(":")[0] for nm, *_ in mbm.params.pop("connect")})
        warnings.warn(f"{mbm.params.get('source', mbm.name)}: MuJoCo connect/weld "
                      f"equalities {names} are open at the nominal configuration (qpos0 "
                      f"moved onto the joint couplings: {exc}); roverimpact ignores them",
                      UserWarning, stacklevel=3)


def _demo_free_body() -> MultibodyModel:
    """A 1 kg free box (doctests)."""
    mujoco = _import_mujoco()
    m = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body name='box'><freejoint name='free'/>"
        "<geom type='box' size='0.1 0.2 0.3' mass='1'/></body></worldbody></mujoco>")
    model, info = pinocchio_from_mujoco(m, name="box")
    return MultibodyModel(model=model, name="box", params=info)
