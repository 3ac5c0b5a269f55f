"""Helpers shared by the built-in rover builders: bodies, inertias, linear loop closures.

Every body is added as a joint plus the body inertia expressed in the joint frame (the
body frame coincides with the joint frame, as in URDF), a JOINT frame named after the
joint and a BODY frame named after the link. This makes the URDF export a one-to-one
map (see :mod:`roverimpact.models.robot`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from ..exceptions import ModelError


def check_positive(params: object, names: tuple[str, ...], *, allow_zero: tuple[str, ...] = ()):
    """Raise :class:`ModelError` if one of ``params.<name>`` is not a positive finite number."""
    cls = type(params).__name__
    for name in names:
        val = getattr(params, name)
        rel = ">= 0" if name in allow_zero else "> 0"
        if isinstance(val, bool) or not isinstance(val, (int, float, np.floating, np.integer)):
            hint = (" (write a plain number in SI units)" if isinstance(val, str) else "")
            raise ModelError(f"{cls}.{name} must be a finite number {rel}, got {val!r}{hint}")
        ok = np.isfinite(val) and (val >= 0 if name in allow_zero else val > 0)
        if not ok:
            raise ModelError(f"{cls}.{name} must be a finite number {rel}, got {val!r}")


def check_finite(params: object, names: tuple[str, ...]):
    """Raise :class:`ModelError` if one of ``params.<name>`` is not a finite number (any
    sign)."""
    cls = type(params).__name__
    for name in names:
        val = getattr(params, name)
        if (isinstance(val, bool) or not isinstance(val, (int, float, np.floating, np.integer))
                or not np.isfinite(val)):
            hint = " (write a plain number in SI units)" if isinstance(val, str) else ""
            raise ModelError(f"{cls}.{name} must be a finite number, got {val!r}{hint}")


def check_bool(params: object, names: tuple[str, ...]):
    """Raise :class:`ModelError` if one of ``params.<name>`` is not a bool (the string
    "false" is not False)."""
    cls = type(params).__name__
    for name in names:
        val = getattr(params, name)
        if not isinstance(val, (bool, np.bool_)):
            raise ModelError(f"{cls}.{name} must be true or false, got {val!r}")


def diag3(a, b, c) -> np.ndarray:
    """Diagonal 3 x 3 matrices ``diag(a, b, c)`` (..., 3, 3) of numbers or arrays (one
    matrix per item of a batch of parameters; for numbers, ``np.diag([a, b, c])``)."""
    a, b, c = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (a, b, c)))
    out = np.zeros((*a.shape, 3, 3))
    out[..., 0, 0], out[..., 1, 1], out[..., 2, 2] = a, b, c
    return out


def box_inertia(mass, lx, ly, lz) -> np.ndarray:
    """Central inertia tensor of a solid box [kg m^2]: diag(m(ly²+lz²)/12, ...).

    Numbers give one (3, 3) tensor; arrays (a batch of boxes) give (..., 3, 3)."""
    return diag3(mass * (ly**2 + lz**2) / 12.0, mass * (lx**2 + lz**2) / 12.0,
                 mass * (lx**2 + ly**2) / 12.0)


def wheel_inertia(mass, radius, width) -> np.ndarray:
    """Central inertia of a solid disc/cylinder spinning about y [kg m^2].

    ``I_yy = m r²/2`` (spin axis), ``I_xx = I_zz = m (3 r² + w²)/12``; (..., 3, 3) for
    arrays.
    """
    a = mass * (3.0 * radius**2 + width**2) / 12.0
    return diag3(a, 0.5 * mass * radius**2, a)


def rod_inertia(mass, length_x, thickness: float = 0.04) -> np.ndarray:
    """Central inertia of a slender bar along x (square section ``thickness``) [kg m^2]."""
    return box_inertia(mass, length_x, thickness, thickness)


def add_body(
    model: pin.Model,
    parent: int,
    joint_model,
    xyz,
    joint_name: str,
    link_name: str,
    mass: float,
    com=(0.0, 0.0, 0.0),
    inertia: np.ndarray | None = None,
) -> int:
    """Add ``joint_name`` (child of joint ``parent`` at translation ``xyz`` in its frame).

    The link's inertia (``mass`` at ``com``, central ``inertia``) is expressed in the joint
    frame. Returns the joint id.
    """
    placement = pin.SE3(np.eye(3), np.asarray(xyz, dtype=float))
    jid = model.addJoint(parent, joint_model, placement, joint_name)
    I3 = np.zeros((3, 3)) if inertia is None else np.asarray(inertia, dtype=float)
    model.appendBodyToJoint(jid, pin.Inertia(float(mass), np.asarray(com, dtype=float), I3),
                            pin.SE3.Identity())
    fid = model.addJointFrame(jid, -1)
    model.addBodyFrame(link_name, jid, pin.SE3.Identity(), fid)
    return jid


def family_columns(base: dict[str, Any], params, structure: dict[str, Any] | None = None):
    """The parameter sets ``params`` (overrides of the defaults ``base``) as one namespace
    of (k,) float arrays, a field of ``base`` each, and the fields ``structure`` (the
    same in every set) as they are; None if a set names a field ``base`` lacks or gives
    one a value that is not a number (the builder's own check then says which)."""
    from types import SimpleNamespace

    structure = structure or {}
    k = len(params)
    given = set().union(*params) if params else set()
    if not given <= base.keys():
        return None
    cols = {}
    for name in given - structure.keys():
        col = [ov.get(name, base[name]) for ov in params]
        if not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in col):
            return None
        cols[name] = np.array(col, dtype=float)
    return SimpleNamespace(**{name: cols[name] if name in cols else np.full(k, float(val))
                              for name, val in base.items() if name not in structure},
                           **structure)


