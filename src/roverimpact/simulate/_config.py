"""Typed configuration of a compliant-contact impact simulation (pydantic v2).

Lengths in m, speeds in m/s, stiffness in N/m^n, angles in degrees (user boundary only:
they are converted to radians by :meth:`SimulationConfig.beta`).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from ..exceptions import ConfigError

#: Gravity presets [m/s^2], magnitude of the acceleration along -z.
GRAVITY: dict[str, float] = {"earth": 9.81, "mars": 3.721, "moon": 1.62, "none": 0.0}

__all__ = ["GRAVITY", "ContactSpec", "IndicatorSpec", "IntegratorSpec", "JointSpring",
           "SimulationConfig", "gravity_vector"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class ContactSpec(_Strict):
    """A contact law of :mod:`roverimpact.contact`, by name and parameters.

    ``k`` is the stiffness [N/m^n], ``e`` the coefficient of restitution (None for
    ``hertz``), ``n`` the exponent (3/2 for Hertz; None for ``kelvin-voigt``), ``c`` the
    damping of ``kelvin-voigt`` [N s/m]; they go to :func:`roverimpact.contact.get_law`.
    ``v_ref`` [m/s] is the reference penetration velocity that
    laws with a ``v_i`` argument (Hunt-Crossley) receive for contacts that do not start
    with an impact (the wheels resting on the ground); for the obstacle, ``v_i`` is the
    normal approach speed at first contact.
    """

    law: str = "hunt-crossley"
    k: float = Field(1.0e7, gt=0.0, allow_inf_nan=False)
    e: float | None = Field(0.5, ge=0.0, le=1.0)
    n: float | None = Field(1.5, gt=0.0, allow_inf_nan=False)
    c: float | None = Field(None, ge=0.0, allow_inf_nan=False)
    v_ref: float = Field(0.1, gt=0.0, allow_inf_nan=False)


class JointSpring(_Strict):
    """Linear spring-damper on a 1-dof joint: ``tau = -k (q - q0) - c v``.

    ``k`` in N m/rad (N/m for prismatic), ``c`` in N m s/rad; ``q0`` is the rest value
    (default: the joint value in the model's reference configuration).
    """

    k: float = Field(0.0, ge=0.0, allow_inf_nan=False)
    c: float = Field(0.0, ge=0.0, allow_inf_nan=False)
    q0: float | None = None


class IntegratorSpec(_Strict):
    """Adaptive integrator settings (scipy ``solve_ivp``).

    The defaults make the peak obstacle force converge to well below 1 % (see
    ``tests/test_simulate_convergence.py`` and docs/simulate.md).
    """

    method: Literal["LSODA", "Radau", "BDF", "RK45", "DOP853"] = "LSODA"
    rtol: float = Field(1e-6, gt=0.0, lt=1.0)
    atol: float = Field(1e-8, gt=0.0)
    max_step: float = Field(math.inf, gt=0.0)
    first_step: float | None = Field(None, gt=0.0)
    baumgarte: float = Field(20.0, ge=0.0, allow_inf_nan=False)


class IndicatorSpec(_Strict):
    """Constraint rows of the T_c^- computed at the pre-impact state (as in a scenario).

    ``ground``: ``"normal"`` rows or ``"noslip"`` (normal + tangential) for every wheel in
    ground contact; ``locked``: joints held fixed; ``constraints``: ``"all"`` candidate
    rows, ``"auto"`` (those that hold through the impact) or a list of row labels /
    patterns, chosen by :func:`roverimpact.scenario.choose_active_rows`.
    """

    ground: Literal["normal", "noslip"] = "normal"
    locked: list[str] = Field(default_factory=list)
    constraints: Literal["all", "auto"] | list[str] = "all"


class SimulationConfig(_Strict):
    """Everything a compliant-contact impact run needs besides the model.

    Attributes
    ----------
    gravity : str or float
        ``"earth"`` (9.81), ``"mars"`` (3.721), ``"moon"`` (1.62), ``"none"`` or a
        magnitude in m/s^2 along -z.
    speed : float
        Driving speed u of the rover along +x at the start [m/s], > 0.
    distance : float
        Initial gap between the wheel nearest to the obstacle and the obstacle face [m].
    obstacle_x : float or None
        If given, the x of the foot of the obstacle face instead of ``distance`` [m].
    beta_deg : float
        Angle of the obstacle face with the ground [deg], in (0, 90]: the outward normal
        is ``n = (-sin beta, 0, cos beta)``; 90 is a vertical wall facing the rover.
    obstacle_height : float
        Height of the obstacle face above the ground [m]; contacts above it are ignored.
    obstacle_wheels : list of str or None
        Names of the wheels the obstacle is in front of (a rock in the path of one wheel,
        as in DETC2015-47747, Fig. 1); ``None``: a face across the whole path, every wheel
        can touch it. A scenario's ``obstacle.wheel`` sets it.
    ground : bool
        Whether the wheels touch the ground plane z = 0.
    settle : bool
        Solve the static equilibrium on the ground before the run.
    obstacle, ground_contact : ContactSpec
        Contact laws of the obstacle face and of the ground.
    mu : float
        Coulomb friction coefficient (obstacle and ground), regularised by ``v_slip``.
    v_slip : float
        Velocity scale of the friction regularisation ``tanh(|v_t| / v_slip)`` [m/s].
    springs : dict
        Joint name -> :class:`JointSpring` (suspension springs and dampers).
    t_max : float
        Time limit of the run [s]: if the obstacle is not touched before, SolverError.
    t_after : float
        Maximum duration simulated after the first obstacle contact [s].
    integrator : IntegratorSpec
    indicator : IndicatorSpec
        Constraint rows of T_c^- at the pre-impact state.
    """

    gravity: str | float = "earth"
    speed: float = Field(0.1, allow_inf_nan=False)
    distance: float = Field(1e-3, allow_inf_nan=False)
    obstacle_x: float | None = None
    beta_deg: float = Field(90.0, allow_inf_nan=False)
    obstacle_height: float = Field(math.inf, gt=0.0)
    obstacle_wheels: list[str] | None = None
    ground: bool = True
    settle: bool = True
    obstacle: ContactSpec = ContactSpec()
    ground_contact: ContactSpec = ContactSpec(e=0.2)
    mu: float = Field(0.0, ge=0.0, allow_inf_nan=False)
    v_slip: float = Field(1e-3, gt=0.0, allow_inf_nan=False)
    springs: dict[str, JointSpring] = Field(default_factory=dict)
    t_max: float = Field(1.0, gt=0.0, allow_inf_nan=False)
    t_after: float = Field(0.2, gt=0.0, allow_inf_nan=False)
    integrator: IntegratorSpec = IntegratorSpec()
    indicator: IndicatorSpec = IndicatorSpec()

    @field_validator("gravity")
    @classmethod
    def _gravity(cls, g):
        if isinstance(g, str):
            if g.lower() not in GRAVITY:
                raise ValueError(f"unknown gravity preset {g!r}; use one of {sorted(GRAVITY)} "
                                 "or a number in m/s^2")
            return g.lower()
        if not (math.isfinite(g) and g >= 0.0):
            raise ValueError(f"gravity must be a finite magnitude >= 0 m/s^2, got {g}")
        return g

    @field_validator("speed")
    @classmethod
    def _speed(cls, u):
        if u <= 0.0:
            raise ValueError(f"speed must be > 0 m/s (driving towards the obstacle in +x), got "
                             f"{u}: with u <= 0 the rover never reaches the obstacle")
        return u

    @field_validator("distance")
    @classmethod
    def _distance(cls, d):
        if d < 0.0:
            raise ValueError(f"distance must be >= 0 m, got {d}: a negative gap puts the "
                             "obstacle behind or inside the rover")
        return d

    @field_validator("beta_deg")
    @classmethod
    def _beta(cls, b):
        if not 0.0 < b <= 90.0:
            raise ValueError(f"beta_deg must be in (0, 90] degrees, got {b}")
        return b

    @property
    def beta(self) -> float:
        """Obstacle angle beta in radians."""
        return math.radians(self.beta_deg)

    @property
    def g(self) -> float:
        """Gravity magnitude [m/s^2]."""
        return GRAVITY[self.gravity] if isinstance(self.gravity, str) else float(self.gravity)

    @classmethod
    def from_dict(cls, data: dict, source: str = "simulation config") -> SimulationConfig:
        """Validate a dict (e.g. a TOML ``[simulation]`` table), ConfigError on failure."""
        try:
            return cls.model_validate(data)
        except ValidationError as exc:
            err = exc.errors()[0]
            loc = ".".join(str(p) for p in err["loc"]) or "(root)"
            raise ConfigError(f"{source}: {loc}: {err['msg']}") from None


def gravity_vector(g: float) -> np.ndarray:
    """Gravity acceleration vector (0, 0, -g) [m/s^2]."""
    return np.array([0.0, 0.0, -float(g)])
