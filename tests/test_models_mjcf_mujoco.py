"""MJCF and URDF files mean what their format means: MuJoCo as the second engine.

Reference: MuJoCo itself (``mujoco`` package), an independent implementation of the
MJCF compiler, of URDF import, of forward kinematics and of the CRBA. For MJCF files,
roverimpact takes MuJoCo's *compiled inertias* (so mass and inertia agreement is by
construction and only the total mass test guards against losing a body); what is checked
independently there is the conversion (placements, joint anchors and axes, refs, chains
of joints in one body, free/ball coordinates), through M(q), T, body poses and body
velocities. For URDF files, MuJoCo's importer reads the inertias itself, so M(q) is an
independent check of the inertias too.

Files are written the way their users write them:

* ``rover.xml`` -- planar rover as MuJoCo users model it: one chassis body with slide x,
  slide z and hinge pitch, the 20 kg chassis mass on a visual geom (contype = conaffinity
  = 0), cylinder wheels from a ``childclass``, one wheel with an explicit ``<inertial>``,
  a welded payload, a site; ``angle="degree"``.
* ``lander.xml`` -- free-floating body (``<freejoint/>``) with a ball-jointed boom, an
  unaligned hinge with an anchor offset, ``ref`` and armature, a slide with ``ref``, a
  mesh geom given by its vertices, capsule and ellipsoid geoms, a joint equality.
* ``rover.urdf`` -- four continuous wheel joints, rotated origins, inertial frames with
  rpy and products of inertia, visual/collision meshes that do not exist on disk, a link
  without ``<inertial>`` and a battery with one, both on fixed joints.
* ``gripper.urdf`` -- a prismatic finger mimicking another (multiplier -1), a fingertip
  on a fixed joint, and a continuous joint mimicking a revolute one with an offset.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import roverimpact as ri
from roverimpact.exceptions import ModelError
from roverimpact.models import load_robot
from roverimpact.models.mjcf import mujoco_state_to_pinocchio, pinocchio_state_to_mujoco
from tests.reference.rovers import FREE_ROOT_ARM_MJCF

mujoco = pytest.importorskip("mujoco")

ROVER_MJCF = """<mujoco model="planar_rover">
  <compiler angle="degree"/>
  <option gravity="0 0 -3.71"/>
  <default>
    <default class="visual">
      <geom contype="0" conaffinity="0" group="1" rgba="0.8 0.8 0.8 1"/>
    </default>
    <default class="wheel">
      <joint type="hinge" axis="0 1 0" damping="0.01"/>
      <geom type="cylinder" size="0.15 0.05" euler="90 0 0" density="800" friction="1 0.005 0.0001"/>
    </default>
  </default>
  <worldbody>
    <geom name="floor" type="plane" size="10 10 0.1"/>
    <body name="chassis" pos="0 0 0.35">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="z" type="slide" axis="0 0 1"/>
      <joint name="pitch" type="hinge" axis="0 1 0"/>
      <geom name="chassis_box" class="visual" type="box" size="0.35 0.2 0.075" mass="20"/>
      <geom name="bumper" type="capsule" fromto="0.36 -0.15 0 0.36 0.15 0" size="0.02" mass="0.3"/>
      <site name="imu" pos="0.1 0 0.08"/>
      <body name="payload" pos="-0.1 0 0.1" euler="0 15 0">
        <geom type="box" size="0.1 0.08 0.05" mass="3"/>
      </body>
      <body name="front_wheel" pos="0.3 0 -0.2" childclass="wheel">
        <joint name="wheel_front"/>
        <geom name="front_tire"/>
      </body>
      <body name="rear_wheel" pos="-0.3 0 -0.2" childclass="wheel">
        <joint name="wheel_rear"/>
        <geom name="rear_tire" contype="0" conaffinity="0"/>
        <inertial pos="0 0.01 0" mass="2" diaginertia="0.012 0.0225 0.012"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

LANDER_MJCF = """<mujoco model="lander">
  <compiler angle="radian" inertiafromgeom="true"/>
  <asset>
    <mesh name="tet" vertex="0 0 0  0.3 0 0  0 0.2 0  0 0 0.25  0.2 0.2 0.2"/>
  </asset>
  <default>
    <geom density="500"/>
  </default>
  <worldbody>
    <body name="hull" pos="0.2 -0.1 1.5" quat="0.9 0.1 0.3 0.2">
      <freejoint name="hull_free"/>
      <geom name="hull_box" type="box" size="0.4 0.3 0.2" pos="0.05 0 0" euler="0.1 0.2 0"/>
      <geom name="tank" type="ellipsoid" size="0.1 0.15 0.2" pos="-0.2 0.1 0.1"/>
      <geom name="antenna_base" type="mesh" mesh="tet" pos="0 0 0.2"/>
      <site name="dock" pos="0.4 0 0" euler="0 1.5708 0"/>
      <body name="boom" pos="0.4 0.2 0">
        <joint name="shoulder" type="ball" pos="0 0 0" armature="0.01"/>
        <geom name="boom_rod" type="capsule" fromto="0 0 0 0.5 0 0.1" size="0.03"/>
        <body name="hand" pos="0.5 0 0.1" euler="0.3 -0.2 0.5">
          <joint name="wrist" type="hinge" axis="1 1 0" pos="0.02 0.01 -0.03" ref="0.4" armature="0.002"/>
          <joint name="extend" type="slide" axis="0 0.6 0.8" ref="0.05"/>
          <geom name="hand_box" type="box" size="0.05 0.04 0.03" pos="0.05 0 0"/>
        </body>
      </body>
      <body name="leg" pos="-0.3 -0.2 -0.2">
        <joint name="leg_hinge" type="hinge" axis="0 -1 0" ref="0.2"/>
        <geom name="leg_rod" type="cylinder" fromto="0 0 0 -0.1 0 -0.4" size="0.025"/>
        <body name="foot" pos="-0.1 0 -0.4">
          <joint name="foot_hinge" type="hinge" axis="0 1 0"/>
          <geom name="pad" type="sphere" size="0.06"/>
        </body>
      </body>
    </body>
  </worldbody>
  <equality>
    <joint name="foot_follows_leg" joint1="foot_hinge" joint2="leg_hinge" polycoef="0.1 -0.5 0 0 0"/>
  </equality>
</mujoco>
"""


