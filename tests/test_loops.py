"""Nonlinear loops declared in the scenario (``[[contacts.loops]]``) against the same
mechanism with the loop eliminated by hand.

The mechanism: a four-bar linkage on a cart sliding along x (joints ``x``, ``th1`` crank,
``th2`` coupler relative to the crank, ``th3`` rocker; all hinges about y), written as a
URDF tree and closed in the scenario

- by a point loop (the coupler's tip on the rocker's tip: the coupler is a link of the
  tree and keeps its mass), or
- by a distance loop (a massless rod of length b between the crank's and the rocker's
  tips: the coupler is not in the file).

The reference eliminates the loop by hand: two independent coordinates (x, phi1), the
coupler and rocker angles from the intersection of two circles, their rates from the
differentiated loop equation (a 2x2 solve), the reduced mass matrix from each link's
mass and centroidal inertia, the contact row from the contact point's velocity. Numpy
only: no Pinocchio, no roverimpact. T_c^- and m_eff of an impact on the rocker must agree
to 1e-9.
"""

from __future__ import annotations

import numpy as np
import pytest

import roverimpact as ri
from roverimpact.exceptions import InputError

A_, B_, C_, D_ = 0.3, 0.8, 0.5, 0.7   # crank, coupler, rocker, ground link [m]
MC, M1, M2, M3 = 4.0, 1.2, 2.0, 1.5   # cart, crank, coupler, rocker masses [kg]
S = 0.7                               # contact point on the rocker: S c from its hinge


def _link(name, mass, length):
    i = mass * length**2 / 12.0
    return f"""
  <link name="{name}">
    <inertial><origin xyz="{length / 2} 0 0"/><mass value="{mass}"/>
      <inertia ixx="1e-4" ixy="0" ixz="0" iyy="{i}" iyz="0" izz="{i}"/></inertial>
  </link>"""


def _hinge(name, parent, child, x):
    return f"""
  <joint name="{name}" type="revolute">
    <parent link="{parent}"/><child link="{child}"/><origin xyz="{x} 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-6.3" upper="6.3" effort="1" velocity="10"/>
  </joint>"""


def _urdf(with_coupler: bool) -> str:
    parts = ['<robot name="fourbar_cart">', '  <link name="world"/>',
             """  <link name="cart">
    <inertial><mass value="4.0"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0"
      izz="0.1"/></inertial>
  </link>""",
             """  <joint name="x" type="prismatic">
    <parent link="world"/><child link="cart"/><axis xyz="1 0 0"/>
    <limit lower="-10" upper="10" effort="1" velocity="10"/>
  </joint>""",
             _link("crank", M1, A_), _hinge("th1", "cart", "crank", 0.0),
             _link("rocker", M3, C_), _hinge("th3", "cart", "rocker", D_)]
    if with_coupler:
        parts += [_link("coupler", M2, B_), _hinge("th2", "crank", "coupler", A_)]
    parts.append("</robot>")
    return "\n".join(parts)


def e(phi):
    """Direction of a link along its local x after a rotation phi about y, in (x, z)."""
    return np.array([np.cos(phi), -np.sin(phi)])


def de(phi):
    return np.array([-np.sin(phi), -np.cos(phi)])


def closed_pose(phi1):
    """Coupler and rocker absolute angles closing the loop (the upper branch)."""
    P, G = A_ * e(phi1), np.array([D_, 0.0])
    dist = np.linalg.norm(G - P)
    along = (B_**2 - C_**2 + dist**2) / (2.0 * dist)
    h = np.sqrt(B_**2 - along**2)
    u = (G - P) / dist
    perp = np.array([-u[1], u[0]])
    Q = P + along * u + h * perp
    if Q[1] < 0.0:
        Q = P + along * u - h * perp
    phi2 = np.arctan2(-(Q - P)[1], (Q - P)[0])
    phi3 = np.arctan2(-(Q - G)[1], (Q - G)[0])
    return phi2, phi3


def reduced(phi1, with_coupler):
    """Hand elimination: M_red (2x2 in (x', phi1')), the rates of phi2, phi3 per phi1',
    and the rocker point's velocity Jacobian (2x2: (x, z) by (x', phi1'))."""
    phi2, phi3 = closed_pose(phi1)
    # a e'(phi1) w1 + b e'(phi2) w2 = c e'(phi3) w3
    r2, r3 = np.linalg.solve(np.column_stack([B_ * de(phi2), -C_ * de(phi3)]),
                             -A_ * de(phi1))
    ex = np.array([1.0, 0.0])
    bodies = [(MC, np.column_stack([ex, [0.0, 0.0]]), 0.0, 0.0),
              (M1, np.column_stack([ex, A_ / 2 * de(phi1)]), 1.0, M1 * A_**2 / 12),
              (M3, np.column_stack([ex, C_ / 2 * de(phi3) * r3]), r3, M3 * C_**2 / 12)]
    if with_coupler:
        bodies.append((M2, np.column_stack([ex, A_ * de(phi1) + B_ / 2 * de(phi2) * r2]),
                       r2, M2 * B_**2 / 12))
    M_red = np.zeros((2, 2))
    for m, J, w, inertia in bodies:
        jw = np.array([0.0, w])
        M_red += m * J.T @ J + inertia * np.outer(jw, jw)
    J_p = np.column_stack([ex, S * C_ * de(phi3) * r3])
    return M_red, (phi2, phi3), (r2, r3), J_p


