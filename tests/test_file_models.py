"""Your own rover, as written: an MJCF rover driven into faces by MuJoCo, analysed as is.

The rover is written the way MuJoCo users write it (one chassis body with slide x, slide
z and hinge pitch joints, the chassis mass on a non-colliding geom, cylinder wheels from a
default class); roverimpact declares its wheels by body name, detects the planar base, and
takes MuJoCo's state at the first obstacle contact with ``Scenario.from_mujoco``.

Checks against what roverimpact did not compute:

- with every contact MuJoCo reports held (``constraints = "all"``), T_c^- equals the one
  from MuJoCo's own mass matrix (``mj_fullM``) and contact Jacobians (``mj_jac`` at its
  contact points along its contact normals);
- with the default (automatic) active set, T_c^- ranks MuJoCo's first-impact peak normal
  force over face angles 10-90 deg (Spearman >= 0.95; 1.0 measured), face and floor a
  spring-damper of fixed stiffness (see ``_material_law``: with MuJoCo's default soft
  contact, whose force scales with the effective mass, the rank correlation measured
  0.93).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import spearmanr

import roverimpact as ri
from roverimpact.models.declare import base_info
from roverimpact.models.mujoco_check import full_mass_matrix

mujoco = pytest.importorskip("mujoco")

ROVER = """
<mujoco model="rover">
  <compiler angle="degree"/>
  <!-- the cylinder/box contact point comes from MuJoCo's convex collider: to 1e-6 m by
       default, which moves T_c^- by 3e-5 at a 20 deg face; 1e-12 here -->
  <option timestep="0.0005" gravity="0 0 -9.81" ccd_tolerance="1e-12" ccd_iterations="200"/>
  <default>
    <geom condim="1"/>
    <default class="visual"><geom contype="0" conaffinity="0" group="1"/></default>
    <default class="wheel">
      <joint type="hinge" axis="0 1 0"/>
      <geom type="cylinder" size="0.15 0.05" euler="90 0 0" mass="2"/>
    </default>
  </default>
  <worldbody>
    <geom name="floor" type="plane" size="20 2 0.1" contype="0" conaffinity="0"/>
    <geom name="face" type="box" size="1 1 0.5" pos="{px} 0 {pz}" euler="0 {angle} 0"
          contype="0" conaffinity="0"/>
    <body name="chassis" pos="0 0 0.35">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="z" type="slide" axis="0 0 1"/>
      <joint name="pitch" type="hinge" axis="0 1 0"/>
      <geom name="chassis_box" class="visual" type="box" size="0.35 0.2 0.075" mass="20"/>
      <body name="front_wheel" pos="0.3 0 -0.2" childclass="wheel">
        <joint name="wheel_front"/><geom name="front_tire"/>
      </body>
      <body name="rear_wheel" pos="-0.3 0 -0.2" childclass="wheel">
        <joint name="wheel_rear"/><geom name="rear_tire"/>
      </body>
    </body>
  </worldbody>
  <contact>
    <pair geom1="face" geom2="front_tire" condim="1" solimp="0.0001 0.0001 0.001"/>
    <pair geom1="face" geom2="rear_tire" condim="1" solimp="0.0001 0.0001 0.001"/>
    <pair geom1="floor" geom2="front_tire" condim="1" solimp="0.0001 0.0001 0.001"/>
    <pair geom1="floor" geom2="rear_tire" condim="1" solimp="0.0001 0.0001 0.001"/>
  </contact>