def _wheel_link(name):
    return f"""  <link name="{name}">
    <inertial><origin xyz="0 0.005 0" rpy="1.5708 0 0"/><mass value="1.8"/>
      <inertia ixx="0.011" iyy="0.011" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="package://rover_description/meshes/wheel.dae"/></geometry></visual>
    <collision><geometry><cylinder radius="0.15" length="0.1"/></geometry></collision>
  </link>
"""


def _wheel_joint(name, xyz, rpy="0 0 0"):
    return f"""  <joint name="{name}_joint" type="continuous">
    <parent link="base_link"/><child link="{name}"/>
    <origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="0 1 0"/>
  </joint>
"""


ROVER_URDF = f"""<?xml version="1.0"?>
<robot name="urdf_rover">
  <link name="base_link">
    <inertial><origin xyz="0.02 0 0.05" rpy="0.1 -0.05 0.2"/><mass value="21"/>
      <inertia ixx="0.45" iyy="0.9" izz="1.1" ixy="0.01" ixz="-0.03" iyz="0.02"/></inertial>
    <visual><geometry><mesh filename="package://rover_description/meshes/chassis.stl"/></geometry></visual>
    <collision><geometry><box size="0.7 0.4 0.15"/></geometry></collision>
  </link>
  <link name="camera_link"/>
  <joint name="camera_mount" type="fixed">
    <parent link="base_link"/><child link="camera_link"/><origin xyz="0.3 0 0.2"/>
  </joint>
  <link name="battery">
    <inertial><origin xyz="0.01 0.02 -0.03" rpy="0 0.3 0"/><mass value="4.5"/>
      <inertia ixx="0.02" iyy="0.03" izz="0.04" ixy="0.001" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="battery_mount" type="fixed">
    <parent link="base_link"/><child link="battery"/><origin xyz="-0.15 0 0.02" rpy="0 0 0.1"/>
  </joint>
{_wheel_link("wheel_fl")}{_wheel_link("wheel_fr")}{_wheel_link("wheel_rl")}{_wheel_link("wheel_rr")}
{_wheel_joint("wheel_fl", "0.3 0.25 -0.15", "0 0 0.05")}{_wheel_joint("wheel_fr", "0.3 -0.25 -0.15")}
{_wheel_joint("wheel_rl", "-0.3 0.25 -0.15", "0.02 0 0")}{_wheel_joint("wheel_rr", "-0.3 -0.25 -0.15")}
</robot>
"""

GRIPPER_URDF = """<?xml version="1.0"?>
<robot name="gripper">
  <link name="world"/>
  <link name="arm">
    <inertial><origin xyz="0.2 0 0"/><mass value="2"/>
      <inertia ixx="0.004" iyy="0.03" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="palm">
    <inertial><origin xyz="0.03 0 0"/><mass value="0.5"/>
      <inertia ixx="0.001" iyy="0.0008" izz="0.0009" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="finger_left">
    <inertial><origin xyz="0.04 0 0"/><mass value="0.1"/>
      <inertia ixx="1e-5" iyy="4e-5" izz="4e-5" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="finger_right">
    <inertial><origin xyz="0.04 0 0"/><mass value="0.12"/>
      <inertia ixx="1e-5" iyy="4e-5" izz="4e-5" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="fingertip">
    <inertial><origin xyz="0.005 0 0"/><mass value="0.03"/>
      <inertia ixx="2e-6" iyy="3e-6" izz="3e-6" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="fingertip_mount" type="fixed">
    <parent link="finger_left"/><child link="fingertip"/><origin xyz="0.08 0 0"/>
  </joint>
  <link name="roller">
    <inertial><mass value="0.2"/>
      <inertia ixx="2e-4" iyy="1e-4" izz="2e-4" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="world"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="2"/>
  </joint>
  <joint name="wrist" type="revolute">
    <parent link="arm"/><child link="palm"/><origin xyz="0.4 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="10" velocity="2"/>
  </joint>
  <joint name="finger_left_joint" type="prismatic">
    <parent link="palm"/><child link="finger_left"/><origin xyz="0.06 0.02 0"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.04" effort="10" velocity="0.1"/>
  </joint>
  <joint name="finger_right_joint" type="prismatic">
    <parent link="palm"/><child link="finger_right"/><origin xyz="0.06 -0.02 0"/><axis xyz="0 1 0"/>
    <limit lower="-0.04" upper="0" effort="10" velocity="0.1"/>
    <mimic joint="finger_left_joint" multiplier="-1" offset="0"/>
  </joint>
  <joint name="roller_joint" type="continuous">
    <parent link="palm"/><child link="roller"/><origin xyz="0.02 0 0.03"/><axis xyz="1 0 0"/>
    <mimic joint="wrist" multiplier="2" offset="0.3"/>
  </joint>
</robot>
"""

FILES = {"rover.xml": ROVER_MJCF, "lander.xml": LANDER_MJCF, "rover.urdf": ROVER_URDF,
         "gripper.urdf": GRIPPER_URDF}
# (file, floating_base) -> how MuJoCo compiles the same file for comparison
CASES = [("rover.xml", None), ("lander.xml", None), ("rover.urdf", False),
         ("rover.urdf", True), ("gripper.urdf", None)]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("models")
    for name, text in FILES.items():
        (d / name).write_text(text)
    return d


def _mj_model(path, floating):
    """MuJoCo's own model of the file: MJCF as is; URDF through MuJoCo's importer with
    URDF's meaning (no mass from geometry, geometry dropped: meshes are not on disk;
    static links not fused into the world, so that their mass counts)."""
    if path.suffix == ".xml":
        return mujoco.MjModel.from_xml_path(str(path))
    import xml.etree.ElementTree as ET

    root = ET.parse(path).getroot()
    for link in root.iter("link"):
        for el in list(link):
            if el.tag in ("visual", "collision"):
                link.remove(el)
    spec = mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode"))
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compiler.fusestatic = False  # keep a fixed base's mass in mj_getTotalmass
    if floating:
        spec.body("base_link").add_freejoint(name="root_joint")
    return spec.compile()


def _mj_M(m, d):
    M = np.zeros((m.nv, m.nv))
    try:
        mujoco.mj_fullM(m, d, M)
    except TypeError:  # MuJoCo < 3.3
        mujoco.mj_fullM(m, M, d.qM)
    return M


