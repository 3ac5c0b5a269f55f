"""[model.wheels.NAME] of an MJCF file: the radius from a cylinder geom, named by the geom
or by the body that carries it (roverimpact.models.declare.declare_wheels).

Reference: MuJoCo's own compiled model (``geom_size``, ``geom_type``) of the same file,
read here directly, and the wheel's spin axis in world axes against the hinge axis the
file gives (0 1 0).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from roverimpact.scenario import Scenario
from roverimpact.scenario.build import make_model

mujoco = pytest.importorskip("mujoco")

XML = Path(__file__).resolve().parents[1] / "examples" / "mjcf_rover.xml"


def _spec(wheels: dict) -> Scenario:
    return Scenario.model_validate({
        "model": {"file": str(XML), "wheels": wheels},
        "obstacle": {"wheel": "front", "beta_deg": 45.0}})


def test_wheel_radius_from_a_cylinder_geom_by_geom_or_body_name():
    mj = mujoco.MjModel.from_xml_path(str(XML))
    gid = {n: mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_GEOM, n) for n in ("front_tire",
                                                                         "rear_tire")}
    assert all(int(mj.geom_type[g]) == int(mujoco.mjtGeom.mjGEOM_CYLINDER) for g in gid.values())
    sc = _spec({"front": {"frame": "front_tire"}, "rear": {"frame": "rear_wheel"}})
    mbm = make_model(sc.model)
    assert isinstance(mbm.params["geoms"], list)        # the loader's documented form
    w = {x.name: x for x in mbm.wheels}
    assert w["front"].radius == pytest.approx(float(mj.geom_size[gid["front_tire"], 0]),
                                              abs=0.0)
    assert w["rear"].radius == pytest.approx(float(mj.geom_size[gid["rear_tire"], 0]), abs=0.0)
    assert (w["front"].spin, w["rear"].spin) == ("wheel_front", "wheel_rear")
    # the spin axis, mapped to world axes by each frame's rotation, is the hinge's y axis
    model = mbm.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, np.array(mbm.params["q_nominal"]))
    for x in w.values():
        R = data.oMf[model.getFrameId(x.frame)].rotation
        np.testing.assert_allclose(R @ np.asarray(x.axis), [0.0, 1.0, 0.0], atol=1e-12)


def test_a_body_without_a_round_geom_asks_for_the_radius():
    from roverimpact.exceptions import ModelError

    sc = _spec({"front": {"frame": "chassis"}})
    with pytest.raises(ModelError, match="give radius"):
        make_model(sc.model)


def test_a_declared_loop_the_configuration_leaves_open_is_refused():
    """[[contacts.loops]] whose points do not meet in the scenario's configuration: one
    ConfigError naming the loop row and the gap (here the rocker tab 1 cm too high)."""
    from roverimpact.exceptions import ConfigError
    from roverimpact.scenario import ImpactSetup, load_scenario

    sc = load_scenario(XML.parent / "sawppy_like_beta.toml")
    loops = [lp.model_copy(update={"point_b": (0.12, -0.02, 0.11)})
             if lp.name == "turnbuckle_left" else lp for lp in sc.contacts.loops]
    bad = sc.model_copy(update={"contacts": sc.contacts.model_copy(update={"loops": loops})})
    with pytest.raises(ConfigError, match=r"loop:turnbuckle_left:z is open by 0\.01 m"):
        ImpactSetup.from_scenario(bad)
    # moved with the configuration: the right rocker turned by 0.1 rad opens its loop
    cfg = sc.configuration.model_copy(update={"joints": {"rocker_right_joint": 0.1}})
    with pytest.raises(ConfigError, match=r"loop:turnbuckle_right:\w is open by"):
        ImpactSetup.from_scenario(sc.model_copy(update={"configuration": cfg}))
    ImpactSetup.from_scenario(sc)                                # closed: accepted


_INERTIAL = ('<inertial><mass value="{m}"/><inertia ixx="{i}" ixy="0" ixz="0" iyy="{i}" '
             'iyz="0" izz="{i}"/></inertial>')


def _two_wheel_urdf(path: Path, front_axis: str) -> Path:
    links = "".join(f'<link name="{n}">{_INERTIAL.format(m=m, i=i)}</link>'
                    for n, m, i in (("base", 10, 0.2), ("wheel_f", 1, 0.01),
                                    ("wheel_r", 1, 0.01)))
    joints = "".join(
        f'<joint name="{n}" type="continuous"><origin xyz="{x} 0 -0.1"/><parent link="base"/>'
        f'<child link="{c}"/><axis xyz="{a}"/></joint>'
        for n, x, c, a in (("spin_f", 0.3, "wheel_f", front_axis),
                           ("spin_r", -0.3, "wheel_r", "0 1 0")))
    path.write_text(f'<?xml version="1.0"?><robot name="two">{links}{joints}</robot>')
    return path


def test_wheels_on_hinges_about_negative_axes(tmp_path):
    """Wheels whose hinge axis is not exactly +x, +y or +z (Pinocchio's "unaligned"
    joints: a URDF continuous joint about "0 -1 0", an MJCF hinge about "0 -1 0"), as files
    are often written: the same rover as with "0 1 0" (it crashed reading the axis). The
    wheel's world spin axis is the file's; T_c^- and both effective masses equal the +y
    rover's (the wheel turns the other way, the motion is the same); the MJCF model's M
    is MuJoCo's mj_fullM."""
    from roverimpact.scenario import ImpactSetup

    def energies(model, wheels, base=None):
        d = {"model": {"file": str(model), "wheels": wheels}, "velocity": {"u": 0.5},
             "obstacle": {"wheel": "front", "beta_deg": 40.0}}
        if base:
            d["model"]["base"] = base
            d["configuration"] = {"base": {"z": 0.2}}
        setup = ImpactSetup.from_scenario(Scenario.model_validate(d))
        return setup, setup.partition()

    flipped = tmp_path / "rover_neg.xml"
    flipped.write_text(XML.read_text().replace('<joint type="hinge" axis="0 1 0"/>',
                                               '<joint type="hinge" axis="0 -1 0"/>'))
    urdf_pos = _two_wheel_urdf(tmp_path / "pos.urdf", "0 1 0")
    urdf_neg = _two_wheel_urdf(tmp_path / "neg.urdf", "0 -1 0")
    wheels_mj = {"front": {"frame": "front_tire"}, "rear": {"frame": "rear_wheel"}}
    wheels_urdf = {"front": {"frame": "wheel_f", "radius": 0.1},
                   "rear": {"frame": "wheel_r", "radius": 0.1}}
    for pos, neg, wheels, base in ((XML, flipped, wheels_mj, None),
                                   (urdf_pos, urdf_neg, wheels_urdf, {"kind": "floating"})):
        (sp, ep), (sn, en) = energies(pos, wheels, base), energies(neg, wheels, base)
        for f in ("T", "T_c_minus", "m_eff", "m_eff_free", "v_n"):
            assert float(getattr(en, f)) == pytest.approx(float(getattr(ep, f)), rel=1e-12)
        assert float(en.T_c_minus) > 0
        w = {x.name: x for x in sn.model.wheels}["front"]
        data = sn.model.model.createData()
        pin.framesForwardKinematics(sn.model.model, data, sn.q)
        R = data.oMf[sn.model.model.getFrameId(w.frame)].rotation
        np.testing.assert_allclose(R @ np.asarray(w.axis), [0.0, -1.0, 0.0], atol=1e-12)
        # the front wheel turns the other way
        iv = sn.model.model.joints[sn.model.model.getJointId(w.spin)].idx_v
        assert sn.v[iv] == pytest.approx(-sp.v[iv], rel=1e-12)
        assert sn.v[iv] != 0
    mj = mujoco.MjModel.from_xml_path(str(flipped))
    sn, _ = energies(flipped, wheels_mj)
    d = mujoco.MjData(mj)
    d.qpos[:] = sn.q  # slide x, slide z, hinge pitch, two wheel hinges: same coordinates
    mujoco.mj_forward(mj, d)
    full = np.zeros((mj.nv, mj.nv))
    mujoco.mj_fullM(mj, d, full)
    np.testing.assert_allclose(sn.M, full, rtol=1e-12, atol=1e-12)
    # the rear wheel rolls: its ground contact point does not slide (it slid at 2 u)
    d.qvel[:] = sn.v
    mujoco.mj_forward(mj, d)
    body = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, "rear_wheel")
    point = d.xpos[body] - [0.0, 0.0, {w.name: w for w in sn.model.wheels}["rear"].radius]
    jac = np.zeros((3, mj.nv))
    mujoco.mj_jac(mj, d, jac, None, point, body)
    np.testing.assert_allclose(jac @ sn.v, 0.0, atol=1e-12)


