"""URDF files as people write them, against MuJoCo's own URDF reader (an independent
parser, inertia transform, forward kinematics, CRBA and point Jacobian).

Reference: ``mujoco.MjModel.from_xml_path`` of the same file; T_c^- of one impact row
from MuJoCo's ``mj_fullM`` and ``mj_jac``, ``T_c = (a qvel)^2 / (2 a M^-1 a^T)`` with
``a = n^T J_p`` when the point approaches the face (``a qvel < 0``), else 0.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from roverimpact.exceptions import ModelError
from roverimpact.models import load_robot
from roverimpact.scenario.build import ImpactSetup

mujoco = pytest.importorskip("mujoco")

_I = ('<inertial><origin xyz="{o}" rpy="{r}"/><mass value="{m}"/><inertia ixx="{a}" '
      'ixy="{d}" ixz="{e}" iyy="{b}" iyz="{f}" izz="{c}"/></inertial>')


def _inertial(m, a, b, c, d=0.0, e=0.0, f=0.0, o="0 0 0", r="0 0 0"):
    return _I.format(m=m, a=a, b=b, c=c, d=d, e=e, f=f, o=o, r=r)


#: rpy joint origins, inertial frames with rpy and products of inertia, axes that are
#: neither unit nor aligned (``0 2 0``, ``1 1 0``, ``0.6 0 0.8``), an unaligned prismatic
#: joint with limits, a continuous joint, xacro-style massless frame links on fixed joints
ARM_URDF = f"""<?xml version="1.0"?>
<robot name="arm">
  <link name="base_link">{_inertial(3, .05, .04, .03, .002, -.001, .003, "0.01 0.02 0.03",
                                    "0.3 -0.2 0.5")}</link>
  <link name="base_footprint"/>
  <joint name="base_footprint_joint" type="fixed"><parent link="base_link"/>
    <child link="base_footprint"/><origin xyz="0 0 -0.1" rpy="0 0 0"/></joint>
  <link name="l1">{_inertial(1.2, .01, .02, .015, .001, .0005, -.001, "0.1 0 0",
                             "1.0 0.5 -0.7")}</link>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="l1"/>
    <origin xyz="0.1 0.2 0.3" rpy="0.4 -0.3 1.2"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="10" velocity="3"/></joint>
  <link name="l1_frame"/>
  <joint name="l1_frame_joint" type="fixed"><parent link="l1"/><child link="l1_frame"/>
    <origin xyz="0.2 0 0" rpy="0 1.5707963 0"/></joint>
  <link name="l2">{_inertial(.8, .004, .005, .006, o="0 0 0.1")}</link>
  <joint name="j2" type="revolute"><parent link="l1_frame"/><child link="l2"/>
    <origin xyz="0 0.05 0" rpy="0.2 0.1 0"/><axis xyz="0 2 0"/>
    <limit lower="-2" upper="2" effort="10" velocity="3"/></joint>
  <link name="l3">{_inertial(.5, .002, .003, .004, o="0 0 0.05", r="0.3 0.3 0.3")}</link>
  <joint name="j3" type="prismatic"><parent link="l2"/><child link="l3"/>
    <origin xyz="0 0 0.2" rpy="0 0 0.7"/><axis xyz="1 1 0"/>
    <limit lower="-0.1" upper="0.2" effort="10" velocity="3"/></joint>
  <link name="l4">{_inertial(.3, .001, .001, .001, o="0.05 0 0")}</link>
  <joint name="j4" type="continuous"><parent link="l3"/><child link="l4"/>
    <origin xyz="0.1 0 0" rpy="-0.5 0 0.2"/><axis xyz="0.6 0 0.8"/></joint>
  <link name="tool"/>
  <joint name="tool_joint" type="fixed"><parent link="l4"/><child link="tool"/>
    <origin xyz="0.1 0.02 0" rpy="0.1 0.2 0.3"/></joint>
</robot>
"""


#: the arm floating on its own: a ``floating`` joint with an origin from a ``world`` link
FLOATING_ARM_URDF = ARM_URDF.replace(
    '<link name="base_footprint"/>',
    '<link name="world"/><joint name="float" type="floating"><parent link="world"/>'
    '<child link="base_link"/><origin xyz="0.5 0.2 1.0" rpy="0.3 0.2 0.9"/></joint>'
    '<link name="base_footprint"/>')


def _planar_urdf(axis: str | None) -> str:
    ax = "" if axis is None else f'<axis xyz="{axis}"/>'
    return f"""<?xml version="1.0"?>
