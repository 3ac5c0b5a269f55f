"""Closed forms of roverimpact.contact against independent references.

References used here (none is the code under test):
- numerical integration of m x'' = -max(f, 0) (impact_1dof, a different method: ODE
  solver with events, versus energy-integral closed forms / root finds / quadrature);
- the classical Hertz impact (Johnson, Contact Mechanics, §11.4), written out below;
- energy conservation for e = 1;
- the implicit restitution relation chi v (1 + e*) = ln[(1 + chi v)/(1 - chi e* v)]
  evaluated directly with numpy.
"""

import functools
import math

import numpy as np
import pytest

from roverimpact import InputError
from roverimpact.contact import (
    LAWS,
    achieved_restitution,
    effective_modulus,
    get_law,
    hertz_duration_factor,
    hertz_stiffness,
    impact_1dof,
    line_contact_stiffness,
    peak_force,
    predict,
    restitution_table,
)

FAMILY = [name for name in LAWS if name not in ("hertz", "kelvin-voigt")]


def _law(name, k, e, n, m):
    if name == "kelvin-voigt":
        return get_law(name, k=k, e=e, m_eff=m)
    if name == "hertz":
        return get_law(name, k=k, n=n)
    return get_law(name, k=k, e=e, n=n)


GRID = [
    # (m [kg], v [m/s], k [N/m^n], e, n)
    (12.0, 0.5, 1e6, 0.8, 1.5),
    (0.3, 2.0, 5e8, 0.3, 1.5),
    (150.0, 0.05, 2e5, 0.55, 1.0),
    (2.0, 1.3, 3e7, 0.95, 1.2),
    (40.0, 0.2, 1e9, 0.1, 2.0),
]


@pytest.mark.parametrize("name", list(LAWS))
@pytest.mark.parametrize(("m", "v", "k", "e", "n"), GRID)
def test_closed_form_matches_integration(name, m, v, k, e, n):
    if name == "kelvin-voigt":
        n = 1.0
    law = _law(name, k, e, n, m)
    p = predict(law, m, v)
    r = impact_1dof(law, m, v)
    tol = 1e-6
    assert p.peak_force == pytest.approx(r.peak_force, rel=tol)
    assert p.max_indentation == pytest.approx(r.max_indentation, rel=tol)
    assert p.duration == pytest.approx(r.duration, rel=tol)
    assert p.restitution_achieved == pytest.approx(r.restitution_achieved, rel=tol)
    assert p.energy_dissipated == pytest.approx(r.energy_dissipated, rel=tol, abs=1e-9 * m * v * v)
    # peak_force from T_c^- = 1/2 m v^2 is the same number
    assert peak_force(0.5 * m * v * v, v, law) == pytest.approx(r.peak_force, rel=tol)


@pytest.mark.parametrize("name", ["flores", "gonthier"])
def test_strong_damping_matches_integration(name):
    """e = 0.02: z ~ 50-80, exit speed close to v/z where the force vanishes."""
    law = get_law(name, k=1e6, e=0.02)
    p, r = predict(law, 5.0, 0.4), impact_1dof(law, 5.0, 0.4)
    for f in ("peak_force", "max_indentation", "duration", "restitution_achieved"):
        assert getattr(p, f) == pytest.approx(getattr(r, f), rel=1e-6), f


@pytest.mark.parametrize("name", FAMILY)
@pytest.mark.parametrize("e", [0.05, 0.3, 0.7, 0.99])
def test_restitution_solves_implicit_relation(name, e):
    law = get_law(name, k=1.0, e=e)
    z, es = law.z, achieved_restitution(law)
    assert 0 < es < 1 and z * es < 1
    if 1 - z * es < 1e-6:
        pytest.skip("relation ill-conditioned as z e* -> 1; covered by the integration tests")
    lhs, rhs = z * (1 + es), math.log((1 + z) / (1 - z * es))
    assert lhs == pytest.approx(rhs, rel=1e-9)


