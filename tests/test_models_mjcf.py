"""MJCF robots (MuJoCo's compiler, converted to Pinocchio): closed-form mass matrix, agreement with the same
robot written as URDF, a T_c^- scenario on an MJCF arm, and clean errors on bad files.

Two-link planar arm, hinges about y, links along x (link 1 from the origin to the elbow at
``l1``; centres of mass at ``c1``, ``c2`` along each link; central inertias ``I1``, ``I2``
about y). With the point velocities of the two centres of mass, the kinetic energy gives
the textbook double-pendulum mass matrix:

    M11 = I1 + m1 c1^2 + I2 + m2 (l1^2 + c2^2 + 2 l1 c2 cos q2)
    M12 = I2 + m2 (c2^2 + l1 c2 cos q2)
    M22 = I2 + m2 c2^2
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from roverimpact.exceptions import ModelError
from roverimpact.models import load_robot

m1, m2, l1, c1, c2 = 1.5, 0.7, 0.5, 0.2, 0.15
I1, I2 = 0.02, 0.005

MJCF = f"""<mujoco model="arm2">
  <compiler angle="radian"/>
  <worldbody>
    <body name="link1" pos="0 0 0">
      <joint name="j1" type="hinge" axis="0 1 0"/>
      <inertial pos="{c1} 0 0" mass="{m1}" diaginertia="0.01 {I1} 0.03"/>
      <body name="link2" pos="{l1} 0 0">
        <joint name="j2" type="hinge" axis="0 1 0"/>
        <inertial pos="{c2} 0 0" mass="{m2}" diaginertia="0.004 {I2} 0.006"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

URDF = f"""<robot name="arm2">
  <link name="world"/>
  <link name="link1">
    <inertial><origin xyz="{c1} 0 0"/><mass value="{m1}"/>
      <inertia ixx="0.01" iyy="{I1}" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="link2">
    <inertial><origin xyz="{c2} 0 0"/><mass value="{m2}"/>
      <inertia ixx="0.004" iyy="{I2}" izz="0.006" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="j1" type="continuous"><parent link="world"/><child link="link1"/>
    <origin xyz="0 0 0"/><axis xyz="0 1 0"/></joint>
  <joint name="j2" type="continuous"><parent link="link1"/><child link="link2"/>
    <origin xyz="{l1} 0 0"/><axis xyz="0 1 0"/></joint>
</robot>
"""


def _closed_form(q2):
    M11 = I1 + m1 * c1**2 + I2 + m2 * (l1**2 + c2**2 + 2 * l1 * c2 * np.cos(q2))
    M12 = I2 + m2 * (c2**2 + l1 * c2 * np.cos(q2))
    M22 = I2 + m2 * c2**2
    return np.array([[M11, M12], [M12, M22]])


def _mass(robot, q):
    import pinocchio as pin

    M = pin.crba(robot.model, robot.model.createData(), np.asarray(q, float))
    return np.triu(M) + np.triu(M, 1).T


@pytest.fixture
def files(tmp_path):
    (tmp_path / "arm.xml").write_text(MJCF)
    (tmp_path / "arm.urdf").write_text(URDF)
    return tmp_path


def test_mjcf_mass_matrix_closed_form_and_urdf(files):
    mj = load_robot(files / "arm.xml")
    ur = load_robot(files / "arm.urdf")
    assert mj.model.nv == ur.model.nv == 2
    # hinges are continuous joints in URDF (cos/sin in q): compare at joint angles
    for q1, q2 in [(0.0, 0.0), (0.3, -1.1), (-2.0, 2.5)]:
        M = _mass(mj, [q1, q2])
        np.testing.assert_allclose(M, _closed_form(q2), rtol=1e-12)
        qu = np.array([np.cos(q1), np.sin(q1), np.cos(q2), np.sin(q2)])
        np.testing.assert_allclose(_mass(ur, qu), M, rtol=1e-12)


