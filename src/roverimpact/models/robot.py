"""Any robot through Pinocchio: load URDF/MJCF files, export the built-in rovers to URDF.

:func:`load_robot` returns a :class:`MultibodyModel` from a URDF (``pin.buildModelFromUrdf``,
optional free-flyer base; ``<mimic>`` couplings as constraint rows) or an MJCF file
(compiled by MuJoCo, :mod:`roverimpact.models.mjcf`), checked against MuJoCo's ``M(q)``
(:mod:`roverimpact.models.mujoco_check`). :func:`export_urdf`
writes a built-in rover or a loaded robot as URDF (plain ``xml.etree``) so it can be
opened in other tools; roverimpact's extra description (wheels, linear loop closures,
lockable joints, floating base, rotor inertia) travels in ``<roverimpact_*>`` elements
that URDF parsers ignore, so loading the file back gives the same M and A. A ``<mujoco><compiler
boundmass boundinertia/>`` element (:data:`MUJOCO_BOUND`) lets MuJoCo compile the
massless links of a planar base without changing any body that has mass.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import xml.etree.ElementTree as ET
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pinocchio as pin

from .._io import check_writable
from ..exceptions import ModelError
from ._build import LinearLoopClosure
from .base import MultibodyModel, Wheel
from .robot_data import ERD_SCHEME, example_robot_file, is_example_robot

__all__ = ["ERD_SCHEME", "example_robot_file", "export_plain_urdf", "export_urdf", "joint_slices",
           "load_robot"]




def joint_slices(model) -> dict[str, tuple[slice, slice]]:
    """``{joint name: (slice in q, slice in v)}`` for every joint but the universe."""
    out = {}
    for j in range(1, model.njoints):
        jm = model.joints[j]
        out[model.names[j]] = (slice(jm.idx_q, jm.idx_q + jm.nq),
                               slice(jm.idx_v, jm.idx_v + jm.nv))
    return out


def joint_armature(model, j: int) -> np.ndarray:
    """The rotor inertia of joint ``j`` of a Pinocchio ``model``, one value per DoF (its
    slice of ``model.armature``, which CRBA adds to M's diagonal as ``mj_fullM`` does)."""
    jm = model.joints[j]
    return np.asarray(model.armature[jm.idx_v:jm.idx_v + jm.nv], dtype=float)


def fmt_floats(x) -> str:
    """Numbers as an XML attribute: space-separated, round-trip precision (``%.17g``)."""
    return " ".join(f"{float(v):.17g}" for v in np.atleast_1d(x))


def link_name(model, j: int) -> str:
    """Name of the body frame that joint ``j`` moves (``<joint name>_link`` if none)."""
    for f in model.frames:
        if f.type == pin.FrameType.BODY and f.parentJoint == j:
            return f.name
    return f"{model.names[j]}_link"


#: MuJoCo's compiler refuses a moving body whose mass or a principal inertia is below
#: mjMINVAL (1e-15): the massless links between the joints of a planar base
#: (``base_x_link``, ``base_z_link``). The exported URDF raises every body's mass and
#: principal inertias, for MuJoCo only (``<mujoco><compiler boundmass boundinertia/>``, an
#: element Pinocchio and other URDF readers ignore), to at least this fraction of the
#: smallest positive body mass and principal inertia of the model (and at least 1e-14, ten
#: times mjMINVAL). On rover2d the two slider links get 2.5e-13 kg each: M_xx changes by
#: 2e-14 of itself; a body that has mass is unchanged.
MUJOCO_BOUND = 1e-13

#: Pinocchio's "no limit" (``model.upperPositionLimit`` of a joint added without limits).
_NO_LIMIT = float(np.finfo(np.float64).max)


def _urdf_joint(model, j: int) -> tuple[str, np.ndarray]:
    """``(URDF type, axis)`` of Pinocchio joint ``j``: its kind
    (:func:`~roverimpact.models.joints.joint_coordinate`) and axis in the joint frame
    (:func:`~roverimpact.models.declare.joint_axis`), or a ModelError naming it."""
    from .declare import joint_axis
    from .joints import joint_coordinate

    kind = joint_coordinate(model, model.names[j]).kind
    axis = joint_axis(model, j)
    if kind not in ("revolute", "prismatic", "continuous") or axis is None:
        raise ModelError(f"export_urdf: joint {model.names[j]!r} of type "
                         f"{model.joints[j].shortname()} is not supported (URDF has revolute, "
                         "continuous and prismatic joints about any axis, and roverimpact "
                         "writes a free-flyer root)")
    return kind, axis


def _limit_value(x: float) -> float:
    """A limit as written: Pinocchio's "no limit" (inf or the largest double) as the
    largest double, which URDF readers (urdfdom, MuJoCo) take as a number."""
    x = float(x)
    return float(np.clip(x, -_NO_LIMIT, _NO_LIMIT)) if not np.isnan(x) else _NO_LIMIT


def _frame_links(mbm: MultibodyModel) -> dict[str, int]:
    """``{frame name: frame id}`` of the wheel frames that are neither a joint's link nor
    a joint (an MJCF geom or site, a second body fused into a joint's body): URDF has
    frames only as links and joints, so :func:`export_urdf` writes each as a link on a
    fixed joint."""
    model = mbm.model
    out = {}
    for w in mbm.wheels:
        if not model.existFrame(w.frame):
            raise ModelError(f"export_urdf: wheel {w.name!r} names unknown frame {w.frame!r}")
        fid = model.getFrameId(w.frame)
        f = model.frames[fid]
        if w.frame == link_name(model, f.parentJoint) or (
                f.type == pin.FrameType.JOINT and w.frame == model.names[f.parentJoint]):
            continue
        out[w.frame] = fid
    return out


def _loop_rows(mbm: MultibodyModel, who: str):
    """The loop closure as URDF can carry it: ``(mimic, rows, joints)``, ``mimic`` the
    ``[joint, leader, multiplier, offset]`` of the rows ``"mimic:<joint>"`` (a loaded
    file's ``<mimic>``, ``params["mimic"]``), ``rows`` the other rows ``(name,
    coefficients)``, linear in ``joints`` without offset (``roverimpact_loop``)."""
    lc = mbm.loop_closure
    if lc is None:
        return [], [], ()
    from .joints import JointCoupling

    if not isinstance(lc, (LinearLoopClosure, JointCoupling)):
        raise ModelError(f"{who}: only linear loop closures can be written "
                         f"(got {type(lc).__name__})")
    mimic = {r[0]: r for r in mbm.params.get("mimic", [])}
    offsets = getattr(lc, "offsets", (0.0,) * len(lc.coefficients))
    out_mimic, rows = [], []
    for name, row, off in zip(mbm.loop_names, lc.coefficients, offsets, strict=True):
        joint = name.removeprefix("mimic:")
        if name.startswith("mimic:") and joint in mimic:
            if mimic[joint][1] is None:
                raise ModelError(f"{who}: joint {joint!r} is held at a value (a joint "
                                 "equality without a second joint); a URDF <mimic> needs "
                                 "a leader joint")
            out_mimic.append(list(mimic[joint]))
        elif off != 0.0:
            raise ModelError(f"{who}: loop {name!r} has an offset ({off:g}); a "
                             "roverimpact_loop row is sum c_i q_i = 0")
        else:
            rows.append((name, row))
    return out_mimic, rows, tuple(lc.joints)


def export_urdf(mbm: MultibodyModel, path: str | Path) -> Path:
    """Write a tree of 1-DoF joints (plus a free-flyer root) as URDF.

    Joints: revolute and prismatic (Pinocchio's ``RX``... ``PZ`` and unaligned joints;
    the axis as it is), continuous (``RUBX``... and unbounded unaligned: ``nq = 2``), with
    the model's position, velocity and effort limits (Pinocchio's "no limit" is written as
    the largest double). A wheel frame that is not a joint's link (an MJCF geom or site)
    becomes a link on a fixed joint (``<frame>_joint``) at the frame's placement. The mass
    fixed to the ground (Pinocchio's ``model.inertias[0]``: a fixed base link) is the
    ``<inertial>`` of the ``ground`` link. A ``<mujoco><compiler boundmass boundinertia/>``
    element (:data:`MUJOCO_BOUND`) lets MuJoCo compile massless links between joints.
    Rotor inertia (``model.armature``, an MJCF joint's ``armature``; URDF has no element
    for it) is a ``<roverimpact_armature joint= value=/>`` per joint that has one.

    Parameters
    ----------
    mbm : MultibodyModel
        A built-in rover or a loaded robot (bodies attached at their joint frames, as the
        builders and :func:`load_robot` do).
    path : str or Path
        Output ``.urdf`` file.

    Returns
    -------
    Path
        The written file. Load it back with :func:`load_robot`.

    Raises
    ------
    ModelError
        If the model has a joint other than revolute/prismatic/continuous or a free-flyer
        root, a loop closure that is not linear in the joint coordinates, or a wheel frame
        on the ground of a floating model.
    ConfigError
        If ``path`` cannot be written (a missing folder, a folder, no permission).
    """
    model = mbm.model
    path = check_writable(path, folder=False, option=None)
    robot = ET.Element("robot", name=mbm.name)
    masses = [model.inertias[j].mass for j in range(model.njoints)]
    moments = np.concatenate([np.linalg.eigvalsh(model.inertias[j].inertia)
                              for j in range(model.njoints)])

    def bound(x):  # MUJOCO_BOUND of the smallest positive value, at least 1e-14
        x = np.asarray(x, dtype=float)
        x = x[x > 0]
        return f"{max(MUJOCO_BOUND * float(x.min()) if x.size else 0.0, 1e-14):.3g}"

    # for MuJoCo only (Pinocchio and other URDF readers ignore <mujoco>)
    ET.SubElement(ET.SubElement(robot, "mujoco"), "compiler", boundmass=bound(masses),
                  boundinertia=bound(moments))
    mimic, loop_rows, loop_joints = _loop_rows(mbm, "export_urdf")
    floating = False
    parent_link = {0: "ground"}
    start = 1
    joint_el = {}
    if model.njoints > 1 and model.joints[1].shortname() == "JointModelFreeFlyer":
        floating = True
        parent_link = {1: link_name(model, 1)}
        start = 2
    for j in range(0 if not floating else 1, model.njoints):
        link = parent_link[0] if j == 0 else link_name(model, j)
        parent_link[j] = link
        el = ET.SubElement(robot, "link", name=link)
        I = model.inertias[j]
        if I.mass > 0:
            inert = ET.SubElement(el, "inertial")
            ET.SubElement(inert, "origin", xyz=fmt_floats(I.lever), rpy="0 0 0")
            ET.SubElement(inert, "mass", value=fmt_floats(I.mass))
            Ic = I.inertia
            ET.SubElement(inert, "inertia", ixx=fmt_floats(Ic[0, 0]),
                          ixy=fmt_floats(Ic[0, 1]), ixz=fmt_floats(Ic[0, 2]),
                          iyy=fmt_floats(Ic[1, 1]), iyz=fmt_floats(Ic[1, 2]),
                          izz=fmt_floats(Ic[2, 2]))
        if j < start:
            continue
        jtype, axis = _urdf_joint(model, j)
        jm = model.joints[j]
        js = joint_el[model.names[j]] = ET.SubElement(robot, "joint", name=model.names[j],
                                                       type=jtype)
        plc = model.jointPlacements[j]
        rpy = pin.rpy.matrixToRpy(plc.rotation)
        ET.SubElement(js, "origin", xyz=fmt_floats(plc.translation), rpy=fmt_floats(rpy))
        ET.SubElement(js, "parent", link=parent_link[model.parents[j]])
        ET.SubElement(js, "child", link=link)
        ET.SubElement(js, "axis", xyz=fmt_floats(axis))
        limit = {"effort": fmt_floats(_limit_value(model.effortLimit[jm.idx_v])),
                 "velocity": fmt_floats(_limit_value(model.velocityLimit[jm.idx_v]))}
        if jtype != "continuous":
            limit = {"lower": fmt_floats(_limit_value(model.lowerPositionLimit[jm.idx_q])),
                     "upper": fmt_floats(_limit_value(model.upperPositionLimit[jm.idx_q]))
                     } | limit
        ET.SubElement(js, "limit", **limit)
    for joint, leader, a, b in mimic:
        ET.SubElement(joint_el[joint], "mimic", joint=leader, multiplier=fmt_floats(a),
                      offset=fmt_floats(b))
    for frame, fid in _frame_links(mbm).items():
        f = model.frames[fid]
        if f.parentJoint not in parent_link:
            raise ModelError(f"export_urdf: wheel frame {frame!r} is fixed to the ground of "
                             "a floating model; URDF has no link there")
        joint = f"{frame}_joint"
        while model.existJointName(joint) or model.existFrame(joint):
            joint += "_"
        ET.SubElement(robot, "link", name=frame)
        js = ET.SubElement(robot, "joint", name=joint, type="fixed")
        ET.SubElement(js, "origin", xyz=fmt_floats(f.placement.translation),
                      rpy=fmt_floats(pin.rpy.matrixToRpy(f.placement.rotation)))
        ET.SubElement(js, "parent", link=parent_link[f.parentJoint])
        ET.SubElement(js, "child", link=frame)
    # roverimpact description (ignored by URDF parsers)
    if floating:
        ET.SubElement(robot, "roverimpact_base", type="floating")
    for w in mbm.wheels:
        ET.SubElement(robot, "roverimpact_wheel", name=w.name, frame=w.frame,
                      radius=fmt_floats(w.radius), width=fmt_floats(w.width),
                      axis=fmt_floats(w.axis))
    for name, row in loop_rows:
        ET.SubElement(robot, "roverimpact_loop", name=name, joints=" ".join(loop_joints),
                      coefficients=fmt_floats(row))
    for jn in mbm.lockable_joints:
        ET.SubElement(robot, "roverimpact_lockable", joint=jn)
    for j in range(1, model.njoints):  # URDF has no rotor inertia: MJCF's armature
        arm = joint_armature(model, j)
        if np.any(arm != 0.0):  # the free-flyer root comes back as Pinocchio's root_joint
            ET.SubElement(robot, "roverimpact_armature",
                          joint="root_joint" if floating and j == 1 else model.names[j],
                          value=fmt_floats(arm))
    params = {k: v for k, v in mbm.params.items() if isinstance(v, (int, float, str, bool, list))}
    ET.SubElement(robot, "roverimpact_params").text = json.dumps(params)
    ET.indent(robot)
    path.write_text(ET.tostring(robot, encoding="unicode") + "\n")
    return path


def export_plain_urdf(mbm: MultibodyModel, path: str | Path) -> dict:
    """Write a built-in rover as a plain URDF, as its users' tools read it, and return
    the scenario tables that declare what URDF cannot say.

    Unlike :func:`export_urdf` the file holds no ``roverimpact_*`` elements (MuJoCo and
    other URDF readers take it as is; MuJoCo compiles the massless links of a planar base
    thanks to the file's ``<mujoco><compiler boundmass boundinertia/>``, which gives them
    1e-13 of the lightest body's mass, :data:`MUJOCO_BOUND`, and leaves M(q) equal to the
    model's to 2e-14 of ``sqrt(M_ii M_jj)`` on rover2d): a linear loop between two joints
    (``a q_1 + b q_2 = 0``, the rocker-bogie differential) becomes a ``<mimic>`` of the
    second joint (multiplier ``-a/b``); the floating base, the wheels (by link name)
    and the nominal base pose go into the returned ``[model]`` and ``[configuration]``
    tables.

    Returns
    -------
    dict
        ``{"model": {"file", "base", "wheels"}, "configuration": {"base": {...}}}``, ready
        to merge into a scenario (e.g. ``{**tables, "velocity": ..., "obstacle": ...}``).

    Raises
    ------
    ModelError
        A loop that is not a linear coupling of two joints, a joint type
        :func:`export_urdf` cannot write, or rotor inertia (``model.armature``).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from roverimpact.models import rocker_bogie
    >>> tables = export_plain_urdf(rocker_bogie(), pathlib.Path(tempfile.mkdtemp()) / "rb.urdf")
    >>> sorted(tables["model"]["wheels"])[:2], tables["model"]["base"]
    (['left_front', 'left_middle'], {'kind': 'floating'})
    """
    path = Path(path)
    if np.any(np.asarray(mbm.model.armature) != 0.0):
        raise ModelError("export_plain_urdf: the model has rotor inertia (model.armature, "
                         "an MJCF joint's armature) that a plain URDF cannot hold; use "
                         "export_urdf, which keeps it in a roverimpact_armature element")
    export_urdf(mbm, path)
    root = ET.parse(path).getroot()
    for el in [e for e in root if e.tag.startswith("roverimpact_")]:
        root.remove(el)
    _, loop_rows, loop_joints = _loop_rows(mbm, "export_plain_urdf")
    if loop_rows:
        joints = {j.get("name"): j for j in root.findall("joint")}
        for name, row in loop_rows:
            nz = [(jn, c) for jn, c in zip(loop_joints, row, strict=True) if c != 0.0]
            if len(nz) != 2:
                raise ModelError(f"export_plain_urdf: loop {name!r} couples {len(nz)} joints; "
                                 "a URDF <mimic> couples two")
            (leader, a), (follower, b) = nz
            if joints[follower].find("mimic") is not None:
                raise ModelError(f"export_plain_urdf: loop {name!r}: joint {follower!r} "
                                 "already mimics another joint")
            ET.SubElement(joints[follower], "mimic", joint=leader, multiplier=fmt_floats(-a / b),
                          offset="0")
    ET.indent(root)
    path.write_text(ET.tostring(root, encoding="unicode") + "\n")
    from .declare import base_info

    model = mbm.model
    info = base_info(mbm)
    floating = info.kind == "floating"
    base = {"kind": info.kind} | ({"joints": list(info.joints)} if info.kind == "planar"
                                  else {})
    wheels = {}
    written = _frame_links(mbm)  # wheel frames written as links on fixed joints
    for w in mbm.wheels:
        j = model.frames[model.getFrameId(w.frame)].parentJoint
        wheels[w.name] = {"frame": w.frame if w.frame in written else link_name(model, j),
                          "radius": float(w.radius),
                          "width": float(w.width), "axis": [float(x) for x in w.axis]}
    tables = {"model": {"file": str(path), "base": base, "wheels": wheels}}
    q = mbm.params.get("q_nominal")
    if q is not None:
        q = np.asarray(q, float)
        conf = {}
        if floating:
            rpy = np.degrees(pin.rpy.matrixToRpy(pin.Quaternion(q[3:7]).normalized()
                                                 .toRotationMatrix()))
            conf["base"] = {"x": float(q[0]), "y": float(q[1]), "z": float(q[2]),
                            "roll_deg": float(rpy[0]), "pitch_deg": float(rpy[1]),
                            "yaw_deg": float(rpy[2])}
        joints = {model.names[j]: float(q[model.joints[j].idx_q])
                  for j in range(1, model.njoints) if model.joints[j].nq == 1
                  and q[model.joints[j].idx_q] != 0.0}
        if joints:
            conf["joints"] = joints
        if conf:
            tables["configuration"] = conf
    return tables


def _parse_meta(path: Path) -> dict:
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ModelError(f"{path}: malformed XML ({exc})") from None
    meta = {"floating": root.find("roverimpact_base") is not None, "wheels": [], "loops": [],
            "lockable": [], "armature": [], "params": {}, "root": root.tag, "element": root}
    try:
        for el in root.iter("roverimpact_wheel"):
            meta["wheels"].append(Wheel(
                name=el.get("name"), frame=el.get("frame"), radius=float(el.get("radius")),
                width=float(el.get("width", 0.0)),
                axis=tuple(float(x) for x in el.get("axis", "0 1 0").split()),
            ))
        for el in root.iter("roverimpact_loop"):
            meta["loops"].append((el.get("name"), el.get("joints").split(),
                                  [float(x) for x in el.get("coefficients").split()]))
        meta["lockable"] = [el.get("joint") for el in root.iter("roverimpact_lockable")]
        meta["armature"] = [(el.get("joint"), [float(x) for x in el.get("value").split()])
                            for el in root.iter("roverimpact_armature")]
        p = root.find("roverimpact_params")
        if p is not None and p.text:
            meta["params"] = json.loads(p.text)
    except (TypeError, ValueError, AttributeError) as exc:
        raise ModelError(f"{path}: malformed roverimpact_* element ({exc})") from None
    _check_meta(meta, path)
    return meta


def _check_meta(meta: dict, path: Path) -> None:
    """One ModelError naming the element for values roverimpact's own elements cannot
    have (they were accepted, or failed later in numpy)."""
    def bad(what: str) -> ModelError:
        return ModelError(f"{path}: {what}")

    names = [w.name for w in meta["wheels"]]
    for w in meta["wheels"]:
        if not w.name or not w.frame:
            raise bad("a roverimpact_wheel needs name and frame")
        if not (np.isfinite(w.radius) and w.radius > 0):
            raise bad(f"roverimpact_wheel {w.name!r}: radius must be > 0 m, got {w.radius}")
        if not (np.isfinite(w.width) and w.width >= 0):
            raise bad(f"roverimpact_wheel {w.name!r}: width must be >= 0 m, got {w.width}")
        if len(w.axis) != 3 or not all(np.isfinite(w.axis)) or not any(w.axis):
            raise bad(f"roverimpact_wheel {w.name!r}: axis must be 3 numbers, not all zero, "
                      f"got {list(w.axis)}")
        if names.count(w.name) > 1:
            raise bad(f"two roverimpact_wheel elements are named {w.name!r}")
    for name, joints, coeffs in meta["loops"]:
        if len(coeffs) != len(joints):
            raise bad(f"roverimpact_loop {name!r}: {len(coeffs)} coefficients for "
                      f"{len(joints)} joints")
    for joint, arm in meta["armature"]:
        if not joint or not arm or not all(np.isfinite(arm)) or min(arm) < 0.0:
            raise bad(f"roverimpact_armature {joint!r}: needs a joint and values >= 0, got "
                      f"{arm}")
    if not isinstance(meta["params"], dict):
        raise bad("roverimpact_params must hold a JSON object ({...}), got "
                  f"{type(meta['params']).__name__}")


@contextmanager
def _parser_stderr(lines: list[str]):
    """Keep what C/C++ code writes to file descriptor 2 during the block (urdfdom's
    "Error: ... at line 607 in joint.cpp" lines) off the terminal; its lines are appended
    to ``lines``, so the caller can say in one message why a file was refused."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError, AttributeError):  # no fd 2 (embedded interpreter)
        yield
        return
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            lines.extend(tmp.read().decode("utf-8", "replace").splitlines())




#: The numbers of a URDF that its dynamics depend on: element -> attributes, and how many
#: numbers each holds. urdfdom drops an <inertial> whose <mass value="8,0"> it cannot read
#: and builds the model without it, silently.
_URDF_NUMBERS = {"mass": {"value": 1},
                 "inertia": {k: 1 for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")},
                 "origin": {"xyz": 3, "rpy": 3}, "axis": {"xyz": 3},
                 "mimic": {"multiplier": 1, "offset": 1}}


#: How to expand a xacro file (ROS's xacro, also on PyPI as ``xacro``).
XACRO_HINT = "xacro robot.urdf.xacro > robot.urdf (ROS's xacro, or pip install xacro)"


def _check_not_xacro(root, path: Path) -> None:
    """One ModelError for a URDF that still holds xacro: a ``<xacro:...>`` element (URDF
    parsers skip it, so the links and joints of an unexpanded ``<xacro:macro>`` call are
    silently missing from the model) or a ``${...}`` / ``$(...)`` in an attribute."""
    for el in root.iter():
        tag = el.tag if isinstance(el.tag, str) else ""
        if tag.startswith("{") and "xacro" in tag.split("}", 1)[0]:
            raise ModelError(f"{path}: unexpanded xacro element <xacro:{tag.split('}', 1)[1]}> "
                             f"(its links and joints are not in the URDF); expand the file "
                             f"first: {XACRO_HINT}")
        for attr, raw in el.attrib.items():
            if "${" in raw or "$(" in raw:
                owner = f" {el.get('name')!r}" if el.get("name") else ""
                raise ModelError(f"{path}: unexpanded xacro expression in <{tag}{owner} "
                                 f"{attr}=\"{raw}\">; expand the file first: {XACRO_HINT}")


#: URDF joint types whose <axis> is used: a zero axis is refused on these only (fixed
#: and floating joints ignore it; "0 0 0" on fixed joints is common: go2, so101).
_AXIS_JOINTS = ("revolute", "continuous", "prismatic", "planar")


def _check_urdf_numbers(root, path: Path) -> None:
    """One ModelError naming the link or joint, the element and the value for a number of
    a link's <inertial> or of a joint (origin, axis, mimic) that is not a finite number,
    or for a zero axis of a joint that moves along it."""
    for kind in ("link", "joint"):
        for owner in root.iter(kind):
            scope = owner.find("inertial") if kind == "link" else owner
            if scope is None:
                continue
            for el in scope:
                for attr, count in _URDF_NUMBERS.get(el.tag, {}).items():
                    raw = el.get(attr)
                    if raw is None:
                        continue
                    try:
                        vals = [float(x) for x in raw.split()]
                        ok = len(vals) == count and all(np.isfinite(vals))
                    except ValueError:
                        ok = False
                    if ok and el.tag == "axis" and not any(vals) \
                            and owner.get("type") in _AXIS_JOINTS:
                        raise ModelError(f"{path}: joint {owner.get('name')!r}: <axis xyz="
                                         f"\"{raw}\"> is no direction (all zero)")
                    if not ok:
                        raise ModelError(
                            f"{path}: {kind} {owner.get('name')!r}: <{el.tag} {attr}="
                            f"\"{raw}\"> must be "
                            f"{f'{count} finite numbers' if count > 1 else 'a finite number'}"
                            " (a decimal point, not a comma; SI units)")


def _check_urdf_planar(root, path: Path) -> None:
    """One ModelError naming a ``planar`` joint whose ``<axis>`` is not ``0 0 1``.

    URDF's planar joint moves in the plane perpendicular to its axis (default ``1 0 0``:
    the y-z plane of the joint frame; MuJoCo's URDF reader follows it), but Pinocchio's
    parser builds ``JointModelPlanar``, x, y and a turn about z, whatever the axis: a
    rover written side-on with ``<axis xyz="0 1 0"/>`` (the x-z plane) moved sideways in
    x-y, with the mass matrix and contact rows of that motion, and no error."""
    for j in root.findall("joint"):
        if j.get("type") != "planar":
            continue
        el = j.find("axis")
        raw = el.get("xyz") if el is not None else None
        axis = np.array([float(x) for x in raw.split()]) if raw else np.array([1.0, 0, 0])
        if np.linalg.norm(axis - [0.0, 0.0, np.linalg.norm(axis)]) > 1e-9 * np.linalg.norm(axis):
            said = f'<axis xyz="{raw}">' if raw else "no <axis> (URDF's default: 1 0 0)"
            raise ModelError(
                f"{path}: planar joint {j.get('name')!r} has {said}: URDF moves it in the "
                "plane perpendicular to that axis, but Pinocchio (which builds the model) "
                "always in the x-y plane of the joint frame. Give it <axis xyz=\"0 0 1\"/> "
                "and rotate its <origin> so that the plane is the joint frame's x-y plane, "
                "or write it as two prismatic joints and a revolute joint through massless "
                "links (the planar base roverimpact reads: x slide, z slide, y hinge)")


def _check_urdf_tree(root, path: Path) -> None:
    """One ModelError for a link that is the child of two joints (a closed chain written
    as URDF: urdfdom keeps one parent, and Pinocchio said "Model does not have any body
    named ..." or "joints [...] move no mass")."""
    parents: dict[str, list[str]] = {}
    for j in root.findall("joint"):
        child = j.find("child")
        if child is not None and child.get("link"):
            parents.setdefault(child.get("link"), []).append(j.get("name"))
    for link, joints in parents.items():
        if len(joints) > 1:
            raise ModelError(
                f"{path}: link {link!r} is the child of {len(joints)} joints {joints}: a URDF "
                "is a tree; cut the closed chain at one joint (give that link's copy its own "
                "name) and close it in the scenario with [[contacts.loops]]")


def _check_urdf_inertias(root, path: Path) -> None:
    """One ModelError naming the link whose <inertial> is no physical body or is incomplete:
    no <mass> (urdfdom drops the <inertial>), no <inertia> (a point mass to Pinocchio, an
    error to MuJoCo), a negative mass or a negative principal moment of inertia
    (Pinocchio builds M with it; MuJoCo refuses the file, so the cross-check is skipped).
    Tolerance: 1e-6 of the largest principal
    moment of the file's links (the rounding of CAD exports: tiago's antenna links have
    -3.5e-8 kg m^2, 6e-8 of tiago's largest; romeo_laas_small's body -0.021, 0.22 of it)."""
    keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    moments = []
    for link in root.findall("link"):
        el = link.find("inertial")
        if el is None:
            continue
        mass, inertia = el.find("mass"), el.find("inertia")
        if mass is None or mass.get("value") is None:
            raise ModelError(f"{path}: link {link.get('name')!r}: its <inertial> has no "
                             "<mass value=...>; the URDF parser drops the whole <inertial> "
                             "without a word (MuJoCo refuses the file): give the mass in kg")
        if inertia is None:
            raise ModelError(f"{path}: link {link.get('name')!r}: its <inertial> has no "
                             "<inertia>; Pinocchio would read a point mass, MuJoCo refuses "
                             "the file: give <inertia ixx= ixy= ixz= iyy= iyz= izz=/> "
                             "(all \"0\" for a point mass)")
        if float(mass.get("value", 0.0)) < 0.0:
            raise ModelError(f"{path}: link {link.get('name')!r}: <mass value="
                             f"\"{mass.get('value')}\"> is negative")
        if inertia is not None:
            xx, xy, xz, yy, yz, zz = (float(inertia.get(k, 0.0)) for k in keys)
            moments.append((link.get("name"), np.linalg.eigvalsh(
                np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]))))
    scale = max((float(ev[-1]) for _n, ev in moments), default=0.0)
    for name, ev in moments:
        if ev[0] < -1e-6 * scale:
            raise ModelError(
                f"{path}: link {name!r}: the <inertia> has a negative principal moment "
                f"({ev[0]:.4g} kg m^2; principal moments "
                f"{', '.join(f'{x:.4g}' for x in ev)}): no physical body has it; check the "
                "signs of the products ixy, ixz, iyz (URDF takes the tensor's entries, not "
                "their negatives)")


