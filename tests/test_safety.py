"""ISO/TS 15066 transient-contact limits and exact effective masses of arm points."""

from __future__ import annotations

import numpy as np
import pytest

import roverimpact as ri
from roverimpact import safety
from roverimpact.exceptions import InputError, ModelError

pin = pytest.importorskip("pinocchio")


# ---------------------------------------------------------------------------------------
# ISO numbers
# ---------------------------------------------------------------------------------------


def test_table_values_match_the_standard():
    """Table A.3 (m_H [kg], K [N/mm]) and Table A.2 (F_qs [N]) of ISO/TS 15066:2016.

    Transcribed independently here (region: m_H, K, F_qs):
    skull/forehead 4.4, 150, 130; face 4.4, 75, 65; neck 1.2, 50, 150;
    back/shoulders 40, 35, 210; chest 40, 25, 140; abdomen 40, 10, 110; pelvis 40, 25, 180;
    upper arms/elbows 3, 30, 150; lower arms/wrists 2, 40, 160; hands/fingers 0.6, 75, 140;
    thighs/knees 75, 50, 220; lower legs 75, 60, 130. Transient force = 2 x quasi-static.
    """
    expected = {
        "skull_forehead": (4.4, 150, 130), "face": (4.4, 75, 65), "neck": (1.2, 50, 150),
        "back_shoulders": (40, 35, 210), "chest": (40, 25, 140), "abdomen": (40, 10, 110),
        "pelvis": (40, 25, 180), "upper_arms_elbows": (3, 30, 150),
        "lower_arms_wrists": (2, 40, 160), "hands_fingers": (0.6, 75, 140),
        "thighs_knees": (75, 50, 220), "lower_legs": (75, 60, 130),
    }
    assert set(safety.BODY_REGIONS) == set(expected)
    for key, (mH, K_npmm, F) in expected.items():
        r = safety.BODY_REGIONS[key]
        assert r.m_H == mH and r.K == K_npmm * 1e3 and r.F_qs == F
        if key in ("skull_forehead", "face"):
            assert r.F_transient is None
        else:
            assert r.F_transient == 2 * F
    assert len(safety.BODY_AREAS) == 29
    assert [a.number for a in safety.BODY_AREAS] == list(range(1, 30))
    assert all(a.region in safety.BODY_REGIONS for a in safety.BODY_AREAS)
    palm = next(a for a in safety.BODY_AREAS if a.label == "Palm D")
    assert palm.p_qs == 260e4 and palm.p_transient == 520e4


def test_hand_worked_example():
    """Hand, robot with M = 20 kg of moving parts and a 1 kg payload, by hand:

    m_R = M/2 + m_L = 10 + 1 = 11 kg
    mu  = (1/0.6 + 1/11)^-1 = 0.6*11/11.6 = 0.568965... kg
    F_T = 2 * 140 = 280 N,  K = 75 N/mm = 75 000 N/m
    v   = F / sqrt(mu K) = 280 / sqrt(0.568966 * 75000) = 280 / 206.573 = 1.35545 m/s
    E   = F^2 / (2K) = 78400 / 150000 = 0.522667 J,  and 1/2 mu v^2 = E.
    """
    m_R = safety.iso_robot_mass(20.0, 1.0)
    assert m_R == pytest.approx(11.0)
    mu = safety.reduced_mass(0.6, m_R)
    assert mu == pytest.approx(6.6 / 11.6, rel=1e-12)
    v = safety.max_transient_speed("hands_fingers", m_R)
    assert v == pytest.approx(1.35545, rel=1e-5)
    E = safety.transfer_energy("hands_fingers")
    assert E == pytest.approx(78400 / 150000)
    assert 0.5 * mu * v**2 == pytest.approx(E, rel=1e-12)


def test_speed_limit_vectorised_and_limits():
    """mu -> m_H as m_R -> inf: v -> F / sqrt(m_H K); heavier robots are slower."""
    m_R = np.array([1.0, 10.0, 100.0, np.inf])
    v = safety.max_transient_speed("chest", m_R)
    assert v.shape == (4,)
    assert np.all(np.diff(v) < 0)
    assert v[-1] == pytest.approx(280 / np.sqrt(40 * 25e3))
    # pressure cap: p_T A below F_T lowers the speed proportionally
    v_p = safety.max_transient_speed("chest", 10.0, pressure=2 * 120e4, contact_area=1e-4)
    assert v_p == pytest.approx(240 / np.sqrt(safety.reduced_mass(40, 10) * 25e3))


def test_bad_input():
    with pytest.raises(InputError, match="unknown body region"):
        safety.body_region("tail")
    with pytest.raises(InputError, match="no transient force"):
        safety.max_transient_speed("face", 10.0)
    with pytest.raises(InputError, match="m_R must be positive"):
        safety.max_transient_speed("chest", -1.0)
    with pytest.raises(InputError, match="together"):
        safety.max_transient_speed("chest", 1.0, pressure=1e6)
    with pytest.raises(ModelError, match="no such URDF"):
        safety.load_arm("/nonexistent.urdf")


# ---------------------------------------------------------------------------------------
# Exact effective mass of arm points
# ---------------------------------------------------------------------------------------


def planar_two_link(m1=2.0, m2=1.5, l1=0.7, l2=0.5):
    r"""Two revolute joints about z, point masses m1 at (l1, 0) of link 1, m2 at (l2, 0) of
    link 2; frame "tip" at the second point mass.

        y
        |        m2
        |      /
        |  m1 o  l2
        | /  l1
        o------------ x   (q1, q2 about z)
    """
    model = pin.Model()
    j1 = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "j1")
    model.appendBodyToJoint(j1, pin.Inertia(m1, np.array([l1, 0, 0]), np.zeros((3, 3))),
                            pin.SE3.Identity())
    model.addBodyFrame("link1", j1, pin.SE3.Identity(), 0)
    j2 = model.addJoint(j1, pin.JointModelRZ(), pin.SE3(np.eye(3), np.array([l1, 0, 0])), "j2")
    model.appendBodyToJoint(j2, pin.Inertia(m2, np.array([l2, 0, 0]), np.zeros((3, 3))),
                            pin.SE3.Identity())
    model.addBodyFrame("link2", j2, pin.SE3.Identity(), 0)
    model.addFrame(pin.Frame("tip", j2, 0, pin.SE3(np.eye(3), np.array([l2, 0, 0])),
                             pin.FrameType.OP_FRAME))
    return model


