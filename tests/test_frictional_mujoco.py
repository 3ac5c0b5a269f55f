"""frictional_impact against MuJoCo: a sphere dropped at an angle onto a plane with friction.

MuJoCo (an independent engine: its own contact solver, elliptic friction cone, soft
contact) integrates a 2 kg sphere of radius 0.1 m with no gravity through a stiff contact
(solref time constant 0.2 ms, critical damping, impratio 100, 10 us steps) until it has
left the plane. Its soft contact rebounds a little (e = 0.14 .. 0.38 here): the impact map
is given MuJoCo's e (its normal velocity after / before), and the tangential velocity and
spin after the impact are compared. Sliding throughout, both are Coulomb's
``dv_t = -mu (1 + e) |v_n|`` against the slip; sticking, MuJoCo's regularised friction
leaves a small slip (about 1 % of the velocity) where the impact map stops it.
"""

from __future__ import annotations

import numpy as np
import pytest

from roverimpact.frictional import frictional_impact

mujoco = pytest.importorskip("mujoco")

m, r = 2.0, 0.1
I = 0.4 * m * r * r  # MuJoCo's inertia of the sphere geom (2/5 m r^2)
XML = """
<mujoco>
  <option timestep="1e-5" gravity="0 0 0" cone="elliptic" impratio="100"
          integrator="implicitfast"/>
  <worldbody>
    <geom type="plane" size="5 5 .1" friction="{mu} 0 0" solref="2e-4 1" condim="3"/>
    <body pos="0 0 {z0}">
      <freejoint/>
      <geom type="sphere" size="{r}" mass="{m}" friction="{mu} 0 0" solref="2e-4 1"
            condim="3"/>
    </body>
  </worldbody>
</mujoco>"""


def _mujoco(v, mu):
    """Velocity (free joint: linear, then angular in the world frame) after the contact."""
    model = mujoco.MjModel.from_xml_string(XML.format(mu=mu, z0=r + 1e-4, r=r, m=m))
    assert model.body_inertia[1] == pytest.approx([I] * 3, rel=1e-12)
    d = mujoco.MjData(model)
    d.qvel[:] = v
    for _ in range(2000):  # 20 ms: the contact lasts about 1 ms
        mujoco.mj_step(model, d)
    assert d.ncon == 0
    return d.qvel.copy()


@pytest.mark.parametrize("vx, wy, mu, state", [
    (1.0, 0.0, 0.1, "sliding"),
    (0.5, 20.0, 0.2, "sliding"),   # backspin: the slip vx - r wy is backward
    (2.0, -10.0, 0.4, "sliding"),
    (1.0, 0.0, 0.3, "sticking"),   # sticking needs mu (1 + e) |v_n| >= 2/7 slip
])
def test_planar_sphere_against_mujoco(vx, wy, mu, state):
    v = np.array([vx, 0.0, -1.0, 0.0, wy, 0.0])
    q = _mujoco(v, mu)
    e = q[2] / -v[2]
    assert 0.1 < e < 0.5
    # planar (x, z, theta_y): slip of the contact point x - r theta_y
    r_ = frictional_impact(np.diag([m, m, I]), v[[0, 2, 4]], [[0.0, 1.0, 0.0]],
                           [[[1.0, 0.0, -r]]], mu, e)
    assert r_.state.tolist() == [state]
    ours, theirs = r_.v_plus, q[[0, 2, 4]]
    rel = 2e-3 if state == "sliding" else 1.5e-2
    assert ours[0] == pytest.approx(theirs[0], rel=rel)
    assert ours[1] == pytest.approx(theirs[1], rel=1e-12)
    assert ours[2] == pytest.approx(theirs[2], rel=rel)


def test_3d_sphere_sliding_between_polygon_directions_against_mujoco():
    """Slip at 22.5 deg, halfway between two of the 8 friction directions: MuJoCo's
    elliptic cone takes mu (1 + e) |v_n| off the slip along it; the 8-gon takes
    cos(pi/8) = 0.924 of that, 22.5 deg off (docs/active-set.md), and 64 facets agree
    with MuJoCo to 1e-3."""
    a, mu = np.radians(22.5), 0.1
    v = np.array([np.cos(a), np.sin(a), -1.0, 0.0, 0.0, 0.0])
    q = _mujoco(v, mu)
    e = q[2] / -v[2]
    T = [[[1.0, 0.0, 0.0, 0.0, -r, 0.0], [0.0, 1.0, 0.0, r, 0.0, 0.0]]]
    M = np.diag([m, m, m, I, I, I])
    dv_mj = q[:2] - v[:2]
    assert np.linalg.norm(dv_mj) == pytest.approx(mu * (1 + e), rel=2e-3)
    for facets, ratio in ((8, np.cos(np.pi / 8)), (64, 1.0)):
        res = frictional_impact(M, v, [[0.0, 0.0, 1.0, 0.0, 0.0, 0.0]], T, mu, e,
                                facets=facets)
        dv = res.v_plus[:2] - v[:2]
        assert np.linalg.norm(dv) == pytest.approx(ratio * np.linalg.norm(dv_mj), rel=2e-3)
    np.testing.assert_allclose(dv, dv_mj, rtol=2e-3)