def test_planar_root_chain_with_negative_axes_and_an_arm_about_minus_z(tmp_path):
    """detect_base on root chains whose joints are "unaligned": a slide about -x, a slide
    about z and a hinge about -y would be a planar base driven backwards (its coordinates
    are read as world x, z and pitch about +y): one ModelError naming the flipped joints;
    written about +x, +z, +y (through rotated placements or not) it is planar. A 3-joint
    arm whose first hinge turns about "0 0 -1" is a fixed base; the point hit 0.7 m from
    that hinge turning at 1 rad/s approaches its face at 0.7 m/s."""
    from roverimpact import load_robot
    from roverimpact.models.declare import detect_base
    from roverimpact.scenario import ImpactSetup

    def chain(name, axes, kinds):
        links = "".join(f'<link name="l{i}">{_INERTIAL.format(m=m, i=0.01)}</link>'
                        for i, m in enumerate((5, 1, 1, 1)))
        joints = "".join(
            f'<joint name="j{i + 1}" type="{k}"><origin xyz="{0.3 if i else 0} 0 0"/>'
            f'<parent link="l{i}"/><child link="l{i + 1}"/><axis xyz="{a}"/>'
            '<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>'
            for i, (a, k) in enumerate(zip(axes, kinds, strict=True)))
        p = tmp_path / f"{name}.urdf"
        p.write_text(f'<?xml version="1.0"?><robot name="{name}">{links}{joints}</robot>')
        return p

    from roverimpact.exceptions import ModelError

    flipped = chain("flipped", ("-1 0 0", "0 0 1", "0 -1 0"),
                    ("prismatic", "prismatic", "revolute"))
    with pytest.raises(ModelError, match=r"planar base: joints \['j1', 'j3'\] move along"):
        detect_base(pin.buildModelFromUrdf(str(flipped)))
    planar = chain("planar", ("1 0 0", "0 0 1", "0 1 0"),
                   ("prismatic", "prismatic", "revolute"))
    info = detect_base(pin.buildModelFromUrdf(str(planar)))
    assert (info.kind, info.joints) == ("planar", ("j1", "j2", "j3"))
    arm = chain("arm", ("0 0 -1", "0 1 0", "0 1 0"), ("revolute",) * 3)
    assert detect_base(load_robot(arm).model).kind == "fixed"
    sc = Scenario.model_validate({
        "model": {"file": str(arm)}, "velocity": {"joints": {"j1": 1.0}},
        "obstacle": {"frame": "l3", "point": [0.1, 0.0, 0.0], "normal": [0.0, 1.0, 0.0]}})
    setup = ImpactSetup.from_scenario(sc)
    # the point hit is 0.7 m from the j1 axis and moves along -y at 0.7 m/s (j1 about -z)
    assert float(setup.partition().v_n) == pytest.approx(0.7, rel=1e-12)