def _random_qpos(m, rng):
    qpos = np.array(m.qpos0)
    for k in range(m.njnt):
        a, t = m.jnt_qposadr[k], m.jnt_type[k]
        if t in (2, 3):
            qpos[a] += rng.uniform(-np.pi, np.pi) if t == 3 else rng.uniform(-0.3, 0.3)
        elif t == 1:
            u = rng.standard_normal(4)
            qpos[a:a + 4] = u / np.linalg.norm(u)
        else:
            qpos[a:a + 3] = rng.uniform(-1, 1, 3)
            u = rng.standard_normal(4)
            qpos[a + 3:a + 7] = u / np.linalg.norm(u)
    return qpos


def _rel(A, B):
    """max |A_ij - B_ij| / sqrt(B_ii B_jj)."""
    d = np.sqrt(np.diag(B))
    return float(np.max(np.abs(A - B) / np.outer(d, d)))


def _pin_M(model, q):
    M = pin.crba(model, model.createData(), q)
    return np.triu(M) + np.triu(M, 1).T


def _velocity_matrix(mbm, q, nv_mj):
    """T with v = T qvel, column by column through the public conversion."""
    qpos, _ = pinocchio_state_to_mujoco(mbm, q)
    return np.column_stack([mujoco_state_to_pinocchio(mbm, qpos, e)[1]
                            for e in np.eye(nv_mj)])


# ------------------------------------------------------------------------ mass, M, T


@pytest.mark.parametrize("name, floating", CASES)
def test_total_mass_equals_mujoco(files, name, floating):
    path = files / name
    mbm = load_robot(path, floating_base=floating)
    m = _mj_model(path, floating)
    total = sum(Y.mass for Y in mbm.model.inertias)  # universe included: welded bodies
    assert total == pytest.approx(mujoco.mj_getTotalmass(m), rel=1e-12)


def test_rover_keeps_the_chassis_mass_on_a_non_colliding_geom(files):
    """The issue's rover: 20 kg chassis box + 0.3 kg bumper + 3 kg payload + wheels
    (cylinder r = 0.15, half-length 0.05, density 800; the rear one explicit 2 kg)."""
    mbm = load_robot(files / "rover.xml")
    wheel = 800 * np.pi * 0.15**2 * 0.1
    assert sum(Y.mass for Y in mbm.model.inertias) == pytest.approx(23.3 + wheel + 2.0,
                                                                    rel=1e-12)
    assert mbm.params["mujoco_check"] == "passed"


@pytest.mark.parametrize("name, floating", CASES)
def test_mass_matrix_and_kinetic_energy_equal_mujoco_at_random_states(files, name, floating):
    """M(q) (Pinocchio CRBA, mapped to MuJoCo's velocity coordinates) = mj_fullM, and
    T = 1/2 v^T M v = 1/2 qvel^T M_mj qvel = mj_energyVel, 1e-9 relative. T also by
    Pinocchio's body-by-body sum (pin.computeKineticEnergy) on a copy without rotor
    inertia, plus 1/2 sum a_i v_i^2 (armature a; pin 4.1's computeKineticEnergy leaves it
    out for RevoluteUnaligned joints while its CRBA counts it)."""
    path = files / name
    mbm = load_robot(path, floating_base=floating)
    model = mbm.model
    bare = pin.Model(model)
    bare.armature[:] = 0.0
    data = bare.createData()
    m = _mj_model(path, floating)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(7)
    for _ in range(6):
        qpos, qvel = _random_qpos(m, rng), rng.standard_normal(m.nv)
        d.qpos[:], d.qvel[:] = qpos, qvel
        mujoco.mj_forward(m, d)
        mujoco.mj_energyVel(m, d)
        M_mj = _mj_M(m, d)
        q, v = mujoco_state_to_pinocchio(mbm, qpos, qvel)
        T = _velocity_matrix(mbm, q, m.nv)
        M = _pin_M(model, q)
        assert _rel(T.T @ M @ T, M_mj) < 1e-9
        T_pin = 0.5 * v @ M @ v
        assert T_pin == pytest.approx(0.5 * qvel @ M_mj @ qvel, rel=1e-9)
        assert T_pin == pytest.approx(d.energy[1], rel=1e-9)
        T_bodies = pin.computeKineticEnergy(bare, data, q, v)
        assert T_bodies + 0.5 * model.armature @ v**2 == pytest.approx(T_pin, rel=1e-9)