def test_two_link_tip_matches_closed_form():
    r"""Tip of the planar 2-link arm with point masses, derived by hand:

    M11 = m1 l1^2 + m2 (l1^2 + l2^2 + 2 l1 l2 c2),  M12 = m2 (l2^2 + l1 l2 c2),  M22 = m2 l2^2
    J   = [[-l1 s1 - l2 s12, -l2 s12], [l1 c1 + l2 c12, l2 c12]]  (x, y rows)
    m_u = 1 / (u^T J M^-1 J^T u)  for u in the plane;  out of plane (z): cannot move -> inf.
    """
    m1, m2, l1, l2 = 2.0, 1.5, 0.7, 0.5
    model = planar_two_link(m1, m2, l1, l2)
    rng = np.random.default_rng(1)
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, 2)
        c2 = np.cos(q[1])
        s1, c1 = np.sin(q[0]), np.cos(q[0])
        s12, c12 = np.sin(q.sum()), np.cos(q.sum())
        M = np.array([[m1 * l1**2 + m2 * (l1**2 + l2**2 + 2 * l1 * l2 * c2),
                       m2 * (l2**2 + l1 * l2 * c2)],
                      [m2 * (l2**2 + l1 * l2 * c2), m2 * l2**2]])
        J = np.array([[-l1 * s1 - l2 * s12, -l2 * s12], [l1 * c1 + l2 * c12, l2 * c12]])
        ang = rng.uniform(0, 2 * np.pi, 4)
        U = np.stack([np.cos(ang), np.sin(ang)], axis=1)
        expected = 1.0 / np.einsum("ki,ij,kj->k", U, J @ np.linalg.solve(M, J.T), U)
        U3 = np.hstack([U, np.zeros((4, 1))])
        got = safety.point_effective_mass(model, q, "tip", U3)
        np.testing.assert_allclose(got, expected, rtol=1e-10)
        assert safety.point_effective_mass(model, q, "tip", [0, 0, 1]) == np.inf
        # the same point given as an offset in link2's frame
        got2 = safety.point_effective_mass(model, q, "link2", U3[0], point=[l2, 0, 0])
        assert got2 == pytest.approx(expected[0], rel=1e-10)


def test_single_link_lever_rule():
    """One link, point mass m at distance l: at distance r, perpendicular, m_u = m l^2 / r^2;
    along the link the point cannot move (inf)."""
    m, l, r = 3.0, 0.8, 0.5
    model = pin.Model()
    j = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "j")
    model.appendBodyToJoint(j, pin.Inertia(m, np.array([l, 0, 0]), np.zeros((3, 3))),
                            pin.SE3.Identity())
    model.addBodyFrame("link", j, pin.SE3.Identity(), 0)
    q = np.array([0.3])
    u_perp = [-np.sin(0.3), np.cos(0.3), 0.0]
    u_along = [np.cos(0.3), np.sin(0.3), 0.0]
    got = safety.point_effective_mass(model, q, "link", [u_perp, u_along], point=[r, 0, 0])
    assert got[0] == pytest.approx(m * l**2 / r**2, rel=1e-12)
    assert got[1] == np.inf
    # `safety point`'s table: the lever's mass, the standard's m_R = m/2 and their speeds
    # (the ISO speed itself: test_hand_worked_example); directions of any length
    df = safety.point_speed_limits(model, q, "link", [[3 * x for x in u_perp], u_along],
                                   point=[r, 0, 0], region="hands_fingers")
    np.testing.assert_allclose(df[["ux", "uy", "uz"]].to_numpy(), [u_perp, u_along],
                               atol=1e-15)
    assert df["m_u"].iloc[0] == pytest.approx(m * l**2 / r**2, rel=1e-12)
    assert df["m_u"].iloc[1] == np.inf and df.attrs["M_total"] == pytest.approx(m)
    np.testing.assert_allclose(df["m_R_iso"], m / 2, rtol=1e-12)
    v = safety.max_transient_speed("hands_fingers", np.array([m * l**2 / r**2, np.inf, m / 2]))
    np.testing.assert_allclose(df["v_max"], v[:2], rtol=1e-12)
    np.testing.assert_allclose(df["v_iso"], v[2], rtol=1e-12)


def test_arm_table_min_max_bracket_sampled_directions():
    """m_min / m_max from the eigenvalues of G = J M^-1 J^T bracket the direction-sampled
    effective masses (second method: point_effective_mass over many directions)."""
    model = planar_two_link()
    q = np.array([0.4, 1.1])
    df = safety.arm_effective_masses(model, q, payload=0.5, region="hands_fingers")
    assert list(df["link"]) == ["link1", "link2"]
    M_total = 3.5
    assert np.allclose(df["m_R_iso"], M_total / 2 + 0.5)
    rng = np.random.default_rng(0)
    U = rng.normal(size=(400, 3))
    for _, row in df.iterrows():
        ptmass = model.inertias[model.getJointId(row["joint"])].lever
        m = safety.point_effective_mass(model, q, row["link"], U, point=ptmass)
        assert m.min() >= row["m_min"] * (1 - 1e-9)
        assert m.min() <= row["m_min"] * 1.05
        assert row["m_max"] == np.inf  # planar arm: no z motion
    assert np.all(df["v_exact_worst"] <= df["v_exact_best"])


def test_sample_manipulator_runs():
    model = pin.buildSampleModelManipulator()
    df = safety.arm_effective_masses(model, pin.neutral(model), points="origin")
    assert len(df) == model.njoints - 1
    assert np.all(df["m_min"] > 0)


def _panda():
    # example-robot-data is a test dependency: a missing package fails, never skips
    return safety.load_arm("erd:panda")


