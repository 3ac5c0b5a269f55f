"""Joint coordinates by name (roverimpact.models.joints): continuous and mimic joints.

References: a revolute twin of every continuous joint (the same pose by forward
kinematics), the spring potential U = k d^2 / 2 (torque = -dU/dtheta by central
differences), MuJoCo's URDF importer (it reads <mimic> into joint equalities on its own)
and Pinocchio's reduced mimic model (``buildModelFromUrdf(..., mimic=True)``, a
``JointModelMimic`` without coordinates) for the kinetic-energy partition with the
coupling rows.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from roverimpact.exceptions import ModelError
from roverimpact.models import load_robot
from roverimpact.models.joints import (
    JointCoupling,
    joint_coordinate,
    joint_value,
    lock_row,
    set_joint_rate,
    set_joint_value,
    spring_torque,
    velocity_index,
)

from .test_models_mjcf_mujoco import GRIPPER_URDF, ROVER_URDF


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("joints")
    (d / "rover.urdf").write_text(ROVER_URDF)
    (d / "gripper.urdf").write_text(GRIPPER_URDF)
    # the same gripper with its continuous joint as a plain revolute one
    (d / "gripper_rev.urdf").write_text(GRIPPER_URDF.replace(
        'name="roller_joint" type="continuous"', 'name="roller_joint" type="revolute"').replace(
        '<mimic joint="wrist" multiplier="2" offset="0.3"/>',
        '<mimic joint="wrist" multiplier="2" offset="0.3"/>'
        '<limit lower="-9" upper="9" effort="1" velocity="1"/>'))
    return d


def test_joint_kinds(files):
    mbm = load_robot(files / "gripper.urdf")
    kinds = {n: joint_coordinate(mbm, n).kind for n in mbm.model.names[1:]}
    assert kinds == {"shoulder": "revolute", "wrist": "revolute",
                     "finger_left_joint": "prismatic", "finger_right_joint": "prismatic",
                     "roller_joint": "continuous"}
    jc = joint_coordinate(mbm, "roller_joint")
    assert (jc.nq, jc.nv) == (2, 1) and jc.mimic == ("wrist", 2.0, 0.3)
    fl = load_robot(files / "rover.urdf", floating_base=True)
    assert joint_coordinate(fl, "root_joint").kind == "free"


def test_unknown_joint_names_the_joint_and_lists_the_known_ones(files):
    mbm = load_robot(files / "rover.urdf")
    with pytest.raises(ModelError, match=r"unknown joint 'wheel_xx'.*wheel_fl_joint"):
        set_joint_value(mbm, pin.neutral(mbm.model), "wheel_xx", 1.0)
    with pytest.raises(ModelError, match=r"velocity.joints: unknown joint"):
        set_joint_rate(mbm, np.zeros(mbm.model.nv), "nope", 1.0)
    fl = load_robot(files / "rover.urdf", floating_base=True)
    with pytest.raises(ModelError, match=r"'root_joint' is a free joint"):
        lock_row(fl, "root_joint")


@pytest.mark.parametrize("theta", [0.0, 0.7, -2.9, np.pi, 4.0, -7.0])
def test_continuous_wheel_pose_equals_a_revolute_twin(files, theta):
    """Set a continuous wheel by angle: (cos, sin) in q, the angle back in (-pi, pi], and
    the wheel frame where a revolute joint at the same angle puts it."""
    mbm = load_robot(files / "gripper.urdf")
    twin = load_robot(files / "gripper_rev.urdf")
    q = set_joint_value(mbm, pin.neutral(mbm.model), "wrist", 0.4)  # roller follows
    q = set_joint_value(mbm, q, "roller_joint", theta)
    jc = joint_coordinate(mbm, "roller_joint")
    np.testing.assert_allclose(q[jc.idx_q:jc.idx_q + 2], [np.cos(theta), np.sin(theta)])
    wrapped = np.mod(theta + np.pi, 2 * np.pi) - np.pi
    back = joint_value(mbm, q, "roller_joint")
    assert np.cos(back - wrapped) == pytest.approx(1.0) and -np.pi < back <= np.pi
    qt = set_joint_value(twin, pin.neutral(twin.model), "wrist", joint_value(mbm, q, "wrist"))
    qt = set_joint_value(twin, qt, "roller_joint", theta)
    poses = []
    for model, qq in ((mbm.model, q), (twin.model, qt)):
        data = model.createData()
        pin.framesForwardKinematics(model, data, qq)
        poses.append(data.oMf[model.getFrameId("roller")].homogeneous)
    np.testing.assert_allclose(poses[0], poses[1], atol=1e-14)


def test_rate_index_and_lock_row_of_a_continuous_wheel(files):
    """The rate set by name is the wheel's angular rate about its axis (frame velocity)."""
    mbm = load_robot(files / "rover.urdf")
    model = mbm.model
    v = set_joint_rate(mbm, np.zeros(model.nv), "wheel_rl_joint", 3.0)
    i = velocity_index(mbm, "wheel_rl_joint")
    assert v[i] == 3.0 and np.count_nonzero(v) == 1
    assert lock_row(mbm, "wheel_rl_joint") @ v == 3.0
    data = model.createData()
    q = set_joint_value(mbm, pin.neutral(model), "wheel_rl_joint", 1.1)
    pin.forwardKinematics(model, data, q, v)
    w = pin.getFrameVelocity(model, data, model.getFrameId("wheel_rl"), pin.LOCAL).angular
    np.testing.assert_allclose(w, [0.0, 3.0, 0.0], atol=1e-15)


