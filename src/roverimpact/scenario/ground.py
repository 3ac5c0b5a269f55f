r"""The ground of a scenario (``[terrain]``): terrain, pose on it, ground rows, velocity.

Without ``[terrain]`` the ground is the plane z = 0 and nothing here runs. With it:

1. :func:`make_terrain`: the :class:`~roverimpact.models.terrain.Terrain` of the table
   (a plane, a height-field file, a Python function), or a mapping ``{wheel: terrain}``
   when some wheels stand on a plane of their own.
2. :func:`pose_scenario`: the rover placed on it (base height, roll, pitch and suspension
   solved, loops closed; :func:`~roverimpact.models.pose.pose_on_terrain`), x, y and yaw
   kept from ``[configuration]``.
3. :func:`ground_on_terrain`: every wheel's contact with the terrain at ``q``
   (:func:`~roverimpact.models.terrain.wheel_ground_contact`): the ground wheels' outward
   normals for their rows (:class:`~roverimpact.models.constraints.GroundContact`), a
   clear error for a ground wheel off the terrain, and, for a velocity given as a speed
   ``u``, the motion made to follow the terrain:

   .. math:: v \leftarrow \frac{u}{\lVert v_{base} \rVert}\,(I - P_c)\,v,\qquad
             P_c = M^{-1}B^T (B M^{-1} B^T)^{+} B,

   with :math:`B` the normal rows of the wheels that touch (and the loop rows): the
   kinetically nearest motion that neither lifts a wheel off nor drives it into the
   ground (the admissible part of ``v``; on flat ground it is ``v`` itself), scaled so
   that the base moves at ``u``.
"""

from __future__ import annotations

import importlib
import importlib.util
from pathlib import Path

import numpy as np

from ..exceptions import ConfigError, InputError
from .schema import TerrainSpec

__all__ = ["ground_on_terrain", "make_terrain", "pose_scenario"]


def _function(spec: str):
    mod, _, name = spec.rpartition(":")
    try:
        if mod.endswith(".py"):
            path = Path(mod)
            if not path.is_file():
                raise ConfigError(f"terrain.function: no file {mod!r}")
            s = importlib.util.spec_from_file_location(f"_roverimpact_terrain_{path.stem}", path)
            module = importlib.util.module_from_spec(s)
            s.loader.exec_module(module)
        else:
            module = importlib.import_module(mod)
    except ConfigError:
        raise
    except Exception as exc:  # the user's module failed to import: say which and why
        raise ConfigError(f"terrain.function: cannot import {mod!r} "
                          f"({type(exc).__name__}: {exc})") from None
    f = getattr(module, name, None)
    if not callable(f):
        raise ConfigError(f"terrain.function: {mod!r} has no function {name!r}")
    return f


def _base_terrain(spec: TerrainSpec):
    from ..models.terrain import FunctionTerrain, HeightField, PlaneTerrain

    if spec.plane is not None:
        try:
            return PlaneTerrain(spec.plane.point, spec.plane.normal)
        except InputError as exc:
            raise ConfigError(f"terrain.plane: {exc}") from None
    if spec.file is not None:
        return HeightField.from_file(spec.file, spec.spacing, spec.origin, nodata=spec.nodata)
    if spec.function is not None:
        return FunctionTerrain(_function(spec.function))
    return PlaneTerrain()


def make_terrain(spec: TerrainSpec, mbm, q):
    """The terrain of ``[terrain]``; with ``wheels``, ``{wheel name: terrain}`` for every
    wheel, a wheel's own plane passing through the point at world height ``z = height``
    straight below its centre at ``q``."""
    import pinocchio as pin

    from ..models.terrain import PlaneTerrain

    base = _base_terrain(spec)
    if not spec.wheels:
        return base
    names = [w.name for w in mbm.wheels]
    unknown = sorted(set(spec.wheels) - set(names))
    if unknown:
        raise ConfigError(f"terrain.wheels: unknown wheels {unknown}; wheels: {names}")
    data = mbm.model.createData()
    pin.framesForwardKinematics(mbm.model, data, np.asarray(q, float))
    out = {}
    for w in mbm.wheels:
        g = spec.wheels.get(w.name)
        if g is None:
            out[w.name] = base
            continue
        c = data.oMf[mbm.model.getFrameId(w.frame)].translation
        try:
            out[w.name] = PlaneTerrain((c[0], c[1], g.height), g.normal)
        except InputError as exc:
            raise ConfigError(f"terrain.wheels.{w.name}: {exc}") from None
    return out