</mujoco>
"""
R, U, X_FACE = 0.15, 0.4, 0.75  # wheel radius, speed, foot of the face [m]
K_FACE, C_FACE = 2.0e5, 300.0  # face and floor spring-damper, per contact point [N/m, N s/m]
WHEELS = {"front": {"frame": "front_wheel"}, "rear": {"frame": "rear_wheel"}}


def _normal(beta_deg: float) -> np.ndarray:
    b = np.radians(beta_deg)
    return np.array([-np.sin(b), 0.0, np.cos(b)])


def _model_file(tmp_path, beta_deg: float):
    """The rover and a box whose top face is the obstacle face through (X_FACE, 0, 0)."""
    n = _normal(beta_deg)
    centre = np.array([X_FACE, 0.0, 0.0]) - 0.5 * n  # half thickness behind the face
    path = tmp_path / f"rover_{beta_deg:g}.xml"
    path.write_text(ROVER.format(px=centre[0], pz=centre[2], angle=-beta_deg))
    return path


def _material_law(m) -> None:
    """Face and floor as a material of fixed stiffness: f = K_FACE delta + C_FACE delta'
    per contact point (every ``<pair>`` of the file). MuJoCo's default soft contact (``solref = (0.02, 1)``) is a
    spring-damper in *acceleration*, its force proportional to the contact's effective
    mass, so its peak force ranks m_eff v_n, not T_c^-; the papers' claim is for a face
    of given stiffness. With impedance d -> 0 and the direct ``solref = (-k a, -c a)``,
    ``a`` the wheel body's ``body_invweight0`` (MuJoCo's diagonal approximation of the
    contact's inverse mass), MuJoCo's constraint force is k delta + c delta' to O(d)
    (as in :mod:`roverimpact.simulate.engines.mujoco`)."""
    for p in range(m.npair):
        a = m.body_invweight0[m.geom_bodyid[m.pair_geom2[p]], 0]
        m.pair_solref[p] = (-K_FACE * a, -C_FACE * a)


def _contacts(m, d, geom: str):
    gid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, geom)
    return [i for i in range(d.ncon) if gid in (d.contact[i].geom1, d.contact[i].geom2)]


def _run(tmp_path, beta_deg: float):
    """Drive into the face; return the model file, the state at first contact (as a
    scenario's inputs) and MuJoCo's first-impact peak normal force."""
    path = _model_file(tmp_path, beta_deg)
    m = mujoco.MjModel.from_xml_path(str(path))
    _material_law(m)
    d = mujoco.MjData(m)
    d.qpos[:] = [0.0, 0.0, 0.0, 0.0, 0.0]
    d.qvel[:] = [U, 0.0, 0.0, U / R, U / R]
    for _ in range(20000):  # settle on the floor and drive (about 1.5 s)
        mujoco.mj_step(m, d)
        if _contacts(m, d, "face"):
            break
    else:
        raise AssertionError("no contact with the face")
    first = mujoco.MjData(m)
    first.qpos[:], first.qvel[:] = d.qpos, d.qvel
    mujoco.mj_forward(m, first)
    peak, f6 = 0.0, np.zeros(6)
    for _ in range(20000):  # the first impact: until the face contact is released
        ids = _contacts(m, d, "face")
        if not ids:
            break
        total = 0.0
        for i in ids:
            mujoco.mj_contactForce(m, d, i, f6)
            total += f6[0]
        peak = max(peak, total)
        mujoco.mj_step(m, d)
    return path, m, first, peak


def _scenario(m, d, path, beta_deg, **tables):
    floor = _contacts(m, d, "floor")
    on_floor = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM,
                                  d.contact[i].geom2 if d.contact[i].geom1 == 0
                                  else d.contact[i].geom1) for i in floor}
    ground = [w for w in WHEELS if f"{w}_tire" in on_floor and w != "front"]
    return ri.Scenario.from_mujoco(
        m, d, file=path, model={"wheels": WHEELS},
        obstacle={"wheel": "front", "normal": _normal(beta_deg).tolist()},
        contacts={"ground_wheels": ground}, **tables), ground


def _mujoco_T_c(m, d, ground_wheels):
    """T_c^- from MuJoCo's own M and contact Jacobians: the face contacts and the floor
    contacts of ``ground_wheels``, rows n^T J_p at MuJoCo's contact points."""
    M = full_mass_matrix(mujoco, m, d)
    rows = []
    keep = {"face"} | {f"{w}_tire" for w in ground_wheels}
    for i in range(d.ncon):
        c = d.contact[i]
        names = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) for g in (c.geom1, c.geom2)}
        if not ({"face", "floor"} & names) or not (keep & names):
            continue
        if "floor" in names and not (keep - {"face"}) & names:
            continue
        wheel_geom = next(g for g in (c.geom1, c.geom2)
                          if mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g).endswith("tire"))
        n = c.frame[:3] * (1.0 if wheel_geom == c.geom2 else -1.0)  # towards the wheel
        jacp = np.zeros((3, m.nv))
        mujoco.mj_jac(m, d, jacp, None, c.pos, m.geom_bodyid[wheel_geom])
        rows.append(n @ jacp)
    A = np.array(rows)
    v = d.qvel.copy()
    # T_c = 1/2 (A v)^T (A M^-1 A^T)^+ (A v), by numpy alone
    G = A @ np.linalg.solve(M, A.T)
    Av = A @ v
    return 0.5 * Av @ np.linalg.pinv(G, rcond=1e-10) @ Av