@pytest.mark.parametrize("name, k, c, theta0", [
    ("wheel_fl_joint", 40.0, 0.5, 0.3), ("shoulder", 12.0, 0.0, -0.2),
    ("finger_left_joint", 800.0, 3.0, 0.01)])
def test_spring_torque_is_minus_the_potential_gradient(files, name, k, c, theta0):
    """tau = -dU/dtheta - c theta_dot with U = k (theta - theta0)^2 / 2, by central
    differences of U along the joint (through set_joint_value)."""
    path = files / ("rover.urdf" if name.startswith("wheel") else "gripper.urdf")
    mbm = load_robot(path)
    model = mbm.model
    q = set_joint_value(mbm, pin.neutral(model), name, theta0 + 0.25)
    v = set_joint_rate(mbm, np.zeros(model.nv), name, 1.5)
    tau = spring_torque(mbm, q, v, name, k, c, theta0)
    h = 1e-6

    def U(th):
        d = joint_value(mbm, set_joint_value(mbm, q, name, th), name) - theta0
        return 0.5 * k * d**2

    th = joint_value(mbm, q, name)
    expected = -(U(th + h) - U(th - h)) / (2 * h) - c * 1.5
    i = velocity_index(mbm, name)
    assert tau[i] == pytest.approx(expected, rel=1e-7)
    assert np.count_nonzero(tau) == 1


def test_continuous_spring_wraps_across_pi(files):
    """theta = 3.0, theta0 = -3.0: the spring sees 6 - 2 pi = -0.283 rad, not 6 rad."""
    mbm = load_robot(files / "rover.urdf")
    q = set_joint_value(mbm, pin.neutral(mbm.model), "wheel_fr_joint", 3.0)
    tau = spring_torque(mbm, q, np.zeros(mbm.model.nv), "wheel_fr_joint", 10.0, 0.0, -3.0)
    assert tau[velocity_index(mbm, "wheel_fr_joint")] == pytest.approx(-10.0 * (6.0 - 2 * np.pi))


def test_batched_values_and_springs(files):
    mbm = load_robot(files / "rover.urdf")
    th = np.array([[0.1, -3.0], [2.0, 0.5]])
    Q = set_joint_value(mbm, np.broadcast_to(pin.neutral(mbm.model), (2, 2, mbm.model.nq)),
                        "wheel_fl_joint", th)
    np.testing.assert_allclose(joint_value(mbm, Q, "wheel_fl_joint"), th)
    tau = spring_torque(mbm, Q, np.zeros(mbm.model.nv), "wheel_fl_joint", 2.0)
    np.testing.assert_allclose(tau[..., velocity_index(mbm, "wheel_fl_joint")], -2.0 * th)


# ------------------------------------------------------------------------ mimic


def test_mimic_couplings_agree_with_mujocos_urdf_importer(files):
    """MuJoCo turns <mimic> into joint equalities (polycoef = offset, multiplier): the
    couplings roverimpact keeps are the same."""
    mujoco = pytest.importorskip("mujoco")
    mbm = load_robot(files / "gripper.urdf")
    m = mujoco.MjModel.from_xml_path(str(files / "gripper.urdf"))
    mj = []
    for e in range(m.neq):
        j1 = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, m.eq_obj1id[e])
        j2 = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, m.eq_obj2id[e])
        mj.append([j1, j2, float(m.eq_data[e, 1]), float(m.eq_data[e, 0])])
    assert sorted(mj) == sorted(mbm.params["mimic"])
    assert mbm.loop_names == ["mimic:finger_right_joint", "mimic:roller_joint"]