def _check_moving_mass(model, path: Path) -> None:
    """One ModelError naming the joints that move no mass (their links and every link
    they carry have no <inertial>): their column of M is zero, so M is singular at every
    configuration and no impact of the model can be analysed."""
    M = pin.crba(model, model.createData(), pin.neutral(model))
    d = np.diag(M)
    floor = len(d) * np.finfo(np.float64).eps * max(float(np.abs(d).max()), 1e-300)
    dead = [model.names[j] for j in range(1, model.njoints)
            if any(d[k] <= floor for k in range(model.joints[j].idx_v,
                                                 model.joints[j].idx_v + model.joints[j].nv))]
    if dead:
        raise ModelError(
            f"{path}: joints {dead} move no mass (the links they carry have no <inertial>, "
            "or no inertia about the joint): M is singular; give those links a mass and "
            "inertia, or make the joints fixed")


def _set_armature(model, armature, path: Path) -> None:
    """``model.armature`` from the file's ``roverimpact_armature`` elements (written by
    :func:`export_urdf` for a model with rotor inertia, e.g. loaded from MJCF; Pinocchio's
    CRBA adds it to the diagonal of M, as MuJoCo's ``mj_fullM`` does)."""
    for joint, arm in armature:
        if not model.existJointName(joint):
            raise ModelError(f"{path}: roverimpact_armature names unknown joint {joint!r}")
        jm = model.joints[model.getJointId(joint)]
        if len(arm) not in (1, jm.nv):
            raise ModelError(f"{path}: roverimpact_armature {joint!r}: {len(arm)} values for "
                             f"a joint of {jm.nv} DoF")
        model.armature[jm.idx_v:jm.idx_v + jm.nv] = np.broadcast_to(np.asarray(arm), jm.nv)