def numbers_ok(p, positive, finite) -> bool:
    """Whether every field ``positive`` of the family namespace ``p`` is finite and > 0 in
    every set, and every field ``finite`` finite."""
    with np.errstate(invalid="ignore"):
        return (all(bool(np.all(np.isfinite(getattr(p, n)) & (getattr(p, n) > 0)))
                    for n in positive)
                and all(bool(np.all(np.isfinite(getattr(p, n)))) for n in finite))


@dataclass(frozen=True)
class Body:
    """One body of a built-in rover's layout: its joint, placed in its parent's joint frame
    (translation ``xyz``, no rotation), and its link (``mass`` at ``com``, central
    ``inertia``), as :func:`add_body` adds it.

    The numbers may be arrays over a batch of parameter sets (one layout for a whole
    family of models, :class:`FamilyNumbers`).

    Attributes
    ----------
    parent : int
        Index of the parent body in the layout; -1 for the world.
    joint : str
        Pinocchio joint model, without ``JointModel`` (``"FreeFlyer"``, ``"RY"``, ...).
    """

    parent: int
    joint: str
    xyz: tuple
    joint_name: str
    link_name: str
    mass: Any
    com: tuple = (0.0, 0.0, 0.0)
    inertia: Any = None


def add_bodies(model: pin.Model, bodies) -> list[int]:
    """:func:`add_body` for each :class:`Body` of a layout (of numbers), in order; returns
    the joint ids."""
    jids: list[int] = []
    for b in bodies:
        parent = 0 if b.parent < 0 else jids[b.parent]
        jids.append(add_body(model, parent, getattr(pin, f"JointModel{b.joint}")(), b.xyz,
                             b.joint_name, b.link_name, b.mass, com=b.com,
                             inertia=b.inertia))
    return jids


@dataclass(frozen=True)
class FamilyNumbers:
    """The numbers of ``k`` models of one builder that share their structure (joints,
    bodies, frames, wheels) and differ in their parameters: body ``b`` is joint ``b + 1``.

    Attributes
    ----------
    mass : (k, nb) ndarray
        Body masses [kg].
    lever : (k, nb, 3) ndarray
        Centres of mass in the joint frames [m].
    inertia : (k, nb, 3, 3) ndarray
        Central inertia tensors [kg m^2].
    translation : (k, nb, 3) ndarray
        Joint placements in the parent joint frames [m] (no rotation).
    q_nominal : (k, nq) ndarray
        Nominal configurations.
    wheel_radius : (k, nw) ndarray
        Radii of the model's wheels, in the order of ``MultibodyModel.wheels`` [m].
    frames : dict of str to (k, 3) ndarray
        Translations of the named frames in their joints' frames [m], for frames whose
        placement is a parameter (the rigid body's contact corner); the others, and the
        frames' rotations, stay as the model was built.
    """

    mass: np.ndarray
    lever: np.ndarray
    inertia: np.ndarray
    translation: np.ndarray
    q_nominal: np.ndarray
    wheel_radius: np.ndarray
    frames: dict[str, np.ndarray] = field(default_factory=dict)

    @classmethod
    def of_layout(cls, bodies, k: int, q_nominal, wheel_radius, frames=None
                  ) -> FamilyNumbers:
        """The numbers of a layout whose entries are numbers or (k,) arrays (``frames``:
        ``{name: (x, y, z)}``, each a number or a (k,) array)."""
        def each(x, shape=()):
            return np.broadcast_to(np.asarray(x, dtype=float), (k, *shape))

        def vec(x):
            return np.stack([each(c) for c in x], axis=-1)

        nb = len(bodies)
        mass = np.stack([each(b.mass) for b in bodies], axis=1)
        lever = np.stack([vec(b.com) for b in bodies], axis=1)
        inertia = np.zeros((k, nb, 3, 3))
        for i, b in enumerate(bodies):
            if b.inertia is not None:
                inertia[:, i] = each(b.inertia, (3, 3))
        translation = np.stack([vec(b.xyz) for b in bodies], axis=1)
        radius = (np.stack([each(r) for r in wheel_radius], axis=1) if len(wheel_radius)
                  else np.zeros((k, 0)))
        return cls(mass, lever, inertia, translation, np.asarray(q_nominal, dtype=float),
                   radius, {name: vec(xyz) for name, xyz in (frames or {}).items()})

    @property
    def k(self) -> int:
        return self.mass.shape[0]

    def total_mass(self) -> np.ndarray:
        """(k,) total masses, summed body by body in joint order (as
        ``pin.computeTotalMass`` and a sum over ``model.inertias`` do)."""
        tot = np.zeros(self.k)
        for b in range(self.mass.shape[1]):
            tot = tot + self.mass[:, b]
        return tot


