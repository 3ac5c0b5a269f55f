r"""The contact-law strategy: :class:`ContactLaw`, the interface every normal law implements.

A law is a small frozen object holding its parameters. Callers never branch on which law
it is; they ask it:

=====================================  ===================================================
``force(delta, delta_dot, v_i)``       raw normal force [N] (vectorized)
``from_parameters(k, e, n, c, m_eff)``  build the law from a parameter spec (classmethod;
                                       what :func:`~roverimpact.contact.get_law` calls)
``predict(m_eff, v_n)``                closed-form :class:`Prediction` (peak force, maximum
                                       indentation, duration, achieved restitution, energy)
``peak_force(T_c_minus, v_n)``         closed-form peak force [N] from T_c^- [J]
``achieved_restitution(m_eff=None)``   e* = v_out / v_n the law really produces
``name``, ``reference``, ``equation``  registry name (kebab-case), literature, formula
``parameters``                         which of k, e, n, c the law takes: name ->
                                       :class:`Parameter` (unit, meaning, default)
``fixed``                              parameters it does not take but tolerates at one
                                       value: name -> :class:`Fixed` (Hertz: e = 1;
                                       Kelvin–Voigt: n = 1)
``can_pull``                           the raw force can become tensile inside one impact
                                       (separation at f = 0 with delta > 0)
``elastic``                            no dissipation for any parameter value (Hertz)
``needs_mass``                         the damping for a given e, and so e*, depends on the
                                       mass: ``from_parameters`` needs ``m_eff`` to set the
                                       damping from e (Kelvin–Voigt)
=====================================  ===================================================

A subclass implements :meth:`ContactLaw.force`, :meth:`ContactLaw._closed_form` and
:meth:`ContactLaw.achieved_restitution` and declares the class attributes; input checks,
broadcasting and the :class:`Prediction` are done here, once.

Conventions (all SI): ``delta`` is the indentation [m] (> 0 in contact), ``delta_dot``
its rate [m/s] (> 0 while approaching/compressing), ``v_i`` the normal approach speed at
first touch [m/s] (> 0). ``force`` returns the *raw* law value [N], vectorized by numpy
broadcasting: it is 0 where ``delta <= 0`` (no contact) and may be **negative** (tensile)
when a dashpot term outweighs the spring during fast separation (Kelvin–Voigt always does
near the end of restitution). The raw value is what the laws define; a simulator clamps it
at 0 (a contact cannot pull), and :func:`~roverimpact.contact.impact_1dof` does so too.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..exceptions import InputError

__all__ = ["ContactLaw", "Fixed", "Parameter", "Prediction"]

#: The parameters a law spec may carry (keyword names of :meth:`ContactLaw.from_parameters`).
SPEC_PARAMETERS = ("k", "e", "n", "c")


def real_number(value, name: str, law: str) -> float:
    """``float(value)``; InputError for what is not a real number, True and False
    included (a flag mistaken for a number: ``float(True)`` is 1)."""
    try:
        if isinstance(value, (bool, np.bool_)):
            raise TypeError
        return float(value)
    except (TypeError, ValueError):
        raise InputError(f"{law}: {name} must be a real number, got {value!r}") from None


def check_positive(value, name: str, law: str) -> float:
    x = real_number(value, name, law)
    if not math.isfinite(x) or x <= 0.0:
        raise InputError(f"{law}: {name} must be finite and > 0, got {value!r}")
    return x


def check_restitution(e, law: str, *, allow_zero: bool) -> float:
    x = real_number(e, "e", law)
    lo_ok = x >= 0.0 if allow_zero else x > 0.0
    if not (math.isfinite(x) and lo_ok and x <= 1.0):
        rng = "[0, 1]" if allow_zero else "(0, 1] (the law is undefined at e = 0)"
        raise InputError(f"{law}: coefficient of restitution e must be in {rng}, got {e!r}")
    return x


@dataclass(frozen=True)
class Parameter:
    """A parameter a law takes (a value of :attr:`ContactLaw.parameters`).

    Attributes
    ----------
    unit : str
        SI unit ("" for dimensionless), e.g. ``"N/m^n"``.
    meaning : str
        What it is, e.g. ``"coefficient of restitution"``.
    default : float or None
        Value used when the caller passes None; None: the caller must give it (unless the
        law documents an alternative, as Kelvin–Voigt's c or e with m_eff).
    """

    unit: str
    meaning: str
    default: float | None = None

    def label(self, name: str) -> str:
        """``"stiffness k [N/m^n]"``: meaning, symbol and unit."""
        return f"{self.meaning} {name}" + (f" [{self.unit}]" if self.unit else "")


@dataclass(frozen=True)
class Fixed:
    """A parameter a law does not take but tolerates at one value (:attr:`ContactLaw.fixed`).

    Attributes
    ----------
    value : float
        The value the law has by construction (Hertz: e = 1; Kelvin–Voigt: n = 1). A spec
        giving this value is accepted and the value ignored; any other value is refused.
    reason : str
        Why, completing "<law> is ...", e.g. ``"elastic (e = 1)"``.
    hint : str
        What to do instead, appended to the error message.
    """

    value: float
    reason: str
    hint: str = ""


class ContactLaw(ABC):
    """Abstract base of the normal contact-force laws: the whole strategy (see the module).

    Class attributes: ``name`` (kebab-case registry name), ``reference``, ``equation``,
    ``parameters``, ``fixed``, ``can_pull``, ``elastic``, ``needs_mass``. Instance
    attributes every law has: ``k`` [N/m^n], ``n`` (exponent of the indentation) and ``e``
    (nominal coefficient of restitution; 1 for elastic laws, NaN when the law was
    parametrized by a damping coefficient instead).
    """

    name: ClassVar[str]
    reference: ClassVar[str]
    equation: ClassVar[str]
    parameters: ClassVar[Mapping[str, Parameter]]
    fixed: ClassVar[Mapping[str, Fixed]] = {}
    can_pull: ClassVar[bool] = False
    elastic: ClassVar[bool] = False
    needs_mass: ClassVar[bool] = False
    k: float
    n: float
    e: float

    # ---------------------------------------------------------------------------------
    # the force
    # ---------------------------------------------------------------------------------

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
        """True when this law object dissipates energy (False for ``e = 1`` or ``c = 0``)."""
        return not self.elastic

    def describe(self) -> str:
        """One line: name, parameters."""
        return f"{self.name}: {self}"

    def spring_damper(self) -> tuple[float, float] | None:
        r"""``(k [N/m], c [N s/m])`` when the law *is* the linear spring-damper
        :math:`f = k\delta + c\dot\delta` (clamped at 0), else None. Engines whose
        contact is linear (MuJoCo's soft constraint) take such a law exactly and
        approximate the others (:mod:`roverimpact.simulate.engines.mujoco`)."""
        return None

    # ---------------------------------------------------------------------------------
    # parameters
    # ---------------------------------------------------------------------------------

    @classmethod
    def from_parameters(cls, k=None, e=None, n=None, c=None, m_eff=None) -> ContactLaw:
        """Build the law from a parameter spec (what :func:`~roverimpact.contact.get_law`
        calls; callers pass every value they have, the law picks).

        A parameter the law takes (:attr:`parameters`) is used, None meaning its default
        (InputError if it has none). A parameter it does not take is ignored if None or
        equal to its :attr:`fixed` value, and refused with an InputError otherwise.
        ``m_eff`` [kg] is used only by laws with ``needs_mass`` and ignored by the others.

        Parameters
        ----------
        k : float
            Stiffness [N/m^n].
        e, n, c : float, optional
            Coefficient of restitution, exponent, damping coefficient [N s/m].
        m_eff : float, optional
            Effective mass [kg] (laws with ``needs_mass``).
        """
        return cls(**cls._take(k=k, e=e, n=n, c=c))

    @classmethod
    def _take(cls, **given) -> dict:
        """Keyword arguments of the law's constructor from a spec (see
        :meth:`from_parameters`): the taken parameters with defaults filled in."""
        out = {}
        for p, value in given.items():
            par = cls.parameters.get(p)
            if par is not None:
                value = par.default if value is None else value
                if value is None:
                    raise InputError(f"{cls.name} needs the {par.label(p)}")
                out[p] = value
            elif value is not None:
                cls._tolerate(p, value)
        return out

    @classmethod
    def _tolerate(cls, p: str, value) -> None:
        """Accept ``value`` of a parameter ``p`` the law does not take only if it equals
        the law's fixed value; InputError otherwise."""
        fx = cls.fixed.get(p)
        takes = ", ".join(cls.parameters)
        if fx is None:
            raise InputError(f"{cls.name} does not take the parameter {p} (it takes "
                             f"{takes}), got {p} = {value!r}")
        x = real_number(value, p, cls.name)
        if x != fx.value:
            raise InputError(f"{cls.name} is {fx.reason}: {p} must be {fx.value:g} (or "
                             f"omitted), got {p} = {value!r}" + (f"; {fx.hint}" if fx.hint
                                                                 else ""))

    # ---------------------------------------------------------------------------------
    # closed forms
    # ---------------------------------------------------------------------------------

    @abstractmethod
    def _closed_form(self, m: np.ndarray, v: np.ndarray) -> tuple:
        """The law's closed forms on checked, broadcast arrays.

        Parameters
        ----------
        m, v : ndarray, same shape
            Effective mass [kg] > 0 and approach speed [m/s] > 0.

        Returns
        -------
        (peak_force, max_indentation, duration, restitution_achieved)
            Arrays of the shape of ``m`` ([N], [m], [s], [-]); duration NaN where the law
            has no closed form for it.
        """

    def _peak_force(self, T: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Peak force [N] from checked T_c^- [J] and v_n [m/s] arrays; default:
        m_eff = 2 T_c^- / v_n^2 and :meth:`_closed_form` (a law overrides it when its peak
        force has a cheaper form in T_c^-)."""
        m = 2.0 * T / (v * v)  # the broadcast shape of T and v
        return self._closed_form(m, np.broadcast_to(v, m.shape))[0]

    @abstractmethod
    def achieved_restitution(self, m_eff=None) -> float | np.ndarray:
        """Coefficient of restitution e* = v_out / v_n the law really produces.

        ``m_eff`` [kg] (float or array) is used by the laws whose e* depends on the mass
        (``needs_mass``) and ignored by the others (then a float is returned)."""

    def predict(self, m_eff, v_n) -> Prediction:
        """Closed-form peak force, maximum indentation, duration and restitution.

        Parameters
        ----------
        m_eff : float or array_like
            Effective mass [kg], > 0.
        v_n : float or array_like
            Normal approach speed [m/s], > 0 (broadcast against ``m_eff``).

        Returns
        -------
        Prediction
            Frozen dataclass of floats (scalar input) or arrays of the broadcast shape;
            ``energy_dissipated = 1/2 m_eff v_n^2 (1 - e*^2)``.
        """
        m, v = _broadcast(positive_array(m_eff, "m_eff [kg]"),
                          positive_array(v_n, "v_n [m/s]"), "m_eff", "v_n")
        with np.errstate(all="ignore"):
            T = 0.5 * m * v * v
            _in_range(T, m, v, "the kinetic energy 1/2 m_eff v_n^2", "J")
            peak, dmax, dur, e_star = self._closed_form(m, v)
            _in_range(peak, m, v, f"{self.name}: the peak force", "N")
            _in_range(dmax, m, v, f"{self.name}: the maximum indentation", "m")
        return Prediction(
            peak_force=as_output(peak),
            max_indentation=as_output(dmax),
            duration=as_output(dur),
            restitution_achieved=as_output(e_star),
            energy_dissipated=as_output(T * (1.0 - e_star**2)),
            law=self.name,
        )

    def peak_force(self, T_c_minus, v_n) -> float | np.ndarray:
        """Peak contact force [N] from the effective kinetic energy T_c^- [J] > 0 and the
        normal approach speed v_n [m/s] > 0 (broadcast): m_eff = 2 T_c^- / v_n^2 in
        :meth:`predict`. Float for scalar input, else an array of the broadcast shape."""
        T = positive_array(T_c_minus, "T_c_minus [J]")
        v = positive_array(v_n, "v_n [m/s]")
        if T.shape != v.shape:
            _broadcast(T, v, "T_c_minus", "v_n")  # one clear error if they do not
        with np.errstate(all="ignore"):
            peak = self._peak_force(T, v)
            m = 2.0 * T / (v * v)  # for the message
            _in_range(peak, m, np.broadcast_to(v, m.shape), f"{self.name}: the peak force",
                      "N")
        return as_output(peak)


def positive_array(x, name: str) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a real number or array, got {x!r}") from None
    if not np.all(np.isfinite(a)) or not np.all(a > 0):
        bad = a[~(np.isfinite(a) & (a > 0))].ravel()[0]
        raise InputError(f"{name} must be finite and > 0 (got {bad!r})")
    return a


def _in_range(x: np.ndarray, m: np.ndarray, v: np.ndarray, what: str, unit: str) -> None:
    """InputError naming the first (m_eff, v_n) for which ``x`` is not finite: the inputs
    are finite, but ``x`` (or a value on the way to it) overflows floating point."""
    bad = ~np.isfinite(np.asarray(x, dtype=float))
    if np.any(bad):
        i = np.flatnonzero(bad.ravel())[0]
        xb, mb, vb = (np.broadcast_to(a, bad.shape).ravel()[i] for a in (x, m, v))
        raise InputError(f"{what} for m_eff = {mb:g} kg, v_n = {vb:g} m/s overflows floating "
                         f"point ({xb:g} {unit}): inputs out of range")


def _broadcast(a: np.ndarray, b: np.ndarray, name_a: str, name_b: str):
    try:
        return np.broadcast_arrays(a, b)
    except ValueError:
        raise InputError(f"{name_a} shape {a.shape} and {name_b} shape {b.shape} do not "
                         "broadcast") from None


def check_law(law) -> ContactLaw:
    if not isinstance(law, ContactLaw):
        raise InputError(
            f"law must be a ContactLaw (e.g. get_law('hunt-crossley', k=..., e=...)), "
            f"got {type(law).__name__}"
        )
    return law


def as_output(x):
    x = np.asarray(x, dtype=np.float64)
    return float(x) if x.ndim == 0 else x


@dataclass(frozen=True)
class Prediction:
    """Closed-form prediction of one (or a batch of) 1-DOF impacts.

    Attributes
    ----------
    peak_force : float or array
        Maximum contact force [N].
    max_indentation : float or array
        Maximum indentation [m].
    duration : float or array
        Contact duration [s] (for the Hunt–Crossley family from a 1-D quadrature of the
        energy integral; NaN where no closed form exists).
    restitution_achieved : float or array
        e* = exit speed / v_n that the law really produces.
    energy_dissipated : float or array
        1/2 m v_n^2 (1 - e*^2) [J].
    law : str
        Name of the law.
    """

    peak_force: float | np.ndarray
    max_indentation: float | np.ndarray
    duration: float | np.ndarray
    restitution_achieved: float | np.ndarray
    energy_dissipated: float | np.ndarray
    law: str