def test_max_indentation_energy_integral():
    """delta_max^(n+1) = (n+1) m / (k chi^2) [chi v - ln(1 + chi v)] (written out)."""
    m, v, k, n = 7.0, 0.9, 4e6, 1.5
    law = get_law("hunt-crossley", k=k, e=0.4, n=n)
    chi = law.chi(v)
    expected = ((n + 1) * m / (k * chi**2) * (chi * v - math.log1p(chi * v))) ** (1 / (n + 1))
    assert predict(law, m, v).max_indentation == pytest.approx(expected, rel=1e-13)


def test_hertz_elastic_closed_form_and_energy():
    m, v, k, n = 3.0, 1.1, 2e7, 1.5
    law = get_law("hertz", k=k, n=n)
    d = ((n + 1) * m * v**2 / (2 * k)) ** (1 / (n + 1))
    p = predict(law, m, v)
    assert p.max_indentation == pytest.approx(d, rel=1e-14)
    assert p.peak_force == pytest.approx(k * d**n, rel=1e-14)
    assert p.restitution_achieved == 1.0 and p.energy_dissipated == 0.0
    r = impact_1dof(law, m, v)
    T = 0.5 * m * v**2
    assert abs(r.energy_dissipated) < 1e-9 * T
    # energy along the history: 1/2 m delta_dot^2 + k delta^(n+1)/(n+1) = T
    E = 0.5 * m * r.delta_dot**2 + k * r.delta ** (n + 1) / (n + 1)
    np.testing.assert_allclose(E, T, rtol=1e-9)


def test_hertz_duration_factor_gamma():
    """(2/(n+1)) B(1/2, 1/(n+1)) via math.gamma; 2.9432 for n = 3/2 (Johnson eq. 11.24)."""
    for n in (1.0, 1.5, 2.0):
        b = 1 / (n + 1)
        ref = 2 / (n + 1) * math.gamma(0.5) * math.gamma(b) / math.gamma(0.5 + b)
        assert hertz_duration_factor(n) == pytest.approx(ref, rel=1e-14)
    assert hertz_duration_factor(1.5) == pytest.approx(2.9432, abs=1e-4)
    # n = 1: linear spring, half period pi sqrt(m/k) = pi delta_max / v
    assert hertz_duration_factor(1.0) == pytest.approx(math.pi, rel=1e-14)


def test_steel_sphere_on_steel_half_space():
    """Johnson, Contact Mechanics §11.4: sphere of radius R, mass m, speed V on a half-space.

    delta* = (15 m V^2 / (16 E* R^(1/2)))^(2/5), P* = 4/3 E* R^(1/2) delta*^(3/2),
    t = 2.87 (m^2 / (R E*^2 V))^(1/5).
    """
    E, nu, rho, R, V = 210e9, 0.3, 7850.0, 0.01, 1.0
    m = rho * 4 / 3 * math.pi * R**3
    E_star = 1 / (2 * (1 - nu**2) / E)
    assert effective_modulus(E, nu, E, nu) == pytest.approx(E_star, rel=1e-14)
    k = hertz_stiffness(E_star, R)
    assert k == pytest.approx(4 / 3 * E_star * math.sqrt(R), rel=1e-14)
    d_ref = (15 * m * V**2 / (16 * E_star * math.sqrt(R))) ** 0.4
    P_ref = 4 / 3 * E_star * math.sqrt(R) * d_ref**1.5
    t_ref = 2.87 * (m**2 / (R * E_star**2 * V)) ** 0.2
    law = get_law("hertz", k=k)
    for res in (predict(law, m, V), impact_1dof(law, m, V)):
        assert res.max_indentation == pytest.approx(d_ref, rel=1e-7)
        assert res.peak_force == pytest.approx(P_ref, rel=1e-7)
        assert res.duration == pytest.approx(t_ref, rel=2e-3)  # 2.87 is rounded
    # orders of magnitude as in Johnson's example: micrometres, kilonewtons, microseconds
    assert 1e-6 < d_ref < 1e-4 and 1e3 < P_ref < 1e5 and 1e-5 < t_ref < 1e-4


