r"""The Hunt–Crossley family and its 8 members, with the family's closed forms.

The family shares

.. math:: f = k\,\delta^n\,(1 + \chi\,\dot\delta), \qquad \chi = h(e)/v_i ,

and the laws differ only in the dimensionless damping number :math:`z = \chi v_i = h(e)`
(a function of the coefficient of restitution e alone). Every closed form of the family
depends on (z, n) only. In the Hertz scales of :func:`~roverimpact.contact.hertz.hertz_scales`
(:math:`\delta_H`, :math:`F_H`, :math:`t_H = \delta_H/v`):

:math:`f = k\delta^n(1 + z\,u)` with :math:`u = \dot\delta/v` and
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
from abc import abstractmethod
from dataclasses import dataclass
from functools import lru_cache
from typing import ClassVar

import numpy as np

from ..exceptions import InputError
from .base import ContactLaw, Parameter, check_positive, check_restitution
from .hertz import hertz_duration_factor, hertz_scales

__all__ = [
    "CarvalhoMartins",
    "Flores",
    "Gonthier",
    "HerbertMcWhannell",
    "HuntCrossley",
    "HuntCrossleyFamily",
    "LankaraniNikravesh",
    "LeeWang",
    "ZhiyingQishao",
    "family_force",
    "one_family",
]


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

    parameters: ClassVar[dict[str, Parameter]] = {
        "k": Parameter("N/m^n", "stiffness"),
        "e": Parameter("", "coefficient of restitution"),
        "n": Parameter("", "exponent of the indentation", 1.5),
    }
    allow_e_zero: ClassVar[bool] = True

    def __post_init__(self):
        object.__setattr__(self, "k", check_positive(self.k, "k [N/m^n]", self.name))
        object.__setattr__(self, "n", check_positive(self.n, "n (exponent)", self.name))
        object.__setattr__(
            self, "e", check_restitution(self.e, self.name, allow_zero=self.allow_e_zero)
        )
        if not math.isfinite(self.z):  # e.g. gonthier's (1-e^2)/e for e < 5.6e-309
            raise InputError(f"{self.name}: e = {self.e!r} is too small: the damping number "
                             f"{self.equation} overflows; use e >= 1e-300")

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
        return family_force(self.k, self.n, self.z, d, np.asarray(delta_dot), np.asarray(v_i))

    def _closed_form(self, m, v):
        z, n = float(self.z), self.n
        d_H, F_H = hertz_scales(m, v, self.k, n)
        phi, _ = _peak_factor(z, n)
        xi_max = (2.0 * _psi(z)) ** (1.0 / (n + 1.0))
        e_star = np.full_like(m, _restitution_z(z))
        return phi * F_H, xi_max * d_H, _duration_factor(z, n) * d_H / v, e_star

    def _peak_force(self, T, v):
        """F_max = phi*(z, n) k^(1/(n+1)) ((n+1) T_c^-)^(n/(n+1)): T_c^- alone."""
        n = self.n
        phi, _ = _peak_factor(float(self.z), n)
        T, _v = np.broadcast_arrays(T, v)
        return phi * self.k ** (1.0 / (n + 1.0)) * ((n + 1.0) * T) ** (n / (n + 1.0))

    def achieved_restitution(self, m_eff=None) -> float:
        """e* = (1 - y)/z, y = -W_0(-(1+z) e^-(1+z)) (exact; depends on z alone, ``m_eff``
        is ignored)."""
        return _restitution_z(float(self.z))


def family_force(k, n, z, delta, delta_dot, v_i):
    r"""The family's force :math:`k\,\delta^n\,(1 + z\,\dot\delta / v_i)`, elementwise.

    ``delta`` >= 0 (not clamped here), ``k``, ``z`` and ``v_i`` numbers or arrays broadcast
    against it: :meth:`HuntCrossleyFamily.force` of one law, or pairs of several laws of
    one ``n`` in one evaluation (the simulator's contact pairs), with the same bits.
    """
    return k * delta**n * (1.0 + z * delta_dot / v_i)


def one_family(laws) -> bool:
    """Whether the ``laws`` (at least one) are all of the Hunt–Crossley family, with the
    family's own force (no subclass overriding it), and share one exponent ``n``: their
    forces are then :func:`family_force` with each law's ``k`` and ``z``, so the pairs of
    several laws can be evaluated in one call with the same bits (the own simulator's
    right-hand side, the MuJoCo engine's ``contact="laws"`` step)."""
    laws = list(laws)
    return (bool(laws) and all(isinstance(law, HuntCrossleyFamily)
                               and type(law).force is HuntCrossleyFamily.force
                               for law in laws)
            and len({law.n for law in laws}) == 1)


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


# --------------------------------------------------------------------------------------
# dimensionless helpers of the Hunt–Crossley family
# --------------------------------------------------------------------------------------


def _psi(x: float) -> float:
    """(x - ln(1+x)) / x^2, accurate for small |x| (series), x > -1."""
    if x <= -1.0:
        return math.inf
    if abs(x) < 1e-3:
        return 0.5 - x / 3 + x * x / 4 - x**3 / 5 + x**4 / 6
    if x > 1e150:  # x * x overflows
        return (1.0 - math.log1p(x) / x) / x
    return (x - math.log1p(x)) / (x * x)


def _div(a: float, b: float) -> float:
    """``a / b`` with IEEE semantics (as in C): +-inf or NaN for ``b == 0``."""
    if b != 0.0:
        return a / b
    if a == 0.0 or a != a:
        return math.nan
    return math.copysign(math.inf, a) * math.copysign(1.0, b)


def brentq(f, xa: float, xb: float, *, xtol: float, rtol: float, maxiter: int) -> float:
    """Root of ``f`` bracketed by ``[xa, xb]``: Brent's method, step for step the algorithm
    of ``scipy.optimize.brentq`` (``scipy/optimize/Zeros/brentq.c``, by Charles Harris), so
    that results are bit-identical to it (tested) without importing scipy.optimize
    (0.25-0.4 s). Raises ValueError if ``f(xa)`` and ``f(xb)`` have the same sign or the
    iteration does not converge in ``maxiter`` steps.
    """
    xpre, xcur = float(xa), float(xb)
    xblk = fblk = spre = scur = 0.0
    fpre, fcur = float(f(xpre)), float(f(xcur))
    if fpre == 0.0:
        return xpre
    if fcur == 0.0:
        return xcur
    if math.copysign(1.0, fpre) == math.copysign(1.0, fcur):
        raise ValueError("f(a) and f(b) must have different signs")
    for _ in range(maxiter):
        if fpre != 0.0 and fcur != 0.0 and (
                math.copysign(1.0, fpre) != math.copysign(1.0, fcur)):
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (xtol + rtol * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0.0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:  # interpolate
                stry = _div(-fcur * (xcur - xpre), fcur - fpre)
            else:  # extrapolate
                dpre = _div(fpre - fcur, xpre - xcur)
                dblk = _div(fblk - fcur, xblk - xcur)
                stry = _div(-fcur * (fblk * dblk - fpre * dpre), dblk * dpre * (fblk - fpre))
            if 2 * abs(stry) < min(abs(spre), 3 * abs(sbis) - delta):  # good short step
                spre, scur = scur, stry
            else:  # bisect
                spre = scur = sbis
        else:  # bisect
            spre = scur = sbis
        xpre, fpre = xcur, fcur
        xcur += scur if abs(scur) > delta else (delta if sbis > 0 else -delta)
        fcur = float(f(xcur))
    raise ValueError(f"brentq did not converge in {maxiter} iterations")


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
        e = brentq(lambda e: e * e * _psi(-z * e) - target, 0.5, 1.0,
                   xtol=1e-16, rtol=1e-15, maxiter=200)
        return e, 1.0 - z * e
    from scipy import special

    arg = -(1.0 + z) * math.exp(-(1.0 + z))
    y = -float(np.real(special.lambertw(arg, 0)))
    return (1.0 - y) / z, y


def _restitution_z(z: float) -> float:
    """Achieved restitution e* of the Hunt–Crossley family with damping number z >= 0."""
    return _restitution_zy(z)[0]


@lru_cache(maxsize=256)
def _peak_factor(z: float, n: float) -> tuple[float, float]:
    """(phi*, u*): peak force / F_H and the speed ratio u = delta_dot/v at the peak.

    The root lies in (0, 1), where :func:`_P` measures from the top end u = 1 and does not
    use e*: neither the Lambert W of e* nor scipy is needed (``roverimpact energy`` imports
    neither)."""
    if z == 0.0:
        return 1.0, 0.0
    a = n / (n + 1.0)
    if z > 1e300:
        # q = (1-u)/(1+zu) ~ 1/z would be subnormal (e < ~1e-300): z P from Q = z q
        def zP(u):
            Q = z * (1.0 - u) / (1.0 + z * u)
            return Q * u + Q * (Q / z) * _psi(Q)

        u = brentq(lambda u: zP(u) - a * u, 0.0, 1.0, xtol=1e-16, rtol=1e-15, maxiter=200)
        return (2.0 * zP(u)) ** a * z ** (-a) * (1.0 + z * u), u
    u = brentq(lambda u: z * _P(u, z, 0.0) - a * u, 0.0, 1.0,
               xtol=1e-16, rtol=1e-15, maxiter=200)
    return (2.0 * _P(u, z, 0.0)) ** a * (1.0 + z * u), u


@lru_cache(maxsize=256)
def _duration_factor(z: float, n: float) -> float:
    """t_c / t_H for the Hunt–Crossley family (1-D quadrature of the energy integral)."""
    from scipy import integrate
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
    if z <= 1e6:
        hi = integrate.quad(g, 0.0, 1.0, weight="alg", wvar=(0.0, -a), **opts)[0]
    else:
        # Strong damping (e < ~1e-6 for gonthier): 1 + z u leaves 1 in a layer u ~ 1/z and
        # the integrand is ~1/u above it, too thin a layer for one adaptive quadrature from
        # u = 0 (z > ~1e80). Pieces: u = r/z, r in [0, 1]; ln u in [-ln z, ln 1/2];
        # [1/2, 1] with the weight. The ratio is scaled by z (it would be subnormal for
        # z ~ 1e308): z ratio = (z u + Q psi(Q))/w with Q = z q.
        za = z**a

        def gz(u):
            w = 1.0 + z * u
            Q = z * (1.0 - u) / w
            return (2.0 * ((z * u + Q * _psi(Q)) / w)) ** (-a) * za / w

        def g_log(t):
            u = math.exp(t)
            return gz(u) * u * (1.0 - u) ** (-a)

        hi = (integrate.quad(lambda r: gz(r / z) * (1.0 - r / z) ** (-a), 0.0, 1.0,
                             **opts)[0] / z
              + integrate.quad(g_log, -math.log(z), math.log(0.5), **opts)[0]
              + integrate.quad(gz, 0.5, 1.0, weight="alg", wvar=(0.0, -a), **opts)[0])
    if z < 0.05:
        lo = integrate.quad(g, s, 0.0, weight="alg", wvar=(-a, 0.0), **opts)[0]
        return 2.0 / (n + 1.0) * (lo + hi)
    # Restitution branch in x = z (u - s) / y in [0, X], X = z e*/y: with 1 + z u = y (1 + x)
    # and P = (u - s) R / z, R = ln(1+x)/x - y, the integrand becomes
    # (2 R x / z^2)^(-a) / (z (1 + x)) dx, free of the 1/(1 + z u) near-singularity that
    # makes the exit slow for strong damping (y ~ 1e-42 for z = 100). y underflows to 0
    # for z > ~745 (e < ~1e-3 for gonthier): beyond x = 1 the integral is taken in
    # t = ln x up to L = ln X = ln(1 - y) - ln y, with ln y exact from y e^-y = (1+z) e^-(1+z),
    # and z^2 is kept out of the powers (it overflows for z > 1e154).
    c = z ** (2.0 * a - 1.0)  # (z^2)^a / z
    ly = math.log(y) if y > 1e-200 else math.log1p(z) - (1.0 + z) + y
    L = math.log1p(-y) - ly  # ln X

    def R(x):
        l1 = 1.0 - x / 2 + x * x / 3 - x**3 / 4 if x < 1e-4 else math.log1p(x) / x
        return l1 - y

    def f_lin(x):  # times the weight x^(-a)
        return c * (2.0 * R(x)) ** (-a) / (1.0 + x)

    def Rx(t):  # R x at x = e^t >= 1: ln(1 + x) - y x, without forming x
        return t + math.log1p(math.exp(-t)) - math.exp(ly + t)

    def f_log(t):  # x = exp(t), dx = x dt
        return c * (2.0 * Rx(t)) ** (-a) / (1.0 + math.exp(-t))

    lo = integrate.quad(f_lin, 0.0, 1.0 if L > 0.0 else math.exp(L), weight="alg",
                        wvar=(-a, 0.0), **opts)[0]
    if 0.0 < L <= 200.0:
        lo += integrate.quad(f_log, 0.0, L, **opts)[0]
    elif L > 200.0:
        # t in [0, 64]: the approach to ~t^-a; t in [64, L - 40]: R x = t to 1e-19
        # (ln(1 + 1/x) < e^-64, y x < e^-40), so the integral of c (2t)^-a is exact; t in
        # [L - 40, L]: the exit, where y x -> 1 - y, in r = L - t (y x = (1 - y) e^-r)
        def f_exit(r):
            t = L - r
            rx = t + math.log1p(math.exp(-t)) - (1.0 - y) * math.exp(-r)
            return c * (2.0 * rx) ** (-a) / (1.0 + math.exp(-t))

        lo += integrate.quad(f_log, 0.0, 64.0, points=[1.0], **opts)[0]
        lo += c * 2.0 ** (-a) * ((L - 40.0) ** (1.0 - a) - 64.0 ** (1.0 - a)) / (1.0 - a)
        lo += integrate.quad(f_exit, 0.0, 40.0, **opts)[0]
    return 2.0 / (n + 1.0) * (lo + hi)