def test_mjcf_arm_scenario_effective_mass(files):
    """Tip of link 2 moving along a normal: m_eff from the scenario equals 1/(a M^-1 a^T)
    with the tip Jacobian of the closed form (planar arm, x-z plane)."""
    from roverimpact.scenario import energy_of, scenario_from_dict

    q1, q2, l2 = 0.4, 0.9, 0.3
    sc = scenario_from_dict({
        "model": {"file": str(files / "arm.xml")},
        "configuration": {"joints": {"j1": q1, "j2": q2}},
        "velocity": {"joints": {"j1": 1.0, "j2": -0.5}},
        "contacts": {"ground_wheels": []},
        "obstacle": {"frame": "link2", "point": [l2, 0.0, 0.0], "normal": [-1.0, 0.0, 0.0]},
    })
    e = energy_of(sc)
    # rotation about +y by angle t maps x to (cos t, 0, -sin t)
    s1, s12 = q1, q1 + q2
    tip_q1 = np.array([-l1 * np.sin(s1) - l2 * np.sin(s12), -l1 * np.cos(s1) - l2 * np.cos(s12)])
    tip_q2 = np.array([-l2 * np.sin(s12), -l2 * np.cos(s12)])
    J = np.column_stack([tip_q1, tip_q2])  # rows: x, z velocity of the tip
    a = np.array([-1.0, 0.0]) @ J
    M = _closed_form(q2)
    assert float(e.m_eff_free) == pytest.approx(1.0 / (a @ np.linalg.solve(M, a)), rel=1e-10)
    v = np.array([1.0, -0.5])
    assert float(e.T) == pytest.approx(0.5 * v @ M @ v, rel=1e-12)


@pytest.mark.parametrize("text, match", [
    ("<mujoco><worldbody><body><joint type='hinge'", "cannot build|malformed|parse"),
    ("<mujoco model='x'><worldbody/></mujoco>", "no degree of freedom"),
    ("<mujoco model='x'><worldbody><body name='b'><inertial pos='0 0 0' mass='1' "
     "diaginertia='1 1 1'/></body></worldbody></mujoco>", "no degree of freedom"),
    ("not xml at all", "cannot build|malformed|parse|not"),
])
def test_bad_mjcf_files(tmp_path, text, match):
    f = tmp_path / "bad.xml"
    f.write_text(text)
    with pytest.raises(ModelError, match=match):
        load_robot(f)


def test_bad_mjcf_from_the_cli(tmp_path, capsys):
    from roverimpact.cli import main

    (tmp_path / "bad.xml").write_text("<mujoco><worldbody><body><joint")
    (tmp_path / "s.toml").write_text(
        '[model]\nfile = "bad.xml"\n[obstacle]\nframe = "link1"\nnormal = [1.0, 0.0, 0.0]\n')
    assert main(["energy", str(tmp_path / "s.toml")]) == 2
    err = capsys.readouterr().err
    assert "bad.xml" in err and "Traceback" not in err


def test_mass_matrix_agrees_with_mujoco(files):
    """Second engine: MuJoCo's M(q) (mj_fullM) equals Pinocchio's for the same MJCF file."""
    mujoco = pytest.importorskip("mujoco")
    mj_model = mujoco.MjModel.from_xml_path(str(files / "arm.xml"))
    mj_data = mujoco.MjData(mj_model)
    robot = load_robot(files / "arm.xml")
    rng = np.random.default_rng(11)
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, 2)
        mj_data.qpos[:] = q
        mujoco.mj_forward(mj_model, mj_data)
        M_mj = np.zeros((2, 2))
        if hasattr(mj_data, "qM"):  # MuJoCo 3: mj_fullM(m, dst, qM)
            mujoco.mj_fullM(mj_model, M_mj, mj_data.qM)
        else:  # MuJoCo 4: mj_fullM(m, d, dst)
            mujoco.mj_fullM(mj_model, mj_data, M_mj)
        np.testing.assert_allclose(_mass(robot, q), M_mj, rtol=1e-10, atol=1e-14)


def _mj_full_M(mujoco, m, d):
    M = np.zeros((m.nv, m.nv))
    if hasattr(d, "qM"):
        mujoco.mj_fullM(m, M, d.qM)
    else:
        mujoco.mj_fullM(m, d, M)
    return M