@pytest.mark.parametrize("name", ["rover.xml", "lander.xml"])
def test_body_site_and_geom_frames_follow_mujoco(files, name):
    """Every body, site and named geom frame at MuJoCo's pose (xpos/xmat, site_xpos,
    geom_xpos) and every body moving with MuJoCo's velocity (mj_objectVelocity, world
    axes) at random states."""
    path = files / name
    mbm = load_robot(path)
    model, data = mbm.model, mbm.model.createData()
    m = _mj_model(path, None)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(3)
    obj = mujoco.mjtObj
    for _ in range(4):
        qpos, qvel = _random_qpos(m, rng), rng.standard_normal(m.nv)
        d.qpos[:], d.qvel[:] = qpos, qvel
        mujoco.mj_forward(m, d)
        q, v = mujoco_state_to_pinocchio(mbm, qpos, qvel)
        pin.forwardKinematics(model, data, q, v)
        pin.updateFramePlacements(model, data)
        for b in range(1, m.nbody):
            fid = model.getFrameId(mujoco.mj_id2name(m, obj.mjOBJ_BODY, b),
                                   pin.FrameType.BODY)
            np.testing.assert_allclose(data.oMf[fid].translation, d.xpos[b], atol=1e-12)
            np.testing.assert_allclose(data.oMf[fid].rotation, d.xmat[b].reshape(3, 3),
                                       atol=1e-12)
            res = np.zeros(6)
            mujoco.mj_objectVelocity(m, d, obj.mjOBJ_XBODY, b, res, 0)  # at xpos
            vel = pin.getFrameVelocity(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            np.testing.assert_allclose(vel.angular, res[:3], atol=1e-11)
            np.testing.assert_allclose(vel.linear, res[3:], atol=1e-11)
        for g in range(m.ngeom):
            gname = mujoco.mj_id2name(m, obj.mjOBJ_GEOM, g)
            if gname:
                fid = model.getFrameId(gname)
                np.testing.assert_allclose(data.oMf[fid].translation, d.geom_xpos[g],
                                           atol=1e-12)
                np.testing.assert_allclose(data.oMf[fid].rotation,
                                           d.geom_xmat[g].reshape(3, 3), atol=1e-12)
        for s in range(m.nsite):
            fid = model.getFrameId(mujoco.mj_id2name(m, obj.mjOBJ_SITE, s))
            np.testing.assert_allclose(data.oMf[fid].translation, d.site_xpos[s], atol=1e-12)


# ------------------------------------------------------------------------ joints, states


def test_rover_joints_keep_their_names_and_can_be_set(files):
    """Three joints of one MuJoCo body stay three named Pinocchio joints (a chain, the
    chassis inertia on 'pitch'); each can be set alone, and MuJoCo agrees on the pose."""
    from roverimpact.models.joints import joint_value, set_joint_value

    mbm = load_robot(files / "rover.xml")
    model = mbm.model
    assert list(model.names[1:]) == ["x", "z", "pitch", "wheel_front", "wheel_rear"]
    assert [model.joints[j].shortname() for j in range(1, 4)] == [
        "JointModelPX", "JointModelPZ", "JointModelRY"]
    assert model.inertias[1].mass == model.inertias[2].mass == 0.0
    q = np.array(mbm.params["q_nominal"])
    for name, val in [("x", 0.4), ("z", -0.05), ("pitch", 0.2), ("wheel_front", 2.0)]:
        q = set_joint_value(mbm, q, name, val)
        assert joint_value(mbm, q, name) == val
    m = _mj_model(files / "rover.xml", None)
    d = mujoco.MjData(m)
    d.qpos[:] = [0.4, -0.05, 0.2, 2.0, 0.0]  # MuJoCo's qpos, by its joint order
    mujoco.mj_kinematics(m, d)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    np.testing.assert_allclose(data.oMf[model.getFrameId("front_wheel")].translation,
                               d.body("front_wheel").xpos, atol=1e-14)


@pytest.mark.parametrize("name, floating", CASES)
def test_state_conversions_both_ways(files, name, floating):
    """qpos/qvel -> q/v -> qpos/qvel is the identity (unit quaternions, hinge angles in
    (-pi, pi] for URDF continuous joints), and q/v -> qpos/qvel -> q/v too; batched."""
    path = files / name
    mbm = load_robot(path, floating_base=floating)
    m = _mj_model(path, floating)
    rng = np.random.default_rng(1)
    qpos = np.array([_random_qpos(m, rng) for _ in range(5)])
    qvel = rng.standard_normal((5, m.nv))
    q, v = mujoco_state_to_pinocchio(mbm, qpos, qvel)
    assert q.shape == (5, mbm.model.nq) and v.shape == (5, mbm.model.nv)
    qpos2, qvel2 = pinocchio_state_to_mujoco(mbm, q, v)
    np.testing.assert_allclose(qpos2, qpos, atol=1e-14)
    np.testing.assert_allclose(qvel2, qvel, atol=1e-14)
    q3, v3 = mujoco_state_to_pinocchio(mbm, qpos2, qvel2)
    np.testing.assert_allclose(q3, q, atol=1e-14)
    np.testing.assert_allclose(v3, v, atol=1e-14)
    q0, _ = mujoco_state_to_pinocchio(mbm, m.qpos0)
    if "mimic" not in mbm.params:  # qpos0 is the reference configuration
        q_ref = mbm.params.get("q_nominal", pin.neutral(mbm.model))
        np.testing.assert_allclose(q0, q_ref, atol=1e-14)


def test_free_joint_conversion_is_the_body_twist(files):
    """Free joint: Pinocchio's v[:3] is the body-frame velocity of the body origin,
    R^T times MuJoCo's world-frame qvel[:3]; quaternion w x y z -> x y z w."""
    mbm = load_robot(files / "lander.xml")
    th = 0.7
    quat = np.array([np.cos(th / 2), 0.0, 0.0, np.sin(th / 2)])  # th about z
    qpos = np.array(mbm.params["mujoco"]["qpos0"])
    qpos[3:7] = quat
    qvel = np.zeros(len(mbm.params["mujoco"]["qpos0"]) - 1 - 1)  # nq - 1 (free) - 1 (ball)
    qvel[:3] = [1.0, 0.0, 0.0]
    q, v = mujoco_state_to_pinocchio(mbm, qpos, qvel)
    np.testing.assert_allclose(q[3:7], [0.0, 0.0, np.sin(th / 2), np.cos(th / 2)])
    np.testing.assert_allclose(v[:3], [np.cos(th), -np.sin(th), 0.0], atol=1e-15)


def test_mjcf_joint_equality_becomes_a_coupling_row(files):
    """foot_hinge - 0 = 0.1 - 0.5 (leg_hinge - 0.2): one row 'mimic:foot_hinge' with
    J = e_foot + 0.5 e_leg, phi = 0 at the nominal configuration."""
    mbm = load_robot(files / "lander.xml")
    assert mbm.params["mimic"] == [["foot_hinge", "leg_hinge", -0.5, pytest.approx(0.2)]]
    assert mbm.loop_names == ["mimic:foot_hinge"]
    q0 = np.array(mbm.params["q_nominal"])
    phi, J = mbm.loop_closure(q0)
    assert abs(phi[0]) < 1e-15
    model = mbm.model
    row = np.zeros(model.nv)
    row[model.joints[model.getJointId("foot_hinge")].idx_v] = 1.0
    row[model.joints[model.getJointId("leg_hinge")].idx_v] = 0.5
    np.testing.assert_array_equal(J[0], row)


# ------------------------------------------------------------------------ the load check


def test_load_check_refuses_a_lost_chassis_mass(files, monkeypatch):
    """Build the rover the way Pinocchio's MJCF parser does (chassis geom without mass):
    the check against mj_fullM refuses and names the chassis."""
    from roverimpact.models import mjcf

    real = mjcf.pinocchio_from_mujoco

    def drop_chassis(m, **kw):
        model, info = real(m, **kw)
        jid = model.getJointId("pitch")
        # the chassis box is centred on the body origin (the pitch joint frame)
        model.inertias[jid] = _minus(model.inertias[jid],
                                     pin.Inertia.FromBox(20.0, 0.7, 0.4, 0.15))
        return model, info

    monkeypatch.setattr(mjcf, "pinocchio_from_mujoco", drop_chassis)
    with pytest.raises(ModelError, match=r"body 'chassis' \(joint 'pitch'\)"):
        load_robot(files / "rover.xml")
    model = load_robot(files / "rover.xml", mujoco_check=False).model
    assert sum(Y.mass for Y in model.inertias) == pytest.approx(mujoco.mj_getTotalmass(
        _mj_model(files / "rover.xml", None)) - 20.0)


def _minus(Y, Z):
    """Spatial inertia Y - Z (both about the same frame), via the 6x6 matrices."""
    return pin.Inertia.FromDynamicParameters(Y.toDynamicParameters() - Z.toDynamicParameters())


def test_load_check_refuses_a_wrong_urdf_inertia_naming_the_link(files, monkeypatch):
    """Pinocchio's URDF model with one wheel's inertia doubled: refused, naming the link."""
    from roverimpact.models import robot

    real = pin.buildModelFromUrdf

    def wrong(*args, **kw):
        model = real(*args, **kw)
        jid = model.getJointId("wheel_rl_joint")
        Y = model.inertias[jid]
        model.inertias[jid] = pin.Inertia(Y.mass, Y.lever, 2.0 * Y.inertia)
        return model

    monkeypatch.setattr(robot.pin, "buildModelFromUrdf", wrong)
    for floating in (False, True):
        with pytest.raises(ModelError, match=r"body 'wheel_rl' \(joint 'wheel_rl_joint'\)"):
            load_robot(files / "rover.urdf", floating_base=floating)


def test_urdf_that_mujoco_cannot_compile_loads_without_the_check(tmp_path):
    """A URDF Pinocchio accepts and MuJoCo refuses (a floating joint below the root; an
    inertia violating the triangle inequality is checked now,
    test_models_urdf_features.py): loaded, check skipped and said so."""
    inertial = ('<inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" '
                'ixz="0" iyz="0"/></inertial>')
    (tmp_path / "odd.urdf").write_text(f"""<robot name="odd">
  <link name="base"/>
  <link name="arm">{inertial}</link>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <link name="float">{inertial}</link>
  <joint name="f" type="floating"><parent link="arm"/><child link="float"/>
    <origin xyz="0.3 0 0"/></joint>
</robot>""")
    mbm = load_robot(tmp_path / "odd.urdf")
    assert mbm.params["mujoco_check"].startswith("skipped: MuJoCo cannot compile it")
    assert mbm.model.nv == 7


def test_urdf_massless_slider_links_are_checked(tmp_path, monkeypatch):
    """Massless intermediate links (x and z sliders) are refused by MuJoCo's compiler;
    the check gives both copies the same tiny inertia and still runs, and still refuses a
    wrong inertia of the same size as that patch would hide (1e-6 of the chassis)."""
    from roverimpact.models import export_urdf, rover2d

    f = export_urdf(rover2d(suspension="rocker"), tmp_path / "rover2d.urdf")
    mbm = load_robot(f)
    assert mbm.params["mujoco_check"] == "passed"
    from roverimpact.models import mujoco_check

    real = mujoco_check.compare_mass_matrices

    def heavier(model, mp, m, **kw):  # 1e-6 of the chassis mass more, 0.1 m ahead
        pm = pin.Model(model)
        jid = pm.getJointId("base_pitch")
        pm.inertias[jid] = pm.inertias[jid] + pin.Inertia(
            1e-6 * pm.inertias[jid].mass, np.array([0.1, 0.0, 0.0]), np.zeros((3, 3)))
        return real(pm, mp, m, **kw)

    monkeypatch.setattr(mujoco_check, "compare_mass_matrices", heavier)
    with pytest.raises(ModelError, match="joint 'base_pitch'"):
        load_robot(f)


@pytest.mark.parametrize("name, floating", [("rover.urdf", False), ("rover.urdf", True),
                                            ("gripper.urdf", False)])
def test_urdf_check_is_exact_with_fused_links_and_patched_inertias(files, name, floating):
    """The load check agrees to 1e-12 (not only to its 1e-8 tolerance): the tiny inertia
    MuJoCo's compiler needs on moving links is the same in both copies, also where
    fixed children with mass are fused into them (battery, fingertip)."""
    import xml.etree.ElementTree as ET

    from roverimpact.models.mujoco_check import check_urdf

    path = files / name
    model = (pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer()) if floating
             else pin.buildModelFromUrdf(str(path)))
    mp, skipped = check_urdf(path, ET.parse(path).getroot(), model, floating=floating,
                             rtol=1e-12)
    assert skipped is None and mp is not None