def _urdf_mimic(root) -> list[list]:
    """``[[joint, leader, multiplier, offset], ...]`` of the URDF's ``<mimic>`` elements."""
    out = []
    for j in root.iter("joint"):
        mm = j.find("mimic")
        if mm is None or j.get("type") == "fixed":
            continue
        try:
            out.append([j.get("name"), mm.get("joint"), float(mm.get("multiplier", 1.0)),
                        float(mm.get("offset", 0.0))])
        except (TypeError, ValueError) as exc:
            raise ModelError(f"joint {j.get('name')!r}: malformed <mimic> ({exc})") from None
    return out


def _floating_root_joint(root) -> str | None:
    """The name of a ``floating`` joint whose parent is the URDF's root link (a file that
    floats on its own: ``world`` -> ``base_link``), else ``None``. ``floating_base=True``
    (``[model.base] kind = "floating"``) on such a file added a second free-flyer above the
    massless root link and was refused as "joints ['root_joint'] move no mass"."""
    links = [el.get("name") for el in root.findall("link")]
    children = {c.get("link") for j in root.findall("joint") for c in j.findall("child")}
    roots = [nm for nm in links if nm not in children]
    for j in root.findall("joint"):
        parent = j.find("parent")
        if (j.get("type") == "floating" and parent is not None and len(roots) == 1
                and parent.get("link") == roots[0]):
            return j.get("name")
    return None