BETAS = (10.0, 20.0, 30.0, 45.0, 60.0, 70.0, 80.0, 90.0)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("mjrover")
    return {b: _run(tmp, b) for b in BETAS}


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.HeldRowsWarning")  # "all" held
@pytest.mark.parametrize("beta_deg", (20.0, 60.0, 90.0))
def test_all_rows_equal_mujocos_own_M_and_contact_jacobians(runs, beta_deg):
    path, m, d, _ = runs[beta_deg]
    sc, ground = _scenario(m, d, path, beta_deg, constraints="all")
    setup = ri.ImpactSetup.from_scenario(sc)
    assert setup.model.params["total_mass"] == pytest.approx(24.0, rel=1e-12)  # chassis kept
    assert base_info(setup.model).kind == "planar"  # detected from the joints' axes
    T_c = float(setup.partition().T_c_minus)
    assert T_c == pytest.approx(_mujoco_T_c(m, d, ground), rel=1e-6)
    # and the whole state: the kinetic energy of MuJoCo's state
    assert float(setup.partition().T) == pytest.approx(
        0.5 * d.qvel @ _full_M(m, d) @ d.qvel, rel=1e-9)


def _full_M(m, d):
    return full_mass_matrix(mujoco, m, d)


def test_default_active_set_ranks_mujocos_peak_force(runs):
    T, F = [], []
    for beta in BETAS:
        path, m, d, peak = runs[beta]
        sc, _ = _scenario(m, d, path, beta)
        T.append(float(ri.energy_of(sc).T_c_minus))
        F.append(peak)
    rho = spearmanr(T, F).statistic
    assert rho >= 0.95, (np.round(T, 4).tolist(), np.round(F, 1).tolist(), rho)


