"""MJCF files written with the compiler's conveniences, against MuJoCo's mj_fullM/mj_jac.

Reference: MuJoCo compiles the same file; T_c^- of one impact row at a site,
``T_c = (a qvel)^2 / (2 a M^-1 a^T)`` with ``a = n^T J_p`` (``mj_jac`` at the site)
and ``n`` turned so that the site approaches the face. roverimpact takes MuJoCo's
compiled inertias, so what this checks is the conversion of placements, joints (anchors,
axes, refs, ball and free coordinates) and sites, through the whole impact pipeline.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from roverimpact.models import load_robot
from roverimpact.models.mjcf import mujoco_state_to_pinocchio
from roverimpact.scenario.build import ImpactSetup

mujoco = pytest.importorskip("mujoco")

#: default classes (nested, childclass), <frame>, radians with eulerseq zyx, quat /
#: axisangle / xyaxes / zaxis / euler orientations, fromto capsules and cylinders,
#: <inertial> with quat + diaginertia and with fullinertia, density and mass, a ball
#: joint, a slide with ref, joint pos and axes off the body axes, armature, <include>
CLASSES = """<mujoco model="m1">
  <compiler angle="radian" eulerseq="zyx" inertiafromgeom="auto"/>
  <default>
    <default class="mm">
      <joint damping="0.1" armature="0.02"/>
      <geom density="1200"/>
      <default class="leg">
        <joint type="hinge" axis="0 1 0" range="-1 1"/>
        <geom type="capsule" size="0.02"/>
        <default class="foot">
          <geom type="sphere" size="0.04" mass="0.3"/>
        </default>
      </default>
    </default>
  </default>
  <worldbody>
    <body name="base" pos="0 0 1" euler="0.3 0.2 0.1" childclass="mm">
      <freejoint name="root"/>
      <geom type="box" size="0.2 0.1 0.05" mass="5"/>
      <inertial pos="0.01 0.02 -0.01" quat="0.9 0.1 0.3 0.2" mass="4" diaginertia="0.05 0.06 0.07"/>
      <frame pos="0.2 0 0" euler="0 0.4 0">
        <body name="thigh" childclass="leg" axisangle="1 0 1 0.7">
          <joint name="hip" pos="0 0.01 0" axis="0.3 1 0.2"/>
          <geom fromto="0 0 0 0 0 -0.3"/>
          <body name="shin" pos="0 0 -0.3" zaxis="0.2 0.3 1">
            <joint name="knee"/>
            <joint name="knee_slide" type="slide" axis="0 0 1" ref="0.05" range="-0.1 0.1"/>
            <geom type="cylinder" fromto="0 0 0 0.05 0 -0.25" size="0.02"/>
            <body name="foot" pos="0.05 0 -0.25" childclass="foot">
              <geom/>
              <site name="toe" pos="0 0 -0.04"/>
            </body>
          </body>
        </body>
      </frame>
      <body name="ballbody" pos="-0.2 0 0.1" quat="0.7 0.7 0.1 0">
        <joint name="ball" type="ball" pos="0 0 0.02" armature="0.005"/>
        <geom type="ellipsoid" size="0.05 0.03 0.08"/><inertial pos="0.01 0 0" mass="0.7" fullinertia="0.05 0.06 0.07 0.01 -0.005 0.002"/>
        <site name="bsite" pos="0.05 0 0"/>
      </body>
      <include file="inc_arm.xml"/>
    </body>
  </worldbody>
</mujoco>
"""
INCLUDED = """<mujoco>
  <body name="arm2" pos="0.1 0.2 0.3" xyaxes="0 1 0 -1 0 0.3">
    <joint name="ja" type="hinge" axis="1 1 0" pos="0.05 0 0.02" armature="0.01" ref="0.3"/>
    <geom type="capsule" fromto="0 0 0 0.3 0.1 -0.2" size="0.03" density="800"/>
    <site name="tip2" pos="0.3 0.1 -0.2"/>
  </body>
</mujoco>
"""
#: a free joint with align="true", a leg below it
ALIGNED = """<mujoco model="m3">
  <worldbody>
    <body name="lander" pos="0 0 1" euler="0.1 0.2 0.3">
      <freejoint name="ff" align="true"/>
      <geom type="box" size="0.3 0.2 0.1" pos="0.1 0.05 0" euler="0.3 0 0" mass="10"/>
      <geom type="sphere" size="0.1" pos="0.4 0 0" mass="3"/>
      <site name="foot" pos="0.3 0.2 -0.1"/>
      <body name="leg" pos="0.3 0 -0.1"><joint name="knee" axis="0 1 0"/><geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.02"/>
      <site name="legtip" pos="0 0 -0.3"/></body>
    </body>
  </worldbody>
