r"""What a scenario declares about a robot file: its base, its wheels, its closed loops.

A URDF or MJCF file describes bodies and joints; roverimpact also needs to know which
coordinates move the base (to drive it and to define the impact angle), which bodies are
wheels (centre, radius, spin axis and spin joint) and which loops the tree leaves open. A
scenario declares them (``[model.base]``, ``[model.wheels.NAME]``, ``[[contacts.loops]]``),
in the file's own names; the robot file stays as its format's users write it.

Loops (``point`` and ``distance`` kinds), with :math:`p_a = o_a + R_a\,r_a` and
:math:`p_b = o_b + R_b\,r_b` the two points in world axes and :math:`J_a, J_b` their
point Jacobians (:func:`roverimpact.models.constraints.point_jacobian`):

.. math::

    \text{point:}\quad \phi = p_a - p_b, \qquad J = J_a - J_b \qquad (3 \text{ rows}),

    \text{distance:}\quad \phi = \lVert p_a - p_b \rVert - L, \qquad
    J = u^T (J_a - J_b), \quad u = \frac{p_a - p_b}{\lVert p_a - p_b\rVert} .
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..exceptions import ConfigError, ModelError
from .base import MultibodyModel, Wheel
from .constraints import point_jacobian

__all__ = ["BaseInfo", "FrameLoop", "FrameLoopClosure", "attach_frame_loops", "base_info",
           "declare_wheels", "detect_base", "joint_axis", "placed_axis", "warn_site_twin"]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@dataclass(frozen=True)
class BaseInfo:
    """How the root moves: ``kind`` ``"floating"`` (a free-flyer joint ``joints[0]``),
    ``"planar"`` (``joints`` = x slide, z slide, pitch hinge) or ``"fixed"``."""

    kind: str
    joints: tuple[str, ...] = ()


def _short(model, j: int) -> str:
    return model.joints[j].shortname().removeprefix("JointModel")


def joint_axis(model, j: int) -> np.ndarray | None:
    """Unit axis (in the joint frame) of a 1-DoF prismatic/revolute joint, else None."""
    s = _short(model, j)
    if s in ("PX", "RX"):
        return np.array([1.0, 0.0, 0.0])
    if s in ("PY", "RY"):
        return np.array([0.0, 1.0, 0.0])
    if s in ("PZ", "RZ"):
        return np.array([0.0, 0.0, 1.0])
    if s in ("PrismaticUnaligned", "RevoluteUnaligned", "RevoluteUnboundedUnaligned"):
        # any axis but +x, +y, +z (a URDF's "0 -1 0", an MJCF hinge "0 0 -1"): read from
        # the joint's motion subspace S = (linear, angular), which every joint type has
        # (the Python JointModel of an unbounded unaligned joint has no .axis)
        jm = model.joints[j]
        jd = jm.createData()
        jm.calc(jd, pin.neutral(model))
        S = np.asarray(jd.S, dtype=float).reshape(6, -1)[:, 0]
        return S[:3].copy() if s == "PrismaticUnaligned" else S[3:].copy()
    if s == "RUBY":  # continuous about y
        return np.array([0.0, 1.0, 0.0])
    if s == "RUBX":
        return np.array([1.0, 0.0, 0.0])
    if s == "RUBZ":
        return np.array([0.0, 0.0, 1.0])
    return None


def _is_prismatic(model, j):
    return _short(model, j) in ("PX", "PY", "PZ", "PrismaticUnaligned")


def _is_revolute(model, j):
    return (model.joints[j].nv == 1 and not _is_prismatic(model, j)
            and joint_axis(model, j) is not None)


def placed_axis(model, j: int, frame: int = 0) -> np.ndarray | None:
    """Axis of 1-DoF joint ``j`` (:func:`joint_axis`) in the axes of joint ``frame``, an
    ancestor (0: the world), through the joint placements at zero angles of the joints
    between them (None for a joint without an axis)."""
    a = joint_axis(model, j)
    return None if a is None else _placed(model, j, a, frame)


def _placed(model, j: int, a: np.ndarray, frame: int = 0) -> np.ndarray:
    """Vector ``a`` given in the axes of joint ``j``, in the axes of its ancestor ``frame``
    (0: the world) at zero angles of the joints between them."""
    parents, placements = model.parents, model.jointPlacements
    k = j
    while k > 0 and k != frame:
        a = placements[k].rotation @ a  # into the parent joint's axes
        k = parents[k]
    return a


def _carries(model, j: int, k: int) -> bool:
    """Joint ``j`` is joint ``k`` or one of its ancestors (it moves what ``k`` moves)."""
    while k > 0 and k != j:
        k = model.parents[k]
    return k == j


def detect_base(model) -> BaseInfo:
    """The base kind of a Pinocchio model from its root joints.

    A free-flyer first joint is ``"floating"``; a root chain of an x slide, a z slide and
    a y hinge (any names; aligned or not) is ``"planar"``; anything else ``"fixed"``.
    """
    if model.njoints > 1 and _short(model, 1) == "FreeFlyer":
        return BaseInfo("floating", (model.names[1],))
    if model.njoints > 3 and [model.parents[j] for j in (1, 2, 3)] == [0, 1, 2]:
        if any(joint_axis(model, j) is None for j in (1, 2, 3)):  # a ball, a free joint, ...
            return BaseInfo("fixed")
        ax = [placed_axis(model, j) for j in (1, 2, 3)]
        want = (np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]),
                np.array([0.0, 1.0, 0.0]))
        kinds = (_is_prismatic(model, 1), _is_prismatic(model, 2), _is_revolute(model, 3))
        if all(kinds) and all(abs(abs(a @ w) - 1.0) < 1e-9 for a, w in zip(ax, want,
                                                                          strict=True)):
            _check_planar_signs(model, (1, 2, 3), ax)
            return BaseInfo("planar", tuple(model.names[j] for j in (1, 2, 3)))
    return BaseInfo("fixed")


def base_info(mbm: MultibodyModel) -> BaseInfo:
    """The base the model was declared with (``params["base"]``), else :func:`detect_base`
    (found once per Pinocchio model of ``mbm``: a case of a study asks five times, and a
    planar root took 0.1-0.2 ms to recognise)."""
    b = (mbm.params or {}).get("base")
    if isinstance(b, dict) and "kind" in b:
        return BaseInfo(str(b["kind"]), tuple(b.get("joints") or ()))
    found = mbm.__dict__.get("_detected_base")
    if found is not None and found[0] is mbm.model:
        return found[1]
    info = detect_base(mbm.model)
    mbm.__dict__["_detected_base"] = (mbm.model, info)
    return info


def declare_base(mbm: MultibodyModel, kind: str, joints: Sequence[str] | None = None) -> None:
    """Record a declared base in ``mbm.params["base"]``; a planar base's three joints must
    be an x slide, a z slide and a y hinge in that order."""
    model = mbm.model
    if kind == "floating":
        if not (model.njoints > 1 and _short(model, 1) == "FreeFlyer"):
            src = str((mbm.params or {}).get("source", ""))
            how = ("add <freejoint/> to its top-level body in the file (MuJoCo's way; alone "
                   "in that body: put a body with other joints under it)"
                   if src.lower().endswith((".xml", ".mjcf")) else
                   "for a URDF, the free-flyer is added: remove a fixed root or set the kind "
                   "from the file")
            raise ModelError(f"model.base.kind = 'floating' but {mbm.name!r} has no free joint "
                             f"at its root: {how}")
        mbm.params["base"] = {"kind": "floating", "joints": [model.names[1]]}
        return
    if kind == "fixed":
        mbm.params["base"] = {"kind": "fixed", "joints": []}
        return
    names = list(joints) if joints else [model.names[j] for j in range(1, min(4, model.njoints))]
    for jn in names:
        if not model.existJointName(jn):
            raise ModelError(f"model.base.joints: unknown joint {jn!r}; joints: "
                             f"{list(model.names[1:])}")
    ids = [model.getJointId(jn) for jn in names]
    ok = (len(ids) == 3 and _is_prismatic(model, ids[0]) and _is_prismatic(model, ids[1])
          and _is_revolute(model, ids[2]))
    if ok:
        ax = [placed_axis(model, j) for j in ids]
        want = ([1, 0, 0], [0, 0, 1], [0, 1, 0])
        ok = all(abs(abs(a @ np.asarray(w, float)) - 1.0) < 1e-9 for a, w in zip(ax, want,
                                                                                strict=True))
    if not ok:
        urdf_planar = [jn for jn, j in zip(names, ids, strict=True) if _short(model, j) == "Planar"]
        raise ModelError(f"model.base: a planar base needs an x slide, a z slide and a y hinge; "
                         f"joints {names} are not (give model.base.joints in that order)"
                         + (f"; {urdf_planar[0]!r} is a URDF planar joint (x, y and a turn "
                            "about z in its frame): write the base as prismatic x, prismatic "
                            "z and revolute y joints through two massless links"
                            if urdf_planar else ""))
    _check_planar_signs(model, ids, ax)
    mbm.params["base"] = {"kind": "planar", "joints": names}


def _check_planar_signs(model, ids, axes) -> None:
    """A planar base's coordinates are read as world x, z and the pitch about +y: a slide
    or hinge written about -x, -z or -y (``axes``: the world axes of joints ``ids``) would
    drive the rover backwards (and pose it mirrored) while its wheels roll forwards, so it
    is one ModelError."""
    want = ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0])
    flipped = [model.names[j] for j, a, w in zip(ids, axes, want, strict=True)
               if a @ np.asarray(w) < 0]
    if flipped:
        raise ModelError(
            f"planar base: joints {flipped} move along -x, -z or about -y; roverimpact reads "
            "a planar base's coordinates as world x, z and the pitch about +y: write their "
            "axes as 1 0 0, 0 0 1 and 0 1 0")


def warn_site_twin(mbm: MultibodyModel, name: str, what: str) -> None:
    """Warn when a scenario names frame ``name`` and an MJCF site of that name exists
    under another frame name (``<name>_site``: the bare name is a body's or joint's frame,
    so the point is the body origin, not the site; dm_control's humanoid, quadruped and
    manipulator name many sites as their bodies)."""
    frame = ((mbm.params or {}).get("sites") or {}).get(name)
    if frame is not None and frame != name:
        import warnings

        warnings.warn(f"{what} = {name!r} is the frame of the body (or joint) {name!r}; the "
                      f"MJCF site of that name is frame {frame!r}: name it to use the site",
                      UserWarning, stacklevel=3)


def _frame_joint(model, fid: int) -> int:
    return int(model.frames[fid].parentJoint)


def _check_spin(model, name: str, spin: str, jid: int, frame: str, axis, others: dict
                ) -> None:
    """A declared spin joint must be a hinge (revolute or continuous) that carries the
    wheel's frame (the frame's own joint or one of its ancestors), no other wheel
    (``others``: name -> the joint of its frame), and turns about the wheel's ``axis``
    when one is declared (in the frame's axes). A slide, another wheel's hinge, a rocker or
    a steering hinge would be driven at u / r while the wheel itself does not roll."""
    sj = model.getJointId(spin)
    if not _is_revolute(model, sj):
        kind = "prismatic (slide)" if _is_prismatic(model, sj) else _short(model, sj)
        raise ModelError(f"model.wheels.{name}.spin: joint {spin!r} is a {kind} joint; a "
                         "wheel spins about a hinge (revolute or continuous joint)")
    if not _carries(model, sj, jid):
        raise ModelError(f"model.wheels.{name}.spin: joint {spin!r} does not carry the "
                         f"wheel's frame {frame!r} (that frame moves with joint "
                         f"{model.names[jid]!r}); give the hinge the wheel turns on")
    for other, ojid in others.items():  # a rocker or a bogie hinge: it turns other wheels
        if _carries(model, sj, ojid):
            raise ModelError(f"model.wheels.{name}.spin: joint {spin!r} also carries wheel "
                             f"{other!r}: a wheel spins on a hinge of its own; give the hinge "
                             "the wheel turns on")
    # the wheel's axis: declared (in the frame's axes), else that of the hinge the frame
    # moves with, when it is another one (a steering hinge given as spin instead)
    a_w = None
    if axis is not None:
        f = model.frames[model.getFrameId(frame)]
        a_w = _placed(model, int(f.parentJoint), f.placement.rotation @ np.asarray(axis, float))
    elif jid != sj and _is_revolute(model, jid):
        a_w = placed_axis(model, jid)
    if a_w is not None:
        a_s = placed_axis(model, sj)
        if np.linalg.norm(np.cross(a_w / np.linalg.norm(a_w), a_s)) > 1e-6:
            raise ModelError(f"model.wheels.{name}.spin: joint {spin!r} turns about "
                             f"{np.round(a_s, 6).tolist()} (world, at the neutral "
                             f"configuration), not about the wheel's axis "
                             f"{np.round(a_w / np.linalg.norm(a_w), 6).tolist()}: the wheel "
                             "cannot roll on it (a steering hinge?); give the hinge the wheel "
                             "turns on")


def declare_wheels(mbm: MultibodyModel, specs: dict) -> None:
    """Set ``mbm.wheels`` from ``[model.wheels.NAME]`` declarations.

    ``specs``: name -> object with ``frame``, ``radius``, ``axis``, ``width``, ``spin``
    (:class:`roverimpact.scenario.schema.WheelSpec`). The frame may be a link, joint,
    site or geom name; the radius defaults to a sphere/cylinder geom of that body (MJCF);
    the axis to the axis of the revolute joint carrying the frame (in the frame's axes);
    the spin joint to that joint.
    """
    model = mbm.model
    geoms = (mbm.params or {}).get("geoms") or []
    wheels = []
    joints_of = {n: _frame_joint(model, model.getFrameId(sp.frame)) for n, sp in specs.items()
                 if model.existFrame(sp.frame)}
    for name, sp in specs.items():
        if not model.existFrame(sp.frame):
            known = sorted({f.name for f in model.frames if f.name != "universe"})
            raise ModelError(f"model.wheels.{name}: unknown frame {sp.frame!r} (a link, joint, "
                             f"site or geom of the file); frames: {known}")
        warn_site_twin(mbm, sp.frame, f"model.wheels.{name}.frame")
        fid = model.getFrameId(sp.frame)
        jid = _frame_joint(model, fid)
        spin = sp.spin
        if spin is None and jid > 0 and _is_revolute(model, jid):
            spin = model.names[jid]
        if spin is not None and not model.existJointName(spin):
            raise ModelError(f"model.wheels.{name}.spin: unknown joint {spin!r}; joints: "
                             f"{list(model.names[1:])}")
        if spin is not None and sp.spin is not None:
            _check_spin(model, name, spin, jid, sp.frame, sp.axis,
                        {n: j for n, j in joints_of.items() if n != name})
        axis = sp.axis
        if axis is None:
            if spin is not None:
                sj = model.getJointId(spin)
                # the spin axis in the wheel frame: joint axis mapped by the frame placement
                R = model.frames[fid].placement.rotation if model.frames[fid].parentJoint == sj \
                    else np.eye(3)
                axis = tuple(float(x) for x in R.T @ joint_axis(model, sj))
            else:
                axis = (0.0, 1.0, 0.0)
        radius = sp.radius
        if radius is None:
            found = _wheel_geom(model, geoms, jid, fid, sp.frame, np.asarray(axis, float))
            if found is None:
                raise ModelError(f"model.wheels.{name}: give radius (no sphere or cylinder "
                                 f"geom about the wheel axis found on the body of frame "
                                 f"{sp.frame!r})")
            radius, offset, g = found
            if offset > 1e-9:
                what = f"geom {g['name']!r}" if g.get("name") else "an unnamed geom"
                raise ModelError(
                    f"model.wheels.{name}: frame {sp.frame!r} is {offset:.4g} m from the "
                    f"centre of the {g['type']} {what} (radius {radius:g} m) that gives the "
                    "wheel its radius; the wheel's centre is its frame's origin: give "
                    + (f"frame = {g['name']!r}" if g.get("name") else "that geom a name in "
                       "the file and use it as the frame")
                    + " (or give radius, if the frame's origin is the wheel's centre)")
        wheels.append(Wheel(name=name, frame=sp.frame, radius=float(radius),
                            width=float(sp.width), axis=tuple(float(x) for x in axis),
                            spin=spin))
    mbm.wheels = wheels


def _wheel_geom(model, geoms, jid: int, fid: int, frame: str, axis: np.ndarray):
    """``(radius, offset, geom)`` of the MJCF geom (``params["geoms"]``) that makes the
    wheel of frame ``fid`` on joint ``jid``, or ``None``: the geom named ``frame``, else
    the sphere or cylinder (about ``axis``, in the frame's axes) on the body named
    ``frame``, else one carried by joint ``jid``; among several, a colliding one before a
    visual one (``contype = conaffinity = 0``: a hub), then the largest radius (the tire).
    ``offset`` [m]: the distance of the geom's centre from the frame's origin."""
    Xw = model.frames[fid].placement

    def placed(g):  # the geom in the wheel frame, None if not on joint jid
        body = g.get("body")
        if not (body and model.existFrame(body, pin.FrameType.BODY)):
            return None
        bf = model.frames[model.getFrameId(body, pin.FrameType.BODY)]
        if int(bf.parentJoint) != jid:
            return None
        w, x, y, z = g["quat"]
        Xg = pin.SE3(pin.Quaternion(w, x, y, z).normalized().toRotationMatrix(),
                     np.asarray(g["pos"], dtype=float))
        return Xw.actInv(bf.placement * Xg)

    cands = []
    for g in geoms:
        if g.get("type") not in ("sphere", "cylinder"):
            continue
        X = placed(g)
        if X is None:
            continue
        about = g["type"] == "sphere" or np.linalg.norm(
            np.cross(X.rotation[:, 2], axis)) <= 1e-9 * np.linalg.norm(axis)
        cands.append((g, X, about))
    for match in (lambda g: g.get("name") == frame, lambda g: g.get("body") == frame,
                  lambda g: True):
        found = [(g, X) for g, X, about in cands if match(g) and (about or g.get("name") == frame)]
        if found:
            g, X = max(found, key=lambda c: (bool(c[0].get("contype") or
                                                   c[0].get("conaffinity")),
                                              float(c[0]["size"][0])))
            return float(g["size"][0]), float(np.linalg.norm(X.translation)), g
    return None


@dataclass(frozen=True)
class FrameLoop:
    """A loop between two frame points (see the module docstring)."""

    name: str
    kind: str
    frame_a: str
    point_a: tuple[float, float, float]
    frame_b: str
    point_b: tuple[float, float, float]
    length: float | None = None

    def labels(self) -> list[str]:
        if self.kind == "point":
            return [f"loop:{self.name}:x", f"loop:{self.name}:y", f"loop:{self.name}:z"]
        return [f"loop:{self.name}"]


def _skew(r: np.ndarray) -> np.ndarray:
    """Skew matrices (..., 3, 3) of vectors (..., 3): ``skew(r) w = r x w``."""
    S = np.zeros((*r.shape[:-1], 3, 3))
    S[..., 0, 1], S[..., 0, 2] = -r[..., 2], r[..., 1]
    S[..., 1, 0], S[..., 1, 2] = r[..., 2], -r[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -r[..., 1], r[..., 0]
    return S


def _points(model, data, fa, ra, fb, rb):
    pa = data.oMf[fa].act(ra)
    pb = data.oMf[fb].act(rb)
    Ja = point_jacobian(model, data, fa, pa - data.oMf[fa].translation)
    Jb = point_jacobian(model, data, fb, pb - data.oMf[fb].translation)
    return pa, pb, Ja, Jb


#: A declared loop must close at the scenario's configuration to this gap [m].
LOOP_GAP_TOL = 1e-6


def _structural_axes(model, data, fa, ra, fb, rb, q_ref, seed=0) -> np.ndarray:
    """The axes (0 x, 1 y, 2 z) of a point loop whose rows are not identically zero: a
    planar mechanism's pin leaves its out-of-plane row zero at every configuration (no
    constraint at all), so it is dropped. Judged at ``q_ref`` and at three configurations
    moved from it along random joint rates."""
    rng = np.random.default_rng(seed)
    size = np.zeros(3)
    for k in range(4):
        q = q_ref if k == 0 else pin.integrate(model, q_ref, 0.5 * rng.standard_normal(model.nv))
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        _, _, Ja, Jb = _points(model, data, fa, ra, fb, rb)
        size = np.maximum(size, np.abs(Ja - Jb).max(axis=1))
    return np.flatnonzero(size > 1e-12 * max(size.max(), 1e-300))


class FrameLoopClosure:
    """``q -> (phi (k,), J (k, nv))``: the rows of a model's own closure ``own`` (if any),
    then those of frame loops (:func:`attach_frame_loops`, which builds it).

    ``jdot_v(q, v)``: the bias term ``J_dot v`` (k,) of these rows for the simulator, the
    central difference of the frame rows' ``J`` along ``v`` and the own closure's
    (:func:`~roverimpact.models.constraints.loop_jdot_v`).
    """

    def __init__(self, model, data, loops, ids, lengths, axes, own):
        self.model, self.data, self.own = model, data, own
        # one Pinocchio data for the rows of every thread: they take turns on it (a
        # model, and its closure, are shared by the setups built on it)
        self._lock = threading.Lock()
        self.loops = list(zip(loops, ids, lengths, axes, strict=True))
        # the two points of every loop, a then b: (frame id, point in the frame)
        self._points = [pt for fa, ra, fb, rb in ids for pt in ((fa, ra), (fb, rb))]

    def _frame_rows(self, q, phis, rows):
        """Append the frame loops' residuals and rows at ``q`` to ``phis``, ``rows``: the
        arithmetic of :func:`_points` and
        :func:`~roverimpact.models.constraints.point_jacobian`, every point at once."""
        model, data = self.model, self.data
        with self._lock:
            pin.computeJointJacobians(model, data, q)
            pin.updateFramePlacements(model, data)
            oMf, P, R, J = data.oMf, [], [], []
            for f, r in self._points:
                M = oMf[f]
                p = M.act(r)
                P.append(p)
                R.append(p - M.translation)
                J.append(pin.getFrameJacobian(model, data, f, _LWA))
        J = np.array(J).reshape(len(P), 6, model.nv)
        Jp = J[:, :3] - _skew(np.array(R)) @ J[:, 3:]          # (points, 3, nv)
        for i, (lp, _, L, ax) in enumerate(self.loops):
            pa, pb, Ja, Jb = P[2 * i], P[2 * i + 1], Jp[2 * i], Jp[2 * i + 1]
            if lp.kind == "point":
                phis.append((pa - pb)[ax])
                rows.append((Ja - Jb)[ax])
            else:
                d = pa - pb
                nd = float(np.linalg.norm(d))
                u = d / nd if nd > 1e-12 else np.zeros(3)
                phis.append(np.array([nd - L]))
                rows.append((u @ (Ja - Jb))[None, :])

    def __getstate__(self):
        state = self.__dict__.copy()
        del state["_lock"]  # a lock does not pickle
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._lock = threading.Lock()

    def __call__(self, q):
        q = np.asarray(q, float)
        phis, rows = [], []
        if self.own is not None:
            phi0, J0 = self.own(q)
            phis.append(np.atleast_1d(np.asarray(phi0, float)))
            rows.append(np.atleast_2d(np.asarray(J0, float)))
        self._frame_rows(q, phis, rows)
        return np.concatenate(phis), np.vstack(rows)

    def jdot_v(self, q, v):
        from .constraints import loop_jdot_v

        q = np.asarray(q, float)
        out = [] if self.own is None else [loop_jdot_v(self.own, self.model, q, v)]
        eps = 1e-6 / max(1.0, float(np.max(np.abs(v))))
        J = []
        for s in (eps, -eps):
            rows = []
            self._frame_rows(pin.integrate(self.model, q, s * v), [], rows)
            J.append(np.vstack(rows))
        out.append((J[0] - J[1]) @ v / (2 * eps))
        return np.concatenate(out)


def attach_frame_loops(mbm: MultibodyModel, loops: Sequence[FrameLoop], q_ref) -> None:
    """Add the rows of ``loops`` to ``mbm.loop_closure`` (after the model's own rows).

    A ``distance`` loop without ``length`` keeps the distance of its points at ``q_ref``.
    A ``point`` loop gives a row per world axis its two points can move apart along (a
    planar mechanism's out-of-plane row is identically zero and left out).

    Raises
    ------
    ModelError
        An unknown frame.
    ConfigError
        A loop that does not close at ``q_ref`` (a row's gap larger than
        :data:`LOOP_GAP_TOL`), named by row.
    """
    if not loops:
        return
    model = mbm.model
    data = model.createData()
    ids = []
    for lp in loops:
        for f in (lp.frame_a, lp.frame_b):
            if not model.existFrame(f):
                known = sorted({fr.name for fr in model.frames if fr.name != "universe"})
                raise ModelError(f"contacts.loops {lp.name!r}: unknown frame {f!r}; "
                                 f"frames: {known}")
            warn_site_twin(mbm, f, f"contacts.loops {lp.name!r} frame")
        ids.append((model.getFrameId(lp.frame_a), np.asarray(lp.point_a, float),
                    model.getFrameId(lp.frame_b), np.asarray(lp.point_b, float)))
    q_ref = np.asarray(q_ref, float)
    pin.forwardKinematics(model, data, q_ref)
    pin.updateFramePlacements(model, data)
    lengths = []
    for lp, (fa, ra, fb, rb) in zip(loops, ids, strict=True):
        d_vec = data.oMf[fa].act(ra) - data.oMf[fb].act(rb)
        d = float(np.linalg.norm(d_vec))
        if lp.kind == "distance":
            if lp.length is None and not d > 1e-9:
                raise ModelError(f"contacts.loops {lp.name!r}: the two points coincide in the "
                                 "configuration; give length, or use kind = 'point'")
            L = d if lp.length is None else float(lp.length)
            rows = {f"loop:{lp.name}": abs(d - L)}
        else:
            L = 0.0
            rows = {f"loop:{lp.name}:{ax}": abs(g) for ax, g in zip("xyz", d_vec, strict=True)}
        label, gap = max(rows.items(), key=lambda kv: kv[1])
        if gap > LOOP_GAP_TOL:
            raise ConfigError(
                f"contacts.loops: {label} is open by {gap:.3g} m in the scenario's "
                f"configuration (at most {LOOP_GAP_TOL:g} m): its points must coincide "
                "('point') or keep their length ('distance'); check point_a, point_b and "
                "the [configuration] joint values")
        lengths.append(L)
    axes = [_structural_axes(model, data, *ids_k, q_ref) if lp.kind == "point" else None
            for lp, ids_k in zip(loops, ids, strict=True)]
    mbm.loop_closure = FrameLoopClosure(model, data, loops, ids, lengths, axes,
                                        mbm.loop_closure)
    names = list(mbm.loop_names)
    for lp, ax in zip(loops, axes, strict=True):
        labels = lp.labels()
        if ax is not None:
            labels = [labels[i] for i in ax]
        names.extend(label.removeprefix("loop:") for label in labels)
    mbm.loop_names = names