@pytest.mark.parametrize("builder", ["rocker_bogie", "rover2d"])
def test_exported_rover_urdf_in_mujoco_same_mass_matrix(tmp_path, builder):
    """Second engine on the built-in rovers: their URDF export compiled by MuJoCo (fixed
    base, MuJoCo's own URDF importer and CRBA) gives Pinocchio's joint-space M at random q.
    (The planar rover's massless x/z slider links, which MuJoCo's compiler refuses, get
    the file's <mujoco><compiler boundmass boundinertia/>.)"""
    import pinocchio as pin

    from roverimpact.models import export_urdf, rocker_bogie, rover2d

    mujoco = pytest.importorskip("mujoco")
    mbm = {"rocker_bogie": rocker_bogie, "rover2d": rover2d}[builder]()
    f = export_urdf(mbm, tmp_path / "rover.urdf")
    robot = load_robot(f, floating_base=False)
    m = mujoco.MjModel.from_xml_path(str(f))
    d = mujoco.MjData(m)
    names = [m.joint(i).name for i in range(m.njnt)]
    joints = [robot.model.joints[robot.model.getJointId(nm)] for nm in names]
    assert m.nv == robot.model.nv == len(names)
    rng = np.random.default_rng(5)
    for _ in range(3):
        q = rng.uniform(-0.6, 0.6, m.nq)
        qp = pin.neutral(robot.model)
        for i, j in enumerate(joints):
            a = q[m.jnt_qposadr[i]]
            qp[j.idx_q:j.idx_q + j.nq] = [a] if j.nq == 1 else [np.cos(a), np.sin(a)]
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        perm = [j.idx_v for j in joints]
        M = _mass(robot, qp)[np.ix_(perm, perm)]
        np.testing.assert_allclose(M, _mj_full_M(mujoco, m, d), rtol=1e-10,
                                   atol=1e-12 * np.abs(M).max())


def test_mjcf_rover_through_export_urdf_keeps_its_wheel_frames_and_M(tmp_path):
    """The MJCF rover of examples/mjcf_rover_beta.toml (its front wheel is the cylinder
    geom 'front_tire', a frame URDF has no element for) written by export_urdf loads back
    ("wheel 'front' names unknown frame 'front_tire'" before): the geom frame is a link on
    a fixed joint. References from MuJoCo's model of the original MJCF file: the wheel
    frames where MuJoCo puts the geom and the body, M(q) = mj_fullM, at random q."""
    import pinocchio as pin

    import roverimpact as ri
    from roverimpact.models import export_urdf

    mujoco = pytest.importorskip("mujoco")
    examples = Path(__file__).resolve().parents[1] / "examples"
    setup = ri.ImpactSetup.from_scenario(ri.load_scenario(examples / "mjcf_rover_beta.toml"))
    back = load_robot(export_urdf(setup.model, tmp_path / "rover.urdf"))
    assert back.params["mujoco_check"] == "passed"
    assert [(w.name, w.frame) for w in back.wheels] == [("front", "front_tire"),
                                                         ("rear", "rear_wheel")]
    model, data = back.model, back.model.createData()
    m = mujoco.MjModel.from_xml_path(str(examples / "mjcf_rover.xml"))
    d = mujoco.MjData(m)
    names = [m.joint(i).name for i in range(m.njnt)]
    joints = [model.joints[model.getJointId(nm)] for nm in names]
    assert m.nv == model.nv == len(names)
    dofs = [j.idx_v for j in joints]
    rng = np.random.default_rng(2)
    for _ in range(3):
        q = pin.neutral(model)
        d.qpos[:] = rng.uniform(-0.6, 0.6, m.nq)
        for i, j in enumerate(joints):
            q[j.idx_q] = d.qpos[m.jnt_qposadr[i]]
        mujoco.mj_forward(m, d)
        M = _mass(back, q)[np.ix_(dofs, dofs)]
        M_mj = _mj_full_M(mujoco, m, d)[np.ix_(m.jnt_dofadr, m.jnt_dofadr)]
        np.testing.assert_allclose(M, M_mj, rtol=1e-10, atol=1e-12 * np.abs(M_mj).max())
        pin.framesForwardKinematics(model, data, q)
        for frame, pos, mat in (("front_tire", d.geom("front_tire").xpos,
                                 d.geom("front_tire").xmat),
                                ("rear_wheel", d.body("rear_wheel").xpos,
                                 d.body("rear_wheel").xmat)):
            oMf = data.oMf[model.getFrameId(frame)]
            np.testing.assert_allclose(oMf.translation, pos, atol=1e-12)
            np.testing.assert_allclose(oMf.rotation, mat.reshape(3, 3), atol=1e-12)