def test_two_spheres_and_line_contact():
    assert hertz_stiffness(1e9, 0.02, 0.02) == pytest.approx(4 / 3 * 1e9 * math.sqrt(0.01))
    assert line_contact_stiffness(2e9, 0.1) == pytest.approx(math.pi / 4 * 2e9 * 0.1)
    assert effective_modulus(1e9, 0.5) == pytest.approx(1e9 / 0.75)
    with pytest.raises(InputError, match="nu1"):
        effective_modulus(1e9, 0.7)
    with pytest.raises(InputError, match="R1"):
        hertz_stiffness(1e9, -1.0)


def test_kelvin_voigt_restitution_identity():
    """Clamped linear dashpot: e* = e^(2 alpha/pi), alpha = arccos zeta (Schwager-Pöschel)."""
    for e in (0.1, 0.5, 0.9):
        law = get_law("kelvin-voigt", k=1e5, e=e, m_eff=2.0)
        zeta = law.damping_ratio(2.0)
        assert achieved_restitution(law, 2.0) == pytest.approx(
            e ** (2 * math.acos(zeta) / math.pi), rel=1e-12)


@pytest.mark.parametrize("name", list(LAWS))
def test_peak_force_monotonic_in_T(name):
    law = _law(name, 1e6, 0.6, 1.5, 10.0)
    T = np.geomspace(1e-3, 1e3, 200)
    F = peak_force(T, 0.5, law)
    assert F.shape == T.shape
    if name == "kelvin-voigt":
        # fixed c: for zeta >= 1/2 (small masses) the peak is c v_n at first touch
        assert np.all(np.diff(F) >= 0) and F[0] == pytest.approx(law.c * 0.5)
    else:
        assert np.all(np.diff(F) > 0)


def test_peak_force_batched_matches_scalar_predict():
    law = get_law("lankarani-nikravesh", k=2e6, e=0.7)
    rng = np.random.default_rng(0)
    T, v = rng.uniform(0.1, 50, 20), rng.uniform(0.1, 2, 20)
    F = peak_force(T, v, law)
    for i in range(0, 20, 5):
        assert F[i] == pytest.approx(predict(law, 2 * T[i] / v[i] ** 2, v[i]).peak_force,
                                     rel=1e-13)


def test_restitution_table_shape_and_honouring_laws():
    df = restitution_table()
    assert list(df.columns) == [0.1, 0.3, 0.5, 0.7, 0.9]
    assert "hertz" not in df.index and len(df) == 9
    # Carvalho-Martins' fit honours e to < 0.03 absolute; Hunt-Crossley does not at e = 0.1
    assert np.all(np.abs(df.loc["carvalho-martins"].to_numpy() - df.columns.to_numpy()) < 0.03)
    assert df.loc["hunt-crossley", 0.1] > 0.5


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda law: predict(law, 1.0, 0.0), r"v_n \[m/s\] must be finite and > 0"),
        (lambda law: predict(law, -1.0, 1.0), r"m_eff \[kg\] must be finite and > 0"),
        (lambda law: impact_1dof(law, 1.0, -2.0), r"v_n"),
        (lambda law: peak_force([1.0, -1.0], 1.0, law), r"T_c_minus \[J\]"),
        (lambda law: peak_force(1.0, np.nan, law), r"v_n"),
        (lambda law: predict("hertz", 1.0, 1.0), "ContactLaw"),
        # finite inputs whose kinetic energy or force overflows (was inf/NaN or, from the
        # CLI, an OverflowError traceback)
        (lambda law: predict(law, 1e300, 1e300), r"1/2 m_eff v_n\^2 .* overflows floating"),
        (lambda law: predict(law, [1.0, 1e300], 1e10), r"m_eff = 1e\+300 kg, v_n = 1e\+10"),
        (lambda law: predict(get_law("hertz", k=1e-300), 1e300, 1e3), "peak force .* overflows"),
        (lambda law: peak_force(1e300, 1e-300, get_law("kelvin-voigt", k=1e6, c=10.0)),
         "peak force .* overflows"),
        (lambda law: impact_1dof(law, 1e300, 1e300), "out of floating-point range"),
    ],
)
def test_bad_inputs(call, match):
    law = get_law("hunt-crossley", k=1e6, e=0.5)
    with pytest.raises(InputError, match=match):
        call(law)