def test_panda_comparison_runs():
    model = _panda().model
    q = np.array(safety.READY_POSES["panda"])
    df = safety.arm_effective_masses(_panda(), q, payload=1.0, region="chest")
    assert len(df) == model.njoints - 1 == 9
    assert df.attrs["M_total"] == pytest.approx(sum(i.mass for i in model.inertias[1:]))
    assert np.all(df["m_min"] > 0) and np.all(df["m_min"] <= df["m_max"])
    # the standard's single number M/2 + m_L overestimates the mass of the distal links
    # at this pose, so the exact speed limit is higher there
    link7 = df.set_index("link").loc["panda_link7"]
    assert link7["m_min"] < link7["m_R_iso"]
    assert link7["v_exact_best"] > link7["v_iso"]
    # cross-check one entry with point_effective_mass along sampled directions
    p = model.inertias[model.getJointId("panda_joint7")].lever
    U = np.random.default_rng(2).normal(size=(300, 3))
    m = safety.point_effective_mass(_panda(), q, "panda_link7", U, point=p)
    assert m.min() >= link7["m_min"] * (1 - 1e-9) and m.max() <= link7["m_max"] * (1 + 1e-9)


def test_cli_safety(capsys):
    from roverimpact.cli import main

    assert main(["safety", "regions", "--robot-mass", "20", "--payload", "1"]) == 0
    out = capsys.readouterr().out
    assert "1.355" in out  # the hand, worked example above
    assert main(["safety", "arm", "/nonexistent.urdf"]) == 2
    assert "no such URDF" in capsys.readouterr().err
    _panda()
    assert main(["safety", "arm", "erd:panda", "--payload", "1", "--region", "chest"]) == 0
    assert "M (moving parts) = 16.822 kg" in capsys.readouterr().out
    assert main(["safety", "arm", "erd:panda", "--q", "1,2"]) == 2
    assert "q must have 9 numbers" in capsys.readouterr().err


def test_public_exports():
    assert ri.max_transient_speed is safety.max_transient_speed
    assert ri.point_effective_mass is safety.point_effective_mass


def test_load_arm_is_load_robot():
    """load_arm is the models layer's loader (either spelling): the MultibodyModel that
    load_robot returns, with the fingers' mimic row. (API check: same code path, same
    numbers.)"""
    mbm = ri.load_robot("example-robot-data:panda")
    model = _panda()
    assert model.model.nq == mbm.model.nq and model.name == mbm.name
    assert model.loop_names == mbm.loop_names == ["mimic:panda_finger_joint2"]
    q = np.array(safety.READY_POSES["panda"])
    u = np.random.default_rng(4).normal(size=(5, 3))
    np.testing.assert_array_equal(safety.point_effective_mass(mbm, q, "panda_link7", u),
                                  safety.point_effective_mass(model, q, "panda_link7", u))
    assert safety.arm_effective_masses(mbm, q).equals(safety.arm_effective_masses(model, q))


# ---------------------------------------------------------------------------------------
# Coupled joints (<mimic>): the reference enforces the coupling by hand, v = S z
# ---------------------------------------------------------------------------------------

#: Two links about z, j2 mimics j1 (theta_2 = theta_1); link i: mass m_i, centre of mass
#: at 0.25 m, I_zz about it; link 2 hinged at x = 0.5 m of link 1.
MIMIC_ARM_URDF = """<?xml version="1.0"?>
<robot name="mimic_arm">
  <link name="base"/>
  <link name="link1"><inertial><origin xyz="0.25 0 0"/><mass value="2.0"/>
    <inertia ixx="0.001" iyy="0.04" izz="0.04" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="link2"><inertial><origin xyz="0.25 0 0"/><mass value="1.0"/>
    <inertia ixx="0.001" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="link1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="link1"/><child link="link2"/>
    <origin xyz="0.5 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/>
    <mimic joint="j1" multiplier="1.0" offset="0"/></joint>
</robot>
"""


def _reduced_reference(urdf, q, frame, point):
    """``(M_z, J_z)`` of a URDF's point with its ``<mimic>`` couplings enforced by hand:
    plain Pinocchio (whose URDF parser keeps every joint independent), the couplings
    read from the file, ``v = S z`` (a mimic joint's rate is ``multiplier`` times its
    leader's), ``M_z = S^T M S``, ``J_z = J_p S`` (world axes)."""
    import xml.etree.ElementTree as ET

    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    S = np.eye(model.nv)
    drop = []
    for j in ET.parse(urdf).getroot().iter("joint"):
        mm = j.find("mimic")
        if mm is not None:
            f = model.joints[model.getJointId(j.get("name"))].idx_v
            lead = model.joints[model.getJointId(mm.get("joint"))].idx_v
            S[f, lead] = float(mm.get("multiplier", 1.0))
            S[f, f] = 0.0
            drop.append(f)
    S = np.delete(S, drop, axis=1)
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    fid = model.getFrameId(frame)
    J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
    r = data.oMf[fid].rotation @ np.asarray(point, dtype=float)
    Jp = J[:3] - pin.skew(r) @ J[3:]
    return S.T @ M @ S, Jp @ S


def _reference_masses(Mz, Jz, U):
    """1 / (u^T J_z M_z^-1 J_z^T u) per row u of U (unit rows)."""
    G = Jz @ np.linalg.solve(Mz, Jz.T)
    return 1.0 / np.einsum("ki,ij,kj->k", U, G, U)