@pytest.mark.parametrize("robot", ["ur5", "panda"])
def test_example_robot_through_export_urdf_keeps_limits_mass_and_M(tmp_path, robot):
    """An example-robot-data arm written by export_urdf and loaded back: each joint's
    position, velocity and effort limits as in the original file (UR5: +-2 pi had become
    +-1000, velocity and effort 1e6), the total mass of the file's links (the UR5's 4 kg
    base link fixed to the world was dropped), the Panda's finger (a prismatic joint along
    -y, refused before) with its <mimic>, and M(q) of plain Pinocchio on the original
    file, at random q."""
    import xml.etree.ElementTree as ET

    import pinocchio as pin

    from roverimpact.models import export_urdf
    from roverimpact.models.robot_data import example_robot_file

    src = example_robot_file(f"erd:{robot}")
    back = load_robot(export_urdf(load_robot(f"erd:{robot}"), tmp_path / f"{robot}.urdf"))
    model = back.model
    root = ET.parse(src).getroot()
    checked = 0
    for el in root.iter("joint"):
        if el.get("type") not in ("revolute", "prismatic"):
            continue
        lim = el.find("limit")
        jm = model.joints[model.getJointId(el.get("name"))]
        assert model.lowerPositionLimit[jm.idx_q] == float(lim.get("lower"))
        assert model.upperPositionLimit[jm.idx_q] == float(lim.get("upper"))
        assert model.velocityLimit[jm.idx_v] == float(lim.get("velocity"))
        assert model.effortLimit[jm.idx_v] == float(lim.get("effort"))
        checked += 1
    assert checked == model.nv
    total = sum(float(el.get("value")) for el in root.iter("mass"))
    assert sum(model.inertias[j].mass for j in range(model.njoints)) == pytest.approx(
        total, rel=1e-12)
    if robot == "panda":
        assert back.loop_names == ["mimic:panda_finger_joint2"]
        jm = model.joints[model.getJointId("panda_finger_joint2")]
        assert jm.shortname() == "JointModelPrismaticUnaligned"
        np.testing.assert_array_equal(jm.extract().axis, [0.0, -1.0, 0.0])
    ref = pin.buildModelFromUrdf(str(src))
    assert list(ref.names) == list(model.names)
    rng = np.random.default_rng(4)
    for _ in range(3):
        q = rng.uniform(ref.lowerPositionLimit, ref.upperPositionLimit)
        M_ref = pin.crba(ref, ref.createData(), q)
        M_ref = np.triu(M_ref) + np.triu(M_ref, 1).T
        np.testing.assert_allclose(_mass(back, q), M_ref, rtol=1e-12,
                                   atol=1e-14 * np.abs(M_ref).max())