@pytest.mark.parametrize("m", [0.05, 0.3, 1.0, 10.0])  # zeta 6.7, 2.7, 1.5, 0.47
def test_kelvin_voigt_given_c_over_and_under_damped(m):
    law = get_law("kelvin-voigt", k=1e4, c=300.0)
    p, r = predict(law, m, 0.5), impact_1dof(law, m, 0.5)
    for f in ("peak_force", "max_indentation", "duration", "restitution_achieved"):
        assert getattr(p, f) == pytest.approx(getattr(r, f), rel=1e-6), f


# --- the peak factor without scipy.optimize (start-up of `roverimpact energy`) -------------

def _brent_cases():
    from roverimpact.contact.hunt_crossley import _P

    cases = [
        (lambda x: x**3 - 2 * x - 5, 2.0, 3.0),
        (lambda x: math.cos(x) - x, 0.0, 1.0),
        (lambda x: math.exp(x) - 10.0, -5.0, 5.0),
        (lambda x: (x - 0.3) ** 9, 0.0, 1.0),      # flat root: many bisections
        (lambda x: math.atan(1e6 * (x - 0.123456789)), -1.0, 1.0),
        (lambda x: x, -1.0, 0.0),                   # root at an end
    ]
    for z in (1e-6, 0.01, 0.3, 1.0, 7.5, 100.0):
        for n in (1.0, 1.5, 2.0):
            a = n / (n + 1.0)
            cases.append((lambda u, z=z, a=a: z * _P(u, z, 0.0) - a * u, 0.0, 1.0))
    return cases


def test_brentq_port_is_bit_identical_to_scipy():
    """The port of Brent's method takes scipy's steps: same root to the last bit."""
    from scipy import optimize

    from roverimpact.contact.hunt_crossley import brentq

    for f, a, b in _brent_cases():
        for xtol, rtol in ((1e-16, 1e-15), (2e-12, 8.881784197001252e-16), (1e-6, 1e-6)):
            ref = optimize.brentq(f, a, b, xtol=xtol, rtol=rtol, maxiter=200)
            assert brentq(f, a, b, xtol=xtol, rtol=rtol, maxiter=200) == ref
    with pytest.raises(ValueError, match="different signs"):
        brentq(lambda x: x * x + 1.0, -1.0, 1.0, xtol=1e-12, rtol=1e-12, maxiter=50)
    with pytest.raises(ValueError, match="did not converge"):
        brentq(lambda x: (x - 0.3) ** 9, 0.0, 1.0, xtol=1e-16, rtol=1e-15, maxiter=3)


def test_peak_factor_equals_the_scipy_root_find():
    """phi*(z, n) as it was computed before (scipy's brentq on P measured with s = -e*)
    and as it is now (the port, P from the top end): identical, and to 1e-12 at worst."""
    from scipy import optimize

    from roverimpact.contact import hunt_crossley as hc

    for name in FAMILY:
        for e in (0.05, 0.3, 0.55, 0.8, 0.95, 0.999, 1.0):
            for n in (1.0, 1.2, 1.5, 2.0):
                law = get_law(name, k=1e7, e=e, n=n)
                z = float(law.z)
                hc._peak_factor.cache_clear()
                phi, u = hc._peak_factor(z, n)
                if z == 0.0:
                    assert (phi, u) == (1.0, 0.0)
                    continue
                a = n / (n + 1.0)
                s = -hc._restitution_z(z)
                u_ref = optimize.brentq(lambda u, z=z, a=a, s=s: z * hc._P(u, z, s) - a * u,
                                        0.0, 1.0, xtol=1e-16, rtol=1e-15, maxiter=200)
                phi_ref = (2.0 * hc._P(u_ref, z, s)) ** a * (1.0 + z * u_ref)
                assert u == u_ref and phi == phi_ref, (name, e, n)
                assert abs(phi - phi_ref) <= 1e-12 * phi_ref


