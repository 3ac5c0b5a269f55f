r"""Robot arms near people: ISO/TS 15066 transient-contact speed limits and exact effective mass.

ISO/TS 15066:2016 (Annex A, power and force limiting) models a free (transient) collision
between a robot and a human body region as two masses joined by a linear spring:

.. math::

    \mu = \Big(\frac{1}{m_H} + \frac{1}{m_R}\Big)^{-1}, \qquad
    E = \frac{F^2}{2K} = \tfrac12 \mu v_{rel}^2 \quad\Rightarrow\quad
    v_{rel,max} = \frac{F_{max}}{\sqrt{\mu K}} ,

with :math:`m_H` the effective mass and :math:`K` the effective spring constant of the
body region (Table A.3), :math:`F_{max}` the permissible transient contact force (Table A.2:
twice the quasi-static force) and the robot's *reduced* mass taken crudely as

.. math::  m_R = \frac{M}{2} + m_L

(:math:`M` total mass of the moving parts of the robot, :math:`m_L` the payload).

The exact robot-side effective mass of an arm is in :mod:`roverimpact.safety.arm`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validation import as_array
from ..exceptions import InputError

__all__ = [
    "BODY_AREAS",
    "BODY_REGIONS",
    "ISO_TS_15066_SOURCE",
    "BodyArea",
    "BodyRegion",
    "body_region",
    "iso_robot_mass",
    "max_transient_speed",
    "reduced_mass",
    "transfer_energy",
]

#: Where the numbers of :data:`BODY_REGIONS` and :data:`BODY_AREAS` come from.
ISO_TS_15066_SOURCE = (
    "ISO/TS 15066:2016, Robots and robotic devices - Collaborative robots, Annex A: "
    "Table A.2 (biomechanical limits: maximum permissible quasi-static force per body region "
    "and pressure per body area; transient limits = 2 x quasi-static, footnote c), "
    "Table A.3 (effective spring constant K and effective mass m_H per body region), "
    "eqs. (A.1)-(A.6) (two-body model, mu, m_R = M/2 + m_L, E = F^2/(2K), "
    "v_rel,max = F_max / sqrt(mu K))."
)


@dataclass(frozen=True)
class BodyRegion:
    """One body region of the ISO/TS 15066 body model.

    Attributes
    ----------
    name : str
        Key used by the API and the CLI (``"hands_fingers"``, ...).
    label : str
        Name as printed in the standard.
    m_H : float
        Effective mass of the body region [kg] (Table A.3).
    K : float
        Effective spring constant [N/m] (Table A.3 gives N/mm).
    F_qs : float
        Maximum permissible quasi-static contact force [N] (Table A.2).
    transient_factor : float or None
        Multiplier from quasi-static to transient force (Table A.2: 2). ``None`` where the
        standard gives no transient value (skull/forehead, face): transient contact with
        the head is to be avoided, so no speed is computed.
    """

    name: str
    label: str
    m_H: float
    K: float
    F_qs: float
    transient_factor: float | None = 2.0

    @property
    def F_transient(self) -> float | None:
        """Maximum permissible transient contact force [N], or ``None``."""
        return None if self.transient_factor is None else self.transient_factor * self.F_qs


@dataclass(frozen=True)
class BodyArea:
    """One of the 29 specific body areas with a pressure limit (Table A.2).

    Attributes
    ----------
    number : int
        Area number in the standard's body map (1..29).
    label : str
        Name of the area in the standard.
    region : str
        Key of the :class:`BodyRegion` it belongs to.
    p_qs : float
        Maximum permissible quasi-static pressure [Pa] (Table A.2 gives N/cm^2).
    """

    number: int
    label: str
    region: str
    p_qs: float

    @property
    def p_transient(self) -> float | None:
        """Maximum permissible transient pressure [Pa]: the region's
        :attr:`~BodyRegion.transient_factor` (2) x quasi-static, or ``None`` where the
        standard gives no transient value (the areas of the head: forehead, temple,
        masticatory muscle)."""
        factor = BODY_REGIONS[self.region].transient_factor
        return None if factor is None else factor * self.p_qs


_NPMM = 1e3  # N/mm -> N/m
_NPCM2 = 1e4  # N/cm^2 -> Pa

#: ISO/TS 15066:2016 body regions: (Table A.3) m_H [kg], K [N/m]; (Table A.2) F_qs [N].
BODY_REGIONS: dict[str, BodyRegion] = {
    r.name: r
    for r in (
        BodyRegion("skull_forehead", "Skull and forehead", 4.4, 150 * _NPMM, 130.0, None),
        BodyRegion("face", "Face", 4.4, 75 * _NPMM, 65.0, None),
        BodyRegion("neck", "Neck", 1.2, 50 * _NPMM, 150.0),
        BodyRegion("back_shoulders", "Back and shoulders", 40.0, 35 * _NPMM, 210.0),
        BodyRegion("chest", "Chest", 40.0, 25 * _NPMM, 140.0),
        BodyRegion("abdomen", "Abdomen", 40.0, 10 * _NPMM, 110.0),
        BodyRegion("pelvis", "Pelvis", 40.0, 25 * _NPMM, 180.0),
        BodyRegion("upper_arms_elbows", "Upper arms and elbow joints", 3.0, 30 * _NPMM, 150.0),
        BodyRegion("lower_arms_wrists", "Lower arms and wrist joints", 2.0, 40 * _NPMM, 160.0),
        BodyRegion("hands_fingers", "Hands and fingers", 0.6, 75 * _NPMM, 140.0),
        BodyRegion("thighs_knees", "Thighs and knees", 75.0, 50 * _NPMM, 220.0),
        BodyRegion("lower_legs", "Lower legs", 75.0, 60 * _NPMM, 130.0),
    )
}

#: ISO/TS 15066:2016 Table A.2 specific body areas and their quasi-static pressure limits.
BODY_AREAS: tuple[BodyArea, ...] = tuple(
    BodyArea(i + 1, label, region, p * _NPCM2)
    for i, (label, region, p) in enumerate(
        (
            ("Middle of forehead", "skull_forehead", 130),
            ("Temple", "skull_forehead", 110),
            ("Masticatory muscle", "face", 110),
            ("Neck muscle", "neck", 140),
            ("Seventh neck muscle", "neck", 210),
            ("Shoulder joint", "back_shoulders", 160),
            ("Fifth lumbar vertebra", "back_shoulders", 210),
            ("Sternum", "chest", 120),
            ("Pectoral muscle", "chest", 170),
            ("Abdominal muscle", "abdomen", 140),
            ("Pelvic bone", "pelvis", 210),
            ("Deltoid muscle", "upper_arms_elbows", 190),
            ("Humerus", "upper_arms_elbows", 220),
            ("Radial bone", "lower_arms_wrists", 190),
            ("Forearm muscle", "lower_arms_wrists", 180),
            ("Arm nerve", "lower_arms_wrists", 180),
            ("Forefinger pad D", "hands_fingers", 300),
            ("Forefinger pad ND", "hands_fingers", 270),
            ("Forefinger end joint D", "hands_fingers", 280),
            ("Forefinger end joint ND", "hands_fingers", 220),
            ("Thenar eminence", "hands_fingers", 200),
            ("Palm D", "hands_fingers", 260),
            ("Palm ND", "hands_fingers", 260),
            ("Back of the hand D", "hands_fingers", 200),
            ("Back of the hand ND", "hands_fingers", 190),
            ("Thigh muscle", "thighs_knees", 250),
            ("Kneecap", "thighs_knees", 220),
            ("Middle of shin", "lower_legs", 220),
            ("Calf muscle", "lower_legs", 210),
        )
    )
)


def body_region(name: str | BodyRegion) -> BodyRegion:
    """Look up a body region by key (``"hands_fingers"``) or return it unchanged."""
    if isinstance(name, BodyRegion):
        return name
    key = str(name).strip().lower().replace("-", "_").replace(" ", "_")
    if key not in BODY_REGIONS:
        raise InputError(
            f"unknown body region {name!r}; known: {', '.join(BODY_REGIONS)}"
        )
    return BODY_REGIONS[key]


def _positive(x, name: str, *, allow_zero: bool = False, allow_inf: bool = False) -> np.ndarray:
    arr = as_array(x, name)
    bad = np.isnan(arr) | (arr < 0 if allow_zero else arr <= 0)
    if not allow_inf:
        bad |= ~np.isfinite(arr)
    if np.any(bad):
        what = "non-negative" if allow_zero else "positive"
        raise InputError(f"{name} must be {what} and finite, got {float(arr[bad].ravel()[0]):g}")
    return arr


def iso_robot_mass(M_total, payload=0.0):
    r"""The standard's reduced robot mass :math:`m_R = M/2 + m_L` [kg].

    Parameters
    ----------
    M_total : float or array_like
        Total mass of the moving parts of the robot [kg].
    payload : float or array_like, optional
        Payload (tool and part) mass :math:`m_L` [kg].
    """
    M_total = _positive(M_total, "M_total")
    payload = _positive(payload, "payload", allow_zero=True)
    out = 0.5 * M_total + payload
    return out[()] if out.ndim == 0 else out


def reduced_mass(m_H, m_R):
    r"""Two-body reduced mass :math:`\mu = (1/m_H + 1/m_R)^{-1}` [kg].

    ``m_R = inf`` (a robot point that cannot move along the contact direction) gives
    :math:`\mu = m_H`. Broadcasts over arrays.
    """
    m_H = _positive(m_H, "m_H")
    m_R = _positive(m_R, "m_R", allow_inf=True)
    out = 1.0 / (1.0 / m_H + 1.0 / m_R)
    return out[()] if out.ndim == 0 else out


def transfer_energy(region: str | BodyRegion, *, force=None):
    r"""Energy the body region can absorb, :math:`E = F^2 / (2K)` [J].

    ``force`` [N] (float or array_like) defaults to the region's transient force limit;
    an array gives an array, as in :func:`max_transient_speed`.
    """
    r = body_region(region)
    F = r.F_transient if force is None else force
    if F is None:
        raise InputError(
            f"ISO/TS 15066 gives no transient force for {r.label!r} (contact with the head is "
            "to be avoided); pass force= explicitly"
        )
    F = _positive(F, "force")
    out = F * F / (2.0 * r.K)
    return float(out) if out.ndim == 0 else out


def max_transient_speed(region: str | BodyRegion, m_R, *, force=None, pressure=None,
                        contact_area=None):
    r"""Largest permissible relative speed for transient contact (ISO/TS 15066 A.3).

    .. math::  v_{rel,max} = \frac{F_{max}}{\sqrt{\mu K}},\quad
        \mu = (1/m_H + 1/m_R)^{-1},\quad F_{max} = \min(F_T,\; p_T A)

    Parameters
    ----------
    region : str or BodyRegion
        Body region (key of :data:`BODY_REGIONS`).
    m_R : float or array_like
        Robot-side mass [kg]: the standard's :func:`iso_robot_mass` or an exact effective
        mass (:func:`point_effective_mass`); ``inf`` allowed.
    force : float, optional
        Force limit [N]; default the region's transient limit (2 x quasi-static).
    pressure, contact_area : float, optional
        Pressure limit [Pa] and contact area [m^2]: if both are given, the force is capped
        at ``pressure * contact_area`` (eq. A.6 of the standard).

    Returns
    -------
    v_max : float or ndarray
        [m/s], broadcast over ``m_R``.
    """
    r = body_region(region)
    F = r.F_transient if force is None else force
    if F is None:
        raise InputError(
            f"ISO/TS 15066 gives no transient force limit for {r.label!r} (transient contact "
            "with the head is to be avoided); pass force= to compute a speed anyway"
        )
    F = _positive(F, "force")
    if (pressure is None) != (contact_area is None):
        raise InputError("pressure and contact_area must be given together")
    if pressure is not None:
        F = np.minimum(F, _positive(pressure, "pressure") * _positive(contact_area,
                                                                      "contact_area"))
    mu = reduced_mass(r.m_H, m_R)
    try:
        out = F / np.sqrt(mu * r.K)
    except ValueError:
        raise InputError(f"force {np.shape(F)} and m_R {np.shape(mu)} do not broadcast "
                         "together: give one force, or one per m_R") from None
    return out[()] if np.ndim(out) == 0 else out