def _free_root_at_origin(model) -> list[float] | None:
    """Make a URDF ``floating`` joint's coordinates the world pose of its link, as MuJoCo's
    ``qpos`` (and an MJCF free joint's, and ``[configuration.base]``) mean them, and return
    the nominal configuration (``None`` if no such joint has an ``<origin>``).

    Pinocchio places the free-flyer at the joint's ``<origin>`` and measures ``q`` from
    there, so a file with ``<origin xyz="0.5 0.2 1" .../>`` on it read MuJoCo's state (and
    ``x``, ``z``, ``yaw_deg``) 1.4 m and 0.9 rad away from where MuJoCo puts the link. The
    placement becomes the identity and ``q_nominal`` the origin's pose: the same set of
    configurations, the link where the file puts it at ``q_nominal``."""
    q0 = pin.neutral(model)
    moved = False
    for j in range(1, model.njoints):
        X = model.jointPlacements[j]
        if (model.parents[j] != 0 or model.joints[j].shortname() != "JointModelFreeFlyer"
                or X.isIdentity()):
            continue
        jm = model.joints[j]
        q0[jm.idx_q:jm.idx_q + 7] = pin.SE3ToXYZQUAT(X)
        model.jointPlacements[j] = pin.SE3.Identity()
        moved = True
    return [float(x) for x in q0] if moved else None