def test_peak_force_does_not_import_scipy_optimize():
    """`roverimpact energy` prints the Hunt-Crossley peak force: that must not pay for
    importing scipy.optimize (0.25-0.4 s of a 1 s command)."""
    import subprocess
    import sys

    code = ("import sys; from roverimpact.contact import get_law, peak_force; "
            "f = peak_force(1.0, 0.5, get_law('hunt-crossley', k=1e7, e=0.8, n=1.5)); "
            "assert f > 0; print('scipy.optimize' in sys.modules, 'scipy.special' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["False", "False"]


# --- strong damping (e -> 0) against an integration written out here -----------------------

# chi v_i = z(e) of the laws that reach any z, from their papers (not from the code)
_Z_OF_E = {"gonthier": lambda e: (1.0 - e * e) / e, "flores": lambda e: 8.0 * (1.0 - e) / (5.0 * e)}


@functools.lru_cache(maxsize=32)
def _hunt_crossley_ode(z, n, k, m, v, rtol=1e-11):
    """m x'' = -max(k x^n (1 + z x'/v), 0), x(0) = 0, x'(0) = v, to separation x = 0.

    Radau (implicit: for large z the slow exit at x' ~ -v/z is stiff) with events written
    out: the peak force where dF/dt = k x^(n-1) [n x' (1 + z x'/v) + x (z/v) x''] changes
    sign, the maximum indentation x' = 0 and the separation. Returns
    (peak force [N], max indentation [m], duration [s], e* = -x'(t_c)/v)."""
    from scipy.integrate import solve_ivp

    d = (m * v * v / k) ** (1.0 / (n + 1.0))  # a length, for the absolute tolerance only

    def force(x, xd):
        return max(k * max(x, 0.0) ** n * (1.0 + z * xd / v), 0.0)

    def rhs(_t, s):
        return [s[1], -force(s[0], s[1]) / m]

    def separation(_t, s):
        return s[0]

    def top(_t, s):
        return s[1]

    def dfdt(_t, s):  # dF/dt / (k x^(n-1))
        x, xd = s
        return n * xd * (1.0 + z * xd / v) - x * (z / v) * force(x, xd) / m

    separation.terminal, separation.direction = True, -1
    top.direction = dfdt.direction = -1
    sol = solve_ivp(rhs, (0.0, 1e9 * d / v), [0.0, v], method="Radau", rtol=rtol,
                    atol=[rtol * 1e-3 * d, rtol * 1e-3 * v], events=[separation, top, dfdt])
    assert sol.status == 1, sol.message
    return (force(*sol.y_events[2][0]), sol.y_events[1][0][0], sol.t_events[0][0],
            -sol.y_events[0][0][1] / v)


@pytest.mark.parametrize(("name", "e"), [
    ("gonthier", 1.0), ("gonthier", 0.3), ("gonthier", 1e-2), ("gonthier", 1e-3),
    ("gonthier", 1e-5), ("gonthier", 1e-8), ("flores", 1e-3), ("flores", 1e-6),
    ("flores", 1e-8),
])
def test_small_restitution_matches_written_out_integration(name, e):
    """e -> 0 (z up to 1.6e8): the closed forms against the integration above (for
    z > ~745, e < ~1e-3, the restitution root y underflowed: ZeroDivisionError in the
    duration, so predict() and `roverimpact contact` crashed)."""
    m, v, k, n = 12.0, 0.5, 1e6, 1.5
    law = get_law(name, k=k, e=e)
    assert law.z == pytest.approx(_Z_OF_E[name](e), rel=1e-15)
    F, dmax, tc, es = _hunt_crossley_ode(_Z_OF_E[name](e), n, k, m, v)
    p = predict(law, m, v)
    assert p.peak_force == pytest.approx(F, rel=1e-9)
    assert p.max_indentation == pytest.approx(dmax, rel=1e-9)
    assert p.duration == pytest.approx(tc, rel=1e-8)
    assert p.restitution_achieved == pytest.approx(es, rel=1e-8)
    assert peak_force(0.5 * m * v * v, v, law) == pytest.approx(F, rel=1e-9)


@pytest.mark.parametrize("e", [1e-100, 1e-300])
@pytest.mark.parametrize("n", [1.0, 1.5, 3.0])
def test_vanishing_restitution_asymptotics(e, n):
    """z = (1-e^2)/e -> inf (gonthier), beyond any integration. From the energy integral
    (docs/contact.md), to relative O(ln z / z): e* = 1/z; xi_max^(n+1) = 2/z; the peak at
    u = 1/(1+a), a = n/(n+1), where F/F_H = 2^a (1-u)^a u z^(1-a); and, the exit at
    x' ~ -v/z dominating, t_c/t_H = 2/(n+1) 2^-a z^a / (1-a)."""
    m, v, k = 12.0, 0.5, 1e6
    z, a = 1.0 / e, n / (n + 1.0)
    d_H = ((n + 1.0) * m * v * v / (2.0 * k)) ** (1.0 / (n + 1.0))
    F_H, t_H = k * d_H**n, d_H / v
    u = 1.0 / (1.0 + a)
    p = predict(get_law("gonthier", k=k, e=e, n=n), m, v)
    assert p.restitution_achieved == pytest.approx(1.0 / z, rel=1e-12)
    assert p.max_indentation == pytest.approx(d_H * (2.0 / z) ** (1.0 / (n + 1.0)), rel=1e-12)
    peak = F_H * 2.0**a * (1.0 - u) ** a * u * math.exp((1.0 - a) * math.log(z))
    assert p.peak_force == pytest.approx(peak, rel=1e-12)
    tc = t_H * 2.0 / (n + 1.0) * 2.0 ** (-a) * math.exp(a * math.log(z)) / (1.0 - a)
    assert p.duration == pytest.approx(tc, rel=1e-12)


def test_restitution_below_floating_point_range_is_refused():
    """e = 1e-320: (1-e^2)/e overflows to inf; one InputError, not inf/NaN predictions."""
    for name in ("gonthier", "flores"):
        with pytest.raises(InputError, match="too small"):
            get_law(name, k=1e6, e=1e-320)


@pytest.mark.parametrize(("name", "e"), [
    ("gonthier", 1.0), ("gonthier", 1e-3), ("gonthier", 1e-5), ("gonthier", 1e-8),
    ("flores", 1e-6), ("flores", 1e-8),
])
def test_impact_1dof_finds_an_early_peak(name, e):
    """For e <= 1e-5 the peak force comes before impact_1dof's first evenly spaced sample
    (the exit lasts 1e3-1e5 Hertz times): it returned 0 N with 9e-5 m of indentation. Against
    the integration written out above and the closed form."""
    m, v, k, n = 12.0, 0.5, 1e6, 1.5
    law = get_law(name, k=k, e=e)
    F, dmax, tc, es = _hunt_crossley_ode(_Z_OF_E[name](e), n, k, m, v)
    r = impact_1dof(law, m, v, max_duration=1e6)
    assert r.peak_force == pytest.approx(F, rel=1e-9)
    assert r.peak_force == pytest.approx(predict(law, m, v).peak_force, rel=1e-9)
    assert r.max_indentation == pytest.approx(dmax, rel=1e-9)
    assert r.duration == pytest.approx(tc, rel=1e-8)
    assert r.restitution_achieved == pytest.approx(es, rel=1e-8)
    assert 0.0 < r.time_of_peak <= r.time_of_max_indentation * (1.0 + 1e-9)
    assert r.peak_force >= r.force.max()