def pose_scenario(mbm, terrain, q, spec: TerrainSpec) -> np.ndarray:
    """``q`` placed on ``terrain`` (x, y, yaw kept; ``spec.pose_wheels`` touch)."""
    from ..models.pose import PoseError, pose_on_terrain

    wheels = spec.pose_wheels
    if wheels is not None:
        names = [w.name for w in mbm.wheels]
        bad = [w for w in wheels if w not in names]
        if bad:
            raise ConfigError(f"terrain.pose_wheels: unknown wheels {bad}; wheels: {names}")
    try:
        return pose_on_terrain(mbm, terrain, q, wheels=wheels).q
    except PoseError as exc:
        raise ConfigError(f"terrain: the rover cannot be placed on the terrain: {exc}") from None
    except InputError as exc:
        hint = ""
        if "outside the height field" in str(exc):
            hint = ("; the rover stands at [configuration.base] x, y (default: the model's "
                    "nominal place, near (0, 0)): give x and y inside the terrain (a DEM in "
                    "projected coordinates has them in its own)")
        raise ConfigError(f"terrain: {exc}{hint}") from None


def _contacts(mbm, terrain, q):
    from ..models.pose import wheel_contacts

    try:
        return wheel_contacts(mbm, terrain, q)
    except InputError as exc:
        raise ConfigError(f"terrain: {exc}") from None


def driving_velocity(mbm, terrain, q, v, u: float, spec: TerrainSpec,
                     h: float = 1e-4) -> np.ndarray:
    r"""The rover driving over ``terrain`` at ``u`` [m/s] from the posed ``q``.

    The base is moved rigidly by :math:`\pm h` [m] along the heading projected on the
    mean plane of the wheels' contacts (the terrain's slope under the rover) and placed
    on the terrain again from there (:func:`pose_scenario`, the pose nearest to the
    moved one); the central difference of the two poses is the motion per metre, scaled
    so that the base moves at ``u``. On a uniform slope the moved pose already touches:
    a pure translation along the slope, no suspension motion. Wheel spins and any joint
    rates already in ``v`` (other than the base's) are kept.
    """
    import pinocchio as pin

    from ..models.declare import base_info

    model = mbm.model
    info = base_info(mbm)
    js = [model.joints[model.getJointId(n)] for n in info.joints]
    if info.kind not in ("floating", "planar"):
        return v
    wc = _contacts(mbm, terrain, q)
    touching = np.abs(wc.gap) <= spec.gap_tol
    nbar = (wc.normal[touching] if touching.any() else wc.normal).mean(axis=0)
    nbar /= np.linalg.norm(nbar)
    heading = _heading_of(mbm, q, info, js)
    t = heading - (heading @ nbar) * nbar
    t /= np.linalg.norm(t)
    moved = np.array([q, q], dtype=float)  # back and forth by h
    for qm, sgn in zip(moved, (-1.0, 1.0), strict=True):
        if info.kind == "floating":
            qm[js[0].idx_q:js[0].idx_q + 3] += sgn * h * t
        else:
            qm[js[0].idx_q] += sgn * h * t[0]
            qm[js[1].idx_q] += sgn * h * t[2]
    # both placed in one solve: one terrain query per step for the two (the terrain's
    # contact search is most of a pose's cost)
    try:
        ends = pose_scenario(mbm, terrain, moved, spec)
    except ConfigError:  # one that fails says so as a pose of its own (not "pose 1 of 2")
        ends = [pose_scenario(mbm, terrain, qm, spec) for qm in moved]
    v_geo = pin.difference(model, ends[0], ends[1]) / (2.0 * h)   # per metre of travel
    if info.kind == "floating":
        lin = slice(js[0].idx_v, js[0].idx_v + 3)
    else:
        lin = [js[0].idx_v, js[1].idx_v]
    speed = float(np.linalg.norm(v_geo[lin]))
    base = np.zeros(model.nv, dtype=bool)
    for jm in js:
        base[jm.idx_v:jm.idx_v + jm.nv] = True
    return np.where(base, 0.0, v) + v_geo * (u / speed)


