"""Coulomb friction at impact (roverimpact.frictional).

References, independent of the solver:

* closed forms derived in the docstrings by hand (momentum balance, Newton's law on the
  normal, Coulomb's law): a point mass striking a plane obliquely (planar and 3-D, where
  the polygonal cone reduces to a Euclidean projection), a tilted rod striking the
  ground with one end (Brach's stick/slip threshold), and an energy gain with e = 1;
* limits: ``mu = 0`` against the frictionless solver ``unilateral_impact``, ``mu = inf``
  against ``unilateral_impact`` with the tangent rows held as bilateral rows (an SVD
  split of a different problem), T_c^- against ``partition`` (rank-revealing QR);
* hypothesis property tests over drawn mass matrices and rows: momentum balance,
  complementarity, impulses inside the polygonal cone, maximal dissipation of the
  sliding contacts, energy, each checked from ``v+`` and the impulses alone.

``frictional_holding_rows`` with ``friction="coulomb"`` is checked against
``frictional_impact`` on the same rows: that proves the label plumbing, not the physics.
"""

from __future__ import annotations

import itertools
import os
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import roverimpact as ri
from roverimpact.exceptions import EnergyGainWarning
from roverimpact.frictional import (
    FACETS,
    MU_MAX,
    frictional_active_set,
    frictional_impact,
)
from roverimpact.scenario.build import holding_rows
from roverimpact.scenario.sweep import _obstacle_basis

from .reference.systems import compass_gait

EXAMPLES = int(os.environ.get("RI_FRICTION_EXAMPLES", "80"))
PROPS = settings(max_examples=EXAMPLES, deadline=None,
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])


def _polygon(m=FACETS):
    """Directions d_j of the polygonal cone (unit vectors at 2 pi j / m)."""
    th = 2 * np.pi * np.arange(m) / m
    return np.stack([np.cos(th), np.sin(th)], axis=1)


def _gauge(tau, m=FACETS):
    """Smallest ``g`` with ``tau`` in ``g`` times the polygon (planar: |tau|)."""
    tau = np.atleast_1d(tau)
    if tau.shape[-1] == 1:
        return float(abs(tau[0]))
    D = _polygon(m)
    mid = D + np.roll(D, -1, axis=0)  # edge midpoints, |.| = 2 cos(pi/m)
    return float(np.max(mid @ tau) / (2 * np.cos(np.pi / m) ** 2))