<robot name="side_on">
  <link name="world"/>
  <link name="body">{_inertial(2, .05, .04, .03, o="0.1 0 0.05")}</link>
  <joint name="plane" type="planar"><parent link="world"/><child link="body"/>
    <origin xyz="0 0 0.3"/>{ax}</joint>
  <link name="arm">{_inertial(.5, .002, .002, .001, o="0 0 -0.1")}</link>
  <joint name="hinge" type="revolute"><parent link="body"/><child link="arm"/>
    <origin xyz="0.2 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
"""


def _mujoco_T_c(m, d, body: str, point, n, qvel) -> tuple[float, np.ndarray, np.ndarray]:
    """T_c^- of the impact row at ``point`` (body frame) of ``body``, the point and the
    normal, ``n`` turned against the point's velocity (so that the point approaches)."""
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body)
    p = d.xpos[b] + d.xmat[b].reshape(3, 3) @ np.asarray(point, float)
    jp = np.zeros((3, m.nv))
    mujoco.mj_jac(m, d, jp, None, p, b)
    n = n if n @ jp @ qvel < 0 else -n
    a = n @ jp
    return float((a @ qvel) ** 2 / (2 * a @ np.linalg.solve(M, a))), p, n


def _roverimpact_T_c(mbm, q, v, frame: str, point, n) -> tuple[float, np.ndarray]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = ImpactSetup.from_state(mbm, q, v, obstacle={"frame": frame, "point": list(point),
                                                         "normal": list(n)},
                                    constraints="all")
    return st.partition().T_c_minus, np.asarray(st.contact_point)


def test_urdf_as_written_gives_mujocos_T_c(tmp_path):
    """rpy origins, rotated inertials, non-unit and unaligned axes, an unaligned prismatic
    joint, a continuous joint, massless frame links: T_c^- at points of three links
    equals MuJoCo's at random states (1e-9), the point to 1e-12 m."""
    f = tmp_path / "arm.urdf"
    f.write_text(ARM_URDF)
    mbm = load_robot(f)
    m = mujoco.MjModel.from_xml_path(str(f))
    d = mujoco.MjData(m)
    model = mbm.model
    rng = np.random.default_rng(7)
    for _ in range(3):
        q, v = pin.neutral(model), np.zeros(model.nv)
        qvel = rng.standard_normal(m.nv)
        for k in range(m.njnt):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, k)
            a = m.jnt_qposadr[k]
            lo, hi = m.jnt_range[k] if m.jnt_limited[k] else (-2.0, 2.0)
            d.qpos[a] = rng.uniform(lo, hi)
            jm = model.joints[model.getJointId(name)]
            if jm.nq == 2:  # continuous: (cos, sin)
                q[jm.idx_q:jm.idx_q + 2] = np.cos(d.qpos[a]), np.sin(d.qpos[a])
            else:
                q[jm.idx_q] = d.qpos[a]
            v[jm.idx_v] = qvel[m.jnt_dofadr[k]]
        d.qvel[:] = qvel
        mujoco.mj_forward(m, d)
        for frame, body, point in (("l2", "l2", [0.1, 0, 0.2]), ("l3", "l3", [0, 0.05, 0]),
                                   ("l4", "l4", [0.1, 0.02, 0.03])):
            T_mj, p_mj, n = _mujoco_T_c(m, d, body, point, rng.standard_normal(3), qvel)
            T_ri, p_ri = _roverimpact_T_c(mbm, q, v, frame, point, n)
            np.testing.assert_allclose(p_ri, p_mj, atol=1e-12)
            assert T_ri == pytest.approx(T_mj, rel=1e-9)


