r"""Parametric six-wheel rocker-bogie rover (DETC2015-47747, Fig. 1) as a Pinocchio model.

Side view of one side (the other side is its mirror in y)::

                  chassis (box), COM G, free-flyer base
             +--------------------------------+
             |               G                |
             +---------------o----------------+      o  rocker pivot (joint rocker_<side>, RY)
                    bogie   / \                          above the axles by rocker_pivot_height
                pivot (o)--/   \
                 /   \          \                    o  bogie pivot (joint bogie_<side>, RY)
           (rear)   (middle)   (front)                   above the axles by bogie_pivot_height
       ----------------------------------------> x (forward)

Coordinates: ``q = [x, y, z, qx, qy, qz, qw, rocker_left, bogie_left, wheel_left_middle,
wheel_left_rear, wheel_left_front, rocker_right, ...]`` (order of the kinematic tree; look
names up with :func:`roverimpact.models.robot.joint_slices`). The base is
``pin.JointModelFreeFlyer``
(joint ``"root_joint"``, at the chassis COM), so ``v[:6]`` is the chassis twist in
**chassis axes** (Pinocchio's LOCAL convention).

The two rockers are joined by a differential: their angles are opposite,
``q_rocker_left + q_rocker_right = 0``. This is kept as a closed loop (``loop_closure``,
row ``"loop:differential"``), not by eliminating a coordinate: the model stays in
dependent coordinates as in the paper. Wheels have spin joints only (no steering).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from types import SimpleNamespace

import numpy as np
import pinocchio as pin

from ..exceptions import ModelError
from ._build import (
    Body,
    FamilyNumbers,
    LinearLoopClosure,
    add_bodies,
    box_inertia,
    check_finite,
    check_positive,
    family_columns,
    numbers_ok,
    rod_inertia,
    wheel_inertia,
)
from .base import MultibodyModel, Wheel

__all__ = ["PRESETS", "RockerBogieParams", "rocker_bogie", "rocker_bogie_numbers"]


@dataclass(frozen=True)
class RockerBogieParams:
    """Parameters of the rocker-bogie rover (SI units); defaults: the ``"prototype"`` preset.

    Wheel axle positions ``front_x``, ``middle_x``, ``rear_x`` are measured along the
    chassis x axis from the rocker pivot; heights are above the wheel axles in the nominal
    configuration (rocker and bogie angles 0, all six wheels on flat ground).

    Attributes
    ----------
    chassis_mass : float
        [kg]
    chassis_length, chassis_width, chassis_height : float
        Box of the chassis (inertia, drawings) [m].
    chassis_com_above_pivot : float
        Height of the chassis COM above the rocker pivots [m].
    com_x : float
        Forward offset of the chassis COM from the rocker pivots [m].
    rocker_mass, bogie_mass, wheel_mass : float
        Mass of each rocker, bogie and wheel [kg].
    wheel_radius, wheel_width : float
        [m]
    front_x, middle_x, rear_x : float
        Axle positions from the rocker pivot [m]; ``rear_x < middle_x < front_x``.
    track : float
        Lateral distance between left and right wheel planes [m].
    rocker_pivot_height, bogie_pivot_height : float
        Pivot heights above the axles [m]; ``bogie_pivot_height < rocker_pivot_height``.
    """

    chassis_mass: float = 13.8
    chassis_length: float = 0.5
    chassis_width: float = 0.35
    chassis_height: float = 0.15
    chassis_com_above_pivot: float = 0.08
    com_x: float = 0.0
    rocker_mass: float = 1.0
    bogie_mass: float = 0.6
    wheel_mass: float = 0.5
    wheel_radius: float = 0.10
    wheel_width: float = 0.08
    front_x: float = 0.30
    middle_x: float = 0.0
    rear_x: float = -0.30
    track: float = 0.50
    rocker_pivot_height: float = 0.20
    bogie_pivot_height: float = 0.10

    def __post_init__(self):
        check_positive(self, _POSITIVE, allow_zero=())
        check_finite(self, _FINITE)
        if not _axles_ordered(self):
            raise ModelError(
                "RockerBogieParams needs rear_x < middle_x < front_x, got "
                f"{self.rear_x}, {self.middle_x}, {self.front_x}"
            )
        if not _pivots_ordered(self):
            raise ModelError("RockerBogieParams needs bogie_pivot_height < rocker_pivot_height")

    @property
    def total_mass(self) -> float:
        return (self.chassis_mass + 2 * self.rocker_mass + 2 * self.bogie_mass
                + 6 * self.wheel_mass)

    @property
    def bogie_x(self) -> float:
        """Bogie pivot x, midway between middle and rear axles [m]."""
        return _bogie_x(self)


def _bogie_x(p):
    return 0.5 * (p.middle_x + p.rear_x)


# the checks of RockerBogieParams, for numbers and for (k,) arrays of them (a family)
_POSITIVE = ("chassis_mass", "chassis_length", "chassis_width", "chassis_height",
             "rocker_mass", "bogie_mass", "wheel_mass", "wheel_radius", "wheel_width", "track",
             "rocker_pivot_height", "bogie_pivot_height")
_FINITE = ("chassis_com_above_pivot", "com_x", "front_x", "middle_x", "rear_x")


def _axles_ordered(p):
    return (p.rear_x < p.middle_x) & (p.middle_x < p.front_x)


def _pivots_ordered(p):
    return p.bogie_pivot_height < p.rocker_pivot_height


#: Presets. Figures are approximate public values, rounded; they are a rover *class*,
#: not design data. MER: ~180 kg, wheel radius 0.125 m, about 1.4 m between front and
#: rear axles (Lindemann & Voorhees, "Mars Exploration Rover mobility assembly design,
#: test and performance", IEEE SMC 2005). Sojourner: 11.5 kg, 0.13 m wheel diameter,
#: 0.63 m long, 0.48 m wide (Mars Pathfinder rover fact sheets). The mass split between
#: chassis, rockers, bogies and wheels is our assumption.
PRESETS: dict[str, RockerBogieParams] = {
    "prototype": RockerBogieParams(),
    "mer": RockerBogieParams(
        chassis_mass=155.0, chassis_length=1.4, chassis_width=1.0, chassis_height=0.3,
        chassis_com_above_pivot=0.15, rocker_mass=5.0, bogie_mass=3.0, wheel_mass=1.5,
        wheel_radius=0.125, wheel_width=0.16, front_x=0.70, middle_x=0.0, rear_x=-0.70,
        track=1.2, rocker_pivot_height=0.45, bogie_pivot_height=0.2,
    ),
    "sojourner": RockerBogieParams(
        chassis_mass=8.4, chassis_length=0.48, chassis_width=0.3, chassis_height=0.12,
        chassis_com_above_pivot=0.05, rocker_mass=0.4, bogie_mass=0.25, wheel_mass=0.3,
        wheel_radius=0.065, wheel_width=0.07, front_x=0.24, middle_x=0.0, rear_x=-0.24,
        track=0.45, rocker_pivot_height=0.15, bogie_pivot_height=0.08,
    ),
}

def _fields(p: RockerBogieParams) -> dict[str, float]:
    """``dataclasses.asdict`` of the (flat, float) parameters, without its deep copies."""
    return {f.name: getattr(p, f.name) for f in fields(p)}


SIDES = (("left", 1.0), ("right", -1.0))
WHEEL_POSITIONS = ("front", "middle", "rear")


def rocker_bogie(
    params: RockerBogieParams | str | None = None, **overrides
) -> MultibodyModel:
    """Build the six-wheel rocker-bogie rover as a :class:`MultibodyModel`.

    Parameters
    ----------
    params : RockerBogieParams or str, optional
        Parameters, or a preset name (``"prototype"`` (default, ~20 kg), ``"mer"``
        (~180 kg), ``"sojourner"`` (~11.5 kg)).
    **overrides
        Field values replacing those of ``params``.

    Returns
    -------
    MultibodyModel
        nq = 7 + 4 + 6 = 17, nv = 16; wheels ``"<side>_<pos>"`` with frames
        ``"wheel_<side>_<pos>"``; ``loop_closure`` (row ``"differential"``);
        ``lockable_joints`` rockers and bogies; ``params`` with ``q_nominal`` (six wheels on
        flat ground at z = 0), ``total_mass`` and ``planar=False``.

    Raises
    ------
    ModelError
        Unknown preset or parameter, non-positive mass or length, inconsistent geometry.
    """
    p = _params(params, overrides)
    bodies, wheel_names = _layout(p)
    model = pin.Model()
    model.name = "rocker_bogie"
    add_bodies(model, bodies)
    wheels = [Wheel(name=w, frame=f"wheel_{w}", radius=p.wheel_radius, width=p.wheel_width)
              for w in wheel_names]
    q_nominal = _nominal(p, pin.neutral(model))
    loop = LinearLoopClosure.from_model(model, ("rocker_left", "rocker_right"), ((1.0, 1.0),))
    info = _fields(p) | {
        "planar": False,
        "total_mass": p.total_mass,
        "q_nominal": q_nominal.tolist(),
        "builder": "rocker_bogie",
    }
    return MultibodyModel(
        model=model, name="rocker_bogie", wheels=wheels, loop_closure=loop,
        loop_names=["differential"],
        lockable_joints=["rocker_left", "rocker_right", "bogie_left", "bogie_right"],
        params=info,
    )


def _params(params, overrides) -> RockerBogieParams:
    """The parameters of :func:`rocker_bogie` (a preset name, with overrides), checked."""
    if params is None:
        params = PRESETS["prototype"]
    elif isinstance(params, str):
        if params not in PRESETS:
            raise ModelError(f"unknown rocker_bogie preset {params!r}; presets: {sorted(PRESETS)}")
        params = PRESETS[params]
    if overrides:
        known = {f.name for f in fields(RockerBogieParams)}
        bad = sorted(set(overrides) - known)
        if bad:
            raise ModelError(f"unknown rocker_bogie parameter(s) {bad}; known: {sorted(known)}")
        params = RockerBogieParams(**{**_fields(params), **overrides})
    return params


def _layout(p) -> tuple[list[Body], list[str]]:
    """Bodies (in the order they are added) and wheel names of the rover of parameters
    ``p``: :class:`RockerBogieParams`, or the same fields as (k,) arrays (a family)."""
    r = p.wheel_radius
    bodies = [Body(-1, "FreeFlyer", (0, 0, 0), "root_joint", "chassis", p.chassis_mass,
                   inertia=box_inertia(p.chassis_mass, p.chassis_length, p.chassis_width,
                                       p.chassis_height))]
    Iw = wheel_inertia(p.wheel_mass, r, p.wheel_width)
    rh, bh, bx = p.rocker_pivot_height, p.bogie_pivot_height, _bogie_x(p)
    rocker_com = ((p.front_x + bx) / 3.0, 0.0, -(rh + (rh - bh)) / 3.0)
    wheels: list[str] = []

    def add_wheel(parent, side, pos, xyz):
        bodies.append(Body(parent, "RY", xyz, f"wheel_{side}_{pos}", f"wheel_{side}_{pos}_link",
                           p.wheel_mass, inertia=Iw))
        wheels.append(f"{side}_{pos}")

    for side, sy in SIDES:
        jr = len(bodies)
        bodies.append(Body(0, "RY", (-p.com_x, sy * 0.5 * p.track, -p.chassis_com_above_pivot),
                           f"rocker_{side}", f"rocker_{side}_link", p.rocker_mass,
                           com=rocker_com, inertia=rod_inertia(p.rocker_mass, p.front_x - bx)))
        # children in alphabetical order of joint names (bogie_ < wheel_), the order of
        # Pinocchio's URDF parser, so that an export loads back with the same q layout
        jb = len(bodies)
        bodies.append(Body(jr, "RY", (bx, 0.0, -(rh - bh)), f"bogie_{side}",
                           f"bogie_{side}_link", p.bogie_mass, com=(0.0, 0.0, -0.5 * bh),
                           inertia=rod_inertia(p.bogie_mass, p.middle_x - p.rear_x)))
        add_wheel(jb, side, "middle", (p.middle_x - bx, 0.0, -bh))
        add_wheel(jb, side, "rear", (p.rear_x - bx, 0.0, -bh))
        add_wheel(jr, side, "front", (p.front_x, 0.0, -rh))
    return bodies, wheels


def _nominal(p, q_neutral) -> np.ndarray:
    """``q_nominal``: six wheels on flat ground at z = 0 (a batch for arrays ``p``)."""
    z = p.wheel_radius + p.rocker_pivot_height + p.chassis_com_above_pivot
    q = np.array(np.broadcast_to(q_neutral, (*np.shape(z), len(q_neutral))), dtype=float)
    q[..., 2] = z
    return q


def rocker_bogie_numbers(preset: str | None, params: Sequence[Mapping]) -> FamilyNumbers:
    """The numbers of the rovers ``rocker_bogie(preset, **params[i])`` without building
    them (:class:`~roverimpact.models.family.ModelFamily` writes them into one model of
    the family), each parameter set checked as :func:`rocker_bogie` checks it.

    Raises
    ------
    ModelError
        As :func:`rocker_bogie`, for the first bad parameter set.
    """
    base = _fields(_params(preset, {}))
    params = list(params)
    k = len(params)
    p = family_columns(base, params)
    ok = (p is not None and numbers_ok(p, _POSITIVE, _FINITE)
          and bool(np.all(_axles_ordered(p))) and bool(np.all(_pivots_ordered(p))))
    if not ok:  # a bad parameter set: RockerBogieParams says which (raises)
        ps = [_params(preset, dict(ov)) for ov in params]
        p = SimpleNamespace(**{name: np.array([getattr(x, name) for x in ps], dtype=float)
                               for name in base})
    bodies, wheels = _layout(p)
    q_nominal = _nominal(p, _neutral())
    return FamilyNumbers.of_layout(bodies, k, q_nominal, [p.wheel_radius] * len(wheels))


@functools.lru_cache(maxsize=1)
def _neutral() -> np.ndarray:
    """``pin.neutral`` of the rover (the same for every parameter set)."""
    q = pin.neutral(rocker_bogie().model)
    q.flags.writeable = False
    return q