# ------------------------------------------------------------------------ bad files


@pytest.mark.parametrize("text, match", [
    ("<mujoco><worldbody><body><geom size='0.1' colour='red'/><joint/></body></worldbody>"
     "</mujoco>", "MuJoCo cannot compile it"),
    ("<mujoco><worldbody><body childclass='nope'><joint/><geom size='1'/></body>"
     "</worldbody></mujoco>", "MuJoCo cannot compile it.*childclass"),
    ("<mujoco><asset><mesh name='m' file='missing.stl'/></asset><worldbody><body><joint/>"
     "<geom type='mesh' mesh='m'/></body></worldbody></mujoco>", "MuJoCo cannot compile it"),
    ("<mujoco><worldbody><body><freejoint/><geom size='0.1'/><body><freejoint/>"
     "<geom size='0.1'/></body></body></worldbody></mujoco>", "free joint"),
    ("<robot name='r'><link name='a'/></robot>", "not an MJCF file"),
])
def test_malformed_mjcf_is_a_model_error(tmp_path, text, match):
    f = tmp_path / "bad.xml"
    f.write_text(text)
    with pytest.raises(ModelError, match=match):
        load_robot(f)


def test_floating_base_on_mjcf(files, tmp_path):
    """floating_base adds a free joint to the single top-level body; refused with two."""
    (tmp_path / "one.xml").write_text(
        "<mujoco><worldbody><body name='base' pos='0 0 1'><geom type='box' size='.2 .1 .1'/>"
        "<body name='arm'><joint name='j' axis='0 1 0'/><geom size='0.05' pos='0.2 0 0'/>"
        "</body></body></worldbody></mujoco>")
    mbm = load_robot(tmp_path / "one.xml", floating_base=True)
    assert list(mbm.model.names[1:]) == ["root_joint", "j"] and mbm.model.nv == 7
    assert mbm.params["q_nominal"][:3] == [0.0, 0.0, 1.0]
    with pytest.raises(ModelError, match="already has joints"):
        load_robot(files / "rover.xml", floating_base=True)
    (tmp_path / "two.xml").write_text(
        "<mujoco><worldbody><body name='a'><geom size='0.1'/></body><body name='b'>"
        "<joint/><geom size='0.1'/></body></worldbody></mujoco>")
    with pytest.raises(ModelError, match="single top-level body"):
        load_robot(tmp_path / "two.xml", floating_base=True)