def test_mimic_arm_holds_the_coupling(tmp_path):
    r"""Tip of link 2 of MIMIC_ARM_URDF along y at q = 0, by hand. With v = (w, w):

        M = [[I1 + m1 0.25^2 + I2 + m2 0.75^2, I2 + m2 0.25 0.75], [., I2 + m2 0.25^2]]
          = [[0.7475, 0.2075], [0.2075, 0.0825]],  M_z = sum of M = 1.245 kg m^2
        J_y(tip) = [1.0, 0.5] m  ->  a_z = 1.5 m,  m_y = 1.245 / 1.5^2 = 0.553333 kg

    (joints independent, as before the fix: 0.300808 kg). Then the reduced reference at
    other configurations and the per-link table."""
    urdf = tmp_path / "mimic_arm.urdf"
    urdf.write_text(MIMIC_ARM_URDF)
    tip = [0.5, 0.0, 0.0]
    for model in (safety.load_arm(urdf), ri.load_robot(urdf)):
        got = safety.point_effective_mass(model, [0.0, 0.0], "link2", [0, 1, 0], point=tip)
        assert got == pytest.approx(1.245 / 1.5**2, rel=1e-12)
    model = safety.load_arm(urdf)
    rng = np.random.default_rng(5)
    U = rng.normal(size=(6, 3))
    U[:, 2] = 0.0  # in the plane; out of it the point cannot move
    U /= np.linalg.norm(U, axis=1)[:, None]
    for th in (0.3, -1.2, 2.0):
        q = np.array([th, th])
        Mz, Jz = _reduced_reference(urdf, q, "link2", tip)
        np.testing.assert_allclose(
            safety.point_effective_mass(model, q, "link2", U, point=tip),
            _reference_masses(Mz, Jz, U), rtol=1e-10)
        df = safety.arm_effective_masses(model, q).set_index("link")
        for link, com in (("link1", [0.25, 0, 0]), ("link2", [0.25, 0, 0])):
            Mz, Jz = _reduced_reference(urdf, q, link, com)
            lam = np.linalg.eigvalsh(Jz @ np.linalg.solve(Mz, Jz.T))
            # one DoF: the point moves along one direction only
            assert df.at[link, "m_min"] == pytest.approx(1 / lam[-1], rel=1e-10)
            assert df.at[link, "m_max"] == np.inf


def test_mimic_arm_refuses_a_q_that_breaks_the_coupling(tmp_path):
    """q with j2 not at j1's value (theta_2 = theta_1) is not a configuration of the
    coupled arm: one error naming the coupling, from the API and the CLI (exit 2), as
    the scenario path refuses joint values that open a loop."""
    from roverimpact.cli import main

    urdf = tmp_path / "mimic_arm.urdf"
    urdf.write_text(MIMIC_ARM_URDF)
    with pytest.raises(ri.RoverImpactError, match=r"open the loop 'mimic:j2' by 0\.1 .*its leader's times"):
        safety.point_effective_mass(safety.load_arm(urdf), [0.3, 0.4], "link2", [0, 1, 0])
    assert main(["safety", "arm", str(urdf), "--q", "0.3,0.4"]) == 2


def test_mimic_arm_cli(tmp_path, capsys):
    """`safety arm` on the mimic arm prints the coupled masses (reduced reference)."""
    import json

    from roverimpact.cli import main

    urdf = tmp_path / "mimic_arm.urdf"
    urdf.write_text(MIMIC_ARM_URDF)
    assert main(["safety", "arm", str(urdf), "--q", "0.3,0.3", "--json"]) == 0
    links = {r["link"]: r for r in json.loads(capsys.readouterr().out)["links"]}
    Mz, Jz = _reduced_reference(urdf, np.array([0.3, 0.3]), "link2", [0.25, 0, 0])
    lam = np.linalg.eigvalsh(Jz @ np.linalg.solve(Mz, Jz.T))
    assert links["link2"]["m_min"] == pytest.approx(1 / lam[-1], rel=1e-10)


def test_panda_fingers_mimic_matches_reduced_reference():
    """Panda (finger_joint2 mimics finger_joint1): points of the hand, a finger and link 7
    along random directions, and the per-link table, against the reduced reference."""
    from roverimpact.models.robot_data import example_robot_urdf

    urdf = example_robot_urdf("panda")
    model = _panda()
    q = np.array(safety.READY_POSES["panda"])
    rng = np.random.default_rng(6)
    U = rng.normal(size=(8, 3))
    U /= np.linalg.norm(U, axis=1)[:, None]
    for frame, point in (("panda_hand_tcp", [0, 0, 0]), ("panda_leftfinger", [0, 0.01, 0.04]),
                         ("panda_link7", [0.02, 0, 0.05])):
        Mz, Jz = _reduced_reference(urdf, q, frame, point)
        np.testing.assert_allclose(
            safety.point_effective_mass(model, q, frame, U, point=point),
            _reference_masses(Mz, Jz, U), rtol=1e-9)
    df = safety.arm_effective_masses(model, q).set_index("link")
    pm = model.model
    for link in ("panda_link6", "panda_link7", "panda_leftfinger", "panda_rightfinger"):
        com = pm.inertias[int(pm.frames[pm.getFrameId(link)].parentJoint)].lever
        Mz, Jz = _reduced_reference(urdf, q, link, com)
        lam = np.linalg.eigvalsh(Jz @ np.linalg.solve(Mz, Jz.T))
        assert df.at[link, "m_min"] == pytest.approx(1 / lam[-1], rel=1e-9)
        assert df.at[link, "m_max"] == pytest.approx(1 / lam[0], rel=1e-6)


def test_panda_agrees_with_energy_scenario():
    """examples/panda_tool_impact.toml: the scenario path's m_eff along n with the other
    rows (the fingers' mimic row) held is the safety path's mass of the same point, and
    both are the reduced reference's (3.96695 kg; 3.96587 kg with the fingers free)."""
    from pathlib import Path

    from roverimpact.models.robot_data import example_robot_urdf
    from roverimpact.scenario import ImpactSetup, load_scenario

    sc = load_scenario(Path(__file__).resolve().parents[1] / "examples"
                       / "panda_tool_impact.toml")
    setup = ImpactSetup.from_scenario(sc)
    m_eff = setup.partition().m_eff
    got = safety.point_effective_mass(_panda(), setup.q, "panda_hand_tcp", setup.normal)
    assert got == pytest.approx(float(m_eff), rel=1e-10)
    Mz, Jz = _reduced_reference(example_robot_urdf("panda"), setup.q, "panda_hand_tcp",
                                [0, 0, 0])
    assert got == pytest.approx(_reference_masses(Mz, Jz, setup.normal[None])[0], rel=1e-10)