def test_setting_a_leader_or_a_follower_keeps_the_coupling(files):
    mbm = load_robot(files / "gripper.urdf")
    model = mbm.model
    q0 = np.array(mbm.params["q_nominal"])  # roller at 2 * 0 + 0.3
    assert joint_value(mbm, q0, "roller_joint") == pytest.approx(0.3)
    q = set_joint_value(mbm, q0, "finger_left_joint", 0.03)
    assert joint_value(mbm, q, "finger_right_joint") == pytest.approx(-0.03)
    q = set_joint_value(mbm, q, "roller_joint", 1.1)  # sets the wrist to (1.1 - 0.3) / 2
    assert joint_value(mbm, q, "wrist") == pytest.approx(0.4)
    phi, J = mbm.loop_closure(q)
    np.testing.assert_allclose(phi, 0.0, atol=1e-15)
    v = set_joint_rate(mbm, np.zeros(model.nv), "finger_right_joint", 0.2)
    v = set_joint_rate(mbm, v, "wrist", -1.0)
    np.testing.assert_allclose(J @ v, 0.0, atol=1e-15)
    assert v[velocity_index(mbm, "finger_left_joint")] == pytest.approx(-0.2)
    assert v[velocity_index(mbm, "roller_joint")] == pytest.approx(-2.0)
    # the coupling residual of a continuous follower is wrapped: 2 pi away is no violation
    q2 = set_joint_value(mbm, q, "roller_joint", 1.1)
    jc = joint_coordinate(mbm, "roller_joint")
    th = 1.1 + 2 * np.pi
    q2[jc.idx_q:jc.idx_q + 2] = [np.cos(th), np.sin(th)]
    assert abs(mbm.loop_closure(q2)[0][1]) < 1e-12


def test_mimic_rows_give_the_partition_of_the_reduced_model(files, tmp_path):
    """T and T_c^- with the always-active mimic row equal those of Pinocchio's reduced
    model (JointModelMimic: the finger has no coordinate of its own), for an impact on
    the mimicking finger. (pin 4.1's reduced model refuses a continuous joint mimicking a
    revolute one, so the roller coupling is left out of this file.)"""
    from roverimpact import partition
    from roverimpact.models.constraints import point_jacobian

    text = GRIPPER_URDF.replace('<mimic joint="wrist" multiplier="2" offset="0.3"/>', "")
    f = tmp_path / "g.urdf"
    f.write_text(text)
    mbm = load_robot(f)
    red = pin.buildModelFromUrdf(str(f), True)
    model = mbm.model
    assert red.nv == model.nv - 1
    rng = np.random.default_rng(2)
    n = np.array([0.3, -0.9, 0.3])
    n /= np.linalg.norm(n)
    for _ in range(4):
        vals = {"shoulder": rng.uniform(-1, 1), "wrist": rng.uniform(-1, 1),
                "finger_left_joint": rng.uniform(0, 0.04), "roller_joint": rng.uniform(-3, 3)}
        rates = {k: rng.standard_normal() for k in vals}
        q, v = pin.neutral(model), np.zeros(model.nv)
        qr, vr = pin.neutral(red), np.zeros(red.nv)
        for k in vals:
            q = set_joint_value(mbm, q, k, vals[k])
            v = set_joint_rate(mbm, v, k, rates[k])
            j = red.joints[red.getJointId(k)]
            if j.nq == 2:
                qr[j.idx_q:j.idx_q + 2] = [np.cos(vals[k]), np.sin(vals[k])]
            else:
                qr[j.idx_q] = vals[k]
            vr[j.idx_v] = rates[k]
        rows = []
        for mdl, qq in ((model, q), (red, qr)):
            data = mdl.createData()
            pin.computeJointJacobians(mdl, data, qq)
            pin.updateFramePlacements(mdl, data)
            fid = mdl.getFrameId("finger_right")
            p = data.oMf[fid].act(np.array([0.05, 0.0, 0.0]))
            rows.append(n @ point_jacobian(mdl, data, fid, p - data.oMf[fid].translation))
        M = pin.crba(model, model.createData(), q)
        M = np.triu(M) + np.triu(M, 1).T
        Mr = pin.crba(red, red.createData(), qr)
        Mr = np.triu(Mr) + np.triu(Mr, 1).T
        A = np.vstack([mbm.loop_closure(q)[1], rows[0]])
        full = partition(M, A, v)
        reduced = partition(Mr, rows[1][None, :], vr)
        assert full.T == pytest.approx(reduced.T, rel=1e-12)
        assert full.T_c == pytest.approx(reduced.T_c, rel=1e-10)