def test_floating_base_false_welds_free_bodies(files, tmp_path):
    """floating_base=False on a file whose bodies have free joints: they are removed and
    the bodies stay where the file puts them. Reference: MuJoCo's mj_fullM of the same
    text with the <freejoint/> deleted by hand."""
    text = FREE_ROOT_ARM_MJCF
    (tmp_path / "free.xml").write_text(text)
    as_is = load_robot(tmp_path / "free.xml")  # default: the file's free joint
    assert as_is.model.nv == 7 and as_is.model.names[1] == "fly"
    fixed = load_robot(tmp_path / "free.xml", floating_base=False)
    assert list(fixed.model.names[1:]) == ["j"] and fixed.model.nv == 1
    m = mujoco.MjModel.from_xml_string(text.replace("<freejoint name='fly'/>", ""))
    d = mujoco.MjData(m)
    for qj in (0.0, 0.7, -1.2):
        d.qpos[:] = qj
        mujoco.mj_forward(m, d)
        M = pin.crba(fixed.model, fixed.model.createData(), np.array([qj]))
        assert M[0, 0] == pytest.approx(_mj_M(m, d)[0, 0], rel=1e-12)
    # the arm's world placement is the file's (base at (0.3, 0, 1) pitched 20 degrees)
    data = fixed.model.createData()
    pin.forwardKinematics(fixed.model, data, np.zeros(1))
    np.testing.assert_allclose(data.oMi[1].translation, d.xpos[m.body("arm").id], atol=1e-12)


def test_geoms_are_recorded_for_wheel_radii(files):
    mbm = load_robot(files / "rover.xml")
    tire = next(g for g in mbm.params["geoms"] if g["name"] == "front_tire")
    assert tire["type"] == "cylinder" and tire["body"] == "front_wheel"
    assert tire["size"][:2] == [0.15, 0.05]
    # the cylinder's z axis is the wheel's spin axis (euler 90 0 0 turns z to -y)
    model, data = mbm.model, mbm.model.createData()
    pin.framesForwardKinematics(model, data, np.array(mbm.params["q_nominal"]))
    np.testing.assert_allclose(data.oMf[model.getFrameId("front_tire")].rotation[:, 2],
                               [0, -1, 0], atol=1e-15)


def test_roverimpact_elements_in_mjcf_and_relative_mesh_paths(tmp_path):
    """<roverimpact_wheel> (which MuJoCo's schema refuses) is read by roverimpact and
    removed before compiling; a mesh in a relative meshdir still loads (mass of a 1000
    kg/m^3 tetrahedron of volume 0.3 * 0.2 * 0.25 / 6)."""
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "tet.obj").write_text(
        "v 0 0 0\nv 0.3 0 0\nv 0 0.2 0\nv 0 0 0.25\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    (tmp_path / "m.xml").write_text(
        '<mujoco model="w"><compiler meshdir="meshes"/><asset><mesh name="tet" '
        'file="tet.obj"/></asset><worldbody><body name="b"><joint name="j" axis="0 1 0"/>'
        '<geom type="mesh" mesh="tet"/></body></worldbody>'
        '<roverimpact_wheel name="w" frame="j" radius="0.1"/></mujoco>')
    mbm = load_robot(tmp_path / "m.xml")
    assert [w.name for w in mbm.wheels] == ["w"]
    assert mbm.params["total_mass"] == pytest.approx(1000 * 0.3 * 0.2 * 0.25 / 6, rel=1e-6)


def test_example_script_prints_the_figures_quoted_in_the_docs(capsys):
    """examples/mjcf_rover.py: the numbers docs/models.md quotes."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "examples" / "mjcf_rover.py"
    spec = importlib.util.spec_from_file_location("mjcf_rover_example", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    mod.main()
    out = capsys.readouterr().out
    docs = (path.parents[1] / "docs" / "models.md").read_text()
    for figure in ("24.00 kg", "14.14 kg", "7.07 kg", "1.3130 J", "0.5890 J"):
        assert figure in out
    for figure in ("24.00 kg", "14.14 kg", "7.07 kg", "1.313 J", "0.589 J"):
        assert figure in docs


def test_a_joint_named_as_its_child_link(files, tmp_path):
    """URDF's common style joint "wheel_fl" -> link "wheel_fl": Pinocchio makes a JOINT and
    a BODY frame of that name, and naming it in a scenario (wheel frame, obstacle frame,
    loops, points) ended in "Several frames match the filter" (a traceback). The name is
    the link's; the joint frame becomes "wheel_fl:joint". The rover gives the numbers of
    the same file with distinct joint names, and M equals MuJoCo's."""
    clash = ROVER_URDF.replace('_joint" type="continuous"', '" type="continuous"')
    assert clash != ROVER_URDF
    (tmp_path / "clash.urdf").write_text(clash)
    mbm = load_robot(tmp_path / "clash.urdf", floating_base=True)
    model = mbm.model
    assert model.frames[model.getFrameId("wheel_fl")].type == pin.FrameType.BODY
    assert model.existFrame("wheel_fl:joint") and model.existJointName("wheel_fl")
    wheels = ("wheel_fl", "wheel_fr", "wheel_rl", "wheel_rr")
    out = []
    for f, spin in ((files / "rover.urdf", "{}_joint"), (tmp_path / "clash.urdf", "{}")):
        sc = {"model": {"file": str(f), "base": {"kind": "floating"},
                        "wheels": {w: {"frame": w, "radius": 0.15, "spin": spin.format(w)}
                                   for w in wheels}},
              "configuration": {"base": {"z": 0.3}}, "velocity": {"u": 0.4},
              "obstacle": {"wheel": "wheel_fl", "beta_deg": 60.0}}
        e = ri.energy_of(sc)
        pt = ri.energy_of({**sc, "obstacle": {"frame": "wheel_rl", "point": [0.0, 0.0, 0.0],
                                              "normal": [-1.0, 0.0, 0.0]}})
        out.append((float(e.T), float(e.T_c_minus), float(e.m_eff), float(pt.T_c_minus)))
    np.testing.assert_allclose(out[1], out[0], rtol=1e-12)
    assert out[0][1] > 0 and out[0][3] > 0


