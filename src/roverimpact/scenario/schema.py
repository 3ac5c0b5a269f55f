r"""Impact scenarios: from a physical description to (M, A, v) just before impact.

A :class:`Scenario` (pydantic v2, unknown keys are errors) names a model (a built-in
rover with parameters, or a URDF/MJCF file), a configuration, a velocity, which
constraints are active and the obstacle contact. :meth:`ImpactSetup.from_scenario` evaluates the
model with Pinocchio and returns an :class:`ImpactSetup` (M, A, v, labels, ...);
:meth:`ImpactSetup.partition` returns the effective kinetic energy :math:`T_c^-`.

Impact angle convention (DETC2014-35554, Fig. 1): for a rover driving along its heading
:math:`\hat x_h` (world +x for the planar rover), the outward normal of the obstacle face
at the contact point is

.. math::  n(\beta) = -\sin\beta\,\hat x_h + \cos\beta\,\hat z,

so :math:`\beta = 0` is a horizontal face (top of a step) and :math:`\beta = 90^\circ` a
vertical wall facing the rover. :math:`\beta` is given in **degrees** in files and on the
command line, radians inside. The obstacle row is :math:`a = n^T J_p` (``a v < 0`` when
approaching) and the normal approach speed is :math:`v_n = -a v`.

TOML layout (see ``examples/*.toml``)::

    description = "..."
    constraints = "auto"           # or "all", or a list of row labels ["ground:rear:normal"]
    [model]        name = "rover2d" | "rocker_bogie"  or  file = "arm.urdf"
                   preset = "mer"; floating_base = false
    [model.params] h = 0.4 ...     # builder parameters (SI)
    [configuration] joints = {rocker = 0.1}; base = {x = 0, z = 0.3, pitch_deg = 5}
    [velocity]     u = 0.5; joints = {...}; base_linear = [..]; base_angular = [..]
    [contacts]     ground_wheels = "others" | ["rear"]; ground = "normal" | "noslip"
                   locked = ["rocker"]; loop_closure = true
    [obstacle]     wheel = "front" | frame = "panda_hand"; point = [0, 0, 0.1]
                   beta_deg = 45  |  normal = [-1, 0, 0]
    [contact_law]  name = "hunt-crossley"; k = 1e6; e = 0.8; n = 1.5   (the obstacle's law)
    [band]         k = [5e6, 2e7]; e = [0.5, 1.0]; n = 3   (F_lo, F_hi of studies' F_pred_refined)
    [terrain]      file = "dem.npy"; spacing = 0.05  |  plane = {normal = [..]}
                   function = "my_terrain:h"; pose = true   (default: the plane z = 0)
                   [terrain.wheels.left_front] height = 0.1; normal = [..]
    [simulation]   gravity = "mars"; mu = 0.3; t_after = 0.05; ...   (roverimpact simulate)
                   [simulation.ground_contact] name = "hunt-crossley"; k = 1e7; e = 0.2
                   [simulation.springs.rocker] k = 50.0; c = 2.0

Every command reads the same file and ignores the tables it does not use: ``energy``
and ``draw`` leave ``[simulation]`` alone, ``simulate`` takes the speed from
``[velocity] u``, the face from ``[obstacle]``, the law from ``[contact_law]`` and the
rows of its T_c^- from ``[contacts]`` and ``constraints``.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from .._schema import StrictModel, validate
from ..exceptions import ConfigError

__all__ = [
    "GRAVITY",
    "BandSpec",
    "ContactLawSpec",
    "IntegratorSpec",
    "JointSpring",
    "Scenario",
    "SimulationSpec",
    "band_laws",
    "load_scenario",
    "scenario_from_dict",
]

Vec3 = tuple[float, float, float]

#: Gravity presets [m/s^2], magnitude of the acceleration along -z.
GRAVITY: dict[str, float] = {"earth": 9.81, "mars": 3.721, "moon": 1.62, "none": 0.0}


def check_gravity(g: str | float) -> str | float:
    """A ``gravity`` setting: a preset name of :data:`GRAVITY` (lower-cased) or a finite
    magnitude >= 0 [m/s^2] (ValueError otherwise, for the schemas' validators)."""
    if isinstance(g, str):
        if g.lower() not in GRAVITY:
            raise ValueError(f"unknown gravity preset {g!r}; use one of {sorted(GRAVITY)} "
                             "or a number in m/s^2")
        return g.lower()
    if not (math.isfinite(g) and g >= 0.0):
        raise ValueError(f"gravity must be a finite magnitude >= 0 m/s^2, got {g}")
    return g


def gravity_magnitude(g: str | float) -> float:
    """The magnitude [m/s^2] of a checked ``gravity`` setting (:func:`check_gravity`)."""
    return GRAVITY[g] if isinstance(g, str) else float(g)


class WheelSpec(StrictModel):
    """A wheel of a robot file: ``[model.wheels.NAME]``.

    ``frame``: the link (body), joint, site or geom at the wheel centre; ``radius`` [m]
    (default: the radius of a sphere or cylinder geom of that body in an MJCF file);
    ``axis``: spin axis in that frame (default: the axis of the revolute joint that carries
    the frame, else y); ``width`` [m] (inertia and drawings only); ``spin``: the joint
    whose rate is the wheel's spin (default: that revolute joint, if any). Names are
    the file's own.
    """

    frame: str
    radius: float | None = Field(None, gt=0.0, allow_inf_nan=False)
    axis: Vec3 | None = None
    width: float = Field(0.0, ge=0.0, allow_inf_nan=False)
    spin: str | None = None

    @field_validator("axis")
    @classmethod
    def _axis(cls, a):
        if a is not None:
            av = np.asarray(a, dtype=float)
            if not np.all(np.isfinite(av)) or not np.linalg.norm(av) > 1e-12:
                raise ValueError(f"a wheel's axis must be a non-zero finite vector, got {list(a)}")
        return a


class BaseKindSpec(StrictModel):
    """How the root of a robot file moves: ``[model.base]``.

    ``kind``: ``"floating"`` (a free-flyer root is added to a URDF; an MJCF free joint is
    one already), ``"planar"`` (three joints move the base in the x-z plane: ``joints`` =
    [x slide, z slide, pitch hinge], default the file's first three joints), or
    ``"fixed"`` (the root stays where the file places it: an MJCF file's free joints are
    removed, a URDF gets no free-flyer). Default: from the file (a free joint is
    floating; a root chain of an x slide, a z slide and a y hinge is planar; else fixed).
    """

    kind: Literal["floating", "planar", "fixed"]
    joints: list[str] | None = None

    @model_validator(mode="after")
    def _joints(self):
        if self.joints is not None and (self.kind != "planar" or len(self.joints) != 3):
            raise ValueError("model.base.joints names the three joints of a planar base "
                             "(x slide, z slide, pitch hinge), with kind = 'planar'")
        return self


class ModelSpec(StrictModel):
    """Which model: a built-in rover (``name``) or a robot file (``file``), and for a file
    its ``wheels`` and ``base`` (declared here, not in the robot file)."""

    name: Literal["rover2d", "rocker_bogie", "rigid_body"] | None = None
    file: str | None = None
    preset: str | None = None
    floating_base: bool | None = None
    params: dict[str, float | int | bool | str] = Field(default_factory=dict)
    wheels: dict[str, WheelSpec] = Field(default_factory=dict)
    base: BaseKindSpec | None = None

    @model_validator(mode="after")
    def _one_source(self):
        if (self.name is None) == (self.file is None):
            raise ValueError("give exactly one of model.name (built-in rover) or model.file")
        if self.preset is not None and self.name != "rocker_bogie":
            raise ValueError("model.preset applies to name = 'rocker_bogie' only")
        if self.file is not None and self.params:
            raise ValueError("model.params apply to built-in rovers only")
        if self.name is not None and (self.wheels or self.base is not None):
            raise ValueError("model.wheels and model.base declare a robot file's wheels and "
                             "base; the built-in rovers have their own")
        if self.base is not None and self.floating_base is not None:
            raise ValueError("give model.base.kind or model.floating_base, not both")
        return self


class BaseSpec(StrictModel):
    """Base pose (world): position [m] and roll/pitch/yaw [deg]; unset = model's nominal
    (each coordinate and angle on its own: ``pitch_deg = 5`` keeps the nominal roll and
    yaw, e.g. the orientation an MJCF file gives its free body)."""

    x: float | None = None
    y: float | None = None
    z: float | None = None
    roll_deg: float | None = None
    pitch_deg: float | None = None
    yaw_deg: float | None = None


JointValue = float | list[float]


class ConfigurationSpec(StrictModel):
    """Joint values by the file's joint names and the base pose.

    A 1-DoF joint (revolute, prismatic, continuous) takes a number [rad or m]; a
    multi-DoF joint a list in MuJoCo's order: a free joint ``[x, y, z, qw, qx, qy, qz]``,
    a ball joint ``[qw, qx, qy, qz]``.
    """

    joints: dict[str, JointValue] = Field(default_factory=dict)
    base: BaseSpec = Field(default_factory=BaseSpec)


class VelocitySpec(StrictModel):
    """Velocity just before impact.

    ``u`` [m/s] drives the rover along its heading with every wheel rolling (spin u/r);
    ``joints`` [rad/s or m/s] sets joint rates by name (after ``u``): a number for a
    1-DoF joint, a list in MuJoCo's order for a multi-DoF one (a free joint: linear
    velocity in world axes, then angular velocity in the body frame; a ball joint: angular
    velocity in the body frame); ``base_linear`` [m/s] and ``base_angular`` [rad/s] set the
    base twist in world axes (replacing what ``u`` set for the base).
    """

    u: float = 0.0
    joints: dict[str, JointValue] = Field(default_factory=dict)
    base_linear: Vec3 | None = None
    base_angular: Vec3 | None = None


class LoopSpec(StrictModel):
    """A closed kinematic loop, ``[[contacts.loops]]``: a point of ``frame_a`` and a point of
    ``frame_b`` (in those frames' coordinates, m) that coincide (``kind = "point"``, three
    rows: a pin joint, a spherical joint), or stay ``length`` apart (``kind = "distance"``,
    one row: a rod or a turnbuckle between two ball joints; default length: their distance
    in the scenario's configuration). The rows join the model's own loop closure, in the
    indicator and in the simulator alike (label ``"loop:<name>"``). The scenario's
    configuration must close the loop (a gap above 1e-6 m is refused, naming the loop),
    and joint rates must not open it.
    """

    name: str
    kind: Literal["point", "distance"]
    frame_a: str
    point_a: Vec3 = (0.0, 0.0, 0.0)
    frame_b: str
    point_b: Vec3 = (0.0, 0.0, 0.0)
    length: float | None = Field(None, gt=0.0, allow_inf_nan=False)

    @model_validator(mode="after")
    def _length(self):
        if self.length is not None and self.kind != "distance":
            raise ValueError(f"contacts.loops {self.name!r}: length applies to kind = "
                             "'distance' only")
        return self


class PointSpec(StrictModel):
    """A further contact, ``[[contacts.points]]``: ``point`` (in ``frame``, m) against a
    surface of outward ``normal`` (world); with ``tangential = true`` its no-slip rows too.
    It joins the candidates like a ground contact (labels ``"point:<name>:normal"``,
    ``":long"``, ``":lat"``), so the automatic active set decides whether it holds.
    """

    frame: str
    point: Vec3 = (0.0, 0.0, 0.0)
    normal: Vec3
    name: str | None = None
    tangential: bool = False

    @field_validator("normal")
    @classmethod
    def _unit(cls, n):
        nv = np.asarray(n, dtype=float)
        if not np.all(np.isfinite(nv)) or not np.linalg.norm(nv) > 1e-12:
            raise ValueError(f"contacts.points normal must be a non-zero finite vector, got "
                             f"{list(n)}")
        return n


class ContactsSpec(StrictModel):
    """Candidate constraint rows besides the obstacle.

    ``ground_wheels``: wheels on flat ground (z = 0); ``"others"`` = every wheel except
    the one hitting the obstacle. ``ground``: how the wheels meet the ground through the
    impact: ``"normal"`` (frictionless: normal rows only, the wheels may slide),
    ``"noslip"`` (normal + tangential rows, held as bilateral rows while the wheel's
    normal contact holds) or ``"coulomb"`` (Coulomb friction ``mu``: a wheel sticks or
    slides as the impulses decide). ``mu``: the friction coefficient (one number, or
    ``{"ground:<wheel>": mu, "default": mu}``); the simulator uses it too unless
    ``simulation.mu`` is given.
    ``locked``: joints held fixed. ``loop_closure``: include the model's closed-loop rows
    (rocker-bogie differential, mimic joints, MJCF joint and tendon equalities), if it has
    any: the default ``true`` adds no row to a model without loops (an explicit ``true``
    cannot be told from the default once a study has normalized its scenarios, so it is
    not refused either). ``loops``: closed loops declared here
    (:class:`LoopSpec`); ``points``: further contacts (:class:`PointSpec`).
    """

    ground_wheels: Literal["others"] | list[str] = "others"
    ground: Literal["normal", "noslip", "coulomb"] = "normal"
    mu: float | dict[str, float] | None = None
    locked: list[str] = Field(default_factory=list)
    loop_closure: bool = True
    loops: list[LoopSpec] = Field(default_factory=list)
    points: list[PointSpec] = Field(default_factory=list)

    @model_validator(mode="after")
    def _mu(self):
        values = (list(self.mu.values()) if isinstance(self.mu, dict)
                  else [] if self.mu is None else [self.mu])
        if any(not (x >= 0.0) for x in values):  # inf allowed: no slip
            raise ValueError(f"contacts.mu must be >= 0, got {self.mu}")
        if self.ground == "coulomb" and self.mu is None:
            raise ValueError('contacts.ground = "coulomb" needs contacts.mu (the friction '
                             "coefficient)")
        return self


class ObstacleSpec(StrictModel):
    """The impact contact: a wheel rim or a point of a frame, and the obstacle normal."""

    wheel: str | None = None
    frame: str | None = None
    point: Vec3 = (0.0, 0.0, 0.0)
    normal: Vec3 | None = None
    beta_deg: float | None = None

    @model_validator(mode="after")
    def _one_each(self):
        if (self.wheel is None) == (self.frame is None):
            raise ValueError("obstacle: give exactly one of wheel or frame")
        if (self.normal is None) == (self.beta_deg is None):
            raise ValueError("obstacle: give exactly one of normal or beta_deg")
        if self.beta_deg is not None and not (0.0 <= self.beta_deg <= 90.0):
            raise ValueError(f"obstacle.beta_deg must be in [0, 90] degrees, got {self.beta_deg}")
        if self.normal is not None:
            nv = np.asarray(self.normal, dtype=float)
            if not np.all(np.isfinite(nv)) or not np.linalg.norm(nv) > 1e-12:
                raise ValueError(f"obstacle.normal must be a non-zero finite vector, got "
                                 f"{list(self.normal)}")
        return self


class ContactLawSpec(StrictModel):
    """A contact law of :mod:`roverimpact.contact`, by name and parameters (one schema for
    the obstacle's ``[contact_law]`` and the simulator's ``[simulation.ground_contact]``).

    ``k`` is the stiffness [N/m^n], ``e`` the coefficient of restitution, ``n`` the
    exponent of the indentation, ``c`` the damping of ``kelvin-voigt`` [N s/m]; a parameter
    left out takes the law's own value (see :func:`roverimpact.contact.get_law`).
    ``v_ref`` [m/s] is the reference penetration velocity that laws with a ``v_i``
    argument (Hunt-Crossley) receive in the simulator for contacts that do not start with
    an impact (wheels resting on the ground); for the obstacle, ``v_i`` is the normal
    approach speed at first contact.
    """

    name: str = "hunt-crossley"
    k: float = Field(1.0e7, gt=0.0, allow_inf_nan=False)
    e: float | None = Field(None, ge=0.0, le=1.0)
    n: float | None = Field(None, gt=0.0, allow_inf_nan=False)
    c: float | None = Field(None, ge=0.0, allow_inf_nan=False)
    v_ref: float = Field(0.1, gt=0.0, allow_inf_nan=False)

    def to_law(self, m_eff: float | None = None):
        """The law object (:func:`roverimpact.contact.get_law`)."""
        from ..contact import get_law

        return get_law(self.name, k=self.k, e=self.e, n=self.n, c=self.c, m_eff=m_eff)


class BandSpec(StrictModel):
    """``[band]``: ranges of the law's stiffness ``k`` [N/m^n] and restitution ``e``; ``n``
    values of each (k log-spaced). In a scenario (and a study's ``[base]``) it gives the
    band ``F_lo``, ``F_hi`` of the predicted peak force ``F_pred_refined``; in a traverse,
    that of ``F_pred`` (:func:`band_laws`)."""

    k: tuple[float, float] | None = None
    e: tuple[float, float] | None = None
    n: int = Field(3, ge=1, le=20)

    @model_validator(mode="after")
    def _ranges(self):
        if self.k is None and self.e is None:
            raise ValueError("band: give k = [lo, hi] and/or e = [lo, hi]")
        if self.k is not None and not (0 < self.k[0] <= self.k[1] < math.inf):
            raise ValueError(f"band.k must be 0 < lo <= hi, got {list(self.k)}")
        if self.e is not None and not (0 <= self.e[0] <= self.e[1] <= 1):
            raise ValueError(f"band.e must be 0 <= lo <= hi <= 1, got {list(self.e)}")
        return self


def band_laws(spec, k_range=None, e_range=None, n: int = 3) -> list[tuple[float, float | None]]:
    """The ``(k, e)`` corners and interior points of the band: ``n`` values of ``k``
    (log-spaced over ``k_range``) times ``n`` of ``e`` (linear over ``e_range``); a range
    not given is the law's own value."""
    if n < 1:
        raise ConfigError(f"band points must be >= 1, got {n}")
    ks = [spec.k] if k_range is None else list(np.geomspace(k_range[0], k_range[1], n))
    es = [spec.e] if e_range is None else list(np.linspace(e_range[0], e_range[1], n))
    return [(float(a), None if b is None else float(b)) for a, b in itertools.product(ks, es)]


class JointSpring(StrictModel):
    """Linear spring-damper on a 1-dof joint: ``tau = -k (q - q0) - c v``.

    ``k`` in N m/rad (N/m for prismatic), ``c`` in N m s/rad; ``q0`` is the rest value
    (default: the joint value in the model's reference configuration).
    """

    k: float = Field(0.0, ge=0.0, allow_inf_nan=False)
    c: float = Field(0.0, ge=0.0, allow_inf_nan=False)
    q0: float | None = None


class IntegratorSpec(StrictModel):
    """Adaptive integrator settings (scipy ``solve_ivp``).

    The defaults make the peak obstacle force converge to well below 1 % (docs/simulate.md).
    """

    method: Literal["LSODA", "Radau", "BDF", "RK45", "DOP853"] = "LSODA"
    rtol: float = Field(1e-6, gt=0.0, lt=1.0)
    atol: float = Field(1e-8, gt=0.0)
    max_step: float = Field(math.inf, gt=0.0)
    first_step: float | None = Field(None, gt=0.0)
    baumgarte: float = Field(20.0, ge=0.0, allow_inf_nan=False)


#: keys that lived in ``[simulation]`` before one schema served every command
_MOVED = {
    "speed": "the driving speed is [velocity] u",
    "beta_deg": "the face angle is [obstacle] beta_deg",
    "obstacle": "the obstacle's law is [contact_law]",
    "obstacle_wheels": "the obstacle is in front of [obstacle] wheel",
    "indicator": "the rows of T_c^- are [contacts] and constraints",
}


class SimulationSpec(StrictModel):
    """The ``[simulation]`` table: what the compliant-contact simulator needs beyond the
    scenario (see :class:`roverimpact.simulate.SimulationConfig` for the meaning of each
    key; speed, face angle, obstacle law and the rows of T_c^- come from the scenario).
    """

    gravity: str | float = "earth"
    distance: float = Field(1e-3, allow_inf_nan=False)
    obstacle_x: float | None = Field(None, allow_inf_nan=False)
    obstacle_height: float = Field(math.inf, gt=0.0)
    ground: bool = True
    settle: bool = True
    ground_contact: ContactLawSpec = ContactLawSpec(e=0.2)
    mu: float = Field(0.0, ge=0.0, allow_inf_nan=False)
    v_slip: float = Field(1e-3, gt=0.0, allow_inf_nan=False)
    springs: dict[str, JointSpring] = Field(default_factory=dict)
    t_max: float = Field(1.0, gt=0.0, allow_inf_nan=False)
    t_after: float = Field(0.2, gt=0.0, allow_inf_nan=False)
    integrator: IntegratorSpec = Field(default_factory=IntegratorSpec)

    @model_validator(mode="before")
    @classmethod
    def _moved_keys(cls, data: Any):
        if cls is SimulationSpec and isinstance(data, dict):
            moved = [f"simulation.{k}: {why}" for k, why in _MOVED.items() if k in data]
            if moved:
                raise ValueError("moved out of [simulation]: " + "; ".join(moved))
        return data

    @field_validator("gravity")
    @classmethod
    def _gravity(cls, g):
        return check_gravity(g)

    @field_validator("distance")
    @classmethod
    def _distance(cls, d):
        if d < 0.0:
            raise ValueError(f"distance must be >= 0 m, got {d}: a negative gap puts the "
                             "obstacle behind or inside the rover")
        return d

    @property
    def g(self) -> float:
        """Gravity magnitude [m/s^2]."""
        return gravity_magnitude(self.gravity)


class PlaneSpec(StrictModel):
    """A plane through ``point`` [m] with outward ``normal`` (world, pointing up)."""

    point: Vec3 = (0.0, 0.0, 0.0)
    normal: Vec3 = (0.0, 0.0, 1.0)


class WheelGroundSpec(StrictModel):
    """The ground under one wheel, ``[terrain.wheels.NAME]``: a plane through the point
    at world height ``z = height`` [m] straight below the wheel centre (an absolute
    height, like the terrain's own: not relative to the terrain under the wheel), with
    outward ``normal`` (world, default up)."""

    height: float = Field(0.0, allow_inf_nan=False)
    normal: Vec3 = (0.0, 0.0, 1.0)


class TerrainSpec(StrictModel):
    """The ground, ``[terrain]`` (without it: the plane z = 0).

    One of ``plane`` (``{point, normal}``), ``file`` (a height field: ``.npy``, ``.csv``
    or ``.tif``/``.tiff`` GeoTIFF, with ``spacing`` [m] (one number or ``[dx, dy]``) and
    ``origin`` [m] of its first node, default (0, 0); rows are y, columns x, see
    docs/terrain.md; a GeoTIFF carries its own spacing and origin: giving them is refused;
    ``nodata``: the value (or values) marking its cells without data, refused like -9999
    and NaN, :meth:`~roverimpact.models.terrain.HeightField.from_file`) or
    ``function`` (a vectorised ``h(x, y)`` [m]: ``"package.module:name"`` importable, or
    ``"file.py:name"`` relative to the scenario's folder); else the plane z = 0.
    ``wheels``: a plane of its own under some wheels (:class:`WheelGroundSpec`), the
    others on the terrain above.

    ``pose`` (default true): place the rover on the terrain before the impact
    (:func:`roverimpact.models.pose.pose_on_terrain`): the base keeps its x, y and yaw
    from ``[configuration]``, its height, roll, pitch and the suspension are solved so
    that ``pose_wheels`` (default: every wheel) touch. With ``pose = false`` the
    configuration is taken as given, and a ground wheel more than ``gap_tol`` [m] off
    the terrain is refused.
    """

    plane: PlaneSpec | None = None
    file: str | None = None
    spacing: float | tuple[float, float] | None = None
    origin: tuple[float, float] | None = None
    nodata: float | list[float] | None = None
    function: str | None = None
    wheels: dict[str, WheelGroundSpec] = Field(default_factory=dict)
    pose: bool = True
    pose_wheels: list[str] | None = None
    gap_tol: float = Field(1e-6, gt=0.0, allow_inf_nan=False)

    @model_validator(mode="after")
    def _one_kind(self):
        given = [k for k in ("plane", "file", "function") if getattr(self, k) is not None]
        if len(given) > 1:
            raise ValueError(f"terrain: give one of plane, file, function (got {given})")
        if self.file is not None and self.spacing is None and not self.file.lower().endswith(
                (".tif", ".tiff")):
            raise ValueError("terrain.file needs spacing (the grid step, m)")
        for key in ("spacing", "origin", "nodata"):
            if getattr(self, key) is not None and self.file is None:
                raise ValueError(f"terrain.{key} applies to a height-field file only")
        if self.file is not None and self.file.lower().endswith((".tif", ".tiff")):
            given = [k for k in ("spacing", "origin") if getattr(self, k) is not None]
            if given:
                raise ValueError(f"terrain.{' and terrain.'.join(given)}: a GeoTIFF "
                                 f"({self.file!r}) carries its own grid spacing and origin "
                                 "(they would be ignored): remove them")
        sp = np.atleast_1d(np.asarray(self.spacing if self.spacing is not None else 1.0, float))
        if not np.all(np.isfinite(sp) & (sp > 0.0)):
            raise ValueError(f"terrain.spacing must be > 0 m and finite, got {self.spacing}")
        if self.function is not None and ":" not in self.function:
            raise ValueError(f"terrain.function must be 'module:name', got {self.function!r}")
        return self


class Scenario(StrictModel):
    """A complete impact scenario; see the module docstring for the TOML layout.

    ``constraints`` selects the active rows among the candidates: ``"auto"`` (default: the
    contacts that hold through the impact, :func:`roverimpact.scenario.build.holding_rows`),
    ``"all"`` or a list of labels (``fnmatch`` patterns allowed, e.g.
    ``"ground:*:normal"``); the obstacle row is always active. The choice is made by
    :func:`roverimpact.scenario.choose_active_rows`. ``simulation`` holds the simulator's
    settings (``roverimpact simulate``); other commands ignore it.
    """

    description: str = ""
    model: ModelSpec
    configuration: ConfigurationSpec = Field(default_factory=ConfigurationSpec)
    velocity: VelocitySpec = Field(default_factory=VelocitySpec)
    contacts: ContactsSpec = Field(default_factory=ContactsSpec)
    obstacle: ObstacleSpec
    constraints: Literal["auto", "all"] | list[str] = "auto"
    contact_law: ContactLawSpec | None = None
    simulation: SimulationSpec | None = None
    terrain: TerrainSpec | None = None
    band: BandSpec | None = None

    @model_validator(mode="after")
    def _band_needs_law(self):
        if self.band is not None and self.contact_law is None:
            raise ValueError("[band] needs [contact_law] (the law whose k and e vary)")
        if self.contacts.ground == "coulomb" and self.constraints != "auto":
            raise ValueError(
                'contacts.ground = "coulomb" needs constraints = "auto": the friction cone '
                "decides which contacts stick, slide or separate; with "
                f"{self.constraints!r} the tangent rows would be held whatever mu (as "
                'ground = "noslip"): use ground = "noslip" or "normal" for that')
        return self

    @classmethod
    def from_mujoco(cls, mj_model, mj_data, /, *, file: str | Path, obstacle: dict,
                    contacts: dict | None = None, **tables) -> Scenario:
        """The scenario of a MuJoCo state: every named joint's position and velocity (by the
        file's joint names, in MuJoCo's order), the model ``file`` the ``model`` was
        compiled from, and the given ``obstacle`` / ``contacts`` tables.

        Parameters
        ----------
        mj_model, mj_data : mujoco.MjModel, mujoco.MjData
            E.g. at the instant a MuJoCo run first touches the obstacle.
        file : str or Path
            The MJCF (or URDF) file of ``model``.
        obstacle, contacts : dict
            The ``[obstacle]`` and ``[contacts]`` tables (e.g. ``{"wheel": "front",
            "normal": [nx, ny, nz]}``).
        **tables
            Further tables or keys: ``model`` (options such as ``wheels`` and ``base``;
            ``file`` is set), ``constraints``, ``contact_law``, ``simulation``, ...

        Raises
        ------
        ConfigError
            A joint without a name (the scenario addresses joints by name).
        """
        import mujoco

        model, data = mj_model, mj_data
        q, v = {}, {}
        for j in range(model.njnt):
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
            if not name:
                raise ConfigError(f"joint {j} of the MuJoCo model has no name: the scenario "
                                  "addresses joints by name")
            t = int(model.jnt_type[j])
            nq, nv = {0: (7, 6), 1: (4, 3)}.get(t, (1, 1))
            a, b = int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j])
            qs = [float(x) for x in data.qpos[a:a + nq]]
            vs = [float(x) for x in data.qvel[b:b + nv]]
            q[name] = qs if nq > 1 else qs[0]
            v[name] = vs if nv > 1 else vs[0]
        model_table = dict(tables.pop("model", {})) | {"file": str(file)}
        raw = {"model": model_table, "configuration": {"joints": q},
               "velocity": {"joints": v}, "obstacle": dict(obstacle),
               "contacts": dict(contacts or {})} | tables
        return validate(cls, raw, "scenario from MuJoCo", "invalid scenario: ")

    def with_beta(self, beta_deg: float) -> Scenario:
        """Copy with the obstacle normal given by ``beta_deg`` (degrees)."""
        obs = self.obstacle.model_copy(update={"beta_deg": beta_deg, "normal": None})
        ObstacleSpec.model_validate(obs.model_dump())
        return self.model_copy(update={"obstacle": obs})


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario TOML file.

    A relative ``model.file`` or ``terrain.file`` is made relative to the scenario file's
    folder.

    Raises
    ------
    ConfigError
        Missing or malformed file, unknown keys, bad values (one message naming them).
    """
    from .._io import read_toml

    path = Path(path)
    sc = scenario_from_dict(read_toml(path), where=str(path))
    model = sc.model
    f = model.file
    if f is not None and not is_example_robot_name(f) and not Path(f).is_absolute():
        model = model.model_copy(update={"file": str(path.parent / model.file)})
        sc = sc.model_copy(update={"model": model})
    t = sc.terrain
    if t is not None:
        upd = {}
        if t.file is not None and not Path(t.file).is_absolute():
            upd["file"] = str(path.parent / t.file)
        if t.function is not None:
            mod, _, name = t.function.rpartition(":")
            if mod.endswith(".py") and not Path(mod).is_absolute():
                upd["function"] = f"{path.parent / mod}:{name}"
        if upd:
            sc = sc.model_copy(update={"terrain": t.model_copy(update=upd)})
    return sc


def is_example_robot_name(file: str) -> bool:
    """A robot of example-robot-data (``erd:`` or ``example-robot-data:``), not a path."""
    from ..models.robot_data import is_example_robot

    return is_example_robot(file)


def scenario_from_dict(raw: dict | Scenario, *, where: str = "scenario") -> Scenario:
    """Validate a scenario given as a dict (as read from TOML)."""
    if not isinstance(raw, (dict, Scenario)):
        raise ConfigError(f"{where}: a scenario is a table of tables, got {type(raw).__name__}")
    return validate(Scenario, raw, where, "invalid scenario: ")


def as_scenario(scenario, *, where: str = "scenario") -> Scenario:
    """A :class:`Scenario` from a scenario, a dict (as read from TOML) or the path of a
    scenario TOML file: one :class:`~roverimpact.exceptions.ConfigError` otherwise."""
    if isinstance(scenario, Scenario):
        return scenario
    if isinstance(scenario, dict):
        return scenario_from_dict(scenario, where=where)
    if isinstance(scenario, (str, Path)):
        return load_scenario(scenario)
    raise ConfigError(f"{where}: expected a Scenario, a dict or the path of a scenario TOML "
                      f"file, got {type(scenario).__name__}")
