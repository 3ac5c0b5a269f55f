"""MuJoCo ``connect`` equalities (closed kinematic loops in MJCF) against MuJoCo.

Reference: MuJoCo's ``mj_fullM`` and ``mj_jac``. The loop rows are the difference of the
point Jacobians of the two anchors (``eq_data[0:3]`` in body1, ``eq_data[3:6]`` in body2,
as MuJoCo's compiler places them); the configuration closes the loop (Gauss-Newton on
MuJoCo's own kinematics) and the velocity is projected onto the loop's null space. T_c^-
with the loop and the impact row held is ``1/2 (A v)^T (A M^-1 A^T)^+ (A v)``.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from roverimpact.models import load_robot
from roverimpact.models.mjcf import mujoco_state_to_pinocchio
from roverimpact.scenario.build import ImpactSetup

mujoco = pytest.importorskip("mujoco")

#: a four-bar: ground pivots 1 m apart, crank 0.4 m, coupler, rocker 0.6 m, closed by a
#: connect between the coupler's far end and the rocker's tip (body anchors, or sites)
FOURBAR = """<mujoco model="fourbar">
  <worldbody>
    <body name="crank">
      <joint name="q1" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 0.4" size="0.02" mass="1"/>
      <body name="coupler" pos="0 0 0.4">
        <joint name="q2" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 1 0 0.2" size="0.02" mass="2"/>
        <site name="tip" pos="0.5 0 0.1"/>
        <site name="end_c" pos="1 0 0.2"/>
      </body>
    </body>
    <body name="rocker" pos="1 0 0">
      <joint name="q3" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 0.6" size="0.02" mass="1.5"/>
      <site name="end_r" pos="0 0 0.6"/>
    </body>
  </worldbody>
  <equality>{}</equality>
</mujoco>
"""
BODIES = '<connect name="close" body1="coupler" body2="rocker" anchor="1 0 0.2"/>'
SITES = '<connect name="close" site1="end_c" site2="end_r"/>'


@pytest.mark.parametrize("connect", [BODIES, SITES], ids=["bodies", "sites"])
def test_connect_closes_the_loop_as_mujoco_does(tmp_path, connect):
    """The connect was ignored (a warning): T_c^- of the coupler point hitting a face
    came out as the open chain's, 0.0014 J where MuJoCo's closed four-bar has 0.018 J
    (12.6x). It is now a point loop: T_c^- equals MuJoCo's to 1e-9 at closed
    configurations, and the rows are ``loop:close:x|z`` (y is out of the plane)."""
    f = tmp_path / "fourbar.xml"
    f.write_text(FOURBAR.format(connect))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "equality ignored" warning
        mbm = load_robot(f)
    m = mujoco.MjModel.from_xml_path(str(f))
    d = mujoco.MjData(m)
    coupler, rocker = 2, 3  # body ids (crank: 1)
    a1 = np.array([1, 0, 0.2])
    a2 = np.array(m.eq_data[0, 3:6]) if connect == BODIES else np.array([0, 0, 0.6])

    def loop(qpos):
        d.qpos[:] = qpos
        mujoco.mj_forward(m, d)
        out = []
        for b, a in ((coupler, a1), (rocker, a2)):
            p = d.xpos[b] + d.xmat[b].reshape(3, 3) @ a
            J = np.zeros((3, m.nv))
            mujoco.mj_jac(m, d, J, None, p, b)
            out.append((p, J))
        return out[0][0] - out[1][0], out[0][1] - out[1][1]

    rng = np.random.default_rng(2)
    ratios = []
    for q1 in (0.0, 0.3, -0.4):
        qpos = np.array([q1, 0.0, 0.0])
        for _ in range(30):
            g, J = loop(qpos)
            qpos[1:] -= np.linalg.lstsq(J[:, 1:], g, rcond=None)[0]
        g, J = loop(qpos)
        assert np.abs(g).max() < 1e-12
        qvel = (np.eye(3) - np.linalg.pinv(J) @ J) @ rng.standard_normal(3)
        d.qvel[:] = qvel
        mujoco.mj_forward(m, d)
        M = np.zeros((3, 3))
        mujoco.mj_fullM(m, d, M)
        s = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tip")
        jp = np.zeros((3, 3))
        mujoco.mj_jac(m, d, jp, None, d.site_xpos[s], coupler)
        n = np.array([0.3, 0, 1.0]) / np.hypot(0.3, 1.0)
        n = n if n @ jp @ qvel < 0 else -n
        A = np.vstack([J, n @ jp])
        T_mj = 0.5 * (A @ qvel) @ np.linalg.pinv(A @ np.linalg.solve(M, A.T)) @ (A @ qvel)
        q, v = mujoco_state_to_pinocchio(mbm, qpos, qvel)
        st = ImpactSetup.from_state(mbm, q, v, obstacle={"frame": "tip", "normal": list(n)},
                                    constraints="all")
        assert st.labels == ("loop:close:x", "loop:close:z", "obstacle:tip:normal")
        assert st.partition().T_c_minus == pytest.approx(T_mj, rel=1e-9)
        a = n @ jp
        ratios.append(T_mj / (0.5 * (a @ qvel) ** 2 / (a @ np.linalg.solve(M, a))))
    assert max(ratios) > 2  # the loop matters


#: a free base with a three-hinge arm whose last link is welded to the world (9 DoF, 6
#: held), and a second arm link welded to the base by relpose at qpos0 (the default)
WELDED = """<mujoco model="welded">
  <worldbody>
    <body name="base" pos="0 0 0.5" euler="10 -20 30">
      <freejoint name="root"/>
      <geom type="box" size="0.3 0.2 0.1" mass="8"/>
      <body name="l1" pos="0.3 0 0.1" euler="0 30 0">
        <joint name="a" axis="0 0 1"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/>
        <body name="l2" pos="0.3 0 0" euler="20 0 0">
          <joint name="b" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0.3 0.1 0" size="0.03" mass="0.8"/>
          <body name="l3" pos="0.3 0.1 0">
            <joint name="c" axis="1 0 0"/>
            <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.03" mass="0.5"/>
          </body>
        </body>
      </body>
      <body name="tail" pos="-0.3 0 0">
        <joint name="t" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 -0.3 0 0" size="0.03" mass="0.6"/>
        <site name="tail_tip" pos="-0.3 0 0"/>
      </body>
    </body>
  </worldbody>
  <equality><weld name="grip" body1="l3"/></equality>