def test_export_urdf_keeps_the_armature_of_an_mjcf_model(tmp_path):
    """MuJoCo's joint ``armature`` (rotor inertia, on the diagonal of mj_fullM; here on the
    free joint too) goes to Pinocchio's ``model.armature``; export_urdf dropped it, so the reloaded model's M
    lacked it (max |dM| 0.3 kg m^2 here: the first joint's armature) and its load-time
    check against MuJoCo compared two copies without it. Reference: mj_fullM of the
    original MJCF at random states."""
    from roverimpact.models.robot import export_urdf

    src = tmp_path / "geared.xml"
    src.write_text(
        "<mujoco><worldbody><body name='base' pos='0.3 0 1' euler='0 20 0'>"
        "<joint type='free' name='fly' armature='0.05'/><geom type='box' size='.2 .1 .1'/>"
        "<body name='l1' pos='0.2 0 0'><joint name='j1' axis='0 0 1' armature='0.3'/>"
        "<geom type='capsule' fromto='0 0 0 0.4 0 0' size='0.03' mass='2'/>"
        "<body name='l2' pos='0.4 0 0'><joint name='j2' axis='0 1 1' armature='0.1'/>"
        "<geom type='capsule' fromto='0 0 0 0.3 0 0' size='0.03' mass='1'/>"
        "</body></body></body></worldbody></mujoco>")
    mbm = load_robot(src)
    back = load_robot(export_urdf(mbm, tmp_path / "geared.urdf"))
    assert back.params["mujoco_check"] == "passed"
    np.testing.assert_array_equal(np.asarray(back.model.armature), [0.05] * 6 + [0.3, 0.1])
    m = mujoco.MjModel.from_xml_path(str(src))
    d = mujoco.MjData(m)
    rng = np.random.default_rng(5)
    for _ in range(3):
        d.qpos[:] = _random_qpos(m, rng)
        mujoco.mj_forward(m, d)
        q, _ = mujoco_state_to_pinocchio(mbm, d.qpos)
        T = _velocity_matrix(mbm, q, m.nv)
        assert _rel(T.T @ _pin_M(back.model, q) @ T, _mj_M(m, d)) < 1e-12
    with pytest.raises(ModelError, match=r"rotor inertia .* a plain URDF cannot hold"):
        ri.models.export_plain_urdf(mbm, tmp_path / "plain.urdf")


def test_mjcf_joint_range_becomes_the_position_limits(tmp_path):
    """A limited hinge's or slide's range (compiled by MuJoCo: degrees to radians) is the
    Pinocchio model's position limits and survives export_urdf (they were dropped: the
    URDF said the largest double). Reference: MuJoCo's jnt_range."""
    from roverimpact.models.robot import export_urdf

    src = tmp_path / "limited.xml"
    src.write_text(
        "<mujoco><compiler angle='degree'/><worldbody><body name='l1'>"
        "<joint name='h' axis='0 0 1' range='-30 60' ref='10'/><geom size='.1' mass='1'/>"
        "<body name='l2' pos='0.3 0 0'><joint name='s' type='slide' axis='1 0 0' "
        "range='-0.1 0.2'/><joint name='free_h' axis='0 1 0'/>"
        "<geom size='.1' mass='1'/></body></body></worldbody></mujoco>")
    m = mujoco.MjModel.from_xml_path(str(src))
    for mbm in (load_robot(src), load_robot(export_urdf(load_robot(src), tmp_path / "l.urdf"))):
        model = mbm.model
        for name in ("h", "s"):
            k = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
            iq = model.joints[model.getJointId(name)].idx_q
            assert model.lowerPositionLimit[iq] == pytest.approx(m.jnt_range[k][0], abs=1e-15)
            assert model.upperPositionLimit[iq] == pytest.approx(m.jnt_range[k][1], abs=1e-15)
        iq = model.joints[model.getJointId("free_h")].idx_q
        assert model.upperPositionLimit[iq] > 1e300
    assert np.deg2rad(60.0) == pytest.approx(float(m.jnt_range[0][1]), rel=1e-15)


def test_a_site_named_as_its_body_is_announced(tmp_path):
    """A site named as a body ('foot' at the sole of body 'foot', whose origin is the
    knee; dm_control's humanoid and quadruped do this) becomes frame 'foot_site', and
    obstacle.frame = 'foot' took the knee without a word. A scenario naming such a frame
    now gets a warning naming the site's frame; the two frames are MuJoCo's body and site
    positions (reference: site_xpos, xpos)."""
    from roverimpact.scenario import Scenario
    from roverimpact.scenario.build import ImpactSetup

    f = tmp_path / "leg.xml"
    f.write_text(
        "<mujoco><worldbody><body name='thigh' pos='0 0 1'><joint name='hip' axis='0 1 0'/>"
        "<geom type='capsule' fromto='0 0 0 0 0 -0.4' size='0.03' mass='2'/>"
        "<body name='foot' pos='0 0 -0.4'><joint name='knee' axis='0 1 0'/>"
        "<geom type='capsule' fromto='0 0 0 0 0 -0.4' size='0.03' mass='1'/>"
        "<site name='foot' pos='0 0 -0.4'/></body></body></worldbody></mujoco>")

    def setup(frame):
        return ImpactSetup.from_scenario(Scenario.model_validate({
            "model": {"file": str(f)}, "configuration": {"joints": {"hip": 0.3, "knee": -0.6}},
            "velocity": {"joints": {"hip": 1.0}},
            "obstacle": {"frame": frame, "normal": [0.0, 0.0, 1.0]}}))

    with pytest.warns(UserWarning, match=r"obstacle.frame = 'foot' is the frame of the body.*"
                                         r"the MJCF site of that name is frame 'foot_site'"):
        body = setup("foot")
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        site = setup("foot_site")
    m = mujoco.MjModel.from_xml_path(str(f))
    d = mujoco.MjData(m)
    d.qpos[:] = [0.3, -0.6]
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(site.contact_point, d.site_xpos[0], atol=1e-14)
    np.testing.assert_allclose(body.contact_point, d.xpos[2], atol=1e-14)