def test_a_declared_spin_joint_must_be_a_hinge_carrying_the_wheel():
    """[model.wheels.NAME] spin = a slide joint, or another wheel's hinge: one ModelError
    (the wheel was "rolled" by driving the base slide at u / r: T = 133 J for 3.25 J)."""
    from roverimpact.exceptions import ModelError

    for spin, match in (("x", r"front\.spin: joint 'x' is a prismatic \(slide\) joint"),
                        ("wheel_rear", r"front\.spin: joint 'wheel_rear' does not carry the "
                                       r"wheel's frame 'front_wheel'")):
        sc = _spec({"front": {"frame": "front_wheel", "spin": spin},
                    "rear": {"frame": "rear_wheel"}})
        with pytest.raises(ModelError, match=match):
            make_model(sc.model)
    sc = _spec({"front": {"frame": "front_tire", "spin": "wheel_front"},
                "rear": {"frame": "rear_wheel"}})
    assert {w.name: w.spin for w in make_model(sc.model).wheels}["front"] == "wheel_front"


def test_a_ball_joint_in_the_root_chain_is_a_fixed_base(tmp_path):
    """An arm whose third joint from the root is a ball joint (no axis): a fixed base (it
    crashed with numpy's ValueError in detect_base); the point hit 0.65 m from the first
    hinge, turning at 1 rad/s, approaches at 0.65 m/s."""
    from roverimpact import load_robot
    from roverimpact.models.declare import detect_base
    from roverimpact.scenario import ImpactSetup

    xml = tmp_path / "arm_ball.xml"
    xml.write_text(
        '<mujoco model="arm_ball"><worldbody><body name="l1">'
        '<joint name="j1" type="hinge" axis="0 0 1"/>'
        '<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>'
        '<body name="l2" pos="0.3 0 0"><joint name="j2" type="hinge" axis="0 1 0"/>'
        '<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>'
        '<body name="hand" pos="0.3 0 0"><joint name="wrist" type="ball"/>'
        '<geom type="box" size="0.05 0.05 0.05"/></body></body></body></worldbody></mujoco>')
    assert detect_base(load_robot(xml).model).kind == "fixed"
    sc = Scenario.model_validate({
        "model": {"file": str(xml)}, "velocity": {"joints": {"j1": 1.0}},
        "obstacle": {"frame": "hand", "point": [0.05, 0.0, 0.0], "normal": [0.0, -1.0, 0.0]}})
    assert float(ImpactSetup.from_scenario(sc).partition().v_n) == pytest.approx(0.65,
                                                                               rel=1e-12)


