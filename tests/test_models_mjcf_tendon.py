"""MJCF tendon equalities over fixed tendons are linear joint couplings: MuJoCo as reference.

A fixed tendon's length is ``L = sum_i coef_i qpos_i``; ``<equality><tendon tendon1="t"
[tendon2="u"] polycoef="c0 c1 ...">`` holds ``L_t - L_t(qpos0) = c0 + c1 (L_u - L_u(qpos0))``
(single tendon: ``c0`` only). It is MuJoCo's idiom for a coupling of several joints, and
how :func:`~roverimpact.models.export_mjcf.export_mjcf` writes the rocker-bogie
differential. Before, the loader kept joint equalities only and dropped these with a
warning: the exported rocker-bogie lost its differential (T_c^- 0.02495 J, m_eff 4.990 kg
at beta = 30 deg instead of the built-in's 0.03337 J, 6.674 kg).

References: the built-in rocker-bogie (its own LinearLoopClosure), and MuJoCo's
``mj_fullM``, ``efc_pos`` and ``efc_J`` of the equality rows, with the constrained
effective mass computed from them and, independently, by eliminating the couplings
(null space of the rows).
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

import roverimpact as ri
from roverimpact.models import load_robot, rocker_bogie
from roverimpact.models.export_mjcf import export_mjcf, mjcf_element
from roverimpact.models.mjcf import (
    mujoco_joint_map,
    mujoco_state_to_pinocchio,
    pinocchio_state_to_mujoco,
    velocity_map,
)
from roverimpact.models.mujoco_check import full_mass_matrix

mujoco = pytest.importorskip("mujoco")


# ------------------------------------------------------------ the exported rocker-bogie


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.HeldRowsWarning")
def test_exported_rocker_bogie_keeps_its_differential(tmp_path):
    """export_mjcf(rocker_bogie()) loaded back: one row 'loop:tendon:loop_differential'
    equal to the built-in's differential row, and the built-in's T_c^- and m_eff (left
    front wheel, beta = 30 deg) to 1e-12 (was 0.0249504 J / 4.990 kg against 0.0333689 J
    / 6.674 kg)."""
    builtin = rocker_bogie("prototype")
    path = export_mjcf(builtin, tmp_path / "rb.xml")
    _, layout = mjcf_element(builtin)
    mbm = load_robot(path, floating_base=True)
    assert mbm.loop_names == ["tendon:loop_differential"]
    assert "mujoco_equalities_ignored" not in mbm.params

    rest = {"velocity": {"u": 0.2}, "obstacle": {"wheel": "left_front", "beta_deg": 30.0},
            "contacts": {"ground_wheels": "others", "ground": "noslip", "loop_closure": True},
            "constraints": "all"}
    wheels = {w.name: {"frame": layout.wheel_bodies[w.name], "radius": w.radius,
                       "width": w.width} for w in builtin.wheels}
    z0 = builtin.params["q_nominal"][2]
    sc_file = ri.Scenario.model_validate(
        {"model": {"file": str(path), "base": {"kind": "floating"}, "wheels": wheels},
         "configuration": {"base": {"z": z0}}, **rest})
    sc_builtin = ri.Scenario.model_validate(
        {"model": {"name": "rocker_bogie", "preset": "prototype"}, **rest})
    e_file, e_builtin = ri.energy_of(sc_file), ri.energy_of(sc_builtin)
    assert float(e_builtin.T_c_minus) == pytest.approx(0.0333689, rel=1e-5)
    np.testing.assert_allclose(e_file.T_c_minus, e_builtin.T_c_minus, rtol=1e-12)
    np.testing.assert_allclose(e_file.m_eff, e_builtin.m_eff, rtol=1e-12)

    s_file = ri.ImpactSetup.from_scenario(sc_file)
    s_builtin = ri.ImpactSetup.from_scenario(sc_builtin)
    assert "loop:tendon:loop_differential" in s_file.labels
    assert len(s_file.labels) == len(s_builtin.labels)
    # the rows, joint by joint
    phi_f, J_f = s_file.model.loop_closure(s_file.q)
    phi_b, J_b = s_builtin.model.loop_closure(s_builtin.q)
    assert np.abs(phi_f).max() == 0.0 and np.abs(phi_b).max() == 0.0
    for jn in ("rocker_left", "rocker_right", "bogie_left", "bogie_right"):
        iv_f = s_file.model.model.joints[s_file.model.model.getJointId(jn)].idx_v
        iv_b = s_builtin.model.model.joints[s_builtin.model.model.getJointId(jn)].idx_v
        assert J_f[0, iv_f] == J_b[0, iv_b]
    assert np.count_nonzero(J_f) == np.count_nonzero(J_b) == 2


# ------------------------------------------------ a file written the way MuJoCo users do

LINKAGE = """
<mujoco model="linkage">
  <compiler angle="degree" autolimits="true"/>
  <default>
    <default class="visual"><geom contype="0" conaffinity="0" group="2" density="0"/></default>
    <default class="wheel"><geom type="sphere" size="0.1" mass="1.5"/></default>
  </default>
  <worldbody>
    <body name="chassis" pos="0 0 0.5">
      <freejoint name="root"/>
      <geom type="box" size="0.3 0.2 0.05" contype="0" conaffinity="0" mass="8"/>
      <geom class="visual" type="box" size="0.32 0.22 0.02" pos="0 0 0.06"/>
      <body name="lift" pos="0 0 0.1">
        <joint name="lift" type="slide" axis="0 0 1" ref="0.01"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.1" size="0.02" mass="0.4"/>
      </body>
      <body name="rocker_l" pos="0 0.25 0">
        <joint name="rocker_l" type="hinge" axis="0 1 0" ref="5" armature="0.01"/>
        <geom type="capsule" fromto="-0.3 0 -0.1 0.3 0 -0.1" size="0.02" mass="1"/>
        <geom class="visual" type="cylinder" size="0.03 0.01" euler="90 0 0"/>
        <body name="bogie_l" pos="-0.3 0 -0.1">
          <joint name="bogie_l" type="hinge" axis="0 1 0"/>
          <geom type="capsule" fromto="-0.15 0 -0.1 0.15 0 -0.1" size="0.02" mass="0.6"/>
          <body name="wheel_l" pos="0.15 0 -0.15">
            <joint name="steer_l" type="hinge" axis="0 0 1"/>
            <joint name="spin_l" type="hinge" axis="0 1 0"/>
            <geom class="wheel"/>
            <geom class="visual" type="cylinder" size="0.1 0.03" euler="90 0 0"/>
          </body>
        </body>
      </body>
      <body name="rocker_r" pos="0 -0.25 0">
        <joint name="rocker_r" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="-0.3 0 -0.1 0.3 0 -0.1" size="0.02" mass="1"/>
        <body name="bogie_r" pos="-0.3 0 -0.1">
          <joint name="bogie_r" type="hinge" axis="0 1 0" ref="-3"/>
          <geom type="capsule" fromto="-0.15 0 -0.1 0.15 0 -0.1" size="0.02" mass="0.6"/>
          <body name="wheel_r" pos="0.15 0 -0.15">
            <joint name="steer_r" type="hinge" axis="0 0 1"/>
            <joint name="spin_r" type="hinge" axis="0 1 0"/>
            <geom class="wheel"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <tendon>
    <fixed name="diff">
      <joint joint="rocker_l" coef="1"/>
      <joint joint="rocker_r" coef="1"/>
      <joint joint="lift" coef="-2"/>
    </fixed>
    <fixed name="bogies">
      <joint joint="bogie_l" coef="1"/>
      <joint joint="bogie_r" coef="0.5"/>
    </fixed>
    <fixed name="steer"><joint joint="steer_r" coef="2"/></fixed>
  </tendon>
  <equality>
    <tendon name="differential" tendon1="diff" polycoef="0.02 0 0 0 0"/>
    <tendon name="bogie_link" tendon1="bogies" tendon2="steer" polycoef="0.05 -0.7 0 0 0"/>
    <joint name="steer_hold" joint1="steer_l" polycoef="0.1 3 1 0 0"/>
  </equality>