@dataclass(frozen=True)
class LinearLoopClosure:
    """Loop closures that are linear in the joint coordinates: ``phi = C q_sel``.

    Each row ``k`` is ``sum_i C[k, i] q[joint_i] = 0`` (e.g. the rocker-bogie differential
    ``q_rocker_left + q_rocker_right = 0``). Callable as ``loop_closure(q) -> (phi, J)``
    where ``J`` (k, nv) is the Jacobian with respect to the velocity ``v``; ``q`` may be
    a batch (..., nq), then ``phi`` is (..., k).

    Attributes
    ----------
    joints : tuple of str
        Names of the 1-DoF joints involved.
    coefficients : tuple of tuple of float
        ``C``, one tuple per loop row, one coefficient per joint.
    idx_q, idx_v : tuple of int
        Positions of the joints in ``q`` and ``v``.
    nv : int
        Dimension of ``v``.
    """

    joints: tuple[str, ...]
    coefficients: tuple[tuple[float, ...], ...]
    idx_q: tuple[int, ...]
    idx_v: tuple[int, ...]
    nv: int
    #: ``J`` does not depend on ``q`` (no bias term ``J_dot v`` in the simulator).
    constant_jacobian = True

    @classmethod
    def from_model(cls, model: pin.Model, joints, coefficients) -> LinearLoopClosure:
        iq, iv = [], []
        for name in joints:
            if not model.existJointName(name):
                raise ModelError(f"loop closure names unknown joint {name!r}")
            j = model.joints[model.getJointId(name)]
            if j.nv != 1 or j.nq != 1:
                raise ModelError(f"loop closure joint {name!r} must have one degree of freedom")
            iq.append(j.idx_q)
            iv.append(j.idx_v)
        C = tuple(tuple(float(c) for c in row) for row in coefficients)
        return cls(tuple(joints), C, tuple(iq), tuple(iv), int(model.nv))

    @functools.cached_property
    def _arrays(self) -> tuple[np.ndarray, list[int], np.ndarray]:
        """``C``, the coordinates' indices and ``J`` (read-only), made once: building them
        on every call was a third of the simulator's constrained acceleration."""
        C = np.asarray(self.coefficients)
        J = np.zeros((C.shape[0], self.nv))
        J[:, list(self.idx_v)] = C
        J.flags.writeable = False
        return C, list(self.idx_q), J

    def __call__(self, q) -> tuple[np.ndarray, np.ndarray]:
        C, iq, J = self._arrays
        phi = np.asarray(q, dtype=float)[..., iq] @ C.T  # (..., k) for (..., nq)
        return phi, J


def joint_index(model: pin.Model, name: str) -> tuple[int, int, int, int]:
    """``(idx_q, nq, idx_v, nv)`` of joint ``name``, with a clear error if it is unknown."""
    if not model.existJointName(name):
        known = [n for n in model.names[1:]]
        raise ModelError(f"unknown joint {name!r}; the model has joints {known}")
    j = model.joints[model.getJointId(name)]
    return j.idx_q, j.nq, j.idx_v, j.nv