def test_a_declared_spin_joint_turns_this_wheel_about_its_axis(tmp_path):
    """spin = a steering hinge (a body with a steer and a spin joint, as MJCF rovers are
    written) or a rocker that carries other wheels: one ModelError each. Both were
    accepted: the steering hinge was driven at u/r while the wheel's ground point slid at
    u; the rocker took the base along (T 3.29 J for 0.86 J, v_n 0.82 for 0.21 m/s)."""
    from roverimpact.exceptions import ModelError

    wheel = ("<geom type='cylinder' size='0.1 0.03' euler='90 0 0' mass='1'/>")
    xml = tmp_path / "steer.xml"
    xml.write_text(
        "<mujoco><worldbody><body name='chassis' pos='0 0 0.3'><freejoint/>"
        "<geom type='box' size='0.3 0.2 0.05' mass='10'/>"
        "<body name='rocker' pos='-0.1 0.25 -0.05'><joint name='rocker' axis='0 1 0'/>"
        "<geom type='capsule' fromto='-0.2 0 0 0.2 0 0' size='0.02' mass='1'/>"
        f"<body name='rl' pos='-0.2 0 -0.15'><joint name='rl_spin' axis='0 1 0'/>{wheel}"
        "</body>"
        f"<body name='ml' pos='0.2 0 -0.15'><joint name='ml_spin' axis='0 1 0'/>{wheel}"
        "</body></body>"
        "<body name='fr' pos='0.3 -0.25 -0.2'><joint name='fr_steer' axis='0 0 1'/>"
        f"<joint name='fr_spin' axis='0 1 0'/>{wheel}</body>"
        "</body></worldbody></mujoco>")

    def model(**fr):
        return make_model(Scenario.model_validate({
            "model": {"file": str(xml), "wheels": {
                "rl": {"frame": "rl"}, "ml": {"frame": "ml"},
                "fr": {"frame": "fr", **fr}}},
            "obstacle": {"wheel": "fr", "beta_deg": 45.0}}).model)

    with pytest.raises(ModelError, match=r"fr\.spin: joint 'fr_steer' turns about "
                                         r"\[0\.0, 0\.0, 1\.0\].*not about the wheel's axis"):
        model(spin="fr_steer")
    with pytest.raises(ModelError, match=r"fr\.spin: joint 'fr_spin' turns about .* not about"):
        model(spin="fr_spin", axis=[1.0, 0.0, 0.0])
    with pytest.raises(ModelError, match=r"rl\.spin: joint 'rocker' also carries wheel 'ml'"):
        make_model(Scenario.model_validate({
            "model": {"file": str(xml), "wheels": {
                "rl": {"frame": "rl", "spin": "rocker"}, "ml": {"frame": "ml"}}},
            "obstacle": {"wheel": "ml", "beta_deg": 45.0}}).model)
    ok = {w.name: w for w in model(spin="fr_spin").wheels}["fr"]
    assert ok.spin == "fr_spin" and np.allclose(np.abs(ok.axis), [0.0, 1.0, 0.0])