</mujoco>
"""


@pytest.fixture(scope="module")
def linkage(tmp_path_factory):
    path = tmp_path_factory.mktemp("tendon") / "linkage.xml"
    path.write_text(LINKAGE)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing is ignored
        mbm = load_robot(path)
    m = mujoco.MjModel.from_xml_path(str(path))
    return mbm, m


def _mujoco_rows(m, d):
    """``(efc_pos, efc_J (rows, nv))`` of the equality rows, by equality name."""
    J = np.zeros((d.nefc, m.nv))
    if mujoco.mj_isSparse(m):
        mujoco.mju_sparse2dense(J, d.efc_J, d.efc_J_rownnz, d.efc_J_rowadr, d.efc_J_colind)
    else:
        J = d.efc_J[:d.nefc * m.nv].reshape(d.nefc, m.nv).copy()
    out = {}
    for i in range(d.nefc):
        if d.efc_type[i] == mujoco.mjtConstraint.mjCNSTR_EQUALITY:
            nm = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, d.efc_id[i])
            out[nm] = (float(d.efc_pos[i]), J[i])
    return out


def test_hand_written_couplings_are_mujocos_rows(linkage):
    """Three equalities (a tendon over three joints with c0 = 0.02, two tendons coupled by
    c1 = -0.7, a single joint with c1 and c2 that MuJoCo does not use) are three rows whose
    residuals and Jacobians are MuJoCo's efc_pos and efc_J at random states."""
    mbm, m = linkage
    assert mbm.loop_names == ["mimic:steer_l", "tendon:differential", "tendon:bogie_link"]
    d = mujoco.MjData(m)
    mp = mujoco_joint_map(mbm)
    rng = np.random.default_rng(7)
    for _ in range(5):
        qpos = m.qpos0 + 0.3 * rng.standard_normal(m.nq)
        qpos[3:7] /= np.linalg.norm(qpos[3:7])
        d.qpos[:] = qpos
        mujoco.mj_forward(m, d)
        rows = _mujoco_rows(m, d)
        q, _ = mujoco_state_to_pinocchio(mbm, qpos)
        phi, J = mbm.loop_closure(q)
        T = velocity_map(mbm, mp, q)
        for k, eq in enumerate(["steer_hold", "differential", "bogie_link"]):
            pos, Jm = rows[eq]
            assert phi[k] == pytest.approx(pos, abs=1e-13)
            np.testing.assert_allclose(J[k] @ T, Jm, atol=1e-13)