def _heading_of(mbm, q, info, js) -> np.ndarray:
    """Horizontal unit heading of the base (+x for a planar base)."""
    import pinocchio as pin

    if info.kind == "planar":
        return np.array([1.0, 0.0, 0.0])
    j = js[0]
    R = pin.Quaternion(np.asarray(q[j.idx_q + 3:j.idx_q + 7])).normalized().toRotationMatrix()
    hx = R[:, 0].copy()
    hx[2] = 0.0
    return hx / np.linalg.norm(hx)


def ground_on_terrain(mbm, terrain, q, v, *, ground: list[str], spec: TerrainSpec,
                      follow: bool, loop_rows: bool = True):
    """Normals of the ``ground`` wheels' rows at ``q`` and the velocity (module doc).

    Returns
    -------
    normals : dict
        ``{wheel name: outward unit normal (3,)}`` of the ground wheels.
    v : (nv,) ndarray
        ``v`` made to follow the terrain when ``follow`` (a speed ``u`` was given),
        else ``v`` unchanged.

    Raises
    ------
    ConfigError
        A ground wheel more than ``spec.gap_tol`` off the terrain (named, with its gap).
    """
    from ..energy import partition
    from ..models.constraints import point_jacobian

    wc = _contacts(mbm, terrain, q)
    names = [w.name for w in mbm.wheels]
    gaps = wc.gap
    off = [(n, g) for n, g in zip(names, gaps, strict=True)
           if n in ground and abs(g) > spec.gap_tol]
    if off:
        n, g = off[0]
        where = "above" if g > 0 else "into"
        raise ConfigError(
            f"terrain: ground wheel {n!r} is {abs(g):.3g} m {where} the terrain in the "
            f"configuration (at most {spec.gap_tol:g} m); let terrain.pose place the rover, "
            "or leave the wheel out of contacts.ground_wheels")
    normals = {n: wc.normal[k] for k, n in enumerate(names) if n in ground}
    if not follow:
        return normals, v
    import pinocchio as pin

    model = mbm.model
    data = model.createData()
    pin.computeJointJacobians(model, data, np.asarray(q, float))
    pin.updateFramePlacements(model, data)
    rows = []
    for k, w in enumerate(mbm.wheels):
        if abs(gaps[k]) <= spec.gap_tol:
            fid = model.getFrameId(w.frame)
            p = wc.point[k]
            rows.append(wc.normal[k] @ point_jacobian(model, data, fid,
                                                         p - data.oMf[fid].translation))
    if loop_rows and mbm.loop_closure is not None:
        rows.extend(np.atleast_2d(mbm.loop_closure(q)[1]))
    if not rows:
        return normals, v
    M = pin.crba(model, data, np.asarray(q, float))
    M = np.triu(M) + np.triu(M, 1).T
    p = partition(M, np.array(rows), v)
    v_a = v - p.v_c
    from ..models.declare import base_info

    info = base_info(mbm)
    kind = info.kind
    iv = [model.joints[model.getJointId(n)].idx_v for n in info.joints]
    if kind == "floating":
        lin = v_a[iv[0]:iv[0] + 3]
    elif kind == "planar":
        lin = v_a[[iv[0], iv[1]]]
    else:
        return normals, v_a
    speed0 = np.linalg.norm(v[iv[0]:iv[0] + 3] if kind == "floating" else v[[iv[0], iv[1]]])
    speed = np.linalg.norm(lin)
    if speed > 1e-12 * max(speed0, 1e-300):
        v_a = v_a * (speed0 / speed)
    return normals, v_a