@pytest.mark.parametrize("axis", ["0 1 0", None, "1 0 0"])
def test_urdf_planar_joint_off_z_is_refused_naming_it(tmp_path, axis):
    """URDF's planar joint moves in the plane perpendicular to its axis (default 1 0 0);
    MuJoCo's reader follows it (``0 1 0``: slides along x and z, a hinge about y), but
    Pinocchio built x, y and a turn about z whatever the axis: a rover written side-on
    moved sideways, with the M and contact rows of that motion and no error. It is now
    refused, naming the joint."""
    f = tmp_path / "p.urdf"
    f.write_text(_planar_urdf(axis))
    m = mujoco.MjModel.from_xml_path(str(f))
    normal = np.array([1.0, 0, 0]) if axis is None else np.array(axis.split(), float)
    plane = [m.jnt_axis[k] for k in range(3)]  # plane_TX, plane_TY, plane_RZ
    assert abs(plane[2] @ normal) == pytest.approx(1.0)
    assert plane[0] @ normal == pytest.approx(0.0) and plane[1] @ normal == pytest.approx(0.0)
    with pytest.raises(ModelError, match=r"planar joint 'plane' has .*x-y plane"):
        load_robot(f)


def test_urdf_planar_joint_about_z_gives_mujocos_T_c(tmp_path):
    """A planar joint about +z is what Pinocchio builds: T_c^- of a point of the arm
    equals MuJoCo's (whose planar joint is slide x, slide y, hinge z) at random states."""
    f = tmp_path / "p.urdf"
    f.write_text(_planar_urdf("0 0 1"))
    mbm = load_robot(f)
    m = mujoco.MjModel.from_xml_path(str(f))
    d = mujoco.MjData(m)
    rng = np.random.default_rng(3)
    for _ in range(4):
        x, y, th, h = rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-3, 3), \
            rng.uniform(-1, 1)
        qvel = rng.standard_normal(4)
        d.qpos[:], d.qvel[:] = (x, y, th, h), qvel
        mujoco.mj_forward(m, d)
        c, s = np.cos(th), np.sin(th)
        q = np.array([x, y, c, s, h])
        v = np.r_[np.array([[c, s], [-s, c]]) @ qvel[:2], qvel[2:]]  # joint-frame rate
        T_mj, p_mj, n = _mujoco_T_c(m, d, "arm", [0.1, 0.05, -0.2], rng.standard_normal(3),
                                    qvel)
        T_ri, p_ri = _roverimpact_T_c(mbm, q, v, "arm", [0.1, 0.05, -0.2], n)
        np.testing.assert_allclose(p_ri, p_mj, atol=1e-12)
        assert T_ri == pytest.approx(T_mj, rel=1e-9)


def test_urdf_floating_joint_with_origin_reads_mujocos_state(tmp_path):
    """A ``floating`` joint with an ``<origin>``: MuJoCo's ``qpos`` is the world pose of
    its link; Pinocchio measured ``q`` from the origin, so the state read from MuJoCo
    (``mujoco_state_to_pinocchio``) put the arm 1.2-1.7 m away and T_c^- was wrong (0 for
    MuJoCo's 0.058 J). Now the point and T_c^- equal MuJoCo's at random states, and the
    nominal configuration puts the link where MuJoCo's ``qpos0`` does."""
    from roverimpact.models.mjcf import mujoco_state_to_pinocchio

    f = tmp_path / "floating.urdf"
    f.write_text(FLOATING_ARM_URDF)
    mbm = load_robot(f)
    m = mujoco.MjModel.from_xml_path(str(f))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    data = mbm.model.createData()
    pin.framesForwardKinematics(mbm.model, data, np.array(mbm.params["q_nominal"]))
    np.testing.assert_allclose(data.oMf[mbm.model.getFrameId("l2")].translation,
                               d.xpos[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "l2")],
                               atol=1e-12)
    rng = np.random.default_rng(11)
    for _ in range(3):
        qpos = m.qpos0.copy()
        qpos[:3] += rng.uniform(-1, 1, 3)
        quat = rng.standard_normal(4)
        qpos[3:7] = quat / np.linalg.norm(quat)
        qpos[7:] += rng.uniform(-0.1, 0.1, m.nq - 7)
        qvel = rng.standard_normal(m.nv)
        d.qpos[:], d.qvel[:] = qpos, qvel
        mujoco.mj_forward(m, d)
        q, v = mujoco_state_to_pinocchio(mbm, qpos, qvel)
        for frame, point in (("l2", [0.1, 0, 0.2]), ("l4", [0.1, 0.02, 0.03])):
            T_mj, p_mj, n = _mujoco_T_c(m, d, frame, point, rng.standard_normal(3), qvel)
            T_ri, p_ri = _roverimpact_T_c(mbm, q, v, frame, point, n)
            np.testing.assert_allclose(p_ri, p_mj, atol=1e-12)
            assert T_ri == pytest.approx(T_mj, rel=1e-9)