def test_nominal_configuration_satisfies_mujocos_equalities(linkage):
    """qpos0 opens the rows (c0 != 0): q_nominal is moved onto them, and MuJoCo agrees
    that its equalities hold there."""
    mbm, m = linkage
    q0 = np.array(mbm.params["q_nominal"])
    phi, _ = mbm.loop_closure(q0)
    assert np.abs(phi).max() < 1e-14
    d = mujoco.MjData(m)
    d.qpos[:] = pinocchio_state_to_mujoco(mbm, q0)[0]
    mujoco.mj_forward(m, d)
    assert max(abs(p) for p, _ in _mujoco_rows(m, d).values()) < 1e-14


def test_constrained_effective_mass_equals_mujocos(linkage):
    """m_eff of the left wheel centre along z with the couplings held: from the package's
    M(q), rows and point Jacobian; from mj_fullM, efc_J and mj_jacBody; and by eliminating
    the couplings (null space of MuJoCo's rows). Without the rows it is lower."""
    from scipy.linalg import null_space

    mbm, m = linkage
    d = mujoco.MjData(m)
    mp = mujoco_joint_map(mbm)
    q = np.array(mbm.params["q_nominal"])
    qpos = pinocchio_state_to_mujoco(mbm, q)[0]
    d.qpos[:] = qpos
    mujoco.mj_forward(m, d)
    M_mj = full_mass_matrix(mujoco, m, d)  # mj_fullM
    A_mj = np.array([J for _, J in _mujoco_rows(m, d).values()])
    jacp = np.zeros((3, m.nv))
    mujoco.mj_jacBody(m, d, jacp, None, m.body("wheel_l").id)
    a_mj = jacp[2]

    model, data = mbm.model, mbm.model.createData()
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    _, A = mbm.loop_closure(q)
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    Jw = pin.getFrameJacobian(model, data, model.getFrameId("wheel_l"),
                              pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
    a = Jw[2]
    T = velocity_map(mbm, mp, q)
    np.testing.assert_allclose(T.T @ M @ T, M_mj, atol=1e-12)

    def m_eff(M, A, a):
        Mi = np.linalg.inv(M)
        P = Mi - Mi @ A.T @ np.linalg.solve(A @ Mi @ A.T, A @ Mi)
        return 1.0 / (a @ P @ a)

    N = null_space(A_mj)
    by_hand = 1.0 / (a_mj @ N @ np.linalg.solve(N.T @ M_mj @ N, N.T @ a_mj))
    ours = m_eff(M, A, a)
    assert ours == pytest.approx(m_eff(M_mj, A_mj, a_mj), rel=1e-10)
    assert ours == pytest.approx(by_hand, rel=1e-10)
    assert ours > 1.01 / (a @ np.linalg.solve(M, a))  # the couplings matter here


# ------------------------------------------------------------------------ what is ignored


def test_unsupported_equalities_are_one_warning_naming_each(tmp_path):
    """A nonlinear two-tendon polycoef, a spatial tendon and a weld without torque
    (torquescale 0) are ignored with one warning naming each and why; the linear tendon
    equality beside them is kept."""
    extra = LINKAGE.replace(
        '<tendon name="bogie_link" tendon1="bogies" tendon2="steer" polycoef="0.05 -0.7 0 0 0"/>',
        '<tendon name="bogie_link" tendon1="bogies" tendon2="steer" polycoef="0 -0.7 0.2 0 0"/>'
        '<tendon name="cable_eq" tendon1="cable"/>'
        '<weld name="pin" body1="wheel_l" body2="wheel_r" torquescale="0"/>'
    ).replace('<fixed name="steer">',
              '<spatial name="cable"><site site="s1"/><site site="s2"/></spatial>'
              '<fixed name="steer">'
    ).replace('<geom class="wheel"/>\n            <geom class="visual"',
              '<geom class="wheel"/><site name="s1"/>\n            <geom class="visual"'
    ).replace('<joint name="spin_r" type="hinge" axis="0 1 0"/>',
              '<joint name="spin_r" type="hinge" axis="0 1 0"/><site name="s2"/>')
    path = tmp_path / "extra.xml"
    path.write_text(extra)
    mujoco.MjModel.from_xml_path(str(path))  # a valid MuJoCo file
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mbm = load_robot(path)
    msgs = [str(w.message) for w in caught if "equality" in str(w.message)]
    assert len(msgs) == 1, msgs
    assert "'bogie_link' (tendon equality, nonlinear polycoef" in msgs[0]
    assert "'cable_eq' (tendon equality over the spatial tendon 'cable')" in msgs[0]
    assert "'pin' (weld, torquescale 0)" in msgs[0]
    assert mbm.params["mujoco_equalities_ignored"] == ["bogie_link", "cable_eq", "pin"]
    assert mbm.loop_names == ["mimic:steer_l", "tendon:differential"]