OFFSET_XML = """<mujoco model="rover_off">
  <compiler angle="degree"/>
  <default><default class="visual"><geom contype="0" conaffinity="0" group="1"/></default>
  </default>
  <worldbody>
    <body name="chassis" pos="0 0 0.35">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="z" type="slide" axis="0 0 1"/>
      <joint name="pitch" type="hinge" axis="0 1 0"/>
      <geom class="visual" type="box" size="0.35 0.2 0.075" mass="20"/>
      <body name="front_wheel" pos="0.1 0 0">
        <joint name="wheel_front" axis="0 1 0" pos="0.2 0 -0.2"/>
        <geom name="front_tire" type="cylinder" size="0.15 0.05" euler="90 0 0"
              pos="0.2 0 -0.2" mass="2"/>
      </body>
      <body name="rear_wheel" pos="-0.3 0 -0.2">
        <joint name="wheel_rear" axis="0 1 0"/>
        <geom name="rear_hub" class="visual" type="cylinder" size="0.04 0.06" euler="90 0 0"
              mass="0.2"/>
        <geom name="strut" type="cylinder" size="0.2 0.01" mass="0.1"/>
        <geom name="rear_tire" type="cylinder" size="0.15 0.05" euler="90 0 0" mass="2"/>
      </body>
    </body>
  </worldbody>
</mujoco>"""


def test_wheel_by_body_takes_the_tire_at_the_frame_origin(tmp_path):
    """A wheel named by its body: the radius was the first round geom's, a visual hub
    (0.04 m instead of the tire's 0.15 m), and a tire placed away from the body origin
    (pos 0.2 0 -0.2, the hinge there too) put the contact point 0.28 m from the tire's rim.
    Now the radius is the largest colliding sphere or cylinder about the wheel axis (not
    the vertical 'strut', radius 0.2), and a frame off the tire's centre is one ModelError
    naming the geom. Reference: MuJoCo's geom_xpos of the tire and the closed-form rim
    point centre - r n of a wheel meeting a 45 deg face (outward normal n)."""
    from roverimpact.exceptions import ModelError
    from roverimpact.scenario.build import ImpactSetup

    f = tmp_path / "rover_off.xml"
    f.write_text(OFFSET_XML)

    def scenario(front):
        return Scenario.model_validate({
            "model": {"file": str(f), "base": {"kind": "planar", "joints": ["x", "z", "pitch"]},
                      "wheels": {"front": {"frame": front}, "rear": {"frame": "rear_wheel"}}},
            "velocity": {"u": 0.5}, "contacts": {"ground_wheels": []},
            "obstacle": {"wheel": "front", "beta_deg": 45.0}})

    with pytest.raises(ModelError, match=r"model.wheels.front: frame 'front_wheel' is 0.2828 m "
                                         r"from the centre of the cylinder geom 'front_tire'.*"
                                         r"give frame = 'front_tire'"):
        make_model(scenario("front_wheel").model)
    setup = ImpactSetup.from_scenario(scenario("front_tire"))
    w = {x.name: x for x in setup.model.wheels}
    assert w["rear"].radius == 0.15 and w["front"].radius == 0.15
    mj = mujoco.MjModel.from_xml_path(str(f))
    d = mujoco.MjData(mj)
    mujoco.mj_forward(mj, d)
    centre = d.geom_xpos[mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_GEOM, "front_tire")]
    # the face's outward normal n points back and up at 45 deg; the rim point is centre - r n
    n = setup.normal
    np.testing.assert_allclose(n, [-np.sqrt(0.5), 0.0, np.sqrt(0.5)], atol=1e-12)
    np.testing.assert_allclose(setup.contact_point, centre - 0.15 * n, atol=1e-12)


