r"""Closed-form impact predictions of a mass m_eff hitting a contact law at speed v_n.

Scales (Hertz, any n): :math:`\delta_H = ((n+1) m v^2 / (2k))^{1/(n+1)}`,
:math:`F_H = k\,\delta_H^n`, :math:`t_H = \delta_H / v`. With :math:`m v^2 = 2 T_c^-`,
:math:`\delta_H = ((n+1) T_c^-/k)^{1/(n+1)}` depends on T_c^- alone.

Hunt–Crossley family, :math:`f = k\delta^n(1 + z\,u)` with :math:`u = \dot\delta/v` and
z = chi v. The energy integral of :math:`m \dot\delta\,d\dot\delta/d\delta = -f` is

.. math:: G(u) = G(1) - \tfrac12 \xi^{n+1},\qquad G(u) = \frac{z u - \ln(1+z u)}{z^2},
          \qquad \xi = \delta/\delta_H ,

so (u = 0) :math:`\delta_{max}^{n+1} = \frac{(n+1)m}{k\chi^2}[\chi v - \ln(1+\chi v)]`,
and at separation (:math:`\xi = 0`, :math:`u = -e^*`) :math:`G(-e^*) = G(1)`, i.e.
:math:`\chi v (1+e^*) = \ln\frac{1+\chi v}{1-\chi e^* v}`, solved exactly with the
Lambert W function: :math:`e^* = (1-y)/z`, :math:`y = -W_0(-(1+z)e^{-(1+z)})`.
The force along the compression branch is :math:`F/F_H = (2P(u))^{n/(n+1)}(1+zu)` with
:math:`P = G(1) - G(u)`; its maximum is at the unique root in (0, 1) of
:math:`z P(u) = \frac{n}{n+1} u` (a bounded 1-D root find). The contact duration is the
1-D quadrature :math:`t_c/t_H = \frac{2}{n+1}\int_{-e^*}^{1} (2P)^{-n/(n+1)}/(1+zu)\,du`,
which for z = 0 is Hertz's :math:`\frac{2}{n+1}B(\tfrac12, \tfrac1{n+1})` (2.9432 for
n = 3/2). All of these depend on (z, n) only: for the family, the peak force is
:math:`F_{max} = \varphi^*(z,n)\,k^{1/(n+1)}((n+1)T_c^-)^{n/(n+1)}`, a function of T_c^-.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import integrate, optimize, special

from ..exceptions import InputError
from ._laws import ContactLaw, KelvinVoigt

__all__ = [
    "Prediction",
    "achieved_restitution",
    "hertz_duration_factor",
    "peak_force",
    "predict",
]


# --------------------------------------------------------------------------------------
# checks
# --------------------------------------------------------------------------------------


def _positive_array(x, name: str) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a real number or array, got {x!r}") from None
    if not np.all(np.isfinite(a)) or not np.all(a > 0):
        bad = a[~(np.isfinite(a) & (a > 0))].ravel()[0]
        raise InputError(f"{name} must be finite and > 0 (got {bad!r})")
    return a


def _check_law(law) -> ContactLaw:
    if not isinstance(law, ContactLaw):
        raise InputError(
            f"law must be a ContactLaw (e.g. get_law('hunt-crossley', k=..., e=...)), "
            f"got {type(law).__name__}"
        )
    return law


def _out(x):
    x = np.asarray(x, dtype=np.float64)
    return float(x) if x.ndim == 0 else x


# --------------------------------------------------------------------------------------
# dimensionless helpers of the Hunt–Crossley family
# --------------------------------------------------------------------------------------


def _psi(x: float) -> float:
    """(x - ln(1+x)) / x^2, accurate for small |x| (series), x > -1."""
    if x <= -1.0:
        return math.inf
    if abs(x) < 1e-3:
        return 0.5 - x / 3 + x * x / 4 - x**3 / 5 + x**4 / 6
    return (x - math.log1p(x)) / (x * x)


def _P(u: float, z: float, s: float) -> float:
    r"""P(u) = G(1) - G(u) = G(s) - G(u) with s = -e*, computed without cancellation.

    For u >= 0 from the top end (q = (1-u)/(1+zu)): P = q u + q^2 psi(z q);
    for u < 0 from the bottom end (q = (s-u)/(1+zu)): P = q u + q^2 psi(z q).
    """
    top = 1.0 if u >= 0 else s
    q = (top - u) / (1.0 + z * u)
    return q * u + q * q * _psi(z * q)


@lru_cache(maxsize=256)
def _restitution_zy(z: float) -> tuple[float, float]:
    """(e*, y = 1 - z e*) of the Hunt–Crossley family with damping number z >= 0.

    y is returned separately because for strong damping it underflows 1 - z e* (e.g.
    y ~ 1e-42 for z = 100): the exit speed approaches v/z, where the force vanishes."""
    if z == 0.0:
        return 1.0, 1.0
    if z < 0.05:
        # near the branch point of W: solve e^2 psi(-z e) = psi(z) (monotone in e)
        target = _psi(z)
        e = optimize.brentq(lambda e: e * e * _psi(-z * e) - target, 0.5, 1.0,
                            xtol=1e-16, rtol=1e-15, maxiter=200)
        return e, 1.0 - z * e
    arg = -(1.0 + z) * math.exp(-(1.0 + z))
    y = -float(np.real(special.lambertw(arg, 0)))
    return (1.0 - y) / z, y


def _restitution_z(z: float) -> float:
    """Achieved restitution e* of the Hunt–Crossley family with damping number z >= 0."""
    return _restitution_zy(z)[0]


@lru_cache(maxsize=256)
def _peak_factor(z: float, n: float) -> tuple[float, float]:
    """(phi*, u*): peak force / F_H and the speed ratio u = delta_dot/v at the peak."""
    if z == 0.0:
        return 1.0, 0.0
    a = n / (n + 1.0)
    s = -_restitution_z(z)
    u = optimize.brentq(lambda u: z * _P(u, z, s) - a * u, 0.0, 1.0,
                        xtol=1e-16, rtol=1e-15, maxiter=200)
    return (2.0 * _P(u, z, s)) ** a * (1.0 + z * u), u


def hertz_duration_factor(n: float = 1.5) -> float:
    r"""t_c v / delta_max of the elastic law f = k delta^n: (2/(n+1)) B(1/2, 1/(n+1)).

    2.9432 for n = 3/2 (Johnson, Contact Mechanics, eq. 11.24)."""
    return 2.0 / (n + 1.0) * float(special.beta(0.5, 1.0 / (n + 1.0)))


@lru_cache(maxsize=256)
def _duration_factor(z: float, n: float) -> float:
    """t_c / t_H for the Hunt–Crossley family (1-D quadrature of the energy integral)."""
    if z == 0.0:
        return hertz_duration_factor(n)
    a = n / (n + 1.0)
    e_star, y = _restitution_zy(z)
    s = -e_star

    # (2P)^(-a)/(1+zu) = g(u) * (u - s)^(-a) * (1 - u)^(-a); g smooth on [s, 1].
    def g(u):
        # P/(1-u) on [0, 1], P/(u-s) on [s, 0] (weak damping): the vanishing factor is
        # divided out analytically (it is carried by the quadrature weight)
        if u >= 0:
            w = 1.0 + z * u
            q = (1.0 - u) / w
            ratio = (u + q * _psi(z * q)) / w
        else:
            w = 1.0 + z * u
            q = (s - u) / w
            ratio = (-u + (u - s) * _psi(z * q) / w) / w
        return (2.0 * ratio) ** (-a) / w

    opts = {"epsabs": 0.0, "epsrel": 1e-13, "limit": 500}
    hi = integrate.quad(g, 0.0, 1.0, weight="alg", wvar=(0.0, -a), **opts)[0]
    if z < 0.05:
        lo = integrate.quad(g, s, 0.0, weight="alg", wvar=(-a, 0.0), **opts)[0]
        return 2.0 / (n + 1.0) * (lo + hi)
    # Restitution branch in x = z (u - s) / y in [0, X], X = z e*/y: with 1 + z u = y (1 + x)
    # and P = (u - s) R / z, R = ln(1+x)/x - y, the integrand becomes
    # (2 R x / z^2)^(-a) / (z (1 + x)) dx, free of the 1/(1 + z u) near-singularity that
    # makes the exit slow for strong damping (y ~ 1e-42 for z = 100).
    X = (1.0 - y) / y

    def R(x):
        l1 = 1.0 - x / 2 + x * x / 3 - x**3 / 4 if x < 1e-4 else math.log1p(x) / x
        return l1 - y

    def f_lin(x):  # times the weight x^(-a)
        return (2.0 * R(x) / (z * z)) ** (-a) / (z * (1.0 + x))

    def f_log(t):  # x = exp(t), dx = x dt
        x = math.exp(t)
        return (2.0 * R(x) * x / (z * z)) ** (-a) * x / (z * (1.0 + x))

    x1 = min(1.0, X)
    lo = integrate.quad(f_lin, 0.0, x1, weight="alg", wvar=(-a, 0.0), **opts)[0]
    if X > 1.0:
        lo += integrate.quad(f_log, 0.0, math.log(X), **opts)[0]
    return 2.0 / (n + 1.0) * (lo + hi)


# --------------------------------------------------------------------------------------
# Kelvin–Voigt (clamped at f = 0)
# --------------------------------------------------------------------------------------


def _kelvin_voigt(law: KelvinVoigt, m, v):
    r"""Closed form of the clamped linear spring-dashpot (any damping ratio zeta).

    With :math:`\omega = \sqrt{k/m}`, :math:`\alpha = \arccos\zeta` (zeta < 1),
    :math:`A = \alpha\cot\alpha`, :math:`S = \alpha/\sin\alpha` (for zeta > 1 the same
    with :math:`\beta = \operatorname{arccosh}\zeta`: A = beta coth beta,
    S = beta/sinh beta; A = S = 1 at zeta = 1):
    :math:`\delta_{max} = (v/\omega)e^{-A}`; f = 0 (separation) at :math:`t_c = 2S/\omega`;
    :math:`e^* = e^{-2A}`; peak force :math:`m v \omega e^{-(3\alpha-\pi)\cot\alpha}` if
    zeta < 1/2 (interior maximum), else c v at first touch.
    """
    zeta = law.damping_ratio(m) * np.ones_like(v)
    omega = np.sqrt(law.k / m)
    under = zeta < 1.0
    alpha = np.arccos(np.minimum(zeta, 1.0))
    beta = np.arccosh(np.maximum(zeta, 1.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        A = np.where(under, alpha / np.tan(alpha), beta / np.tanh(beta))
        S = np.where(under, alpha / np.sin(alpha), beta / np.sinh(beta))
        cot = np.where(zeta < 0.5, zeta / np.sqrt(1.0 - np.minimum(zeta, 0.5) ** 2), 0.0)
    A = np.where(zeta == 1.0, 1.0, A)
    S = np.where(zeta == 1.0, 1.0, S)
    delta_max = v / omega * np.exp(-A)
    duration = 2.0 * S / omega
    e_star = np.exp(-2.0 * A)
    interior = m * v * omega * np.exp(-np.maximum(3.0 * alpha - np.pi, 0.0) * cot)
    peak = np.where(zeta < 0.5, interior, law.c * v)
    return peak, delta_max, duration, e_star


# --------------------------------------------------------------------------------------
# public API
# --------------------------------------------------------------------------------------


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


def achieved_restitution(law: ContactLaw, m_eff=None) -> float | np.ndarray:
    """Coefficient of restitution e* = v_out / v_n that ``law`` really produces.

    For Hertz and the Hunt–Crossley family it depends on the law alone (exact, Lambert W);
    for Kelvin–Voigt it depends on the mass ``m_eff`` [kg] through zeta (e* = exp(-2 alpha
    cot alpha), alpha = arccos zeta).
    """
    _check_law(law)
    if isinstance(law, KelvinVoigt):
        if m_eff is None:
            if math.isnan(law.m_ref):
                raise InputError("kelvin-voigt: achieved_restitution needs m_eff [kg]")
            m_eff = law.m_ref
        m = _positive_array(m_eff, "m_eff [kg]")
        return _out(_kelvin_voigt(law, m, np.ones_like(m))[3])
    return _restitution_z(float(law.z))


def predict(law: ContactLaw, m_eff, v_n) -> Prediction:
    """Closed-form peak force, maximum indentation, duration and restitution.

    Parameters
    ----------
    law : ContactLaw
        A law from :func:`get_law`.
    m_eff : float or array_like
        Effective mass [kg], > 0.
    v_n : float or array_like
        Normal approach speed [m/s], > 0 (broadcast against ``m_eff``).

    Returns
    -------
    Prediction
        Frozen dataclass of floats (scalar input) or arrays of the broadcast shape.
    """
    _check_law(law)
    m = _positive_array(m_eff, "m_eff [kg]")
    v = _positive_array(v_n, "v_n [m/s]")
    try:
        m, v = np.broadcast_arrays(m, v)
    except ValueError:
        raise InputError(f"m_eff shape {m.shape} and v_n shape {v.shape} do not broadcast") \
            from None
    if isinstance(law, KelvinVoigt):
        peak, dmax, dur, e_star = _kelvin_voigt(law, m, v)
    else:
        z, n, k = float(law.z), law.n, law.k
        d_H = ((n + 1.0) * m * v * v / (2.0 * k)) ** (1.0 / (n + 1.0))
        F_H = k * d_H**n
        phi, _ = _peak_factor(z, n)
        xi_max = (2.0 * _psi(z)) ** (1.0 / (n + 1.0))
        peak = phi * F_H
        dmax = xi_max * d_H
        dur = _duration_factor(z, n) * d_H / v
        e_star = np.full_like(m, _restitution_z(z))
    return Prediction(
        peak_force=_out(peak),
        max_indentation=_out(dmax),
        duration=_out(dur),
        restitution_achieved=_out(e_star),
        energy_dissipated=_out(0.5 * m * v * v * (1.0 - e_star**2)),
        law=law.name,
    )


def peak_force(T_c_minus, v_n, law: ContactLaw) -> float | np.ndarray:
    r"""Peak contact force [N] from the effective kinetic energy T_c^- [J].

    m_eff = 2 T_c^- / v_n^2, then the closed form of :func:`predict`. For Hertz and the
    Hunt–Crossley family the result depends on T_c^- alone,
    :math:`F_{max} = \varphi^*(z, n)\,k^{1/(n+1)}((n+1)T_c^-)^{n/(n+1)}` with
    :math:`\varphi^*` computed once per law (bounded root find); v_n is still required
    (it sets the damping chi = z/v_n and is checked) and matters for Kelvin–Voigt.

    Parameters
    ----------
    T_c_minus : float or array_like
        Effective kinetic energy [J], > 0.
    v_n : float or array_like
        Normal approach speed [m/s], > 0, broadcast against ``T_c_minus``.
    law : ContactLaw

    Returns
    -------
    float or ndarray
        Peak force [N], broadcast shape.
    """
    _check_law(law)
    T = _positive_array(T_c_minus, "T_c_minus [J]")
    v = _positive_array(v_n, "v_n [m/s]")
    if isinstance(law, KelvinVoigt):
        m = 2.0 * T / (v * v)
        return _out(_kelvin_voigt(law, m, v)[0])
    n = law.n
    phi, _ = _peak_factor(float(law.z), n)
    T, _v = np.broadcast_arrays(T, v)
    return _out(phi * law.k ** (1.0 / (n + 1.0)) * ((n + 1.0) * T) ** (n / (n + 1.0)))