# ---------------------------------------------------------------------------------------
# Continuous joints: (cos theta, sin theta) in q
# ---------------------------------------------------------------------------------------


def test_continuous_joint_takes_a_unit_cos_sin_pair(tmp_path):
    r"""MIMIC_ARM_URDF with j2 continuous and no coupling: q = (theta_1, cos theta_2,
    sin theta_2). Tip of link 2 along y at theta = 0, by hand (M as in
    test_mimic_arm_holds_the_coupling, a = J_y = [1.0, 0.5] m):

        det M = 0.7475 0.0825 - 0.2075^2 = 0.0186125
        a M^-1 a^T = (0.0825 - 2 0.2075 0.5 + 0.7475 0.25) / det = 3.324379 1/kg
        m_y = 0.300808 kg

    A pair of norm 2, 0.5 or 0 is no angle: one ModelError naming the joint (it gave
    0.9449 kg for norm 0.5, and "M is not positive definite" for norm 2)."""
    urdf = tmp_path / "cont_arm.urdf"
    urdf.write_text(MIMIC_ARM_URDF.replace('type="revolute"><parent link="link1"',
                                           'type="continuous"><parent link="link1"')
                    .replace('<mimic joint="j1" multiplier="1.0" offset="0"/>', ""))
    model = safety.load_arm(urdf)
    tip = [0.5, 0, 0]
    got = safety.point_effective_mass(model, [0.0, 1.0, 0.0], "link2", [0, 1, 0], point=tip)
    assert got == pytest.approx(0.0186125 / 0.061875, rel=1e-12)
    for q in ([0, 2, 0], [0, 0.5, 0], [0, 0, 0]):
        with pytest.raises(ModelError, match=r"joint 'j2' has norm .*a continuous joint "
                                             r"takes two numbers, cos theta and sin theta"):
            safety.point_effective_mass(model, q, "link2", [0, 1, 0], point=tip)
        with pytest.raises(ModelError, match="joint 'j2'"):
            safety.arm_effective_masses(model, q)
    with pytest.raises(InputError, match=r"shape \(3,\).*continuous joint takes two numbers"):
        safety.point_effective_mass(model, [0.0, 0.5], "link2", [0, 1, 0])


def test_cli_continuous_joint(tmp_path, capsys):
    """`safety arm --q`: the 3 coordinates with a unit (cos, sin) pair, or one angle per
    joint (as [configuration.joints] of a scenario); a pair of norm 2 is an error (it
    printed inf everywhere with exit 0), and so is a count that is neither."""
    import json

    from roverimpact.cli import main

    urdf = tmp_path / "cont_arm.urdf"
    urdf.write_text(MIMIC_ARM_URDF.replace('type="revolute"><parent link="link1"',
                                           'type="continuous"><parent link="link1"')
                    .replace('<mimic joint="j1" multiplier="1.0" offset="0"/>', ""))
    assert main(["safety", "arm", str(urdf), "--q", "0,2,0"]) == 2
    err = capsys.readouterr().err
    assert "joint 'j2' has norm 2" in err and "cos theta and sin theta" in err
    assert main(["safety", "arm", str(urdf), "--q", "1,2,3,4"]) == 2
    err = capsys.readouterr().err
    assert "q must have 3 numbers" in err and "or 2 (one value per joint" in err
    th = 0.5
    q = [0.2, np.cos(th), np.sin(th)]
    want = safety.arm_effective_masses(safety.load_arm(urdf), q)
    for arg in (f"0.2,{th}", ",".join(repr(float(x)) for x in q)):
        assert main(["safety", "arm", str(urdf), "--q", arg, "--json"]) == 0
        out = json.loads(capsys.readouterr().out)
        np.testing.assert_allclose(out["q"], q, rtol=1e-15)
        np.testing.assert_allclose([r["m_min"] for r in out["links"]], want["m_min"],
                                   rtol=1e-12)


def test_ready_pose_under_every_spelling(capsys):
    """`safety arm` starts from the ready pose for either spelling of the same robot of
    example-robot-data (example-robot-data:panda got the neutral pose: m_min of link 1
    1930 kg instead of 13 774 kg)."""
    import json

    from roverimpact.cli import main

    ready = safety.READY_POSES["panda"]
    spellings = ("erd:panda", "example-robot-data:panda",
                 "erd:panda_description/urdf/panda.urdf",
                 "example-robot-data:panda_description/urdf/panda.urdf")
    for robot in spellings:
        assert main(["safety", "arm", robot, "--json"]) == 0
        assert json.loads(capsys.readouterr().out)["q"] == ready
    from roverimpact.safety.arm import ready_pose

    assert all(ready_pose(robot) == ready for robot in spellings)
    assert ready_pose("erd:ur5") is None and ready_pose("my_arm.urdf") is None


def test_head_region_speeds_are_null(capsys):
    """No transient contact with the head: `safety arm --json --region face` gives the
    speed keys as null (docs/robot-safety.md), not left out; the table prints "-"."""
    import json

    from roverimpact.cli import main

    for region in ("face", "skull_forehead"):
        assert main(["safety", "arm", "erd:panda", "--json", "--region", region]) == 0
        links = json.loads(capsys.readouterr().out)["links"]
        assert all(r["v_iso"] is None and r["v_exact_worst"] is None
                   and r["v_exact_best"] is None for r in links)
        assert all(r["m_min"] > 0 for r in links)
    df = safety.arm_effective_masses(_panda(), safety.READY_POSES["panda"], region="face")
    assert df[["v_iso", "v_exact_worst", "v_exact_best"]].isna().all().all()
    assert main(["safety", "arm", "erd:panda", "--region", "face"]) == 0
    assert "transient contact not permitted" in capsys.readouterr().out