</mujoco>
"""


def test_weld_holds_the_relative_pose_as_mujoco_does(tmp_path):
    """A weld (here of an arm's last link to the world, closing base + arm into a loop)
    was ignored with a warning. It is now three point loops of body2's origin and unit
    x, y points (9 rows, rank 6): T_c^- of the tail tip equals MuJoCo's with the weld's
    six rows (``mj_jac`` translation and rotation differences) held, to 1e-9."""
    f = tmp_path / "welded.xml"
    f.write_text(WELDED)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mbm = load_robot(f)
    m = mujoco.MjModel.from_xml_path(str(f))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    l3 = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "l3")
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    mujoco.mj_jac(m, d, jp, jr, d.xpos[l3], l3)
    J = np.vstack([jp, jr])  # the world does not move
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    s = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tail_tip")
    jt = np.zeros((3, m.nv))
    mujoco.mj_jac(m, d, jt, None, d.site_xpos[s], m.site_bodyid[s])
    rng = np.random.default_rng(4)
    ratios = []
    for _ in range(3):
        qvel = (np.eye(m.nv) - np.linalg.pinv(J) @ J) @ rng.standard_normal(m.nv)
        n = rng.standard_normal(3)
        n = n if n @ jt @ qvel < 0 else -n
        n /= np.linalg.norm(n)
        A = np.vstack([J, n @ jt])
        T_mj = 0.5 * (A @ qvel) @ np.linalg.pinv(A @ np.linalg.solve(M, A.T)) @ (A @ qvel)
        q, v = mujoco_state_to_pinocchio(mbm, m.qpos0, qvel)
        st = ImpactSetup.from_state(mbm, q, v, constraints="all",
                                    obstacle={"frame": "tail_tip", "normal": list(n)})
        assert st.labels[-1] == "obstacle:tail_tip:normal" and len(st.labels) == 10
        assert st.partition().T_c_minus == pytest.approx(T_mj, rel=1e-9)
        a = n @ jt
        ratios.append(T_mj / (0.5 * (a @ qvel) ** 2 / (a @ np.linalg.solve(M, a))))
    assert max(abs(r - 1) for r in ratios) > 0.05  # the weld matters


def test_weld_open_at_qpos0_is_ignored_with_a_warning_naming_it(tmp_path):
    """A weld whose explicit relpose does not hold at qpos0 (MuJoCo pulls the bodies
    together in its first steps) cannot be a loop of the nominal configuration: it is
    left out with the warning that names the ignored equalities, and the gap."""
    f = tmp_path / "open.xml"
    f.write_text(WELDED.replace('body1="l3"/>', 'body1="l3" relpose="0 0 0.1 1 0 0 0"/>'))
    with pytest.warns(UserWarning, match=r"'grip' \(weld open by [0-9.]+ m at qpos0\)"):
        mbm = load_robot(f)
    assert mbm.loop_closure is None and mbm.params["mujoco_equalities_ignored"] == ["grip"]