def by_hand(phi1, xdot, w1, n_xz, with_coupler):
    M_red, _, _, J_p = reduced(phi1, with_coupler)
    a = n_xz @ J_p
    m_eff = 1.0 / (a @ np.linalg.solve(M_red, a))
    v_n = a @ np.array([xdot, w1])
    return m_eff, 0.5 * m_eff * v_n**2


def _scenario(tmp_path, phi1, xdot, w1, n_xz, with_coupler, **over):
    path = tmp_path / ("fourbar.urdf" if with_coupler else "fourbar_rod.urdf")
    path.write_text(_urdf(with_coupler))
    _, (phi2, phi3), (r2, r3), _ = reduced(phi1, with_coupler)
    q = {"x": 0.1, "th1": phi1, "th3": phi3}
    v = {"x": xdot, "th1": w1, "th3": r3 * w1}
    if with_coupler:
        q["th2"], v["th2"] = phi2 - phi1, (r2 - 1.0) * w1
        loop = {"name": "coupler_pin", "kind": "point", "frame_a": "coupler",
                "point_a": [B_, 0.0, 0.0], "frame_b": "rocker", "point_b": [C_, 0.0, 0.0]}
    else:
        loop = {"name": "rod", "kind": "distance", "frame_a": "crank",
                "point_a": [A_, 0.0, 0.0], "frame_b": "rocker", "point_b": [C_, 0.0, 0.0],
                "length": B_}
    raw = {"model": {"file": str(path), "base": {"kind": "fixed"}},
           "configuration": {"joints": q}, "velocity": {"joints": v},
           "obstacle": {"frame": "rocker", "point": [S * C_, 0.0, 0.0],
                        "normal": [n_xz[0], 0.0, n_xz[1]]},
           "contacts": {"loops": [loop]}}
    for k, val in over.items():
        raw[k] = val
    return ri.Scenario.model_validate(raw)


# each normal faces the motion of the point hit (v_n > 0): a receding point is no impact
CASES = [(-1.0, 0.3, 1.5, 200.0), (-0.4, -0.2, 2.0, 70.0), (-2.0, 0.5, -1.0, 135.0),
         (-1.3, 0.0, 0.8, 250.0)]


@pytest.mark.parametrize("with_coupler", [True, False], ids=["point-loop", "rod"])
@pytest.mark.parametrize("phi1, xdot, w1, normal_deg", CASES)
def test_loop_equals_hand_elimination(tmp_path, with_coupler, phi1, xdot, w1, normal_deg):
    n_xz = np.array([np.cos(np.radians(normal_deg)), np.sin(np.radians(normal_deg))])
    m_ref, T_ref = by_hand(phi1, xdot, w1, n_xz, with_coupler)
    sc = _scenario(tmp_path, phi1, xdot, w1, n_xz, with_coupler)
    en = ri.energy_of(sc)
    assert float(en.v_n) > 0
    assert float(en.m_eff) == pytest.approx(m_ref, rel=1e-9)
    assert float(en.T_c_minus) == pytest.approx(T_ref, rel=1e-9)
    # and the whole kinetic energy, from the same hand model
    M_red, *_ = reduced(phi1, with_coupler)
    u = np.array([xdot, w1])
    assert float(en.T) == pytest.approx(0.5 * u @ M_red @ u, rel=1e-9)


def test_loop_that_does_not_close_is_refused(tmp_path):
    """A point loop whose points are apart in the scenario's configuration: one error
    naming the loop (not a T_c^- of a mechanism that is not the one drawn)."""
    n_xz = np.array([0.0, 1.0])
    sc = _scenario(tmp_path, -1.0, 0.3, 1.5, n_xz, True)
    raw = sc.model_dump(exclude_none=True)
    raw["configuration"]["joints"]["th3"] += 0.2
    with pytest.raises(InputError, match="coupler_pin"):
        ri.energy_of(ri.Scenario.model_validate(raw))


def test_unknown_loop_frame_is_named(tmp_path):
    n_xz = np.array([0.0, 1.0])
    sc = _scenario(tmp_path, -1.0, 0.3, 1.5, n_xz, False)
    raw = sc.model_dump(exclude_none=True)
    raw["contacts"]["loops"][0]["frame_b"] = "rockr"
    with pytest.raises(InputError, match="rockr"):
        ri.energy_of(ri.Scenario.model_validate(raw))


def test_rates_that_open_the_loop_are_refused(tmp_path):
    """Joint rates that pull the coupler off the rocker: one error naming the loop."""
    n_xz = np.array([0.0, 1.0])
    sc = _scenario(tmp_path, -1.0, 0.3, 1.5, n_xz, True)
    raw = sc.model_dump(exclude_none=True)
    raw["velocity"]["joints"]["th3"] += 0.1
    with pytest.raises(InputError, match="coupler_pin"):
        ri.energy_of(ri.Scenario.model_validate(raw))


def test_planar_pin_keeps_its_in_plane_rows(tmp_path):
    """The pin of a planar four-bar: rows x and z; y (no constraint) is left out."""
    sc = _scenario(tmp_path, -1.0, 0.3, 1.5, np.array([0.0, 1.0]), True)
    setup = ri.ImpactSetup.from_scenario(sc)
    assert [lb for lb in setup.candidate_labels if lb.startswith("loop")] == [
        "loop:coupler_pin:x", "loop:coupler_pin:z"]