def test_model_as_robot_file_or_bad_type():
    """point_effective_mass takes a robot file as the CLI does ("erd:panda" gave a raw
    AttributeError), and anything else that is not a model is one InputError."""
    q = safety.READY_POSES["panda"]
    u = [[0, 0, 1], [1, 0, 0]]
    np.testing.assert_array_equal(
        safety.point_effective_mass("erd:panda", q, "panda_link7", u),
        safety.point_effective_mass(_panda(), q, "panda_link7", u))
    assert safety.arm_effective_masses("example-robot-data:panda", q).equals(
        safety.arm_effective_masses(_panda(), q))
    for bad in (None, 3.0):
        with pytest.raises(InputError, match="model must be a MultibodyModel"):
            safety.point_effective_mass(bad, q, "panda_link7", [0, 0, 1])


def test_transfer_energy_broadcasts_like_the_speed():
    """E = F^2 / (2K) per force, chest K = 25 N/mm: 100 N -> 0.2 J, 280 N -> 1.568 J (an
    array gave a raw TypeError while max_transient_speed broadcast); 1/2 mu v^2 = E."""
    F = np.array([100.0, 280.0])
    E = safety.transfer_energy("chest", force=F)
    np.testing.assert_allclose(E, [0.2, 1.568], rtol=1e-14)
    v = safety.max_transient_speed("chest", 11.0, force=F)
    np.testing.assert_allclose(0.5 * safety.reduced_mass(40.0, 11.0) * v**2, E, rtol=1e-12)
    assert isinstance(safety.transfer_energy("chest"), float)
    with pytest.raises(InputError, match="force must be positive"):
        safety.transfer_energy("chest", force=[100.0, -1.0])
    with pytest.raises(InputError, match="force"):
        safety.transfer_energy("chest", force="abc")


def test_direction_of_any_scale():
    """A direction is normalised without overflow or underflow: (0, 0, 1e300),
    (0, 0, 1e-300) and (1e200, 1e200, 0) are (0, 0, 1) and (1, 1, 0) (they were refused as
    "must be finite and non-zero")."""
    model, q = _panda(), safety.READY_POSES["panda"]
    ref = safety.point_effective_mass(model, q, "panda_link7", [[0, 0, 1], [1, 1, 0]])
    got = safety.point_effective_mass(model, q, "panda_link7",
                                      [[0, 0, 1e300], [0, 0, 1e-300], [1e200, 1e200, 0]])
    np.testing.assert_allclose(got, ref[[0, 0, 1]], rtol=1e-14)
    for bad in ([0, 0, 0], [np.nan, 0, 1], [np.inf, 0, 0]):
        with pytest.raises(InputError, match="finite and non-zero"):
            safety.point_effective_mass(model, q, "panda_link7", bad)


def test_head_areas_have_no_transient_pressure():
    """Table A.2 gives no transient value for the head (areas 1-3: middle of forehead,
    temple, masticatory muscle), as for its regions; p_transient gave 2 x p_qs there.
    Elsewhere 2 x p_qs (sternum: 120 N/cm^2 -> 240 N/cm^2)."""
    head = [a for a in safety.BODY_AREAS if a.number <= 3]
    assert [a.label for a in head] == ["Middle of forehead", "Temple", "Masticatory muscle"]
    assert all(a.p_transient is None for a in head)
    sternum = next(a for a in safety.BODY_AREAS if a.label == "Sternum")
    assert sternum.p_transient == 240e4
    assert all(a.p_transient == 2 * a.p_qs for a in safety.BODY_AREAS if a.number > 3)


# ---------------------------------------------------------------------------------------
# MuJoCo as the second engine; batches of configurations; degrees; `safety point`
# ---------------------------------------------------------------------------------------


def _ur5_in_mujoco(payload=None):
    """MuJoCo's model of example-robot-data's UR5 URDF (visuals and collisions dropped,
    fixed links kept as bodies so that ``tool0`` exists, no inertia from geometry);
    ``payload=(mass, xyz)``: a link of that mass at ``xyz`` of tool0 (a point mass, its
    inertia 1e-9 kg m^2)."""
    import xml.etree.ElementTree as ET

    mujoco = pytest.importorskip("mujoco")
    from roverimpact.models.robot_data import example_robot_file

    root = ET.parse(example_robot_file("erd:ur5")).getroot()
    for link in root.iter("link"):
        for tag in ("visual", "collision"):
            for e in link.findall(tag):
                link.remove(e)
    if payload is not None:
        mass, xyz = payload
        link = ET.SubElement(root, "link", name="payload")
        inertial = ET.SubElement(link, "inertial")
        ET.SubElement(inertial, "mass", value=str(mass))
        ET.SubElement(inertial, "inertia", ixx="1e-9", iyy="1e-9", izz="1e-9", ixy="0",
                      ixz="0", iyz="0")
        joint = ET.SubElement(root, "joint", name="payload_joint", type="fixed")
        ET.SubElement(joint, "parent", link="tool0")
        ET.SubElement(joint, "child", link="payload")
        ET.SubElement(joint, "origin", xyz=" ".join(map(str, xyz)))
    ET.SubElement(ET.SubElement(root, "mujoco"), "compiler", fusestatic="false",
                  discardvisual="true", inertiafromgeom="false", balanceinertia="false")
    return mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))


@pytest.fixture(scope="module")
def ur5_mujoco():
    """(MultibodyModel, mujoco.MjModel) of example-robot-data's UR5, the same URDF."""
    return safety.load_arm("erd:ur5"), _ur5_in_mujoco()


def _mujoco_masses(m, qpos, body, p_body, U):
    """Khatib's m_u = 1 / (u^T J_p M^-1 J_p^T u) from MuJoCo alone: ``mj_fullM`` for M,
    ``mj_jac`` for J_p at the point ``p_body`` of ``body`` (body coordinates)."""
    import mujoco

    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body)
    jacp = np.zeros((3, m.nv))
    mujoco.mj_jac(m, d, jacp, None, d.xpos[b] + d.xmat[b].reshape(3, 3) @ p_body, b)
    return 1.0 / np.einsum("ki,ij,kj->k", U, jacp @ np.linalg.solve(M, jacp.T), U)