</mujoco>
"""
#: a mesh geom found through meshdir, degrees, a mocap body and a world site
MESHED = """<mujoco model="meshed">
  <compiler meshdir="assets/meshes"/>
  <asset><mesh name="blk" file="blk.obj" scale="1 1.5 1"/></asset>
  <worldbody>
    <site name="wsite" pos="1 0 0"/>
    <body name="target" mocap="true" pos="0 1 0"><geom size="0.1" contype="0" conaffinity="0"/></body>
    <body name="base" pos="0 0 0.5" euler="10 20 30">
      <joint name="h" axis="0 0 1" ref="20"/>
      <geom type="box" size="0.2 0.1 0.05" mass="5"/>
      <body name="leg" pos="0.3 0 0" euler="30 0 0">
        <joint name="ball2" type="ball" pos="0.02 0 0"/>
        <joint name="s2" type="slide" axis="1 1 1" ref="0.1"/>
        <geom type="mesh" mesh="blk" density="2700"/>
        <site name="foot" pos="0.1 0.05 0.3"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _write(tmp_path, name: str):
    if name == "classes":
        (tmp_path / "inc_arm.xml").write_text(INCLUDED)
        f = tmp_path / "classes.xml"
        f.write_text(CLASSES)
        return f, ["toe", "bsite", "tip2"]
    if name == "aligned":
        f = tmp_path / "aligned.xml"
        f.write_text(ALIGNED)
        return f, ["foot", "legtip"]
    meshes = tmp_path / "assets" / "meshes"
    meshes.mkdir(parents=True)
    v = [(x, y, z) for x in (0, 0.2) for y in (0, 0.1) for z in (0, 0.3)]
    quads = [(1, 3, 4, 2), (5, 6, 8, 7), (1, 2, 6, 5), (3, 7, 8, 4), (1, 5, 7, 3), (2, 4, 8, 6)]
    (meshes / "blk.obj").write_text(
        "".join(f"v {x} {y} {z}\n" for x, y, z in v)
        + "".join(f"f {a} {b} {c}\nf {a} {c} {d}\n" for a, b, c, d in quads))
    f = tmp_path / "meshed.mjcf"  # MuJoCo's reader is given the text: meshdir must hold
    f.write_text(MESHED)
    return f, ["foot"]


@pytest.mark.parametrize("name", ["classes", "aligned", "meshed"])
def test_mjcf_as_written_gives_mujocos_T_c_at_its_sites(tmp_path, name):
    """T_c^- at each site equals MuJoCo's at random states to 1e-9, the site to 1e-12 m."""
    f, sites = _write(tmp_path, name)
    mbm = load_robot(f)
    m = mujoco.MjModel.from_xml_path(str(f))
    d = mujoco.MjData(m)
    rng = np.random.default_rng(8)
    for _ in range(3):
        qpos = m.qpos0.copy()
        for k in range(m.njnt):
            a, t = m.jnt_qposadr[k], m.jnt_type[k]
            if t in (2, 3):  # slide, hinge
                qpos[a] += rng.uniform(-0.5, 0.5)
            else:  # ball, free: a random orientation (and position)
                i = a + (3 if t == 0 else 0)
                qpos[a:i] += rng.uniform(-1, 1, i - a)
                x = rng.standard_normal(4)
                qpos[i:i + 4] = x / np.linalg.norm(x)
        qvel = rng.standard_normal(m.nv)
        d.qpos[:], d.qvel[:] = qpos, qvel
        mujoco.mj_forward(m, d)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        q, v = mujoco_state_to_pinocchio(mbm, qpos, qvel)
        for site in sites:
            s = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, site)
            jp = np.zeros((3, m.nv))
            mujoco.mj_jac(m, d, jp, None, d.site_xpos[s], m.site_bodyid[s])
            n = rng.standard_normal(3)
            n = (n if n @ jp @ qvel < 0 else -n) / np.linalg.norm(n)
            a = n @ jp
            T_mj = (a @ qvel) ** 2 / (2 * a @ np.linalg.solve(M, a))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                st = ImpactSetup.from_state(mbm, q, v, constraints="all",
                                            obstacle={"frame": site, "normal": list(n)})
            np.testing.assert_allclose(st.contact_point, d.site_xpos[s], atol=1e-12)
            assert st.partition().T_c_minus == pytest.approx(T_mj, rel=1e-9)
