r"""Parametric planar rover (DETC2014-35554, Fig. 1) as a Pinocchio model.

::

                 z
                 ^        chassis (box), COM at height z_c
                 |     +-----------------------+
                 |     |           G           |  pitch theta about +y
                 |     +-----------+-----------+  (+theta: nose DOWN, x turns to -z)
                 |          rocker pivot (o)           (suspension="rocker")
                 |        /                  \
              (  rear  )        (middle)      (  front  )   wheels: radius r,
       ---------------------------------------------------------> x   spin about +y
       ground z = 0      <------ wheelbase L ------>

Coordinates (all revolute/prismatic, so ``nq == nv`` and ``v = dq/dt``)::

    q = [x, z, theta, <suspension>, <wheel spins>]

``x, z`` [m] are the world position of the chassis centre of mass (a PX then a PZ joint
with massless links), ``theta`` [rad] the chassis pitch (an RY joint). The chassis
moves in the vertical x-z plane; world y is the wheel axis. We use PX + PZ + RY joints
rather than ``pin.JointModelPlanar`` (which lives in the x-y plane and has ``nq = 4``),
so that every generalized velocity is a physical rate in world axes.

Suspension (``Rover2DParams.suspension``):

* ``"rigid"``: wheel spin joints directly on the chassis.
* ``"rocker"``: one rocker link pinned to the chassis (joint ``"rocker"``, RY) at
  ``rocker_pivot_height`` above the wheel axles, carrying all wheels; the chassis pitches
  freely about the pivot unless the rocker is locked.
* ``"prismatic"``: each wheel on its own strut (joint ``"susp_<wheel>"``, PZ in chassis
  axes, + = wheel moves up relative to the chassis), i.e. spring-damper travel.

Every wheel has a spin joint ``"wheel_<name>"`` (RY) whose JOINT frame is at the wheel
centre, so ground no-slip rows can be written.

``h`` is the height of the centre of mass of the whole vehicle above flat ground in the
nominal configuration (all wheels on the ground, suspension at 0), as in the paper's
Fig. 3; the chassis centre of mass is placed to achieve it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, fields
from typing import Literal

import numpy as np
import pinocchio as pin

from ..exceptions import ModelError
from ._build import (
    Body,
    FamilyNumbers,
    add_bodies,
    box_inertia,
    check_bool,
    check_finite,
    check_positive,
    family_columns,
    numbers_ok,
    rod_inertia,
    wheel_inertia,
)
from .base import MultibodyModel, Wheel

__all__ = ["Rover2DParams", "rover2d", "rover2d_numbers"]


@dataclass(frozen=True)
class Rover2DParams:
    """Parameters of the planar rover (SI units).

    Defaults describe a small research rover of about 24 kg with 0.15 m wheels and a
    0.6 m wheelbase, the scale of the McGill prototype used in DETC2015-47747 (Fig. 3).
    The individual values are **assumptions** chosen to be plausible (box chassis,
    solid-disc wheels), not measured data of a specific vehicle.

    Attributes
    ----------
    chassis_mass : float
        Chassis mass [kg] (default 19.0).
    wheel_mass : float
        Mass of each wheel [kg] (default 2.5).
    wheel_radius : float
        Wheel radius r [m] (default 0.15).
    wheel_width : float
        Wheel width [m] (default 0.10); only enters the wheel inertia.
    wheelbase : float
        Distance between front and rear wheel axles L [m] (default 0.6).
    h : float
        Height of the vehicle centre of mass above the ground in the nominal
        configuration [m] (default 0.35). Must put the chassis COM above the ground.
    com_x : float
        Forward offset of the chassis COM from mid-wheelbase [m] (default 0).
    chassis_length, chassis_height, chassis_width : float
        Box dimensions for the chassis inertia and drawings [m] (0.7, 0.15, 0.4).
    suspension : {"rigid", "rocker", "prismatic"}
        Suspension type (default ``"rigid"``); see the module docstring.
    middle_wheel : bool
        Add a middle wheel at mid-wheelbase (default False).
    rocker_mass : float
        Rocker mass [kg] (default 1.5), ``suspension="rocker"`` only.
    rocker_pivot_height : float
        Height of the rocker pivot above the wheel axles [m] (default 0.12).
    strut_mass : float
        Mass of each prismatic strut (hub carrier) [kg] (default 0.5).
    """

    chassis_mass: float = 19.0
    wheel_mass: float = 2.5
    wheel_radius: float = 0.15
    wheel_width: float = 0.10
    wheelbase: float = 0.6
    h: float = 0.35
    com_x: float = 0.0
    chassis_length: float = 0.7
    chassis_height: float = 0.15
    chassis_width: float = 0.4
    suspension: Literal["rigid", "rocker", "prismatic"] = "rigid"
    middle_wheel: bool = False
    rocker_mass: float = 1.5
    rocker_pivot_height: float = 0.12
    strut_mass: float = 0.5

    def __post_init__(self):
        check_positive(self, _POSITIVE)
        check_finite(self, _FINITE)
        check_bool(self, ("middle_wheel",))
        if self.suspension not in ("rigid", "rocker", "prismatic"):
            raise ModelError(
                f"Rover2DParams.suspension must be 'rigid', 'rocker' or 'prismatic', "
                f"got {self.suspension!r}"
            )

    @property
    def wheel_names(self) -> tuple[str, ...]:
        return _wheel_names(self.middle_wheel)

    def wheel_x(self, name: str) -> float:
        """x of a wheel axle relative to mid-wheelbase [m]."""
        return _wheel_x(self, name)

    @property
    def total_mass(self) -> float:
        return _total_mass(self)

    @property
    def chassis_com_height(self) -> float:
        """Height z_c of the chassis COM that puts the vehicle COM at ``h`` [m].

        ``m_tot h = m_c z_c + sum_w m_w r + m_rocker (r + p/2) + sum_s m_s r``.
        """
        return _chassis_com_height(self)


_POSITIVE = ("chassis_mass", "wheel_mass", "wheel_radius", "wheel_width", "wheelbase", "h",
             "chassis_length", "chassis_height", "chassis_width", "rocker_mass",
             "rocker_pivot_height", "strut_mass")
_FINITE = ("com_x",)
#: the parameters that are not numbers: they set the model's structure (one family each)
_STRUCTURE = ("suspension", "middle_wheel")


# The rover's numbers from its parameters ``p``: a Rover2DParams, or the same fields as
# (k,) arrays (a family, rover2d_numbers), with the same operations in the same order.

def _wheel_names(middle_wheel: bool) -> tuple[str, ...]:
    # alphabetical = the order of Pinocchio's URDF parser, so exports load back identically
    return ("front", "middle", "rear") if middle_wheel else ("front", "rear")


def _wheel_x(p, name: str):
    return {"rear": -0.5, "middle": 0.0, "front": 0.5}[name] * p.wheelbase


def _total_mass(p):
    nw = len(_wheel_names(p.middle_wheel))
    m = p.chassis_mass + p.wheel_mass * nw
    if p.suspension == "rocker":
        m += p.rocker_mass
    elif p.suspension == "prismatic":
        m += p.strut_mass * nw
    return m


def _chassis_com_height(p):
    nw = len(_wheel_names(p.middle_wheel))
    r = p.wheel_radius
    rest = p.wheel_mass * r * nw
    if p.suspension == "rocker":
        rest += p.rocker_mass * (r + 0.5 * p.rocker_pivot_height)
    elif p.suspension == "prismatic":
        rest += p.strut_mass * r * nw
    return (_total_mass(p) * p.h - rest) / p.chassis_mass


def _check_com(p: Rover2DParams) -> float:
    """The chassis COM height z_c of ``p``, or the ModelError of an ``h`` that puts it
    below the ground."""
    z_c = p.chassis_com_height
    if not z_c > 0.0:
        raise ModelError(
            f"Rover2DParams.h = {p.h} m is too small: the chassis COM would be at "
            f"z = {z_c:.3g} m (below the ground); increase h or lower the wheel masses"
        )
    return z_c


def _layout(p, z_c) -> list[Body]:
    """Bodies of the rover of parameters ``p`` (numbers or (k,) arrays) whose chassis COM
    is at height ``z_c``, in the order they are added; the wheels are the bodies named
    ``wheel_<name>``, in the order of :func:`_wheel_names`."""
    r = p.wheel_radius
    bodies = [
        Body(-1, "PX", (0, 0, 0), "base_x", "base_x_link", 0.0),
        Body(0, "PZ", (0, 0, 0), "base_z", "base_z_link", 0.0),
        Body(1, "RY", (0, 0, 0), "base_pitch", "chassis", p.chassis_mass,
             inertia=box_inertia(p.chassis_mass, p.chassis_length, p.chassis_width,
                                 p.chassis_height)),
    ]
    Iw = wheel_inertia(p.wheel_mass, r, p.wheel_width)

    def add_wheel(parent: int, name: str, xyz) -> None:
        bodies.append(Body(parent, "RY", xyz, f"wheel_{name}", f"wheel_{name}_link",
                           p.wheel_mass, inertia=Iw))

    names = _wheel_names(p.middle_wheel)
    if p.suspension == "rocker":
        ph = p.rocker_pivot_height
        bodies.append(Body(2, "RY", (-p.com_x, 0.0, r + ph - z_c), "rocker", "rocker_link",
                           p.rocker_mass, com=(0.0, 0.0, -0.5 * ph),
                           inertia=rod_inertia(p.rocker_mass, p.wheelbase)))
        for name in names:
            add_wheel(3, name, (_wheel_x(p, name), 0.0, -ph))
    elif p.suspension == "prismatic":
        Is = box_inertia(p.strut_mass, 0.05, 0.05, 0.05)
        for name in names:
            bodies.append(Body(2, "PZ", (_wheel_x(p, name) - p.com_x, 0.0, r - z_c),
                               f"susp_{name}", f"strut_{name}", p.strut_mass, inertia=Is))
            add_wheel(len(bodies) - 1, name, (0.0, 0.0, 0.0))
    else:
        for name in names:
            add_wheel(2, name, (_wheel_x(p, name) - p.com_x, 0.0, r - z_c))
    return bodies


def rover2d(params: Rover2DParams | None = None, **overrides) -> MultibodyModel:
    """Build the planar rover as a :class:`MultibodyModel`.

    Parameters
    ----------
    params : Rover2DParams, optional
        Parameters; defaults if omitted.
    **overrides
        Field values replacing those of ``params`` (e.g. ``h=0.5, suspension="rocker"``).

    Returns
    -------
    MultibodyModel
        ``model`` (nq = nv = 3 + n_suspension + n_wheels), ``wheels`` (frames
        ``"wheel_<name>"`` at the wheel centres), ``lockable_joints`` (suspension joints),
        no loop closure, and ``params`` with the parameters plus ``planar=True``,
        ``total_mass``, ``chassis_com_height`` and ``q_nominal`` (all wheels on flat
        ground at z = 0).

    Raises
    ------
    ModelError
        For a non-positive mass or length, an unknown suspension, or an ``h`` so small
        that the chassis COM would be below the ground.

    Examples
    --------
    >>> from roverimpact.models import rover2d
    >>> rv = rover2d(suspension="rocker")
    >>> rv.model.nv, [w.name for w in rv.wheels], rv.lockable_joints
    (6, ['front', 'rear'], ['rocker'])
    """
    if params is None:
        params = Rover2DParams()
    if overrides:
        known = set(Rover2DParams.__dataclass_fields__)
        bad = sorted(set(overrides) - known)
        if bad:
            raise ModelError(f"unknown rover2d parameter(s) {bad}; known: {sorted(known)}")
        params = Rover2DParams(**{**asdict(params), **overrides})
    p = params
    z_c = _check_com(p)
    model = pin.Model()
    model.name = "rover2d"
    add_bodies(model, _layout(p, z_c))
    wheels = [Wheel(name=name, frame=f"wheel_{name}", radius=p.wheel_radius,
                    width=p.wheel_width) for name in p.wheel_names]
    lockable = (["rocker"] if p.suspension == "rocker" else
                [f"susp_{name}" for name in p.wheel_names] if p.suspension == "prismatic"
                else [])
    q_nominal = np.zeros(model.nq)
    q_nominal[1] = z_c
    info = asdict(p) | {
        "planar": True,
        "total_mass": p.total_mass,
        "chassis_com_height": z_c,
        "q_nominal": q_nominal.tolist(),
        "builder": "rover2d",
    }
    return MultibodyModel(model=model, name="rover2d", wheels=wheels, loop_closure=None,
                          loop_names=[], lockable_joints=lockable, params=info)


def rover2d_numbers(preset: str | None, params: Sequence[Mapping]) -> FamilyNumbers:
    """The numbers of the rovers ``rover2d(**params[i])`` without building them
    (:class:`~roverimpact.models.family.ModelFamily` writes them into one model of the
    family), each parameter set checked as :func:`rover2d` checks it. The parameters that
    are not numbers (``suspension``, ``middle_wheel``) must be the same in every set: they
    set the model's structure.

    Raises
    ------
    ModelError
        As :func:`rover2d`, for the first bad parameter set; a preset (rover2d has none).
    ValueError
        Parameter sets of more than one structure (each of them a model ``rover2d``
        builds).
    """
    if preset is not None:
        raise ModelError(f"rover2d has no presets, got {preset!r}")
    base = {f.name: getattr(Rover2DParams(), f.name) for f in fields(Rover2DParams)}
    params = list(params)
    k = len(params)
    ok = True
    structure = {}
    for name in _STRUCTURE:
        col = [ov.get(name, base[name]) for ov in params]
        structure[name] = col[0] if col else base[name]
        # two values: a bad one (middle_wheel = 1 and 0, which a block takes for numbers;
        # the checks below say which) or two structures (ValueError below)
        ok = ok and all(type(x) is type(col[0]) and x == col[0] for x in col)
    p = family_columns(base, params, structure) if ok else None
    with np.errstate(invalid="ignore", divide="ignore"):
        ok = (p is not None and numbers_ok(p, _POSITIVE, _FINITE)
              and structure["suspension"] in ("rigid", "rocker", "prismatic")
              and isinstance(structure["middle_wheel"], (bool, np.bool_))
              and bool(np.all(_chassis_com_height(p) > 0.0)))
    if not ok:  # a bad parameter set: Rover2DParams or the COM check says which (raises)
        for ov in params:
            bad = set(ov) - base.keys()
            if bad:
                raise ModelError(f"unknown rover2d parameter(s) {sorted(bad)}; known: "
                                 f"{sorted(base)}")
            _check_com(Rover2DParams(**{**base, **ov}))
        raise ValueError("rover2d_numbers: the parameter sets are of more than one "
                         "structure (suspension, middle_wheel)")
    z_c = _chassis_com_height(p)
    bodies = _layout(p, z_c)
    q_nominal = np.zeros((k, len(bodies)))  # one coordinate per joint (PX, PZ, RY, ...)
    q_nominal[:, 1] = z_c
    n_wheels = len(_wheel_names(p.middle_wheel))
    return FamilyNumbers.of_layout(bodies, k, q_nominal, [p.wheel_radius] * n_wheels)