def test_batch_of_configurations_matches_one_at_a_time_and_mujoco(ur5_mujoco):
    """q (4, 2, nq) at the UR5's tool0 with a TCP offset, 3 directions: one call gives
    (4, 2, 3), equal to the configurations one at a time and to MuJoCo's
    mj_fullM / mj_jac (a batch was refused: "q must have shape (6,)")."""
    mbm, m = ur5_mujoco
    rng = np.random.default_rng(7)
    q = rng.uniform(-2.5, 2.5, (4, 2, 6))
    U = rng.normal(size=(3, 3))
    U /= np.linalg.norm(U, axis=1)[:, None]
    tcp = np.array([0.0, 0.0, 0.12])
    got = safety.point_effective_mass(mbm, q, "tool0", U, point=tcp)
    assert got.shape == (4, 2, 3)
    one = np.array([safety.point_effective_mass(mbm, qi, "tool0", U, point=tcp)
                    for qi in q.reshape(-1, 6)]).reshape(4, 2, 3)
    np.testing.assert_allclose(got, one, rtol=1e-12)
    ref = np.array([_mujoco_masses(m, qi, "tool0", tcp, U)
                    for qi in q.reshape(-1, 6)]).reshape(4, 2, 3)
    np.testing.assert_allclose(got, ref, rtol=1e-9)
    single = safety.point_effective_mass(mbm, q[:, 0], "tool0", U[0], point=tcp)
    assert single.shape == (4,)
    np.testing.assert_allclose(single, ref[:, 0, 0], rtol=1e-9)