def test_floating_base_on_an_mjcf_without_a_free_joint_says_how(tmp_path):
    """kind = 'floating' on an MJCF file without a free joint: the message spoke of URDF
    only ('for a URDF, the free-flyer is added'); it now says to add <freejoint/>."""
    from roverimpact.exceptions import ModelError

    f = tmp_path / "arm.xml"
    f.write_text("<mujoco><worldbody><body name='l1'><joint name='j1' axis='0 0 1'/>"
                 "<geom size='.1' mass='1'/></body></worldbody></mujoco>")
    sc = Scenario.model_validate({"model": {"file": str(f), "base": {"kind": "floating"}},
                                  "obstacle": {"frame": "l1", "normal": [0, 1, 0]}})
    with pytest.raises(ModelError, match=r"has no free joint at its root: add <freejoint/> "
                                         r"to its top-level body"):
        make_model(sc.model)


def test_a_urdf_planar_joint_as_planar_base_says_what_to_write(tmp_path):
    """kind = 'planar' on a URDF whose base is a `planar` joint said only 'joints ['p',
    'j2'] are not'; it now says that a URDF planar joint is not roverimpact's x-z base and
    how to write one."""
    from roverimpact.exceptions import ModelError

    inertia = ('<inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" '
               'izz="1"/></inertial>')
    f = tmp_path / "p.urdf"
    f.write_text(f'<robot name="r"><link name="world_link"/><link name="body">{inertia}</link>'
                 '<joint name="p" type="planar"><parent link="world_link"/><child link="body"/>'
                 '<axis xyz="0 0 1"/></joint></robot>')
    sc = Scenario.model_validate({"model": {"file": str(f), "base": {"kind": "planar"}},
                                  "obstacle": {"frame": "body", "normal": [0, 0, 1]}})
    with pytest.raises(ModelError, match=r"'p' is a URDF planar joint .*write the base as "
                                         r"prismatic x, prismatic z and revolute y joints"):
        make_model(sc.model)


def test_frame_loops_of_a_shared_model_take_turns_on_their_data(monkeypatch):
    """A model's frame loops ([[contacts.loops]]) keep one Pinocchio data for the setups
    built on the model: two threads asking for their rows take turns on it (every pass
    on it sleeps 2 ms here, so passes of the two threads would overlap) and get the rows
    of one thread."""
    import threading
    import time

    import pinocchio as pin

    from roverimpact.scenario import ImpactSetup, load_scenario

    setup = ImpactSetup.from_scenario(load_scenario(XML.parent / "sawppy_like_beta.toml"))
    loop = setup.model.loop_closure
    model = setup.model.model
    rng = np.random.default_rng(1)
    Q = [pin.integrate(model, setup.q, 0.05 * rng.standard_normal(model.nv))
         for _ in range(2)]
    expected = [loop(q) for q in Q]
    inside, most = [0], [0]
    jacobians = pin.computeJointJacobians

    def slow(model_, data_, q):
        if data_ is not loop.data:
            return jacobians(model_, data_, q)
        inside[0] += 1
        most[0] = max(most[0], inside[0])
        try:
            time.sleep(0.002)
            return jacobians(model_, data_, q)
        finally:
            inside[0] -= 1

    monkeypatch.setattr(pin, "computeJointJacobians", slow)
    got: list[list] = [[], []]

    def work(i):
        for _ in range(5):
            got[i].append(loop(Q[i]))

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert most[0] == 1
    for i in range(2):
        for phi, J in got[i]:
            np.testing.assert_array_equal(phi, expected[i][0])
            np.testing.assert_array_equal(J, expected[i][1])


def test_the_detected_base_follows_the_model_and_its_declaration():
    """base_info detects a model's base once, for the Pinocchio model it was asked about:
    a model put in its place is detected again, and a declared base still decides."""
    from roverimpact.models import rigid_body, rocker_bogie
    from roverimpact.models.declare import base_info, declare_base, detect_base

    mbm = rigid_body()
    first = base_info(mbm)
    assert first.kind == "planar" and base_info(mbm) is first
    mbm.model = rocker_bogie().model
    assert base_info(mbm) == detect_base(mbm.model) and base_info(mbm).kind == "floating"
    declare_base(mbm, "fixed")
    assert base_info(mbm).kind == "fixed"