def test_coupling_rows_are_constant_for_the_compiled_row_plan(files):
    """The coupling's J does not depend on q (the compiled row plan stores it once) and
    a scenario-style constraint set gives the same rows as the per-constraint path."""
    from roverimpact.models.kinematics import ConstraintSet, LoopClosure, PointContact

    mbm = load_robot(files / "gripper.urdf")
    assert isinstance(mbm.loop_closure, JointCoupling) and mbm.loop_closure.constant_jacobian
    cs = ConstraintSet(mbm, [LoopClosure(tuple(mbm.loop_names)),
                             PointContact("tip", "finger_left", (0.0, 1.0, 0.0))])
    q = set_joint_value(mbm, np.array(mbm.params["q_nominal"]), "wrist", 0.7)
    _, A = cs.evaluate(q)
    cs.kinematics(q)
    np.testing.assert_allclose(A, cs.rows(q), atol=1e-14)
    assert cs._row_plan()._loop_constant


def test_a_fixed_joint_equality_holds_its_joint(tmp_path):
    """MJCF <equality><joint joint1="j"/> without joint2: j = ref + c0, cannot be set."""
    pytest.importorskip("mujoco")
    (tmp_path / "f.xml").write_text(
        "<mujoco><compiler angle='radian'/><worldbody><body><joint name='a' axis='0 1 0'/>"
        "<geom size='0.1' pos='0.2 0 0'/>"
        "<body><joint name='b' axis='0 1 0' ref='0.1'/><geom size='0.1' pos='0.4 0 0'/></body>"
        "</body></worldbody><equality><joint joint1='b' polycoef='0.2 0 0 0 0'/></equality>"
        "</mujoco>")
    mbm = load_robot(tmp_path / "f.xml")
    assert mbm.params["mimic"] == [["b", None, 0.0, pytest.approx(0.3)]]
    assert joint_value(mbm, np.array(mbm.params["q_nominal"]), "b") == pytest.approx(0.3)
    with pytest.raises(ModelError, match=r"held at 0\.3"):
        set_joint_value(mbm, np.array(mbm.params["q_nominal"]), "b", 1.0)


def test_a_mimic_naming_no_joint_is_ignored_with_a_warning(tmp_path):
    """A <mimic> naming a joint the file does not have (as in example-robot-data's
    alex_psyonic_hands.urdf) loads, without that coupling, and says so."""
    f = tmp_path / "g.urdf"
    f.write_text(GRIPPER_URDF.replace('<mimic joint="finger_left_joint"', '<mimic joint="left_q1"'))
    with pytest.warns(UserWarning, match=r"finger_right_joint.*left_q1.*ignored"):
        mbm = load_robot(f)
    assert mbm.loop_names == ["mimic:roller_joint"]


def test_loop_rows_on_continuous_joints_join_the_mimic_rows(tmp_path):
    """A <roverimpact_loop> row on continuous joints (wheel_fl = wheel_fr: a shared axle)
    is a JointCoupling; mimic rows are appended to it; phi wraps, J = C."""
    text = ROVER_URDF.replace("</robot>", """  <roverimpact_loop name="axle"
    joints="wheel_fl_joint wheel_fr_joint" coefficients="1 -1"/>
</robot>""")
    text = text.replace('<child link="wheel_rr"/>',
                        '<child link="wheel_rr"/><mimic joint="wheel_rl_joint"/>')
    f = tmp_path / "r.urdf"
    f.write_text(text)
    mbm = load_robot(f)
    assert mbm.loop_names == ["axle", "mimic:wheel_rr_joint"]
    q = set_joint_value(mbm, pin.neutral(mbm.model), "wheel_fl_joint", 3.0)
    q = set_joint_value(mbm, q, "wheel_fr_joint", -3.0 + 2 * np.pi)
    q = set_joint_value(mbm, q, "wheel_rl_joint", 1.0)
    phi, J = mbm.loop_closure(q)
    # wheel_fl - wheel_fr = 3 - (2 pi - 3) = 6 - 2 pi, already in (-pi, pi]
    np.testing.assert_allclose(phi, [6.0 - 2 * np.pi, 0.0], atol=1e-12)
    q = set_joint_value(mbm, q, "wheel_fr_joint", 3.0 - 2 * np.pi)  # the same angle
    assert abs(mbm.loop_closure(q)[0][0]) < 1e-12
    assert J[0, velocity_index(mbm, "wheel_fl_joint")] == 1.0
    assert J[0, velocity_index(mbm, "wheel_fr_joint")] == -1.0


def test_mujoco_writes_no_log_file_in_the_working_directory(tmp_path, monkeypatch):
    """MuJoCo's URDF import of the check's copy warns about the broken <mimic>; by default
    MuJoCo would append that to MUJOCO_LOG.TXT in the current directory."""
    pytest.importorskip("mujoco")
    f = tmp_path / "g.urdf"
    f.write_text(GRIPPER_URDF.replace('<mimic joint="finger_left_joint"', '<mimic joint="left_q1"'))
    monkeypatch.chdir(tmp_path)
    with pytest.warns(UserWarning, match="ignored"):
        mbm = load_robot(f)
    assert mbm.params["mujoco_check"] == "passed"
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