def test_q_in_degrees_is_refused_naming_the_joint(ur5_mujoco, capsys):
    """UR5 at (0, -90, 90, -90, -90, 0) typed in degrees: read as radians it printed a
    table (exit 0) for a pose 90 rad away. The URDF limits (+-2 pi) refuse it, naming the
    joint; with --deg the table is MuJoCo's at np.radians of the same numbers."""
    import json

    from roverimpact.cli import main

    mbm, m = ur5_mujoco
    deg = [0, -90, 90, -90, -90, 0]
    with pytest.raises(InputError, match=r"'shoulder_lift_joint' = -90 rad is outside its "
                                         r"limits \[-6.28319, 6.28319\].*degrees"):
        safety.point_effective_mass(mbm, deg, "tool0", [1, 0, 0])
    q_s = ",".join(str(x) for x in deg)
    assert main(["safety", "arm", "erd:ur5", "--q", q_s]) == 2
    err = capsys.readouterr().err
    assert "outside its limits" in err and "--deg" in err and "Traceback" not in err
    assert main(["safety", "point", "erd:ur5", "--frame", "tool0", "--direction", "1,0,0",
                 "--q", q_s, "--deg", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    np.testing.assert_allclose(out["q"], np.radians(deg), rtol=1e-15)
    ref = _mujoco_masses(m, np.radians(deg), "tool0", np.zeros(3), np.eye(3)[:1])
    assert out["directions"][0]["m_u"] == pytest.approx(ref[0], rel=1e-9)
    with pytest.raises(InputError, match="q in degrees takes 6"):
        safety.arm.arm_configuration(mbm, [0.0] * 5, deg=True)


def test_cli_point(ur5_mujoco, capsys):
    """`safety point`: the exact mass of a named frame + offset along given directions
    (MuJoCo's), v_max = F_T / sqrt(mu K) with mu = (1/m_H + 1/m_u)^-1 by hand (hand:
    280 N, 75 N/mm, 0.6 kg), the ISO m_R = M/2 + m_L beside it; bad input is one line and
    exit 2."""
    import json

    from roverimpact.cli import main

    _, m = ur5_mujoco
    q = [0.3, -1.2, 1.4, -0.5, 1.2, 0.3]
    args = ["safety", "point", "erd:ur5", "--frame", "wrist_3_link", "--point", "0,0.1,0",
            "--direction", "1,0,0", "--direction", "0,2,2", "--q", ",".join(map(str, q)),
            "--region", "hands_fingers", "--payload", "0"]
    assert main([*args, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    U = np.array([[1, 0, 0], [0, 1, 1]]) / np.array([[1.0], [np.sqrt(2)]])
    ref = _mujoco_masses(m, q, "wrist_3_link", np.array([0, 0.1, 0]), U)
    got = [r["m_u"] for r in out["directions"]]
    np.testing.assert_allclose(got, ref, rtol=1e-9)
    for r, m_u in zip(out["directions"], ref, strict=True):
        mu = 1 / (1 / 0.6 + 1 / m_u)
        assert r["v_max"] == pytest.approx(280 / np.sqrt(mu * 75e3), rel=1e-12)
        assert r["m_R_iso"] == pytest.approx(out["M_total"] / 2, rel=1e-15)
    assert main(args) == 0
    assert "ISO/TS 15066: m_R = M/2 + m_L" in capsys.readouterr().out
    big = list(args)
    big[big.index("0,2,2")] = "0,3e300,3e300"  # printed as (0, 0, 0): its norm overflowed
    assert main([*big, "--json"]) == 0
    r = json.loads(capsys.readouterr().out)["directions"][1]
    np.testing.assert_allclose(r["direction"], U[1], rtol=1e-15)
    assert r["m_u"] == pytest.approx(ref[1], rel=1e-9)
    for bad, msg in (({"--frame": "tool"}, "no frame 'tool'"),
                     ({"--direction": "0,0,0"}, "finite and non-zero"),
                     ({"--direction": "1,0"}, "--direction must be 3"),
                     ({"--region": "hand"}, "unknown body region 'hand'"),
                     ({"--payload": "-1"}, "--payload (payload m_L) must be")):
        a = list(args)
        for k, v in bad.items():
            a[a.index(k) + 1] = v
        assert main(a) == 2
        err = capsys.readouterr().err
        assert msg in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_payload_is_a_point_mass_in_the_exact_model(ur5_mujoco, capsys):
    """payload= adds m_L at the payload point (M + m_L J_L^T J_L): MuJoCo with a 1.2 kg
    link at tool0 + (0, 0, 0.05) gives the same masses at wrist_3_link + (0, 0.1, 0)
    (1e-7: its 1e-9 inertia), and the lever rule of one link by hand,
    m_u = (m l^2 + m_L r_L^2) / r^2. `safety point --payload` used m_L only in the
    ISO number (the exact mass of the arm without it)."""
    import json

    from roverimpact.cli import main

    mbm, m0 = ur5_mujoco
    m = _ur5_in_mujoco((1.2, (0, 0, 0.05)))
    q = np.array([0.3, -1.2, 1.4, -0.5, 1.2, 0.3])
    U = np.random.default_rng(3).normal(size=(4, 3))
    U /= np.linalg.norm(U, axis=1)[:, None]
    p = np.array([0, 0.1, 0])
    got = safety.point_effective_mass(mbm, q, "wrist_3_link", U, point=p, payload=1.2,
                                      payload_frame="tool0", payload_point=[0, 0, 0.05])
    ref = _mujoco_masses(m, q, "wrist_3_link", p, U)
    np.testing.assert_allclose(got, ref, rtol=1e-7)
    assert np.all(got > _mujoco_masses(m0, q, "wrist_3_link", p, U))
    assert main(["safety", "point", "erd:ur5", "--frame", "wrist_3_link", "--point", "0,0.1,0",
                 "--direction", ",".join(map(str, U[0])), "--q", ",".join(map(str, q)),
                 "--payload", "1.2", "--payload-frame", "tool0", "--payload-point",
                 "0,0,0.05", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["directions"][0]["m_u"] == pytest.approx(ref[0], rel=1e-7)
    # one link about z: point mass m at l, payload m_L at r_L, contact at r (perpendicular)
    mass, l, m_L, r_L, r = 3.0, 0.8, 1.5, 0.6, 0.5
    model = pin.Model()
    j = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "j")
    model.appendBodyToJoint(j, pin.Inertia(mass, np.array([l, 0, 0]), np.zeros((3, 3))),
                            pin.SE3.Identity())
    model.addBodyFrame("link", j, pin.SE3.Identity(), 0)
    u = [-np.sin(0.3), np.cos(0.3), 0]
    assert safety.point_effective_mass(model, [0.3], "link", u, point=[r, 0, 0], payload=m_L,
                                       payload_point=[r_L, 0, 0]) == pytest.approx(
        (mass * l**2 + m_L * r_L**2) / r**2, rel=1e-12)
    assert safety.point_effective_mass(model, [0.3], "link", u, point=[r, 0, 0],
                                       payload=m_L) == pytest.approx(
        (mass * l**2 + m_L * r**2) / r**2, rel=1e-12)  # default: at the contact point
    for bad in (-1.0, np.nan, [1.0, 2.0]):
        with pytest.raises(InputError, match="payload must be one finite number >= 0"):
            safety.point_effective_mass(model, [0.3], "link", u, payload=bad)
    with pytest.raises(ModelError, match="no frame 'nope'"):
        safety.point_effective_mass(model, [0.3], "link", u, payload=1.0, payload_frame="nope")


def test_two_link_near_stretched_stays_finite_closed_form():
    """Planar 2-link arm, tip pushed along link 2 (u = (c12, s12)): u^T J = (l1 s2, 0), so
    m_u = det M / (l1^2 s2^2 M22) = m1 / sin^2 q2 + m2 (closed form): finite however close
    to stretched, inf only at q2 = 0 (the singular rule |u^T J_p| <= 1e-10 |J_p|)."""
    model = planar_two_link(m1=2.0, m2=1.5)
    for q2 in (1e-3, 1e-5, 1e-7):
        u = [np.cos(0.3 + q2), np.sin(0.3 + q2), 0.0]
        got = safety.point_effective_mass(model, [0.3, q2], "tip", u)
        assert got == pytest.approx(2.0 / np.sin(q2) ** 2 + 1.5, rel=1e-7)
    assert safety.point_effective_mass(model, [0.3, 0.0], "tip",
                                       [np.cos(0.3), np.sin(0.3), 0]) == np.inf


def test_table_m_max_is_the_point_mass_along_the_weakest_direction(ur5_mujoco):
    """UR5 1e-5 rad from a stretched elbow: the table's m_max of the forearm and wrist links
    is the effective mass along the eigenvector of lambda_min(G), finite (9e10, 6e10 kg), the
    same as point_effective_mass along it and as MuJoCo (mj_fullM, mj_jac at the body's
    centre of mass, the row a = v^T J_p: m = 1 / (a M^-1 a^T)). The table said inf where
    the point function gave a finite mass (lambda_min <= 1e-10 lambda_max was inf there).
    (main: inf for both links at this pose). Exactly stretched, both are inf."""
    import mujoco

    mbm, m = ur5_mujoco
    for elbow, finite in ((1e-5, True), (0.0, False)):
        q = np.array([0.0, -np.pi / 2, elbow, 0.0, 0.0, 0.0])  # upright, elbow ~ 0
        df = safety.arm_effective_masses(mbm, q).set_index("link")
        d = mujoco.MjData(m)
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        for link in ("forearm_link", "wrist_1_link"):
            b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, link)
            J = np.zeros((3, m.nv))
            mujoco.mj_jac(m, d, J, None, d.xipos[b], b)
            v = np.linalg.eigh(J @ np.linalg.solve(M, J.T))[1][:, 0]
            a = v @ J
            com = mbm.model.inertias[mbm.model.getJointId(df.at[link, "joint"])].lever
            fid = mbm.model.getFrameId(link)
            p = mbm.model.frames[fid].placement.actInv(np.array(com))
            point = safety.point_effective_mass(mbm, q, link, v, point=p)
            assert point == df.at[link, "m_max"] or point == pytest.approx(
                df.at[link, "m_max"], rel=1e-6)
            if finite:
                assert 1e10 < df.at[link, "m_max"] < 1e11
                assert df.at[link, "m_max"] == pytest.approx(
                    1.0 / (a @ np.linalg.solve(M, a)), rel=1e-6)
            else:
                assert df.at[link, "m_max"] == np.inf