def test_mjcf_suffix_and_includes_with_roverimpact_elements(tmp_path):
    """A file named ``.mjcf`` (the docs list ``.xml`` or ``.mjcf``; MuJoCo's MjSpec file
    reader refused it, "could not find decoder") loads as its ``.xml`` copy; an
    ``<include>`` next to ``<roverimpact_*>`` elements is found (the text was compiled
    without its directory). M against MuJoCo's own mj_fullM of the same files."""
    import shutil
    from pathlib import Path

    mujoco = pytest.importorskip("mujoco")
    from roverimpact.models.mujoco_check import full_mass_matrix

    src = Path(__file__).resolve().parents[1] / "examples" / "mjcf_rover.xml"
    dst = tmp_path / "rover.mjcf"
    shutil.copy(src, dst)
    a, b = load_robot(src), load_robot(dst)
    assert b.params["mujoco_check"] == "passed"
    q = np.array(a.params["q_nominal"])
    import pinocchio as pin

    np.testing.assert_array_equal(pin.crba(a.model, a.model.createData(), q),
                                  pin.crba(b.model, b.model.createData(), q))
    sub = tmp_path / "sub"
    sub.mkdir()
    (sub / "arm.xml").write_text(
        '<mujoco><body name="link" pos="0 0 1"><joint name="j" type="hinge" axis="1 0 0"/>'
        '<geom type="box" size="0.1 0.2 0.3" pos="0 0.2 0" mass="2"/></body></mujoco>')
    (tmp_path / "part.xml").write_text(
        '<mujoco><worldbody><include file="sub/arm.xml"/></worldbody></mujoco>')
    main = tmp_path / "main.xml"
    main.write_text('<mujoco model="m"><include file="part.xml"/>'
                    '<roverimpact_wheel name="w" frame="link" radius="0.1"/></mujoco>')
    mbm = load_robot(main)
    assert mbm.model.nv == 1 and [w.name for w in mbm.wheels] == ["w"]
    mj = mujoco.MjModel.from_xml_path(str(tmp_path / "part.xml"))
    d = mujoco.MjData(mj)
    mujoco.mj_forward(mj, d)
    M = pin.crba(mbm.model, mbm.model.createData(), np.zeros(1))
    np.testing.assert_allclose(M, full_mass_matrix(mujoco, mj, d), rtol=1e-12)


#: Two links on continuous joints, the first about a tilted axis (Pinocchio builds a
#: RevoluteUnboundedUnaligned joint, whose Python object has no .axis), the second about y.
CONTINUOUS_URDF = """<?xml version="1.0"?>
<robot name="spinner">
  <link name="base"/>
  <link name="a"><inertial><origin xyz="0.1 0 0"/><mass value="1.5"/>
    <inertia ixx="0.01" iyy="0.02" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="b"><inertial><origin xyz="0 0 0.2"/><mass value="0.7"/>
    <inertia ixx="0.004" iyy="0.005" izz="0.006" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="ja" type="continuous"><parent link="base"/><child link="a"/>
    <axis xyz="0 0.6 0.8"/></joint>
  <joint name="jb" type="continuous"><parent link="a"/><child link="b"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 1 0"/></joint>
</robot>
"""


def test_continuous_joints_through_export_urdf(tmp_path):
    """Continuous joints, one about a tilted axis, written by export_urdf (which read
    that axis from a Python attribute Pinocchio does not have: AttributeError) and loaded
    back: type continuous with the original axes, and M(q) of plain Pinocchio on the
    original file at random (cos, sin) configurations."""
    import xml.etree.ElementTree as ET

    import pinocchio as pin

    from roverimpact.models import export_urdf

    src = tmp_path / "spinner.urdf"
    src.write_text(CONTINUOUS_URDF)
    out = export_urdf(load_robot(src), tmp_path / "out.urdf")
    joints = {el.get("name"): el for el in ET.parse(out).getroot().iter("joint")}
    for name, axis in (("ja", [0.0, 0.6, 0.8]), ("jb", [0.0, 1.0, 0.0])):
        assert joints[name].get("type") == "continuous"
        np.testing.assert_allclose([float(x) for x in joints[name].find("axis")
                                    .get("xyz").split()], axis, atol=1e-15)
    back = load_robot(out)
    ref = pin.buildModelFromUrdf(str(src))
    rng = np.random.default_rng(2)
    for _ in range(3):
        a, b = rng.uniform(-np.pi, np.pi, 2)
        q = np.array([np.cos(a), np.sin(a), np.cos(b), np.sin(b)])
        M_ref = pin.crba(ref, ref.createData(), q)
        M_ref = np.triu(M_ref) + np.triu(M_ref, 1).T
        np.testing.assert_allclose(_mass(back, q), M_ref, rtol=1e-12,
                                   atol=1e-14 * np.abs(M_ref).max())