def _project_polygon(x, radius, m=FACETS):
    """Euclidean projection of the 2-vector ``x`` onto the regular m-gon of circumradius
    ``radius`` (vertices at 2 pi j / m), by brute force over its edges."""
    if _gauge(x, m) <= radius:
        return x
    V = radius * _polygon(m)
    best, dist = None, np.inf
    for j in range(m):
        a, b = V[j], V[(j + 1) % m]
        t = np.clip((x - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
        p = a + t * (b - a)
        if np.linalg.norm(x - p) < dist:
            best, dist = p, np.linalg.norm(x - p)
    return best


# ------------------------------------------------------------------------------------
# Closed forms
# ------------------------------------------------------------------------------------


@pytest.mark.parametrize("alpha_deg", [0.0, 25.0])
@pytest.mark.parametrize("e", [0.0, 0.5])
@pytest.mark.parametrize("factor", [0.5, 0.99, 1.01, 2.0])
def test_point_mass_oblique_impact_on_inclined_plane(alpha_deg, e, factor):
    r"""A point of mass m (coordinates x, z) strikes a plane inclined at alpha.

    ::

          \  v-
           \|
        ____*________  plane, normal n = (-sin a, cos a), tangent t = (cos a, sin a)

    Rows n and t (unit), M = m I, so the normal and tangential impulses decouple. With
    :math:`w = -n\cdot v^- > 0` and :math:`u = t\cdot v^-`, Newton's law gives
    :math:`P_n = m(1+e)w`; sticking needs :math:`P_t = -m u`, allowed iff
    :math:`|P_t| \le \mu P_n`, i.e.

    .. math::  \mu \ge \mu^* = \frac{|u|}{(1+e)\, w}.

    Below the threshold the point slides with :math:`P_t = -\mu P_n\,\mathrm{sgn}\,u`
    and keeps the tangential speed :math:`u - \mu(1+e)w\,\mathrm{sgn}\,u` (same sign).
    """
    m = 3.0
    a = np.radians(alpha_deg)
    n = np.array([-np.sin(a), np.cos(a)])
    t = np.array([np.cos(a), np.sin(a)])
    w, u = 1.2, -0.7
    v = u * t - w * n
    mu_star = abs(u) / ((1 + e) * w)
    mu = factor * mu_star
    r = frictional_impact(m * np.eye(2), v, [n], [[t]], mu, e)
    Pn = m * (1 + e) * w
    assert r.impulse[0] == pytest.approx(Pn, rel=1e-12)
    if mu >= mu_star:
        assert r.state.tolist() == ["sticking"]
        assert r.impulse_tangent[0, 0] == pytest.approx(-m * u, rel=1e-12)
        np.testing.assert_allclose(r.v_plus, e * w * n, atol=1e-12)
        assert r.hold_tangent.tolist() == [[True]]
    else:
        assert r.state.tolist() == ["sliding"]
        assert r.impulse_tangent[0, 0] == pytest.approx(-mu * Pn * np.sign(u), rel=1e-12)
        ut = u - mu * (1 + e) * w * np.sign(u)
        np.testing.assert_allclose(r.v_plus, ut * t + e * w * n, atol=1e-12)
        assert r.hold_tangent.tolist() == [[False]]
    assert r.hold_normal.tolist() == [True]


@pytest.mark.parametrize("phi_deg", [0.0, 10.0, 22.5, 37.0, 45.0, 100.0, 200.0])
@pytest.mark.parametrize("mu", [0.1, 0.3, 0.45, 0.6, 1.0])
def test_point_mass_3d_friction_is_projection_on_polygon(phi_deg, mu):
    r"""A 3-D point of mass m hits the floor at normal speed w, slipping at speed s in the
    direction phi of the floor plane. Rows: z (normal), x and y (tangent), M = m I.

    :math:`P_n = m(1+e)w`. Slip after the impact :math:`s^+ = s^- + \tau/m`; Coulomb's
    law on the polygon with maximal dissipation says :math:`\tau` maximizes
    :math:`-\tau\cdot s^+` over the polygon :math:`C` of circumradius
    :math:`\mu P_n`. That is the optimality condition of the Euclidean projection
    :math:`\tau = \Pi_C(-m s^-)` (since :math:`-m s^- - \tau = -m s^+`): the friction
    impulse is the sticking impulse projected on the polygon (computed here by brute
    force over the edges). Along a vertex direction (phi = 0, 45, 200 - 20 off...) the
    polygon and the circular cone agree.
    """
    m, w, s, e = 2.0, 1.0, 0.8, 0.3
    ph = np.radians(phi_deg)
    s_minus = s * np.array([np.cos(ph), np.sin(ph)])
    v = np.array([s_minus[0], s_minus[1], -w])
    r = frictional_impact(m * np.eye(3), v, [[0, 0, 1.0]], [[[1.0, 0, 0], [0, 1.0, 0]]],
                          mu, e)
    Pn = m * (1 + e) * w
    tau = _project_polygon(-m * s_minus, mu * Pn)
    assert r.impulse[0] == pytest.approx(Pn, rel=1e-12)
    np.testing.assert_allclose(r.impulse_tangent[0], tau, atol=1e-11)
    np.testing.assert_allclose(r.v_plus[:2], s_minus + tau / m, atol=1e-11)
    sticks = _gauge(-m * s_minus) <= mu * Pn
    assert r.state[0] == ("sticking" if sticks else "sliding")


def _rod(m=2.0, length=1.0):
    """Free planar rod, coordinates (x, z, theta) of the centre, M = diag(m, m, m l^2/12)."""
    return np.diag([m, m, m * length**2 / 12])


def _rod_end_rows(theta, length=1.0):
    """Rows of the lower end B = G - (l/2)(cos th, sin th): tangent (x), normal (z)."""
    s, c = np.sin(theta), np.cos(theta)
    return np.array([0.0, 1.0, -0.5 * length * c]), np.array([1.0, 0.0, 0.5 * length * s])


@pytest.mark.parametrize("theta_deg", [15.0, 40.0, 60.0, 75.0])
@pytest.mark.parametrize("e", [0.0, 0.5])
@pytest.mark.parametrize("factor", [0.3, 0.95, 1.05, 3.0])
def test_tilted_rod_striking_ground_stick_slip_threshold(theta_deg, e, factor):
    r"""A rod (m, l) tilted at theta falls without rotation at speed V and strikes the
    ground with its lower end B (Brach, *Mechanical Impact Dynamics*, ch. 5)::

                 /
               G/      theta from horizontal
              /
        _____B______   ground

    With :math:`I = ml^2/12`, :math:`(l/2)^2/I = 3/m`, the inverse inertia at B in
    (tangent x, normal z) is :math:`K = \frac1m\begin{pmatrix}1+3s^2 & -3sc\\ -3sc &
    1+3c^2\end{pmatrix}` (:math:`s, c = \sin, \cos\theta`, :math:`\det K = 4/m^2`).
    Before the impact B has slip 0 and normal velocity -V. Sticking needs
    :math:`K P = (0, (1+e)V)`: :math:`P_t = \tfrac{m}{4}3sc(1+e)V`,
    :math:`P_n = \tfrac{m}{4}(1+3s^2)(1+e)V`, so B sticks iff

    .. math::  \mu \ge \mu^* = \frac{3 s c}{1 + 3 s^2}

    (independent of e). Below it B slides backwards with :math:`P_t = \mu P_n` and
    :math:`P_n = (1+e) m V / (1 + 3c^2 - 3\mu s c)`. T_c^- is the energy of the
    contact-point velocity :math:`g = (0, -V)` in the metric of the held rows: sticking
    holds both, :math:`T_c^- = \tfrac12 g^T K^{-1} g = \tfrac{m}{8}(1+3s^2)V^2`;
    sliding holds the normal row only, :math:`T_c^- = \tfrac12 V^2/K_{zz} =
    \tfrac12 m V^2/(1+3c^2)`.
    """
    m, V, length = 2.0, 1.3, 1.0
    th = np.radians(theta_deg)
    s, c = np.sin(th), np.cos(th)
    n, t = _rod_end_rows(th, length)
    mu_star = 3 * s * c / (1 + 3 * s * s)
    mu = factor * mu_star
    r = frictional_impact(_rod(m, length), [0.0, -V, 0.0], [n], [[t]], mu, e)
    if mu >= mu_star:
        Pn, Pt = m / 4 * (1 + 3 * s * s) * (1 + e) * V, m / 4 * 3 * s * c * (1 + e) * V
        assert r.state.tolist() == ["sticking"]
        assert r.T_c_minus == pytest.approx(m / 8 * (1 + 3 * s * s) * V**2, rel=1e-12)
    else:
        Pn = (1 + e) * m * V / (1 + 3 * c * c - 3 * mu * s * c)
        Pt = mu * Pn
        assert r.state.tolist() == ["sliding"]
        assert r.slip[0, 0] < 0  # B slides backwards, friction pushes forwards
        assert r.T_c_minus == pytest.approx(0.5 * V**2 * m / (1 + 3 * c * c), rel=1e-12)
    assert r.impulse[0] == pytest.approx(Pn, rel=1e-12)
    assert r.impulse_tangent[0, 0] == pytest.approx(Pt, rel=1e-12)
    assert n @ r.v_plus == pytest.approx(e * V, abs=1e-12)


def test_energy_gain_with_restitution_and_slip():
    r"""Newton's law with friction can add energy (Kane's paradox; Stronge 2000, ch. 5).

    Rod (m = 1, l = 1) at 45 degrees, end B approaching at -n.v = 1 m/s... with a spin
    that gives B a slip :math:`s^- = t\cdot v^-` forward; e = 1, mu = 0.5. Sticking
    impulses :math:`P = K^{-1}(-(1+e)\gamma^-, -s^-)` (K of the rod test) satisfy
    :math:`|P_t| \le \mu P_n`, so B sticks, and the energy change is
    :math:`\Delta T = \tfrac12[P_n(\gamma^+ + \gamma^-) + P_t(s^+ + s^-)] =
    \tfrac12 P_t s^-` (e = 1, :math:`s^+ = 0`), positive here: the normal rebound is
    kept whole while the tangential rebound is forced to zero.
    """
    m = 1.0
    th = np.radians(45.0)
    M = _rod(m, 1.0)
    n, t = _rod_end_rows(th)
    v = np.array([0.2, -1.0, 3.0])
    g, sm = n @ v, t @ v
    J = np.vstack([n, t])
    K = J @ np.linalg.solve(M, J.T)
    Pn, Pt = np.linalg.solve(K, [-(1 + 1.0) * g, -sm])
    assert abs(Pt) <= 0.5 * Pn
    gain = 0.5 * Pt * sm
    assert gain > 0.4
    with pytest.warns(EnergyGainWarning, match="slip stops or reverses"):
        r = frictional_impact(M, v, [n], [[t]], 0.5, 1.0)
    assert r.state.tolist() == ["sticking"]
    assert -r.energy_lost == pytest.approx(gain, rel=1e-12)
    # e = 0: the same rod loses energy, and nothing is said
    with warnings.catch_warnings():
        warnings.simplefilter("error", EnergyGainWarning)
        assert float(frictional_impact(M, v, [n], [[t]], 0.5, 0.0).energy_lost) > 0


def test_energy_gain_when_slip_stops_without_reversing():
    r"""Newton's law with friction adds energy when slip merely stops (Stronge 2000, ch. 4-5).

    Rod (m = 1, l = 1) at 45 degrees falling without spin, end B at 1 m/s down with a
    forward slip of 0.6 m/s; e = 1, mu = 0.8. Routh's incremental analysis: in the
    contact frame (t, n) the inverse inertia is K = [[2.5, -1.5], [-1.5, 2.5]]; B slides
    with P_t = -mu P_n, its slip falling at K_tn - mu K_tt = -3.5 per unit P_n, until it
    stops at P_n = 0.6/3.5 (during compression: v_n is still -1 + 3.7 * 0.6/3.5 < 0);
    the sticking ratio -K_tn/K_tt = 0.6 <= mu, so B stays stuck (no reversal) and the
    end state is Newton's: v_n^+ = +1, s^+ = 0, i.e. K P = (-0.6, 2): P_t = 0.375,
    P_n = 1.025 (friction pushes *along* the initial slip). With e = 1 and s^+ = 0 the
    energy change is 1/2 P_t s^- = +0.1125 J of T^- = 0.68 J.
    """
    m, mu = 1.0, 0.8
    M = _rod(m, 1.0)
    n, t = _rod_end_rows(np.radians(45.0))
    v = np.array([0.6, -1.0, 0.0])
    J = np.vstack([t, n])
    K = J @ np.linalg.solve(M, J.T)
    assert K == pytest.approx(np.array([[2.5, -1.5], [-1.5, 2.5]]), abs=1e-12)
    # Routh: the slip stops during compression and sticking can hold it
    p_stop = 0.6 / (mu * K[0, 0] - K[0, 1])
    assert -1.0 + (K[1, 1] - mu * K[1, 0]) * p_stop < 0.0
    assert abs(K[0, 1] / K[0, 0]) <= mu
    with pytest.warns(EnergyGainWarning, match=r"T\+ = 0\.7925 J from T- = 0\.68 J"):
        r = frictional_impact(M, v, [n], [[t]], mu, 1.0)
    assert r.state.tolist() == ["sticking"]
    assert r.impulse[0] == pytest.approx(1.025, rel=1e-12)
    assert r.impulse_tangent[0, 0] == pytest.approx(0.375, rel=1e-12)
    assert float(r.T_minus) == pytest.approx(0.68, rel=1e-12)
    assert -float(r.energy_lost) == pytest.approx(0.1125, rel=1e-12)


def test_polygon_cone_underestimates_mu():
    r"""3-D point mass (M = I) at 1 m/s onto the floor, e = 0, mu = 0.5: P_n = 1 N s, and
    Coulomb's circular cone stops a slip of 0.48 m/s in every direction (0.48 <= mu P_n).
    The inscribed 8-gon reaches only cos(pi/8) mu P_n = 0.462 halfway between two of its
    directions (22.5 deg): there the contact slides, along a direction it reaches fully
    (0 deg) it sticks, and with 64 facets (cos(pi/64) = 0.9988) it sticks at 22.5 deg too.
    Sliding at 1 m/s: the exact slip after is 0.5 m/s along the slip, the 8-gon's
    |tau| = cos(pi/8) mu P_n at 22.5 deg (docs/active-set.md)."""
    M, N, T = np.eye(3), [[0.0, 0.0, 1.0]], [[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]]

    def hit(speed, deg, facets=8):
        a = np.radians(deg)
        return frictional_impact(M, [speed * np.cos(a), speed * np.sin(a), -1.0], N, T,
                                 0.5, 0.0, facets=facets)

    assert hit(0.48, 0.0).state.tolist() == ["sticking"]
    assert hit(0.48, 22.5).state.tolist() == ["sliding"]
    assert hit(0.48, 22.5, facets=64).state.tolist() == ["sticking"]
    r = hit(1.0, 22.5)
    assert np.linalg.norm(r.impulse_tangent[0]) == pytest.approx(0.5 * np.cos(np.pi / 8),
                                                                 rel=1e-9)
    r = hit(1.0, 0.0)
    assert r.v_plus[:2] == pytest.approx([0.5, 0.0], abs=1e-12)


def test_slip_reversal_algebraic_law_not_routh():
    r"""The impact law is the algebraic one (Coulomb on the slip *after* the impact), not
    Routh's incremental analysis (Stronge 2000, ch. 4); they differ when the slip reverses
    during the impact (docs/active-set.md).

    Rod (m = 1, l = 1) at 45 degrees, no spin, end B at 1 m/s down with a forward slip of
    0.2 m/s; e = 0.5, mu = 0.3. K = [[2.5, -1.5], [-1.5, 2.5]] in (t, n); the sticking
    ratio 0.6 > mu, so B cannot stick. Algebraic law: the slip after is backward, the whole
    friction impulse is +mu P_n: v_n gains 2.5 + 0.3 (-1.5) = 2.05 per unit P_n, so
    P_n = 1.5/2.05 = 30/41, P_t = 9/41, slip after 0.2 - 0.75 P_n. Routh: forward slip stops
    at P_n = 0.2/2.25 (v_n gains 2.95 per unit P_n on the way), then B slides backward to
    v_n = 0.5: P_n = 0.693, P_t = 0.154, slip after -0.453 (the friction impulse 30 % smaller).
    """
    mu, e = 0.3, 0.5
    M = _rod(1.0, 1.0)
    n, t = _rod_end_rows(np.radians(45.0))
    v = np.array([0.2, -1.0, 0.0])
    r = frictional_impact(M, v, [n], [[t]], mu, e)
    assert r.state.tolist() == ["sliding"]
    assert r.impulse[0] == pytest.approx(30 / 41, rel=1e-12)
    assert r.impulse_tangent[0, 0] == pytest.approx(9 / 41, rel=1e-12)
    assert r.slip[0, 0] == pytest.approx(0.2 - 0.75 * 30 / 41, rel=1e-12)
    # Routh's path, for the record of the difference
    p1 = 0.2 / (mu * 2.5 + 1.5)
    p2 = (e - (-1.0 + (2.5 + mu * 1.5) * p1)) / (2.5 - mu * 1.5)
    routh_Pn, routh_Pt = p1 + p2, mu * (p2 - p1)
    assert routh_Pn == pytest.approx(0.6927, abs=1e-4)
    assert routh_Pt == pytest.approx(0.1545, abs=1e-4)
    assert r.impulse_tangent[0, 0] / routh_Pt == pytest.approx(1.42, abs=0.01)


def test_mu_above_mu_max_is_refused_not_solved_outside_the_cone():
    r"""A body with n = 2 and one contact whose sticking impulses
    :math:`K (P_n, P_t) = -(\gamma^-, s^-)` (K the 2 x 2 Delassus matrix) are
    (6.737, -1.722) N s: Coulomb's law sticks for every mu >= 0.256 and stops the body
    (v+ = 0, the impact removes all of T^- = 3.4645 J). mu = 1e4 and inf give that. At
    mu = 1e12 the solver returned "sliding" with P_n = -5.8e-12 N s and P_t = +5.75 N s,
    outside the cone |P_t| <= mu P_n, and T^+ = 17.4 J from 3.46 J with e = 0 (which no
    Coulomb solution can gain); a finite mu above MU_MAX = 1e4 is now refused, naming
    inf."""
    M = np.array([[2.6, -0.1], [-0.1, 1.3]])
    v = np.array([1.4, 1.3])
    N, T = np.array([[-0.7, 0.0]]), np.array([[[-0.7, 0.9]]])
    J = np.vstack([N[0], T[0, 0]])
    Pn, Pt = np.linalg.solve(J @ np.linalg.solve(M, J.T), -(J @ v))
    assert Pn > 0 and abs(Pt) / Pn == pytest.approx(0.2557, abs=1e-4)
    for mu in (0.3, MU_MAX, np.inf):
        r = frictional_impact(M, v, N, T, mu, 0.0)
        assert r.state.tolist() == ["sticking"], mu
        assert r.impulse[0] == pytest.approx(Pn, rel=1e-12)
        assert r.impulse_tangent[0, 0] == pytest.approx(Pt, rel=1e-12)
        np.testing.assert_allclose(r.v_plus, 0.0, atol=1e-14)
        assert float(r.energy_lost) == pytest.approx(3.4645, rel=1e-12)
    for mu in (1e12, [1e12]):
        with pytest.raises(ri.InputError, match=r"mu must be at most 10000 or inf .*got 1e\+12"):
            frictional_impact(M, v, N, T, mu, 0.0)
    # two contacts at rest (N v = 1e-16, round-off) of a sliding body: nothing approaches,
    # so no impulse and v+ = v-. At mu = 1e6 the solver put 5e-4 N s of friction on the
    # first contact with P_n = 0 (and 1e-3 N s on the second with 1.5e-4)
    M = [[1.3, -0.06, -0.33], [-0.06, 2.85, 0.15], [-0.33, 0.15, 1.54]]
    v = [0.12319378798109365, 0.27943956785955437, 0.3064821066846725]
    N, T = [[-0.3, 0.9, -0.7], [0.9, 0.7, -1.0]], [[[0.9, 0.9, 0.4]], [[-0.6, 0.7, -0.4]]]
    for mu in (MU_MAX, np.inf):
        r = frictional_impact(M, v, N, T, mu, 0.0)
        assert np.abs(r.impulse).max() == 0 and np.abs(r.impulse_tangent).max() == 0
        np.testing.assert_allclose(r.v_plus, v, rtol=1e-15)
    with pytest.raises(ri.InputError, match=r"got 1e\+06 \(contact 0\)"):
        frictional_impact(M, v, N, T, 1e6, 0.0)


def test_mu_inf_no_friction_without_normal_impulse():
    r"""mu = inf is the limit of Coulomb friction: a contact with zero normal impulse
    carries no friction impulse (|tau| <= mu p_n), however large mu.

    Planar body (x, z, theta), M = diag(1.4, 1.4, 0.42), contacts 1 and 2 with normal rows
    (0, 1, 0.42), (0, 1, 0.11) and tangent rows (1, 0, 0.15), (1, 0, 0.32), both
    approaching (v = (1.26, -0.37, -1.41)), e = 0. By hand: contact 1 sticking,
    K [P_t, P_n] = -[slip_1, gamma_1] with K its 2 x 2 Delassus matrix, gives
    P_n = 1.056, P_t = -1.572 (any mu >= 1.49), and contact 2 then separates
    (gamma_2^+ = 0.284 > 0): a Coulomb solution for every mu >= 1.49, which
    frictional_impact returns for mu = 10 and 1e4. With mu = inf the locked-set iteration
    kept both contacts locked from its all-locked start and stopped the body (v+ = 0,
    T_c^- 1.650 J instead of 1.332 J): contact 1 then took P_t = -6.5 N s with P_n = 0.
    """
    M = np.diag([1.4, 1.4, 0.42])
    N = np.array([[0.0, 1.0, 0.42], [0.0, 1.0, 0.11]])
    T = np.array([[[1.0, 0.0, 0.15]], [[1.0, 0.0, 0.32]]])
    v = np.array([1.26, -0.37, -1.41])
    J = np.vstack([T[0, 0], N[0]])
    K = J @ np.linalg.solve(M, J.T)
    Pt, Pn = np.linalg.solve(K, -(J @ v))
    v_hand = v + np.linalg.solve(M, J.T @ [Pt, Pn])
    assert Pn > 0 and abs(Pt) <= 1.5 * Pn and N[1] @ v_hand > 0.28
    T_c_hand = 0.5 * (J @ v) @ np.linalg.solve(K, J @ v)
    for mu in (10.0, 1e4, np.inf):
        r = frictional_impact(M, v, N, T, mu, 0.0)
        assert r.state.tolist() == ["sticking", "separating"], mu
        np.testing.assert_allclose(r.v_plus, v_hand, rtol=1e-9, atol=1e-12)
        assert r.impulse == pytest.approx([Pn, 0.0], abs=1e-12)
        assert r.impulse_tangent[:, 0] == pytest.approx([Pt, 0.0], abs=1e-9)
        assert float(r.T_c_minus) == pytest.approx(T_c_hand, rel=1e-9)


# ------------------------------------------------------------------------------------
# Drawn systems
# ------------------------------------------------------------------------------------


@st.composite
def systems(draw, *, tdim=None, independent=True, max_n=8):
    """(M, v, N, T, B): SPD M = X X^T + diag(d) and rows drawn element by element.

    ``independent``: the normal, tangent and bilateral rows are few enough to be
    independent (k (1 + t) + p <= n) and well conditioned; else a contact is repeated
    (redundant contacts, as several wheels on flat ground).
    """
    t = draw(st.sampled_from([1, 2])) if tdim is None else tdim
    n = draw(st.integers(1 + t, max_n))
    pb = draw(st.integers(0, min(1, n - 1 - t)))
    k = draw(st.integers(1, max(1, (n - pb) // (1 + t))))
    el = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
    X = draw(hnp.arrays(np.float64, (n, n), elements=el))
    d = draw(hnp.arrays(np.float64, n, elements=st.floats(0.1, 3.0)))
    M = X @ X.T + np.diag(d)
    N = draw(hnp.arrays(np.float64, (k, n), elements=el))
    T = draw(hnp.arrays(np.float64, (k, t, n), elements=el))
    B = draw(hnp.arrays(np.float64, (pb, n), elements=el))
    v = draw(hnp.arrays(np.float64, n, elements=st.floats(-2.0, 2.0)))
    R = np.vstack([N, T.reshape(-1, n), B])
    assume(np.all(np.linalg.norm(R, axis=1) > 0.1))
    if independent:
        assume(np.linalg.cond(R) < 1e3)
    else:
        N = np.vstack([N, N[:1]])
        T = np.concatenate([T, T[:1]])
        assume(np.linalg.cond(np.vstack([N[:-1], T[:-1].reshape(-1, n), B])) < 1e3)
    return M, v, N, T, (B if pb else None)


def _check_solution(r, M, v, N, T, B, mu, e, facets=FACETS):
    """Every condition of the frictional impact problem, from v+ and the impulses."""
    k, t, n = T.shape
    vp = r.v_plus
    scale_v = 1.0 + np.linalg.norm(v) * max(1.0, np.abs(np.vstack([N, T.reshape(-1, n)])).max())
    scale_p = 1.0 + np.abs(M).max() * scale_v
    tv, tp = 1e-7 * scale_v, 1e-7 * scale_p
    # momentum balance: the bilateral impulses make up the rest, and B v+ = 0
    g = M @ (vp - v) - N.T @ r.impulse - np.einsum("ktn,kt->n", T, r.impulse_tangent)
    if B is not None:
        g = g - B.T @ r.impulse_bilateral
        np.testing.assert_allclose(B @ vp, 0.0, atol=tv)
    np.testing.assert_allclose(g, 0.0, atol=tp)
    # normal complementarity (Newton)
    gp, gm = N @ vp, N @ v
    w = gp + e * gm
    assert np.all(r.impulse >= -tp)
    assert np.all(w >= -tv)
    assert np.all(np.minimum(r.impulse / tp, w / tv) <= 1.0)  # p = 0 or w = 0
    np.testing.assert_allclose(r.slack, w, atol=tv)
    # Coulomb's law on the polygon
    D = _polygon(facets) if t == 2 else np.array([[1.0], [-1.0]])
    for i in range(k):
        tau = r.impulse_tangent[i]
        s = T[i] @ vp
        np.testing.assert_allclose(r.slip[i], s, atol=tv)
        cap = mu[i] * r.impulse[i] if np.isfinite(mu[i]) else np.inf  # inf: no bound
        assert _gauge(tau, facets) <= cap + tp
        if r.state[i] == "sticking":
            np.testing.assert_allclose(s, 0.0, atol=tv)
            assert r.hold_normal[i] and r.hold_tangent[i].all()
        elif r.state[i] == "sliding":
            assert r.hold_normal[i] and not r.hold_tangent[i].any()
            if 0 < mu[i] < np.inf and np.linalg.norm(s) > tv:
                # on the boundary, in the direction(s) most opposed to the slip
                assert _gauge(tau, facets) == pytest.approx(cap, rel=1e-6, abs=tp)
                lam = np.max(-(D @ s))
                assert -tau @ s == pytest.approx(cap * lam, rel=1e-6, abs=tp * tv)
        else:
            assert not r.hold_normal[i] and not r.hold_tangent[i].any()
            assert r.impulse[i] <= tp and np.linalg.norm(tau) <= tp
    # T_c^- is the partition of v- with the held rows (rank-revealing QR)
    rows = [N[r.hold_normal], T[r.hold_tangent]] + ([B] if B is not None else [])
    A = np.vstack(rows)
    Tc = ri.partition(M, A, v).T_c if len(A) else 0.0
    assert float(r.T_c_minus) == pytest.approx(Tc, rel=1e-8, abs=1e-10 * (1 + r.T_minus))
    assert float(r.T_minus) == pytest.approx(0.5 * v @ M @ v, rel=1e-12)
    assert float(r.T_plus) == pytest.approx(0.5 * vp @ M @ vp, rel=1e-9, abs=1e-12)


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.EnergyGainWarning")  # e > 0: Kane
@PROPS
@given(sys_=systems(), mu=st.lists(st.floats(0.0, 2.0), min_size=8, max_size=8),
       e=st.floats(0.0, 1.0), facets=st.sampled_from([4, 8]))
# found by CI: tangent rows nearly dependent on the normal, a sticking solution with
# impulses 1e5 x the momentum (Kane's paradox, T+ = 1.3e5 J from 1.5 J); the residual's
# product term must be read relative to the impulses, not to sqrt(2 T^-) alone
@example(sys_=(np.eye(3), -np.ones(3), np.array([[0.375, 0.375, 1.0]]),
               np.array([[[-0.21875, -0.1875, -1.0], [-0.75, -0.875, 0.0]]]), None),
         mu=[2.0] * 8, e=1.0, facets=4)
def test_property_frictional_impact_conditions(sys_, mu, e, facets):
    """Momentum, complementarity, cone, maximal dissipation, T_c^- on drawn systems."""
    M, v, N, T, B = sys_
    mu = np.array(mu[: len(N)])
    r = frictional_impact(M, v, N, T, mu, e, bilateral=B, facets=facets)
    _check_solution(r, M, v, N, T, B, mu, e, facets)


@PROPS
@given(sys_=systems(independent=False), mu=st.floats(0.0, 2.0))
def test_property_redundant_contacts(sys_, mu):
    """A repeated contact (rank-deficient rows, e = 0): the conditions still hold."""
    M, v, N, T, B = sys_
    mus = np.full(len(N), mu)
    r = frictional_impact(M, v, N, T, mus, 0.0, bilateral=B)
    _check_solution(r, M, v, N, T, B, mus, 0.0)


@PROPS
@given(sys_=systems(), mu=st.floats(0.0, 2.0))
def test_property_no_energy_gain_with_e0(sys_, mu):
    r"""e = 0: :math:`T^+ \le T^-`, and without sliding contacts (and bilateral rows at
    rest) the impact removes exactly T_c^-.

    Proof of the first: :math:`T^+ - T^- = v^{+T} M\Delta v - \tfrac12\Delta v^TM\Delta v`
    and :math:`v^{+T}M\Delta v = p\cdot\gamma^+ + \tau\cdot s^+ = 0 - \sum\mu\lambda p
    \le 0` by complementarity.
    """
    M, v, N, T, B = sys_
    if B is not None:
        v = v - np.linalg.pinv(B) @ (B @ v)
    r = frictional_impact(M, v, N, T, mu, 0.0, bilateral=B)
    dv = r.v_plus - v
    assert float(r.energy_lost) >= -1e-10 * (1 + r.T_minus)
    assert float(r.energy_lost) >= 0.5 * dv @ M @ dv - 1e-9 * (1 + r.T_minus)
    if not (r.state == "sliding").any():
        assert float(r.T_c_minus) == pytest.approx(float(r.energy_lost), rel=1e-7,
                                                   abs=1e-10 * (1 + r.T_minus))


@PROPS
@given(sys_=systems(), mu=st.floats(0.0, 2.0), e=st.lists(st.floats(0.0, 1.0),
                                                          min_size=8, max_size=8),
       gam=st.lists(st.floats(-2.0, 0.0), min_size=8, max_size=8))
def test_property_no_energy_gain_without_initial_slip(sys_, mu, e, gam):
    r"""Every contact at rest or approaching (:math:`\gamma^- \le 0`) with zero slip
    before the impact, as the wheels of a rolling rover: no energy gain for any
    :math:`e_i \in [0, 1]`. :math:`T^+ - T^- = \tfrac12\sum p_i(\gamma^+_i+\gamma^-_i)
    + \tfrac12\tau\cdot(s^+ + s^-)`; the first sum is :math:`\tfrac12\sum
    p_i(1-e_i)\gamma^-_i \le 0`, the second :math:`-\tfrac12\sum\mu\lambda p \le 0`.
    """
    M, v, N, T, B = sys_
    k, _, n = T.shape
    C = np.vstack([N, T.reshape(-1, n)] + ([B] if B is not None else []))
    target = np.zeros(len(C))
    target[:k] = gam[:k]
    v = np.linalg.lstsq(C, target, rcond=None)[0]
    e = np.array(e[:k])
    r = frictional_impact(M, v, N, T, mu, e, bilateral=B)
    assert float(r.energy_lost) >= -1e-10 * (1 + r.T_minus)


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.EnergyGainWarning")  # B v- != 0
@PROPS
@given(sys_=systems(), e=st.floats(0.0, 1.0))
def test_property_mu0_is_the_frictionless_problem(sys_, e):
    """mu = 0: v+, impulses, the contacts that hold and T_c^- of unilateral_impact.

    Off the knife edge of a contact exactly at rest (N_i v = 0, found by hypothesis with
    v = (0, -5.7e-212)): there "holds with zero impulse" and "separates with zero
    impulse" are both solutions, and the two solvers may report either."""
    M, v, N, T, B = sys_
    assume(np.all(np.abs(N @ v) > 1e-9 * (1.0 + np.linalg.norm(v))))
    ref = ri.unilateral_impact(M, v, N, e, bilateral=B)
    r = frictional_impact(M, v, N, T, 0.0, e, bilateral=B)
    np.testing.assert_allclose(r.v_plus, ref.v_plus, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(r.impulse, ref.impulse, rtol=1e-12, atol=1e-12)
    assert r.hold_normal.tolist() == ref.active.tolist()
    assert not r.hold_tangent.any()
    assert float(r.T_c_minus) == pytest.approx(float(ref.T_c_minus), rel=1e-9, abs=1e-14)
    assert set(r.state.tolist()) <= {"separating", "sliding"}


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.EnergyGainWarning")  # e > 0: Kane
@PROPS
@given(sys_=systems(), e=st.floats(0.0, 1.0),
       gam=st.lists(st.floats(-2.0, -0.1), min_size=8, max_size=8),
       slip=st.lists(st.floats(-1.0, 1.0), min_size=16, max_size=16))
def test_property_mu_inf_is_bilateral_no_slip(sys_, e, gam, slip):
    """mu = inf: when every contact holds with the tangent rows held as bilateral rows
    (the reference: unilateral_impact with those rows added to the bilateral ones, all
    normal impulses positive), the frictional problem returns that solution, every
    contact sticking.

    A finite mu above the friction ratio of that solution admits it too, but need not
    return it: with friction the impact problem can have several solutions (found by
    hypothesis: two contacts, mu = 31, one solution with both sticking, another with
    one separating). There only the conditions of a solution are checked.
    """
    M, v, N, T, B = sys_
    k, t, n = T.shape
    C = np.vstack([N, T.reshape(-1, n)] + ([B] if B is not None else []))
    target = np.zeros(len(C))
    target[:k] = gam[:k]
    target[k:k + k * t] = slip[: k * t]
    v = np.linalg.lstsq(C, target, rcond=None)[0]
    Bx = np.vstack([T.reshape(-1, n)] + ([B] if B is not None else []))
    ref = ri.unilateral_impact(M, v, N, e, bilateral=Bx)
    assume(np.all(ref.impulse > 1e-3 * np.abs(ref.impulse).max()))
    tau_ref = ref.impulse_bilateral[: k * t].reshape(k, t)
    r = frictional_impact(M, v, N, T, np.inf, e, bilateral=B)
    assert r.state.tolist() == ["sticking"] * k
    assert r.locked.all()
    np.testing.assert_allclose(r.v_plus, ref.v_plus, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(r.impulse, ref.impulse, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(r.impulse_tangent, tau_ref, rtol=1e-7, atol=1e-9)
    assert float(r.T_c_minus) == pytest.approx(float(ref.T_c_minus), rel=1e-9)
    ratio = max(np.linalg.norm(tau_ref[i]) / ref.impulse[i] for i in range(k))
    mu = np.full(k, 2.0 * ratio / np.cos(np.pi / FACETS) + 0.1)
    r = frictional_impact(M, v, N, T, mu, e, bilateral=B)
    _check_solution(r, M, v, N, T, B, mu, e)


def test_mu_inf_contact_that_separates_is_released():
    """A mu = inf contact that separates holds nothing (its tangent row is released): a
    point mass moving up and sideways off the floor (mu = inf) while it hits a
    frictionless wall, which stops the x motion only."""
    r = frictional_impact(np.eye(2), [-1.0, 0.5], [[1.0, 0.0], [0.0, 1.0]],
                          [[[0.0, 1.0]], [[1.0, 0.0]]], [0.0, np.inf])
    assert r.state.tolist() == ["sliding", "separating"]
    assert r.locked.tolist() == [False, False]
    np.testing.assert_allclose(r.v_plus, [0.0, 0.5], atol=1e-14)
    assert r.hold_tangent.tolist() == [[False], [False]]
    # with mu = inf at the wall too, the wall stops the point: the floor ends at rest,
    # holding (at the threshold) without slip
    r = frictional_impact(np.eye(2), [-1.0, 0.5], [[1.0, 0.0], [0.0, 1.0]],
                          [[[0.0, 1.0]], [[1.0, 0.0]]], np.inf)
    assert r.locked[0] and r.state.tolist() == ["sticking", "sticking"]
    np.testing.assert_allclose(r.v_plus, [0.0, 0.0], atol=1e-14)


# ------------------------------------------------------------------------------------
# Batches, input forms
# ------------------------------------------------------------------------------------


def test_batched_matches_single_items_and_shared_M(rng):
    n, k, nb = 7, 2, 12
    X = rng.standard_normal((n, n))
    M = X @ X.T + n * np.eye(n)
    N = rng.standard_normal((nb, k, n))
    T = rng.standard_normal((nb, k, 2, n))
    v = rng.standard_normal((nb, n))
    B = rng.standard_normal((1, n))
    mu = rng.uniform(0.1, 1.0, (nb, k))
    rb = frictional_impact(M, v, N, T, mu, 0.3, bilateral=B)
    assert rb.v_plus.shape == (nb, n) and rb.state.shape == (nb, k)
    assert rb.impulse_tangent.shape == (nb, k, 2) and rb.T_c_minus.shape == (nb,)
    for i in range(nb):
        ri_ = frictional_impact(M, v[i], N[i], T[i], mu[i], 0.3, bilateral=B)
        np.testing.assert_array_equal(rb.v_plus[i], ri_.v_plus)
        assert rb.state[i].tolist() == ri_.state.tolist()
        assert rb.T_c_minus[i] == float(ri_.T_c_minus)


def test_per_contact_tangent_list_and_zero_rows():
    """The list form (a planar contact, a 3-D one, a frictionless one) equals the padded
    array form with zero rows; all-zero rows make a contact frictionless."""
    rng = np.random.default_rng(3)
    n = 8
    X = rng.standard_normal((n, n))
    M = X @ X.T + n * np.eye(n)
    N = rng.standard_normal((3, n))
    t1 = rng.standard_normal((1, n))
    t2 = rng.standard_normal((2, n))
    v = rng.standard_normal(n)
    r = frictional_impact(M, v, N, [t1, t2, None], [0.4, 0.7, 5.0])
    Tpad = np.zeros((3, 2, n))
    Tpad[0, :1] = t1
    Tpad[1] = t2
    # the array form gives every contact 2 rows: contact 0 padded with zeros is NOT the
    # same (partly zero rows), so compare contact 0 and 2 as frictionless instead
    Tz = Tpad.copy()
    Tz[0] = 0.0
    ra = frictional_impact(M, v, N, Tz, [0.4, 0.7, 5.0])
    rl = frictional_impact(M, v, N, [None, t2, None], [0.4, 0.7, 5.0])
    np.testing.assert_allclose(ra.v_plus, rl.v_plus, atol=1e-14)
    assert ra.state.tolist() == rl.state.tolist()
    assert r.impulse_tangent.shape == (3, 2)
    assert r.impulse_tangent[0, 1] == 0.0 and not r.impulse_tangent[2].any()


def test_docstring_example():
    import doctest

    import roverimpact.frictional as fr

    res = doctest.testmod(fr, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert res.attempted > 0 and res.failed == 0


# ------------------------------------------------------------------------------------
# Errors
# ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"v": [np.nan, -1.0]}, "v contains NaN"),
        ({"M": [[1.0, 0.0], [0.0, np.nan]]}, "M contains NaN"),
        ({"M": [[1.0, 0.0], [0.0, -1.0]]}, "not positive definite"),
        ({"mu": -0.1}, "mu must be >= 0"),
        ({"mu": np.nan}, "mu contains NaN"),
        ({"mu": [0.1, 0.2, 0.3]}, "mu must be a scalar or have k = 1"),
        ({"restitution": 1.2}, r"restitution must lie in \[0, 1\], got 1.2"),
        ({"tangent": [[[np.nan, 1.0]]]}, "tangent contains NaN"),
        ({"tangent": np.ones((1, 1, 3))}, "k = 1 contacts and n = 2 columns"),
        ({"tangent": [[1.0, 0.0], [0.0, 1.0]]}, "one entry per contact"),
        ({"tangent": [np.ones((3, 2))]}, "has 3 tangent rows"),
        ({"tangent": np.array([[[1.0, 0.0], [0.0, 0.0]]])}, "partly zero"),
        ({"normal": [[0.0, 0.0]]}, "normal row 0 is all zeros"),
        ({"normal": [[0.0, 1.0, 0.0]]}, "n = 2 columns"),
        ({"facets": 2}, "facets must be an integer >= 3"),
        ({"facets": 4.5}, "facets must be an integer"),
    ],
)
def test_bad_input_one_clear_error(kwargs, match):
    args = {"M": np.eye(2), "v": [0.5, -1.0], "normal": [[0.0, 1.0]],
            "tangent": np.array([[[1.0, 0.0]]]), "mu": 0.5}
    args |= kwargs
    with pytest.raises(ri.InputError, match=match):
        frictional_impact(args.pop("M"), args.pop("v"), args.pop("normal"),
                          args.pop("tangent"), args.pop("mu"), **args)


def test_infeasible_raises_solver_error():
    """Two opposite walls and e = (0.8, 0.2), as in the frictionless test: no impulses."""
    with pytest.raises(ri.SolverError, match="no solution"):
        frictional_impact(np.eye(2), [-1.0, 0.3], [[1.0, 0.0], [-1.0, 0.0]],
                          [[[0.0, 1.0]], [[0.0, 1.0]]], 0.5, [0.8, 0.2])


def _planar_solutions(M, v, N, t, mu, e):
    """Every solution of a planar frictional impact (one tangent row ``t[i]`` per contact)
    by enumerating the contact modes (separating, sticking, sliding either way), each a
    linear system in the impulses; an independent reference for small problems."""
    k = len(N)
    W = np.linalg.solve(M, np.hstack([N.T, t.T]))  # dv per unit (p, tau)
    found = []
    for modes in itertools.product(range(4), repeat=k):
        rows, rhs = [], []
        for i, md in enumerate(modes):
            ep, et = np.eye(2 * k)[i], np.eye(2 * k)[k + i]
            if md == 0:
                rows += [ep, et]
                rhs += [0.0, 0.0]
                continue
            rows.append(N[i] @ W)
            rhs.append(-(1 + e) * N[i] @ v)
            if md == 1:
                rows.append(t[i] @ W)
                rhs.append(-t[i] @ v)
            else:  # slip of sign s after the impact, tau = -s mu p
                rows.append(et + (1 if md == 2 else -1) * mu * ep)
                rhs.append(0.0)
        A, b = np.array(rows), np.array(rhs)
        x = np.linalg.lstsq(A, b, rcond=None)[0]
        if np.linalg.norm(A @ x - b) > 1e-9:
            continue
        p, tau, vp = x[:k], x[k:], v + W @ x
        slip = t @ vp
        ok = (p >= -1e-9).all() and (N @ vp + e * (N @ v) >= -1e-9).all()
        for i, md in enumerate(modes):
            ok &= {0: True, 1: abs(tau[i]) <= mu * p[i] + 1e-9, 2: slip[i] >= -1e-9,
                   3: slip[i] <= 1e-9}[md]
        if ok:
            found.append(modes)
    return found


def test_no_solution_with_restitution_is_said_so_not_ill_conditioning():
    """Three planar contacts, the first and third identical (dependent rows), e = 0.5:
    a search of every contact mode (:func:`_planar_solutions`) finds solutions at mu = 0.5
    and none at mu = 3 or 1e4 (Newton's restitution with Coulomb friction). At mu = 3 the
    error said "no solution"; at mu = 1e4 it said only "the problem is too ill-conditioned;
    check the scaling of M and of the contact rows". It now names the restitution too."""
    M = np.array([[1.49, 0.33], [0.33, 1.44]])
    v = np.array([0.26, 1.72])
    N = np.array([[-0.08, -0.78], [-0.58, -0.79], [-0.08, -0.78]])
    t = np.array([[-0.61, 0.03], [-0.42, 0.95], [-0.61, 0.03]])
    assert _planar_solutions(M, v, N, t, 0.5, 0.5)
    frictional_impact(M, v, N, t[:, None], 0.5, 0.5)
    for mu in (3.0, 1e4):
        assert not _planar_solutions(M, v, N, t, mu, 0.5)
        with pytest.raises(ri.SolverError, match="Newton's restitution"):
            frictional_impact(M, v, N, t[:, None], mu, 0.5)


# ------------------------------------------------------------------------------------
# Scenario rows (labels)
# ------------------------------------------------------------------------------------


def _rover_rows(beta_deg):
    """Candidate rows of the planar rover with no-slip ground rows, batched over beta."""
    from roverimpact.scenario import normal_from_beta

    sc = ri.Scenario.model_validate({
        "model": {"name": "rover2d", "params": {"suspension": "rigid"}},
        "velocity": {"u": 0.5}, "constraints": "auto",
        "contacts": {"ground_wheels": ["rear"], "ground": "noslip"},
        "obstacle": {"wheel": "front", "beta_deg": 30.0},
    })
    s = ri.ImpactSetup.from_scenario(sc)
    beta = np.radians(np.atleast_1d(beta_deg))
    Nb = normal_from_beta(beta, s._heading)
    J, wheel, oMf = _obstacle_basis(s)
    a = oMf.rotation @ np.asarray(wheel.axis, float)
    d = Nb - (Nb @ a)[:, None] * a
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    rows = Nb @ J[:3] + np.cross(-wheel.radius * d, Nb) @ J[3:]
    A_all = s._cs.evaluate(s.q)[1]
    obs = len(s.candidate_labels) - 1
    A = np.broadcast_to(A_all, (len(beta), *A_all.shape)).copy()
    A[:, obs, :] = rows
    return s.candidate_labels, s.M, A, s.v, obs


def test_holding_rows_variants_on_the_planar_rover():
    labels, M, A, v, obs = _rover_rows(np.arange(5.0, 90.0, 10.0))
    assert labels == ("ground:rear:normal", "ground:rear:long", "obstacle:front:normal")
    noslip = holding_rows(labels, M, A, v, obstacle_row=obs, friction="no-slip")
    assert noslip[:, 1].tolist() == noslip[:, 0].tolist()  # the no-slip row follows its wheel
    fl = holding_rows(labels, M, A, v, obstacle_row=obs, friction="frictionless")
    act = ri.active_set(M, v, A[:, [0, 2]])
    np.testing.assert_array_equal(fl[:, [0, 2]], act)
    assert not fl[:, 1].any()
    c0 = holding_rows(labels, M, A, v, obstacle_row=obs, friction="coulomb", mu=0.0)
    np.testing.assert_array_equal(c0, fl)
    for mu in (0.3, np.inf):
        keep = holding_rows(labels, M, A, v, obstacle_row=obs, friction="coulomb", mu=mu)
        r = frictional_impact(M, v, A[:, [0, 2]], [A[:, 1:2], None], mu)
        np.testing.assert_array_equal(keep[:, [0, 2]], r.hold_normal)
        np.testing.assert_array_equal(keep[:, 1], r.hold_tangent[:, 0, 0])
        assert keep[:, obs].all()
    by_name = holding_rows(labels, M, A, v, obstacle_row=obs, friction="coulomb",
                           mu={"ground:rear": 0.3, "obstacle:front": 0.9})
    np.testing.assert_array_equal(
        by_name, holding_rows(labels, M, A, v, obstacle_row=obs, friction="coulomb",
                              mu=[0.3, 0.9]))


def test_holding_rows_obstacle_friction_and_bilateral_labels():
    """A point mass in 3-D hitting a wall with friction at the wall: the obstacle's
    tangent rows (``obstacle:<name>:long/lat``) are held when it sticks; a locked-joint
    row is bilateral."""
    labels = ("obstacle:wall:normal", "obstacle:wall:long", "obstacle:wall:lat",
              "locked:z")
    A = np.array([[-1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [0, 0, 1.0]])
    v = np.array([1.0, 0.3, 0.0])
    keep = holding_rows(labels, np.eye(3), A, v, obstacle_row=0, friction="coulomb", mu=1.0)
    assert keep.tolist() == [True, True, True, True]
    keep = holding_rows(labels, np.eye(3), A, v, obstacle_row=0, friction="coulomb", mu=0.1)
    assert keep.tolist() == [True, False, False, True]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"friction": "viscous"}, "friction must be one of"),
        ({"mu": None}, "needs contacts.mu"),
        ({"mu": {"obstacle:front": 0.3}}, r"missing \['ground:rear'\]"),
        ({"mu": {"ground:rear": 0.3, "obstacle:front": 0.3, "x": 1.0}}, "unknown"),
        ({"obstacle_row": 7}, "obstacle_row must index"),
        # a finite mu beyond float64 in the friction cone: named by contact (it was
        # frictional_impact's "contact 0")
        ({"mu": {"ground:rear": 1e9, "default": 0.5}},
         r"contacts.mu of ground:rear is 1e\+09: give at most 10000, or inf"),
    ],
)
def test_holding_rows_bad_input(kwargs, match):
    labels, M, A, v, obs = _rover_rows(30.0)
    args = {"obstacle_row": obs, "mu": 0.5, "friction": "coulomb"} | kwargs
    with pytest.raises(ri.InputError, match=match):
        holding_rows(labels, M, A, v, **args)


# ------------------------------------------------------------------------------------
# Docs: docs/active-set.md, "Friction at impact"
# ------------------------------------------------------------------------------------

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _doc_section():
    import re

    with open(os.path.join(ROOT, "docs", "active-set.md")) as fh:
        text = fh.read()
    sec = text.split("## Friction at impact", 1)[1].split("\n## ", 1)[0]
    return (re.findall(r"```python\n(.*?)```", sec, flags=re.S),
            re.findall(r"```text\n(.*?)```", sec, flags=re.S))


def test_docs_python_block_runs(monkeypatch, capsys):
    blocks, _ = _doc_section()
    assert blocks
    monkeypatch.chdir(ROOT)
    for block in blocks:
        exec(compile(block, "docs/active-set.md", "exec"), {})
    out = capsys.readouterr().out
    assert "['sliding']" in out and "['sticking']" in out


def test_docs_quoted_output_is_the_example_output(capsys):
    import runpy

    _, texts = _doc_section()
    runpy.run_path(os.path.join(ROOT, "examples", "friction_at_impact.py"),
                   run_name="__main__")
    assert capsys.readouterr().out == texts[0]


@pytest.mark.parametrize("mu", [0.5, 30.0, np.inf])
def test_rocker_bogie_sweep_every_item_is_a_solution(mu):
    """The 3-D rocker-bogie over 90 obstacle angles (five ground wheels with long/lat
    rows, a loop closure, a frictionless obstacle contact): every item satisfies the
    conditions of the frictional problem, whichever path solved it (the mode iteration
    or Lemke's algorithm, also with the perturbation; for mu = 30 and inf both occur,
    checked through the private method codes)."""
    from roverimpact.frictional import _solve
    from roverimpact.scenario import normal_from_beta

    sc = ri.load_scenario(os.path.join(ROOT, "examples", "rocker_bogie_beta30.toml"))
    s = ri.ImpactSetup.from_scenario(sc, base_dir=os.path.join(ROOT, "examples"))
    beta = np.radians(np.linspace(0.5, 89.5, 90))
    Nb = normal_from_beta(beta, s._heading)
    J, wheel, oMf = _obstacle_basis(s)
    a = oMf.rotation @ np.asarray(wheel.axis, float)
    d = Nb - (Nb @ a)[:, None] * a
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    obs_rows = Nb @ J[:3] + np.cross(-wheel.radius * d, Nb) @ J[3:]
    lab = list(s.labels)
    normal = [i for i, x in enumerate(lab) if x.endswith(":normal")]
    keys = [lab[i].rsplit(":", 1)[0] for i in normal]
    bil = [i for i, x in enumerate(lab) if not x.startswith(("ground:", "obstacle:"))]
    n = s.A.shape[1]
    T = np.zeros((len(normal), 2, n))
    for c, key in enumerate(keys):
        for q, dname in enumerate(("long", "lat")):
            if f"{key}:{dname}" in lab:
                T[c, q] = s.A[lab.index(f"{key}:{dname}")]
    Nn = np.broadcast_to(s.A[normal], (len(beta), len(normal), n)).copy()
    Nn[:, keys.index("obstacle:left_front")] = obs_rows
    B = s.A[bil]
    r = frictional_impact(s.M, s.v, Nn, T, mu, bilateral=B)
    mus = np.full(len(normal), mu)
    for i in range(len(beta)):
        ri_ = frictional_impact(s.M, s.v, Nn[i], T, mu, bilateral=B)
        assert ri_.state.tolist() == r.state[i].tolist()
        _check_solution(ri_, s.M, s.v, Nn[i], T, B, mus, 0.0)
    meth = _solve(s.M, s.v, Nn, T, mu, 0.0, B, FACETS, 1e-9, 1e-9, False)[0]["meth"]
    assert (meth == 1).any() and (mu == 0.5 or (meth >= 2).any())


def test_a_contact_without_tangent_rows_needs_no_mu():
    """A scenario's obstacle row is its normal alone (no friction on the face in T_c^-):
    a per-contact mu mapping need not name it (it had to, and the value changed nothing),
    while a contact with tangent rows must still be given one (test_holding_rows_bad_input)."""
    labels, M, A, v, obs = _rover_rows(np.arange(5.0, 90.0, 10.0))
    full = holding_rows(labels, M, A, v, obstacle_row=obs, friction="coulomb",
                        mu={"ground:rear": 0.3, "obstacle:front": 0.9})
    np.testing.assert_array_equal(
        holding_rows(labels, M, A, v, obstacle_row=obs, friction="coulomb",
                     mu={"ground:rear": 0.3}), full)


@pytest.mark.parametrize("s", [1e-170, 1e-155, 1e-100, 1.0, 1e100, 1e160, 1e170])
def test_row_scale_changes_only_the_impulse_unit(s):
    """Rows scaled by s (a contact written in other units): the same motion, impulses by
    1/s, slack and slip by s. By hand, for a unit point at (0.3, -1) m/s on the floor with
    mu = 0.1 and e = 0.5: normal impulse 1.5 N s, friction 0.15 N s, v+ = (0.15, 0.5),
    sliding. Rows of 1e-155 gave NaN and rows of 1e160 no impact at all before the rows
    were scaled inside (G = N M^-1 N^T under- or overflowed), as unilateral_impact does."""
    B = np.array([[0.0, 0.0, s]])  # a bilateral row of the same scale: z held
    r = frictional_impact(np.eye(3), [0.3, -1.0, 0.0], [[0.0, s, 0.0]],
                             [[[s, 0.0, 0.0]]], 0.1, restitution=0.5, bilateral=B)
    np.testing.assert_allclose(r.v_plus, [0.15, 0.5, 0.0], rtol=1e-13, atol=1e-15)
    assert r.state.tolist() == ["sliding"]
    assert float(r.impulse[0]) * s == pytest.approx(1.5, rel=1e-13)
    assert float(r.impulse_tangent[0, 0]) * s == pytest.approx(-0.15, rel=1e-13)
    assert float(r.slip[0, 0]) / s == pytest.approx(0.15, rel=1e-13)
    assert abs(float(r.slack[0])) <= 1e-13 * s  # N v+ + e N v- of a holding contact
    hold_n, hold_t = frictional_active_set(np.eye(3), [0.3, -1.0, 0.0], [[0.0, s, 0.0]],
                                              [[[s, 0.0, 0.0]]], 0.1, bilateral=B)
    assert hold_n.tolist() == [True] and hold_t.tolist() == [[False]]


@pytest.mark.parametrize("s", [1e-200, 1e200])
def test_items_of_very_different_row_scales_in_one_batch(s):
    """A 1 kg point hits the floor at 1 m/s with 0.6 m/s of slip, mu = 0.5: it slides,
    v+ = (0.1, 0), normal impulse 1 N s, friction -0.5 N s (closed form: mu p opposes the
    slip, 0.6 - 0.5 = 0.1 m/s left). The same contact with its rows times s has impulses
    1/s as large. Alone each item was right; in one batch the rows were scaled by one
    factor per contact over the batch, which left the item of 1e-200 rows unscaled beside
    the item of order 1: ZeroDivisionError from the kernel."""
    from roverimpact.frictional import frictional_impact

    normal = np.array([[[0.0, 1.0]], [[0.0, s]]])
    tangent = np.array([[[[1.0, 0.0]]], [[[s, 0.0]]]])
    r = frictional_impact(np.eye(2), [0.6, -1.0], normal, tangent, 0.5)
    np.testing.assert_allclose(r.v_plus, [[0.1, 0.0], [0.1, 0.0]], atol=1e-15)
    np.testing.assert_allclose(r.impulse * [[1.0], [s]], 1.0, rtol=1e-14)
    np.testing.assert_allclose(r.impulse_tangent[..., 0] * [[1.0], [s]], -0.5, rtol=1e-14)
    assert r.state.tolist() == [["sliding"], ["sliding"]]
    alone = frictional_impact(np.eye(2), [0.6, -1.0], normal[0], tangent[0], 0.5)
    assert (r.v_plus[0] == alone.v_plus).all()  # the same bits alone as in the batch


@pytest.mark.parametrize("mu", [np.inf, 50.0])
def test_compass_gait_heel_strike_matches_momentum_conservation(mu):
    """The landing foot sticks, the trailing foot leaves the ground, and v+ is the textbook
    compass-gait impact map (angular momentum about the new stance foot and of the trailing
    leg about the hip conserved: tests/reference/systems.compass_gait)."""
    c = compass_gait()
    r = frictional_impact(c.M, c.v, c.normal, c.tangent, mu=mu)
    assert list(r.state) == ["separating", "sticking"]
    np.testing.assert_allclose(r.v_plus, c.v_plus, rtol=0, atol=1e-12)
    assert r.energy_lost == pytest.approx(c.energy_lost, rel=1e-12)
    assert r.T_c_minus == pytest.approx(c.energy_lost, rel=1e-12)  # e = 0, no sliding
