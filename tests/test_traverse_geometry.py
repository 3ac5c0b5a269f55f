"""Geometry of the traverse: the next contact a rolling wheel meets, against closed forms.

References (each derived in the test's docstring):

* a ramp of angle gamma on level ground and on a slope alpha (beta = alpha + gamma, the
  rim meets the ramp where the ramp normal points at the centre);
* a vertical step on level ground (beta = arccos((r - h)/r)) and on a slope (the top edge
  is met: beta = alpha + arccos((r - h_n)/r), h_n the step height normal to the slope);
* a sphere rock on level ground and on a slope (contact on the line of centres,
  |c' - S'| = r + R' in the wheel plane, 3-D normal (p - S)/R);
* level support: the same contact as :func:`roverimpact.models.terrain.first_rim_contact`
  (the project's horizontal-translation routine, tested on its own), on rocky ground;
* rolling on: a concave terrain gentler than the rim is no impact, and neither a concave
  support nor an upward slope hides a rock further on (they do hide it from a horizontal
  translation, which meets the support at once).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from roverimpact.exceptions import InputError
from roverimpact.models.terrain import (
    FunctionTerrain,
    HeightField,
    PlaneTerrain,
    first_rim_contact,
    wheel_ground_contact,
)
from roverimpact.models.terrain_synth import synthetic_mars
from roverimpact.traverse.lookahead import first_contact_ahead

R = 0.1


def _on_slope(alpha, xi, r=R):
    """Centre and support of a wheel (axis y) standing on the plane z = tan(alpha) x at the
    along-slope coordinate xi (support at (xi cos a, 0, xi sin a))."""
    p = np.array([xi * np.cos(alpha), 0.0, xi * np.sin(alpha)])
    c = p + r * np.array([-np.sin(alpha), 0.0, np.cos(alpha)])
    return c, p


def _ahead(terrain, c, p, max_travel=1.0, **kw):
    return first_contact_ahead(terrain, c, (0, 1, 0), R, (1, 0, 0), p, max_travel=max_travel,
                               **kw)


@settings(max_examples=25, deadline=None)
@given(alpha=st.floats(-20.0, 25.0), gamma=st.floats(3.0, 60.0), xi0=st.floats(0.05, 0.4))
def test_ramp_on_a_slope(alpha, gamma, xi0):
    """A crease at along-slope distance xi0 ahead of the support, beyond which the ground
    rises gamma more steeply. In the slope's frame it is the level-ground ramp of
    docs/terrain.md: the rim meets the ramp where its normal points at the centre, at
    height r (1 - cos gamma) above the slope, xi = xi0 + r(1 - cos g)/tan g; the centre is
    then r sin(gamma) behind that point: travel = xi0 + r(1 - cos g)/tan g - r sin g;
    beta = alpha + gamma."""
    a, g = np.radians(alpha), np.radians(gamma)
    xk = xi0 * np.cos(a)                       # world x of the crease (support at x = 0)
    zk = xi0 * np.sin(a)

    def h(x, y):
        return np.where(x < xk, np.tan(a) * x, zk + np.tan(a + g) * (x - xk)) + 0.0 * y

    def grad(x, y):
        gx = np.where(x < xk, np.tan(a), np.tan(a + g))
        return gx + 0.0 * y, 0.0 * x + 0.0 * y

    travel = xi0 + R * (1 - np.cos(g)) / np.tan(g) - R * np.sin(g)
    assume(travel > 2 * R / 64)            # the wheel stands clear of the ramp
    c, p = _on_slope(a, 0.0)
    hit = _ahead(FunctionTerrain(h, grad), c, p, step=R / 64)
    assert hit.found
    assert hit.distance == pytest.approx(travel, abs=1e-7)
    assert np.degrees(hit.beta) == pytest.approx(alpha + gamma, abs=1e-5)
    assert np.degrees(hit.alpha) == pytest.approx(alpha, abs=1e-9)
    n = np.array([-np.sin(a + g), 0.0, np.cos(a + g)])
    assert hit.normal == pytest.approx(n, abs=1e-6)
    assert hit.point == pytest.approx(hit.centre - R * n, abs=1e-6)


@pytest.mark.parametrize("alpha", [0.0, 8.0, 15.0, -10.0])
@pytest.mark.parametrize("hn", [0.02, 0.05, 0.08])
def test_vertical_step_on_a_slope(alpha, hn):
    """A vertical riser at x_e raising the slope by h_n (measured normal to it). In the
    slope's frame the riser leans forward by alpha. While
    (r - h_n)/sqrt(2 r h_n - h_n^2) > tan(alpha) (always for alpha <= 0) the rim meets its
    top edge E first, at |c' - E| = r with the centre at height r above the slope:
    travel = xi_E - sqrt(2 r h_n - h_n^2), beta = alpha + arccos((r - h_n)/r). Otherwise
    it meets the vertical face itself, at the rim's foremost point: c'_x = x_e - r,
    travel = (x_e - r - c_x)/cos(alpha), beta = 90 deg. Level ground (alpha = 0) is the
    step of docs/terrain.md."""
    a = np.radians(alpha)
    xe = 0.3

    def h(x, y):
        return np.tan(a) * x + np.where(x >= xe, hn / np.cos(a), 0.0) + 0.0 * y

    c, p = _on_slope(a, 0.0)
    hit = _ahead(FunctionTerrain(h), c, p, step=R / 64)
    assert hit.found
    zE = np.tan(a) * xe + hn / np.cos(a)
    if (R - hn) / np.sqrt(2 * R * hn - hn**2) > np.tan(max(a, 0.0)):
        xi_E = xe * np.cos(a) + zE * np.sin(a)
        assert hit.distance == pytest.approx(xi_E - np.sqrt(2 * R * hn - hn**2), abs=1e-7)
        assert np.degrees(hit.beta) == pytest.approx(
            alpha + np.degrees(np.arccos((R - hn) / R)), abs=1e-5)
        assert hit.point == pytest.approx([xe, 0.0, zE], abs=1e-7)
    else:
        lam = (xe - R - c[0]) / np.cos(a)
        assert hit.distance == pytest.approx(lam, abs=1e-9)
        assert np.degrees(hit.beta) == pytest.approx(90.0, abs=1e-9)
        assert hit.point == pytest.approx([xe, 0.0, c[2] + lam * np.sin(a)], abs=1e-9)
        assert hit.point[2] < zE


def _sphere_terrain(alpha, S, Rs):
    def h(x, y):
        base = np.tan(alpha) * x + 0.0 * y
        q = Rs**2 - (x - S[0]) ** 2 - (y - S[1]) ** 2
        return np.maximum(base, np.where(q > 0, S[2] + np.sqrt(np.maximum(q, 0.0)), -np.inf))

    def grad(x, y):
        q = Rs**2 - (x - S[0]) ** 2 - (y - S[1]) ** 2
        top = S[2] + np.sqrt(np.maximum(q, 1e-300))
        on = (q > 0) & (top > np.tan(alpha) * x)
        sq = np.sqrt(np.maximum(q, 1e-300))
        return (np.where(on, -(x - S[0]) / sq, np.tan(alpha)),
                np.where(on, -(y - S[1]) / sq, 0.0))

    return FunctionTerrain(h, grad)


@pytest.mark.parametrize("alpha,y_off,bury", [(0.0, 0.0, 0.0), (0.0, 0.05, 0.03),
                                              (10.0, 0.0, 0.02), (-8.0, 0.04, 0.0),
                                              (12.0, -0.06, 0.05)])
def test_sphere_rock(alpha, y_off, bury):
    """A sphere rock (radius Rs, centre S) on a slope, the wheel plane at lateral offset
    y_off from S. The plane cuts the sphere in a circle of radius R' = sqrt(Rs^2 - y_off^2)
    about S' (S moved into the plane); the centre moves on the line c0 + lam d and first
    touches when |c(lam) - S'| = r + R' (smaller root of the quadratic); the contact is on
    the line of centres, p = S' + R'(c' - S')/(r + R'), with the 3-D normal (p - S)/Rs."""
    a = np.radians(alpha)
    Rs = 0.12
    xi_s = 0.35                              # rock centre along the slope, buried by `bury`
    S = np.array([xi_s * np.cos(a), y_off, xi_s * np.sin(a)]) \
        + (Rs * 0.3 - bury) * np.array([-np.sin(a), 0, np.cos(a)])
    c, p = _on_slope(a, 0.0)
    hit = _ahead(_sphere_terrain(a, S, Rs), c, p, step=R / 64)
    Sp = S.copy()
    Sp[1] = 0.0
    Rp = np.sqrt(Rs**2 - y_off**2)
    d = np.array([np.cos(a), 0.0, np.sin(a)])
    w = c - Sp
    B, C = w @ d, w @ w - (R + Rp) ** 2
    lam = -B - np.sqrt(B * B - C)
    cm = c + lam * d
    pt = Sp + Rp * (cm - Sp) / (R + Rp)
    n = (pt - S) / Rs
    assert pt[2] > np.tan(a) * pt[0]          # met on the rock's exposed part
    assert hit.found
    assert hit.distance == pytest.approx(lam, abs=1e-7)
    assert hit.point == pytest.approx(pt, abs=1e-6)
    assert hit.normal == pytest.approx(n, abs=1e-5)
    assert hit.beta == pytest.approx(np.arctan2(-n[0], n[2]), abs=1e-5)


def test_level_support_equals_first_rim_contact():
    """On level ground (rms = 0) between Golombek-Rapp rocks, a wheel standing on the ground
    rolls horizontally: both routines describe the same translation and must agree on
    every wheel that meets a rock (first_rim_contact is the project's tested routine)."""
    T = synthetic_mars((12.0, 6.0), 0.05, seed=3, rms=0.0, rock_abundance=0.2, d_max=0.6)
    rng = np.random.default_rng(0)
    xy = rng.uniform([1, 1], [11, 5], (4000, 2))
    yaw = rng.uniform(-np.pi, np.pi, 4000)
    c = np.column_stack([xy, np.full(len(xy), R)])
    ax = np.column_stack([-np.sin(yaw), np.cos(yaw), np.zeros_like(yaw)])
    hd = np.column_stack([np.cos(yaw), np.sin(yaw)])
    wc = wheel_ground_contact(T, c, ax, R)
    level = (np.abs(wc.gap) < 1e-12) & (np.abs(wc.phi) < 1e-9)   # standing on flat ground
    c, ax, hd, sup = c[level], ax[level], hd[level], wc.point[level]
    step = R / 32
    ref = first_rim_contact(T, c, ax, R, hd, max_travel=0.3, step=step)
    new = first_contact_ahead(T, c, ax, R, hd, sup, max_travel=0.3, step=step)
    # a rock whose foot is within a scan step of the support is, on the grid, joined to
    # the support (rolled onto, not hit): seen from a station further back instead
    near = ref.found & (ref.distance <= 2 * step)
    assert (new.found == ref.found)[~near].all()
    both = ref.found & ~near
    assert both.sum() > 150
    assert new.distance[both] == pytest.approx(ref.distance[both], abs=1e-7)
    assert new.point[both] == pytest.approx(ref.point[both], abs=1e-6)
    assert new.normal[both] == pytest.approx(ref.normal[both], abs=1e-5)
    assert new.beta[both] == pytest.approx(ref.beta[both], abs=1e-5)


def test_rolling_on_and_hidden_rocks():
    """A concave trough of radius 1 m (> r) is rolled through, not hit; a rock beyond it
    is found from inside the trough. On an upward plane a horizontal translation meets the
    support at once (first_rim_contact: distance 0, beta = slope), hiding the rock that
    the rolling wheel meets."""
    Rt = 1.0
    trough = FunctionTerrain(lambda x, y: Rt - np.sqrt(np.maximum(Rt**2 - x**2, 0)) + 0 * y)
    c = np.array([0.0, 0.0, 0.0]) + np.array([0, 0, R])
    x0 = -0.2
    z0 = Rt - np.sqrt(Rt**2 - x0**2)
    nrm = np.array([x0, 0, Rt - z0]) / Rt * -1.0
    nrm = -np.array([x0, 0.0, -(Rt - z0)]) / Rt          # towards the trough's centre
    p = np.array([x0, 0.0, z0])
    c = p + R * nrm
    hit = _ahead(trough, c, p, max_travel=0.3)
    assert not hit.found
    S = np.array([0.25, 0.0, Rt - np.sqrt(Rt**2 - 0.25**2)])
    Rs = 0.06

    def rocky(x, y):
        q = Rs**2 - (x - S[0]) ** 2 - y**2
        return np.maximum(trough.height(x, y), np.where(q > 0, S[2] + np.sqrt(np.abs(q)),
                                                        -np.inf))

    hit = _ahead(FunctionTerrain(rocky), c, p, max_travel=0.4)
    assert hit.found and hit.point[0] > 0.15
    a = np.radians(12.0)
    slope = PlaneTerrain((0, 0, 0), (-np.sin(a), 0, np.cos(a)))
    cs, ps = _on_slope(a, 0.0)
    ref = first_rim_contact(slope, cs, (0, 1, 0), R, (1, 0, 0), max_travel=0.3)
    assert ref.found and ref.distance == pytest.approx(0.0, abs=1e-9)
    assert np.degrees(ref.beta) == pytest.approx(12.0, abs=1e-6)
    assert not _ahead(slope, cs, ps, max_travel=0.3).found
    Sr = np.array([0.3 * np.cos(a), 0.0, 0.3 * np.sin(a)])
    hit = _ahead(_sphere_terrain(a, Sr, 0.05), cs, ps, max_travel=0.4)
    assert hit.found and hit.distance > 0.1


def test_heightfield_and_tilted_wheel_plane():
    """A sampled rock (HeightField, 2 mm) gives the analytic sphere's contact; a wheel
    whose plane is rolled by 6 degrees on a plane sloping sideways by the same angle is a
    level wheel in that plane's frame: nothing ahead, and on a step of that plane the same
    travel as the upright case."""
    a = 0.0
    Rs = 0.1
    S = np.array([0.35, 0.0, -0.02])
    exact = _sphere_terrain(a, S, Rs)
    x = np.arange(-0.2, 0.8001, 0.002)
    y = np.arange(-0.2, 0.2001, 0.002)
    X, Y = np.meshgrid(x, y)
    hf = HeightField(exact.height(X, Y), 0.002, (-0.2, -0.2))
    c, p = _on_slope(a, 0.0)
    h1, h2 = _ahead(exact, c, p, max_travel=0.4), _ahead(hf, c, p, max_travel=0.4)
    assert h2.distance == pytest.approx(h1.distance, abs=2e-5)
    assert h2.normal == pytest.approx(h1.normal, abs=5e-3)
    phi = np.radians(6.0)
    side = PlaneTerrain((0, 0, 0), (0, -np.sin(phi), np.cos(phi)))
    ax = np.array([0.0, np.cos(phi), np.sin(phi)])
    up = np.array([0.0, -np.sin(phi), np.cos(phi)])
    hit = first_contact_ahead(side, R * up, ax, R, (1, 0, 0), (0, 0, 0), max_travel=0.3)
    assert not hit.found
    step = FunctionTerrain(lambda x, y: np.tan(phi) * y + np.where(x >= 0.3, 0.05 / np.cos(phi),
                                                                   0.0))
    hit = first_contact_ahead(step, R * up, ax, R, (1, 0, 0), (0, 0, 0), max_travel=0.5,
                              step=R / 64)
    # the riser x = 0.3 is normal to the wheel plane's travel; its top edge is 5 cm above
    # the plane (normal to it): travel = 0.3 - sqrt(2 r h - h^2)
    assert hit.distance == pytest.approx(0.3 - np.sqrt(2 * R * 0.05 - 0.05**2), abs=1e-6)


def test_bad_inputs():
    T = PlaneTerrain()
    with pytest.raises(InputError, match="support"):
        first_contact_ahead(T, (0, 0, R), (0, 1, 0), R, (1, 0, 0), (0, 0), max_travel=0.1)
    with pytest.raises(InputError, match="off the wheel plane"):
        first_contact_ahead(T, (0, 0, R), (0, 1, 0), R, (0, 1, 0), (0, 0, 0), max_travel=0.1)
    with pytest.raises(InputError, match="max_travel"):
        first_contact_ahead(T, (0, 0, R), (0, 1, 0), R, (1, 0, 0), (0, 0, 0), max_travel=-1)


def test_a_step_sampled_in_a_height_field_is_met_as_a_step_29_27_as_high():
    """What an operator's DEM of a curb gives. Catmull-Rom (Keys' cubic convolution,
    a = -1/2) of a sampled step of height h overshoots to (1 + 2/27) h at dx/3 past the
    edge and dips to -2/27 h before it, at every cell size dx (the kernel's closed form:
    p(1/3) = 1 + 2/27 for the data 0, 1, 1, 1 around the edge); a wheel of radius r then
    meets, as dx -> 0, the top edge of a step 29/27 h high: beta -> arccos((r - 29 h/27)/r)
    (62.42 deg for h = r/2 instead of 60 deg), and the coarse grids lie below. Documented
    in docs/traverse.md (Limits)."""
    h = 0.05
    betas = []
    for dx in (0.01, 0.002):
        n = round(1.0 / dx)
        z = np.tile(np.where(np.arange(n + 1) >= n // 2, h, 0.0), (11, 1))
        hf = HeightField(z, dx, origin=(-0.5, -5 * dx))
        assert hf.height(dx / 3, 0.0) == pytest.approx(h * 29 / 27, rel=1e-9)
        assert hf.height(-4 * dx / 3, 0.0) == pytest.approx(-h * 2 / 27, rel=1e-9)
        c, p = np.array([-0.3, 0.0, R]), np.array([-0.3, 0.0, 0.0])
        betas.append(np.degrees(_ahead(hf, c, p, max_travel=0.4).beta))
    top = np.degrees(np.arccos((R - 29 / 27 * h) / R))
    assert betas[0] < betas[1] < top and betas[1] == pytest.approx(top, abs=0.15)
    assert betas[0] == pytest.approx(61.04, abs=0.02)    # 1 cm cells (docs/traverse.md)