def _unique_frame_names(model) -> None:
    """One frame per name: a URDF joint named as its child link (``rocker_left`` ->
    link ``rocker_left``, a common style) gives Pinocchio a JOINT and a BODY frame of that
    name, and ``getFrameId(name)`` raises "Several frames match". The name stays the link's
    (BODY frame; a URDF link's frame is its parent joint's frame, so the placement is the
    same); the others become ``name:joint`` (``name:fixed_joint``, ...). Joint names are
    unchanged."""
    seen: dict[str, list[int]] = {}
    for i, f in enumerate(model.frames):
        seen.setdefault(f.name, []).append(i)
    for name, ids in seen.items():
        if len(ids) < 2:
            continue
        keep = next((i for i in ids if model.frames[i].type == pin.FrameType.BODY), ids[0])
        for i in ids:
            if i != keep:
                f = model.frames[i]
                f.name = f"{name}:{str(f.type).rsplit('.', 1)[-1].lower()}"
                model.frames[i] = f


def load_robot(path: str | Path, *, floating_base: bool | None = None,
               mujoco_check: bool = True) -> MultibodyModel:
    """Load a URDF (``.urdf``) or MJCF (``.xml``, ``.mjcf``) file as a :class:`MultibodyModel`.

    URDF goes through Pinocchio's parser (``pin.buildModelFromUrdf``; continuous joints
    have ``nq = 2`` (cos, sin), ``nv = 1``); ``<mimic>`` couplings, which that parser
    drops, come back as constraint rows ``"mimic:<joint>"`` of the loop closure
    (:mod:`roverimpact.models.joints`). MJCF is compiled by MuJoCo and converted body by
    body (:func:`roverimpact.models.mjcf.load_mjcf`): inertias as MuJoCo computes them,
    one named Pinocchio joint per MuJoCo joint.

    When ``mujoco`` can be imported, the model's ``M(q)`` at a reference configuration is
    compared with MuJoCo's ``mj_fullM`` of the same file (one evaluation,
    :mod:`roverimpact.models.mujoco_check`) and a mismatch is refused. For a URDF that
    MuJoCo cannot compile (or with a joint MuJoCo has no counterpart for), the check is
    skipped, never failed; ``params["mujoco_check"]`` says what happened.

    Parameters
    ----------
    path : str or Path
        Robot description file, or a robot of the example-robot-data package:
        ``"erd:<name or path>"`` or ``"example-robot-data:<name or path>"`` (e.g.
        ``"erd:panda"``; see :mod:`roverimpact.models.robot_data`).
    floating_base : bool, optional
        Add a free-flyer root (joint ``"root_joint"``); ``False`` for an MJCF file
        removes the free joints of its top-level bodies (fixed where the file places
        them). Default: as recorded by :func:`export_urdf` in the file, else fixed base
        (MJCF: as in the file).
    mujoco_check : bool
        Run the comparison with MuJoCo (default ``True``).

    Returns
    -------
    MultibodyModel
        With the wheels, loop closures and lockable joints recorded by
        :func:`export_urdf`, if any (an arm has none: use explicit contact points), and
        ``params["mujoco"]`` (MuJoCo joint map for
        :func:`~roverimpact.models.mjcf.mujoco_state_to_pinocchio`) when MuJoCo compiled
        the file.

    Raises
    ------
    ModelError
        Missing, unreadable or malformed file, a file Pinocchio (URDF) or MuJoCo (MJCF)
        cannot build, or an ``M(q)`` that differs from MuJoCo's.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise ModelError(f"load_robot: expected the path of a URDF/MJCF file, got "
                         f"{type(path).__name__}")
    if is_example_robot(str(path)):
        path = example_robot_file(str(path))
    path = Path(path)
    if not path.is_file():
        if path.is_dir():
            raise ModelError(f"{path}: a folder, not a URDF/MJCF file")
        raise ModelError(f"{path}: no such URDF/MJCF file (a robot of example-robot-data: "
                         "erd:<name>)")
    suffix = path.suffix.lower()
    if suffix == ".xacro":
        raise ModelError(f"{path}: a xacro file; expand it to URDF first: {XACRO_HINT}")
    if suffix not in (".urdf", ".xml", ".mjcf"):
        raise ModelError(f"{path}: unknown robot file type {suffix!r}; use .urdf, .xml or .mjcf")
    from .._io import utf16_problem

    with path.open("rb") as fh:
        problem = utf16_problem(fh.read(4))
    if problem:  # valid XML, but MuJoCo's and Pinocchio's parsers read UTF-8 only
        raise ModelError(f"{path}: {problem}")
    meta = _parse_meta(path)
    floating = meta["floating"] if floating_base is None else bool(floating_base)
    extra: dict = {}
    if suffix != ".urdf":
        if meta["root"] != "mujoco":
            raise ModelError(f"{path}: not an MJCF file (root element <{meta['root']}>)")
        from .mjcf import load_mjcf
        from .mujoco_check import check_mass_matrix

        # None: the file's own free joints (False would remove them)
        mj, compiled = load_mjcf(path, floating_base=True if floating else floating_base)
        if mujoco_check:
            check_mass_matrix(mj, compiled, source=str(path))
        model, extra = mj.model, dict(mj.params)
        extra["mujoco_check"] = "passed" if mujoco_check else "off"
    else:
        if meta["root"] != "robot":
            raise ModelError(f"{path}: not a URDF file (root element <{meta['root']}>)")
        _check_not_xacro(meta["element"], path)
        _check_urdf_numbers(meta["element"], path)
        _check_urdf_tree(meta["element"], path)
        _check_urdf_planar(meta["element"], path)
        _check_urdf_inertias(meta["element"], path)
        if floating and _floating_root_joint(meta["element"]):
            floating = False  # the file's own floating joint is the free base
        args = (str(path), pin.JointModelFreeFlyer()) if floating else (str(path),)
        parser_said: list[str] = []
        try:
            with _parser_stderr(parser_said):  # urdfdom prints "Error: ..." lines on fd 2
                model = pin.buildModelFromUrdf(*args)
        except Exception as exc:  # pinocchio raises RuntimeError/ValueError/... on bad files
            msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            said = [ln.strip().removeprefix("Error:").strip() for ln in parser_said
                    if ln.strip().startswith("Error:")]
            raise ModelError(f"{path}: Pinocchio cannot build a model from it ("
                             + (f"{said[0]}; " if said else "") + f"{msg})") from None
        _unique_frame_names(model)
        q_free = _free_root_at_origin(model)
        if q_free is not None and "q_nominal" not in meta["params"]:
            extra["q_nominal"] = q_free
        _set_armature(model, meta["armature"], path)
        extra["mujoco_check"] = "off"
        if mujoco_check and model.nv > 0:
            from .mujoco_check import check_urdf

            mp, skipped = check_urdf(path, meta["element"], model, floating=floating)
            extra["mujoco_check"] = "passed" if mp is not None else f"skipped: {skipped}"
            if mp is not None:
                extra["mujoco"] = mp
        mimic = _urdf_mimic(meta["element"])
        bad = [r for r in mimic if not (model.existJointName(r[0])
                                        and model.existJointName(r[1]))]
        if bad:
            import warnings

            warnings.warn(f"{path}: the <mimic> of joints {[r[0] for r in bad]} names joints "
                          f"the model does not have ({sorted({r[1] for r in bad})}); these "
                          "couplings are ignored", UserWarning, stacklevel=2)
            mimic = [r for r in mimic if r not in bad]
        if mimic:
            extra["mimic"] = mimic
    if model.nv == 0:
        raise ModelError(f"{path}: the model has no degree of freedom")
    if suffix == ".urdf":
        _check_moving_mass(model, path)
    masses = [model.inertias[j].mass for j in range(1, model.njoints)]
    if any(m < 0 for m in masses):
        raise ModelError(f"{path}: a body has negative mass")
    loop = None
    names = []
    if meta["loops"]:
        joints = meta["loops"][0][1]
        if any(lp[1] != joints for lp in meta["loops"]):
            raise ModelError(f"{path}: all roverimpact_loop rows must name the same joints")
        coeffs = [lp[2] for lp in meta["loops"]]
        if all(model.existJointName(nm) and model.joints[model.getJointId(nm)].nq == 1
               for nm in joints):
            loop = LinearLoopClosure.from_model(model, joints, coeffs)
        else:  # continuous joints (angle from cos, sin)
            from .joints import JointCoupling

            loop = JointCoupling.from_rows(model, joints, coeffs, [0.0] * len(coeffs))
        names = [lp[0] for lp in meta["loops"]]
    for w in meta["wheels"]:
        if not model.existFrame(w.frame):
            raise ModelError(f"{path}: wheel {w.name!r} names unknown frame {w.frame!r}")
    for jn in meta["lockable"]:
        if not (jn and model.existJointName(jn)):
            raise ModelError(f"{path}: roverimpact_lockable names unknown joint {jn!r}")
    qn = meta["params"].get("q_nominal")
    if qn is not None:  # (another length is ignored: floating_base=False drops the base)
        try:
            ok = np.ndim(qn) == 1 and bool(np.isfinite(np.asarray(qn, dtype=float)).all())
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise ModelError(f"{path}: roverimpact_params q_nominal must be a list of "
                             f"numbers, got {qn!r}")
    params = dict(meta["params"]) | extra | {"source": str(path)}
    mbm = MultibodyModel(model=model, name=model.name or path.stem, wheels=meta["wheels"],
                         loop_closure=loop, loop_names=names, lockable_joints=meta["lockable"],
                         params=params)
    if params.get("mimic") or params.get("couplings"):
        from .joints import attach_couplings

        attach_couplings(mbm)
    if params.get("connect"):
        from .mjcf import attach_connect_loops

        attach_connect_loops(mbm)
    return mbm