def test_declared_floating_base_on_a_urdf_that_floats_uses_its_floating_joint(tmp_path):
    """``[model.base] kind = "floating"`` on a URDF whose root link already floats added a
    second free-flyer above the massless ``world`` link, refused as "joints
    ['root_joint'] move no mass". The file's floating joint is now the base: MuJoCo's
    number of DoF, and MuJoCo's T_c^- at its nominal state."""
    from roverimpact.scenario.build import make_model
    from roverimpact.scenario.schema import ModelSpec

    f = tmp_path / "floating.urdf"
    f.write_text(FLOATING_ARM_URDF)
    mbm = make_model(ModelSpec.model_validate({"file": str(f), "base": {"kind": "floating"}}))
    m = mujoco.MjModel.from_xml_path(str(f))
    d = mujoco.MjData(m)
    assert mbm.model.nv == m.nv == 10
    qvel = np.random.default_rng(5).standard_normal(m.nv)
    d.qvel[:] = qvel
    mujoco.mj_forward(m, d)
    from roverimpact.models.mjcf import mujoco_state_to_pinocchio

    q, v = mujoco_state_to_pinocchio(mbm, m.qpos0, qvel)
    T_mj, p_mj, n = _mujoco_T_c(m, d, "l3", [0, 0.05, 0], np.array([0.3, -0.2, 1.0]), qvel)
    T_ri, p_ri = _roverimpact_T_c(mbm, q, v, "l3", [0, 0.05, 0], n)
    np.testing.assert_allclose(p_ri, p_mj, atol=1e-12)
    assert T_ri == pytest.approx(T_mj, rel=1e-9)


@pytest.mark.parametrize("inertial, said", [
    ('<inertial><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>',
     r"has no <mass value=...>"),
    ('<inertial><origin xyz="0.2 0 0"/><mass value="2"/></inertial>', r"has no <inertia>"),
], ids=["no-mass", "no-inertia"])
def test_urdf_inertial_without_mass_or_inertia_is_refused_naming_the_link(tmp_path, inertial,
                                                                       said):
    """MuJoCo refuses an <inertial> without <mass> or without <inertia>. Pinocchio's
    parser dropped the whole <inertial> when the mass was missing (the load then failed
    as "joints ['j1'] move no mass", about links "without <inertial>") and read a point
    mass when the inertia was missing (loaded, T_c^- of a point mass, the check skipped).
    Both are now one error naming the link and the missing element."""
    f = tmp_path / "r.urdf"
    f.write_text(f"""<robot name="r">
  <link name="base">{_inertial(1, .1, .1, .1)}</link>
  <link name="l1">{inertial}</link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>""")
    with pytest.raises(ValueError):
        mujoco.MjModel.from_xml_path(str(f))
    with pytest.raises(ModelError, match=rf"link 'l1': its <inertial> {said}"):
        load_robot(f)


def test_urdf_inertia_violating_the_triangle_inequality_is_still_cross_checked(tmp_path):
    """MuJoCo refuses an inertia with A + B < C (CAD exports have them: the allegro hand's
    finger links by 20 %), so the load-time M(q) check was skipped for the whole file.
    Both engines' copies now get the same isotropic addition on that link, just enough
    for MuJoCo: the check passes on the file as Pinocchio reads it and refuses a model
    whose violating link is 1 % heavier (compared with MuJoCo's mj_fullM)."""
    from roverimpact.models.mujoco_check import check_urdf

    text = ARM_URDF.replace(_inertial(.8, .004, .005, .006, o="0 0 0.1"),
                            _inertial(.8, .001, .0015, .006, .0002, o="0 0 0.1"))
    f = tmp_path / "violating.urdf"
    f.write_text(text)
    with pytest.raises(ValueError, match="A \\+ B >= C"):
        mujoco.MjModel.from_xml_path(str(f))
    mbm = load_robot(f)
    assert mbm.params["mujoco_check"] == "passed"
    import xml.etree.ElementTree as ET

    wrong = pin.Model(mbm.model)
    jid = wrong.getJointId("j2")
    Y = wrong.inertias[jid]
    wrong.inertias[jid] = pin.Inertia(Y.mass * 1.01, Y.lever, Y.inertia)
    with pytest.raises(ModelError, match="disagrees with MuJoCo"):
        check_urdf(f, ET.parse(f).getroot(), wrong, floating=False)