@pytest.mark.parametrize("name, wheel", [("rocker_bogie", "left_front"), ("rover2d", "front")])
def test_builtin_rover_as_plain_urdf_equals_the_builtin(tmp_path, name, wheel):
    """The built-in rovers written as plain URDF (``export_plain_urdf``: no roverimpact
    elements, the differential as a ``<mimic>`` joint; loaded with the MuJoCo check of
    M(q) where MuJoCo takes the file) and declared in the scenario: the same T_c^-,
    m_eff over beta 0-90 deg as the built-in rover."""
    from roverimpact.models import export_plain_urdf
    from roverimpact.models import rocker_bogie as rb_builder
    from roverimpact.models import rover2d as rv_builder

    mbm = {"rocker_bogie": rb_builder, "rover2d": rv_builder}[name]()
    tables = export_plain_urdf(mbm, tmp_path / f"{name}.urdf")
    mujoco.MjModel.from_xml_path(tables["model"]["file"])  # a file MuJoCo reads
    rest = {"velocity": {"u": 0.2}, "obstacle": {"wheel": wheel, "beta_deg": 30.0}}
    s_file = ri.ImpactSetup.from_scenario(ri.Scenario.model_validate({**tables, **rest}))
    s_builtin = ri.ImpactSetup.from_scenario(ri.Scenario.model_validate(
        {"model": {"name": name}, **rest}))
    assert s_file.model.name != "rocker_bogie" or "mimic" in " ".join(s_file.labels)
    beta = np.radians(np.linspace(0.0, 90.0, 19))
    e_file, e_builtin = ri.sweep_energy(s_file, beta), ri.sweep_energy(s_builtin, beta)
    np.testing.assert_allclose(e_file.T_c_minus, e_builtin.T_c_minus, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(e_file.m_eff, e_builtin.m_eff, rtol=1e-12)


@pytest.mark.parametrize("name, params", [
    ("rover2d", {}), ("rover2d", {"suspension": "rocker", "middle_wheel": True}),
    ("rover2d", {"suspension": "prismatic"}), ("rocker_bogie", {})])
def test_plain_urdf_mass_matrix_in_mujoco_and_pinocchio(tmp_path, name, params):
    """The plain URDF as other tools read it: MuJoCo compiles it (rover2d's planar base is
    two massless slider links, which MuJoCo refused: "mass and inertia of moving bodies
    must be larger than mjMINVAL, Element 'base_x_link'"), and MuJoCo's ``mj_fullM`` and
    plain Pinocchio's CRBA of the file equal the built-in rover's M(q) at random
    configurations to 1e-12 of sqrt(M_ii M_jj) (the ``<mujoco><compiler boundmass>``
    that lets MuJoCo compile the massless links gives each 1e-13 of the lightest body's
    mass; 2e-14 of M_xx measured). The
    floating rocker-bogie's file has a fixed root in both readers: its joint block of M."""
    import pinocchio as pin

    from roverimpact.models import export_plain_urdf
    from roverimpact.models import rocker_bogie as rb_builder
    from roverimpact.models import rover2d as rv_builder

    mbm = {"rocker_bogie": rb_builder, "rover2d": rv_builder}[name](**params)
    model = mbm.model
    tables = export_plain_urdf(mbm, tmp_path / f"{name}.urdf")
    m = mujoco.MjModel.from_xml_path(tables["model"]["file"])
    plain = pin.buildModelFromUrdf(tables["model"]["file"])
    names = [m.joint(i).name for i in range(m.njnt)]
    assert sorted(names) == sorted(plain.names[1:])
    assert len(names) == model.nv - (6 if name == "rocker_bogie" else 0)
    dofs = [model.joints[model.getJointId(nm)].idx_v for nm in names]
    plain_dofs = [plain.joints[plain.getJointId(nm)].idx_v for nm in names]
    mj_dofs = [int(m.jnt_dofadr[i]) for i in range(m.njnt)]
    d = mujoco.MjData(m)
    rng = np.random.default_rng(8)

    def rel(A, B):  # |A - B| relative to sqrt(B_ii B_jj)
        s = np.sqrt(np.diag(B))
        return float(np.max(np.abs(A - B) / np.outer(s, s)))

    for _ in range(4):
        q, q_plain = pin.neutral(model), pin.neutral(plain)
        for i, nm in enumerate(names):
            x = rng.uniform(-0.6, 0.6)
            q[model.joints[model.getJointId(nm)].idx_q] = x
            q_plain[plain.joints[plain.getJointId(nm)].idx_q] = x
            d.qpos[m.jnt_qposadr[i]] = x
        mujoco.mj_forward(m, d)
        M = pin.crba(model, model.createData(), q)
        M = (np.triu(M) + np.triu(M, 1).T)[np.ix_(dofs, dofs)]
        M_plain = pin.crba(plain, plain.createData(), q_plain)
        M_plain = (np.triu(M_plain) + np.triu(M_plain, 1).T)[np.ix_(plain_dofs, plain_dofs)]
        M_mj = full_mass_matrix(mujoco, m, d)[np.ix_(mj_dofs, mj_dofs)]
        assert rel(M_mj, M) <= 1e-12
        assert rel(M_plain, M) <= 1e-14


def test_urdf_numbers_urdfdom_would_drop_and_massless_joints(tmp_path):
    """A <mass value="8,0"> (a decimal comma) or "nan" is one ModelError naming the link:
    urdfdom dropped the whole <inertial> and the model was built without it, silently (a
    safety analysis then reported 1 kg of moving parts for 3.5). An <origin xyz> of two
    numbers likewise. A revolute joint whose link has no <inertial> moves no mass: one
    ModelError naming it (numpy's LinAlgError escaped from `safety arm`)."""
    from roverimpact import load_robot
    from roverimpact.exceptions import ModelError

    def arm(mass="2.5", xyz="0.4 0 0", tip_inertial=True):
        inertial = ('<inertial><origin xyz="0.2 0 0"/><mass value="{m}"/><inertia ixx="0.01" '
                    'iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>')
        tip = inertial.format(m="1.0") if tip_inertial else ""
        p = tmp_path / "arm.urdf"
        p.write_text(
            f'<robot name="arm"><link name="base"/><link name="l1">{inertial.format(m=mass)}'
            '</link><joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>'
            '<axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>'
            f'<link name="l2">{tip}</link><joint name="j2" type="revolute"><parent link="l1"/>'
            f'<child link="l2"/><origin xyz="{xyz}"/><axis xyz="0 0 1"/>'
            '<limit lower="-3" upper="3" effort="1" velocity="1"/></joint></robot>')
        return p

    mbm = load_robot(arm())
    assert sum(mbm.model.inertias[j].mass for j in range(1, mbm.model.njoints)) == 3.5
    for kw, match in (({"mass": "2,5"}, r"link 'l1': <mass value=\"2,5\"> must be a finite "
                                        r"number \(a decimal point, not a comma"),
                      ({"mass": "nan"}, r"link 'l1': <mass value=\"nan\">"),
                      ({"xyz": "0.4 0"}, r"joint 'j2': <origin xyz=\"0.4 0\"> must be 3 "
                                         "finite numbers"),
                      ({"tip_inertial": False}, r"joints \['j2'\] move no mass")):
        with pytest.raises(ModelError, match=match):
            load_robot(arm(**kw))
    zero_axis = arm().read_text().replace('<axis xyz="0 0 1"/>', '<axis xyz="0 0 0"/>', 1)
    (tmp_path / "arm.urdf").write_text(zero_axis)
    with pytest.raises(ModelError, match=r"joint 'j1': <axis xyz=\"0 0 0\"> is no direction"):
        load_robot(tmp_path / "arm.urdf")


def test_zero_axis_on_a_fixed_joint_loads(tmp_path):
    """A fixed joint ignores its <axis>; "0 0 0" there is common (go2, so101, romeo_laas_small
    of example-robot-data, all refused with 'is no direction'). The model is Pinocchio's."""
    import pinocchio as pin

    p = tmp_path / "arm.urdf"
    p.write_text(
        '<robot name="arm"><link name="base"/><link name="l1"><inertial><mass value="2"/>'
        '<origin xyz="0.3 0 0"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" '
        'izz="0.03"/></inertial></link><joint name="j1" type="revolute"><parent link="base"/>'
        '<child link="l1"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" '
        'velocity="1"/></joint><link name="tool"><inertial><mass value="0.5"/><inertia '
        'ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial></link>'
        '<joint name="tool_fixed" type="fixed"><parent link="l1"/><child link="tool"/>'
        '<origin xyz="0.6 0 0"/><axis xyz="0 0 0"/></joint></robot>')
    mbm = ri.load_robot(p)
    ref = pin.buildModelFromUrdf(str(p))
    q = np.array([0.4])
    M = pin.crba(mbm.model, mbm.model.createData(), q)
    M_ref = pin.crba(ref, ref.createData(), q)
    assert M[0, 0] == pytest.approx(0.03 + 2 * 0.3**2 + 0.001 + 0.5 * 0.6**2, rel=1e-12)
    np.testing.assert_allclose(M, M_ref, rtol=1e-14)


def test_malformed_roverimpact_elements_are_one_error_each(tmp_path):
    """roverimpact's own elements in an exported URDF, edited by hand: each impossible
    value is one ModelError naming the element (a negative radius, an unknown lockable
    joint or a JSON list of parameters were accepted; a two-number axis or a coefficient
    count that does not match failed later in numpy)."""
    import re

    from roverimpact import load_robot
    from roverimpact.exceptions import ModelError
    from roverimpact.models import export_urdf, rocker_bogie

    text = export_urdf(rocker_bogie(), tmp_path / "rb.urdf").read_text()
    load_robot(tmp_path / "rb.urdf")
    edits = (
        (lambda t: re.sub(r'(<roverimpact_wheel name="left_middle"[^>]*?radius=")[^"]*',
                          r"\g<1>-0.1", t), "radius must be > 0 m, got -0.1"),
        (lambda t: t.replace('axis="0 1 0"', 'axis="0 1"', 1), "axis must be 3 numbers"),
        (lambda t: t.replace('name="left_rear"', 'name="left_middle"', 1),
         "two roverimpact_wheel elements are named 'left_middle'"),
        (lambda t: re.sub(r'coefficients="[^"]*"', 'coefficients="1"', t),
         "1 coefficients for 2 joints"),
        (lambda t: t.replace('<roverimpact_lockable joint="rocker_left"',
                             '<roverimpact_lockable joint="nope"'),
         "roverimpact_lockable names unknown joint 'nope'"),
        (lambda t: re.sub(r"<roverimpact_params>.*</roverimpact_params>",
                          "<roverimpact_params>[1, 2]</roverimpact_params>", t, flags=re.S),
         "must hold a JSON object"),
        (lambda t: re.sub(r'"q_nominal": \[[^\]]*\]', '"q_nominal": "abc"', t),
         "q_nominal must be a list of numbers"),
    )
    for k, (edit, match) in enumerate(edits):
        edited = edit(text)
        assert edited != text, k
        p = tmp_path / f"rb{k}.urdf"
        p.write_text(edited)
        with pytest.raises(ModelError, match=re.escape(match)):
            load_robot(p)


def test_unexpanded_xacro_is_one_clear_error(tmp_path):
    """A URDF that still holds xacro: urdfdom skips <xacro:...> elements, so a leg made by
    a macro call was silently missing (the file below loaded with 1 joint of 3, no error);
    a ${...} was 'must be a finite number (a decimal point, not a comma ...)'. Each is one
    ModelError saying to expand the file; a .xacro file too."""
    inertia = ('<inertial><mass value="5"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" '
               'izz="1"/></inertial>')
    macro = ('<xacro:macro name="leg" params="prefix"><link name="${prefix}_leg">'
             f'{inertia}</link><joint name="${{prefix}}_hip" type="continuous"><parent '
             'link="base"/><child link="${prefix}_leg"/><axis xyz="0 1 0"/></joint>'
             '</xacro:macro>')
    body = (f'<link name="base"/><link name="arm">{inertia}</link><joint name="j" '
            'type="continuous"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>'
            '</joint>')
    head = '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
    cases = {
        "macro": (f'{head}{macro}{body}<xacro:leg prefix="left"/><xacro:leg prefix="right"/>'
                  '</robot>', r"unexpanded xacro element <xacro:macro>"),
        "expr": (f'{head}{body.replace("0 0 1", "0 0 ${z}")}</robot>',
                 r"unexpanded xacro expression in <axis xyz=\"0 0 \$\{z\}\">"),
        "find": (f'{head}<xacro:include filename="$(find pkg)/leg.xacro"/>{body}</robot>',
                 r"unexpanded xacro element <xacro:include>"),
    }
    for name, (text, match) in cases.items():
        p = tmp_path / f"{name}.urdf"
        p.write_text(text)
        with pytest.raises(ri.ModelError, match=match + r".*expand the file first: xacro "):
            ri.load_robot(p)
    p = tmp_path / "r.urdf.xacro"
    p.write_text(f"{head}{body}</robot>")
    with pytest.raises(ri.ModelError, match=r"a xacro file; expand it to URDF first"):
        ri.load_robot(p)
    # the namespace declaration alone (kept by xacro in expanded files) is fine
    p = tmp_path / "plain.urdf"
    p.write_text(f"{head}{body}</robot>")
    assert ri.load_robot(p).model.nv == 1



def _two_link_urdf(tmp_path, *, mass2="1", inertia2="1 0 0 1 0 1", extra_joint=""):
    ixx, ixy, ixz, iyy, iyz, izz = inertia2.split()
    lim = '<limit lower="-3" upper="3" effort="1" velocity="1"/>'
    p = tmp_path / "r.urdf"
    p.write_text(
        '<robot name="r"><link name="base"/>'
        '<link name="l1"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" '
        'iyz="0" izz="1"/></inertial></link>'
        f'<link name="l2"><inertial><mass value="{mass2}"/><inertia ixx="{ixx}" ixy="{ixy}" '
        f'ixz="{ixz}" iyy="{iyy}" iyz="{iyz}" izz="{izz}"/></inertial></link>'
        f'<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>'
        f'<axis xyz="0 0 1"/>{lim}</joint>'
        f'<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>'
        f'<origin xyz="0.5 0 0"/><axis xyz="0 0 1"/>{lim}</joint>{extra_joint}</robot>')
    return p


def test_urdf_with_a_link_of_two_parents_is_one_clear_error(tmp_path):
    """A closed chain written as URDF (link l2 child of j2 and j3): Pinocchio said 'Model
    does not have any body named l1' or 'joints [...] move no mass'; now one ModelError
    naming the link, its joints and the way to close the loop."""
    j3 = ('<joint name="j3" type="revolute"><parent link="base"/><child link="l2"/>'
          '<axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>')
    with pytest.raises(ri.ModelError, match=r"link 'l2' is the child of 2 joints \['j2', "
                                            r"'j3'\]: a URDF is a tree.*contacts.loops"):
        ri.load_robot(_two_link_urdf(tmp_path, extra_joint=j3))


def test_urdf_inertia_with_a_negative_principal_moment_is_refused(tmp_path):
    """Pinocchio builds M with an inertia no body has (ixy with the wrong sign convention,
    say) and MuJoCo refuses the file, so the cross-check was skipped and the model loaded
    without a word. The eigenvalues of [[a, b, 0], [b, a, 0], [0, 0, 1]] are a -+ b and 1."""
    ok = ri.load_robot(_two_link_urdf(tmp_path, inertia2="1 0.5 0 1 0 1"))  # 0.5, 1, 1.5
    assert ok.params["mujoco_check"] == "passed"
    with pytest.raises(ri.ModelError, match=r"link 'l2': the <inertia> has a negative principal "
                                            r"moment \(-0.5 kg m\^2; principal moments -0.5, "
                                            r"1, 1.5\)"):
        ri.load_robot(_two_link_urdf(tmp_path, inertia2="0.5 1 0 0.5 0 1"))
    with pytest.raises(ri.ModelError, match=r"link 'l2': <mass value=\"-1\"> is negative"):
        ri.load_robot(_two_link_urdf(tmp_path, mass2="-1"))