def test_unset_base_angles_keep_the_files_orientation(tmp_path):
    """configuration.base documents 'unset = model's nominal', but roll/pitch/yaw defaulted
    to 0: an MJCF free body placed with euler='0 10 90' was turned back to the identity
    (the tip site at (0.6, 0, 0.4) instead of MuJoCo's (0, 0.6, 0.4) at qpos0). Unset
    angles now keep the nominal ones, a given angle replaces only itself (Pinocchio's
    rpy: R = Rz(yaw) Ry(pitch) Rx(roll)). Reference: MuJoCo's site_xpos at qpos0."""
    from roverimpact.scenario import Scenario
    from roverimpact.scenario.build import ImpactSetup

    f = tmp_path / "tilted.xml"
    f.write_text(
        "<mujoco><compiler angle='degree'/><worldbody><body name='rover' pos='0 0 0.4' "
        "euler='0 10 90'><freejoint name='root'/><geom type='box' size='0.3 0.2 0.1' "
        "mass='10'/><body name='arm' pos='0.3 0 0'><joint name='j' axis='0 1 0'/>"
        "<geom type='capsule' fromto='0 0 0 0.3 0 0' size='0.02' mass='1'/>"
        "<site name='tip' pos='0.3 0 0'/></body></body></worldbody></mujoco>")

    def setup(base):
        return ImpactSetup.from_scenario(Scenario.model_validate({
            "model": {"file": str(f)}, "configuration": {"base": base},
            "velocity": {"joints": {"j": 1.0}},
            "obstacle": {"frame": "tip", "normal": [0.0, 0.0, 1.0]}}))

    m = mujoco.MjModel.from_xml_path(str(f))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(setup({}).contact_point, d.site_xpos[0], atol=1e-12)
    R0 = pin.Quaternion(*m.qpos0[3:7]).toRotationMatrix()  # w x y z
    roll, _, yaw = pin.rpy.matrixToRpy(R0)
    q = setup({"pitch_deg": 5.0}).q
    np.testing.assert_allclose(pin.Quaternion(q[3:7]).toRotationMatrix(),
                               pin.rpy.rpyToMatrix(roll, np.deg2rad(5.0), yaw), atol=1e-12)
    q = setup({"roll_deg": 0.0, "pitch_deg": 0.0, "yaw_deg": 0.0}).q   # all given: level
    np.testing.assert_allclose(q[3:7], [0.0, 0.0, 0.0, 1.0], atol=1e-15)


def test_missing_texture_files_do_not_stop_the_load(tmp_path):
    """An MJCF copied without its textures/ folder (or its terrain height-field image):
    MuJoCo stops at "Error opening file 'textures/grid.png'" and the model was unloadable,
    though neither changes any number. It now loads with a warning naming the files; M equals MuJoCo's mj_fullM of the same
    model written without the texture (reference), and a missing mesh still fails."""
    body = ("<worldbody><geom name='floor' type='plane' size='5 5 0.1' material='m'/>"
            "<body name='a' pos='0 0 1'><joint name='j' axis='0 1 0'/><geom type='box' "
            "size='0.1 0.2 0.3' pos='0.2 0 0' mass='2' material='m'/></body></worldbody>")
    f = tmp_path / "tex.xml"
    f.write_text("<mujoco><asset><texture name='grid' type='2d' file='textures/grid.png'/>"
                 f"<material name='m' texture='grid'/></asset>{body}</mujoco>")
    with pytest.warns(UserWarning, match=r"texture and terrain files "
                                         r"\['textures/grid.png'\].*loaded without textures"):
        mbm = load_robot(f)
    m = mujoco.MjModel.from_xml_string(f"<mujoco><asset><material name='m'/></asset>{body}"
                                       "</mujoco>")
    d = mujoco.MjData(m)
    d.qpos[:] = [0.7]
    mujoco.mj_forward(m, d)
    assert _pin_M(mbm.model, np.array([0.7]))[0, 0] == pytest.approx(_mj_M(m, d)[0, 0],
                                                                     rel=1e-14)
    assert _mj_M(m, d)[0, 0] == pytest.approx(2 * (0.2**2 + (0.2**2 + 0.6**2) / 12), rel=1e-12)
    g = tmp_path / "mesh.xml"
    g.write_text(f.read_text().replace(
        "<material", "<mesh name='hull' file='hull.obj'/><material").replace(
        "<geom type='box' size='0.1 0.2 0.3'", "<geom type='mesh' mesh='hull'"))
    with pytest.raises(ModelError, match=r"hull\.obj"):
        load_robot(g)
    # a height-field terrain read from a missing file, on the world body: dropped too
    h = tmp_path / "terrain.xml"
    h.write_text(f.read_text().replace(
        "<material", "<hfield name='ground' file='terrain.png' size='5 5 0.5 0.1'/><material")
        .replace("type='plane' size='5 5 0.1'", "type='hfield' hfield='ground'"))
    with pytest.warns(UserWarning, match=r"\['textures/grid.png', 'terrain.png'\].*without "
                                         r"the static height fields \['ground'\]"):
        mbm = load_robot(h)
    assert _pin_M(mbm.model, np.array([0.7]))[0, 0] == pytest.approx(_mj_M(m, d)[0, 0],
                                                                     rel=1e-14)


@pytest.mark.parametrize("name, text", [
    ("bad.xml", "<mujoco><worldbody><body><joint/><geom size='0.1'/></body></worldbody>"
                "</mujoco>"),
    ("bad.urdf", "<robot name='r'><link name='a'/></robot>"),
])
def test_utf16_robot_file_is_named(tmp_path, name, text):
    """A URDF/MJCF file saved as UTF-16 (valid XML, but neither MuJoCo's nor Pinocchio's
    parser reads it) said "MuJoCo cannot compile it (XML parse error 15 ...)" or
    "Pinocchio cannot build a model from it (... XML_ERROR_PARSING ...)"."""
    f = tmp_path / name
    f.write_bytes(text.encode("utf-16"))
    with pytest.raises(ModelError, match=rf"{name}: the file is UTF-16: save it as UTF-8$"):
        load_robot(f)
