"""Any robot through Pinocchio: load URDF/MJCF files, export the built-in rovers to URDF.

:func:`load_robot` returns a :class:`MultibodyModel` from a URDF (``pin.buildModelFromUrdf``,
optional free-flyer base) or an MJCF file (``pin.buildModelFromMJCF``). :func:`export_urdf`
writes a built-in rover as URDF (plain ``xml.etree``) so it can be opened in other tools;
roverimpact's extra description (wheels, linear loop closures, lockable joints, floating
base) travels in ``<roverimpact_*>`` elements that URDF parsers ignore, so loading the
file back gives the same M and A.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..exceptions import ModelError
from ._build import LinearLoopClosure
from .base import MultibodyModel, Wheel

__all__ = ["ERD_SCHEME", "example_robot_file", "export_urdf", "joint_slices", "load_robot"]

#: Prefix of robot paths inside the example-robot-data package, e.g.
#: ``"example-robot-data:panda_description/urdf/panda.urdf"``.
ERD_SCHEME = "example-robot-data:"


def example_robot_file(relpath: str) -> Path:
    """Path of a file shipped by the ``example-robot-data`` package (e.g. the Panda URDF).

    See :func:`roverimpact.models.robot_data.example_robot_urdf`.

    Raises
    ------
    ModelError
        If the package is not installed or has no such file.
    """
    from .robot_data import example_robot_urdf

    return example_robot_urdf(relpath.removeprefix(ERD_SCHEME))


_URDF_AXES = {"X": "1 0 0", "Y": "0 1 0", "Z": "0 0 1"}


def joint_slices(model) -> dict[str, tuple[slice, slice]]:
    """``{joint name: (slice in q, slice in v)}`` for every joint but the universe."""
    out = {}
    for j in range(1, model.njoints):
        jm = model.joints[j]
        out[model.names[j]] = (slice(jm.idx_q, jm.idx_q + jm.nq),
                               slice(jm.idx_v, jm.idx_v + jm.nv))
    return out


def _fmt(x) -> str:
    return " ".join(f"{float(v):.17g}" for v in np.atleast_1d(x))


def _link_name(model, j: int) -> str:
    for f in model.frames:
        if f.type == pin.FrameType.BODY and f.parentJoint == j:
            return f.name
    return f"{model.names[j]}_link"


def export_urdf(mbm: MultibodyModel, path: str | Path) -> Path:
    """Write a tree of 1-DoF prismatic/revolute joints (plus a free-flyer root) as URDF.

    Parameters
    ----------
    mbm : MultibodyModel
        A built-in rover (bodies attached at their joint frames, as the builders do).
    path : str or Path
        Output ``.urdf`` file.

    Returns
    -------
    Path
        The written file. Load it back with :func:`load_robot`.

    Raises
    ------
    ModelError
        If the model has a joint other than PX/PY/PZ/RX/RY/RZ or a free-flyer root, or
        a loop closure that is not linear in the joint coordinates.
    """
    model = mbm.model
    path = Path(path)
    robot = ET.Element("robot", name=mbm.name)
    floating = False
    parent_link = {0: "ground"}
    start = 1
    if model.njoints > 1 and model.joints[1].shortname() == "JointModelFreeFlyer":
        floating = True
        parent_link[1] = _link_name(model, 1)
        start = 2
    else:
        ET.SubElement(robot, "link", name="ground")
    for j in range(1 if floating else start, model.njoints):
        link = _link_name(model, j)
        parent_link[j] = link
        el = ET.SubElement(robot, "link", name=link)
        I = model.inertias[j]
        if I.mass > 0:
            inert = ET.SubElement(el, "inertial")
            ET.SubElement(inert, "origin", xyz=_fmt(I.lever), rpy="0 0 0")
            ET.SubElement(inert, "mass", value=_fmt(I.mass))
            Ic = I.inertia
            ET.SubElement(inert, "inertia", ixx=_fmt(Ic[0, 0]), ixy=_fmt(Ic[0, 1]),
                          ixz=_fmt(Ic[0, 2]), iyy=_fmt(Ic[1, 1]), iyz=_fmt(Ic[1, 2]),
                          izz=_fmt(Ic[2, 2]))
        if j < start:
            continue
        short = model.joints[j].shortname()
        if short[-2:-1] == "P" and short[-1] in "XYZ":
            jtype = "prismatic"
        elif short[-2:-1] == "R" and short[-1] in "XYZ":
            jtype = "revolute"
        else:
            raise ModelError(f"export_urdf: joint {model.names[j]!r} of type {short} is not "
                             "supported (only PX/PY/PZ/RX/RY/RZ and a free-flyer root)")
        js = ET.SubElement(robot, "joint", name=model.names[j], type=jtype)
        plc = model.jointPlacements[j]
        rpy = pin.rpy.matrixToRpy(plc.rotation)
        ET.SubElement(js, "origin", xyz=_fmt(plc.translation), rpy=_fmt(rpy))
        ET.SubElement(js, "parent", link=parent_link[model.parents[j]])
        ET.SubElement(js, "child", link=link)
        ET.SubElement(js, "axis", xyz=_URDF_AXES[short[-1]])
        lim = 1e3  # [m] or [rad]: wide limits, Pinocchio keeps them as bounds only
        ET.SubElement(js, "limit", lower=_fmt(-lim), upper=_fmt(lim), effort="1e6",
                      velocity="1e6")
    # roverimpact description (ignored by URDF parsers)
    if floating:
        ET.SubElement(robot, "roverimpact_base", type="floating")
    for w in mbm.wheels:
        ET.SubElement(robot, "roverimpact_wheel", name=w.name, frame=w.frame,
                      radius=_fmt(w.radius), width=_fmt(w.width), axis=_fmt(w.axis))
    if mbm.loop_closure is not None:
        lc = mbm.loop_closure
        if not isinstance(lc, LinearLoopClosure):
            raise ModelError("export_urdf: only linear loop closures can be exported")
        for name, row in zip(mbm.loop_names, lc.coefficients, strict=True):
            ET.SubElement(robot, "roverimpact_loop", name=name, joints=" ".join(lc.joints),
                          coefficients=_fmt(row))
    for jn in mbm.lockable_joints:
        ET.SubElement(robot, "roverimpact_lockable", joint=jn)
    params = {k: v for k, v in mbm.params.items() if isinstance(v, (int, float, str, bool, list))}
    ET.SubElement(robot, "roverimpact_params").text = json.dumps(params)
    ET.indent(robot)
    path.write_text(ET.tostring(robot, encoding="unicode") + "\n")
    return path


def _parse_meta(path: Path) -> dict:
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ModelError(f"{path}: malformed XML ({exc})") from None
    meta = {"floating": root.find("roverimpact_base") is not None, "wheels": [], "loops": [],
            "lockable": [], "params": {}, "root": root.tag}
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
        p = root.find("roverimpact_params")
        if p is not None and p.text:
            meta["params"] = json.loads(p.text)
    except (TypeError, ValueError, AttributeError) as exc:
        raise ModelError(f"{path}: malformed roverimpact_* element ({exc})") from None
    return meta


def load_robot(path: str | Path, *, floating_base: bool | None = None) -> MultibodyModel:
    """Load a URDF (``.urdf``) or MJCF (``.xml``, ``.mjcf``) file as a :class:`MultibodyModel`.

    Parameters
    ----------
    path : str or Path
        Robot description file, or ``"example-robot-data:<path inside the package>"``.
    floating_base : bool, optional
        Add a ``pin.JointModelFreeFlyer`` root (joint ``"root_joint"``). Default: as
        recorded by :func:`export_urdf` in the file, else fixed base.

    Returns
    -------
    MultibodyModel
        With the wheels, loop closures and lockable joints recorded by
        :func:`export_urdf`, if any (an arm has none: use explicit contact points).

    Raises
    ------
    ModelError
        Missing, unreadable or malformed file, or a file Pinocchio cannot build.
    """
    if str(path).startswith(ERD_SCHEME):
        path = example_robot_file(str(path))
    path = Path(path)
    if not path.is_file():
        raise ModelError(f"{path}: no such robot file")
    suffix = path.suffix.lower()
    if suffix not in (".urdf", ".xml", ".mjcf"):
        raise ModelError(f"{path}: unknown robot file type {suffix!r}; use .urdf, .xml or .mjcf")
    meta = _parse_meta(path)
    floating = meta["floating"] if floating_base is None else bool(floating_base)
    try:
        if suffix == ".urdf":
            if meta["root"] != "robot":
                raise ModelError(f"{path}: not a URDF file (root element <{meta['root']}>)")
            model = (pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer()) if floating
                     else pin.buildModelFromUrdf(str(path)))
        else:
            model = (pin.buildModelFromMJCF(str(path), pin.JointModelFreeFlyer()) if floating
                     else pin.buildModelFromMJCF(str(path)))
    except ModelError:
        raise
    except Exception as exc:  # pinocchio raises RuntimeError/ValueError/... on bad files
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ModelError(f"{path}: Pinocchio cannot build a model from it ({msg})") from None
    if model.nv == 0:
        raise ModelError(f"{path}: the model has no degree of freedom")
    masses = [model.inertias[j].mass for j in range(1, model.njoints)]
    if any(m < 0 for m in masses):
        raise ModelError(f"{path}: a body has negative mass")
    loop = None
    names = []
    if meta["loops"]:
        joints = meta["loops"][0][1]
        if any(lp[1] != joints for lp in meta["loops"]):
            raise ModelError(f"{path}: all roverimpact_loop rows must name the same joints")
        loop = LinearLoopClosure.from_model(model, joints, [lp[2] for lp in meta["loops"]])
        names = [lp[0] for lp in meta["loops"]]
    for w in meta["wheels"]:
        if not model.existFrame(w.frame):
            raise ModelError(f"{path}: wheel {w.name!r} names unknown frame {w.frame!r}")
    params = dict(meta["params"]) | {"source": str(path)}
    return MultibodyModel(model=model, name=model.name or path.stem, wheels=meta["wheels"],
                          loop_closure=loop, loop_names=names, lockable_joints=meta["lockable"],
                          params=params)
