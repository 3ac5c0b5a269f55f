r"""Contact-force laws f(delta, delta_dot; parameters) for the normal direction.

Conventions (all SI): ``delta`` is the indentation [m] (> 0 in contact), ``delta_dot``
its rate [m/s] (> 0 while approaching/compressing), ``v_i`` the normal approach speed at
first touch [m/s] (> 0). ``force`` returns the *raw* law value [N], vectorized by numpy
broadcasting: it is 0 where ``delta <= 0`` (no contact) and may be **negative** (tensile)
when a dashpot term outweighs the spring during fast separation (Kelvin–Voigt always does
near the end of restitution). The raw value is what the laws define; a simulator clamps it
at 0 (a contact cannot pull), and :func:`~roverimpact.contact.impact_1dof` does so too.

The Hunt–Crossley family shares

.. math:: f = k\,\delta^n\,(1 + \chi\,\dot\delta), \qquad \chi = h(e)/v_i ,

and the laws differ only in the dimensionless damping number :math:`z = \chi v_i = h(e)`
(a function of the coefficient of restitution e alone; see :data:`LAWS`). Every closed
form of :mod:`roverimpact.contact` for the family depends on (z, n) only.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ..exceptions import InputError

__all__ = [
    "LAWS",
    "CarvalhoMartins",
    "ContactLaw",
    "Flores",
    "Gonthier",
    "HerbertMcWhannell",
    "Hertz",
    "HuntCrossley",
    "HuntCrossleyFamily",
    "KelvinVoigt",
    "LankaraniNikravesh",
    "LeeWang",
    "ZhiyingQishao",
    "get_law",
]


def _check_positive(value, name: str, law: str) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{law}: {name} must be a real number, got {value!r}") from None
    if not math.isfinite(x) or x <= 0.0:
        raise InputError(f"{law}: {name} must be finite and > 0, got {value!r}")
    return x


class ContactLaw(ABC):
    """Abstract base of the normal contact-force laws.

    Attributes every law has: ``name`` (kebab-case registry name), ``reference`` (the
    literature source), ``equation`` (plain-text formula), ``k`` [N/m^n], ``n`` (exponent of
    the indentation), ``e`` (nominal coefficient of restitution; 1 for elastic laws, NaN when
    the law is parametrized by a damping coefficient instead) and ``can_pull`` (True when the
    raw law value can become negative inside one impact, so separation happens at f = 0
    before delta returns to 0).
    """

    name: ClassVar[str]
    reference: ClassVar[str]
    equation: ClassVar[str]
    can_pull: ClassVar[bool] = False
    k: float
    n: float
    e: float

    @abstractmethod
    def force(self, delta, delta_dot, v_i=1.0) -> np.ndarray:
        """Raw normal force [N] of the law (vectorized; 0 where delta <= 0, may be < 0).

        Parameters
        ----------
        delta : array_like
            Indentation [m].
        delta_dot : array_like
            Indentation rate [m/s], positive while compressing.
        v_i : array_like
            Normal approach speed at first touch [m/s], > 0 (used by the laws whose
            damping is set from the restitution; ignored by the others).
        """

    @property
    def dissipative(self) -> bool:
        """True when the law dissipates energy."""
        return True

    def describe(self) -> str:
        """One line: name, parameters."""
        return f"{self.name}: {self}"


# --------------------------------------------------------------------------------------
# Linear spring-dashpot
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class KelvinVoigt(ContactLaw):
    r"""Linear spring-dashpot (Kelvin–Voigt): :math:`f = k\,\delta + c\,\dot\delta`.

    Parameters
    ----------
    k : float
        Stiffness [N/m].
    c : float
        Damping coefficient [N s/m], >= 0.
    e : float, optional
        Nominal coefficient of restitution the damping was set from (information only; NaN
        when ``c`` was given directly). See :meth:`from_restitution`.
    m_ref : float, optional
        Mass [kg] used to set ``c`` from ``e`` (information only).

    Notes
    -----
    The force jumps to ``c v_i`` at first touch and becomes tensile before delta returns
    to 0, so the clamped law separates at f = 0 (Schwager & Pöschel 2007). For a given
    e the damping depends on the mass (c = 2 zeta sqrt(k m)), unlike the Hunt–Crossley
    family. References: Goldsmith, *Impact* (1960); Machado, Moreira, Flores, Lankarani,
    "Compliant contact force models in multibody dynamics: evolution of the Hertz contact
    theory", Mech. Mach. Theory 53 (2012) 99–121; T. Schwager, T. Pöschel, "Coefficient of
    restitution and linear-dashpot model revisited", Granular Matter 9 (2007) 465–469.
    """

    k: float
    c: float
    e: float = float("nan")
    m_ref: float = float("nan")
    n: float = field(default=1.0, init=False)

    name: ClassVar[str] = "kelvin-voigt"
    reference: ClassVar[str] = (
        "Goldsmith, Impact (1960); Machado et al., Mech. Mach. Theory 53 (2012) 99-121; "
        "Schwager & Pöschel, Granular Matter 9 (2007) 465-469"
    )
    equation: ClassVar[str] = "f = k*delta + c*delta_dot"
    can_pull: ClassVar[bool] = True

    def __post_init__(self):
        object.__setattr__(self, "k", _check_positive(self.k, "k [N/m]", self.name))
        c = float(self.c)
        if not math.isfinite(c) or c < 0:
            raise InputError(f"{self.name}: c [N s/m] must be finite and >= 0, got {self.c!r}")
        object.__setattr__(self, "c", c)

    @classmethod
    def from_restitution(cls, k: float, e: float, m_eff: float) -> KelvinVoigt:
        r"""Set c so that the *unclamped* linear oscillator of mass ``m_eff`` returns to
        delta = 0 with speed e v_i: :math:`\zeta = -\ln e/\sqrt{\pi^2 + \ln^2 e}`,
        :math:`c = 2\zeta\sqrt{k m}`. e in (0, 1]. The clamped law achieves
        :math:`e^* = e^{2\alpha/\pi} > e` with :math:`\alpha = \arccos\zeta` (see docs)."""
        k = _check_positive(k, "k [N/m]", cls.name)
        m = _check_positive(m_eff, "m_eff [kg] (needed to set c from e)", cls.name)
        e = _check_restitution(e, cls.name, allow_zero=False)
        le = math.log(e)
        zeta = -le / math.sqrt(math.pi**2 + le**2)
        return cls(k=k, c=2.0 * zeta * math.sqrt(k * m), e=e, m_ref=m)

    def damping_ratio(self, m_eff) -> np.ndarray:
        """zeta = c / (2 sqrt(k m)) for the mass ``m_eff`` [kg]."""
        return self.c / (2.0 * np.sqrt(self.k * np.asarray(m_eff, dtype=float)))

    @property
    def dissipative(self) -> bool:
        return self.c > 0

    def force(self, delta, delta_dot, v_i=1.0) -> np.ndarray:
        delta = np.asarray(delta, dtype=float)
        return np.where(delta > 0.0, self.k * delta + self.c * np.asarray(delta_dot), 0.0)


# --------------------------------------------------------------------------------------
# Hertz
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Hertz(ContactLaw):
    r"""Elastic Hertz law :math:`f = k\,\delta^n` (n = 3/2 for point contact).

    Parameters
    ----------
    k : float
        Generalized stiffness [N/m^n]; for a sphere on a plane or two spheres
        k = 4/3 E* sqrt(R), see :func:`~roverimpact.contact.hertz_stiffness`.
    n : float
        Exponent, > 0 (3/2 Hertz point contact; ~1 to 1.1 for line contact).

    Reference: H. Hertz, "Über die Berührung fester elastischer Körper", J. reine angew.
    Math. 92 (1882) 156–171; K. L. Johnson, *Contact Mechanics*, CUP (1985), §4.2, §11.4.
    """

    k: float
    n: float = 1.5
    e: float = field(default=1.0, init=False)

    name: ClassVar[str] = "hertz"
    reference: ClassVar[str] = (
        "Hertz, J. reine angew. Math. 92 (1882) 156-171; Johnson, Contact Mechanics (1985) "
        "§4.2, §11.4"
    )
    equation: ClassVar[str] = "f = k*delta^n"

    def __post_init__(self):
        object.__setattr__(self, "k", _check_positive(self.k, "k [N/m^n]", self.name))
        object.__setattr__(self, "n", _check_positive(self.n, "n (exponent)", self.name))

    @property
    def dissipative(self) -> bool:
        return False

    @property
    def z(self) -> float:
        """Dimensionless damping number chi v_i (0: elastic)."""
        return 0.0

    def force(self, delta, delta_dot=0.0, v_i=1.0) -> np.ndarray:
        d = np.maximum(np.asarray(delta, dtype=float), 0.0)
        return self.k * d**self.n


# --------------------------------------------------------------------------------------
# Hunt–Crossley family
# --------------------------------------------------------------------------------------


def _check_restitution(e, law: str, *, allow_zero: bool) -> float:
    try:
        x = float(e)
    except (TypeError, ValueError):
        raise InputError(f"{law}: e must be a real number, got {e!r}") from None
    lo_ok = x >= 0.0 if allow_zero else x > 0.0
    if not (math.isfinite(x) and lo_ok and x <= 1.0):
        rng = "[0, 1]" if allow_zero else "(0, 1] (the law is undefined at e = 0)"
        raise InputError(f"{law}: coefficient of restitution e must be in {rng}, got {e!r}")
    return x


@dataclass(frozen=True)
class HuntCrossleyFamily(ContactLaw):
    r"""Base of the laws :math:`f = k\,\delta^n\,(1 + h(e)\,\dot\delta / v_i)`.

    Parameters
    ----------
    k : float
        Generalized stiffness [N/m^n], > 0.
    e : float
        Nominal coefficient of restitution (range per law: [0, 1], or (0, 1] for the laws
        whose h(e) is singular at e = 0).
    n : float
        Exponent of the indentation, > 0 (default 3/2).

    A subclass defines :meth:`h`, the dimensionless damping number z = chi v_i.
    """

    k: float
    e: float
    n: float = 1.5

    allow_e_zero: ClassVar[bool] = True

    def __post_init__(self):
        object.__setattr__(self, "k", _check_positive(self.k, "k [N/m^n]", self.name))
        object.__setattr__(self, "n", _check_positive(self.n, "n (exponent)", self.name))
        object.__setattr__(
            self, "e", _check_restitution(self.e, self.name, allow_zero=self.allow_e_zero)
        )

    @staticmethod
    @abstractmethod
    def h(e: float) -> float:
        """Dimensionless damping number z = chi v_i as a function of e."""

    @property
    def z(self) -> float:
        """Dimensionless damping number z = chi v_i of this law (0 when e = 1)."""
        return float(self.h(self.e))

    def chi(self, v_i) -> np.ndarray:
        """Hysteresis damping factor chi = z / v_i [s/m]."""
        return self.z / np.asarray(v_i, dtype=float)

    @property
    def dissipative(self) -> bool:
        return self.z > 0

    def force(self, delta, delta_dot, v_i=1.0) -> np.ndarray:
        d = np.maximum(np.asarray(delta, dtype=float), 0.0)
        return self.k * d**self.n * (1.0 + self.z * np.asarray(delta_dot) / np.asarray(v_i))


@dataclass(frozen=True)
class HuntCrossley(HuntCrossleyFamily):
    """Hunt & Crossley: z = 3(1 - e)/2 (as used by González et al., DETC2014-35554, eq. 4)."""

    name: ClassVar[str] = "hunt-crossley"
    reference: ClassVar[str] = (
        "Hunt & Crossley, J. Appl. Mech. 42 (1975) 440-445; González et al. DETC2014-35554 "
        "eq. (4)"
    )
    equation: ClassVar[str] = "chi*v_i = 3(1-e)/2"

    @staticmethod
    def h(e):
        return 1.5 * (1.0 - e)


@dataclass(frozen=True)
class LankaraniNikravesh(HuntCrossleyFamily):
    """Lankarani & Nikravesh: z = 3(1 - e^2)/4."""

    name: ClassVar[str] = "lankarani-nikravesh"
    reference: ClassVar[str] = "Lankarani & Nikravesh, J. Mech. Des. 112 (1990) 369-376"
    equation: ClassVar[str] = "chi*v_i = 3(1-e^2)/4"

    @staticmethod
    def h(e):
        return 0.75 * (1.0 - e * e)


@dataclass(frozen=True)
class HerbertMcWhannell(HuntCrossleyFamily):
    """Herbert & McWhannell: z = 6(1 - e) / ((2e - 1)^2 + 3)."""

    name: ClassVar[str] = "herbert-mcwhannell"
    reference: ClassVar[str] = (
        "Herbert & McWhannell, J. Eng. Ind. 99 (1977) 513-518 (as tabulated by Flores et al., "
        "Multibody Syst. Dyn. 25 (2011) 357-375)"
    )
    equation: ClassVar[str] = "chi*v_i = 6(1-e)/((2e-1)^2+3)"

    @staticmethod
    def h(e):
        return 6.0 * (1.0 - e) / ((2.0 * e - 1.0) ** 2 + 3.0)


@dataclass(frozen=True)
class LeeWang(HuntCrossleyFamily):
    """Lee & Wang: z = 3(1 - e)/4."""

    name: ClassVar[str] = "lee-wang"
    reference: ClassVar[str] = "Lee & Wang, J. Mech. Trans. Autom. Des. 105 (1983) 534-540"
    equation: ClassVar[str] = "chi*v_i = 3(1-e)/4"

    @staticmethod
    def h(e):
        return 0.75 * (1.0 - e)


@dataclass(frozen=True)
class Gonthier(HuntCrossleyFamily):
    """Gonthier, McPhee, Lange & Piedbœuf: z = (1 - e^2)/e, e in (0, 1]."""

    name: ClassVar[str] = "gonthier"
    reference: ClassVar[str] = (
        "Gonthier, McPhee, Lange & Piedboeuf, Multibody Syst. Dyn. 11 (2004) 209-233"
    )
    equation: ClassVar[str] = "chi*v_i = (1-e^2)/e"
    allow_e_zero: ClassVar[bool] = False

    @staticmethod
    def h(e):
        return (1.0 - e * e) / e


@dataclass(frozen=True)
class Flores(HuntCrossleyFamily):
    """Flores, Machado, Silva & Martins: z = 8(1 - e)/(5e), e in (0, 1]."""

    name: ClassVar[str] = "flores"
    reference: ClassVar[str] = (
        "Flores, Machado, Silva & Martins, Multibody Syst. Dyn. 25 (2011) 357-375"
    )
    equation: ClassVar[str] = "chi*v_i = 8(1-e)/(5e)"
    allow_e_zero: ClassVar[bool] = False

    @staticmethod
    def h(e):
        return 8.0 * (1.0 - e) / (5.0 * e)


@dataclass(frozen=True)
class ZhiyingQishao(HuntCrossleyFamily):
    """Zhiying & Qishao: z = 3(1 - e^2) exp(2(1 - e)) / 4."""

    name: ClassVar[str] = "zhiying-qishao"
    reference: ClassVar[str] = (
        "Zhiying & Qishao, J. Dyn. Control 4 (2006) 294-298 (as reviewed by Corral et al., "
        "Mech. Mach. Theory 2021, and Skrinjar et al., 2018)"
    )
    equation: ClassVar[str] = "chi*v_i = 3(1-e^2) exp(2(1-e))/4"

    @staticmethod
    def h(e):
        return 0.75 * (1.0 - e * e) * math.exp(2.0 * (1.0 - e))


@dataclass(frozen=True)
class CarvalhoMartins(HuntCrossleyFamily):
    """Carvalho & Martins (explicit fit of their exact restitution relation):
    z = 3(1 - e)(11 - e) / (2(1 + 9e)) (equal to Gonthier's (1-e^2)/e at e = 1/3)."""

    name: ClassVar[str] = "carvalho-martins"
    reference: ClassVar[str] = (
        "Carvalho & Martins, Mech. Mach. Theory 139 (2019) 174-194"
    )
    equation: ClassVar[str] = "chi*v_i = 3(1-e)(11-e)/(2(1+9e))"

    @staticmethod
    def h(e):
        return 1.5 * (1.0 - e) * (11.0 - e) / (1.0 + 9.0 * e)


#: Registry: kebab-case name -> law class.
LAWS: dict[str, type[ContactLaw]] = {
    cls.name: cls
    for cls in (
        KelvinVoigt,
        Hertz,
        HuntCrossley,
        LankaraniNikravesh,
        HerbertMcWhannell,
        LeeWang,
        Gonthier,
        Flores,
        ZhiyingQishao,
        CarvalhoMartins,
    )
}


def get_law(
    name: str,
    *,
    k: float,
    e: float | None = None,
    n: float | None = None,
    c: float | None = None,
    m_eff: float | None = None,
) -> ContactLaw:
    """Build a law from its registry name.

    Parameters
    ----------
    name : str
        One of :data:`LAWS` (kebab-case; underscores and case are tolerated).
    k : float
        Stiffness [N/m^n].
    e : float, optional
        Coefficient of restitution. Required for the Hunt–Crossley family; for ``hertz`` only
        e = 1 (or None) is accepted; for ``kelvin-voigt`` it sets c together with ``m_eff``.
    n : float, optional
        Exponent (default 3/2); ``kelvin-voigt`` is linear (n must be None or 1).
    c : float, optional
        Damping coefficient [N s/m] of ``kelvin-voigt`` (instead of e and m_eff).
    m_eff : float, optional
        Effective mass [kg] used by ``kelvin-voigt`` to set c from e.
    """
    key = str(name).strip().lower().replace("_", "-").replace(" ", "-")
    if key not in LAWS:
        raise InputError(f"unknown contact law {name!r}; choose one of: {', '.join(LAWS)}")
    cls = LAWS[key]
    if cls is KelvinVoigt:
        if n is not None and float(n) != 1.0:
            raise InputError(f"kelvin-voigt is linear: n must be 1 (or omitted), got {n!r}")
        if c is not None:
            if e is not None:
                raise InputError("kelvin-voigt: give either c or (e and m_eff), not both")
            return KelvinVoigt(k=k, c=c)
        if e is None or m_eff is None:
            raise InputError("kelvin-voigt needs c [N s/m], or e and m_eff [kg] to set c")
        return KelvinVoigt.from_restitution(k, e, m_eff)
    if c is not None:
        raise InputError(f"{key}: parameter c applies to kelvin-voigt only")
    nn = 1.5 if n is None else n
    if cls is Hertz:
        if e is not None and float(e) != 1.0:
            raise InputError(
                f"hertz is elastic (e = 1), got e = {e!r}; use a damped law such as "
                "'hunt-crossley' for e < 1"
            )
        return Hertz(k=k, n=nn)
    if e is None:
        raise InputError(f"{key} needs the coefficient of restitution e")
    return cls(k=k, e=e, n=nn)
